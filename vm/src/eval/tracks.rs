//! Animation: bones, transform-rule tracks (sampled frames) and convolutions.

use super::*;

impl<'b> Eval<'b> {
    /// Makes a bone for a call of model rule `rule` (which has transform rules) in
    /// state `child`, inside bone `parent`; returns its index.
    pub(super) fn new_bone(&mut self, rule: u32, child: &State, parent: u32) -> u32 {
        let b = self.b;
        let r = &b.rules[rule as usize];
        let fps = if child.fps.is_finite() && child.fps > 0.0 { child.fps } else { 0.0 };
        let needed = frames_needed(self.horizon, fps);
        self.limits.keyframes = self.limits.keyframes.saturating_add(needed as u64);
        if self.limits.keyframes > self.keyframe_budget() {
            self.limits.animation = true;
            self.stopped = true;
        }
        let tracks = r.transforms.iter().map(|&x| self.track(x, needed)).collect();
        let bones = &mut self.out.animation.bones;
        if bones.is_empty() {
            bones.push(Bone { rule: String::new(), parent: 0, rest: Frame::identity(), fps: 0.0, tracks: Vec::new() });
        }
        bones.push(Bone { rule: b.string(r.name).to_string(), parent, rest: child.f, fps, tracks });
        (bones.len() - 1) as u32
    }
}

impl<'b> Eval<'b> {
    /// The track of transform rule `rule` with at least `needed` frames (or all of
    /// them, if it ends sooner): from the cache, extended by a fresh sampling run when
    /// a cut track is too short. Returns its index in `out.animation.tracks`.
    pub(super) fn track(&mut self, rule: u32, needed: usize) -> u32 {
        self.track_within(rule, needed, MAX_TRACK_FRAMES)
    }

    /// [`Eval::track`] with at most `max` frames sampled (a convolution samples its
    /// rules up to its frame budget instead of [`MAX_TRACK_FRAMES`]).
    pub(super) fn track_within(&mut self, rule: u32, needed: usize, max: usize) -> u32 {
        let b = self.b;
        let name = b.string(b.rules[rule as usize].name).to_string();
        if needed > max {
            self.warn_once(format!(
                "{}transform rule `{name}`: only its first {max} frames are sampled",
                self.rule_at(rule)
            ));
        }
        let needed = needed.clamp(1, max.max(1));
        if let Some(&k) = self.track_ids.get(&rule) {
            let t = &self.out.animation.tracks[k as usize];
            if t.complete || t.frames.len() >= needed || self.computing.contains(&rule) {
                return k;
            }
            let (frames, complete) = self.sample(rule, needed);
            let t = &mut self.out.animation.tracks[k as usize];
            t.frames = frames;
            t.complete = complete;
            return k;
        }
        let tracks = &self.out.animation.tracks;
        let k = tracks.len() as u32;
        let why = if self.computing.contains(&rule) {
            Some("needs its own frames while they are being sampled (a cycle through `*` or `:`)".to_string())
        } else if self.computing.len() >= MAX_TRACK_NESTING {
            Some(format!("is sampled inside {MAX_TRACK_NESTING} other transform rules being sampled"))
        } else {
            None
        };
        if let Some(why) = why {
            self.warn_once(format!("{}transform rule `{name}` {why}; there it has no frames", self.rule_at(rule)));
            self.out.animation.tracks.push(Track { rule: name, frames: Vec::new(), complete: true });
            return k;
        }
        let (frames, complete) = self.sample(rule, needed);
        let k = self.out.animation.tracks.len() as u32;
        self.out.animation.tracks.push(Track { rule: name, frames, complete });
        self.track_ids.insert(rule, k);
        k
    }

    /// Evaluates transform rule `rule` from the identity, recording at most `limit`
    /// frames; returns them and whether the rule ended by itself (not cut at `limit`).
    /// The run has its own random stream (from the seed and the rule), its own
    /// sequential-selection state and no effect on pens or the continuation register.
    pub(super) fn sample(&mut self, rule: u32, limit: usize) -> (Vec<Frame>, bool) {
        self.computing.push(rule);
        let seed = self.seed ^ (rule as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let saved_rng = std::mem::replace(&mut self.rng, Pcg(Pcg64::seed_from_u64(seed)));
        let saved_seq = std::mem::take(&mut self.sequential);
        let saved_sink = std::mem::take(&mut self.frame_sink);
        let saved_limit = std::mem::replace(&mut self.frame_limit, limit);
        let saved_halt = std::mem::replace(&mut self.halt, false);
        let saved_last = self.last;
        self.run(rule, State::start(self.b.settings.fps), Mode::Transform);
        // A run stopped by a limit did not end by itself either.
        let complete = !self.halt && !self.stopped;
        let frames = std::mem::replace(&mut self.frame_sink, saved_sink);
        self.rng = saved_rng;
        self.sequential = saved_seq;
        self.frame_limit = saved_limit;
        self.halt = saved_halt;
        self.last = saved_last;
        self.computing.pop();
        (frames, complete)
    }

    /// The frames a convolution rule's body runs under (`I[i]·A[i]·B[i]` for every
    /// frame index i of its iterator rule I; A, B… sampled by index and clamped to
    /// their last frame). A terminating I contributes **all** its frames (SPEC §8:
    /// `duration·fps` bounds the animation, not a convolution); one that has not ended
    /// within the frame budget (`EvalOptions::max_frames`) is cut there with a warning.
    pub(super) fn convolution(&mut self, rule: u32) -> Arc<Vec<Frame>> {
        let b = self.b;
        if let Some(c) = self.conv_cache.get(&rule) {
            return c.clone();
        }
        let budget = self.opts.max_frames.clamp(1, usize::MAX as u64) as usize;
        let r = &b.rules[rule as usize];
        let it = self.track_within(r.iter, budget, budget) as usize;
        let t = &self.out.animation.tracks[it];
        let n = t.frames.len().min(budget);
        if !t.complete && !self.stopped {
            let msg = format!(
                "{}convolution `{}`: iterator rule `{}` did not end within the frame budget of {budget} frames; only those are used (an iterator rule must terminate; raise the budget with `--max-frames N`)",
                self.rule_at(r.iter),
                b.string(r.name),
                b.string(b.rules[r.iter as usize].name),
            );
            self.warn_once(msg);
        }
        let parts: Vec<u32> = r.transforms.iter().map(|&x| self.track_within(x, n, budget)).collect();
        let tracks = &self.out.animation.tracks;
        // (Sampling the parts can have re-sampled the iterator's track: a run stopped by
        // a limit meanwhile leaves it shorter. Take what it holds.)
        let frames: Vec<Frame> = tracks[it]
            .frames
            .iter()
            .take(n)
            .enumerate()
            .map(|(i, f)| parts.iter().fold(*f, |acc, &k| acc.compose(&tracks[k as usize].clamped(i as u64))))
            .collect();
        let frames = Arc::new(frames);
        self.conv_cache.insert(rule, frames.clone());
        frames
    }
}
