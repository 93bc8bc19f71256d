//! Scenes of named parts (a creature: one node per placed part) as a node
//! hierarchy: each part hangs from the part it is attached to, with its transform
//! local to it, so moving a torso in an editor moves everything attached to it.
//! Every part mesh is written once and has a material named after it.

use super::Y_UP_ROTATION;
use super::{
    finite3, mirrored_copy, orthogonal_trs, place_mesh, Builder, FlatSource, GMesh, Material, Node, Pbr, Scene,
};
use crate::ExportError;
use glam::{Mat4, Vec3};
use mdg_vm::output::Mesh;
use std::collections::BTreeMap;

/// One node of a [`write_glb_nodes`] scene: shared mesh `mesh` placed by
/// `transform` (model space: rotation, uniform scale, translation; may be
/// mirrored), hanging from node `parent` (an index into the scene's nodes, lower
/// than its own) or, for `None`, from the scene's root node.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshNode {
    pub name: String,
    pub mesh: u32,
    pub transform: Mat4,
    pub parent: Option<u32>,
}

/// Writes a scene of named nodes, each placing one of `meshes` — a model made of
/// parts. Every mesh is written once, in its own coordinates with its vertex
/// colours, with a material named after it (`meshes[i].0`), and shared by the
/// nodes that place it; a mirrored placement refers to a copy mirrored in x
/// (written once per mesh, mesh `NAME mirrored`, the same material), so every node
/// has a proper TRS. Each node's TRS is local to its parent node (the parent's
/// node matrix is its placement, made proper); a placement that is not a
/// similarity relative to its parent is baked into a mesh of its own, in the
/// parent's space. The top nodes are children of one root node named `root` that
/// turns MDG's z up into glTF's y up.
pub fn write_glb_nodes(
    root: &str,
    meshes: &[(String, Mesh)],
    nodes: &[MeshNode],
    w: &mut dyn std::io::Write,
) -> Result<(), ExportError> {
    let mut g = Builder::default();
    let mut gltf_meshes: BTreeMap<(u32, bool), u32> = BTreeMap::new();
    let mut materials: BTreeMap<(u32, bool), u32> = BTreeMap::new();
    // Each node's node matrix in model space.
    let mut world: Vec<Mat4> = Vec::with_capacity(nodes.len());
    let mut index: Vec<Option<usize>> = Vec::with_capacity(nodes.len());
    // The nodes written, each with the position in `out` of its parent.
    let mut out: Vec<(Node, Option<usize>)> = Vec::new();
    for (i, n) in nodes.iter().enumerate() {
        let Some((name, mesh)) = meshes.get(n.mesh as usize) else {
            return Err(ExportError::NoMesh { node: n.name.clone(), mesh: n.mesh });
        };
        let parent = match n.parent {
            Some(p) if (p as usize) < i => Some(p as usize),
            Some(p) => return Err(ExportError::ParentOrder { node: n.name.clone(), parent: p }),
            None => None,
        };
        let parent_world = parent.and_then(|p| world.get(p).copied()).unwrap_or(Mat4::IDENTITY);
        // Where node i's children hang: its own glTF node, or (a node without
        // triangles has none) where it would have hung.
        let glb_parent = parent.and_then(|p| index.get(p).copied().flatten());
        let mirrored = glam::Mat3::from_mat4(n.transform).determinant() < 0.0;
        let proper = if mirrored { n.transform * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) } else { n.transform };
        let local = parent_world.inverse() * proper;
        let (node, node_world) = match orthogonal_trs(&local) {
            Some((t, r, s)) => {
                let m = match gltf_meshes.get(&(n.mesh, mirrored)) {
                    Some(&m) => m,
                    None => {
                        let src =
                            if mirrored { FlatSource::Owned(mirrored_copy(mesh)) } else { FlatSource::Mesh(mesh) };
                        let what = if mirrored { format!("{name} mirrored") } else { name.clone() };
                        let Some(m) = part_mesh(&mut g, &mut materials, src, what, name, n.mesh)? else {
                            world.push(parent_world);
                            index.push(glb_parent);
                            continue;
                        };
                        gltf_meshes.insert((n.mesh, mirrored), m);
                        m
                    }
                };
                let node = Node {
                    name: Some(n.name.clone()),
                    mesh: Some(m),
                    translation: Some(finite3(t.to_array())),
                    rotation: Some(r.to_array()),
                    scale: Some(finite3(s.to_array())),
                    ..Node::default()
                };
                (node, proper)
            }
            None => {
                // The part keeps its own colours, placed in its parent's space.
                let mut baked = Mesh::default();
                let rel = parent_world.inverse() * n.transform;
                let rel_mirrored = glam::Mat3::from_mat4(rel).determinant() < 0.0;
                place_mesh(&mut baked, mesh, &rel, None, rel_mirrored, 0);
                let what = format!("{name} baked");
                let Some(m) = part_mesh(&mut g, &mut materials, FlatSource::Owned(baked), what, name, n.mesh)? else {
                    world.push(parent_world);
                    index.push(glb_parent);
                    continue;
                };
                (Node { name: Some(n.name.clone()), mesh: Some(m), ..Node::default() }, parent_world)
            }
        };
        world.push(node_world);
        index.push(Some(out.len()));
        out.push((node, glb_parent));
    }
    // Children lists, then the nodes: glTF indices are `base + position in out`.
    let base = g.root.nodes.len() as u32;
    let mut top = Vec::new();
    let mut children: Vec<Vec<u32>> = vec![Vec::new(); out.len()];
    for (me, (_, parent)) in out.iter().enumerate() {
        match parent.and_then(|p| children.get_mut(p)) {
            Some(c) => c.push(base + me as u32),
            None => top.push(base + me as u32),
        }
    }
    for ((node, _), kids) in out.into_iter().zip(children) {
        g.push_node(Node { children: kids, ..node });
    }
    let mut scene = Vec::new();
    if !top.is_empty() {
        scene.push(g.push_node(Node {
            name: Some(root.to_string()),
            rotation: Some(Y_UP_ROTATION),
            children: top,
            ..Node::default()
        }));
    }
    g.root.scenes.push(Scene { nodes: scene });
    g.finish(w)
}

/// Writes part `name`'s triangles `src` as glTF mesh `what` with one primitive and
/// the part's named material ([`named_material`]); `None` when `src` has no
/// triangles. The one way both a shared part mesh and a baked one are written.
fn part_mesh<'a>(
    g: &mut Builder<'a>,
    materials: &mut BTreeMap<(u32, bool), u32>,
    src: FlatSource<'a>,
    what: String,
    name: &str,
    mesh: u32,
) -> Result<Option<u32>, ExportError> {
    let before = g.root.materials.len();
    let Some(mut p) = g.colored_primitive(src, &what)? else {
        return Ok(None);
    };
    let fresh = g.root.materials.len() > before;
    p.material = Some(named_material(g, materials, fresh, name, mesh, p.material));
    Ok(Some(g.push_mesh(GMesh { name: Some(what), primitives: vec![p] })))
}

/// The material of part mesh `mesh`, named after it (`name`): the primitive's own
/// material `like` when [`Builder::colored_primitive`] has just made it for this
/// primitive (it is then taken out of the shared colour cache), else a new one with
/// its base colour and sidedness; one per (part, sidedness).
fn named_material(
    g: &mut Builder,
    made: &mut BTreeMap<(u32, bool), u32>,
    fresh: bool,
    name: &str,
    mesh: u32,
    like: Option<u32>,
) -> u32 {
    let double_sided = like.and_then(|m| g.root.materials.get(m as usize)).is_some_and(|m| m.double_sided);
    if let Some(&m) = made.get(&(mesh, double_sided)) {
        // The material just made for this primitive is not needed: only it uses it.
        if let (true, Some(fresh)) = (fresh, like) {
            if fresh as usize + 1 == g.root.materials.len() {
                g.root.materials.pop();
                g.materials.retain(|_, v| *v != fresh);
            }
        }
        return m;
    }
    let taken = made.keys().any(|(k, _)| *k == mesh);
    let name = if taken { format!("{name} double-sided") } else { name.to_string() };
    let m = match like {
        Some(m) if fresh => {
            g.materials.retain(|_, v| *v != m);
            if let Some(mat) = g.root.materials.get_mut(m as usize) {
                mat.name = Some(name);
            }
            m
        }
        _ => {
            let (base_color_factor, roughness_factor) = like
                .and_then(|m| g.root.materials.get(m as usize))
                .map(|m| (m.pbr_metallic_roughness.base_color_factor, m.pbr_metallic_roughness.roughness_factor))
                .unwrap_or(([1.0; 4], 0.6));
            g.root.materials.push(Material {
                name: Some(name),
                pbr_metallic_roughness: Pbr { base_color_factor, metallic_factor: 0.0, roughness_factor },
                double_sided,
            });
            g.root.materials.len() as u32 - 1
        }
    };
    made.insert((mesh, double_sided), m);
    m
}
