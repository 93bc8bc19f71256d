//! Guide-edit latency benchmark: from a control-point edit to the new model drawn,
//! with the std guided tree (`std/examples/guided_tree.mdg`, its own three guides)
//! offscreen at 800 × 600 with 4× MSAA on whatever Vulkan is here (lavapipe without
//! a GPU). Target: a median of at most 50 ms on lavapipe.
//!
//! `cargo bench -p mdg-cli --bench guided_edit` (validation off). Each of N edits
//! (50; `MDG_BENCH_EDITS=N`) drags a control point a few pixels in the view plane
//! (cycling through the guides' points, alternating directions), then runs what the
//! window runs for it, timing each part: preparing the guides, the search (the
//! `search` section's settings, its 200 ms budget included), the geometry phase,
//! packing the scene with the editor's overlay, uploading it (the pipelines are
//! kept: same program), and drawing a frame and waiting for the GPU (the offscreen
//! frame is also copied to host memory, as a screenshot would be). Prints the median
//! and the 90th percentile of each part and of the total.

use glam::DVec2;
use mdg_cli::toolchain::Toolchain;
use mdg_guided::{Cancel, GuidedTable};
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::guided::edit::Editor;
use mdg_viewer::guided::project::ScreenView;
use mdg_viewer::guided::search::{run_search, SearchRequest};
use mdg_viewer::model::{self, Loader as _};
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::{program, scene};
use mdg_vm::bundle::Section as _;
use mdg_vm::eval::EvalOptions;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    if s.is_empty() {
        return f64::NAN;
    }
    let i = ((s.len() - 1) as f64 * q).round() as usize;
    s[i.min(s.len() - 1)]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let edits: usize = std::env::var("MDG_BENCH_EDITS").ok().and_then(|v| v.parse().ok()).unwrap_or(50);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let grammar = root.join("std/examples/guided_tree.mdg");
    let opts =
        model::LoadOptions { std_dir: Some(root.join("std")), guided_search: true, ..model::LoadOptions::default() };
    let (m, _) = Toolchain.load(&grammar, &opts).map_err(|f| f.error.to_string())?;
    let table = GuidedTable::from_bundle(&m.bundle)
        .map_err(|e| e.to_string())?
        .ok_or("guided_tree.mdg has no search section")?;
    let bundle = Arc::new(m.bundle.clone());
    let seed = m.bundle.settings.randseed;
    let ctx = Arc::new(Context::new(&ContextOptions {
        validation: Validation::Off,
        surface_extensions: vec![],
        on_message: Some(mdg_cli::say),
    })?);
    let programs = Toolchain.programs(Some(&root.join("std")))?;
    let prog = program::for_bundle(&m.bundle, &programs)?;
    // The instanced program, as the window draws with (`Renderer::set_output`).
    let inst_prog = program::instanced_for_bundle(&m.bundle, &programs)?;
    let (w, h) = (800u32, 600u32);
    let mut off = Offscreen::new(&ctx, w, h, 4)?;
    let mut editor = Editor::new(table.guides.clone());
    // The grammar's reach, estimated by the first search (as in the window).
    let reach = std::sync::Arc::new(std::sync::OnceLock::new());
    let request = |editor: &Editor| SearchRequest {
        bundle: bundle.clone(),
        guides: editor.guides().to_vec(),
        seed,
        eval: EvalOptions::default(),
        utilisation: None,
        reach: reach.clone(),
    };

    // The first model, uploaded with its pipelines built (not in the totals).
    let t = Instant::now();
    let first = run_search(&request(&editor), &Cancel::new())?;
    let t_first_search = ms(t);
    let mut out = first.output;
    let n_lines = out.lines.len();
    out.lines.extend(editor.overlay(editor.marker_size()));
    let sc = scene::build_with(&out, inst_prog.is_some());
    let t = Instant::now();
    off.renderer_mut().set_scene_instanced(&sc, &m.bundle, &out, &prog, &programs.lines, inst_prog.as_ref())?;
    let t_first_upload = ms(t);
    out.lines.truncate(n_lines);
    let camera = off.home_camera();
    let frame = FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false };
    off.render(&frame)?;
    let (view, proj, eye) = off.renderer_mut().view_projection(&frame);
    let screen = ScreenView::new(view, proj, eye, w, h);
    println!(
        "guided edit benchmark: {} with its {} guides, {w}x{h}, {}x MSAA, on {}; {edits} edits",
        grammar.strip_prefix(&root).unwrap_or(&grammar).display(),
        editor.guides().len(),
        off.samples(),
        ctx.device_name
    );
    println!(
        "  (not in the totals) first search {t_first_search:.1} ms, first upload with pipelines {t_first_upload:.1} ms, \
         {} triangles",
        sc.n_triangles()
    );

    let points: Vec<(usize, usize)> =
        editor.guides().iter().enumerate().flat_map(|(g, gd)| (0..gd.points.len()).map(move |p| (g, p))).collect();
    let names = ["prepare", "search", "geometry", "pack", "upload", "draw", "total"];
    let mut parts: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut budget_cuts = 0;
    let mut generations = Vec::new();
    for i in 0..edits {
        let (g, p) = points[i % points.len()];
        let at = editor.point_on_screen(&screen, g, p).ok_or("a control point is off screen")?;
        let sign = if (i / points.len()).is_multiple_of(2) { 1.0 } else { -1.0 };
        if !editor.begin_drag(&screen, at, g, p) {
            return Err("cannot grab a control point".into());
        }
        editor.drag_to(&screen, at + DVec2::new(6.0 * sign, -4.0 * sign));
        editor.end_drag();

        let t_all = Instant::now();
        let searched = run_search(&request(&editor), &Cancel::new())?;
        let t = Instant::now();
        let mut out = searched.output;
        out.lines.extend(editor.overlay(editor.marker_size()));
        let sc = scene::build_with(&out, inst_prog.is_some());
        let t_pack = ms(t);
        let t = Instant::now();
        off.renderer_mut().set_scene_instanced(&sc, &m.bundle, &out, &prog, &programs.lines, inst_prog.as_ref())?;
        let t_upload = ms(t);
        let t = Instant::now();
        off.render(&frame)?;
        let t_draw = ms(t);
        let total = ms(t_all);
        let tm = searched.timings;
        let row = [
            tm.prepare.as_secs_f64() * 1e3,
            tm.search.as_secs_f64() * 1e3,
            tm.geometry.as_secs_f64() * 1e3,
            t_pack,
            t_upload,
            t_draw,
            total,
        ];
        for (k, v) in row.iter().enumerate() {
            parts[k].push(*v);
        }
        if searched.summary.stop == mdg_guided::Stop::Budget {
            budget_cuts += 1;
        }
        generations.push(searched.summary.generations as f64);
    }
    println!("  {:<10} {:>10} {:>10}", "part", "median", "p90");
    for (name, v) in names.iter().zip(&parts) {
        println!("  {:<10} {:>7.1} ms {:>7.1} ms", name, quantile(v, 0.5), quantile(v, 0.9));
    }
    println!(
        "  edit -> new model drawn: median {:.1} ms (target <= 50 ms on lavapipe); {budget_cuts} of {edits} searches \
         cut by the 200 ms budget; median {} generations",
        quantile(&parts[6], 0.5),
        quantile(&generations, 0.5)
    );
    Ok(())
}
