//! `--instances`: the prototype and isosurface instances grouped for
//! `EXT_mesh_gpu_instancing`, one node per group with its instances' TRS (one
//! strided view, written in one pass when the file is) and colours.

use super::*;

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
    for (i, r) in records(out).enumerate() {
        let Some(&(is_prototype, deltas)) = kind.get(r.mesh as usize) else { continue };
        prototypes += usize::from(is_prototype);
        let Some(deltas) = deltas else { continue };
        // (An isosurface in a frame with a non-uniform factor is no TRS: a node or baked.)
        if (skinned && r.bone != 0) || !prototype_placeable(&r.frame) || r.lin != 0 {
            continue;
        }
        let bits = r.color.map(f32::to_bits);
        let key = (r.mesh, frame_mirrors(&r.frame), deltas.then_some(bits));
        let k = match last {
            Some((k, at)) if k == key => at,
            _ => match index.get(&key) {
                Some(&k) => k,
                None => {
                    let n = variants.entry(r.mesh).or_insert(0);
                    if deltas && *n >= MAX_COLOR_VARIANTS {
                        continue;
                    }
                    *n += 1;
                    g.groups.push(GpuGroup {
                        mesh: r.mesh,
                        mirrored: key.1,
                        color: deltas.then_some(r.color),
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
        let i32 = i as u32;
        match group.runs.last_mut() {
            Some(run) if run.end == i32 => run.end += 1,
            _ => group.runs.push(i32..i32 + 1),
        }
        group.count += 1;
        g.instanced[i] = true;
        placed += usize::from(is_prototype);
    }
    g.all_prototypes_instanced = placed == prototypes;
    g
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
    for i in group.indices() {
        sink.floats(out.instances.frame(i as usize).map_or([0.0; 10], |f| trs_record(&f, group.mirrored)))?;
    }
    if per_color {
        let mut last = ([1.0f32; 4], linear_color([1.0; 4]));
        for i in group.indices() {
            let c = out.instances.color(i as usize).map_or([0.0; 4], clamp_color);
            if c != last.0 {
                last = (c, linear_color(c));
            }
            sink.floats([last.1[0], last.1[1], last.1[2]])?;
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
