//! Hot reload: editing the grammar or a file it imports delivers a new model; a
//! compile error delivers the diagnostics (the window then keeps the last good
//! model); and the renderer keeps its model when a new one cannot be loaded.

mod common;

use common::*;
use mdg_cli::toolchain::Toolchain;
use mdg_viewer::model::Loader as _;
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::reload::{ReloadHandle, Reloaded};
use mdg_viewer::renderer::FrameParams;
use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

/// Waits for the next reload result (generous: a loaded CI machine is slow).
fn next(rx: &mpsc::Receiver<Reloaded>) -> Reloaded {
    rx.recv_timeout(Duration::from_secs(30)).expect("a reload within 30 s")
}

fn triangles(r: Reloaded) -> usize {
    match r {
        Reloaded::Model(m) => m.output.vertex_mesh().triangles.len(),
        Reloaded::Failed(msg) => panic!("expected a model, got:\n{msg}"),
    }
}

/// Writes a file the way editors do: a temporary file renamed over the old one.
fn save(path: &Path, text: &str) {
    let tmp = path.with_extension("tmp~");
    std::fs::write(&tmp, text).expect("write");
    std::fs::rename(&tmp, path).expect("rename");
}

#[test]
fn edits_to_the_grammar_and_its_imports_reload() {
    let dir = out_dir().join("reload");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("mkdir");
    let main = dir.join("main.mdg");
    let lib = dir.join("lib.mdg");
    std::fs::write(&lib, "rule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("write");
    std::fs::write(&main, "@import lib.mdg\nstartshape A\nrule A { tri {} }\n").expect("write");
    let (model, files) = Toolchain.load(&main, &load_options()).map_err(|f| f.error.to_string()).expect("loads");
    assert_eq!(model.output.vertex_mesh().triangles.len(), 1);
    assert!(files.iter().any(|f| f.ends_with("lib.mdg")), "{files:?}");

    let (tx, rx) = mpsc::channel();
    let handle = ReloadHandle::start(
        main.clone(),
        files,
        load_options(),
        std::sync::Arc::new(mdg_cli::toolchain::Toolchain),
        move |r| {
            let _ = tx.send(r);
        },
    )
    .expect("watch");
    // Give the watcher a moment to be registered before the first change.
    std::thread::sleep(Duration::from_millis(200));

    save(&main, "@import lib.mdg\nstartshape A\nrule A { tri {} tri {z 1} }\n");
    assert_eq!(triangles(next(&rx)), 2, "an edit of the main file");

    save(&main, "@import lib.mdg\nstartshape A\nrule A { tri {} nosuchrule {} }\n");
    match next(&rx) {
        Reloaded::Failed(msg) => assert!(msg.contains("E0301") && msg.contains("nosuchrule"), "{msg}"),
        Reloaded::Model(_) => panic!("a broken grammar must not load"),
    }

    save(&main, "@import lib.mdg\nstartshape A\nrule A { tri {} }\n");
    assert_eq!(triangles(next(&rx)), 1, "the fix reloads");

    save(&lib, "rule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} VERTEX {} VERTEX {x -1} VERTEX {y -1} }\n");
    assert_eq!(triangles(next(&rx)), 2, "an edit of the imported file");
    drop(handle);
}

#[test]
fn renderer_keeps_the_last_good_model() {
    let Some(ctx) = vulkan() else { return };
    let good = load(&data("cube.mdg"));
    let mut off = Offscreen::new(&ctx, 128, 96, 4).expect("offscreen");
    off.set_model(&good, &programs()).expect("upload");
    let camera = off.home_camera();
    let frame = FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false };
    let before = off.render(&frame).expect("render");
    // A model whose program has no SPIR-V (a bundle built without the shader
    // stage) cannot be drawn: set_model fails and the cube stays.
    let mut bad = load(&data("custom_shader.mdg"));
    bad.bundle.shaders.iter_mut().for_each(|s| s.spirv.clear());
    assert!(off.set_model(&bad, &programs()).is_err());
    let after = off.render(&frame).expect("render");
    drop(off);
    assert_no_validation_errors(&ctx);
    assert!(before == after, "the last good model must still be drawn");
}
