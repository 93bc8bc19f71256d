//! Limits and budgets: calls, depth, size, stack, vertices, time, keyframes; the
//! counts behind their warnings.

use super::*;

#[derive(Default)]
pub(super) struct LimitCounts {
    pub(super) maxdepth: u64,
    pub(super) minsize: u64,
    pub(super) stacksize: u64,
    /// The CALL op of the first call each per-branch limit refused (`maxdepth`,
    /// `minsize`, stack size): its warning names that rule and line.
    pub(super) first_refused: [Option<u32>; 3],
    pub(super) maxiter: bool,
    pub(super) vertices: bool,
    pub(super) time: bool,
    /// Keyframes of the bones made so far (see [`MAX_KEYFRAMES`]).
    pub(super) keyframes: u64,
    pub(super) animation: bool,
    /// `maxobjects` ended a breadth-first run.
    pub(super) objects: Option<ObjectsReached>,
}

/// The next count of calls at which [`Eval::count_call`] and [`Eval::count_run`]
/// must look closer, after `calls`: the next multiple of 4,096 (the budgets'
/// check) or `maxiter + 1` (the limit), whichever comes first; every count once
/// past `maxiter`.
pub(super) fn next_check(calls: u64, maxiter: u64) -> u64 {
    let budgets = (calls | 0xFFF).saturating_add(1);
    if calls <= maxiter {
        budgets.min(maxiter.saturating_add(1))
    } else {
        calls.saturating_add(1)
    }
}

impl<'b> Eval<'b> {
    /// Counts an iterator run or a convolution's body run as a call, so `maxiter`
    /// bounds them too (checking the budgets now and then).
    #[inline]
    pub(super) fn count_run(&mut self) {
        self.calls += 1;
        if self.calls >= self.next_check {
            self.count_run_closely();
        }
    }

    /// [`Eval::count_run`] at a count where something is due (see [`next_check`]).
    #[cold]
    #[inline(never)]
    fn count_run_closely(&mut self) {
        self.next_check = next_check(self.calls, self.maxiter);
        if self.calls > self.maxiter {
            self.limits.maxiter = true;
            self.stopped = true;
        }
        if self.calls & 0xFFF == 0 {
            self.check_budgets();
        }
    }

    /// A call refused by `maxdepth` before its frame was made: counted as
    /// [`Eval::admit`] counts it (the run-wide limits come first). Whether the
    /// count was one where the run-wide limits are looked at (only then can the
    /// count have stopped the run).
    #[inline(always)]
    pub(super) fn refuse_deep_call(&mut self, pc: u32) -> bool {
        self.calls += 1;
        let looked = self.calls >= self.next_check;
        if !looked || self.count_call_closely() {
            self.limits.maxdepth += 1;
            self.limits.first_refused[0].get_or_insert(pc);
        }
        looked
    }

    /// `n` calls refused by `maxdepth` at once, the first at `pc`, at counts where
    /// none is looked at (the caller checked that `calls + n < next_check`): what
    /// `n` times [`Eval::refuse_deep_call`] would count.
    #[inline(always)]
    pub(super) fn refuse_deep_calls(&mut self, n: u32, pc: u32) {
        if n > 0 {
            self.calls += u64::from(n);
            self.limits.maxdepth += u64::from(n);
            self.limits.first_refused[0].get_or_insert(pc);
        }
    }

    /// Counts a call against the run-wide limits (checking the budgets now and
    /// then); whether the run goes on.
    #[inline]
    pub(super) fn count_call(&mut self) -> bool {
        self.calls += 1;
        // (One comparison on the way: the budgets' check and `maxiter` are due
        // only at `next_check`.)
        self.calls < self.next_check || self.count_call_closely()
    }

    /// [`Eval::count_call`] at a count where something is due (see [`next_check`]).
    #[cold]
    #[inline(never)]
    fn count_call_closely(&mut self) -> bool {
        self.next_check = next_check(self.calls, self.maxiter);
        if self.calls & 0xFFF == 0 {
            self.check_budgets();
            if let Some(p) = self.progress {
                p(self.calls);
            }
            if self.stopped {
                // A budget ran out: this call is not made (the warning names its line).
                return false;
            }
        }
        if self.calls > self.maxiter {
            self.limits.maxiter = true;
            self.stopped = true;
            return false;
        }
        true
    }

    /// Whether a call may proceed; counts the limits that stop it.
    /// `pc` is the CALL op's (for the warning's rule and line). With `depth_ok`
    /// (a constant where it is inlined) the caller has already found `depth` within
    /// `maxdepth` (the fast path refuses deeper calls before composing their
    /// frame), so it is not tested again. `scale` is the child's
    /// [`State::scale`], asked only under `minsize`; with `MINSIZE_OFF` (a caller
    /// that found `minsize` off) `minsize` is not looked at.
    #[inline(always)]
    pub(super) fn admit<const MINSIZE_OFF: bool>(
        &mut self,
        scale: impl FnOnce() -> f32,
        depth: u32,
        stack_len: usize,
        pc: u32,
        depth_ok: bool,
    ) -> bool {
        if !self.count_call() {
            return false;
        }
        self.admit_rest::<MINSIZE_OFF>(scale, depth, stack_len, pc, depth_ok)
    }

    /// The per-branch limits of a call: `maxdepth` (unless `depth_ok`), `minsize`
    /// (unless `MINSIZE_OFF`), the stack size.
    #[inline]
    pub(super) fn admit_rest<const MINSIZE_OFF: bool>(
        &mut self,
        scale: impl FnOnce() -> f32,
        depth: u32,
        stack_len: usize,
        pc: u32,
        depth_ok: bool,
    ) -> bool {
        let s = &self.b.settings;
        let refused = if !depth_ok && s.maxdepth > 0 && depth > s.maxdepth {
            self.limits.maxdepth += 1;
            0
        } else if !MINSIZE_OFF && s.minsize > 0.0 && scale() < s.minsize {
            self.limits.minsize += 1;
            1
        } else if stack_len >= self.stacksize as usize {
            self.limits.stacksize += 1;
            2
        } else {
            return true;
        };
        self.limits.first_refused[refused].get_or_insert(pc);
        false
    }

    /// The vertices the run has made so far, as the vertex budget counts them: a
    /// prototype instance as its expanded vertices, or as one record when the output
    /// keeps it instanced ([`EvalOptions::instances_stored`]).
    pub(super) fn vertices_made(&self) -> u64 {
        let (n, vertices) = self.uncounted_instances();
        let instances = if self.opts.instances_stored {
            self.prototype_instances + n
        } else {
            self.instanced_vertices + n * vertices
        };
        (self.out.mesh.n_vertices() + self.out.sweeps.n_vertices()) as u64 + self.extra_vertices + instances
    }

    /// The prototype instances a lean run made and has not counted yet (see
    /// `Eval::uncounted_from`), and the vertices each has.
    pub(super) fn uncounted_instances(&self) -> (u64, u64) {
        match (self.uncounted_from, self.proto_vertices) {
            (Some(from), Some(v)) => (self.out.instances.len().saturating_sub(from) as u64, u64::from(v)),
            _ => (0, 0),
        }
    }

    /// Counts the instances [`Eval::uncounted_instances`] names; none is left
    /// uncounted.
    pub(super) fn count_instances(&mut self) {
        let (n, vertices) = self.uncounted_instances();
        self.prototype_instances += n;
        self.instanced_vertices += n * vertices;
        self.uncounted_from = None;
    }

    pub(super) fn check_budgets(&mut self) {
        if self.opts.cancel.as_ref().is_some_and(|c| (c.0)()) {
            self.stopped = true;
        }
        if self.vertices_made() > self.opts.max_vertices {
            self.limits.vertices = true;
            self.stopped = true;
        }
        if let Some(t) = self.opts.time_budget {
            if self.started.elapsed() > t {
                self.limits.time = true;
                self.stopped = true;
            }
        }
    }
}

impl<'b> Eval<'b> {
    /// The most points one profile keeps: [`MAX_PROFILE_POINTS`], and never more
    /// than half the vertex budget (a sweep makes two rings of them).
    pub(super) fn profile_limit(&self) -> usize {
        (MAX_PROFILE_POINTS as u64).min(self.opts.max_vertices / 2).max(2) as usize
    }

    /// Whether `more` vertices fit in the vertex budget; if not, the run stops there
    /// (before they are made) with the budget's warning.
    pub(super) fn room_for(&mut self, more: usize) -> bool {
        if self.vertices_made().saturating_add(more as u64) > self.opts.max_vertices {
            self.limits.vertices = true;
            self.stopped = true;
            return false;
        }
        true
    }
}

impl<'b> Eval<'b> {
    /// The keyframe budget: [`MAX_KEYFRAMES`], or the vertex budget when smaller.
    pub(super) fn keyframe_budget(&self) -> u64 {
        MAX_KEYFRAMES.min(self.opts.max_vertices)
    }

    /// Records a warning once.
    pub(super) fn warn_once(&mut self, msg: String) {
        if !self.out.stats.warnings.contains(&msg) {
            self.out.stats.warnings.push(msg);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::next_check;

    /// Every count at which the budgets (every 4,096 calls) or `maxiter` (every
    /// count past it) must be looked at is one where the counters look closer,
    /// starting as an evaluation starts (`next_check` 0).
    #[test]
    fn next_check_reaches_every_count_that_is_due() {
        for maxiter in [0, 1, 5, 4_095, 4_096, 4_097, 8_191, 10_000, u64::MAX] {
            let mut next = 0;
            for calls in 1..=20_000u64 {
                let closer = calls >= next;
                if closer {
                    next = next_check(calls, maxiter);
                    assert!(next > calls, "maxiter {maxiter}, at {calls}: next {next}");
                }
                let due = calls & 0xFFF == 0 || calls > maxiter;
                assert!(!due || closer, "maxiter {maxiter}: count {calls} is due but not looked at");
            }
        }
    }
}
