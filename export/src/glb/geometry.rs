//! The flat triangle primitives of the `geometry` node: the `VERTEX` group (its
//! prototype instances expanded), the sweeps and the baked instances.

use super::*;

impl<'a> Builder<'a> {
    /// A triangle primitive with vertex colours for `m` (world space), or `None` when
    /// it has no triangles.
    pub(super) fn colored_primitive(
        &mut self,
        src: FlatSource<'a>,
        what: &str,
    ) -> Result<Option<Primitive>, ExportError> {
        let m = match &src {
            FlatSource::Mesh(m) => *m,
            FlatSource::Owned(m) => m,
            FlatSource::Vertex { .. } => return Err(ExportError::NotOneMesh { what: what.to_string() }),
        };
        let tris = checked_triangles(m, what)?;
        if tris.is_empty() {
            return Ok(None);
        }
        let double_sided = !is_closed(m, &tris);
        drop(tris);
        self.flat_primitive(src, double_sided, what)
    }

    /// The primitive of the `VERTEX` triangles with the prototype instances not in
    /// `instanced` expanded where they were made, or `None` when there are no
    /// triangles. Double-sided unless the triangles emitted one by one form closed
    /// surfaces and so does every expanded prototype on its own (exact where there
    /// are no prototype instances; otherwise a piece that is only closed by another
    /// piece is taken as open, which shows nothing wrong: see docs/decisions.md).
    pub(super) fn vertex_primitive(
        &mut self,
        out: &'a Output,
        gpu: &'a GpuGroups,
    ) -> Result<Option<Primitive>, ExportError> {
        let instanced = gpu.instanced.as_slice();
        let expand = |i: usize| !instanced.get(i).copied().unwrap_or(false);
        // (With every prototype instanced, the group is the mesh alone.)
        let mesh_only = gpu.all_prototypes_instanced;
        // (Without instanced nodes every instance is expanded: counted by spans.)
        let n_tris = match (mesh_only, instanced.contains(&true)) {
            (true, _) => out.mesh.triangles.len(),
            (false, false) => out.flat_counts_where(Groups::VERTEX, |_| true).1,
            (false, true) => out.flat_counts_where(Groups::VERTEX, expand).1,
        };
        if n_tris == 0 {
            return Ok(None);
        }
        // (Every prototype in the table has instances; with --instances some may all be
        // instanced, and counting such a one errs on the double-sided side.)
        let mut closed = is_closed(&out.mesh, &checked_triangles(&out.mesh, "VERTEX mesh")?);
        for s in out.shared_meshes.iter().filter(|s| s.is_prototype()) {
            if !closed {
                break;
            }
            closed = is_closed(&s.mesh, &checked_triangles(&s.mesh, &s.name)?);
        }
        self.flat_primitive(FlatSource::Vertex { out, instanced, mesh_only }, !closed, "VERTEX mesh")
    }

    /// A triangle primitive with vertex colours (and the skin attributes of a skinned
    /// output) from the pieces of `src`, streamed into the file: a first walk finds
    /// the counts, the bounds, the colour precision and whether an index buffer is
    /// needed; the file's second walk writes the vertices as interleaved records
    /// ([`VertexRecord`]) straight to the output, expanding each prototype instance
    /// from its frame. Without indices (the usual case: every vertex in one triangle,
    /// in order) the vertices go in each triangle's oriented order.
    pub(super) fn flat_primitive(
        &mut self,
        src: FlatSource<'a>,
        double_sided: bool,
        what: &str,
    ) -> Result<Option<Primitive>, ExportError> {
        let mut infos = src.output().map(ProtoInfos::new);
        let skinned = self.skinned;
        // The usual layout is guessed from the counts: 8-bit colours, no indices. A
        // walk places the vertices once, writing them to a spool and finding their
        // bounds (which the JSON, before the binary chunk, needs); if the guess does
        // not hold, a first walk plans the layout and the vertices are written again.
        let (n, n_tris) = src.counts();
        if n_tris == 0 {
            return Ok(None);
        }
        let spooled = spool_flat(&src, what, skinned, &mut infos, (n, n_tris), self.spool_bytes)?;
        let plan_of = |p: &FlatPlan| (p.n, p.n_tris, p.wide, p.sequential);
        let (offset, (n, n_tris, wide, sequential), lo, hi) = match spooled {
            Some((plan, bytes, bounds)) => {
                let (lo, hi) = bounds.arrays();
                (self.held(bytes), plan_of(&plan), lo, hi)
            }
            None => {
                // Too big to hold: a walk finds the bounds, and the file's walk writes.
                let plan = flat_plan(&src, what, &mut infos, true)?;
                let bytes =
                    plan.n * flat_stride(plan.wide, skinned) + if plan.sequential { 0 } else { 12 * plan.n_tris };
                let (lo, hi, layout) = (plan.lo, plan.hi, plan_of(&plan));
                let write = move |sink: &mut Sink| match flat_write(&src, &plan, skinned, &mut infos, sink)? {
                    Some(_) => Ok(()),
                    None => Err(ExportError::Inconsistent("flat geometry: the layout planned does not hold")),
                };
                (self.stream(bytes, Box::new(write)), layout, lo, hi)
            }
        };
        let stride = flat_stride(wide, skinned);
        let vertex_bytes = n * stride;
        let index_bytes = if sequential { 0 } else { 12 * n_tris };
        if n_tris == 0 {
            return Err(ExportError::Inconsistent("flat geometry: triangles counted but not walked"));
        }
        self.root.buffer_views.push(BufferView {
            buffer: 0,
            byte_offset: offset,
            byte_length: vertex_bytes,
            target: Some(ARRAY_BUFFER),
            byte_stride: Some(stride),
        });
        let vertices = self.root.buffer_views.len() as u32 - 1;
        let mut attributes = BTreeMap::new();
        let mut acc = |byte_offset, component_type, normalized, kind, bounds: Option<([f32; 3], [f32; 3])>| {
            let (min, max) = bounds.map_or((None, None), |(a, b)| (Some(a.to_vec()), Some(b.to_vec())));
            self.accessor(Accessor {
                buffer_view: vertices,
                byte_offset,
                component_type,
                normalized,
                count: n,
                kind,
                min,
                max,
            })
        };
        attributes.insert("POSITION", acc(0, FLOAT, false, "VEC3", Some((lo, hi))));
        attributes.insert("NORMAL", acc(12, FLOAT, false, "VEC3", None));
        let color_type = if wide { UNSIGNED_SHORT } else { UNSIGNED_BYTE };
        attributes.insert("COLOR_0", acc(24, color_type, true, "VEC4", None));
        if skinned {
            let w = if wide { 32 } else { 28 };
            attributes.insert("JOINTS_0", acc(w, UNSIGNED_SHORT, false, "VEC4", None));
            attributes.insert("WEIGHTS_0", acc(w + 8, FLOAT, false, "VEC4", None));
        }
        let indices = if sequential {
            None
        } else {
            self.root.buffer_views.push(BufferView {
                buffer: 0,
                byte_offset: offset + vertex_bytes,
                byte_length: index_bytes,
                target: Some(ELEMENT_ARRAY_BUFFER),
                byte_stride: None,
            });
            let view = self.root.buffer_views.len() as u32 - 1;
            Some(self.accessor(Accessor {
                buffer_view: view,
                component_type: UNSIGNED_INT,
                count: 3 * n_tris,
                kind: "SCALAR",
                ..Accessor::default()
            }))
        };
        let material = Some(self.material([1.0; 4], double_sided));
        Ok(Some(Primitive { attributes, indices, material, mode: None, extras: None }))
    }
}

/// A flat primitive written to a spool by the walk that finds its bounds: its
/// layout, bytes and bounds, or `None` when it is bigger than `spool_bytes` (`None`:
/// [`SPOOL_BYTES`]). The layout is first guessed from the counts `(n, n_tris)`
/// (8-bit colours, no indices); where the guess does not hold, a walk plans it.
fn spool_flat(
    src: &FlatSource,
    what: &str,
    skinned: bool,
    infos: &mut Option<ProtoInfos>,
    (n, n_tris): (usize, usize),
    spool_bytes: Option<usize>,
) -> Result<Option<(FlatPlan, Vec<u8>, flat::Bounds)>, ExportError> {
    let spool_bytes = spool_bytes.unwrap_or(SPOOL_BYTES);
    // (Other layouts are bigger: wider records, indices.)
    if n * flat_stride(false, skinned) > spool_bytes {
        return Ok(None);
    }
    let guess =
        FlatPlan { n, n_tris, sequential: true, wide: false, lo: [f32::INFINITY; 3], hi: [f32::NEG_INFINITY; 3] };
    let mut sink = Sink::spool(n * flat_stride(false, skinned));
    if let Some(bounds) = flat_write(src, &guess, skinned, infos, &mut sink)? {
        return Ok(Some((guess, sink.into_spool()?, bounds)));
    }
    let plan = flat_plan(src, what, infos, false)?;
    let bytes = plan.n * flat_stride(plan.wide, skinned) + if plan.sequential { 0 } else { 12 * plan.n_tris };
    if bytes > spool_bytes {
        return Ok(None);
    }
    let mut sink = Sink::spool(bytes);
    let bounds = flat_write(src, &plan, skinned, infos, &mut sink)?
        .ok_or(ExportError::Inconsistent("flat geometry: the layout planned does not hold"))?;
    Ok(Some((plan, sink.into_spool()?, bounds)))
}
