//! The interpreter: one loop over the bundle's ops ([`Eval::interpret`]), one
//! handler per op, and the activation records. Every kind of run (sites recorded or
//! not, the constant-transform fast path, the guided search's expansion) is this
//! loop with its own [`Sink`] (see `sink.rs`).

use super::*;

/// Data derived once per constant transform, for the `VERTEX` fast path.
pub(super) struct XfInfo {
    pub(super) frame: Frame,
    /// The transform's linear part applied to the `normal` directive's vector.
    pub(super) normal: Vec3,
    pub(super) mirrored: bool,
}

/// Whether the fast path (the [`Simple`] sink) can run `b`'s model: no rule has parameters, bones or
/// an iterator rule, and the code is only `INST` (with the items it covers), calls
/// and `LOOP`s with constant transforms (no non-uniform scale; no `\` after a call,
/// no chained runs), `ENDLOOP` and `RET`.
/// `xf_pure` is [`Eval::xf_pure`].
pub(super) fn fast_path_applies(b: &Bundle, xf_pure: &[bool]) -> bool {
    let pure = |xf: TransformId| xf_pure.get(xf.index()).copied().unwrap_or(false);
    let rules_ok =
        b.rules.iter().all(|r| r.params.is_empty() && r.frame == 0 && r.transforms.is_empty() && r.iter == NONE)
            && b.rules.iter().all(|r| r.defs.iter().all(|d| d.retire_depth == 0));
    let mut pc = 0usize;
    while let Some(op) = b.code.get(pc) {
        pc += match *op {
            Op::Inst { count, .. } => 1 + count.index(),
            Op::Call { xf, flags, .. } if flags == 0 && pure(xf) => 1,
            Op::Loop { step, chain, .. } if chain & bundle::ops::LOOP_CHAIN == 0 && pure(step) => 1,
            Op::EndLoop { .. } | Op::Ret {} => 1,
            _ => return false,
        };
    }
    rules_ok
}

/// The state a constant `VERTEX` item (transform `c`, cached as `x`) leaves in
/// `last` when it starts from `from`: what composing `c` gives, without its linear
/// factor (the `VERTEX` fast path's frames have none).
#[inline]
pub(super) fn vertex_state(from: &State, x: &XfInfo, c: &Composite) -> State {
    State {
        f: from.f.compose(&x.frame),
        color: add(from.color, c.color),
        weight: add(from.weight, c.weight),
        fps: from.fps + c.fps,
        ..*from
    }
}

/// The last frame whose linear map the `VERTEX` path computed, and that map: the
/// items of a body that run one by one share their frame, so it is computed once.
pub(super) struct LinCache {
    pub(super) frame: Frame,
    pub(super) lin: (Mat3, bool),
}

impl LinCache {
    /// `f.linear()`, from the cache when `f` is the frame it holds (compared bit
    /// for bit: equal frames have equal maps).
    #[inline]
    pub(super) fn get(&mut self, f: &Frame) -> (Mat3, bool) {
        let same = |a: &Frame, b: &Frame| {
            a.q.to_array().map(f32::to_bits) == b.q.to_array().map(f32::to_bits)
                && a.qh.to_array().map(f32::to_bits) == b.qh.to_array().map(f32::to_bits)
                && a.u.to_array().map(f32::to_bits) == b.u.to_array().map(f32::to_bits)
        };
        if !same(&self.frame, f) {
            *self = LinCache { frame: *f, lin: f.linear() };
        }
        self.lin
    }
}

/// An activation: what a call and a return copy (112 bytes). What few activations
/// have lives in side stacks of [`Regs`], keyed by the activation's level (its
/// callers' count): a bone other than its caller's, a convolution's remaining
/// runs, and the iterators it opened (each [`LoopRec`] names its level).
#[derive(Clone, Copy)]
pub(super) struct Act {
    pub(super) base: State,
    pub(super) pc: u32,
    pub(super) depth: u32,
    /// The activation's frame is `slots[slot_base..slot_top]` (parameters, then locals);
    /// `ARG`s for the next call are pushed above it.
    pub(super) slot_base: u32,
    pub(super) slot_top: u32,
}

/// The remaining runs of a convolution rule's body.
pub(super) struct Conv {
    /// The level of the activation that runs the body (see [`Act`]).
    pub(super) level: u32,
    /// `I[i]·A[i]·B[i]` for every frame index i of the iterator rule.
    pub(super) frames: Arc<Vec<Frame>>,
    /// The next frame index to run.
    pub(super) next: usize,
    /// The body's first op (the definition chosen at the call).
    pub(super) pc: u32,
    /// R's state at the call; run i is under its frame composed with `frames[i]`.
    pub(super) origin: State,
}

pub(super) struct LoopRec {
    /// The level of the activation that opened it (see [`Act`]).
    pub(super) level: u32,
    /// Its `LOOP` op, and the depth of the activation that opened it (an identity
    /// block's `ENDLOOP` tells by them whether the block opened this record, see
    /// `block.rs`).
    pub(super) begin: u32,
    pub(super) depth: u32,
    pub(super) remaining: u64,
    pub(super) step: TransformId,
    pub(super) saved_base: State,
    pub(super) chain: bool,
    /// The current run's frame in `f64` (see [`State::compose_step`]).
    pub(super) acc: Frame64,
}

impl LoopRec {
    /// Whether the `LOOP` at `begin`, run by an activation at `depth`, opened this
    /// record (an identity block entered without one did not: see `block.rs`).
    #[inline(always)]
    pub(super) fn opened_by(&self, begin: OpIndex, depth: u32) -> bool {
        self.begin == begin.0 && self.depth == depth
    }
}

impl<'b> Eval<'b> {
    /// `from` composed with transform `xf` (at `depth`, in the frame `slots[base..top]`).
    #[inline(always)]
    pub(super) fn apply(&mut self, xf: TransformId, from: &State, depth: u32, base: u32, top: u32) -> State {
        let b = self.b;
        // A constant transform is composed where it lies (a composite is too big to
        // copy), with its frame prepared where neither side has a non-uniform factor.
        if let Transform::Const(c) = &b.transforms[xf] {
            return match self.prepared.get(xf.index()) {
                Some(Some(p)) if from.lin == 0 => from.compose_prepared(c, p),
                _ => from.compose(c, &mut self.lins),
            };
        }
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let env = Env { at: from, depth, slots };
        let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
        from.compose(&c, &mut self.lins)
    }

    /// [`Eval::apply`] for an iterator's step: composed by [`State::compose_step`]
    /// with the running frame `acc`.
    #[inline]
    pub(super) fn apply_step(
        &mut self,
        xf: TransformId,
        from: &State,
        acc: &mut Frame64,
        depth: u32,
        base: u32,
        top: u32,
    ) -> State {
        let b = self.b;
        if let Transform::Const(c) = &b.transforms[xf] {
            return from.compose_step(c, acc, &mut self.lins);
        }
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let env = Env { at: from, depth, slots };
        let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
        from.compose_step(&c, acc, &mut self.lins)
    }

    /// Expression `e` at state `at` and `depth` in the frame `slots[base..top]`.
    #[inline]
    pub(super) fn value(&mut self, e: ExprId, at: &State, depth: u32, base: u32, top: u32) -> f64 {
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let code: &[ExprOp] = &self.b.exprs[e];
        // (Tried before the environment is built: most arguments are `n - 1`.)
        if let Some(v) = expr::quick(code, slots) {
            return v;
        }
        Env { at, depth, slots }.eval_full(code, &mut self.rng, &mut self.expr_stack)
    }

    /// The definition of `rule_idx` for a call in state `child` at `depth` whose
    /// arguments are `slots[args..]`.
    pub(super) fn select(&mut self, rule: RuleId, child: &State, depth: u32, args: usize) -> u32 {
        if let Some(pc) = self.by_depth(rule, depth) {
            return pc;
        }
        let slots = self.slots.get(args..).unwrap_or(&[]);
        select_def(
            self.b,
            rule,
            child,
            depth,
            slots,
            &mut self.rng,
            &mut self.sequential,
            &mut self.expr_stack,
            &mut self.weights,
            &mut self.non_finite,
        )
    }

    /// The definition a depth selector with constant weights picks at `depth`
    /// (precomputed at load), if `rule` has one.
    #[inline(always)]
    pub(super) fn by_depth(&self, rule: RuleId, depth: u32) -> Option<u32> {
        self.weights.by_depth.get(rule.index()).and_then(|t| t.get(depth as usize)).copied()
    }

    /// Pushes a frame for a run that starts at `rule` (no caller passes arguments: the
    /// parameters take their defaults); returns its base.
    pub(super) fn default_frame(&mut self, rule: RuleId) -> (u32, u32) {
        let r = &self.b.rules[rule];
        let base = self.slots.len();
        self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
        self.slots.resize(base + r.frame as usize, 0.0);
        (base as u32, self.slots.len() as u32)
    }

    /// Pushes a frame for a run that starts at `rule` with the arguments `args`
    /// (a queued call's); returns its base.
    pub(super) fn frame_with(&mut self, rule: RuleId, args: &[f64]) -> (u32, u32) {
        let r = &self.b.rules[rule];
        let base = self.slots.len();
        self.slots.extend(args.iter().copied().chain(r.params.iter().skip(args.len()).map(|d| d.unwrap_or(0.0))));
        self.slots.resize(base + r.frame as usize, 0.0);
        (base as u32, self.slots.len() as u32)
    }

    /// Runs `rule` from `start` until its whole derivation is done.
    pub(super) fn run(&mut self, rule: u32, start: State, mode: Mode) {
        self.run_from(rule, start, 0, mode)
    }

    /// Runs a call of `rule` in state `start` at `depth` until its whole derivation
    /// is done: the one loop ([`Eval::interpret`]) with the sink this run needs.
    pub(super) fn run_from(&mut self, rule: u32, start: State, depth: u32, mode: Mode) {
        if self.b.settings.breadth && mode == Mode::Model {
            self.run_breadth(rule, start, depth);
        } else if self.fast && mode == Mode::Model {
            if self.lean && plain_start(&start) {
                self.interpret(&mut Lean, rule, start, depth, mode);
            } else {
                self.interpret(&mut Simple, rule, start, depth, mode);
            }
        } else if self.opts.record_sites || self.tree.is_some() {
            self.interpret(&mut Sited, rule, start, depth, mode);
        } else {
            self.interpret(&mut Plain, rule, start, depth, mode);
        }
    }

    /// The interpreter: runs a call of `rule` in state `start` at `depth` until its
    /// whole derivation is done (or, for a sink that collects calls, until its body
    /// is done), with an explicit stack of activations. What differs between runs
    /// (sites recorded or not, the constant-transform fast path, the guided search's
    /// expansion) is the sink `S`, resolved at compile time (see [`Sink`]).
    pub(super) fn interpret<S: Sink>(&mut self, sink: &mut S, rule: u32, start: State, depth: u32, mode: Mode) {
        let b = self.b;
        let rule = RuleId(rule);
        // The sink is asked once: the run's arguments fill the frame, its bone is the
        // parent of the bones the body makes.
        let ((slot_base, slot_top), parent_bone) = match sink.start_args() {
            Some((args, bone)) => (self.frame_with(rule, args), bone),
            None => (self.default_frame(rule), 0),
        };
        let pc = self.select(rule, &start, depth, slot_base as usize);
        // Rule-local retirement applies to the run's first call too (see `retire.rs`).
        let retiring = !S::SIMPLE && !S::COLLECTS && self.retire.any;
        let first =
            if retiring { self.retired_first(rule, pc, &start, depth, slot_base) } else { Some((rule, pc, slot_top)) };
        let Some((rule, pc, slot_top)) = first else { return };
        if S::COLLECTS {
            // (`sequential` and `pattern` start afresh with every expansion.)
            self.sequential.clear();
        }
        let Some((act, bone, conv)) =
            self.first_activation::<S>(rule, start, pc, (depth, parent_bone), (slot_base, slot_top), mode)
        else {
            if retiring {
                self.retire.end_run();
            }
            self.slots.truncate(slot_base as usize);
            return;
        };
        if retiring {
            self.retire.enter(pc, 0);
        }
        // (A nested run, sampling a transform rule, returns to the op that started it.)
        let outer = (self.site_pc, self.site_depth, self.site_node);
        // The derivation node of the running activation (see [`Eval::call_node`]); a
        // nested run (a profile, a transform rule) is no call of the model's derivation.
        let tree = S::SITES && mode == Mode::Model && self.tree.is_some();
        let node = if tree { self.call_node(sink.parent_node(), rule.0, depth) } else { outer.2 };
        let mut m = Regs {
            act,
            stack: Vec::new(),
            lean: Vec::new(),
            start_depth: depth,
            fixed: None,
            bone,
            bones: Vec::new(),
            seed: None,
            seeds: Vec::new(),
            subpaths: Vec::new(),
            convs: conv.into_iter().collect(),
            cont: None,
            lin_cache: LinCache { frame: Frame::identity(), lin: Frame::identity().linear() },
            loops: std::mem::take(&mut self.spare_loops),
            node,
            nodes: Vec::new(),
            // `maxdepth` (0: none) as the depth past which calls are refused.
            maxdepth: if b.settings.maxdepth > 0 { b.settings.maxdepth } else { u32::MAX },
            tree,
            mode,
        };
        m.loops.clear();
        if S::LEAN {
            let unweighted = start.weight == [0.0; 4] && self.out.instance_weights.is_empty();
            let at = self.out.mesh.n_vertices() as u32;
            m.fixed = Some((Fixed::new(start.color, m.bone, 0, at), unweighted));
        }
        let code: &[Op] = &b.code;
        // (The fast path checks for a stop where one can happen, after a refused call
        // or a counted iterator run, rather than before every op; see `stops`.)
        let stopped_at_start = S::SIMPLE && self.stops(&m);
        loop {
            if S::SITES {
                self.note_site(m.act.pc, m.act.depth, m.node);
            }
            if (!S::SIMPLE && self.stops(&m)) || stopped_at_start {
                break;
            }
            // (Matched where it lies: its fields are read from the bundle, not from a
            // copy of the op.)
            let op = &code[m.act.pc as usize];
            let go_on = match *op {
                // (A lean run's calls, instances and returns run in their own
                // small handler, with the running frame in registers.)
                Op::Call { .. } | Op::Inst { .. } | Op::Ret {} if S::LEAN => self.lean_run(&mut m),
                Op::Call { rule, xf, flags } => self.op_call(sink, &mut m, rule, xf, flags),
                Op::Draw { kind: Drawable::Vertex, xf, ns, profile, flags: _ }
                    if !S::COLLECTS && mode == Mode::Model && self.xf_info[xf.index()].is_some() =>
                {
                    self.op_vertex(&mut m, xf, ns, profile);
                    true
                }
                Op::Draw { kind, xf, ns, profile, flags } => {
                    self.op_draw::<S>(&mut m, kind, xf, (ns.0, profile.0, flags), mode);
                    true
                }
                Op::Iso { iso, xf, flags: _ } => {
                    let s = self.item(&mut m, xf);
                    if !S::COLLECTS && mode == Mode::Model {
                        self.instance(iso.0, &s, m.act.pc - 1, m.bone);
                    }
                    true
                }
                Op::Loop { .. } | Op::LoopN { .. } => {
                    if !self.enter_block::<S>(&mut m) {
                        self.op_loop(&mut m, *op);
                    }
                    true
                }
                Op::EndLoop { begin } => {
                    (self.leave_block(&mut m, begin) || self.op_end_loop(sink, &mut m, begin))
                        && !(S::SIMPLE && self.stops(&m))
                }
                Op::Inst { proto, count } => {
                    self.op_inst::<S>(&mut m, proto, count);
                    true
                }
                Op::Cont {} => {
                    m.act.pc += 1;
                    m.cont = Some(self.last);
                    true
                }
                // (A sink that collects calls runs no callee: it has no arguments
                // to pass, and the compiler rejects calls with arguments there.)
                Op::Arg { .. } if S::COLLECTS => {
                    m.act.pc += 1;
                    true
                }
                Op::Arg { expr } => {
                    m.act.pc += 1;
                    let v = self.value_at(&m, expr);
                    self.slots.push(v);
                    true
                }
                Op::Set { slot, expr } => {
                    m.act.pc += 1;
                    let v = self.value_at(&m, expr);
                    if let Some(s) = self.slots.get_mut(m.act.slot_base as usize + slot.index()) {
                        *s = v;
                    }
                    true
                }
                Op::Jump { target } => {
                    m.act.pc = target.0;
                    true
                }
                Op::JumpIfNot { expr, target } => {
                    let v = self.value_at(&m, expr);
                    m.act.pc = if expr::truthy(v) { m.act.pc + 1 } else { target.0 };
                    true
                }
                Op::Seed { expr } => {
                    m.act.pc += 1;
                    if !S::SIMPLE {
                        m.seed = Some(self.value_at(&m, expr));
                    }
                    true
                }
                Op::Ret {} => self.op_ret::<S>(&mut m),
            };
            if !go_on {
                break;
            }
        }
        if S::SITES {
            self.note_site(outer.0, outer.1, outer.2);
        }
        self.end_run(m, retiring, slot_base);
    }

    /// The first call of a run under rule-local retirement (see `retire.rs`): the
    /// rule, pc and slots' top it runs with, or `None` (the run ends before it
    /// starts, its slots given back).
    fn retired_first(
        &mut self,
        rule: RuleId,
        pc: u32,
        start: &State,
        depth: u32,
        slot_base: u32,
    ) -> Option<(RuleId, u32, u32)> {
        self.retire.begin_run();
        match self.retired(rule, pc, start, depth, slot_base as usize, pc) {
            Some((to, pc)) => {
                let frame = self.b.rules[to].frame as usize;
                self.slots.resize(slot_base as usize + frame, 0.0);
                Some((to, pc, self.slots.len() as u32))
            }
            None => {
                self.retire.end_run();
                self.slots.truncate(slot_base as usize);
                None
            }
        }
    }

    /// What a run leaves when it ends, by its last op or a limit: its loop records
    /// kept for the next run, its subpath activations and slots given back.
    fn end_run(&mut self, m: Regs, retiring: bool, slot_base: u32) {
        self.spare_loops = m.loops;
        // (A run ended by a limit leaves its subpath activations.)
        self.path.subpaths = self.path.subpaths.saturating_sub(m.subpaths.len() as u32);
        if retiring {
            self.retire.end_run();
        }
        // A run ended by a limit leaves its frames: the caller's slots end here.
        self.slots.truncate(slot_base as usize);
    }

    /// A `DRAW` op but a `VERTEX` of the fast path: a flat path's op (its
    /// arguments are on the slots; none were pushed for a sink that collects
    /// calls), or a drawable made under the op's item state. `nsp` is the op's
    /// namespace, profile and flags.
    #[inline]
    fn op_draw<S: Sink>(&mut self, m: &mut Regs, kind: Drawable, xf: TransformId, nsp: (u32, u32, u8), mode: Mode) {
        let (ns, profile, flags) = nsp;
        if let Some(n) = path_arity(kind, flags) {
            let base = *m.cont.as_ref().unwrap_or(&m.act.base);
            let s = self.item(m, xf);
            if !S::COLLECTS {
                let at = self.slots.len().saturating_sub(n);
                let mut args = [0.0; 7];
                for (a, v) in args.iter_mut().zip(&self.slots[at..]) {
                    *a = *v;
                }
                self.slots.truncate(at);
                if mode == Mode::Model {
                    self.path_op(kind, &base, &s, &args[..n], m.bone, m.act.pc - 1);
                }
            }
        } else {
            let s = self.item(m, xf);
            if !S::COLLECTS {
                self.draw(kind, s, ns, profile, mode, m.bone);
            }
        }
    }

    /// Whether the run stops before the op at `pc` (a limit ran out, or a nested
    /// run halted): then the op that tripped a limit is noted (every op advances
    /// `pc` first). Under [`Sink::SIMPLE`] only a refused call (an admitted one
    /// found no limit) or a counted iterator run can stop a run (no op draws or
    /// samples), so it is asked only after those.
    #[inline(always)]
    pub(super) fn stops(&mut self, m: &Regs) -> bool {
        if self.stopped || self.halt {
            if self.stopped && self.stop_pc.is_none() {
                self.stop_pc = Some(m.act.pc.saturating_sub(1));
            }
            return true;
        }
        false
    }

    /// The state the running item starts from: the continuation state, if any,
    /// else the body's frame (under [`Sink::SIMPLE`] there is no `\`, so always the
    /// body's frame).
    #[inline(always)]
    fn from<S: Sink>(m: &Regs) -> &State {
        if S::SIMPLE {
            &m.act.base
        } else {
            m.cont.as_ref().unwrap_or(&m.act.base)
        }
    }

    /// The activation a run starts with: `rule`'s body at `pc` under `start` (a
    /// convolution's first run, or a bone's), with its bone and convolution; `None`
    /// for a convolution with no frame.
    #[inline]
    fn first_activation<S: Sink>(
        &mut self,
        rule: RuleId,
        start: State,
        pc: u32,
        (depth, parent_bone): (u32, u32),
        (slot_base, slot_top): (u32, u32),
        mode: Mode,
    ) -> Option<(Act, u32, Option<Conv>)> {
        let r = &self.b.rules[rule];
        if !S::SIMPLE && !S::COLLECTS && r.iter != NONE {
            // The start shape (or a sampled rule) is itself a convolution.
            let frames = self.convolution(rule.0);
            let f = frames.first().copied()?;
            let base = start.then(&f, &self.lins);
            let conv = Conv { level: 0, frames, next: 1, pc, origin: start };
            return Some((Act { pc, slot_base, slot_top, base, depth }, parent_bone, Some(conv)));
        }
        let bone = if !S::SIMPLE && !S::COLLECTS && mode == Mode::Model && !r.transforms.is_empty() {
            self.new_bone(rule.0, &start, parent_bone)
        } else {
            parent_bone
        };
        Some((Act { pc, slot_base, slot_top, base: start, depth }, bone, None))
    }

    /// The value of expression `e` for the running item (from the continuation state,
    /// if any, else the body's frame).
    #[inline]
    fn value_at(&mut self, m: &Regs, e: ExprId) -> f64 {
        let at = m.cont.as_ref().unwrap_or(&m.act.base);
        self.value(e, at, m.act.depth, m.act.slot_base, m.act.slot_top)
    }

    /// A drawable or isosurface item's state: its start composed with transform
    /// `xf`; it becomes `last`.
    #[inline]
    fn item(&mut self, m: &mut Regs, xf: TransformId) -> State {
        m.act.pc += 1;
        let from = m.cont.as_ref().unwrap_or(&m.act.base);
        let s = self.apply(xf, from, m.act.depth, m.act.slot_base, m.act.slot_top);
        m.cont = None;
        self.last = s;
        s
    }

    /// `CALL rule xf flags`: the callee's activation pushed (or the call refused by a
    /// limit, or handed to a collecting sink). Whether the run goes on.
    #[inline(always)]
    fn op_call<S: Sink>(&mut self, sink: &mut S, m: &mut Regs, rule: RuleId, xf: TransformId, flags: u8) -> bool {
        let b = self.b;
        m.act.pc += 1;
        let depth = m.act.depth + 1;
        let args = m.act.slot_top as usize;
        // (No SEED under the fast path: `fast_path_applies` refuses it.)
        let seed = if S::SIMPLE { None } else { m.seed.take() };
        if !S::SIMPLE && flags & SUBPATH != 0 && (S::COLLECTS || S::QUEUES) {
            let how = if S::QUEUES { "under `breadthfirst`" } else { "in a guided search's skeleton" };
            let at = where_op(b, m.act.pc - 1);
            self.warn_once(format!("the subpath call{at} is queued {how}: its points do not join the calling path"));
        }
        if seed.is_some() && S::COLLECTS {
            let at = where_op(b, m.act.pc - 1);
            self.warn_once(format!(
                "`seed`{at} is ignored in a guided search's skeleton: the call draws from the run's stream"
            ));
        }
        // (Under the fast path every call's transform is constant and no call has `\`.)
        if depth > m.maxdepth && (S::SIMPLE || (flags & CONT_NEXT == 0 && self.xf_pure[xf.index()])) {
            // Refused before its frame is composed: the frame would be thrown away,
            // and composing a constant changes nothing else.
            if !S::SIMPLE {
                m.cont = None;
            }
            // (Under the fast path only the run-wide limits, looked at now and
            // then, stop a run: a count where they were not looked at cannot.)
            let looked = !S::COLLECTS && self.refuse_deep_call(m.act.pc - 1);
            if !S::SIMPLE && self.slots.len() > args {
                self.slots.truncate(args);
            }
            // (A counted call can stop the run only when it is refused.)
            return !(S::SIMPLE && looked && self.stops(m));
        }
        let from = Self::from::<S>(m);
        let child = self.apply(xf, from, m.act.depth, m.act.slot_base, m.act.slot_top);
        if !S::SIMPLE {
            m.cont = None;
            if flags & CONT_NEXT != 0 {
                self.last = child;
            }
        }
        if S::COLLECTS {
            // The call is the sink's: past `maxdepth` or under `minsize` it is dropped.
            let s = &b.settings;
            if depth > m.maxdepth || (s.minsize > 0.0 && child.scale() < s.minsize) {
                return true;
            }
            return sink.call(rule, &child, depth);
        }
        // The ARGs before this CALL are the callee's first slots (the verifier
        // checked their number).
        let r = &b.rules[rule];
        // (A queued call waits in the queue, which `stacksize` bounds.)
        let stack_len = if S::QUEUES { sink.pending() } else { m.stack.len() + 1 };
        if !self.admit::<false>(|| child.scale(), depth, stack_len, m.act.pc - 1, S::SIMPLE) {
            if !S::SIMPLE && self.slots.len() > args {
                self.slots.truncate(args);
            }
            return !(S::SIMPLE && self.stops(m));
        }
        // (Rules without parameters or locals touch no slot.)
        if !S::SIMPLE && self.slots.len() != args + r.params.len() {
            self.slots.resize(args + r.params.len(), f64::NAN);
        }
        if S::QUEUES {
            // Breadth first: the call waits for its generation (its definition is
            // picked when it leaves the queue); a seeded one with its stream.
            if let Some(v) = seed {
                sink.seed_next(seeded_stream(self.seed, v));
            }
            if m.tree {
                sink.caller_node(m.node);
            }
            sink.enqueue(rule, &child, depth, m.bone, &self.slots[args..], &self.retire.counts);
            self.slots.truncate(args);
            return true;
        }
        // (The callee's level is its callers' count, the caller's level + 1.)
        let level = m.stack.len() as u32 + 1;
        if let Some(v) = seed {
            // The whole sub-derivation, its definition's choice included, draws
            // from the stream of (run seed, v); its return restores the caller's.
            let saved = self.reseed(v);
            m.seeds.push((level, saved));
        }
        let pc = match r.defs.as_slice() {
            [only] => only.start,
            _ => self.select(rule, &child, depth, args),
        };
        let (rule, r, pc) = if !S::SIMPLE && self.retire.any {
            match self.retired(rule, pc, &child, depth, args, m.act.pc - 1) {
                Some((to, pc)) => (to, &b.rules[to], pc),
                None => {
                    self.slots.truncate(args);
                    self.unseed(m, level);
                    return true;
                }
            }
        } else {
            (rule, r, pc)
        };
        if !S::SIMPLE && r.frame as usize != r.params.len() {
            self.slots.resize(args + r.frame as usize, 0.0);
        }
        let (slot_base, slot_top) = (args as u32, (args + r.frame as usize) as u32);
        if !S::SIMPLE && r.iter != NONE {
            // Convolution: the body runs once per frame of the iterator rule.
            let frames = self.convolution(rule.0);
            let Some(f) = frames.first().copied() else {
                self.slots.truncate(args);
                self.unseed(m, level);
                return true;
            };
            let base = child.then(&f, &self.lins);
            m.convs.push(Conv { level, frames, next: 1, pc, origin: child });
            let callee = Act { pc, slot_base, slot_top, base, depth };
            m.stack.push(std::mem::replace(&mut m.act, callee));
        } else {
            if !S::SIMPLE && m.mode == Mode::Model && !r.transforms.is_empty() {
                let bone = self.new_bone(rule.0, &child, m.bone);
                m.bones.push((level, m.bone));
                m.bone = bone;
            }
            let callee = Act { pc, slot_base, slot_top, base: child, depth };
            m.stack.push(std::mem::replace(&mut m.act, callee));
        }
        if !S::SIMPLE && flags & SUBPATH != 0 {
            m.subpaths.push(level);
            self.path.subpaths += 1;
        }
        if !S::SIMPLE && self.retire.any {
            self.retire.enter(pc, m.stack.len());
        }
        if S::SITES {
            m.nodes.push(m.node);
            if m.tree {
                m.node = self.call_node(m.node, rule.0, depth);
            }
        }
        true
    }

    /// `VERTEX` with a constant transform in a model run: position, normal and
    /// mirroring from the cached linear maps, without composing quaternions.
    #[inline]
    fn op_vertex(&mut self, m: &mut Regs, xf: TransformId, ns: NsId, profile: Profile) {
        let b = self.b;
        m.act.pc += 1;
        // `from` is borrowed, not copied: this runs once per vertex.
        let (from, lin) = match &m.cont {
            Some(c) => (c, c.f.linear()),
            None => (&m.act.base, m.lin_cache.get(&m.act.base.f)),
        };
        let Transform::Const(c) = &b.transforms[xf] else {
            m.cont = None;
            return;
        };
        if from.lin != 0 {
            // Under a non-uniform scale, the general path (a normal takes the
            // inverse transpose of the whole linear map).
            let s = from.compose(c, &mut self.lins);
            m.cont = None;
            self.last = s;
            self.draw(Drawable::Vertex, s, ns.0, profile.0, m.mode, m.bone);
            return;
        }
        let Some(x) = &self.xf_info[xf.index()] else {
            m.cont = None;
            return;
        };
        let p = from.f.u + lin.0 * x.frame.u;
        let n = (lin.0 * x.normal).normalize_or(Vec3::Z);
        let color = add(from.color, c.color).map(|v| v.clamp(0.0, 1.0));
        let weight = add(from.weight, c.weight);
        let mirrored = lin.1 != x.mirrored;
        let mesh = &mut self.out.mesh;
        let k = mesh.push_vertex(p, n, color, weight, m.bone) + 1;
        if k.is_multiple_of(3) {
            mesh.push_triangle([k - 3, k - 2, k - 1], mirrored);
        }
        if self.needs_last {
            self.last = vertex_state(from, x, c);
        }
        m.cont = None;
    }

    /// `LOOP`/`LOOPN`: an iterator's first run (or a jump past its body).
    #[inline]
    fn op_loop(&mut self, m: &mut Regs, op: Op) {
        let (count, step, end, chain) = match op {
            Op::LoopN { count: e, step, end, chain } => {
                let n = self.value_at(m, e);
                if n.is_nan() {
                    self.non_finite.note(Fallback::Count, Site::Op(m.act.pc));
                }
                // Saturating: negative and NaN counts give no runs.
                (n as u64, step, end, chain)
            }
            Op::Loop { count, step, end, chain } => (count, step, end, chain),
            _ => return,
        };
        let from = m.cont.take().unwrap_or(m.act.base);
        if count == 0 {
            m.act.pc = end.0 + 1;
            return;
        }
        // Context Free's `loop`: the first run is under the frame itself.
        let mut acc = Frame64::from(&from.f);
        let next = if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 {
            from.compose(&Composite::IDENTITY, &mut self.lins)
        } else {
            self.apply_step(step, &from, &mut acc, m.act.depth, m.act.slot_base, m.act.slot_top)
        };
        let chain = chain & bundle::ops::LOOP_CHAIN != 0;
        let level = m.stack.len() as u32;
        let (begin, depth) = (m.act.pc, m.act.depth);
        m.loops.push(LoopRec { level, begin, depth, remaining: count, step, saved_base: m.act.base, chain, acc });
        m.act.base = next;
        if chain {
            // A run that reaches no drawable ends where it started.
            self.last = m.act.base;
        }
        m.act.pc += 1;
    }

    /// `ENDLOOP begin`: the iterator's next run, or the end of the block. Whether
    /// the run goes on.
    #[inline]
    fn op_end_loop<S: Sink>(&mut self, sink: &mut S, m: &mut Regs, begin: OpIndex) -> bool {
        // A continuation chain is scoped to its body: it does not leak into the next
        // run or out of the block.
        m.cont = None;
        let Some(l) = m.loops.last_mut() else {
            m.act.pc += 1;
            return true;
        };
        l.remaining -= 1;
        if l.remaining == 0 {
            m.act.base = l.saved_base;
            m.loops.pop();
            m.act.pc += 1;
            return true;
        }
        if S::COLLECTS && !sink.next_run() {
            return false;
        }
        let step = l.step;
        if l.chain {
            // Each run continues from the last one's end state.
            let from = self.last;
            m.act.base = self.apply(step, &from, m.act.depth, m.act.slot_base, m.act.slot_top);
            self.last = m.act.base;
        } else {
            let from = m.act.base;
            m.act.base = self.apply_step(step, &from, &mut l.acc, m.act.depth, m.act.slot_base, m.act.slot_top);
        }
        // Back to the op after LOOP.
        m.act.pc = begin.0 + 1;
        if !S::COLLECTS {
            // Iterator runs count as calls, so `maxiter` also ends huge loops.
            self.count_run();
        }
        true
    }

    /// `INST proto count`: one instance of the prototype, where it gives the very
    /// triangles the items would (a model run, in a similarity frame, from the body's
    /// frame, no continuation, a whole number of triangles before it); otherwise the
    /// items run one by one.
    #[inline]
    fn op_inst<S: Sink>(&mut self, m: &mut Regs, proto: ProtoId, count: OpCount) {
        let b = self.b;
        m.act.pc += 1;
        if S::COLLECTS {
            return;
        }
        if !S::SIMPLE
            && (!self.instancing
                || m.mode != Mode::Model
                || m.cont.is_some()
                || m.act.base.lin != 0
                || !self.out.mesh.n_vertices().is_multiple_of(3))
        {
            // A flat primitive's items, one by one: their vertices are the next
            // ones the mesh gets (constant items, no calls).
            if let Some(slot) = self.protos.get(proto.index()).filter(|s| s.matte && m.mode == Mode::Model) {
                let at = self.out.mesh.n_vertices();
                self.matte_runs.push(at..at + slot.vertices as usize);
            }
            return;
        }
        self.emit_instance(proto.0, &m.act.base, m.bone);
        m.act.pc += count.0;
        if self.needs_last {
            // `last` as the run's last item leaves it.
            if let Op::Draw { kind, xf, .. } = b.code[m.act.pc as usize - 1] {
                if let (Transform::Const(c), Some(x)) = (&b.transforms[xf], &self.xf_info[xf.index()]) {
                    self.last = if kind == Drawable::Vertex {
                        vertex_state(&m.act.base, x, c)
                    } else {
                        m.act.base.compose(c, &mut self.lins)
                    };
                }
            }
        }
    }

    /// `RET`: a convolution's next run, or back to the caller. Whether the run goes
    /// on (not after the run's first activation).
    #[inline(always)]
    fn op_ret<S: Sink>(&mut self, m: &mut Regs) -> bool {
        // (Under the fast path an activation closes every iterator it opens and has
        // no convolution or bone of its own.)
        if !S::SIMPLE {
            let level = m.stack.len() as u32;
            while m.loops.last().is_some_and(|l| l.level >= level) {
                m.loops.pop();
            }
            if let Some(conv) = m.convs.last_mut().filter(|c| c.level == level) {
                if let Some(f) = conv.frames.get(conv.next) {
                    // The next run of a convolution body, under R's frame · frame i.
                    m.act.base = conv.origin.then(f, &self.lins);
                    m.cont = None;
                    m.act.pc = conv.pc;
                    conv.next += 1;
                    // Body runs count as calls, so `maxiter` also bounds them.
                    self.count_run();
                    return true;
                }
                m.convs.pop();
            }
            if m.bones.last().is_some_and(|&(l, _)| l == level) {
                if let Some((_, bone)) = m.bones.pop() {
                    m.bone = bone;
                }
            }
            self.unseed(m, level);
            if m.subpaths.last() == Some(&level) {
                m.subpaths.pop();
                self.path.subpaths = self.path.subpaths.saturating_sub(1);
            }
            let base = m.act.slot_base as usize;
            if self.slots.len() > base {
                self.slots.truncate(base);
            }
        }
        if !S::SIMPLE && self.retire.any {
            self.retire.leave(m.stack.len());
        }
        match m.stack.pop() {
            Some(caller) => m.act = caller,
            None => return false,
        }
        if S::SITES {
            m.node = m.nodes.pop().unwrap_or(m.node);
        }
        true
    }
}
