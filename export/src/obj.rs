//! Wavefront OBJ writer: `v x y z r g b` (vertex colours), `vn`, `f a//a b//b c//c`,
//! and the pen polylines as `l` elements. Y up, as OBJ importers assume: MDG's
//! (x, y, z) is written (x, z, −y) (see [`z_up_to_y_up`]). Colours are the display
//! (sRGB) values MDG shows, as 0..1 floats.

use super::text::Formatter;
use super::{check_flat_triangles, color_at, finite3, normal_at, z_up_to_y_up, ExportError};
use mdg_vm::output::{Groups, Output};

/// Appends `out` (flattened: VERTEX triangles, sweeps and expanded instances) as OBJ.
/// Indices are 1-based; triangles use the oriented (mirror-corrected) winding. Line
/// points are written as extra vertices (white) after the mesh vertices, one `l`
/// element per polyline with two or more points.
pub fn write_obj(out: &Output, buf: &mut Vec<u8>) -> Result<(), ExportError> {
    write_obj_to(out, buf)
}

/// Writes `out` as OBJ to `w` in one walk, expanding instances as it goes: each
/// piece's `v` and `vn` lines, then its faces (a face refers only to vertices
/// already written; OBJ counts them by kind, so `v` and `vn` may alternate), through
/// one buffered formatter ([`Formatter`]).
pub fn write_obj_to(out: &Output, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    // Every triangle is checked before anything is written.
    check_flat_triangles(out)?;
    let mut f = Formatter::new(w);
    f.bytes(b"# mdg\n")?;
    out.for_each_piece::<ExportError>(Groups::ALL, |piece| {
        let m = piece.mesh;
        for i in piece.vertices.clone() {
            let p = z_up_to_y_up(finite3(m.positions[i]));
            let c = color_at(m, i);
            f.bytes(b"v ")?;
            f.f32s(&p)?;
            f.bytes(b" ")?;
            f.f32s(&c[..3])?;
            f.bytes(b"\nvn ")?;
            f.f32s(&z_up_to_y_up(normal_at(m, i)))?;
            f.bytes(b"\n")?;
        }
        for k in piece.triangles.clone() {
            let Some(t) = piece.oriented(k) else { continue };
            f.bytes(b"f")?;
            for v in t {
                let v = v as u64 + 1;
                f.bytes(b" ")?;
                f.u64(v)?;
                f.bytes(b"//")?;
                f.u64(v)?;
            }
            f.bytes(b"\n")?;
        }
        Ok(())
    })?;
    let (n_vertices, _) = out.flat_counts(Groups::ALL);
    let mut next = n_vertices as u64 + 1;
    for line in out.lines.iter().filter(|l| l.points.len() >= 2) {
        f.bytes(b"g line ")?;
        f.bytes(if line.namespace.is_empty() { b"default" } else { line.namespace.as_bytes() })?;
        f.bytes(b"\n")?;
        for p in &line.points {
            let p = z_up_to_y_up(finite3(*p));
            f.bytes(b"v ")?;
            f.f32s(&p)?;
            f.bytes(b" 1 1 1\n")?;
        }
        f.bytes(b"l")?;
        for k in 0..line.points.len() as u64 {
            f.bytes(b" ")?;
            f.u64(next + k)?;
        }
        f.bytes(b"\n")?;
        next += line.points.len() as u64;
    }
    f.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::sample_output;

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
