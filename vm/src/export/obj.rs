//! Wavefront OBJ writer: `v x y z r g b` (vertex colours), `vn`, `f a//a b//b c//c`,
//! and the pen polylines as `l` elements. Y up, as OBJ importers assume: MDG's
//! (x, y, z) is written (x, z, −y) (see [`z_up_to_y_up`]). Colours are the display
//! (sRGB) values MDG shows, as 0..1 floats.

use super::{color_at, finite3, local_oriented, normal_at, z_up_to_y_up};
use crate::output::{Groups, Output};

/// Appends `out` (flattened: VERTEX triangles, sweeps and expanded instances) as OBJ.
/// Indices are 1-based; triangles use the oriented (mirror-corrected) winding. Line
/// points are written as extra vertices (white) after the mesh vertices, one `l`
/// element per polyline with two or more points.
pub fn write_obj(out: &Output, buf: &mut Vec<u8>) -> Result<(), String> {
    write_obj_to(out, buf)
}

/// Writes `out` as OBJ to `w`, expanding instances as it goes (once for the `v`
/// lines, once for the `vn` lines, once for the faces).
pub fn write_obj_to(out: &Output, w: &mut dyn std::io::Write) -> Result<(), String> {
    let io = |e: std::io::Error| e.to_string();
    // Every triangle is checked before anything is written.
    out.for_each_piece::<String>(Groups::ALL, |piece| {
        piece.triangles.clone().try_for_each(|k| local_oriented(piece, k).map(|_| ()))
    })?;
    w.write_all(b"# mdg\n").map_err(io)?;
    out.for_each_piece::<String>(Groups::ALL, |piece| {
        let m = piece.mesh;
        for i in piece.vertices.clone() {
            let p = z_up_to_y_up(finite3(m.positions[i]));
            let c = color_at(m, i);
            writeln!(w, "v {} {} {} {} {} {}", p[0], p[1], p[2], c[0], c[1], c[2]).map_err(io)?;
        }
        Ok(())
    })?;
    out.for_each_piece::<String>(Groups::ALL, |piece| {
        for i in piece.vertices.clone() {
            let n = z_up_to_y_up(normal_at(piece.mesh, i));
            writeln!(w, "vn {} {} {}", n[0], n[1], n[2]).map_err(io)?;
        }
        Ok(())
    })?;
    out.for_each_piece::<String>(Groups::ALL, |piece| {
        for k in piece.triangles.clone() {
            let Some(t) = piece.oriented(k) else { continue };
            let (a, b, c) = (t[0] as u64 + 1, t[1] as u64 + 1, t[2] as u64 + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}").map_err(io)?;
        }
        Ok(())
    })?;
    let (n_vertices, _) = out.flat_counts(Groups::ALL);
    let mut next = n_vertices as u64 + 1;
    for line in out.lines.iter().filter(|l| l.points.len() >= 2) {
        writeln!(w, "g line {}", if line.namespace.is_empty() { "default" } else { &line.namespace }).map_err(io)?;
        for p in &line.points {
            let p = z_up_to_y_up(finite3(*p));
            writeln!(w, "v {} {} {} 1 1 1", p[0], p[1], p[2]).map_err(io)?;
        }
        w.write_all(b"l").map_err(io)?;
        for k in 0..line.points.len() as u64 {
            write!(w, " {}", next + k).map_err(io)?;
        }
        w.write_all(b"\n").map_err(io)?;
        next += line.points.len() as u64;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::tests::sample_output;

    #[test]
    fn line_counts_and_mirrored_winding() {
        let out = sample_output();
        let flat = out.flattened();
        let mut b = Vec::new();
        write_obj(&out, &mut b).expect("writes");
        let text = String::from_utf8(b).expect("utf8");
        let count = |prefix: &str| text.lines().filter(|l| l.starts_with(prefix)).count();
        assert_eq!(count("v "), flat.positions.len() + 3);
        assert_eq!(count("vn "), flat.positions.len());
        assert_eq!(count("f "), flat.triangles.len());
        assert_eq!(count("l "), 1);
        let v: Vec<&str> = text.lines().filter(|l| l.starts_with("v ")).collect();
        assert_eq!(v[0].split(' ').count(), 7);
        let first_face = text.lines().find(|l| l.starts_with("f ")).expect("a face");
        let t = out.mesh.triangles[0];
        let (a, b, c) = (t[0] + 1, t[2] + 1, t[1] + 1);
        assert_eq!(first_face, format!("f {a}//{a} {b}//{b} {c}//{c}"));
        // Y up: the line point (0, 1, 2) of MDG space is written (0, 2, −1).
        assert!(text.lines().any(|l| l == "v 0 2 -1 1 1 1"), "{text}");
        let p = flat.positions[0];
        let first: Vec<f32> = v[0].split(' ').skip(1).take(3).map(|x| x.parse().expect("float")).collect();
        assert_eq!(first, vec![p[0], p[2], -p[1]]);
    }
}
