//! Tests of the `.glb` writer: the container, accessors and bounds, colours,
//! instances as nodes and with `--instances`, skins, animation and the spool.

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
    let (size, read): (usize, fn(&[u8]) -> f64) = match a["componentType"].as_u64().expect("component type") as u32 {
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
    assert!(count == 0 || start + (count - 1) * stride + width * size <= end, "accessor {accessor} overruns its view");
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
    for p in json["meshes"].as_array().expect("meshes").iter().flat_map(|m| m["primitives"].as_array().expect("prims"))
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
    let names: Vec<&str> = json["nodes"].as_array().expect("nodes").iter().filter_map(|n| n["name"].as_str()).collect();
    assert_eq!(names, vec!["geometry", "BIG", "mdg z-up"]);
}

#[test]
fn skins_have_identity_inverse_bind_matrices() {
    use mdg_vm::output::{Bone, Track};
    let mut out = sample_output();
    let frames = (0..4).map(|k| Frame::identity().rotate(Quat::from_rotation_z(k as f32))).collect();
    out.animation.duration = 1.0;
    out.animation.tracks.push(Track { rule: "X".into(), frames, complete: true });
    let bone =
        |rule: &str, tracks: Vec<u32>| Bone { rule: rule.into(), parent: 0, rest: Frame::identity(), fps: 4.0, tracks };
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
    let names: Vec<&str> = scene.iter().map(|&n| json["nodes"][n as usize]["name"].as_str().expect("name")).collect();
    assert_eq!(names, vec!["mdg z-up", "geometry", "lines"]);
}

#[test]
fn a_search_s_guides_and_bones_get_nodes_of_their_own() {
    let mut out = sample_output();
    let line =
        |ns: &str, x: f32| Polyline { namespace: ns.into(), points: vec![[x, 0.0, 0.0], [x, 1.0, 0.0]], bones: vec![] };
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
    let m =
        Mat4::from_scale_rotation_translation(Vec3::splat(0.5), Quat::from_rotation_z(1.0), Vec3::new(1.0, 2.0, 3.0));
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

/// Square prototype instances (two triangles) in frames of every turn, size and
/// mirroring, each of its own colour, placed by `--instances`.
fn coloured_square_instances(n: usize) -> Output {
    let mut out = Output::default();
    let mut square = Mesh::default();
    for [x, y] in [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]] {
        square.push_vertex(Vec3::new(x, y, 0.0), Vec3::Z, [0.0; 4], [0.0; 4], 0);
    }
    square.push_triangle([0, 1, 2], false);
    square.push_triangle([3, 4, 5], false);
    let kind = mdg_vm::output::SharedKind::Prototype { face_normals: vec![None; 2] };
    out.shared_meshes.push(SharedMesh { name: "square".into(), mesh: square, kind });
    for i in 0..n {
        let k = i as f32;
        let mut f = Frame::identity()
            .translate(Vec3::new(k, 0.5 * k, -0.25 * k))
            .rotate(Quat::from_axis_angle(Vec3::new(1.0, k, 2.0).normalize(), 0.7 * k))
            .scale(0.5 + 0.1 * k);
        if i % 3 == 1 {
            f = f.reflect(Vec3::X);
        }
        let color = [k / n as f32, 0.5, 1.0 - k / n as f32, 1.0];
        out.instances.push(mdg_vm::output::Instance { frame: f, color, mesh: 0, bone: 0, lin: 0, at: 0 });
    }
    out
}

#[test]
fn instance_trs_share_one_strided_view_and_colours_have_their_own() {
    // One pass writes each instance's TRANSLATION, ROTATION and SCALE side by side;
    // `_COLOR_0` stays tightly packed in a view of its own (three.js reads its array
    // whole). The values are `prototype_placement`'s, bit for bit.
    let out = coloured_square_instances(12);
    let mut b = Vec::new();
    write_glb_with(&out, &GlbOptions { instances: true }, &mut b).expect("writes");
    let (json, bin) = parse_glb(&b);
    let mut seen = 0;
    for node in json["nodes"].as_array().expect("nodes") {
        let Some(attrs) = node.pointer("/extensions/EXT_mesh_gpu_instancing/attributes") else { continue };
        let acc = |name: &str| attrs[name].as_u64().expect("attribute");
        let view_of = |a: u64| json["accessors"][a as usize]["bufferView"].as_u64().expect("view");
        let (t, r, s, c) = (acc("TRANSLATION"), acc("ROTATION"), acc("SCALE"), acc("_COLOR_0"));
        assert!(view_of(t) == view_of(r) && view_of(r) == view_of(s), "TRS in one view");
        assert_eq!(json["bufferViews"][view_of(t) as usize]["byteStride"].as_u64(), Some(40));
        let offsets: Vec<u64> =
            [t, r, s].iter().map(|&a| json["accessors"][a as usize]["byteOffset"].as_u64().unwrap_or(0)).collect();
        assert_eq!(offsets, [0, 12, 28]);
        assert_ne!(view_of(c), view_of(t));
        assert!(json["bufferViews"][view_of(c) as usize].get("byteStride").is_none(), "colours tightly packed");
        let mirrored = node["name"].as_str().expect("name").ends_with("mirrored");
        let mine: Vec<usize> = (0..out.instances.len()).filter(|i| (i % 3 == 1) == mirrored).collect();
        let (tv, rv, sv, cv) = (
            components(&bin, &json, t),
            components(&bin, &json, r),
            components(&bin, &json, s),
            components(&bin, &json, c),
        );
        assert_eq!(tv.len(), 3 * mine.len());
        for (k, &i) in mine.iter().enumerate() {
            let inst = out.instances.get(i).expect("instance");
            let (pt, pr, ps) = prototype_placement(&inst.frame).expect("placeable");
            let f = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
            assert_eq!(f(&tv[3 * k..3 * k + 3]), pt.to_vec(), "instance {i}: translation");
            assert_eq!(f(&rv[4 * k..4 * k + 4]), pr.to_vec(), "instance {i}: rotation");
            assert_eq!(f(&sv[3 * k..3 * k + 3]), ps.map(f32::abs).to_vec(), "instance {i}: scale");
            let want = linear_color(clamp_color(inst.color));
            assert_eq!(f(&cv[3 * k..3 * k + 3]), want[..3].to_vec(), "instance {i}: colour");
        }
        seen += mine.len();
    }
    assert_eq!(seen, 12, "every instance placed by an instanced node");
}

#[test]
fn spooled_and_streamed_flat_primitives_are_the_same_bytes() {
    // A flat primitive up to the spool's size is placed once, its bounds found while
    // it is written to the spool; a bigger one is planned by a walk and streamed.
    // Both give the same file, for the usual layout and for those the guess from the
    // counts gets wrong (16-bit colours, triangles that need indices), prototypes
    // mirrored or not, skinned or not.
    let mut outputs = vec![
        ("instances", coloured_square_instances(40)),
        ("dark", strip([0.01, 0.02, 0.5, 1.0])),
        ("sample", sample_output()),
    ];
    let mut shared = strip([0.8, 0.3, 0.1, 1.0]);
    shared.mesh.triangles[1] = [0, 1, 2];
    outputs.push(("indexed", shared));
    let mut dark_instances = coloured_square_instances(9);
    let mut all: Vec<_> = dark_instances.instances.iter().collect();
    all[4].color = [0.002, 0.0, 0.0, 1.0];
    dark_instances.instances = Default::default();
    for inst in all {
        dark_instances.instances.push(inst);
    }
    outputs.push(("dark instances", dark_instances));
    for (name, out) in outputs {
        let (mut spooled, mut streamed) = (Vec::new(), Vec::new());
        write_glb_spooling(&out, &GlbOptions::default(), None, &mut spooled).expect("writes");
        write_glb_spooling(&out, &GlbOptions::default(), Some(0), &mut streamed).expect("writes");
        assert!(spooled == streamed, "{name}: the spooled and streamed files differ");
        let (json, _) = parse_glb(&spooled);
        assert!(json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].is_u64(), "{name}: no geometry");
    }
}
