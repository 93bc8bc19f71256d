//! A part's mesh reduced to what its silhouette needs (see [`super::silhouette`]),
//! made once per part when the library is built.
//!
//! A silhouette marks, in each view, the pixel of every triangle corner and the
//! pixels whose centres a triangle covers. The std parts are isosurfaces of thousands
//! of triangles much smaller than a silhouette's pixel, and their vertices repeat
//! (every triangle corner carries its own normal and colour). So an outline keeps
//! each distinct position once (bit for bit: equal positions project to equal
//! pixels), the positions that are corners of some triangle, and the triangles
//! ordered by their longest edge, longest first: a triangle whose projection spans
//! less than half a pixel in both directions can only cover the pixel centre of the
//! pixel all its corners lie in, so the silhouette fills only the triangles at the
//! front of that order and marks the corners of the rest.

use glam::Vec3;
use mdg_vm::output::Mesh;

/// See the module documentation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outline {
    /// The mesh's distinct positions (equal bits once), in order of first use.
    pub points: Vec<Vec3>,
    /// The points that are a corner of some triangle (indices into `points`,
    /// ascending).
    pub corners: Vec<u32>,
    /// The triangles as indices into `points`, each with its longest edge's length,
    /// longest first (ties in the mesh's order). Triangles with a corner outside the
    /// mesh's positions are left out.
    pub triangles: Vec<([u32; 3], f32)>,
    /// The largest absolute coordinate of the points (0 for none; infinite or NaN
    /// for a point that is not finite).
    pub reach: f32,
}

impl Outline {
    /// The outline of `mesh`.
    pub fn new(mesh: &Mesh) -> Outline {
        let mut index: std::collections::HashMap<[u32; 3], u32> = std::collections::HashMap::new();
        let mut points = Vec::new();
        let remap: Vec<u32> = mesh
            .positions
            .iter()
            .map(|p| {
                *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
                    points.push(Vec3::from(*p));
                    points.len() as u32 - 1
                })
            })
            .collect();
        let mut used = vec![false; points.len()];
        let mut triangles: Vec<([u32; 3], f32)> = Vec::with_capacity(mesh.triangles.len());
        for t in &mesh.triangles {
            let Some(r) = t.iter().map(|&i| remap.get(i as usize).copied()).collect::<Option<Vec<u32>>>() else {
                continue;
            };
            let r = [r[0], r[1], r[2]];
            let q = r.map(|i| points.get(i as usize).copied().unwrap_or(Vec3::NAN));
            let longest = (q[1] - q[0]).length().max((q[2] - q[1]).length()).max((q[0] - q[2]).length());
            for &i in &r {
                if let Some(u) = used.get_mut(i as usize) {
                    *u = true;
                }
            }
            // A non-finite length (a corner at infinity) sorts first: always filled.
            triangles.push((r, if longest.is_nan() { f32::INFINITY } else { longest }));
        }
        triangles.sort_by(|a, b| b.1.total_cmp(&a.1));
        let corners = (0..points.len() as u32).filter(|&i| used.get(i as usize) == Some(&true)).collect();
        let reach = points.iter().fold(0.0f32, |m, p| {
            let a = p.abs().max_element();
            if a.is_finite() {
                m.max(a)
            } else {
                f32::INFINITY
            }
        });
        Outline { points, corners, triangles, reach }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_outline_keeps_each_position_once_and_orders_triangles_longest_first() {
        let m = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 3.0, 0.0], [9.0; 3]],
            triangles: vec![[0, 1, 2], [3, 2, 4], [0, 1, 7]],
            ..Mesh::default()
        };
        let o = Outline::new(&m);
        assert_eq!(o.points.len(), 5, "the repeated corner is kept once");
        // The unused position (9, 9, 9) is a point but no corner; the triangle with a
        // corner out of range is left out.
        assert_eq!(o.corners, vec![0, 1, 2, 3]);
        assert_eq!(o.triangles.len(), 2);
        assert_eq!(o.triangles[0].0, [1, 2, 3]);
        assert!((o.triangles[0].1 - 10f32.sqrt()).abs() < 1e-6);
        assert_eq!(o.triangles[1].0, [0, 1, 2]);
    }
}
