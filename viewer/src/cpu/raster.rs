//! The CPU renderer's rasteriser: triangles, point sprites and lines into one
//! thread's share of the picture (its row strips), with a depth buffer, at 1 or 4
//! samples a pixel, shaded as std's `phong_fs` (or unlit) computes it.
//!
//! Coverage follows Vulkan's rules as lavapipe applies them: vertices snapped to
//! 1/256 pixel ([`SUB`]), samples at pixel centres (1×) or the standard 4× pattern,
//! edge functions in exact integer arithmetic, a sample on an edge covered only by
//! the triangle to its top or left. Depth is `z/w` interpolated linearly on the
//! screen and tested `LESS_OR_EQUAL`; colours are interpolated perspective-correct
//! and shaded once per pixel at its centre (as a fragment shader without sample
//! shading runs), then blended (`SRC_ALPHA`, `ONE_MINUS_SRC_ALPHA`) into every
//! covered sample.

use glam::{Vec3, Vec4};

/// A vertex on the screen ([`Target::snap`]): x and y in [`SUB`] units, depth, 1/w.
pub type Snapped = (i64, i64, f32, f32);

/// Whether a clip position is inside the clip volume and the guard band (a
/// triangle of such vertices is rasterised without clipping).
#[inline]
pub fn inside(p: Vec4) -> bool {
    p.w > 0.0 && p.z >= 0.0 && p.z <= p.w && p.x.abs() <= GUARD * p.w && p.y.abs() <= GUARD * p.w && p.is_finite()
}

/// Sub-pixel steps per pixel: vertices are snapped to 1/256 pixel.
pub const SUB: i64 = 256;
/// Rows per strip: thread `t` of `n` owns the strips `k` with `k % n == t`, so the
/// work of a picture spreads evenly whatever part of it the model covers.
pub const STRIP: u32 = 8;
/// Where the guard band ends, in multiples of `w`: triangles reaching farther are
/// clipped (the fixed-point edge functions stay far from overflow).
const GUARD: f32 = 16.0;

/// Sample offsets from the pixel's corner, in [`SUB`] units: the centre at 1×,
/// Vulkan's standard pattern at 4×.
const ONE: [(i64, i64); 1] = [(128, 128)];
const FOUR: [(i64, i64); 4] = [(96, 32), (224, 96), (32, 160), (160, 224)];

/// One vertex after the vertex stage: clip position and the fragment shader's
/// inputs (world position, normal, colour, matte).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct V {
    pub clip: Vec4,
    pub world: Vec3,
    pub normal: Vec3,
    pub color: Vec4,
    pub matte: f32,
}

impl V {
    fn lerp(&self, o: &V, t: f32) -> V {
        V {
            clip: self.clip + (o.clip - self.clip) * t,
            world: self.world + (o.world - self.world) * t,
            normal: self.normal + (o.normal - self.normal) * t,
            color: self.color + (o.color - self.color) * t,
            matte: self.matte + (o.matte - self.matte) * t,
        }
    }
}

/// How fragments are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shade {
    /// std's `phong_fs`.
    Phong,
    /// The colour as given (the flat-art and pen-line program).
    Unlit,
}

/// What every primitive of a frame shares: the light and the eye, for `phong_fs`.
#[derive(Clone, Copy, Debug)]
pub struct Lighting {
    pub eye: Vec3,
    pub light: Vec3,
    pub spec: [f32; 4],
}

/// std's `phong_fs`: position `p`, interpolated normal `n`, colour `c`, matte,
/// facing the viewer or not.
pub fn phong(l: &Lighting, p: Vec3, n: Vec3, c: Vec4, matte: f32, front: bool) -> Vec4 {
    let mut normal = n.normalize_or_zero();
    if !front {
        normal = -normal;
    }
    let light_dir = (l.light - p).normalize_or_zero();
    let lambertian = light_dir.dot(normal).max(0.0);
    let mut specular = 0.0;
    if lambertian > 0.0 && matte < 0.5 {
        let reflect_dir = -light_dir - 2.0 * normal.dot(-light_dir) * normal;
        let view_dir = (l.eye - p).normalize_or_zero();
        specular = reflect_dir.dot(view_dir).max(0.0).powf(l.spec[3]);
    }
    let rgb = (0.15 + 0.85 * lambertian) * c.truncate() + specular * Vec3::new(l.spec[0], l.spec[1], l.spec[2]);
    rgb.extend(c.w)
}

/// `x` rounded to the nearest integer (halves up), without a libm call; `x` is
/// finite and within ±2^31 (the guard band keeps it so).
#[inline]
fn round_i64(x: f32) -> i64 {
    let y = x + 0.5;
    let t = y as i64;
    if (t as f32) > y {
        t - 1
    } else {
        t
    }
}

/// `x` rounded down, without a libm call (as `round_i64`).
#[inline]
pub fn floor_i64(x: f32) -> i64 {
    let t = x as i64;
    if (t as f32) > x {
        t - 1
    } else {
        t
    }
}

fn unorm(x: f32) -> u8 {
    // (NaN becomes 0, as `as` saturates it.)
    // (x ≥ 0 after the clamp: adding a half and truncating rounds it.)
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// `src` blended over `dst` (`SRC_ALPHA`, `ONE_MINUS_SRC_ALPHA`; alpha `ONE`,
/// `ONE_MINUS_SRC_ALPHA`), stored as 8-bit.
fn blend(src: Vec4, dst: [u8; 4]) -> [u8; 4] {
    let a = src.w.clamp(0.0, 1.0);
    if a >= 1.0 {
        return [unorm(src.x), unorm(src.y), unorm(src.z), 255];
    }
    let d = |k: usize| f32::from(dst[k]) / 255.0;
    let c = |s: f32, k: usize| unorm(s.clamp(0.0, 1.0) * a + d(k) * (1.0 - a));
    [c(src.x, 0), c(src.y, 1), c(src.z, 2), unorm(a + d(3) * (1.0 - a))]
}

/// A point sprite on a `width` × `height` picture: the square it covers (pixels)
/// and its depth ([`point_setup`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSetup {
    pub x0: f32,
    pub x1: f32,
    pub y0: f32,
    pub y1: f32,
    pub z: f32,
}

/// A point sprite of centre `clip`, `size` pixels wide (at least one, as lavapipe
/// (llvmpipe's point setup) draws them), on a `width` × `height` picture; `None`
/// when its centre is outside the clip volume, as Vulkan clips points.
#[inline]
pub fn point_setup(clip: Vec4, size: f32, width: u32, height: u32) -> Option<PointSetup> {
    let c = clip;
    if !(c.w > 0.0 && c.z >= 0.0 && c.z <= c.w && c.x.abs() <= c.w && c.y.abs() <= c.w) {
        return None;
    }
    let (w, h) = (width as f32, height as f32);
    let sx = (c.x / c.w + 1.0) * 0.5 * w;
    let sy = (c.y / c.w + 1.0) * 0.5 * h;
    let z = c.z / c.w;
    let half = 0.5 * size.max(1.0);
    Some(PointSetup { x0: sx - half, x1: sx + half, y0: sy - half, y1: sy + half, z })
}

/// An 8-bit colour as the blending reads it.
#[inline]
pub fn unorm_color(rgba: [u8; 4]) -> Vec4 {
    Vec4::new(
        f32::from(rgba[0]) / 255.0,
        f32::from(rgba[1]) / 255.0,
        f32::from(rgba[2]) / 255.0,
        f32::from(rgba[3]) / 255.0,
    )
}

/// One thread's part of the picture: the row strips it owns, every sample's colour
/// and depth. Aligned to 128 bytes (two cache lines): the targets of the threads lie
/// side by side in one `Vec`, and `triangles` changes per primitive drawn, so no two
/// threads may share a line.
#[repr(align(128))]
pub struct Target {
    pub thread: u32,
    pub threads: u32,
    pub width: u32,
    pub height: u32,
    pub samples: usize,
    /// Per owned row (in order), per pixel, per sample.
    pub color: Vec<[u8; 4]>,
    depth: Vec<f32>,
    pub lighting: Lighting,
    pub shade: Shade,
    /// Depth-test and write (off for flat art: painted in order).
    pub depth_test: bool,
    /// Primitives this thread rasterised (triangles, points) that had a sample in
    /// its strips.
    pub triangles: u64,
    /// Per row of the picture: its place among this thread's rows, or
    /// [`NOT_MINE`] (no division by the thread count per pixel).
    slot: Vec<u32>,
}

/// [`Target`]'s slot of a row another thread owns.
const NOT_MINE: u32 = u32::MAX;

impl Target {
    /// The target of thread `thread` of `threads`, cleared to `background`.
    pub fn new(thread: u32, threads: u32, width: u32, height: u32, samples: usize, background: [u8; 4]) -> Target {
        let mut rows = 0;
        let slot: Vec<u32> = (0..height)
            .map(|y| {
                if (y / STRIP) % threads == thread {
                    rows += 1;
                    rows - 1
                } else {
                    NOT_MINE
                }
            })
            .collect();
        let n = rows as usize * width as usize * samples;
        Target {
            thread,
            threads,
            width,
            height,
            samples,
            color: vec![background; n],
            depth: vec![1.0; n],
            lighting: Lighting { eye: Vec3::ZERO, light: Vec3::ZERO, spec: [0.0; 4] },
            shade: Shade::Phong,
            depth_test: true,
            triangles: 0,
            slot,
        }
    }

    #[inline]
    pub fn owns(&self, y: u32) -> bool {
        self.slot.get(y as usize).is_some_and(|&s| s != NOT_MINE)
    }

    /// The first sample of pixel (x, y), a row this thread owns.
    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        let row = self.slot.get(y as usize).copied().unwrap_or(NOT_MINE);
        (row as usize * self.width as usize + x as usize) * self.samples
    }

    /// Whether any row in `y0..=y1` (clamped to the picture) is this thread's.
    pub fn any_row(&self, y0: i64, y1: i64) -> bool {
        let (y0, y1) = (y0.max(0), y1.min(i64::from(self.height) - 1));
        if y0 > y1 {
            return false;
        }
        if (y1 - y0) as u32 >= STRIP * self.threads {
            return true;
        }
        self.slot.get(y0 as usize..=y1 as usize).is_some_and(|r| r.iter().any(|&s| s != NOT_MINE))
    }

    /// The rows of `y0..=y1` (clamped) this thread owns (an iterator that does not
    /// borrow the target, so the rows can be drawn while it runs).
    fn rows(&self, y0: i64, y1: i64) -> impl Iterator<Item = u32> + use<> {
        let (thread, threads) = (self.thread, self.threads);
        let (y0, y1) = (y0.max(0), y1.min(i64::from(self.height) - 1));
        let range = if y0 > y1 { 0..0 } else { y0 as u32..y1 as u32 + 1 };
        range.filter(move |&y| (y / STRIP) % threads == thread)
    }

    fn offsets(&self) -> &'static [(i64, i64)] {
        if self.samples == 4 {
            &FOUR
        } else {
            &ONE
        }
    }

    /// Writes `color` into sample `k` of the pixel at `i` if it passes the depth test.
    #[inline]
    fn write(&mut self, i: usize, z: f32, color: Vec4, depth_write: bool) {
        self.write_with(i, z, depth_write, |c: &mut [u8; 4]| *c = blend(color, *c));
    }

    /// [`Target::write`] with `paint` for what the sample gets.
    #[inline(always)]
    fn write_with(&mut self, i: usize, z: f32, depth_write: bool, paint: impl Fn(&mut [u8; 4])) {
        let (Some(d), Some(c)) = (self.depth.get_mut(i), self.color.get_mut(i)) else { return };
        if self.depth_test {
            // (A NaN depth fails the test.)
            if z.partial_cmp(d).is_none_or(|o| o == std::cmp::Ordering::Greater) {
                return;
            }
            if depth_write {
                *d = z;
            }
        }
        paint(c);
    }

    /// Rasterises a triangle (clipped when it leaves the clip volume or the guard
    /// band); `cull_back` skips it when it faces away.
    pub fn triangle(&mut self, v: [V; 3], cull_back: bool) {
        if v.iter().all(|x| inside(x.clip)) {
            self.clipped(v, cull_back);
            return;
        }
        // Sutherland–Hodgman against the near and far planes and the guard band.
        let planes: [fn(Vec4) -> f32; 6] = [
            |p| p.z,
            |p| p.w - p.z,
            |p| GUARD * p.w - p.x,
            |p| GUARD * p.w + p.x,
            |p| GUARD * p.w - p.y,
            |p| GUARD * p.w + p.y,
        ];
        let mut poly: Vec<V> = v.to_vec();
        for plane in planes {
            let mut next = Vec::with_capacity(poly.len() + 2);
            for (k, a) in poly.iter().enumerate() {
                let b = &poly[(k + 1) % poly.len()];
                let (da, db) = (plane(a.clip), plane(b.clip));
                if !(da.is_finite() && db.is_finite()) {
                    return;
                }
                if da >= 0.0 {
                    next.push(*a);
                }
                if (da >= 0.0) != (db >= 0.0) {
                    next.push(a.lerp(b, da / (da - db)));
                }
            }
            poly = next;
            if poly.len() < 3 {
                return;
            }
        }
        for k in 1..poly.len() - 1 {
            self.clipped([poly[0], poly[k], poly[k + 1]], cull_back);
        }
    }

    /// A vertex inside the clip volume and guard band on the screen: where it snaps
    /// (in [`SUB`] units), its depth and 1/w.
    #[inline]
    pub fn snap(&self, clip: Vec4) -> Snapped {
        let (w, h) = (self.width as f32, self.height as f32);
        let iw = 1.0 / clip.w;
        let sx = (clip.x * iw + 1.0) * 0.5 * w;
        let sy = (clip.y * iw + 1.0) * 0.5 * h;
        (round_i64(sx * SUB as f32), round_i64(sy * SUB as f32), clip.z * iw, iw)
    }

    /// Whether the triangle snapped to `p` covers no sample of the picture: its box
    /// holds none (the small shapes of flat art, most of a fractal's). The samples lie
    /// on a lattice: the pixel centres at 1×, every quarter pixel from 1/8 at 4×.
    #[inline]
    pub fn misses_every_sample(&self, p: &[Snapped; 3]) -> bool {
        let (x0, x1) = (p[0].0.min(p[1].0).min(p[2].0), p[0].0.max(p[1].0).max(p[2].0));
        let (y0, y1) = (p[0].1.min(p[1].1).min(p[2].1), p[0].1.max(p[1].1).max(p[2].1));
        self.box_misses_every_sample(x0, x1, y0, y1)
    }

    /// [`Target::misses_every_sample`] of the box `x0..=x1` × `y0..=y1` (in [`SUB`]
    /// units).
    #[inline]
    fn box_misses_every_sample(&self, x0: i64, x1: i64, y0: i64, y1: i64) -> bool {
        let (first, step) = if self.samples == 4 { (32, 64) } else { (SUB / 2, SUB) };
        let holds = |lo: i64, hi: i64| (hi - first).div_euclid(step) >= (lo - first + step - 1).div_euclid(step);
        !holds(x0, x1) || !holds(y0, y1)
    }

    /// [`Target::triangle`] of vertices all [`inside`], snapped already
    /// ([`Target::snap`] of each clip position): the same pixels.
    pub fn triangle_snapped(&mut self, v: [V; 3], scr: [Snapped; 3]) {
        self.rasterise(v, scr, false);
    }

    /// Rasterises a triangle inside the clip volume and guard band.
    fn clipped(&mut self, v: [V; 3], cull_back: bool) {
        let scr = v.map(|x| self.snap(x.clip));
        self.rasterise(v, scr, cull_back);
    }

    fn rasterise(&mut self, v: [V; 3], scr: [Snapped; 3], cull_back: bool) {
        let (x0, y0) = (scr[0].0, scr[0].1);
        let area = (scr[1].0 - x0) * (scr[2].1 - y0) - (scr[2].0 - x0) * (scr[1].1 - y0);
        if area == 0 {
            return;
        }
        // Vulkan's facing: counter-clockwise (front) in a framebuffer whose y points
        // down is a negative `area`.
        let front = area < 0;
        if cull_back && !front {
            return;
        }
        // Order the vertices so the area is positive: every edge function is then
        // positive inside.
        let (order, area) = if area > 0 { ([0, 1, 2], area) } else { ([0, 2, 1], -area) };
        let p = order.map(|k| scr[k]);
        let vv = order.map(|k| v[k]);
        let min_x = p.iter().map(|q| q.0).min().unwrap_or(0);
        let max_x = p.iter().map(|q| q.0).max().unwrap_or(0);
        let min_y = p.iter().map(|q| q.1).min().unwrap_or(0);
        let max_y = p.iter().map(|q| q.1).max().unwrap_or(0);
        if self.box_misses_every_sample(min_x, max_x, min_y, max_y) {
            return;
        }
        let px0 = (min_x.div_euclid(SUB)).max(0);
        let px1 = (max_x.div_euclid(SUB)).min(i64::from(self.width) - 1);
        let py0 = min_y.div_euclid(SUB);
        let py1 = max_y.div_euclid(SUB);
        if px0 > px1 || !self.any_row(py0, py1) {
            return;
        }
        // Edge k runs from vertex k+1 to vertex k+2 and is the weight of vertex k:
        // E(x, y) = (b.x − a.x)(y − a.y) − (b.y − a.y)(x − a.x). A sample exactly on an
        // edge belongs to it only on a top or left edge (bias 0, else −1).
        let edge = |k: usize| {
            let (a, b) = (p[(k + 1) % 3], p[(k + 2) % 3]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let top_left = dy < 0 || (dy == 0 && dx > 0);
            (a.0, a.1, dx, dy, if top_left { 0 } else { -1 })
        };
        let edges = [edge(0), edge(1), edge(2)];
        let e_at = |k: usize, x: i64, y: i64| {
            let (ax, ay, dx, dy, _) = edges[k];
            dx * (y - ay) - dy * (x - ax)
        };
        let inv_area = 1.0 / area as f64;
        // Perspective-correct inputs: each attribute over w, and 1/w.
        let iw = p.map(|q| q.3);
        let zs = p.map(|q| q.2);
        let offsets = self.offsets();
        let lighting = self.lighting;
        let shade = self.shade;
        let depth_write = self.depth_test;
        let mut any = false;
        for y in self.rows(py0, py1) {
            let cy = i64::from(y) * SUB;
            for x in px0..=px1 {
                let cx = x * SUB;
                let base = self.index(x as u32, y);
                let mut covered = 0u32;
                let mut zs_s = [0f32; 4];
                for (s, &(ox, oy)) in offsets.iter().enumerate() {
                    let (sx, sy) = (cx + ox, cy + oy);
                    let e = [e_at(0, sx, sy), e_at(1, sx, sy), e_at(2, sx, sy)];
                    if (0..3).all(|k| e[k] + edges[k].4 >= 0) {
                        covered |= 1 << s;
                        let l = e.map(|v| (v as f64 * inv_area) as f32);
                        zs_s[s] = l[0] * zs[0] + l[1] * zs[1] + l[2] * zs[2];
                    }
                }
                // Early depth test: a pixel whose every covered sample is hidden is
                // not shaded (what it would write fails the test anyway).
                if self.depth_test {
                    for (s, z) in zs_s.iter().enumerate().take(offsets.len()) {
                        let hidden =
                            self.depth.get(base + s).is_none_or(|d| z.partial_cmp(d).is_none_or(|o| o.is_gt()));
                        if hidden {
                            covered &= !(1 << s);
                        }
                    }
                }
                if covered == 0 {
                    continue;
                }
                any = true;
                // The fragment shader at the pixel centre.
                let (sx, sy) = (cx + SUB / 2, cy + SUB / 2);
                let l = [e_at(0, sx, sy), e_at(1, sx, sy), e_at(2, sx, sy)].map(|v| (v as f64 * inv_area) as f32);
                let wl = [l[0] * iw[0], l[1] * iw[1], l[2] * iw[2]];
                let q = 1.0 / (wl[0] + wl[1] + wl[2]);
                let b = wl.map(|x| x * q);
                let color = vv[0].color * b[0] + vv[1].color * b[1] + vv[2].color * b[2];
                let out = match shade {
                    Shade::Unlit => color,
                    Shade::Phong => {
                        let world = vv[0].world * b[0] + vv[1].world * b[1] + vv[2].world * b[2];
                        let normal = vv[0].normal * b[0] + vv[1].normal * b[1] + vv[2].normal * b[2];
                        let matte = vv[0].matte * b[0] + vv[1].matte * b[1] + vv[2].matte * b[2];
                        phong(&lighting, world, normal, color, matte, front)
                    }
                };
                for (s, z) in zs_s.iter().enumerate().take(offsets.len()) {
                    if covered & (1 << s) != 0 {
                        self.write(base + s, *z, out, depth_write);
                    }
                }
            }
        }
        if any {
            self.triangles += 1;
        }
    }

    /// A point sprite: centre `clip`, `size` pixels wide (at least one), in colour
    /// `rgba` (already shaded), depth-tested and written. Dropped when its centre is outside the
    /// clip volume, as Vulkan clips points.
    pub fn point(&mut self, clip: Vec4, size: f32, rgba: [u8; 4]) {
        if let Some(p) = point_setup(clip, size, self.width, self.height) {
            self.point_at(&p, rgba);
        }
    }

    /// A point set up by [`point_setup`] (for this target's size), in colour
    /// `rgba`: blended as [`unorm_color`] of its bytes, or, opaque (alpha 255),
    /// stored as they are (what blending an opaque colour of 8-bit channels
    /// gives: `unorm(k / 255) = k`).
    #[inline]
    pub fn point_at(&mut self, p: &PointSetup, rgba: [u8; 4]) {
        if rgba[3] == 255 {
            self.point_with(p, |c: &mut [u8; 4]| *c = rgba);
        } else {
            let color = unorm_color(rgba);
            self.point_with(p, |c: &mut [u8; 4]| *c = blend(color, *c));
        }
    }

    /// [`Target::point_at`] with `paint` for what a covered sample that passes
    /// the depth test gets.
    #[inline(always)]
    fn point_with(&mut self, p: &PointSetup, paint: impl Fn(&mut [u8; 4])) {
        let PointSetup { x0, x1, y0, y1, z } = *p;
        let (r0, r1) = (floor_i64(y0), floor_i64(y1));
        // (A one-pixel point covers one or two rows: no thread's iteration.)
        if !self.any_row(r0, r1) {
            return;
        }
        let offsets = self.offsets();
        let depth_write = self.depth_test;
        let px0 = floor_i64(x0).max(0);
        let px1 = floor_i64(x1).min(i64::from(self.width) - 1);
        let mut any = false;
        let (r0, r1) = (r0.max(0), r1.min(i64::from(self.height) - 1));
        if let [(ox, oy)] = *offsets {
            // One sample, at the pixel's centre: the same tests, a row's once.
            let (ox, oy) = (ox as f32 / SUB as f32, oy as f32 / SUB as f32);
            for y in (r0..=r1).map(|y| y as u32) {
                let qy = y as f32 + oy;
                if !(qy >= y0 && qy < y1 && self.owns(y)) {
                    continue;
                }
                let row = self.index(0, y);
                for x in px0..=px1 {
                    let qx = x as f32 + ox;
                    if qx >= x0 && qx < x1 {
                        self.write_with(row + x as usize, z, depth_write, &paint);
                        any = true;
                    }
                }
            }
            if any {
                self.triangles += 1;
            }
            return;
        }
        for y in (r0..=r1).map(|y| y as u32) {
            if !self.owns(y) {
                continue;
            }
            for x in px0..=px1 {
                let base = self.index(x as u32, y);
                for (s, &(ox, oy)) in offsets.iter().enumerate() {
                    let qx = x as f32 + ox as f32 / SUB as f32;
                    let qy = y as f32 + oy as f32 / SUB as f32;
                    if qx >= x0 && qx < x1 && qy >= y0 && qy < y1 {
                        self.write_with(base + s, z, depth_write, &paint);
                        any = true;
                    }
                }
            }
        }
        if any {
            self.triangles += 1;
        }
    }

    /// A line one pixel wide from `a` to `b` (clip positions) in `color`, one
    /// pixel per step along its major axis; `depth` tests and writes depth (pen
    /// lines), else it is drawn over everything (overlays).
    pub fn line(&mut self, a: Vec4, b: Vec4, color: Vec4, depth: bool) {
        // Clip against the near and far planes.
        let (mut a, mut b) = (a, b);
        for plane in [|p: Vec4| p.z, |p: Vec4| p.w - p.z] {
            let (da, db) = (plane(a), plane(b));
            if !(da.is_finite() && db.is_finite()) || (da < 0.0 && db < 0.0) {
                return;
            }
            if da < 0.0 {
                a = a + (b - a) * (da / (da - db));
            } else if db < 0.0 {
                b = b + (a - b) * (db / (db - da));
            }
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let scr = |c: Vec4| Vec3::new((c.x / c.w + 1.0) * 0.5 * w, (c.y / c.w + 1.0) * 0.5 * h, c.z / c.w);
        let (p, q) = (scr(a), scr(b));
        let d = q - p;
        let steps = d.x.abs().max(d.y.abs());
        if !steps.is_finite() || steps > 1e6 {
            return;
        }
        let saved = self.depth_test;
        self.depth_test = depth;
        let x_major = d.x.abs() >= d.y.abs();
        let (from, to) = if x_major { (p.x.min(q.x), p.x.max(q.x)) } else { (p.y.min(q.y), p.y.max(q.y)) };
        // Every pixel centre along the major axis within [from, to).
        let mut k = (from - 0.5).ceil();
        while k + 0.5 < to + 1e-6 && k + 0.5 >= from && k < 1e6 {
            let c = k + 0.5;
            let t = if x_major { (c - p.x) / d.x } else { (c - p.y) / d.y };
            let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
            let at = p + d * t;
            let (x, y) = if x_major { (k, at.y.floor()) } else { (at.x.floor(), k) };
            if x >= 0.0 && y >= 0.0 && x < w && y < h && self.owns(y as u32) {
                let base = self.index(x as u32, y as u32);
                for s in 0..self.samples {
                    self.write(base + s, at.z, color, depth);
                }
            }
            k += 1.0;
        }
        self.depth_test = saved;
    }

    /// This thread's row `y` (one it owns), resolved: each pixel the rounded mean
    /// of its samples.
    pub fn resolve_row(&self, y: u32, out: &mut [u8]) {
        let base = self.index(0, y);
        let n = self.samples;
        for (x, px) in out.chunks_exact_mut(4).enumerate().take(self.width as usize) {
            let Some(samples) = self.color.get(base + x * n..base + (x + 1) * n) else { return };
            if n == 1 {
                px.copy_from_slice(&samples[0]);
            } else {
                for c in 0..4 {
                    let sum: u32 = samples.iter().map(|s| u32::from(s[c])).sum();
                    px[c] = ((sum + n as u32 / 2) / n as u32) as u8;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An opaque point's bytes are stored as they are: blending the colour they
    /// stand for over any sample gives them back, every channel value.
    #[test]
    fn an_opaque_colour_of_bytes_blends_to_its_bytes() {
        for k in 0..=255u8 {
            let rgba = [k, 255 - k, k / 2, 255];
            for dst in [[0, 0, 0, 0], [255, 255, 255, 255], [k, 7, 200, 9]] {
                assert_eq!(blend(unorm_color(rgba), dst), rgba, "{k}");
            }
        }
        let mut t = Target::new(0, 1, 4, 4, 1, [9, 9, 9, 9]);
        let p = PointSetup { x0: 1.0, x1: 2.0, y0: 1.0, y1: 2.0, z: 0.5 };
        t.point_at(&p, [10, 20, 30, 128]);
        let half = blend(unorm_color([10, 20, 30, 128]), [9, 9, 9, 9]);
        assert_eq!(t.color[t.index(1, 1)], half);
        t.point_at(&p, [10, 20, 30, 255]);
        assert_eq!(t.color[t.index(1, 1)], [10, 20, 30, 255]);
    }

    fn vtx(x: f32, y: f32, c: [f32; 4]) -> V {
        V { clip: Vec4::new(x, y, 0.5, 1.0), color: Vec4::from_array(c), ..V::default() }
    }

    fn unlit(threads: u32, samples: usize) -> Vec<Target> {
        (0..threads)
            .map(|t| {
                let mut tg = Target::new(t, threads, 16, 16, samples, [0, 0, 0, 255]);
                tg.shade = Shade::Unlit;
                tg
            })
            .collect()
    }

    fn picture(targets: &[Target]) -> Vec<u8> {
        let w = targets[0].width;
        let mut px = vec![0u8; (w * targets[0].height * 4) as usize];
        for (y, row) in px.chunks_exact_mut(w as usize * 4).enumerate() {
            let y = y as u32;
            if let Some(t) = targets.iter().find(|t| t.owns(y)) {
                t.resolve_row(y, row);
            }
        }
        px
    }

    #[test]
    fn two_triangles_sharing_an_edge_cover_each_pixel_once() {
        // A square of the whole picture as two triangles, half-transparent: a pixel
        // covered twice would be blended twice.
        for threads in [1, 3] {
            let mut ts = unlit(threads, 1);
            let c = [1.0, 1.0, 1.0, 0.5];
            for t in &mut ts {
                t.triangle([vtx(-1.0, -1.0, c), vtx(1.0, -1.0, c), vtx(1.0, 1.0, c)], false);
                t.triangle([vtx(-1.0, -1.0, c), vtx(1.0, 1.0, c), vtx(-1.0, 1.0, c)], false);
            }
            let px = picture(&ts);
            assert!(px.chunks_exact(4).all(|p| p[0] == 128), "{:?}", &px[..16]);
        }
    }

    #[test]
    fn a_triangle_covers_about_its_area_and_four_samples_blend_its_edges() {
        let c = [1.0, 0.0, 0.0, 1.0];
        let tri = [vtx(-1.0, -1.0, c), vtx(1.0, -1.0, c), vtx(-1.0, 1.0, c)];
        let mut one = unlit(1, 1);
        one[0].triangle(tri, false);
        let red = picture(&one).chunks_exact(4).filter(|p| p[0] == 255).count();
        // Half of 256 pixels; the diagonal's pixel centres lie off it.
        assert!((120..=136).contains(&red), "{red}");
        let mut four = unlit(1, 4);
        four[0].triangle(tri, false);
        let px = picture(&four);
        let partial = px.chunks_exact(4).filter(|p| p[0] > 0 && p[0] < 255).count();
        assert!(partial >= 8, "edge pixels partly covered: {partial}");
    }

    #[test]
    fn the_nearer_triangle_wins_whatever_the_order() {
        let mk = |z: f32, c: [f32; 4]| {
            [(-1.0, -1.0), (1.0, -1.0), (0.0, 1.0)].map(|(x, y)| V {
                clip: Vec4::new(x, y, z, 1.0),
                color: Vec4::from_array(c),
                ..V::default()
            })
        };
        let a = mk(0.3, [1.0, 0.0, 0.0, 1.0]);
        let b = mk(0.6, [0.0, 0.0, 1.0, 1.0]);
        for order in [[a, b], [b, a]] {
            let mut ts = unlit(1, 1);
            for t in order {
                ts[0].triangle(t, false);
            }
            let px = picture(&ts);
            let i = ((8 * 16 + 8) * 4) as usize;
            assert_eq!(&px[i..i + 4], &[255, 0, 0, 255]);
        }
    }
}
