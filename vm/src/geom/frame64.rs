//! Frames in `f64` for iterated transforms (issue 38).
//!
//! An iterator `N * {T}` runs its body under `F·T`, `F·T·T`, … Composing those
//! frames one step at a time in `f32` adds a rounding error at every step, so the
//! error grows linearly with the count: the thesis's knot (Listing C.2) missed its
//! start by 3·10⁻⁴ of its size after 4,000 steps, and a 10⁶-step spiral would miss
//! by percents. The evaluator therefore keeps an iterator's running frame as a
//! [`Frame64`], composes each step in `f64`, and stores the result in the `f32`
//! frame the body runs under (Context Free composes in `f64` throughout).
//!
//! A step's quaternions are stored in `f32`, and for a small rotation that storage
//! itself is off: `rz 0.00036` has `cos(θ/4)` round to 1, so its quaternions are
//! longer than 1 by about 10⁻¹², which 10⁶ steps would turn into a scale of
//! 1 + 10⁻⁵. [`Frame64::step`] therefore reads a step as *its rotation* (the
//! direction of each quaternion, in `f64`) and *its scale* (the product of their
//! lengths, rounded to the nearest `f32`, the precision the grammar's numbers have;
//! `s 0.75` is then exactly 0.75). A scale within [`UNIT_SCALE_TOLERANCE`] of 1 is
//! read as exactly 1: the `f32` quaternions of a rotation (or of several rotations
//! composed by the compiler) are that far from unit length, and rounding their
//! length to `f32` can land on 1 − 2⁻²⁴ as well as on 1, which 4,000 steps would turn
//! into a scale error of 2·10⁻⁴. The cost: an iterator step that scales by less than
//! 10⁻⁶ (`s 0.9999995`) runs as a pure rotation (`docs/decisions.md`).
//!
//! Products are written out in scalar order, like [`super::quat::hamilton_scalar`],
//! so the bits are the same on every target.

use super::quat::Frame;
use glam::{Quat, Vec3};

/// How far from 1 a step's scale may be and still be read as exactly 1 (2⁻²⁰,
/// about 9.5·10⁻⁷: sixteen `f32` steps around 1).
pub const UNIT_SCALE_TOLERANCE: f64 = 1.0 / (1u64 << 20) as f64;

/// A quaternion `[x, y, z, w]` in `f64`.
type Q64 = [f64; 4];

/// The Hamilton product `a b` in `f64` (any norm). (Always inlined: with constant
/// factors, as in [`Frame64::compose`]'s pure translations, it folds.)
#[inline(always)]
fn hamilton64(a: &Q64, b: &Q64) -> Q64 {
    let [ax, ay, az, aw] = *a;
    let [bx, by, bz, bw] = *b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// The identity quaternion `[0, 0, 0, 1]`.
const IDENTITY: Q64 = [0.0, 0.0, 0.0, 1.0];

/// `q` is [`IDENTITY`] bit for bit (`-0.0` is not `0.0` here: it changes the
/// products' signs of zero).
#[inline]
fn is_identity(q: &Q64) -> bool {
    q.iter().zip(IDENTITY).all(|(a, b)| a.to_bits() == b.to_bits())
}

fn widen(q: Quat) -> Q64 {
    q.to_array().map(f64::from)
}

fn length(q: &Q64) -> f64 {
    q.iter().map(|c| c * c).sum::<f64>().sqrt()
}

/// A [`Frame`] (q, q̂, u) in `f64`: `x ↦ u + q x q̂`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame64 {
    q: Q64,
    qh: Q64,
    u: [f64; 3],
}

impl From<&Frame> for Frame64 {
    /// `f` exactly (every `f32` is an `f64`).
    fn from(f: &Frame) -> Frame64 {
        Frame64 { q: widen(f.q), qh: widen(f.qh), u: f.u.to_array().map(f64::from) }
    }
}

impl Frame64 {
    /// An iterator's step `f` as the transform it stands for: each quaternion's
    /// direction, and their combined length (the linear scale) rounded to the
    /// nearest `f32` — exactly 1 within [`UNIT_SCALE_TOLERANCE`] — and shared equally
    /// between them (see the module docs). A step with a zero or non-finite
    /// quaternion is taken as it is.
    pub fn step(f: &Frame) -> Frame64 {
        Frame64::step_of(&f.q.to_array(), &f.qh.to_array(), &f.u.to_array())
    }

    /// [`Frame64::step`] of the frame (`q`, `q̂`, `u`), read from where it lies (an
    /// iterator's composite: a `Frame` made of it on the stack just before costs a
    /// store-forwarding stall per step).
    #[inline(always)]
    pub fn step_of(q: &[f32; 4], qh: &[f32; 4], u: &[f32; 3]) -> Frame64 {
        let exact = Frame64 { q: q.map(f64::from), qh: qh.map(f64::from), u: u.map(f64::from) };
        if is_identity(&exact.q) && is_identity(&exact.qh) {
            // A pure translation: lengths 1, scale 1, each part divided by 1 and
            // multiplied by 1 — the same bits without the square roots and divisions.
            return exact;
        }
        let (lq, lqh) = (length(&exact.q), length(&exact.qh));
        if !(lq > 0.0 && lqh > 0.0 && lq.is_finite() && lqh.is_finite()) {
            return exact;
        }
        let stored = lq * lqh;
        let scale = if (stored - 1.0).abs() <= UNIT_SCALE_TOLERANCE { 1.0 } else { f64::from(stored as f32) };
        let k = scale.sqrt();
        Frame64 { q: exact.q.map(|c| c / lq * k), qh: exact.qh.map(|c| c / lqh * k), u: exact.u }
    }

    /// `self ∘ child` (as [`Frame::compose`]): `p' = p + w u ŵ`, `w' = w q`,
    /// `ŵ' = q̂ ŵ`.
    #[must_use]
    #[inline(always)]
    pub fn compose(&self, child: &Frame64) -> Frame64 {
        let [x, y, z] = child.u;
        let pure_child = is_identity(&child.q) && is_identity(&child.qh);
        if pure_child && is_identity(&self.q) && is_identity(&self.qh) {
            // A pure translation under one (a grid's steps under an unrotated,
            // unscaled frame): the same products with every quaternion a constant.
            let moved = hamilton64(&hamilton64(&IDENTITY, &[x, y, z, 0.0]), &IDENTITY);
            let (q, qh) = (hamilton64(&IDENTITY, &IDENTITY), hamilton64(&IDENTITY, &IDENTITY));
            return Frame64 { q, qh, u: [self.u[0] + moved[0], self.u[1] + moved[1], self.u[2] + moved[2]] };
        }
        let moved = hamilton64(&hamilton64(&self.q, &[x, y, z, 0.0]), &self.qh);
        let (q, qh) = if pure_child {
            // A pure translation (an iterator's `x 1`): the same products with the
            // child's parts as constants, which the compiler folds where IEEE
            // arithmetic allows (`v · 1 = v`; `v · 0` is kept for its sign and NaN).
            (hamilton64(&self.q, &IDENTITY), hamilton64(&IDENTITY, &self.qh))
        } else {
            (hamilton64(&self.q, &child.q), hamilton64(&child.qh, &self.qh))
        };
        Frame64 { q, qh, u: [self.u[0] + moved[0], self.u[1] + moved[1], self.u[2] + moved[2]] }
    }

    /// The frame rounded to `f32`, component by component.
    #[inline]
    pub fn to_frame(&self) -> Frame {
        let q = |c: &Q64| Quat::from_array(c.map(|v| v as f32));
        Frame { q: q(&self.q), qh: q(&self.qh), u: Vec3::from_array(self.u.map(|v| v as f32)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rz(deg: f32) -> Frame {
        Frame::identity().rotate(Quat::from_rotation_z(deg.to_radians()))
    }

    #[test]
    fn a_frame_survives_the_round_trip_and_composes_as_in_f32() {
        let a = Frame::identity().translate(Vec3::new(1.0, 2.0, 3.0)).rotate(Quat::from_rotation_x(0.3)).scale(0.5);
        assert_eq!(Frame64::from(&a).to_frame(), a);
        let b = Frame::identity().translate(Vec3::new(-1.0, 0.5, 2.0)).rotate(Quat::from_rotation_y(1.1));
        let wide = Frame64::from(&a).compose(&Frame64::from(&b)).to_frame();
        let narrow = a.compose(&b);
        assert!(wide.u.distance(narrow.u) < 1e-6, "{wide:?} vs {narrow:?}");
        assert!((wide.q - narrow.q).length() < 1e-6 && (wide.qh - narrow.qh).length() < 1e-6);
    }

    #[test]
    fn a_small_rotation_step_has_scale_exactly_one() {
        // In f32 the quaternion of rz 0.00036 is longer than 1 (cos rounds to 1).
        let f = rz(0.00036);
        let stored = length(&widen(f.q)) * length(&widen(f.qh));
        assert!(stored != 1.0, "{stored}");
        let s = Frame64::step(&f);
        let scale = length(&s.q) * length(&s.qh);
        assert!((scale - 1.0).abs() < 1e-15, "{scale}");
        // So has every step of the knot's iterators and a composed rotation.
        for step in [
            rz(0.18),
            Frame::identity().rotate(Quat::from_rotation_y(0.27f32.to_radians())),
            rz(25.0).compose(&rz(-7.0)),
        ] {
            let s = Frame64::step(&step);
            let scale = length(&s.q) * length(&s.qh);
            assert!((scale - 1.0).abs() < 1e-15, "{step:?}: {scale}");
        }
        // A scale keeps its f32 value.
        let s = Frame64::step(&Frame::identity().scale(0.75));
        assert!((length(&s.q) * length(&s.qh) - 0.75).abs() < 1e-15);
        // A zero scale is taken as it is.
        let z = Frame::identity().scale(0.0);
        assert_eq!(Frame64::step(&z).to_frame(), z);
    }

    #[test]
    fn a_million_small_steps_make_a_full_turn() {
        let step = Frame64::step(&rz(0.00036));
        let mut acc = Frame64::from(&Frame::identity());
        for _ in 0..1_000_000 {
            acc = acc.compose(&step);
        }
        let p = acc.to_frame().apply_point(Vec3::X);
        assert!(p.distance(Vec3::X) < 2e-6, "{p}");
    }

    /// `self ∘ child` by the general products (the composition before the
    /// pure-translation path).
    fn compose_by_products(a: &Frame64, child: &Frame64) -> Frame64 {
        let [x, y, z] = child.u;
        let moved = hamilton64(&hamilton64(&a.q, &[x, y, z, 0.0]), &a.qh);
        Frame64 {
            q: hamilton64(&a.q, &child.q),
            qh: hamilton64(&child.qh, &a.qh),
            u: [a.u[0] + moved[0], a.u[1] + moved[1], a.u[2] + moved[2]],
        }
    }

    /// The frame's bits, every NaN as one (which NaN an operation on NaNs or on
    /// ∞ · 0 gives depends on the operands' order, which IEEE leaves open).
    fn bits(f: &Frame64) -> Vec<u64> {
        f.q.iter().chain(&f.qh).chain(&f.u).map(|v| if v.is_nan() { 1 } else { v.to_bits() }).collect()
    }

    /// A pure translation step (`x 1`) composes to the bits of the general
    /// products, signs of zero and infinities included (and NaN where they give
    /// NaN); and its step reads
    /// as the frame itself, as the general reading makes it.
    #[test]
    fn a_pure_translation_step_gives_the_bits_of_the_general_products() {
        let parts: [f64; 8] = [0.0, -0.0, 1.0, -0.5, 0.3, f64::INFINITY, f64::NAN, 3.0e-300];
        let steps = [[1.0f32, 0.0, 0.0], [0.0, -1.0, 0.0], [-0.0, 0.5, 2.5], [f32::INFINITY, 0.0, 1.0]];
        let mut compared = 0;
        for k in 0..parts.len().pow(4) {
            let pick = |j: u32| parts[(k / parts.len().pow(j)) % parts.len()];
            let q = [pick(0), pick(1), pick(2), pick(3)];
            let qh = [pick(3), pick(0), pick(1), pick(2)];
            let acc = Frame64 { q, qh, u: [pick(1), 2.0, pick(0)] };
            for u in steps {
                let step = Frame64::step_of(&[0.0, 0.0, 0.0, 1.0], &[0.0, 0.0, 0.0, 1.0], &u);
                let general = Frame64 { q: IDENTITY, qh: IDENTITY, u: u.map(f64::from) };
                assert_eq!(bits(&step), bits(&general));
                assert_eq!(bits(&acc.compose(&step)), bits(&compose_by_products(&acc, &general)), "{acc:?} {u:?}");
                compared += 1;
            }
        }
        assert_eq!(compared, 4 * 4096);
        // A step with a negative zero in its quaternion is not a pure translation.
        let signed = Frame64 { q: [-0.0, 0.0, 0.0, 1.0], qh: IDENTITY, u: [1.0, 0.0, 0.0] };
        let acc = Frame64 { q: [0.0, 0.0, 0.0, -1.0], qh: IDENTITY, u: [0.0; 3] };
        assert_eq!(bits(&acc.compose(&signed)), bits(&compose_by_products(&acc, &signed)));
    }

    /// A pure translation step under a pure-translation frame (a grid's rows and
    /// columns) composes to the bits of the general products, whatever the
    /// offsets: signs of zero, infinities and NaN included.
    #[test]
    fn a_pure_translation_under_one_gives_the_bits_of_the_general_products() {
        let parts: [f64; 7] = [0.0, -0.0, 1.0, -0.5, f64::INFINITY, f64::NAN, 3.0e-300];
        let steps = [[1.0f32, 0.0, 0.0], [0.0, -1.0, -0.0], [-0.0, 0.5, 2.5], [f32::NEG_INFINITY, 0.0, 1.0]];
        for k in 0..parts.len().pow(3) {
            let pick = |j: u32| parts[(k / parts.len().pow(j)) % parts.len()];
            let acc = Frame64 { q: IDENTITY, qh: IDENTITY, u: [pick(0), pick(1), pick(2)] };
            for u in steps {
                let step = Frame64::step_of(&[0.0, 0.0, 0.0, 1.0], &[0.0, 0.0, 0.0, 1.0], &u);
                let general = Frame64 { q: IDENTITY, qh: IDENTITY, u: u.map(f64::from) };
                let by_products = compose_by_products(&std::hint::black_box(acc), &std::hint::black_box(general));
                assert_eq!(bits(&acc.compose(&step)), bits(&by_products), "{acc:?} {u:?}");
            }
        }
    }
}
