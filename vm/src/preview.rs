//! A software preview renderer: an `Output` to a PNG without a GPU.
//!
//! `mdg-run --png` uses it so every machine can write a picture; the Vulkan viewer
//! (`viewer/`) is the real renderer. The camera frames the model's bounding sphere
//! from a three-quarter view; faces are lit with two-sided Lambert + ambient using the
//! vertex colours; pen lines are drawn as one-pixel lines. 2×2 supersampling.

use crate::output::Output;
use glam::{Vec3, Vec4};

/// Preview settings.
#[derive(Clone, Copy, Debug)]
pub struct PreviewOptions {
    pub width: u32,
    pub height: u32,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    /// Camera azimuth around the vertical axis, degrees.
    pub azimuth_deg: f32,
    /// Camera elevation, degrees.
    pub elevation_deg: f32,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions { width: 800, height: 600, fov_deg: 40.0, azimuth_deg: 35.0, elevation_deg: 25.0 }
    }
}

/// Renders to RGBA8 pixels (row-major, top row first).
pub fn render(out: &Output, opts: &PreviewOptions) -> Vec<u8> {
    let ss = 2u32;
    let (w, h) = (opts.width * ss, opts.height * ss);
    // World-space triangles are produced on the fly (instances are not flattened into
    // one mesh, which for thousands of isosurface instances would cost gigabytes).
    let mut pts: Vec<Vec3> = Vec::new();
    for_each_triangle(out, &mut |t| pts.extend_from_slice(&[t.p[0], t.p[1], t.p[2]]));
    pts.extend(out.lines.iter().flat_map(|l| l.points.iter().map(|p| Vec3::from_array(*p))));
    let (lo, hi) = pts.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
    let (center, radius) =
        if pts.is_empty() { (Vec3::ZERO, 1.0) } else { ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-4)) };
    // Z is up in MDG models by convention of the examples; view from the front-right.
    // A flat model in the xy-plane (curves, tilings) is shown from above.
    let flat = out.flat || (hi.z - lo.z) < radius * 0.01;
    let el_deg = if flat { 89.0 } else { opts.elevation_deg };
    let az_deg = if flat { 0.0 } else { opts.azimuth_deg };
    let (az, el) = (az_deg.to_radians(), el_deg.to_radians());
    let dir = Vec3::new(el.cos() * az.sin(), -el.cos() * az.cos(), el.sin());
    let fov = opts.fov_deg.to_radians();
    let dist = radius / (fov * 0.5).sin() * 1.05;
    let eye = center + dir * dist;
    let view = glam::camera::rh::view::look_at_mat4(eye, center, Vec3::Z);
    let proj = glam::camera::rh::proj::directx::perspective(
        fov,
        w as f32 / h as f32,
        (dist - radius * 1.5).max(dist * 1e-3),
        dist + radius * 1.5,
    );
    let vp = proj * view;
    let bg = out.background;
    let mut color = vec![[bg[0], bg[1], bg[2]]; (w * h) as usize];
    let mut depth = vec![f32::INFINITY; (w * h) as usize];
    let to_screen = |p: Vec3| -> Option<Vec3> {
        let c: Vec4 = vp * p.extend(1.0);
        if c.w <= 1e-6 {
            return None;
        }
        let n = c.truncate() / c.w;
        Some(Vec3::new((n.x * 0.5 + 0.5) * w as f32, (1.0 - (n.y * 0.5 + 0.5)) * h as f32, n.z))
    };
    let light = (dir + Vec3::new(0.3, -0.2, 0.6)).normalize();
    let mut raster = |t: Tri| {
        let p = t.p;
        let Some(s) = p.iter().map(|x| to_screen(*x)).collect::<Option<Vec<_>>>() else { return };
        let face_n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let shade = |i: usize| -> [f32; 3] {
            let mut n = t.n[i];
            if n.dot(face_n) < 0.0 {
                n = -n;
            }
            if n.dot(eye - p[i]) < 0.0 {
                n = -n;
            }
            let lam = n.dot(light).max(0.0);
            let c = t.c[i];
            // `flat`: unlit, the colour as given.
            let k = if out.flat { 1.0 } else { 0.25 + 0.75 * lam };
            [c[0] * k, c[1] * k, c[2] * k]
        };
        let cs = [shade(0), shade(1), shade(2)];
        let min_x = s.iter().map(|v| v.x).fold(f32::MAX, f32::min).floor().max(0.0) as i64;
        let max_x = s.iter().map(|v| v.x).fold(f32::MIN, f32::max).ceil().min(w as f32 - 1.0) as i64;
        let min_y = s.iter().map(|v| v.y).fold(f32::MAX, f32::min).floor().max(0.0) as i64;
        let max_y = s.iter().map(|v| v.y).fold(f32::MIN, f32::max).ceil().min(h as f32 - 1.0) as i64;
        let area = (s[1].x - s[0].x) * (s[2].y - s[0].y) - (s[2].x - s[0].x) * (s[1].y - s[0].y);
        if area.abs() < 1e-12 {
            return;
        }
        for y in min_y..=max_y {
            for x in min_x..=max_x {
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let e = |a: Vec3, b: Vec3| (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
                let (w0, w1, w2) = (e(s[1], s[2]) / area, e(s[2], s[0]) / area, e(s[0], s[1]) / area);
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * s[0].z + w1 * s[1].z + w2 * s[2].z;
                let i = (y as u32 * w + x as u32) as usize;
                // `flat`: painted in triangle order, later on top (no depth test).
                if out.flat || z < depth[i] {
                    depth[i] = z;
                    color[i] = std::array::from_fn(|k| w0 * cs[0][k] + w1 * cs[1][k] + w2 * cs[2][k]);
                }
            }
        }
    };
    for_each_triangle(out, &mut raster);
    // Pen lines, when nothing was swept along them.
    if out.sweeps.triangles.is_empty() {
        let ink = if bg[0] + bg[1] + bg[2] > 1.5 { [0.1, 0.1, 0.1] } else { [0.9, 0.9, 0.9] };
        for l in &out.lines {
            for seg in l.points.windows(2) {
                let (Some(a), Some(b)) = (to_screen(Vec3::from_array(seg[0])), to_screen(Vec3::from_array(seg[1])))
                else {
                    continue;
                };
                let n = ((b - a).truncate().length() as usize).clamp(1, 20_000);
                for k in 0..=n {
                    let p = a.lerp(b, k as f32 / n as f32);
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (x, y) = (p.x as i64 + dx, p.y as i64 + dy);
                        if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                            let i = (y as u32 * w + x as u32) as usize;
                            if p.z <= depth[i] + 1e-3 {
                                color[i] = ink;
                            }
                        }
                    }
                }
            }
        }
    }
    let mut rgba = Vec::with_capacity((opts.width * opts.height * 4) as usize);
    for y in 0..opts.height {
        for x in 0..opts.width {
            let mut acc = [0.0f32; 3];
            for sy in 0..ss {
                for sx in 0..ss {
                    let c = color[((y * ss + sy) * w + x * ss + sx) as usize];
                    for k in 0..3 {
                        acc[k] += c[k];
                    }
                }
            }
            for a in acc {
                rgba.push((a / (ss * ss) as f32 * 255.0).round().clamp(0.0, 255.0) as u8);
            }
            rgba.push(255);
        }
    }
    rgba
}

/// One world-space triangle with per-corner normals and colours, winding corrected.
struct Tri {
    p: [Vec3; 3],
    n: [Vec3; 3],
    c: [[f32; 4]; 3],
}

/// Calls `f` for every triangle of the output: VERTEX mesh, sweeps, then each
/// instance's shared mesh transformed into place.
fn for_each_triangle(out: &Output, f: &mut dyn FnMut(Tri)) {
    let _ = out.for_each_piece::<()>(crate::output::Groups::ALL, |p| {
        let m = p.mesh;
        for k in p.triangles.clone() {
            let t = m.triangles[k];
            let mirrored = m.mirrored.get(k).copied().unwrap_or(false);
            let i = if mirrored { [t[0], t[2], t[1]] } else { t }.map(|i| i as usize);
            if i.iter().any(|&j| j >= m.positions.len() || j >= m.normals.len() || j >= m.colors.len()) {
                continue;
            }
            f(Tri {
                p: i.map(|j| Vec3::from_array(m.positions[j])),
                n: i.map(|j| Vec3::from_array(m.normals[j])),
                c: i.map(|j| m.colors[j]),
            });
        }
        Ok(())
    });
}

/// Encodes RGBA8 pixels as PNG bytes; the encoder's error when the pixels do not
/// fill `width × height` (or the size is one PNG cannot hold).
pub fn encode_png(rgba: &[u8], width: u32, height: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut buf = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut buf, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        // fdeflate: several times faster than the default level on renders, files a
        // little larger.
        enc.set_compression(png::Compression::Fast);
        let mut writer = enc.write_header()?;
        writer.write_image_data(rgba)?;
    }
    Ok(buf)
}
