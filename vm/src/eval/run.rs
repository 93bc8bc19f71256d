//! The interpreter loops over the bundle's ops: the general loop (with or without
//! source sites) and the constant-transform fast path, and their activation records.

use super::*;

/// Data derived once per constant transform, for the `VERTEX` fast path.
pub(super) struct XfInfo {
    pub(super) frame: Frame,
    /// The transform's linear part applied to the `normal` directive's vector.
    pub(super) normal: Vec3,
    pub(super) mirrored: bool,
}

/// Whether [`Eval::run_fast`] can run `b`'s model: no rule has parameters, bones or
/// an iterator rule, and the code is only `INST` (with the items it covers), calls
/// and `LOOP`s with constant transforms (no non-uniform scale; no `\` after a call,
/// no chained runs), `ENDLOOP` and `RET`.
/// `xf_pure` is [`Eval::xf_pure`].
pub(super) fn fast_path_applies(b: &Bundle, xf_pure: &[bool]) -> bool {
    let pure = |xf: u32| xf_pure.get(xf as usize).copied().unwrap_or(false);
    let rules_ok =
        b.rules.iter().all(|r| r.params.is_empty() && r.frame == 0 && r.transforms.is_empty() && r.iter == NONE);
    let mut pc = 0usize;
    while let Some(op) = b.code.get(pc) {
        pc += match *op {
            Op::Inst { count, .. } => 1 + count as usize,
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

pub(super) struct Act {
    pub(super) pc: u32,
    /// The activation's frame is `slots[slot_base..slot_top]` (parameters, then locals);
    /// `ARG`s for the next call are pushed above it.
    pub(super) slot_base: u32,
    pub(super) slot_top: u32,
    pub(super) base: State,
    pub(super) depth: u32,
    pub(super) loops_at: u32,
    /// The innermost bone (0 = the root): vertices emitted here carry it.
    pub(super) bone: u32,
    /// Set when this activation runs a convolution rule's body once per frame.
    pub(super) conv: Option<Box<Conv>>,
}

/// The remaining runs of a convolution rule's body.
pub(super) struct Conv {
    /// `I[i]·A[i]·B[i]` for every frame index i of the iterator rule.
    pub(super) frames: Rc<Vec<Frame>>,
    /// The next frame index to run.
    pub(super) next: usize,
    /// The body's first op (the definition chosen at the call).
    pub(super) pc: u32,
    /// R's state at the call; run i is under its frame composed with `frames[i]`.
    pub(super) origin: State,
}

pub(super) struct LoopRec {
    pub(super) remaining: u64,
    pub(super) step: u32,
    pub(super) saved_base: State,
    pub(super) chain: bool,
    /// The current run's frame in `f64` (see [`State::compose_step`]).
    pub(super) acc: Frame64,
}

impl<'b> Eval<'b> {
    /// `from` composed with transform `xf` (at `depth`, in the frame `slots[base..top]`).
    #[inline(always)]
    pub(super) fn apply(&mut self, xf: u32, from: &State, depth: u32, base: u32, top: u32) -> State {
        let b = self.b;
        // A constant transform is composed where it lies (a composite is too big to copy).
        if let Transform::Const(c) = &b.transforms[xf as usize] {
            return from.compose(c, &mut self.lins);
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
        xf: u32,
        from: &State,
        acc: &mut Frame64,
        depth: u32,
        base: u32,
        top: u32,
    ) -> State {
        let b = self.b;
        if let Transform::Const(c) = &b.transforms[xf as usize] {
            return from.compose_step(c, acc, &mut self.lins);
        }
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let env = Env { at: from, depth, slots };
        let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
        from.compose_step(&c, acc, &mut self.lins)
    }

    /// Expression `e` at state `at` and `depth` in the frame `slots[base..top]`.
    #[inline]
    pub(super) fn value(&mut self, e: u32, at: &State, depth: u32, base: u32, top: u32) -> f64 {
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let code: &[ExprOp] = &self.b.exprs[e as usize];
        // (Tried before the environment is built: most arguments are `n - 1`.)
        if let Some(v) = expr::quick(code, slots) {
            return v;
        }
        Env { at, depth, slots }.eval_full(code, &mut self.rng, &mut self.expr_stack)
    }

    /// The definition of `rule_idx` for a call in state `child` at `depth` whose
    /// arguments are `slots[args..]`.
    pub(super) fn select(&mut self, rule_idx: u32, child: &State, depth: u32, args: usize) -> u32 {
        let slots = self.slots.get(args..).unwrap_or(&[]);
        select_def(
            self.b,
            rule_idx,
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

    /// Pushes a frame for a run that starts at `rule` (no caller passes arguments: the
    /// parameters take their defaults); returns its base.
    pub(super) fn default_frame(&mut self, rule: u32) -> (u32, u32) {
        let r = &self.b.rules[rule as usize];
        let base = self.slots.len();
        self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
        self.slots.resize(base + r.frame as usize, 0.0);
        (base as u32, self.slots.len() as u32)
    }

    /// Runs `rule` from `start` until its whole derivation is done.
    pub(super) fn run(&mut self, rule: u32, start: State, mode: Mode) {
        self.run_from(rule, start, 0, mode)
    }

    /// Runs a call of `rule` in state `start` at `depth` until its whole derivation is done.
    pub(super) fn run_from(&mut self, rule: u32, start: State, depth: u32, mode: Mode) {
        if self.fast && mode == Mode::Model {
            return self.run_fast(rule, start, depth);
        }
        // Two copies of the loop: the one that records nothing has no per-op check.
        if self.opts.record_sites || self.tree.is_some() {
            self.run_loop::<true>(rule, start, depth, mode)
        } else {
            self.run_loop::<false>(rule, start, depth, mode)
        }
    }

    /// [`Eval::run_from`], recording sites and the derivation tree (those asked
    /// for) when `SITES`.
    pub(super) fn run_loop<const SITES: bool>(&mut self, rule: u32, start: State, depth: u32, mode: Mode) {
        let b = self.b;
        let (slot_base, slot_top) = self.default_frame(rule);
        let pc = self.select(rule, &start, depth, slot_base as usize);
        let first = if b.rules[rule as usize].iter != NONE {
            // The start shape (or a sampled rule) is itself a convolution.
            let frames = self.convolution(rule);
            let Some(f) = frames.first().copied() else {
                self.slots.truncate(slot_base as usize);
                return;
            };
            let base = start.then(&f, &self.lins);
            Act {
                pc,
                slot_base,
                slot_top,
                base,
                depth,
                loops_at: 0,
                bone: 0,
                conv: Some(Box::new(Conv { frames, next: 1, pc, origin: start })),
            }
        } else {
            let bone = if mode == Mode::Model && !b.rules[rule as usize].transforms.is_empty() {
                self.new_bone(rule, &start, 0)
            } else {
                0
            };
            Act { pc, slot_base, slot_top, base: start, depth, loops_at: 0, bone, conv: None }
        };
        // `maxdepth` (0: none) as the depth past which calls are refused.
        let maxdepth = if b.settings.maxdepth > 0 { b.settings.maxdepth } else { u32::MAX };
        // The running activation; `stack` holds its callers.
        let mut act: Act = first;
        let mut stack: Vec<Act> = Vec::new();
        // The continuation state after `\`: set by CONT and taken by the next item of
        // the same body (a call takes it before its callee runs, so one register serves
        // every activation).
        let mut cont: Option<State> = None;
        let mut lin_cache = LinCache { frame: Frame::identity(), lin: Frame::identity().linear() };
        let mut loops: Vec<LoopRec> = Vec::new();
        let code = &b.code;
        let record_sites = SITES;
        // (A nested run, sampling a transform rule, returns to the op that started it.)
        let outer = (self.site_pc, self.site_depth, self.site_node);
        // The derivation node of the running activation (see [`Eval::call_node`]), and
        // those of its callers; a nested run (a profile, a transform rule) is no call
        // of the model's derivation.
        let tree = SITES && mode == Mode::Model && self.tree.is_some();
        let mut node = if tree { self.call_node(NONE, rule, depth) } else { outer.2 };
        let mut nodes: Vec<u32> = Vec::new();
        loop {
            if record_sites {
                self.note_site(act.pc, act.depth, node);
            }
            if self.stopped || self.halt {
                if self.stopped && self.stop_pc.is_none() {
                    // The op that tripped the limit (every op advances `pc` first).
                    self.stop_pc = Some(act.pc.saturating_sub(1));
                }
                break;
            }
            let op = code[act.pc as usize];
            match op {
                Op::Call { rule, xf, flags } => {
                    act.pc += 1;
                    let depth = act.depth + 1;
                    if depth > maxdepth && flags & CONT_NEXT == 0 && self.xf_pure[xf as usize] {
                        // Refused before its frame is composed: the frame would be
                        // thrown away, and composing a constant changes nothing else.
                        cont = None;
                        self.refuse_deep_call(act.pc - 1);
                        let args = act.slot_top as usize;
                        if self.slots.len() > args {
                            self.slots.truncate(args);
                        }
                        continue;
                    }
                    let parent_bone = act.bone;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let child = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    if flags & CONT_NEXT != 0 {
                        self.last = child;
                    }
                    // The ARGs before this CALL are the callee's first slots (the
                    // verifier checked their number).
                    let r = &b.rules[rule as usize];
                    let args = act.slot_top as usize;
                    if !self.admit(&child, depth, stack.len() + 1, act.pc - 1) {
                        if self.slots.len() > args {
                            self.slots.truncate(args);
                        }
                        continue;
                    }
                    // (Rules without parameters or locals touch no slot.)
                    if self.slots.len() != args + r.params.len() {
                        self.slots.resize(args + r.params.len(), f64::NAN);
                    }
                    let pc = match r.defs.as_slice() {
                        [only] => only.start,
                        _ => self.select(rule, &child, depth, args),
                    };
                    if r.frame as usize != r.params.len() {
                        self.slots.resize(args + r.frame as usize, 0.0);
                    }
                    let (slot_base, slot_top) = (args as u32, (args + r.frame as usize) as u32);
                    let loops_at = loops.len() as u32;
                    if r.iter != NONE {
                        // Convolution: the body runs once per frame of the iterator rule.
                        let frames = self.convolution(rule);
                        let Some(f) = frames.first().copied() else {
                            self.slots.truncate(args);
                            continue;
                        };
                        let base = child.then(&f, &self.lins);
                        let conv = Some(Box::new(Conv { frames, next: 1, pc, origin: child }));
                        let callee = Act { pc, slot_base, slot_top, base, depth, loops_at, bone: parent_bone, conv };
                        stack.push(std::mem::replace(&mut act, callee));
                    } else {
                        let bone = if mode == Mode::Model && !r.transforms.is_empty() {
                            self.new_bone(rule, &child, parent_bone)
                        } else {
                            parent_bone
                        };
                        let callee = Act { pc, slot_base, slot_top, base: child, depth, loops_at, bone, conv: None };
                        stack.push(std::mem::replace(&mut act, callee));
                    }
                    if SITES {
                        nodes.push(node);
                        if tree {
                            node = self.call_node(node, rule, depth);
                        }
                    }
                }
                Op::Draw { kind: Drawable::Vertex, xf, ns, profile, flags: _ }
                    if mode == Mode::Model && self.xf_info[xf as usize].is_some() =>
                {
                    // VERTEX with a constant transform: position, normal and mirroring
                    // from the cached linear maps, without composing quaternions.
                    act.pc += 1;
                    // `from` is borrowed, not copied: this runs once per vertex.
                    let (from, lin) = match &cont {
                        Some(c) => (c, c.f.linear()),
                        None => (&act.base, lin_cache.get(&act.base.f)),
                    };
                    let Transform::Const(c) = &b.transforms[xf as usize] else {
                        cont = None;
                        continue;
                    };
                    if from.lin != 0 {
                        // Under a non-uniform scale, the general path (a normal takes the
                        // inverse transpose of the whole linear map).
                        let s = from.compose(c, &mut self.lins);
                        cont = None;
                        self.last = s;
                        let bone = act.bone;
                        self.draw(Drawable::Vertex, s, ns, profile, mode, bone);
                        continue;
                    }
                    let Some(x) = &self.xf_info[xf as usize] else {
                        cont = None;
                        continue;
                    };
                    let p = from.f.u + lin.0 * x.frame.u;
                    let n = (lin.0 * x.normal).normalize_or(Vec3::Z);
                    let color = add(from.color, c.color).map(|v| v.clamp(0.0, 1.0));
                    let weight = add(from.weight, c.weight);
                    let mirrored = lin.1 != x.mirrored;
                    let m = &mut self.out.mesh;
                    let k = m.push_vertex(p, n, color, weight, act.bone) + 1;
                    if k.is_multiple_of(3) {
                        m.push_triangle([k - 3, k - 2, k - 1], mirrored);
                    }
                    if self.needs_last {
                        self.last = vertex_state(from, x, c);
                    }
                    cont = None;
                }
                Op::Draw { kind, xf, ns, profile, flags: _ } => {
                    act.pc += 1;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let s = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    self.last = s;
                    let bone = act.bone;
                    self.draw(kind, s, ns, profile, mode, bone);
                }
                Op::Iso { iso, xf, flags: _ } => {
                    act.pc += 1;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let s = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    self.last = s;
                    if mode == Mode::Model {
                        let bone = act.bone;
                        self.instance(iso, &s, act.pc - 1, bone);
                    }
                }
                Op::Loop { step, end, chain, .. } | Op::LoopN { step, end, chain, .. } => {
                    let count = match op {
                        Op::LoopN { count: e, .. } => {
                            let at = cont.unwrap_or(act.base);
                            let n = self.value(e, &at, act.depth, act.slot_base, act.slot_top);
                            if n.is_nan() {
                                self.non_finite.note(Fallback::Count, Site::Op(act.pc));
                            }
                            // Saturating: negative and NaN counts give no runs.
                            n as u64
                        }
                        Op::Loop { count, .. } => count,
                        _ => 0,
                    };
                    let from = cont.take().unwrap_or(act.base);
                    if count == 0 {
                        act.pc = end + 1;
                        continue;
                    }
                    // Context Free's `loop`: the first run is under the frame itself.
                    let mut acc = Frame64::from(&from.f);
                    let next = if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 {
                        from.compose(&Composite::IDENTITY, &mut self.lins)
                    } else {
                        self.apply_step(step, &from, &mut acc, act.depth, act.slot_base, act.slot_top)
                    };
                    let chain = chain & bundle::ops::LOOP_CHAIN != 0;
                    loops.push(LoopRec { remaining: count, step, saved_base: act.base, chain, acc });
                    act.base = next;
                    if chain {
                        // A run that reaches no drawable ends where it started.
                        self.last = act.base;
                    }
                    act.pc += 1;
                }
                Op::EndLoop { begin: _ } => {
                    // A continuation chain is scoped to its body: it does not leak into
                    // the next run or out of the block.
                    cont = None;
                    let Some(l) = loops.last_mut() else {
                        act.pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        let step = l.step;
                        if l.chain {
                            // Each run continues from the last one's end state.
                            let from = self.last;
                            act.base = self.apply(step, &from, act.depth, act.slot_base, act.slot_top);
                            self.last = act.base;
                        } else {
                            let from = act.base;
                            act.base = self.apply_step(step, &from, &mut l.acc, act.depth, act.slot_base, act.slot_top);
                        }
                        // Back to the op after LOOP.
                        if let Op::EndLoop { begin } = op {
                            act.pc = begin + 1;
                        }
                        // Iterator runs count as calls, so `maxiter` also ends huge loops.
                        self.count_run();
                    } else {
                        act.base = l.saved_base;
                        loops.pop();
                        act.pc += 1;
                    }
                }
                Op::Inst { proto, count } => {
                    act.pc += 1;
                    // An instance where it gives the very triangles the items would: a
                    // model run, in a similarity frame, from the body's frame (no
                    // continuation), with a whole number of triangles before it.
                    // Otherwise the items run one by one.
                    if !self.instancing
                        || mode != Mode::Model
                        || cont.is_some()
                        || act.base.lin != 0
                        || !self.out.mesh.n_vertices().is_multiple_of(3)
                    {
                        // A flat primitive's items, one by one: their vertices are
                        // the next ones the mesh gets (constant items, no calls).
                        if let Some(slot) = self.protos.get(proto as usize).filter(|s| s.matte && mode == Mode::Model) {
                            let at = self.out.mesh.n_vertices();
                            self.matte_runs.push(at..at + slot.vertices as usize);
                        }
                        continue;
                    }
                    let bone = act.bone;
                    self.emit_instance(proto, &act.base, bone);
                    act.pc += count;
                    if self.needs_last {
                        // `last` as the run's last item leaves it.
                        if let Op::Draw { kind, xf, .. } = code[act.pc as usize - 1] {
                            if let (Transform::Const(c), Some(x)) =
                                (&b.transforms[xf as usize], &self.xf_info[xf as usize])
                            {
                                self.last = if kind == Drawable::Vertex {
                                    vertex_state(&act.base, x, c)
                                } else {
                                    act.base.compose(c, &mut self.lins)
                                };
                            }
                        }
                    }
                }
                Op::Cont {} => {
                    act.pc += 1;
                    cont = Some(self.last);
                }
                Op::Arg { expr } => {
                    act.pc += 1;
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    self.slots.push(v);
                }
                Op::Set { slot, expr } => {
                    act.pc += 1;
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    if let Some(s) = self.slots.get_mut(act.slot_base as usize + slot as usize) {
                        *s = v;
                    }
                }
                Op::Jump { target } => act.pc = target,
                Op::JumpIfNot { expr, target } => {
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    act.pc = if expr::truthy(v) { act.pc + 1 } else { target };
                }
                Op::Ret {} => {
                    let at = act.loops_at as usize;
                    loops.truncate(at);
                    if let Some(conv) = act.conv.as_mut() {
                        if let Some(f) = conv.frames.get(conv.next) {
                            // The next run of a convolution body, under R's frame · frame i.
                            act.base = conv.origin.then(f, &self.lins);
                            cont = None;
                            act.pc = conv.pc;
                            conv.next += 1;
                            // Body runs count as calls, so `maxiter` also bounds them.
                            self.count_run();
                            continue;
                        }
                    }
                    let base = act.slot_base as usize;
                    if self.slots.len() > base {
                        self.slots.truncate(base);
                    }
                    match stack.pop() {
                        Some(caller) => act = caller,
                        None => break,
                    }
                    if SITES {
                        node = nodes.pop().unwrap_or(node);
                    }
                }
            }
        }
        if record_sites {
            self.note_site(outer.0, outer.1, outer.2);
        }
        // A run ended by a limit leaves its frames: the caller's slots end here.
        self.slots.truncate(slot_base as usize);
    }

    /// [`Eval::run_from`] in a model run of a bundle whose code is only prototype
    /// instances, calls and iterators with constant transforms, and returns
    /// ([`fast_path_applies`]): the same steps, in the same order, with the same
    /// arithmetic as the general loop (so the same output), for activations that
    /// need no parameter slots, bones, convolutions or continuations.
    pub(super) fn run_fast(&mut self, rule: u32, start: State, depth: u32) {
        /// One activation: the op to run, the body's (or iterator run's) state, the
        /// depth, and where its iterators begin in `loops`.
        struct FastAct {
            pc: u32,
            depth: u32,
            loops_at: u32,
            base: State,
        }
        let b = self.b;
        let code = &b.code;
        let maxdepth = if b.settings.maxdepth > 0 { b.settings.maxdepth } else { u32::MAX };
        let args = self.slots.len();
        let pc = self.select(rule, &start, depth, args);
        let mut act = FastAct { pc, depth, loops_at: 0, base: start };
        let mut stack: Vec<FastAct> = Vec::new();
        let mut loops: Vec<LoopRec> = Vec::new();
        // (A run stops only where a call or an iterator run is counted: the limit is
        // checked there, and the op that tripped it named, as the general loop does.)
        let stop = |e: &mut Self, pc: u32| {
            e.stop_pc.get_or_insert(pc);
        };
        if self.stopped {
            return;
        }
        loop {
            match code[act.pc as usize] {
                Op::Inst { proto, count } => {
                    self.emit_instance(proto, &act.base, 0);
                    act.pc += 1 + count;
                }
                Op::Call { rule, xf, .. } => {
                    act.pc += 1;
                    let depth = act.depth + 1;
                    if depth > maxdepth {
                        self.refuse_deep_call(act.pc - 1);
                        if self.stopped {
                            stop(self, act.pc - 1);
                            break;
                        }
                        continue;
                    }
                    let Transform::Const(c) = &b.transforms[xf as usize] else { break };
                    let child = act.base.compose(c, &mut self.lins);
                    if !self.admit(&child, depth, stack.len() + 1, act.pc - 1) {
                        if self.stopped {
                            stop(self, act.pc - 1);
                            break;
                        }
                        continue;
                    }
                    let pc = match b.rules[rule as usize].defs.as_slice() {
                        [only] => only.start,
                        _ => self.select(rule, &child, depth, args),
                    };
                    let callee = FastAct { pc, depth, loops_at: loops.len() as u32, base: child };
                    stack.push(std::mem::replace(&mut act, callee));
                }
                Op::Loop { count, step, end, chain } => {
                    if count == 0 {
                        act.pc = end + 1;
                        continue;
                    }
                    let from = act.base;
                    let mut acc = Frame64::from(&from.f);
                    // Context Free's `loop`: the first run is under the frame itself.
                    let next = match &b.transforms[step as usize] {
                        _ if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 => {
                            from.compose(&Composite::IDENTITY, &mut self.lins)
                        }
                        Transform::Const(c) => from.compose_step(c, &mut acc, &mut self.lins),
                        Transform::Dynamic { .. } => break,
                    };
                    loops.push(LoopRec { remaining: count, step, saved_base: act.base, chain: false, acc });
                    act.base = next;
                    act.pc += 1;
                }
                Op::EndLoop { begin } => {
                    let Some(l) = loops.last_mut() else {
                        act.pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        let Transform::Const(c) = &b.transforms[l.step as usize] else { break };
                        act.base = act.base.compose_step(c, &mut l.acc, &mut self.lins);
                        act.pc = begin + 1;
                        // Iterator runs count as calls, so `maxiter` also ends huge loops.
                        self.count_run();
                        if self.stopped {
                            // (The general loop names the LOOP op: the run stops after
                            // jumping back to it.)
                            stop(self, begin);
                            break;
                        }
                    } else {
                        act.base = l.saved_base;
                        loops.pop();
                        act.pc += 1;
                    }
                }
                Op::Ret {} => {
                    loops.truncate(act.loops_at as usize);
                    match stack.pop() {
                        Some(caller) => act = caller,
                        None => break,
                    }
                }
                // Not in a bundle the fast path takes (see `fast_path_applies`).
                _ => break,
            }
        }
    }
}
