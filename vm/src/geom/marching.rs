//! Isosurface extraction by marching cubes: the surface `f = 0` of a scalar field
//! sampled on a regular grid, with the inside where `f < 0`.
//!
//! # Method
//!
//! Marching cubes, but with the per-cube polygons *derived* from the corner signs
//! instead of read from the classic 256-entry tables (the result is the same kind of
//! surface; deriving it removes a large hand-typed table and its ambiguity holes):
//!
//! 1. On each of the cube's six faces, the crossing points (on edges whose ends have
//!    different signs) are joined in pairs by segments. A face with four crossings is
//!    ambiguous; it is resolved with the asymptotic decider (the sign of the bilinear
//!    interpolant at its saddle point), which depends only on that face's four values,
//!    so the two cubes sharing a face always agree and the mesh has no holes.
//! 2. Each segment is directed from the crossing where the face boundary (walked
//!    counter-clockwise seen from outside the cube) enters the inside to the one where
//!    it leaves, which keeps the inside on the same side of every segment. Every
//!    crossing then has exactly one incoming and one outgoing segment, so the segments
//!    chain into closed loops, oriented counter-clockwise seen from the outside of the
//!    solid (from where `f > 0`).
//! 3. A loop of three is a triangle, a loop of four is split along its shorter
//!    diagonal, and longer loops are fanned around their centroid (one extra vertex),
//!    which stays valid for the non-planar loops of saddle-shaped cells.
//!
//! Vertices on grid edges are created once and shared by all cells around the edge
//! (an edge-index map), so a closed surface inside the grid comes out watertight and
//! consistently oriented. Vertex positions interpolate linearly along the edge;
//! normals are the normalised gradient by central differences. The field is sampled
//! one z-slab at a time, so memory grows with the surface, not the grid volume.

use std::collections::HashMap;

use glam::Vec3;

use super::Mesh;

/// A sampling grid: the box `[min, max]` divided into `res` cells per axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Lower corner of the box.
    pub min: Vec3,
    /// Upper corner of the box.
    pub max: Vec3,
    /// Number of cells along x, y and z (each at least 1).
    pub res: [u32; 3],
}

impl Grid {
    /// Number of cells, `res.x · res.y · res.z`.
    pub fn n_cells(&self) -> u64 {
        self.res.iter().map(|&r| r as u64).fold(1u64, |a, r| a.saturating_mul(r))
    }

    /// Position of grid point (i, j, k).
    fn point(&self, i: u32, j: u32, k: u32) -> Vec3 {
        let t = Vec3::new(i as f32 / self.res[0] as f32, j as f32 / self.res[1] as f32, k as f32 / self.res[2] as f32);
        self.min + (self.max - self.min) * t
    }
}

/// Cube corner c sits at offset (c & 1, c >> 1 & 1, c >> 2 & 1).
const CORNER_OFFSETS: [[u32; 3]; 8] =
    [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]];

/// The 12 cube edges as (lower corner, upper corner); the corners differ in one bit.
const EDGES: [(u8, u8); 12] =
    [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)];

/// The six faces, corners counter-clockwise seen from outside the cube
/// (-x, +x, -y, +y, -z, +z).
const FACES: [[u8; 4]; 6] = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];

/// Index into [`EDGES`] of the edge joining corners a and b.
fn edge_index(a: u8, b: u8) -> usize {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    EDGES.iter().position(|&e| e == (lo, hi)).unwrap_or(0)
}

/// Why an isosurface was not built.
#[derive(Clone, Debug, PartialEq)]
pub enum Refused {
    /// The grid has this many cells, more than allowed.
    TooManyCells(u64),
    /// The time budget ran out while polygonising.
    OutOfTime,
    /// A grid that cannot be polygonised (no cells, an empty or non-finite box).
    Bad(String),
}

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refused::TooManyCells(n) => write!(f, "isosurface grid has {n} cells, more than the limit"),
            Refused::OutOfTime => write!(f, "the time budget ran out while it was polygonised"),
            Refused::Bad(m) => write!(f, "{m}"),
        }
    }
}

/// Extracts the surface `f = 0` (inside where `f < 0`) as an indexed, welded mesh with
/// outward-facing (counter-clockwise from outside) triangles, white vertex colours and
/// gradient normals.
///
/// Errors when a resolution is zero, the box is empty or not finite, or the grid has
/// more than `max_cells` cells (a guard against runaway memory and time).
pub fn polygonize(
    grid: &Grid,
    f: &dyn Fn(Vec3) -> f32,
    max_cells: u64,
    out_of_time: &dyn Fn() -> bool,
) -> Result<Mesh, Refused> {
    if grid.res.contains(&0) {
        return Err(Refused::Bad(format!(
            "isosurface grid resolution must be at least 1 per axis, got {:?}",
            grid.res
        )));
    }
    if !(grid.min.is_finite() && grid.max.is_finite() && grid.min.cmplt(grid.max).all()) {
        return Err(Refused::Bad(format!("isosurface box is empty or not finite: min {} max {}", grid.min, grid.max)));
    }
    if grid.n_cells() > max_cells {
        return Err(Refused::TooManyCells(grid.n_cells()));
    }
    let [nx, ny, nz] = grid.res;
    let layer_len = ((nx + 1) * (ny + 1)) as usize;
    let sample_layer = |k: u32| -> Vec<f32> {
        let mut v = Vec::with_capacity(layer_len);
        for j in 0..=ny {
            for i in 0..=nx {
                v.push(f(grid.point(i, j, k)));
            }
        }
        v
    };
    let cell = (grid.max - grid.min) / Vec3::new(nx as f32, ny as f32, nz as f32);
    let mut builder = Builder { grid, f, h: cell * 0.5, mesh: Mesh::default(), edge_vertices: HashMap::new() };
    let mut lower = sample_layer(0);
    for k in 0..nz {
        // The time budget is checked once per layer of cells (a 256² layer samples
        // 66,000 function values), so a budget bounds a large grid too.
        if out_of_time() {
            return Err(Refused::OutOfTime);
        }
        let upper = sample_layer(k + 1);
        for j in 0..ny {
            for i in 0..nx {
                let mut values = [0.0f32; 8];
                for (c, o) in CORNER_OFFSETS.iter().enumerate() {
                    let layer = if o[2] == 0 { &lower } else { &upper };
                    values[c] = layer[((j + o[1]) * (nx + 1) + i + o[0]) as usize];
                }
                builder.cell([i, j, k], &values);
            }
        }
        lower = upper;
    }
    Ok(builder.mesh)
}

/// Per-run state: the mesh being built and the vertex of each crossed grid edge.
struct Builder<'a> {
    grid: &'a Grid,
    f: &'a dyn Fn(Vec3) -> f32,
    /// Central-difference step per axis.
    h: Vec3,
    mesh: Mesh,
    /// Grid edge key (lower grid point id · 3 + axis) → vertex index.
    edge_vertices: HashMap<u64, u32>,
}

impl Builder<'_> {
    /// Emits the polygons of one cell.
    fn cell(&mut self, cell: [u32; 3], values: &[f32; 8]) {
        let inside = values.map(|v| v < 0.0);
        if inside.iter().all(|&b| b) || !inside.iter().any(|&b| b) {
            return;
        }
        // next[e] = the crossing that follows crossing e on its loop.
        let mut next: [Option<u8>; 12] = [None; 12];
        for face in &FACES {
            let mut entries = [0u8; 2];
            let mut exits = [0u8; 2];
            let (mut n_entries, mut n_exits) = (0, 0);
            // Classify the crossings: the boundary walk enters the inside (entry) or leaves it (exit).
            for e in 0..4 {
                let (a, b) = (face[e], face[(e + 1) % 4]);
                if inside[a as usize] == inside[b as usize] {
                    continue;
                }
                let edge = edge_index(a, b) as u8;
                if inside[b as usize] {
                    entries[n_entries] = edge;
                    n_entries += 1;
                } else {
                    exits[n_exits] = edge;
                    n_exits += 1;
                }
            }
            match (n_entries, n_exits) {
                (1, 1) => next[entries[0] as usize] = Some(exits[0]),
                (2, 2) => {
                    // Ambiguous face: cut off the inside corners (connect each entry to
                    // the following exit) unless the asymptotic decider says the inside
                    // is connected across the face centre; then cut off the outside ones.
                    let centre_inside = saddle_value(face.map(|c| values[c as usize])) < 0.0;
                    for &entry in &entries {
                        next[entry as usize] = Some(pick_exit(face, &inside, entry, !centre_inside));
                    }
                }
                _ => {}
            }
        }
        let mut seen = [false; 12];
        for start in 0..12 {
            if seen[start] || next[start].is_none() {
                continue;
            }
            let mut lp: Vec<u32> = Vec::with_capacity(12);
            let mut e = start;
            while !seen[e] {
                seen[e] = true;
                lp.push(self.edge_vertex(cell, e, values));
                match next[e] {
                    Some(n) => e = n as usize,
                    None => break,
                }
            }
            self.emit_loop(&lp);
        }
    }

    /// The vertex on cube edge `e` of `cell`, created on first use.
    fn edge_vertex(&mut self, cell: [u32; 3], e: usize, values: &[f32; 8]) -> u32 {
        let (lo, hi) = EDGES[e];
        let o = CORNER_OFFSETS[lo as usize];
        let axis = (lo ^ hi).trailing_zeros() as u64;
        let [nx, ny, _] = self.grid.res;
        let (i, j, k) = (cell[0] + o[0], cell[1] + o[1], cell[2] + o[2]);
        let id = i as u64 + (nx as u64 + 1) * (j as u64 + (ny as u64 + 1) * k as u64);
        let key = id * 3 + axis;
        if let Some(&v) = self.edge_vertices.get(&key) {
            return v;
        }
        let oh = CORNER_OFFSETS[hi as usize];
        let p0 = self.grid.point(i, j, k);
        let p1 = self.grid.point(cell[0] + oh[0], cell[1] + oh[1], cell[2] + oh[2]);
        let (f0, f1) = (values[lo as usize], values[hi as usize]);
        let t = f0 / (f0 - f1);
        let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.5 };
        let p = p0.lerp(p1, t);
        let v = self.push(p);
        self.edge_vertices.insert(key, v);
        v
    }

    /// Appends a vertex at `p` with the field's gradient as its normal.
    fn push(&mut self, p: Vec3) -> u32 {
        let f = self.f;
        let h = self.h;
        let g = Vec3::new(
            (f(p + Vec3::X * h.x) - f(p - Vec3::X * h.x)) / (2.0 * h.x),
            (f(p + Vec3::Y * h.y) - f(p - Vec3::Y * h.y)) / (2.0 * h.y),
            (f(p + Vec3::Z * h.z) - f(p - Vec3::Z * h.z)) / (2.0 * h.z),
        );
        let n = if g.is_finite() { g.normalize_or(Vec3::Z) } else { Vec3::Z };
        self.mesh.push_vertex(p, n, [1.0; 4], [0.0; 4], 0)
    }

    /// Triangulates one oriented loop.
    fn emit_loop(&mut self, lp: &[u32]) {
        let pos = |m: &Mesh, i: u32| Vec3::from(m.positions[i as usize]);
        match lp.len() {
            0..=2 => {}
            3 => self.mesh.push_triangle([lp[0], lp[1], lp[2]], false),
            4 => {
                let d02 = pos(&self.mesh, lp[0]).distance_squared(pos(&self.mesh, lp[2]));
                let d13 = pos(&self.mesh, lp[1]).distance_squared(pos(&self.mesh, lp[3]));
                if d02 <= d13 {
                    self.mesh.push_triangle([lp[0], lp[1], lp[2]], false);
                    self.mesh.push_triangle([lp[0], lp[2], lp[3]], false);
                } else {
                    self.mesh.push_triangle([lp[1], lp[2], lp[3]], false);
                    self.mesh.push_triangle([lp[1], lp[3], lp[0]], false);
                }
            }
            n => {
                let c = lp.iter().map(|&i| pos(&self.mesh, i)).sum::<Vec3>() / n as f32;
                let ci = self.push(c);
                for m in 0..n {
                    self.mesh.push_triangle([ci, lp[m], lp[(m + 1) % n]], false);
                }
            }
        }
    }
}

/// The value of the bilinear interpolant of a face at its saddle point (asymptotic
/// decider). `v` holds the corners in cyclic order, so (v0, v2) and (v1, v3) are the
/// diagonals. Only called for ambiguous faces, where the denominator cannot vanish.
fn saddle_value(v: [f32; 4]) -> f32 {
    let den = v[0] + v[2] - v[1] - v[3];
    if den == 0.0 {
        return 0.25 * (v[0] + v[1] + v[2] + v[3]);
    }
    (v[0] * v[2] - v[1] * v[3]) / den
}

/// On an ambiguous face, the exit crossing that the segment starting at the entry
/// crossing `entry` ends at: the next exit counter-clockwise (cutting off an inside
/// corner) when `to_following`, else the previous one (cutting off an outside corner).
fn pick_exit(face: &[u8; 4], inside: &[bool; 8], entry: u8, to_following: bool) -> u8 {
    let pos = (0..4).find(|&e| edge_index(face[e], face[(e + 1) % 4]) as u8 == entry).unwrap_or(0);
    // On an ambiguous face every edge is a crossing and entries and exits alternate,
    // so the neighbouring edges of an entry are exits.
    let e = if to_following { (pos + 1) % 4 } else { (pos + 3) % 4 };
    debug_assert!(inside[face[e] as usize] && !inside[face[(e + 1) % 4] as usize]);
    edge_index(face[e], face[(e + 1) % 4]) as u8
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;

    fn sphere_mesh(res: u32) -> Mesh {
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [res; 3] };
        polygonize(&grid, &|p: Vec3| p.length() - 0.8, 1 << 20, &|| false).expect("grid within limits")
    }

    fn signed_volume(m: &Mesh) -> f32 {
        m.oriented_triangles()
            .map(|t| {
                let p = t.map(|i| Vec3::from(m.positions[i as usize]));
                p[0].dot(p[1].cross(p[2])) / 6.0
            })
            .sum()
    }

    /// Every undirected edge is used by exactly two triangles, once in each direction.
    fn assert_closed_and_oriented(m: &Mesh) {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &directed {
            assert_eq!(c, 1, "edge {a}-{b} used twice in the same direction");
            assert_eq!(directed.get(&(b, a)), Some(&1), "edge {a}-{b} is a boundary");
        }
    }

    #[test]
    fn sphere_is_watertight_outward_and_accurate() {
        let m = sphere_mesh(32);
        assert!(m.triangles.len() > 1000);
        assert_closed_and_oriented(&m);
        let exact = 4.0 / 3.0 * std::f32::consts::PI * 0.8f32.powi(3);
        let v = signed_volume(&m);
        assert!((v - exact).abs() / exact < 0.03, "volume {v} vs {exact}");
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let p = Vec3::from(*p);
            assert!((p.length() - 0.8).abs() < 0.02, "vertex at radius {}", p.length());
            assert!(Vec3::from(*n).dot(p.normalize()) > 0.99, "normal is radial");
        }
    }

    #[test]
    fn the_time_budget_is_checked_inside_a_grid() {
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [40, 40, 40] };
        let layers = std::cell::Cell::new(0);
        let stop_after_3 = || {
            layers.set(layers.get() + 1);
            layers.get() > 3
        };
        let err = polygonize(&grid, &|p: Vec3| p.length() - 0.5, 1 << 20, &stop_after_3).expect_err("out of time");
        assert_eq!(err, Refused::OutOfTime);
        assert_eq!(layers.get(), 4, "checked once per layer, stopped at the first late one");
    }

    #[test]
    fn saddle_cells_stay_watertight() {
        // Two close spheres and a torus produce ambiguous faces and tunnel cells.
        let grid = Grid { min: Vec3::splat(-1.5), max: Vec3::splat(1.5), res: [19, 17, 23] };
        let f = |p: Vec3| {
            let a = (p - Vec3::new(0.42, 0.0, 0.0)).length() - 0.4;
            let b = (p + Vec3::new(0.42, 0.0, 0.0)).length() - 0.4;
            let q = Vec3::new(Vec3::new(p.x, p.y, 0.0).length() - 0.9, p.z, 0.0);
            a.min(b).min(q.length() - 0.25)
        };
        let m = polygonize(&grid, &f, 1 << 20, &|| false).expect("within limits");
        assert_closed_and_oriented(&m);
        assert!(signed_volume(&m) > 0.0);
        // A noisy field with many sign changes.
        let g = |p: Vec3| (p.x * 7.1).sin() * (p.y * 5.3).cos() + (p.z * 6.7).sin() * 0.7 + 0.05;
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [12, 12, 12] };
        let m = polygonize(&grid, &g, 1 << 20, &|| false).expect("within limits");
        // Surfaces cut by the box are open at the box; check interior edges only by
        // requiring that no edge is used twice in the same direction.
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert!(directed.values().all(|&c| c == 1));
    }

    #[test]
    fn refuses_oversized_and_invalid_grids() {
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [100, 100, 100] };
        let err = polygonize(&grid, &|p: Vec3| p.length() - 0.5, 999_999, &|| false).expect_err("too many cells");
        assert_eq!(err, Refused::TooManyCells(1_000_000));
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [0, 4, 4] };
        assert!(polygonize(&grid, &|p: Vec3| p.length(), 1000, &|| false).is_err());
        let grid = Grid { min: Vec3::splat(1.0), max: Vec3::splat(-1.0), res: [4, 4, 4] };
        assert!(polygonize(&grid, &|p: Vec3| p.length(), 1000, &|| false).is_err());
    }

    #[test]
    fn empty_and_full_fields_give_empty_meshes() {
        let grid = Grid { min: Vec3::splat(-1.0), max: Vec3::splat(1.0), res: [4, 4, 4] };
        assert!(polygonize(&grid, &|_| 1.0, 1000, &|| false).expect("ok").triangles.is_empty());
        assert!(polygonize(&grid, &|_| -1.0, 1000, &|| false).expect("ok").triangles.is_empty());
    }
}
