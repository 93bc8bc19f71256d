//! Guide editing in the window: the guided-search session, the mouse's presses
//! and releases on guides (dragging a control point, drawing a stroke), the
//! editor's keys, the searches' answers, and the `--guides` file watched.

use super::{App, UserEvent, WindowOptions};
use crate::guided::edit::{Param, Pick};
use crate::guided::session::{Accepted, Outcome, Session, SessionError, SessionOptions};
use crate::guided::watch::{GuideFileError, GuideWatch};
use crate::guided::worker::Preempt;
use crate::input::{Key, Modifiers};
use crate::model::Model;
use glam::DVec2;
use mdg_guided::Guide;
use std::sync::{Arc, Mutex};
use winit::event_loop::EventLoopProxy;

/// A log line's message: the `Ok` one, or the error's.
pub(super) fn said<E: std::fmt::Display>(r: Result<String, E>) -> String {
    r.unwrap_or_else(|e| e.to_string())
}

/// Starts a guided-search session on `model`'s grammar; its answers come to the
/// event loop through `proxy`.
pub(super) fn start_session(
    model: &Model,
    opts: &WindowOptions,
    proxy: &EventLoopProxy<UserEvent>,
) -> Result<Session, SessionError> {
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

impl App {
    /// Watches the `--guides` file of a guided grammar (with hot reload on).
    pub(super) fn start_guide_watch(&mut self) {
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

    /// A left press with guides shown: starts a stroke (draw mode or Ctrl), a drag
    /// of the control point under the cursor, or selects the guide whose curve is
    /// under it. Returns false when it is none of these (the press orbits).
    pub(super) fn guided_press(&mut self) -> bool {
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
    pub(super) fn guided_release(&mut self) {
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
    pub(super) fn guided_key(&mut self, key: &Key) -> bool {
        let Modifiers { shift, ctrl } = self.modifiers;
        let log = self.opts.log;
        let Some(s) = &mut self.guided else { return false };
        // What an edit did, or why it was not done.
        let say = |m: String| log(&format!("mdg-view: {m}"));
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
            (Key::Delete | Key::Backspace, _) => say(said(s.editor.delete_selected())),
            (Key::PageUp, _) => say(said(s.editor.step_param(steps))),
            (Key::PageDown, _) => say(said(s.editor.step_param(-steps))),
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
            (_, "j") => say(said(s.editor.step_param(-steps))),
            (_, "k") => say(said(s.editor.step_param(steps))),
            (_, "r") => {
                let seed = s.reseed();
                log(&format!("mdg-view: seed {seed}: searching"));
                s.request(Preempt::Cancel);
            }
            (_, "s") => say(said(s.save())),
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

    /// A guided search answered.
    pub(super) fn searched(&mut self, id: u64, outcome: Outcome) {
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
    pub(super) fn guides_file_changed(&mut self, r: Result<Vec<Guide>, GuideFileError>) {
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
}
