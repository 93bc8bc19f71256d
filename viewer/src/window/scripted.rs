//! `--script`: the script's commands run as the window's own input, with its
//! `idle`, `point`, `screenshot` and `quit`.

use super::App;
use crate::guided::session::Session;
use crate::input::Input;
use crate::script::Step;
use crate::Error;
use winit::event_loop::ActiveEventLoop;

/// How long a script waiting for a search looks again.
const SCRIPT_POLL: std::time::Duration = std::time::Duration::from_millis(10);

impl App {
    /// Whether nothing is left to do for the script's `idle`: every search asked for
    /// answered and the newest model uploaded.
    pub(super) fn is_idle(&self) -> bool {
        self.guided.as_ref().is_none_or(Session::is_idle) && !self.scene_dirty
    }

    /// Runs the script's next steps; returns when to look again (`None`: it is over).
    pub(super) fn run_script(&mut self, event_loop: &ActiveEventLoop) -> Option<std::time::Instant> {
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
}
