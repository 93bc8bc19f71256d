//! Profile sweeps for `LINETO`, `BLENDTO`, `SLINETO` and `ALINETO` (thesis §4.3):
//! a profile placed in successive pen frames, consecutive rings joined by triangle
//! strips (a generalised cylinder).
//!
//! # Winding and normals
//!
//! The profile is a list of points in the pen's local frame. A ring's vertex normal
//! is the direction from the profile's centroid to the point (for a two-point ribbon,
//! `(p₁ − p₀) × ẑ`), mapped with [`Frame::apply_normal`]. Each quad between ring A
//! (earlier frame) and ring B is split into `(Aᵢ, Aⱼ, Bⱼ)` and `(Aᵢ, Bⱼ, Bᵢ)`, which faces
//! outward for a counter-clockwise profile (seen from +z) swept along +z. So that
//! faces stay outward when a sweep runs backwards along z or the profile is
//! clockwise, each triangle whose world-space face normal disagrees with the sum of
//! its vertex normals is flipped. Triangles of a segment that starts in a mirrored
//! frame are stored with the reverse of that outward winding and flagged mirrored, so
//! the exporters' correction ([`crate::output::Mesh::oriented_triangles`]) yields the
//! outward winding again (SPEC resolved semantics 8).

use glam::{Quat, Vec3, Vec4};

use super::quat::{conj, hamilton, scaled, Affine, Frame};
use super::rotation::rotation_between;
use super::Mesh;

/// A frame a profile ring can be placed in: a [`Frame`], or an [`Affine`] (a frame
/// under a non-uniform scale, which makes an elliptic tube of a round profile).
pub trait Ring: Copy {
    fn apply_point(&self, x: Vec3) -> Vec3;
    fn apply_normal(&self, n: Vec3) -> Vec3;
    fn scale_factor(&self) -> f32;
    fn mirrored(&self) -> bool;
}

macro_rules! ring {
    ($t:ty) => {
        impl Ring for $t {
            fn apply_point(&self, x: Vec3) -> Vec3 {
                <$t>::apply_point(self, x)
            }
            fn apply_normal(&self, n: Vec3) -> Vec3 {
                <$t>::apply_normal(self, n)
            }
            fn scale_factor(&self) -> f32 {
                <$t>::scale_factor(self)
            }
            fn mirrored(&self) -> bool {
                <$t>::mirrored(self)
            }
        }
    };
}
ring!(Frame);
ring!(Affine);

/// Sweeps `profile` from the frame `from` to the frame `to` (`LINETO`): two rings
/// joined by two triangles per profile edge, the loop closed when the profile has
/// three or more points. Colours go from `color_from` (first ring) to `color_to`.
pub fn sweep<R: Ring>(
    mesh: &mut Mesh,
    profile: &[Vec3],
    from: &R,
    to: &R,
    color_from: [f32; 4],
    color_to: [f32; 4],
    bone: u32,
) {
    sweep_path(mesh, profile, &[*from, *to], color_from, color_to, bone);
}

/// Sweeps `profile` through every frame of `frames` (e.g. the output of
/// [`super::blend_frames`] for `BLENDTO`), sharing each intermediate ring between the
/// two segments it joins. Colours are interpolated linearly along the frame list.
/// Fewer than two frames or fewer than two profile points emit nothing.
pub fn sweep_path<R: Ring>(
    mesh: &mut Mesh,
    profile: &[Vec3],
    frames: &[R],
    color_from: [f32; 4],
    color_to: [f32; 4],
    bone: u32,
) {
    let n = profile.len();
    if n < 2 || frames.len() < 2 {
        return;
    }
    let local_normals = profile_normals(profile);
    let rings: Vec<Vec<Vec3>> =
        frames.iter().map(|f| local_normals.iter().map(|&ln| f.apply_normal(ln)).collect()).collect();
    let degenerate = |f: &R| f.scale_factor().is_nan() || f.scale_factor() <= 1e-12;
    let last = frames.len() - 1;
    let base = mesh.positions.len() as u32;
    for (k, f) in frames.iter().enumerate() {
        // A zero-scale ring (a cone tip, `s 0`) has no direction of its own: borrow the
        // normals of the nearest ring before or after it that has one.
        let normals = if degenerate(f) {
            let before = (0..k).rev().find(|&j| !degenerate(&frames[j]));
            let after = (k + 1..frames.len()).find(|&j| !degenerate(&frames[j]));
            &rings[before.or(after).unwrap_or(k)]
        } else {
            &rings[k]
        };
        let t = k as f32 / last as f32;
        let color = Vec4::from(color_from).lerp(Vec4::from(color_to), t).to_array();
        for (p, nrm) in profile.iter().zip(normals) {
            mesh.push_vertex(f.apply_point(*p), *nrm, color, [0.0; 4], bone);
        }
    }
    let n_edges = if n >= 3 { n } else { 1 };
    for (k, f) in frames[..last].iter().enumerate() {
        let a = base + (k * n) as u32;
        let b = a + n as u32;
        let mirrored = f.mirrored();
        for i in 0..n_edges {
            let j = (i + 1) % n;
            let (ai, aj, bi, bj) = (a + i as u32, a + j as u32, b + i as u32, b + j as u32);
            for t in [[ai, aj, bj], [ai, bj, bi]] {
                let t = outward(mesh, t);
                if mirrored {
                    mesh.push_triangle([t[0], t[2], t[1]], true);
                } else {
                    mesh.push_triangle(t, false);
                }
            }
        }
    }
}

/// `SLINETO`: like [`sweep`], but each ring is turned so that the frame's +z axis points
/// along the segment `to.u − from.u` (the rotation between the two directions, thesis
/// eq. 3.29, applied on the world side so the frame keeps its roll, scale, position and
/// handedness). A zero-length segment sweeps the frames unchanged.
pub fn sweep_oriented(
    mesh: &mut Mesh,
    profile: &[Vec3],
    from: &Frame,
    to: &Frame,
    color_from: [f32; 4],
    color_to: [f32; 4],
    bone: u32,
) {
    let (a, b) = oriented_pair(from, to);
    sweep(mesh, profile, &a, &b, color_from, color_to, bone);
}

/// The two ring frames of [`sweep_oriented`]: `from` and `to` turned on the world side
/// so that +z points along `to.u − from.u` (unchanged for a zero-length segment).
pub fn oriented_pair(from: &Frame, to: &Frame) -> (Frame, Frame) {
    let dir = to.u - from.u;
    if dir.length_squared() == 0.0 {
        return (*from, *to);
    }
    (orient_along(from, dir), orient_along(to, dir))
}

/// `ALINETO`: like [`sweep`], but both rings use the orientation of
/// [`average_frame`]`(from, to)`. Each ring keeps its own position and its own scale,
/// so a tapering line still tapers; only the twist between the two ends is removed
/// (the profile planes are parallel).
pub fn sweep_averaged(
    mesh: &mut Mesh,
    profile: &[Vec3],
    from: &Frame,
    to: &Frame,
    color_from: [f32; 4],
    color_to: [f32; 4],
    bone: u32,
) {
    let (a, b) = averaged_pair(from, to);
    sweep(mesh, profile, &a, &b, color_from, color_to, bone);
}

/// The two ring frames of [`sweep_averaged`]: the orientation of
/// [`average_frame`]`(from, to)`, each with its own position and scale.
pub fn averaged_pair(from: &Frame, to: &Frame) -> (Frame, Frame) {
    let avg = average_frame(from, to);
    (with_scale(&avg, from.scale_factor(), from.u), with_scale(&avg, to.scale_factor(), to.u))
}

/// The average of two frames: the normalised LERP (at ½, same hemisphere) of the unit
/// parts of their q's, the mean position and the mean linear scale. The handedness
/// is `a`'s (two frames of different handedness have no mean rotation).
pub fn average_frame(a: &Frame, b: &Frame) -> Frame {
    let ra = Vec4::from(unit(a.q));
    let mut rb = Vec4::from(unit(b.q));
    if ra.dot(rb) < 0.0 {
        rb = -rb;
    }
    let r = Quat::from_vec4((ra + rb).try_normalize().unwrap_or(ra));
    let avg = Frame { q: r, qh: signed_conj(r, a.mirrored()), u: Vec3::ZERO };
    with_scale(&avg, 0.5 * (a.scale_factor() + b.scale_factor()), 0.5 * (a.u + b.u))
}

/// `q` scaled to unit length (identity for zero).
fn unit(q: Quat) -> Quat {
    let l = q.length();
    if l > 0.0 && l.is_finite() {
        scaled(q, 1.0 / l)
    } else {
        Quat::IDENTITY
    }
}

/// `ε q̄`, the right quaternion matching `q` (see the invariant in [`super::quat`]).
fn signed_conj(q: Quat, mirrored: bool) -> Quat {
    scaled(conj(q), if mirrored { -1.0 } else { 1.0 })
}

/// The orientation and handedness of `f` with linear scale `s` at position `u`.
fn with_scale(f: &Frame, s: f32, u: Vec3) -> Frame {
    let k = s.max(0.0).sqrt();
    let q = scaled(unit(f.q), k);
    Frame { q, qh: signed_conj(q, f.mirrored()), u }
}

/// `f` turned on the world side so that its +z axis points along `dir`.
fn orient_along(f: &Frame, dir: Vec3) -> Frame {
    let z = f.apply_vector(Vec3::Z);
    let r = rotation_between(if z.length_squared() > 0.0 { z } else { Vec3::Z }, dir);
    Frame { q: hamilton(r, f.q), qh: hamilton(f.qh, conj(r)), u: f.u }
}

/// Local vertex normals of a profile: away from the centroid for a closed profile,
/// `(p₁ − p₀) × ẑ` for a two-point ribbon.
fn profile_normals(profile: &[Vec3]) -> Vec<Vec3> {
    if profile.len() == 2 {
        let n = (profile[1] - profile[0]).cross(Vec3::Z).normalize_or(Vec3::X);
        return vec![n, n];
    }
    let centre = profile.iter().copied().sum::<Vec3>() / profile.len() as f32;
    profile.iter().map(|p| (*p - centre).normalize_or(Vec3::Z)).collect()
}

/// `t`, reversed if its world-space face normal disagrees with its vertex normals.
fn outward(mesh: &Mesh, t: [u32; 3]) -> [u32; 3] {
    let p = |i: u32| Vec3::from(mesh.positions[i as usize]);
    let n = |i: u32| Vec3::from(mesh.normals[i as usize]);
    let face = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
    if face.dot(n(t[0]) + n(t[1]) + n(t[2])) < 0.0 {
        [t[0], t[2], t[1]]
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use crate::geom::quat::tests::{close, rot};

    const WHITE: [f32; 4] = [1.0; 4];

    fn square() -> Vec<Vec3> {
        vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)]
    }

    /// Directed-edge counts of the oriented triangles.
    fn edges(m: &Mesh) -> HashMap<(u32, u32), usize> {
        let mut e = HashMap::new();
        for t in m.oriented_triangles() {
            for k in 0..3 {
                *e.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        e
    }

    /// Every oriented triangle faces away from the z axis (the tube's axis).
    fn faces_out_from_z_axis(m: &Mesh) -> bool {
        m.oriented_triangles().all(|t| {
            let p: Vec<Vec3> = t.iter().map(|&i| Vec3::from(m.positions[i as usize])).collect();
            let face = (p[1] - p[0]).cross(p[2] - p[0]);
            let c = (p[0] + p[1] + p[2]) / 3.0;
            face.dot(Vec3::new(c.x, c.y, 0.0)) > 0.0
        })
    }

    #[test]
    fn square_tube_is_closed_and_outward() {
        let mut m = Mesh::default();
        let to = Frame::identity().translate(Vec3::Z);
        sweep(&mut m, &square(), &Frame::identity(), &to, WHITE, [0.0, 0.0, 0.0, 1.0], 3);
        assert_eq!(m.triangles.len(), 8);
        assert_eq!(m.n_vertices(), 8);
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let radial = Vec3::new(p[0], p[1], 0.0);
            assert!(Vec3::from(*n).dot(radial) > 0.0, "normal points away from the axis");
        }
        assert!(faces_out_from_z_axis(&m));
        let e = edges(&m);
        // Interior edges appear once in each direction; the 8 ring edges once only.
        let boundary: Vec<_> = e.keys().filter(|(a, b)| !e.contains_key(&(*b, *a))).collect();
        assert_eq!(boundary.len(), 8);
        assert!(e.values().all(|&c| c == 1));
        assert_eq!(m.bones, vec![3; 8]);
        assert_eq!(m.colors[4], [0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn backwards_and_mirrored_sweeps_still_face_outward() {
        let back = Frame::identity().translate(-Vec3::Z);
        let mut m = Mesh::default();
        sweep(&mut m, &square(), &Frame::identity(), &back, WHITE, WHITE, 0);
        assert!(faces_out_from_z_axis(&m));

        let a = Frame::identity().reflect(Vec3::X);
        let b = a.translate(Vec3::Z);
        let mut m = Mesh::default();
        sweep(&mut m, &square(), &a, &b, WHITE, WHITE, 0);
        assert!(m.mirrored.iter().all(|&x| x));
        assert!(faces_out_from_z_axis(&m));
    }

    #[test]
    fn path_shares_rings() {
        let frames: Vec<Frame> = (0..5).map(|k| Frame::identity().translate(Vec3::Z * k as f32)).collect();
        let mut m = Mesh::default();
        sweep_path(&mut m, &square(), &frames, WHITE, WHITE, 0);
        assert_eq!(m.n_vertices(), 20);
        assert_eq!(m.triangles.len(), 32);
        let e = edges(&m);
        assert!(e.values().all(|&c| c == 1));
    }

    #[test]
    fn ribbon_and_degenerate_profiles() {
        let mut m = Mesh::default();
        let to = Frame::identity().translate(Vec3::Z);
        sweep(&mut m, &[Vec3::ZERO], &Frame::identity(), &to, WHITE, WHITE, 0);
        assert!(m.triangles.is_empty());
        sweep(&mut m, &[-Vec3::X, Vec3::X], &Frame::identity(), &to, WHITE, WHITE, 0);
        assert_eq!(m.triangles.len(), 2);
        // A cone to a zero-scale tip keeps usable normals.
        let mut m = Mesh::default();
        sweep(&mut m, &square(), &Frame::identity(), &to.scale(0.0), WHITE, WHITE, 0);
        assert!(m.normals.iter().all(|n| (Vec3::from(*n).length() - 1.0).abs() < 1e-5));
    }

    #[test]
    fn oriented_sweep_is_orthogonal_to_the_segment() {
        let from = Frame::identity();
        let to = Frame::identity().translate(Vec3::new(3.0, 0.0, 0.0)).scale(2.0);
        let mut m = Mesh::default();
        sweep_oriented(&mut m, &square(), &from, &to, WHITE, WHITE, 0);
        // Both rings lie in planes x = const, with their own scales.
        for p in &m.positions[..4] {
            assert!(p[0].abs() < 1e-5);
        }
        for p in &m.positions[4..] {
            assert!((p[0] - 3.0).abs() < 1e-5);
            assert!((Vec3::new(0.0, p[1], p[2]).length() - 2.0 * 2f32.sqrt()).abs() < 1e-4);
        }
    }

    #[test]
    fn average_frame_and_averaged_sweep() {
        let a = Frame::identity().scale(1.0);
        let b = Frame::identity().rotate(rot(Vec3::Z, 90.0)).translate(Vec3::new(0.0, 0.0, 2.0)).scale(3.0);
        let avg = average_frame(&a, &b);
        assert!((avg.scale_factor() - 2.0).abs() < 1e-5);
        assert!(close(avg.u, Vec3::new(0.0, 0.0, 1.0), 1e-6));
        assert!(close(avg.apply_vector(Vec3::X).normalize(), rot(Vec3::Z, 45.0) * Vec3::X, 1e-5));
        let mut m = Mesh::default();
        sweep_averaged(&mut m, &square(), &a, &b, WHITE, WHITE, 0);
        // Same orientation in both rings: corresponding points differ by scale only.
        let p0 = Vec3::from(m.positions[0]);
        let p4 = Vec3::from(m.positions[4]) - b.u;
        assert!(close(p4, p0 * 3.0, 1e-4));
    }
}
