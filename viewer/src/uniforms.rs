//! The uniform blocks of docs/reference.md §13, laid out in std140/std430 bytes:
//! `Globals` (binding 0), `Bones` (binding 1) and `User` (binding 2).
//!
//! `uniform light_pos …` and `uniform spec_color_power …` set the `Globals` members
//! of those names; every other `uniform` is one `vec4` of `User`, in source order.
//! `uniform NAME RULE PROP` reads the frame of transform rule RULE at the current
//! time from the evaluation's animation tracks (frame ⌊t·fps⌋, wrapping like a
//! bone's). The VM samples a track only for rules used as bone or camera motions;
//! a rule used by nothing else has no track, and reads as the identity frame. The
//! tracks hold geometry only, so `color` and `weight` read the start colour
//! (1, 1, 1, 1) and zero weight. Bone matrices are the pose at the current time
//! (`mdg_vm::anim`), identities for an unanimated model.

use glam::{Mat4, Vec3};
use mdg_vm::anim::frame_index;
use mdg_vm::bundle::{Bundle, UniformSource};
use mdg_vm::geom::quat::Frame;
use mdg_vm::output::{Animation, Output};

/// Bytes of the `Globals` block: two mat4 and three vec4 (std140).
pub const GLOBALS_SIZE: usize = 2 * 64 + 3 * 16;

/// Default specular colour and Phong exponent.
pub const DEFAULT_SPEC_COLOR_POWER: [f32; 4] = [1.0, 1.0, 1.0, 32.0];

/// Where one uniform's value comes from, resolved against an evaluation.
#[derive(Clone, Debug, PartialEq)]
enum Source {
    Const([f32; 4]),
    /// A frame property; `track` indexes `Animation::tracks` (none: identity).
    Frame {
        track: Option<usize>,
        prop: u8,
    },
}

/// The `uniform` directives of a model, ready to be read at any time.
#[derive(Clone, Debug, PartialEq)]
pub struct UniformSpec {
    entries: Vec<(String, Source)>,
    fps: f32,
    normal: [f32; 3],
}

/// Uniform values at one time.
#[derive(Clone, Debug, PartialEq)]
pub struct UniformValues {
    /// `uniform light_pos`, if given.
    pub light_pos: Option<[f32; 4]>,
    /// `uniform spec_color_power`, if given.
    pub spec_color_power: Option<[f32; 4]>,
    /// Every other uniform, in order.
    pub user: Vec<(String, [f32; 4])>,
}

impl UniformSpec {
    /// Resolves the bundle's uniforms against the tracks of `output`.
    pub fn new(bundle: &Bundle, output: &Output) -> UniformSpec {
        let entries = bundle
            .uniforms
            .iter()
            .map(|u| {
                let source = match u.source {
                    UniformSource::Const(c) => Source::Const(c),
                    UniformSource::Frame { rule, prop } => {
                        let name = bundle.rules.get(rule as usize).map(|r| bundle.string(r.name)).unwrap_or("");
                        let track = output.animation.tracks.iter().position(|t| t.rule == name);
                        Source::Frame { track, prop }
                    }
                };
                (bundle.string(u.name).to_string(), source)
            })
            .collect();
        UniformSpec { entries, fps: bundle.settings.fps, normal: bundle.settings.normal }
    }

    /// The values at `time` seconds.
    pub fn values(&self, anim: &Animation, time: f32) -> UniformValues {
        let mut v = UniformValues { light_pos: None, spec_color_power: None, user: Vec::new() };
        let index = frame_index(time as f64, self.fps);
        for (name, source) in &self.entries {
            let value = match source {
                Source::Const(c) => *c,
                Source::Frame { track, prop } => {
                    let f = track.and_then(|k| anim.tracks.get(k)).map(|t| t.at(index)).unwrap_or_else(Frame::identity);
                    frame_property(&f, *prop, self.normal)
                }
            };
            match name.as_str() {
                "light_pos" => v.light_pos = Some(value),
                "spec_color_power" => v.spec_color_power = Some(value),
                _ => v.user.push((name.clone(), value)),
            }
        }
        v
    }
}

/// A frame property as a vec4 (`UNIFORM_PROPS` order: pos, dir, conj, color,
/// weight, normal).
fn frame_property(f: &Frame, prop: u8, normal: [f32; 3]) -> [f32; 4] {
    match prop {
        0 => [f.u.x, f.u.y, f.u.z, 1.0],
        1 => f.q.to_array(),
        2 => f.qh.to_array(),
        3 => mdg_vm::eval::START_COLOR,
        4 => [0.0; 4],
        _ => {
            let n = f.apply_normal(Vec3::from_array(normal));
            [n.x, n.y, n.z, 0.0]
        }
    }
}

/// The default light: a key light above the model, a little to the left of the
/// home view, at four radii from the model's centre. It is a fixed world position
/// (turning the model shows its shading change); from the home view a box shows
/// three distinct tones: top bright, front medium, right side darker. Reference §13
/// documents this default.
pub fn default_light(center: Vec3, radius: f32) -> [f32; 4] {
    let (az, el) = (crate::camera::HOME_AZIMUTH_DEG.to_radians(), crate::camera::HOME_ELEVATION_DEG.to_radians());
    // Towards the home camera, and the home view's screen-right direction.
    let toward = Vec3::new(el.cos() * az.sin(), -el.cos() * az.cos(), el.sin());
    let right = Vec3::Z.cross(toward).normalize_or(Vec3::X);
    let dir = (toward * 0.5 + Vec3::Z * 0.8 - right * 0.1).normalize_or(Vec3::Z);
    let p = center + dir * radius * 4.0;
    [p.x, p.y, p.z, 1.0]
}

fn push_mat(out: &mut Vec<u8>, m: &Mat4) {
    for x in m.to_cols_array() {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

fn push_vec4(out: &mut Vec<u8>, v: [f32; 4]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

/// The `Globals` block.
pub fn globals(
    projection: &Mat4,
    view: &Mat4,
    camera_pos: Vec3,
    light_pos: [f32; 4],
    spec_color_power: [f32; 4],
) -> Vec<u8> {
    let mut out = Vec::with_capacity(GLOBALS_SIZE);
    push_mat(&mut out, projection);
    push_mat(&mut out, view);
    push_vec4(&mut out, [camera_pos.x, camera_pos.y, camera_pos.z, 1.0]);
    push_vec4(&mut out, light_pos);
    push_vec4(&mut out, spec_color_power);
    out
}

/// The `User` block: one vec4 per user uniform (at least one vec4, so the buffer is
/// never empty).
pub fn user(values: &UniformValues) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 * values.user.len().max(1));
    for (_, v) in &values.user {
        push_vec4(&mut out, *v);
    }
    if out.is_empty() {
        push_vec4(&mut out, [0.0; 4]);
    }
    out
}

/// The `Bones` buffer at `time`: the pose of every bone, at least `n` matrices
/// (identities past the animation's bones).
pub fn bones(anim: &Animation, time: f32, n: u32) -> Vec<u8> {
    let pose = anim.pose(time as f64);
    let n = (n as usize).max(pose.len()).max(1);
    let mut out = Vec::with_capacity(64 * n);
    for i in 0..n {
        let m = pose.get(i).map(|f| f.to_mat4()).unwrap_or(Mat4::IDENTITY);
        push_mat(&mut out, &m);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globals_layout_is_std140() {
        let g = globals(
            &Mat4::IDENTITY,
            &Mat4::IDENTITY,
            Vec3::new(1.0, 2.0, 3.0),
            [4.0, 5.0, 6.0, 1.0],
            [1.0, 1.0, 1.0, 32.0],
        );
        assert_eq!(g.len(), GLOBALS_SIZE);
        let f = |i: usize| f32::from_le_bytes([g[i * 4], g[i * 4 + 1], g[i * 4 + 2], g[i * 4 + 3]]);
        assert_eq!((f(32), f(33), f(34), f(35)), (1.0, 2.0, 3.0, 1.0));
        assert_eq!(f(36), 4.0);
        assert_eq!(f(43), 32.0);
        assert_eq!(user(&UniformValues { light_pos: None, spec_color_power: None, user: vec![] }).len(), 16);
        assert_eq!(bones(&Animation::default(), 0.0, 3).len(), 192);
    }
}
