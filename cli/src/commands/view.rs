//! `mdg-view FILE`: show a grammar in a window, or render it offscreen to PNG.

use crate::toolchain::Toolchain;
use mdg_viewer::camera::Pose;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::model::{self, LoadOptions, Loader};
use mdg_viewer::offscreen::{self, Offscreen};
use mdg_viewer::program::Programs;
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::window::{self, WindowOptions};
use mdg_viewer::Error;
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
Esc/Q = quit.

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
    /// Draw wireframe (offscreen; press W in the window).
    #[arg(long)]
    wireframe: bool,
    /// MSAA samples (the largest supported ≤ this, at least 2; 4 always works).
    #[arg(long, default_value_t = 4)]
    samples: u32,
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

/// The largest picture side, as `mdg-run --size` (an 8192² RGBA picture is 256 MiB).
const MAX_SIDE: u32 = 8192;

fn parse_size(s: &str) -> Option<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X'])?;
    let (w, h) = (w.trim().parse().ok()?, h.trim().parse().ok()?);
    (w > 0 && h > 0 && w <= MAX_SIDE && h <= MAX_SIDE).then_some((w, h))
}

/// `dir/stem-NN.ext` beside `path`.
fn numbered(path: &Path, i: u32, n: u32) -> PathBuf {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "view".into());
    let digits = (n.max(1) - 1).to_string().len().max(2);
    path.with_file_name(format!("{stem}-{i:0digits$}.png"))
}

fn offscreen(cli: &Args, model: &model::Model, size: (u32, u32), programs: &Programs) -> Result<u32, Error> {
    let ctx = Arc::new(Context::new(&ContextOptions {
        validation: Validation::from_env(),
        surface_extensions: vec![],
        on_message: Some(crate::say),
    })?);
    let mut off = Offscreen::new(&ctx, size.0, size.1, cli.samples)?;
    let t0 = std::time::Instant::now();
    let info = off.set_model(model, programs)?;
    eprintln!(
        "mdg-view: {} triangles, {} line segments, program {} on {}, {}x MSAA (upload {:.0} ms)",
        info.n_triangles,
        info.n_line_segments,
        info.program,
        ctx.device_name,
        off.samples(),
        t0.elapsed().as_secs_f64() * 1e3
    );
    let Some(png) = &cli.png else { return Ok(0) };
    let pose = camera_pose(&cli.camera)?;
    let home = match pose {
        Some(p) => off.home_camera().posed(&info.bounds, size.0 as f32 / size.1 as f32, p),
        None => off.home_camera(),
    };
    let camera_rule = match cli.camera.as_str() {
        _ if pose.is_some() => false,
        "home" => false,
        "rule" if !info.has_camera_rule => {
            return Err(Error::Other("--camera rule: the grammar has no camerarule".into()));
        }
        _ => info.has_camera_rule && cli.turntable.is_none(),
    };
    let frame = |camera| FrameParams { camera, time: cli.time, wireframe: cli.wireframe && ctx.wireframe, camera_rule };
    match cli.turntable {
        None => {
            let px = off.render(&frame(home))?;
            offscreen::write_png(png, &px, size.0, size.1)?;
        }
        Some(n) => {
            // Only the sheet's shrunk copies are kept: memory stays that of one sheet.
            let k = offscreen::sheet_factor(n, size.0);
            let mut views = Vec::new();
            let mut tile = size;
            for (i, cam) in offscreen::turntable(&home, n).into_iter().enumerate() {
                let px = off.render(&frame(cam))?;
                offscreen::write_png(&numbered(png, i as u32, n), &px, size.0, size.1)?;
                let (small, w, h) = offscreen::shrink(&px, size.0, size.1, k);
                tile = (w, h);
                views.push(small);
            }
            let bg = info.background.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
            let (sheet, w, h) = offscreen::contact_sheet(&views, tile.0, tile.1, bg);
            offscreen::write_png(png, &sheet, w, h)?;
        }
    }
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
    let Some(size) = parse_size(&cli.size) else {
        eprintln!("mdg-view: --size {}: expected WIDTHxHEIGHT, each 1..{MAX_SIDE}, e.g. 1024x768", cli.size);
        return ExitCode::from(2);
    };
    let opts = match cli.compile.options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("mdg-view: {e}");
            return ExitCode::from(2);
        }
    };
    let pose = match camera_pose(&cli.camera) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("mdg-view: {e}");
            return ExitCode::from(2);
        }
    };
    if cli.turntable.is_some() && cli.png.is_none() {
        eprintln!("mdg-view: --turntable needs --png");
        return ExitCode::from(2);
    }
    let eval = EvalOptions { seed: cli.seed, ..cli.limits.eval_options() };
    let load = LoadOptions { std_dir: opts.std_dir, params: opts.params, presets: opts.defines, eval };
    let (model, files) = match Toolchain.load(&cli.file, &load) {
        Ok(m) => m,
        Err(fail) => {
            eprint!("{}", fail.error);
            if !fail.error.to_string().ends_with('\n') {
                eprintln!();
            }
            return ExitCode::from(1);
        }
    };
    eprint!("{}", model.warnings);
    for d in &model.output.debug {
        eprintln!("{d}");
    }
    for w in &model.output.stats.warnings {
        eprintln!("warning: {w}");
    }
    let result = if cli.png.is_some() {
        Toolchain.programs(load.std_dir.as_deref()).and_then(|programs| offscreen(&cli, &model, size, &programs))
    } else {
        let opts = WindowOptions {
            width: size.0,
            height: size.1,
            frames: cli.frames,
            screenshot: cli.screenshot.clone(),
            watch: !cli.no_watch,
            load: load.clone(),
            validation: Validation::from_env(),
            samples: cli.samples,
            time: cli.time,
            pose,
            log: crate::say,
        };
        window::run(cli.file.clone(), model, files, opts, Arc::new(Toolchain)).map(|s| {
            eprintln!("mdg-view: closed cleanly after {} frames ({} reloads) on {}", s.frames, s.reloads, s.device);
            s.validation_errors
        })
    };
    match result {
        Ok(0) => ExitCode::SUCCESS,
        Ok(n) => {
            eprintln!("mdg-view: {n} Vulkan validation error(s)");
            ExitCode::from(3)
        }
        Err(e) => {
            eprintln!("mdg-view: {e}");
            ExitCode::from(1)
        }
    }
}
