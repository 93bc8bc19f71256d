//! The CPU renderer for pictures (`mdg_viewer::cpu`, issue 37): it recognises std's
//! Phong program by content, its pictures match lavapipe's under the picture
//! equivalence metric (docs/viewer.md), it does not depend on the thread count, a
//! grammar with its own shaders falls back to Vulkan (and says so), and the CPU
//! path loads no Vulkan. The comparisons need Vulkan (lavapipe in CI); without it
//! they fail with instructions unless `MDG_SKIP_VULKAN_TESTS=1`.

mod common;

use common::*;
use mdg_cli::pictures::{cpu_options, cpu_pixels, decide, Decision, RendererChoice};
use mdg_viewer::cpu;
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::renderer::FrameParams;

/// std's `phong_vs` and `phong_fs`, as the CLI reads them (built in, or from the
/// workspace's std), are the shaders the CPU renderer implements: an edit to either
/// changes its content hash, and pictures go back to Vulkan until the CPU renderer
/// is checked against the new shader and its hash updated.
#[test]
fn std_phong_is_the_program_the_cpu_renderer_implements() {
    for dir in [None, Some(root().join("std"))] {
        let (vs, fs) = mdg_cli::toolchain::std_phong_code(dir.as_deref());
        assert!(vs.contains("void main()") && fs.contains("gl_FrontFacing"), "{vs}\n{fs}");
        assert_eq!(cpu::shader_hash(&vs), cpu::PHONG_VS_HASH, "phong_vs from {dir:?}");
        assert_eq!(cpu::shader_hash(&fs), cpu::PHONG_FS_HASH, "phong_fs from {dir:?}");
    }
    // The hash sees content, not layout.
    assert_eq!(cpu::shader_hash("  a;\n\n b;  \n"), cpu::shader_hash("a;\nb;"));
    assert_ne!(cpu::shader_hash("a;\nb;"), cpu::shader_hash("a;\nc;"));
    // A grammar importing std's shaders is covered; one with its own is not.
    let icosahedron = load(&root().join("std/examples/icosahedron.mdg"));
    assert!(icosahedron.bundle.program.is_some());
    let d = decide(RendererChoice::Auto, &icosahedron.bundle, &icosahedron.output, Some(&root().join("std")), false);
    assert!(matches!(d, Ok(Decision::Cpu(_))), "{d:?}");
    let custom = load(&data("custom_shader.mdg"));
    let d = decide(RendererChoice::Auto, &custom.bundle, &custom.output, Some(&root().join("std")), false);
    match d {
        Ok(Decision::Vulkan(why)) => assert!(why.contains("flat_vs") && why.contains("its own"), "{why}"),
        other => panic!("a grammar's own shaders must go to Vulkan: {other:?}"),
    }
    let d = decide(RendererChoice::Cpu, &custom.bundle, &custom.output, Some(&root().join("std")), false);
    assert!(d.as_ref().is_err_and(|e| e.starts_with("--renderer cpu:")), "{d:?}");
}

/// Every std example drawn by the CPU renderer matches lavapipe's picture, at the
/// default (1 sample and edge smoothing) and at 4×, under the picture-equivalence
/// metric: at most 0.5 % of the pixels more than 8/255 off away from an edge of
/// lavapipe's picture, and a mean difference under 3/255. And the CPU picture is the
/// same bytes for 1 and 3 threads.
#[test]
fn cpu_pictures_of_every_std_example_match_lavapipe() {
    let Some(ctx) = vulkan() else { return };
    let (w, h) = (240, 180);
    let mut dir = std_examples();
    // And the test grammars for what the examples lack: flat art (unlit, painted in
    // order), pen lines, matte flat primitives, mirrored frames, bones, a camera rule.
    for name in [
        "flat_overlap.mdg",
        "flat_instances.mdg",
        "pen_lines.mdg",
        "matte_flat_primitives.mdg",
        "mirrored_cube.mdg",
        "animated_arm.mdg",
        "camera_rule.mdg",
        "red_blue_cubes.mdg",
    ] {
        dir.push(data(name));
    }
    let programs = programs();
    let std = root().join("std");
    let mut report = Vec::new();
    let mut failures = Vec::new();
    for path in &dir {
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let model = load(path);
        let program = match decide(RendererChoice::Auto, &model.bundle, &model.output, Some(&std), false) {
            Ok(Decision::Cpu(p)) => p,
            other => {
                failures.push(format!("{name}: not drawn by the CPU renderer: {other:?}"));
                continue;
            }
        };
        for samples in [0u32, 4] {
            let mut off = Offscreen::new(&ctx, w, h, samples).expect("offscreen");
            let info = off.set_model(&model, &programs).expect("upload");
            let camera = off.home_camera();
            let frame = FrameParams { camera, time: 0.0, wireframe: false, camera_rule: info.has_camera_rule };
            let lavapipe = Image { px: off.render(&frame).expect("render"), w, h };
            let (mut opts, _) = cpu_options(samples, (w, h));
            opts.threads = 1;
            let (px, _) = cpu_pixels(&model.bundle, &model.output, &program, &opts, 0.0, None);
            opts.threads = 3;
            let (px3, _) = cpu_pixels(&model.bundle, &model.output, &program, &opts, 0.0, None);
            let label = if samples == 0 { "1x+smoothing" } else { "4x" };
            if px3 != px {
                failures.push(format!("{name} {label}: 1 and 3 threads draw different pictures"));
            }
            let cpu_img = Image { px, w, h };
            if name == "tree" || name == "city_block" || name == "pebbles" {
                lavapipe.save(&format!("cpu-eq-{name}-{label}-lavapipe.png"));
                cpu_img.save(&format!("cpu-eq-{name}-{label}-cpu.png"));
            }
            let (mean, off_edge) = off_edge_differences(&lavapipe, &cpu_img);
            report.push(format!("{name} {label}: mean {mean:.2}/255, {off_edge} px off edges"));
            if mean > EQ_MEAN || off_edge as f64 > EQ_OFF_EDGE_SHARE * f64::from(w * h) {
                failures.push(report.last().cloned().unwrap_or_default());
            }
        }
    }
    assert_no_validation_errors(&ctx);
    eprintln!("{}", report.join("\n"));
    assert!(failures.is_empty(), "CPU pictures that differ from lavapipe's:\n{}", failures.join("\n"));
}

/// Flat art keeps its prototype instances (CIRCLE, SQUARE, TRIANGLE: one record
/// each) and the CPU renderer paints them in program order, expanding each as it
/// paints it: the same bytes as the picture of the output with every instance
/// expanded (instancing off), at 1× with smoothing and at 4×, on 1 and 3 threads,
/// and the same triangle count. Shapes out of z order are expanded and sorted by
/// the evaluator (the output then has no prototype instance) and paint the same too.
#[test]
fn flat_art_paints_its_instances_in_order_as_if_expanded() {
    for (name, kept) in [("flat_instances.mdg", true), ("flat_instances_z.mdg", false)] {
        let model = load(&data(name));
        let out = &model.output;
        let protos = out.instances.iter().filter(|i| out.is_prototype_instance(i)).count();
        assert_eq!(protos > 0, kept, "{name}: {protos} prototype instances");
        let opts = mdg_vm::eval::EvalOptions { instancing: false, ..mdg_vm::eval::EvalOptions::default() };
        let expanded = mdg_vm::eval::evaluate(&model.bundle, &opts);
        assert!(expanded.instances.is_empty());
        assert_eq!(expanded.mesh.triangles.len(), out.flat_counts(mdg_vm::output::Groups::ALL).1, "{name}");
        // With sites recorded nothing is sorted: out of z order, the run says so.
        let opts = mdg_vm::eval::EvalOptions { record_sites: true, ..mdg_vm::eval::EvalOptions::default() };
        let sited = mdg_vm::eval::evaluate(&model.bundle, &opts);
        let warned = sited.stats.warnings.iter().any(|w| w.contains("painted in derivation order while sites"));
        assert_eq!(warned, !kept, "{name}: {:?}", sited.stats.warnings);
        for samples in [0u32, 4] {
            for threads in [1, 3] {
                let (mut o, _) = cpu_options(samples, (160, 120));
                o.threads = threads;
                let (a, da) = cpu_pixels(&model.bundle, out, &cpu::Program::Unlit, &o, 0.0, None);
                let (b, db) = cpu_pixels(&model.bundle, &expanded, &cpu::Program::Unlit, &o, 0.0, None);
                assert_eq!(da, db, "{name} samples {samples} threads {threads}");
                assert!(a == b, "{name}: samples {samples}, threads {threads}: the pictures differ");
                // Not an empty picture: most of it is painted, in many colours.
                let colours: std::collections::HashSet<&[u8]> = a.chunks_exact(4).collect();
                assert!(colours.len() > 4, "{name}: {} colours", colours.len());
            }
        }
    }
}

fn mdg_run(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_mdg-run")).args(args).output().expect("run mdg-run")
}

/// `mdg-run --png --stats` says which renderer drew the picture and why; the CPU
/// path leaves libvulkan unloaded, compiles and reads no shader, and draws the same
/// bytes twice; a grammar with
/// its own shaders is drawn by Vulkan, and `--renderer cpu` refuses it (exit 2).
#[test]
fn mdg_run_says_which_renderer_drew_the_picture() {
    let dir = out_dir().join("cpu-renderer-cli");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch");
    let tree = root().join("std/examples/tree.mdg");
    let (a, b) = (dir.join("a.png"), dir.join("b.png"));
    for png in [&a, &b] {
        let o = mdg_run(&[
            tree.to_str().expect("path"),
            "--format",
            "none",
            "--png",
            png.to_str().expect("path"),
            "--size",
            "160x120",
            "--stats",
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains("picture drawn by the CPU renderer (program std phong_vs + std phong_fs"), "{err}");
        assert!(err.contains("libvulkan loaded: no"), "{err}");
        assert!(err.contains("shaders compiled with glslang 0  taken from the SPIR-V cache 0"), "{err}");
    }
    assert_eq!(std::fs::read(&a).expect("a"), std::fs::read(&b).expect("b"), "same source, same picture bytes");
    let custom = data("custom_shader.mdg");
    let o = mdg_run(&[
        custom.to_str().expect("path"),
        "--format",
        "none",
        "--png",
        dir.join("c.png").to_str().expect("path"),
        "--renderer",
        "cpu",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--renderer cpu: the grammar's vertex shader `flat_vs` is its own"), "{err}");
    if skip_vulkan() {
        return;
    }
    let o = mdg_run(&[
        custom.to_str().expect("path"),
        "--format",
        "none",
        "--png",
        dir.join("c.png").to_str().expect("path"),
        "--size",
        "64x48",
        "--stats",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("picture drawn by the Vulkan renderer, because the grammar's vertex shader `flat_vs`"),
        "{err}"
    );
}
