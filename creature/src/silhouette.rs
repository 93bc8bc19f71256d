//! Silhouettes: what a monster looks like, for telling monsters apart by what the
//! artist sees rather than by their abstract shapes. Stacked copies that hide one
//! another, or a tail behind a body, change the structure but not the silhouette.
//!
//! A silhouette is the monster's placed geometry rasterised, orthographically, at
//! [`RES`] × [`RES`] pixels from three views — the front (along y: x across, z up),
//! the side (along x: y across, z up) and the contact sheet's three-quarter view —
//! each framed by the outline's box scaled uniformly (its larger side fills the
//! picture, as the contact sheet frames each monster), so a monster and its
//! enlarged copy look alike. Two silhouettes are [`distance`] apart: the mean over
//! the views of the share of their pixels that lie more than a pixel from the
//! other silhouette. Deterministic and on the CPU: every
//! triangle is projected in f32 and filled by pixel centres; a triangle smaller
//! than a pixel marks the pixels of its corners.

use super::geometry::{Layout, Library};
use super::outline::Outline;
use glam::{Mat3, Mat4, Vec2, Vec3};

/// Pixels along each side of a view.
pub const RES: usize = 32;

/// Two monsters whose silhouettes are closer than this look alike (one is a
/// duplicate of the other for diversity), whatever their parts. Tuned on the
/// contact sheets (docs/creatures.md §6). On `monsters.mdg` (seed 3, generation 5)
/// as presented with the rule before (alike silhouettes and one part set within the
/// other's, threshold 0.05): the four ogres with stacked claw arms that the sheet
/// shows as one monster, whatever head they wear, were 0.019–0.093 apart, the
/// bat-winged humanoid with one boar head or two 0.094, the horned humanoid with one
/// head or two 0.117, the two horse-headed birds 0.118. At 0.125 the next sheet
/// still showed the bat-winged humanoid on bird legs with one pair of wings and two
/// (0.136), the blue-winged humanoid with a horned head and a plain one (0.142) and
/// the two long-legged herons with an arm (0.151) as pairs; at 0.15 the nearest
/// presented pairs are 0.160 and more, and one pair (two bat-winged humanoids that
/// differ in the side view) still looks alike on the sheet.
pub const DUPLICATE: f64 = 0.15;

/// Three views of [`RES`] rows, one bit per pixel.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Silhouette {
    pub views: [[u32; RES]; 3],
}

impl Silhouette {
    /// Pixels covered in view `v`.
    pub fn area(&self, v: usize) -> u32 {
        self.views.get(v).map(|rows| rows.iter().map(|r| r.count_ones()).sum()).unwrap_or(0)
    }
}

/// The direction the contact sheet's pictures look from, in the monster's own
/// coordinates: the preview camera (azimuth 35°, elevation 25°) with the monster
/// turned −15° for its picture — azimuth 50°.
const SHEET_AZIMUTH_DEG: f32 = 50.0;
const SHEET_ELEVATION_DEG: f32 = 25.0;

/// The silhouette of a laid-out monster.
pub fn silhouette(lib: &Library, layout: &Layout) -> Silhouette {
    let parts: Vec<(&Outline, Mat4)> =
        layout.placed.iter().filter_map(|p| Some((&lib.parts.get(p.part as usize)?.outline, p.transform))).collect();
    of_outlines(&parts)
}

/// The three views' axes (across, up) in the monster's coordinates: the front (x
/// across, z up), the side (y across, z up) and the sheet's three-quarter view.
fn view_axes() -> [(Vec3, Vec3); 3] {
    let (az, el) = (SHEET_AZIMUTH_DEG.to_radians(), SHEET_ELEVATION_DEG.to_radians());
    let dir = Vec3::new(el.cos() * az.sin(), -el.cos() * az.cos(), el.sin());
    let right = Vec3::new(az.cos(), az.sin(), 0.0);
    let up = dir.cross(right).normalize_or_zero();
    [(Vec3::X, Vec3::Z), (Vec3::Y, Vec3::Z), (right, up)]
}

/// The silhouette of outlines placed by their transforms (part to model space).
///
/// The same pixels as projecting every vertex of the placed meshes and filling every
/// triangle with [`fill`] (a test checks it against such a rasteriser), for a
/// fraction of the work: each distinct position is transformed once and marks its
/// pixel, and the pixel-centre test runs only on the triangles whose projection may
/// span half a pixel or more along an axis of the view — bounded, before projecting,
/// by their longest edge times how much the transform and the framing stretch a
/// part-space length along that axis, so the triangles are visited longest first
/// and the visit stops at the first one that cannot. A smaller triangle's box can
/// hold a pixel centre only in the pixel all its corners lie in (each corner is
/// within half a pixel of the centre on both axes), which the corners mark.
pub fn of_outlines(parts: &[(&Outline, Mat4)]) -> Silhouette {
    let axes = view_axes();
    // Every distinct position in each view's coordinates.
    let n = parts.iter().map(|(o, _)| o.points.len()).sum();
    let mut flat: [Vec<Vec2>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
    for (o, t) in parts {
        for q in &o.points {
            let w = t.transform_point3(*q);
            for (f, (u, v)) in flat.iter_mut().zip(&axes) {
                f.push(Vec2::new(w.dot(*u), w.dot(*v)));
            }
        }
    }
    // How large the model-space coordinates and the sums that make them can be, for
    // the rounding bound below.
    let magnitude = parts.iter().fold(0.0f64, |m, (o, t)| {
        let cols = [t.x_axis, t.y_axis, t.z_axis].map(|c| c.truncate().abs().max_element() as f64);
        m.max(cols.iter().sum::<f64>() * o.reach as f64 + t.w_axis.truncate().abs().max_element() as f64)
    });
    let mut s = Silhouette::default();
    let mut px: Vec<Vec2> = Vec::new();
    for ((view, (u, v)), flat) in s.views.iter_mut().zip(axes).zip(&flat) {
        let (lo, hi) = flat
            .iter()
            .filter(|p| p.is_finite())
            .fold((Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)), |(a, b), p| (a.min(*p), b.max(*p)));
        if lo.x > hi.x {
            continue;
        }
        // The view's box centred, its larger side spanning RES − 1 pixels.
        let k = (RES as f32 - 1.0) / (hi - lo).max_element().max(1e-6);
        let centre = (lo + hi) * 0.5;
        let half = Vec2::splat(RES as f32 * 0.5);
        // The pixel coordinates are rounded by less than 20 units in the last place of
        // k · magnitude (transform, projection, framing): under 0.003 pixel while
        // that is at most 2000 (a monster framed about the origin: about 40), so
        // a bound below 0.45 keeps the span below 0.5. Past that every triangle
        // is filled.
        let exact = k as f64 * magnitude <= 2000.0;
        let mut at = 0;
        for (o, t) in parts {
            let Some(mine) = flat.get(at..at + o.points.len()) else { break };
            at += o.points.len();
            px.clear();
            let all_corners = o.corners.len() == mine.len();
            // Marked on a copy: a part with a point that is not finite takes the
            // reference's way below instead.
            let (mut finite, mut marked) = (true, *view);
            px.extend(mine.iter().map(|p| {
                let q = (*p - centre) * k + half;
                finite &= q.is_finite();
                if all_corners {
                    mark(&mut marked, q);
                }
                q
            }));
            let corner = |i: u32| px.get(i as usize).copied().unwrap_or(Vec2::NAN);
            if !exact || !finite {
                // Every triangle with finite corners, as the reference does.
                for (tri, _) in &o.triangles {
                    let [a, b, c] = tri.map(corner);
                    if a.is_finite() && b.is_finite() && c.is_finite() {
                        fill(view, [a, b, c]);
                    }
                }
                continue;
            }
            *view = marked;
            if !all_corners {
                o.corners.iter().for_each(|&i| mark(view, corner(i)));
            }
            // How far a part-space length can stretch along either axis of the view,
            // in pixels: k·|Aᵀu| and k·|Aᵀv| for the transform's linear part A.
            let a = Mat3::from_mat4(*t).as_dmat3().transpose();
            let stretch = k as f64 * (a * u.as_dvec3()).length().max((a * v.as_dvec3()).length());
            // Longest edges under this are shorter than 0.45 / stretch.
            let limit = (0.449 / stretch) as f32;
            for (tri, longest) in &o.triangles {
                if *longest < limit {
                    break;
                }
                fill_centres(view, tri.map(corner));
            }
        }
    }
    s
}

/// Marks the pixel of `view` that point `p` (pixel coordinates) lies in, if it is
/// in the picture: pixel (⌊x⌋, ⌊y⌋), without the rounding functions (calls into
/// libm on the base x86-64 target).
#[inline]
fn mark(view: &mut [u32; RES], p: Vec2) {
    let side = RES as f32;
    if p.x >= 0.0 && p.x < side && p.y >= 0.0 && p.y < side {
        if let Some(row) = view.get_mut(p.y as usize) {
            *row |= 1 << (p.x as u32);
        }
    }
}

/// The pixels x of the picture whose centres x + 0.5 lie in [lo, hi]: ⌈lo − 0.5⌉
/// to ⌊hi − 0.5⌋, clamped to the picture (`None` when there are none).
#[inline]
fn centres(lo: f32, hi: f32) -> Option<(usize, usize)> {
    let (a, b) = (lo - 0.5, hi - 0.5);
    let last = (RES - 1) as f32;
    if !(b >= 0.0 && a <= last) {
        return None;
    }
    let x0 = if a <= 0.0 {
        0
    } else {
        let t = a as usize;
        t + usize::from((t as f32) < a)
    };
    let x1 = if b >= last { RES - 1 } else { b as usize };
    (x0 <= x1).then_some((x0, x1))
}

/// Marks the pixels of `view` whose centres lie in triangle `t` (pixel
/// coordinates), and the pixels of its corners.
fn fill(view: &mut [u32; RES], t: [Vec2; 3]) {
    for p in t {
        mark(view, p);
    }
    fill_centres(view, t);
}

/// Marks the pixels of `view` whose centres lie in triangle `t`: within its box,
/// on the inner side of its three edges (or on one).
fn fill_centres(view: &mut [u32; RES], t: [Vec2; 3]) {
    let lo = t[0].min(t[1]).min(t[2]);
    let hi = t[0].max(t[1]).max(t[2]);
    let (Some((x0, x1)), Some((y0, y1))) = (centres(lo.x, hi.x), centres(lo.y, hi.y)) else { return };
    let area = (t[1] - t[0]).perp_dot(t[2] - t[0]);
    if area == 0.0 {
        return;
    }
    for (y, row) in view.iter_mut().enumerate().take(y1 + 1).skip(y0) {
        for x in x0..=x1 {
            let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let w0 = (t[1] - t[0]).perp_dot(q - t[0]) * area.signum();
            let w1 = (t[2] - t[1]).perp_dot(q - t[1]) * area.signum();
            let w2 = (t[0] - t[2]).perp_dot(q - t[2]) * area.signum();
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                *row |= 1 << x;
            }
        }
    }
}

/// A view grown by one pixel in every direction (8-neighbourhood).
fn dilate(v: &[u32; RES]) -> [u32; RES] {
    let grow = |r: u32| r | (r << 1) | (r >> 1);
    let mut out = [0u32; RES];
    for (y, o) in out.iter_mut().enumerate() {
        let mut r = grow(v[y]);
        if y > 0 {
            r |= grow(v[y - 1]);
        }
        if y + 1 < RES {
            r |= grow(v[y + 1]);
        }
        *o = r;
    }
    out
}

/// The mean over the three views of the share of the union |A ∪ B| that lies
/// more than a pixel away from the other silhouette: (|A ∖ grow(B)| + |B ∖
/// grow(A)|) / |A ∪ B|, 0 for silhouettes within a pixel of each other (a part
/// moved or the framing shifted by a pixel counts for nothing), 1 for far apart
/// ones; two empty views count as equal.
pub fn distance(a: &Silhouette, b: &Silhouette) -> f64 {
    let mut sum = 0.0;
    for (va, vb) in a.views.iter().zip(&b.views) {
        let (ga, gb) = (dilate(va), dilate(vb));
        let (mut apart, mut or) = (0u32, 0u32);
        for y in 0..RES {
            apart += (va[y] & !gb[y]).count_ones() + (vb[y] & !ga[y]).count_ones();
            or += (va[y] | vb[y]).count_ones();
        }
        sum += if or == 0 { 0.0 } else { apart as f64 / or as f64 };
    }
    sum / a.views.len() as f64
}

/// Whether two silhouettes look alike (closer than [`DUPLICATE`]).
pub fn alike(a: &Silhouette, b: &Silhouette) -> bool {
    distance(a, b) < DUPLICATE
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_vm::output::Mesh;
    use mdg_vm::rng::Rng;

    /// A number in `lo..hi`.
    fn uniform(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((rng.bits() >> 40) as f32 / (1u64 << 24) as f32)
    }

    #[test]
    fn a_filled_triangle_covers_the_pixels_inside_it() {
        let mut v = [0u32; RES];
        fill(&mut v, [Vec2::new(0.0, 0.0), Vec2::new(32.0, 0.0), Vec2::new(0.0, 32.0)]);
        let n: u32 = v.iter().map(|r| r.count_ones()).sum();
        // Half the square, with the diagonal's pixels whose centres lie on it.
        assert!((512..=560).contains(&n), "{n}");
        assert_eq!(v[0], u32::MAX);
        assert_eq!(v[31] & 1, 1);
        assert_eq!(v[31] >> 1, 0);
        // A speck marks its pixel.
        let mut w = [0u32; RES];
        fill(&mut w, [Vec2::new(5.2, 7.1), Vec2::new(5.3, 7.1), Vec2::new(5.2, 7.2)]);
        assert_eq!(w[7], 1 << 5);
    }

    #[test]
    fn distance_counts_the_pixels_more_than_one_pixel_from_the_other_silhouette() {
        let mut a = Silhouette::default();
        let mut b = Silhouette::default();
        for v in 0..3 {
            a.views[v][0] = 0b1111;
            b.views[v][0] = 0b0011;
        }
        // Pixel 3 of A is two pixels from B; pixel 2 only one.
        assert!((distance(&a, &b) - 0.25).abs() < 1e-12);
        // Shifted by one pixel: within tolerance.
        let mut c = Silhouette::default();
        for v in 0..3 {
            c.views[v][1] = 0b1111 << 1;
        }
        assert_eq!(distance(&a, &c), 0.0);
        assert_eq!(distance(&a, &a), 0.0);
        assert!(alike(&a, &a) && !alike(&a, &b));
        assert_eq!(distance(&Silhouette::default(), &Silhouette::default()), 0.0);
    }

    /// The straightforward rasteriser the fast one must equal: every pixel of the
    /// view against every triangle of every placed mesh, marked when a corner lies in
    /// it or (with `centres`) when its centre lies within the triangle's box on the
    /// inner side of its three edges.
    fn reference(parts: &[(&Mesh, Mat4)], centre_test: bool) -> Silhouette {
        let mut world: Vec<Vec3> = Vec::new();
        let mut tris: Vec<[usize; 3]> = Vec::new();
        for (m, t) in parts {
            let base = world.len();
            world.extend(m.positions.iter().map(|q| t.transform_point3(Vec3::from(*q))));
            tris.extend(m.triangles.iter().map(|t| t.map(|i| i as usize + base)));
        }
        let mut s = Silhouette::default();
        for (view, (u, v)) in s.views.iter_mut().zip(view_axes()) {
            let flat: Vec<Vec2> = world.iter().map(|w| Vec2::new(w.dot(u), w.dot(v))).collect();
            let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
            for p in flat.iter().filter(|p| p.is_finite()) {
                (lo, hi) = (lo.min(*p), hi.max(*p));
            }
            if lo.x > hi.x {
                continue;
            }
            let k = (RES as f32 - 1.0) / (hi - lo).max_element().max(1e-6);
            let centre = (lo + hi) * 0.5;
            let px: Vec<Vec2> = flat.iter().map(|p| (*p - centre) * k + Vec2::splat(RES as f32 * 0.5)).collect();
            for (y, row) in view.iter_mut().enumerate() {
                for x in 0..RES {
                    let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    let covered = tris.iter().any(|t| {
                        let t = t.map(|i| px[i]);
                        if !t.iter().all(|p| p.is_finite()) {
                            return false;
                        }
                        if t.iter().any(|p| p.x.floor() == x as f32 && p.y.floor() == y as f32) {
                            return true;
                        }
                        let (a, b) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                        let area = (t[1] - t[0]).perp_dot(t[2] - t[0]);
                        let inside = |p: Vec2, e: Vec2| (e - p).perp_dot(q - p) * area.signum() >= 0.0;
                        centre_test
                            && area != 0.0
                            && q.cmpge(a).all()
                            && q.cmple(b).all()
                            && inside(t[0], t[1])
                            && inside(t[1], t[2])
                            && inside(t[2], t[0])
                    });
                    if covered {
                        *row |= 1 << x;
                    }
                }
            }
        }
        s
    }

    /// A random part: a blob of `n` small triangles of sizes from a hundredth of a
    /// unit to about one, corners shared and repeated as the evaluator's meshes
    /// repeat them, and a few large triangles.
    fn random_part(rng: &mut Rng, n: usize) -> Mesh {
        let mut m = Mesh::default();
        for i in 0..n {
            let size = 10f32.powf(uniform(rng, -1.5, 0.8));
            let c = Vec3::new(uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0)) * 4.0;
            let base = m.positions.len() as u32;
            // Every other triangle reuses the previous one's last corner as a new
            // vertex of the same position (a repeated position, not a shared index).
            if i % 2 == 1 {
                if let Some(&p) = m.positions.last() {
                    m.positions.push(p);
                }
            } else {
                m.positions.push((c + Vec3::splat(size * 0.1)).to_array());
            }
            for _ in 0..2 {
                let d = Vec3::new(uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0));
                m.positions.push((c + d * size).to_array());
            }
            m.triangles.push([base, base + 1, base + 2]);
        }
        // A shared-index fan and a degenerate sliver.
        let b = m.positions.len() as u32;
        m.positions.extend([[0.0, 0.0, 0.0], [3.0, 0.5, 0.0], [0.2, 3.0, 1.0], [-2.0, 0.3, 0.5]]);
        m.triangles.extend([[b, b + 1, b + 2], [b, b + 2, b + 3], [b + 1, b + 1, b + 3]]);
        // Now and then a corner that is not finite: its triangle is left out, the
        // rest of the part is drawn.
        if rng.below(8) == 0 {
            m.positions.push([f32::NAN, 0.0, 1.0]);
            m.triangles.push([b, b + 1, b + 4]);
        }
        m
    }

    fn random_transform(rng: &mut Rng) -> Mat4 {
        let axis = Vec3::new(uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0), uniform(rng, 0.1, 1.0));
        let scale = Vec3::new(uniform(rng, 0.05, 2.0), uniform(rng, 0.05, 2.0), uniform(rng, 0.05, 2.0));
        let mirror = if rng.below(10) < 3 { Vec3::new(-1.0, 1.0, 1.0) } else { Vec3::ONE };
        let at = Vec3::new(uniform(rng, -6.0, 6.0), uniform(rng, -6.0, 6.0), uniform(rng, 0.0, 8.0));
        Mat4::from_scale_rotation_translation(
            scale * mirror,
            glam::Quat::from_axis_angle(axis.normalize(), uniform(rng, 0.0, 6.3)),
            at,
        )
    }

    #[test]
    fn the_fast_rasteriser_equals_the_reference_on_random_triangles() {
        let mut rng = Rng::new(43);
        let mut filled_past_corners = 0;
        for trial in 0..60 {
            let n_parts = 1 + rng.below(5);
            let meshes: Vec<(Mesh, Mat4)> = (0..n_parts)
                .map(|_| {
                    let n = 5 + rng.below(60);
                    (random_part(&mut rng, n), random_transform(&mut rng))
                })
                .collect();
            let outlines: Vec<Outline> = meshes.iter().map(|(m, _)| Outline::new(m)).collect();
            let placed: Vec<(&Outline, Mat4)> = outlines.iter().zip(&meshes).map(|(o, (_, t))| (o, *t)).collect();
            let fast = of_outlines(&placed);
            let meshes: Vec<(&Mesh, Mat4)> = meshes.iter().map(|(m, t)| (m, *t)).collect();
            let want = reference(&meshes, true);
            assert_eq!(fast, want, "trial {trial}");
            // The trials exercise the centre test: pixels no corner lies in.
            let corners = reference(&meshes, false);
            for v in 0..3 {
                filled_past_corners += want.area(v) - corners.area(v);
            }
        }
        assert!(filled_past_corners > 1000, "{filled_past_corners}");
    }

    /// Triangles of about a pixel, apart from one another, in a picture framed at
    /// one unit a pixel: those that span half a pixel to a pixel and a half are the
    /// ones a wrong size bound would skip.
    #[test]
    fn pixel_sized_triangles_are_filled_as_the_reference_fills_them() {
        let mut rng = Rng::new(7);
        let mut filled_past_corners = 0;
        for trial in 0..100 {
            let mut m = Mesh::default();
            // The frame: two points no triangle uses, 31 units apart on every axis.
            m.positions.extend([[0.0; 3], [31.0; 3]]);
            for _ in 0..30 {
                let c =
                    Vec3::new(uniform(&mut rng, 1.0, 30.0), uniform(&mut rng, 1.0, 30.0), uniform(&mut rng, 1.0, 30.0));
                let size = uniform(&mut rng, 0.8, 2.5);
                let b = m.positions.len() as u32;
                for _ in 0..3 {
                    let d = Vec3::new(
                        uniform(&mut rng, -0.5, 0.5),
                        uniform(&mut rng, -0.5, 0.5),
                        uniform(&mut rng, -0.5, 0.5),
                    );
                    m.positions.push((c + d * size).to_array());
                }
                m.triangles.push([b, b + 1, b + 2]);
            }
            let t = if trial % 2 == 0 { Mat4::IDENTITY } else { Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) };
            let o = Outline::new(&m);
            let want = reference(&[(&m, t)], true);
            assert_eq!(of_outlines(&[(&o, t)]), want, "trial {trial}");
            let corners = reference(&[(&m, t)], false);
            for v in 0..3 {
                filled_past_corners += want.area(v) - corners.area(v);
            }
        }
        assert!(filled_past_corners > 100, "{filled_past_corners}");
    }
}
