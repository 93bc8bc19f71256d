//! An [`Output`] turned into flat buffers (Rust vectors that become numpy arrays
//! without a copy): the flat walks of [`Output::for_each_piece_where`], and the
//! prototype instances as meshes plus placements.

use glam::Vec3;
use mdg_vm::export::glb::prototype_placement;
use mdg_vm::output::{Groups, Output, Piece};

/// A flat mesh: what [`crate::Mesh`] holds.
#[derive(Debug, Default)]
pub struct Flat {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub colors: Vec<[f32; 4]>,
    pub triangles: Vec<[u32; 3]>,
    pub bones: Vec<u32>,
    /// Whether the model has bones (else `bones` is left empty).
    pub animated: bool,
}

/// A coordinate as the exporters write it: 0 where not finite.
pub fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

pub fn finite3(p: [f32; 3]) -> [f32; 3] {
    p.map(finite)
}

/// A unit normal (+z for a zero-length or non-finite one), as the exporters write it.
fn unit(n: [f32; 3]) -> [f32; 3] {
    let v = Vec3::from(n);
    if v.is_finite() {
        v.normalize_or(Vec3::Z).to_array()
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// A colour clamped to 0..1 (NaN as 0).
fn clamped(c: [f32; 4]) -> [f32; 4] {
    c.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) })
}

impl Flat {
    fn push_piece(&mut self, p: &Piece) {
        let m = p.mesh;
        for i in p.vertices.clone() {
            self.positions.push(finite3(m.positions[i]));
            self.normals.push(unit(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0])));
            self.colors.push(clamped(m.colors.get(i).copied().unwrap_or([1.0; 4])));
            if self.animated {
                self.bones.push(m.bone(i));
            }
        }
        self.triangles.extend(p.triangles.clone().filter_map(|k| p.oriented(k)));
    }
}

/// The geometry of `groups` as one world-space mesh, leaving out the instances
/// `expand` refuses (triangles wound as the exporters write them).
pub fn flatten(out: &Output, groups: Groups, expand: impl Fn(usize) -> bool) -> Flat {
    let (v, t) = out.flat_counts_where(groups, &expand);
    let animated = out.animation.bones.len() > 1;
    let mut f = Flat {
        positions: Vec::with_capacity(v),
        normals: Vec::with_capacity(v),
        colors: Vec::with_capacity(v),
        triangles: Vec::with_capacity(t),
        bones: Vec::with_capacity(if animated { v } else { 0 }),
        animated,
    };
    let _ = out.for_each_piece_where::<()>(groups, &expand, |p| {
        f.push_piece(p);
        Ok(())
    });
    f
}

/// Per instance of `out`: whether it is a prototype instance placed by a transform
/// (listed in [`Placed`]) rather than expanded into the base mesh.
pub fn placed(out: &Output) -> Vec<bool> {
    out.instances
        .iter()
        .map(|i| {
            out.shared(i).is_some_and(|s| s.is_prototype() && !s.mesh.triangles.is_empty())
                && prototype_placement(&i.frame).is_some()
        })
        .collect()
}

/// Prototype instances as meshes and placements.
#[derive(Debug, Default)]
pub struct Placed {
    pub prototypes: Vec<Flat>,
    pub names: Vec<String>,
    pub prototype: Vec<u32>,
    pub translation: Vec<[f32; 3]>,
    /// (w, x, y, z).
    pub rotation: Vec<[f32; 4]>,
    pub scale: Vec<[f32; 3]>,
    pub color: Vec<[f32; 4]>,
    pub bone: Vec<u32>,
}

/// The placed prototype instances of `out` (see [`placed`]), with every prototype
/// (of the shared meshes, in order) in its own space: normals as a renderer placing
/// it needs them, colours the deltas its vertices add to the instance's colour.
pub fn instances(out: &Output) -> Placed {
    let mut p = Placed::default();
    let mut index = vec![u32::MAX; out.shared_meshes.len()];
    for (k, s) in out.shared_meshes.iter().enumerate().filter(|(_, s)| s.is_prototype()) {
        index[k] = p.prototypes.len() as u32;
        let m = &s.mesh;
        let mut f = Flat::default();
        for i in 0..m.n_vertices() {
            f.positions.push(m.positions[i]);
            f.normals.push(s.local_normal(i).to_array());
            f.colors.push(m.colors.get(i).copied().unwrap_or([0.0; 4]));
        }
        let piece = Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: 0 };
        f.triangles.extend((0..m.triangles.len()).filter_map(|t| piece.oriented(t)));
        p.prototypes.push(f);
        p.names.push(s.name.clone());
    }
    let placed = placed(out);
    let n = placed.iter().filter(|x| **x).count();
    p.prototype.reserve(n);
    p.translation.reserve(n);
    p.rotation.reserve(n);
    p.scale.reserve(n);
    p.color.reserve(n);
    p.bone.reserve(n);
    for (i, inst) in out.instances.iter().enumerate() {
        if !placed[i] {
            continue;
        }
        let Some((t, r, s)) = prototype_placement(&inst.frame) else { continue };
        p.prototype.push(index.get(inst.mesh as usize).copied().unwrap_or(0));
        p.translation.push(t);
        p.rotation.push([r[3], r[0], r[1], r[2]]);
        p.scale.push(s);
        p.color.push(clamped(inst.color));
        p.bone.push(inst.bone);
    }
    p
}
