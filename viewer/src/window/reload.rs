//! Hot reload in the window: the grammar's files watched, a reloaded model (or a
//! guided grammar's new search) taking the old one's place, and the scene uploaded
//! again when the model or the guides change.

use super::gpu::upload;
use super::guides::start_session;
use super::{App, UserEvent};
use crate::guided::worker::Preempt;
use crate::reload::{ReloadHandle, Reloaded};
use std::sync::Arc;

impl App {
    pub(super) fn start_reload(&mut self) {
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

    pub(super) fn reloaded(&mut self, r: Reloaded) {
        match r {
            Reloaded::Failed(msg) => {
                (self.opts.log)(&format!("mdg-view: reload failed; keeping the last good model\n{msg}"));
            }
            Reloaded::Model(mut m) if m.bundle.extensions.has(mdg_vm::bundle::SectionKind::Guided) => {
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

    /// The guides or the model changed: upload before the next frame.
    pub(super) fn scene_changed(&mut self) {
        self.scene_dirty = true;
        self.update_title();
        self.redraw();
    }

    /// Uploads the model and the guide overlay if they changed.
    pub(super) fn sync_scene(&mut self) {
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

    pub(super) fn update_title(&self) {
        let (Some(g), Some(s)) = (&self.gpu, &self.guided) else { return };
        let mode = if self.draw_mode { " — D: drag with the left button to draw a guide" } else { "" };
        g.window.set_title(&format!("mdg-view — {} — {}{mode}", self.path.display(), s.title()));
    }
}
