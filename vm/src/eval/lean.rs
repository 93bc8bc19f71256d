//! The fast path where only frames change ([`Sink::LEAN`]): when it applies, the
//! callers' activations ([`LeanAct`]), and the calls and returns of the one loop
//! ([`Eval::interpret`]) under it.

use super::*;

/// Whether the fast path's runs of `b` change nothing but frames (then they take
/// the [`Lean`] sink, from a start state that [`plain_start`] accepts): every call's
/// and iterator's transform is a constant whose colour, weight and fps deltas are
/// +0.0 (bit for bit), with no set colour, HSB part or non-uniform scale. Composing
/// such a transform adds +0.0 to those fields and keeps hue, `lin` and `ndet`.
pub(super) fn lean_path_applies(b: &Bundle) -> bool {
    let keeps = |xf: TransformId| {
        matches!(b.transforms.get(xf.index()), Some(Transform::Const(c))
            if c.set.is_none() && c.hsb.is_none() && c.n.is_none()
                && c.color.iter().chain(&c.weight).chain([&c.fps]).all(|v| v.to_bits() == 0))
    };
    b.code.iter().all(|op| match *op {
        Op::Call { xf, .. } => keeps(xf),
        Op::Loop { step, .. } | Op::LoopN { step, .. } => keeps(step),
        _ => true,
    })
}

/// Whether adding +0.0 gives back each of `s`'s colour, weight and fps bit for bit
/// (none is −0.0 or a signalling NaN) and `s` has no non-uniform factor: then every
/// composition [`lean_path_applies`] allows keeps all of `s` but its frame.
pub(super) fn plain_start(s: &State) -> bool {
    s.lin == 0
        && s.ndet.to_bits() == 1.0f32.to_bits()
        && s.color.iter().chain(&s.weight).chain([&s.fps]).all(|v| (v + 0.0).to_bits() == v.to_bits())
}

/// Per op of `b`: for an `INST` whose items are followed only by calls and then
/// the body's `RET` (a leaf of a tree, whose calls `maxdepth` refuses, or one
/// with none), how many calls; [`NONE`] for every other op.
pub(super) fn leaf_calls(b: &Bundle) -> Vec<u32> {
    let code = &b.code;
    (0..code.len())
        .map(|pc| {
            let Some(&Op::Inst { count, .. }) = code.get(pc) else { return NONE };
            let first = pc + 1 + count.index();
            let calls =
                code.get(first..).map_or(0, |c| c.iter().take_while(|op| matches!(op, Op::Call { .. })).count());
            match code.get(first + calls) {
                Some(Op::Ret {}) => calls as u32,
                _ => NONE,
            }
        })
        .collect()
}

/// What a lean call needs of its `CALL` op beyond its operands, made once at load:
/// the callee's first op when its rule has one definition, and whether the op after
/// the call is the body's `RET` (a tail call). A `start` with [`DEPTH_TABLE`] set
/// is selected at the call: where the rule has a depth table of at most `last + 1`
/// depths, `start`'s other bits are where it begins in [`LeanCalls::depth_starts`]
/// (a depth past the table picks what its last entry picks); for other rules
/// `start` is [`NONE`], whose position lies past that table.
#[derive(Clone, Copy)]
pub(super) struct LeanCall {
    pub(super) start: u32,
    pub(super) tail: bool,
    pub(super) last: u16,
}

/// The bit of [`LeanCall::start`] that says the callee is selected at the call.
pub(super) const DEPTH_TABLE: u32 = 1 << 31;

/// The lean calls' entries and their depth tables, end to end (see [`LeanCall`]).
#[derive(Default)]
pub(super) struct LeanCalls {
    /// Per op of the bundle, the [`LeanCall`] of a `CALL` just before it (for any
    /// other op, [`NONE`] and not a tail): a call looks its entry up at its return
    /// address.
    pub(super) calls: Vec<LeanCall>,
    /// The first op of the definition each depth-selected rule picks at each
    /// depth of its table (see [`Weights::by_depth`]), the rules' tables end to end.
    pub(super) depth_starts: Vec<u32>,
}

/// The [`LeanCalls`] of `b`, whose rules' depth tables are `by_depth` (see
/// [`Weights::by_depth`]).
pub(super) fn lean_calls(b: &Bundle, by_depth: &[Vec<u32>]) -> LeanCalls {
    let code = &b.code;
    let mut depth_starts = Vec::new();
    // Per rule, where its table begins and its last depth, for tables that cover
    // every depth (shorter than the cap: deeper calls pick what the last picks)
    // and whose positions stay clear of `DEPTH_TABLE`.
    let tables: Vec<Option<(u32, u16)>> = by_depth
        .iter()
        .map(|t| {
            let (Some(last), Ok(base)) = (t.len().checked_sub(1), u32::try_from(depth_starts.len())) else {
                return None;
            };
            let fits = t.len() < select::DEPTH_TABLE_MAX && base.checked_add(2 * t.len() as u32)? < DEPTH_TABLE;
            let last = u16::try_from(last).ok()?;
            fits.then(|| {
                depth_starts.extend_from_slice(t);
                (base, last)
            })
        })
        .collect();
    let calls = (0..=code.len())
        .map(|at| match at.checked_sub(1).and_then(|pc| code.get(pc).map(|op| (pc, op))) {
            Some((pc, Op::Call { rule, .. })) => {
                let tail = matches!(code.get(pc + 1), Some(Op::Ret {}));
                match (b.rules.get(rule.index()).map(|r| r.defs.as_slice()), tables.get(rule.index())) {
                    (Some([only]), _) if only.start & DEPTH_TABLE == 0 => LeanCall { start: only.start, tail, last: 0 },
                    (_, Some(&Some((base, last)))) => LeanCall { start: DEPTH_TABLE | base, tail, last },
                    _ => LeanCall { start: NONE, tail, last: 0 },
                }
            }
            _ => LeanCall { start: NONE, tail: false, last: 0 },
        })
        .collect();
    LeanCalls { calls, depth_starts }
}

/// An activation under [`Sink::LEAN`]: its frame, program counter and depth (the
/// rest of its state is the run's: no call changes it; its slots are empty). The
/// frame's translation is the first three lanes of `u` (the fourth is unused), so
/// that a composition adds it in one instruction and it takes one register.
#[derive(Clone, Copy)]
pub(super) struct LeanAct {
    pub(super) q: Quat,
    pub(super) qh: Quat,
    pub(super) u: Vec4,
    pub(super) pc: u32,
    pub(super) depth: u32,
}

impl LeanAct {
    /// The activation of frame `f` at `pc` and `depth`.
    #[inline(always)]
    fn new(f: &Frame, pc: u32, depth: u32) -> LeanAct {
        LeanAct { q: f.q, qh: f.qh, u: f.u.extend(0.0), pc, depth }
    }

    /// Its frame.
    #[inline(always)]
    fn frame(&self) -> Frame {
        Frame { q: self.q, qh: self.qh, u: self.u.truncate() }
    }
}

/// A [`LeanAct`] as the callers' stack keeps it (`Regs::lean`): its fields packed,
/// 56 bytes with no padding (a `LeanAct` has 8 bytes of it, which its copies would
/// carry along).
#[derive(Clone, Copy)]
#[repr(C, packed)]
pub(super) struct Caller {
    q: Quat,
    qh: Quat,
    u: Vec4,
    pc: u32,
    depth: u32,
}

impl Caller {
    /// `a` packed.
    #[inline(always)]
    fn of(a: &LeanAct) -> Caller {
        Caller { q: a.q, qh: a.qh, u: a.u, pc: a.pc, depth: a.depth }
    }

    /// The activation this packs.
    #[inline(always)]
    fn act(self) -> LeanAct {
        let Caller { q, qh, u, pc, depth } = self;
        LeanAct { q, qh, u, pc, depth }
    }
}

impl<'b> Eval<'b> {
    /// The loop's handler of `CALL`, `INST` and `RET` under [`Sink::LEAN`]: runs the
    /// ops from `m.act.pc` while they are one of those three, then hands the next
    /// op back to the loop ([`Eval::interpret`]). The running activation (frame,
    /// program counter and depth: a [`LeanAct`]) is a local of this small function,
    /// so it stays in registers across calls, instances and returns instead of
    /// being spilled around each by the loop's large body. Whether the run goes on.
    ///
    /// The handlers are the loop's (the same admission, selection, tail calls and
    /// instance push, in the same order); only their dispatch is here. A `PLAIN` run
    /// (see [`Eval::plain_lean`]) counts its instances when it is over rather than
    /// one by one, and tests neither `minsize` nor weights. Under the
    /// fast path nothing but a refused call, an iterator run or a limit looked at
    /// can stop a run (see [`Eval::stops`]), so a stop is asked only after those.
    /// With `LEAVES` (see `Eval::lean_leaves`), a call-less leaf's instance returns
    /// at once. With `LOOPS` (see `Eval::lean_loops`), identity blocks and the runs of
    /// iterators are taken here too; a bundle without them runs the handler without
    /// their arms (they cost a run of calls ~8 instructions per expansion in register
    /// allocation alone).
    #[inline(never)]
    pub(super) fn lean_ops<const PLAIN: bool, const LEAVES: bool, const LOOPS: bool>(&mut self, m: &mut Regs) -> bool {
        let code: &[Op] = &self.b.code;
        let Some(fixed) = m.fixed else { return false };
        let weight = m.act.base.weight;
        let maxdepth = m.maxdepth;
        let mut r = LeanAct::new(&m.act.base.f, m.act.pc, m.act.depth);
        let first_instance = self.out.instances.len();
        if PLAIN {
            // (Counted when the run is over, see `Eval::uncounted_from`.)
            self.uncounted_from = Some(first_instance);
        }
        // Whether the last instance's fields but frame and mesh are the run's (only
        // this run's pushes change them while it runs).
        let mut tail_is_fixed = self.out.instances.tail_is(&fixed.0);
        let go_on = loop {
            match code.get(r.pc as usize) {
                Some(&Op::Call { rule, xf, .. }) => {
                    r.pc += 1;
                    let depth = r.depth + 1;
                    let looked = if depth > maxdepth {
                        // Refused before its frame is composed (see `op_call`).
                        self.refuse_deep_call(r.pc - 1)
                    } else {
                        self.lean_call::<PLAIN>(m, &mut r, rule, xf, depth)
                    };
                    if looked {
                        m.act.pc = r.pc;
                        if self.stops(m) {
                            break false;
                        }
                    }
                }
                Some(&Op::Inst { proto, count }) => {
                    self.lean_instance::<PLAIN>(proto.0, &r.frame(), weight, &fixed, &mut tail_is_fixed);
                    let at = r.pc as usize;
                    r.pc += 1 + count.0;
                    // A call-less leaf (its next op is the body's `RET`): it returns
                    // here, not through the dispatch.
                    if LEAVES && self.leaf_calls.get(at) == Some(&0) {
                        match m.lean.pop() {
                            Some(caller) => r = caller.act(),
                            None => break false,
                        }
                        continue;
                    }
                    // A leaf at `maxdepth`: the body's calls will all be refused,
                    // at counts where no limit is looked at, so they are counted
                    // at once and the body returns.
                    if r.depth >= maxdepth {
                        let leaf = self.leaf_calls.get(at).copied().unwrap_or(NONE);
                        if leaf != NONE && self.calls + u64::from(leaf) < self.next_check {
                            self.refuse_deep_calls(leaf, r.pc);
                            match m.lean.pop() {
                                Some(caller) => r = caller.act(),
                                None => {
                                    r.pc += leaf;
                                    break false;
                                }
                            }
                        }
                    }
                }
                Some(Op::Ret {}) => match m.lean.pop() {
                    Some(caller) => r = caller.act(),
                    None => break false,
                },
                // An identity block entered without a record (see `block.rs`).
                Some(&Op::Loop { .. })
                    if LOOPS && self.blocks.get(r.pc as usize) == Some(&true) && keeps_identity_frame(&r.frame()) =>
                {
                    r.pc += 1;
                }
                Some(&Op::EndLoop { begin }) if LOOPS => {
                    if !self.lean_end_loop(m, &mut r, begin) {
                        break true;
                    }
                    // (As the loop asks after every `ENDLOOP`.)
                    m.act.pc = r.pc;
                    if self.stops(m) {
                        break false;
                    }
                }
                _ => break true,
            }
        };
        m.act.base.f = r.frame();
        m.act.pc = r.pc;
        m.act.depth = r.depth;
        // The finiteness bound of the run's instances (see `Eval::instance_mesh`),
        // tested on their frames now rather than at each push.
        if !self.out.instances.frames_surely_small(first_instance) {
            self.instances_small = glam::BVec4A::splat(false);
        }
        if PLAIN {
            self.count_instances();
        }
        go_on
    }

    /// `ENDLOOP begin` in a lean run, `r` the running activation, where it is
    /// what the loop's `ENDLOOP` does to a lean run's state: the end of an identity
    /// block entered without a record, the next run of an iterator (its constant
    /// step composed as [`State::compose_step`] composes it: a lean run's state
    /// changes only in its frame, which never has a non-uniform factor), or its
    /// last run's end (the frame it was opened in). Whether it was done here (if
    /// not, the loop does it).
    #[inline(always)]
    fn lean_end_loop(&mut self, m: &mut Regs, r: &mut LeanAct, begin: OpIndex) -> bool {
        let top = m.loops.last_mut().filter(|l| l.opened_by(begin, r.depth));
        let Some(l) = top else {
            // (Under the fast path a record open at `ENDLOOP` is its own loop's,
            // but for an identity block entered without one.)
            if self.blocks.get(begin.index()) != Some(&true) {
                return false;
            }
            r.pc += 1;
            return true;
        };
        if l.remaining <= 1 {
            let f = l.saved_base.f;
            m.loops.pop();
            *r = LeanAct::new(&f, r.pc + 1, r.depth);
            return true;
        }
        let Some(Transform::Const(c)) = self.b.transforms.get(l.step.index()) else { return false };
        if l.chain {
            return false;
        }
        l.remaining -= 1;
        l.acc = l.acc.compose(&Frame64::step_of(&c.q, &c.qh, &c.u));
        *r = LeanAct::new(&l.acc.to_frame(), begin.0 + 1, r.depth);
        // Iterator runs count as calls, so `maxiter` also ends huge loops.
        self.count_run();
        true
    }

    /// Whether a lean run from `m` is plain: every prototype has as many vertices
    /// (its instances can be counted when it is over, see `Eval::uncounted_from`),
    /// it carries no weights (see `Regs::fixed`) and `minsize` is off.
    pub(super) fn plain_lean(&self, m: &Regs) -> bool {
        // (`minsize` is off unless above zero: NaN is off too, as `admit` reads it.)
        let minsize_off = self.b.settings.minsize.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater);
        self.proto_vertices.is_some() && m.fixed.is_some_and(|f| f.1) && minsize_off
    }

    /// The loop's arm for a lean run's `CALL`, `INST` and `RET`: the variant of
    /// [`Eval::lean_ops`] this run and bundle take (plain or not, with call-less
    /// leaves or not, with `LOOP`s or not). Whether the run goes on.
    #[inline(always)]
    pub(super) fn lean_run(&mut self, m: &mut Regs) -> bool {
        match (self.plain_lean(m), self.lean_leaves, self.lean_loops) {
            (true, false, false) => self.lean_ops::<true, false, false>(m),
            (true, true, false) => self.lean_ops::<true, true, false>(m),
            (false, false, false) => self.lean_ops::<false, false, false>(m),
            (false, true, false) => self.lean_ops::<false, true, false>(m),
            (true, false, true) => self.lean_ops::<true, false, true>(m),
            (true, true, true) => self.lean_ops::<true, true, true>(m),
            (false, false, true) => self.lean_ops::<false, false, true>(m),
            (false, true, true) => self.lean_ops::<false, true, true>(m),
        }
    }

    /// A lean call (see [`Eval::lean_ops`]) within `maxdepth`, `r` the running
    /// activation: only the frame is composed (the rest of the callee's state is the
    /// caller's, see [`lean_path_applies`]), and only the caller's frame, program
    /// counter and depth are pushed. Whether the call was refused by a limit (then
    /// the run may have to stop).
    #[inline(always)]
    fn lean_call<const PLAIN: bool>(
        &mut self,
        m: &mut Regs,
        r: &mut LeanAct,
        rule: RuleId,
        xf: TransformId,
        depth: u32,
    ) -> bool {
        // (Every transform a lean call has is a constant without a non-uniform scale.)
        let (q, qh, u) = match self.prepared.get(xf.index()) {
            Some(Some(p)) => Frame::compose_prepared_lanes(r.q, r.qh, r.u, p),
            _ => {
                let from = State { f: r.frame(), ..m.act.base };
                let f = self.apply(xf, &from, r.depth, m.act.slot_base, m.act.slot_top).f;
                (f.q, f.qh, f.u.extend(0.0))
            }
        };
        let f = Frame { q, qh, u: u.truncate() };
        let ndet = m.act.base.ndet;
        // (On the fast path every call adds one to the depth and one caller to the
        // stack, and a return takes both back: the callers' count is the depth
        // gained since the run's start, whether tail calls kept their caller or not.)
        let stack_len = (depth - m.start_depth) as usize;
        if !self.admit::<PLAIN>(|| f.scale_factor() * ndet.abs(), depth, stack_len, r.pc - 1, true) {
            return true;
        }
        // (At the return address: `r.pc` is past the call.)
        let call =
            self.lean_calls.calls.get(r.pc as usize).copied().unwrap_or(LeanCall { start: NONE, tail: false, last: 0 });
        let pc = if call.start & DEPTH_TABLE == 0 {
            call.start
        } else {
            // (`NONE`'s position is past the tables: the rule is selected as any is.)
            let at = (call.start & !DEPTH_TABLE) as usize + depth.min(u32::from(call.last)) as usize;
            match self.lean_calls.depth_starts.get(at) {
                Some(&pc) => pc,
                None => match self.by_depth(rule, depth) {
                    Some(pc) => pc,
                    None => {
                        let child = State { f, ..m.act.base };
                        self.select(rule, &child, depth, m.act.slot_top as usize)
                    }
                },
            }
        };
        // A tail call (the caller's next op is its `RET`, and a lean `RET` only
        // returns): the callee takes the caller's place, so its return is the
        // caller's.
        if !call.tail {
            m.lean.push(Caller::of(r));
        }
        *r = LeanAct { q, qh, u, pc, depth };
        false
    }
}
