//! Point-sprite stand-ins for instances that cover a few pixels (issue 37's level of
//! detail): plain Rust, no Vulkan.
//!
//! On a CPU driver (lavapipe) an instanced draw costs per instance far more than its
//! few pixels: the driver runs its vertex pipeline once per instance, then sets up
//! and bins every triangle. An instance whose bounding sphere is at most
//! [`POINT_PIXELS`] across on the screen, closed (or open in a flat model:
//! [`View::flat`]) and compact ([`COMPACT`]; any
//! instance at most [`POINT_ANY_PIXELS`] across) is drawn instead as points of a single
//! non-instanced draw, one per facet it shows ([`crate::scene::Facet`]: its
//! triangles that face about one way; a box shows up to three, a square one): a
//! screen-aligned square as large as the facet's projected area (so it covers as
//! many pixel centres, on average, as the facet would: a sub-pixel square of area
//! `a` covers a pixel centre with probability `a`, and so does a point of side
//! `√a`), at the facet's centre, in the colour std's Phong fragment shader
//! (`phong_fs`) gives it there. One point per facet rather than per instance keeps
//! each face's own depth, so in a dense array the faces that neighbours hide stay
//! hidden (one mean-coloured point per box made the million boxes' picture 2.9/255
//! brighter). The selection is made per frame from the instance
//! records already in the instance buffer ([`select`]); the instances that stay
//! meshes are copied, draw by draw, into a second instance buffer.

use crate::scene::{Facet, InstancedDraw, StandIn, INSTANCE_STRIDE};
use glam::{Mat3, Mat4, Vec3, Vec4};

/// Instances whose bounding sphere is at most this many pixels across are drawn as
/// points when they are compact ([`COMPACT`])…
pub const POINT_PIXELS: f32 = 10.0;
/// …that is, when they cover at least this share of their bounding sphere's disc on
/// the screen (a box or a square seen face-on about 0.6, a branch's side 0.05: a
/// chain of thin instances drawn as squares would be a dotted line)…
pub const COMPACT: f32 = 0.2;
/// …and any instance at most this many pixels across, whose shape no pixel shows.
pub const POINT_ANY_PIXELS: f32 = 1.0;

/// Bytes per point vertex: position `R32G32B32_SFLOAT` (location 0), size in pixels
/// `R32_SFLOAT` (location 1), colour `R8G8B8A8_UNORM` (location 2).
pub const POINT_STRIDE: u32 = 20;

/// What the frame looks like, for [`select`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Projection × view.
    pub view_projection: Mat4,
    /// The eye (the fragment shader's `camera_pos`).
    pub eye: Vec3,
    /// The light (`light_pos`) and the specular colour and power (`spec_color_power`).
    pub light: Vec3,
    pub spec: [f32; 4],
    /// The target's size in pixels.
    pub width: f32,
    pub height: f32,
    /// The model is flat ([`crate::scene::Bounds::is_flat`]): open meshes may stand
    /// in as points too. In a 3-D model they do not, since their backs may be
    /// hidden by neighbours that a point cannot hide them behind (six open sides
    /// make a branch; their points would cover both its front and its back).
    pub flat: bool,
}

/// The outcome of [`select`]: the point vertices ([`POINT_STRIDE`] bytes each), in
/// pieces to be written one after the other (as they were made: a million boxes'
/// points are 60 MB that need not be joined on the heap before the upload) and,
/// per draw, the indices (into the instance buffer) of the instances kept as meshes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Selection {
    pub points: Vec<Vec<u8>>,
    pub kept: Vec<Vec<u32>>,
}

impl Selection {
    pub fn n_points(&self) -> usize {
        self.points.iter().map(Vec::len).sum::<usize>() / POINT_STRIDE as usize
    }

    /// Writes the points into `dst` ([`Selection::n_points`] × [`POINT_STRIDE`]
    /// bytes).
    pub fn write_points(&self, dst: &mut [u8]) {
        let mut at = 0;
        for piece in &self.points {
            if let Some(d) = dst.get_mut(at..at + piece.len()) {
                d.copy_from_slice(piece);
            }
            at += piece.len();
        }
    }

    /// Instances kept as meshes, in all.
    pub fn n_kept(&self) -> usize {
        self.kept.iter().map(Vec::len).sum()
    }
}

/// std's `phong_fs` for one fragment: position `p`, normal `n` (unit, facing the
/// viewer), colour `c`, matte or not; the colour's bytes as the 8-bit target stores
/// them (clamped, rounded by [`unorm`]).
fn phong(view: &View, p: Vec3, n: Vec3, c: Vec4, matte: bool) -> [u8; 3] {
    let light_dir = (view.light - p).normalize_or_zero();
    let lambertian = light_dir.dot(n).max(0.0);
    let base = (0.15 + 0.85 * lambertian) * c.truncate();
    let spec = Vec3::new(view.spec[0], view.spec[1], view.spec[2]);
    let rgb = |specular: f32| (base + specular * spec).clamp(Vec3::ZERO, Vec3::ONE);
    if lambertian > 0.0 && !matte {
        let reflect_dir = -light_dir - 2.0 * n.dot(-light_dir) * n;
        let view_dir = (view.eye - p).normalize_or_zero();
        return specular_bytes(reflect_dir.dot(view_dir).max(0.0), view.spec[3], rgb);
    }
    bytes(rgb(0.0))
}

/// [`Point::rgba`] of four points, stage by stage over the four: the same
/// operations, lane by lane (the view's direction made for every point, used
/// where [`phong`] uses it). The directions, their lengths and the dot products
/// are computed in the four lanes of one vector each ([`Lanes`]): the same
/// correctly rounded operations, in the same order, as `Vec3`'s on each point.
/// So are the colours: the base colour, the two ends of [`specular_bytes`]'
/// interval, their clamps (`Vec3::clamp` is `x > lo ? x : lo`, then `x < hi ? x :
/// hi`, which is what `maxps` and `minps` compute) and their bytes ([`unorm4`]);
/// a point whose ends give different bytes, or whose specular power
/// is not 32 or whose term is at least 2, is shaded alone ([`shade_one`]).
pub fn rgba4(view: &View, pts: &[Point; 4]) -> [[u8; 4]; 4] {
    let pos = Lanes::of(pts.map(|p| p.pos));
    let n = Lanes::of(pts.map(|p| p.normal));
    let l = (Lanes::splat(view.light) - pos).normalize_or_zero();
    let v = (Lanes::splat(view.eye) - pos).normalize_or_zero();
    let lambertian = l.dot(&n).to_array().map(|d| d.max(0.0));
    // `-l - 2.0 * n.dot(-l) * n`, as `Vec3` computes it.
    let minus_l = -l;
    let k = Vec4::splat(2.0) * n.dot(&minus_l);
    let reflect = minus_l - n.scaled(k);
    let x = reflect.dot(&v).to_array().map(|d| d.max(0.0));
    // The specular term's interval per point: `0..0` for an unlit or matte point
    // (its colour is `rgb(0.0)`); `slow` where `powf` itself is needed.
    let (mut lo, mut hi, mut slow) = ([0.0f32; 4], [0.0f32; 4], [false; 4]);
    for i in 0..4 {
        // (`lambertian` is never NaN: `max` gave 0 for one.)
        if lambertian[i] <= 0.0 || pts[i].matte {
            continue;
        }
        match specular_interval(x[i], view.spec[3]) {
            Some((a, b)) => (lo[i], hi[i]) = (a, b),
            None => slow[i] = true,
        }
    }
    let color = Lanes::of(pts.map(|p| p.color.truncate()));
    let base = color.scaled(Vec4::splat(0.15) + Vec4::splat(0.85) * Vec4::from_array(lambertian));
    let spec = Lanes::splat(Vec3::new(view.spec[0], view.spec[1], view.spec[2]));
    let rgb = |s: Vec4| {
        let channel = |b: Vec4, c: Vec4| (b + s * c).max(Vec4::ZERO).min(Vec4::ONE);
        Lanes { x: channel(base.x, spec.x), y: channel(base.y, spec.y), z: channel(base.z, spec.z) }
    };
    let (a, b) = (rgb(Vec4::from_array(lo)), rgb(Vec4::from_array(hi)));
    let [ar, ag, ab] = [unorm4(a.x), unorm4(a.y), unorm4(a.z)];
    let [br, bg, bb] = [unorm4(b.x), unorm4(b.y), unorm4(b.z)];
    // (`unorm` of the alpha: `f32::clamp` and `maxps`/`minps` agree but on NaN,
    // which gives 0 either way.)
    let alpha = unorm4(Vec4::from_array(pts.map(|p| p.color.w)).max(Vec4::ZERO).min(Vec4::ONE));
    // The bytes of the interval's ends agree (as they do where the colours do):
    // they are `powf`'s.
    let mut fast = 0u32;
    for i in 0..4 {
        fast |= u32::from(!slow[i] && ar[i] == br[i] && ag[i] == bg[i] && ab[i] == bb[i]) << i;
    }
    let mut out: [[u8; 4]; 4] =
        std::array::from_fn(|i| ((ar[i] | ag[i] << 8 | ab[i] << 16 | alpha[i] << 24) as u32).to_le_bytes());
    if fast != 0b1111 {
        for (i, o) in out.iter_mut().enumerate() {
            if fast & (1 << i) == 0 {
                let [r, g, b] = shade_one(view, lambertian[i], x[i], &pts[i]);
                o[..3].copy_from_slice(&[r, g, b]);
            }
        }
    }
    out
}

/// What [`rgba4`] gives point `p` alone, from its `lambertian` and specular term
/// `x` (both `max`ed with 0): [`phong`]'s colour after the dot products.
#[inline(never)]
fn shade_one(view: &View, lambertian: f32, x: f32, p: &Point) -> [u8; 3] {
    let base = (0.15 + 0.85 * lambertian) * p.color.truncate();
    let spec = Vec3::new(view.spec[0], view.spec[1], view.spec[2]);
    let rgb = |specular: f32| (base + specular * spec).clamp(Vec3::ZERO, Vec3::ONE);
    if lambertian > 0.0 && !p.matte {
        specular_bytes(x, view.spec[3], rgb)
    } else {
        bytes(rgb(0.0))
    }
}

/// [`unorm`] of each lane of `v`, every lane in `-0.0..=1.0` (a clamped colour):
/// `v · 255` truncated, plus one where the rest is at least 0.5 ([`round_unit`]'s
/// steps; below 2^8 the truncation is `as i32`'s).
#[inline(always)]
fn unorm4(v: Vec4) -> [i32; 4] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            __m128, __m128i, _mm_castps_si128, _mm_cmpge_ps, _mm_cvtepi32_ps, _mm_cvttps_epi32, _mm_mul_ps,
            _mm_set1_ps, _mm_sub_epi32, _mm_sub_ps,
        };
        let m: __m128 = v.into();
        // SAFETY: SSE and SSE2 are part of x86-64's baseline, so these intrinsics are
        // available on every x86-64 processor; they read and write only registers.
        let r: __m128i = unsafe {
            let y = _mm_mul_ps(m, _mm_set1_ps(255.0));
            let t = _mm_cvttps_epi32(y);
            let up = _mm_cmpge_ps(_mm_sub_ps(y, _mm_cvtepi32_ps(t)), _mm_set1_ps(0.5));
            // (`up` is all ones, −1, where the rest is at least 0.5.)
            _mm_sub_epi32(t, _mm_castps_si128(up))
        };
        // SAFETY: `__m128i` and `[i32; 4]` are 16 bytes, every bit pattern valid in both.
        return unsafe { std::mem::transmute::<__m128i, [i32; 4]>(r) };
    }
    #[allow(unreachable_code)]
    v.to_array().map(|c| i32::from(unorm(c)))
}

/// Four `Vec3`s, a vector per coordinate (lane `i` is the `i`-th point's).
#[derive(Clone, Copy)]
struct Lanes {
    x: Vec4,
    y: Vec4,
    z: Vec4,
}

impl Lanes {
    #[inline(always)]
    fn of(v: [Vec3; 4]) -> Lanes {
        Lanes {
            x: Vec4::new(v[0].x, v[1].x, v[2].x, v[3].x),
            y: Vec4::new(v[0].y, v[1].y, v[2].y, v[3].y),
            z: Vec4::new(v[0].z, v[1].z, v[2].z, v[3].z),
        }
    }

    #[inline(always)]
    fn splat(v: Vec3) -> Lanes {
        Lanes { x: Vec4::splat(v.x), y: Vec4::splat(v.y), z: Vec4::splat(v.z) }
    }

    /// `Vec3::dot` lane by lane: `(x x' + y y') + z z'`.
    #[inline(always)]
    fn dot(&self, o: &Lanes) -> Vec4 {
        (self.x * o.x + self.y * o.y) + self.z * o.z
    }

    /// `k * v` (`f32` times `Vec3`) lane by lane.
    #[inline(always)]
    fn scaled(&self, k: Vec4) -> Lanes {
        Lanes { x: k * self.x, y: k * self.y, z: k * self.z }
    }

    /// `Vec3::normalize_or_zero` lane by lane: `rcp = 1 / sqrt(v · v)`, then
    /// `v * rcp` where `rcp` is finite and positive, else zero.
    #[inline(always)]
    fn normalize_or_zero(&self) -> Lanes {
        let rcp = Vec4::ONE / sqrt4(self.dot(self));
        let ok = rcp.is_finite_mask() & rcp.cmpgt(Vec4::ZERO);
        let pick = |c: Vec4| Vec4::select(ok, c * rcp, Vec4::ZERO);
        Lanes { x: pick(self.x), y: pick(self.y), z: pick(self.z) }
    }
}

impl std::ops::Sub for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn sub(self, o: Lanes) -> Lanes {
        Lanes { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl std::ops::Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        Lanes { x: -self.x, y: -self.y, z: -self.z }
    }
}

/// The square root of each lane, correctly rounded (as `f32::sqrt`): one
/// instruction for the four on x86-64.
#[inline(always)]
fn sqrt4(v: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_sqrt_ps};
        let m: __m128 = v.into();
        // SAFETY: SSE is part of x86-64's baseline, so `_mm_sqrt_ps` is available
        // on every x86-64 processor; it reads and writes only its register operand.
        return Vec4::from(unsafe { _mm_sqrt_ps(m) });
    }
    #[allow(unreachable_code)]
    v.to_array().map(f32::sqrt).into()
}

/// A colour's bytes as the 8-bit target stores them.
#[inline]
fn bytes(rgb: Vec3) -> [u8; 3] {
    [unorm(rgb.x), unorm(rgb.y), unorm(rgb.z)]
}

/// `bytes(rgb(x.powf(power)))` (`x` ≥ 0), without libm's `powf` where the bytes
/// cannot depend on its last bits: for std's power 32, `x^32` by five squarings in
/// `f64` is within one step of `powf`'s `f32` (checked for every `f32` in 2^-4..2
/// against glibc's `powf`; glibc documents 0.82 ULP), so below 2^-3 `powf` gives
/// 0..2^-96, taken as 0..2^-64 (no subnormal operand: those cost a microcode
/// assist each). The bytes are monotonic in the specular term (each channel
/// `base + s · spec` clamped and rounded), so when the two ends of that interval
/// give the same colour, or the same bytes, `powf`'s value gives them too;
/// otherwise (rarely) it is called.
#[inline]
fn specular_bytes(x: f32, power: f32, rgb: impl Fn(f32) -> Vec3) -> [u8; 3] {
    if let Some((lo, hi)) = specular_interval(x, power) {
        let (a, b) = (rgb(lo), rgb(hi));
        let ab = bytes(a);
        if a == b || ab == bytes(b) {
            return ab;
        }
    }
    bytes(rgb(x.powf(power)))
}

/// An interval that holds `x.powf(power)` (`x` ≥ 0), for std's power 32 and `x`
/// below 2 ([`specular_bytes`]); `None` otherwise.
#[inline(always)]
fn specular_interval(x: f32, power: f32) -> Option<(f32, f32)> {
    if !(power == 32.0 && x < 2.0) {
        return None;
    }
    if x < 0.125 {
        return Some((0.0, TINY_SPECULAR));
    }
    // (`s` is positive and finite, 2^-96..2^32: its neighbours are one bit
    // pattern away, `next_down` and `next_up` without their special cases.)
    let s = pow32(x).to_bits();
    Some((f32::from_bits(s - 1), f32::from_bits(s + 1)))
}

/// An upper bound of `x.powf(32.0)` for `x` below 2^-3 (2^-64).
const TINY_SPECULAR: f32 = 5.421_011e-20;

/// `x^32` by five squarings in `f64`, rounded once to `f32`.
#[inline]
fn pow32(x: f32) -> f32 {
    let mut d = f64::from(x);
    for _ in 0..5 {
        d *= d;
    }
    d as f32
}

/// A colour channel as the 8-bit target stores it (clamped, rounded).
#[inline]
fn unorm(x: f32) -> u8 {
    round_unit(x.clamp(0.0, 1.0) * 255.0)
}

/// `x` (in 0..=255) rounded half away from zero, as `x.round() as u8` (without a
/// libm call: `x − trunc(x)` is exact below 2^23).
#[inline]
fn round_unit(x: f32) -> u8 {
    // (`i32` rather than `u32`: one instruction each way; a negative `x` or NaN
    // gives 0 as before.)
    let t = x as i32;
    let r = if x - t as f32 >= 0.5 { t.saturating_add(1) } else { t };
    r.clamp(0, 255) as u8
}

fn f32_at(rec: &[u8], k: usize) -> f32 {
    let mut b = [0u8; 4];
    if let Some(s) = rec.get(4 * k..4 * k + 4) {
        b.copy_from_slice(s);
    }
    f32::from_le_bytes(b)
}

/// One point of a stand-in: its centre (world), size in pixels, and what std's
/// `phong_fs` reads there (its facet's normal facing the viewer, colour and
/// matteness): its colour is [`Point::rgba`], shaded when it is drawn (a renderer
/// shades its points in a loop of their own, where one point's shading overlaps
/// the next's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub pos: Vec3,
    pub size: f32,
    pub normal: Vec3,
    pub color: Vec4,
    pub matte: bool,
}

impl Point {
    /// Its colour's bytes (std's `phong_fs` under `view`; alpha the colour's).
    #[inline]
    pub fn rgba(&self, view: &View) -> [u8; 4] {
        let [r, g, b] = phong(view, self.pos, self.normal, self.color, self.matte);
        [r, g, b, unorm(self.color.w)]
    }
}

/// Appends the points standing in for one instance (its record `rec`,
/// [`INSTANCE_STRIDE`] bytes) to `out`, one per facet it shows (`scratch` holds
/// them meanwhile); `false` (and nothing appended) when it is to be drawn as a mesh.
fn stand_in(
    view: &View,
    s: &StandIn,
    facets: &[Facet],
    rec: &[u8],
    scratch: &mut Vec<Point>,
    out: &mut Vec<u8>,
) -> bool {
    let row = |r: usize| {
        Vec4::new(f32_at(rec, 4 * r), f32_at(rec, 4 * r + 1), f32_at(rec, 4 * r + 2), f32_at(rec, 4 * r + 3))
    };
    let (r0, r1, r2) = (row(0), row(1), row(2));
    let bone = rec.get(64..68).map_or(1, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    if bone != 0 {
        return false; // posed by a bone at draw time
    }
    let color = Vec4::new(f32_at(rec, 12), f32_at(rec, 13), f32_at(rec, 14), f32_at(rec, 15));
    let l = Mat3::from_cols(r0.truncate(), r1.truncate(), r2.truncate()).transpose();
    let t = Vec3::new(r0.w, r1.w, r2.w);
    if !stand_in_points(view, s, facets, l, t, color, &Placed::new(view, s, l, t), scratch) {
        return false;
    }
    for p in scratch.iter() {
        for x in [p.pos.x, p.pos.y, p.pos.z, p.size] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&p.rgba(view));
    }
    true
}

/// A stand-in's bounding sphere placed: its centre, radius and the centre's clip
/// position (what a renderer that culls by the sphere has computed already).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    pub centre: Vec3,
    pub radius: f32,
    pub clip: Vec4,
    /// The length of the view-projection's w row (without its last column).
    pub w_len: f32,
}

impl Placed {
    /// The sphere of `s` placed by the linear map `l` and translation `t`.
    #[inline]
    pub fn new(view: &View, s: &StandIn, l: Mat3, t: Vec3) -> Placed {
        let centre = l * s.centre + t;
        let scale = l.x_axis.length().max(l.y_axis.length()).max(l.z_axis.length());
        let m = &view.view_projection;
        Placed {
            centre,
            radius: s.radius * scale,
            clip: *m * centre.extend(1.0),
            w_len: Vec3::new(m.x_axis.w, m.y_axis.w, m.z_axis.w).length(),
        }
    }
}

/// The points standing in for one instance of bone 0 placed by the linear map `l`
/// and translation `t` in `color` (its sphere placed: `at`), appended to `out`
/// (cleared first), one per facet it shows; `false` (and `out` empty) when it is
/// to be drawn as a mesh. What [`stand_in`] computes from a record, for a renderer
/// that has the matrix already (the CPU renderer: no record is written).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn stand_in_points(
    view: &View,
    s: &StandIn,
    facets: &[Facet],
    l: Mat3,
    t: Vec3,
    color: Vec4,
    at: &Placed,
    out: &mut Vec<Point>,
) -> bool {
    let (cof, sign) = cofactor_and_sign(l);
    points_of(
        view,
        s,
        facets,
        color,
        at,
        out,
        |_, f| (sign * (cof * f.area), l * f.centre + t),
        |_, f| (sign * (cof * f.normal)).normalize_or_zero(),
    )
}

/// The cofactor matrix of `l`, which takes facets' normals and area vectors, and the
/// sign that flips them for a mirrored instance (as the mirrored draw's reversed
/// winding flips them).
#[inline(always)]
fn cofactor_and_sign(l: Mat3) -> (Mat3, f32) {
    let cof = Mat3::from_cols(l.y_axis.cross(l.z_axis), l.z_axis.cross(l.x_axis), l.x_axis.cross(l.y_axis));
    (cof, if l.determinant() < 0.0 { -1.0 } else { 1.0 })
}

/// What [`stand_in_points`] makes of an instance's linear part alone, for every
/// facet: made once for a run of instances that share it (a grid's squares), then
/// [`stand_in_points_oriented`] places each of them with the same bits.
#[derive(Clone, Debug, Default)]
pub struct Oriented {
    /// Per facet: its area vector and unit normal (through the cofactor matrix,
    /// flipped for a mirrored part) and its centre under the linear part.
    facets: Vec<OrientedFacet>,
}

#[derive(Clone, Copy, Debug)]
struct OrientedFacet {
    area: Vec3,
    normal: Vec3,
    centre: Vec3,
}

impl Oriented {
    /// Orients `facets` by the linear part `l`.
    pub fn set(&mut self, l: Mat3, facets: &[Facet]) {
        let (cof, sign) = cofactor_and_sign(l);
        self.facets.clear();
        self.facets.extend(facets.iter().map(|f| OrientedFacet {
            area: sign * (cof * f.area),
            normal: (sign * (cof * f.normal)).normalize_or_zero(),
            centre: l * f.centre,
        }));
    }
}

/// [`stand_in_points`] for an instance whose linear part `o` was made from
/// (by [`Oriented::set`], with these `facets`), at translation `t`: the same points.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn stand_in_points_oriented(
    view: &View,
    s: &StandIn,
    facets: &[Facet],
    o: &Oriented,
    t: Vec3,
    color: Vec4,
    at: &Placed,
    out: &mut Vec<Point>,
) -> bool {
    // (`o` was made from `facets`: every index is in it.)
    points_of(
        view,
        s,
        facets,
        color,
        at,
        out,
        |k, _| o.facets.get(k).map_or((Vec3::NAN, Vec3::NAN), |f| (f.area, f.centre + t)),
        |k, _| o.facets.get(k).map_or(Vec3::NAN, |f| f.normal),
    )
}

/// The points of [`stand_in_points`], with each facet's area vector and centre
/// (`placed`) and unit normal (`normal`, called
/// with the facet's index only where it is seen).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn points_of(
    view: &View,
    s: &StandIn,
    facets: &[Facet],
    color: Vec4,
    at: &Placed,
    out: &mut Vec<Point>,
    placed: impl Fn(usize, &Facet) -> (Vec3, Vec3),
    normal: impl Fn(usize, &Facet) -> Vec3,
) -> bool {
    out.clear();
    if !(s.closed || view.flat) {
        return false; // open in a 3-D model
    }
    let (p, radius, c) = (at.centre, at.radius, at.clip);
    let m = &view.view_projection;
    // In front of the eye with all of its bounding sphere (else the clipper decides).
    let w_axis = Vec3::new(m.x_axis.w, m.y_axis.w, m.z_axis.w);
    let ahead = c.w - radius * at.w_len;
    if ahead.is_nan() || ahead <= 0.0 || !p.is_finite() {
        return false;
    }
    // Pixels per world unit at p: the rows of the Jacobian of the pixel position.
    let (nx, ny) = (c.x / c.w, c.y / c.w);
    let row_of = |k: usize| Vec3::new(m.x_axis[k], m.y_axis[k], m.z_axis[k]);
    let j0 = (row_of(0) - nx * w_axis) * (0.5 * view.width / c.w);
    let j1 = (row_of(1) - ny * w_axis) * (0.5 * view.height / c.w);
    let jn = j0.cross(j1);
    let diameter = 2.0 * radius * jn.length().sqrt();
    if diameter.is_nan() || diameter > POINT_PIXELS {
        return false;
    }
    let mut area = 0.0f32;
    for (k, f) in facets.iter().enumerate() {
        let (a, q) = placed(k, f);
        let facing = a.dot(view.eye - q);
        if s.closed && facing <= 0.0 {
            continue;
        }
        let px = a.dot(jn).abs();
        if !(px > 0.0 && px.is_finite()) {
            continue; // seen edge-on: it covers nothing
        }
        let mut n = normal(k, f);
        if facing < 0.0 {
            n = -n;
        }
        let c = (color + Vec4::from_array(f.delta)).clamp(Vec4::ZERO, Vec4::ONE);
        out.push(Point { pos: q, size: px.sqrt(), normal: n, color: c, matte: f.matte });
        area += px;
    }
    let disc = std::f32::consts::PI * 0.25 * diameter * diameter;
    if diameter > POINT_ANY_PIXELS && (area.is_nan() || area < COMPACT * disc) {
        out.clear();
        return false;
    }
    true
}

/// Chooses, for every instance of the draws (`stand_ins`: each draw's), a point or
/// the mesh, reading the instance records
/// from `records` (the instance buffer). The work is split over `threads` threads;
/// the outcome is the same for any count.
pub fn select(
    view: &View,
    draws: &[InstancedDraw],
    stand_ins: &[StandIn],
    facets: &[Facet],
    records: &[u8],
    threads: usize,
) -> Selection {
    let stride = INSTANCE_STRIDE as usize;
    // (draw, first instance, count) pieces of at most CHUNK instances.
    const CHUNK: u32 = 1 << 14;
    let mut pieces = Vec::new();
    for (k, d) in draws.iter().enumerate() {
        let mut first = d.first_instance;
        let end = d.first_instance + d.instance_count;
        while first < end {
            let n = CHUNK.min(end - first);
            pieces.push((k, first, n));
            first += n;
        }
    }
    let work = |&(k, first, n): &(usize, u32, u32)| -> (Vec<u8>, Vec<u32>) {
        let mut points = Vec::new();
        let mut kept = Vec::new();
        let mut scratch = Vec::new();
        let s = stand_ins.get(k).copied();
        let fs = s.and_then(|s| facets.get(s.first_facet as usize..(s.first_facet + s.n_facets) as usize));
        for i in first..first + n {
            let rec = records.get(i as usize * stride..(i as usize + 1) * stride).unwrap_or(&[]);
            let as_points = match (s, fs) {
                (Some(s), Some(fs)) => stand_in(view, &s, fs, rec, &mut scratch, &mut points),
                _ => false,
            };
            if !as_points {
                kept.push(i);
            }
        }
        (points, kept)
    };
    let threads = threads.clamp(1, pieces.len().max(1));
    let results: Vec<(Vec<u8>, Vec<u32>)> = if threads == 1 {
        pieces.iter().map(work).collect()
    } else {
        let per = pieces.len().div_ceil(threads);
        std::thread::scope(|scope| {
            let handles: Vec<_> =
                pieces.chunks(per).map(|c| (c, scope.spawn(move || c.iter().map(work).collect::<Vec<_>>()))).collect();
            // (A thread that panicked has its share done again here: none is lost.)
            handles.into_iter().flat_map(|(c, h)| h.join().unwrap_or_else(|_| c.iter().map(work).collect())).collect()
        })
    };
    let mut out = Selection { points: Vec::with_capacity(results.len()), kept: vec![Vec::new(); draws.len()] };
    for ((k, ..), (points, kept)) in pieces.iter().zip(results) {
        if !points.is_empty() {
            out.points.push(points);
        }
        if let Some(list) = out.kept.get_mut(*k) {
            list.extend(kept);
        }
    }
    out
}

#[cfg(test)]
mod tests;
