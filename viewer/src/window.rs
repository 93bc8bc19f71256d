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

use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::{vkerr, Context, ContextOptions, Validation};
use crate::model::{LoadOptions, Loader, Model};
use crate::program::Programs;
use crate::reload::{ReloadHandle, Reloaded};
use crate::renderer::{FrameParams, Renderer, RendererOptions};
use crate::swapchain::{choose_format, Surface, Swapchain};
use crate::sync::{Fence, Semaphore};
use crate::Error;
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::path::PathBuf;
use std::sync::Arc;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, EventLoopProxy};
use winit::keyboard::{Key, NamedKey};
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
    shift: bool,
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
        let size = window.inner_size();
        let swapchain = Swapchain::new(&ctx, &surface, format, (size.width, size.height), &mut renderer, None)?;
        if let Some(m) = &self.model {
            let info = renderer.set_model(m, &self.programs)?;
            (self.opts.log)(&format!(
                "mdg-view: {} triangles, {} line segments, program {} on {}",
                info.n_triangles, info.n_line_segments, info.program, ctx.device_name
            ));
            let aspect = swapchain.extent.width as f32 / swapchain.extent.height.max(1) as f32;
            let home = OrbitCamera::framing(&info.bounds, info.fov_deg, aspect);
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
        if !self.gpu.as_ref().is_some_and(|g| g.swapchain.can_read_back) {
            (self.opts.log)("mdg-view: this swapchain cannot be read back; no screenshot");
            return Ok(());
        }
        // An out-of-date swapchain draws nothing; a second try uses the new one.
        for _ in 0..2 {
            if let Some(px) = self.draw(true)? {
                let Some(g) = &self.gpu else { return Ok(()) };
                let e = g.swapchain.extent;
                return crate::offscreen::write_png(&path, &px, e.width, e.height);
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
            _ => self.camera = Some(OrbitCamera::framing(&info.bounds, info.fov_deg, aspect)),
        }
        self.redraw();
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, ev: &KeyEvent) {
        if ev.state != ElementState::Pressed {
            return;
        }
        let step = 10f32.to_radians();
        match &ev.logical_key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::ArrowLeft) => self.orbit(-step, 0.0),
            Key::Named(NamedKey::ArrowRight) => self.orbit(step, 0.0),
            Key::Named(NamedKey::ArrowUp) => self.orbit(0.0, step),
            Key::Named(NamedKey::ArrowDown) => self.orbit(0.0, -step),
            Key::Named(NamedKey::Home) => self.frame_model(true),
            Key::Character(c) => match c.to_lowercase().as_str() {
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

    fn reloaded(&mut self, r: Reloaded) {
        match r {
            Reloaded::Failed(msg) => {
                (self.opts.log)(&format!("mdg-view: reload failed; keeping the last good model\n{msg}"));
            }
            Reloaded::Model(m) => {
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
            WindowEvent::KeyboardInput { event, .. } => self.key(event_loop, &event),
            WindowEvent::ModifiersChanged(m) => self.mouse.shift = m.state().shift_key(),
            WindowEvent::MouseInput { state, button, .. } => {
                let down = state == ElementState::Pressed;
                match button {
                    MouseButton::Left if self.mouse.shift => self.mouse.pan = down,
                    MouseButton::Left => self.mouse.orbit = down,
                    MouseButton::Right | MouseButton::Middle => self.mouse.pan = down,
                    _ => {}
                }
                if !down {
                    self.mouse.orbit = false;
                    self.mouse.pan = false;
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let (x, y) = (position.x, position.y);
                if let Some((px, py)) = self.mouse.pos {
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
                self.mouse.pos = Some((x, y));
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.zoom(0.9f32.powf(lines));
            }
            _ => {}
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
        // Wake up now and then to notice a signal while idle.
        event_loop.set_control_flow(ControlFlow::WaitUntil(std::time::Instant::now() + QUIT_POLL));
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
