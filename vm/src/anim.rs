//! Animation: transform-rule tracks, bone poses and the camera, sampled at a time.
//!
//! The evaluator ([`crate::eval`]) records the frames of every transform rule it
//! needs once, in a [`Track`] (the cache of thesis §4.4.1: rewinding is a lookup),
//! and one [`crate::output::Bone`] per call of a model rule with transform rules. This module turns
//! those into poses. The semantics, stated again in docs/reference.md §11:
//!
//! * **Frame index.** At time t a track running at `fps` frames per second shows frame
//!   `i = ⌊t·fps⌋` ([`frame_index`]; negative times show frame 0).
//! * **Wrapping.** A finite track of n frames ([`Track::complete`]) repeats: frame i is
//!   `X[i mod n]`. A track cut where the run stopped needing frames (an infinite rule,
//!   sampled lazily up to `⌊horizon·fps⌋`) clamps to its last frame beyond that.
//!   An empty track is the identity.
//! * **Bones.** Bone b of model rule A, called in frame F (A's own space, world
//!   coordinates, the rest pose), with transform rules X1…Xn, has at frame i the
//!   *motion* `P_b(i) = X1[i]·X2[i]·…·Xn[i]` (frame composition: Xn is applied first,
//!   in the space of the ones before it). The motion acts in A's own space, so the
//!   bone's *local* transform is `L_b = F·P_b(i)·F⁻¹` and its world transform is
//!   `M_b(t) = M_parent(t)·L_b(t)` with `M_0 = I`. A vertex emitted inside A's
//!   derivation at rest position v (world) is at `M_b(t)·v` at time t. A point at A's
//!   origin stays put under a pure rotation: the bone turns about its own origin.
//! * **Camera.** `camerarule C`: the camera's frame at time t is `C[⌊t·fps⌋]`
//!   (wrapping like a bone's track), in world space.

use crate::geom::quat::Frame;
use crate::output::{Animation, Instances, Mesh, Output, Track};
use glam::{Quat, Vec3};

/// The most frames the VM samples from one transform rule (a bound on memory for
/// extreme `fps`, `duration` or `--time` values; hitting it is reported).
pub const MAX_TRACK_FRAMES: usize = 1 << 20;

/// The frame index shown at time `t` by a track running at `fps`: `⌊t·fps⌋`, with
/// products within 1e-6 (relative) of an integer snapped to it so that decimal times
/// such as 0.7 s at 10 fps give frame 7. Negative or non-finite values give 0.
pub fn frame_index(t: f64, fps: f32) -> u64 {
    let x = t * fps as f64;
    if !(x.is_finite() && x > 0.0) {
        return 0;
    }
    let k = x.round();
    let i = if (x - k).abs() <= 1e-6 * k.max(1.0) { k } else { x.floor() };
    i.min(u64::MAX as f64) as u64
}

/// How many frames a track running at `fps` needs to cover `0 ≤ t ≤ span`: frame
/// indices `0..=⌊span·fps⌋`, at least 1, and at most one more than
/// [`MAX_TRACK_FRAMES`] (so that a caller can tell a track it must cut, and say so).
pub fn frames_needed(span: f64, fps: f32) -> usize {
    let last = frame_index(span, fps);
    (last.saturating_add(1)).min(MAX_TRACK_FRAMES as u64 + 1) as usize
}

impl Track {
    /// Frame `i` with the animation's rule: wraps around a complete track, clamps to
    /// the last frame of a cut one; the identity for an empty track.
    pub fn at(&self, i: u64) -> Frame {
        let n = self.frames.len() as u64;
        if n == 0 {
            return Frame::identity();
        }
        let k = if self.complete { i % n } else { i.min(n - 1) };
        self.frames[k as usize]
    }

    /// Frame `i` clamped to the last frame (convolution's rule); the identity for an
    /// empty track.
    pub fn clamped(&self, i: u64) -> Frame {
        match self.frames.len() {
            0 => Frame::identity(),
            n => self.frames[(i as usize).min(n - 1)],
        }
    }
}

impl Animation {
    /// Whether there is anything to play: a bone besides the root, or a camera.
    pub fn is_animated(&self) -> bool {
        self.bones.len() > 1 || self.camera.is_some()
    }

    /// The frame index bone `b` shows at time `t`.
    pub fn bone_frame_index(&self, b: usize, t: f64) -> u64 {
        self.bones.get(b).map(|bone| frame_index(t, bone.fps)).unwrap_or(0)
    }

    /// The motion `P_b(i) = X1[i]·…·Xn[i]` of bone `b` at frame `i`, in its own space.
    pub fn motion(&self, b: usize, i: u64) -> Frame {
        let Some(bone) = self.bones.get(b) else { return Frame::identity() };
        bone.tracks
            .iter()
            .filter_map(|&k| self.tracks.get(k as usize))
            .fold(Frame::identity(), |acc, track| acc.compose(&track.at(i)))
    }

    /// The local transform `F·P_b(i)·F⁻¹` of bone `b` at frame `i`, relative to its
    /// parent bone. The root, and a bone whose rest frame has zero scale (all its
    /// geometry is one point), do not move.
    pub fn local(&self, b: usize, i: u64) -> Frame {
        let Some(bone) = self.bones.get(b) else { return Frame::identity() };
        if b == 0 {
            return Frame::identity();
        }
        match bone.rest.inverse() {
            Some(inv) => bone.rest.compose(&self.motion(b, i)).compose(&inv),
            None => Frame::identity(),
        }
    }

    /// The world transform `M_b(t)` of every bone at time `t` (index = bone).
    /// Bones are numbered in creation order, so a parent always precedes its children.
    pub fn pose(&self, t: f64) -> Vec<Frame> {
        let mut pose: Vec<Frame> = Vec::with_capacity(self.bones.len());
        for (b, bone) in self.bones.iter().enumerate() {
            if b == 0 {
                pose.push(Frame::identity());
                continue;
            }
            let parent = pose.get(bone.parent as usize).copied().unwrap_or_else(Frame::identity);
            let local = self.local(b, frame_index(t, bone.fps));
            pose.push(parent.compose(&local));
        }
        pose
    }

    /// The camera's frame at time `t`, when there is a camera.
    pub fn camera_at(&self, t: f64) -> Option<Frame> {
        let cam = self.camera.as_ref()?;
        let track = self.tracks.get(cam.track as usize)?;
        Some(track.at(frame_index(t, cam.fps)))
    }
}

/// Translation, rotation (unit quaternion) and uniform scale of a frame, so that
/// `x ↦ T + S·R(x)`: T = u, R = q/|q|, S = N(q) (the linear scale), negated for a
/// mirrored frame (a mirrored similarity is −(scale)·(rotation) in 3D). A zero-scale
/// frame gives the identity rotation and scale 0.
pub fn trs(f: &Frame) -> (Vec3, Quat, f32) {
    let s = f.scale_factor();
    let l = f.q.length();
    let r = if l > 0.0 && l.is_finite() { crate::geom::quat::scaled(f.q, 1.0 / l) } else { Quat::IDENTITY };
    let s = if f.mirrored() { -s } else { s };
    (f.u, r, if s.is_finite() { s } else { 0.0 })
}

/// Moves every vertex of `m` by its bone's transform in `pose`; triangles whose
/// first vertex's bone is mirrored at this pose flip their mirrored flag.
fn pose_mesh(m: &mut Mesh, pose: &[Frame]) {
    if m.bones.is_empty() {
        return;
    }
    for i in 0..m.positions.len() {
        let b = m.bone(i) as usize;
        if b == 0 {
            continue;
        }
        let Some(f) = pose.get(b) else { continue };
        m.positions[i] = f.apply_point(Vec3::from_array(m.positions[i])).to_array();
        if let Some(n) = m.normals.get_mut(i) {
            *n = f.apply_normal(Vec3::from_array(*n)).to_array();
        }
    }
    for k in 0..m.triangles.len() {
        let b = m.bone(m.triangles[k][0] as usize) as usize;
        if b != 0 && pose.get(b).is_some_and(|f| f.mirrored()) {
            if let Some(flag) = m.mirrored.get_mut(k) {
                *flag = !*flag;
            }
        }
    }
    m.bones.clear();
}

impl Output {
    /// The pose at time `t` as a static output (what `mdg-run --time T` writes):
    /// every vertex, pen-line point and instance of bone b moved by `M_b(t)`, all
    /// bones reset to the root, and the animation replaced by a still camera at its
    /// frame at `t` (if there is a camera).
    pub fn posed(&self, t: f64) -> Output {
        let pose = self.animation.pose(t);
        let mut o = self.clone();
        if o.instances.iter().any(|i| i.bone != 0 && self.is_prototype_instance(&i)) {
            // Posed vertex by vertex, as the evaluator's vertices would be.
            o.expand_prototypes();
        }
        pose_mesh(&mut o.mesh, &pose);
        pose_mesh(&mut o.sweeps, &pose);
        for line in &mut o.lines {
            for (i, p) in line.points.iter_mut().enumerate() {
                let b = line.bones.get(i).copied().unwrap_or(0) as usize;
                if let Some(f) = pose.get(b).filter(|_| b != 0) {
                    *p = f.apply_point(Vec3::from_array(*p)).to_array();
                }
            }
            line.bones.clear();
        }
        let mut posed = Instances::new();
        for mut inst in &o.instances {
            let b = inst.bone as usize;
            if b == 0 {
                posed.push(inst);
                continue;
            }
            if let Some(f) = pose.get(b) {
                let n = if inst.lin == 0 { None } else { o.lins.get(inst.lin as usize).map(|l| l.0) };
                let a = crate::geom::Affine::from(*f).compose(&crate::geom::Affine { f: inst.frame, n });
                inst.frame = a.f;
                if let Some(n) = a.n {
                    if o.lins.is_empty() {
                        o.lins.push((glam::Mat3::IDENTITY, 1.0));
                    }
                    o.lins.push((n, n.determinant().cbrt()));
                    inst.lin = o.lins.len() as u32 - 1;
                }
            }
            inst.bone = 0;
            posed.push(inst);
        }
        o.instances = posed;
        let camera = self.animation.camera.as_ref().zip(self.animation.camera_at(t));
        let (tracks, camera) = match camera {
            Some((cam, frame)) => {
                let rule = self.animation.tracks.get(cam.track as usize).map(|t| t.rule.clone()).unwrap_or_default();
                (
                    vec![Track { rule, frames: vec![frame], complete: true }],
                    Some(crate::output::Camera { track: 0, ..cam.clone() }),
                )
            }
            None => (Vec::new(), None),
        };
        o.animation = Animation { duration: self.animation.duration, bones: Vec::new(), tracks, camera };
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::Bone;

    fn track(frames: Vec<Frame>, complete: bool) -> Track {
        Track { rule: "X".into(), frames, complete }
    }

    #[test]
    fn frame_index_floors_and_snaps_decimal_times() {
        assert_eq!(frame_index(0.0, 30.0), 0);
        assert_eq!(frame_index(0.7, 10.0), 7);
        assert_eq!(frame_index(0.29, 100.0), 29);
        assert_eq!(frame_index(0.349, 10.0), 3);
        assert_eq!(frame_index(-1.0, 10.0), 0);
        assert_eq!(frame_index(1.0, f32::NAN), 0);
        assert_eq!(frames_needed(4.0, 25.0), 101);
        assert_eq!(frames_needed(0.0, 25.0), 1);
        assert_eq!(frames_needed(1e30, 1e9), MAX_TRACK_FRAMES + 1);
    }

    #[test]
    fn complete_tracks_wrap_and_cut_tracks_clamp() {
        let f = |z: f32| Frame::identity().translate(Vec3::new(0.0, 0.0, z));
        let frames = vec![f(0.0), f(1.0), f(2.0)];
        assert_eq!(track(frames.clone(), true).at(4), f(1.0));
        assert_eq!(track(frames.clone(), false).at(4), f(2.0));
        assert_eq!(track(frames, true).clamped(7), f(2.0));
        assert_eq!(track(Vec::new(), true).at(3), Frame::identity());
    }

    #[test]
    fn a_bone_turns_about_its_own_origin_and_children_follow() {
        let spin: Vec<Frame> = (1..=4)
            .map(|k| Frame::identity().rotate(Quat::from_rotation_z(k as f32 * std::f32::consts::FRAC_PI_2)))
            .collect();
        let rest = Frame::identity().translate(Vec3::new(2.0, 0.0, 0.0));
        let child_rest = rest.translate(Vec3::new(1.0, 0.0, 0.0));
        let root = Bone { rule: String::new(), parent: 0, rest: Frame::identity(), fps: 1.0, tracks: Vec::new() };
        let anim = Animation {
            duration: 4.0,
            bones: vec![
                root,
                Bone { rule: "A".into(), parent: 0, rest, fps: 1.0, tracks: vec![0] },
                Bone { rule: "B".into(), parent: 1, rest: child_rest, fps: 1.0, tracks: Vec::new() },
            ],
            tracks: vec![track(spin, true)],
            camera: None,
        };
        // t = 0: frame 0 is a quarter turn about A's origin (2, 0, 0).
        let pose = anim.pose(0.0);
        assert!((pose[1].apply_point(Vec3::new(2.0, 0.0, 0.0)) - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5);
        assert!((pose[1].apply_point(Vec3::new(3.0, 0.0, 0.0)) - Vec3::new(2.0, 1.0, 0.0)).length() < 1e-5);
        // The child bone (no tracks of its own) moves with its parent.
        assert!((pose[2].apply_point(Vec3::new(3.0, 0.0, 0.0)) - Vec3::new(2.0, 1.0, 0.0)).length() < 1e-5);
        // t = 5 wraps to frame 1: a half turn.
        assert!((anim.pose(5.0)[1].apply_point(Vec3::new(3.0, 0.0, 0.0)) - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-5);
    }

    #[test]
    fn trs_reproduces_the_frame() {
        let f = Frame::identity().translate(Vec3::new(1.0, 2.0, 3.0)).rotate(Quat::from_rotation_y(0.7)).scale(1.5);
        let m = f.reflect(Vec3::X);
        for g in [f, m] {
            let (t, r, s) = trs(&g);
            let x = Vec3::new(0.3, -0.2, 0.9);
            assert!((t + s * (r * x) - g.apply_point(x)).length() < 1e-5);
        }
    }
}
