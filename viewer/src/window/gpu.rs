//! The GPU's life cycle in the window: the instance, surface, swapchain and
//! renderer made when the window opens ([`App::create_gpu`]), the swapchain made
//! again after a resize, one frame drawn (and read back when a screenshot is
//! asked for), and the model with the guide overlay uploaded ([`upload`]).

use super::capture::record_readback;
use super::{App, FrameSync, Gpu};
use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::{vkerr, Context, ContextOptions};
use crate::guided::session::Session;
use crate::model::Model;
use crate::program::Programs;
use crate::renderer::{FrameParams, ModelInfo, Renderer, RendererOptions};
use crate::swapchain::{choose_format, Surface, Swapchain};
use crate::sync::{Fence, Semaphore};
use crate::Error;
use ash::vk;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use std::sync::Arc;
use winit::dpi::PhysicalSize;
use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

/// Uploads `model`, with the guide editor's overlay when there is one.
pub(super) fn upload(
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

impl App {
    pub(super) fn create_gpu(&mut self, event_loop: &ActiveEventLoop) -> Result<(), Error> {
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

    pub(super) fn recreate_swapchain(&mut self) -> Result<(), Error> {
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
    pub(super) fn draw(&mut self, screenshot: bool) -> Result<Option<Vec<u8>>, Error> {
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
}
