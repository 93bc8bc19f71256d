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
//! [`Input`]s and goes through [`App::input`]; while a script runs, the real mouse
//! and keyboard are ignored.

use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::{vkerr, Context, ContextOptions, Validation};
use crate::guided::edit::{Param, Pick};
use crate::guided::project::ScreenView;
use crate::guided::session::{Accepted, Outcome, Session, SessionOptions};
use crate::guided::watch::GuideWatch;
use crate::guided::worker::Preempt;
use crate::input::{Button, Input, Key, Modifiers};
use crate::model::{LoadOptions, Loader, Model};
use crate::program::Programs;
use crate::reload::{ReloadHandle, Reloaded};
use crate::renderer::{FrameParams, ModelInfo, Renderer, RendererOptions};
use crate::script::{self, Runner, Step};
use crate::swapchain::{choose_format, Surface, Swapchain};
use crate::sync::{Fence, Semaphore};
use crate::Error;
use ash::vk;
use glam::DVec2;
use mdg_guided::Guide;
use mdg_vm::bundle::SectionKind;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::keyboard::{Key as WinitKey, NamedKey};
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
    GuidesFile(Result<Vec<Guide>, String>),
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

/// How long a script waiting for a search looks again.
const SCRIPT_POLL: std::time::Duration = std::time::Duration::from_millis(10);

/// Starts a guided-search session on `model`'s grammar; its answers come to the
/// event loop through `proxy`.
fn start_session(model: &Model, opts: &WindowOptions, proxy: &EventLoopProxy<UserEvent>) -> Result<Session, String> {
    let proxy = Mutex::new(proxy.clone());
    let session = SessionOptions {
        seed: opts.load.eval.seed.unwrap_or(model.bundle.settings.randseed),
        eval: opts.load.eval.clone(),
        guides: opts.guides.clone(),
        save_to: opts.save_guides.clone(),
    };
    Session::start(Arc::new(model.bundle.clone()), session, move |id, outcome| {
        if let Ok(p) = proxy.lock() {
            let _ = p.send_event(UserEvent::Searched(id, Box::new(outcome)));
        }
    })
}

/// Uploads `model`, with the guide editor's overlay when there is one.
fn upload(
    renderer: &mut Renderer,
    model: &mut Model,
    guided: Option<&Session>,
    programs: &Programs,
) -> Result<ModelInfo, Error> {
    let n = model.output.lines.len();
    if let Some(s) = guided {
        model.output.lines.extend(s.editor.overlay(s.editor.marker_size()));
    }
    let info = renderer.set_model(model, programs).cloned();
    model.output.lines.truncate(n);
    info
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
    let guided = match model.bundle.extensions.has(SectionKind::Guided) {
        true => {
            let mut s = start_session(&model, &opts, &proxy).map_err(Error::Other)?;
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

    fn create_gpu(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Error> {
        let attrs = Window::default_attributes()
            .with_title(format!("mdg-view — {}", self.path.display()))
            .with_inner_size(PhysicalSize::new(self.opts.width, self.opts.height));
        let window = Arc::new(
            event_loop.create_window(attrs).map_err(|e| Error::Other(format!("cannot create a window: {e}")))?,
        );
        let display = window.display_handle().map_err(|e| Error::Other(format!("display handle: {e}")))?.as_raw();
        let handle = window.window_handle().map_err(|e| Error::Other(format!("window handle: {e}")))?.as_raw();
        let exts = ash_window::enumerate_required_extensions(display).map_err(vkerr("surface extensions"))?;
        // SAFETY: ash_window returns pointers to static NUL-terminated extension names.
        let surface_extensions = exts.iter().map(|p| unsafe { std::ffi::CStr::from_ptr(*p) }).collect();
        let ctx = Arc::new(Context::new(&ContextOptions {
            validation: self.opts.validation,
            surface_extensions,
            on_message: Some(self.opts.log),
        })?);
        self.summary.device = ctx.device_name.clone();
        let surface = Surface::new(&ctx, display, handle)?;
        let format = choose_format(&ctx, &surface)?;
        let mut renderer = Renderer::new(
            &ctx,
            RendererOptions {
                color_format: format.format,
                final_layout: vk::ImageLayout::PRESENT_SRC_KHR,
                samples: self.opts.samples,
            },
        )?;
        let choice = renderer.sample_choice;
        if choice.differs() {
            (self.opts.log)(&format!(
                "warning: --samples {}: {} offers {} samples; drawing with {}",
                choice.wanted,
                ctx.device_name,
                choice.offered(),
                choice.count()
            ));
        }
        let size = window.inner_size();
        let swapchain = Swapchain::new(&ctx, &surface, format, (size.width, size.height), &mut renderer, None)?;
        if let Some(m) = &mut self.model {
            let info = upload(&mut renderer, m, self.guided.as_ref(), &self.programs)?;
            (self.opts.log)(&format!(
                "mdg-view: {} triangles, {} line segments, program {} on {}",
                info.n_triangles, info.n_line_segments, info.program, ctx.device_name
            ));
            let aspect = swapchain.extent.width as f32 / swapchain.extent.height.max(1) as f32;
            let home = OrbitCamera::framing_art(&info.bounds, info.fov_deg, aspect, info.flat);
            self.camera = Some(match self.opts.pose {
                Some(p) => home.posed(&info.bounds, aspect, p),
                None => home,
            });
            if !m.bundle.params.is_empty() {
                let names: Vec<&str> = m.bundle.params.iter().map(|p| m.bundle.string(p.name)).collect();
                (self.opts.log)(&format!(
                    "mdg-view: @param {}: P selects, [ and ] change (Shift: ×10)",
                    names.join(", ")
                ));
            }
            if info.animated {
                (self.opts.log)(&format!("mdg-view: animated ({:.1} s at {} fps): Space plays, , and . step, C looks through the camera rule", info.duration, info.fps));
            }
        }
        if let Some(s) = &self.guided {
            (self.opts.log)(&format!(
                "mdg-view: guides: drag a control point to move it; Ctrl+drag (or D, then drag) draws a guide; Tab or a \
                 click selects one, Delete deletes it; T or 1-5 choose a parameter, J/K change it; L cycles the utilisation term; R reseeds; U undoes; \
                 S saves to {}",
                s.save_path().display()
            ));
        }
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(ctx.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid pool; freed in `shutdown`.
        let cmd = unsafe { ctx.device.allocate_command_buffers(&alloc) }.map_err(vkerr("allocate command buffer"))?[0];
        let sync = FrameSync {
            image_available: Semaphore::new(&ctx)?,
            render_finished: (0..swapchain.images.len()).map(|_| Semaphore::new(&ctx)).collect::<Result<_, _>>()?,
            in_flight: Fence::new(&ctx, true)?,
            cmd,
        };
        self.gpu = Some(Gpu { sync, readback: None, swapchain, renderer, surface, ctx, window, format, stale: false });
        Ok(())
    }

    fn start_reload(&mut self) {
        if !self.opts.watch || self.reload.is_some() {
            return;
        }
        let proxy = self.proxy.clone();
        let loader = self.loader.clone();
        match ReloadHandle::start(self.path.clone(), self.files.clone(), self.opts.load.clone(), loader, move |r| {
            let _ = proxy.send_event(UserEvent::Reloaded(r));
        }) {
            Ok(h) => self.reload = Some(h),
            Err(e) => (self.opts.log)(&format!("mdg-view: hot reload is off: {e}")),
        }
        self.start_guide_watch();
    }

    /// Watches the `--guides` file of a guided grammar (with hot reload on).
    fn start_guide_watch(&mut self) {
        if !self.opts.watch || self.guide_watch.is_some() || self.guided.is_none() {
            return;
        }
        let Some((path, _)) = &self.opts.guides else { return };
        let proxy = Mutex::new(self.proxy.clone());
        match GuideWatch::start(path.clone(), move |r| {
            if let Ok(p) = proxy.lock() {
                let _ = p.send_event(UserEvent::GuidesFile(r));
            }
        }) {
            Ok(w) => self.guide_watch = Some(w),
            Err(e) => (self.opts.log)(&format!("mdg-view: the guide file is not watched: {e}")),
        }
    }

    fn recreate_swapchain(&mut self) -> Result<(), Error> {
        let Some(g) = &mut self.gpu else { return Ok(()) };
        let size = g.window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // Minimised: wait for a real size.
        }
        g.ctx.wait_idle();
        let new = Swapchain::new(
            &g.ctx,
            &g.surface,
            g.format,
            (size.width, size.height),
            &mut g.renderer,
            Some(&g.swapchain),
        )?;
        if new.images.len() != g.sync.render_finished.len() {
            g.sync.render_finished = (0..new.images.len()).map(|_| Semaphore::new(&g.ctx)).collect::<Result<_, _>>()?;
        }
        g.swapchain = new;
        g.readback = None;
        // The camera is kept: only the aspect changed, which the projection reads.
        g.stale = false;
        Ok(())
    }

    /// Draws one frame; `screenshot` also copies it to the readback buffer.
    fn draw(&mut self, screenshot: bool) -> Result<Option<Vec<u8>>, Error> {
        self.sync_scene();
        if self.gpu.as_ref().is_some_and(|g| g.stale) {
            self.recreate_swapchain()?;
            if self.gpu.as_ref().is_some_and(|g| g.stale) {
                return Ok(None); // Minimised: nothing to draw into until resized.
            }
        }
        let Some(g) = &mut self.gpu else { return Ok(None) };
        let Some(camera) = self.camera else { return Ok(None) };
        let ctx = g.ctx.clone();
        g.sync.in_flight.wait()?;
        let Some((index, suboptimal)) = g.swapchain.acquire(g.sync.image_available.raw)? else {
            // Out of date (resized): recreate and draw again.
            g.stale = true;
            g.window.request_redraw();
            return Ok(None);
        };
        g.sync.in_flight.reset()?;
        let frame = FrameParams { camera, time: self.time, wireframe: self.wireframe, camera_rule: self.camera_rule };
        g.renderer.update(&frame)?;
        let extent = g.swapchain.extent;
        let copy = screenshot && g.swapchain.can_read_back;
        if copy && g.readback.is_none() {
            g.readback = Some(Buffer::host(
                &ctx,
                extent.width as u64 * extent.height as u64 * 4,
                vk::BufferUsageFlags::TRANSFER_DST,
            )?);
        }
        let cmd = g.sync.cmd;
        let image = g.swapchain.images[index as usize];
        // SAFETY: the fence wait above guarantees the command buffer is not in use.
        unsafe {
            ctx.device
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .map_err(vkerr("reset command buffer"))?;
            ctx.device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(vkerr("begin command buffer"))?;
        }
        g.renderer.record(cmd, &g.swapchain.framebuffers[index as usize], &frame);
        if let (true, Some(buf)) = (copy, &g.readback) {
            record_readback(&ctx, cmd, image, extent, buf.raw);
        }
        // SAFETY: `cmd` is in the recording state (begun above on this thread) and only
        // the renderer and the readback appended commands to it.
        unsafe { ctx.device.end_command_buffer(cmd) }.map_err(vkerr("end command buffer"))?;
        let waits = [g.sync.image_available.raw];
        let stages = [vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT];
        let cmds = [cmd];
        let signals = [g.sync.render_finished[index as usize].raw];
        let submit = [vk::SubmitInfo::default()
            .wait_semaphores(&waits)
            .wait_dst_stage_mask(&stages)
            .command_buffers(&cmds)
            .signal_semaphores(&signals)];
        // SAFETY: the command buffer is recorded; semaphores and fence are ours and
        // not pending (fence reset after its wait, semaphore per image).
        unsafe { ctx.device.queue_submit(ctx.queue, &submit, g.sync.in_flight.raw) }.map_err(vkerr("queue submit"))?;
        let ok = g.swapchain.present(index, signals[0])?;
        if !ok || suboptimal {
            g.stale = true;
            g.window.request_redraw();
        }
        self.summary.frames += 1;
        if copy {
            g.sync.in_flight.wait()?;
            let Some(buf) = &g.readback else { return Ok(None) };
            let mut px = buf.read(extent.width as usize * extent.height as usize * 4)?;
            if matches!(g.format.format, vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB) {
                for p in px.chunks_exact_mut(4) {
                    p.swap(0, 2);
                }
            }
            return Ok(Some(px));
        }
        Ok(None)
    }

    /// Draws one more frame, reads it back and writes the screenshot (if asked for).
    fn write_screenshot(&mut self) -> Result<(), Error> {
        let Some(path) = self.opts.screenshot.clone() else { return Ok(()) };
        self.write_screenshot_to(&path)
    }

    /// Draws one more frame, reads it back and writes it to `path`.
    fn write_screenshot_to(&mut self, path: &Path) -> Result<(), Error> {
        if !self.gpu.as_ref().is_some_and(|g| g.swapchain.can_read_back) {
            (self.opts.log)("mdg-view: this swapchain cannot be read back; no screenshot");
            return Ok(());
        }
        // An out-of-date swapchain draws nothing; a second try uses the new one.
        for _ in 0..2 {
            if let Some(px) = self.draw(true)? {
                let Some(g) = &self.gpu else { return Ok(()) };
                let e = g.swapchain.extent;
                return crate::offscreen::write_png(path, &px, e.width, e.height);
            }
        }
        (self.opts.log)("mdg-view: no frame to write as the screenshot");
        Ok(())
    }

    fn redraw(&self) {
        if let Some(g) = &self.gpu {
            g.window.request_redraw();
        }
    }

    fn aspect(&self) -> f32 {
        self.gpu
            .as_ref()
            .map(|g| g.swapchain.extent.width as f32 / g.swapchain.extent.height.max(1) as f32)
            .unwrap_or(1.0)
    }

    fn frame_model(&mut self, home: bool) {
        let aspect = self.aspect();
        let Some(info) = self.gpu.as_ref().and_then(|g| g.renderer.info()).cloned() else { return };
        match (&mut self.camera, home) {
            (Some(c), false) => c.frame(&info.bounds, aspect),
            _ => self.camera = Some(OrbitCamera::framing_art(&info.bounds, info.fov_deg, aspect, info.flat)),
        }
        self.redraw();
    }

    /// Every input, from winit or from the script.
    fn input(&mut self, event_loop: &ActiveEventLoop, input: Input) {
        match input {
            Input::Modifiers(m) => self.modifiers = m,
            Input::Key(k) => self.key(event_loop, &k),
            Input::Wheel(lines) => self.zoom(0.9f32.powf(lines)),
            Input::Button { button, pressed } => self.button(button, pressed),
            Input::CursorMoved(x, y) => self.cursor_moved(x, y),
        }
    }

    fn button(&mut self, button: Button, pressed: bool) {
        if !pressed {
            if button == Button::Left {
                self.guided_release();
            }
            self.mouse.orbit = false;
            self.mouse.pan = false;
            return;
        }
        match button {
            Button::Left if self.modifiers.shift => self.mouse.pan = true,
            Button::Left => {
                if !self.guided_press() {
                    self.mouse.orbit = true;
                }
            }
            Button::Right | Button::Middle => self.mouse.pan = true,
        }
    }

    fn cursor_moved(&mut self, x: f64, y: f64) {
        let previous = self.mouse.pos.replace((x, y));
        if self.guided.as_ref().is_some_and(|s| s.editor.is_dragging() || s.editor.is_drawing()) {
            let Some(view) = self.screen_view() else { return };
            let Some(s) = &mut self.guided else { return };
            let px = DVec2::new(x, y);
            if s.editor.is_dragging() {
                if s.editor.drag_to(&view, px) {
                    // A search per move; one running is let finish (Preempt::Wait), so
                    // models keep coming while the point moves.
                    s.request(Preempt::Wait);
                    self.scene_changed();
                }
            } else if s.editor.extend_stroke(&view, px) {
                self.scene_changed();
            }
            return;
        }
        let Some((px, py)) = previous else { return };
        let h = self.gpu.as_ref().map(|g| g.swapchain.extent.height.max(1) as f64).unwrap_or(1.0);
        let (dx, dy) = (((x - px) / h) as f32, ((y - py) / h) as f32);
        if self.mouse.orbit {
            self.orbit(dx * std::f32::consts::PI, dy * std::f32::consts::PI);
        } else if self.mouse.pan {
            if let Some(c) = &mut self.camera {
                c.pan(dx, dy);
                self.redraw();
            }
        }
    }

    /// What the window shows now, for mapping pixels to the world.
    fn screen_view(&self) -> Option<ScreenView> {
        let g = self.gpu.as_ref()?;
        let camera = self.camera?;
        let frame = FrameParams { camera, time: self.time, wireframe: self.wireframe, camera_rule: self.camera_rule };
        let (view, proj, eye) = g.renderer.view_projection(&frame);
        let e = g.swapchain.extent;
        Some(ScreenView::new(view, proj, eye, e.width, e.height))
    }

    /// The guides or the model changed: upload before the next frame.
    fn scene_changed(&mut self) {
        self.scene_dirty = true;
        self.update_title();
        self.redraw();
    }

    /// Uploads the model and the guide overlay if they changed.
    fn sync_scene(&mut self) {
        if !self.scene_dirty {
            return;
        }
        self.scene_dirty = false;
        let (Some(g), Some(m)) = (&mut self.gpu, &mut self.model) else { return };
        g.ctx.wait_idle();
        if let Err(e) = upload(&mut g.renderer, m, self.guided.as_ref(), &self.programs) {
            (self.opts.log)(&format!("mdg-view: cannot show the model: {e}"));
        }
    }

    fn update_title(&self) {
        let (Some(g), Some(s)) = (&self.gpu, &self.guided) else { return };
        let mode = if self.draw_mode { " — D: drag with the left button to draw a guide" } else { "" };
        g.window.set_title(&format!("mdg-view — {} — {}{mode}", self.path.display(), s.title()));
    }

    /// A left press with guides shown: starts a stroke (draw mode or Ctrl), a drag
    /// of the control point under the cursor, or selects the guide whose curve is
    /// under it. Returns false when it is none of these (the press orbits).
    fn guided_press(&mut self) -> bool {
        let overlays = self.gpu.as_ref().is_some_and(|g| g.renderer.show_overlays);
        let (Some(pos), Some(view), true) = (self.mouse.pos, self.screen_view(), overlays) else { return false };
        let target = self.camera.map(|c| c.target.as_dvec3()).unwrap_or_default();
        let draw = std::mem::take(&mut self.draw_mode) || self.modifiers.ctrl;
        let Some(s) = &mut self.guided else { return false };
        let px = DVec2::new(pos.0, pos.1);
        let handled = if draw {
            s.editor.begin_stroke(&view, px, target)
        } else {
            match s.editor.pick(&view, px) {
                Some(Pick::Point { guide, point }) => s.editor.begin_drag(&view, px, guide, point),
                Some(Pick::Curve { guide }) => {
                    s.editor.select(Some(guide));
                    true
                }
                None => false,
            }
        };
        if handled || draw {
            self.scene_changed();
        }
        handled
    }

    /// A left release: ends a drag (its searches were asked for while it moved) or
    /// a stroke (fitted and added as a guide).
    fn guided_release(&mut self) {
        let view = self.screen_view();
        let Some(s) = &mut self.guided else { return };
        if s.editor.is_dragging() {
            if s.editor.end_drag() {
                if let Some((index, guide)) = s.editor.selected().and_then(|i| s.editor.guides().get(i).map(|g| (i, g)))
                {
                    (self.opts.log)(&format!("mdg-view: moved a control point of {}", guide.label(index)));
                }
                s.request_if_changed(Preempt::Wait);
            }
        } else if s.editor.is_drawing() {
            let Some(view) = view else { return };
            match s.editor.end_stroke(&view) {
                Ok(i) => {
                    let g = &s.editor.guides()[i];
                    let n = (g.points.len() - 1) / 3;
                    (self.opts.log)(&format!(
                        "mdg-view: added {} ({n} cubic segment{})",
                        g.label(i),
                        if n == 1 { "" } else { "s" }
                    ));
                    s.request(Preempt::Cancel);
                }
                Err(e) => (self.opts.log)(&format!("mdg-view: no guide drawn: {e}")),
            }
        } else {
            return;
        }
        self.scene_changed();
    }

    /// The guide editor's keys. Returns whether `key` was one of them.
    fn guided_key(&mut self, key: &Key) -> bool {
        let Modifiers { shift, ctrl } = self.modifiers;
        let log = self.opts.log;
        let Some(s) = &mut self.guided else { return false };
        let say = |r: Result<String, String>| match r {
            Ok(m) | Err(m) => log(&format!("mdg-view: {m}")),
        };
        let steps = if shift { 10.0 } else { 1.0 };
        let text = match key {
            Key::Char(c) => c.to_lowercase(),
            _ => String::new(),
        };
        match (key, text.as_str()) {
            (Key::Escape, _) => {
                if !s.editor.cancel_gesture() {
                    return false;
                }
                log("mdg-view: cancelled");
            }
            (Key::Tab, _) => {
                s.editor.select_next();
                log(&format!("mdg-view: {}", s.editor.status()));
            }
            (Key::Delete | Key::Backspace, _) => say(s.editor.delete_selected()),
            (Key::PageUp, _) => say(s.editor.step_param(steps)),
            (Key::PageDown, _) => say(s.editor.step_param(-steps)),
            (_, "z") if ctrl => {
                if !s.editor.undo() {
                    log("mdg-view: nothing to undo");
                }
            }
            (_, "y") if ctrl => {
                if !s.editor.redo() {
                    log("mdg-view: nothing to redo");
                }
            }
            (_, _) if ctrl => return false,
            (_, "u") => {
                let done = if shift { s.editor.redo() } else { s.editor.undo() };
                if !done {
                    log(if shift { "mdg-view: nothing to redo" } else { "mdg-view: nothing to undo" });
                }
            }
            (_, "d") => {
                self.draw_mode = !self.draw_mode;
                log(if self.draw_mode {
                    "mdg-view: drag with the left button to draw a guide"
                } else {
                    "mdg-view: drawing off"
                });
            }
            (_, "t") => {
                s.editor.set_param(s.editor.param().cycled(shift));
                log(&format!("mdg-view: {}", s.editor.status()));
            }
            (_, "1" | "2" | "3" | "4" | "5") => {
                let i = text.parse::<usize>().map_or(0, |i| i - 1);
                s.editor.set_param(Param::ALL[i.min(Param::ALL.len() - 1)]);
                log(&format!("mdg-view: {}", s.editor.status()));
            }
            (_, "j") => say(s.editor.step_param(-steps)),
            (_, "k") => say(s.editor.step_param(steps)),
            (_, "r") => {
                let seed = s.reseed();
                log(&format!("mdg-view: seed {seed}: searching"));
                s.request(Preempt::Cancel);
            }
            (_, "s") => say(s.save()),
            (_, "l") => {
                let u = s.cycle_utilisation();
                log(&format!("mdg-view: utilisation {}: searching", u.name()));
                s.request(Preempt::Cancel);
            }
            _ => return false,
        }
        s.request_if_changed(Preempt::Cancel);
        self.scene_changed();
        true
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) {
        if self.guided_key(key) {
            return;
        }
        let step = 10f32.to_radians();
        match key {
            Key::Escape => event_loop.exit(),
            Key::ArrowLeft => self.orbit(-step, 0.0),
            Key::ArrowRight => self.orbit(step, 0.0),
            Key::ArrowUp => self.orbit(0.0, step),
            Key::ArrowDown => self.orbit(0.0, -step),
            Key::Home => self.frame_model(true),
            Key::Char(c) => match c.to_lowercase().as_str() {
                "q" => event_loop.exit(),
                "f" => self.frame_model(false),
                "h" => self.frame_model(true),
                "w" => {
                    let supported = self.gpu.as_ref().is_some_and(|g| g.ctx.wireframe);
                    if supported {
                        self.wireframe = !self.wireframe;
                        self.redraw();
                    } else {
                        (self.opts.log)("mdg-view: this device cannot draw wireframes (no fillModeNonSolid)");
                    }
                }
                "+" | "=" => self.zoom(0.9),
                "-" | "_" => self.zoom(1.0 / 0.9),
                "c" => {
                    let has = self.gpu.as_ref().and_then(|g| g.renderer.info()).is_some_and(|i| i.has_camera_rule);
                    if has {
                        self.camera_rule = !self.camera_rule;
                        self.redraw();
                    }
                }
                "g" => {
                    if let Some(g) = &mut self.gpu {
                        g.renderer.show_overlays = !g.renderer.show_overlays;
                        self.redraw();
                    }
                }
                "p" => self.select_param(),
                "[" => self.change_param(-1.0),
                "]" => self.change_param(1.0),
                "{" => self.change_param(-10.0),
                "}" => self.change_param(10.0),
                "," | "<" => self.step(-1.0),
                "." | ">" => self.step(1.0),
                " " => {
                    self.playing = !self.playing;
                    self.last_tick = None;
                    self.redraw();
                }
                _ => {}
            },
            _ => {}
        }
    }

    /// Moves the time by `frames` frames of the model's fps.
    fn step(&mut self, frames: f32) {
        let fps = self.gpu.as_ref().and_then(|g| g.renderer.info()).map(|i| i.fps).unwrap_or(30.0).max(1e-3);
        self.playing = false;
        self.time = (self.time + frames / fps).max(0.0);
        self.show_time();
        self.redraw();
    }

    /// Advances the time while playing, wrapping at the duration.
    fn tick(&mut self) {
        if !self.playing {
            return;
        }
        let now = std::time::Instant::now();
        if let Some(last) = self.last_tick {
            let duration = self.gpu.as_ref().and_then(|g| g.renderer.info()).map(|i| i.duration).unwrap_or(0.0);
            self.time += (now - last).as_secs_f32();
            if duration > 0.0 && self.time > duration {
                self.time %= duration;
            }
        }
        self.last_tick = Some(now);
        self.show_time();
    }

    fn show_time(&self) {
        if let Some(g) = &self.gpu {
            g.window.set_title(&format!(
                "mdg-view — {} — t = {:.2} s{}",
                self.path.display(),
                self.time,
                if self.playing { "" } else { " (paused)" }
            ));
        }
    }

    fn orbit(&mut self, dx: f32, dy: f32) {
        if let Some(c) = &mut self.camera {
            c.orbit(dx, dy);
            self.redraw();
        }
    }

    fn zoom(&mut self, f: f32) {
        if let Some(c) = &mut self.camera {
            c.zoom(f);
            self.redraw();
        }
    }

    /// Selects the next `@param` and shows it.
    fn select_param(&mut self) {
        let Some(m) = &self.model else { return };
        let n = m.bundle.params.len();
        if n == 0 {
            (self.opts.log)("mdg-view: this grammar has no @param");
            return;
        }
        self.param = (self.param + 1) % n;
        self.show_param();
    }

    fn show_param(&self) {
        let Some(m) = &self.model else { return };
        let Some(p) = m.bundle.params.get(self.param % m.bundle.params.len().max(1)) else { return };
        let range = if p.max > p.min { format!(" in [{}, {}]", p.min, p.max) } else { String::new() };
        let text = format!("{} = {}{range}", m.bundle.string(p.name), p.value);
        (self.opts.log)(&format!("mdg-view: @param {text}"));
        if let Some(g) = &self.gpu {
            g.window.set_title(&format!("mdg-view — {} — {text}", self.path.display()));
        }
    }

    /// Moves the selected `@param` by `steps` steps (1 for an int; a twentieth of
    /// the range, or a tenth of the value, for a float), clamped to its range, and
    /// rebuilds the model with it in the background.
    fn change_param(&mut self, steps: f64) {
        let Some(m) = &self.model else { return };
        let Some(p) = m.bundle.params.get(self.param) else {
            (self.opts.log)("mdg-view: this grammar has no @param");
            return;
        };
        let Some(v) = stepped(p, steps) else { return };
        let name = m.bundle.string(p.name).to_string();
        let value = if p.ty == 0 { format!("{}", v as i64) } else { format!("{v}") };
        self.opts.load.params.retain(|(n, _)| *n != name);
        self.opts.load.params.push((name.clone(), value.clone()));
        if let Some(r) = &self.reload {
            r.set_options(self.opts.load.clone());
        }
        (self.opts.log)(&format!("mdg-view: @param {name} = {value}: rebuilding"));
        self.param_generation += 1;
        let generation = self.param_generation;
        let (path, opts, proxy) = (self.path.clone(), self.opts.load.clone(), self.proxy.clone());
        let loader = self.loader.clone();
        let spawned = std::thread::Builder::new().name("mdg-param".into()).spawn(move || {
            let r = match loader.load(&path, &opts) {
                Ok((m, _)) => Reloaded::Model(Box::new(m)),
                Err(fail) => Reloaded::Failed(fail.error.to_string()),
            };
            let _ = proxy.send_event(UserEvent::ParamRebuilt(generation, r));
        });
        if let Err(e) = spawned {
            (self.opts.log)(&format!("mdg-view: cannot rebuild: {e}"));
        }
    }

    /// A guided search answered.
    fn searched(&mut self, id: u64, outcome: Outcome) {
        let Some(s) = &mut self.guided else { return };
        let dragging = s.editor.is_dragging();
        match s.accept(id, outcome) {
            Accepted::Show(found) => {
                if !dragging {
                    let t = found.timings;
                    (self.opts.log)(&format!(
                        "mdg-view: guided search: {} ({:.1} ms preparing, {:.1} ms searching, {:.1} ms geometry)",
                        found.summary.line(),
                        t.prepare.as_secs_f64() * 1e3,
                        t.search.as_secs_f64() * 1e3,
                        t.geometry.as_secs_f64() * 1e3
                    ));
                    for w in &found.output.stats.warnings {
                        (self.opts.log)(&format!("mdg-view: warning: {w}"));
                    }
                }
                if let Some(m) = &mut self.model {
                    m.output = found.output;
                }
                self.scene_changed();
            }
            Accepted::Failed(e) => {
                (self.opts.log)(&format!("mdg-view: guided search failed; keeping the last model: {e}"));
            }
            Accepted::Nothing => {}
        }
    }

    /// The `--guides` file changed.
    fn guides_file_changed(&mut self, r: Result<Vec<Guide>, String>) {
        let Some(s) = &mut self.guided else { return };
        match r {
            Ok(guides) => {
                if s.file_changed(guides) {
                    (self.opts.log)("mdg-view: the guide file changed: searching");
                    s.request(Preempt::Cancel);
                    self.scene_changed();
                }
            }
            Err(e) => (self.opts.log)(&format!("mdg-view: keeping the guides: {e}")),
        }
    }

    /// Whether nothing is left to do for the script's `idle`: every search asked for
    /// answered and the newest model uploaded.
    fn is_idle(&self) -> bool {
        self.guided.as_ref().is_none_or(Session::is_idle) && !self.scene_dirty
    }

    /// Runs the script's next steps; returns when to look again (`None`: it is over).
    fn run_script(&mut self, event_loop: &ActiveEventLoop) -> Option<std::time::Instant> {
        loop {
            // Upload what changed now rather than at the next frame: `idle` must not
            // wait for a redraw (a window that is not shown gets none).
            self.sync_scene();
            let idle = self.is_idle();
            let now = std::time::Instant::now();
            let (step, line) = {
                let r = self.script.as_mut()?;
                (r.next(now, idle, self.modifiers), r.line())
            };
            match step {
                Step::Input(i) => self.input(event_loop, i),
                Step::Point { guide, point } => {
                    let at = match (self.screen_view(), &self.guided) {
                        (Some(v), Some(s)) => s.editor.point_on_screen(&v, guide, point),
                        _ => None,
                    };
                    let Some(px) = at else {
                        let e = format!(
                            "--script line {line}: guide {} has no control point {} on screen",
                            guide + 1,
                            point + 1
                        );
                        self.script = None;
                        self.fail(event_loop, Error::Other(e));
                        return None;
                    };
                    (self.opts.log)(&format!(
                        "mdg-view: script line {line}: guide {} point {} is at pixel ({:.2}, {:.2})",
                        guide + 1,
                        point + 1,
                        px.x,
                        px.y
                    ));
                    if let Some(r) = &mut self.script {
                        r.cursor_at(px.x, px.y);
                    }
                    self.input(event_loop, Input::CursorMoved(px.x, px.y));
                }
                Step::Screenshot(path) => {
                    if let Err(e) = self.write_screenshot_to(&path) {
                        self.script = None;
                        self.fail(event_loop, e);
                        return None;
                    }
                    (self.opts.log)(&format!("mdg-view: script line {line}: wrote {}", path.display()));
                }
                Step::Quit => {
                    self.script = None;
                    if let Err(e) = self.write_screenshot() {
                        self.fail(event_loop, e);
                    }
                    event_loop.exit();
                    return None;
                }
                Step::Wait(at) => return Some(at.unwrap_or(now + SCRIPT_POLL)),
                Step::Done => {
                    self.script = None;
                    (self.opts.log)("mdg-view: the script is done");
                    return None;
                }
            }
        }
    }

    fn reloaded(&mut self, r: Reloaded) {
        match r {
            Reloaded::Failed(msg) => {
                (self.opts.log)(&format!("mdg-view: reload failed; keeping the last good model\n{msg}"));
            }
            Reloaded::Model(mut m) if m.bundle.extensions.has(SectionKind::Guided) => {
                // A guided grammar: search with it; the model on screen stays until
                // the search answers (the camera is kept).
                let bundle = Arc::new(m.bundle.clone());
                match &mut self.guided {
                    Some(s) => s.set_bundle(bundle),
                    None => match start_session(&m, &self.opts, &self.proxy) {
                        Ok(s) => self.guided = Some(s),
                        Err(e) => {
                            (self.opts.log)(&format!("mdg-view: reload failed; keeping the last good model\n{e}"));
                            return;
                        }
                    },
                }
                if !m.warnings.is_empty() {
                    (self.opts.log)(m.warnings.trim_end());
                }
                if let Some(old) = self.model.take() {
                    m.output = old.output;
                }
                self.model = Some(*m);
                self.summary.reloads += 1;
                (self.opts.log)("mdg-view: reloaded: searching");
                if let Some(s) = &mut self.guided {
                    s.request(Preempt::Cancel);
                }
                self.start_guide_watch();
                self.scene_changed();
            }
            Reloaded::Model(m) => {
                // Not (or no longer) a guided grammar.
                self.guide_watch = None;
                self.guided = None;
                let Some(g) = &mut self.gpu else { return };
                g.ctx.wait_idle();
                match g.renderer.set_model(&m, &self.programs) {
                    Ok(info) => {
                        (self.opts.log)(&format!(
                            "mdg-view: reloaded: {} triangles, program {}",
                            info.n_triangles, info.program
                        ));
                        if !m.warnings.is_empty() {
                            (self.opts.log)(m.warnings.trim_end());
                        }
                        self.summary.reloads += 1;
                        self.model = Some(*m);
                        self.redraw();
                    }
                    Err(e) => (self.opts.log)(&format!("mdg-view: reload failed; keeping the last good model\n{e}")),
                }
            }
        }
    }
}

/// The window's input from a winit event, if it is one the window handles.
fn input_of(event: &WindowEvent) -> Option<Input> {
    Some(match event {
        WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
            Input::Key(key_of(&event.logical_key)?)
        }
        WindowEvent::ModifiersChanged(m) => {
            Input::Modifiers(Modifiers { shift: m.state().shift_key(), ctrl: m.state().control_key() })
        }
        WindowEvent::MouseInput { state, button, .. } => Input::Button {
            button: match button {
                MouseButton::Left => Button::Left,
                MouseButton::Right => Button::Right,
                MouseButton::Middle => Button::Middle,
                _ => return None,
            },
            pressed: *state == ElementState::Pressed,
        },
        WindowEvent::CursorMoved { position, .. } => Input::CursorMoved(position.x, position.y),
        WindowEvent::MouseWheel { delta, .. } => Input::Wheel(match delta {
            MouseScrollDelta::LineDelta(_, y) => *y,
            MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
        }),
        _ => return None,
    })
}

/// The window's name for a winit key.
fn key_of(key: &WinitKey) -> Option<Key> {
    Some(match key {
        WinitKey::Named(NamedKey::Escape) => Key::Escape,
        WinitKey::Named(NamedKey::Tab) => Key::Tab,
        WinitKey::Named(NamedKey::Delete) => Key::Delete,
        WinitKey::Named(NamedKey::Backspace) => Key::Backspace,
        WinitKey::Named(NamedKey::Home) => Key::Home,
        WinitKey::Named(NamedKey::ArrowLeft) => Key::ArrowLeft,
        WinitKey::Named(NamedKey::ArrowRight) => Key::ArrowRight,
        WinitKey::Named(NamedKey::ArrowUp) => Key::ArrowUp,
        WinitKey::Named(NamedKey::ArrowDown) => Key::ArrowDown,
        WinitKey::Named(NamedKey::PageUp) => Key::PageUp,
        WinitKey::Named(NamedKey::PageDown) => Key::PageDown,
        WinitKey::Named(NamedKey::Space) => Key::Char(" ".into()),
        WinitKey::Character(c) => Key::Char(c.to_string()),
        _ => return None,
    })
}

/// `p`'s value moved by `steps` steps — a bool flips; 1 for an int; a twentieth of the range, or
/// a tenth of the value (at least 0.1) for a float without one — rounded for ints
/// and clamped to the range. `None` when it would not change.
pub fn stepped(p: &mdg_vm::bundle::Param, steps: f64) -> Option<f64> {
    if p.ty == 2 {
        // A bool flips.
        return Some(if p.value != 0.0 { 0.0 } else { 1.0 });
    }
    let step = if p.ty == 0 {
        1.0
    } else if p.max > p.min {
        (p.max - p.min) / 20.0
    } else {
        (p.value.abs() * 0.1).max(0.1)
    };
    let mut v = p.value + steps * step;
    if p.ty == 0 {
        v = v.round();
    }
    if p.max > p.min {
        v = v.clamp(p.min, p.max);
    }
    (v != p.value && v.is_finite()).then_some(v)
}

/// Copies the presented image to `buffer`, leaving it ready to present.
fn record_readback(ctx: &Context, cmd: vk::CommandBuffer, image: vk::Image, extent: vk::Extent2D, buffer: vk::Buffer) {
    let range = vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    };
    let to_src = vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
        .old_layout(vk::ImageLayout::PRESENT_SRC_KHR)
        .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range);
    let back = vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_READ)
        .dst_access_mask(vk::AccessFlags::empty())
        .old_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
        .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range);
    let region = [vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })];
    let host = vk::BufferMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .buffer(buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE);
    // SAFETY: `cmd` is recording after the render pass that left `image` in
    // PRESENT_SRC_KHR; the buffer holds width × height × 4 bytes.
    unsafe {
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[to_src],
        );
        ctx.device.cmd_copy_image_to_buffer(cmd, image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buffer, &region);
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::BOTTOM_OF_PIPE | vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &[],
            &[host],
            &[back],
        );
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

#[cfg(test)]
mod tests {
    use super::stepped;
    use mdg_vm::bundle::Param;

    #[test]
    fn param_steps_round_ints_clamp_to_the_range_and_scale_floats() {
        let int = Param { name: 0, ty: 0, value: 3.0, min: 1.0, max: 5.0 };
        assert_eq!(stepped(&int, 1.0), Some(4.0));
        assert_eq!(stepped(&int, 10.0), Some(5.0));
        assert_eq!(stepped(&Param { value: 5.0, ..int }, 1.0), None);
        assert_eq!(stepped(&int, -10.0), Some(1.0));
        let ranged = Param { name: 0, ty: 1, value: 0.5, min: 0.0, max: 2.0 };
        let near = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() < 1e-12);
        assert!(near(stepped(&ranged, 1.0), 0.6));
        let free = Param { name: 0, ty: 1, value: 4.0, min: 0.0, max: 0.0 };
        assert!(near(stepped(&free, -1.0), 3.6));
        assert!(near(stepped(&Param { value: 0.0, ..free }, 1.0), 0.1));
        let flag = Param { name: 0, ty: 2, value: 1.0, min: 0.0, max: 0.0 };
        assert_eq!(stepped(&flag, 1.0), Some(0.0));
        assert_eq!(stepped(&Param { value: 0.0, ..flag }, -1.0), Some(1.0));
    }
}
