//! Greedy meshing: a voxel model to a triangle mesh with one colour per block kind.
//!
//! Every block is an opaque unit cube. For each of the six face directions and each
//! slice, the visible faces (block on this side, no block on the other) form a mask of
//! block kinds; maximal rectangles of one kind become one quad each (Mikola Lysenko's
//! greedy scheme), so a flat wall of one material is two triangles.
//! Triangles wind counter-clockwise seen from outside. Coordinates are blocks, y up.

use super::voxel::{Grid, VoxelModel};
use glam::Vec3;
use mdg_vm::output::{Mesh, Output};

/// The mesh of `model`, moved by `offset` (in blocks).
pub fn mesh(model: &VoxelModel, offset: [f32; 3]) -> Mesh {
    let mut out = Mesh::default();
    if model.blocks.is_empty() {
        return out;
    }
    let grid = Grid::new(&model.blocks, 1);
    let colors: Vec<[f32; 4]> = model
        .kinds
        .iter()
        .map(|k| [k.color[0] as f32 / 255.0, k.color[1] as f32 / 255.0, k.color[2] as f32 / 255.0, 1.0])
        .collect();
    let kind_at = |p: [i32; 3]| -> u32 {
        match grid.get(p) {
            Grid::EMPTY => 0,
            i => model.blocks[i as usize].kind + 1,
        }
    };
    let lo = grid.lo;
    let dims = grid.dims;
    for d in 0..3 {
        let (u, v) = ((d + 1) % 3, (d + 2) % 3);
        let (nu, nv) = (dims[u] as usize, dims[v] as usize);
        let mut mask = vec![0u32; nu * nv];
        for s in [1i32, -1] {
            for c in 0..dims[d] {
                // The mask of faces of blocks in slice c looking towards c + s.
                let mut any = false;
                for j in 0..nv {
                    for i in 0..nu {
                        let mut p = [0; 3];
                        p[d] = lo[d] + c;
                        p[u] = lo[u] + i as i32;
                        p[v] = lo[v] + j as i32;
                        let k = kind_at(p);
                        let mut q = p;
                        q[d] += s;
                        let m = if k != 0 && kind_at(q) == 0 { k } else { 0 };
                        mask[j * nu + i] = m;
                        any |= m != 0;
                    }
                }
                if !any {
                    continue;
                }
                for j in 0..nv {
                    let mut i = 0;
                    while i < nu {
                        let k = mask[j * nu + i];
                        if k == 0 {
                            i += 1;
                            continue;
                        }
                        let mut w = 1;
                        while i + w < nu && mask[j * nu + i + w] == k {
                            w += 1;
                        }
                        let mut h = 1;
                        'grow: while j + h < nv {
                            for x in 0..w {
                                if mask[(j + h) * nu + i + x] != k {
                                    break 'grow;
                                }
                            }
                            h += 1;
                        }
                        for y in 0..h {
                            for x in 0..w {
                                mask[(j + y) * nu + i + x] = 0;
                            }
                        }
                        let plane = lo[d] + c + if s > 0 { 1 } else { 0 };
                        let corner = |a: usize, b: usize| {
                            let mut p = [0f32; 3];
                            p[d] = plane as f32 + offset[d];
                            p[u] = (lo[u] + a as i32) as f32 + offset[u];
                            p[v] = (lo[v] + b as i32) as f32 + offset[v];
                            Vec3::from_array(p)
                        };
                        let mut quad = [corner(i, j), corner(i + w, j), corner(i + w, j + h), corner(i, j + h)];
                        if s < 0 {
                            quad.reverse();
                        }
                        let mut n = [0f32; 3];
                        n[d] = s as f32;
                        let color = colors.get(k as usize - 1).copied().unwrap_or([0.5, 0.5, 0.5, 1.0]);
                        let base = out.n_vertices() as u32;
                        for p in quad {
                            out.push_vertex(p, Vec3::from_array(n), color, [0.0; 4], 0);
                        }
                        out.push_triangle([base, base + 1, base + 2], false);
                        out.push_triangle([base, base + 2, base + 3], false);
                        i += w;
                    }
                }
            }
        }
    }
    out
}

/// An [`Output`] holding `meshes` side by side along x (a gap of `gap` blocks between
/// them, each resting on y = 0), y up, for export.
pub fn output_side_by_side(models: &[&VoxelModel], gap: i32) -> Output {
    let mut out = Output { background: [1.0, 1.0, 1.0, 1.0], ..Output::default() };
    let mut x = 0;
    for m in models {
        let Some((lo, hi)) = m.bounds() else { continue };
        let offset = [(x - lo[0]) as f32, -lo[1] as f32, -lo[2] as f32];
        out.mesh.append(&mesh(m, offset));
        x += hi[0] - lo[0] + 1 + gap;
    }
    out
}

/// The same output turned z-up (y → z, z → −y), the convention of the picture renderer.
pub fn z_up(out: &Output) -> Output {
    let turn = |p: [f32; 3]| [p[0], -p[2], p[1]];
    let mut o = out.clone();
    o.mesh.positions.iter_mut().for_each(|p| *p = turn(*p));
    o.mesh.normals.iter_mut().for_each(|n| *n = turn(*n));
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flat_wall_of_one_kind_is_six_quads() {
        let m = crate::format::text::read(
            "0 0 0 a\n1 0 0 a\n2 0 0 a\n0 1 0 a\n1 1 0 a\n2 1 0 a\n", //
        )
        .expect("text");
        let mesh = mesh(&m, [0.0; 3]);
        assert_eq!(mesh.triangles.len(), 12, "one quad per face direction");
        // The +z face: area 3×2, facing +z, counter-clockwise seen from +z.
        let mut area = 0.0;
        for t in &mesh.triangles {
            let p = t.map(|i| Vec3::from_array(mesh.positions[i as usize]));
            let n = Vec3::from_array(mesh.normals[t[0] as usize]);
            let cross = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(cross.dot(n) > 0.0, "winding matches the normal");
            area += cross.length() / 2.0;
        }
        assert!((area - 2.0 * (3.0 * 2.0 + 3.0 + 2.0)).abs() < 1e-5, "surface area {area}");
    }

    #[test]
    fn kinds_keep_their_colours_and_hidden_faces_vanish() {
        let m = crate::format::text::read("0 0 0 #ff0000\n1 0 0 #0000ff\n").expect("text");
        let mesh = mesh(&m, [0.0; 3]);
        assert_eq!(mesh.triangles.len(), 2 * 10, "the shared face is hidden");
        assert!(mesh.colors.iter().all(|c| *c == [1.0, 0.0, 0.0, 1.0] || *c == [0.0, 0.0, 1.0, 1.0]));
    }
}
