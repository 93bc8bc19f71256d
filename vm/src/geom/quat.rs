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
//! Quaternion products are written out here (not `glam::Quat * Quat`) so that they are
//! plain Hamilton products for any norm and give bit-identical results on every target,
//! whichever SIMD path glam would pick.

use glam::{Mat4, Quat, Vec3};

/// The Hamilton product `a b`, valid for quaternions of any norm.
pub fn hamilton(a: Quat, b: Quat) -> Quat {
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
        let fallback = n.normalize_or(Vec3::Z);
        let Some(unit) = self.unit_linear() else { return fallback };
        let [a, b, c] = unit.axes();
        let det = a.dot(b.cross(c));
        let m = n.x * b.cross(c) + n.y * c.cross(a) + n.z * a.cross(b);
        (m * det.signum()).normalize_or(fallback)
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A rotation of `deg` degrees about `axis` (right-handed).
    pub(crate) fn rot(axis: Vec3, deg: f32) -> Quat {
        Quat::from_axis_angle(axis.normalize(), deg.to_radians())
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
