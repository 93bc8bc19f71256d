//! Every std example compiles, evaluates to geometry, renders a picture that is not
//! blank, and exports a `.glb` that the Khronos glTF-Validator accepts with 0 errors.

use mdg_tests::{analyze_file, mdg_files, root};
use mdg_vm::eval::{evaluate, EvalOptions};

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
        mdg_vm::export::write(mdg_vm::export::Format::Glb, &out, &mut bytes).expect("glb");
        let file = tmp.join(format!("{name}.glb"));
        std::fs::write(&file, bytes).expect("write");
        glbs.push(file);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
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
    assert!(
        status.status.success(),
        "glTF validation failed:\n{}{}",
        String::from_utf8_lossy(&status.stdout),
        String::from_utf8_lossy(&status.stderr)
    );
}
