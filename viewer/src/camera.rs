//! The orbit camera: frames a bounding sphere, orbits around its target, pans and
//! zooms; builds the view and (Vulkan clip space) projection matrices.
//!
//! Z is up, as in the std examples and the software preview; the home view looks
//! from the front right (azimuth 35°, elevation 25°), and flat models (curves,
//! tilings in the xy-plane) are seen from above.

use crate::scene::Bounds;
use glam::{Mat4, Vec3};

/// Home azimuth, degrees.
pub const HOME_AZIMUTH_DEG: f32 = 35.0;
/// Home elevation, degrees.
pub const HOME_ELEVATION_DEG: f32 = 25.0;

/// A view given on the command line (`--camera AZ,EL[,ZOOM]`): degrees around +z
/// and above the xy-plane, and a zoom factor over the framed distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub azimuth_deg: f32,
    pub elevation_deg: f32,
    pub zoom: f32,
}

impl std::str::FromStr for Pose {
    type Err = String;

    /// `AZ,EL` or `AZ,EL,ZOOM`, e.g. `35,25` (the home view) or `0,90,2`.
    fn from_str(s: &str) -> Result<Pose, String> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let num = |t: &str| t.parse::<f32>().ok().filter(|v| v.is_finite());
        let bad = || format!("`{s}`: expected AZ,EL or AZ,EL,ZOOM in degrees (e.g. 35,25 or 0,90,2)");
        match parts.as_slice() {
            [a, e] | [a, e, _] => {
                let zoom = match parts.get(2) {
                    Some(z) => num(z).filter(|z| *z > 0.0).ok_or_else(bad)?,
                    None => 1.0,
                };
                Ok(Pose { azimuth_deg: num(a).ok_or_else(bad)?, elevation_deg: num(e).ok_or_else(bad)?, zoom })
            }
            _ => Err(bad()),
        }
    }
}

/// An orbit camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    pub target: Vec3,
    pub distance: f32,
    /// Radians around +z, 0 looking along +y.
    pub azimuth: f32,
    /// Radians above the xy-plane.
    pub elevation: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Radius of the framed sphere (for near/far and pan speed).
    pub radius: f32,
}

impl OrbitCamera {
    /// The home view of `bounds` for a viewport of aspect `aspect` (width / height),
    /// `fov_deg` the vertical field of view.
    pub fn framing(bounds: &Bounds, fov_deg: f32, aspect: f32) -> OrbitCamera {
        OrbitCamera::framing_art(bounds, fov_deg, aspect, false)
    }

    /// [`OrbitCamera::framing`], looking straight down z with y up (as Context Free
    /// shows a design) when `flat_art` (the grammar's `flat` directive) whatever
    /// the model's depth.
    pub fn framing_art(bounds: &Bounds, fov_deg: f32, aspect: f32, flat_art: bool) -> OrbitCamera {
        let (az, el) = if flat_art {
            (0.0, 89.9)
        } else if bounds.is_flat() {
            (0.0, 89.0)
        } else {
            (HOME_AZIMUTH_DEG, HOME_ELEVATION_DEG)
        };
        let mut c = OrbitCamera {
            target: Vec3::ZERO,
            distance: 1.0,
            azimuth: az.to_radians(),
            elevation: el.to_radians(),
            fov_y: fov_deg.clamp(1.0, 170.0).to_radians(),
            radius: 1.0,
        };
        c.frame(bounds, aspect);
        c
    }

    /// This camera seen from azimuth `az_deg` and elevation `el_deg` (degrees, as
    /// [`HOME_AZIMUTH_DEG`]), framed again, then moved `zoom` times closer (1 = framed).
    pub fn posed(mut self, bounds: &Bounds, aspect: f32, pose: Pose) -> OrbitCamera {
        self.azimuth = pose.azimuth_deg.to_radians();
        self.elevation = pose.elevation_deg.clamp(-89.9, 89.9).to_radians();
        self.frame(bounds, aspect);
        self.distance /= pose.zoom.max(1e-3);
        self
    }

    /// Keeps the direction, moves so the bounding sphere fills the view.
    pub fn frame(&mut self, bounds: &Bounds, aspect: f32) {
        let (center, radius) = bounds.sphere();
        self.target = center;
        self.radius = radius;
        // The narrower of the two fields of view decides.
        let half_y = self.fov_y * 0.5;
        let half_x = (half_y.tan() * aspect.max(1e-3)).atan();
        let half = half_y.min(half_x);
        self.distance = radius / half.sin() * 1.05;
    }

    /// Unit vector from the target to the eye.
    pub fn direction(&self) -> Vec3 {
        let (el, az) = (self.elevation, self.azimuth);
        Vec3::new(el.cos() * az.sin(), -el.cos() * az.cos(), el.sin())
    }

    pub fn eye(&self) -> Vec3 {
        self.target + self.direction() * self.distance
    }

    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye(), self.target, Vec3::Z)
    }

    /// Near and far planes: the grammar's (`cameranearplane`, `camerafarplane`)
    /// unless they would clip the framed sphere.
    pub fn planes(&self, near: f32, far: f32) -> (f32, f32) {
        let min_near = (self.distance - self.radius * 1.5).max(self.distance * 1e-3);
        let max_far = self.distance + self.radius * 1.5;
        let n = if near > 0.0 { near.min(min_near) } else { min_near };
        let f = far.max(max_far).max(n * 2.0);
        (n, f)
    }

    /// Perspective projection into Vulkan clip space (y down, depth 0..1).
    pub fn projection(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        let (n, f) = self.planes(near, far);
        let mut p = glam::camera::rh::proj::directx::perspective(self.fov_y, aspect.max(1e-3), n, f);
        // Vulkan's clip space has y pointing down; flipping here keeps the image
        // upright and counter-clockwise faces front-facing.
        p.y_axis.y = -p.y_axis.y;
        p
    }

    /// Orbits by (dx, dy) radians.
    pub fn orbit(&mut self, dx: f32, dy: f32) {
        self.azimuth = (self.azimuth - dx).rem_euclid(std::f32::consts::TAU);
        let lim = 89.5f32.to_radians();
        self.elevation = (self.elevation + dy).clamp(-lim, lim);
    }

    /// Pans by (dx, dy) in viewport heights (1.0 = the whole view height).
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let dir = self.direction();
        let right = Vec3::Z.cross(dir).normalize_or(Vec3::X);
        let up = dir.cross(right).normalize_or(Vec3::Z);
        let scale = 2.0 * self.distance * (self.fov_y * 0.5).tan();
        self.target += (-right * dx + up * dy) * scale;
    }

    /// Multiplies the distance by `factor` (< 1 zooms in).
    pub fn zoom(&mut self, factor: f32) {
        self.distance = (self.distance * factor).clamp(self.radius * 1e-3, self.radius * 1e4);
    }
}

/// The view and projection of a frame, and the eye: the orbit camera (`planes`, the
/// grammar's near and far planes, kept unless they clip the model), or, when
/// `rule_at` is a time and the animation has a camera rule, that rule at that time
/// (looking along its −z with +y up). Shared by the Vulkan renderer and
/// the CPU renderer ([`crate::cpu`]), so both frame a picture alike.
pub fn frame_view_projection(
    camera: &OrbitCamera,
    rule_at: Option<f32>,
    animation: Option<&mdg_vm::output::Animation>,
    planes: (f32, f32),
    aspect: f32,
) -> (Mat4, Mat4, Vec3) {
    if let (Some(time), Some(anim)) = (rule_at, animation) {
        if let (Some(cam), Some(f)) = (&anim.camera, anim.camera_at(time as f64)) {
            let (t, r, _) = mdg_vm::anim::trs(&f);
            let view = Mat4::from_rotation_translation(r, t).inverse();
            let near = cam.near.max(1e-4);
            let far = cam.far.max(near * 2.0);
            let mut proj =
                glam::camera::rh::proj::directx::perspective(cam.fov.clamp(1.0, 170.0).to_radians(), aspect, near, far);
            proj.y_axis.y = -proj.y_axis.y;
            return (view, proj, t);
        }
    }
    (camera.view(), camera.projection(aspect, planes.0, planes.1), camera.eye())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_puts_the_sphere_inside_the_view() {
        let b = Bounds { lo: Vec3::splat(-1.0), hi: Vec3::splat(1.0) };
        let c = OrbitCamera::framing(&b, 40.0, 1.0);
        let (center, r) = b.sphere();
        assert!((c.target - center).length() < 1e-6);
        // The sphere's angular radius is at most half the field of view.
        assert!((r / c.distance).asin() <= c.fov_y * 0.5 + 1e-6);
        let vp = c.projection(1.0, 0.1, 1000.0) * c.view();
        let clip = vp * center.extend(1.0);
        let ndc = clip.truncate() / clip.w;
        assert!(ndc.x.abs() < 1e-4 && ndc.y.abs() < 1e-4 && (0.0..1.0).contains(&ndc.z));
        // +z (up in the world) is up on screen: negative y in Vulkan clip space.
        let top = vp * (center + Vec3::Z * 0.5).extend(1.0);
        assert!(top.y / top.w < 0.0);
    }

    #[test]
    fn near_and_far_never_clip_the_model() {
        let b = Bounds { lo: Vec3::splat(-500.0), hi: Vec3::splat(500.0) };
        let c = OrbitCamera::framing(&b, 40.0, 1.0);
        let (n, f) = c.planes(0.1, 1000.0);
        assert!(n <= 0.1 && f >= c.distance + c.radius);
    }
}
