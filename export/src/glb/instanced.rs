//! `--instances`: the prototype and isosurface instances grouped for
//! `EXT_mesh_gpu_instancing`, one node per group with its instances' TRS (one
//! strided view, written in one pass when the file is) and colours.

use super::*;
use mdg_vm::output::PackedFrame;

/// The most glTF meshes one prototype gets for colour variants under `--instances`
/// (a prototype whose items add colours to the frame's needs one per distinct frame
/// colour); the instances of further colours are expanded into the geometry.
pub const MAX_COLOR_VARIANTS: usize = 64;

/// Prototype instances drawn by one instanced node: same prototype, same mirroring,
/// and (for a prototype whose items add colour deltas) the same frame colour.
pub(super) struct GpuGroup {
    mesh: u32,
    mirrored: bool,
    /// The frame colour baked into the mesh's COLOR_0 (prototypes with colour
    /// deltas); `None`: the mesh is white and each instance's colour is `_COLOR_0`.
    color: Option<[f32; 4]>,
    /// The instances (indices into [`Output::instances`]) in order, as runs of
    /// consecutive indices: a tree's instances are one run (no index list is held).
    runs: Vec<std::ops::Range<u32>>,
    /// How many instances the runs hold.
    count: usize,
    /// The bits of the first instance's colour, and whether every instance's colour
    /// has the same bits (then they all share one material colour, found without a
    /// second walk over the instances).
    first_bits: [u32; 4],
    same_bits: bool,
}

impl GpuGroup {
    /// The group's instances, in order.
    pub(super) fn indices(&self) -> impl Iterator<Item = u32> + '_ {
        self.runs.iter().flat_map(Clone::clone)
    }
}

/// Which prototype instances become instanced nodes, and their groups.
#[derive(Default)]
pub(super) struct GpuGroups {
    /// Per instance: placed by an instanced node (not expanded).
    pub(super) instanced: Vec<bool>,
    pub(super) groups: Vec<GpuGroup>,
    /// Every prototype instance is placed by an instanced node: the flat `VERTEX`
    /// primitive is [`Output::mesh`] alone, found without walking the instances.
    pub(super) all_prototypes_instanced: bool,
}

/// What groups prototype instances: the shared mesh, the mirroring, and the frame
/// colour's bits for a prototype whose items add colour deltas.
pub(super) type GroupKey = (u32, bool, Option<[u32; 4]>);

/// Groups the instances of every shared mesh — prototypes and isosurfaces alike —
/// for `EXT_mesh_gpu_instancing`. Left to the geometry (prototypes) or to nodes and
/// baking (isosurfaces): instances of animated bones in a skinned output (three.js
/// cannot instance skinned meshes), degenerate or non-finite frames, isosurfaces in
/// frames with a non-uniform factor, and colour variants past [`MAX_COLOR_VARIANTS`].
pub(super) fn gpu_instance_groups(out: &Output, skinned: bool) -> GpuGroups {
    let mut g = GpuGroups { instanced: vec![false; out.instances.len()], ..GpuGroups::default() };
    let mut index: BTreeMap<GroupKey, usize> = BTreeMap::new();
    let mut variants: BTreeMap<u32, usize> = BTreeMap::new();
    // Per shared mesh: whether it is a prototype, and for one with triangles (a
    // prototype or an isosurface) whether its vertices add colours to the
    // instance's (a prototype's items' deltas).
    let kind: Vec<(bool, Option<bool>)> = out
        .shared_meshes
        .iter()
        .map(|s| {
            let deltas = s.is_prototype() && s.mesh.colors.iter().any(|c| *c != [0.0; 4]);
            (s.is_prototype(), (!s.mesh.triangles.is_empty()).then_some(deltas))
        })
        .collect();
    // Prototype instances seen, and those placed by instanced nodes.
    let (mut prototypes, mut placed) = (0usize, 0usize);
    // Consecutive instances mostly share a group: the last one is tried first.
    let mut last: Option<(GroupKey, usize)> = None;
    let frames = out.instances.packed_frames();
    // By spans of equal mesh, colour, bone and `lin`: within one, an instance's group
    // depends on its frame alone (placeable or not, mirrored or not), so the frames
    // are classed in a tight loop and each run of one class joins its group at once.
    for span in out.instances.spans() {
        let Some(&(is_prototype, deltas)) = kind.get(span.mesh as usize) else { continue };
        if is_prototype {
            prototypes += span.range.len();
        }
        let Some(deltas) = deltas else { continue };
        // (An isosurface in a frame with a non-uniform factor is no TRS: a node or baked.)
        if (skinned && span.bone != 0) || span.lin != 0 {
            continue;
        }
        let bits = span.color.map(f32::to_bits);
        let Some(fs) = frames.get(span.range.clone()) else { continue };
        let mut at = span.range.start;
        for (class, n) in class_runs(fs) {
            let run = at..at + n;
            at += n;
            let Some(mirrored) = class else { continue };
            let key = (span.mesh, mirrored, deltas.then_some(bits));
            let k = match last {
                Some((k, at)) if k == key => at,
                _ => match index.get(&key) {
                    Some(&k) => k,
                    None => {
                        let n = variants.entry(span.mesh).or_insert(0);
                        if deltas && *n >= MAX_COLOR_VARIANTS {
                            continue;
                        }
                        *n += 1;
                        g.groups.push(GpuGroup {
                            mesh: span.mesh,
                            mirrored,
                            color: deltas.then_some(span.color),
                            runs: Vec::new(),
                            count: 0,
                            first_bits: bits,
                            same_bits: true,
                        });
                        index.insert(key, g.groups.len() - 1);
                        g.groups.len() - 1
                    }
                },
            };
            last = Some((key, k));
            let group = &mut g.groups[k];
            group.same_bits &= bits == group.first_bits;
            let (a, b) = (run.start as u32, run.end as u32);
            match group.runs.last_mut() {
                Some(r) if r.end == a => r.end = b,
                _ => group.runs.push(a..b),
            }
            group.count += run.len();
            if let Some(flags) = g.instanced.get_mut(run.clone()) {
                flags.fill(true);
            }
            if is_prototype {
                placed += run.len();
            }
        }
    }
    g.all_prototypes_instanced = placed == prototypes;
    g
}

/// The frames `fs` as runs of one class, in order: `(None, n)` for n frames that
/// are no TRS ([`prototype_placeable`]), `(Some(mirrored), n)` for n that are
/// ([`frame_mirrors`]).
fn class_runs(fs: &[PackedFrame]) -> impl Iterator<Item = (Option<bool>, usize)> + '_ {
    // 0: not placeable, 1: placeable, 2: placeable and mirrored: the products and
    // sums of `prototype_placeable` and `frame_mirrors` (Quat's dot is Vec4's), on
    // the packed numbers in SIMD lanes.
    let class = |p: &PackedFrame| {
        let q = glam::Vec4::from_slice(&p[0..4]);
        let h = glam::Vec4::from_slice(&p[4..8]);
        let u = glam::Vec4::new(p[8], p[9], p[10], 0.0);
        let s = q.length_squared() * h.length_squared();
        let placeable = (s > 0.0) & (s < f32::INFINITY) & u.abs().cmplt(glam::Vec4::INFINITY).all();
        let mirrored = h.dot(q * glam::Vec4::new(-1.0, -1.0, -1.0, 1.0)) < 0.0;
        u8::from(placeable) * (1 + u8::from(mirrored))
    };
    let mut at = 0;
    std::iter::from_fn(move || {
        let first = class(fs.get(at)?);
        let n = 1 + fs.get(at + 1..).map_or(0, |rest| rest.iter().take_while(|p| class(p) == first).count());
        at += n;
        Some(([None, Some(false), Some(true)][usize::from(first)], n))
    })
}

/// The frame a packed frame holds (the bits of [`mdg_vm::output::Instances::frame`]).
#[inline(always)]
pub(super) fn packed_frame(p: &PackedFrame) -> Frame {
    let [qx, qy, qz, qw, hx, hy, hz, hw, ux, uy, uz] = *p;
    Frame { q: Quat::from_xyzw(qx, qy, qz, qw), qh: Quat::from_xyzw(hx, hy, hz, hw), u: Vec3::new(ux, uy, uz) }
}

/// Whether a frame built by the adjustments mirrors: `q̂ = ±q̄` (geom::quat), the
/// sign being the mirroring, read off `q̂ · q̄`.
pub(super) fn frame_mirrors(f: &Frame) -> bool {
    f.qh.dot(mdg_vm::geom::quat::conj(f.q)) < 0.0
}

/// Whether a prototype instance's frame can be a glTF TRS: finite, of non-zero scale.
pub(super) fn prototype_placeable(f: &Frame) -> bool {
    let s = f.q.length_squared() * f.qh.length_squared();
    // (Branch-free: the comparisons fail for NaN.)
    (s > 0.0) & (s < f32::INFINITY) & f.u.abs().cmplt(Vec3::INFINITY).all()
}

/// The TRS of a placeable prototype instance's frame as glTF holds it
/// (translation, unit rotation, uniform scale): for a mirrored frame, of the frame
/// times a mirror in x, which places the prototype's copy mirrored in x. A frame
/// built by the adjustments maps `x ↦ ±s R x` (q̂ = ±q̄): R is the rotation of
/// q/|q|, s = |q| |q̂|; −I times the mirror in x is a half turn about x.
pub(super) fn prototype_trs(f: &Frame) -> ([f32; 3], [f32; 4], f32) {
    (f.u.to_array(), prototype_rotation(f), prototype_scale(f))
}

/// The rotation of [`prototype_trs`].
#[inline]
pub(super) fn prototype_rotation(f: &Frame) -> [f32; 4] {
    // q/|q| is a unit quaternion; times the unit x quaternion (a half turn about x)
    // it stays one: r·i = (w, z, −y, −x) in (x, y, z, w), no normalisation needed.
    let r = mdg_vm::geom::quat::scaled(f.q, 1.0 / f.q.length());
    let r = if frame_mirrors(f) { Quat::from_xyzw(r.w, r.z, -r.y, -r.x) } else { r };
    r.to_array()
}

/// The uniform scale of [`prototype_trs`].
#[inline]
pub(super) fn prototype_scale(f: &Frame) -> f32 {
    f.q.length() * f.qh.length()
}

/// The bytes of one instance in an instanced node's strided TRS view: TRANSLATION
/// (3 floats), ROTATION (4), SCALE (3).
pub(super) const TRS_STRIDE: usize = 40;

/// One instance's TRANSLATION, ROTATION and SCALE as the strided view holds them
/// (see [`prototype_trs`]; `mirrored` is the group's, which is the frame's),
/// non-finite numbers written as 0: the same bits as [`prototype_rotation`] and
/// [`prototype_scale`], |q| computed once.
#[inline]
pub(super) fn trs_record(f: &Frame, mirrored: bool) -> [f32; 10] {
    let lq = f.q.length();
    let r = mdg_vm::geom::quat::scaled(f.q, 1.0 / lq);
    let r = if mirrored { [r.w, r.z, -r.y, -r.x] } else { r.to_array() };
    let s = lq * f.qh.length();
    [f.u.x, f.u.y, f.u.z, r[0], r[1], r[2], r[3], s, s, s].map(finite)
}

/// The instance attributes of an instanced node, streamed into the file (nothing
/// of them is held), in one pass over the instances: per instance its TRANSLATION,
/// ROTATION and SCALE side by side ([`TRS_STRIDE`] bytes, one strided view); then,
/// when `per_color`, `_COLOR_0` in a view of its own (three.js reads an instance
/// colour attribute's whole array, so it cannot share a strided view).
pub(super) fn write_instance_attributes(
    out: &Output,
    group: &GpuGroup,
    per_color: bool,
    sink: &mut Sink,
) -> Result<(), ExportError> {
    let frames = out.instances.packed_frames();
    let missing = || ExportError::Inconsistent("instanced node: an instance out of range");
    // (The records of a run in slots of at most SINK_BYTES, each filled in a tight
    // loop over the packed frames.)
    for run in &group.runs {
        let fs = frames.get(run.start as usize..run.end as usize).ok_or_else(missing)?;
        for part in fs.chunks(SINK_BYTES / TRS_STRIDE) {
            let b = sink.slot(part.len() * TRS_STRIDE)?;
            let (records, _) = b.as_chunks_mut::<TRS_STRIDE>();
            for (d, p) in records.iter_mut().zip(part) {
                let r = trs_record(&packed_frame(p), group.mirrored);
                for (d, x) in d.as_chunks_mut::<4>().0.iter_mut().zip(r) {
                    *d = x.to_le_bytes();
                }
            }
        }
    }
    if per_color {
        // The colours by spans (one colour each) met in the order of the runs.
        let mut spans = out.instances.spans();
        let mut span = spans.next();
        let mut last = ([1.0f32; 4], linear_color([1.0; 4]));
        for run in &group.runs {
            let (mut a, b) = (run.start as usize, run.end as usize);
            while a < b {
                while span.as_ref().is_some_and(|s| s.range.end <= a) {
                    span = spans.next();
                }
                let s = span.as_ref().filter(|s| s.range.start <= a).ok_or_else(missing)?;
                let c = clamp_color(s.color);
                if c != last.0 {
                    last = (c, linear_color(c));
                }
                let n = b.min(s.range.end) - a;
                let rgb = [last.1[0], last.1[1], last.1[2]].map(f32::to_le_bytes);
                for _ in 0..n {
                    sink.put(rgb.as_flattened())?;
                }
                a += n;
            }
        }
    }
    Ok(())
}

/// How a prototype instance of frame `f` is placed as a translation, a unit
/// rotation (x, y, z, w) and a per-axis scale applied to the prototype's own mesh —
/// what `--instances` writes, for other instancing consumers (the Python package,
/// Blender's geometry nodes). A mirrored frame gets the scale (−s, s, s): the mirror
/// in x, with the rotation that `--instances` gives its mirrored copy. `None` for a
/// frame that cannot be placed so (zero or non-finite scale or translation): such an
/// instance is expanded into the geometry instead.
pub fn prototype_placement(f: &Frame) -> Option<([f32; 3], [f32; 4], [f32; 3])> {
    if !prototype_placeable(f) {
        return None;
    }
    let (t, r, s) = prototype_trs(f);
    let sx = if frame_mirrors(f) { -s } else { s };
    Some((t, r, [sx, s, s]))
}

/// A prototype's mesh as an instanced node draws it: in its own space, normals as
/// [`mdg_vm::output::SharedMesh::local_normal`], colours `frame colour + delta` when
/// `color` is given (else white), triangles oriented for an unmirrored frame (and
/// the whole mesh mirrored in x when `mirrored`).
pub(super) fn prototype_local_mesh(
    shared: &mdg_vm::output::SharedMesh,
    color: Option<[f32; 4]>,
    mirrored: bool,
) -> Mesh {
    let p = &shared.mesh;
    let mut m = Mesh::default();
    for i in 0..p.n_vertices() {
        let c = match color {
            Some(f) => {
                let d = p.colors.get(i).copied().unwrap_or([0.0; 4]);
                [f[0] + d[0], f[1] + d[1], f[2] + d[2], f[3] + d[3]]
            }
            None => [1.0; 4],
        };
        m.push_vertex(Vec3::from(p.positions[i]), shared.local_normal(i), c, [0.0; 4], 0);
    }
    for (t, tri) in p.triangles.iter().enumerate() {
        m.push_triangle(*tri, p.mirrored.get(t).copied().unwrap_or(false));
    }
    if mirrored {
        mirrored_copy(&m)
    } else {
        m
    }
}

impl<'a> Builder<'a> {
    /// One node drawing `group`'s instances with `EXT_mesh_gpu_instancing`: the
    /// prototype's mesh in its own space (mirrored in x for mirrored frames), and
    /// per instance TRANSLATION, ROTATION and SCALE, plus `_COLOR_0` (linear RGB,
    /// which three.js reads as the instance colour) when the colours differ; a
    /// colour shared by every instance goes in the material instead.
    pub(super) fn instanced_node(&mut self, out: &'a Output, group: &'a GpuGroup) -> Result<Option<u32>, ExportError> {
        let Some(shared) = out.shared_meshes.get(group.mesh as usize) else { return Ok(None) };
        let local = prototype_local_mesh(shared, group.color, group.mirrored);
        let name = if group.mirrored { format!("{} mirrored", shared.name) } else { shared.name.clone() };
        let tris = checked_triangles(&local, &name)?;
        if tris.is_empty() {
            return Ok(None);
        }
        let n = local.positions.len();
        let double_sided = !is_closed(&local, &tris);
        let mut attributes = BTreeMap::new();
        attributes.insert("POSITION", self.vec3_from(n, |i| finite3(local.positions[i]), true));
        attributes.insert("NORMAL", self.vec3_from(n, |i| normal_at(&local, i), false));
        if group.color.is_some() {
            attributes.insert("COLOR_0", self.vec4_from(n, |i| linear_color(color_at(&local, i))));
        }
        let indices = Some(self.indices_of(tris.len() * 3, tris.iter().flatten().copied()));
        let colors = || group.indices().filter_map(|i| out.instances.color(i as usize));
        // A colour shared by every instance goes in the material: seen from the
        // colours' bits while grouping, or (rarely: different bits, say above 1, that
        // clamp alike) by a walk.
        let first = colors().next().map(clamp_color);
        let shared_color = match (group.color, first) {
            (None, Some(c)) if group.same_bits || colors().all(|k| clamp_color(k) == c) => Some(c),
            _ => None,
        };
        let material = Some(self.material(shared_color.unwrap_or([1.0; 4]), double_sided));
        let extras = sites::instanced_extras(out, group.indices());
        let mesh = self.push_mesh(GMesh {
            name: Some(name.clone()),
            primitives: vec![Primitive { attributes, indices, material, mode: None, extras }],
        });
        let n_inst = group.count;
        let per_color = group.color.is_none() && shared_color.is_none();
        // The attributes' values are written when the file is, in one pass: TRS side
        // by side in one strided view, then `_COLOR_0` in a view of its own.
        let trs_len = TRS_STRIDE * n_inst;
        let color_len = if per_color { 12 * n_inst } else { 0 };
        let at = self.stream(
            trs_len + color_len,
            Box::new(move |sink: &mut Sink| write_instance_attributes(out, group, per_color, sink)),
        );
        let view = |b: &mut Builder, byte_offset: usize, byte_length: usize, byte_stride: Option<usize>| {
            b.root.buffer_views.push(BufferView { buffer: 0, byte_offset, byte_length, target: None, byte_stride });
            b.root.buffer_views.len() as u32 - 1
        };
        let trs = view(self, at, trs_len, Some(TRS_STRIDE));
        let colour_view = per_color.then(|| view(self, at + trs_len, color_len, None));
        let mut inst_attrs = BTreeMap::new();
        let attrs = [
            ("TRANSLATION", Some(trs), 0, "VEC3"),
            ("ROTATION", Some(trs), 12, "VEC4"),
            ("SCALE", Some(trs), 28, "VEC3"),
            ("_COLOR_0", colour_view, 0, "VEC3"),
        ];
        for (name, view, byte_offset, kind) in attrs {
            let Some(buffer_view) = view else { continue };
            let acc = self.accessor(Accessor {
                buffer_view,
                byte_offset,
                component_type: FLOAT,
                count: n_inst,
                kind,
                ..Accessor::default()
            });
            inst_attrs.insert(name, acc);
        }
        self.root.extensions_used = vec![EXT_INSTANCING];
        let node = self.push_node(Node {
            name: Some(name),
            mesh: Some(mesh),
            extensions: Some(NodeExtensions { instancing: Instancing { attributes: inst_attrs } }),
            ..Node::default()
        });
        Ok(Some(node))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_vm::output::{Instance, SharedKind, SharedMesh};

    /// A triangle prototype, with colour deltas when `deltas`.
    fn triangle(name: &str, deltas: bool) -> SharedMesh {
        let mut m = Mesh::default();
        let d = if deltas { [0.1, 0.0, 0.0, 0.0] } else { [0.0; 4] };
        for p in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] {
            m.push_vertex(Vec3::new(p[0], p[1], 0.0), Vec3::Z, d, [0.0; 4], 0);
        }
        m.push_triangle([0, 1, 2], false);
        SharedMesh { name: name.into(), mesh: m, kind: SharedKind::Prototype { face_normals: vec![None] } }
    }

    /// The groups as the walk instance by instance made them (the writer before
    /// spans): per instance its key, groups in order of their first instance.
    /// A group as the test compares it: key, instances, whether the colours' bits agree.
    type Seen = (GroupKey, Vec<u32>, bool);

    fn one_by_one(out: &Output) -> (Vec<bool>, Vec<Seen>) {
        let mut instanced = vec![false; out.instances.len()];
        let mut groups: Vec<(GroupKey, Vec<u32>, bool, [u32; 4])> = Vec::new();
        let mut variants: BTreeMap<u32, usize> = BTreeMap::new();
        for (i, r) in out.instances.iter().enumerate() {
            let Some(s) = out.shared_meshes.get(r.mesh as usize) else { continue };
            let deltas = s.mesh.colors.iter().any(|c| *c != [0.0; 4]);
            if r.lin != 0 || !prototype_placeable(&r.frame) {
                continue;
            }
            let bits = r.color.map(f32::to_bits);
            let key = (r.mesh, frame_mirrors(&r.frame), deltas.then_some(bits));
            let k = match groups.iter().position(|g| g.0 == key) {
                Some(k) => k,
                None => {
                    let n = variants.entry(r.mesh).or_insert(0);
                    if deltas && *n >= MAX_COLOR_VARIANTS {
                        continue;
                    }
                    *n += 1;
                    groups.push((key, Vec::new(), true, bits));
                    groups.len() - 1
                }
            };
            groups[k].1.push(i as u32);
            groups[k].2 &= bits == groups[k].3;
            instanced[i] = true;
        }
        (instanced, groups.into_iter().map(|(k, v, same, _)| (k, v, same)).collect())
    }

    /// Grouping by spans and classed runs of frames gives the groups, instances and
    /// flags of the walk instance by instance: mirrored, degenerate and non-finite
    /// frames among plain ones, colours changing within and between groups, a
    /// prototype with colour deltas past its variants, a non-uniform factor.
    #[test]
    fn grouping_by_spans_is_grouping_one_by_one() {
        let mut out = Output::default();
        out.shared_meshes.push(triangle("plain", false));
        out.shared_meshes.push(triangle("deltas", true));
        let mut rng = mdg_vm::rng::Rng::new(37);
        let mut unit = move || (rng.bits() >> 40) as f32 / (1u64 << 24) as f32;
        for i in 0..3000u32 {
            let mut f = Frame::identity()
                .translate(Vec3::new(unit(), unit(), unit()))
                .rotate(Quat::from_rotation_z(7.0 * unit()))
                .scale(0.5 + unit());
            match (unit() * 12.0) as u32 {
                0..3 => f = f.reflect(Vec3::X),
                3 => f = f.scale(0.0),
                4 => f.u.y = f32::INFINITY,
                5 => f.q.x = f32::NAN,
                _ => {}
            }
            let color = [((i / 7) % 3) as f32 * 0.25, 0.5, (i % 90 / 45) as f32, 1.0];
            let mesh = u32::from(i % 500 >= 400);
            let lin = u32::from(i % 250 == 3);
            out.instances.push(Instance { frame: f, color, mesh, bone: 0, lin, at: 0 });
        }
        // Colour variants past the limit for the prototype with deltas.
        for k in 0..(MAX_COLOR_VARIANTS as u32 + 5) {
            let color = [0.001 * k as f32, 0.2, 0.3, 1.0];
            out.instances.push(Instance { frame: Frame::identity(), color, mesh: 1, bone: 0, lin: 0, at: 0 });
        }
        let g = gpu_instance_groups(&out, false);
        let got: Vec<Seen> = g
            .groups
            .iter()
            .map(|x| {
                assert_eq!(x.count, x.indices().count());
                ((x.mesh, x.mirrored, x.color.map(|c| c.map(f32::to_bits))), x.indices().collect(), x.same_bits)
            })
            .collect();
        let (instanced, want) = one_by_one(&out);
        assert!(want.len() > 4 && want.iter().any(|w| w.0 .1) && want.iter().any(|w| !w.2));
        assert_eq!(got, want);
        assert_eq!(g.instanced, instanced);
        assert!(!g.all_prototypes_instanced);
    }
}
