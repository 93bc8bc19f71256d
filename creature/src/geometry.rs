//! Geometry rules (paper §3.4): the part library (each part's mesh evaluated once),
//! the geometry-rule program that attaches every meta-part by its slots — translate
//! to the slot centre (T_ST), arrange, fine rotations (R_x, R_y, R_z), rotate the
//! joint onto the slot (R_ST), scale to the slot size (S_ST) and by S_s, instance
//! (I k_i), with `[` `]` pushing and popping the frame — its interpreter, the
//! stability test, and the assembled mesh.

use super::error::LibraryError;
use super::outline::Outline;
use super::shape::Shape;
use super::table::{CreatureTable, Geometry, Mode, PartDef, Slot};
use glam::{Mat3, Mat4, Vec2, Vec3};
use mdg_vm::bundle::Bundle;
use mdg_vm::eval::{evaluate, EvalOptions};
use mdg_vm::output::{Mesh, Output};
use rayon::prelude::*;
use std::fmt::Write as _;

/// One part's geometry, evaluated once per run, in the part's own coordinates.
#[derive(Clone, Debug)]
pub struct PartGeometry {
    pub mesh: Mesh,
    /// A sparse set of surface points (one per grid cell) for grounding and support.
    pub points: Vec<Vec3>,
    /// Volume (mass at unit density) and centre of mass.
    pub volume: f32,
    pub centroid: Vec3,
    /// Extent along the joint frame's x and y axes (for spacing arrangements).
    pub joint_extent: Vec2,
    /// Diagonal of the bounding box (part units).
    pub diag: f32,
    /// Surface points for the contact test (one per cell of 1/40 of the diagonal),
    /// nearest to the joint first: a part touching its parent does so near its joint.
    pub contact_points: Vec<Vec3>,
    /// Triangles (indices into the mesh's), bucketed by the cells of
    /// [`CONTACT_EPSILON`] × `diag` within that distance of their bounding boxes,
    /// to find the surface near a point from its own cell.
    pub grid: std::collections::HashMap<(i32, i32, i32), Vec<u32>>,
    /// The mesh reduced to what a silhouette needs (see [`super::silhouette`]).
    pub outline: Outline,
}

/// Contact tolerance: a part touches its parent when a point of its surface is
/// within this fraction of the parent part's bounding-box diagonal (in the parent's
/// units, so it scales with the parent) of the parent's surface.
pub const CONTACT_EPSILON: f32 = 0.03;

/// The geometry of every part of a table (index-aligned with `table.parts`).
#[derive(Clone, Debug)]
pub struct Library {
    pub parts: Vec<PartGeometry>,
    /// Seat every copy of an arrangement on its torso's surface (see [`seat`]);
    /// `false` keeps the plain arrangement offsets (for measuring the difference).
    pub seat: bool,
    /// Seated offsets by (torso part, slot, offset bits): [`seat`] is a pure
    /// function of them, and the same few arrangements recur in every offspring.
    pub seat_cache: SeatCache,
}

/// See [`Library::seat_cache`].
pub type SeatCache = std::sync::Arc<std::sync::RwLock<std::collections::HashMap<(u32, u32, [u32; 3]), Vec3>>>;

impl PartGeometry {
    /// Whether `q` (in the part's coordinates) is within [`CONTACT_EPSILON`] ×
    /// `diag` of the part's surface.
    pub fn near_surface(&self, q: Vec3) -> bool {
        let e = CONTACT_EPSILON * self.diag;
        let k = (q / e).floor().as_ivec3();
        let Some(tris) = self.grid.get(&(k.x, k.y, k.z)) else { return false };
        tris.iter().any(|&ti| {
            let Some(t) = self.mesh.triangles.get(ti as usize) else { return false };
            let [a, b, c] = t.map(|i| Vec3::from(self.mesh.positions.get(i as usize).copied().unwrap_or_default()));
            // The box test first: most triangles of the cell are farther than ε.
            let (lo, hi) = (a.min(b).min(c) - Vec3::splat(e), a.max(b).max(c) + Vec3::splat(e));
            q.cmpge(lo).all() && q.cmple(hi).all() && closest_on_triangle(q, a, b, c).distance_squared(q) <= e * e
        })
    }
}

/// The point of triangle (a, b, c) closest to `p` (Ericson, *Real-Time Collision
/// Detection*, 5.1.5).
pub fn closest_on_triangle(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < 1e-30 {
        return a;
    }
    let (v, w) = (vb / denom, vc / denom);
    a + ab * v + ac * w
}

/// The orthonormal frame of a slot: x = up × normal, y = up, z = normal, origin at
/// the centre.
pub fn slot_frame(s: &Slot) -> Mat4 {
    let z = Vec3::from(s.normal).normalize_or_zero();
    let y = Vec3::from(s.up).normalize_or_zero();
    let x = y.cross(z);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), Vec3::from(s.at).extend(1.0))
}

/// Reflection across the plane x = 0 (the creatures' plane of symmetry).
pub fn mirror_x() -> Mat4 {
    Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))
}

/// The frame of slot `slot` of `part`: a mirror slot is its original's frame reflected.
pub fn part_slot_frame(part: &PartDef, slot: u32) -> Option<Mat4> {
    let s = part.slots.get(slot as usize)?;
    match s.mirror_of {
        Some(m) => Some(mirror_x() * slot_frame(part.slots.get(m as usize)?)),
        None => Some(slot_frame(s)),
    }
}

impl Library {
    /// Evaluates every part's rule (with the bundle's own seed and the default
    /// limits) or converts its embedded mesh: [`Library::build_with`], with the
    /// limits' warnings dropped.
    pub fn build(bundle: &Bundle, t: &CreatureTable) -> Result<Library, LibraryError> {
        Library::build_with(bundle, t, &EvalOptions::default()).map(|(lib, _)| lib)
    }

    /// Evaluates every part's rule (with the bundle's own seed, under the limits
    /// of `opts`) or converts its embedded mesh; returns the library and the
    /// evaluations' warnings, each naming its part. Parts are independent, so they
    /// are made in parallel.
    pub fn build_with(
        bundle: &Bundle,
        t: &CreatureTable,
        opts: &EvalOptions,
    ) -> Result<(Library, Vec<String>), LibraryError> {
        let opts = EvalOptions { seed: None, record_sites: false, ..opts.clone() };
        let built = t
            .parts
            .par_iter()
            .map(|p| {
                let (mesh, warnings) = match &p.geometry {
                    Geometry::Rule(r) => {
                        let mut b = bundle.clone();
                        b.settings.startshape = *r;
                        b.settings.camerarule = mdg_vm::bundle::NONE;
                        let out = evaluate(&b, &opts);
                        let w = out.stats.warnings.iter().map(|w| format!("part `{}`: {w}", p.name)).collect();
                        (out.flattened(), w)
                    }
                    Geometry::Mesh(m) => {
                        let pm =
                            t.meshes.get(*m as usize).ok_or_else(|| LibraryError::NoMesh { part: p.name.clone() })?;
                        (mesh_from_obj(&pm.positions, &pm.triangles, pm.color), Vec::new())
                    }
                };
                if mesh.triangles.is_empty() {
                    let warning = warnings.first().cloned();
                    return Err(LibraryError::NoTriangles { part: p.name.clone(), warning });
                }
                Ok((PartGeometry::new(mesh, p), warnings))
            })
            .collect::<Result<Vec<_>, LibraryError>>()?;
        let mut parts = Vec::with_capacity(built.len());
        let mut warnings = Vec::new();
        for (part, w) in built {
            parts.push(part);
            warnings.extend(w);
        }
        Ok((Library { parts, seat: true, seat_cache: SeatCache::default() }, warnings))
    }
}

/// A mesh with area-weighted vertex normals from positions and triangles.
pub fn mesh_from_obj(positions: &[[f32; 3]], triangles: &[[u32; 3]], color: [f32; 4]) -> Mesh {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| Vec3::from(positions.get(i as usize).copied().unwrap_or_default()));
        let n = (b - a).cross(c - a);
        for &i in t {
            if let Some(v) = normals.get_mut(i as usize) {
                *v += n;
            }
        }
    }
    let mut m = Mesh::default();
    for (p, n) in positions.iter().zip(&normals) {
        m.push_vertex(Vec3::from(*p), n.normalize_or(Vec3::Z), color, [0.0; 4], 0);
    }
    for t in triangles {
        m.push_triangle(*t, false);
    }
    m
}

impl PartGeometry {
    fn new(mesh: Mesh, def: &PartDef) -> PartGeometry {
        let pos: Vec<Vec3> = mesh.positions.iter().map(|p| Vec3::from(*p)).collect();
        let (lo, hi) =
            pos.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        let diag = (hi - lo).length().max(1e-6);
        // Volume and centre of mass by the divergence theorem; open or flat meshes
        // (membranes) fall back to a thin shell of their area.
        let (mut vol, mut moment, mut area, mut area_moment) = (0.0f64, glam::DVec3::ZERO, 0.0f64, glam::DVec3::ZERO);
        for t in mesh.oriented_triangles() {
            let [a, b, c] = t.map(|i| pos.get(i as usize).copied().unwrap_or_default().as_dvec3());
            let v = a.dot(b.cross(c)) / 6.0;
            vol += v;
            moment += v * (a + b + c) / 4.0;
            let ar = (b - a).cross(c - a).length() / 2.0;
            area += ar;
            area_moment += ar * (a + b + c) / 3.0;
        }
        let box_vol = ((hi - lo).x * (hi - lo).y * (hi - lo).z).abs() as f64;
        let (volume, centroid) = if vol.abs() > 1e-3 * box_vol && vol.abs() > 1e-12 {
            (vol.abs() as f32, (moment / vol).as_vec3())
        } else if area > 0.0 {
            ((area * 0.01 * diag as f64) as f32, (area_moment / area).as_vec3())
        } else {
            (1e-6, (lo + hi) * 0.5)
        };
        // One surface point per occupied grid cell.
        let cell = diag / 14.0;
        let mut cells = std::collections::BTreeSet::new();
        let mut points = Vec::new();
        for p in &pos {
            let k = ((p - lo) / cell).floor().as_ivec3();
            if cells.insert((k.x, k.y, k.z)) {
                points.push(*p);
            }
        }
        let joint_extent = match &def.joint {
            Some(j) => {
                let f = slot_frame(j).inverse();
                let (mut lo2, mut hi2) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
                for p in &pos {
                    let q = f.transform_point3(*p).truncate();
                    lo2 = lo2.min(q);
                    hi2 = hi2.max(q);
                }
                (hi2 - lo2).max(Vec2::ZERO)
            }
            None => Vec2::new(hi.x - lo.x, hi.z - lo.z),
        };
        let joint_at = def.joint.as_ref().map(|j| Vec3::from(j.at)).unwrap_or((lo + hi) * 0.5);
        let fine = diag / 40.0;
        let mut fine_cells = std::collections::BTreeSet::new();
        let mut contact_points: Vec<Vec3> = Vec::new();
        let tri_pos = |t: &[u32; 3]| t.map(|i| pos.get(i as usize).copied().unwrap_or_default());
        let centroids: Vec<Vec3> = mesh.triangles.iter().map(|t| tri_pos(t).iter().sum::<Vec3>() / 3.0).collect();
        for p in pos.iter().chain(&centroids) {
            let k = ((p - lo) / fine).floor().as_ivec3();
            if fine_cells.insert((k.x, k.y, k.z)) {
                contact_points.push(*p);
            }
        }
        contact_points.sort_by(|a, b| a.distance_squared(joint_at).total_cmp(&b.distance_squared(joint_at)));
        let gcell = CONTACT_EPSILON * diag;
        let mut grid: std::collections::HashMap<(i32, i32, i32), Vec<u32>> = std::collections::HashMap::new();
        for (i, t) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = tri_pos(t);
            // Every cell within ε of the triangle's box: a point needs only its own cell.
            let k0 = ((a.min(b).min(c) - Vec3::splat(gcell)) / gcell).floor().as_ivec3();
            let k1 = ((a.max(b).max(c) + Vec3::splat(gcell)) / gcell).floor().as_ivec3();
            for x in k0.x..=k1.x {
                for y in k0.y..=k1.y {
                    for z in k0.z..=k1.z {
                        grid.entry((x, y, z)).or_default().push(i as u32);
                    }
                }
            }
        }
        let outline = Outline::new(&mesh);
        PartGeometry { mesh, points, volume, centroid, joint_extent, diag, contact_points, grid, outline }
    }
}

/// One instruction of a geometry-rule program.
#[derive(Clone, Debug, PartialEq)]
pub enum GeoOp {
    /// `[`: save the frame.
    Push,
    /// `]`: restore it.
    Pop,
    /// T_ST: move to the centre and orientation of slot `slot` of torso part `part`.
    Slot { part: u32, slot: u32 },
    /// The arrangement: meta-part `k` of `n` in `mode`, as an offset and tilt in
    /// the slot frame.
    Arrange { mode: Mode, k: u32, n: u32, offset: Vec3, tilt: Vec3 },
    /// R_x, R_y, R_z: fine rotations in the slot frame (radians).
    Turn(Vec3),
    /// R_ST: turn the part so its joint faces the slot (a half turn about y).
    Align,
    /// S_ST: scale by slot size / joint size.
    ScaleToSlot(f32),
    /// S_s: the part's own scale.
    Scale(f32),
    /// Move the part's joint frame onto the current frame.
    Joint(u32),
    /// I k_i: place part `part` as meta-part `meta`.
    Instance { part: u32, meta: u32 },
}

/// A placed geometry instance.
#[derive(Clone, Debug, PartialEq)]
pub struct Placed {
    pub part: u32,
    /// Meta-part id.
    pub meta: u32,
    /// Part to world (may be mirrored).
    pub transform: Mat4,
}

/// The result of the stability test.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stability {
    /// Centre of mass (after grounding).
    pub com: Vec3,
    /// Convex hull of the support points projected on the ground, counter-clockwise.
    pub hull: Vec<Vec2>,
    /// Signed distance from the projected centre of mass to the hull's boundary
    /// (positive inside), in model units.
    pub margin: f32,
    pub stable: bool,
}

/// A shape interpreted into geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Layout {
    pub program: Vec<GeoOp>,
    pub placed: Vec<Placed>,
    pub stability: Stability,
    /// Bounding box after grounding (min z = 0, centred on x = y = 0).
    pub min: Vec3,
    pub max: Vec3,
    /// Meta-part ids of placed parts that touch nothing of the torso they are
    /// attached to (see [`touches`]); evolution rejects such layouts.
    pub detached: Vec<u32>,
}

/// Arrangement geometry: the offset and tilt of meta-part `k` of `n`.
fn arrange(mode: Mode, k: u32, n: u32, spacing: Vec2) -> (Vec3, Vec3) {
    if n <= 1 {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let t = k as f32 - (n as f32 - 1.0) / 2.0;
    match mode {
        Mode::Def | Mode::Row => (Vec3::new(t * spacing.x, 0.0, 0.0), Vec3::new(0.0, t * 14f32.to_radians(), 0.0)),
        Mode::Stack => (Vec3::new(0.0, -t * spacing.y, 0.0), Vec3::new(t * 22f32.to_radians(), 0.0, 0.0)),
        Mode::Fan => (Vec3::new(t * spacing.x * 0.25, 0.0, 0.0), Vec3::new(0.0, t * 30f32.to_radians(), 0.0)),
    }
}

/// Seats a copy of an arrangement on the torso's surface: its offset `offset` (in
/// the slot frame: x, y across the slot, z along its normal) is moved along the
/// normal so the copy's joint is as deep below the torso's surface as the slot
/// centre is, the surface found by a ray cast against the torso's mesh from
/// outside along −normal. Where the ray misses the torso near the slot (the copy
/// would hang beside a narrow neck), the offset is shrunk towards the centre until
/// it meets the surface — the spacing becomes the torso's width at the slot.
pub fn seat(torso: &PartDef, geometry: Option<&PartGeometry>, slot: u32, offset: Vec3) -> Vec3 {
    let (Some(g), Some(frame), Some(s)) = (geometry, part_slot_frame(torso, slot), torso.slots.get(slot as usize))
    else {
        return offset;
    };
    let window = s.size.max(1e-4);
    let depth_at = |x: f32, y: f32| surface_depth(&g.mesh, &frame, x, y, g.diag, window);
    let centre = depth_at(0.0, 0.0).unwrap_or(0.0);
    let mut f = 1.0f32;
    for _ in 0..12 {
        let (x, y) = (offset.x * f, offset.y * f);
        if let Some(z) = depth_at(x, y) {
            return Vec3::new(x, y, offset.z + z - centre);
        }
        f *= 0.8;
    }
    Vec3::new(0.0, 0.0, offset.z)
}

/// The outermost point of `mesh` on the line through (x, y) along the z axis of
/// slot frame `frame` (slot coordinates), within `window` of the slot plane: its z,
/// or `None` when the line meets no surface there.
fn surface_depth(mesh: &Mesh, frame: &Mat4, x: f32, y: f32, reach: f32, window: f32) -> Option<f32> {
    let o = frame.transform_point3(Vec3::new(x, y, reach));
    let d = frame.transform_vector3(Vec3::new(0.0, 0.0, -1.0));
    let len = d.length();
    if len <= 0.0 || !o.is_finite() {
        return None;
    }
    let d = d / len;
    let mut best: Option<f32> = None;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| Vec3::from(mesh.positions.get(i as usize).copied().unwrap_or_default()));
        // Möller–Trumbore, both sides.
        let (e1, e2) = (b - a, c - a);
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            continue;
        }
        let inv = 1.0 / det;
        let s = o - a;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            continue;
        }
        let q = s.cross(e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            continue;
        }
        let dist = e2.dot(q) * inv;
        // Slot-frame z of the hit: the frame's z axis is a unit vector.
        let z = reach - dist / len;
        if z.abs() <= window && best.is_none_or(|b| z > b) {
            best = Some(z);
        }
    }
    best
}

fn rot_xyz(r: Vec3) -> Mat4 {
    Mat4::from_rotation_x(r.x) * Mat4::from_rotation_y(r.y) * Mat4::from_rotation_z(r.z)
}

/// The geometry-rule program of `shape` (paper §3.4): the root torso, then for
/// every super-part attached to a torso, for each of its meta-parts,
/// `[ T_ST A R R_ST S_ST S_s J I … ]`, torsos nesting the parts attached to them.
pub fn program(t: &CreatureTable, lib: &Library, shape: &Shape) -> Vec<GeoOp> {
    let mut ops = Vec::new();
    if let Some(root) = shape.supers.first().and_then(|s| s.metas.first()) {
        let scale = t.parts.get(root.geometry as usize).map(|p| p.scale).unwrap_or(1.0);
        ops.push(GeoOp::Scale(scale));
        ops.push(GeoOp::Instance { part: root.geometry, meta: root.id });
        children(t, lib, shape, 0, &mut ops, 0);
    }
    ops
}

fn children(t: &CreatureTable, lib: &Library, shape: &Shape, torso: usize, ops: &mut Vec<GeoOp>, depth: usize) {
    if depth > shape.supers.len() {
        return;
    }
    let Some(torso_geo) = shape.supers.get(torso).and_then(|s| s.metas.first()).map(|m| m.geometry) else { return };
    let Some(torso_part) = t.parts.get(torso_geo as usize) else { return };
    for c in shape.children(torso as u32).collect::<Vec<_>>() {
        let sp = &shape.supers[c];
        let Some(a) = sp.attach else { continue };
        let Some(slot) = torso_part.slots.get(a.slot as usize) else { continue };
        let orig = slot.mirror_of.and_then(|m| torso_part.slots.get(m as usize)).unwrap_or(slot);
        let n = sp.metas.len() as u32;
        for (k, m) in sp.metas.iter().enumerate() {
            let Some(part) = t.parts.get(m.geometry as usize) else { continue };
            let Some(joint) = &part.joint else { continue };
            let ratio = orig.size / joint.size;
            let spacing = if orig.spacing > 0.0 {
                Vec2::splat(orig.spacing)
            } else {
                lib.parts.get(m.geometry as usize).map(|g| g.joint_extent).unwrap_or(Vec2::ONE)
                    * ratio
                    * part.scale
                    * 1.05
            };
            let (mut offset, tilt) = arrange(sp.mode, k as u32, n, spacing);
            if lib.seat && offset != Vec3::ZERO {
                let key = (torso_geo, a.slot, offset.to_array().map(f32::to_bits));
                let cached = lib.seat_cache.read().ok().and_then(|c| c.get(&key).copied());
                offset = match cached {
                    Some(o) => o,
                    None => {
                        let o = seat(torso_part, lib.parts.get(torso_geo as usize), a.slot, offset);
                        if let Ok(mut c) = lib.seat_cache.write() {
                            c.insert(key, o);
                        }
                        o
                    }
                };
            }
            ops.push(GeoOp::Push);
            ops.push(GeoOp::Slot { part: torso_geo, slot: a.slot });
            ops.push(GeoOp::Arrange { mode: sp.mode, k: k as u32, n, offset, tilt });
            if orig.turn != [0.0; 3] {
                ops.push(GeoOp::Turn(Vec3::from(orig.turn)));
            }
            ops.push(GeoOp::Align);
            ops.push(GeoOp::ScaleToSlot(ratio));
            if part.scale != 1.0 {
                ops.push(GeoOp::Scale(part.scale));
            }
            ops.push(GeoOp::Joint(m.geometry));
            ops.push(GeoOp::Instance { part: m.geometry, meta: m.id });
            if t.kinds.get(sp.kind as usize).is_some_and(|k| k.torso) {
                children(t, lib, shape, c, ops, depth + 1);
            }
            ops.push(GeoOp::Pop);
        }
    }
}

/// Runs a geometry-rule program: the placed instances, in model space.
pub fn interpret(t: &CreatureTable, ops: &[GeoOp]) -> Vec<Placed> {
    let mut m = Mat4::IDENTITY;
    let mut stack = Vec::new();
    let mut placed = Vec::new();
    for op in ops {
        match op {
            GeoOp::Push => stack.push(m),
            GeoOp::Pop => m = stack.pop().unwrap_or(Mat4::IDENTITY),
            GeoOp::Slot { part, slot } => {
                if let Some(f) = t.parts.get(*part as usize).and_then(|p| part_slot_frame(p, *slot)) {
                    m *= f;
                }
            }
            GeoOp::Arrange { offset, tilt, .. } => m = m * Mat4::from_translation(*offset) * rot_xyz(*tilt),
            GeoOp::Turn(r) => m *= rot_xyz(*r),
            GeoOp::Align => m *= Mat4::from_rotation_y(std::f32::consts::PI),
            GeoOp::ScaleToSlot(s) | GeoOp::Scale(s) => m *= Mat4::from_scale(Vec3::splat(*s)),
            GeoOp::Joint(p) => {
                if let Some(j) = t.parts.get(*p as usize).and_then(|p| p.joint.as_ref()) {
                    m *= slot_frame(j).inverse();
                }
            }
            GeoOp::Instance { part, meta } => placed.push(Placed { part: *part, meta: *meta, transform: m }),
        }
    }
    placed
}

/// The program in the paper's notation, e.g.
/// `S(1) I h_torso [ T(neck) A(def) R_ST S_ST(0.9) J I h_head ] …`.
pub fn program_text(t: &CreatureTable, ops: &[GeoOp]) -> String {
    let name = |p: u32| t.parts.get(p as usize).map(|p| p.name.as_str()).unwrap_or("?");
    let mut s = String::new();
    for op in ops {
        let _ = match op {
            GeoOp::Push => write!(s, "[ "),
            GeoOp::Pop => write!(s, "] "),
            GeoOp::Slot { part, slot } => {
                let sl = t.parts.get(*part as usize).and_then(|p| p.slots.get(*slot as usize));
                write!(s, "T({}) ", sl.map(|s| s.name.as_str()).unwrap_or("?"))
            }
            GeoOp::Arrange { mode, k, n, .. } => write!(s, "A({}) ", mode.position(*k as usize, *n as usize)),
            GeoOp::Turn(r) => write!(s, "R({:.0},{:.0},{:.0}) ", r.x.to_degrees(), r.y.to_degrees(), r.z.to_degrees()),
            GeoOp::Align => write!(s, "R_ST "),
            GeoOp::ScaleToSlot(k) => write!(s, "S_ST({k:.2}) "),
            GeoOp::Scale(k) => write!(s, "S({k:.2}) "),
            GeoOp::Joint(_) => Ok(()),
            GeoOp::Instance { part, .. } => write!(s, "I {} ", name(*part)),
        };
    }
    s.trim_end().to_string()
}

/// Lays out `shape`: runs its geometry program, puts it on the ground (lowest point
/// at z = 0, centred on x = y = 0) and runs the stability test.
pub fn layout(t: &CreatureTable, lib: &Library, shape: &Shape) -> Layout {
    let ops = program(t, lib, shape);
    let mut placed = interpret(t, &ops);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for p in &placed {
        let Some(g) = lib.parts.get(p.part as usize) else { continue };
        for q in &g.points {
            let w = p.transform.transform_point3(*q);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    if lo.x > hi.x {
        lo = Vec3::ZERO;
        hi = Vec3::ZERO;
    }
    let shift = Vec3::new(-(lo.x + hi.x) * 0.5, -(lo.y + hi.y) * 0.5, -lo.z);
    for p in &mut placed {
        p.transform = Mat4::from_translation(shift) * p.transform;
    }
    let stability = stability(t, lib, &placed, hi.z - lo.z);
    let detached = detached(lib, shape, &placed);
    Layout { program: ops, placed, stability, min: lo + shift, max: hi + shift, detached }
}

/// Whether placed part `child` touches placed part `parent`: a point of the
/// child's surface lies within [`CONTACT_EPSILON`] of the parent's diagonal of the
/// parent's surface.
pub fn touches(lib: &Library, child: &Placed, parent: &Placed) -> bool {
    let (Some(c), Some(p)) = (lib.parts.get(child.part as usize), lib.parts.get(parent.part as usize)) else {
        return false;
    };
    let to_parent = parent.transform.inverse() * child.transform;
    if !to_parent.is_finite() {
        return false;
    }
    c.contact_points.iter().any(|q| p.near_surface(to_parent.transform_point3(*q)))
}

/// Meta-part ids of the placed parts that do not touch the torso they are attached to.
pub fn detached(lib: &Library, shape: &Shape, placed: &[Placed]) -> Vec<u32> {
    let by_meta: std::collections::BTreeMap<u32, &Placed> = placed.iter().map(|p| (p.meta, p)).collect();
    let mut out = Vec::new();
    for sp in &shape.supers {
        let Some(a) = sp.attach else { continue };
        let Some(parent) = shape.supers.get(a.parent as usize).and_then(|s| s.metas.first()) else { continue };
        let Some(pp) = by_meta.get(&parent.id) else { continue };
        for m in &sp.metas {
            if let Some(cp) = by_meta.get(&m.id) {
                if !touches(lib, cp, pp) {
                    out.push(m.id);
                }
            }
        }
    }
    out
}

/// The stability test (paper §4, after Fit and Diverse): the centre of mass,
/// projected on the ground, must fall inside the convex hull of the support points
/// — the points of support parts (legs) within 2.5% of the height of the ground.
/// Parts are grounded already (lowest point at z = 0).
pub fn stability(t: &CreatureTable, lib: &Library, placed: &[Placed], height: f32) -> Stability {
    let mut mass = 0.0f32;
    let mut moment = Vec3::ZERO;
    let eps = (0.025 * height).max(1e-4);
    let mut contacts: Vec<Vec2> = Vec::new();
    for p in placed {
        let (Some(g), Some(def)) = (lib.parts.get(p.part as usize), t.parts.get(p.part as usize)) else { continue };
        let det = Mat3::from_mat4(p.transform).determinant().abs();
        let m = g.volume * det;
        mass += m;
        moment += m * p.transform.transform_point3(g.centroid);
        if def.support {
            for q in &g.points {
                let w = p.transform.transform_point3(*q);
                if w.z <= eps {
                    contacts.push(w.truncate());
                }
            }
        }
    }
    let com = if mass > 0.0 { moment / mass } else { Vec3::ZERO };
    let hull = convex_hull(contacts);
    let margin = hull_margin(&hull, com.truncate());
    Stability { com, stable: hull.len() >= 3 && margin > 0.0, hull, margin }
}

/// Convex hull (Andrew's monotone chain), counter-clockwise, no collinear points.
pub fn convex_hull(mut pts: Vec<Vec2>) -> Vec<Vec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: Vec2, a: Vec2, b: Vec2| (a - o).perp_dot(b - o);
    let mut lower: Vec<Vec2> = Vec::new();
    for &p in &pts {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<Vec2> = Vec::new();
    for &p in pts.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Signed distance from `p` to the boundary of a counter-clockwise convex polygon:
/// positive inside. −∞ for fewer than three vertices.
pub fn hull_margin(hull: &[Vec2], p: Vec2) -> f32 {
    if hull.len() < 3 {
        return f32::NEG_INFINITY;
    }
    let mut m = f32::INFINITY;
    for i in 0..hull.len() {
        let (a, b) = (hull[i], hull[(i + 1) % hull.len()]);
        let e = b - a;
        let len = e.length();
        if len <= 0.0 {
            continue;
        }
        m = m.min(e.perp_dot(p - a) / len);
    }
    m
}

/// The monster as one mesh (every instance transformed into place), for export
/// and pictures. `offset` moves the whole model.
pub fn assemble(lib: &Library, placed: &[Placed], offset: Vec3, out: &mut Mesh) {
    let extra: usize = placed.iter().filter_map(|p| lib.parts.get(p.part as usize)).map(|g| g.mesh.n_vertices()).sum();
    let extra_t: usize =
        placed.iter().filter_map(|p| lib.parts.get(p.part as usize)).map(|g| g.mesh.triangles.len()).sum();
    out.positions.reserve(extra);
    out.normals.reserve(extra);
    out.colors.reserve(extra);
    out.triangles.reserve(extra_t);
    out.mirrored.reserve(extra_t);
    // Weights and bones stay empty (all zero), as `Mesh::push_vertex` keeps them.
    let pad = !out.weights.is_empty() || !out.bones.is_empty();
    for p in placed {
        let Some(g) = lib.parts.get(p.part as usize) else { continue };
        let m = Mat4::from_translation(offset) * p.transform;
        let lin = Mat3::from_mat4(m);
        let nm = lin.inverse().transpose();
        let mirrored = lin.determinant() < 0.0;
        let base = out.positions.len() as u32;
        let src = &g.mesh;
        let n = src.n_vertices();
        out.positions.extend(src.positions.iter().map(|q| m.transform_point3(Vec3::from(*q)).to_array()));
        out.normals.extend((0..n).map(|i| {
            (nm * Vec3::from(src.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]))).normalize_or_zero().to_array()
        }));
        out.colors.extend((0..n).map(|i| src.colors.get(i).copied().unwrap_or([1.0; 4])));
        out.triangles.extend(src.triangles.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        out.mirrored
            .extend((0..src.triangles.len()).map(|k| src.mirrored.get(k).copied().unwrap_or(false) != mirrored));
        if pad {
            let len = out.positions.len();
            if !out.weights.is_empty() {
                out.weights.resize(len, [0.0; 4]);
            }
            if !out.bones.is_empty() {
                out.bones.resize(len, 0);
            }
        }
    }
}

/// The name of the node of meta-part `meta` in a monster's `.glb`: its super-part,
/// type and place in the arrangement, its part, and for a part on one of a pair of
/// mirror slots Blender's side suffix, `.L` on the creature's left (+x), `.R` on
/// its right: `S2.arm[1] h_arm.L`. The two sides of a symmetry group share the
/// number of the group's first super-part, so their names differ only in the
/// suffix (`S2.arm[1] h_arm.L`, `S2.arm[1] h_arm.R`) and Blender's mirror tools
/// (flip names, X-mirror) pair them.
pub fn node_name(t: &CreatureTable, shape: &Shape, meta: u32) -> String {
    for (i, sp) in shape.supers.iter().enumerate() {
        if let Some(k) = sp.metas.iter().position(|m| m.id == meta) {
            let part = t.parts.get(sp.metas[k].geometry as usize).map(|p| p.name.as_str()).unwrap_or("?");
            let side = side(t, shape, i);
            // The pair's first super-part: same group, same torso.
            let first = match (side, sp.attach) {
                ("", _) | (_, None) => i,
                (_, Some(a)) => shape
                    .supers
                    .iter()
                    .position(|o| o.sym == sp.sym && o.attach.is_some_and(|b| b.parent == a.parent))
                    .unwrap_or(i),
            };
            return format!("S{first}.{}[{k}] {part}{side}", super::shape::kind_name(t, sp.kind));
        }
    }
    format!("M{meta}")
}

/// `.L` or `.R` for super-part `i` when it sits on a slot that has a mirror slot,
/// by the side of the torso its slot is on (the creature's left is +x); "" else.
fn side(t: &CreatureTable, shape: &Shape, i: usize) -> &'static str {
    let Some(a) = shape.supers.get(i).and_then(|s| s.attach) else { return "" };
    let torso = shape.supers.get(a.parent as usize).and_then(|p| p.metas.first()).map(|m| m.geometry);
    let Some(part) = torso.and_then(|g| t.parts.get(g as usize)) else { return "" };
    let Some(slot) = part.slots.get(a.slot as usize) else { return "" };
    let x = match slot.mirror_of.and_then(|m| part.slots.get(m as usize)) {
        Some(orig) => -orig.at[0],
        None if slot.partner.is_some() => slot.at[0],
        None => return "",
    };
    if x > 0.0 {
        ".L"
    } else if x < 0.0 {
        ".R"
    } else {
        ""
    }
}

/// A monster as a scene of parts: one node per placed meta-part (named by
/// [`node_name`]) referring to one shared mesh per library part it uses, moved by
/// `offset`, each hanging from the node of the torso it is attached to (the root
/// torso from the scene's root).
pub fn part_nodes(
    t: &CreatureTable,
    lib: &Library,
    shape: &Shape,
    placed: &[Placed],
    offset: Vec3,
) -> (Vec<(String, Mesh)>, Vec<mdg_export::glb::MeshNode>) {
    let mut meshes = Vec::new();
    let mut index = std::collections::BTreeMap::new();
    let mut nodes = Vec::new();
    // Meta-part id → the torso meta-part it hangs from.
    let mut hangs = std::collections::BTreeMap::new();
    for sp in &shape.supers {
        let Some(a) = sp.attach else { continue };
        let Some(torso) = shape.supers.get(a.parent as usize).and_then(|p| p.metas.first()) else { continue };
        for m in &sp.metas {
            hangs.insert(m.id, torso.id);
        }
    }
    // The program places a torso before the parts attached to it.
    let mut node_of = std::collections::BTreeMap::new();
    for p in placed {
        let Some(g) = lib.parts.get(p.part as usize) else { continue };
        let mesh = *index.entry(p.part).or_insert_with(|| {
            let name = t.parts.get(p.part as usize).map(|d| d.name.clone()).unwrap_or_default();
            meshes.push((name, g.mesh.clone()));
            meshes.len() as u32 - 1
        });
        let parent = hangs.get(&p.meta).and_then(|torso| node_of.get(torso)).copied();
        node_of.insert(p.meta, nodes.len() as u32);
        nodes.push(mdg_export::glb::MeshNode {
            name: node_name(t, shape, p.meta),
            mesh,
            transform: Mat4::from_translation(offset) * p.transform,
            parent,
        });
    }
    (meshes, nodes)
}

/// A monster's `.glb`: its parts as named nodes (see [`part_nodes`]) under a root
/// node named `name` that stands it up in glTF's y-up convention.
pub fn write_glb(
    t: &CreatureTable,
    lib: &Library,
    name: &str,
    shape: &Shape,
    placed: &[Placed],
) -> Result<Vec<u8>, mdg_export::ExportError> {
    let (meshes, nodes) = part_nodes(t, lib, shape, placed, Vec3::ZERO);
    let mut bytes = Vec::new();
    mdg_export::glb::write_glb_nodes(name, &meshes, &nodes, &mut bytes)?;
    Ok(bytes)
}

/// An [`Output`] holding `meshes` (a monster or a sheet of them) on `background`.
pub fn output_of(mesh: Mesh, background: [f32; 4]) -> Output {
    Output { mesh, background, ..Output::default() }
}
