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

/// A caller's activation under [`Sink::LEAN`]: the rest of its state is the running
/// activation's (no call changes it; its slots are empty).
#[derive(Clone, Copy)]
pub(super) struct LeanAct {
    pub(super) f: Frame,
    pub(super) pc: u32,
    pub(super) depth: u32,
}

impl<'b> Eval<'b> {
    /// [`Eval::op_call`] under [`Sink::LEAN`], for a call within `maxdepth`: only the
    /// frame is composed (the rest of the callee's state is the caller's, see
    /// [`lean_path_applies`]), and only the caller's frame, program counter and depth
    /// are pushed.
    #[inline(always)]
    pub(super) fn lean_call(&mut self, m: &mut Regs, rule: RuleId, xf: TransformId, depth: u32) -> bool {
        let b = self.b;
        // (Every transform a lean call has is a constant without a non-uniform scale.)
        let f = match self.prepared.get(xf.index()) {
            Some(Some(p)) => m.act.base.f.compose_prepared(p),
            _ => {
                let from = m.act.base;
                self.apply(xf, &from, m.act.depth, m.act.slot_base, m.act.slot_top).f
            }
        };
        let ndet = m.act.base.ndet;
        // (On the fast path every call adds one to the depth and one caller to the
        // stack, and a return takes both back: the callers' count is the depth
        // gained since the run's start, whether tail calls kept their caller or not.)
        let stack_len = (depth - m.start_depth) as usize;
        if !self.admit(|| f.scale_factor() * ndet.abs(), depth, stack_len, m.act.pc - 1, true) {
            return !self.stops(m);
        }
        let pc = match b.rules[rule].defs.as_slice() {
            [only] => only.start,
            _ => match self.by_depth(rule, depth) {
                Some(pc) => pc,
                None => {
                    let child = State { f, ..m.act.base };
                    self.select(rule, &child, depth, m.act.slot_top as usize)
                }
            },
        };
        // A tail call (the caller's next op is its `RET`, and a lean `RET` only
        // returns): the callee takes the caller's place, so its return is the
        // caller's.
        if !matches!(b.code.get(m.act.pc as usize), Some(Op::Ret {})) {
            m.lean.push(LeanAct { f: m.act.base.f, pc: m.act.pc, depth: m.act.depth });
        }
        m.act.base.f = f;
        m.act.pc = pc;
        m.act.depth = depth;
        true
    }

    /// After a lean call refused by `maxdepth` at a count where no limit was looked
    /// at: the calls that follow it in the body (as deep, so refused too) and the
    /// body's `RET`, here rather than through the loop's dispatch (the loop would
    /// run the same handlers: under the fast path a stop is asked only where a
    /// limit was looked at, and a lean `RET` only returns). Whether the run goes on.
    #[inline(always)]
    pub(super) fn lean_refuse_rest(&mut self, m: &mut Regs) -> bool {
        let code: &[Op] = &self.b.code;
        loop {
            match code.get(m.act.pc as usize) {
                Some(Op::Call { .. }) => {
                    m.act.pc += 1;
                    if self.refuse_deep_call(m.act.pc - 1) {
                        return !self.stops(m);
                    }
                }
                Some(Op::Ret {}) => {
                    let Some(caller) = m.lean.pop() else { return false };
                    m.act.base.f = caller.f;
                    m.act.pc = caller.pc;
                    m.act.depth = caller.depth;
                    return true;
                }
                _ => return true,
            }
        }
    }
}
