//! Every std example compiles, evaluates to geometry, renders a picture that is not
//! blank, and exports a `.glb` that the Khronos glTF-Validator accepts with 0 errors,
//! flat and with prototype instances as `EXT_mesh_gpu_instancing` (`mdg-run
//! --instances`), as does the benchmark tree (small) with instances.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze_text;
use mdg_compiler::source::FsLoader;
use mdg_export::glb::{write_glb_with, GlbOptions};
use mdg_tests::{analyze_file, mdg_files, options, root};
use mdg_vm::eval::{evaluate, EvalOptions};
use mdg_vm::output::Output;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn node_ready() -> Result<(), String> {
    let dir = root().join("tests/gltf");
    if !dir.join("node_modules/gltf-validator").is_dir() {
        return Err("the glTF validator is not installed: run `npm ci --prefix tests/gltf` (or bash .ci/run)".into());
    }
    Ok(())
}

#[test]
fn std_examples_evaluate_render_and_validate() {
    let tmp = std::env::temp_dir().join(format!("mdg-examples-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).expect("temp dir");
    let mut glbs = Vec::new();
    let mut instanced = Vec::new();
    let mut failures = Vec::new();
    let examples = mdg_files("std/examples");
    assert!(examples.len() >= 12);
    for path in examples {
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let a = analyze_file(&path, true);
        assert!(!a.has_errors(), "{name} does not compile");
        let bundle = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
        let out = evaluate(&bundle, &EvalOptions::default());
        let amount = out.mesh.n_vertices() + out.sweeps.n_vertices() + out.instances.len();
        if amount == 0 {
            failures.push(format!("{name}: no geometry"));
            continue;
        }
        // The preview has visible content: at least 1% of pixels differ from the background.
        let opts = mdg_vm::preview::PreviewOptions { width: 160, height: 120, ..Default::default() };
        let rgba = mdg_vm::preview::render(&out, &opts);
        let bg = out.background.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as i32);
        let differing = rgba.chunks(4).filter(|p| (0..3).any(|k| (p[k] as i32 - bg[k]).abs() > 8)).count();
        if differing * 100 < rgba.len() / 4 {
            failures
                .push(format!("{name}: the picture is nearly blank ({differing} pixels differ from the background)"));
        }
        let mut bytes = Vec::new();
        mdg_export::write(mdg_export::Format::Glb, &out, &mut bytes).expect("glb");
        let file = tmp.join(format!("{name}.glb"));
        std::fs::write(&file, bytes).expect("write");
        glbs.push(file);
        instanced.push(write_instanced(&tmp, &name, &out));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // With instances too: the benchmark tree (depth 12 here: 8,191 instances), the
    // grid of squares and every kind of prototype instance (tests/instancing/).
    let tree = root().join("benches/workloads/tree.mdg");
    let text = std::fs::read_to_string(&tree).expect("tree workload").replace("maxdepth 19", "maxdepth 12");
    let analyses = [
        ("tree_workload_12", analyze_text(&FsLoader, &tree, &text, &options(), CheckOptions { require_start: true })),
        ("grid_of_squares", analyze_file(&root().join("tests/instancing/grid_of_squares.mdg"), true)),
        ("prototypes", analyze_file(&root().join("tests/instancing/prototypes.mdg"), true)),
    ];
    for (name, a) in analyses {
        assert!(!a.has_errors(), "{name} does not compile");
        let bundle = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
        instanced.push(write_instanced(&tmp, name, &evaluate(&bundle, &EvalOptions::default())));
    }
    let problems: Vec<&String> = instanced.iter().flat_map(|i| &i.problems).collect();
    assert!(problems.is_empty(), "EXT_mesh_gpu_instancing as written:\n{problems:#?}");
    let with_extension = instanced.iter().filter(|i| i.instanced_nodes > 0).count();
    assert!(with_extension >= 10, "only {with_extension} files use EXT_mesh_gpu_instancing");
    glbs.extend(instanced.iter().map(|i| i.path.clone()));
    if std::env::var_os("MDG_SKIP_NODE_TESTS").is_some() {
        eprintln!("MDG_SKIP_NODE_TESTS set: glTF validation skipped");
        return;
    }
    node_ready().expect("glTF validator");
    let status = std::process::Command::new("node")
        .arg(root().join("tests/gltf/validate.mjs"))
        .args(&glbs)
        .output()
        .expect("run node (is Node.js installed? bash .ci/run installs it)");
    let _ = std::fs::remove_dir_all(&tmp);
    let report = String::from_utf8_lossy(&status.stdout);
    assert!(status.status.success(), "glTF validation failed:\n{report}{}", String::from_utf8_lossy(&status.stderr));
    assert_eq!(report.matches(": 0 errors").count(), glbs.len(), "{report}");
    // Warnings and infos are reported, not fatal: printed for the record. The
    // validator does not know EXT_mesh_gpu_instancing (an UNSUPPORTED_EXTENSION info)
    // and so reports the instance attributes' accessors as UNUSED_OBJECT; nothing
    // else may be unused.
    eprintln!("{report}");
    for i in &instanced {
        let file = i.path.display().to_string();
        let infos = report
            .lines()
            .skip_while(|l| !l.starts_with(&format!("{file}: ")))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .find_map(|l| l.strip_prefix("  infos: "))
            .unwrap_or("");
        let mut expected = Vec::new();
        if i.instanced_nodes > 0 {
            expected.push("UNSUPPORTED_EXTENSION ×1".to_string());
            expected.push(format!("UNUSED_OBJECT ×{}", i.instance_accessors));
        }
        assert_eq!(infos, expected.join(", "), "{file}: the validator's infos");
    }
}

/// A `.glb` written with prototype instances as `EXT_mesh_gpu_instancing`.
struct Instanced {
    path: PathBuf,
    /// Nodes with the extension.
    instanced_nodes: usize,
    /// Accessors the extension's attributes use.
    instance_accessors: usize,
    /// Where the file breaks the extension's rules (which the Khronos validator
    /// does not check: it reports the extension as unsupported).
    problems: Vec<String>,
}

/// Writes `out` as `DIR/NAME.instances.glb` with prototype instances as
/// `EXT_mesh_gpu_instancing` and checks the extension's rules in it.
fn write_instanced(dir: &Path, name: &str, out: &Output) -> Instanced {
    let mut bytes = Vec::new();
    write_glb_with(out, &GlbOptions { instances: true }, &mut bytes).expect("glb --instances");
    let path = dir.join(format!("{name}.instances.glb"));
    std::fs::write(&path, &bytes).expect("write");
    let (json, bin) = glb_chunks(&bytes);
    let (instanced_nodes, problems) = check_gpu_instancing(&json, &bin);
    let instance_accessors = json["nodes"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|n| n.pointer("/extensions/EXT_mesh_gpu_instancing/attributes")?.as_object().map(|a| a.len()))
        .sum();
    let problems = problems.into_iter().map(|p| format!("{name}: {p}")).collect();
    Instanced { path, instanced_nodes, instance_accessors, problems }
}

/// The JSON and binary chunks of a `.glb`.
fn glb_chunks(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes")) as usize;
    let json_len = u32_at(12);
    let json: Value = serde_json::from_slice(&bytes[20..20 + json_len]).expect("glTF JSON");
    let bin_at = 20 + json_len;
    let bin =
        if bytes.len() > bin_at + 8 { bytes[bin_at + 8..bin_at + 8 + u32_at(bin_at)].to_vec() } else { Vec::new() };
    (json, bin)
}

/// The floats of a FLOAT accessor (tightly packed, or strided by its view).
fn accessor_floats(json: &Value, bin: &[u8], accessor: &Value) -> Vec<f32> {
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap_or(u64::MAX) as usize];
    let at = view["byteOffset"].as_u64().unwrap_or(0) as usize + accessor["byteOffset"].as_u64().unwrap_or(0) as usize;
    let width = match accessor["type"].as_str() {
        Some("VEC3") => 3,
        Some("VEC4") => 4,
        _ => 1,
    };
    let count = accessor["count"].as_u64().unwrap_or(0) as usize;
    let stride = view["byteStride"].as_u64().map_or(4 * width, |s| s as usize);
    let mut values = Vec::with_capacity(count * width);
    for k in 0..count {
        let Some(b) = bin.get(at + k * stride..at + k * stride + 4 * width) else { return Vec::new() };
        values.extend(b.chunks(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))));
    }
    values
}

/// Checks every node with `EXT_mesh_gpu_instancing` against the extension's rules
/// (it has a mesh and no skin; TRANSLATION and SCALE are FLOAT VEC3, ROTATION FLOAT
/// VEC4, other attributes start with `_`; all have the same count, above 0) and
/// against what clients need (the extension in `extensionsUsed`, unit rotations,
/// finite values, positive scales, `_COLOR_0` a VEC3 of linear colours in 0..1 in a
/// view without a byte stride: three.js reads an instance colour attribute's whole
/// array; TRANSLATION, ROTATION and SCALE may share a strided view, which it reads
/// element by element). Returns the number of such nodes and the problems.
fn check_gpu_instancing(json: &Value, bin: &[u8]) -> (usize, Vec<String>) {
    const EXT: &str = "EXT_mesh_gpu_instancing";
    let mut problems = Vec::new();
    let mut nodes = 0;
    for (i, node) in json["nodes"].as_array().into_iter().flatten().enumerate() {
        let Some(ext) = node.get("extensions").and_then(|e| e.get(EXT)) else { continue };
        nodes += 1;
        if node.get("mesh").is_none() || node.get("skin").is_some() {
            problems.push(format!("node {i}: an instanced node needs a mesh and no skin"));
        }
        let mut counts = Vec::new();
        for (attr, acc) in ext["attributes"].as_object().into_iter().flatten() {
            let a = &json["accessors"][acc.as_u64().unwrap_or(u64::MAX) as usize];
            let (kind, component) = (a["type"].as_str().unwrap_or(""), a["componentType"].as_u64().unwrap_or(0));
            let want = match attr.as_str() {
                "TRANSLATION" | "SCALE" | "_COLOR_0" => "VEC3",
                "ROTATION" => "VEC4",
                other if other.starts_with('_') => kind,
                other => {
                    problems.push(format!("node {i}: attribute {other} is not in the extension and has no `_`"));
                    kind
                }
            };
            if kind != want || component != 5126 {
                problems.push(format!("node {i}: {attr} is {kind} of component type {component}, want FLOAT {want}"));
                continue;
            }
            let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap_or(u64::MAX) as usize];
            if view.get("byteStride").is_some() && attr.starts_with('_') {
                problems.push(format!("node {i}: {attr}'s buffer view has a byte stride"));
            }
            let count = a["count"].as_u64().unwrap_or(0) as usize;
            counts.push(count);
            let values = accessor_floats(json, bin, a);
            if values.len() != count * if kind == "VEC4" { 4 } else { 3 } {
                problems.push(format!("node {i}: {attr}'s data is outside the buffer"));
                continue;
            }
            let bad = match attr.as_str() {
                "ROTATION" => {
                    values.chunks(4).position(|q| (q.iter().map(|x| x * x).sum::<f32>().sqrt() - 1.0).abs() > 1e-5)
                }
                "SCALE" => values.chunks(3).position(|s| !s.iter().all(|x| x.is_finite() && *x > 0.0)),
                "_COLOR_0" => values.chunks(3).position(|c| !c.iter().all(|x| (0.0..=1.0).contains(x))),
                _ => values.chunks(3).position(|t| !t.iter().all(|x| x.is_finite())),
            };
            if let Some(k) = bad {
                problems.push(format!("node {i}: {attr} of instance {k} is out of range"));
            }
        }
        if !counts.contains(&0) && counts.windows(2).all(|w| w[0] == w[1]) && counts.len() >= 3 {
            continue;
        }
        problems.push(format!("node {i}: instance attribute counts {counts:?} (all the same, above 0, TRS each)"));
    }
    let used = json["extensionsUsed"].as_array().is_some_and(|u| u.iter().any(|e| e == EXT));
    if nodes > 0 && !used {
        problems.push(format!("{EXT} is not in extensionsUsed"));
    }
    (nodes, problems)
}
