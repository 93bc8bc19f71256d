//! glTF 2.0 binary (`.glb`) writer, by hand: a JSON chunk built with serde and one
//! binary buffer.
//!
//! # Conventions
//!
//! * **Y up.** glTF is +y up, MDG is +z up: the scene's root node `mdg z-up` rotates
//!   −90° about x ((x, y, z) → (x, z, −y)) and every other node is its child, so the
//!   data stay in MDG's coordinates (and skins, cameras and animation channels need
//!   no change) while every client shows the model upright. Skinned mesh nodes are
//!   the exception: glTF ignores their own transforms, so they sit beside the root
//!   and follow their joints, which are under it.
//! * **Linear colour.** MDG colours are display (sRGB) values; glTF's COLOR_0 and
//!   `baseColorFactor` are linear, so both are converted ([`super::srgb_to_linear`]).
//! * **Double-sided** materials for surfaces that are not closed ([`super::is_closed`]):
//!   a leaf must be seen from both sides; closed solids keep back-face culling.
//!
//! # Layout
//!
//! * Node `geometry` (mesh `mdg`): one primitive each for the `VERTEX` triangles, the
//!   sweeps and the *baked* instances, with POSITION, NORMAL, COLOR_0 (float RGBA,
//!   clamped to 0..1, linear) and u32 indices. Empty groups are left out (glTF forbids
//!   accessors with no elements).
//! * Node `lines` (mesh `lines`): the pen polylines as one `LINES` primitive.
//! * Each shared mesh's positions, normals and indices are written once. Every
//!   instance is a node with translation/rotation/scale referring to a glTF mesh
//!   that reuses those accessors with a material of the instance's colour (one glTF
//!   mesh per distinct (shared mesh, colour) pair; the colour replaces the shared
//!   mesh's vertex colours, as in [`Output::flattened`]).
//! * A mirrored instance is a node too: its transform times a mirror in x is a proper
//!   TRS, and it refers to a copy of the shared mesh mirrored in x (written once per
//!   shared mesh, x negated and triangles reversed; mesh `NAME mirrored`). Negative
//!   scales are avoided because validators and viewers disagree on them.
//! * Instances that are degenerate or not a similarity are baked into the geometry.
//! * Above [`MAX_INSTANCE_NODES`] instances, those of small shared meshes (at most
//!   [`MAX_MERGED_MESH_VERTICES`] vertices) are baked (merged into the geometry):
//!   importers spend time per node, and a batched mesh of leaves loads in seconds.
//!
//! Nodes use TRS rather than `matrix` because glTF only lets TRS nodes be animation
//! targets. All numbers are written as f32 with serde_json's shortest round-trip
//! form, and every map is ordered, so the bytes are a deterministic function of the
//! output.
//!
//! # Animation
//!
//! When the output has bones (see [`mdg_vm::anim`]):
//!
//! * Every bone is a node (`bone N RULE`, bone 0 = `root`), nested like the bones,
//!   so that a node's world matrix is the bone's `M_b(t)`; its local TRS is the
//!   bone's local transform `F·P_b(i)·F⁻¹` (translation, rotation, uniform scale;
//!   negative for a mirrored motion). The node's static TRS is the pose at t = 0.
//! * The geometry mesh is skinned: `JOINTS_0` holds each vertex's bone (u16; at most
//!   65,536 bones), `WEIGHTS_0` is (1, 0, 0, 0), and skin 0 lists the bone nodes as
//!   joints with identity inverse bind matrices, written out (the vertices are stored
//!   in world space at rest, where every bone is the identity; assimp needs them).
//! * Instance nodes of animated bones are children of their bone's node; the pen
//!   lines are skinned like the geometry.
//! * Animation `mdg` has, per moving bone, translation/rotation/scale channels with
//!   one keyframe per frame index i = 0..=⌊duration·fps⌋ at time i/fps, `STEP`
//!   interpolation, so a player shows exactly frame ⌊t·fps⌋ as the VM does.
//! * A `camerarule` becomes camera 0 (perspective, `yfov` = camerafov in radians,
//!   `znear`/`zfar` from the near and far planes) on node `camera`, animated by
//!   translation and rotation channels sampled at the directive `fps` (the camera
//!   frame's scale is not exported).

mod flat;
mod nodes;
use flat::{flat_plan, flat_stride, flat_write, FlatSource, ProtoInfos};
pub use nodes::{write_glb_nodes, MeshNode};

use std::collections::BTreeMap;

use glam::{Mat4, Quat, Vec3};
use serde::Serialize;

use super::sites::{self, Baked};
use super::ExportError;
use super::{
    checked_triangles, clamp_color, color_at, finite, finite3, is_closed, linear_color, normal_at, unit_normal,
};
use mdg_vm::anim::{frames_needed, trs};
use mdg_vm::geom::quat::Frame;
use mdg_vm::output::{
    expand_prototype, place_mesh, Animation, Groups, Mesh, Output, Piece, Polyline, SharedKind, SharedMesh, VertexPart,
};

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_BYTE: u32 = 5121;
/// The most instances written as nodes; above it, instances of meshes of at most
/// [`MAX_MERGED_MESH_VERTICES`] vertices are merged into the geometry (Blender
/// imports 9,900 nodes in 13 s, the same 10,100 octahedra merged in 0.7 s).
pub const MAX_INSTANCE_NODES: usize = 10_000;
/// The biggest shared mesh whose instances are merged when there are too many
/// nodes: Blender takes as long for a node as for about 50 merged vertices (10,100
/// balls of ~150 vertices: 37 s merged, 13 s for 9,900 as nodes).
pub const MAX_MERGED_MESH_VERTICES: usize = 48;
/// The root node's rotation (x, y, z, w): −90° about x, MDG's z up to glTF's y up,
/// (x, y, z) → (x, z, −y).
pub const Y_UP_ROTATION: [f32; 4] = [-std::f32::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f32::consts::FRAC_1_SQRT_2];
/// The most bones a glTF file can hold here (`JOINTS_0` is u16).
pub const MAX_GLTF_BONES: usize = 1 << 16;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const MODE_LINES: u32 = 1;
const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Options of the glTF writer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GlbOptions {
    /// Write the instances of every shared mesh (prototypes and isosurfaces) with
    /// `EXT_mesh_gpu_instancing` (one mesh per shared mesh, translation/rotation/scale
    /// per instance) instead of expanding them into the geometry or making a node of
    /// each: small files that engines and three.js draw with GPU
    /// instancing. Off by default: Blender makes an object of every instance, and
    /// importers without the extension show one instance only.
    pub instances: bool,
}

/// Appends `out` as a glTF 2.0 binary to `buf`.
pub fn write_glb(out: &Output, buf: &mut Vec<u8>) -> Result<(), ExportError> {
    write_glb_to(out, buf)
}

/// Writes `out` as a glTF 2.0 binary to `w` (a file, say: no copy of the whole
/// file is held in memory, only the binary chunk being assembled).
pub fn write_glb_to(out: &Output, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    write_glb_with(out, &GlbOptions::default(), w)
}

/// [`write_glb_to`] with options.
pub fn write_glb_with(out: &Output, opts: &GlbOptions, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    let anim = &out.animation;
    let skinned = anim.bones.len() > 1;
    if anim.bones.len() > MAX_GLTF_BONES {
        return Err(ExportError::TooManyBones { bones: anim.bones.len(), max: MAX_GLTF_BONES });
    }
    // Prototype instances that become instanced nodes (with --instances); the rest
    // are expanded into the geometry where they were made.
    let gpu = if opts.instances { gpu_instance_groups(out, skinned) } else { GpuGroups::default() };

    // Split isosurface instances into ones that can be nodes and ones that must be
    // baked. A mirrored similarity is a node too: its transform times a mirror in x
    // is a proper TRS, placed over a copy of the shared mesh mirrored in x (one copy
    // per mesh).
    let mut baked = Baked::default();
    let mut as_nodes = Vec::new();
    for (i, inst) in out.instances.iter().enumerate() {
        if gpu.instanced.get(i).copied().unwrap_or(false) {
            continue;
        }
        let Some(shared) = out.shared(&inst).filter(|s| !s.is_prototype()) else { continue };
        if shared.mesh.triangles.is_empty() {
            continue;
        }
        let transform = out.instance_transform(&inst);
        let placed = if out.instance_mirrored(&inst) {
            orthogonal_trs(&(transform * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)))).map(|trs| (trs, true))
        } else {
            orthogonal_trs(&transform).map(|trs| (trs, false))
        };
        match placed {
            Some((trs, mirror)) => as_nodes.push((i as u32, inst, trs, mirror)),
            None => baked.bake(&shared.mesh, out, i as u32, &inst),
        }
    }
    // Thousands of nodes make importers crawl (Blender spends over a millisecond on
    // each object, about as long as on 50 vertices): above the limit, instances of
    // small meshes are merged into the geometry; big ones stay nodes.
    if as_nodes.len() > MAX_INSTANCE_NODES {
        as_nodes.retain(|&(i, inst, _, _)| match out.shared(&inst) {
            Some(shared) if shared.mesh.positions.len() <= MAX_MERGED_MESH_VERTICES => {
                baked.bake(&shared.mesh, out, i, &inst);
                false
            }
            _ => true,
        });
    }

    // The flat geometry (the VERTEX group, the sweeps, the baked instances) is
    // streamed into the file when it is written: the binary chunk holds no copy of it.
    let mut g = Builder { skinned, ..Builder::default() };
    let mut scene_nodes = Vec::new();
    // Bone nodes first, so instances can be attached to them.
    let bone_nodes: Vec<u32> = if g.skinned { g.bone_nodes(anim) } else { Vec::new() };
    if let Some(&root) = bone_nodes.first() {
        scene_nodes.push(root);
    }
    // Nodes under the y-up root; skinned meshes stay at the scene root (a skinned
    // mesh ignores its node's transforms and follows its joints, which are under it).
    let mut top_nodes = Vec::new();
    let mut primitives = Vec::new();
    if let Some(mut p) = g.vertex_primitive(out, &gpu)? {
        p.extras = sites::extras(&out.sites.runs, &out.sites.sites);
        primitives.push(p);
    }
    let sweep_sites = sites::extras(&out.sites.sweep_runs, &out.sites.sites);
    for (m, what, extras) in [(&out.sweeps, "sweeps", sweep_sites), (&baked.mesh, "baked instances", baked.extras(out))]
    {
        if let Some(mut p) = g.colored_primitive(FlatSource::Mesh(m), what)? {
            p.extras = extras;
            primitives.push(p);
        }
    }
    if !primitives.is_empty() {
        let mesh = g.push_mesh(GMesh { name: Some("mdg".into()), primitives });
        let skin = g.skinned.then(|| g.skin(&bone_nodes));
        let node = g.push_node(Node { name: Some("geometry".into()), mesh: Some(mesh), skin, ..Node::default() });
        if g.skinned {
            top_nodes.push(node);
        } else {
            scene_nodes.push(node);
        }
    }

    // The pen lines; a guided search's guides and bones in nodes of their own, so
    // that viewers can tell them apart (the editor's preview draws them as overlays).
    for name in ["lines", "guides", "bones"] {
        let pick = |l: &Polyline| match name {
            "lines" => !SEARCH_LINES.contains(&l.namespace.as_str()),
            ns => l.namespace == ns,
        };
        if let Some(p) = g.lines_primitive(out, &pick) {
            let mesh = g.push_mesh(GMesh { name: Some(name.into()), primitives: vec![p] });
            let skin = g.skinned.then(|| g.skin(&bone_nodes));
            let node = g.push_node(Node { name: Some(name.into()), mesh: Some(mesh), skin, ..Node::default() });
            if g.skinned {
                top_nodes.push(node);
            } else {
                scene_nodes.push(node);
            }
        }
    }

    let mut shared_accessors: BTreeMap<(u32, bool), SharedAccessors> = BTreeMap::new();
    let mut instance_meshes: BTreeMap<(u32, bool, [u32; 4]), u32> = BTreeMap::new();
    for (i, inst, (t, r, s), mirror) in as_nodes {
        let Some(shared) = out.shared(&inst) else { continue };
        let acc = match shared_accessors.get(&(inst.mesh, mirror)) {
            Some(a) => *a,
            None => {
                let a = g.shared_accessors(&shared.mesh, &shared.name, mirror)?;
                shared_accessors.insert((inst.mesh, mirror), a);
                a
            }
        };
        let color = clamp_color(inst.color);
        let key = (inst.mesh, mirror, color.map(f32::to_bits));
        let mesh = match instance_meshes.get(&key) {
            Some(m) => *m,
            None => {
                let material = g.material(color, acc.double_sided);
                let name = Some(if mirror { format!("{} mirrored", shared.name) } else { shared.name.clone() });
                let mut attributes = BTreeMap::new();
                attributes.insert("POSITION", acc.position);
                attributes.insert("NORMAL", acc.normal);
                let prim = Primitive {
                    attributes,
                    indices: Some(acc.indices),
                    material: Some(material),
                    mode: None,
                    extras: None,
                };
                let m = g.push_mesh(GMesh { name, primitives: vec![prim] });
                instance_meshes.insert(key, m);
                m
            }
        };
        let node = Node {
            name: Some(shared.name.clone()),
            mesh: Some(mesh),
            translation: Some(t.to_array()),
            rotation: Some(r.to_array()),
            scale: Some(s.to_array()),
            extras: sites::node_extras(out, i),
            ..Node::default()
        };
        let n = g.push_node(node);
        match bone_nodes.get(inst.bone as usize) {
            Some(&parent) if inst.bone != 0 => g.root.nodes[parent as usize].children.push(n),
            _ => scene_nodes.push(n),
        }
    }

    // Prototype instances with EXT_mesh_gpu_instancing: one node per group.
    for group in &gpu.groups {
        if let Some(node) = g.instanced_node(out, group)? {
            scene_nodes.push(node);
        }
    }

    let mut animation = GAnimation { name: Some("mdg".into()), channels: Vec::new(), samplers: Vec::new() };
    g.bone_channels(anim, &bone_nodes, &mut animation);
    if let Some(camera) = g.camera(anim, &mut animation) {
        scene_nodes.push(camera);
    }
    if !animation.channels.is_empty() {
        g.root.animations.push(animation);
    }

    // One root node turns MDG's z-up space into glTF's y-up (see [`Y_UP_ROTATION`]).
    if !scene_nodes.is_empty() {
        let root = g.push_node(Node {
            name: Some("mdg z-up".into()),
            rotation: Some(Y_UP_ROTATION),
            children: scene_nodes,
            ..Node::default()
        });
        top_nodes.insert(0, root);
    }
    g.root.scenes.push(Scene { nodes: top_nodes });
    g.finish(w)
}

/// The most glTF meshes one prototype gets for colour variants under `--instances`
/// (a prototype whose items add colours to the frame's needs one per distinct frame
/// colour); the instances of further colours are expanded into the geometry.
pub const MAX_COLOR_VARIANTS: usize = 64;

/// Prototype instances drawn by one instanced node: same prototype, same mirroring,
/// and (for a prototype whose items add colour deltas) the same frame colour.
struct GpuGroup {
    mesh: u32,
    mirrored: bool,
    /// The frame colour baked into the mesh's COLOR_0 (prototypes with colour
    /// deltas); `None`: the mesh is white and each instance's colour is `_COLOR_0`.
    color: Option<[f32; 4]>,
    instances: Vec<u32>,
    /// The bits of the first instance's colour, and whether every instance's colour
    /// has the same bits (then they all share one material colour, found without a
    /// second walk over the instances).
    first_bits: [u32; 4],
    same_bits: bool,
}

/// Which prototype instances become instanced nodes, and their groups.
#[derive(Default)]
struct GpuGroups {
    /// Per instance: placed by an instanced node (not expanded).
    instanced: Vec<bool>,
    groups: Vec<GpuGroup>,
    /// Every prototype instance is placed by an instanced node: the flat `VERTEX`
    /// primitive is [`Output::mesh`] alone, found without walking the instances.
    all_prototypes_instanced: bool,
}

/// What groups prototype instances: the shared mesh, the mirroring, and the frame
/// colour's bits for a prototype whose items add colour deltas.
type GroupKey = (u32, bool, Option<[u32; 4]>);

/// Groups the instances of every shared mesh — prototypes and isosurfaces alike —
/// for `EXT_mesh_gpu_instancing`. Left to the geometry (prototypes) or to nodes and
/// baking (isosurfaces): instances of animated bones in a skinned output (three.js
/// cannot instance skinned meshes), degenerate or non-finite frames, isosurfaces in
/// frames with a non-uniform factor, and colour variants past [`MAX_COLOR_VARIANTS`].
fn gpu_instance_groups(out: &Output, skinned: bool) -> GpuGroups {
    let mut g = GpuGroups { instanced: vec![false; out.instances.len()], ..GpuGroups::default() };
    let mut index: BTreeMap<GroupKey, usize> = BTreeMap::new();
    let mut variants: BTreeMap<u32, usize> = BTreeMap::new();
    // Per shared mesh with triangles (a prototype or an isosurface): whether its
    // vertices add colours to the instance's (a prototype's items' deltas).
    let kind: Vec<Option<bool>> = out
        .shared_meshes
        .iter()
        .map(|s| {
            (!s.mesh.triangles.is_empty()).then(|| s.is_prototype() && s.mesh.colors.iter().any(|c| *c != [0.0; 4]))
        })
        .collect();
    let prototype: Vec<bool> = out.shared_meshes.iter().map(SharedMesh::is_prototype).collect();
    // Prototype instances seen, and those placed by instanced nodes.
    let (mut prototypes, mut placed) = (0usize, 0usize);
    // Consecutive instances mostly share a group: the last one is tried first.
    let mut last: Option<(GroupKey, usize)> = None;
    for (i, inst) in out.instances.iter().enumerate() {
        let is_prototype = prototype.get(inst.mesh as usize).copied().unwrap_or(false);
        prototypes += usize::from(is_prototype);
        let Some(Some(deltas)) = kind.get(inst.mesh as usize).copied() else { continue };
        // (An isosurface in a frame with a non-uniform factor is no TRS: a node or baked.)
        if (skinned && inst.bone != 0) || !prototype_placeable(&inst.frame) || inst.lin != 0 {
            continue;
        }
        let key = (inst.mesh, frame_mirrors(&inst.frame), deltas.then(|| inst.color.map(f32::to_bits)));
        let k = match last {
            Some((k, at)) if k == key => at,
            _ => match index.get(&key) {
                Some(&k) => k,
                None => {
                    let n = variants.entry(inst.mesh).or_insert(0);
                    if deltas && *n >= MAX_COLOR_VARIANTS {
                        continue;
                    }
                    *n += 1;
                    let color = deltas.then_some(inst.color);
                    g.groups.push(GpuGroup {
                        mesh: inst.mesh,
                        mirrored: key.1,
                        color,
                        instances: Vec::new(),
                        first_bits: inst.color.map(f32::to_bits),
                        same_bits: true,
                    });
                    index.insert(key, g.groups.len() - 1);
                    g.groups.len() - 1
                }
            },
        };
        last = Some((key, k));
        let group = &mut g.groups[k];
        group.same_bits &= inst.color.map(f32::to_bits) == group.first_bits;
        group.instances.push(i as u32);
        g.instanced[i] = true;
        placed += usize::from(is_prototype);
    }
    g.all_prototypes_instanced = placed == prototypes;
    g
}

/// Whether a frame built by the adjustments mirrors: `q̂ = ±q̄` (geom::quat), the
/// sign being the mirroring, read off `q̂ · q̄`.
fn frame_mirrors(f: &Frame) -> bool {
    f.qh.dot(mdg_vm::geom::quat::conj(f.q)) < 0.0
}

/// Whether a prototype instance's frame can be a glTF TRS: finite, of non-zero scale.
fn prototype_placeable(f: &Frame) -> bool {
    let s = f.q.length_squared() * f.qh.length_squared();
    s.is_finite() && s > 0.0 && f.u.is_finite()
}

/// The TRS of a placeable prototype instance's frame as glTF holds it
/// (translation, unit rotation, uniform scale): for a mirrored frame, of the frame
/// times a mirror in x, which places the prototype's copy mirrored in x. A frame
/// built by the adjustments maps `x ↦ ±s R x` (q̂ = ±q̄): R is the rotation of
/// q/|q|, s = |q| |q̂|; −I times the mirror in x is a half turn about x.
fn prototype_trs(f: &Frame) -> ([f32; 3], [f32; 4], f32) {
    (f.u.to_array(), prototype_rotation(f), prototype_scale(f))
}

/// The rotation of [`prototype_trs`].
#[inline]
fn prototype_rotation(f: &Frame) -> [f32; 4] {
    // q/|q| is a unit quaternion; times the unit x quaternion (a half turn about x)
    // it stays one: r·i = (w, z, −y, −x) in (x, y, z, w), no normalisation needed.
    let r = mdg_vm::geom::quat::scaled(f.q, 1.0 / f.q.length());
    let r = if frame_mirrors(f) { Quat::from_xyzw(r.w, r.z, -r.y, -r.x) } else { r };
    r.to_array()
}

/// The uniform scale of [`prototype_trs`].
#[inline]
fn prototype_scale(f: &Frame) -> f32 {
    f.q.length() * f.qh.length()
}

/// The instance attributes of an instanced node, streamed into the file (nothing
/// of them is held): TRANSLATION, ROTATION and SCALE of instances `order` of `out`,
/// then `_COLOR_0` when `per_color`, each attribute's values one after the other
/// (one accessor each), non-finite numbers written as 0. One pass per attribute:
/// each reads only what it writes (the translation is the frame's `u`).
fn write_instance_attributes(out: &Output, order: &[u32], per_color: bool, sink: &mut Sink) -> Result<(), ExportError> {
    let frames = || order.iter().map(|&i| out.instances.frame(i as usize));
    for f in frames() {
        sink.floats(f.map_or([0.0; 3], |f| finite3(f.u.to_array())))?;
    }
    for f in frames() {
        sink.floats(f.map_or([0.0; 4], |f| prototype_rotation(&f).map(finite)))?;
    }
    for f in frames() {
        sink.floats([f.map_or(0.0, |f| finite(prototype_scale(&f))); 3])?;
    }
    if per_color {
        let mut last = ([1.0f32; 4], linear_color([1.0; 4]));
        for &i in order {
            let c = out.instances.color(i as usize).map_or([0.0; 4], clamp_color);
            if c != last.0 {
                last = (c, linear_color(c));
            }
            sink.floats([last.1[0], last.1[1], last.1[2]])?;
        }
    }
    Ok(())
}

/// How a prototype instance of frame `f` is placed as a translation, a unit
/// rotation (x, y, z, w) and a per-axis scale applied to the prototype's own mesh —
/// what `--instances` writes, for other instancing consumers (the Python package,
/// Blender's geometry nodes). A mirrored frame gets the scale (−s, s, s): the mirror
/// in x, with the rotation that `--instances` gives its mirrored copy. `None` for a
/// frame that cannot be placed so (zero or non-finite scale or translation): such an
/// instance is expanded into the geometry instead.
pub fn prototype_placement(f: &Frame) -> Option<([f32; 3], [f32; 4], [f32; 3])> {
    if !prototype_placeable(f) {
        return None;
    }
    let (t, r, s) = prototype_trs(f);
    let sx = if frame_mirrors(f) { -s } else { s };
    Some((t, r, [sx, s, s]))
}

/// A prototype's mesh as an instanced node draws it: in its own space, normals as
/// [`mdg_vm::output::SharedMesh::local_normal`], colours `frame colour + delta` when
/// `color` is given (else white), triangles oriented for an unmirrored frame (and
/// the whole mesh mirrored in x when `mirrored`).
fn prototype_local_mesh(shared: &mdg_vm::output::SharedMesh, color: Option<[f32; 4]>, mirrored: bool) -> Mesh {
    let p = &shared.mesh;
    let mut m = Mesh::default();
    for i in 0..p.n_vertices() {
        let c = match color {
            Some(f) => {
                let d = p.colors.get(i).copied().unwrap_or([0.0; 4]);
                [f[0] + d[0], f[1] + d[1], f[2] + d[2], f[3] + d[3]]
            }
            None => [1.0; 4],
        };
        m.push_vertex(Vec3::from(p.positions[i]), shared.local_normal(i), c, [0.0; 4], 0);
    }
    for (t, tri) in p.triangles.iter().enumerate() {
        m.push_triangle(*tri, p.mirrored.get(t).copied().unwrap_or(false));
    }
    if mirrored {
        mirrored_copy(&m)
    } else {
        m
    }
}

/// `m` mirrored in x: positions and normals with x negated, every triangle reversed.
fn mirrored_copy(m: &Mesh) -> Mesh {
    let mut c = m.clone();
    for p in &mut c.positions {
        p[0] = -p[0];
    }
    for n in &mut c.normals {
        n[0] = -n[0];
    }
    c.mirrored = (0..c.triangles.len()).map(|i| !m.mirrored.get(i).copied().unwrap_or(false)).collect();
    c
}

/// A frame's TRS as glTF arrays: translation, unit rotation (x, y, z, w) and a uniform
/// scale (see [`trs`]); non-finite values become 0 (the rotation the identity).
fn gltf_trs(f: &Frame) -> ([f32; 3], [f32; 4], f32) {
    let (t, r, s) = trs(f);
    let r = if r.is_finite() { r.to_array() } else { [0.0, 0.0, 0.0, 1.0] };
    (finite3(t.to_array()), r, finite(s))
}

/// Accessors of one shared mesh, written once and used by all its instances.
#[derive(Clone, Copy)]
struct SharedAccessors {
    position: u32,
    normal: u32,
    indices: u32,
    /// The mesh is not closed (see [`is_closed`]).
    double_sided: bool,
}

/// Translation, rotation and per-axis scale of a proper transform whose axes are
/// orthogonal (a rotation times a scale along the object's own axes: a similarity, or
/// `s X Y Z` applied in the object's frame), or `None` when the matrix is mirrored,
/// degenerate, non-finite or sheared (relative tolerance 1e-3): glTF's TRS cannot hold
/// those, and their instances are baked.
fn orthogonal_trs(m: &Mat4) -> Option<(Vec3, Quat, Vec3)> {
    if !m.is_finite() || m.row(3).truncate().length_squared() != 0.0 || m.row(3).w != 1.0 {
        return None;
    }
    let (a, b, c) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let big = la.max(lb).max(lc);
    if big.is_nan() || la.min(lb).min(lc) <= 1e-6 * big || big <= 1e-12 || a.dot(b.cross(c)) <= 0.0 {
        return None;
    }
    if a.dot(b).abs() > 1e-3 * la * lb || b.dot(c).abs() > 1e-3 * lb * lc || c.dot(a).abs() > 1e-3 * lc * la {
        return None;
    }
    let rot = Quat::from_mat3(&glam::Mat3::from_cols(a / la, b / lb, c / lc)).normalize();
    Some((m.w_axis.truncate(), rot, Vec3::new(la, lb, lc)))
}

/// The document plus the binary buffer under construction: the bytes made so far
/// (`bin`, from offset `base` of the chunk) after the segments before them, some of
/// which are written only when the file is (the flat geometry, streamed).
#[derive(Default)]
struct Builder<'a> {
    root: Root,
    bin: Vec<u8>,
    segments: Vec<Segment<'a>>,
    /// The chunk offset of `bin[0]`: the bytes of the segments before it.
    base: usize,
    materials: BTreeMap<([u32; 4], bool), u32>,
    /// Geometry primitives carry JOINTS_0/WEIGHTS_0 (the output has bones).
    skinned: bool,
    /// Keyframe-time accessors by (fps bits, count).
    times: BTreeMap<(u32, usize), u32>,
}

impl<'a> Builder<'a> {
    /// The chunk offset where the next bytes go, padded to 4 bytes.
    fn aligned_end(&mut self) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.base + self.bin.len()
    }

    /// Reserves `len` bytes (a multiple of 4) at the current end of the chunk, to be
    /// written by `write` when the file is written; returns their offset.
    fn stream(&mut self, len: usize, write: Box<StreamFn<'a>>) -> usize {
        let offset = self.aligned_end();
        let held = std::mem::take(&mut self.bin);
        if !held.is_empty() {
            self.segments.push(Segment::Bytes(held));
        }
        self.segments.push(Segment::Stream { len, write });
        self.base = offset + len;
        offset
    }

    /// Appends `bytes` (4-byte aligned) as a buffer view and returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> u32 {
        self.view_for(bytes, Some(target))
    }

    /// A buffer view with an optional target (animation data has none).
    fn view_for(&mut self, bytes: &[u8], target: Option<u32>) -> u32 {
        let offset = self.aligned_end();
        self.bin.extend_from_slice(bytes);
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length: bytes.len(),
            target,
            byte_stride: None,
        });
        self.root.buffer_views.len() as u32 - 1
    }

    /// The skin whose joints are the bone nodes (created once), with identity inverse
    /// bind matrices: the vertices are stored at rest, where every bone is the
    /// identity (assimp, among others, needs them written out).
    fn skin(&mut self, bone_nodes: &[u32]) -> u32 {
        if self.root.skins.is_empty() {
            let identity = Mat4::IDENTITY.to_cols_array();
            let bytes: Vec<u8> = (0..bone_nodes.len()).flat_map(|_| identity).flat_map(f32::to_le_bytes).collect();
            let view = self.view_for(&bytes, None);
            let inverse_bind_matrices = Some(self.accessor(Accessor {
                buffer_view: view,
                component_type: FLOAT,
                count: bone_nodes.len(),
                kind: "MAT4",
                min: None,
                max: None,
                ..Accessor::default()
            }));
            self.root.skins.push(Skin {
                inverse_bind_matrices,
                joints: bone_nodes.to_vec(),
                skeleton: bone_nodes.first().copied(),
            });
        }
        0
    }

    /// JOINTS_0 (u16, the bone) and WEIGHTS_0 ((1, 0, 0, 0)) for `n` vertices.
    fn skin_attributes(&mut self, attributes: &mut BTreeMap<&'static str, u32>, n: usize, bone: impl Fn(usize) -> u32) {
        let joints: Vec<u8> = (0..n)
            .flat_map(|i| [(bone(i).min(u16::MAX as u32) as u16).to_le_bytes(), [0; 2], [0; 2], [0; 2]])
            .flatten()
            .collect();
        let view = self.view(&joints, ARRAY_BUFFER);
        let j = self.accessor(Accessor {
            buffer_view: view,
            component_type: UNSIGNED_SHORT,
            count: n,
            kind: "VEC4",
            min: None,
            max: None,
            ..Accessor::default()
        });
        attributes.insert("JOINTS_0", j);
        let weights = vec![[1.0, 0.0, 0.0, 0.0]; n];
        attributes.insert("WEIGHTS_0", self.vec4(&weights));
    }

    /// An animation sampler's input: `count` keyframe times i/fps, with bounds.
    fn key_times(&mut self, fps: f32, count: usize) -> u32 {
        if let Some(&a) = self.times.get(&(fps.to_bits(), count)) {
            return a;
        }
        let times: Vec<f32> = (0..count).map(|i| (i as f64 / fps as f64) as f32).collect();
        let bytes: Vec<u8> = times.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view_for(&bytes, None);
        let (lo, hi) = (times.first().copied().unwrap_or(0.0), times.last().copied().unwrap_or(0.0));
        let a = self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count,
            kind: "SCALAR",
            min: Some(vec![lo]),
            max: Some(vec![hi]),
            ..Accessor::default()
        });
        self.times.insert((fps.to_bits(), count), a);
        a
    }

    /// An animation sampler's output: float vectors of `kind` ("VEC3", "VEC4").
    fn key_values(&mut self, data: &[f32], width: usize, kind: &'static str) -> u32 {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view_for(&bytes, None);
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: data.len() / width,
            kind,
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// Adds a STEP sampler reading `input`/`output` and a channel to `node`'s `path`.
    fn channel(&mut self, a: &mut GAnimation, input: u32, output: u32, node: u32, path: &'static str) {
        a.samplers.push(Sampler { input, output, interpolation: "STEP" });
        a.channels.push(Channel { sampler: a.samplers.len() as u32 - 1, target: Target { node, path } });
    }

    /// Translation, rotation and scale channels for `node` from one frame per keyframe.
    fn trs_channels(&mut self, a: &mut GAnimation, input: u32, frames: &[Frame], node: u32, with_scale: bool) {
        let (mut t, mut r, mut s) = (Vec::new(), Vec::new(), Vec::new());
        let mut prev: Option<[f32; 4]> = None;
        for f in frames {
            let (ft, mut fr, fs) = gltf_trs(f);
            // q and −q are the same rotation; keep consecutive keys on one side.
            if let Some(p) = prev {
                if p[0] * fr[0] + p[1] * fr[1] + p[2] * fr[2] + p[3] * fr[3] < 0.0 {
                    fr = fr.map(|x| -x);
                }
            }
            prev = Some(fr);
            t.extend(ft);
            r.extend(fr);
            s.extend([fs; 3]);
        }
        let out_t = self.key_values(&t, 3, "VEC3");
        self.channel(a, input, out_t, node, "translation");
        let out_r = self.key_values(&r, 4, "VEC4");
        self.channel(a, input, out_r, node, "rotation");
        if with_scale {
            let out_s = self.key_values(&s, 3, "VEC3");
            self.channel(a, input, out_s, node, "scale");
        }
    }

    /// One node per bone, nested like the bones, each with its pose at t = 0 as
    /// static TRS; returns the node of every bone (index = bone).
    fn bone_nodes(&mut self, anim: &Animation) -> Vec<u32> {
        let mut nodes = Vec::with_capacity(anim.bones.len());
        for (b, bone) in anim.bones.iter().enumerate() {
            let name = if b == 0 { "root".to_string() } else { format!("bone {b} {}", bone.rule) };
            let mut node = Node { name: Some(name), ..Node::default() };
            if b != 0 {
                let (t, r, s) = gltf_trs(&anim.local(b, 0));
                node.translation = Some(t);
                node.rotation = Some(r);
                node.scale = Some([s; 3]);
            }
            let n = self.push_node(node);
            if b != 0 {
                if let Some(&p) = nodes.get(bone.parent as usize) {
                    let parent: u32 = p;
                    self.root.nodes[parent as usize].children.push(n);
                }
            }
            nodes.push(n);
        }
        nodes
    }

    /// Channels for every bone that moves within `duration`: keyframe i at i/fps for
    /// i = 0..=⌊duration·fps⌋, the bone's local transform at frame i.
    fn bone_channels(&mut self, anim: &Animation, bone_nodes: &[u32], a: &mut GAnimation) {
        for (b, bone) in anim.bones.iter().enumerate().skip(1) {
            let Some(&node) = bone_nodes.get(b) else { continue };
            if !(bone.fps > 0.0 && bone.fps.is_finite()) {
                continue;
            }
            let n = frames_needed(anim.duration as f64, bone.fps).min(mdg_vm::anim::MAX_TRACK_FRAMES);
            let frames: Vec<Frame> = (0..n as u64).map(|i| anim.local(b, i)).collect();
            if n < 2 || frames.iter().all(|f| *f == frames[0]) {
                continue;
            }
            let input = self.key_times(bone.fps, n);
            self.trs_channels(a, input, &frames, node, true);
        }
    }

    /// Camera 0 and its node (static pose at t = 0, animated when it moves); returns
    /// the node.
    fn camera(&mut self, anim: &Animation, a: &mut GAnimation) -> Option<u32> {
        let cam = anim.camera.as_ref()?;
        let track = anim.tracks.get(cam.track as usize)?;
        let znear = if cam.near.is_finite() && cam.near > 0.0 { cam.near } else { 0.1 };
        let zfar = (cam.far.is_finite() && cam.far > znear).then_some(cam.far);
        let yfov = if cam.fov.is_finite() {
            cam.fov.to_radians().clamp(1e-3, std::f32::consts::PI - 1e-3)
        } else {
            40f32.to_radians()
        };
        self.root.cameras.push(GCamera { kind: "perspective", perspective: Perspective { yfov, znear, zfar } });
        let camera = Some(self.root.cameras.len() as u32 - 1);
        let (t, r, _) = gltf_trs(&track.at(0));
        let node = self.push_node(Node {
            name: Some("camera".into()),
            camera,
            translation: Some(t),
            rotation: Some(r),
            ..Node::default()
        });
        if cam.fps > 0.0 && cam.fps.is_finite() {
            let n = frames_needed(anim.duration as f64, cam.fps).min(mdg_vm::anim::MAX_TRACK_FRAMES);
            let frames: Vec<Frame> = (0..n as u64).map(|i| track.at(i)).collect();
            if n >= 2 && frames.iter().any(|f| *f != frames[0]) {
                let input = self.key_times(cam.fps, n);
                self.trs_channels(a, input, &frames, node, false);
            }
        }
        Some(node)
    }

    fn accessor(&mut self, a: Accessor) -> u32 {
        self.root.accessors.push(a);
        self.root.accessors.len() as u32 - 1
    }

    /// A VEC3 float vertex attribute, with min/max when `bounds`.
    fn vec3(&mut self, data: &[[f32; 3]], bounds: bool) -> u32 {
        self.vec3_from(data.len(), |i| data[i], bounds)
    }

    /// Appends `n` items of `width` floats, `item(i)` each, straight into the binary
    /// chunk (no intermediate copy), as a vertex-attribute buffer view.
    fn floats_view<const W: usize>(&mut self, n: usize, mut item: impl FnMut(usize) -> [f32; W]) -> u32 {
        let offset = self.aligned_end();
        self.bin.reserve(n * W * 4);
        for i in 0..n {
            for x in item(i) {
                self.bin.extend_from_slice(&x.to_le_bytes());
            }
        }
        let byte_length = self.base + self.bin.len() - offset;
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length,
            target: Some(ARRAY_BUFFER),
            byte_stride: None,
        });
        self.root.buffer_views.len() as u32 - 1
    }

    /// Like [`Builder::vec3`], item by item.
    fn vec3_from(&mut self, n: usize, item: impl Fn(usize) -> [f32; 3], bounds: bool) -> u32 {
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let view = self.floats_view(n, |i| {
            let p = item(i);
            if bounds {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            p
        });
        let (min, max) = if bounds { (Some(lo.to_vec()), Some(hi.to_vec())) } else { (None, None) };
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: n,
            kind: "VEC3",
            min,
            max,
            ..Accessor::default()
        })
    }

    /// A VEC4 float vertex attribute.
    fn vec4(&mut self, data: &[[f32; 4]]) -> u32 {
        self.vec4_from(data.len(), |i| data[i])
    }

    /// Like [`Builder::vec4`], item by item.
    fn vec4_from(&mut self, n: usize, item: impl Fn(usize) -> [f32; 4]) -> u32 {
        let view = self.floats_view(n, item);
        self.accessor(Accessor {
            buffer_view: view,
            component_type: FLOAT,
            count: n,
            kind: "VEC4",
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// A u32 index list.
    fn indices(&mut self, data: &[u32]) -> u32 {
        self.indices_of(data.len(), data.iter().copied())
    }

    /// A u32 index list of `n` indices, written straight into the binary chunk.
    fn indices_of(&mut self, n: usize, data: impl Iterator<Item = u32>) -> u32 {
        let offset = self.aligned_end();
        self.bin.reserve(n * 4);
        for x in data {
            self.bin.extend_from_slice(&x.to_le_bytes());
        }
        let byte_length = self.base + self.bin.len() - offset;
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length,
            target: Some(ELEMENT_ARRAY_BUFFER),
            byte_stride: None,
        });
        let view = self.root.buffer_views.len() as u32 - 1;
        self.accessor(Accessor {
            buffer_view: view,
            component_type: UNSIGNED_INT,
            count: byte_length / 4,
            kind: "SCALAR",
            min: None,
            max: None,
            ..Accessor::default()
        })
    }

    /// The material for a base colour (display values, already clamped; written
    /// linear), double-sided for open surfaces, created on first use.
    fn material(&mut self, color: [f32; 4], double_sided: bool) -> u32 {
        let key = (color.map(f32::to_bits), double_sided);
        if let Some(&m) = self.materials.get(&key) {
            return m;
        }
        // Dielectric: the glTF default material is fully metallic, which renders
        // vertex colours nearly black in most viewers.
        self.root.materials.push(Material {
            name: None,
            pbr_metallic_roughness: Pbr {
                base_color_factor: linear_color(color),
                metallic_factor: 0.0,
                roughness_factor: 0.6,
            },
            double_sided,
        });
        let m = self.root.materials.len() as u32 - 1;
        self.materials.insert(key, m);
        m
    }

    /// A triangle primitive with vertex colours for `m` (world space), or `None` when
    /// it has no triangles.
    fn colored_primitive(&mut self, src: FlatSource<'a>, what: &str) -> Result<Option<Primitive>, ExportError> {
        let m = match &src {
            FlatSource::Mesh(m) => *m,
            FlatSource::Owned(m) => m,
            FlatSource::Vertex { .. } => return Err(ExportError::NotOneMesh { what: what.to_string() }),
        };
        let tris = checked_triangles(m, what)?;
        if tris.is_empty() {
            return Ok(None);
        }
        let double_sided = !is_closed(m, &tris);
        drop(tris);
        self.flat_primitive(src, double_sided, what)
    }

    /// The primitive of the `VERTEX` triangles with the prototype instances not in
    /// `instanced` expanded where they were made, or `None` when there are no
    /// triangles. Double-sided unless the triangles emitted one by one form closed
    /// surfaces and so does every expanded prototype on its own (exact where there
    /// are no prototype instances; otherwise a piece that is only closed by another
    /// piece is taken as open, which shows nothing wrong: see docs/decisions.md).
    fn vertex_primitive(&mut self, out: &'a Output, gpu: &'a GpuGroups) -> Result<Option<Primitive>, ExportError> {
        let instanced = gpu.instanced.as_slice();
        let expand = |i: usize| !instanced.get(i).copied().unwrap_or(false);
        // (With every prototype instanced, the group is the mesh alone.)
        let mesh_only = gpu.all_prototypes_instanced;
        let n_tris = match mesh_only {
            true => out.mesh.triangles.len(),
            false => out.flat_counts_where(Groups::VERTEX, expand).1,
        };
        if n_tris == 0 {
            return Ok(None);
        }
        // (Every prototype in the table has instances; with --instances some may all be
        // instanced, and counting such a one errs on the double-sided side.)
        let mut closed = is_closed(&out.mesh, &checked_triangles(&out.mesh, "VERTEX mesh")?);
        for s in out.shared_meshes.iter().filter(|s| s.is_prototype()) {
            if !closed {
                break;
            }
            closed = is_closed(&s.mesh, &checked_triangles(&s.mesh, &s.name)?);
        }
        self.flat_primitive(FlatSource::Vertex { out, instanced, mesh_only }, !closed, "VERTEX mesh")
    }

    /// A triangle primitive with vertex colours (and the skin attributes of a skinned
    /// output) from the pieces of `src`, streamed into the file: a first walk finds
    /// the counts, the bounds, the colour precision and whether an index buffer is
    /// needed; the file's second walk writes the vertices as interleaved records
    /// ([`VertexRecord`]) straight to the output, expanding each prototype instance
    /// from its frame. Without indices (the usual case: every vertex in one triangle,
    /// in order) the vertices go in each triangle's oriented order.
    fn flat_primitive(
        &mut self,
        src: FlatSource<'a>,
        double_sided: bool,
        what: &str,
    ) -> Result<Option<Primitive>, ExportError> {
        let mut infos = src.output().map(ProtoInfos::new);
        let plan = flat_plan(&src, what, &mut infos)?;
        if plan.n_tris == 0 {
            return Ok(None);
        }
        let skinned = self.skinned;
        let stride = flat_stride(plan.wide, skinned);
        let vertex_bytes = plan.n * stride;
        let index_bytes = if plan.sequential { 0 } else { 12 * plan.n_tris };
        let (n, n_tris, wide, sequential, lo, hi) = (plan.n, plan.n_tris, plan.wide, plan.sequential, plan.lo, plan.hi);
        let offset = self.stream(
            vertex_bytes + index_bytes,
            Box::new(move |sink: &mut Sink| flat_write(&src, &plan, skinned, &mut infos, sink)),
        );
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length: vertex_bytes,
            target: Some(ARRAY_BUFFER),
            byte_stride: Some(stride),
        });
        let vertices = self.root.buffer_views.len() as u32 - 1;
        let mut attributes = BTreeMap::new();
        let mut acc = |byte_offset, component_type, normalized, kind, bounds: Option<([f32; 3], [f32; 3])>| {
            let (min, max) = bounds.map_or((None, None), |(a, b)| (Some(a.to_vec()), Some(b.to_vec())));
            self.accessor(Accessor {
                buffer_view: vertices,
                byte_offset,
                component_type,
                normalized,
                count: n,
                kind,
                min,
                max,
            })
        };
        attributes.insert("POSITION", acc(0, FLOAT, false, "VEC3", Some((lo, hi))));
        attributes.insert("NORMAL", acc(12, FLOAT, false, "VEC3", None));
        let color_type = if wide { UNSIGNED_SHORT } else { UNSIGNED_BYTE };
        attributes.insert("COLOR_0", acc(24, color_type, true, "VEC4", None));
        if skinned {
            let w = if wide { 32 } else { 28 };
            attributes.insert("JOINTS_0", acc(w, UNSIGNED_SHORT, false, "VEC4", None));
            attributes.insert("WEIGHTS_0", acc(w + 8, FLOAT, false, "VEC4", None));
        }
        let indices = if sequential {
            None
        } else {
            self.root.buffer_views.push(BufferView {
                buffer: 0,
                byte_offset: offset + vertex_bytes,
                byte_length: index_bytes,
                target: Some(ELEMENT_ARRAY_BUFFER),
                byte_stride: None,
            });
            let view = self.root.buffer_views.len() as u32 - 1;
            Some(self.accessor(Accessor {
                buffer_view: view,
                component_type: UNSIGNED_INT,
                count: 3 * n_tris,
                kind: "SCALAR",
                ..Accessor::default()
            }))
        };
        let material = Some(self.material([1.0; 4], double_sided));
        Ok(Some(Primitive { attributes, indices, material, mode: None, extras: None }))
    }

    /// One node drawing `group`'s instances with `EXT_mesh_gpu_instancing`: the
    /// prototype's mesh in its own space (mirrored in x for mirrored frames), and
    /// per instance TRANSLATION, ROTATION and SCALE, plus `_COLOR_0` (linear RGB,
    /// which three.js reads as the instance colour) when the colours differ; a
    /// colour shared by every instance goes in the material instead.
    fn instanced_node(&mut self, out: &'a Output, group: &'a GpuGroup) -> Result<Option<u32>, ExportError> {
        let Some(shared) = out.shared_meshes.get(group.mesh as usize) else { return Ok(None) };
        let local = prototype_local_mesh(shared, group.color, group.mirrored);
        let name = if group.mirrored { format!("{} mirrored", shared.name) } else { shared.name.clone() };
        let tris = checked_triangles(&local, &name)?;
        if tris.is_empty() {
            return Ok(None);
        }
        let n = local.positions.len();
        let double_sided = !is_closed(&local, &tris);
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3_from(n, |i| finite3(local.positions[i]), true));
        attributes.insert("NORMAL", self.vec3_from(n, |i| normal_at(&local, i), false));
        if group.color.is_some() {
            attributes.insert("COLOR_0", self.vec4_from(n, |i| linear_color(color_at(&local, i))));
        }
        let indices = Some(self.indices_of(tris.len() * 3, tris.iter().flatten().copied()));
        let insts = || group.instances.iter().filter_map(|&i| out.instances.get(i as usize));
        // A colour shared by every instance goes in the material: seen from the
        // colours' bits while grouping, or (rarely: different bits, say above 1, that
        // clamp alike) by a walk.
        let first = insts().next().map(|i| clamp_color(i.color));
        let shared_color = match (group.color, first) {
            (None, Some(c)) if group.same_bits || insts().all(|i| clamp_color(i.color) == c) => Some(c),
            _ => None,
        };
        let material = Some(self.material(shared_color.unwrap_or([1.0; 4]), double_sided));
        let extras = sites::instanced_extras(out, &group.instances);
        let mesh = self.push_mesh(GMesh {
            name: Some(name.clone()),
            primitives: vec![Primitive { attributes, indices, material, mode: None, extras }],
        });
        let n_inst = group.instances.len();
        let mut inst_attrs = BTreeMap::new();
        let per_color = group.color.is_none() && shared_color.is_none();
        let widths: &[(&'static str, usize, &'static str)] = if per_color {
            &[("TRANSLATION", 3, "VEC3"), ("ROTATION", 4, "VEC4"), ("SCALE", 3, "VEC3"), ("_COLOR_0", 3, "VEC3")]
        } else {
            &[("TRANSLATION", 3, "VEC3"), ("ROTATION", 4, "VEC4"), ("SCALE", 3, "VEC3")]
        };
        // The attributes' values are written when the file is: one view and accessor
        // per attribute, one after the other.
        let len: usize = widths.iter().map(|&(_, w, _)| 4 * w * n_inst).sum();
        let order = group.instances.as_slice();
        let mut at =
            self.stream(len, Box::new(move |sink: &mut Sink| write_instance_attributes(out, order, per_color, sink)));
        for (name, w, kind) in widths {
            let len = 4 * w * n_inst;
            self.root.buffer_views.push(BufferView {
                buffer: 0,
                byte_offset: at,
                byte_length: len,
                target: None,
                byte_stride: None,
            });
            let view = self.root.buffer_views.len() as u32 - 1;
            let acc = self.accessor(Accessor {
                buffer_view: view,
                component_type: FLOAT,
                count: n_inst,
                kind,
                min: None,
                max: None,
                ..Accessor::default()
            });
            inst_attrs.insert(*name, acc);
            at += len;
        }
        self.root.extensions_used = vec![EXT_INSTANCING];
        let node = self.push_node(Node {
            name: Some(name),
            mesh: Some(mesh),
            extensions: Some(NodeExtensions { instancing: Instancing { attributes: inst_attrs } }),
            ..Node::default()
        });
        Ok(Some(node))
    }

    /// Positions, normals and indices of a shared mesh in its own space, or of its
    /// copy mirrored in x (x negated, every triangle reversed) when `mirror`.
    fn shared_accessors(&mut self, m: &Mesh, name: &str, mirror: bool) -> Result<SharedAccessors, ExportError> {
        let tris = checked_triangles(m, &format!("shared mesh {name}"))?;
        let double_sided = !is_closed(m, &tris);
        let n = m.positions.len();
        let flip = |p: [f32; 3]| if mirror { [-p[0], p[1], p[2]] } else { p };
        let position = self.vec3_from(n, |i| flip(finite3(m.positions[i])), true);
        let normal = self.vec3_from(n, |i| flip(normal_at(m, i)), false);
        let indices = if mirror {
            self.indices_of(tris.len() * 3, tris.iter().flat_map(|t| [t[0], t[2], t[1]]))
        } else {
            self.indices_of(tris.len() * 3, tris.iter().flatten().copied())
        };
        Ok(SharedAccessors { position, normal, indices, double_sided })
    }

    /// The polylines `pick` chooses with two or more points as one `LINES` primitive.
    fn lines_primitive(&mut self, out: &Output, pick: &dyn Fn(&Polyline) -> bool) -> Option<Primitive> {
        let mut positions = Vec::new();
        let mut bones = Vec::new();
        let mut indices = Vec::new();
        for line in out.lines.iter().filter(|l| l.points.len() >= 2 && pick(l)) {
            let base = positions.len() as u32;
            positions.extend(line.points.iter().map(|p| finite3(*p)));
            bones.extend((0..line.points.len()).map(|i| line.bone(i)));
            for k in 0..line.points.len() as u32 - 1 {
                indices.extend([base + k, base + k + 1]);
            }
        }
        if indices.is_empty() {
            return None;
        }
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3(&positions, true));
        if self.skinned {
            self.skin_attributes(&mut attributes, positions.len(), |i| bones[i]);
        }
        let indices = Some(self.indices(&indices));
        let material = Some(self.material([1.0; 4], false));
        Some(Primitive { attributes, indices, material, mode: Some(MODE_LINES), extras: None })
    }

    fn push_mesh(&mut self, m: GMesh) -> u32 {
        self.root.meshes.push(m);
        self.root.meshes.len() as u32 - 1
    }

    fn push_node(&mut self, n: Node) -> u32 {
        self.root.nodes.push(n);
        self.root.nodes.len() as u32 - 1
    }

    /// Serialises the document and writes the GLB container.
    fn finish(mut self, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
        let bin_len = self.aligned_end();
        if bin_len > 0 {
            self.root.buffers.push(Buffer { byte_length: bin_len });
        }
        let mut json = serde_json::to_vec(&self.root).map_err(ExportError::GltfJson)?;
        json.resize(json.len().next_multiple_of(4), b' ');
        let bin_chunk = if bin_len == 0 { 0 } else { 8 + bin_len };
        let total = 12 + 8 + json.len() + bin_chunk;
        let total = u32::try_from(total).map_err(|_| ExportError::GlbTooLarge { bytes: total as u64 })?;
        let mut head = Vec::with_capacity(20);
        head.extend_from_slice(GLB_MAGIC);
        head.extend_from_slice(&2u32.to_le_bytes());
        head.extend_from_slice(&total.to_le_bytes());
        head.extend_from_slice(&(json.len() as u32).to_le_bytes());
        head.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        let io = ExportError::GlbIo;
        w.write_all(&head).map_err(io)?;
        w.write_all(&json).map_err(io)?;
        if bin_len > 0 {
            let mut bin_head = Vec::with_capacity(8);
            bin_head.extend_from_slice(&(bin_len as u32).to_le_bytes());
            bin_head.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            w.write_all(&bin_head).map_err(io)?;
            for seg in self.segments {
                match seg {
                    Segment::Bytes(b) => w.write_all(&b).map_err(io)?,
                    Segment::Stream { len, write } => {
                        let mut sink = Sink::new(w);
                        write(&mut sink)?;
                        sink.flush()?;
                        if sink.written != len {
                            return Err(ExportError::StreamLength { written: sink.written, laid_out: len });
                        }
                    }
                }
            }
            w.write_all(&self.bin).map_err(io)?;
        }
        Ok(())
    }
}

/// Writes a streamed part of the binary chunk into a [`Sink`].
type StreamFn<'a> = dyn FnOnce(&mut Sink) -> Result<(), ExportError> + 'a;

/// A part of the binary chunk: bytes made in advance, or `len` bytes that `write`
/// makes while the file is written.
enum Segment<'a> {
    Bytes(Vec<u8>),
    Stream { len: usize, write: Box<StreamFn<'a>> },
}

/// How many bytes a [`Sink`] gathers before handing them on.
const SINK_BYTES: usize = 1 << 16;

/// The writer a streamed part writes into: a fixed buffer (`buf[..len]` filled) in
/// front of the output, counting what went through.
struct Sink<'w> {
    buf: Box<[u8]>,
    len: usize,
    w: &'w mut dyn std::io::Write,
    written: usize,
}

impl<'w> Sink<'w> {
    fn new(w: &'w mut dyn std::io::Write) -> Sink<'w> {
        Sink { buf: vec![0; SINK_BYTES].into_boxed_slice(), len: 0, w, written: 0 }
    }

    /// The next `n` bytes (at most [`SINK_BYTES`]) to fill in.
    #[inline]
    fn slot(&mut self, n: usize) -> Result<&mut [u8], ExportError> {
        if self.len + n > self.buf.len() {
            self.flush()?;
        }
        let at = self.len;
        self.len += n;
        self.buf.get_mut(at..at + n).ok_or(ExportError::Record { bytes: n })
    }

    #[inline]
    fn put(&mut self, bytes: &[u8]) -> Result<(), ExportError> {
        self.slot(bytes.len())?.copy_from_slice(bytes);
        Ok(())
    }

    /// Appends `xs` as little-endian f32s.
    #[inline]
    fn floats<const N: usize>(&mut self, xs: [f32; N]) -> Result<(), ExportError> {
        let b = self.slot(4 * N)?;
        for (d, x) in b.chunks_exact_mut(4).zip(xs) {
            d.copy_from_slice(&x.to_le_bytes());
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), ExportError> {
        self.w.write_all(&self.buf[..self.len]).map_err(ExportError::GlbIo)?;
        self.written += self.len;
        self.len = 0;
        Ok(())
    }
}

// The glTF JSON schema subset written here. Empty arrays are omitted because glTF
// requires every array that is present to be non-empty.

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Root {
    asset: Asset,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    extensions_used: Vec<&'static str>,
    scene: u32,
    scenes: Vec<Scene>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    nodes: Vec<Node>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    meshes: Vec<GMesh>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    materials: Vec<Material>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    accessors: Vec<Accessor>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    buffer_views: Vec<BufferView>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    buffers: Vec<Buffer>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    skins: Vec<Skin>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    cameras: Vec<GCamera>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    animations: Vec<GAnimation>,
}

impl Default for Root {
    fn default() -> Self {
        Root {
            asset: Asset { version: "2.0", generator: "mdg" },
            extensions_used: Vec::new(),
            scene: 0,
            scenes: Vec::new(),
            nodes: Vec::new(),
            meshes: Vec::new(),
            materials: Vec::new(),
            accessors: Vec::new(),
            buffer_views: Vec::new(),
            buffers: Vec::new(),
            skins: Vec::new(),
            cameras: Vec::new(),
            animations: Vec::new(),
        }
    }
}

#[derive(Serialize)]
struct Asset {
    version: &'static str,
    generator: &'static str,
}

#[derive(Serialize)]
struct Scene {
    #[serde(skip_serializing_if = "Vec::is_empty")]
    nodes: Vec<u32>,
}

#[derive(Serialize, Default)]
struct Node {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mesh: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    translation: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rotation: Option<[f32; 4]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    scale: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    children: Vec<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    skin: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    camera: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extensions: Option<NodeExtensions>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extras: Option<serde_json::Value>,
}

/// The extension name of GPU instancing.
const EXT_INSTANCING: &str = "EXT_mesh_gpu_instancing";

#[derive(Serialize)]
struct NodeExtensions {
    #[serde(rename = "EXT_mesh_gpu_instancing")]
    instancing: Instancing,
}

#[derive(Serialize)]
struct Instancing {
    attributes: BTreeMap<&'static str, u32>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Skin {
    #[serde(skip_serializing_if = "Option::is_none")]
    inverse_bind_matrices: Option<u32>,
    joints: Vec<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    skeleton: Option<u32>,
}

#[derive(Serialize)]
struct GCamera {
    #[serde(rename = "type")]
    kind: &'static str,
    perspective: Perspective,
}

#[derive(Serialize)]
struct Perspective {
    yfov: f32,
    znear: f32,
    #[serde(skip_serializing_if = "Option::is_none")]
    zfar: Option<f32>,
}

#[derive(Serialize)]
struct GAnimation {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    channels: Vec<Channel>,
    samplers: Vec<Sampler>,
}

#[derive(Serialize)]
struct Channel {
    sampler: u32,
    target: Target,
}

#[derive(Serialize)]
struct Target {
    node: u32,
    path: &'static str,
}

#[derive(Serialize)]
struct Sampler {
    input: u32,
    output: u32,
    interpolation: &'static str,
}

#[derive(Serialize)]
struct GMesh {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    primitives: Vec<Primitive>,
}

/// The namespaces of the lines a guided search adds (`sosmc::search`): each gets a
/// node of its own.
const SEARCH_LINES: [&str; 2] = ["guides", "bones"];

#[derive(Serialize)]
struct Primitive {
    attributes: BTreeMap<&'static str, u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    indices: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    material: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mode: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    extras: Option<serde_json::Value>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Material {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    pbr_metallic_roughness: Pbr,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    double_sided: bool,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Pbr {
    base_color_factor: [f32; 4],
    metallic_factor: f32,
    roughness_factor: f32,
}

#[derive(Serialize, Default)]
#[serde(rename_all = "camelCase")]
struct Accessor {
    buffer_view: u32,
    #[serde(skip_serializing_if = "is_zero")]
    byte_offset: usize,
    component_type: u32,
    /// Integer components read as 0..1 (colours).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    normalized: bool,
    count: usize,
    #[serde(rename = "type")]
    kind: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    min: Option<Vec<f32>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max: Option<Vec<f32>>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct BufferView {
    buffer: u32,
    byte_offset: usize,
    byte_length: usize,
    /// Interleaved vertex attributes: the bytes from one vertex to the next.
    #[serde(skip_serializing_if = "Option::is_none")]
    byte_stride: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    target: Option<u32>,
}

fn is_zero(x: &usize) -> bool {
    *x == 0
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Buffer {
    byte_length: usize,
}

#[cfg(test)]
pub(crate) mod tests {
    use serde_json::Value;

    use super::flat::fits_8_bits;
    use super::*;
    use crate::linear_to_srgb;
    use crate::tests::sample_output;
    use mdg_vm::output::SharedMesh;

    /// An instance of shared mesh `mesh` in `frame`.
    fn iso(mesh: u32, frame: Frame, color: [f32; 4]) -> mdg_vm::output::Instance {
        mdg_vm::output::Instance { frame, color, mesh, bone: 0, lin: 0, at: 0 }
    }

    #[test]
    fn more_bones_than_gltf_holds_is_an_error_and_nothing_is_written() {
        let mut out = sample_output();
        let bone = mdg_vm::output::Bone {
            rule: "B".into(),
            parent: 0,
            rest: mdg_vm::geom::quat::Frame::default(),
            fps: 1.0,
            tracks: Vec::new(),
        };
        out.animation.bones = vec![bone; MAX_GLTF_BONES + 1];
        let dir = std::env::temp_dir().join(format!("mdg-glb-bones-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("out.glb");
        let e = crate::write_file(crate::Format::Glb, &out, &path).expect_err("too many bones");
        let crate::ExportError::File { source, .. } = &e else { panic!("{e:?}") };
        assert!(matches!(**source, crate::ExportError::TooManyBones { bones: 65537, max: 65536 }), "{source:?}");
        assert!(!e.is_io(), "the model's fault, not the destination's");
        assert_eq!(
            e.to_string(),
            format!(
                "cannot write {}: 65537 bones: glTF export holds at most 65536 (write one pose with --time instead)",
                path.display()
            )
        );
        assert!(!path.exists(), "nothing is written");
        assert_eq!(std::fs::read_dir(&dir).expect("list").count(), 0, "no temporary file is left");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Splits a GLB into its JSON document and binary chunk, checking the container.
    pub(crate) fn parse_glb(b: &[u8]) -> (Value, Vec<u8>) {
        let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"));
        assert_eq!(&b[0..4], b"glTF");
        assert_eq!(u32_at(4), 2);
        assert_eq!(u32_at(8) as usize, b.len());
        let json_len = u32_at(12) as usize;
        assert_eq!(json_len % 4, 0);
        assert_eq!(u32_at(16), CHUNK_JSON);
        let json: Value = serde_json::from_slice(&b[20..20 + json_len]).expect("valid JSON");
        let mut bin = Vec::new();
        let o = 20 + json_len;
        if o < b.len() {
            let bin_len = u32_at(o) as usize;
            assert_eq!(bin_len % 4, 0);
            assert_eq!(u32_at(o + 4), CHUNK_BIN);
            bin = b[o + 8..o + 8 + bin_len].to_vec();
            assert_eq!(o + 8 + bin_len, b.len());
        }
        (json, bin)
    }

    /// An accessor's components as a client reads them: through its view's offset
    /// and stride, each as f64 (normalised integers divided by their maximum).
    pub(crate) fn components(bin: &[u8], json: &Value, accessor: u64) -> Vec<f64> {
        let a = &json["accessors"][accessor as usize];
        let v = &json["bufferViews"][a["bufferView"].as_u64().expect("view") as usize];
        let width = match a["type"].as_str().expect("type") {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            t => panic!("type {t}"),
        };
        let (size, read): (usize, fn(&[u8]) -> f64) = match a["componentType"].as_u64().expect("component type") as u32
        {
            FLOAT => (4, |b| f32::from_le_bytes(b.try_into().expect("4")) as f64),
            UNSIGNED_INT => (4, |b| u32::from_le_bytes(b.try_into().expect("4")) as f64),
            UNSIGNED_SHORT => (2, |b| u16::from_le_bytes(b.try_into().expect("2")) as f64),
            UNSIGNED_BYTE => (1, |b| b[0] as f64),
            t => panic!("component type {t}"),
        };
        let scale = match (a["normalized"].as_bool().unwrap_or(false), size) {
            (true, 1) => 255.0,
            (true, 2) => 65535.0,
            _ => 1.0,
        };
        let start = v["byteOffset"].as_u64().unwrap_or(0) as usize + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let stride = v["byteStride"].as_u64().map_or(width * size, |s| s as usize);
        let count = a["count"].as_u64().expect("count") as usize;
        let end = v["byteOffset"].as_u64().unwrap_or(0) as usize + v["byteLength"].as_u64().expect("length") as usize;
        assert!(
            count == 0 || start + (count - 1) * stride + width * size <= end,
            "accessor {accessor} overruns its view"
        );
        (0..count)
            .flat_map(|i| (0..width).map(move |k| start + i * stride + k * size))
            .map(|o| read(&bin[o..o + size]) / scale)
            .collect()
    }

    fn floats(bin: &[u8], json: &Value, accessor: u64) -> Vec<f32> {
        components(bin, json, accessor).into_iter().map(|x| x as f32).collect()
    }

    fn uints(bin: &[u8], json: &Value, accessor: u64) -> Vec<u32> {
        components(bin, json, accessor).into_iter().map(|x| x as u32).collect()
    }

    /// A triangle primitive's indices: its index accessor's, or 0…N−1 without one.
    pub(crate) fn primitive_indices(bin: &[u8], json: &Value, p: &Value) -> Vec<u32> {
        match p["indices"].as_u64() {
            Some(i) => uints(bin, json, i),
            None => {
                let pos = p["attributes"]["POSITION"].as_u64().expect("position");
                (0..json["accessors"][pos as usize]["count"].as_u64().expect("count") as u32).collect()
            }
        }
    }

    #[test]
    fn container_accessors_and_bounds() {
        let out = sample_output();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        assert_eq!(json["asset"]["generator"], "mdg");
        assert_eq!(json["buffers"][0]["byteLength"].as_u64(), Some(bin.len() as u64));
        // geometry: VERTEX + sweeps (the mirrored instance is a node too).
        let prims = json["meshes"][0]["primitives"].as_array().expect("primitives");
        assert_eq!(prims.len(), 2);
        let vertex = &prims[0];
        let pos = vertex["attributes"]["POSITION"].as_u64().expect("position");
        assert_eq!(json["accessors"][pos as usize]["count"], 24);
        assert_eq!(json["accessors"][pos as usize]["min"], serde_json::json!([-0.5, -0.5, -0.5]));
        assert_eq!(json["accessors"][pos as usize]["max"], serde_json::json!([0.5, 0.5, 0.5]));
        let idx = vertex["indices"].as_u64().expect("indices");
        assert_eq!(json["accessors"][idx as usize]["count"], 36);
        // Every POSITION accessor's min/max match its data; normals are unit.
        for p in
            json["meshes"].as_array().expect("meshes").iter().flat_map(|m| m["primitives"].as_array().expect("prims"))
        {
            let a = p["attributes"]["POSITION"].as_u64().expect("position");
            let data = floats(&bin, &json, a);
            for k in 0..3 {
                let lo = data.iter().skip(k).step_by(3).copied().fold(f32::INFINITY, f32::min);
                let hi = data.iter().skip(k).step_by(3).copied().fold(f32::NEG_INFINITY, f32::max);
                // The JSON holds the shortest decimal that reads back as the same f32.
                assert_eq!(json["accessors"][a as usize]["min"][k].as_f64().map(|x| x as f32), Some(lo));
                assert_eq!(json["accessors"][a as usize]["max"][k].as_f64().map(|x| x as f32), Some(hi));
            }
            if let Some(n) = p["attributes"]["NORMAL"].as_u64() {
                for v in floats(&bin, &json, n).chunks(3) {
                    assert!((Vec3::from_slice(v).length() - 1.0).abs() < 1e-5);
                }
            }
            if let Some(c) = p["attributes"]["COLOR_0"].as_u64() {
                assert!(floats(&bin, &json, c).iter().all(|x| (0.0..=1.0).contains(x)));
            }
        }
        // Three instances are TRS nodes; the two non-mirrored ones share the CUBE accessors.
        let nodes = json["nodes"].as_array().expect("nodes");
        let all_cubes: Vec<&Value> = nodes.iter().filter(|n| n["name"] == "CUBE").collect();
        assert_eq!(all_cubes.len(), 3);
        let mesh_name = |n: &Value| json["meshes"][n["mesh"].as_u64().expect("mesh") as usize]["name"].clone();
        let cubes: Vec<&Value> = all_cubes.iter().copied().filter(|n| mesh_name(n) == "CUBE").collect();
        assert_eq!(cubes.len(), 2);
        assert!(cubes.iter().all(|n| n.get("matrix").is_none() && n["scale"].is_array()));
        let m1 = &json["meshes"][cubes[0]["mesh"].as_u64().expect("mesh") as usize]["primitives"][0];
        let m2 = &json["meshes"][cubes[1]["mesh"].as_u64().expect("mesh") as usize]["primitives"][0];
        assert_eq!(m1["attributes"], m2["attributes"]);
        assert_ne!(m1["material"], m2["material"], "different instance colours");
        assert!((cubes[1]["scale"][0].as_f64().expect("scale") - 2.0).abs() < 1e-5);
        // Lines.
        let lines = nodes.iter().find(|n| n["name"] == "lines").expect("lines node");
        let lp = &json["meshes"][lines["mesh"].as_u64().expect("mesh") as usize]["primitives"][0];
        assert_eq!(lp["mode"], 1);
        assert_eq!(uints(&bin, &json, lp["indices"].as_u64().expect("indices")), vec![0, 1, 1, 2]);
        // One root node (y up) holds every other node.
        let scene = json["scenes"][0]["nodes"].as_array().expect("scene");
        assert_eq!(scene.len(), 1);
        let root = &nodes[scene[0].as_u64().expect("root") as usize];
        assert_eq!(root["children"].as_array().expect("children").len(), nodes.len() - 1);
    }

    /// World-space triangles (each as its three corners, rotated to start at the
    /// smallest) of every mesh node under `node`, composing TRS transforms.
    fn world_triangles(json: &Value, bin: &[u8], node: usize, parent: Mat4, out: &mut Vec<[[i64; 3]; 3]>) {
        let n = &json["nodes"][node];
        let v = |k: &str, d: &[f32]| -> Vec<f32> {
            n[k].as_array().map(|a| a.iter().map(|x| x.as_f64().expect("f") as f32).collect()).unwrap_or(d.to_vec())
        };
        let (t, r, sc) = (v("translation", &[0.0; 3]), v("rotation", &[0.0, 0.0, 0.0, 1.0]), v("scale", &[1.0; 3]));
        let m = parent
            * Mat4::from_scale_rotation_translation(Vec3::from_slice(&sc), Quat::from_slice(&r), Vec3::from_slice(&t));
        if let Some(mesh) = n["mesh"].as_u64() {
            for p in json["meshes"][mesh as usize]["primitives"].as_array().expect("prims") {
                if p.get("mode").is_some() {
                    continue;
                }
                let pos = floats(bin, json, p["attributes"]["POSITION"].as_u64().expect("pos"));
                let idx = primitive_indices(bin, json, p);
                for tri in idx.chunks(3) {
                    let c: Vec<[i64; 3]> = tri
                        .iter()
                        .map(|&i| {
                            let w = m.transform_point3(Vec3::from_slice(&pos[i as usize * 3..i as usize * 3 + 3]));
                            w.to_array().map(|x| (x * 1e3).round() as i64)
                        })
                        .collect();
                    let k = (0..3).min_by_key(|&k| c[k]).expect("corner");
                    out.push([c[k], c[(k + 1) % 3], c[(k + 2) % 3]]);
                }
            }
        }
        for c in n["children"].as_array().into_iter().flatten() {
            world_triangles(json, bin, c.as_u64().expect("child") as usize, m, out);
        }
    }

    /// The same triangles, oriented, in world space, whether instances are nodes
    /// (mirrored ones over a mirrored copy) or baked: turned y up.
    #[test]
    fn nodes_place_the_same_oriented_triangles_as_baking_y_up() {
        let out = sample_output();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let mut got = Vec::new();
        for n in json["scenes"][0]["nodes"].as_array().expect("scene") {
            world_triangles(&json, &bin, n.as_u64().expect("node") as usize, Mat4::IDENTITY, &mut got);
        }
        let flat = out.flattened();
        let mut want: Vec<[[i64; 3]; 3]> = flat
            .oriented_triangles()
            .map(|t| {
                let c: Vec<[i64; 3]> = t
                    .iter()
                    .map(|&i| super::super::z_up_to_y_up(flat.positions[i as usize]).map(|x| (x * 1e3).round() as i64))
                    .collect();
                let k = (0..3).min_by_key(|&k| c[k]).expect("corner");
                [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
            })
            .collect();
        got.sort();
        want.sort();
        assert_eq!(got, want);
        // One mirrored copy of CUBE, used by the mirrored instance.
        let names: Vec<&str> =
            json["meshes"].as_array().expect("meshes").iter().filter_map(|m| m["name"].as_str()).collect();
        assert_eq!(names.iter().filter(|n| **n == "CUBE mirrored").count(), 1);
    }

    #[test]
    fn colours_are_linear_and_open_surfaces_double_sided() {
        let mut out = Output::default();
        // An open quad in sRGB 0.5 grey, and a closed cube instance.
        for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
            out.mesh.push_vertex(Vec3::from(p), Vec3::Z, [0.5, 0.5, 0.5, 1.0], [0.0; 4], 0);
        }
        out.mesh.push_triangle([0, 1, 2], false);
        out.mesh.push_triangle([0, 2, 3], false);
        out.shared_meshes.push(SharedMesh::isosurface("CUBE", crate::tests::cube(false)));
        out.instances.push(iso(0, Frame::identity(), [1.0, 0.5, 0.0, 0.5]));
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let geometry = &json["meshes"][0]["primitives"][0];
        let color = geometry["attributes"]["COLOR_0"].as_u64().expect("colours");
        // Normalised 8-bit: the linear value to within half a step.
        assert_eq!(json["accessors"][color as usize]["componentType"], UNSIGNED_BYTE);
        assert_eq!(json["accessors"][color as usize]["normalized"], true);
        let c = floats(&bin, &json, color);
        assert!((c[0] - 0.214_041_14).abs() <= 0.5 / 255.0 && c[3] == 1.0, "{c:?}");
        let material = |p: &Value| json["materials"][p["material"].as_u64().expect("material") as usize].clone();
        assert_eq!(material(geometry)["doubleSided"], true);
        let cube = json["nodes"].as_array().expect("nodes").iter().find(|n| n["name"] == "CUBE").expect("cube");
        let m = material(&json["meshes"][cube["mesh"].as_u64().expect("mesh") as usize]["primitives"][0]);
        assert!(m.get("doubleSided").is_none(), "a closed cube culls its back faces");
        let factor: Vec<f64> = m["pbrMetallicRoughness"]["baseColorFactor"]
            .as_array()
            .expect("factor")
            .iter()
            .filter_map(Value::as_f64)
            .collect();
        assert!((factor[0] - 1.0).abs() < 1e-6 && (factor[1] - 0.214_041_14).abs() < 1e-6 && factor[2] == 0.0);
        assert_eq!(factor[3], 0.5, "alpha stays as it is");
    }

    /// Triangles of three vertices each, in order (what VERTEX items make), one of
    /// them mirrored, in colour `c`.
    fn strip(c: [f32; 4]) -> Output {
        let mut out = Output::default();
        for t in 0..4 {
            let x = t as f32;
            let k = out.mesh.push_vertex(Vec3::new(x, 0.0, 0.0), Vec3::Z, c, [0.0; 4], 0);
            out.mesh.push_vertex(Vec3::new(x + 1.0, 0.0, 0.0), Vec3::Z, c, [0.0; 4], 0);
            out.mesh.push_vertex(Vec3::new(x, 1.0, 0.0), Vec3::Z, c, [0.0; 4], 0);
            if t == 2 {
                out.mesh.push_triangle([k, k + 2, k + 1], true);
            } else {
                out.mesh.push_triangle([k, k + 1, k + 2], false);
            }
        }
        out
    }

    #[test]
    fn triangles_of_their_own_vertices_are_written_without_indices() {
        let out = strip([1.0, 0.5, 0.0, 1.0]);
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let p = &json["meshes"][0]["primitives"][0];
        assert!(p.get("indices").is_none(), "no index buffer counting 0…N−1: {p}");
        // One interleaved view: position, normal, colour (u8): 28 bytes a vertex.
        let pos = p["attributes"]["POSITION"].as_u64().expect("position") as usize;
        let view = json["accessors"][pos]["bufferView"].as_u64().expect("view") as usize;
        assert_eq!(json["bufferViews"][view]["byteStride"], 28);
        assert_eq!(bin.len(), 28 * 12);
        // The mirrored triangle's vertices are written in its oriented order.
        let flat = out.flattened();
        let positions = floats(&bin, &json, pos as u64);
        let mut k = 0;
        for t in 0..4 {
            let o = out.mesh.oriented_triangles().nth(t).expect("triangle");
            for v in o {
                assert_eq!(&positions[3 * k..3 * k + 3], &flat.positions[v as usize], "triangle {t}");
                k += 1;
            }
        }
        let colors = floats(&bin, &json, p["attributes"]["COLOR_0"].as_u64().expect("colours"));
        let want = linear_color([1.0, 0.5, 0.0, 1.0]);
        assert!(colors.chunks(4).all(|c| c.iter().zip(want).all(|(a, b)| (a - b).abs() <= 0.5 / 255.0)), "{colors:?}");
    }

    #[test]
    fn dark_colours_take_16_bits() {
        // Display 2/255 is linear 0.0006: 8-bit linear storage reads it back as 0.
        let dark = 2.0 / 255.0;
        assert!(!fits_8_bits([dark, 0.5, 0.5, 1.0]));
        assert!(fits_8_bits([0.5, 0.5, 0.5, 1.0]) && fits_8_bits([1.0, 0.0, 1.0, 0.3]));
        let out = strip([dark, 0.5, 0.5, 1.0]);
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let color = json["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"].as_u64().expect("colours");
        assert_eq!(json["accessors"][color as usize]["componentType"], UNSIGNED_SHORT);
        let c = floats(&bin, &json, color);
        let shown = (linear_to_srgb(c[0]) * 255.0).round();
        assert_eq!(shown, 2.0, "the 8-bit display value survives: {c:?}");
        assert_eq!(bin.len(), 32 * 12, "32 bytes a vertex");
    }

    #[test]
    fn many_instances_are_merged_into_the_geometry() {
        let mut out = Output::default();
        out.shared_meshes.push(SharedMesh::isosurface("CUBE", crate::tests::cube(false)));
        let inst = |k: usize| iso(0, Frame::identity().translate(Vec3::new(k as f32 * 2.0, 0.0, 0.0)), [1.0; 4]);
        out.instances = (0..MAX_INSTANCE_NODES).map(inst).collect();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        assert_eq!(json["nodes"].as_array().expect("nodes").len(), MAX_INSTANCE_NODES + 1, "nodes and the root");
        out.instances.push(inst(MAX_INSTANCE_NODES));
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let nodes = json["nodes"].as_array().expect("nodes");
        assert_eq!(nodes.len(), 2, "geometry and the root: {nodes:?}");
        let pos = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].as_u64().expect("positions");
        assert_eq!(floats(&bin, &json, pos).len(), 3 * 24 * (MAX_INSTANCE_NODES + 1));
        // Instances of a big mesh stay nodes (merging them would import slower).
        let mut big = Mesh::default();
        for k in 0..=MAX_MERGED_MESH_VERTICES as u32 {
            big.push_vertex(Vec3::new(k as f32, 0.0, 0.0), Vec3::Z, [1.0; 4], [0.0; 4], 0);
            big.push_vertex(Vec3::new(k as f32, 1.0, 0.0), Vec3::Z, [1.0; 4], [0.0; 4], 0);
        }
        big.push_triangle([0, 1, 2], false);
        out.shared_meshes.push(SharedMesh::isosurface("BIG", big));
        out.instances.push(mdg_vm::output::Instance { mesh: 1, ..inst(0) });
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        let names: Vec<&str> =
            json["nodes"].as_array().expect("nodes").iter().filter_map(|n| n["name"].as_str()).collect();
        assert_eq!(names, vec!["geometry", "BIG", "mdg z-up"]);
    }

    #[test]
    fn skins_have_identity_inverse_bind_matrices() {
        use mdg_vm::output::{Bone, Track};
        let mut out = sample_output();
        let frames = (0..4).map(|k| Frame::identity().rotate(Quat::from_rotation_z(k as f32))).collect();
        out.animation.duration = 1.0;
        out.animation.tracks.push(Track { rule: "X".into(), frames, complete: true });
        let bone = |rule: &str, tracks: Vec<u32>| Bone {
            rule: rule.into(),
            parent: 0,
            rest: Frame::identity(),
            fps: 4.0,
            tracks,
        };
        out.animation.bones = vec![bone("", vec![]), bone("A", vec![0])];
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let skin = &json["skins"][0];
        let a = skin["inverseBindMatrices"].as_u64().expect("inverse bind matrices");
        assert_eq!(json["accessors"][a as usize]["type"], "MAT4");
        assert_eq!(json["accessors"][a as usize]["count"], 2);
        let m = floats(&bin, &json, a);
        assert_eq!(m.len(), 32);
        assert!(m.chunks(16).all(|c| c == Mat4::IDENTITY.to_cols_array()));
        // The skinned geometry is a scene root (its transforms are ignored); the
        // bones are under the y-up root.
        let scene: Vec<u64> =
            json["scenes"][0]["nodes"].as_array().expect("scene").iter().filter_map(Value::as_u64).collect();
        let names: Vec<&str> =
            scene.iter().map(|&n| json["nodes"][n as usize]["name"].as_str().expect("name")).collect();
        assert_eq!(names, vec!["mdg z-up", "geometry", "lines"]);
    }

    #[test]
    fn a_search_s_guides_and_bones_get_nodes_of_their_own() {
        let mut out = sample_output();
        let line = |ns: &str, x: f32| Polyline {
            namespace: ns.into(),
            points: vec![[x, 0.0, 0.0], [x, 1.0, 0.0]],
            bones: vec![],
        };
        out.lines.extend([line("guides", 1.0), line("bones", 2.0), line("bones", 3.0)]);
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        let node = |name: &str| json["nodes"].as_array().expect("nodes").iter().find(|n| n["name"] == name).cloned();
        let segments = |name: &str| {
            let n = node(name).unwrap_or_else(|| panic!("no node {name}: {json}"));
            let p = &json["meshes"][n["mesh"].as_u64().expect("mesh") as usize]["primitives"][0];
            assert_eq!(p["mode"], MODE_LINES);
            json["accessors"][p["indices"].as_u64().expect("indices") as usize]["count"].as_u64().expect("count") / 2
        };
        // The pen line of the sample (3 points), one guide, two bones.
        assert_eq!((segments("lines"), segments("guides"), segments("bones")), (2, 1, 2));
    }

    #[test]
    fn mirrored_triangles_are_reversed() {
        let out = sample_output();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let idx = json["meshes"][0]["primitives"][0]["indices"].as_u64().expect("indices");
        let ind = uints(&bin, &json, idx);
        let t = out.mesh.triangles[0];
        assert!(out.mesh.mirrored[0]);
        assert_eq!(&ind[0..3], &[t[0], t[2], t[1]]);
        assert_eq!(&ind[3..6], &out.mesh.triangles[1]);
    }

    #[test]
    fn empty_output_is_a_valid_empty_scene() {
        let mut b = Vec::new();
        write_glb(&Output::default(), &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        assert!(bin.is_empty());
        assert!(json.get("accessors").is_none() && json.get("buffers").is_none());
        assert_eq!(json["scenes"].as_array().map(Vec::len), Some(1));
    }

    #[test]
    fn static_output_has_no_animation_and_a_camera_alone_is_not_skinned() {
        use mdg_vm::output::{Camera, Track};
        let mut b = Vec::new();
        write_glb(&sample_output(), &mut b).expect("writes");
        let (json, _) = parse_glb(&b);
        for key in ["skins", "animations", "cameras"] {
            assert!(json.get(key).is_none(), "{key} in a static output");
        }
        let mut out = sample_output();
        let frames = (0..4).map(|k| Frame::identity().rotate(Quat::from_rotation_z(k as f32))).collect();
        out.animation.duration = 1.0;
        out.animation.tracks.push(Track { rule: "C".into(), frames, complete: true });
        out.animation.camera = Some(Camera { track: 0, fps: 4.0, fov: 60.0, near: 0.5, far: 0.1 });
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        assert!(json.get("skins").is_none());
        // A far plane not beyond the near plane is left out (an infinite projection).
        let persp = &json["cameras"][0]["perspective"];
        assert_eq!(persp["yfov"].as_f64().map(|v| v as f32), Some(60f32.to_radians()));
        assert_eq!(persp["znear"].as_f64(), Some(0.5));
        assert!(persp.get("zfar").is_none());
        let sampler = &json["animations"][0]["samplers"][0];
        assert_eq!(sampler["interpolation"], "STEP");
        // Keys at 0, 1/4, …, 1 s: frames 0..=4, the 4-frame track wrapping at 4.
        assert_eq!(floats(&bin, &json, sampler["input"].as_u64().expect("input")), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        let rot = &json["animations"][0]["samplers"][1];
        let q = floats(&bin, &json, rot["output"].as_u64().expect("output"));
        assert!((q[19] - q[3]).abs() < 1e-6 && (q[18] - q[2]).abs() < 1e-6, "key 4 is frame 0 again");
    }

    #[test]
    fn trs_decomposition() {
        let m = Mat4::from_scale_rotation_translation(
            Vec3::splat(0.5),
            Quat::from_rotation_z(1.0),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let (t, r, s) = orthogonal_trs(&m).expect("similarity");
        assert!((s - Vec3::splat(0.5)).length() < 1e-6 && (t - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        assert!(r.dot(Quat::from_rotation_z(1.0)).abs() > 1.0 - 1e-6);
        // A scale along the object's own (rotated) axes is a TRS too.
        let m = Mat4::from_scale_rotation_translation(Vec3::new(2.0, 0.5, 1.0), Quat::from_rotation_z(0.7), Vec3::X);
        let (t, r, s) = orthogonal_trs(&m).expect("rotation times axis scale");
        let back = Mat4::from_scale_rotation_translation(s, r, t);
        assert!(back.abs_diff_eq(m, 1e-5), "{back:?} vs {m:?}");
        assert!(orthogonal_trs(&Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0))).is_some());
        // A scale along world axes after a rotation shears the object's axes: baked.
        let sheared = Mat4::from_scale(Vec3::new(3.0, 1.0, 1.0)) * Mat4::from_rotation_z(0.7);
        assert!(orthogonal_trs(&sheared).is_none());
        assert!(orthogonal_trs(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))).is_none());
        assert!(orthogonal_trs(&Mat4::from_scale(Vec3::ZERO)).is_none());
    }
}
