//! glTF 2.0 binary (`.glb`) writer, by hand: a JSON chunk built with serde and one
//! binary buffer.
//!
//! # Layout
//!
//! * Node `geometry` (mesh `mdg`): one primitive each for the `VERTEX` triangles, the
//!   sweeps and the *baked* instances, with POSITION, NORMAL, COLOR_0 (float RGBA,
//!   clamped to 0..1) and u32 indices. Empty groups are left out (glTF forbids
//!   accessors with no elements).
//! * Node `lines` (mesh `lines`): the pen polylines as one `LINES` primitive.
//! * Each shared mesh's positions, normals and indices are written once. Every
//!   instance is a node with translation/rotation/scale referring to a glTF mesh
//!   that reuses those accessors with a material of the instance's colour (one glTF
//!   mesh per distinct (shared mesh, colour) pair; the colour replaces the shared
//!   mesh's vertex colours, as in [`Output::flattened`]).
//! * Instances that are mirrored, degenerate or not a similarity are baked into the
//!   geometry instead: a node transform must decompose into TRS, and validators and
//!   viewers disagree on negative scales.
//!
//! Nodes use TRS rather than `matrix` because glTF only lets TRS nodes be animation
//! targets: a later animation section adds an `animations` array (samplers reading
//! accessors from the same buffer) without changing anything written here.
//! All numbers are written as f32 with serde_json's shortest round-trip form, and
//! every map is ordered, so the bytes are a deterministic function of the output.

use std::collections::BTreeMap;

use glam::{Mat4, Quat, Vec3};
use serde::Serialize;

use super::{bake_instance, checked_triangles, clamp_color, color_at, finite3, normal_at};
use crate::output::{Mesh, Output};

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const MODE_LINES: u32 = 1;
const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Appends `out` as a glTF 2.0 binary to `buf`.
pub fn write_glb(out: &Output, buf: &mut Vec<u8>) -> Result<(), String> {
    let mut g = Builder::default();
    let mut scene_nodes = Vec::new();

    // Split instances into ones that can be nodes and ones that must be baked.
    let mut baked = Mesh::default();
    let mut as_nodes = Vec::new();
    for inst in &out.instances {
        let Some((_, shared)) = out.shared_meshes.get(inst.mesh as usize) else { continue };
        if shared.triangles.is_empty() {
            continue;
        }
        match similarity_trs(&inst.transform) {
            Some(trs) if !inst.mirrored => as_nodes.push((inst, trs)),
            _ => bake_instance(&mut baked, shared, inst),
        }
    }

    let mut primitives = Vec::new();
    for (m, what) in [(&out.mesh, "VERTEX mesh"), (&out.sweeps, "sweeps"), (&baked, "baked instances")] {
        if let Some(p) = g.colored_primitive(m, what)? {
            primitives.push(p);
        }
    }
    if !primitives.is_empty() {
        let mesh = g.push_mesh(GMesh { name: Some("mdg".into()), primitives });
        scene_nodes.push(g.push_node(Node { name: Some("geometry".into()), mesh: Some(mesh), ..Node::default() }));
    }

    if let Some(p) = g.lines_primitive(out) {
        let mesh = g.push_mesh(GMesh { name: Some("lines".into()), primitives: vec![p] });
        scene_nodes.push(g.push_node(Node { name: Some("lines".into()), mesh: Some(mesh), ..Node::default() }));
    }

    let mut shared_accessors: BTreeMap<u32, SharedAccessors> = BTreeMap::new();
    let mut instance_meshes: BTreeMap<(u32, [u32; 4]), u32> = BTreeMap::new();
    for (inst, (t, r, s)) in as_nodes {
        let acc = match shared_accessors.get(&inst.mesh) {
            Some(a) => *a,
            None => {
                let Some((name, shared)) = out.shared_meshes.get(inst.mesh as usize) else { continue };
                let a = g.shared_accessors(shared, name)?;
                shared_accessors.insert(inst.mesh, a);
                a
            }
        };
        let color = clamp_color(inst.color);
        let key = (inst.mesh, color.map(f32::to_bits));
        let mesh = match instance_meshes.get(&key) {
            Some(m) => *m,
            None => {
                let material = g.material(color);
                let name = out.shared_meshes.get(inst.mesh as usize).map(|(n, _)| n.clone());
                let mut attributes = BTreeMap::new();
                attributes.insert("POSITION", acc.position);
                attributes.insert("NORMAL", acc.normal);
                let prim = Primitive { attributes, indices: Some(acc.indices), material: Some(material), mode: None };
                let m = g.push_mesh(GMesh { name, primitives: vec![prim] });
                instance_meshes.insert(key, m);
                m
            }
        };
        let node = Node {
            name: Some(inst.name.clone()),
            mesh: Some(mesh),
            translation: Some(t.to_array()),
            rotation: Some(r.to_array()),
            scale: Some([s; 3]),
        };
        scene_nodes.push(g.push_node(node));
    }

    g.root.scenes.push(Scene { nodes: scene_nodes });
    g.finish(buf)
}

/// Accessors of one shared mesh, written once and used by all its instances.
#[derive(Clone, Copy)]
struct SharedAccessors {
    position: u32,
    normal: u32,
    indices: u32,
}

/// Translation, rotation and uniform scale of a proper similarity transform, or
/// `None` when the matrix is mirrored, degenerate, non-finite, sheared or
/// non-uniformly scaled (relative tolerance 1e-3).
fn similarity_trs(m: &Mat4) -> Option<(Vec3, Quat, f32)> {
    if !m.is_finite() || m.row(3).truncate().length_squared() != 0.0 || m.row(3).w != 1.0 {
        return None;
    }
    let (a, b, c) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let s = (la + lb + lc) / 3.0;
    if s.is_nan() || s <= 1e-12 || a.dot(b.cross(c)) <= 0.0 {
        return None;
    }
    let tol = 1e-3 * s;
    if (la - s).abs() > tol || (lb - s).abs() > tol || (lc - s).abs() > tol {
        return None;
    }
    let tol2 = 1e-3 * s * s;
    if a.dot(b).abs() > tol2 || b.dot(c).abs() > tol2 || c.dot(a).abs() > tol2 {
        return None;
    }
    let rot = Quat::from_mat3(&glam::Mat3::from_cols(a / la, b / lb, c / lc)).normalize();
    Some((m.w_axis.truncate(), rot, s))
}

/// The document plus the binary buffer under construction.
#[derive(Default)]
struct Builder {
    root: Root,
    bin: Vec<u8>,
    materials: BTreeMap<[u32; 4], u32>,
}

impl Builder {
    /// Appends `bytes` (4-byte aligned) as a buffer view and returns its index.
    fn view(&mut self, bytes: &[u8], target: u32) -> u32 {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.buffer_views.push(BufferView { buffer: 0, byte_offset: offset, byte_length: bytes.len(), target: Some(target) });
        self.root.buffer_views.len() as u32 - 1
    }

    fn accessor(&mut self, a: Accessor) -> u32 {
        self.root.accessors.push(a);
        self.root.accessors.len() as u32 - 1
    }

    /// A VEC3 float vertex attribute, with min/max when `bounds`.
    fn vec3(&mut self, data: &[[f32; 3]], bounds: bool) -> u32 {
        let bytes: Vec<u8> = data.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        let (min, max) = if bounds {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for p in data {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            (Some(lo.to_vec()), Some(hi.to_vec()))
        } else {
            (None, None)
        };
        self.accessor(Accessor { buffer_view: view, component_type: FLOAT, count: data.len(), kind: "VEC3", min, max })
    }

    /// A VEC4 float vertex attribute.
    fn vec4(&mut self, data: &[[f32; 4]]) -> u32 {
        let bytes: Vec<u8> = data.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ARRAY_BUFFER);
        self.accessor(Accessor { buffer_view: view, component_type: FLOAT, count: data.len(), kind: "VEC4", min: None, max: None })
    }

    /// A u32 index list.
    fn indices(&mut self, data: &[u32]) -> u32 {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, ELEMENT_ARRAY_BUFFER);
        self.accessor(Accessor { buffer_view: view, component_type: UNSIGNED_INT, count: data.len(), kind: "SCALAR", min: None, max: None })
    }

    /// The material for a base colour (already clamped), created on first use.
    fn material(&mut self, color: [f32; 4]) -> u32 {
        let key = color.map(f32::to_bits);
        if let Some(&m) = self.materials.get(&key) {
            return m;
        }
        // Dielectric: the glTF default material is fully metallic, which renders
        // vertex colours nearly black in most viewers.
        self.root.materials.push(Material {
            pbr_metallic_roughness: Pbr { base_color_factor: color, metallic_factor: 0.0, roughness_factor: 0.6 },
        });
        let m = self.root.materials.len() as u32 - 1;
        self.materials.insert(key, m);
        m
    }

    /// A triangle primitive with vertex colours for `m` (world space), or `None` when
    /// it has no triangles.
    fn colored_primitive(&mut self, m: &Mesh, what: &str) -> Result<Option<Primitive>, String> {
        let tris = checked_triangles(m, what)?;
        if tris.is_empty() {
            return Ok(None);
        }
        let n = m.positions.len();
        let positions: Vec<[f32; 3]> = m.positions.iter().map(|p| finite3(*p)).collect();
        let normals: Vec<[f32; 3]> = (0..n).map(|i| normal_at(m, i)).collect();
        let colors: Vec<[f32; 4]> = (0..n).map(|i| color_at(m, i)).collect();
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3(&positions, true));
        attributes.insert("NORMAL", self.vec3(&normals, false));
        attributes.insert("COLOR_0", self.vec4(&colors));
        let flat: Vec<u32> = tris.iter().flatten().copied().collect();
        let indices = Some(self.indices(&flat));
        let material = Some(self.material([1.0; 4]));
        Ok(Some(Primitive { attributes, indices, material, mode: None }))
    }

    /// Positions, normals and indices of a shared mesh in its own space.
    fn shared_accessors(&mut self, m: &Mesh, name: &str) -> Result<SharedAccessors, String> {
        let tris = checked_triangles(m, &format!("shared mesh {name}"))?;
        let n = m.positions.len();
        let positions: Vec<[f32; 3]> = m.positions.iter().map(|p| finite3(*p)).collect();
        let normals: Vec<[f32; 3]> = (0..n).map(|i| normal_at(m, i)).collect();
        let position = self.vec3(&positions, true);
        let normal = self.vec3(&normals, false);
        let flat: Vec<u32> = tris.iter().flatten().copied().collect();
        let indices = self.indices(&flat);
        Ok(SharedAccessors { position, normal, indices })
    }

    /// All polylines with two or more points as one `LINES` primitive.
    fn lines_primitive(&mut self, out: &Output) -> Option<Primitive> {
        let mut positions = Vec::new();
        let mut indices = Vec::new();
        for line in out.lines.iter().filter(|l| l.points.len() >= 2) {
            let base = positions.len() as u32;
            positions.extend(line.points.iter().map(|p| finite3(*p)));
            for k in 0..line.points.len() as u32 - 1 {
                indices.extend([base + k, base + k + 1]);
            }
        }
        if indices.is_empty() {
            return None;
        }
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3(&positions, true));
        let indices = Some(self.indices(&indices));
        let material = Some(self.material([1.0; 4]));
        Some(Primitive { attributes, indices, material, mode: Some(MODE_LINES) })
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
    fn finish(mut self, buf: &mut Vec<u8>) -> Result<(), String> {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        if !self.bin.is_empty() {
            self.root.buffers.push(Buffer { byte_length: self.bin.len() });
        }
        let mut json = serde_json::to_vec(&self.root).map_err(|e| format!("glTF JSON: {e}"))?;
        json.resize(json.len().next_multiple_of(4), b' ');
        let bin_chunk = if self.bin.is_empty() { 0 } else { 8 + self.bin.len() };
        let total = 12 + 8 + json.len() + bin_chunk;
        let total = u32::try_from(total).map_err(|_| format!("glTF binary of {total} bytes exceeds the 4 GiB GLB limit"))?;
        buf.reserve(total as usize);
        buf.extend_from_slice(GLB_MAGIC);
        buf.extend_from_slice(&2u32.to_le_bytes());
        buf.extend_from_slice(&total.to_le_bytes());
        buf.extend_from_slice(&(json.len() as u32).to_le_bytes());
        buf.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        buf.extend_from_slice(&json);
        if !self.bin.is_empty() {
            buf.extend_from_slice(&(self.bin.len() as u32).to_le_bytes());
            buf.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            buf.extend_from_slice(&self.bin);
        }
        Ok(())
    }
}

// The glTF JSON schema subset written here. Empty arrays are omitted because glTF
// requires every array that is present to be non-empty.

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Root {
    asset: Asset,
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
}

impl Default for Root {
    fn default() -> Self {
        Root {
            asset: Asset { version: "2.0", generator: "mdg" },
            scene: 0,
            scenes: Vec::new(),
            nodes: Vec::new(),
            meshes: Vec::new(),
            materials: Vec::new(),
            accessors: Vec::new(),
            buffer_views: Vec::new(),
            buffers: Vec::new(),
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
}

#[derive(Serialize)]
struct GMesh {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    primitives: Vec<Primitive>,
}

#[derive(Serialize)]
struct Primitive {
    attributes: BTreeMap<&'static str, u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    indices: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    material: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mode: Option<u32>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Material {
    pbr_metallic_roughness: Pbr,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Pbr {
    base_color_factor: [f32; 4],
    metallic_factor: f32,
    roughness_factor: f32,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Accessor {
    buffer_view: u32,
    component_type: u32,
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
    #[serde(skip_serializing_if = "Option::is_none")]
    target: Option<u32>,
}

#[derive(Serialize)]
#[serde(rename_all = "camelCase")]
struct Buffer {
    byte_length: usize,
}

#[cfg(test)]
pub(crate) mod tests {
    use serde_json::Value;

    use super::*;
    use crate::export::tests::sample_output;

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

    fn view_bytes<'a>(bin: &'a [u8], json: &Value, accessor: u64) -> &'a [u8] {
        let a = &json["accessors"][accessor as usize];
        let v = &json["bufferViews"][a["bufferView"].as_u64().expect("view") as usize];
        let off = v["byteOffset"].as_u64().expect("offset") as usize;
        let len = v["byteLength"].as_u64().expect("length") as usize;
        &bin[off..off + len]
    }

    fn floats(bin: &[u8], json: &Value, accessor: u64) -> Vec<f32> {
        view_bytes(bin, json, accessor).chunks(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect()
    }

    fn uints(bin: &[u8], json: &Value, accessor: u64) -> Vec<u32> {
        view_bytes(bin, json, accessor).chunks(4).map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes"))).collect()
    }

    #[test]
    fn container_accessors_and_bounds() {
        let out = sample_output();
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        assert_eq!(json["asset"]["generator"], "mdg");
        assert_eq!(json["buffers"][0]["byteLength"].as_u64(), Some(bin.len() as u64));
        // geometry: VERTEX + sweeps + one baked (mirrored) instance.
        let prims = json["meshes"][0]["primitives"].as_array().expect("primitives");
        assert_eq!(prims.len(), 3);
        let vertex = &prims[0];
        let pos = vertex["attributes"]["POSITION"].as_u64().expect("position");
        assert_eq!(json["accessors"][pos as usize]["count"], 24);
        assert_eq!(json["accessors"][pos as usize]["min"], serde_json::json!([-0.5, -0.5, -0.5]));
        assert_eq!(json["accessors"][pos as usize]["max"], serde_json::json!([0.5, 0.5, 0.5]));
        let idx = vertex["indices"].as_u64().expect("indices");
        assert_eq!(json["accessors"][idx as usize]["count"], 36);
        // Every POSITION accessor's min/max match its data; normals are unit.
        for p in json["meshes"].as_array().expect("meshes").iter().flat_map(|m| m["primitives"].as_array().expect("prims")) {
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
        // Two non-mirrored instances share the CUBE accessors; each is a TRS node.
        let nodes = json["nodes"].as_array().expect("nodes");
        let cubes: Vec<&Value> = nodes.iter().filter(|n| n["name"] == "CUBE").collect();
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
        assert_eq!(json["scenes"][0]["nodes"].as_array().expect("scene").len(), nodes.len());
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
    fn trs_decomposition() {
        let m = Mat4::from_scale_rotation_translation(Vec3::splat(0.5), Quat::from_rotation_z(1.0), Vec3::new(1.0, 2.0, 3.0));
        let (t, r, s) = similarity_trs(&m).expect("similarity");
        assert!((s - 0.5).abs() < 1e-6 && (t - Vec3::new(1.0, 2.0, 3.0)).length() < 1e-6);
        assert!(r.dot(Quat::from_rotation_z(1.0)).abs() > 1.0 - 1e-6);
        assert!(similarity_trs(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))).is_none());
        assert!(similarity_trs(&Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0))).is_none());
        assert!(similarity_trs(&Mat4::from_scale(Vec3::ZERO)).is_none());
    }
}
