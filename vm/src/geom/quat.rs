//! The thesis's transform state: three quaternions (q, q̂, u) with *non-unit* q and q̂.
//!
//! A point x maps to `u + q x q̂` (thesis eqs. 4.1–4.14, SPEC §4). Rotations and
//! reflections are products with unit quaternions; a uniform scale k is kept in the
//! norm of q and q̂ (each multiplied by √k, SPEC resolved semantics 7), so the linear
//! scale is N(q) = q q̄ = |q|², the squared length of q.
//!
//! # Invariant
//!
//! Every frame built through this API satisfies `q̂ = ε q̄` with ε = +1 for an even
//! number of reflections and ε = −1 for an odd number (each reflection `q ← q n`,
//! `q̂ ← n q̂` flips the sign because `n̄ = −n` for a pure quaternion). Hence the
//! linear part is `M(x) = q x q̂ = ε N(q) R(x)`, with R the rotation of q/|q|:
//! a similarity whose determinant has the sign of ε. The functions below do not
//! rely on the invariant where a general formula is as cheap (normals, mirroring).
//!
//! # Non-uniform scale
//!
//! A non-uniform scale `s X Y Z` is no similarity, so it cannot live in the norm of
//! q. An [`Affine`] is a frame with a general linear factor N on the *world side*:
//! `x ↦ u + N (q x q̂)`, N = `None` (the identity) until a non-uniform scale is
//! applied, so every frame that never meets one keeps the thesis's representation and
//! cost. On the world side N changes only when another non-uniform scale is applied
//! (`Q D = (R D Rᵀ) Q` for the similarity Q = s R): rotations, reflections, uniform
//! scales and translations after it act on q, q̂ and u exactly as before, and
//! composition stays exact.
//!
//! Quaternion products are written out here (not `glam::Quat * Quat`) so that they are
//! plain Hamilton products for any norm and give bit-identical results on every target,
//! whichever SIMD path glam would pick.

use glam::{Mat3, Mat4, Quat, Vec3, Vec4, Vec4Swizzles};

/// The Hamilton product `a b`, valid for quaternions of any norm.
///
/// Computed four lanes at a time (glam's `Vec4`: SSE, NEON or scalar), each lane as
/// the sum, left to right, of the same four products as the scalar formula
/// ([`hamilton_scalar`]): a product that formula subtracts is added negated here,
/// which IEEE arithmetic makes exact, so the bits are the same on every target.
#[inline]
pub fn hamilton(a: Quat, b: Quat) -> Quat {
    let b = Vec4::from(b);
    let t1 = Vec4::splat(a.w) * b;
    let t2 = (Vec4::splat(a.x) * Vec4::new(1.0, -1.0, 1.0, -1.0)) * b.wzyx();
    let t3 = (Vec4::splat(a.y) * Vec4::new(1.0, 1.0, -1.0, -1.0)) * b.zwxy();
    let t4 = (Vec4::splat(a.z) * Vec4::new(-1.0, 1.0, 1.0, -1.0)) * b.yxwz();
    Quat::from_vec4(((t1 + t2) + t3) + t4)
}

/// The sign patterns [`hamilton`] multiplies the splatted x, y and z of `a` by.
const SIGNS: [Vec4; 3] =
    [Vec4::new(1.0, -1.0, 1.0, -1.0), Vec4::new(1.0, 1.0, -1.0, -1.0), Vec4::new(-1.0, 1.0, 1.0, -1.0)];

/// A constant right factor `b` of [`hamilton`], prepared: `b` and its three
/// shuffles, each times its sign pattern.
#[derive(Clone, Copy, Debug)]
struct RightFactor([Vec4; 4]);

impl RightFactor {
    fn new(b: Quat) -> RightFactor {
        let b = Vec4::from(b);
        RightFactor([b, SIGNS[0] * b.wzyx(), SIGNS[1] * b.zwxy(), SIGNS[2] * b.yxwz()])
    }

    /// `hamilton(a, b)`, bit for bit: [`hamilton`] forms `(a.x · s) · b'` with s = ±1,
    /// this `a.x · (s · b')`, and both are `±(a.x · b')` rounded once (IEEE rounding
    /// is symmetric), signed zeros and infinities included.
    #[inline(always)]
    fn times(&self, a: Quat) -> Quat {
        let [b, b1, b2, b3] = self.0;
        let t1 = Vec4::splat(a.w) * b;
        let t2 = Vec4::splat(a.x) * b1;
        let t3 = Vec4::splat(a.y) * b2;
        let t4 = Vec4::splat(a.z) * b3;
        Quat::from_vec4(((t1 + t2) + t3) + t4)
    }
}

/// A constant left factor `a` of [`hamilton`], prepared: its splatted w, and its
/// splatted x, y and z times their sign patterns (the very vectors [`hamilton`]
/// computes first).
#[derive(Clone, Copy, Debug)]
struct LeftFactor([Vec4; 4]);

impl LeftFactor {
    fn new(a: Quat) -> LeftFactor {
        LeftFactor([
            Vec4::splat(a.w),
            Vec4::splat(a.x) * SIGNS[0],
            Vec4::splat(a.y) * SIGNS[1],
            Vec4::splat(a.z) * SIGNS[2],
        ])
    }

    /// `hamilton(a, b)`, bit for bit (the same products and sums).
    #[inline(always)]
    fn times(&self, b: Quat) -> Quat {
        let [a0, a1, a2, a3] = self.0;
        let b = Vec4::from(b);
        let t1 = a0 * b;
        let t2 = a1 * b.wzyx();
        let t3 = a2 * b.zwxy();
        let t4 = a3 * b.yxwz();
        Quat::from_vec4(((t1 + t2) + t3) + t4)
    }
}

/// A constant child frame prepared for [`Frame::compose_prepared`]: three of the four
/// Hamilton products of a composition have a constant factor, whose shuffles and
/// signs are computed once here.
#[derive(Clone, Copy, Debug)]
pub struct PreparedFrame {
    q: RightFactor,
    qh: LeftFactor,
    u: RightFactor,
}

impl PreparedFrame {
    pub fn new(child: &Frame) -> PreparedFrame {
        PreparedFrame {
            q: RightFactor::new(child.q),
            qh: LeftFactor::new(child.qh),
            u: RightFactor::new(pure(child.u)),
        }
    }
}

/// [`hamilton`] written out component by component: the reference its lanes follow.
pub fn hamilton_scalar(a: Quat, b: Quat) -> Quat {
    Quat::from_xyzw(
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    )
}

/// The conjugate `q*` (= `q̄`): the vector part negated.
pub fn conj(q: Quat) -> Quat {
    Quat::from_xyzw(-q.x, -q.y, -q.z, q.w)
}

/// The pure quaternion `(v, 0)`.
pub fn pure(v: Vec3) -> Quat {
    Quat::from_xyzw(v.x, v.y, v.z, 0.0)
}

/// The thesis's quaternion norm `N(q) = q q̄`, i.e. the *squared* length.
pub fn norm(q: Quat) -> f32 {
    q.length_squared()
}

/// `q` multiplied by the scalar `k` (all four components).
pub fn scaled(q: Quat, k: f32) -> Quat {
    Quat::from_xyzw(q.x * k, q.y * k, q.z * k, q.w * k)
}

/// A transform state (q, q̂, u): `x ↦ u + q x q̂`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Left quaternion q (rotation·reflection, norm² = linear scale).
    pub q: Quat,
    /// Right quaternion q̂.
    pub qh: Quat,
    /// Translation u (the vector part of a pure quaternion).
    pub u: Vec3,
}

impl Default for Frame {
    fn default() -> Self {
        Self::identity()
    }
}

impl Frame {
    /// The identity frame: q = q̂ = 1, u = 0 (thesis eqs. 4.1–4.2).
    pub fn identity() -> Frame {
        Frame { q: Quat::IDENTITY, qh: Quat::IDENTITY, u: Vec3::ZERO }
    }

    /// Translation by `v` in the current frame: `u ← u + q v q̂` (eq. 4.3).
    #[must_use]
    pub fn translate(mut self, v: Vec3) -> Frame {
        self.u += self.apply_vector(v);
        self
    }

    /// Rotation by the unit quaternion `r`: `q ← q r`, `q̂ ← r* q̂` (eqs. 4.4–4.5).
    #[must_use]
    pub fn rotate(mut self, r: Quat) -> Frame {
        self.q = hamilton(self.q, r);
        self.qh = hamilton(conj(r), self.qh);
        self
    }

    /// Reflection across the plane through the frame's origin with normal `n`
    /// (in the current frame): with `r = (n̂, 0)`, `q ← q r`, `q̂ ← r q̂` (eqs. 4.6–4.7).
    /// A zero normal leaves the frame unchanged.
    #[must_use]
    pub fn reflect(mut self, n: Vec3) -> Frame {
        let Some(n) = n.try_normalize() else { return self };
        let r = pure(n);
        self.q = hamilton(self.q, r);
        self.qh = hamilton(r, self.qh);
        self
    }

    /// Uniform scale by `s` (SPEC resolved semantics 7): q and q̂ are each multiplied
    /// by √|s| so that `q x q̂` scales lengths by |s|. A negative `s` also applies the
    /// point reflection −I (three reflections: `q ← −q`), so lengths scale by `s`
    /// exactly as a matrix `s·I` would and the frame becomes mirrored.
    #[must_use]
    pub fn scale(mut self, s: f32) -> Frame {
        let k = s.abs().sqrt();
        self.q = scaled(self.q, if s < 0.0 { -k } else { k });
        self.qh = scaled(self.qh, k);
        self
    }

    /// `self ∘ child`: the child's frame expressed in this frame's parent space
    /// (thesis eqs. 4.12–4.14 with the eq. 4.14 typo fixed, SPEC resolved semantics 7):
    /// `p' = p + w u ŵ`, `w' = w q`, `ŵ' = q̂ ŵ`, where `self = (w, ŵ, p)` and
    /// `child = (q, q̂, u)`.
    #[must_use]
    pub fn compose(&self, child: &Frame) -> Frame {
        Frame { q: hamilton(self.q, child.q), qh: hamilton(child.qh, self.qh), u: self.u + self.apply_vector(child.u) }
    }

    /// [`Frame::compose`] with a child prepared once ([`PreparedFrame`]): the same
    /// bits, with fewer shuffles and sign products per composition.
    #[inline(always)]
    #[must_use]
    pub fn compose_prepared(&self, child: &PreparedFrame) -> Frame {
        let v = hamilton(child.u.times(self.q), self.qh);
        Frame { q: child.q.times(self.q), qh: child.qh.times(self.qh), u: self.u + Vec3::new(v.x, v.y, v.z) }
    }

    /// [`Frame::compose_prepared`] of the frame `(q, q̂, u)` whose translation is
    /// the first three lanes of `u` (the fourth is carried along, unused): the
    /// composed q, q̂ and translation, the same bits in those lanes (a translation
    /// held in one vector is one addition).
    #[inline(always)]
    #[must_use]
    pub fn compose_prepared_lanes(q: Quat, qh: Quat, u: Vec4, child: &PreparedFrame) -> (Quat, Quat, Vec4) {
        let v = hamilton(child.u.times(q), qh);
        (child.q.times(q), child.qh.times(qh), u + Vec4::from(v))
    }

    /// The inverse map `x ↦ q⁻¹ (x − u) q̂⁻¹` (with `q⁻¹ = q̄ / N(q)`), so that
    /// `f.compose(&f.inverse()?)` is the identity; `None` for a zero or non-finite
    /// scale. The inverse of a mirrored frame is mirrored.
    pub fn inverse(&self) -> Option<Frame> {
        let (nq, nqh) = (norm(self.q), norm(self.qh));
        if !(nq > 0.0 && nqh > 0.0 && nq.is_finite() && nqh.is_finite() && self.u.is_finite()) {
            return None;
        }
        let lin = Frame { q: scaled(conj(self.q), 1.0 / nq), qh: scaled(conj(self.qh), 1.0 / nqh), u: Vec3::ZERO };
        Some(Frame { u: -lin.apply_vector(self.u), ..lin })
    }

    /// Maps a point: `u + q x q̂`.
    pub fn apply_point(&self, x: Vec3) -> Vec3 {
        self.u + self.apply_vector(x)
    }

    /// Maps a direction (no translation): `q x q̂`.
    pub fn apply_vector(&self, x: Vec3) -> Vec3 {
        let r = hamilton(hamilton(self.q, pure(x)), self.qh);
        Vec3::new(r.x, r.y, r.z)
    }

    /// Maps a surface normal and normalises it.
    ///
    /// Normals transform by the inverse transpose of the linear map `M(x) = q x q̂`.
    /// With the columns `a, b, c` of M, `M⁻ᵀ = [b×c, c×a, a×b] / det M`. Because M is a
    /// similarity (`ε s R`), this equals `M / s²`, i.e. the normal is simply `M n`
    /// normalised, and for a mirrored frame it is the reflected normal, which is the
    /// face normal of the *reversed* winding the exporters write (SPEC resolved
    /// semantics 8). The general cofactor form is used anyway, computed on the unit
    /// parts of q and q̂ so tiny scales do not underflow. A degenerate frame (zero
    /// scale) returns `n` normalised (or +z).
    pub fn apply_normal(&self, n: Vec3) -> Vec3 {
        match self.unit_linear() {
            Some(unit) => cofactor_normal(unit.axes(), n),
            None => n.normalize_or(Vec3::Z),
        }
    }

    /// The linear scale of the frame: `|q| |q̂|`, which equals the thesis's `N(q) = q q̄`
    /// (SPEC resolved semantics 7) for every frame built through this API.
    pub fn scale_factor(&self) -> f32 {
        self.q.length() * self.qh.length()
    }

    /// True when the linear map has a negative determinant (an odd number of
    /// reflections). A zero-scale frame reports `false`.
    pub fn mirrored(&self) -> bool {
        let Some(unit) = self.unit_linear() else { return false };
        let [a, b, c] = unit.axes();
        a.dot(b.cross(c)) < 0.0
    }

    /// The images of the unit axes under the linear part: the columns of its matrix.
    pub fn axes(&self) -> [Vec3; 3] {
        [self.apply_vector(Vec3::X), self.apply_vector(Vec3::Y), self.apply_vector(Vec3::Z)]
    }

    /// The linear part as a matrix (its columns are [`Frame::axes`]) and whether its
    /// determinant, taken on those scaled axes, is negative. The evaluator's `VERTEX`
    /// path and the expansion of prototype instances both use this, so an instance
    /// expands to the very bits the vertices would have had.
    #[inline]
    pub fn linear(&self) -> (Mat3, bool) {
        let [a, b, c] = self.axes();
        (Mat3::from_cols(a, b, c), a.dot(b.cross(c)) < 0.0)
    }

    /// The frame as an affine matrix (column vectors, `M * (x, 1)`).
    pub fn to_mat4(&self) -> Mat4 {
        let [a, b, c] = self.axes();
        Mat4::from_cols(a.extend(0.0), b.extend(0.0), c.extend(0.0), self.u.extend(1.0))
    }

    /// The same frame with q and q̂ normalised and no translation: the rotation or
    /// rotation-reflection part. `None` for a zero or non-finite scale.
    fn unit_linear(&self) -> Option<Frame> {
        let (lq, lqh) = (self.q.length(), self.qh.length());
        if !(lq > 0.0 && lqh > 0.0 && lq.is_finite() && lqh.is_finite()) {
            return None;
        }
        Some(Frame { q: scaled(self.q, 1.0 / lq), qh: scaled(self.qh, 1.0 / lqh), u: Vec3::ZERO })
    }
}

/// A [`Frame`] with a world-side general linear factor N: `x ↦ u + N (q x q̂)` (see
/// the module docs). N is `None` until a non-uniform scale is applied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine {
    pub f: Frame,
    pub n: Option<Mat3>,
}

impl From<Frame> for Affine {
    fn from(f: Frame) -> Affine {
        Affine { f, n: None }
    }
}

impl Affine {
    /// The identity.
    pub fn identity() -> Affine {
        Frame::identity().into()
    }

    /// Translation by `v` in the current frame: `u ← u + N q v q̂`.
    #[must_use]
    pub fn translate(mut self, v: Vec3) -> Affine {
        self.f.u += self.apply_vector(v);
        self
    }

    /// [`Frame::rotate`] (N is on the world side and does not change).
    #[must_use]
    pub fn rotate(self, r: Quat) -> Affine {
        Affine { f: self.f.rotate(r), ..self }
    }

    /// [`Frame::reflect`].
    #[must_use]
    pub fn reflect(self, n: Vec3) -> Affine {
        Affine { f: self.f.reflect(n), ..self }
    }

    /// [`Frame::scale`].
    #[must_use]
    pub fn scale(self, s: f32) -> Affine {
        Affine { f: self.f.scale(s), ..self }
    }

    /// Scale by `v.x`, `v.y`, `v.z` along the frame's own axes. Equal factors are the
    /// uniform [`Frame::scale`]; otherwise `N ← N · R D Rᵀ`, D = diag(v), R the
    /// rotation part of q.
    #[must_use]
    pub fn scale3(self, v: Vec3) -> Affine {
        if v.x == v.y && v.y == v.z {
            return self.scale(v.x);
        }
        let r = rotation_matrix(&self.f);
        let d = r * Mat3::from_diagonal(v) * r.transpose();
        Affine { n: Some(self.n.map_or(d, |n| n * d)), ..self }
    }

    /// A general linear map `k` along the frame's own axes (a skew): `N ← N · R K Rᵀ`,
    /// R the rotation part of q (the similarity's scale and sign cancel in
    /// `Q K Q⁻¹`), as [`Affine::scale3`] does for a diagonal K.
    #[must_use]
    pub fn linear(self, k: Mat3) -> Affine {
        let r = rotation_matrix(&self.f);
        let d = r * k * r.transpose();
        Affine { n: Some(self.n.map_or(d, |n| n * d)), ..self }
    }

    /// `self ∘ child`: q, q̂ and u as [`Frame::compose`] (with N applied to the
    /// child's offset), and `N' = N · R N_c Rᵀ`.
    #[must_use]
    pub fn compose(&self, child: &Affine) -> Affine {
        let n = match (self.n, child.n) {
            (n, None) => n,
            (n, Some(nc)) => {
                let r = rotation_matrix(&self.f);
                Some(n.unwrap_or(Mat3::IDENTITY) * r * nc * r.transpose())
            }
        };
        // q and q̂ compose as plain frames; only the child's offset also meets N.
        let mut f = self.f.compose(&child.f);
        if self.n.is_some() {
            f.u = self.f.u + self.apply_vector(child.f.u);
        }
        Affine { f, n }
    }

    /// The inverse map, `None` for a singular or non-finite one.
    pub fn inverse(&self) -> Option<Affine> {
        let inv = self.f.inverse()?;
        let Some(n) = self.n else { return Some(inv.into()) };
        // (N Q)⁻¹ = Q⁻¹ N⁻¹ = (Rᵀ N⁻¹ R) Q⁻¹ on the world side.
        if n.determinant() == 0.0 {
            return None;
        }
        let r = rotation_matrix(&self.f);
        let n = r.transpose() * n.inverse() * r;
        if !n.is_finite() {
            return None;
        }
        let lin = Affine { f: Frame { u: Vec3::ZERO, ..inv }, n: Some(n) };
        Some(Affine { f: Frame { u: -lin.apply_vector(self.f.u), ..inv }, n: Some(n) })
    }

    /// Maps a point: `u + N q x q̂`.
    pub fn apply_point(&self, x: Vec3) -> Vec3 {
        self.f.u + self.apply_vector(x)
    }

    /// Maps a direction: `N q x q̂`.
    pub fn apply_vector(&self, x: Vec3) -> Vec3 {
        let v = self.f.apply_vector(x);
        match self.n {
            None => v,
            Some(n) => n * v,
        }
    }

    /// Maps a surface normal by the inverse transpose (cofactor form, on the unit
    /// parts of q and q̂ as [`Frame::apply_normal`]) and normalises it.
    pub fn apply_normal(&self, n: Vec3) -> Vec3 {
        let Some(m) = self.n else { return self.f.apply_normal(n) };
        match self.f.unit_linear() {
            Some(unit) => cofactor_normal(unit.axes().map(|v| m * v), n),
            None => n.normalize_or(Vec3::Z),
        }
    }

    /// The linear scale: the similarity's times `∛|det N|`, the geometric mean of N's
    /// axis scales (`s 2 2 2` and `s 8 1 1` both read 2: a cube of the same volume).
    pub fn scale_factor(&self) -> f32 {
        self.f.scale_factor() * self.n.map_or(1.0, |n| n.determinant().abs().cbrt())
    }

    /// True when the linear map has a negative determinant.
    pub fn mirrored(&self) -> bool {
        self.f.mirrored() ^ self.n.is_some_and(|n| n.determinant() < 0.0)
    }

    /// The map as an affine matrix (column vectors).
    pub fn to_mat4(&self) -> Mat4 {
        let [a, b, c] = [Vec3::X, Vec3::Y, Vec3::Z].map(|v| self.apply_vector(v));
        Mat4::from_cols(a.extend(0.0), b.extend(0.0), c.extend(0.0), self.f.u.extend(1.0))
    }
}

/// The normal `n` mapped by the inverse transpose of the linear map with columns
/// `[a, b, c]`, in cofactor form (`[b×c, c×a, a×b]`, signed by the determinant),
/// normalised; `n` normalised (or +z) where the map is degenerate.
fn cofactor_normal([a, b, c]: [Vec3; 3], n: Vec3) -> Vec3 {
    let det = a.dot(b.cross(c));
    let m = n.x * b.cross(c) + n.y * c.cross(a) + n.z * a.cross(b);
    (m * det.signum()).normalize_or(n.normalize_or(Vec3::Z))
}

/// The rotation (or rotation-reflection) part of `f`'s `q x q̂` as an orthogonal
/// matrix; the identity for a zero or non-finite scale.
fn rotation_matrix(f: &Frame) -> Mat3 {
    match f.unit_linear() {
        Some(u) => {
            let [a, b, c] = u.axes();
            Mat3::from_cols(a, b, c)
        }
        None => Mat3::IDENTITY,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A rotation of `deg` degrees about `axis` (right-handed).
    pub(crate) fn rot(axis: Vec3, deg: f32) -> Quat {
        Quat::from_axis_angle(axis.normalize(), deg.to_radians())
    }

    #[test]
    fn the_simd_hamilton_product_has_the_scalar_formula_s_bits() {
        let mut g = Lcg(7);
        let specials = [0.0, -0.0, 1.0, -1.0, 1e-30, -3e20, f32::MIN_POSITIVE, 0.5];
        for i in 0..20_000 {
            let mut q = || {
                let mut c = [0.0f32; 4];
                for x in &mut c {
                    *x = if i % 7 == 0 { specials[(g.next_f32() * 8.0) as usize % 8] } else { g.range(-3.0, 3.0) };
                }
                Quat::from_array(c)
            };
            let (a, b) = (q(), q());
            let (x, y) = (hamilton(a, b), hamilton_scalar(a, b));
            assert_eq!(x.to_array().map(f32::to_bits), y.to_array().map(f32::to_bits), "{a} {b}");
        }
    }

    /// A prepared child composes to the bits [`Frame::compose`] gives, for random
    /// frames and special values (signed zeros, infinities, tiny and huge values);
    /// NaNs compose to NaNs in the same places.
    #[test]
    fn a_prepared_child_composes_to_the_same_bits() {
        let mut g = Lcg(11);
        let specials = [0.0, -0.0, 1.0, -1.0, 1e-30, -3e20, f32::MIN_POSITIVE, f32::INFINITY, -f32::INFINITY, f32::NAN];
        let mut nans = 0;
        for i in 0..20_000 {
            let mut c = || {
                let mut c = [0.0f32; 11];
                for x in &mut c {
                    *x = if i % 5 == 0 { specials[(g.next_f32() * 10.0) as usize % 10] } else { g.range(-3.0, 3.0) };
                }
                Frame {
                    q: Quat::from_xyzw(c[0], c[1], c[2], c[3]),
                    qh: Quat::from_xyzw(c[4], c[5], c[6], c[7]),
                    u: Vec3::new(c[8], c[9], c[10]),
                }
            };
            let (a, b) = (c(), c());
            let (x, y) = (a.compose(&b), a.compose_prepared(&PreparedFrame::new(&b)));
            let bits = |f: &Frame| [f.q.to_array(), f.qh.to_array(), f.u.extend(0.0).to_array()].concat();
            for (p, q) in bits(&x).iter().zip(&bits(&y)) {
                if p.is_nan() {
                    nans += 1;
                    assert!(q.is_nan(), "{a:?} ∘ {b:?}");
                } else {
                    assert_eq!(p.to_bits(), q.to_bits(), "{a:?} ∘ {b:?}");
                }
            }
        }
        assert!(nans > 0);
    }

    /// A tiny deterministic generator for property-style tests.
    pub(crate) struct Lcg(pub u64);
    impl Lcg {
        pub(crate) fn next_f32(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32) / ((1u64 << 24) as f32)
        }
        pub(crate) fn range(&mut self, a: f32, b: f32) -> f32 {
            a + (b - a) * self.next_f32()
        }
        pub(crate) fn vec(&mut self, a: f32, b: f32) -> Vec3 {
            Vec3::new(self.range(a, b), self.range(a, b), self.range(a, b))
        }
        pub(crate) fn frame(&mut self) -> Frame {
            let mut f = Frame::identity();
            for _ in 0..4 {
                let k = (self.next_f32() * 4.0) as u32;
                f = match k {
                    0 => f.translate(self.vec(-2.0, 2.0)),
                    1 => f.rotate(rot(self.vec(-1.0, 1.0) + Vec3::splat(0.01), self.range(-180.0, 180.0))),
                    2 => f.reflect(self.vec(-1.0, 1.0) + Vec3::splat(0.01)),
                    _ => f.scale(self.range(0.3, 2.0)),
                };
            }
            f
        }
        /// A frame that also meets non-uniform scales (some of them mirroring).
        pub(crate) fn affine(&mut self) -> Affine {
            let mut f = Affine::identity();
            for _ in 0..5 {
                f = if self.next_f32() < 0.4 {
                    let mut v = self.vec(0.3, 2.0);
                    if self.next_f32() < 0.2 {
                        v.y = -v.y;
                    }
                    f.scale3(v)
                } else {
                    f.compose(&self.frame().into())
                };
            }
            f
        }
    }

    /// The affine matrix of `a` built from its definition, independently of `to_mat4`.
    fn reference_matrix(a: &Affine) -> Mat4 {
        let [x, y, z] = a.f.axes();
        let lin = a.n.unwrap_or(Mat3::IDENTITY) * Mat3::from_cols(x, y, z);
        Mat4::from_cols(lin.x_axis.extend(0.0), lin.y_axis.extend(0.0), lin.z_axis.extend(0.0), a.f.u.extend(1.0))
    }

    #[test]
    fn a_non_uniform_scale_composes_exactly_like_matrices() {
        let mut rng = Lcg(17);
        let mut general = 0;
        for _ in 0..100 {
            let (a, b, c) = (rng.affine(), rng.affine(), rng.affine());
            general += usize::from(a.n.is_some());
            let l = a.compose(&b).compose(&c);
            let r = a.compose(&b.compose(&c));
            let m = reference_matrix(&a) * reference_matrix(&b) * reference_matrix(&c);
            let x = rng.vec(-1.0, 1.0);
            assert!(close(l.apply_point(x), r.apply_point(x), 1e-3));
            assert!(close(l.apply_point(x), m.transform_point3(x), 1e-3));
            assert!(close(l.to_mat4().transform_point3(x), m.transform_point3(x), 1e-3));
            assert_eq!(l.mirrored(), m.determinant() < 0.0);
            assert!((l.scale_factor() - m.determinant().abs().cbrt()).abs() < 1e-3 * l.scale_factor().max(1.0));
            let n = rng.vec(-1.0, 1.0).normalize();
            let expect = m.inverse().transpose().transform_vector3(n).normalize();
            assert!(close(l.apply_normal(n), expect, 1e-3));
            let inv = l.inverse().expect("invertible");
            assert!(close(inv.apply_point(l.apply_point(x)), x, 1e-3));
            // Translation after a non-uniform scale moves along the scaled axis.
            assert!(close(l.translate(Vec3::X).f.u, m.transform_point3(Vec3::X), 1e-3));
        }
        assert!(general > 30, "the generator meets non-uniform scales ({general} of 100)");
    }

    #[test]
    fn equal_factors_are_a_uniform_scale_and_leave_no_factor() {
        let f = Affine::identity().rotate(rot(Vec3::Z, 30.0)).scale3(Vec3::splat(2.0));
        assert_eq!(f, Affine::from(Frame::identity().rotate(rot(Vec3::Z, 30.0)).scale(2.0)));
        assert!(f.n.is_none());
        // A non-uniform scale is along the frame's own axes: x after rz 90 is world y.
        let g = Affine::identity().rotate(rot(Vec3::Z, 90.0)).scale3(Vec3::new(3.0, 1.0, 1.0));
        assert!(close(g.apply_vector(Vec3::X), Vec3::new(0.0, 3.0, 0.0), 1e-5));
        assert!(close(g.apply_vector(Vec3::Y), Vec3::new(-1.0, 0.0, 0.0), 1e-5));
    }

    pub(crate) fn close(a: Vec3, b: Vec3, eps: f32) -> bool {
        (a - b).length() <= eps
    }

    #[test]
    fn rx_90_sends_z_to_minus_y() {
        let f = Frame::identity().rotate(rot(Vec3::X, 90.0));
        assert!(close(f.apply_vector(Vec3::Z), -Vec3::Y, 1e-6), "{:?}", f.apply_vector(Vec3::Z));
        assert!(!f.mirrored());
    }

    #[test]
    fn fx_mirrors_x_and_twice_is_identity() {
        let f = Frame::identity().reflect(Vec3::X);
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert!(close(f.apply_point(p), Vec3::new(-1.0, 2.0, 3.0), 1e-6));
        assert!(f.mirrored());
        let ff = f.reflect(Vec3::X);
        assert!(close(ff.apply_point(p), p, 1e-6));
        assert!(!ff.mirrored());
        // The mirrored normal of a +x-facing surface faces −x.
        assert!(close(f.apply_normal(Vec3::X), -Vec3::X, 1e-6));
    }

    #[test]
    fn translate_after_rotate_moves_along_rotated_axis() {
        let f = Frame::identity().rotate(rot(Vec3::X, 90.0)).translate(Vec3::Z);
        assert!(close(f.u, -Vec3::Y, 1e-6));
    }

    #[test]
    fn scale_is_linear_and_read_from_the_norm() {
        let f = Frame::identity().scale(3.0);
        assert!((f.apply_vector(Vec3::X).length() - 3.0).abs() < 1e-6);
        assert!((f.scale_factor() - 3.0).abs() < 1e-6);
        assert!((norm(f.q) - 3.0).abs() < 1e-6, "N(q) is the linear scale");
        let g = f.translate(Vec3::X);
        assert!(close(g.u, Vec3::new(3.0, 0.0, 0.0), 1e-6));
        let h = Frame::identity().scale(-2.0);
        assert!(close(h.apply_vector(Vec3::new(1.0, 2.0, 3.0)), Vec3::new(-2.0, -4.0, -6.0), 1e-5));
        assert!(h.mirrored());
    }

    #[test]
    fn compose_is_associative_and_matches_sequential_application() {
        let mut rng = Lcg(7);
        for _ in 0..50 {
            let (a, b, c) = (rng.frame(), rng.frame(), rng.frame());
            let l = a.compose(&b).compose(&c);
            let r = a.compose(&b.compose(&c));
            let x = rng.vec(-1.0, 1.0);
            assert!(close(l.apply_point(x), r.apply_point(x), 1e-3));
            assert!(close(l.apply_point(x), a.apply_point(b.apply_point(c.apply_point(x))), 1e-3));
            assert_eq!(l.mirrored(), a.mirrored() ^ b.mirrored() ^ c.mirrored());
            assert!((l.scale_factor() - a.scale_factor() * b.scale_factor() * c.scale_factor()).abs() < 1e-3);
        }
    }

    #[test]
    fn inverse_undoes_the_frame() {
        let mut rng = Lcg(5);
        for _ in 0..50 {
            let f = rng.frame();
            let inv = f.inverse().expect("invertible");
            let x = rng.vec(-1.0, 1.0);
            assert!(close(inv.apply_point(f.apply_point(x)), x, 1e-4));
            assert!(close(f.compose(&inv).apply_point(x), x, 1e-4));
            assert_eq!(inv.mirrored(), f.mirrored());
        }
        assert!(Frame::identity().scale(0.0).inverse().is_none());
    }

    #[test]
    fn matrix_and_normals_agree_with_the_quaternion_map() {
        let mut rng = Lcg(11);
        for _ in 0..50 {
            let f = rng.frame();
            let m = f.to_mat4();
            let x = rng.vec(-1.0, 1.0);
            assert!(close(m.transform_point3(x), f.apply_point(x), 1e-4));
            assert_eq!(f.mirrored(), m.determinant() < 0.0);
            let n = rng.vec(-1.0, 1.0).normalize();
            let expect = m.inverse().transpose().transform_vector3(n).normalize();
            assert!(close(f.apply_normal(n), expect, 1e-4));
        }
    }

    #[test]
    fn invariant_qh_is_signed_conjugate() {
        let mut rng = Lcg(3);
        for _ in 0..50 {
            let f = rng.frame();
            let eps = if f.mirrored() { -1.0 } else { 1.0 };
            let c = scaled(conj(f.q), eps);
            assert!((Vec3::new(c.x, c.y, c.z) - Vec3::new(f.qh.x, f.qh.y, f.qh.z)).length() < 1e-4);
            assert!((c.w - f.qh.w).abs() < 1e-4);
        }
    }
}
