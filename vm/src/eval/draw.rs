//! Drawing: vertices, lines, sweeps, blends, isosurfaces, prototype instances.

use super::*;

/// A prototype of the bundle (an `INST` op): where its items are, and its mesh in the
/// output once an instance of it has been made.
pub(super) struct ProtoSlot {
    /// The op after the `INST` (its first item) and how many items it covers.
    pub(super) first: u32,
    pub(super) count: u32,
    /// Index into `Output::shared_meshes`, or `NONE` until the first instance.
    pub(super) mesh: u32,
    /// Vertices per instance.
    pub(super) vertices: u32,
    /// The largest coordinate of its mesh (see [`frame_surely_maps_finite`]).
    pub(super) extent: f32,
    /// Its items are std `flat`'s (a flat primitive's): its vertices are matte
    /// ([`Mesh::matte`](crate::geom::mesh::Mesh#structfield.matte)).
    pub(super) matte: bool,
}

/// Whether the op at `pc` is in std `flat` (`CIRCLE`, `SQUARE`, `TRIANGLE`): its
/// vertices are drawn without a specular highlight.
pub(super) fn in_std_flat(b: &Bundle, pc: u32) -> bool {
    b.source_of(pc).is_some_and(|(file, _)| file == "std/flat.mdg")
}

#[derive(Clone, Copy)]
pub(super) struct Pen {
    pub(super) state: State,
    pub(super) lifted: bool,
    pub(super) line: Option<usize>,
    /// The bone the pen's position was set in: a sweep's first ring and a line's
    /// point there belong to it.
    pub(super) bone: u32,
}

impl<'b> Eval<'b> {
    /// Adds an instance of prototype `proto` in state `base` (bone `bone`): the one
    /// record its items stand for (see the `INST` op).
    #[inline(always)]
    pub(super) fn emit_instance(&mut self, proto: u32, base: &State, bone: u32) {
        let Some(mesh) = self.instance_mesh::<true, false>(proto, &base.f) else { return };
        let out = &mut self.out;
        if base.weight != [0.0; 4] || !out.instance_weights.is_empty() {
            out.instance_weights.resize(out.instances.len(), [0.0; 4]);
            out.instance_weights.push(base.weight);
        }
        let at = out.mesh.n_vertices() as u32;
        out.instances.push_parts(&base.f, base.color, [mesh, bone, 0, at]);
    }

    /// [`Eval::emit_instance`] in a lean run (see [`Sink::LEAN`]): the instance's
    /// fields but frame and mesh are the run's `fixed` ones, and its weights are
    /// `weight` unless `fixed` says the run carries none (see `Regs::fixed`).
    /// In a `PLAIN` run (see [`Eval::plain_lean`]) the instance is not counted
    /// (see `Eval::uncounted_from`) and carries no weights.
    #[inline(always)]
    pub(super) fn lean_instance<const PLAIN: bool>(
        &mut self,
        proto: u32,
        f: &Frame,
        weight: [f32; 4],
        fixed: &(Fixed, bool),
        tail_is_fixed: &mut bool,
    ) {
        // (The finiteness bound of a lean run's frames is tested when the run is
        // over, see `Eval::lean_ops`.)
        let Some(mesh) = self.instance_mesh::<false, PLAIN>(proto, f) else { return };
        let out = &mut self.out;
        if !PLAIN && !fixed.1 && (weight != [0.0; 4] || !out.instance_weights.is_empty()) {
            out.instance_weights.resize(out.instances.len(), [0.0; 4]);
            out.instance_weights.push(weight);
        }
        out.instances.push_fixed_after(f, &fixed.0, mesh, *tail_is_fixed);
        *tail_is_fixed = true;
    }

    /// What every instance of prototype `proto` under frame `f` does before its
    /// record is pushed: the prototype's mesh (made at its first instance), the
    /// finiteness bound of `f` (with `BOUND`) and the counts (unless `DEFER`). The
    /// mesh, or `None` for no prototype.
    #[inline(always)]
    fn instance_mesh<const BOUND: bool, const DEFER: bool>(&mut self, proto: u32, f: &Frame) -> Option<u32> {
        let slot = self.protos.get(proto as usize)?;
        let (mut mesh, vertices, mut extent) = (slot.mesh, slot.vertices, slot.extent);
        if mesh == NONE {
            mesh = self.make_prototype(proto as usize);
            extent = self.protos.get(proto as usize).map_or(0.0, |s| s.extent);
        }
        // The finiteness bound (`frame_surely_maps_finite`) while the frame is at
        // hand, lane by lane: tested once, at the end (see `finish`). (The extent,
        // a largest absolute coordinate, is never negative: its absolute value is
        // itself.)
        if BOUND {
            self.instances_small &= Vec4::from(f.q).abs().cmplt(Vec4::splat(1e7))
                & Vec4::from(f.qh).abs().cmplt(Vec4::splat(1e7))
                & f.u.extend(extent).abs().cmplt(Vec4::splat(1e15));
        }
        if !DEFER {
            self.instanced_vertices += u64::from(vertices);
            self.prototype_instances += 1;
        }
        Some(mesh)
    }
}

impl<'b> Eval<'b> {
    /// Builds prototype `p`'s mesh from its items (positions, normals, colour and
    /// weight deltas in the run's frame; see [`SharedKind::Prototype`]), adds it to
    /// the output's shared meshes and returns its index.
    #[cold]
    pub(super) fn make_prototype(&mut self, p: usize) -> u32 {
        let b = self.b;
        let Some(slot) = self.protos.get(p) else { return NONE };
        let (first, count) = (slot.first as usize, slot.count as usize);
        let mut m = Mesh::default();
        let mut face_normals = Vec::new();
        for op in b.code.iter().skip(first).take(count) {
            let Op::Draw { kind, xf, .. } = *op else { continue };
            let (Some(Transform::Const(c)), Some(Some(x))) =
                (b.transforms.get(xf.index()), self.xf_info.get(xf.index()))
            else {
                continue;
            };
            match kind {
                Drawable::Vertex => {
                    let k = m.push_vertex(x.frame.u, x.normal, c.color, c.weight, 0) + 1;
                    if k.is_multiple_of(3) {
                        m.push_triangle([k - 3, k - 2, k - 1], x.mirrored);
                        face_normals.push(None);
                    }
                }
                Drawable::FaceNormals => {
                    if let Some(f) = face_normals.last_mut() {
                        *f = Some(x.frame);
                    }
                }
                _ => {}
            }
        }
        if slot.matte {
            m.mark_matte(0..m.n_vertices());
        }
        let name = self.rule_of(first as u32).unwrap_or("").to_string();
        self.out.shared_meshes.push(SharedMesh { name, mesh: m, kind: SharedKind::Prototype { face_normals } });
        let mesh = self.out.shared_meshes.len() as u32 - 1;
        let extent = crate::output::max_abs(&self.out.shared_meshes[mesh as usize].mesh.positions);
        // The extent's part of the finiteness bound, for every instance of it (an
        // instance is made right after): as `instance_mesh` tests it, for the
        // instances that do not test it there.
        self.instances_small &= glam::BVec4A::new(true, true, true, extent.abs() < 1e15);
        if let Some(slot) = self.protos.get_mut(p) {
            slot.mesh = mesh;
            slot.extent = extent;
        }
        mesh
    }
}

impl<'b> Eval<'b> {
    /// The points of profile rule `rule`, made on first use: at most
    /// [`Eval::profile_limit`] (the run of the rule is halted there, with a warning
    /// at the end), so a runaway profile costs neither memory nor time.
    pub(super) fn profile(&mut self, rule: u32) -> std::sync::Arc<[Vec3]> {
        if let Some(p) = self.profiles.get(&rule) {
            return p.clone();
        }
        let saved = std::mem::take(&mut self.profile_points);
        let saved_last = self.last;
        let saved_halt = std::mem::replace(&mut self.halt, false);
        self.run(rule, State::start(self.b.settings.fps), Mode::Profile);
        if self.halt {
            self.profiles_cut.push((rule, self.profile_limit()));
        }
        self.halt = saved_halt;
        self.last = saved_last;
        let pts: std::sync::Arc<[Vec3]> = std::mem::replace(&mut self.profile_points, saved).into();
        self.profiles.insert(rule, pts.clone());
        pts
    }
}

impl<'b> Eval<'b> {
    pub(super) fn draw(&mut self, kind: Drawable, s: State, ns: u32, profile: u32, mode: Mode, bone: u32) {
        if mode == Mode::Profile {
            if kind == Drawable::Vertex {
                if self.profile_points.len() >= self.profile_limit() {
                    self.halt = true;
                } else {
                    self.profile_points.push(s.f.u);
                }
            }
            return;
        }
        if mode == Mode::Transform {
            // Only FRAME counts while a transform rule is sampled.
            if kind == Drawable::Frame {
                if self.frame_sink.len() >= self.frame_limit {
                    self.halt = true;
                } else {
                    self.frame_sink.push(s.f);
                }
            }
            return;
        }
        let ns_i = ns as usize;
        match kind {
            Drawable::Vertex => {
                let n = self.lins.affine(&s).apply_normal(Vec3::from_array(self.b.settings.normal));
                let m = &mut self.out.mesh;
                m.push_vertex(s.f.u, n, s.display_color(), s.weight, bone);
                let k = m.n_vertices() as u32;
                if k.is_multiple_of(3) {
                    m.push_triangle([k - 3, k - 2, k - 1], s.mirrored());
                }
            }
            Drawable::FaceNormals => {
                let m = &mut self.out.mesh;
                let k = m.n_vertices();
                if k >= 3 {
                    let p = |i: usize| Vec3::from_array(m.positions[i]);
                    let (a, b, c) = (p(k - 3), p(k - 2), p(k - 1));
                    let mut n = (b - a).cross(c - a).normalize_or_zero();
                    if s.mirrored() {
                        n = -n;
                    }
                    for i in k - 3..k {
                        m.normals[i] = n.to_array();
                    }
                }
            }
            Drawable::MoveTo => {
                self.pens[ns_i] = Pen { state: s, lifted: false, line: None, bone };
                self.new_line(ns_i, s.f.u, bone);
            }
            Drawable::LineTo | Drawable::BlendTo | Drawable::SLineTo | Drawable::ALineTo => {
                let pen = self.pens[ns_i];
                if pen.lifted {
                    self.pens[ns_i] = Pen { state: s, lifted: false, line: None, bone };
                    self.new_line(ns_i, s.f.u, bone);
                    return;
                }
                let prof_rule = if profile != NONE { profile } else { self.b.settings.linerule };
                if prof_rule != NONE {
                    let pts = self.profile(prof_rule);
                    let rings = if kind == Drawable::BlendTo { BLEND_SEGMENTS + 1 } else { 2 };
                    if pts.len() >= 2 && !self.room_for(rings * pts.len()) {
                        return;
                    }
                    if pts.len() >= 2 {
                        let (ca, cb) = (pen.state.display_color(), s.display_color());
                        let m = &mut self.out.sweeps;
                        let first = m.n_vertices();
                        // Rings carry their end's non-uniform factor (an elliptic tube
                        // from a round profile); BLENDTO's spline, SLINETO's turn and
                        // ALINETO's averaging act on the frames' similarity parts.
                        let (na, nb) = (self.lins.affine(&pen.state).n, self.lins.affine(&s).n);
                        let ring = |f: Frame, n| Affine { f, n };
                        match kind {
                            Drawable::LineTo => {
                                sweep::sweep(m, &pts, &ring(pen.state.f, na), &ring(s.f, nb), ca, cb, bone)
                            }
                            Drawable::BlendTo => {
                                let frames = blend::blend_frames(&pen.state.f, &s.f, BLEND_SEGMENTS);
                                let last = frames.len().saturating_sub(1);
                                let rings: Vec<Affine> = frames
                                    .iter()
                                    .enumerate()
                                    .map(|(i, f)| ring(*f, if i == last { nb } else { na }))
                                    .collect();
                                sweep::sweep_path(m, &pts, &rings, ca, cb, bone);
                            }
                            _ => {
                                let (a, b) = if kind == Drawable::SLineTo {
                                    sweep::oriented_pair(&pen.state.f, &s.f)
                                } else {
                                    sweep::averaged_pair(&pen.state.f, &s.f)
                                };
                                sweep::sweep(m, &pts, &ring(a, na), &ring(b, nb), ca, cb, bone)
                            }
                        }
                        // The first ring stays with the bone the pen started in, so a
                        // tube from outside a bone into it stretches as the bone moves.
                        if pen.bone != bone && m.n_vertices() >= first + pts.len() {
                            m.bones.resize(m.n_vertices(), 0);
                            m.bones[first..first + pts.len()].fill(pen.bone);
                        }
                        // One sweep can add many vertices (a long profile): check the
                        // vertex budget now, not only every 4,096 calls.
                        self.check_budgets();
                    }
                }
                let l = match pen.line {
                    Some(l) => l,
                    None => self.new_line(ns_i, pen.state.f.u, pen.bone),
                };
                self.out.lines[l].push(s.f.u, bone);
                self.extra_vertices += 1;
                self.pens[ns_i].state = s;
                self.pens[ns_i].bone = bone;
            }
            Drawable::NewLine => self.pens[ns_i].lifted = true,
            // FRAME draws nothing in a model: it only counts when a transform rule is sampled.
            Drawable::Frame => {}
            // (Flat path ops come with their arguments to `path_op`; without them, as in
            // a bundle whose DRAW lacks them, which the verifier refuses, nothing.)
            Drawable::ArcTo | Drawable::CurveTo | Drawable::ClosePoly | Drawable::Fill | Drawable::Stroke => {}
            Drawable::Reset => self.last = self.pens[ns_i].state,
            Drawable::Debug => {
                let p = s.f.u;
                let debug = &mut self.out.debug;
                if debug.len() < crate::output::MAX_DEBUG_LINES {
                    debug.push(format!(
                        "DEBUG: position ({:.4}, {:.4}, {:.4}) scale {:.4} mirrored {} colour {:?} weight {:?}",
                        p.x,
                        p.y,
                        p.z,
                        s.scale(),
                        s.mirrored(),
                        s.color,
                        s.weight
                    ));
                } else if debug.len() == crate::output::MAX_DEBUG_LINES {
                    debug.push(format!(
                        "DEBUG: (more reports left out; at most {} are kept)",
                        crate::output::MAX_DEBUG_LINES
                    ));
                }
            }
        }
    }

    pub(super) fn new_line(&mut self, ns: usize, start: Vec3, bone: u32) -> usize {
        let name = self.b.string(self.b.settings.namespaces[ns]).to_string();
        let mut line = Polyline { namespace: name, ..Polyline::default() };
        line.push(start, bone);
        self.extra_vertices += 1;
        self.out.lines.push(line);
        let l = self.out.lines.len() - 1;
        self.pens[ns].line = Some(l);
        l
    }

    pub(super) fn instance(&mut self, iso: u32, s: &State, pc: u32, bone: u32) {
        let mesh = match self.iso_meshes.get(&iso) {
            Some(m) => *m,
            None => {
                let decl = &self.b.isosurfaces[iso as usize];
                let grid =
                    marching::Grid { min: Vec3::from_array(decl.min), max: Vec3::from_array(decl.max), res: decl.res };
                let code = &self.b.exprs[decl.function as usize];
                let rng = std::cell::RefCell::new(Pcg(Pcg64::seed_from_u64(0)));
                let stack = std::cell::RefCell::new(expr::Machine::new(self.opts.calls));
                let f = |p: Vec3| {
                    let vars = [p.x as f64, p.y as f64, p.z as f64, 0.0, 1.0, 0.0];
                    expr::eval(code, &vars, &[], &mut *rng.borrow_mut(), &mut stack.borrow_mut()) as f32
                };
                let name = self.b.string(decl.name).to_string();
                // One cell limit for the run, and the time budget checked inside.
                let cells_left = self.opts.max_iso_cells.saturating_sub(self.iso_cells);
                let (started, budget) = (self.started, self.opts.time_budget);
                let out_of_time = || budget.is_some_and(|t| started.elapsed() > t);
                let r = match marching::polygonize(&grid, &f, cells_left, &out_of_time) {
                    Ok(m) => {
                        self.iso_cells += grid.n_cells();
                        // A shared mesh can hold many vertices: check now, not every
                        // 4,096 calls.
                        self.extra_vertices += m.n_vertices() as u64;
                        self.check_budgets();
                        self.out.shared_meshes.push(SharedMesh::isosurface(name, m));
                        Some(self.out.shared_meshes.len() as u32 - 1)
                    }
                    Err(marching::Refused::OutOfTime) => {
                        self.check_budgets();
                        self.stop_pc.get_or_insert(pc);
                        None
                    }
                    Err(e) => {
                        let at = self.b.source_of(pc).map(|(f, l)| format!("{f}:{l}: ")).unwrap_or_default();
                        let e = match e {
                            marching::Refused::TooManyCells(n) if n <= self.opts.max_iso_cells => format!(
                                "its {n} cells would take the run past the limit of {} cells for all isosurfaces \
                                 ({} already used; raise it with `--max-iso-cells N`)",
                                self.opts.max_iso_cells, self.iso_cells
                            ),
                            marching::Refused::TooManyCells(n) => format!(
                                "isosurface grid has {n} cells, more than the limit of {} \
                                 (raise it with `--max-iso-cells N`)",
                                self.opts.max_iso_cells
                            ),
                            e => e.to_string(),
                        };
                        self.out.stats.warnings.push(format!("{at}isosurface `{name}` not built: {e}"));
                        None
                    }
                };
                // Calls the function's recursion limits stopped count with the run's.
                let cut = stack.borrow().cut;
                self.expr_stack.cut.depth += cut.depth;
                self.expr_stack.cut.calls += cut.calls;
                self.iso_meshes.insert(iso, r);
                r
            }
        };
        let Some(mesh) = mesh else { return };
        self.extra_vertices += 1;
        self.out.instances.push(Instance { frame: s.f, color: s.color, mesh, bone, lin: s.lin, at: 0 });
        if s.lin != 0 {
            self.lins_used = true;
        }
    }
}
