//! Render benchmark: 1M triangles (a 44 × 44 × 44 lattice of cubes, 1,022,208
//! triangles, seen from the three-quarter home view) rendered offscreen to a 1024 × 1024 PNG with 4× MSAA and the std Phong program.
//! Target on lavapipe: ≤ 2 s from the evaluated model to the PNG on disk.
//!
//! `cargo bench -p mdg-cli --bench render` (validation off). Prints each phase:
//! packing the vertex data, uploading and building pipelines, drawing and reading
//! back, encoding and writing the PNG; the end-to-end time is their sum. Two more
//! frames of the same model show the draw alone (frames per second). 4× MSAA;
//! `MDG_BENCH_SAMPLES=N` asks for another count. `MDG_BENCH_CUBES=N` renders an N × N × N lattice (95 for about 10M triangles on
//! a GPU), `MDG_BENCH_SIZE=S` an S × S image.

use mdg_cli::toolchain::Toolchain;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::model::{self, Loader as _};
use mdg_viewer::offscreen::{self, Offscreen};
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::{program, scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: u32 = std::env::var("MDG_BENCH_CUBES").ok().and_then(|v| v.parse().ok()).unwrap_or(44);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/bench-render");
    std::fs::create_dir_all(&dir)?;
    let grammar = dir.join("lattice.mdg");
    std::fs::write(
        &grammar,
        format!(
            "// {n} x {n} x {n} cubes of 12 triangles.\n@import primitives\nstartshape block\nbackground 1 1 1\n\
             rule block {{ {n} * {{z 1.5 B -0.01}} layer {{}} }}\nrule layer {{ {n} * {{x 1.5}} row {{}} }}\n\
             rule row {{ {n} * {{y 1.5 R -0.01}} cube {{G -0.5 B -0.3}} }}\n"
        ),
    )?;
    let opts = model::LoadOptions { std_dir: Some(root.join("std")), ..model::LoadOptions::default() };
    let t = Instant::now();
    let (m, _) = Toolchain.load(&grammar, &opts).map_err(|f| f.error.to_string())?;
    let t_eval = ms(t);
    let n_tri = m.output.flat_counts(mdg_vm::output::Groups::ALL).1;

    let t = Instant::now();
    let ctx = Arc::new(Context::new(&ContextOptions {
        validation: Validation::Off,
        surface_extensions: vec![],
        on_message: Some(mdg_cli::say),
    })?);
    let t_ctx = ms(t);
    let t = Instant::now();
    let programs = Toolchain.programs(Some(&root.join("std")))?;
    let prog = program::for_bundle(&m.bundle, &programs)?;
    let t_prog = ms(t);

    let side: u32 = std::env::var("MDG_BENCH_SIZE").ok().and_then(|v| v.parse().ok()).unwrap_or(1024);
    println!("render benchmark: {n_tri} triangles to a {side}x{side} PNG, on {}", ctx.device_name);
    println!("  (not in the totals) evaluate grammar {t_eval:.0} ms, Vulkan context {t_ctx:.0} ms, std program {t_prog:.0} ms");
    // 4x MSAA, as mdg-view draws (lavapipe supports only 1 and 4 samples).
    // `MDG_BENCH_SAMPLES` asks for another count (the largest supported ≤ it).
    let samples: u32 = std::env::var("MDG_BENCH_SAMPLES").ok().and_then(|v| v.parse().ok()).unwrap_or(4);
    let configs = [samples];
    for samples in configs {
        let mut off = Offscreen::new(&ctx, side, side, samples)?;
        let samples = off.samples();
        let t_all = Instant::now();
        let t = Instant::now();
        let sc = scene::build(&m.output);
        let t_pack = ms(t);
        let t = Instant::now();
        off.renderer_mut().set_scene(&sc, &m.bundle, &m.output, &prog, &programs.lines)?;
        let t_upload = ms(t);
        let frame = FrameParams { camera: off.home_camera(), time: 0.0, wireframe: false, camera_rule: false };
        let t = Instant::now();
        let px = off.render(&frame)?;
        let t_draw = ms(t);
        let t = Instant::now();
        let out: PathBuf = dir.join(format!("lattice-{samples}x.png"));
        offscreen::write_png(&out, &px, side, side)?;
        let t_png = ms(t);
        let t_total = ms(t_all);
        let mut redraws = Vec::new();
        for _ in 0..2 {
            let t = Instant::now();
            off.render(&frame)?;
            redraws.push(ms(t));
        }
        let redraw = redraws.iter().copied().fold(f64::MAX, f64::min);
        println!("  {samples}x MSAA:");
        println!("    pack vertices       {t_pack:8.1} ms");
        println!("    upload + pipelines  {t_upload:8.1} ms");
        println!("    draw + read back    {t_draw:8.1} ms");
        println!("    encode + write PNG  {t_png:8.1} ms");
        println!("    total               {t_total:8.1} ms   (target <= 2000 ms on lavapipe)");
        println!("    redraw, best of 2   {redraw:8.1} ms   ({:.2} frames/s)", 1000.0 / redraw.max(1e-3));
        println!("    wrote {}", out.display());
    }
    Ok(())
}
