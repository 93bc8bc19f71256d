//! The interactive window (winit 0.30 + ash-window): orbit / pan / zoom camera,
//! frame-the-model, wireframe toggle, hot reload keeping the camera, and a clean
//! close — from the window, `Esc`/`Q`, or SIGINT/SIGTERM (Ctrl-C in the terminal):
//! the GPU is waited for and everything is freed in order. `--frames N` exits
//! after N frames (for tests); `--screenshot` reads the last frame back from the
//! swapchain.
//!
//! Keys: drag with the left button to orbit, with the right or middle button (or
//! shift + left) to pan, scroll to zoom; `F` frames the model, `H` returns to the
//! home view, `W` toggles wireframe, arrow keys orbit, `+`/`-` zoom; for animated
//! models `Space` plays and pauses, `,` and `.` step one frame, `C` looks through
//! the camera rule; `G` shows or hides the overlays (guided search's guide curves
//! and skeleton bones); `P` selects the next `@param`, `[` and `]` step it down and up
//! (Shift: ten steps) and the model is rebuilt with the new value, keeping the
//! camera; `Esc`/`Q` quit.
//!
//! Grammars with a `search` section are searched ([`crate::guided`]): on opening,
//! on every reload and whenever the guides change, in the background, the newest
//! search winning. Their guides can be edited: press the left button on a control
//! point and drag it (in the plane through it facing the camera; the model follows
//! while dragging), press on a curve to select its guide, `Tab` selects the next,
//! `D` then a left drag (or Ctrl + left drag) draws a new guide, `Delete` or
//! `Backspace` deletes the selected one, `T` (Shift: back) or `1`–`5` choose a cost
//! parameter (`delta_a`, `scale_a`, `scale_d`, `scale_u`, `segment`) and `J` / `K`
//! (or Page Down / Page Up) lower and raise it (Shift: ten steps), `L` cycles the
//! utilisation term (`paper`, `local`; shown in the title), `R` reseeds,
//! `U` or Ctrl+Z undoes, Shift+U or Ctrl+Y redoes, `S` saves the guides as JSON, and
//! `Esc` abandons a drag or a stroke under way. The title bar shows the final cost,
//! its three terms, the model's generation, why the search stopped and the
//! utilisation term.
//!
//! Input from winit and from a `--script` ([`crate::script`]) becomes the same
//! [`Input`](crate::input::Input)s and goes through `App::input`; while a script runs, the real mouse
//! and keyboard are ignored.
//!
//! One file per concern, each adding methods to the one `App`: [`gpu`] (the GPU's
//! life cycle and one frame), [`capture`] (screenshots), [`view`] (the camera),
//! [`events`] (input mapping), [`guides`] (guide editing), [`playback`],
//! [`params`] (`@param` stepping), [`scripted`] (`--script`) and [`reload`] (hot
//! reload and uploading the scene). This file holds the state, the event loop
//! and its start.

mod capture;
mod events;
mod gpu;
mod guides;
mod params;
mod playback;
mod reload;
mod scripted;
mod view;

pub use params::stepped;

use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::{Context, Validation};
use crate::guided::session::{Outcome, Session};
use crate::guided::watch::{GuideFileError, GuideWatch};
use crate::input::Modifiers;
use crate::model::{LoadOptions, Loader, Model};
use crate::program::Programs;
use crate::reload::{ReloadHandle, Reloaded};
use crate::renderer::Renderer;
use crate::script::{self, Runner};
use crate::swapchain::{Surface, Swapchain};
use crate::sync::{Fence, Semaphore};
use crate::Error;
use ash::vk;
use events::input_of;
use guides::start_session;
use mdg_guided::Guide;
use std::path::PathBuf;
use std::sync::Arc;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::window::{Window, WindowId};

/// What the window is asked to do.
#[derive(Clone, Debug)]
pub struct WindowOptions {
    pub width: u32,
    pub height: u32,
    /// Exit after this many frames (tests); `None` runs until closed.
    pub frames: Option<u64>,
    /// Write the last frame here (PNG) before exiting.
    pub screenshot: Option<PathBuf>,
    /// Watch the files and reload on change.
    pub watch: bool,
    pub load: LoadOptions,
    pub validation: Validation,
    pub samples: u32,
    pub time: f32,
    /// The starting view (`--camera AZ,EL[,ZOOM]`); the home view when `None`.
    pub pose: Option<crate::camera::Pose>,
    /// Where the window's messages go (reloads, key help, errors it recovers
    /// from): the viewer prints nothing itself.
    pub log: fn(&str),
    /// Guided search: guides from a file (`--guides`, watched when `watch` is on)
    /// instead of the grammar's `guide` sections.
    pub guides: Option<(PathBuf, Vec<Guide>)>,
    /// Guided search: where `S` saves the guides.
    pub save_guides: PathBuf,
    /// Scripted input (`--script`); while it runs the mouse and keyboard are ignored.
    pub script: Option<Vec<(usize, script::Command)>>,
}

/// How the run ended.
#[derive(Clone, Debug, Default)]
pub struct RunSummary {
    pub frames: u64,
    pub validation_errors: u32,
    pub reloads: u32,
    pub device: String,
}

/// Set by SIGINT/SIGTERM; the event loop polls it and closes cleanly.
static QUIT_REQUESTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[cfg(unix)]
extern "C" fn on_quit_signal(_signal: libc::c_int) {
    // Only an atomic store: async-signal-safe.
    QUIT_REQUESTED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Routes SIGINT and SIGTERM to a clean close instead of killing the process.
fn install_quit_signals() {
    #[cfg(unix)]
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: the handler only stores to an atomic, which is async-signal-safe;
        // `signal` is given a valid function pointer of the right type.
        unsafe {
            libc::signal(sig, on_quit_signal as extern "C" fn(libc::c_int) as libc::sighandler_t);
        }
    }
}

/// How often the event loop looks at the quit flag while idle.
const QUIT_POLL: std::time::Duration = std::time::Duration::from_millis(100);

/// Messages from other threads to the event loop.
pub enum UserEvent {
    Reloaded(Reloaded),
    /// A rebuild after a `@param` change, numbered so that only the newest is shown.
    ParamRebuilt(u64, Reloaded),
    /// A guided search's answer (its request's number).
    Searched(u64, Box<Outcome>),
    /// The `--guides` file changed: its guides, or why they cannot be used.
    GuidesFile(Result<Vec<Guide>, GuideFileError>),
}

/// Per-frame synchronisation: one frame in flight.
struct FrameSync {
    image_available: Semaphore,
    /// One per swapchain image: a present may still wait on the previous one.
    render_finished: Vec<Semaphore>,
    in_flight: Fence,
    cmd: vk::CommandBuffer,
}

/// Everything that exists while the window is open. Field order is drop order:
/// GPU objects, then the swapchain and renderer, then the surface, then the window.
struct Gpu {
    sync: FrameSync,
    readback: Option<Buffer>,
    swapchain: Swapchain,
    renderer: Renderer,
    surface: Surface,
    ctx: Arc<Context>,
    window: Arc<Window>,
    format: vk::SurfaceFormatKHR,
    stale: bool,
}

#[derive(Default)]
struct Mouse {
    pos: Option<(f64, f64)>,
    orbit: bool,
    pan: bool,
}

struct App {
    opts: WindowOptions,
    path: PathBuf,
    model: Option<Model>,
    files: Vec<PathBuf>,
    gpu: Option<Gpu>,
    camera: Option<OrbitCamera>,
    wireframe: bool,
    /// Animation time in seconds, whether it advances, and when it last did.
    time: f32,
    playing: bool,
    last_tick: Option<std::time::Instant>,
    camera_rule: bool,
    mouse: Mouse,
    proxy: EventLoopProxy<UserEvent>,
    /// Compiles the grammar again (hot reload, `@param` changes).
    loader: Arc<dyn Loader>,
    /// The fallback shader programs (std Phong, lines).
    programs: Programs,
    reload: Option<ReloadHandle>,
    summary: RunSummary,
    error: Option<Error>,
    /// The selected `@param` (index into the bundle's params) and the number of the
    /// newest rebuild asked for.
    param: usize,
    param_generation: u64,
    /// The guide editor and its searches (grammars with a `search` section).
    guided: Option<Session>,
    guide_watch: Option<GuideWatch>,
    script: Option<Runner>,
    modifiers: Modifiers,
    /// The model or the guide overlay changed: upload before the next frame.
    scene_dirty: bool,
    /// The next left drag draws a guide (`D`).
    draw_mode: bool,
}

/// Opens a window showing `model` (compiled from `path`, read from `files`) until it
/// is closed or `opts.frames` frames were drawn. `loader` compiles the grammar again
/// when it changes.
pub fn run(
    path: PathBuf,
    model: Model,
    files: Vec<PathBuf>,
    opts: WindowOptions,
    loader: Arc<dyn Loader>,
) -> Result<RunSummary, Error> {
    let programs = loader.programs(opts.load.std_dir.as_deref())?;
    let event_loop = EventLoop::<UserEvent>::with_user_event()
        .build()
        .map_err(|e| Error::Other(format!("cannot open a window: {e}")))?;
    install_quit_signals();
    let proxy = event_loop.create_proxy();
    let start_time = opts.time;
    let mut model = model;
    // A guided grammar opens with its first search done here, so the first frame
    // (and the home view's framing) shows the searched model.
    let guided = match model.bundle.extensions.has(mdg_vm::bundle::SectionKind::Guided) {
        true => {
            let mut s = start_session(&model, &opts, &proxy).map_err(|e| Error::Other(e.to_string()))?;
            let found = s.search_now().map_err(|e| Error::Other(format!("guided search: {e}")))?;
            (opts.log)(&format!("mdg-view: guided search: {}", found.summary.line()));
            for w in &found.output.stats.warnings {
                (opts.log)(&format!("mdg-view: warning: {w}"));
            }
            model.output = found.output;
            Some(s)
        }
        false => None,
    };
    let script = opts.script.clone().map(Runner::new);
    let mut app = App {
        opts,
        path,
        model: Some(model),
        files,
        gpu: None,
        camera: None,
        wireframe: false,
        time: 0.0,
        playing: false,
        last_tick: None,
        camera_rule: false,
        mouse: Mouse::default(),
        proxy,
        loader,
        programs,
        reload: None,
        summary: RunSummary::default(),
        error: None,
        param: 0,
        param_generation: 0,
        guided,
        guide_watch: None,
        script,
        modifiers: Modifiers::default(),
        scene_dirty: false,
        draw_mode: false,
    };
    app.time = start_time;
    event_loop.run_app(&mut app).map_err(|e| Error::Other(format!("event loop: {e}")))?;
    app.shutdown();
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(app.summary),
    }
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    /// Tears down in order, after the GPU is idle.
    fn shutdown(&mut self) {
        self.reload = None;
        self.guide_watch = None;
        self.guided = None;
        if let Some(g) = self.gpu.take() {
            g.ctx.wait_idle();
            self.summary.validation_errors = g.ctx.validation_log().errors();
            // SAFETY: the device is idle; the buffer came from the context's pool.
            unsafe { g.ctx.device.free_command_buffers(g.ctx.command_pool, &[g.sync.cmd]) };
            drop(g);
        }
    }
}

impl ApplicationHandler<UserEvent> for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        if let Err(e) = self.create_gpu(event_loop) {
            self.fail(event_loop, e);
            return;
        }
        self.start_reload();
        self.redraw();
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) => {
                if let Some(g) = &mut self.gpu {
                    g.stale = true;
                }
                self.redraw();
            }
            WindowEvent::RedrawRequested => {
                self.tick();
                let last = self.opts.frames.is_some_and(|n| self.summary.frames + 1 >= n);
                let result = if last && self.opts.screenshot.is_some() {
                    self.write_screenshot()
                } else {
                    self.draw(false).map(|_| ())
                };
                if let Err(e) = result {
                    self.fail(event_loop, e);
                    return;
                }
                match self.opts.frames {
                    Some(n) if self.summary.frames >= n => event_loop.exit(),
                    // In --frames mode draw continuously; otherwise only on change.
                    Some(_) => self.redraw(),
                    None if self.playing => self.redraw(),
                    None => {}
                }
            }
            // The mouse and keyboard become `Input`s (ignored while a script runs).
            event => {
                if self.script.is_none() {
                    if let Some(input) = input_of(&event) {
                        self.input(event_loop, input);
                    }
                }
            }
        }
    }

    fn user_event(&mut self, _event_loop: &ActiveEventLoop, event: UserEvent) {
        match event {
            UserEvent::Reloaded(r) => self.reloaded(r),
            UserEvent::ParamRebuilt(generation, r) => {
                if generation == self.param_generation {
                    self.reloaded(r);
                    self.show_param();
                }
            }
            UserEvent::Searched(id, outcome) => self.searched(id, *outcome),
            UserEvent::GuidesFile(r) => self.guides_file_changed(r),
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if QUIT_REQUESTED.load(std::sync::atomic::Ordering::SeqCst) {
            (self.opts.log)("mdg-view: interrupted, closing");
            if let Err(e) = self.write_screenshot() {
                self.fail(event_loop, e);
            }
            event_loop.exit();
            return;
        }
        let mut wake = std::time::Instant::now() + QUIT_POLL;
        if self.script.is_some() {
            if let Some(at) = self.run_script(event_loop) {
                wake = wake.min(at);
            }
        }
        // Wake up now and then to notice a signal while idle.
        event_loop.set_control_flow(ControlFlow::WaitUntil(wake));
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        self.shutdown();
    }
}
