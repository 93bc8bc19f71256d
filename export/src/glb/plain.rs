//! The flat writer's usual prototype run ([`PlainWriter::run`]): instances of one
//! prototype in one colour, written as 28-byte records (position, normal, 8-bit
//! colour) without indices or skin, in oriented triangle order.
//!
//! What depends on the prototype alone is worked out once ([`PlainProto`]): its
//! distinct positions (as the splatted coordinates `Mat3A * Vec3A` multiplies by),
//! its distinct records and its corners as indices into them, every index checked.
//! What depends on the frame's linear part alone (the matrix, the mirroring, the
//! prototype's normals as written) is made once per distinct q, q̂ and prototype
//! and kept in a [`Memo`]. Per instance that leaves a straight-line loop: the
//! distinct positions placed and bounded (four at a time), the distinct record
//! tails (normal and colour) filled, and each corner's record copied into the
//! output as its position and its tail, a slot of many instances at a time. A face
//! of one tail (one normal, one colour) keeps it in registers: the normal's x rides
//! in the placed positions' fourth lane, the rest is 12 bytes.
//!
//! Every number is computed by the same operations, in the same order, as the
//! per-instance path of `flat.rs` (`ProtoFrame`), so the bytes are the same.

use super::builder::{Sink, SINK_BYTES};
use super::instanced::packed_frame;
use super::memo::{pair, Memo};
use crate::{unit_normal, ExportError};
use glam::{Mat3, Vec3, Vec3A, Vec4};
use mdg_vm::output::PackedFrame;

/// The bytes of a plain record: position, normal (three `f32` each), RGBA8 colour.
pub(super) const PLAIN_STRIDE: usize = 28;

/// The normals a [`Placing`] holds; a prototype with more distinct normals has
/// them made per instance (through a memo of the written normal).
const HELD_NORMALS: usize = 4;

/// The exact bounds of the positions a walk wrote (finite), per coordinate.
pub(super) struct Bounds {
    lo: Vec3A,
    hi: Vec3A,
}

impl Bounds {
    pub(super) fn new() -> Bounds {
        Bounds { lo: Vec3A::INFINITY, hi: Vec3A::NEG_INFINITY }
    }

    #[inline(always)]
    pub(super) fn add(&mut self, q: Vec3A) {
        self.lo = self.lo.min(q);
        self.hi = self.hi.max(q);
    }

    /// The lowest and highest coordinates.
    pub(super) fn arrays(&self) -> ([f32; 3], [f32; 3]) {
        (self.lo.to_array(), self.hi.to_array())
    }
}

/// A placed position as written: non-finite coordinates replaced by 0.
#[inline(always)]
pub(super) fn finite_position(q: Vec3A) -> Vec3A {
    match q.is_finite() {
        true => q,
        false => Vec3A::from(crate::finite3(q.to_array())),
    }
}

/// A normal mapped by a frame's linear map (`lin * n`), as written: normalised
/// twice (once expanding the prototype, once writing), +z where it has no length.
#[inline]
pub(super) fn written_normal(m: Vec3) -> [f32; 3] {
    unit_normal(m.normalize_or(Vec3::Z).to_array())
}

/// Three floats as little-endian bytes.
#[inline(always)]
pub(super) fn float3_bytes(p: [f32; 3]) -> [u8; 12] {
    let mut b = [0u8; 12];
    for (d, x) in b.chunks_exact_mut(4).zip(p) {
        d.copy_from_slice(&x.to_le_bytes());
    }
    b
}

/// The most distinct positions, and distinct (normal, colour) pairs, of a
/// prototype [`PlainProto`] takes: its tables are indexed by bytes.
pub(super) const PLAIN_TABLE: usize = 256;

/// A prototype's tables for [`PlainWriter::run`].
pub(super) struct PlainProto {
    /// The shared mesh (part of the [`Placing`] memo's key).
    mesh: u32,
    /// Distinct positions, each as its coordinates splatted: `[x x x 0, y y y 0,
    /// z z z −0]` (the lanes of `Mat3A * Vec3A`; the fourth lanes' products with
    /// the matrix's zeros sum to −0, so a placed position's fourth lane is the
    /// translation's, bit for bit), in groups of four (placed in one pass of an
    /// unrolled loop), the last group filled up with copies of the last position
    /// (placed, bounded and never written).
    positions: Vec<[[Vec4; 3]; 4]>,
    /// Distinct normals (before the frame).
    normals: Vec<Vec3>,
    /// Distinct (normal, colour) pairs of the corners: a record's last 16 bytes.
    tails: Vec<(usize, usize)>,
    /// The corners in oriented triangle order, each as its position and its tail,
    /// for a frame that does not mirror (`[0]`) and one that does (`[1]`).
    corners: [Vec<(u8, u8)>; 2],
    /// Where every corner has one tail whose normal a [`Placing`] holds (a flat
    /// face of one colour: a square, a triangle), that normal's index: the
    /// normal's x is then placed as the positions' fourth lane and the rest of
    /// the tail kept in registers, not in [`PlainWriter::tails`].
    one_tail: Option<usize>,
}

impl PlainProto {
    /// The tables of prototype `mesh` from its distinct positions and normals, the
    /// number of its distinct colours and its corners (unmirrored, mirrored) as
    /// position, normal and colour indices; `None` when an index is out of range,
    /// the two corner lists differ in length, or there are more than
    /// [`PLAIN_TABLE`] positions or (normal, colour) pairs.
    pub(super) fn new(
        mesh: u32,
        positions: &[Vec3A],
        normals: &[Vec3],
        n_colors: usize,
        corners: &[Vec<[u32; 3]>; 2],
    ) -> Option<PlainProto> {
        let sizes = [positions.len(), normals.len(), n_colors];
        let valid = corners.iter().flatten().all(|c| (0..3).all(|k| (c[k] as usize) < sizes[k]));
        if !valid || corners[0].len() != corners[1].len() || positions.len() > PLAIN_TABLE {
            return None;
        }
        let mut tails: Vec<(usize, usize)> = Vec::new();
        let mut table = |c: &[u32; 3]| -> Option<(u8, u8)> {
            let tail = (c[1] as usize, c[2] as usize);
            let k = match tails.iter().position(|t| *t == tail) {
                Some(k) => k,
                None => {
                    tails.push(tail);
                    tails.len() - 1
                }
            };
            Some((u8::try_from(c[0]).ok()?, u8::try_from(k).ok()?))
        };
        let unmirrored = corners[0].iter().map(&mut table).collect::<Option<Vec<_>>>()?;
        let mirrored = corners[1].iter().map(&mut table).collect::<Option<Vec<_>>>()?;
        Some(PlainProto {
            mesh,
            positions: positions
                .chunks(4)
                .map(|g| std::array::from_fn(|k| g.get(k).or(g.last()).copied().unwrap_or_default()))
                .map(|g: [Vec3A; 4]| g.map(|p| [p.x, p.y, p.z].map(|c| Vec4::new(c, c, c, -0.0))))
                .collect(),
            normals: normals.to_vec(),
            one_tail: tails.first().map(|t| t.0).filter(|_| tails.len() == 1 && normals.len() <= HELD_NORMALS),
            tails,
            corners: [unmirrored, mirrored],
        })
    }

    /// The vertices an instance writes.
    pub(super) fn corners_per_instance(&self) -> usize {
        self.corners[0].len()
    }
}

/// What a frame's linear part gives a prototype: the matrix's columns
/// ([`mdg_vm::geom::quat::Frame::axes`], fourth lanes 0), whether it mirrors, and
/// the prototype's first [`HELD_NORMALS`] normals as written.
#[derive(Clone, Copy, Default)]
struct Placing {
    lin: [Vec4; 3],
    mirrored: bool,
    normals: [[u8; 12]; HELD_NORMALS],
}

/// The state of the plain runs of one flat primitive: the memos, and the placed
/// positions and record tails of the instance being written.
pub(super) struct PlainWriter {
    /// Per q, q̂ and prototype, its [`Placing`].
    placings: Memo<5, Placing>,
    /// Per normal mapped by a linear map (before normalising), the normal as
    /// written (the normals past [`HELD_NORMALS`]).
    unit_normals: Memo<2, [u8; 12]>,
    /// The normals past [`HELD_NORMALS`] of the instance, as written.
    normals: Vec<[u8; 12]>,
    /// The instance's placed positions (a fourth lane 0, overwritten in the record
    /// by the tail) and record tails (normal and colour bytes), indexed by
    /// [`PlainProto::corners`]' bytes.
    placed: Box<[Vec4; PLAIN_TABLE]>,
    tails: Box<[[u8; 16]; PLAIN_TABLE]>,
}

impl Default for PlainWriter {
    fn default() -> PlainWriter {
        PlainWriter {
            placings: Memo::new(),
            unit_normals: Memo::new(),
            normals: Vec::new(),
            placed: Box::new([Vec4::ZERO; PLAIN_TABLE]),
            tails: Box::new([[0; 16]; PLAIN_TABLE]),
        }
    }
}

impl PlainWriter {
    /// The records of the instances of `proto` in frames `frames`, whose vertex
    /// colours are `colors` (encoded, the first four bytes written), into `sink`;
    /// the placed positions added to `bounds`.
    pub(super) fn run(
        &mut self,
        proto: &PlainProto,
        colors: &[[u8; 8]],
        frames: &[PackedFrame],
        sink: &mut Sink,
        bounds: &mut Bounds,
    ) -> Result<(), ExportError> {
        let short = || ExportError::Inconsistent("flat geometry: a prototype colour out of range");
        // (The colour bytes of the tails, put in once per run.)
        for (d, &(_, c)) in self.tails.iter_mut().zip(&proto.tails) {
            d[12..16].copy_from_slice(&colors.get(c).ok_or_else(short)?[..4]);
        }
        self.normals.resize(proto.normals.len().saturating_sub(HELD_NORMALS), [0; 12]);
        let per = proto.corners_per_instance();
        if per == 0 {
            return Ok(());
        }
        let mut b = (bounds.lo.extend(0.0), bounds.hi.extend(0.0));
        match proto.one_tail.is_some() {
            true => self.instances::<true>(proto, frames, sink, &mut b)?,
            false => self.instances::<false>(proto, frames, sink, &mut b)?,
        }
        *bounds = Bounds { lo: Vec3A::from_vec4(b.0), hi: Vec3A::from_vec4(b.1) };
        Ok(())
    }

    /// The records of [`PlainWriter::run`]'s instances (of at least one corner)
    /// into `sink`, their positions added to the bounds `b`; `ONE`:
    /// [`PlainProto::one_tail`].
    #[inline(always)]
    fn instances<const ONE: bool>(
        &mut self,
        proto: &PlainProto,
        frames: &[PackedFrame],
        sink: &mut Sink,
        b: &mut (Vec4, Vec4),
    ) -> Result<(), ExportError> {
        let per = proto.corners_per_instance().max(1);
        if per * PLAIN_STRIDE > SINK_BYTES {
            // (A prototype of more corners than a slot holds: each instance's
            // records in slots of at most SINK_BYTES.)
            for frame in frames {
                let (mirrored, tail) = self.place::<ONE>(proto, frame, b);
                for corners in proto.corners[usize::from(mirrored)].chunks(SINK_BYTES / PLAIN_STRIDE) {
                    let out = sink.slot(PLAIN_STRIDE * corners.len())?;
                    self.copy_corners::<ONE>(out.as_chunks_mut::<PLAIN_STRIDE>().0, corners, tail);
                }
            }
        } else {
            // As many instances as a slot holds at a time.
            for frames in frames.chunks(SINK_BYTES / (per * PLAIN_STRIDE)) {
                let out = sink.slot(PLAIN_STRIDE * per * frames.len())?;
                for (out, frame) in out.as_chunks_mut::<PLAIN_STRIDE>().0.chunks_exact_mut(per).zip(frames) {
                    let (mirrored, tail) = self.place::<ONE>(proto, frame, b);
                    self.copy_corners::<ONE>(out, &proto.corners[usize::from(mirrored)], tail);
                }
            }
        }
        Ok(())
    }

    /// Places the distinct positions of `proto`'s instance in `frame` and fills in
    /// its tails' normals, its positions added to the bounds `(lo, hi)` (fourth
    /// lanes unused); whether the frame mirrors, and (`ONE`, see
    /// [`PlainProto::one_tail`]: instead of filling in the tails) the one tail.
    #[inline(always)]
    fn place<const ONE: bool>(
        &mut self,
        proto: &PlainProto,
        frame: &PackedFrame,
        bounds: &mut (Vec4, Vec4),
    ) -> (bool, u128) {
        let key = [
            pair(frame[0], frame[1]),
            pair(frame[2], frame[3]),
            pair(frame[4], frame[5]),
            pair(frame[6], frame[7]),
            u64::from(proto.mesh),
        ];
        let pl = self.placings.get_ref(key, || placing(frame, &proto.normals));
        let held = &pl.normals;
        // (`ONE`: the normal's x bits ride in the positions' fourth lane, which
        // the record's normal then overwrites no more: the position's 16 bytes are
        // the record's first 16; what is left of the tail is 12 bytes.)
        let (w, one) = match proto.one_tail.filter(|_| ONE) {
            Some(n) => {
                let (normal, mut rest) = (held[n % HELD_NORMALS], [0u8; 16]);
                rest[0..8].copy_from_slice(&normal[4..12]);
                rest[8..12].copy_from_slice(&self.tails[0][12..16]);
                let [x0, x1, x2, x3, ..] = normal;
                (f32::from_le_bytes([x0, x1, x2, x3]), u128::from_le_bytes(rest))
            }
            None => (0.0, 0),
        };
        let u = Vec4::new(frame[8], frame[9], frame[10], w);
        let [a, b, c] = pl.lin;
        // (`u + lin * p`, as `ProtoFrame::position` sums it: x, then y, then z, the
        // same operations lane by lane; the bounds taken aside and kept where
        // every position is finite.)
        // (Every position is finite where their sum is: an infinite or NaN
        // coordinate makes it so, and a sum that overflows only sends a finite
        // instance down the exact way below, which gives the same bits.)
        let (mut lo, mut hi, mut sum) = (bounds.0, bounds.1, Vec4::ZERO);
        for (d, g) in self.placed.as_chunks_mut::<4>().0.iter_mut().zip(&proto.positions) {
            for (d, p) in d.iter_mut().zip(g) {
                let q = u + ((a * p[0] + b * p[1]) + c * p[2]);
                sum += q;
                lo = lo.min(q);
                hi = hi.max(q);
                *d = q;
            }
        }
        if sum.is_finite() {
            *bounds = (lo, hi);
        } else {
            // (Some coordinate overflowed: placed again, each position made finite.)
            for (d, p) in self.placed.iter_mut().zip(proto.positions.iter().flatten()) {
                let q = u + ((a * p[0] + b * p[1]) + c * p[2]);
                let q = finite_position(Vec3A::from_vec4(q)).extend(q.w);
                bounds.0 = bounds.0.min(q);
                bounds.1 = bounds.1.max(q);
                *d = q;
            }
        }
        let mirrored = pl.mirrored;
        if ONE {
            return (mirrored, one);
        }
        if proto.normals.len() > HELD_NORMALS {
            let lin = Mat3::from_cols(a.truncate(), b.truncate(), c.truncate());
            for (d, &n) in self.normals.iter_mut().zip(&proto.normals[HELD_NORMALS..]) {
                let m = lin * n;
                *d = self
                    .unit_normals
                    .get([pair(m.x, m.y), u64::from(m.z.to_bits())], || float3_bytes(written_normal(m)));
            }
        }
        if proto.normals.len() <= HELD_NORMALS {
            // (Every tail's normal is held: a copy each, no look-up elsewhere.)
            for (d, &(n, _)) in self.tails.iter_mut().zip(&proto.tails) {
                d[0..12].copy_from_slice(&held[n % HELD_NORMALS]);
            }
            return (mirrored, 0);
        }
        for (d, &(n, _)) in self.tails.iter_mut().zip(&proto.tails) {
            let n = match n.checked_sub(HELD_NORMALS) {
                None => held.get(n),
                Some(k) => self.normals.get(k),
            };
            if let Some(n) = n {
                d[0..12].copy_from_slice(n);
            }
        }
        (mirrored, 0)
    }

    /// Each corner's record (its placed position and its tail; `ONE`: the
    /// position with the normal's x, then the tail's last 12 bytes `one`, the same
    /// for every corner) into `out`.
    #[inline(always)]
    fn copy_corners<const ONE: bool>(&self, out: &mut [[u8; PLAIN_STRIDE]], corners: &[(u8, u8)], one: u128) {
        for (d, &(p, t)) in out.iter_mut().zip(corners) {
            // (The position's 16 bytes, the last four then overwritten by the tail.)
            let p = self.placed[usize::from(p)].to_array();
            for (b, x) in d[0..16].as_chunks_mut::<4>().0.iter_mut().zip(p) {
                *b = x.to_le_bytes();
            }
            match ONE {
                true => d[16..28].copy_from_slice(&one.to_le_bytes()[0..12]),
                false => d[12..28].copy_from_slice(&self.tails[usize::from(t)]),
            }
        }
    }
}

/// The [`Placing`] of the frame `frame` for a prototype of normals `normals`.
fn placing(frame: &PackedFrame, normals: &[Vec3]) -> Placing {
    let (lin, mirrored) = packed_frame(frame).linear();
    let mut held = [[0u8; 12]; HELD_NORMALS];
    for (d, &n) in held.iter_mut().zip(normals) {
        *d = float3_bytes(written_normal(lin * n));
    }
    Placing { lin: [lin.x_axis, lin.y_axis, lin.z_axis].map(|c| c.extend(0.0)), mirrored, normals: held }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{components, parse_glb};
    use super::super::write_glb;
    use crate::{color_at, finite3, linear_color, normal_at};
    use glam::{Quat, Vec3};
    use mdg_vm::geom::quat::Frame;
    use mdg_vm::output::{Instance, Mesh, Output, SharedKind, SharedMesh};

    /// A box of twelve triangles (8 positions, 6 normals: more than a placing
    /// holds), its top in a second colour; a fan of 100 triangles whose 300
    /// vertices are all distinct (more positions than the plain tables take); a
    /// strip of two normals and more corners than a slot holds.
    fn prototypes() -> Vec<SharedMesh> {
        let mut bx = Mesh::default();
        for axis in 0..3 {
            for side in [-1.0f32, 1.0] {
                let n = Vec3::AXES[axis] * side;
                let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
                let c = |a: f32, b: f32| (n + u * a + v * b) * 0.5;
                let delta = if axis == 2 && side > 0.0 { [0.2, -0.2, 0.0, 0.0] } else { [0.0; 4] };
                for p in [c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0), c(-1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0)] {
                    bx.push_vertex(p, n, delta, [0.0; 4], 0);
                }
                let k = bx.n_vertices() as u32 - 6;
                bx.push_triangle([k, k + 1, k + 2], side < 0.0);
                bx.push_triangle([k + 3, k + 4, k + 5], side < 0.0);
            }
        }
        let mut fan = Mesh::default();
        for t in 0..100 {
            let a = |k: f32| 0.0628 * (t as f32 + k);
            for p in [
                Vec3::new(0.0, 0.0, 0.01 * t as f32),
                Vec3::new(a(0.0).cos(), a(0.0).sin(), 0.0),
                Vec3::new(a(1.0).cos(), a(1.0).sin(), 0.001),
            ] {
                fan.push_vertex(p, Vec3::new(0.0, 0.1, 1.0), [0.0, 0.0, -0.4, 0.0], [0.0; 4], 0);
            }
            fan.push_triangle([3 * t, 3 * t + 1, 3 * t + 2], false);
        }
        // A strip of 12,500 triangles over four positions: more corners than a
        // slot of the sink holds.
        let mut strip = Mesh::default();
        for t in 0..12_500u32 {
            for k in 0..3 {
                let a = std::f32::consts::FRAC_PI_2 * ((t + k) % 4) as f32;
                let n = if t % 3 == 0 { Vec3::Z } else { Vec3::new(0.0, 1.0, 1.0) };
                strip.push_vertex(Vec3::new(a.cos(), a.sin(), 0.0), n, [0.0; 4], [0.0; 4], 0);
            }
            strip.push_triangle([3 * t, 3 * t + 1, 3 * t + 2], t % 2 == 1);
        }
        // Flat faces of one normal and one colour (the one-tail way): a square (one
        // group of four positions), a triangle and a pentagon (groups filled up
        // with copies), and a strip of 12,500 triangles (more corners than a slot).
        // (Three vertices a triangle, in order: no index buffer.)
        let face = |points: &[[f32; 2]], tris: &[[u32; 3]], n: Vec3, delta: [f32; 4]| {
            let mut m = Mesh::default();
            for (k, t) in tris.iter().enumerate() {
                for p in t.map(|i| points[i as usize]) {
                    m.push_vertex(Vec3::new(p[0], p[1], 0.1 * p[0]), n, delta, [0.0; 4], 0);
                }
                let v = 3 * k as u32;
                m.push_triangle([v, v + 1, v + 2], k % 2 == 1);
            }
            m
        };
        let square = face(
            &[[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]],
            &[[0, 1, 2], [0, 2, 3]],
            Vec3::new(0.3, -0.2, 1.0),
            [0.2, -0.2, 0.0, 0.0],
        );
        let triangle = face(&[[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]], &[[0, 1, 2]], Vec3::new(-1.0, 0.5, 0.2), [0.0; 4]);
        let pentagon = face(
            &[[1.0, 0.0], [0.31, 0.95], [-0.81, 0.59], [-0.81, -0.59], [0.31, -0.95]],
            &[[0, 1, 2], [0, 2, 3], [0, 3, 4]],
            Vec3::Z,
            [0.0, 0.0, -0.4, 0.0],
        );
        let sheet_tris: Vec<[u32; 3]> = (0..12_500u32).map(|t| [t % 4, (t + 1) % 4, (t + 2) % 4]).collect();
        let sheet = face(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], &sheet_tris, Vec3::X, [0.0; 4]);
        // (Its normal's x, mirrored in x, is −0: the fourth lane's bits.)
        let tilted = face(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &[[0, 1, 2]], Vec3::new(0.0, -0.6, -0.8), [0.0; 4]);
        [
            ("box", bx),
            ("fan", fan),
            ("strip", strip),
            ("square", square),
            ("triangle", triangle),
            ("pentagon", pentagon),
            ("sheet", sheet),
            ("tilted", tilted),
        ]
        .map(|(name, mesh)| {
            let kind = SharedKind::Prototype { face_normals: vec![None; mesh.triangles.len()] };
            SharedMesh { name: name.into(), mesh, kind }
        })
        .into()
    }

    /// Instances of the prototypes in runs (broken by colour changes), in frames
    /// of every turn, size and mirroring, each frame used again (the placings'
    /// memo hits) and some so large that positions overflow to infinity.
    fn mixed_instances() -> Output {
        let mut out = Output { shared_meshes: prototypes(), ..Output::default() };
        let mut rng = mdg_vm::rng::Rng::new(37);
        let mut unit = || (rng.bits() >> 40) as f32 / (1u64 << 24) as f32;
        let mut frames = Vec::new();
        for i in 0..40 {
            let axis = Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(Vec3::Z);
            let size = match i % 8 {
                6 => 1e38,
                7 => 3e38,
                _ => 10f32.powf(2.0 * unit() - 1.0),
            };
            // (Some placed at an infinite x: every corner's x is not finite, but
            // the normals are, and their x rides in the one-tail positions' fourth
            // lane.)
            let far = if i % 8 == 5 { Vec3::new(f32::INFINITY, 0.0, 0.0) } else { Vec3::ZERO };
            let mut f = Frame::identity()
                .translate(far + Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * 10.0)
                .rotate(Quat::from_axis_angle(axis, 7.0 * unit()))
                .scale(size);
            if size > 2e38 {
                // (Placed far out along the scaled axes: corners overflow.)
                f = f.translate(Vec3::splat(0.9));
            }
            if i % 3 == 0 {
                f = f.reflect(Vec3::Y);
            }
            frames.push(f);
        }
        for k in 0..400usize {
            let color = [0.8, if k % 50 < 25 { 0.6 } else { 1.0 }, 1.0, 1.0];
            let mesh = match k % 100 {
                0 => 2,
                10..30 => 3,
                30..45 => 4,
                45..60 => 5,
                60 => 6,
                70.. => 1,
                _ => 0,
            };
            out.instances.push(Instance { frame: frames[(k * 7) % 40], color, mesh, bone: 0, lin: 0, at: 0 });
        }
        for size in [1.0, 2.0, 0.5] {
            let frame = Frame::identity().translate(Vec3::Y).reflect(Vec3::X).scale(size);
            out.instances.push(Instance { frame, color: [1.0; 4], mesh: 7, bone: 0, lin: 0, at: 0 });
        }
        out
    }

    /// Writes `out`'s flat file and checks that its positions, normals and colours
    /// are those of the expanded mesh (`Output::vertex_mesh`), bit for bit, and its
    /// POSITION bounds the data's; the positions as written.
    fn check_flat_file(out: &Output) -> Vec<f64> {
        let mut b = Vec::new();
        write_glb(out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let attrs = &json["meshes"][0]["primitives"][0]["attributes"];
        let read = |name: &str| components(&bin, &json, attrs[name].as_u64().expect(name));
        let (positions, normals, colors) = (read("POSITION"), read("NORMAL"), read("COLOR_0"));
        // (8-bit colours: the plain record.)
        let color_type = &json["accessors"][attrs["COLOR_0"].as_u64().expect("colours") as usize]["componentType"];
        assert_eq!(color_type.as_u64(), Some(5121));
        let m = out.vertex_mesh();
        let (mut want_p, mut want_n, mut want_c) = (Vec::new(), Vec::new(), Vec::new());
        for (t, tri) in m.triangles.iter().enumerate() {
            let o = if m.mirrored[t] { [tri[0], tri[2], tri[1]] } else { *tri };
            for v in o.map(|v| v as usize) {
                want_p.extend(finite3(m.positions[v]).map(f64::from));
                want_n.extend(normal_at(&m, v).map(f64::from));
                want_c.extend(linear_color(color_at(&m, v)).map(|x| f64::from((x * 255.0).round())));
            }
        }
        let first_wrong = |got: &[f64], want: &[f64]| {
            assert_eq!(got.len(), want.len());
            got.iter().zip(want).position(|(a, b)| (*a as f32).to_bits() != (*b as f32).to_bits())
        };
        assert_eq!(first_wrong(&positions, &want_p), None, "positions");
        assert_eq!(first_wrong(&normals, &want_n), None, "normals");
        let colors: Vec<f64> = colors.iter().map(|c| (c * 255.0).round()).collect();
        assert_eq!(first_wrong(&colors, &want_c), None, "colours");
        let a = &json["accessors"][attrs["POSITION"].as_u64().expect("positions") as usize];
        for c in 0..3 {
            let lo = positions.iter().skip(c).step_by(3).fold(f64::INFINITY, |a, &x| a.min(x));
            let hi = positions.iter().skip(c).step_by(3).fold(f64::NEG_INFINITY, |a, &x| a.max(x));
            assert_eq!(a["min"][c].as_f64().map(|x| x as f32), Some(lo as f32), "min of coordinate {c}");
            assert_eq!(a["max"][c].as_f64().map(|x| x as f32), Some(hi as f32), "max of coordinate {c}");
        }
        positions
    }

    /// The flat file of [`mixed_instances`] is the expanded mesh ([`check_flat_file`]):
    /// through the plain runs (the box: normals made past those a placing holds,
    /// positions that overflow; the strip: an instance in several slots; the
    /// square, triangle, pentagon, sheet and tilted triangle: one tail, its
    /// normal's x in the positions' fourth lane, groups of positions filled up)
    /// and the per-instance path (the fan).
    #[test]
    fn plain_runs_write_the_expanded_mesh() {
        let out = mixed_instances();
        let positions = check_flat_file(&out);
        let m = out.vertex_mesh();
        let non_finite = m.positions.iter().flatten().filter(|x| !x.is_finite()).count();
        let big = positions.iter().fold(0.0f64, |a, &x| a.max(x.abs()));
        assert!(non_finite > 0 && big > 1e37, "overflowing frames: {non_finite} non-finite, largest {big}");
        // (Boxes, fans, strips, squares, triangles, pentagons, sheets and tilted
        // triangles.)
        let corners = 72 * 36 + 120 * 300 + 4 * 37_500 + 80 * 6 + 60 * 3 + 60 * 9 + 4 * 37_500 + 3 * 3;
        assert_eq!(positions.len(), 3 * corners);
    }

    /// The copies that fill up a group of positions (the triangle's fourth, the
    /// pentagon's last three) are bounded with the others but never written: the
    /// bounds of small instances alone are their corners'.
    #[test]
    fn filled_up_groups_leave_the_bounds_alone() {
        for mesh in [4, 5] {
            let mut out = Output { shared_meshes: prototypes(), ..Output::default() };
            for k in 0..5 {
                let frame = Frame::identity()
                    .translate(Vec3::new(k as f32, -2.0, 0.5))
                    .rotate(Quat::from_rotation_z(0.7 * k as f32))
                    .scale(0.3 + 0.2 * k as f32);
                out.instances.push(Instance { frame, color: [1.0; 4], mesh, bone: 0, lin: 0, at: 0 });
            }
            let positions = check_flat_file(&out);
            assert_eq!(positions.len(), 3 * 5 * [3, 9][mesh as usize - 4]);
        }
    }
}
