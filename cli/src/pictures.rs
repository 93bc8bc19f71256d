//! Pictures for the commands: a grammar's output rendered to PNG bytes.
//!
//! [`Pictures`] is what every command and mode draws with (`mdg-run --png` and
//! `--frames`, the creature contact sheets, grid renders). [`Vulkan`] draws with the
//! viewer's CPU renderer (`mdg_viewer::cpu`) when the model's program is one it
//! implements (std's Phong program, flat art) and `--renderer` allows it, else
//! offscreen with Vulkan (lavapipe without a GPU), reusing one device and one target
//! per size, started only when a picture needs it; where no Vulkan can start it
//! falls back to the software preview (`mdg_vm::preview`) and says so once.
//! [`Software`] is the software preview alone.

use crate::toolchain::Toolchain;
use mdg_viewer::camera::Pose;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::cpu::{self, CpuScene};
use mdg_viewer::model::Loader as _;
use mdg_viewer::offscreen::Offscreen;
use mdg_viewer::program::Programs;
use mdg_viewer::renderer::FrameParams;
use mdg_viewer::Error;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Renders a model (with the bundle it came from, for its background, field of view,
/// shaders and camera rule) to the bytes of a PNG file.
pub trait Pictures: Sync {
    /// The model at `time` seconds of its animation (bones, camera rule, frame-bound
    /// uniforms); `output` is the rest pose.
    fn render_at(
        &self,
        bundle: Option<&Bundle>,
        output: &Output,
        size: (u32, u32),
        time: f32,
    ) -> Result<Vec<u8>, String>;

    /// The model as it is (a still, or the rest pose).
    fn render(&self, bundle: Option<&Bundle>, output: &Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
        self.render_at(bundle, output, size, 0.0)
    }

    /// Which renderer drew the last picture, and why (for `--stats`).
    fn last_renderer(&self) -> Option<String> {
        None
    }
}

/// `--renderer`: which renderer draws a picture.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RendererChoice {
    /// The CPU renderer when it implements the model's program, else Vulkan.
    #[default]
    Auto,
    /// The CPU renderer; an error for a program it does not implement.
    Cpu,
    /// Vulkan (lavapipe without a GPU).
    Vulkan,
}

/// What draws a picture: the CPU renderer with its program, or Vulkan and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Decision {
    Cpu(cpu::Program),
    Vulkan(String),
}

/// Chooses the renderer of `bundle`'s picture for `--renderer choice` (`wireframe`:
/// a wireframe picture, which only Vulkan draws). An error for `--renderer cpu` and
/// a program the CPU renderer does not implement.
pub fn decide(
    choice: RendererChoice,
    bundle: &Bundle,
    output: &Output,
    std_dir: Option<&std::path::Path>,
    wireframe: bool,
) -> Result<Decision, String> {
    if choice == RendererChoice::Vulkan {
        return Ok(Decision::Vulkan("--renderer vulkan".into()));
    }
    let why = if wireframe {
        "the CPU renderer draws no wireframe".to_string()
    } else {
        let (vs, fs) = crate::toolchain::std_phong_code(std_dir);
        match cpu::program_of(bundle, output, &vs, &fs) {
            Ok(p) => return Ok(Decision::Cpu(p)),
            Err(why) => format!("{why}: the CPU renderer implements std's Phong program and flat art only"),
        }
    };
    match choice {
        RendererChoice::Cpu => Err(format!("--renderer cpu: {why}; use --renderer auto or vulkan")),
        _ => Ok(Decision::Vulkan(why)),
    }
}

/// The CPU renderer's options for `--samples samples` (0: one sample and edge
/// smoothing, as on a CPU Vulkan driver; 1 or 4 as asked; any other count the next
/// of 1 and 4 up, with a warning) at `size`.
pub fn cpu_options(samples: u32, size: (u32, u32)) -> (cpu::Options, Option<String>) {
    let (n, warning) = match samples {
        0 | 1 | 4 => (samples.max(1), None),
        n => (4, Some(format!("warning: --samples {n}: the CPU renderer draws 1 or 4 samples; drawing with 4"))),
    };
    let opts = cpu::Options {
        width: size.0,
        height: size.1,
        samples: n,
        smooth: samples == 0,
        threads: std::thread::available_parallelism().map_or(1, usize::from),
        lod: true,
        stand_ins: !stand_ins_off(),
    };
    (opts, warning)
}

/// One line for `--stats` and `mdg-view`: the CPU renderer drew it, how.
pub fn cpu_note(program: &cpu::Program, opts: &cpu::Options, drawn: &cpu::Drawn) -> String {
    format!(
        "CPU renderer (program {} implemented exactly; no Vulkan loaded), {} sample(s){}, {} threads, {} triangles at the level of detail, {} instances as points",
        program.label(),
        opts.samples,
        if opts.smooth { " and edge smoothing" } else { "" },
        opts.threads,
        drawn.triangles,
        drawn.stood_in
    )
}

/// Draws `output` with the CPU renderer from the home view (or `pose`), through the
/// camera rule when it has one and no pose is given: RGBA pixels.
pub fn cpu_pixels(
    bundle: &Bundle,
    output: &Output,
    program: &cpu::Program,
    opts: &cpu::Options,
    time: f32,
    pose: Option<Pose>,
) -> (Vec<u8>, cpu::Drawn) {
    let scene = CpuScene::new(bundle, output, program);
    let aspect = opts.width as f32 / opts.height.max(1) as f32;
    let home = scene.home_camera(aspect);
    let camera = match pose {
        Some(p) => home.posed(&scene.info().bounds, aspect, p),
        None => home,
    };
    let frame =
        FrameParams { camera, time, wireframe: false, camera_rule: scene.info().has_camera_rule && pose.is_none() };
    scene.render(&frame, opts)
}

/// The software renderer, from the home view.
pub struct Software;

impl Pictures for Software {
    fn render_at(
        &self,
        _bundle: Option<&Bundle>,
        output: &Output,
        size: (u32, u32),
        time: f32,
    ) -> Result<Vec<u8>, String> {
        software(output, size, time, None)
    }
}

fn software(output: &Output, size: (u32, u32), time: f32, pose: Option<Pose>) -> Result<Vec<u8>, String> {
    let mut opts = mdg_vm::preview::PreviewOptions { width: size.0, height: size.1, ..Default::default() };
    if let Some(p) = pose {
        opts.azimuth_deg = p.azimuth_deg;
        opts.elevation_deg = p.elevation_deg;
    }
    let posed;
    let output = if time > 0.0 && output.animation.bones.len() > 1 {
        posed = output.posed(f64::from(time));
        &posed
    } else {
        output
    };
    let rgba = mdg_vm::preview::render(output, &opts);
    mdg_vm::preview::encode_png(&rgba, size.0, size.1).map_err(|e| format!("cannot encode PNG: {e}"))
}

/// One Vulkan device and render target.
struct Device {
    ctx: Arc<Context>,
    target: Option<Offscreen>,
    programs: Programs,
    /// The samples asked for (0: the device's choice, [`mdg_viewer::image::default_samples`]).
    samples: u32,
    /// The warning that the device could not give them was printed.
    warned: bool,
}

impl Device {
    fn open(std_dir: Option<&std::path::Path>, samples: u32) -> Result<Device, Error> {
        mdg_viewer::offscreen::keep_freed_memory();
        let validation = match std::env::var("MDG_VALIDATION").as_deref() {
            Ok("1") => Validation::Required,
            _ => Validation::Off,
        };
        let programs = Toolchain.programs(std_dir)?;
        let ctx = Arc::new(Context::new(&ContextOptions {
            validation,
            surface_extensions: vec![],
            on_message: Some(crate::say),
        })?);
        Ok(Device { ctx, target: None, programs, samples, warned: false })
    }

    fn render(
        &mut self,
        bundle: &Bundle,
        output: &Output,
        size: (u32, u32),
        time: f32,
        pose: Option<Pose>,
    ) -> Result<Vec<u8>, Error> {
        let reuse = self.target.as_ref().is_some_and(|t| (t.width, t.height) == size);
        if !reuse {
            self.target = None;
            let off = Offscreen::new(&self.ctx, size.0, size.1, self.samples)?;
            if let (Some(w), false) =
                (crate::args::samples_warning(&off.sample_choice(), &self.ctx.device_name), self.warned)
            {
                eprintln!("{w}");
                self.warned = true;
            }
            self.target = Some(off);
        }
        let Some(off) = self.target.as_mut() else { return Err(Error::Other("no render target".into())) };
        if stand_ins_off() {
            off.renderer_mut().stand_ins = false;
        }
        let info = off.set_output(bundle, output, &self.programs)?;
        let camera = match pose {
            Some(p) => off.home_camera().posed(&info.bounds, size.0 as f32 / size.1 as f32, p),
            None => off.home_camera(),
        };
        // A chosen view replaces the grammar's camera rule.
        let frame = FrameParams { camera, time, wireframe: false, camera_rule: info.has_camera_rule && pose.is_none() };
        let px = off.render(&frame)?;
        mdg_vm::preview::encode_png(&px, size.0, size.1).map_err(|e| Error::Other(e.to_string()))
    }
}

/// `MDG_STAND_INS=0`: small instances are drawn as meshes, not as point sprites
/// (`mdg_viewer::points`), in the offscreen pictures of `mdg-run` and `mdg-view`;
/// for comparing the two (`benches/run`).
pub fn stand_ins_off() -> bool {
    std::env::var("MDG_STAND_INS").as_deref() == Ok("0")
}

/// The commands' pictures: the CPU renderer where it implements the program (and
/// `--renderer` allows it), else Vulkan offscreen, opened on first use; the software
/// preview where Vulkan cannot start (one note on stderr says so).
pub struct Vulkan {
    std_dir: Option<PathBuf>,
    pose: Option<Pose>,
    samples: u32,
    choice: RendererChoice,
    device: Mutex<Option<Result<Device, String>>>,
    /// Which renderer drew the last picture, and why.
    last: Mutex<Option<String>>,
    /// The CPU renderer's `--samples` warning was printed.
    warned: std::sync::atomic::AtomicBool,
}

impl Vulkan {
    pub fn new(std_dir: Option<PathBuf>) -> Vulkan {
        Vulkan {
            std_dir,
            pose: None,
            samples: 0,
            choice: RendererChoice::Auto,
            device: Mutex::new(None),
            last: Mutex::new(None),
            warned: std::sync::atomic::AtomicBool::new(false),
        }
    }

    /// `--renderer`.
    pub fn renderer(mut self, choice: RendererChoice) -> Vulkan {
        self.choice = choice;
        self
    }

    fn note(&self, line: String) {
        if let Ok(mut l) = self.last.lock() {
            *l = Some(line);
        }
    }

    /// Pictures from this view (`--camera AZ,EL[,ZOOM]`) instead of the home view
    /// or the grammar's camera rule.
    pub fn posed(mut self, pose: Option<Pose>) -> Vulkan {
        self.pose = pose;
        self
    }

    /// Pictures drawn with `samples` samples (`--samples`; 0, the default: one
    /// sample and edge smoothing on a CPU driver, 4 on a GPU).
    pub fn samples(mut self, samples: u32) -> Vulkan {
        self.samples = samples;
        self
    }
}

impl Pictures for Vulkan {
    fn render_at(
        &self,
        bundle: Option<&Bundle>,
        output: &Output,
        size: (u32, u32),
        time: f32,
    ) -> Result<Vec<u8>, String> {
        let empty;
        let b = match bundle {
            Some(b) => b,
            None => {
                empty = Bundle::empty();
                &empty
            }
        };
        let why = match decide(self.choice, b, output, self.std_dir.as_deref(), false)? {
            Decision::Cpu(program) => {
                let (opts, warning) = cpu_options(self.samples, size);
                if let Some(w) = warning {
                    if !self.warned.swap(true, std::sync::atomic::Ordering::Relaxed) {
                        eprintln!("{w}");
                    }
                }
                let (px, drawn) = cpu_pixels(b, output, &program, &opts, time, self.pose);
                self.note(cpu_note(&program, &opts, &drawn));
                return mdg_vm::preview::encode_png(&px, size.0, size.1).map_err(|e| e.to_string());
            }
            Decision::Vulkan(why) => why,
        };
        self.note(format!("Vulkan renderer, because {why}"));
        let mut guard = self.device.lock().map_err(|_| "picture renderer poisoned".to_string())?;
        let device = guard.get_or_insert_with(|| {
            Device::open(self.std_dir.as_deref(), self.samples).map_err(|e| {
                eprintln!("note: pictures are drawn by the software renderer, because Vulkan cannot start here: {e}");
                e.to_string()
            })
        });
        match device {
            Ok(d) => match bundle {
                Some(b) => d.render(b, output, size, time, self.pose),
                None => d.render(&Bundle::empty(), output, size, time, self.pose),
            }
            .map_err(|e| e.to_string()),
            Err(_) => software(output, size, time, self.pose),
        }
    }

    fn last_renderer(&self) -> Option<String> {
        self.last.lock().ok().and_then(|l| l.clone())
    }
}
