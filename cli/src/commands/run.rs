//! `mdg-run FILE`: evaluate a grammar (`.mdg` source or `.mdgb` bundle) and write a
//! mesh; grammars with extension sections run their mode (guided search, creature
//! evolution, grid generation). Pictures (`--png`, the modes' contact sheets) are
//! drawn by the viewer's CPU renderer when it implements the model's program (std's
//! Phong program, flat art), else by its Vulkan offscreen renderer (`--renderer`),
//! the software preview where no Vulkan can start.

use crate::batch::{self, Manifest, Seeds, Shard};
use crate::failure::Failure;
use crate::modes::{self, Common};
use crate::pictures::{Pictures, RendererChoice, Vulkan};
use mdg_compiler::diag::render_plain;
use mdg_compiler::driver;
use mdg_compiler::source::{FsLoader, MemLoader};
use mdg_export::{self as export, Format};
use mdg_viewer::camera::Pose;
use mdg_vm::bundle::{Bundle, SectionKind};
use mdg_vm::eval::{evaluate_with_progress, EvalOptions};
use mdg_vm::output::Output;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

#[derive(clap::Parser, Debug)]
#[command(name = "mdg-run", version, about = "Evaluate an MDG grammar and write the mesh")]
#[command(after_help = "Examples:
  mdg-run std/examples/tree.mdg                 # writes ./tree.glb (the current directory)
  mdg-run tree.mdg -o tree.obj --seed 7         # OBJ, another random tree
  mdg-run knot.mdg --param nx=3 --param ny=5    # override @param values
  mdg-run tree.mdg --format json -o tree.json   # inspection dump (vertices, lines, instances, stats)
  mdg-run tree.mdgb --stats                     # run a compiled bundle, print counters
  mdg-run solar_system.mdg                      # .glb with the animation (bones, camera)
  mdg-run solar_system.mdg --time 2.5 -o a.obj  # the pose at 2.5 s as a still mesh
  mdg-run solar_system.mdg --frames frames/     # the animation as PNGs (and an .mp4 with ffmpeg)
  mdg-run tree.mdg --camera 0,90 --png top.png  # the picture from above
  mdg-run tree.mdg --seeds 0..1000 -o 'out/{seed}.glb' --shard 3/8   # a batch: docs/batch.md")]
pub struct Args {
    /// The grammar: `.mdg` source or `.mdgb` bundle.
    pub file: PathBuf,
    /// Output file (default: in the current directory, named after the input, with
    /// the format's extension). With --seeds, a template holding `{seed}`.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Output format: glb, obj, stl, ply, json (default: from -o's extension, else
    /// glb), or none: evaluate only and write no model (for timing with --stats;
    /// warnings, --stats and --png still apply).
    #[arg(long)]
    format: Option<String>,
    /// Seed for the random stream (overrides `randseed`).
    #[arg(long)]
    seed: Option<u64>,
    #[command(flatten)]
    compile: crate::args::CompileArgs,
    /// Read the source from standard input; FILE still names it, so `@import`s
    /// resolve beside it (editors preview unsaved text this way).
    #[arg(long)]
    stdin: bool,
    /// Also write the grammar's `@param` declarations (name, type, value in force,
    /// min, max) as JSON to PATH, before evaluating (the editor's sliders read it).
    #[arg(long, value_name = "PATH")]
    params_json: Option<PathBuf>,
    /// Record which rule and source line drew each triangle, sweep and instance, and
    /// at which derivation depth, in the `.glb`'s extras (`mdg_sites` on the
    /// primitives and instance nodes): the editor's preview uses it to go from a
    /// click on the model to the source. Off by default (the file stays as without
    /// it).
    #[arg(long)]
    sites: bool,
    /// .glb: write prototype instances (the runs of VERTEX items the compiler marks,
    /// see `mdgc disasm`) with EXT_mesh_gpu_instancing — one mesh per prototype and
    /// a transform per instance, for game engines and three.js (drawn as
    /// InstancedMesh). Off by default: Blender makes one object per instance and
    /// importers without the extension show a single one (docs/instancing.md).
    #[arg(long)]
    instances: bool,
    /// Print rule calls, vertices, triangles, time and peak memory, and the wall and
    /// CPU time of each phase (evaluate, write, picture) and of the whole process.
    #[arg(long)]
    stats: bool,
    #[command(flatten)]
    limits: crate::args::LimitArgs,
    /// Also write a picture (the CPU renderer for std's Phong program and flat art,
    /// else Vulkan offscreen, lavapipe without a GPU: --renderer; the software
    /// preview where no Vulkan is installed).
    #[arg(long)]
    png: Option<PathBuf>,
    /// Picture size, WIDTHxHEIGHT.
    #[arg(long, default_value = "800x600")]
    size: String,
    /// Picture samples: `auto` (one sample and edge smoothing on the CPU renderer
    /// and on a CPU driver such as lavapipe, 4x multisampling on a GPU) or a count
    /// (1 draws aliased edges; a count the renderer lacks gives the next it has,
    /// with a warning).
    #[arg(long, default_value = "auto", value_name = "auto|N", value_parser = crate::args::parse_samples)]
    samples: u32,
    /// Which renderer draws pictures: `auto` (the CPU renderer when the model's
    /// program is std's Phong program or flat art, which it implements exactly; else
    /// Vulkan), `cpu` (an error for a grammar's own shaders) or `vulkan`. --stats
    /// says which drew the picture and why.
    #[arg(long, value_enum, default_value = "auto")]
    renderer: crate::pictures::RendererChoice,
    /// Write the pose at T seconds as a still model: every bone moved by its
    /// transform rules' frames at index ⌊T·fps⌋, the camera fixed there. For formats
    /// without animation (obj, stl, ply); applies to every format and the picture.
    /// Without it, .glb holds the whole animation and obj/stl/ply the rest pose.
    #[arg(long, value_name = "T")]
    time: Option<f64>,
    /// The picture's view: azimuth and elevation in degrees, ZOOM times closer
    /// (e.g. `0,90` looks down); replaces the home view and the camera rule.
    #[arg(long, value_name = "AZ,EL[,ZOOM]")]
    camera: Option<String>,
    /// Write the animation as a numbered PNG sequence into DIR (frame-00000.png, …,
    /// `duration · fps` frames at --size), and DIR/animation.mp4 when `ffmpeg` is on PATH.
    #[arg(long, value_name = "DIR")]
    frames: Option<PathBuf>,
    /// A batch: run every seed in A..B (B excluded) or A..=B, each written to the -o
    /// template with `{seed}` replaced, with a manifest; resumable. One run per shard
    /// at a time: a second stops with exit 75 naming the first (docs/batch.md).
    #[arg(long, value_name = "A..B")]
    seeds: Option<String>,
    /// With --seeds: run only shard K of N (the seeds at positions ≡ K mod N; K from 0).
    #[arg(long, value_name = "K/N", requires = "seeds")]
    shard: Option<String>,
    /// With --seeds: run N seeds at a time (default: the machine's cores). Outputs and
    /// manifest are byte for byte those of -j 1.
    #[arg(short = 'j', long = "jobs", value_name = "N", requires = "seeds",
          value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    #[command(flatten)]
    guided: crate::modes::guided::GuidedArgs,
    #[command(flatten)]
    creature: crate::modes::creature::CreatureArgs,
    #[command(flatten)]
    grid: crate::modes::grid::GridArgs,
}

/// Whether the Vulkan loader is mapped into this process (`/proc/self/maps`;
/// `None` where there is no such file): the CPU renderer's pictures load none.
fn vulkan_loaded() -> Option<bool> {
    let maps = std::fs::read_to_string("/proc/self/maps").ok()?;
    Some(maps.lines().any(|l| l.contains("libvulkan")))
}

fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// The CPU time (user + system) of the whole process so far, all its threads, in
/// milliseconds: fields 14 and 15 of `/proc/self/stat`, in the kernel's USER_HZ
/// ticks (100 a second on every Linux: a resolution of 10 ms). `None` elsewhere.
pub fn process_cpu_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The command name (field 2) is in parentheses and may hold spaces.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<u64>().ok());
    Some((ticks(11)? + ticks(12)?) as f64 * 10.0)
}

/// The wall and CPU time of a run's phases (`--stats`): evaluate, write, picture.
struct Phases {
    at: (std::time::Instant, Option<f64>),
    done: Vec<(&'static str, f64, Option<f64>)>,
}

impl Phases {
    fn start() -> Phases {
        Phases { at: (std::time::Instant::now(), process_cpu_ms()), done: Vec::new() }
    }

    /// A phase starts now (what ran since the last one is not counted).
    fn restart(&mut self) {
        self.at = (std::time::Instant::now(), process_cpu_ms());
    }

    /// The phase `name` ends now.
    fn end(&mut self, name: &'static str) {
        let cpu = process_cpu_ms();
        let wall = self.at.0.elapsed().as_secs_f64() * 1000.0;
        self.done.push((name, wall, cpu.zip(self.at.1).map(|(b, a)| b - a)));
        self.restart();
    }

    /// `time: evaluate 61.2 ms wall 60 ms CPU, write …, process 180.3 ms wall 170 ms CPU`.
    fn line(&self) -> String {
        let cpu = |c: Option<f64>| c.map_or_else(|| "n/a".to_string(), |c| format!("{c:.0} ms"));
        let mut parts: Vec<String> =
            self.done.iter().map(|(n, w, c)| format!("{n} {w:.1} ms wall {} CPU", cpu(*c))).collect();
        parts.push(format!("process {} wall {} CPU", cpu(process_wall_ms()), cpu(process_cpu_ms())));
        format!("time: {} (CPU: user + system, 10 ms ticks)", parts.join(", "))
    }
}

/// Milliseconds since the process started: `/proc/self/stat` field 22 (the start,
/// in USER_HZ ticks since boot) against `/proc/uptime` (10 ms resolution). `None`
/// where they cannot be read.
fn process_wall_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 1..];
    let start_ticks: f64 = rest.split_whitespace().nth(19)?.parse().ok()?;
    let up: f64 = std::fs::read_to_string("/proc/uptime").ok()?.split_whitespace().next()?.parse().ok()?;
    Some((up - start_ticks / 100.0) * 1000.0)
}

pub fn run(cli: Args) -> ExitCode {
    match run_checked(&cli) {
        Ok(code) => code,
        Err(failure) => failure.report("mdg-run"),
    }
}

/// The file name of `input` with `ext`, in the current directory: outputs never
/// land in the std library or beside a shared input (docs/decisions.md).
pub fn default_output(input: &Path, ext: &str) -> PathBuf {
    let stem = input.file_stem().map(|s| s.to_os_string()).unwrap_or_else(|| "out".into());
    PathBuf::from(stem).with_extension(ext)
}

fn parse_size(s: &str) -> Result<(u32, u32), Failure> {
    crate::args::parse_picture_size(s).map_err(Failure::usage)
}

/// The bundle of `file`, and the files read to make it (the source and its imports).
fn load_bundle(
    file: &Path,
    opts: &mdg_compiler::expand::Options,
    stdin: bool,
) -> Result<(Bundle, Vec<PathBuf>), Failure> {
    if file.extension().is_some_and(|e| e == "mdgb") && !stdin {
        if let Some(flag) = crate::args::source_only_flag(opts) {
            return Err(Failure::usage(format!(
                "{flag}: {} is a compiled bundle; {flag} applies when compiling the source (mdgc build {flag} …)",
                file.display()
            )));
        }
        let bytes = mdg_vm::input::read_bounded(file, mdg_vm::input::MAX_DATA_BYTES)
            .map_err(|e| Failure::usage(format!("cannot read {}: {e}", file.display())))?;
        let b = mdg_vm::bundle::load(&bytes).map_err(|e| Failure::input(format!("{}: {e}", file.display())))?;
        return Ok((b, vec![file.to_path_buf()]));
    }
    let built = if stdin {
        // At most the compiler's source limit: standard input can be endless.
        let max = mdg_compiler::source::MAX_SOURCE_BYTES;
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut std::io::Read::take(std::io::stdin().lock(), max as u64 + 1), &mut bytes)
            .map_err(|e| Failure::usage(format!("cannot read standard input: {e}")))?;
        if bytes.len() > max {
            return Err(Failure::usage(format!(
                "standard input is larger than the {} MiB source limit ({max} bytes); split the grammar into \
                     files joined with `@import`",
                max >> 20
            )));
        }
        let text = mdg_compiler::source::decode_source(bytes)
            .map_err(|e| Failure::usage(format!("cannot read standard input: {e}")))?;
        let loader = MemLoader { files: [(file.to_path_buf(), text)].into(), disk_fallback: true };
        driver::build(&loader, file, opts)
    } else {
        driver::build(&FsLoader, file, opts)
    };
    match built {
        Ok((b, a)) => {
            eprint!("{}", render_plain(&a.diagnostics, &a.sources));
            crate::args::check_declared(&a, opts).map_err(Failure::usage)?;
            let mut inputs: Vec<PathBuf> = a.sources.files.iter().map(|f| f.path.clone()).collect();
            inputs.push(file.to_path_buf());
            Ok((b, inputs))
        }
        Err(a) => {
            eprint!("{}", render_plain(&a.diagnostics, &a.sources));
            Err(Failure::input(format!("{} has errors", file.display())))
        }
    }
}

fn run_checked(cli: &Args) -> Result<ExitCode, Failure> {
    let opts = cli.compile.options().map_err(Failure::usage)?;
    let size = parse_size(&cli.size)?;
    let pose = match &cli.camera {
        Some(c) => Some(c.parse::<Pose>().map_err(|e| Failure::usage(format!("--camera {e}")))?),
        None => None,
    };
    if let Some(t) = cli.time {
        if !(t.is_finite() && t >= 0.0) {
            return Err(Failure::usage(format!("--time {t}: expected a number of seconds ≥ 0")));
        }
    }
    let batch = match &cli.seeds {
        Some(s) => {
            let seeds: Seeds = s.parse().map_err(Failure::usage)?;
            let shard: Shard = match &cli.shard {
                Some(k) => k.parse().map_err(Failure::usage)?,
                None => Shard::default(),
            };
            let template = cli
                .output
                .as_ref()
                .ok_or(Failure::usage("--seeds needs -o with `{seed}` in it, e.g. -o 'out/{seed}.glb'".to_string()))?;
            batch::output_for(template, 0).map_err(Failure::usage)?;
            if cli.seed.is_some() {
                return Err(Failure::usage("--seed and --seeds: choose one"));
            }
            Some((seeds, shard, template.clone()))
        }
        None => None,
    };
    if format_none(cli) {
        if let Some(o) = &cli.output {
            return Err(Failure::usage(format!(
                "--format none writes no model; drop -o {} (or choose a format)",
                o.display()
            )));
        }
        if cli.seeds.is_some() {
            return Err(Failure::usage(
                "--format none and --seeds: a batch writes one model per seed; choose a format",
            ));
        }
    }
    let (bundle, inputs) = load_bundle(&cli.file, &opts, cli.stdin)?;
    // An output that is an input would destroy the source (`mdg-run x.mdg -o x.mdg`).
    let outputs = [
        ("-o", cli.output.as_ref().filter(|_| cli.seeds.is_none())),
        ("--png", cli.png.as_ref()),
        ("--params-json", cli.params_json.as_ref()),
    ];
    for (flag, o) in outputs.iter().filter_map(|(f, o)| o.map(|o| (f, o))) {
        if let Some(i) = inputs.iter().find(|i| mdg_export::same_file(i, o)) {
            let (o, i) = (o.display(), i.display());
            return Err(Failure::usage(format!("{flag} {o}: that is an input ({i}); choose another output file")));
        }
    }
    if let Some(p) = &cli.params_json {
        export::write_atomic(p, bundle.params_json().as_bytes())
            .map_err(|e| Failure::usage(format!("cannot write {}: {e}", p.display())))?;
    }
    let pictures = Vulkan::new(opts.std_dir.clone()).posed(pose).samples(cli.samples).renderer(cli.renderer);
    if bundle.extensions.has(SectionKind::Creatures) {
        if batch.is_some() {
            return Err(Failure::usage(
                "--seeds: creature evolution writes a gallery per run; run it once per seed instead",
            ));
        }
        if let Some(o) = &cli.output {
            if o.extension().is_some() && !o.is_dir() {
                return Err(Failure::usage(format!(
                        "-o {}: creature evolution writes a folder (one .glb per monster, pictures, index.html); give a folder name such as -o monsters/",
                        o.display()
                    ),
                ));
            }
        }
        let out_dir = cli.output.clone().unwrap_or_else(|| modes::creature::default_dir(&cli.file));
        let common = common(cli, &opts, Some(&out_dir), cli.seed, size, &pictures);
        modes::creature::run(&bundle, &cli.creature, &common)?;
        return Ok(ExitCode::SUCCESS);
    }
    let is_grid = bundle.extensions.has(SectionKind::Grid);
    if is_grid && format_none(cli) {
        return Err(Failure::usage(
            "--format none is for mesh grammars; a grid grammar writes a voxel file (docs/grid.md)",
        ));
    }
    match batch {
        Some((seeds, shard, template)) => {
            if !is_grid && mesh_target(cli, &template)? == Target::Picture {
                return Err(Failure::usage(format!(
                    "-o {}: --seeds writes one model per seed ({MESH_FORMATS}); pictures are for single runs",
                    template.display()
                )));
            }
            run_batch(cli, &opts, &bundle, seeds, shard, &template, size, &pictures)
        }
        None => {
            let output = match &cli.output {
                Some(o) => o.clone(),
                None if is_grid => default_output(&cli.file, cli.format.as_deref().unwrap_or("vox")),
                // (--format none writes nothing: the name is only for messages.)
                None if format_none(cli) => default_output(&cli.file, "glb"),
                None => default_output(&cli.file, format(cli)?.extension()),
            };
            if is_grid {
                grid_format_agrees(cli, &output)?;
            } else if mesh_target(cli, &output)? == Target::Picture && cli.png.is_some() {
                return Err(Failure::usage(format!(
                        "-o {} and --png: both are pictures; write the model with -o NAME.glb (or .obj, …) and the picture with --png",
                        output.display()
                    ),
                ));
            }
            run_one(cli, &opts, &bundle, cli.seed, &output, size, &pictures, true).map(|_| ExitCode::SUCCESS)
        }
    }
}

fn common<'a>(
    cli: &'a Args,
    compile: &'a mdg_compiler::expand::Options,
    output: Option<&'a Path>,
    seed: Option<u64>,
    size: (u32, u32),
    pictures: &'a dyn Pictures,
) -> Common<'a> {
    let eval = eval_options(cli, seed);
    Common { file: &cli.file, output, seed, stats: cli.stats, png: cli.png.as_deref(), size, pictures, eval, compile }
}

/// The evaluation options of one run of `seed`: the limit flags, `--time`, `--sites`.
fn eval_options(cli: &Args, seed: Option<u64>) -> EvalOptions {
    EvalOptions { seed, time: cli.time, record_sites: cli.sites, ..cli.limits.eval_options() }
}

/// The formats a mesh grammar's `-o` takes, for messages.
const MESH_FORMATS: &str = ".glb, .obj, .stl, .ply, .json";

/// What `-o` asks a mesh grammar for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Model(Format),
    /// `--format none`: evaluate only, no model file.
    Nothing,
    /// `-o NAME.png`: the picture, as `--png NAME.png` draws it, and no model.
    Picture,
}

/// What `-o path` asks a mesh grammar for, checked against `--format`: an extension
/// no writer makes is an error listing the formats (the voxel ones say they are for
/// grid grammars), `.png` is the picture, and `--format` must agree with the
/// extension. No extension: `--format`, else glb.
fn mesh_target(cli: &Args, path: &Path) -> Result<Target, Failure> {
    if format_none(cli) {
        return Ok(Target::Nothing);
    }
    let flag = match &cli.format {
        Some(_) => Some(format(cli)?),
        None => None,
    };
    let Some(ext) = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()) else {
        return Ok(Target::Model(flag.unwrap_or(Format::Glb)));
    };
    let shown = path.display();
    let target = match Format::from_extension(&ext) {
        Some(f) => Target::Model(f),
        None if ext == "png" => Target::Picture,
        None if mdg_grid::format::VoxelFormat::from_extension(&ext).is_some() => {
            return Err(Failure::usage(format!(
                "-o {shown}: .{ext} is a voxel format, written by grid grammars (a `grid` section: docs/grid.md); \
                     this grammar makes a mesh: write {MESH_FORMATS}"
            )))
        }
        None => {
            let hint = if ext == "gltf" { " (binary glTF is .glb)" } else { "" };
            return Err(Failure::usage(format!("-o {shown}: mdg-run does not write .{ext} files{hint}; it writes {MESH_FORMATS}, or a picture with .png"),
            ));
        }
    };
    match (flag, target) {
        (Some(f), Target::Model(g)) if f != g => Err(Failure::usage(format!(
            "--format {} and -o {shown} disagree; drop --format or name the file .{}",
            f.extension(),
            f.extension()
        ))),
        (Some(f), Target::Picture) => Err(Failure::usage(format!(
            "--format {} and -o {shown} disagree: .png is the picture; drop --format",
            f.extension()
        ))),
        _ => Ok(target),
    }
}

/// A grid grammar's `--format` must agree with `-o`'s extension (its output format
/// comes from the extension, docs/grid.md).
fn grid_format_agrees(cli: &Args, output: &Path) -> Result<(), Failure> {
    let Some(f) = &cli.format else { return Ok(()) };
    format(cli)?;
    let ext = output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext.as_deref() != Some(f.to_ascii_lowercase().trim_start_matches('.')) {
        return Err(Failure::usage(format!(
            "--format {f} and -o {} disagree; a grid grammar writes the format of -o's extension",
            output.display()
        )));
    }
    Ok(())
}

/// Whether `--format none` asks for an evaluation that writes no model.
fn format_none(cli: &Args) -> bool {
    cli.format.as_deref().is_some_and(|f| f.eq_ignore_ascii_case("none"))
}

fn format(cli: &Args) -> Result<Format, Failure> {
    match &cli.format {
        Some(f) => Format::from_extension(f)
            .ok_or(Failure::usage(format!("unknown format `{f}` (glb, obj, stl, ply, json, none)"))),
        None => Ok(cli.output.as_deref().and_then(Format::from_path).unwrap_or(Format::Glb)),
    }
}

/// Evaluates one seed into `output` (and the picture, the frames); returns the
/// vertex and triangle counts of a mesh output (`None` for a grid's voxels).
#[allow(clippy::too_many_arguments)]
fn run_one(
    cli: &Args,
    opts: &mdg_compiler::expand::Options,
    bundle: &Bundle,
    seed: Option<u64>,
    output: &Path,
    size: (u32, u32),
    pictures: &dyn Pictures,
    say_wrote: bool,
) -> Result<Option<(u64, u64)>, Failure> {
    if bundle.extensions.has(SectionKind::Grid) {
        let common = common(cli, opts, Some(output), seed, size, pictures);
        modes::grid::run(bundle, &cli.grid, &common)?;
        return Ok(None);
    }
    let (format, picture_only, nothing) = match mesh_target(cli, output)? {
        Target::Model(f) => (f, false, false),
        Target::Picture => (Format::Glb, true, false),
        Target::Nothing => (Format::Glb, false, true),
    };
    // A `.glb` written with --instances keeps prototype instances as records: the
    // vertex budget counts them so (docs/limits.md). So does a picture of flat art
    // alone that the CPU renderer paints (unlit, no isosurface): it expands each
    // instance as it paints it and stores none.
    let painted = picture_only
        && bundle.settings.flat
        && bundle.program.is_none()
        && bundle.isosurfaces.is_empty()
        && cli.renderer != crate::pictures::RendererChoice::Vulkan;
    let stored = (cli.instances && format == Format::Glb && !picture_only && !nothing) || painted;
    let eval_opts = EvalOptions { instances_stored: stored, ..eval_options(cli, seed) };
    let mut phases = Phases::start();
    let started = std::time::Instant::now();
    let bar = indicatif::ProgressBar::hidden();
    // (A batch shows its own bar: its seeds run side by side, without spinners.)
    let progress = |calls: u64| {
        if say_wrote && bar.is_hidden() && started.elapsed() > Duration::from_secs(1) {
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            bar.set_style(
                indicatif::ProgressStyle::with_template("{spinner} {elapsed} {msg}")
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
        }
        bar.set_message(format!("{calls} rule calls"));
        bar.tick();
    };
    let mut out = if bundle.extensions.has(SectionKind::Guided) {
        let common = common(cli, opts, Some(output), seed, size, pictures);
        modes::guided::run(bundle, &cli.guided, &common, &eval_opts)?
    } else {
        let mut out = evaluate_with_progress(bundle, &eval_opts, Some(&progress));
        if let Some(flag) = cli.guided.given() {
            out.stats.warnings.push(format!("{flag} is ignored: the grammar has no `search` section (docs/guided.md)"));
        }
        out
    };
    bar.finish_and_clear();
    phases.end("evaluate");
    for d in &out.debug {
        eprintln!("{}", mdg_compiler::diag::escape_text(d));
    }
    for w in &out.stats.warnings {
        // Warnings quote names and paths from the grammar: printed escaped.
        eprintln!("warning: {}", mdg_compiler::diag::escape_text(w));
    }
    match cli.time {
        Some(t) => out = out.posed(t),
        None if out.animation.bones.len() > 1 && format != Format::Glb => {
            eprintln!("note: the model is animated; {} has no animation, so this is the rest pose (choose a pose with --time T)", format.extension());
        }
        None => {}
    }
    if let Some(dir) = output.parent().filter(|d| !d.as_os_str().is_empty() && !d.exists()) {
        std::fs::create_dir_all(dir).map_err(|e| Failure::usage(format!("cannot create {}: {e}", dir.display())))?;
    }
    if cli.instances && picture_only {
        eprintln!("note: --instances is for .glb; -o {} writes only the picture", output.display());
    } else if cli.instances && nothing {
        eprintln!("note: --instances is for .glb; --format none writes no model");
    } else if cli.instances && format != Format::Glb {
        eprintln!("note: --instances is for .glb; {} expands every instance", format.extension());
    }
    let glb = export::glb::GlbOptions { instances: cli.instances };
    if !picture_only && !nothing {
        phases.restart();
        export::write_file_with(format, &out, &glb, output)?;
        phases.end("write");
    }
    let picture = if picture_only { Some(output) } else { cli.png.as_deref() };
    if let Some(png_path) = picture {
        // `--renderer cpu` for a program the CPU renderer does not implement is a
        // usage error, before anything is drawn.
        if cli.renderer == RendererChoice::Cpu {
            crate::pictures::decide(cli.renderer, bundle, &out, opts.std_dir.as_deref(), false)
                .map_err(Failure::usage)?;
        }
        // With --time the pose is already baked into `out`.
        phases.restart();
        let bytes = pictures
            .render(Some(bundle), &out, size)
            .map_err(|e| Failure::input(format!("cannot render the picture: {e}")))?;
        export::write_atomic(png_path, &bytes)
            .map_err(|e| Failure::usage(format!("cannot write {}: {e}", png_path.display())))?;
        phases.end("picture");
        eprintln!("wrote {}", png_path.display());
    }
    if let Some(dir) = &cli.frames {
        write_frames(bundle, &out, dir, size, pictures)?;
    }
    if cli.stats {
        let s = &out.stats;
        let prototypes = out.instances.iter().filter(|i| out.is_prototype_instance(i)).count();
        eprintln!(
            "rule calls {}  vertices {}  triangles {}  lines {}  instances {}  prototype instances {}  time {:.1} ms  peak memory {}",
            s.rule_calls,
            s.vertices,
            s.triangles,
            out.lines.len(),
            out.instances.len() - prototypes,
            prototypes,
            s.elapsed_ms,
            peak_rss_kib().map(|k| format!("{:.1} MiB", k as f64 / 1024.0)).unwrap_or_else(|| "n/a".into())
        );
        eprintln!("{}", phases.line());
        if let (Some(line), true) = (pictures.last_renderer(), picture.is_some() || cli.frames.is_some()) {
            let loaded = match vulkan_loaded() {
                Some(true) => "yes",
                Some(false) => "no",
                None => "n/a",
            };
            eprintln!("picture drawn by the {line}; libvulkan loaded: {loaded}");
        }
        let (compiled, cached) = mdg_compiler::shaders::compile_counts();
        eprintln!("shaders compiled with glslang {compiled}  taken from the SPIR-V cache {cached}");
    }
    if say_wrote && !picture_only && !nothing {
        eprintln!("wrote {}", output.display());
    }
    // The counts go into a batch's manifest; a single run has no use for them (and
    // counting walks every instance of a big model).
    Ok(Some(if say_wrote { (0, 0) } else { counts(&out) }))
}

/// Vertices and triangles of the flattened model (what OBJ, STL and PLY hold),
/// counted without building it.
fn counts(out: &Output) -> (u64, u64) {
    let (v, t) = out.flat_counts(mdg_vm::output::Groups::ALL);
    (v as u64, t as u64)
}

/// The most frames `--frames` writes.
pub const MAX_FRAMES: u64 = 100_000;

/// `--frames DIR`: the animation at `fps` for `duration` seconds as numbered PNGs,
/// then `animation.mp4` when ffmpeg is installed.
fn write_frames(
    bundle: &Bundle,
    out: &Output,
    dir: &Path,
    size: (u32, u32),
    pictures: &dyn Pictures,
) -> Result<(), Failure> {
    let (fps, duration) = (bundle.settings.fps, bundle.settings.duration);
    if !(fps.is_finite() && fps > 0.0 && duration.is_finite() && duration > 0.0) {
        return Err(Failure::input(format!(
            "--frames: the grammar's fps ({fps}) and duration ({duration}) give no frames"
        )));
    }
    let n = (f64::from(duration) * f64::from(fps)).ceil().max(1.0);
    if n > MAX_FRAMES as f64 {
        return Err(Failure::usage(format!("--frames: {n} frames (duration {duration} s at {fps} fps); at most {MAX_FRAMES}: lower `duration` or `fps`")));
    }
    std::fs::create_dir_all(dir).map_err(|e| Failure::usage(format!("cannot create {}: {e}", dir.display())))?;
    let n = n as u64;
    let bar = indicatif::ProgressBar::new(n);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} frames  {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    for i in 0..n {
        let t = i as f32 / fps;
        let png = pictures
            .render_at(Some(bundle), out, size, t)
            .map_err(|e| Failure::input(format!("cannot render frame {i}: {e}")))?;
        let path = dir.join(format!("frame-{i:05}.png"));
        export::write_atomic(&path, &png)
            .map_err(|e| Failure::usage(format!("cannot write {}: {e}", path.display())))?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    eprintln!("wrote {n} frames to {}", dir.display());
    let mp4 = dir.join("animation.mp4");
    let ffmpeg = std::process::Command::new("ffmpeg")
        .args(["-loglevel", "error", "-y", "-framerate"])
        .arg(format!("{fps}"))
        .arg("-i")
        .arg(dir.join("frame-%05d.png"))
        .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
        .arg(&mp4)
        .status();
    match ffmpeg {
        Ok(s) if s.success() => eprintln!("wrote {}", mp4.display()),
        Ok(s) => eprintln!("warning: ffmpeg failed ({s}); the PNG frames are in {}", dir.display()),
        Err(_) => eprintln!("note: no ffmpeg on PATH, so no animation.mp4 (the PNG frames are in {})", dir.display()),
    }
    Ok(())
}

/// `--seeds`: every seed of this shard, skipping the finished ones.
#[allow(clippy::too_many_arguments)]
fn run_batch(
    cli: &Args,
    opts: &mdg_compiler::expand::Options,
    bundle: &Bundle,
    seeds: Seeds,
    shard: Shard,
    template: &Path,
    size: (u32, u32),
    pictures: &dyn Pictures,
) -> Result<ExitCode, Failure> {
    if cli.png.is_some() || cli.frames.is_some() {
        return Err(Failure::usage("--seeds writes one model per seed; --png and --frames are for single runs"));
    }
    let in_shard = |s: u64| s >= seeds.start && s < seeds.end && (s - seeds.start) % shard.count == shard.index;
    let (mut manifest, warnings) = match Manifest::open(&batch::manifest_path(template, shard), in_shard) {
        Ok(m) => m,
        // EX_TEMPFAIL: the shard is being run; try again later.
        Err(batch::OpenError::Busy(m)) => return Err(Failure::busy(m)),
        Err(batch::OpenError::Refused(m)) => return Err(Failure::usage(m)),
    };
    for w in warnings {
        eprintln!("warning: {w}");
    }
    let mut skipped = 0u64;
    let seeds_here: Vec<u64> = batch::shard_seeds(seeds, shard).collect();
    let bar = indicatif::ProgressBar::new(seeds_here.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} seeds  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let mut todo = Vec::new();
    for seed in seeds_here {
        let output = batch::output_for(template, seed).map_err(Failure::usage)?;
        if manifest.is_done(seed, &output) {
            skipped += 1;
            bar.inc(1);
        } else {
            todo.push((seed, output));
        }
    }
    let jobs = cli
        .jobs
        .map(|j| j as usize)
        .unwrap_or_else(|| std::thread::available_parallelism().map(std::num::NonZeroUsize::get).unwrap_or(1));
    // A worker runs its seed, its files written under their temporary names, and
    // makes its manifest line (hashing the files as written); this thread flushes
    // them to disk and renames them into place, then appends the line, in seed
    // order (the workers compute meanwhile: they never wait for the disk).
    let run = |seed: u64, output: &Path| {
        let (counts, pending) =
            export::durable::deferring(|| run_one(cli, opts, bundle, Some(seed), output, size, pictures, false));
        let counts = counts?;
        let resolved = export::resolve_symlinks(output).unwrap_or_else(|_| output.to_path_buf());
        let written = pending.iter().find(|p| p.path() == resolved).map_or(output, |p| p.written());
        let line = batch::Entry { seed, file: output.to_path_buf(), counts }.line_reading(written);
        Ok((pending, line.map_err(Failure::usage)?))
    };
    let ran =
        batch::run_in_order(&todo, jobs, run, |seed, _, (pending, line): (Vec<export::durable::Pending>, String)| {
            for p in pending {
                let path = p.path().to_path_buf();
                p.finish().map_err(|e| Failure::usage(format!("cannot write {}: {e}", path.display())))?;
            }
            bar.inc(1);
            manifest.record(seed, &line).map_err(Failure::usage)
        })?;
    bar.finish_and_clear();
    eprintln!(
        "{ran} seeds run, {skipped} already done (shard {}/{}); manifest {}",
        shard.index,
        shard.count,
        manifest.path().display()
    );
    Ok(ExitCode::SUCCESS)
}
