//! The flat primitives of a `.glb` (the `VERTEX` group with its prototype
//! instances expanded, the sweeps, the baked instances), streamed into the file in
//! two walks: the first ([`flat_plan`]) finds the counts, the exact POSITION bounds,
//! the colour precision and whether an index buffer is needed; the second
//! ([`flat_write`]) writes the interleaved vertex records while the file is written.
//!
//! Prototype instances cost the first walk little: an instance whose frame's scale
//! shows that it lies inside the bounds found so far is not placed
//! ([`ProtoInfo::surely_within`]); only the others' vertices are computed. The
//! second walk places each instance's distinct positions and normals once and
//! encodes them once, then copies the encoded bytes into each vertex's record.

pub(super) use super::plain::Bounds;
use super::plain::{finite_position, float3_bytes, written_normal, PlainProto, PlainWriter, PLAIN_STRIDE};
use super::*;

/// Where a flat primitive's pieces come from.
pub(super) enum FlatSource<'a> {
    /// The `VERTEX` group, with the prototype instances not in `instanced` expanded
    /// (`mesh_only`: none is; the group is [`Output::mesh`] as one piece).
    Vertex { out: &'a Output, instanced: &'a [bool], mesh_only: bool },
    /// One mesh in world space (the sweeps, the baked isosurface instances).
    Mesh(&'a Mesh),
    /// One mesh made for the file (a mirrored or baked part of a scene of nodes).
    Owned(Mesh),
}

impl<'a> FlatSource<'a> {
    fn walk<'s>(&'s self, f: &mut dyn FnMut(VertexRun<'s>) -> Result<(), ExportError>) -> Result<(), ExportError> {
        let m = match self {
            FlatSource::Vertex { out, mesh_only: true, .. } => {
                // What `for_each_vertex_part` makes when it expands no instance.
                let m = &out.mesh;
                if m.n_vertices() == 0 && m.triangles.is_empty() {
                    return Ok(());
                }
                &out.mesh
            }
            FlatSource::Vertex { out, instanced, .. } => {
                // (Without instanced nodes every instance is expanded.)
                return match instanced.contains(&true) {
                    false => out.for_each_vertex_run(&|_| true, f),
                    true => out.for_each_vertex_run(&|i| !instanced.get(i).copied().unwrap_or(false), f),
                };
            }
            FlatSource::Mesh(m) => *m,
            FlatSource::Owned(m) => m,
        };
        f(VertexRun::Piece(Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: 0 }))
    }

    /// Vertices and triangles of the primitive, without walking it (a prototype
    /// instance counts its prototype's).
    pub(super) fn counts(&self) -> (usize, usize) {
        let whole = |m: &Mesh| (m.n_vertices(), m.triangles.len());
        match self {
            FlatSource::Vertex { out, mesh_only: true, .. } => whole(&out.mesh),
            FlatSource::Vertex { out, instanced, .. } => match instanced.contains(&true) {
                false => out.flat_counts_where(Groups::VERTEX, |_| true),
                true => out.flat_counts_where(Groups::VERTEX, |i| !instanced.get(i).copied().unwrap_or(false)),
            },
            FlatSource::Mesh(m) => whole(m),
            FlatSource::Owned(m) => whole(m),
        }
    }

    pub(super) fn output(&self) -> Option<&'a Output> {
        match self {
            FlatSource::Vertex { out, .. } => Some(out),
            FlatSource::Mesh(_) | FlatSource::Owned(_) => None,
        }
    }
}

/// What a prototype's expansion needs, worked out once per prototype: its distinct
/// positions (for the bounds) and normals, and whether the fast expansion applies.
struct ProtoInfo {
    /// Triangle t is vertices 3t..3t+2 and every vertex is in one triangle.
    sequential: bool,
    /// Every triangle refers to vertices of the mesh.
    valid: bool,
    n_tris: usize,
    /// A `FACENORMALS` item recomputed normals: expanded by [`expand_prototype`].
    face_normals: bool,
    /// Distinct positions, and per vertex the index of its position.
    positions: Vec<glam::Vec3A>,
    position_of: Vec<u32>,
    /// Distinct normals and colour deltas (the indices of a vertex's are in
    /// [`ProtoInfo::flat`]).
    normals: Vec<Vec3>,
    deltas: Vec<[f32; 4]>,
    /// The largest distance of a position from the origin (`f64`; infinite when a
    /// position is not finite), and the largest coordinate's size.
    radius: f64,
    extent: f32,
    /// The records an instance writes, in order, each as the indices of its
    /// position, normal and colour among those [`ProtoVertices::fill`] makes: in
    /// oriented triangle order for an instance whose frame does not mirror (`[0]`)
    /// or does (`[1]`), and in vertex order (`flat`, for a primitive with indices).
    corners: [Vec<[u32; 3]>; 2],
    flat: Vec<[u32; 3]>,
    /// The tables of the usual run (sequential, no `FACENORMALS`, at most
    /// [`super::plain::PLAIN_TABLE`] distinct positions; see [`PlainWriter::run`]).
    plain: Option<PlainProto>,
}

impl ProtoInfo {
    fn new(mesh: u32, s: &SharedMesh) -> ProtoInfo {
        let m = &s.mesh;
        let n = m.n_vertices();
        let sequential = m.triangles.len() * 3 == n
            && m.triangles
                .iter()
                .enumerate()
                .all(|(t, tri)| *tri == [3 * t as u32, 3 * t as u32 + 1, 3 * t as u32 + 2]);
        let face_normals = match &s.kind {
            SharedKind::Prototype { face_normals } => face_normals.iter().any(Option::is_some),
            SharedKind::Isosurface => false,
        };
        fn distinct<T: Copy, K: Ord>(items: impl Iterator<Item = T>, key: impl Fn(&T) -> K) -> (Vec<T>, Vec<u32>) {
            let mut seen: BTreeMap<K, u32> = BTreeMap::new();
            let mut values = Vec::new();
            let of = items
                .map(|x| {
                    *seen.entry(key(&x)).or_insert_with(|| {
                        values.push(x);
                        values.len() as u32 - 1
                    })
                })
                .collect();
            (values, of)
        }
        let (positions, position_of) =
            distinct((0..n).map(|i| glam::Vec3A::from(m.positions[i])), |p| p.to_array().map(f32::to_bits));
        let (normals, normal_of) =
            distinct((0..n).map(|i| Vec3::from(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]))), |p| {
                p.to_array().map(f32::to_bits)
            });
        let (deltas, delta_of) =
            distinct((0..n).map(|i| m.colors.get(i).copied().unwrap_or([0.0; 4])), |c| c.map(f32::to_bits));
        let valid = m.triangles.iter().all(|t| t.iter().all(|&i| (i as usize) < n));
        let radius = positions.iter().map(|p| p.as_dvec3().length()).fold(0.0f64, |r, x| {
            if x.is_finite() {
                r.max(x)
            } else {
                f64::INFINITY
            }
        });
        let extent = mdg_vm::output::max_abs(&m.positions);
        // (With FACENORMALS, the instance's vertices are made one by one.)
        let flat: Vec<[u32; 3]> = match face_normals {
            true => (0..n as u32).map(|v| [v; 3]).collect(),
            false => (0..n).map(|v| [position_of[v], normal_of[v], delta_of[v]]).collect(),
        };
        let corners = [false, true].map(|mirrored| {
            let mut c = Vec::new();
            if sequential {
                for t in 0..m.triangles.len() {
                    let v = 3 * t;
                    let flip = mirrored != m.mirrored.get(t).copied().unwrap_or(false);
                    let order = if flip { [v, v + 2, v + 1] } else { [v, v + 1, v + 2] };
                    c.extend(order.iter().filter_map(|&v| flat.get(v).copied()));
                }
            }
            c
        });
        let plain = match sequential && !face_normals {
            true => PlainProto::new(mesh, &positions, &normals, deltas.len(), &corners),
            false => None,
        };
        ProtoInfo {
            corners,
            flat,
            plain,
            sequential,
            valid,
            n_tris: m.triangles.len(),
            face_normals,
            positions,
            position_of,
            normals,
            deltas,
            radius,
            extent,
        }
    }

    /// Whether every vertex of an instance in frame `f`, as [`ProtoFrame`] computes
    /// it, surely lies within `lo..=hi` (so it cannot move the bounds), by the
    /// frame's scale alone: `x ↦ q x q̂` stretches no vector by more than |q| |q̂|,
    /// so each coordinate is within `u ± |q| |q̂| · radius`, with a margin far above
    /// the `f32` rounding of the linear map and the sums (relative 10⁻³ of the reach,
    /// 10⁻⁶ of the coordinate). Only for frames that surely map finite (no overflow
    /// on the way); the bounds must be finite.
    #[inline]
    fn surely_within(&self, f: &Frame, lo: &[f32; 3], hi: &[f32; 3]) -> bool {
        if !mdg_vm::output::frame_surely_maps_finite(f, self.extent) {
            return false;
        }
        let reach = glam::DVec4::from(f.q.to_array().map(f64::from)).length()
            * glam::DVec4::from(f.qh.to_array().map(f64::from)).length()
            * self.radius
            * 1.001
            + 1e-30;
        let u = f.u.as_dvec3();
        (0..3).all(|c| {
            let margin = reach + u[c].abs() * 1e-6;
            u[c] + margin < f64::from(hi[c]) && u[c] - margin > f64::from(lo[c])
        })
    }
}

/// Per shared mesh, its [`ProtoInfo`] when it is a prototype, made on first use.
pub(super) struct ProtoInfos<'a> {
    out: &'a Output,
    infos: Vec<Option<ProtoInfo>>,
}

impl<'a> ProtoInfos<'a> {
    pub(super) fn new(out: &'a Output) -> ProtoInfos<'a> {
        ProtoInfos { out, infos: (0..out.shared_meshes.len()).map(|_| None).collect() }
    }

    #[inline]
    fn get(&mut self, mesh: u32) -> Option<&ProtoInfo> {
        let slot = self.infos.get_mut(mesh as usize)?;
        if slot.is_none() {
            *slot = Some(ProtoInfo::new(mesh, self.out.shared_meshes.get(mesh as usize)?));
        }
        slot.as_ref()
    }
}

/// Whether every 8-bit display value of `c` (clamped RGBA) survives being stored as
/// 8-bit linear `COLOR_0` and read back: sRGB's dark end is finer than 1/255 in
/// linear light (display 1/255 is linear 0.0003), so dark colours need 16 bits.
pub(super) fn fits_8_bits(c: [f32; 4]) -> bool {
    c[..3].iter().all(|&x| {
        let shown = (x * 255.0).round();
        let stored = (crate::srgb_to_linear(x) * 255.0).round() / 255.0;
        (crate::linear_to_srgb(stored) * 255.0).round() == shown
    })
}

/// A flat primitive's layout, from a first walk: counts, bounds, and how it is stored.
pub(super) struct FlatPlan {
    pub(super) n: usize,
    pub(super) n_tris: usize,
    /// The oriented triangles are 0,1,2, 3,4,5, … up to the order within each (the
    /// index buffer would count 0…N−1): written without indices, each triangle's
    /// vertices in its oriented order.
    pub(super) sequential: bool,
    /// Some colour needs 16 bits ([`fits_8_bits`]).
    pub(super) wide: bool,
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
}

/// A prototype vertex as [`expand_prototype`] makes it and the exporters read it:
/// the frame's linear part applied, the normal normalised (twice, as the flat walk
/// does: once expanding, once writing), the colour clamped.
struct ProtoFrame {
    lin: glam::Mat3,
    /// `lin` and the translation in SIMD lanes: each lane sums the same products
    /// in the same order as `Mat3 * Vec3`, so the bits are the same.
    lin_a: glam::Mat3A,
    u_a: glam::Vec3A,
    mirrored: bool,
}

impl ProtoFrame {
    fn new(f: &Frame) -> ProtoFrame {
        let (lin, mirrored) = f.linear();
        ProtoFrame::of(lin, mirrored, f.u)
    }

    /// The frame of linear map `lin` (and its mirroring) and translation `u`.
    #[inline]
    fn of(lin: glam::Mat3, mirrored: bool, u: Vec3) -> ProtoFrame {
        ProtoFrame { lin, lin_a: glam::Mat3A::from(lin), u_a: u.into(), mirrored }
    }

    #[inline]
    fn position(&self, p: glam::Vec3A) -> glam::Vec3A {
        finite_position(self.u_a + self.lin_a * p)
    }

    #[inline]
    fn normal(&self, n: Vec3) -> [f32; 3] {
        self.unit(self.lin * n)
    }

    /// A normal mapped by the linear map (`lin * n`), as written: normalised twice.
    #[inline]
    fn unit(&self, m: Vec3) -> [f32; 3] {
        written_normal(m)
    }
}

/// The colour of a prototype vertex: the instance's plus the item's delta, clamped.
#[inline]
fn proto_color(inst: [f32; 4], delta: [f32; 4]) -> [f32; 4] {
    clamp_color(
        [inst[0] + delta[0], inst[1] + delta[1], inst[2] + delta[2], inst[3] + delta[3]].map(|v| v.clamp(0.0, 1.0)),
    )
}

/// The first walk of a flat primitive: counts, colour precision, and whether the
/// triangles need an index buffer; checks every triangle. With `bounds`, also the
/// exact POSITION bounds, placing the instances' vertices (the streamed layout,
/// whose bounds must be known before its vertices are written); without, the
/// instances' frames are not read (the spooled layout: [`flat_write`] finds the
/// bounds as it places the vertices).
pub(super) fn flat_plan(
    src: &FlatSource,
    what: &str,
    infos: &mut Option<ProtoInfos>,
    bounds: bool,
) -> Result<FlatPlan, ExportError> {
    let mut plan =
        FlatPlan { n: 0, n_tris: 0, sequential: true, wide: false, lo: [f32::INFINITY; 3], hi: [f32::NEG_INFINITY; 3] };
    let mut last_color: Option<[f32; 4]> = None;
    let mut color = |plan: &mut FlatPlan, c: [f32; 4]| {
        if last_color != Some(c) {
            last_color = Some(c);
            plan.wide |= !fits_8_bits(c);
        }
    };
    let bound = |plan: &mut FlatPlan, q: [f32; 3]| {
        for (c, x) in q.into_iter().enumerate() {
            plan.lo[c] = plan.lo[c].min(x);
            plan.hi[c] = plan.hi[c].max(x);
        }
    };
    let out = src.output();
    let mut last_proto: Option<(u32, [u32; 4])> = None;
    src.walk(&mut |part| {
        match part {
            VertexRun::Piece(p) => {
                let m = p.mesh;
                if p.base as usize != plan.n {
                    return Err(ExportError::PiecesOutOfOrder { what: what.to_string() });
                }
                for v in p.vertices.clone() {
                    if bounds {
                        bound(&mut plan, finite3(m.positions[v]));
                    }
                    color(&mut plan, color_at(m, v));
                }
                for t in p.triangles.clone() {
                    let Some(o) = p.oriented(t) else {
                        return Err(ExportError::TriangleOutOfRange {
                            what: what.to_string(),
                            triangle: m.triangles[t],
                            vertices: p.vertices.len(),
                        });
                    };
                    let k = 3 * plan.n_tris as u32;
                    let mut sorted = o;
                    sorted.sort_unstable();
                    plan.sequential &= sorted == [k, k + 1, k + 2];
                    plan.n_tris += 1;
                }
                plan.n += p.vertices.len();
                plan.sequential &= plan.n == 3 * plan.n_tris;
            }
            VertexRun::Prototypes { instances, base, span } => {
                let (Some(out), Some(infos)) = (out, infos.as_mut()) else { return Ok(()) };
                let Some(info) = infos.get(span.mesh) else { return Ok(()) };
                let per = info.position_of.len();
                let frames = out.instances.packed_frames().get(instances).unwrap_or(&[]);
                for (k, frame) in frames.iter().enumerate() {
                    if base as usize + k * per != plan.n {
                        return Err(ExportError::PiecesOutOfOrder { what: what.to_string() });
                    }
                    if !info.valid {
                        let name = out.shared_meshes.get(span.mesh as usize).map_or("", |s| s.name.as_str());
                        return Err(ExportError::PrototypeTriangles {
                            what: what.to_string(),
                            prototype: name.to_string(),
                        });
                    }
                    let inst = span.instance(frame);
                    // Most instances lie inside the bounds found so far, which their
                    // scale shows without placing their vertices.
                    if bounds && !info.surely_within(&inst.frame, &plan.lo, &plan.hi) {
                        let f = ProtoFrame::new(&inst.frame);
                        for &p in &info.positions {
                            bound(&mut plan, f.position(p).to_array());
                        }
                    }
                    // (Consecutive instances mostly share their mesh and colour.)
                    let key = (inst.mesh, inst.color.map(f32::to_bits));
                    if last_proto != Some(key) {
                        last_proto = Some(key);
                        for &d in &info.deltas {
                            color(&mut plan, proto_color(inst.color, d));
                        }
                    }
                    plan.sequential &= info.sequential && plan.n == 3 * plan.n_tris;
                    plan.n += per;
                    plan.n_tris += info.n_tris;
                }
            }
        }
        Ok(())
    })?;
    Ok(plan)
}

/// Encodes vertices into a flat primitive's interleaved records: position and normal
/// (f32), colour (linear, normalised u8 or u16 RGBA), and for a skinned output the
/// bone (u16 JOINTS_0) and weights (1, 0, 0, 0).
struct VertexRecord {
    stride: usize,
    wide: bool,
    skinned: bool,
    /// The last colour's bits and its encoding: neighbouring vertices mostly share
    /// one, and the sRGB curve (three powers) would cost more than the rest of a vertex.
    last: ([u32; 4], [u8; 8]),
    /// A colour that needs 16 bits was met in 8-bit records.
    too_narrow: bool,
}

impl VertexRecord {
    fn new(wide: bool, skinned: bool) -> VertexRecord {
        let last = ([f32::NAN.to_bits(); 4], [0; 8]);
        VertexRecord { stride: flat_stride(wide, skinned), wide, skinned, last, too_narrow: false }
    }

    /// The colour `c` (clamped) as the record stores it: linear, normalised u8 or
    /// u16 RGBA (the first 4 or all 8 bytes).
    #[inline]
    fn encode(&mut self, c: [f32; 4]) -> [u8; 8] {
        let bits = c.map(f32::to_bits);
        if bits != self.last.0 {
            self.too_narrow |= !self.wide && !fits_8_bits(c);
            let l = linear_color(c);
            let mut e = [0u8; 8];
            for k in 0..4 {
                if self.wide {
                    e[2 * k..2 * k + 2].copy_from_slice(&((l[k] * 65535.0).round() as u16).to_le_bytes());
                } else {
                    e[k] = (l[k] * 255.0).round() as u8;
                }
            }
            self.last = (bits, e);
        }
        self.last.1
    }

    /// Fills `b` (one record, [`VertexRecord::stride`] bytes) with a position, a
    /// normal and a colour already encoded, and the bone.
    #[inline(always)]
    fn fill(&self, b: &mut [u8], p: &[u8; 12], n: &[u8; 12], e: &[u8; 8], bone: u32) {
        if let Some(h) = b.first_chunk_mut::<28>() {
            h[0..12].copy_from_slice(p);
            h[12..24].copy_from_slice(n);
            h[24..28].copy_from_slice(&e[..4]);
        }
        if !(self.wide || self.skinned) {
            return;
        }
        let w = if self.wide { 32 } else { 28 };
        if let Some(c) = b.get_mut(28..32).filter(|_| self.wide) {
            c.copy_from_slice(&e[4..]);
        }
        if let Some(s) = b.get_mut(w..w + 24).filter(|_| self.skinned) {
            let j = (bone.min(u16::MAX as u32) as u16).to_le_bytes();
            s[0..8].copy_from_slice(&[j[0], j[1], 0, 0, 0, 0, 0, 0]);
            s[8..12].copy_from_slice(&1.0f32.to_le_bytes());
            s[12..24].fill(0);
        }
    }

    /// One vertex's record, its position added to `bounds`.
    #[inline]
    fn put(
        &mut self,
        sink: &mut Sink,
        bounds: &mut Bounds,
        p: [f32; 3],
        n: [f32; 3],
        c: [f32; 4],
        bone: u32,
    ) -> Result<(), ExportError> {
        bounds.add(p.into());
        let e = self.encode(c);
        let stride = self.stride;
        self.fill(sink.slot(stride)?, &float3_bytes(p), &float3_bytes(n), &e, bone);
        Ok(())
    }
}

/// The bytes of one vertex of a flat primitive (see [`VertexRecord`]).
pub(super) fn flat_stride(wide: bool, skinned: bool) -> usize {
    24 + if wide { 8 } else { 4 } + if skinned { 24 } else { 0 }
}

/// One prototype instance's vertices, as [`expand_prototype`] makes them and the
/// exporters read them (positions, normals and colours, by vertex), encoded as the
/// records hold them.
#[derive(Default)]
struct ProtoVertices {
    /// The usual runs' writer (its memos and records).
    plain: PlainWriter,
    positions: Vec<[u8; 12]>,
    normals: Vec<[u8; 12]>,
    colors: Vec<[u8; 8]>,
    /// The shared mesh and instance colour (bits) whose colours `colors` holds:
    /// consecutive instances mostly share them.
    colors_of: Option<(u32, [u32; 4])>,
    scratch: Mesh,
}

impl ProtoVertices {
    /// Fills in instance `inst`'s vertices (the prototype's distinct positions,
    /// normals and colours, or one of each per vertex where `FACENORMALS` makes
    /// normals per instance), its positions added to `bounds`; whether the frame
    /// mirrors.
    fn fill(
        &mut self,
        rec: &mut VertexRecord,
        bounds: &mut Bounds,
        shared: &SharedMesh,
        info: &ProtoInfo,
        inst: &Record,
    ) -> bool {
        let f = ProtoFrame::new(&inst.frame);
        self.positions.clear();
        self.normals.clear();
        if info.face_normals {
            self.colors.clear();
            self.colors_of = None;
            self.scratch.clear();
            expand_prototype(&mut self.scratch, shared, &inst.instance(), [0.0; 4]);
            let m = &self.scratch;
            for i in 0..m.n_vertices() {
                let p = finite3(m.positions[i]);
                bounds.add(p.into());
                self.positions.push(float3_bytes(p));
                self.normals.push(float3_bytes(normal_at(m, i)));
                self.colors.push(rec.encode(color_at(m, i)));
            }
            return f.mirrored;
        }
        for &p in &info.positions {
            let p = f.position(p);
            bounds.add(p);
            self.positions.push(float3_bytes(p.to_array()));
        }
        self.normals.extend(info.normals.iter().map(|&n| float3_bytes(f.normal(n))));
        let key = (inst.mesh, inst.color.map(f32::to_bits));
        if self.colors_of != Some(key) {
            self.colors.clear();
            self.colors.extend(info.deltas.iter().map(|&d| rec.encode(proto_color(inst.color, d))));
            self.colors_of = Some(key);
        }
        f.mirrored
    }

    /// The records of a run of instances of one prototype with one colour
    /// (`span`'s, frames `frames`), without indices, 8-bit colours and no skin (the
    /// usual record, 28 bytes), by [`PlainWriter::run`].
    #[allow(clippy::too_many_arguments)]
    fn put_plain_run(
        &mut self,
        rec: &mut VertexRecord,
        bounds: &mut Bounds,
        sink: &mut Sink,
        info: &ProtoInfo,
        plain: &PlainProto,
        span: &mdg_vm::output::Span,
        frames: &[mdg_vm::output::PackedFrame],
    ) -> Result<(), ExportError> {
        let key = (span.mesh, span.color.map(f32::to_bits));
        if self.colors_of != Some(key) {
            self.colors.clear();
            self.colors.extend(info.deltas.iter().map(|&d| rec.encode(proto_color(span.color, d))));
            self.colors_of = Some(key);
        }
        self.plain.run(plain, &self.colors, frames, sink, bounds)
    }

    /// The records of `corners` (see [`ProtoInfo::corners`]) after
    /// [`ProtoVertices::fill`], in slots of at most [`SINK_BYTES`].
    #[inline]
    fn put(&self, rec: &VertexRecord, sink: &mut Sink, corners: &[[u32; 3]], bone: u32) -> Result<(), ExportError> {
        let stride = rec.stride;
        let short = || ExportError::Inconsistent("flat geometry: a prototype vertex out of range");
        for corners in corners.chunks((SINK_BYTES / stride).max(1)) {
            let b = sink.slot(corners.len() * stride)?;
            let plain = !(rec.wide || rec.skinned);
            if plain {
                // (The usual record, 28 bytes, copied whole.)
                let (records, _) = b.as_chunks_mut::<28>();
                for (r, c) in records.iter_mut().zip(corners) {
                    let (Some(p), Some(n), Some(e)) = (
                        self.positions.get(c[0] as usize),
                        self.normals.get(c[1] as usize),
                        self.colors.get(c[2] as usize),
                    ) else {
                        return Err(short());
                    };
                    let (rp, rest) = r.split_at_mut(12);
                    let (rn, re) = rest.split_at_mut(12);
                    rp.copy_from_slice(p);
                    rn.copy_from_slice(n);
                    re.copy_from_slice(&e[..4]);
                }
                continue;
            }
            for (r, c) in b.chunks_exact_mut(stride).zip(corners) {
                let (Some(p), Some(n), Some(e)) = (
                    self.positions.get(c[0] as usize),
                    self.normals.get(c[1] as usize),
                    self.colors.get(c[2] as usize),
                ) else {
                    return Err(short());
                };
                rec.fill(r, p, n, e, bone);
            }
        }
        Ok(())
    }
}

/// The walk that writes a flat primitive: its vertex records (in oriented triangle
/// order when `plan.sequential`, else in flat order followed by the u32 indices);
/// returns the exact bounds of the positions written. `plan` may be a guess (the
/// counts, with 8-bit colours and no indices, the usual case: see
/// [`super::Builder::flat_primitive`]): `None` when the walk finds that it does not
/// hold (a colour that needs 16 bits, triangles that need indices, pieces out of
/// order, a triangle out of range), and what it wrote is to be thrown away.
pub(super) fn flat_write(
    src: &FlatSource,
    plan: &FlatPlan,
    skinned: bool,
    infos: &mut Option<ProtoInfos>,
    sink: &mut Sink,
) -> Result<Option<Bounds>, ExportError> {
    let mut rec = VertexRecord::new(plan.wide, skinned);
    let mut pv = ProtoVertices::default();
    let mut bounds = Bounds::new();
    let out = src.output();
    let missing = || ExportError::Inconsistent("flat geometry: an instance of a missing shared mesh");
    // Vertices and triangles written so far; whether the plan was found not to hold.
    let (mut n, mut n_tris, mut wrong) = (0usize, 0usize, false);
    let off_plan = || ExportError::Inconsistent("flat geometry: the layout planned does not hold");
    let walked = src.walk(&mut |part| match part {
        VertexRun::Piece(p) => {
            let m = p.mesh;
            wrong |= p.base as usize != n;
            let mut vertex = |rec: &mut VertexRecord, sink: &mut Sink, v: usize| {
                rec.put(sink, &mut bounds, finite3(m.positions[v]), normal_at(m, v), color_at(m, v), m.bone(v))
            };
            if plan.sequential {
                for t in p.triangles.clone() {
                    let k = 3 * n_tris as u32;
                    let Some(o) = p.oriented(t).filter(|o| {
                        let mut sorted = *o;
                        sorted.sort_unstable();
                        sorted == [k, k + 1, k + 2]
                    }) else {
                        wrong = true;
                        return Err(off_plan());
                    };
                    for v in o {
                        vertex(&mut rec, sink, (v - p.base) as usize + p.vertices.start)?;
                    }
                    n_tris += 1;
                }
            } else {
                for v in p.vertices.clone() {
                    vertex(&mut rec, sink, v)?;
                }
                n_tris += p.triangles.len();
            }
            n += p.vertices.len();
            wrong |= plan.sequential && n != 3 * n_tris;
            if wrong {
                return Err(off_plan());
            }
            Ok(())
        }
        VertexRun::Prototypes { instances, base, span } => {
            let (Some(out), Some(infos)) = (out, infos.as_mut()) else { return Err(missing()) };
            let shared = out.shared_meshes.get(span.mesh as usize).ok_or_else(missing)?;
            let info = infos.get(span.mesh).ok_or_else(missing)?;
            let frames = out.instances.packed_frames().get(instances).ok_or_else(missing)?;
            wrong |= base as usize != n || !info.valid || (plan.sequential && !info.sequential);
            if wrong {
                return Err(off_plan());
            }
            if let Some(plain) = info.plain.as_ref().filter(|_| plan.sequential && rec.stride == PLAIN_STRIDE) {
                // The usual case: whole 28-byte records, one per distinct vertex of
                // each instance, copied to its corners.
                pv.put_plain_run(&mut rec, &mut bounds, sink, info, plain, &span, frames)?;
            } else {
                for frame in frames {
                    let inst = record_of(&span.instance(frame));
                    let mirrored = pv.fill(&mut rec, &mut bounds, shared, info, &inst);
                    let corners = if plan.sequential { &info.corners[usize::from(mirrored)] } else { &info.flat };
                    pv.put(&rec, sink, corners, inst.bone)?;
                }
            }
            n += info.flat.len() * frames.len();
            n_tris += info.n_tris * frames.len();
            Ok(())
        }
    });
    if wrong || rec.too_narrow || n != plan.n {
        return Ok(None);
    }
    walked?;
    if plan.sequential {
        return Ok(Some(bounds));
    }
    src.walk(&mut |part| {
        let tri = |sink: &mut Sink, t: [u32; 3]| {
            let mut b = [0u8; 12];
            for k in 0..3 {
                b[4 * k..4 * k + 4].copy_from_slice(&t[k].to_le_bytes());
            }
            sink.put(&b)
        };
        match part {
            VertexRun::Piece(p) => {
                for t in p.triangles.clone() {
                    tri(
                        sink,
                        p.oriented(t).ok_or(ExportError::Inconsistent("flat geometry: a triangle out of range"))?,
                    )?;
                }
            }
            VertexRun::Prototypes { instances, base, span } => {
                let Some(out) = out else { return Err(missing()) };
                let shared = out.shared_meshes.get(span.mesh as usize).ok_or_else(missing)?;
                let frames = out.instances.packed_frames().get(instances).ok_or_else(missing)?;
                let per = shared.mesh.n_vertices() as u32;
                for (k, frame) in frames.iter().enumerate() {
                    let base = base + k as u32 * per;
                    let mirrored = ProtoFrame::new(&span.instance(frame).frame).mirrored;
                    for (t, v) in shared.mesh.triangles.iter().enumerate() {
                        let v = v.map(|i| i + base);
                        let flip = mirrored != shared.mesh.mirrored.get(t).copied().unwrap_or(false);
                        tri(sink, if flip { [v[0], v[2], v[1]] } else { v })?;
                    }
                }
            }
        }
        Ok(())
    })?;
    Ok(Some(bounds))
}

#[cfg(test)]
mod tests {
    use super::super::tests::{components, parse_glb};
    use super::*;
    use glam::Quat;

    /// A prototype (a square of two triangles, as the benchmark tree draws) placed
    /// `n` times in frames of every size, turn, mirroring and place, some far out.
    fn scattered_squares(n: usize) -> Output {
        let mut out = Output::default();
        let mut square = Mesh::default();
        let corners = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]];
        for [x, y] in corners {
            square.push_vertex(Vec3::new(x, y, 0.0), Vec3::Z, [0.0; 4], [0.0; 4], 0);
        }
        square.push_triangle([0, 1, 2], false);
        square.push_triangle([3, 4, 5], false);
        let kind = SharedKind::Prototype { face_normals: vec![None; 2] };
        out.shared_meshes.push(SharedMesh { name: "square".into(), mesh: square, kind });
        let mut rng = mdg_vm::rng::Rng::new(38);
        let mut unit = || (rng.bits() >> 40) as f32 / (1u64 << 24) as f32;
        for i in 0..n {
            let axis = Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(Vec3::Z);
            // Most near the origin and of one size, so that the bounds are made by
            // the squares' corners and turns, not by where they are placed.
            let (spread, size) = match i % 10 {
                0..9 => (0.1, 1.0 + 0.1 * unit()),
                _ => (10f32.powf(4.0 * unit() - 1.0), 10f32.powf(3.0 * unit() - 2.0)),
            };
            let mut f = Frame::identity()
                .translate(Vec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * spread)
                .rotate(Quat::from_axis_angle(axis, 7.0 * unit()))
                .scale(size);
            if i % 3 == 0 {
                f = f.reflect(Vec3::X);
            }
            out.instances.push(mdg_vm::output::Instance {
                frame: f,
                color: [0.8, 0.3, 0.1, 1.0],
                mesh: 0,
                bone: 0,
                lin: 0,
                at: 0,
            });
        }
        out
    }

    /// The flat file's positions and normals are the expanded mesh's, bit for bit,
    /// where frames repeat (the memos of linear maps and normals hit) and where a
    /// frame and its mirror share q (their keys differ in q̂ alone), in runs broken
    /// by colour changes.
    #[test]
    fn repeated_and_mirrored_frames_write_the_expanded_mesh() {
        let mut out = scattered_squares(60);
        let firsts: Vec<mdg_vm::output::Instance> =
            out.instances.iter().map(|i| mdg_vm::output::Instance { color: [1.0; 4], ..i }).collect();
        out.instances = firsts.iter().copied().collect();
        for k in 0..600usize {
            let mut inst = firsts[k % 60];
            if k % 7 == 0 {
                inst.frame.qh = -inst.frame.qh;
            }
            inst.color = [1.0, if k % 90 < 45 { 1.0 } else { 0.0 }, 1.0, 1.0];
            out.instances.push(inst);
        }
        let mut b = Vec::new();
        write_glb(&out, &mut b).expect("writes");
        let (json, bin) = parse_glb(&b);
        let attrs = &json["meshes"][0]["primitives"][0]["attributes"];
        let read = |name: &str| components(&bin, &json, attrs[name].as_u64().expect(name));
        let (positions, normals) = (read("POSITION"), read("NORMAL"));
        // (8-bit colours: the usual record, whose runs are written whole.)
        let colors = &json["accessors"][attrs["COLOR_0"].as_u64().expect("colours") as usize];
        assert_eq!(colors["componentType"], UNSIGNED_BYTE);
        let m = out.vertex_mesh();
        let (mut want_p, mut want_n) = (Vec::new(), Vec::new());
        for (t, tri) in m.triangles.iter().enumerate() {
            let o = if m.mirrored[t] { [tri[0], tri[2], tri[1]] } else { *tri };
            for v in o.map(|v| v as usize) {
                want_p.extend(finite3(m.positions[v]).map(f64::from));
                want_n.extend(normal_at(&m, v).map(f64::from));
            }
        }
        // (The first number that differs, by its index.)
        let first_wrong = |got: &[f64], want: &[f64]| {
            assert_eq!(got.len(), want.len());
            got.iter().zip(want).position(|(a, b)| (*a as f32).to_bits() != (*b as f32).to_bits())
        };
        assert_eq!(positions.len(), 3 * 6 * 660);
        assert_eq!(first_wrong(&positions, &want_p), None, "positions");
        assert_eq!(first_wrong(&normals, &want_n), None, "normals");
    }

    #[test]
    fn flat_bounds_are_the_data_s_exactly() {
        // The writer skips the vertices of instances surely inside the bounds found so
        // far; the bounds must still be the data's, bit for bit (validators check).
        for n in [1, 2, 10, 1000] {
            let out = scattered_squares(n);
            let mut b = Vec::new();
            write_glb(&out, &mut b).expect("writes");
            let (json, bin) = parse_glb(&b);
            let pos = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"].as_u64().expect("positions");
            let data = components(&bin, &json, pos);
            assert_eq!(data.len(), 3 * 6 * n);
            for c in 0..3 {
                let lo = data.iter().skip(c).step_by(3).fold(f64::INFINITY, |a, &x| a.min(x));
                let hi = data.iter().skip(c).step_by(3).fold(f64::NEG_INFINITY, |a, &x| a.max(x));
                // (The JSON holds each bound as its f32's shortest text.)
                let a = &json["accessors"][pos as usize];
                assert_eq!(
                    a["min"][c].as_f64().map(|x| x as f32),
                    Some(lo as f32),
                    "{n} instances: min of coordinate {c}"
                );
                assert_eq!(
                    a["max"][c].as_f64().map(|x| x as f32),
                    Some(hi as f32),
                    "{n} instances: max of coordinate {c}"
                );
            }
        }
    }
}
