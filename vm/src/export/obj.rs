//! Wavefront OBJ writer: `v x y z r g b` (vertex colours), `vn`, `f a//a b//b c//c`,
//! and the pen polylines as `l` elements. Y up, as OBJ importers assume: MDG's
//! (x, y, z) is written (x, z, −y) (see [`z_up_to_y_up`]). Colours are the display
//! (sRGB) values MDG shows, as 0..1 floats.

use std::fmt::Write as _;

use super::{checked_triangles, color_at, finite3, normal_at, z_up_to_y_up};
use crate::output::Output;

/// Appends `out` (flattened: VERTEX triangles, sweeps and expanded instances) as OBJ.
/// Indices are 1-based; triangles use the oriented (mirror-corrected) winding. Line
/// points are written as extra vertices (white) after the mesh vertices, one `l`
/// element per polyline with two or more points.
pub fn write_obj(out: &Output, buf: &mut Vec<u8>) -> Result<(), String> {
    let m = out.flattened();
    let tris = checked_triangles(&m, "flattened mesh")?;
    let mut s = String::with_capacity(64 * (m.positions.len() + tris.len()) + 64);
    s.push_str("# mdg\n");
    for (i, p) in m.positions.iter().enumerate() {
        let p = z_up_to_y_up(finite3(*p));
        let c = color_at(&m, i);
        let _ = writeln!(s, "v {} {} {} {} {} {}", p[0], p[1], p[2], c[0], c[1], c[2]);
    }
    for i in 0..m.positions.len() {
        let n = z_up_to_y_up(normal_at(&m, i));
        let _ = writeln!(s, "vn {} {} {}", n[0], n[1], n[2]);
    }
    for t in &tris {
        let (a, b, c) = (t[0] as u64 + 1, t[1] as u64 + 1, t[2] as u64 + 1);
        let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    let mut next = m.positions.len() as u64 + 1;
    for line in out.lines.iter().filter(|l| l.points.len() >= 2) {
        let _ = writeln!(s, "g line {}", if line.namespace.is_empty() { "default" } else { &line.namespace });
        for p in &line.points {
            let p = z_up_to_y_up(finite3(*p));
            let _ = writeln!(s, "v {} {} {} 1 1 1", p[0], p[1], p[2]);
        }
        s.push('l');
        for k in 0..line.points.len() as u64 {
            let _ = write!(s, " {}", next + k);
        }
        s.push('\n');
        next += line.points.len() as u64;
    }
    buf.extend_from_slice(s.as_bytes());
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
