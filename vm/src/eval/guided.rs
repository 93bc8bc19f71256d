//! Guided search's expansion: one rule body run to the calls it makes, without
//! recursing ([`Expander`], [`Call`]).

use super::*;

/// A rule call waiting to run: guided search keeps these instead of recursing
/// (see [`Expander`] and [`evaluate_calls`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Call {
    pub rule: u32,
    /// The state the rule's body runs in (the caller's state composed with the call's
    /// adjustments).
    pub state: State,
    /// The start shape is at depth 0; every call adds 1.
    pub depth: u32,
}

impl Call {
    /// The start shape's call: the identity frame, the start colour, depth 0.
    pub fn start(b: &Bundle) -> Call {
        Call { rule: b.settings.startshape, state: State::start_in(&b.settings), depth: 0 }
    }
}

/// The most calls and iterator runs one [`Expander::expand`] performs; a body that
/// makes more is cut there (so a huge iterator in a skeleton rule cannot stall a search).
pub const MAX_EXPANSION_CALLS: usize = 1 << 16;

/// Runs one rule call's body *without* descending into the calls it makes: each call
/// is returned (rule, state, depth) instead (guided search's skeleton phase, SPEC §11).
///
/// The body runs as in [`evaluate`]: the definition its selector picks, iterators,
/// continuations, `rand`/`randn` in adjustments (drawn from this expander's stream),
/// and the `maxdepth` and `minsize` limits, which drop the calls beyond them. What is
/// not evaluated is the callees, so a continuation `A \ B` where `A` is a call starts
/// `B` from `A`'s own frame (the frame of a drawable inside `A` is not known yet).
/// Drawables and isosurfaces are skipped: skeleton rules may not draw (the compiler
/// and the bundle verifier reject those that do). `sequential` and `pattern`
/// selectors start afresh with every expansion.
pub struct Expander<'b> {
    pub(super) b: &'b Bundle,
    pub(super) rng: Pcg,
    pub(super) expr_stack: Vec<f64>,
    pub(super) sequential: HashMap<u32, (usize, u32)>,
    pub(super) loops: Vec<LoopRec>,
    /// The expanded body's frame (its parameters take their defaults: the compiler
    /// rejects skeleton rules with parameters and calls from them that pass arguments).
    pub(super) slots: Vec<f64>,
    /// (The compiler rejects non-uniform scales in skeleton rules, so the states an
    /// expansion returns carry none; this only keeps a hand-made bundle harmless.)
    pub(super) lins: Lins,
    pub(super) weights: Weights,
    /// Computed values that were not finite numbers, and the fallbacks used.
    pub(super) non_finite: NonFinite,
}

impl<'b> Expander<'b> {
    /// An expander over `b`, with the stream of [`Expander::reseed`]`(0, 0)`.
    pub fn new(b: &'b Bundle) -> Expander<'b> {
        let mut e = Expander {
            b,
            rng: Pcg(Pcg64::new(0, 0)),
            expr_stack: Vec::with_capacity(16),
            sequential: HashMap::new(),
            loops: Vec::new(),
            slots: Vec::new(),
            lins: Lins::default(),
            weights: Weights::new(b),
            non_finite: NonFinite::default(),
        };
        e.reseed(0, 0);
        e
    }

    /// The fallbacks the expansions so far used for computed values that were NaN or
    /// infinite (adjustment arguments, weights, selector values, counts), as
    /// warnings naming the rule and line; empty if none.
    pub fn warnings(&self) -> Vec<String> {
        self.non_finite.warnings(self.b)
    }

    /// Restarts the random stream: PCG-64 stream `stream` at a state derived from
    /// `seed`. Distinct (seed, stream) pairs give independent streams, so work split by
    /// (seed, stream) gives the same numbers in any order or on any thread.
    pub fn reseed(&mut self, seed: u64, stream: u64) {
        let mix = |mut z: u64| {
            // SplitMix64 finaliser: spreads nearby seeds over the whole state space.
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let hi = mix(seed ^ 0x6A09_E667_F3BC_C908);
        let lo = mix(seed.wrapping_add(0x9E37_79B9_7F4A_7C15));
        let state = ((hi as u128) << 64) | lo as u128;
        let s = mix(stream ^ 0xBB67_AE85_84CA_A73B);
        let inc = ((s as u128) << 64) | mix(stream.wrapping_add(0x3C6E_F372_FE94_F82B)) as u128;
        self.rng = Pcg(Pcg64::new(state, inc));
    }

    /// A uniform number in [0, 1) from the stream (53 random bits).
    pub fn uniform(&mut self) -> f64 {
        self.rng.uniform()
    }

    /// A uniform index in `0..n` (`n` > 0; 0 when `n` is 0).
    pub fn index(&mut self, n: usize) -> usize {
        ((self.rng.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// Runs the body of `call` and appends the calls it makes to `out`, in the order
    /// the body makes them. Returns `false` when the body was cut at
    /// [`MAX_EXPANSION_CALLS`] calls and iterator runs.
    pub fn expand(&mut self, call: &Call, out: &mut Vec<Call>) -> bool {
        let b = self.b;
        let code = &b.code;
        let s = &b.settings;
        let r = &b.rules[call.rule as usize];
        self.slots.clear();
        self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
        self.slots.resize(r.frame as usize, 0.0);
        let mut pc = select_def(
            b,
            call.rule,
            &call.state,
            call.depth,
            &self.slots,
            &mut self.rng,
            &mut self.sequential,
            &mut self.expr_stack,
            &mut self.weights,
            &mut self.non_finite,
        ) as usize;
        self.sequential.clear();
        self.loops.clear();
        let depth = call.depth.saturating_add(1);
        let mut base = call.state;
        let mut cont: Option<State> = None;
        let mut last = call.state;
        let mut made = 0usize;
        while let Some(&op) = code.get(pc) {
            match op {
                Op::Call { rule, xf, flags } => {
                    pc += 1;
                    let from = cont.take().unwrap_or(base);
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                    let child = from.compose(&c, &mut self.lins);
                    if flags & CONT_NEXT != 0 {
                        last = child;
                    }
                    if s.maxdepth > 0 && depth > s.maxdepth {
                        continue;
                    }
                    if s.minsize > 0.0 && child.scale() < s.minsize {
                        continue;
                    }
                    if made >= MAX_EXPANSION_CALLS {
                        return false;
                    }
                    made += 1;
                    out.push(Call { rule, state: child, depth });
                }
                Op::Draw { xf, .. } | Op::Iso { xf, .. } => {
                    pc += 1;
                    let from = cont.take().unwrap_or(base);
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                    last = from.compose(&c, &mut self.lins);
                }
                Op::Loop { step, end, chain, .. } | Op::LoopN { step, end, chain, .. } => {
                    let count = match op {
                        Op::LoopN { count: e, .. } => {
                            let at = cont.unwrap_or(base);
                            let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                            let n = env.eval(&b.exprs[e as usize], &mut self.rng, &mut self.expr_stack);
                            if n.is_nan() {
                                self.non_finite.note(Fallback::Count, Site::Op(pc as u32));
                            }
                            // Saturating: negative and NaN counts give no runs.
                            n as u64
                        }
                        Op::Loop { count, .. } => count,
                        _ => 0,
                    };
                    let from = cont.take().unwrap_or(base);
                    if count == 0 {
                        pc = end as usize + 1;
                        continue;
                    }
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let mut acc = Frame64::from(&from.f);
                    let next = if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 {
                        from.compose(&Composite::IDENTITY, &mut self.lins)
                    } else {
                        let c =
                            eval_transform(b, step, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                        from.compose_step(&c, &mut acc, &mut self.lins)
                    };
                    let chain = chain & bundle::ops::LOOP_CHAIN != 0;
                    self.loops.push(LoopRec { remaining: count, step, saved_base: base, chain, acc });
                    base = next;
                    pc += 1;
                }
                Op::EndLoop { begin } => {
                    cont = None;
                    let Some(l) = self.loops.last_mut() else {
                        pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        if made >= MAX_EXPANSION_CALLS {
                            return false;
                        }
                        let (chain, step, mut acc) = (l.chain, l.step, l.acc);
                        let from = if chain { last } else { base };
                        let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                        let c =
                            eval_transform(b, step, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                        base = if chain {
                            from.compose(&c, &mut self.lins)
                        } else {
                            from.compose_step(&c, &mut acc, &mut self.lins)
                        };
                        if let Some(l) = self.loops.last_mut() {
                            l.acc = acc;
                        }
                        pc = begin as usize + 1;
                        // Runs count like calls, so a huge iterator is cut too.
                        made += 1;
                    } else {
                        base = l.saved_base;
                        self.loops.pop();
                        pc += 1;
                    }
                }
                Op::Cont {} => {
                    pc += 1;
                    cont = Some(last);
                }
                // The items it covers are drawables, skipped one by one.
                Op::Arg { .. } | Op::Inst { .. } => pc += 1,
                Op::Set { slot, expr } => {
                    pc += 1;
                    let at = cont.unwrap_or(base);
                    let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                    let v = env.eval(&b.exprs[expr as usize], &mut self.rng, &mut self.expr_stack);
                    if let Some(s) = self.slots.get_mut(slot as usize) {
                        *s = v;
                    }
                }
                Op::Jump { target } => pc = target as usize,
                Op::JumpIfNot { expr, target } => {
                    let at = cont.unwrap_or(base);
                    let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                    let v = env.eval(&b.exprs[expr as usize], &mut self.rng, &mut self.expr_stack);
                    pc = if expr::truthy(v) { pc + 1 } else { target as usize };
                }
                Op::Ret {} => break,
            }
        }
        true
    }
}
