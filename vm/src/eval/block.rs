//! Identity blocks: a body's `{ … }` (an iterator's block body, `N * {T} { … }`)
//! compiles to `LOOP count=1 X` with `X` the identity, whose one run is under the
//! frame composed with the identity ([`State::compose_step`]) and whose `ENDLOOP`
//! gives the frame back. That composition keeps every bit of most states (see
//! [`keeps_identity`]); for those, and when no `\` before the block hands it a
//! continuation state, the `LOOP` opens no record and its `ENDLOOP` only ends the
//! block: the same ops run, in the same order, on the same states.

use super::*;

/// Per op of `b`: whether it is an identity block's `LOOP` (a constant count of 1,
/// neither chained nor first-plain, whose step is [`Composite::IDENTITY`] bit for
/// bit, non-uniform factor, HSB part and colour value included).
pub(super) fn identity_blocks(b: &Bundle) -> Vec<bool> {
    let identity = |xf: TransformId| match b.transforms.get(xf.index()) {
        Some(Transform::Const(c)) => {
            let i = &Composite::IDENTITY;
            let bits = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            bits(&c.q, &i.q)
                && bits(&c.qh, &i.qh)
                && bits(&c.u, &i.u)
                && bits(&c.color, &i.color)
                && bits(&c.weight, &i.weight)
                && c.fps.to_bits() == i.fps.to_bits()
                && c.n.is_none()
                && c.hsb.is_none()
                && c.set.is_none()
        }
        _ => false,
    };
    b.code.iter().map(|op| matches!(*op, Op::Loop { count: 1, step, chain: 0, .. } if identity(step))).collect()
}

/// A frame component that composing with the identity gives back: finite and not
/// `−0.0` (a product by the identity's zeros is `±0`, which turns a `−0.0` sum
/// into `+0.0`; an infinity times zero is NaN).
#[inline(always)]
fn plain(v: f32) -> bool {
    let bits = v.to_bits();
    (bits != 0x8000_0000) & (bits & 0x7f80_0000 != 0x7f80_0000)
}

/// Whether `s.compose_step(&Composite::IDENTITY, …)` is `s` bit for bit: no
/// non-uniform factor (and `ndet` 1), every component of the frame [`plain`], and
/// (unless `kept_rest`: the run's compositions are known to keep them, as under
/// [`Sink::LEAN`], see [`plain_start`]) colour, weight and fps unchanged by adding
/// `+0.0`. Hue is kept by any composition without an HSB part or colour value.
///
/// In `f64` the identity step is taken as it is ([`Frame64::step_of`]); composing
/// it computes `u + q·0·q̂` (`±0` added to each finite or infinite `u` component),
/// `q·1` and `1·q̂` (each component plus `±0` products of the others), which are
/// exact for such components, and rounding back to `f32` gives the same values.
#[inline(always)]
pub(super) fn keeps_identity(s: &State, kept_rest: bool) -> bool {
    let kept = |v: &f32| (v + 0.0).to_bits() == v.to_bits();
    let rest = kept_rest || (s.color.iter().chain(&s.weight).chain([&s.fps]).all(kept));
    keeps_identity_frame(&s.f) && rest && s.lin == 0 && s.ndet.to_bits() == 1.0f32.to_bits()
}

/// The frame's part of [`keeps_identity`]: every component [`plain`] (a lean
/// run's state but its frame keeps the identity, see [`plain_start`]).
#[inline(always)]
pub(super) fn keeps_identity_frame(f: &Frame) -> bool {
    f.q.to_array().iter().chain(&f.qh.to_array()).chain(&f.u.to_array()).fold(true, |a, &v| a & plain(v))
}

impl<'b> Eval<'b> {
    /// Whether the `LOOP` at `m.act.pc` is an identity block that this run can
    /// enter without opening a record (see the module docs): then the block is
    /// entered.
    #[inline(always)]
    pub(super) fn enter_block<S: Sink>(&self, m: &mut Regs) -> bool {
        let enter = self.blocks.get(m.act.pc as usize) == Some(&true)
            && m.cont.is_none()
            && keeps_identity(&m.act.base, S::LEAN);
        if enter {
            m.act.pc += 1;
        }
        enter
    }

    /// Whether the `ENDLOOP` of the loop at `begin` ends an identity block entered
    /// without a record (no open record is this activation's for `begin`; records
    /// are told apart by their depth, which every call raises): then the block is
    /// left, as its one run's end leaves it (the continuation cleared).
    #[inline(always)]
    pub(super) fn leave_block(&self, m: &mut Regs, begin: OpIndex) -> bool {
        let leave = self.blocks.get(begin.index()) == Some(&true)
            && !m.loops.last().is_some_and(|l| l.opened_by(begin, m.act.depth));
        if leave {
            m.cont = None;
            m.act.pc += 1;
        }
        leave
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bits of a state's fields.
    fn bits(s: &State) -> Vec<u32> {
        let f = &s.f;
        [f.q.to_array().as_slice(), &f.qh.to_array(), &f.u.to_array(), &s.color, &s.weight, &[s.fps, s.ndet, s.hue]]
            .concat()
            .iter()
            .map(|v| v.to_bits())
            .chain([s.lin])
            .collect()
    }

    #[test]
    fn a_state_that_keeps_the_identity_is_its_composition_bit_for_bit() {
        let specials =
            [0.0, -0.0, 1.0, -1.0, 0.5, -2.5e-40, 1e-45, 3.0e38, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 0.25];
        let mut lins = Lins::default();
        let mut kept = 0;
        let mut seen_unkept = 0;
        // A walk over states whose every field takes special values, by a simple
        // deterministic mix.
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for round in 0..200_000 {
            let mut pick = |rare: bool| {
                let r = next();
                if rare && r % 8 != 0 {
                    // Mostly ordinary values, so that most states keep the identity.
                    return ((r >> 8) % 1000) as f32 / 100.0 - 5.0;
                }
                specials[(r >> 3) as usize % specials.len()]
            };
            let rare = round % 4 != 0;
            let mut q = [0.0f32; 4].map(|_| pick(rare));
            if round % 3 == 0 {
                q = [0.0, 0.0, 0.0, 1.0];
            }
            let qh = [0.0f32; 4].map(|_| pick(rare));
            let u = [0.0f32; 3].map(|_| pick(rare));
            let s = State {
                f: Frame { q: Quat::from_array(q), qh: Quat::from_array(qh), u: Vec3::from_array(u) },
                color: [0.0f32; 4].map(|_| pick(rare)),
                weight: [0.0f32; 4].map(|_| pick(rare)),
                fps: pick(rare),
                lin: 0,
                ndet: 1.0,
                hue: pick(false),
            };
            let mut acc = Frame64::from(&s.f);
            let composed = s.compose_step(&Composite::IDENTITY, &mut acc, &mut lins);
            if keeps_identity(&s, false) {
                kept += 1;
                assert_eq!(bits(&composed), bits(&s), "{s:?}");
            } else if bits(&composed) != bits(&s) {
                seen_unkept += 1;
            }
        }
        // (Both kinds were met: the test can fail either way.)
        assert!(kept > 10_000 && seen_unkept > 1_000, "{kept} kept, {seen_unkept} changed");
    }
}
