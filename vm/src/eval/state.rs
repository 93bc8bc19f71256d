//! The state a frame carries and its algebra: composing transforms (constant
//! composites and iterator steps), colour changes, and the non-uniform factors.

use super::*;

/// The state a frame carries: transform, colour, weight, fps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    pub f: Frame,
    pub color: [f32; 4],
    pub weight: [f32; 4],
    pub fps: f32,
    /// The frame's non-uniform factor N (`geom::quat::Affine`): an index into the
    /// evaluation's [`Lins`], 0 for none (every frame that has met no `s X Y Z`).
    pub lin: u32,
    /// `∛det N` (1 without one): the factor's share of the scale, and its sign the
    /// factor's mirroring, readable without the table.
    pub ndet: f32,
    /// The hue (degrees) the last `hue`/`sat`/`b` change left: Context Free keeps hue
    /// while the colour is grey, where RGB has none, so a hue turn on a grey shows
    /// once a descendant gives saturation (see [`apply_hsb_keeping`]).
    pub hue: f32,
}

impl State {
    /// The state at the start of a run: identity frame, white, no weights.
    pub fn start(fps: f32) -> State {
        State { f: Frame::identity(), color: START_COLOR, weight: [0.0; 4], fps, lin: 0, ndet: 1.0, hue: 0.0 }
    }

    /// The state at the start of a model run of a bundle with `settings`: as
    /// [`State::start`], black under the `flat` directive (Context Free's start).
    pub fn start_in(settings: &bundle::Settings) -> State {
        let s = State::start(settings.fps);
        if settings.flat {
            State { color: FLAT_START_COLOR, ..s }
        } else {
            s
        }
    }

    /// `self ∘ c`. The non-uniform factors of a frame live in `lins`, which gains an
    /// entry only when `c` itself holds a non-uniform scale.
    #[inline(always)]
    pub(super) fn compose(&self, c: &Composite, lins: &mut Lins) -> State {
        let (color, hue) = compose_color(self.color, self.hue, c);
        let (f, lin, ndet) = if self.lin == 0 && c.n.is_none() {
            (self.f.compose(&composite_frame(c)), 0, 1.0)
        } else {
            self.compose_general(c, lins)
        };
        State { f, color, weight: add(self.weight, c.weight), fps: self.fps + c.fps, lin, ndet, hue }
    }

    /// [`State::compose`] for a state without a non-uniform factor and a `c`
    /// without one, whose frame `p` has prepared ([`PreparedFrame`]): the same bits.
    #[inline(always)]
    pub(super) fn compose_prepared(&self, c: &Composite, p: &PreparedFrame) -> State {
        let (color, hue) = compose_color(self.color, self.hue, c);
        let f = self.f.compose_prepared(p);
        State { f, color, weight: add(self.weight, c.weight), fps: self.fps + c.fps, lin: 0, ndet: 1.0, hue }
    }

    /// `self ∘ c` for an iterator's step, where `acc` is `self`'s frame in `f64`:
    /// the frame is composed there (the step read by [`Frame64::step`]) and rounded
    /// to `f32`, so iterated steps do not accumulate `f32` error. Under a
    /// non-uniform factor, as [`State::compose`] (and `acc` restarts from the result).
    #[inline]
    pub(super) fn compose_step(&self, c: &Composite, acc: &mut Frame64, lins: &mut Lins) -> State {
        if self.lin != 0 || c.n.is_some() {
            let s = self.compose(c, lins);
            *acc = Frame64::from(&s.f);
            return s;
        }
        *acc = acc.compose(&Frame64::step_of(&c.q, &c.qh, &c.u));
        let (color, hue) = compose_color(self.color, self.hue, c);
        State {
            f: acc.to_frame(),
            color,
            weight: add(self.weight, c.weight),
            fps: self.fps + c.fps,
            lin: 0,
            ndet: 1.0,
            hue,
        }
    }

    /// The frame part of [`State::compose`] when a non-uniform factor is involved.
    #[cold]
    #[inline(never)]
    pub(super) fn compose_general(&self, c: &Composite, lins: &mut Lins) -> (Frame, u32, f32) {
        let child = Affine { f: composite_frame(c), n: c.n.map(|n| Mat3::from_cols_array(&n)) };
        let a = lins.affine(self).compose(&child);
        // N changes only when `c` brings a non-uniform scale of its own.
        match (c.n, a.n) {
            (Some(_), Some(n)) => {
                let (lin, ndet) = lins.put(n);
                (a.f, lin, ndet)
            }
            _ => (a.f, self.lin, self.ndet),
        }
    }

    /// `self ∘ f` for a plain frame (a convolution's or a sampled track's).
    pub(super) fn then(&self, f: &Frame, lins: &Lins) -> State {
        if self.lin == 0 {
            State { f: self.f.compose(f), ..*self }
        } else {
            State { f: lins.affine(self).compose(&Affine::from(*f)).f, ..*self }
        }
    }

    /// The linear scale (SPEC resolved semantics 7; with `∛|det N|` under a
    /// non-uniform scale): what `minsize`, `scale` selection and `scale` read.
    #[inline]
    pub fn scale(&self) -> f32 {
        self.f.scale_factor() * self.ndet.abs()
    }

    /// Whether the frame mirrors.
    pub fn mirrored(&self) -> bool {
        self.f.mirrored() ^ (self.ndet < 0.0)
    }

    /// The colour as shown: every component clamped to 0..1.
    pub(super) fn display_color(&self) -> [f32; 4] {
        self.color.map(|c| c.clamp(0.0, 1.0))
    }
}

/// The non-uniform factors N of one evaluation's frames, shared by the states that
/// carry the same one (index 0 is none). Entries are only added, by a composition
/// with a non-uniform scale.
#[derive(Debug)]
pub struct Lins(pub(super) Vec<Mat3>);

impl Default for Lins {
    fn default() -> Self {
        Lins(vec![Mat3::IDENTITY])
    }
}

impl Lins {
    /// `s`'s frame with its factor.
    #[inline]
    pub(super) fn affine(&self, s: &State) -> Affine {
        let n = if s.lin == 0 { None } else { self.0.get(s.lin as usize).copied() };
        Affine { f: s.f, n }
    }

    /// Stores `n`: its index and `∛det n`.
    pub(super) fn put(&mut self, n: Mat3) -> (u32, f32) {
        self.0.push(n);
        ((self.0.len() - 1) as u32, n.determinant().cbrt())
    }
}

/// `a + b` component-wise, four lanes at once (each lane one IEEE addition, as the
/// scalar sum would be).
#[inline(always)]
pub(super) fn add(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    (Vec4::from_array(a) + Vec4::from_array(b)).to_array()
}

/// Composes primitive adjustments (constant arguments) into one composite, each
/// argument divided into `divisor` steps (scale: the divisor-th root; flips kept).
/// The compiler folds constant lists with this same function, so run-time and
/// compile-time composites agree bit for bit.
pub fn compose_prims(prims: &[bundle::PrimAdj], divisor: f32) -> Composite {
    let mut f = Affine::identity();
    let mut c = Composite::IDENTITY;
    for p in prims {
        let mut vals = [0.0f32; 4];
        for (v, a) in vals.iter_mut().zip(&p.args) {
            if let bundle::Arg::Const(x) = a {
                *v = *x;
            }
        }
        apply_prim(&mut f, &mut c, p.kind, p.axis, &vals, p.args.len(), divisor);
    }
    set_frame(&mut c, &f);
    c
}

/// The frame of a composite (without its non-uniform factor, [`Composite::n`]).
#[inline]
pub(super) fn composite_frame(c: &Composite) -> Frame {
    Frame { q: Quat::from_array(c.q), qh: Quat::from_array(c.qh), u: Vec3::from_array(c.u) }
}

/// Stores `a` in composite `c`.
pub(super) fn set_frame(c: &mut Composite, a: &Affine) {
    c.q = a.f.q.to_array();
    c.qh = a.f.qh.to_array();
    c.u = a.f.u.to_array();
    c.n = a.n.map(|n| n.to_cols_array());
}

/// Applies HSB adjustments `h` (see [`Composite::hsb`]) to an RGBA colour: the colour
/// is clamped to 0..1 (HSB is defined there), converted to hue, saturation and
/// brightness (HSV), adjusted, and converted back. Alpha is kept. A grey has no hue
/// of its own: it takes `grey_hue`, the hue its frame kept (Context Free's colour
/// state). Returns the colour and the hue it leaves (kept even if it ends grey).
pub(super) fn apply_hsb_keeping(c: [f32; 4], grey_hue: f32, h: &[f32; 5]) -> ([f32; 4], f32) {
    let [r, g, b] = [c[0], c[1], c[2]].map(|v| v.clamp(0.0, 1.0));
    let max = r.max(g).max(b);
    let d = max - r.min(g).min(b);
    let hue = hue_of(c).unwrap_or(grey_hue);
    let sat = if max > 0.0 { d / max } else { 0.0 };
    let hue = (hue + h[0]).rem_euclid(360.0);
    let sat = (sat * h[1] + h[2]).clamp(0.0, 1.0);
    let v = (max * h[3] + h[4]).clamp(0.0, 1.0);
    // HSV to RGB.
    let k = |n: f32| {
        let k = (n + hue / 60.0).rem_euclid(6.0);
        v - v * sat * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    ([k(5.0), k(3.0), k(1.0), c[3]], hue)
}

/// The colour and kept hue after composite `c`: its set colour (if any) replaces the
/// frame's (the kept hue becomes the value's own, 0 for a grey), then the RGBA deltas
/// add, then the HSB part applies (reference §5: one rule for the VM and the folder).
#[inline(always)]
pub(super) fn compose_color(color: [f32; 4], hue: f32, c: &Composite) -> ([f32; 4], f32) {
    let (base, hue) = match c.set {
        Some(s) => (s, hue_of(s).unwrap_or(0.0)),
        None => (color, hue),
    };
    let color = add(base, c.color);
    match &c.hsb {
        Some(h) => apply_hsb_keeping(color, hue, h),
        None => (color, hue),
    }
}

/// The HSV hue (degrees) of an RGB colour (clamped to 0..1), `None` for a grey.
pub(super) fn hue_of(c: [f32; 4]) -> Option<f32> {
    let [r, g, b] = [c[0], c[1], c[2]].map(|v| v.clamp(0.0, 1.0));
    let max = r.max(g).max(b);
    let d = max - r.min(g).min(b);
    if d <= 0.0 {
        None
    } else if max == r {
        Some(60.0 * ((g - b) / d).rem_euclid(6.0))
    } else if max == g {
        Some(60.0 * ((b - r) / d + 2.0))
    } else {
        Some(60.0 * ((r - g) / d + 4.0))
    }
}

/// [`apply_hsb_keeping`] for a frame that kept no hue (hue 0: red).
#[cfg(test)]
fn apply_hsb(c: [f32; 4], h: &[f32; 5]) -> [f32; 4] {
    apply_hsb_keeping(c, 0.0, h).0
}

/// Composes the affine channel map `(m, a)` (`v ↦ m v + a`) after the one at `h[i..i+2]`.
pub(super) fn then_affine(h: &mut [f32; 5], i: usize, m: f32, a: f32) {
    h[i + 1] = m * h[i + 1] + a;
    h[i] *= m;
}

/// The linear map of `skew X Y` (radians; Context Free's, from AGG): `x += tan X · y`,
/// `y += tan Y · x`, z unchanged; for an iterator's step (`divisor` N), its N-th
/// root, so N steps compose to the skew. With S the off-diagonal part, S² = pI
/// (p = tan X · tan Y), so every power of K = I + S is αI + βS: p = 0 gives
/// I + S/N exactly; p > 0 the real eigenvalues 1 ± √p; p < 0 the complex pair
/// 1 ± i√−p. Where K has no real root (p ≥ 1: a folding or singular skew) the step
/// is I + S/N, an approximation.
pub(crate) fn skew_matrix(x: f32, y: f32, divisor: f32) -> Mat3 {
    let (a, b) = (x.tan() as f64, y.tan() as f64);
    let n = divisor as f64;
    let p = a * b;
    let (alpha, beta) = if divisor == 1.0 {
        (1.0, 1.0)
    } else if p == 0.0 || p >= 1.0 || !p.is_finite() {
        (1.0, 1.0 / n)
    } else if p > 0.0 {
        let m = p.sqrt();
        let (hi, lo) = ((1.0 + m).powf(1.0 / n), (1.0 - m).powf(1.0 / n));
        ((hi + lo) / 2.0, (hi - lo) / (2.0 * m))
    } else {
        let m = (-p).sqrt();
        let (rho, theta) = ((1.0 + m * m).sqrt().powf(1.0 / n), m.atan() / n);
        (rho * theta.cos(), rho * theta.sin() / m)
    };
    let (al, ba, bb) = (alpha as f32, (beta * a) as f32, (beta * b) as f32);
    Mat3::from_cols(Vec3::new(al, bb, 0.0), Vec3::new(ba, al, 0.0), Vec3::Z)
}

/// Applies one primitive adjustment with argument values `args` (`n_args` of them
/// given; missing ones are 0) to the frame `f` and the deltas `c` (see [`compose_prims`]).
#[inline]
pub(super) fn apply_prim(
    f: &mut Affine,
    c: &mut Composite,
    kind: bundle::AdjOp,
    axis: u8,
    args: &[f32; 4],
    n_args: usize,
    divisor: f32,
) {
    let arg = |i: usize| if i < n_args { args[i] } else { 0.0 };
    use bundle::AdjOp;
    match kind {
        AdjOp::Translate => {
            let v = match axis {
                0 => Vec3::new(arg(0), 0.0, 0.0),
                1 => Vec3::new(0.0, arg(0), 0.0),
                2 => Vec3::new(0.0, 0.0, arg(0)),
                _ => Vec3::new(arg(0), arg(1), arg(2)),
            };
            *f = f.translate(v / divisor);
        }
        AdjOp::Rotate => {
            let axes = [Vec3::X, Vec3::Y, Vec3::Z];
            if axis == 3 {
                for (i, a) in axes.iter().enumerate().take(n_args.min(3)) {
                    *f = f.rotate(Quat::from_axis_angle(*a, arg(i) / divisor));
                }
            } else {
                *f = f.rotate(Quat::from_axis_angle(axes[axis as usize % 3], arg(0) / divisor));
            }
        }
        AdjOp::Scale => {
            let root = |s: f32| if divisor == 1.0 { s } else { s.signum() * s.abs().powf(1.0 / divisor) };
            *f = if n_args >= 2 {
                // `s X Y [Z]` (Z defaults to 1, as Context Free's `s X Y`).
                let z = if n_args >= 3 { arg(2) } else { 1.0 };
                f.scale3(Vec3::new(root(arg(0)), root(arg(1)), root(z)))
            } else {
                f.scale(root(arg(0)))
            };
        }
        AdjOp::Skew => *f = f.linear(skew_matrix(arg(0), arg(1), divisor)),
        AdjOp::Flip => {
            let n = match axis {
                0 => Vec3::X,
                1 => Vec3::Y,
                2 => Vec3::Z,
                _ => Vec3::new(arg(0), arg(1), arg(2)),
            };
            *f = f.reflect(n);
        }
        AdjOp::Color => c.color[axis as usize & 3] += arg(0) / divisor,
        AdjOp::Hsb => {
            // Hue, saturation (axis 1) or brightness (axis 2), Context Free's
            // semantics: `hue h` adds h degrees; `sat s`/`b s` with s in -1..1 move the
            // channel the fraction s of the way to 1 (s > 0) or to 0 (s < 0). An
            // iterator's step is the divisor-th root of that map, so the steps of
            // `M/N * {sat s}` compose to exactly `sat s`.
            let h = c.hsb.get_or_insert(bundle::HSB_IDENTITY);
            if axis == 0 {
                h[0] += arg(0) / divisor;
            } else {
                let s = arg(0).clamp(-1.0, 1.0);
                let keep = if divisor == 1.0 { 1.0 - s.abs() } else { (1.0 - s.abs()).powf(1.0 / divisor) };
                let i = if axis == 1 { 1 } else { 3 };
                then_affine(h, i, keep, if s > 0.0 { 1.0 - keep } else { 0.0 });
            }
        }
        AdjOp::Paint => {
            // A colour value: what the list did to the colour before it is replaced
            // (an iterator's step sets the same value: setting is idempotent).
            c.set = Some([arg(0), arg(1), arg(2), arg(3)]);
            c.color = [0.0; 4];
            c.hsb = None;
        }
        AdjOp::Weight => c.weight[axis as usize & 3] += arg(0) / divisor,
        AdjOp::Fps => c.fps += arg(0) / divisor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn affine(c: &Composite) -> Affine {
        Affine { f: composite_frame(c), n: c.n.map(|n| Mat3::from_cols_array(&n)) }
    }

    fn close(a: [f32; 4], b: [f32; 4]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    /// A skew's step for `N` steps, composed `N` times, is the skew (1e-5), for
    /// angles with tan X · tan Y zero, positive and negative; one step of 1 is K.
    #[test]
    fn skew_steps_compose_to_the_skew() {
        let deg = |d: f32| d.to_radians();
        for (x, y) in [(45.0, 0.0), (0.0, -30.0), (20.0, 30.0), (-25.0, 40.0), (30.0, -50.0)] {
            let k = skew_matrix(deg(x), deg(y), 1.0);
            let (tx, ty) = (deg(x).tan(), deg(y).tan());
            assert!(k.abs_diff_eq(Mat3::from_cols(Vec3::new(1.0, ty, 0.0), Vec3::new(tx, 1.0, 0.0), Vec3::Z), 1e-6));
            for n in [2.0f32, 3.0, 7.0] {
                let step = skew_matrix(deg(x), deg(y), n);
                let mut m = Mat3::IDENTITY;
                for _ in 0..n as usize {
                    m *= step;
                }
                assert!(m.abs_diff_eq(k, 1e-5), "skew {x} {y} in {n} steps: {m:?} vs {k:?}");
            }
        }
    }

    /// `skew` in a rotated frame acts along the frame's own axes: under `rz 90` the
    /// frame's y axis is the world's −x.
    #[test]
    fn skew_acts_along_the_frames_axes() {
        let prims = |list: &[(bundle::AdjOp, u8, Vec<f32>)]| -> Vec<bundle::PrimAdj> {
            list.iter()
                .map(|(kind, axis, args)| bundle::PrimAdj {
                    kind: *kind,
                    axis: *axis,
                    args: args.iter().map(|v| bundle::Arg::Const(*v)).collect(),
                })
                .collect()
        };
        let plain = compose_prims(&prims(&[(bundle::AdjOp::Skew, 0, vec![45f32.to_radians(), 0.0])]), 1.0);
        let f = affine(&plain);
        assert!(f.apply_point(Vec3::Y).abs_diff_eq(Vec3::new(1.0, 1.0, 0.0), 1e-6), "{:?}", f.apply_point(Vec3::Y));
        assert!(f.apply_point(Vec3::X).abs_diff_eq(Vec3::X, 1e-6));
        let turned = compose_prims(
            &prims(&[
                (bundle::AdjOp::Rotate, 2, vec![90f32.to_radians()]),
                (bundle::AdjOp::Skew, 0, vec![45f32.to_radians(), 0.0]),
            ]),
            1.0,
        );
        let f = affine(&turned);
        // Local (0, 1) skews to local (1, 1), which rz 90 takes to world (−1, 1).
        assert!(f.apply_point(Vec3::Y).abs_diff_eq(Vec3::new(-1.0, 1.0, 0.0), 1e-5), "{:?}", f.apply_point(Vec3::Y));
    }

    fn hsb(kind_axis: &[(u8, f32)], divisor: f32) -> [f32; 5] {
        let prims: Vec<bundle::PrimAdj> = kind_axis
            .iter()
            .map(|&(axis, v)| bundle::PrimAdj { kind: bundle::AdjOp::Hsb, axis, args: vec![bundle::Arg::Const(v)] })
            .collect();
        compose_prims(&prims, divisor).hsb.expect("an HSB part")
    }

    #[test]
    fn hue_turns_and_saturation_and_brightness_move_toward_their_ends() {
        let red = [1.0, 0.0, 0.0, 1.0];
        assert!(close(apply_hsb(red, &hsb(&[(0, 120.0)], 1.0)), [0.0, 1.0, 0.0, 1.0]));
        assert!(close(apply_hsb(red, &hsb(&[(0, -120.0)], 1.0)), [0.0, 0.0, 1.0, 1.0]));
        // Brightness halfway to 0, then saturation halfway to 0 (Context Free's `b -0.5 sat -0.5`).
        assert!(close(apply_hsb(red, &hsb(&[(2, -0.5)], 1.0)), [0.5, 0.0, 0.0, 1.0]));
        assert!(close(apply_hsb(red, &hsb(&[(1, -0.5)], 1.0)), [1.0, 0.5, 0.5, 1.0]));
        // White has no hue; saturating it toward 1 gives red (hue 0).
        assert!(close(apply_hsb([1.0; 4], &hsb(&[(0, 77.0)], 1.0)), [1.0; 4]));
        assert!(close(apply_hsb([1.0; 4], &hsb(&[(1, 1.0)], 1.0)), [1.0, 0.0, 0.0, 1.0]));
        // Alpha is kept; out-of-range channels are clamped first.
        assert!(close(apply_hsb([2.0, -1.0, 0.0, 0.25], &hsb(&[(0, 0.0)], 1.0)), [1.0, 0.0, 0.0, 0.25]));
    }

    #[test]
    fn a_list_of_hsb_changes_folds_into_one_and_iterator_steps_compose_to_the_whole() {
        // Two `sat 0.5` in a row: 0 → 0.5 → 0.75.
        let h = hsb(&[(1, 0.5), (1, 0.5)], 1.0);
        assert!((h[1] * 0.0 + h[2] - 0.75).abs() < 1e-6);
        // Four steps of `4/4 * {b -0.5}`... each the 4th root: together exactly `b -0.5`.
        let whole = hsb(&[(2, -0.5)], 1.0);
        let step = hsb(&[(2, -0.5)], 4.0);
        let (mut m, mut a) = (1.0f32, 0.0f32);
        for _ in 0..4 {
            (m, a) = (step[3] * m, step[3] * a + step[4]);
        }
        assert!((m - whole[3]).abs() < 1e-6 && (a - whole[4]).abs() < 1e-6);
        let step = hsb(&[(1, 0.6)], 3.0);
        let (mut m, mut a) = (1.0f32, 0.0f32);
        for _ in 0..3 {
            (m, a) = (step[1] * m, step[1] * a + step[2]);
        }
        let whole = hsb(&[(1, 0.6)], 1.0);
        assert!((m - whole[1]).abs() < 1e-5 && (a - whole[2]).abs() < 1e-5);
    }

    #[test]
    fn a_non_uniform_scale_is_per_axis_and_its_steps_are_roots() {
        let prims = [bundle::PrimAdj {
            kind: bundle::AdjOp::Scale,
            axis: 0,
            args: vec![bundle::Arg::Const(8.0), bundle::Arg::Const(1.0), bundle::Arg::Const(27.0)],
        }];
        let f = affine(&compose_prims(&prims, 1.0));
        assert!((f.apply_vector(Vec3::X) - Vec3::new(8.0, 0.0, 0.0)).length() < 1e-5);
        assert!((f.apply_vector(Vec3::Z) - Vec3::new(0.0, 0.0, 27.0)).length() < 1e-4);
        let step = affine(&compose_prims(&prims, 3.0));
        let three = step.compose(&step).compose(&step);
        for v in [Vec3::X, Vec3::Y, Vec3::Z] {
            assert!((three.apply_vector(v) - f.apply_vector(v)).length() < 1e-4);
        }
        // `s X Y` leaves z alone.
        let two = [bundle::PrimAdj {
            kind: bundle::AdjOp::Scale,
            axis: 0,
            args: vec![bundle::Arg::Const(0.1), bundle::Arg::Const(1.0)],
        }];
        let g = affine(&compose_prims(&two, 1.0));
        assert!((g.apply_vector(Vec3::new(1.0, 1.0, 1.0)) - Vec3::new(0.1, 1.0, 1.0)).length() < 1e-6);
    }
}
