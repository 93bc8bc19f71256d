//! Geometry rules (paper §3.4): the part library (each part's mesh evaluated once),
//! the geometry-rule program that attaches every meta-part by its slots — translate
//! to the slot centre (T_ST), arrange, fine rotations (R_x, R_y, R_z), rotate the
//! joint onto the slot (R_ST), scale to the slot size (S_ST) and by S_s, instance
//! (I k_i), with `[` `]` pushing and popping the frame — its interpreter, the
//! stability test, and the assembled mesh.

use super::shape::Shape;
use super::table::{CreatureTable, Geometry, Mode, PartDef, Slot};
use crate::bundle::Bundle;
use crate::eval::{evaluate, EvalOptions};
use crate::output::{Mesh, Output};
use glam::{Mat3, Mat4, Vec2, Vec3};
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
}

/// The geometry of every part of a table (index-aligned with `table.parts`).
#[derive(Clone, Debug)]
pub struct Library {
    pub parts: Vec<PartGeometry>,
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
    /// Evaluates every part's rule (with the bundle's own seed) or converts its
    /// embedded mesh. Parts are independent, so they are made in parallel.
    pub fn build(bundle: &Bundle, t: &CreatureTable) -> Result<Library, String> {
        let parts = t
            .parts
            .par_iter()
            .map(|p| {
                let mesh = match &p.geometry {
                    Geometry::Rule(r) => {
                        let mut b = bundle.clone();
                        b.settings.startshape = *r;
                        b.settings.camerarule = crate::bundle::NONE;
                        let out = evaluate(&b, &EvalOptions::default());
                        out.flattened()
                    }
                    Geometry::Mesh(m) => {
                        let pm = t.meshes.get(*m as usize).ok_or_else(|| format!("part `{}`: no mesh", p.name))?;
                        mesh_from_obj(&pm.positions, &pm.triangles, pm.color)
                    }
                };
                if mesh.triangles.is_empty() {
                    return Err(format!("part `{}`: its geometry has no triangles", p.name));
                }
                Ok(PartGeometry::new(mesh, p))
            })
            .collect::<Result<Vec<_>, String>>()?;
        Ok(Library { parts })
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
        PartGeometry { mesh, points, volume, centroid, joint_extent }
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
            let (offset, tilt) = arrange(sp.mode, k as u32, n, spacing);
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
    Layout { program: ops, placed, stability, min: lo + shift, max: hi + shift }
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

/// An [`Output`] holding `meshes` (a monster or a sheet of them) on `background`.
pub fn output_of(mesh: Mesh, background: [f32; 4]) -> Output {
    Output { mesh, background, ..Output::default() }
}
