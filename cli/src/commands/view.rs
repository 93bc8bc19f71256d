//! `mdg-view FILE`: show a grammar in a window, or render it offscreen to PNG. A
//! grammar with a `search` section is searched first (its guides from the grammar
//! or `--guides`), and in the window its guides can be edited (docs/guided.md).

use crate::failure::{Exit, Failure};
use crate::toolchain::Toolchain;
use mdg_guided::{Cancel, Guide, GuidedTable, Stop};
use mdg_viewer::camera::Pose;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::cpu;
use mdg_viewer::guided::edit::Editor;
use mdg_viewer::guided::search::{run_search, SearchRequest};
use mdg_viewer::guided::watch::read_guides;
use mdg_viewer::model::{self, LoadOptions, Loader};
use mdg_viewer::offscreen::{self, Offscreen};
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::window::{self, WindowOptions};
use mdg_viewer::Error;
use mdg_vm::bundle::{Section as _, SectionKind};
use mdg_vm::eval::EvalOptions;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

#[derive(clap::Parser, Debug)]
#[command(name = "mdg-view", version, about = "Show an MDG grammar with Vulkan, in a window or offscreen to PNG")]
#[command(after_help = "Examples:
  mdg-view std/examples/tree.mdg                          # window with hot reload
  mdg-view tree.mdg --png tree.png --size 1024x768        # offscreen, no window
  mdg-view tree.mdg --png sheet.png --turntable 8         # 8 views + contact sheet
  mdg-view tree.mdg --frames 10 --screenshot shot.png     # window, 10 frames, then exit

Window keys: drag = orbit, right/middle drag or shift+drag = pan, wheel = zoom,
F = frame the model, H = home view, W = wireframe, arrows = orbit, +/- = zoom,
Space = play/pause, , and . = step one frame back/forward, C = camera rule on/off,
G = overlays on/off, P = next @param, [ and ] = change it ({ }: x10), Esc/Q = quit.

Guided grammars (a `search` section) are searched on opening, on every reload and
whenever the guides change; the title shows the final cost, its terms, the model's
generation and why the search stopped. Editing the guides in the window:
  left drag on a control point   move it in the view plane (the tree follows)
  left click on a curve, Tab     select a guide
  Ctrl+left drag, or D then drag draw a new guide (fitted with Bezier segments)
  Delete / Backspace             delete the selected guide
  T (Shift+T back), 1-5          choose delta_a, scale_a, scale_d, scale_u, segment
  J / K (Shift: x10)             lower / raise it (also Page Down / Page Up)
  R = reseed, U or Ctrl+Z = undo, Shift+U or Ctrl+Y = redo, Esc = abandon a drag
  S                              save the guides as JSON (to --guides FILE, else
                                 ./NAME.guides.json), the format of mdg-run --guides

--script FILE feeds the window input from a file, one command a line: wait MS,
idle (until the newest search is shown), move X Y, move-by DX DY [N], point G P
(the cursor onto guide G's control point P, from 1), press/release left|right|middle,
key K (a character or escape, tab, delete, backspace, home, left, right, up, down,
pageup, pagedown, space; ctrl+ and shift+ prefixes), screenshot FILE.png, quit.

Exit status: 0 ok, 1 compile or render error, 2 usage, 3 Vulkan validation errors.")]
pub struct Args {
    /// The grammar: `.mdg` source or `.mdgb` bundle.
    pub file: PathBuf,
    /// Render offscreen to this PNG instead of opening a window.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Image or window size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x768")]
    size: String,
    /// Animation time in seconds: bones, the camera rule and frame-bound uniforms
    /// are read at this time (the window starts there).
    #[arg(long, default_value_t = 0.0)]
    time: f32,
    /// The view: `rule` looks through the grammar's camerarule, `home` frames the
    /// model from the front right, `auto` is `rule` when there is one (offscreen);
    /// `AZ,EL[,ZOOM]` frames it from azimuth AZ and elevation EL in degrees, ZOOM
    /// times closer (window and offscreen), e.g. `--camera 0,90` looks down.
    #[arg(long, default_value = "auto")]
    camera: String,
    /// With --png: render N views around the model (1 to 360), written as
    /// FILE-NN.png as they are made, and a contact sheet of them at FILE (at most
    /// 4096 pixels wide: the views shrink to fit).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=MAX_TURNTABLE as i64))]
    turntable: Option<u32>,
    /// Window: exit after N frames.
    #[arg(long, value_name = "N")]
    frames: Option<u64>,
    /// Window: write the last frame to this PNG (read back from the swapchain).
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Window: do not reload when the files change.
    #[arg(long)]
    no_watch: bool,
    /// Guided search: guiding curves from a JSON file instead of the grammar's
    /// `guide` sections (watched in the window; `S` saves the edited guides back to it).
    #[arg(long, value_name = "FILE.json")]
    guides: Option<PathBuf>,
    /// Window: read input from FILE instead of the mouse and keyboard (commands
    /// below).
    #[arg(long, value_name = "FILE")]
    script: Option<PathBuf>,
    /// Draw wireframe (offscreen; press W in the window).
    #[arg(long)]
    wireframe: bool,
    /// Samples: `auto` (offscreen: one sample and edge smoothing on the CPU
    /// renderer and on a CPU driver such as lavapipe, 4x multisampling on a GPU;
    /// the window: 4x) or a count (1 draws aliased edges; a count the renderer
    /// lacks gives the next it has, with a warning).
    #[arg(long, default_value = "auto", value_name = "auto|N", value_parser = crate::args::parse_samples)]
    samples: u32,
    /// With --png: which renderer draws: `auto` (the CPU renderer when the model's
    /// program is std's Phong program or flat art, which it implements exactly; else
    /// Vulkan), `cpu` (an error for a grammar's own shaders or --wireframe) or
    /// `vulkan`. The line printed before the picture says which drew it and why.
    #[arg(long, value_enum, default_value = "auto")]
    renderer: crate::pictures::RendererChoice,
    /// Seed for the random stream (overrides `randseed`).
    #[arg(long)]
    seed: Option<u64>,
    #[command(flatten)]
    compile: crate::args::CompileArgs,
    #[command(flatten)]
    limits: crate::args::LimitArgs,
}

/// The most views `--turntable` renders.
const MAX_TURNTABLE: u32 = 360;

/// `dir/stem-NN.ext` beside `path`.
fn numbered(path: &Path, i: u32, n: u32) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "view".into());
    let digits = (n.max(1) - 1).to_string().len().max(2);
    path.with_file_name(format!("{stem}-{i:0digits$}.png"))
}

/// Runs the guided search as the window's first one does and puts its model, the
/// guides and the bones (the window's overlay) into `model`.
fn search_for_picture(model: &mut model::Model, guides: Option<Vec<Guide>>, eval: &EvalOptions) -> Result<(), Failure> {
    let Some(table) = GuidedTable::from_bundle(&model.bundle).map_err(|e| Failure::input(e.to_string()))? else {
        return Ok(());
    };
    let guides = guides.unwrap_or_else(|| table.guides.clone());
    let seed = eval.seed.unwrap_or(model.bundle.settings.randseed);
    let request = SearchRequest {
        bundle: Arc::new(model.bundle.clone()),
        guides: guides.clone(),
        seed,
        eval: eval.clone(),
        utilisation: None,
        reach: Arc::default(),
    };
    let found = run_search(&request, &Cancel::new())?;
    eprintln!("mdg-view: guided search: {}", found.summary.line());
    if found.summary.stop == Stop::Budget {
        eprintln!(
            "warning: guided search: the `search` section's time budget ended the search after {} of {} generations \
             (the picture depends on the machine's speed)",
            found.summary.generations, found.summary.scheduled
        );
    }
    model.output = found.output;
    let editor = Editor::new(guides);
    model.output.lines.extend(editor.overlay(editor.marker_size()));
    Ok(())
}

/// The offscreen camera choice of `--camera` for a model with (or without) a camera
/// rule: the pose, and whether to look through the rule.
fn offscreen_view(cli: &Args, has_camera_rule: bool) -> Result<(Option<Pose>, bool), Error> {
    let pose = camera_pose(&cli.camera)?;
    let camera_rule = match cli.camera.as_str() {
        _ if pose.is_some() => false,
        "home" => false,
        "rule" if !has_camera_rule => {
            return Err(Error::Other("--camera rule: the grammar has no camerarule".into()));
        }
        _ => has_camera_rule && cli.turntable.is_none(),
    };
    Ok((pose, camera_rule))
}

/// Writes the picture (or the turntable's views and sheet) of `render`, a function
/// of a camera giving RGBA pixels.
fn write_pictures(
    cli: &Args,
    png: &Path,
    size: (u32, u32),
    home: mdg_viewer::camera::OrbitCamera,
    background: [f32; 4],
    mut render: impl FnMut(mdg_viewer::camera::OrbitCamera) -> Result<Vec<u8>, Error>,
) -> Result<(), Error> {
    match cli.turntable {
        None => {
            let px = render(home)?;
            offscreen::write_png(png, &px, size.0, size.1)?;
        }
        Some(n) => {
            // Only the sheet's shrunk copies are kept: memory stays that of one sheet.
            let k = offscreen::sheet_factor(n, size.0);
            let mut views = Vec::new();
            let mut tile = size;
            for (i, cam) in offscreen::turntable(&home, n).into_iter().enumerate() {
                let px = render(cam)?;
                offscreen::write_png(&numbered(png, i as u32, n), &px, size.0, size.1)?;
                let (small, w, h) = offscreen::shrink(&px, size.0, size.1, k);
                tile = (w, h);
                views.push(small);
            }
            let bg = background.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
            let (sheet, w, h) = offscreen::contact_sheet(&views, tile.0, tile.1, bg);
            offscreen::write_png(png, &sheet, w, h)?;
        }
    }
    Ok(())
}

/// The picture by the CPU renderer (`mdg_viewer::cpu`): no Vulkan is loaded.
fn offscreen_cpu(cli: &Args, model: &model::Model, size: (u32, u32), program: &cpu::Program) -> Result<u32, Error> {
    let Some(png) = &cli.png else { return Ok(0) };
    let t0 = std::time::Instant::now();
    let (opts, warning) = crate::pictures::cpu_options(cli.samples, size);
    if let Some(w) = warning {
        eprintln!("{w}");
    }
    let scene = cpu::CpuScene::new(&model.bundle, &model.output, program);
    let info = scene.info().clone();
    let (pose, camera_rule) = offscreen_view(cli, info.has_camera_rule)?;
    let aspect = size.0 as f32 / size.1 as f32;
    let home = match pose {
        Some(p) => scene.home_camera(aspect).posed(&info.bounds, aspect, p),
        None => scene.home_camera(aspect),
    };
    let mut drawn = cpu::Drawn::default();
    write_pictures(cli, png, size, home, info.background, |camera| {
        let frame = FrameParams { camera, time: cli.time, wireframe: false, camera_rule };
        let (px, d) = scene.render(&frame, &opts);
        drawn = d;
        Ok(px)
    })?;
    eprintln!(
        "mdg-view: {} triangles, {} line segments, drawn by the {}",
        info.n_triangles,
        info.n_line_segments,
        crate::pictures::cpu_note(program, &opts, &drawn)
    );
    eprintln!("mdg-view: wrote {} ({:.0} ms)", png.display(), t0.elapsed().as_secs_f64() * 1e3);
    Ok(0)
}

fn offscreen(cli: &Args, model: &model::Model, size: (u32, u32), std_dir: Option<&Path>) -> Result<u32, Error> {
    let decision = crate::pictures::decide(cli.renderer, &model.bundle, &model.output, std_dir, cli.wireframe)
        .map_err(Error::Other)?;
    let why = match decision {
        crate::pictures::Decision::Cpu(program) => return offscreen_cpu(cli, model, size, &program),
        crate::pictures::Decision::Vulkan(why) => why,
    };
    let programs = Toolchain.programs(std_dir)?;
    let programs = &programs;
    offscreen::keep_freed_memory();
    let ctx = Arc::new(Context::new(&ContextOptions {
        validation: Validation::from_env(),
        surface_extensions: vec![],
        on_message: Some(crate::say),
    })?);
    let mut off = Offscreen::new(&ctx, size.0, size.1, cli.samples)?;
    if crate::pictures::stand_ins_off() {
        off.renderer_mut().stand_ins = false;
    }
    if let Some(w) = crate::args::samples_warning(&off.sample_choice(), &ctx.device_name) {
        eprintln!("{w}");
    }
    let t0 = std::time::Instant::now();
    let info = off.set_model(model, programs)?;
    eprintln!(
        "mdg-view: {} triangles, {} line segments, program {} on {}, {} sample(s){} (upload {:.0} ms), drawn by the Vulkan renderer, because {why}",
        info.n_triangles,
        info.n_line_segments,
        info.program,
        ctx.device_name,
        off.samples(),
        if off.smooth { " and edge smoothing" } else { "" },
        t0.elapsed().as_secs_f64() * 1e3
    );
    let Some(png) = &cli.png else { return Ok(0) };
    let (pose, camera_rule) = offscreen_view(cli, info.has_camera_rule)?;
    let home = match pose {
        Some(p) => off.home_camera().posed(&info.bounds, size.0 as f32 / size.1 as f32, p),
        None => off.home_camera(),
    };
    let frame = |camera| FrameParams { camera, time: cli.time, wireframe: cli.wireframe && ctx.wireframe, camera_rule };
    write_pictures(cli, png, size, home, info.background, |cam| off.render(&frame(cam)))?;
    eprintln!("mdg-view: wrote {} ({:.0} ms)", png.display(), t0.elapsed().as_secs_f64() * 1e3);
    drop(off);
    Ok(ctx.validation_log().errors())
}

/// `--camera`: `None` for auto/home/rule, the pose for `AZ,EL[,ZOOM]`.
fn camera_pose(arg: &str) -> Result<Option<Pose>, Error> {
    match arg {
        "auto" | "home" | "rule" => Ok(None),
        _ => arg.parse::<Pose>().map(Some).map_err(|e| Error::Other(format!("--camera {e}"))),
    }
}

pub fn run(cli: Args) -> ExitCode {
    match run_checked(&cli) {
        Ok(code) => code,
        Err(failure) => failure.report("mdg-view"),
    }
}

/// The viewer's errors: compile errors in the grammar (their diagnostics are the
/// message) and the window's and Vulkan's failures are errors in the input, a flag
/// the grammar does not use (`Other` from the loader) a usage error.
fn viewer_failure(e: Error) -> Failure {
    match e {
        Error::Other(_) => Failure::usage(e.to_string()),
        _ => Failure::input(e.to_string()),
    }
}

fn run_checked(cli: &Args) -> Result<ExitCode, Failure> {
    let size = crate::args::parse_picture_size(&cli.size).map_err(Failure::usage)?;
    let opts = cli.compile.options().map_err(Failure::usage)?;
    let pose = camera_pose(&cli.camera).map_err(|e| Failure::usage(e.to_string()))?;
    if cli.turntable.is_some() && cli.png.is_none() {
        return Err(Failure::usage("--turntable needs --png"));
    }
    if cli.script.is_some() && (cli.png.is_some() || cli.frames.is_some()) {
        return Err(Failure::usage(
            "--script drives the window: it cannot be combined with --png or --frames (use `quit`)",
        ));
    }
    let script = match &cli.script {
        None => None,
        Some(path) => {
            let text = mdg_vm::input::read_text_bounded(path, mdg_vm::input::MAX_DATA_BYTES)
                .map_err(|e| Failure::from(e).context(format!("--script cannot read {}", path.display())))?;
            let commands = mdg_viewer::script::parse(&text)
                .map_err(|e| Failure::from(e).context(format!("--script {}", path.display())))?;
            Some(commands)
        }
    };
    let eval = EvalOptions { seed: cli.seed, ..cli.limits.eval_options() };
    let load =
        LoadOptions { std_dir: opts.std_dir, params: opts.params, presets: opts.defines, eval, guided_search: true };
    let (mut model, files) = match Toolchain.load(&cli.file, &load) {
        Ok(m) => m,
        // A grammar's diagnostics are printed as they are, without the prefix.
        Err(fail) if matches!(fail.error, Error::Compile(_)) => {
            let text = fail.error.to_string();
            eprint!("{text}");
            if !text.ends_with('\n') {
                eprintln!();
            }
            return Err(Failure::shown(Exit::Input));
        }
        Err(fail) => return Err(viewer_failure(fail.error)),
    };
    eprint!("{}", model.warnings);
    let guided = model.bundle.extensions.has(SectionKind::Guided);
    let guides = match (&cli.guides, guided) {
        (Some(path), true) => Some((path.clone(), read_guides(path)?)),
        (Some(_), false) => {
            eprintln!("warning: `--guides` is ignored: the grammar has no `search` section");
            None
        }
        (None, _) => None,
    };
    if cli.png.is_some() {
        search_for_picture(&mut model, guides.clone().map(|g| g.1), &load.eval)?;
    }
    for d in &model.output.debug {
        eprintln!("{}", mdg_compiler::diag::escape_text(d));
    }
    for w in &model.output.stats.warnings {
        // Warnings quote names and paths from the grammar: printed escaped.
        eprintln!("warning: {}", mdg_compiler::diag::escape_text(w));
    }
    // `S` saves to the guide file, else to NAME.guides.json in the current directory.
    let save_guides = match &guides {
        Some((path, _)) => path.clone(),
        None => {
            let stem =
                cli.file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "guides".into());
            PathBuf::from(format!("{stem}.guides.json"))
        }
    };
    let result = if cli.png.is_some() {
        offscreen(cli, &model, size, load.std_dir.as_deref())
    } else {
        let opts = WindowOptions {
            width: size.0,
            height: size.1,
            frames: cli.frames,
            screenshot: cli.screenshot.clone(),
            watch: !cli.no_watch,
            load: load.clone(),
            validation: Validation::from_env(),
            // The window keeps 4x multisampling unless asked otherwise: it has no
            // smoothing pass.
            samples: if cli.samples == 0 { 4 } else { cli.samples },
            time: cli.time,
            pose,
            log: crate::say,
            guides,
            save_guides,
            script,
        };
        window::run(cli.file.clone(), model, files, opts, Arc::new(Toolchain)).map(|s| {
            eprintln!("mdg-view: closed cleanly after {} frames ({} reloads) on {}", s.frames, s.reloads, s.device);
            s.validation_errors
        })
    };
    match result {
        Ok(0) => Ok(ExitCode::SUCCESS),
        Ok(n) => Err(Failure { exit: Exit::Validation, message: format!("{n} Vulkan validation error(s)") }),
        Err(e) => Err(Failure::input(e.to_string())),
    }
}
