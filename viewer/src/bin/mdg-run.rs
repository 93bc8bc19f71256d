//! `mdg-run`: evaluate a grammar (`.mdg` source or `.mdgb` bundle) and write a mesh.
//!
//! It lives in the viewer package so that pictures (`--png`, the modes' contact
//! sheets) are rendered by the Vulkan offscreen renderer; the software renderer is
//! the fallback where no Vulkan can start.

use clap::Parser;
use mdg_compiler::diag::render_plain;
use mdg_compiler::driver;
use mdg_compiler::modes::{self, Common};
use mdg_compiler::source::{FsLoader, MemLoader};
use mdg_vm::eval::{evaluate_with_progress, EvalOptions};
use mdg_vm::export::{self, Format};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

#[derive(Parser)]
#[command(name = "mdg-run", version, about = "Evaluate an MDG grammar and write the mesh")]
#[command(after_help = "Examples:
  mdg-run std/examples/tree.mdg                 # writes std/examples/tree.glb
  mdg-run tree.mdg -o tree.obj --seed 7         # OBJ, another random tree
  mdg-run knot.mdg --param nx=3 --param ny=5    # override @param values
  mdg-run tree.mdg --format json -o tree.json   # inspection dump (vertices, lines, instances, stats)
  mdg-run tree.mdgb --stats                     # run a compiled bundle, print counters
  mdg-run solar_system.mdg                      # .glb with the animation (bones, camera)
  mdg-run solar_system.mdg --time 2.5 -o a.obj  # the pose at 2.5 s as a still mesh")]
struct Cli {
    /// The grammar: `.mdg` source or `.mdgb` bundle.
    file: PathBuf,
    /// Output file (default: beside the input, with the format's extension).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Output format: glb, obj, stl, ply, json (default: from -o's extension, else glb).
    #[arg(long)]
    format: Option<String>,
    /// Seed for the random stream (overrides `randseed`).
    #[arg(long)]
    seed: Option<u64>,
    #[command(flatten)]
    compile: mdg_compiler::cli::CompileArgs,
    /// Read the source from standard input; FILE still names it, so `@import`s
    /// resolve beside it (editors preview unsaved text this way).
    #[arg(long)]
    stdin: bool,
    /// Print rule calls, vertices, triangles, time and peak memory.
    #[arg(long)]
    stats: bool,
    /// Stop after this many vertices (default 50,000,000).
    #[arg(long)]
    max_vertices: Option<u64>,
    /// Stop after this many seconds of evaluation.
    #[arg(long)]
    time_budget: Option<f64>,
    /// Also write a picture (Vulkan offscreen, lavapipe without a GPU; the software
    /// renderer where no Vulkan is installed).
    #[arg(long)]
    png: Option<PathBuf>,
    /// Picture size, WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600")]
    size: String,
    /// Write the pose at T seconds as a still model: every bone moved by its
    /// transform rules' frames at index ⌊T·fps⌋, the camera fixed there. For formats
    /// without animation (obj, stl, ply); applies to every format and the picture.
    /// Without it, .glb holds the whole animation and obj/stl/ply the rest pose.
    #[arg(long, value_name = "T")]
    time: Option<f64>,
    #[command(flatten)]
    guided: mdg_compiler::modes::guided::GuidedArgs,
    #[command(flatten)]
    creature: mdg_compiler::modes::creature::CreatureArgs,
    #[command(flatten)]
    grid: mdg_compiler::modes::grid::GridArgs,
}

fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let opts = match cli.compile.options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("mdg-run: {e}");
            return ExitCode::from(2);
        }
    };
    mdg_viewer::picture::install(opts.std_dir.clone());
    let is_bundle = cli.file.extension().is_some_and(|e| e == "mdgb");
    let bundle = if is_bundle {
        let bytes = match std::fs::read(&cli.file) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("mdg-run: cannot read {}: {e}", cli.file.display());
                return ExitCode::from(2);
            }
        };
        match mdg_vm::bundle::load(&bytes) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("mdg-run: {}: {e}", cli.file.display());
                return ExitCode::from(1);
            }
        }
    } else {
        let built = if cli.stdin {
            let mut text = String::new();
            if let Err(e) = std::io::Read::read_to_string(&mut std::io::stdin(), &mut text) {
                eprintln!("mdg-run: cannot read standard input: {e}");
                return ExitCode::from(2);
            }
            let loader = MemLoader { files: [(cli.file.clone(), text)].into(), disk_fallback: true };
            driver::build(&loader, &cli.file, &opts)
        } else {
            driver::build(&FsLoader, &cli.file, &opts)
        };
        match built {
            Ok((b, a)) => {
                eprint!("{}", render_plain(&a.diagnostics, &a.sources));
                b
            }
            Err(a) => {
                eprint!("{}", render_plain(&a.diagnostics, &a.sources));
                return ExitCode::from(1);
            }
        }
    };
    let (w, h) =
        match cli.size.split_once('x').and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?))) {
            Some((w, h)) if w > 0 && h > 0 && w <= 8192 && h <= 8192 => (w, h),
            _ => {
                eprintln!("mdg-run: --size {}: expected WIDTHxHEIGHT, each 1..8192", cli.size);
                return ExitCode::from(2);
            }
        };
    let common = Common {
        file: &cli.file,
        output: cli.output.as_deref(),
        seed: cli.seed,
        stats: cli.stats,
        png: cli.png.as_deref(),
        size: (w, h),
    };
    if bundle.extensions.creatures.is_some() {
        return modes::creature::run(&bundle, &cli.creature, &common);
    }
    if bundle.extensions.grid.is_some() {
        return modes::grid::run(&bundle, &cli.grid, &common);
    }
    let format = match &cli.format {
        Some(f) => match Format::from_extension(f) {
            Some(f) => f,
            None => {
                eprintln!("mdg-run: unknown format `{f}` (glb, obj, stl, ply, json)");
                return ExitCode::from(2);
            }
        },
        None => cli.output.as_deref().and_then(Format::from_path).unwrap_or(Format::Glb),
    };
    if let Some(t) = cli.time {
        if !(t.is_finite() && t >= 0.0) {
            eprintln!("mdg-run: --time {t}: expected a number of seconds ≥ 0");
            return ExitCode::from(2);
        }
    }
    let output = cli.output.clone().unwrap_or_else(|| cli.file.with_extension(format.extension()));
    let eval_opts = EvalOptions {
        seed: cli.seed,
        max_vertices: cli.max_vertices.unwrap_or(mdg_vm::eval::DEFAULT_MAX_VERTICES),
        time_budget: cli.time_budget.map(Duration::from_secs_f64),
        time: cli.time,
        ..EvalOptions::default()
    };
    let started = std::time::Instant::now();
    let bar = indicatif::ProgressBar::hidden();
    let progress = |calls: u64| {
        if bar.is_hidden() && started.elapsed() > Duration::from_secs(1) {
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            bar.set_style(
                indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
        }
        bar.set_message(format!("{calls} rule calls"));
        bar.tick();
    };
    let mut out = if bundle.extensions.guided.is_some() {
        match modes::guided::run(&bundle, &cli.guided, &common) {
            Ok(out) => out,
            Err(e) => {
                eprintln!("mdg-run: {e}");
                return ExitCode::from(1);
            }
        }
    } else {
        evaluate_with_progress(&bundle, &eval_opts, Some(&progress))
    };
    bar.finish_and_clear();
    for w in &out.stats.warnings {
        eprintln!("warning: {w}");
    }
    match cli.time {
        Some(t) => out = out.posed(t),
        None if out.animation.bones.len() > 1 && format != Format::Glb => {
            eprintln!("note: the model is animated; {} has no animation, so this is the rest pose (choose a pose with --time T)", format.extension());
        }
        None => {}
    }
    if let Err(e) = export::write_file(format, &out, &output) {
        eprintln!("mdg-run: cannot write {}: {e}", output.display());
        return ExitCode::from(1);
    }
    if let Some(png_path) = &cli.png {
        // With --time the pose is already baked into `out`.
        match modes::render_png_of(Some(&bundle), &out, (w, h)) {
            Ok(bytes) => {
                if let Err(e) = export::write_atomic(png_path, &bytes) {
                    eprintln!("mdg-run: cannot write {}: {e}", png_path.display());
                    return ExitCode::from(2);
                }
                eprintln!("wrote {}", display(png_path));
            }
            Err(e) => {
                eprintln!("mdg-run: cannot render the picture: {e}");
                return ExitCode::from(1);
            }
        }
    }
    if cli.stats {
        let s = &out.stats;
        eprintln!(
            "rule calls {}  vertices {}  triangles {}  lines {}  instances {}  time {:.1} ms  peak memory {}",
            s.rule_calls,
            s.vertices,
            s.triangles,
            out.lines.len(),
            out.instances.len(),
            s.elapsed_ms,
            peak_rss_kib().map(|k| format!("{:.1} MiB", k as f64 / 1024.0)).unwrap_or_else(|| "n/a".into())
        );
    }
    eprintln!("wrote {}", display(&output));
    ExitCode::SUCCESS
}

fn display(p: &Path) -> String {
    p.display().to_string()
}
