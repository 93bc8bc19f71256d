//! An evaluation's output packed for the GPU: interleaved vertices, indices with the
//! winding corrected for mirrored frames, pen-line segments, and the bounding sphere
//! the camera frames.
//!
//! Vertex layout (binding 0, 24 bytes; the shader sees the types of reference §13):
//! position `R32G32B32_SFLOAT` (location 0, `vec3`), normal `R16G16B16A16_SNORM`
//! (location 1, `vec3`; std's Phong program reads it as a `vec4` whose `w` is 1 for
//! a flat primitive's vertex, drawn without a specular highlight), colour `R8G8B8A8_UNORM` (location 2, `vec4`). Binding 1
//! (20 bytes): weight `R32G32B32A32_SFLOAT` (location 3, `vec4`) and bone `R32_UINT`
//! (location 4, `uint`); most models have neither, and then binding 1 is one zero
//! element read with stride 0, which saves 45% of the memory of a big model.

use glam::Vec3;
use mdg_vm::output::{Groups, Output, Piece};

mod painted;
pub use painted::{build_painted, PaintProto, PaintStep, Painted};

/// Bytes per vertex in binding 0.
pub const VERTEX_STRIDE: u32 = 24;
/// Bytes per vertex in binding 1 (weight, bone).
pub const SKIN_STRIDE: u32 = 20;

/// The model's extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Bounds {
    /// Nothing yet.
    pub const EMPTY: Bounds = Bounds { lo: Vec3::splat(f32::MAX), hi: Vec3::splat(f32::MIN) };
}

impl Default for Bounds {
    fn default() -> Bounds {
        Bounds::EMPTY
    }
}

impl Bounds {
    /// Grows to include `p` (non-finite points are ignored).
    pub fn add(&mut self, p: Vec3) {
        if p.is_finite() {
            self.lo = self.lo.min(p);
            self.hi = self.hi.max(p);
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }

    /// Grows to include `other`.
    pub fn add_bounds(&mut self, other: &Bounds) {
        if !other.is_empty() {
            self.add(other.lo);
            self.add(other.hi);
        }
    }

    /// Centre and radius of the sphere around the box (unit sphere when empty).
    pub fn sphere(&self) -> (Vec3, f32) {
        if self.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            ((self.lo + self.hi) * 0.5, ((self.hi - self.lo).length() * 0.5).max(1e-4))
        }
    }

    /// Whether the model is flat in z (curves, tilings): shown from above.
    pub fn is_flat(&self) -> bool {
        let (_, r) = self.sphere();
        !self.is_empty() && (self.hi.z - self.lo.z) < r * 0.01
    }
}

/// Packed geometry, ready to upload.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Binding 0 data, [`VERTEX_STRIDE`] bytes per vertex.
    pub vertices: Vec<u8>,
    /// Binding 1 data, [`SKIN_STRIDE`] bytes per vertex, or empty when every weight
    /// and bone is zero.
    pub skins: Vec<u8>,
    pub indices: Vec<u32>,
    /// Pen-line segments as pairs of vertices (binding 0 layout); drawn when nothing
    /// was swept along the lines.
    pub line_vertices: Vec<u8>,
    pub n_vertices: u32,
    /// All line vertices: pen lines first, then the overlay lines.
    pub n_line_vertices: u32,
    /// How many of the line vertices (the last ones) are overlays ([`OVERLAYS`]):
    /// guided search's guide curves (namespace `guides`), skeleton bones (namespace
    /// `bones`) and the guide editor's lines, drawn whether or not anything was
    /// swept, in their own colours, over the model.
    pub n_overlay_vertices: u32,
    /// Largest bone index used (the bones buffer holds this many + 1 matrices).
    pub max_bone: u32,
    pub bounds: Bounds,
    /// The instances, when they are drawn with GPU instancing (see [`build_with`]);
    /// else they are expanded into `vertices`.
    pub instanced: Option<Instanced>,
}

impl Scene {
    /// Number of triangles, instances' included.
    pub fn n_triangles(&self) -> usize {
        self.indices.len() / 3 + self.instanced.as_ref().map_or(0, |i| i.n_triangles as usize)
    }
}

/// Bytes per vertex of a shared mesh drawn instanced (binding 0 of the instanced
/// pipeline): position `R32G32B32_SFLOAT` (location 0), normal
/// `R16G16B16A16_SNORM` (location 1), colour delta `R32G32B32A32_SFLOAT` (location 2).
pub const PROTO_STRIDE: u32 = 36;
/// Bytes per instance (binding 1, per instance): the transform's rows 0..2 as three
/// `R32G32B32A32_SFLOAT` (locations 5, 6, 7), the frame's colour
/// `R32G32B32A32_SFLOAT` (location 8), the bone `R32_UINT` (location 4).
pub const INSTANCE_STRIDE: u32 = 68;

/// Instances drawn with GPU instancing: every shared mesh once, and one draw per
/// shared mesh and handedness over its instances' transforms.
#[derive(Clone, Debug, Default)]
pub struct Instanced {
    /// The shared meshes, [`PROTO_STRIDE`] bytes per vertex.
    pub vertices: Vec<u8>,
    /// Their triangles: per shared mesh, wound for unmirrored instances, then the
    /// same reversed for mirrored ones.
    pub indices: Vec<u32>,
    /// The output's instances (indices into `Output::instances`) in the order
    /// their records go in the instance buffer, grouped by draw. The records
    /// themselves ([`INSTANCE_STRIDE`] bytes each) are written by
    /// [`Instanced::write_instances`] straight into the buffer the GPU reads: a
    /// million instances are 68 MB that need not be built and then copied.
    pub order: Vec<u32>,
    pub draws: Vec<InstancedDraw>,
    /// Per draw, its level of detail: a coarser mesh for when every instance of the
    /// draw is small on the screen (see [`Lod`]); `None` for small meshes.
    pub lods: Vec<Option<Lod>>,
    /// Per draw, what its instances look like from afar ([`StandIn`]): a draw's
    /// instances that cover a few pixels are drawn as point sprites of their area
    /// and mean shaded colour (`crate::points`).
    pub stand_ins: Vec<StandIn>,
    /// The facets of every [`StandIn`].
    pub facets: Vec<Facet>,
    /// Triangles drawn in all (every instance's).
    pub n_triangles: u64,
}

impl Instanced {
    /// Bytes of the instance buffer: [`INSTANCE_STRIDE`] per instance.
    pub fn instance_bytes(&self) -> usize {
        self.order.len() * INSTANCE_STRIDE as usize
    }

    /// Writes the instance records of `out` (the output this was built from) into
    /// `dst`, [`Instanced::instance_bytes`] long: per instance, the rows 0..2 of its
    /// transform, its colour and its bone (see [`INSTANCE_STRIDE`]).
    pub fn write_instances(&self, out: &Output, dst: &mut [u8]) {
        for (&i, rec) in self.order.iter().zip(dst.chunks_exact_mut(INSTANCE_STRIDE as usize)) {
            let Some(instance) = out.instances.get(i as usize) else { continue };
            let t = out.instance_transform(&instance);
            let mut w = 0;
            let mut put = |x: [u8; 4]| {
                rec[w..w + 4].copy_from_slice(&x);
                w += 4;
            };
            for r in [t.row(0), t.row(1), t.row(2)] {
                for x in r.to_array() {
                    put(x.to_le_bytes());
                }
            }
            for x in instance.color {
                put(x.to_le_bytes());
            }
            put(instance.bone.to_le_bytes());
        }
    }
}

/// A shared mesh's level of detail: the mesh simplified by vertex clustering on a
/// [`LOD_CELLS`]³ grid over its bounds, drawn instead of the full mesh when the
/// renderer finds every instance of a draw smaller than
/// [`LOD_PIXELS`] on the screen (a leaf blob of ~1,200 triangles 10 pixels wide
/// needs not be 1,200 triangles). Not culled (clustering may open the mesh).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lod {
    pub first_index: u32,
    pub index_count: u32,
    pub vertex_offset: i32,
    /// The largest bounding-sphere radius of the draw's instances, in world units
    /// (around each instance's origin).
    pub radius: f32,
}

/// Meshes with more triangles than this get a [`Lod`].
pub const LOD_MIN_TRIANGLES: usize = 256;
/// Grid cells per axis of a [`Lod`]'s vertex clustering.
pub const LOD_CELLS: u32 = 6;
/// A draw uses its [`Lod`] when its instances' bounding spheres are at most this
/// many pixels across.
pub const LOD_PIXELS: f32 = 32.0;

/// A shared mesh summarised for drawing it as one point sprite: its triangles
/// grouped by the direction they face ([`Facet`]), its centre and the radius
/// around it, in the mesh's own space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StandIn {
    /// Its facets: `Instanced::facets[first_facet..first_facet + n_facets]`.
    pub first_facet: u32,
    pub n_facets: u32,
    /// The centre of the mesh's bounding box.
    pub centre: Vec3,
    /// The largest distance of a vertex from `centre`.
    pub radius: f32,
    /// The mesh is closed: only facets facing the eye are seen.
    pub closed: bool,
}

/// The triangles of a shared mesh that face about one way (one of 26 directions)
/// and are all matte or all not, summed: their area vector (the sum of the
/// triangles' area times their normal, wound as drawn for unmirrored instances),
/// their centroid and shading normal (the vertex normals' mean), both
/// area-weighted, and their colour delta (area-weighted, divided by the area).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Facet {
    pub area: Vec3,
    /// The triangles' centroid, area-weighted.
    pub centre: Vec3,
    pub normal: Vec3,
    pub delta: [f32; 4],
    pub matte: bool,
}

/// Sums `shared`'s oriented triangles into at most 52 [`Facet`]s (26 directions,
/// matte or not), in a fixed order.
fn facets_of(shared: &mdg_vm::output::SharedMesh, triangles: &[[u32; 3]]) -> Vec<Facet> {
    let m = &shared.mesh;
    // (direction bin, matte) -> (area vector, centroid × area, normal, delta × area, area)
    type Sums = (Vec3, Vec3, Vec3, [f32; 4], f32);
    let mut bins: std::collections::BTreeMap<(i8, i8, i8, bool), Sums> = std::collections::BTreeMap::new();
    for t in triangles {
        let p = t.map(|k| Vec3::from(m.positions[k as usize]));
        let area = (p[1] - p[0]).cross(p[2] - p[0]) * 0.5;
        let a = area.length();
        if !(a > 0.0 && a.is_finite()) {
            continue;
        }
        let dir = area / a;
        let q = |x: f32| (x * 1.5).round().clamp(-1.0, 1.0) as i8;
        let matte = t.iter().all(|&k| m.matte(k as usize));
        let normal = t.iter().map(|&k| shared.local_normal(k as usize).normalize_or_zero()).sum::<Vec3>();
        let normal = normal.normalize_or_zero();
        let mut delta = [0.0f32; 4];
        if shared.is_prototype() {
            for &k in t {
                let c = m.colors.get(k as usize).copied().unwrap_or([0.0; 4]);
                for (d, x) in delta.iter_mut().zip(c) {
                    *d += x / 3.0;
                }
            }
        }
        let e = bins.entry((q(dir.x), q(dir.y), q(dir.z), matte)).or_insert((
            Vec3::ZERO,
            Vec3::ZERO,
            Vec3::ZERO,
            [0.0; 4],
            0.0,
        ));
        e.0 += area;
        e.1 += (p[0] + p[1] + p[2]) / 3.0 * a;
        e.2 += normal * a;
        for (d, x) in e.3.iter_mut().zip(delta) {
            *d += x * a;
        }
        e.4 += a;
    }
    bins.into_iter()
        .map(|((.., matte), (area, centre, normal, delta, a))| Facet {
            area,
            centre: centre / a,
            normal: normal.normalize_or_zero(),
            delta: delta.map(|d| d / a),
            matte,
        })
        .collect()
}

/// One instanced draw (`vkCmdDrawIndexed`'s arguments).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct InstancedDraw {
    pub first_index: u32,
    pub index_count: u32,
    pub vertex_offset: i32,
    pub first_instance: u32,
    pub instance_count: u32,
    /// The mesh is closed (`mdg_export::is_closed`): its back faces are hidden
    /// behind its front faces, and the draw culls them (half the triangles a CPU
    /// driver rasterises).
    pub closed: bool,
}

fn snorm16(v: f32) -> i16 {
    (v.clamp(-1.0, 1.0) * 32767.0).round() as i16
}

pub(crate) fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Appends one binding-0 vertex; `matte` (a flat primitive's vertex, see
/// [`mdg_vm::geom::Mesh::matte`]) goes in the normal's fourth component, which std's
/// Phong program reads as "no specular highlight".
fn push_vertex(out: &mut Vec<u8>, p: Vec3, n: Vec3, c: [f32; 4], matte: bool) {
    let n = n.normalize_or_zero();
    for x in p.to_array() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for x in [n.x, n.y, n.z, if matte { 1.0 } else { 0.0 }] {
        out.extend_from_slice(&snorm16(x).to_le_bytes());
    }
    out.extend_from_slice(&c.map(unorm8));
}

fn push_skin(out: &mut Vec<u8>, w: [f32; 4], bone: u32) {
    for x in w {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out.extend_from_slice(&bone.to_le_bytes());
}

struct Builder {
    s: Scene,
    skinned: bool,
}

impl Builder {
    /// Appends a flat piece of the output (world space), with oriented triangles.
    fn piece(&mut self, p: &Piece) {
        let m = p.mesh;
        let base = self.s.n_vertices;
        for i in p.vertices.clone() {
            let pos = Vec3::from_array(m.positions[i]);
            let nn = Vec3::from_array(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]));
            let c = m.colors.get(i).copied().unwrap_or([1.0; 4]);
            let bone = m.bone(i);
            self.s.bounds.add(pos);
            push_vertex(&mut self.s.vertices, pos, nn, c, m.matte(i));
            if self.skinned {
                push_skin(&mut self.s.skins, m.weight(i), bone);
            }
            self.s.max_bone = self.s.max_bone.max(bone);
        }
        for k in p.triangles.clone() {
            if let Some(t) = p.oriented(k) {
                self.s.indices.extend(t.map(|v| v - p.base + base));
            }
        }
        self.s.n_vertices += p.vertices.len() as u32;
    }
}

/// Packs an output: the VERTEX mesh, sweeps and every instance (expanded in place),
/// plus pen lines when there are no sweeps.
pub fn build(out: &Output) -> Scene {
    build_with(out, false)
}

/// [`build`], with the instances (prototypes and isosurfaces) left to GPU instancing
/// when `instanced` (the program has std's instanced vertex shader).
pub fn build_with(out: &Output, instanced: bool) -> Scene {
    let skinned = skinned(out);
    let n_vertices =
        if instanced { out.mesh.n_vertices() + out.sweeps.n_vertices() } else { out.flat_counts(Groups::ALL).0 };
    let mut b = Builder { s: Scene { bounds: Bounds::EMPTY, ..Scene::default() }, skinned };
    b.s.vertices.reserve(n_vertices * VERTEX_STRIDE as usize);
    if skinned {
        b.s.skins.reserve(n_vertices * SKIN_STRIDE as usize);
    }
    if instanced {
        // No instance expanded: the flat walk's pieces are the whole VERTEX mesh
        // and the sweeps (`Output::for_each_piece_where` with nothing to expand,
        // without its walks over every instance).
        fn whole(m: &mdg_vm::output::Mesh, base: usize) -> Piece<'_> {
            Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: base as u32 }
        }
        if out.mesh.n_vertices() > 0 || !out.mesh.triangles.is_empty() {
            b.piece(&whole(&out.mesh, 0));
        }
        b.piece(&whole(&out.sweeps, out.mesh.n_vertices()));
    } else {
        let _ = out.for_each_piece::<()>(Groups::ALL, |p| {
            b.piece(p);
            Ok(())
        });
    }
    if instanced && !out.instances.is_empty() {
        let (inst, bounds, max_bone) = build_instanced(out);
        b.s.bounds.add_bounds(&bounds);
        b.s.max_bone = b.s.max_bone.max(max_bone);
        b.s.instanced = Some(inst);
    }
    b.lines(out);
    b.s
}

/// Whether `out` has weights or bones (binding 1 is then filled).
fn skinned(out: &Output) -> bool {
    !out.mesh.weights.is_empty()
        || !out.mesh.bones.is_empty()
        || !out.sweeps.weights.is_empty()
        || !out.sweeps.bones.is_empty()
        || !out.instance_weights.is_empty()
        || out.instances.bone_runs().any(|(_, b)| b != 0)
}

impl Builder {
    /// Appends the pen lines (when nothing was swept) and the overlays.
    fn lines(&mut self, out: &Output) {
        let is_overlay = |l: &mdg_vm::output::Polyline| OVERLAYS.iter().any(|(ns, _)| *ns == l.namespace);
        if out.sweeps.triangles.is_empty() {
            let ink = ink(out.background);
            for line in out.lines.iter().filter(|l| !is_overlay(l)) {
                self.segments(line, ink);
            }
        }
        for (ns, color) in OVERLAYS {
            let color = color.unwrap_or_else(|| ink(out.background));
            for line in out.lines.iter().filter(|l| l.namespace == ns) {
                let before = self.s.n_line_vertices;
                self.segments(line, color);
                self.s.n_overlay_vertices += self.s.n_line_vertices - before;
            }
        }
    }

    /// Appends `line`'s segments as pairs of line vertices in `color`.
    fn segments(&mut self, line: &mdg_vm::output::Polyline, color: [f32; 4]) {
        for seg in line.points.windows(2) {
            for p in seg {
                let p = Vec3::from_array(*p);
                self.s.bounds.add(p);
                push_vertex(&mut self.s.line_vertices, p, Vec3::ZERO, color, false);
                self.s.n_line_vertices += 1;
            }
        }
    }
}

/// Packs the instances for GPU instancing; returns them with their bounds and the
/// largest bone they use.
/// Appends `shared`'s mesh simplified by vertex clustering ([`Lod`]) to the
/// instanced vertices and indices (one winding, then the reversed one); returns its
/// first index, index count (one winding) and vertex offset, or `None` when nothing
/// is left of it.
fn coarse_mesh(
    shared: &mdg_vm::output::SharedMesh,
    triangles: &[[u32; 3]],
    vertices: &mut Vec<u8>,
    indices: &mut Vec<u32>,
) -> Option<(u32, u32, i32)> {
    let m = &shared.mesh;
    let mut lo = Vec3::splat(f32::MAX);
    let mut hi = Vec3::splat(f32::MIN);
    for q in &m.positions {
        lo = lo.min(Vec3::from(*q));
        hi = hi.max(Vec3::from(*q));
    }
    let size = (hi - lo).max(Vec3::splat(1e-12));
    let cells = LOD_CELLS as f32;
    let cell_of = |q: Vec3| {
        let c = ((q - lo) / size * cells).floor().clamp(Vec3::ZERO, Vec3::splat(cells - 1.0));
        (c.x as u32, c.y as u32, c.z as u32)
    };
    // Each cell's vertices become one: the mean position, colour delta and normal.
    let mut cluster: std::collections::BTreeMap<(u32, u32, u32), u32> = std::collections::BTreeMap::new();
    let mut sums: Vec<(Vec3, Vec3, [f32; 4], f32)> = Vec::new();
    let mut of_vertex = Vec::with_capacity(m.n_vertices());
    for v in 0..m.n_vertices() {
        let q = Vec3::from(m.positions[v]);
        let next = sums.len() as u32;
        let k = *cluster.entry(cell_of(q)).or_insert(next);
        if k == next {
            sums.push((Vec3::ZERO, Vec3::ZERO, [0.0; 4], 0.0));
        }
        let s = &mut sums[k as usize];
        s.0 += q;
        s.1 += shared.local_normal(v).normalize_or_zero();
        if shared.is_prototype() {
            let c = m.colors.get(v).copied().unwrap_or([0.0; 4]);
            for (a, b) in s.2.iter_mut().zip(c) {
                *a += b;
            }
        }
        s.3 += 1.0;
        of_vertex.push(k);
    }
    let mut tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|k| of_vertex.get(k as usize).copied().unwrap_or(0)))
        .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        .collect();
    // The same triangle from several fine ones is drawn once.
    let mut seen = std::collections::BTreeSet::new();
    tris.retain(|t| {
        let r = if t[0] < t[1] && t[0] < t[2] {
            *t
        } else if t[1] < t[2] {
            [t[1], t[2], t[0]]
        } else {
            [t[2], t[0], t[1]]
        };
        seen.insert(r)
    });
    if tris.is_empty() {
        return None;
    }
    let vertex_offset = (vertices.len() / PROTO_STRIDE as usize) as i32;
    for (p, n, c, count) in &sums {
        let p = *p / *count;
        let n = n.normalize_or_zero();
        for x in p.to_array() {
            vertices.extend_from_slice(&x.to_le_bytes());
        }
        for x in [n.x, n.y, n.z, 0.0] {
            vertices.extend_from_slice(&snorm16(x).to_le_bytes());
        }
        for x in c {
            vertices.extend_from_slice(&(x / count).to_le_bytes());
        }
    }
    let first_index = indices.len() as u32;
    indices.extend(tris.iter().flatten());
    indices.extend(tris.iter().flat_map(|t| [t[0], t[2], t[1]]));
    Some((first_index, 3 * tris.len() as u32, vertex_offset))
}

/// The instances `first..=last` of a run of equal linear parts (its mesh's corners
/// under the linear part: `moved`, finite, in the box of [`MovedBox`]), whose
/// translations are finite and lie in the box `lo..hi`: their bounds, added at
/// once. Every corner of every one of them is `c + u`, and rounding is monotonic,
/// so those points lie in the box `(min c + lo)..(max c + hi)` and reach both of
/// its corners. Where those two are finite (then so is every point), adding them
/// gives the bounds that adding every point does, coordinate by coordinate, if
/// the order of the comparisons cannot matter: a minimum or maximum that is no
/// zero is one value, and a coordinate that every point has with the same bits
/// (a flat grid's `z`) is one value too; a zero that may be `-0.0` or `0.0`
/// otherwise sends the run back to every point, added in order.
struct RunBounds {
    first: usize,
    last: usize,
    lo: Vec3,
    hi: Vec3,
    /// The first translation, and per coordinate whether every one since has its
    /// bits.
    u0: Vec3,
    same: [bool; 3],
}

/// The box of a run's corners under its linear part, and per coordinate whether
/// every corner has the same bits there.
type MovedBox = (Vec3, Vec3, [bool; 3]);

impl RunBounds {
    fn new(i: usize, u: Vec3) -> RunBounds {
        RunBounds { first: i, last: i, lo: u, hi: u, u0: u, same: [true; 3] }
    }

    #[inline]
    fn push(&mut self, i: usize, u: Vec3) {
        self.last = i;
        self.lo = self.lo.min(u);
        self.hi = self.hi.max(u);
        for (k, same) in self.same.iter_mut().enumerate() {
            *same &= u[k].to_bits() == self.u0[k].to_bits();
        }
    }

    /// Adds the pending run's bounds (if any) to `bounds`.
    fn flush(
        pending: &mut Option<RunBounds>,
        bounds: &mut Bounds,
        moved: &[Vec3],
        moved_box: Option<MovedBox>,
        frames: &[mdg_vm::output::PackedFrame],
    ) {
        let (Some(r), Some((cmin, cmax, moved_same))) = (pending.take(), moved_box) else { return };
        let (a, b) = (cmin + r.lo, cmax + r.hi);
        let one_value = |k: usize| r.same[k] && moved_same[k];
        let ordered = (0..3).all(|k| (a[k] != 0.0 || one_value(k)) && (b[k] != 0.0 || one_value(k)));
        if a.is_finite() && b.is_finite() && ordered {
            bounds.add(a);
            bounds.add(b);
            return;
        }
        for pf in frames.get(r.first..=r.last).unwrap_or(&[]) {
            let u = Vec3::new(pf[8], pf[9], pf[10]);
            for lq in moved {
                bounds.add(*lq + u);
            }
        }
    }

    /// The box of `moved` (and which coordinates all its corners share), when
    /// every corner is finite.
    fn moved_box(moved: &[Vec3]) -> Option<MovedBox> {
        let first = *moved.first()?;
        moved.iter().all(|q| q.is_finite()).then(|| {
            let lo = moved.iter().fold(Vec3::splat(f32::MAX), |a, q| a.min(*q));
            let hi = moved.iter().fold(Vec3::splat(f32::MIN), |a, q| a.max(*q));
            (lo, hi, std::array::from_fn(|k| moved.iter().all(|q| q[k].to_bits() == first[k].to_bits())))
        })
    }
}

fn build_instanced(out: &Output) -> (Instanced, Bounds, u32) {
    let mut inst = Instanced::default();
    let mut bounds = Bounds::EMPTY;
    let mut max_bone = 0;
    // Per shared mesh: where its vertices and its two index runs are, its bounding
    // sphere, and its instances by handedness.
    struct Placed {
        vertex_offset: i32,
        first_index: u32,
        index_count: u32,
        closed: bool,
        instances: [Vec<u32>; 2],
        /// The largest scale of its instances, by handedness (for the level of
        /// detail's radius).
        scales: [f32; 2],
        /// The mesh's distinct positions (for the bounds).
        corners: Vec<Vec3>,
        /// The coarse mesh: first index, index count (one winding), vertex offset.
        coarse: Option<(u32, u32, i32)>,
        /// The largest distance of a vertex from the mesh's origin.
        radius: f32,
        /// Its point-sprite summary (the facets are in `inst.facets`).
        stand_in: StandIn,
    }
    let mut placed: Vec<Option<Placed>> = (0..out.shared_meshes.len()).map(|_| None).collect();
    // Each mesh's list sized for all its instances (unmirrored, as most are).
    let counts = out.instances.mesh_counts();
    // One walk: each instance's transform is made once, for its handedness, the
    // bounds and the level of detail's radius.
    // (The frames read as a slice and the other fields by runs: no unpacked
    // iterator state goes through memory per instance.)
    let frames = out.instances.packed_frames();
    // A run of instances of one field run whose linear parts are bit-equal (q and
    // q̂; no non-uniform factor: every square of a grid) shares its handedness, its
    // scale and its mesh's corners under the linear part (`moved`), made once: the
    // run's first instance (the next one shares its linear part) records them.
    let linear_bits = |pf: &mdg_vm::output::PackedFrame| -> [u32; 8] { std::array::from_fn(|k| pf[k].to_bits()) };
    let (mut run_mirrored, mut run_scale) = (false, 0.0f32);
    let mut moved: Vec<Vec3> = Vec::new();
    // The box of `moved` when its corners are finite, and the run's instances whose
    // bounds wait in `pending` ([`RunBounds`]).
    let mut moved_box: Option<MovedBox> = None;
    let mut pending: Option<RunBounds> = None;
    for (run, f) in out.instances.field_runs() {
        let mut shared_run: Option<[u32; 8]> = None;
        let end = run.end;
        for i in run {
            let Some(pf) = frames.get(i) else { break };
            if f.lin == 0 && shared_run.is_some_and(|b| b == linear_bits(pf)) {
                // (The run's mesh was placed by its first instance.)
                if let Some(p) = placed.get_mut(f.mesh as usize).and_then(Option::as_mut) {
                    let side = usize::from(run_mirrored);
                    p.instances[side].push(i as u32);
                    let u = Vec3::new(pf[8], pf[9], pf[10]);
                    match (moved_box, u.is_finite()) {
                        (Some(_), true) => match &mut pending {
                            Some(r) => r.push(i, u),
                            None => pending = Some(RunBounds::new(i, u)),
                        },
                        _ => {
                            RunBounds::flush(&mut pending, &mut bounds, &moved, moved_box, frames);
                            // The same bits as `transform_point3`: (l q) + u.
                            for lq in &moved {
                                bounds.add(*lq + u);
                            }
                        }
                    }
                    p.scales[side] = p.scales[side].max(run_scale);
                    continue;
                }
            }
            RunBounds::flush(&mut pending, &mut bounds, &moved, moved_box, frames);
            let frame = mdg_vm::geom::Frame {
                q: glam::Quat::from_xyzw(pf[0], pf[1], pf[2], pf[3]),
                qh: glam::Quat::from_xyzw(pf[4], pf[5], pf[6], pf[7]),
                u: Vec3::new(pf[8], pf[9], pf[10]),
            };
            let instance =
                mdg_vm::output::Instance { frame, color: f.color, mesh: f.mesh, bone: f.bone, lin: f.lin, at: f.at };
            let Some(shared) = out.shared(&instance) else { continue };
            let m = &shared.mesh;
            if m.triangles.is_empty() {
                continue;
            }
            // (A prototype's frame has no non-uniform factor: its matrix's columns are
            // the frame's axes, `Frame::linear`'s, whose determinant says mirrored.)
            let t = if instance.lin == 0 {
                let [a, b, c] = instance.frame.axes();
                glam::Affine3A::from_cols(a.into(), b.into(), c.into(), instance.frame.u.into())
            } else {
                glam::Affine3A::from_mat4(out.instance_transform(&instance))
            };
            let mirrored = if shared.is_prototype() {
                let l = &t.matrix3;
                Vec3::from(l.x_axis).dot(Vec3::from(l.y_axis).cross(Vec3::from(l.z_axis))) < 0.0
            } else {
                out.instance_mirrored(&instance)
            };
            let p = placed[instance.mesh as usize].get_or_insert_with(|| {
                let vertex_offset = (inst.vertices.len() / PROTO_STRIDE as usize) as i32;
                // Equal vertices (a cube's corners, shared by the two triangles of a face)
                // are stored once: the driver shades each once per instance.
                let mut seen: std::collections::HashMap<Vec<u8>, u32> = std::collections::HashMap::new();
                let mut remap = Vec::with_capacity(m.n_vertices());
                for v in 0..m.n_vertices() {
                    let pos = Vec3::from(m.positions[v]);
                    let n = shared.local_normal(v).normalize_or_zero();
                    let delta =
                        if shared.is_prototype() { m.colors.get(v).copied().unwrap_or([0.0; 4]) } else { [0.0; 4] };
                    let mut bytes = Vec::with_capacity(PROTO_STRIDE as usize);
                    for x in pos.to_array() {
                        bytes.extend_from_slice(&x.to_le_bytes());
                    }
                    for x in [n.x, n.y, n.z, if m.matte(v) { 1.0 } else { 0.0 }] {
                        bytes.extend_from_slice(&snorm16(x).to_le_bytes());
                    }
                    for x in delta {
                        bytes.extend_from_slice(&x.to_le_bytes());
                    }
                    let next = seen.len() as u32;
                    let k = *seen.entry(bytes.clone()).or_insert_with(|| {
                        inst.vertices.extend_from_slice(&bytes);
                        next
                    });
                    remap.push(k);
                }
                let first_index = inst.indices.len() as u32;
                let n = m.n_vertices() as u32;
                let tris: Vec<[u32; 3]> = m
                    .oriented_triangles()
                    .filter(|t| t.iter().all(|&k| k < n))
                    .map(|t| t.map(|k| remap[k as usize]))
                    .collect();
                inst.indices.extend(tris.iter().flatten());
                inst.indices.extend(tris.iter().flat_map(|t| [t[0], t[2], t[1]]));
                let oriented: Vec<[u32; 3]> = m.oriented_triangles().filter(|t| t.iter().all(|&k| k < n)).collect();
                let coarse = (oriented.len() > LOD_MIN_TRIANGLES)
                    .then(|| coarse_mesh(shared, &oriented, &mut inst.vertices, &mut inst.indices))
                    .flatten();
                let closed = mdg_export::is_closed(m, &oriented);
                let facets = facets_of(shared, &oriented);
                let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
                for q in &m.positions {
                    lo = lo.min(Vec3::from(*q));
                    hi = hi.max(Vec3::from(*q));
                }
                let centre = (lo + hi) * 0.5;
                let stand_in = StandIn {
                    first_facet: inst.facets.len() as u32,
                    n_facets: facets.len() as u32,
                    centre,
                    radius: m.positions.iter().map(|q| Vec3::from(*q).distance(centre)).fold(0.0, f32::max),
                    closed,
                };
                inst.facets.extend(facets);
                Placed {
                    stand_in,
                    coarse,
                    radius: m.positions.iter().map(|q| Vec3::from(*q).length()).fold(0.0, f32::max),
                    vertex_offset,
                    first_index,
                    index_count: 3 * tris.len() as u32,
                    closed,
                    instances: [
                        Vec::with_capacity(counts.get(instance.mesh as usize).copied().unwrap_or(0)),
                        Vec::new(),
                    ],
                    scales: [0.0; 2],
                    corners: {
                        let mut c: Vec<[u32; 3]> = m.positions.iter().map(|q| q.map(f32::to_bits)).collect();
                        c.sort_unstable();
                        c.dedup();
                        c.into_iter().map(|q| Vec3::from(q.map(f32::from_bits))).collect()
                    },
                }
            });
            let side = usize::from(mirrored);
            p.instances[side].push(i as u32);
            max_bone = max_bone.max(instance.bone);
            // Exact bounds (the camera frames the model as when it was expanded): every
            // distinct vertex placed (a cube's 24 are 8 corners), but nothing stored.
            for q in &p.corners {
                bounds.add(t.transform_point3(*q));
            }
            // (The longest axis with one square root: the same bits as the longest of
            // three lengths, a square root being correctly rounded and increasing.)
            let l = &t.matrix3;
            let scale = l.x_axis.length_squared().max(l.y_axis.length_squared()).max(l.z_axis.length_squared()).sqrt();
            p.scales[side] = p.scales[side].max(scale);
            shared_run = None;
            if instance.lin == 0 && i + 1 < end && frames.get(i + 1).is_some_and(|n| linear_bits(n) == linear_bits(pf))
            {
                shared_run = Some(linear_bits(pf));
                (run_mirrored, run_scale) = (mirrored, scale);
                moved.clear();
                moved.extend(p.corners.iter().map(|q| *l * *q));
                moved_box = RunBounds::moved_box(&moved);
            }
        }
        RunBounds::flush(&mut pending, &mut bounds, &moved, moved_box, frames);
    }
    // One draw, one list: it is the order (not copied).
    let single = placed.iter().flatten().flat_map(|p| &p.instances).filter(|l| !l.is_empty()).count() == 1;
    for p in placed.iter_mut().flatten() {
        for (side, list) in p.instances.iter_mut().enumerate() {
            if list.is_empty() {
                continue;
            }
            inst.draws.push(InstancedDraw {
                first_index: p.first_index + side as u32 * p.index_count,
                index_count: p.index_count,
                vertex_offset: p.vertex_offset,
                first_instance: inst.order.len() as u32,
                instance_count: list.len() as u32,
                closed: p.closed,
            });
            inst.n_triangles += u64::from(p.index_count / 3) * list.len() as u64;
            let radius = p.radius * p.scales[side];
            if single {
                inst.order = std::mem::take(list);
            } else {
                inst.order.extend_from_slice(list);
            }
            inst.stand_ins.push(p.stand_in);
            inst.lods.push(p.coarse.map(|(first, count, offset)| Lod {
                first_index: first + side as u32 * count,
                index_count: count,
                vertex_offset: offset,
                radius,
            }));
        }
    }
    (inst, bounds, max_bone)
}

/// Line namespaces drawn as overlays (over the model, in this order), and their
/// colours: guide curves amber, skeleton bones cyan (as the live preview draws
/// them), and the guide editor's selected guide magenta and control-point markers in
/// the ink colour (`None`: [`ink`]).
pub const OVERLAYS: [(&str, Option<[f32; 4]>); 4] = [
    ("guides", Some([1.0, 0.66, 0.0, 1.0])),
    ("bones", Some([0.0, 0.78, 0.92, 1.0])),
    ("guide_selected", Some([0.9, 0.1, 0.75, 1.0])),
    ("guide_points", None),
];

/// The colour pen lines are drawn in: dark on a light background, light on a dark one.
pub fn ink(background: [f32; 4]) -> [f32; 4] {
    if background[0] + background[1] + background[2] > 1.5 {
        [0.1, 0.1, 0.1, 1.0]
    } else {
        [0.9, 0.9, 0.9, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirrored_triangles_are_reoriented_and_bounds_cover_everything() {
        let mut out = Output::default();
        let m = &mut out.mesh;
        for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            m.push_vertex(Vec3::from_array(p), Vec3::Z, [1.0, 0.0, 0.0, 1.0], [0.0; 4], 0);
        }
        m.push_triangle([0, 1, 2], true);
        let s = build(&out);
        assert_eq!(s.indices, vec![0, 2, 1]);
        assert_eq!(s.vertices.len(), 3 * VERTEX_STRIDE as usize);
        assert!(s.skins.is_empty());
        assert_eq!(s.bounds.lo, Vec3::ZERO);
        assert_eq!(s.bounds.hi, Vec3::new(1.0, 1.0, 0.0));
        assert!(s.bounds.is_flat());
        // Colour bytes of the first vertex: red, opaque.
        assert_eq!(&s.vertices[20..24], &[255, 0, 0, 255]);
    }

    /// Runs of instances that share a linear part (and single ones between them,
    /// and a mirrored run) give the bounds, the order and the level of detail's
    /// radius of every instance placed on its own.
    #[test]
    fn runs_of_equal_linear_parts_bound_and_list_as_single_instances() {
        use mdg_vm::geom::Frame;
        use mdg_vm::output::SharedMesh;
        let mut out = Output::default();
        let mut m = mdg_vm::output::Mesh::default();
        let corners = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for p in corners {
            m.push_vertex(Vec3::from_array(p), Vec3::Z, [1.0; 4], [0.0; 4], 0);
        }
        for t in [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]] {
            m.push_triangle(t, false);
        }
        out.shared_meshes.push(SharedMesh::isosurface("tetra", m));
        let turned = Frame::identity().rotate(glam::Quat::from_rotation_z(0.7)).scale(0.3);
        let other = Frame::identity().rotate(glam::Quat::from_rotation_x(-1.9)).scale(2.5);
        let flipped = Frame::identity().rotate(glam::Quat::from_rotation_y(0.4)).scale(-0.6);
        let mut frames = Vec::new();
        for k in 0..7 {
            frames.push(turned.translate(Vec3::new(k as f32 * 1.7, -3.1, 0.2)));
        }
        frames.push(other.translate(Vec3::new(9.0, 4.0, -2.0)));
        for k in 0..3 {
            frames.push(turned.translate(Vec3::new(-5.0, k as f32 * 0.3, 7.5)));
        }
        frames.push(other);
        for k in 0..4 {
            frames.push(flipped.translate(Vec3::new(0.5, 0.5, k as f32 * -11.0)));
        }
        for f in &frames {
            out.instances.push_parts(f, [1.0; 4], [0, 0, 0, 0]);
        }
        let s = build_with(&out, true);
        let mut bounds = Bounds::default();
        let mut lists: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
        for (i, f) in frames.iter().enumerate() {
            let [a, b, c] = f.axes();
            let t = glam::Affine3A::from_cols(a.into(), b.into(), c.into(), f.u.into());
            for q in corners {
                bounds.add(t.transform_point3(Vec3::from_array(q)));
            }
            let side = usize::from(out.instance_mirrored(&out.instances.get(i).expect("instance")));
            lists[side].push(i as u32);
        }
        assert!(!lists[1].is_empty() && !lists[0].is_empty());
        assert_eq!(s.bounds.lo.to_array().map(f32::to_bits), bounds.lo.to_array().map(f32::to_bits));
        assert_eq!(s.bounds.hi.to_array().map(f32::to_bits), bounds.hi.to_array().map(f32::to_bits));
        let inst = s.instanced.expect("instanced");
        assert_eq!(inst.order, [lists[0].clone(), lists[1].clone()].concat());
        assert_eq!(inst.draws.len(), 2);
        assert_eq!(inst.draws[0].instance_count as usize, lists[0].len());
    }

    /// A run's bounds added at once are the bounds of every point added in order,
    /// bit for bit: flat and signed zeros, coordinates that cross zero, overflow
    /// and non-finite translations included.
    #[test]
    fn a_runs_bounds_at_once_are_those_of_every_point() {
        let frame =
            |u: [f32; 3]| -> mdg_vm::output::PackedFrame { [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, u[0], u[1], u[2]] };
        let square = vec![
            Vec3::new(-0.5, -0.5, 0.0),
            Vec3::new(0.5, -0.5, 0.0),
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(-0.5, 0.5, 0.0),
        ];
        let signed = vec![Vec3::new(-0.0, 1.0, -0.0), Vec3::new(0.0, 2.0, 0.0)];
        let runs: Vec<Vec<[f32; 3]>> = vec![
            (0..9).map(|k| [1.0, k as f32, 0.0]).collect(),
            (0..9).map(|k| [0.5, k as f32 - 4.0, -0.0]).collect(),
            vec![[0.0, 0.0, -0.0], [-0.0, 0.0, 0.0], [0.5, -1.0, 0.0]],
            vec![[3.0e38, 1.0, 1.0], [1.0, 1.0, 1.0]],
            vec![[1.0, 2.0, 3.0], [f32::NAN, 2.0, 3.0], [4.0, 5.0, 6.0]],
            vec![[f32::INFINITY, 0.0, 0.0], [2.0, 2.0, 2.0]],
        ];
        let mut flushed = 0;
        for moved in [square, signed] {
            let moved_box = RunBounds::moved_box(&moved);
            for us in &runs {
                for start in [Bounds::EMPTY, Bounds { lo: Vec3::splat(-0.0), hi: Vec3::splat(0.0) }] {
                    let frames: Vec<_> = us.iter().map(|u| frame(*u)).collect();
                    let mut every = start;
                    for u in us {
                        for lq in &moved {
                            every.add(*lq + Vec3::from_array(*u));
                        }
                    }
                    // As the scene's walk does: finite translations wait, others go alone.
                    let (mut once, mut pending) = (start, None::<RunBounds>);
                    for (i, u) in us.iter().enumerate() {
                        let u = Vec3::from_array(*u);
                        if u.is_finite() {
                            match &mut pending {
                                Some(r) => r.push(i, u),
                                None => pending = Some(RunBounds::new(i, u)),
                            }
                        } else {
                            RunBounds::flush(&mut pending, &mut once, &moved, moved_box, &frames);
                            for lq in &moved {
                                once.add(*lq + u);
                            }
                        }
                    }
                    let before = (once.lo, once.hi);
                    RunBounds::flush(&mut pending, &mut once, &moved, moved_box, &frames);
                    flushed += usize::from(before != (once.lo, once.hi));
                    let bits = |b: &Bounds| (b.lo.to_array().map(f32::to_bits), b.hi.to_array().map(f32::to_bits));
                    assert_eq!(bits(&once), bits(&every), "{moved:?} {us:?}");
                }
            }
        }
        assert!(flushed > 4);
    }
}
