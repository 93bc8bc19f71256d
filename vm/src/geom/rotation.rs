//! The rotation taking one direction onto another (thesis eq. 3.29), used by `SLINETO`.

use glam::{Quat, Vec3};

/// The unit quaternion r with `r a r* ∥ b` (the shortest-arc rotation), following
/// thesis eq. 3.29: `(r_v, r_w) = (a × b, a·b + √(N(a) N(b)))`, then normalised.
/// (The thesis prints the scalar part without the `+`; the sum is the standard
/// half-angle form, since `|a×b| = |a||b| sin θ` and `a·b + |a||b| = |a||b|(1 + cos θ)`
/// are `2|a||b| cos(θ/2)` times `sin(θ/2)` and `cos(θ/2)`.)
///
/// When `a ≈ −b` the formula degenerates (both parts vanish); any half-turn about an
/// axis orthogonal to `a` is then correct, and a fixed choice keeps the result
/// deterministic. A zero or non-finite input gives the identity.
pub fn rotation_between(a: Vec3, b: Vec3) -> Quat {
    let (Some(a), Some(b)) = (a.try_normalize(), b.try_normalize()) else { return Quat::IDENTITY };
    let d = a.dot(b);
    if d < -1.0 + 1e-6 {
        let axis = a.any_orthonormal_vector();
        return Quat::from_xyzw(axis.x, axis.y, axis.z, 0.0);
    }
    let v = a.cross(b);
    let q = Quat::from_xyzw(v.x, v.y, v.z, d + 1.0);
    q.normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::quat::tests::{close, Lcg};

    #[test]
    fn rotates_a_onto_b() {
        let mut rng = Lcg(5);
        for _ in 0..100 {
            let a = rng.vec(-1.0, 1.0) + Vec3::splat(1e-3);
            let b = rng.vec(-1.0, 1.0) + Vec3::splat(1e-3);
            let r = rotation_between(a, b);
            assert!((r.length() - 1.0).abs() < 1e-5);
            assert!(close(r * a.normalize(), b.normalize(), 1e-4));
        }
    }

    #[test]
    fn handles_parallel_and_antiparallel() {
        assert!(close(rotation_between(Vec3::Z, Vec3::Z) * Vec3::Z, Vec3::Z, 1e-6));
        for a in [Vec3::Z, Vec3::X, Vec3::new(0.3, -0.2, 0.9)] {
            let r = rotation_between(a, -a);
            assert!(r.is_finite());
            assert!(close(r * a.normalize(), -a.normalize(), 1e-5));
        }
        assert_eq!(rotation_between(Vec3::ZERO, Vec3::Z), Quat::IDENTITY);
    }

    #[test]
    fn is_the_shortest_arc() {
        // z onto x is a quarter turn about +y.
        let r = rotation_between(Vec3::Z, Vec3::X);
        let expect = Quat::from_axis_angle(Vec3::Y, std::f32::consts::FRAC_PI_2);
        assert!(r.dot(expect).abs() > 1.0 - 1e-6);
    }
}
