//! Playback of animated models: play and pause, a frame forward or back, the
//! time shown in the title.

use super::App;

impl App {
    /// Moves the time by `frames` frames of the model's fps.
    pub(super) fn step(&mut self, frames: f32) {
        let fps = self.gpu.as_ref().and_then(|g| g.renderer.info()).map(|i| i.fps).unwrap_or(30.0).max(1e-3);
        self.playing = false;
        self.time = (self.time + frames / fps).max(0.0);
        self.show_time();
        self.redraw();
    }

    /// Advances the time while playing, wrapping at the duration.
    pub(super) fn tick(&mut self) {
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

    pub(super) fn show_time(&self) {
        if let Some(g) = &self.gpu {
            g.window.set_title(&format!(
                "mdg-view — {} — t = {:.2} s{}",
                self.path.display(),
                self.time,
                if self.playing { "" } else { " (paused)" }
            ));
        }
    }
}
