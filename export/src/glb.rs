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

mod anim;
mod builder;
mod flat;
mod geometry;
mod instanced;
mod memo;
mod nodes;
mod plain;
#[cfg(test)]
pub(crate) mod tests;
use builder::*;
use flat::{flat_plan, flat_stride, flat_write, FlatPlan, FlatSource, ProtoInfos};
use instanced::*;
pub use instanced::{prototype_placement, MAX_COLOR_VARIANTS};
pub use nodes::{write_glb_nodes, MeshNode};

use std::collections::BTreeMap;

use glam::{Mat4, Quat, Vec3};
use serde::Serialize;

use super::sites::{self, Baked};
use super::ExportError;
use super::{checked_triangles, clamp_color, color_at, finite, finite3, is_closed, linear_color, normal_at};
use mdg_vm::anim::{frames_needed, trs};
use mdg_vm::geom::quat::Frame;
use mdg_vm::output::{
    expand_prototype, place_mesh, Animation, Groups, Mesh, Output, Piece, Polyline, SharedKind, SharedMesh, VertexRun,
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
    write_glb_spooling(out, opts, None, w)
}

/// [`write_glb_with`], spooling flat primitives of at most `spool_bytes` bytes
/// (`None`: [`SPOOL_BYTES`]) and streaming bigger ones: both give the same bytes.
fn write_glb_spooling(
    out: &Output,
    opts: &GlbOptions,
    spool_bytes: Option<usize>,
    w: &mut dyn std::io::Write,
) -> Result<(), ExportError> {
    let anim = &out.animation;
    let skinned = anim.bones.len() > 1;
    if anim.bones.len() > MAX_GLTF_BONES {
        return Err(ExportError::TooManyBones { bones: anim.bones.len(), max: MAX_GLTF_BONES });
    }
    // Prototype instances that become instanced nodes (with --instances); the rest
    // are expanded into the geometry where they were made.
    let gpu = if opts.instances { gpu_instance_groups(out, skinned) } else { GpuGroups::default() };

    let (baked, as_nodes) = isosurface_placements(out, &gpu);

    // The flat geometry (the VERTEX group, the sweeps, the baked instances) is
    // streamed into the file when it is written: the binary chunk holds no copy of it.
    let mut g = Builder { skinned, spool_bytes, ..Builder::default() };
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

    g.instance_nodes(out, as_nodes, &bone_nodes, &mut scene_nodes)?;

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

/// An isosurface instance placed by a node of its own: its index, the instance,
/// its TRS and whether it places the shared mesh's copy mirrored in x.
type NodePlacement = (u32, mdg_vm::output::Instance, (Vec3, Quat, Vec3), bool);

/// The isosurface instances not in `gpu`'s instanced nodes, split into ones that
/// can be nodes and ones that must be baked (into the returned [`Baked`]).
fn isosurface_placements(out: &Output, gpu: &GpuGroups) -> (Baked, Vec<NodePlacement>) {
    // Split isosurface instances into ones that can be nodes and ones that must be
    // baked. A mirrored similarity is a node too: its transform times a mirror in x
    // is a proper TRS, placed over a copy of the shared mesh mirrored in x (one copy
    // per mesh).
    let mut baked = Baked::default();
    let mut as_nodes = Vec::new();
    // (By spans of one shared mesh: a prototype's instances are passed over whole.)
    let frames = out.instances.packed_frames();
    for span in out.instances.spans() {
        let Some(shared) = out.shared_meshes.get(span.mesh as usize).filter(|s| !s.is_prototype()) else { continue };
        if shared.mesh.triangles.is_empty() {
            continue;
        }
        for i in span.range.clone() {
            let Some(frame) = frames.get(i).filter(|_| !gpu.instanced.get(i).copied().unwrap_or(false)) else {
                continue;
            };
            let inst = span.instance(frame);
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

    (baked, as_nodes)
}

impl<'a> Builder<'a> {
    /// A node for each isosurface instance of `as_nodes`, under its bone's node (an
    /// animated bone's) or in `scene_nodes`; each shared mesh's accessors written once
    /// (and its mirrored copy's), one glTF mesh per (shared mesh, mirrored, colour).
    fn instance_nodes(
        &mut self,
        out: &Output,
        as_nodes: Vec<NodePlacement>,
        bone_nodes: &[u32],
        scene_nodes: &mut Vec<u32>,
    ) -> Result<(), ExportError> {
        let g = self;
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
        Ok(())
    }
}

/// The fields of an instance record the writer reads, by value. Every read of
/// [`Output::instances`] in the instanced writer and the flat walks goes through
/// [`record`] or [`records`], so that a change of the record's layout touches one place.
#[derive(Clone, Copy)]
struct Record {
    frame: Frame,
    color: [f32; 4],
    mesh: u32,
    bone: u32,
    lin: u32,
    at: u32,
}

impl Record {
    /// The instance again, for [`expand_prototype`].
    fn instance(&self) -> mdg_vm::output::Instance {
        let Record { frame, color, mesh, bone, lin, at } = *self;
        mdg_vm::output::Instance { frame, color, mesh, bone, lin, at }
    }
}

#[inline(always)]
fn record_of(inst: &mdg_vm::output::Instance) -> Record {
    Record { frame: inst.frame, color: inst.color, mesh: inst.mesh, bone: inst.bone, lin: inst.lin, at: inst.at }
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
    /// The largest flat primitive spooled (`None`: [`SPOOL_BYTES`]).
    spool_bytes: Option<usize>,
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
