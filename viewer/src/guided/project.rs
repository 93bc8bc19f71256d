//! Between the screen and the world: where a point is drawn (pixels, top-left
//! origin, as window events give them), the ray under a pixel, and the point under
//! a pixel on the plane through a given point facing the camera (the view plane
//! that control points are dragged in and strokes are drawn on).

use glam::{DMat4, DVec2, DVec3, DVec4, Mat4, Vec3};

/// A view and projection (Vulkan clip space: y down, depth 0…1) and the viewport
/// size in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenView {
    view_proj: DMat4,
    inverse: DMat4,
    eye: DVec3,
    /// Unit vector from the eye into the scene.
    forward: DVec3,
    pub width: f64,
    pub height: f64,
}

impl ScreenView {
    /// The view of a frame (`view` and `proj` as the renderer uses them, `eye` the
    /// camera position) in a `width` × `height` viewport.
    pub fn new(view: Mat4, proj: Mat4, eye: Vec3, width: u32, height: u32) -> ScreenView {
        let view_proj = proj.as_dmat4() * view.as_dmat4();
        let inverse = view_proj.inverse();
        // The camera looks along −z of its view space.
        let forward = view.as_dmat4().inverse().transform_vector3(DVec3::NEG_Z).normalize_or(DVec3::NEG_Z);
        ScreenView {
            view_proj,
            inverse,
            eye: eye.as_dvec3(),
            forward,
            width: width.max(1) as f64,
            height: height.max(1) as f64,
        }
    }

    /// The unit vector from the eye into the scene.
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// Where `p` is drawn, in pixels; `None` when it is behind the camera.
    pub fn to_screen(&self, p: DVec3) -> Option<DVec2> {
        let clip = self.view_proj * p.extend(1.0);
        if clip.w <= 1e-12 || !clip.is_finite() {
            return None;
        }
        let ndc = clip.truncate() / clip.w;
        Some(DVec2::new((ndc.x + 1.0) * 0.5 * self.width, (ndc.y + 1.0) * 0.5 * self.height))
    }

    /// The ray under pixel `px`: its origin (on the near plane) and unit direction.
    pub fn ray(&self, px: DVec2) -> (DVec3, DVec3) {
        let ndc = DVec2::new(px.x / self.width * 2.0 - 1.0, px.y / self.height * 2.0 - 1.0);
        let unproject = |z: f64| {
            let h: DVec4 = self.inverse * DVec4::new(ndc.x, ndc.y, z, 1.0);
            h.truncate() / h.w
        };
        let (near, far) = (unproject(0.0), unproject(1.0));
        let dir = (far - near).normalize_or(self.forward);
        (near, dir)
    }

    /// The point under pixel `px` on the plane through `through` that faces the
    /// camera; `None` if the ray runs parallel to it or the plane is behind the eye.
    pub fn on_view_plane(&self, px: DVec2, through: DVec3) -> Option<DVec3> {
        let (origin, dir) = self.ray(px);
        let denom = dir.dot(self.forward);
        if denom.abs() < 1e-12 || (through - self.eye).dot(self.forward) <= 0.0 {
            return None;
        }
        let t = (through - origin).dot(self.forward) / denom;
        let p = origin + dir * t;
        (t.is_finite() && p.is_finite()).then_some(p)
    }

    /// World units per pixel on the view plane through `p` (how far a one-pixel
    /// move there is).
    pub fn world_per_pixel(&self, p: DVec3) -> f64 {
        let c = self.to_screen(p).unwrap_or(DVec2::new(self.width * 0.5, self.height * 0.5));
        match (self.on_view_plane(c, p), self.on_view_plane(c + DVec2::X, p)) {
            (Some(a), Some(b)) => (b - a).length(),
            _ => 0.0,
        }
    }
}

/// The distance in pixels from `p` to the segment `a`–`b`.
pub fn distance_to_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - p).length()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::camera::OrbitCamera;

    /// Looking along +y at the xz-plane (the std guides' plane), 800 × 600: the view
    /// and its camera.
    pub(crate) fn front_view() -> (ScreenView, OrbitCamera) {
        let cam = OrbitCamera {
            target: Vec3::new(0.0, 0.0, 2.0),
            distance: 10.0,
            azimuth: 0.0,
            elevation: 0.0,
            fov_y: 40f32.to_radians(),
            radius: 3.0,
        };
        let aspect = 800.0 / 600.0;
        (ScreenView::new(cam.view(), cam.projection(aspect, 0.1, 100.0), cam.eye(), 800, 600), cam)
    }

    #[test]
    fn the_target_is_in_the_middle_and_up_is_up() {
        let (v, _) = front_view();
        let c = v.to_screen(DVec3::new(0.0, 0.0, 2.0)).expect("in front");
        assert!((c - DVec2::new(400.0, 300.0)).length() < 1e-6, "{c:?}");
        let up = v.to_screen(DVec3::new(0.0, 0.0, 3.0)).expect("in front");
        assert!(up.y < 300.0 && (up.x - 400.0).abs() < 1e-6, "{up:?}");
        // Seen from the front (azimuth 0, looking along +y), +x is to the right.
        let right = v.to_screen(DVec3::new(1.0, 0.0, 2.0)).expect("in front");
        assert!(right.x > 400.0);
        // Behind the eye: not drawn.
        assert!(v.to_screen(DVec3::new(0.0, -20.0, 2.0)).is_none());
    }

    #[test]
    fn a_pixel_on_the_view_plane_projects_back_to_itself() {
        let (v, _) = front_view();
        let through = DVec3::new(0.7, 1.0, 1.3);
        for px in [DVec2::new(10.0, 20.0), DVec2::new(400.0, 300.0), DVec2::new(731.5, 555.25)] {
            let p = v.on_view_plane(px, through).expect("on the plane");
            // On the plane: same depth along the view direction as `through`.
            assert!((p - through).dot(v.forward()).abs() < 1e-9);
            let back = v.to_screen(p).expect("in front");
            assert!((back - px).length() < 1e-6, "{px:?} -> {p:?} -> {back:?}");
        }
        // One pixel at the depth of the target spans 2·d·tan(fov/2) / height.
        let expected = 2.0 * 10.0 * (20f64.to_radians()).tan() / 600.0;
        let got = v.world_per_pixel(DVec3::new(0.0, 0.0, 2.0));
        assert!((got - expected).abs() < 1e-6 * expected, "{got} vs {expected}");
    }

    #[test]
    fn segment_distances() {
        let (a, b) = (DVec2::new(0.0, 0.0), DVec2::new(10.0, 0.0));
        assert_eq!(distance_to_segment(DVec2::new(5.0, 3.0), a, b), 3.0);
        assert_eq!(distance_to_segment(DVec2::new(-4.0, 3.0), a, b), 5.0);
        assert_eq!(distance_to_segment(DVec2::new(1.0, 1.0), a, a), 2f64.sqrt());
    }
}
