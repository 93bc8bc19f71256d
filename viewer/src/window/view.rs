//! The camera: framing the model, orbiting and zooming, and the view of the
//! window's pixels that guide editing maps to the world.

use super::App;
use crate::camera::OrbitCamera;
use crate::guided::project::ScreenView;
use crate::renderer::FrameParams;

impl App {
    pub(super) fn redraw(&self) {
        if let Some(g) = &self.gpu {
            g.window.request_redraw();
        }
    }

    pub(super) fn aspect(&self) -> f32 {
        self.gpu
            .as_ref()
            .map(|g| g.swapchain.extent.width as f32 / g.swapchain.extent.height.max(1) as f32)
            .unwrap_or(1.0)
    }

    pub(super) fn frame_model(&mut self, home: bool) {
        let aspect = self.aspect();
        let Some(info) = self.gpu.as_ref().and_then(|g| g.renderer.info()).cloned() else { return };
        match (&mut self.camera, home) {
            (Some(c), false) => c.frame(&info.bounds, aspect),
            _ => self.camera = Some(OrbitCamera::framing_art(&info.bounds, info.fov_deg, aspect, info.flat)),
        }
        self.redraw();
    }

    pub(super) fn orbit(&mut self, dx: f32, dy: f32) {
        if let Some(c) = &mut self.camera {
            c.orbit(dx, dy);
            self.redraw();
        }
    }

    pub(super) fn zoom(&mut self, f: f32) {
        if let Some(c) = &mut self.camera {
            c.zoom(f);
            self.redraw();
        }
    }

    /// What the window shows now, for mapping pixels to the world.
    pub(super) fn screen_view(&self) -> Option<ScreenView> {
        let g = self.gpu.as_ref()?;
        let camera = self.camera?;
        let frame = FrameParams { camera, time: self.time, wireframe: self.wireframe, camera_rule: self.camera_rule };
        let (view, proj, eye) = g.renderer.view_projection(&frame);
        let e = g.swapchain.extent;
        Some(ScreenView::new(view, proj, eye, e.width, e.height))
    }
}
