//! Shared helpers for the viewer tests: a validated Vulkan context (or a clear
//! failure saying how to get one), rendering a test grammar offscreen, and pixel
//! and geometry measurements.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use mdg_cli::toolchain::Toolchain;
use mdg_viewer::camera::OrbitCamera;
use mdg_viewer::context::{Context, ContextOptions, Validation};
use mdg_viewer::model::{LoadOptions, Loader as _, Model};
use mdg_viewer::offscreen::{self, Offscreen};
use mdg_viewer::program::Programs;
use mdg_viewer::renderer::{FrameParams, ModelInfo};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every std example (`std/examples/*.mdg`), sorted; at least 20.
pub fn std_examples() -> Vec<PathBuf> {
    let mut dir: Vec<PathBuf> = std::fs::read_dir(root().join("std/examples"))
        .expect("std/examples")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mdg"))
        .collect();
    dir.sort();
    assert!(dir.len() >= 20, "{dir:?}");
    dir
}

/// A test data file.
pub fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

/// Where tests write images for inspection.
pub fn out_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("viewer-tests");
    std::fs::create_dir_all(&d).expect("create test output directory");
    d
}

/// Whether the Vulkan tests are switched off (`MDG_SKIP_VULKAN_TESTS=1`).
pub fn skip_vulkan() -> bool {
    if std::env::var("MDG_SKIP_VULKAN_TESTS").as_deref() == Ok("1") {
        eprintln!("MDG_SKIP_VULKAN_TESTS=1: skipping a Vulkan test");
        return true;
    }
    false
}

/// A Vulkan context with validation required, or `None` when the Vulkan tests are
/// switched off. Panics with instructions when there is no Vulkan here.
pub fn vulkan() -> Option<Arc<Context>> {
    if skip_vulkan() {
        return None;
    }
    match Context::new(&ContextOptions {
        validation: Validation::Required,
        surface_extensions: vec![],
        on_message: Some(mdg_cli::say),
    }) {
        Ok(c) => Some(Arc::new(c)),
        Err(e) => panic!(
            "{e}\n\nThe viewer tests render with Vulkan and need a device and the validation layer: \
             run `bash .ci/run` (it installs lavapipe), or set MDG_SKIP_VULKAN_TESTS=1 to skip them."
        ),
    }
}

/// Test load options: std from the workspace.
pub fn load_options() -> LoadOptions {
    LoadOptions { std_dir: Some(root().join("std")), ..LoadOptions::default() }
}

/// The fallback programs, compiled from the workspace's std.
pub fn programs() -> Programs {
    match mdg_cli::toolchain::Toolchain.programs(Some(&root().join("std"))) {
        Ok(p) => p,
        Err(e) => panic!("the std programs do not compile: {e}"),
    }
}

/// Compiles and evaluates a test grammar.
pub fn load(path: &Path) -> Model {
    match Toolchain.load(path, &load_options()) {
        Ok((m, _)) => m,
        Err(f) => panic!("{} does not load:\n{}", path.display(), f.error),
    }
}

/// An RGBA8 image.
pub struct Image {
    pub px: Vec<u8>,
    pub w: u32,
    pub h: u32,
}

impl Image {
    pub fn at(&self, x: u32, y: u32) -> [u8; 4] {
        let i = ((y * self.w + x) * 4) as usize;
        [self.px[i], self.px[i + 1], self.px[i + 2], self.px[i + 3]]
    }

    pub fn save(&self, name: &str) -> PathBuf {
        let p = out_dir().join(name);
        offscreen::write_png(&p, &self.px, self.w, self.h).expect("write test image");
        p
    }

    /// Pixels (x, y, rgba) matching `f`.
    pub fn count(&self, f: impl Fn(u32, u32, [u8; 4]) -> bool) -> usize {
        let mut n = 0;
        for y in 0..self.h {
            for x in 0..self.w {
                if f(x, y, self.at(x, y)) {
                    n += 1;
                }
            }
        }
        n
    }
}

/// What a test render produced.
pub struct Render {
    pub image: Image,
    pub camera: OrbitCamera,
    pub info: ModelInfo,
}

/// Asserts the validation layer reported no errors so far.
pub fn assert_no_validation_errors(ctx: &Context) {
    let log = ctx.validation_log();
    assert_eq!(log.errors(), 0, "Vulkan validation errors:\n{}", log.error_messages().join("\n"));
}

/// Renders `model` from its home camera at `w` × `h`.
pub fn render_model(ctx: &Arc<Context>, model: &Model, w: u32, h: u32) -> Render {
    let mut off = Offscreen::new(ctx, w, h, 4).expect("offscreen target");
    let info = off.set_model(model, &programs()).expect("upload model");
    let camera = off.home_camera();
    let px = off.render(&FrameParams { camera, time: 0.0, wireframe: false, camera_rule: false }).expect("render");
    drop(off);
    assert_no_validation_errors(ctx);
    Render { image: Image { px, w, h }, camera, info }
}

/// Renders a test data grammar.
pub fn render(ctx: &Arc<Context>, name: &str, w: u32, h: u32) -> Render {
    render_model(ctx, &load(&data(name)), w, h)
}

/// Screen position (pixels, y down) of world point `p` for `camera`.
pub fn project(camera: &OrbitCamera, info: &ModelInfo, w: u32, h: u32, p: Vec3) -> (f32, f32) {
    let vp: Mat4 = camera.projection(w as f32 / h as f32, info.near, info.far) * camera.view();
    let c = vp * p.extend(1.0);
    let n = c.truncate() / c.w;
    // Vulkan: NDC y points down, like pixel rows.
    ((n.x * 0.5 + 0.5) * w as f32, (n.y * 0.5 + 0.5) * h as f32)
}

/// The 8 corners of an axis-aligned cube.
pub fn cube_corners(center: Vec3, side: f32) -> Vec<Vec3> {
    let h = side * 0.5;
    let mut v = Vec::new();
    for x in [-h, h] {
        for y in [-h, h] {
            for z in [-h, h] {
                v.push(center + Vec3::new(x, y, z));
            }
        }
    }
    v
}

/// Convex hull (counter-clockwise in y-down screen space does not matter here) of
/// points, by Andrew's monotone chain.
pub fn convex_hull(mut pts: Vec<(f32, f32)>) -> Vec<(f32, f32)> {
    pts.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let cross = |o: (f32, f32), a: (f32, f32), b: (f32, f32)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let mut lower: Vec<(f32, f32)> = Vec::new();
    for &p in &pts {
        while lower.len() >= 2 && cross(lower[lower.len() - 2], lower[lower.len() - 1], p) <= 0.0 {
            lower.pop();
        }
        lower.push(p);
    }
    let mut upper: Vec<(f32, f32)> = Vec::new();
    for &p in pts.iter().rev() {
        while upper.len() >= 2 && cross(upper[upper.len() - 2], upper[upper.len() - 1], p) <= 0.0 {
            upper.pop();
        }
        upper.push(p);
    }
    lower.pop();
    upper.pop();
    lower.extend(upper);
    lower
}

/// Area and perimeter of a polygon.
pub fn area_perimeter(poly: &[(f32, f32)]) -> (f32, f32) {
    let n = poly.len();
    let (mut a, mut p) = (0.0, 0.0);
    for i in 0..n {
        let (x0, y0) = poly[i];
        let (x1, y1) = poly[(i + 1) % n];
        a += x0 * y1 - x1 * y0;
        p += ((x1 - x0).powi(2) + (y1 - y0).powi(2)).sqrt();
    }
    (a.abs() * 0.5, p)
}

/// Whether (x, y) is inside a convex polygon (either winding).
pub fn inside(poly: &[(f32, f32)], x: f32, y: f32) -> bool {
    let n = poly.len();
    let mut sign = 0.0f32;
    for i in 0..n {
        let (x0, y0) = poly[i];
        let (x1, y1) = poly[(i + 1) % n];
        let c = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0);
        if c != 0.0 {
            if sign == 0.0 {
                sign = c.signum();
            } else if c.signum() != sign {
                return false;
            }
        }
    }
    true
}

/// Distance from (x, y) to the polygon's boundary.
pub fn edge_distance(poly: &[(f32, f32)], x: f32, y: f32) -> f32 {
    let n = poly.len();
    let mut best = f32::MAX;
    for i in 0..n {
        let (ax, ay) = poly[i];
        let (bx, by) = poly[(i + 1) % n];
        let (dx, dy) = (bx - ax, by - ay);
        let len2 = (dx * dx + dy * dy).max(1e-12);
        let t = (((x - ax) * dx + (y - ay) * dy) / len2).clamp(0.0, 1.0);
        let (px, py) = (ax + t * dx, ay + t * dy);
        best = best.min(((x - px).powi(2) + (y - py).powi(2)).sqrt());
    }
    best
}

/// Red dominates: the red cube's lit and shaded faces (specular highlights excepted).
pub fn reddish(c: [u8; 4]) -> bool {
    let (r, g, b) = (c[0] as i32, c[1] as i32, c[2] as i32);
    r >= 25 && r >= 2 * g.max(b) + 10
}

/// Blue dominates.
pub fn bluish(c: [u8; 4]) -> bool {
    let (r, g, b) = (c[0] as i32, c[1] as i32, c[2] as i32);
    b >= 25 && b >= 2 * r.max(g) + 10
}

/// Exactly the white background.
pub fn white(c: [u8; 4]) -> bool {
    c[0] == 255 && c[1] == 255 && c[2] == 255
}

/// The picture-equivalence metric of issue 37 (docs/viewer.md, "What the software
/// renderer costs"): how `other` differs from `reference` (the 4× picture).
/// Returns the mean absolute difference per channel (of 255) and the number of
/// pixels that differ by more than [`EQ_PIXEL`] in some channel although no pixel
/// within one pixel of them (their 3 × 3 neighbourhood) lies on an edge of the
/// reference — an edge pixel being one whose colour steps by more than [`EQ_EDGE`]
/// to a 4-neighbour.
pub fn off_edge_differences(reference: &Image, other: &Image) -> (f64, usize) {
    let (w, h) = (reference.w as i32, reference.h as i32);
    let step = |a: [u8; 4], b: [u8; 4]| (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0);
    let at = |img: &Image, x: i32, y: i32| img.at(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32);
    let edge = |x: i32, y: i32| {
        let c = at(reference, x, y);
        [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|(dx, dy)| step(c, at(reference, x + dx, y + dy)) > EQ_EDGE)
    };
    let mut off_edge = 0;
    for y in 0..h {
        for x in 0..w {
            if step(at(reference, x, y), at(other, x, y)) > EQ_PIXEL {
                let near = (-1..=1).any(|dy| (-1..=1).any(|dx| edge(x + dx, y + dy)));
                if !near {
                    off_edge += 1;
                }
            }
        }
    }
    let total: u64 = reference.px.iter().zip(&other.px).map(|(a, b)| u64::from(a.abs_diff(*b))).sum();
    (total as f64 / reference.px.len().max(1) as f64, off_edge)
}

/// A pixel "differs" when a channel moves by more than this (of 255).
pub const EQ_PIXEL: u8 = 8;
/// A reference pixel is on an edge when a channel steps by more than this to a
/// neighbour.
pub const EQ_EDGE: u8 = 16;
/// The most pixels of a picture that may differ off the reference's edges: 0.5 %.
pub const EQ_OFF_EDGE_SHARE: f64 = 0.005;
/// The largest mean difference per channel, of 255, of the smoothed picture (the
/// default on a CPU driver; measured at most 2.3, guided_tree's 1-pixel guide lines)…
pub const EQ_MEAN: f64 = 3.0;
/// …and of the aliased one (`--samples 1`; measured at most 3.1, the same lines).
pub const EQ_MEAN_ALIASED: f64 = 4.0;
