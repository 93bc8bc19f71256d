//! Binary STL writer: 80-byte header, triangle count, then per triangle a normal,
//! three vertices and a zero attribute word.
//! Z up, MDG's own axes (slicers and Blender's STL importer expect z up).

use glam::Vec3;

use super::{finite3, local_oriented, ExportError};
use mdg_vm::output::{Groups, Output};

/// The STL header. It must not begin with `solid`, which marks ASCII STL.
const HEADER: &[u8] = b"MDG binary STL";

/// Appends `out` (flattened) as binary STL. Each facet normal is computed from the
/// oriented (mirror-corrected) triangle; degenerate triangles get a zero normal.
pub fn write_stl(out: &Output, buf: &mut Vec<u8>) -> Result<(), ExportError> {
    write_stl_to(out, buf)
}

/// Writes `out` as binary STL to `w`, expanding instances as it goes.
pub fn write_stl_to(out: &Output, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    let (_, n_tris) = out.flat_counts(Groups::ALL);
    let n = u32::try_from(n_tris).map_err(|_| ExportError::StlTooLarge { triangles: n_tris })?;
    let mut header = [0u8; 80];
    header[..HEADER.len()].copy_from_slice(HEADER);
    let io = ExportError::Io;
    w.write_all(&header).map_err(io)?;
    w.write_all(&n.to_le_bytes()).map_err(io)?;
    let mut facet = [0u8; 50];
    out.for_each_piece::<ExportError>(Groups::ALL, |piece| {
        let m = piece.mesh;
        for k in piece.triangles.clone() {
            let t = local_oriented(piece, k)?;
            let p = t.map(|i| Vec3::from(finite3(m.positions[i])));
            let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            for (j, v) in [normal, p[0], p[1], p[2]].iter().enumerate() {
                for (c, x) in v.to_array().iter().enumerate() {
                    facet[12 * j + 4 * c..12 * j + 4 * c + 4].copy_from_slice(&x.to_le_bytes());
                }
            }
            w.write_all(&facet).map_err(io)?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::sample_output;

    fn f32_at(b: &[u8], o: usize) -> f32 {
        f32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"))
    }

    #[test]
    fn size_count_and_outward_normals() {
        let out = sample_output();
        let n = out.flattened().triangles.len();
        let mut b = Vec::new();
        write_stl(&out, &mut b).expect("writes");
        assert_eq!(b.len(), 84 + 50 * n);
        assert_eq!(u32::from_le_bytes(b[80..84].try_into().expect("4 bytes")) as usize, n);
        assert!(!b.starts_with(b"solid"));
        // The first triangle is the mirrored one on the cube's +x face: its written
        // normal must still be +x, and match the written vertex order.
        let normal = Vec3::new(f32_at(&b, 84), f32_at(&b, 88), f32_at(&b, 92));
        assert!((normal - Vec3::X).length() < 1e-6, "{normal}");
        let v = |k: usize| Vec3::new(f32_at(&b, 96 + 12 * k), f32_at(&b, 100 + 12 * k), f32_at(&b, 104 + 12 * k));
        assert!((v(1) - v(0)).cross(v(2) - v(0)).dot(Vec3::X) > 0.0);
    }
}
