//! The `BLENDTO` spline (thesis §4.3.2, eqs. 4.15–4.21): interpolates position,
//! orientation and scale between two pen frames.
//!
//! # How the equations are read
//!
//! With the source frame (u₁, q₁), target frame (u₂, q₂), λ = 0.75 and `w ∈ [0, 1]`:
//!
//! * (4.15) `D = √N(u₁ − u₂) · λ = |u₁ − u₂| · λ` — N of a pure quaternion is its
//!   squared length.
//! * (4.16–4.17) `v₁ = q₁ (0,0,D/N(q₁),0) q₁*` is `D` times the unit direction of the
//!   frame's +z axis, and `v₂` is `D` times *minus* the target's +z axis. They are
//!   offsets, so the control points are `c₁ = u₁ + v₁` (ahead of the source along its
//!   z) and `c₂ = u₂ + v₂` (behind the target). The thesis's `q₁ x q₁*` only gives the
//!   frame's z axis for unmirrored frames; for a mirrored frame (`q̂ = −q̄`) it points
//!   backwards, so the axis used here is the frame's own `q ẑ q̂`, normalised. The
//!   two agree whenever the frame is not mirrored.
//! * (4.18–4.19) `s = SMOOTHSTEP(w)` and the position is a blend of two straight
//!   lines. Read literally (`LERP(LERP(u₁,v₁,s), LERP(u₂,v₂,s), w)`), the curve would
//!   end at c₂ instead of u₂ and leave u₁ along the chord, contradicting the text
//!   ("the line is going to continue in the z-direction"). The reading used swaps the
//!   roles of s and w and runs the second line towards u₂:
//!   `u(w) = LERP(LERP(u₁, c₁, w), LERP(c₂, u₂, w), s)`.
//!   Because `s'(0) = s'(1) = 0`, `u'(0) = c₁ − u₁ = v₁` and `u'(1) = u₂ − c₂ = −v₂`:
//!   the curve leaves u₁ along the source's +z and arrives at u₂ along the target's +z,
//!   and `u(0) = u₁`, `u(1) = u₂`. For aligned frames it is a straight, monotone line.
//! * (4.20–4.21) the orientation is the normalised LERP of q₁ and q₂ and the norm is
//!   set so that `N(q) = LERP(N(q₁), N(q₂), s)`. The LERP is taken between the *unit*
//!   parts of q₁ and q₂ (in the same hemisphere), so a larger scale at one end does not
//!   pull the orientation towards it; the thesis's LERP of the raw q's would.
//!   q̂ is rebuilt from the invariant `q̂ = ε q̄` (see [`super::quat`]), with ε the
//!   handedness of the nearer end frame (blending between frames of different
//!   handedness has no continuous answer; the switch happens at w = ½).

use glam::{Quat, Vec3, Vec4};

use super::quat::{conj, norm, scaled, Frame};

/// The thesis's spline tension λ.
pub const BLEND_LAMBDA: f32 = 0.75;

/// `3w² − 2w³`.
fn smoothstep(w: f32) -> f32 {
    w * w * (3.0 - 2.0 * w)
}

/// The unit direction of the frame's +z axis, or the rotation part's z when the
/// frame has zero scale.
fn z_axis(f: &Frame) -> Vec3 {
    f.apply_vector(Vec3::Z).try_normalize().unwrap_or(Vec3::Z)
}

/// The unit quaternion of a frame's rotation part (identity for a zero q).
fn unit(q: Quat) -> Quat {
    let l = q.length();
    if l > 0.0 && l.is_finite() {
        scaled(q, 1.0 / l)
    } else {
        Quat::IDENTITY
    }
}

/// The interpolated frames of `BLENDTO` from `a` to `b` for `w = k / segments`,
/// `k = 0..=segments` (so `segments + 1` frames; the first is `a` and the last is `b`
/// exactly). `segments = 0` is treated as 1.
pub fn blend_frames(a: &Frame, b: &Frame, segments: usize) -> Vec<Frame> {
    let segments = segments.max(1);
    let d = (a.u - b.u).length() * BLEND_LAMBDA;
    let c1 = a.u + z_axis(a) * d;
    let c2 = b.u - z_axis(b) * d;
    let (n1, n2) = (norm(a.q), norm(b.q));
    let r1 = unit(a.q);
    let mut r2 = unit(b.q);
    if Vec4::from(r1).dot(Vec4::from(r2)) < 0.0 {
        // q and −q are the same rotation; take the short way round.
        r2 = scaled(r2, -1.0);
    }
    let mut out = Vec::with_capacity(segments + 1);
    out.push(*a);
    for k in 1..segments {
        let w = k as f32 / segments as f32;
        let s = smoothstep(w);
        let u = a.u.lerp(c1, w).lerp(c2.lerp(b.u, w), s);
        let qhat = Quat::from_vec4(Vec4::from(r1).lerp(Vec4::from(r2), w));
        let n_target = n1 + (n2 - n1) * s;
        let nq = norm(qhat);
        let q = if nq > 0.0 { scaled(qhat, (n_target / nq).max(0.0).sqrt()) } else { Quat::IDENTITY };
        let mirrored = if w < 0.5 { a.mirrored() } else { b.mirrored() };
        let qh = scaled(conj(q), if mirrored { -1.0 } else { 1.0 });
        out.push(Frame { q, qh, u });
    }
    out.push(*b);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::quat::tests::{close, rot};

    fn ends() -> (Frame, Frame) {
        let a = Frame::identity().translate(Vec3::new(0.5, 0.0, 0.0)).scale(0.5);
        let b = Frame::identity()
            .translate(Vec3::new(2.0, 1.0, 3.0))
            .rotate(rot(Vec3::new(1.0, 1.0, 0.0), 70.0))
            .scale(2.0);
        (a, b)
    }

    #[test]
    fn endpoints_match() {
        let (a, b) = ends();
        let fs = blend_frames(&a, &b, 10);
        assert_eq!(fs.len(), 11);
        assert!(close(fs[0].u, a.u, 1e-5) && close(fs[10].u, b.u, 1e-5));
        assert_eq!(fs[0], a);
        assert_eq!(fs[10], b);
    }

    #[test]
    fn tangents_follow_the_end_frames_z_axes() {
        let (a, b) = ends();
        let n = 1000;
        let fs = blend_frames(&a, &b, n);
        let start = (fs[1].u - fs[0].u).normalize();
        let end = (fs[n].u - fs[n - 1].u).normalize();
        assert!(start.dot(z_axis(&a)) > 0.999, "{start:?}");
        assert!(end.dot(z_axis(&b)) > 0.999, "{end:?}");
    }

    #[test]
    fn mirrored_frames_use_their_own_z_axis() {
        // fx keeps +z; the curve must still leave along +z.
        let a = Frame::identity().reflect(Vec3::X);
        let b = Frame::identity().reflect(Vec3::X).translate(Vec3::new(1.0, 0.0, 4.0));
        let fs = blend_frames(&a, &b, 100);
        assert!((fs[1].u - fs[0].u).normalize().dot(Vec3::Z) > 0.999);
        assert!(fs.iter().all(|f| f.mirrored()));
    }

    #[test]
    fn scale_interpolates_with_smoothstep() {
        let (a, b) = ends();
        let fs = blend_frames(&a, &b, 8);
        for (k, f) in fs.iter().enumerate() {
            let s = smoothstep(k as f32 / 8.0);
            let expect = 0.5 + (2.0 - 0.5) * s;
            assert!((f.scale_factor() - expect).abs() < 1e-4, "{k}: {} vs {expect}", f.scale_factor());
            assert!(!f.mirrored());
        }
    }

    #[test]
    fn aligned_frames_give_a_straight_monotone_line() {
        let a = Frame::identity();
        let b = Frame::identity().translate(Vec3::new(0.0, 0.0, 4.0));
        let fs = blend_frames(&a, &b, 16);
        for w in fs.windows(2) {
            assert!(w[1].u.z > w[0].u.z);
            assert!(w[1].u.x.abs() < 1e-6 && w[1].u.y.abs() < 1e-6);
        }
        assert!(close(fs[8].u, Vec3::new(0.0, 0.0, 2.0), 1e-5));
    }
}
