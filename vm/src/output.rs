//! What an evaluation produces: flat buffers, ready for the exporters.
//!
//! Geometry is kept in three groups so tools can tell them apart: triangles emitted by
//! `VERTEX` ([`Output::mesh`]), swept profiles from `LINETO`/`BLENDTO`/… ([`Output::sweeps`]),
//! and instances of shared meshes such as isosurfaces ([`Output::instances`]).
//! Animation ([`Output::animation`]) is kept beside the geometry: the bones with
//! the frame tracks of their transform rules, and the camera's track; vertices refer
//! to their bone by index ([`Mesh::bones`]). Sampling at a time is in [`crate::anim`].

use crate::geom::quat::{Affine, Frame};
use glam::{Mat3, Mat4, Vec3};
use serde::Serialize;
use std::ops::Range;

pub use crate::geom::Mesh;
pub use instances::{
    FieldReader, Fields, Fixed, Instance, InstanceIter, Instances, PackedFrame, Span, FRAME_WORDS, TRANSLATION_AT,
};

mod instances;

/// A pen line: the positions reached by MOVETO/LINETO/BLENDTO/SLINETO/ALINETO in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Polyline {
    pub namespace: String,
    pub points: Vec<[f32; 3]>,
    /// Bone per point (as [`Mesh::bones`]), or empty while all are 0.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub bones: Vec<u32>,
}

impl Polyline {
    /// Appends a point drawn in `bone`.
    pub fn push(&mut self, p: Vec3, bone: u32) {
        let i = self.points.len();
        self.points.push(p.to_array());
        if bone != 0 || !self.bones.is_empty() {
            self.bones.resize(i, 0);
            self.bones.push(bone);
        }
    }

    /// The bone of point `i` (0 when bones are not stored).
    pub fn bone(&self, i: usize) -> u32 {
        self.bones.get(i).copied().unwrap_or(0)
    }
}

/// What a shared mesh is, which decides how an instance of it is expanded.
#[derive(Clone, Debug, PartialEq)]
pub enum SharedKind {
    /// An isosurface (marching cubes in its own space): an instance is the mesh under
    /// its transform, painted in its colour, with zero weights.
    Isosurface,
    /// A prototype. Its mesh holds, per vertex, the position of the `VERTEX` item in
    /// the run's frame, the `normal` directive turned by the item's transform (not
    /// normalised), and the item's colour and weight *deltas*; triangle t is vertices
    /// 3t..3t+2, flagged mirrored when its third item's transform mirrors.
    /// `face_normals[t]` is the transform of the `FACENORMALS` item that last
    /// recomputed triangle t's normals, if one did.
    Prototype { face_normals: Vec<Option<Frame>> },
}

/// A mesh that instances place: an isosurface or a prototype.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedMesh {
    /// The drawable's name (`SPHERE`) or the prototype's rule (`ns.NAME`).
    pub name: String,
    pub mesh: Mesh,
    pub kind: SharedKind,
}

impl SharedMesh {
    /// An isosurface's mesh.
    pub fn isosurface(name: impl Into<String>, mesh: Mesh) -> SharedMesh {
        SharedMesh { name: name.into(), mesh, kind: SharedKind::Isosurface }
    }

    /// Whether this is a prototype.
    pub fn is_prototype(&self) -> bool {
        matches!(self.kind, SharedKind::Prototype { .. })
    }

    /// The normal of vertex `i` in the mesh's own space, as a renderer that places
    /// the mesh by a transform needs it: for a prototype, the face normal where a
    /// `FACENORMALS` recomputed it, else the item's normal, normalised.
    pub fn local_normal(&self, i: usize) -> Vec3 {
        let m = &self.mesh;
        let stored = Vec3::from(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]));
        let SharedKind::Prototype { face_normals } = &self.kind else { return stored };
        let t = i / 3;
        match face_normals.get(t).copied().flatten() {
            Some(f) if 3 * t + 2 < m.positions.len() => {
                let p = |k: usize| Vec3::from(m.positions[3 * t + k]);
                let n = (p(1) - p(0)).cross(p(2) - p(0)).normalize_or_zero();
                if f.mirrored() {
                    -n
                } else {
                    n
                }
            }
            _ => stored.normalize_or(Vec3::Z),
        }
    }
}

/// A run of flattened geometry handed to a visitor (see [`Output::for_each_piece`]):
/// vertices `vertices` of `mesh`, which become the flat vertices from `base` on, and
/// the triangles `triangles` of `mesh`, which refer to those vertices.
#[derive(Clone, Debug)]
pub struct Piece<'a> {
    pub mesh: &'a Mesh,
    pub vertices: Range<usize>,
    pub triangles: Range<usize>,
    pub base: u32,
}

impl Piece<'_> {
    /// Triangle `t` (an index into `mesh.triangles`) in flat vertex indices, with the
    /// winding reversed when it was emitted in a mirrored frame (what exporters
    /// write), or `None` if it refers outside the piece.
    pub fn oriented(&self, t: usize) -> Option<[u32; 3]> {
        let tri = *self.mesh.triangles.get(t)?;
        let mirrored = self.mesh.mirrored.get(t).copied().unwrap_or(false);
        let (lo, hi) = (self.vertices.start as u64, self.vertices.end as u64);
        let mut out = [0u32; 3];
        for (o, &v) in out.iter_mut().zip(&tri) {
            let v = v as u64;
            if v < lo || v >= hi {
                return None;
            }
            *o = (v - lo) as u32 + self.base;
        }
        Some(if mirrored { [out[0], out[2], out[1]] } else { out })
    }
}

/// A part of the `VERTEX` group's flat walk (see [`Output::for_each_vertex_part`]).
#[derive(Clone, Debug)]
pub enum VertexPart<'a> {
    /// A run of [`Output::mesh`].
    Piece(Piece<'a>),
    /// Prototype instance `instance` (an index into [`Output::instances`]; `inst`
    /// is the instance), whose expanded vertices become the flat vertices from `base`
    /// on.
    Prototype { instance: usize, base: u32, inst: Instance },
}

/// A part of the `VERTEX` group's flat walk by runs (see
/// [`Output::for_each_vertex_run`]).
#[derive(Clone, Debug)]
pub enum VertexRun<'a> {
    /// A run of [`Output::mesh`].
    Piece(Piece<'a>),
    /// Prototype instances `instances` (indices into [`Output::instances`], frames
    /// in [`Instances::packed_frames`]), all with `span`'s fields, whose expanded
    /// vertices follow one another from `base` on.
    Prototypes { instances: Range<usize>, base: u32, span: Span },
}

/// Which groups of geometry a flat walk visits, in this order: the `VERTEX`
/// triangles (with prototype instances expanded where they were made), the sweeps,
/// the isosurface instances.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Groups {
    pub vertex: bool,
    pub sweeps: bool,
    pub isosurfaces: bool,
}

impl Groups {
    /// Everything: what formats without instancing write.
    pub const ALL: Groups = Groups { vertex: true, sweeps: true, isosurfaces: true };
    /// The `VERTEX` triangles only (the JSON dump's, and what `Output::mesh` held
    /// before prototypes).
    pub const VERTEX: Groups = Groups { vertex: true, sweeps: false, isosurfaces: false };
}

/// Counters reported by `--stats` and stored in the JSON dump (all but the elapsed
/// time: a dump is byte-identical from run to run; timings go to `--stats`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub rule_calls: u64,
    pub vertices: u64,
    pub triangles: u64,
    pub max_depth: u32,
    /// Flat paths painted (`FILL`/`STROKE` of a non-empty path); left out of the
    /// dump when 0, so grammars without paths dump as before.
    #[serde(skip_serializing_if = "is_zero")]
    pub paths: u64,
    /// The triangles those paints drew (in `triangles` too); left out when 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub path_triangles: u64,
    /// Wall-clock time of the evaluation (`--stats` only; never in the dump).
    #[serde(skip)]
    pub elapsed_ms: f64,
    /// Limits that ended branches or the run, with a message each.
    pub warnings: Vec<String>,
}

/// The frames one transform rule emitted (thesis §4.4.1), in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// The transform rule's name.
    pub rule: String,
    /// Frame k is the frame of the k-th `FRAME {adj}` reached when the rule is
    /// evaluated from the identity: the current frame composed with `adj`.
    pub frames: Vec<Frame>,
    /// True when the rule ended by itself (a finite track: animation wraps around
    /// it); false when it was cut at the number of frames the run needed (an
    /// infinite rule, sampled lazily).
    pub complete: bool,
}

/// A bone: one call of a model rule with transform rules (`rule A : X1 : X2 {…}`).
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    /// The model rule's name (`""` for the root, bone 0).
    pub rule: String,
    /// The enclosing bone (0 = the root; the root is its own parent).
    pub parent: u32,
    /// A's frame at the call, in world space (the rest pose): A's own space.
    pub rest: Frame,
    /// Frames per second of the bone's transform rules (the `fps` directive plus the
    /// `fps` adjustments on the way to the call).
    pub fps: f32,
    /// The transform rules X1…Xn, as indices into [`Animation::tracks`].
    pub tracks: Vec<u32>,
}

/// The camera of a `camerarule`.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The camera rule's frames, as an index into [`Animation::tracks`].
    pub track: u32,
    /// Frames per second (the `fps` directive).
    pub fps: f32,
    /// `camerafov`: vertical field of view in degrees.
    pub fov: f32,
    /// `cameranearplane`.
    pub near: f32,
    /// `camerafarplane`.
    pub far: f32,
}

/// Bones, their tracks and the camera. Empty (the default) for a static model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// `duration` in seconds.
    pub duration: f32,
    /// Bone b is `bones[b]`; `bones[0]` is the root (unanimated). Empty when no
    /// bone was made: every vertex then belongs to the root.
    pub bones: Vec<Bone>,
    /// One track per transform rule used (bones and the camera share them).
    pub tracks: Vec<Track>,
    pub camera: Option<Camera>,
}

/// Which op of the grammar drew each triangle of [`Output::mesh`] and of
/// [`Output::sweeps`], and each instance of [`Output::instances`], recorded when
/// [`crate::eval::EvalOptions::record_sites`] is set: what an editor needs to go
/// from a click on the model to the source and back (`mdg-run --sites`), and to cut
/// the model at a derivation depth. Recording sites turns prototype instancing off
/// (their items are drawn one by one, as `VERTEX` triangles with sites of their own);
/// isosurface instances stay instances, with a site each.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sites {
    /// `[first triangle, site, depth, node]` over the `VERTEX` mesh's triangles, in
    /// triangle order: triangles from `first` up to the next run's first were drawn at
    /// `sites[site]`, by an activation at derivation depth `depth` (the start shape's
    /// body is depth 0), of node `node` of [`Output::derivation`] (0 without one).
    pub runs: Vec<[u32; 4]>,
    /// The same over the sweeps' triangles.
    pub sweep_runs: Vec<[u32; 4]>,
    /// The same over the instances (`first` is an index into [`Output::instances`]).
    pub instance_runs: Vec<[u32; 4]>,
    pub sites: Vec<Site>,
}

/// One drawing op of the grammar: its rule and source line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Site {
    /// The rule whose definition holds the op (`ns.NAME`), "" if the bundle has no
    /// such information.
    pub rule: String,
    /// The source file and 1-based line of the op, as the bundle records them
    /// ("" and 0 without a source map).
    pub file: String,
    pub line: u32,
}

impl Sites {
    /// The site of `VERTEX` triangle `t`.
    pub fn of(&self, t: u32) -> Option<&Site> {
        self.sites.get(run_of(&self.runs, t)?[1] as usize)
    }

    /// The run (`[first, site, depth, node]`) holding `VERTEX` triangle `t`.
    pub fn run_of_triangle(&self, t: u32) -> Option<[u32; 4]> {
        run_of(&self.runs, t)
    }

    /// The run holding sweep triangle `t`.
    pub fn run_of_sweep(&self, t: u32) -> Option<[u32; 4]> {
        run_of(&self.sweep_runs, t)
    }

    /// The run holding instance `i`.
    pub fn run_of_instance(&self, i: u32) -> Option<[u32; 4]> {
        run_of(&self.instance_runs, i)
    }
}

/// The run of `runs` (sorted by their first element) holding item `t`.
fn run_of(runs: &[[u32; 4]], t: u32) -> Option<[u32; 4]> {
    let i = runs.partition_point(|r| r[0] <= t).checked_sub(1)?;
    runs.get(i).copied()
}

/// The derivation in aggregate, recorded when
/// [`crate::eval::EvalOptions::record_derivation`] is set: a tree of rule calls,
/// one node per *path* of rules from the start shape (`tree → branch → leaf`), not
/// per call, with how often that path was called and how much geometry its calls
/// drew. A path deeper than [`crate::eval::DERIVATION_MAX_DEPTH`] calls, or past
/// [`crate::eval::DERIVATION_MAX_NODES`] nodes, gets no node of its own: its calls
/// and geometry are counted in the nearest node above it (`deeper`, and `cut`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Derivation {
    /// The rules of the nodes: name and first definition's file and line.
    pub rules: Vec<Site>,
    /// Parents before children; the roots (the start shape, or the calls a guided
    /// search evaluates) have no parent.
    pub nodes: Vec<DerivNode>,
    /// Whether some calls had no node of their own (see `deeper`).
    pub cut: bool,
    /// Triangles drawn in the whole run (instances counted by their meshes'
    /// triangles): the sum of the roots' `total`.
    pub triangles: u64,
}

/// One path of rule calls (see [`Derivation`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct DerivNode {
    /// Index into [`Derivation::rules`].
    pub rule: u32,
    /// Index of the calling path's node; `None` for a root.
    pub parent: Option<u32>,
    /// Derivation depth of the calls (the start shape's call is depth 0).
    pub depth: u32,
    /// Calls of this path.
    pub calls: u64,
    /// Calls below this path that have no node of their own (past the depth or node
    /// limit); their geometry is in `triangles`.
    pub deeper: u64,
    /// Triangles the calls' own ops drew (instances by their meshes' triangles).
    pub triangles: u64,
    /// Triangles drawn by this path and every path below it.
    pub total: u64,
}

/// Everything an evaluation produced.
#[derive(Clone, Debug, Default)]
pub struct Output {
    /// The `VERTEX` triangles the evaluator emitted vertex by vertex (runs of items
    /// that are prototypes are instances instead, see [`Output::instances`]; a flat
    /// walk, [`Output::for_each_piece`], puts them back in order).
    pub mesh: Mesh,
    pub sweeps: Mesh,
    pub lines: Vec<Polyline>,
    /// The meshes instances place: isosurfaces and prototypes.
    pub shared_meshes: Vec<SharedMesh>,
    /// Placements of shared meshes, in the order they were made (packed: read them
    /// through [`Instances`]' accessors).
    pub instances: Instances,
    /// Weight per instance (a prototype's vertices add their deltas to it), or empty
    /// while every weight is zero. Read with [`Output::instance_weight`].
    pub instance_weights: Vec<[f32; 4]>,
    /// Non-uniform factors of instance frames and `∛det` of each (index 0 is the
    /// identity and stands for none); see [`Instance::lin`].
    pub lins: Vec<(Mat3, f32)>,
    pub stats: Stats,
    /// `background r g b a`.
    pub background: [f32; 4],
    /// The grammar's `flat` directive: draw unlit, in triangle order, without a
    /// depth test (the mesh's triangles are in derivation order, stably sorted by z).
    pub flat: bool,
    /// Bones with their frame tracks, and the camera track.
    pub animation: Animation,
    /// What `DEBUG {}` items reported, in order (at most [`MAX_DEBUG_LINES`]; the
    /// caller prints them: the VM prints nothing).
    pub debug: Vec<String>,
    /// Which op drew each mesh triangle (empty unless asked for).
    pub sites: Sites,
    /// The tree of rule calls (only when asked for).
    pub derivation: Option<Derivation>,
}

/// How many `DEBUG {}` reports one run keeps (a loop over a DEBUG item would fill
/// memory otherwise); the last line says how many more there were.
pub const MAX_DEBUG_LINES: usize = 10_000;

impl Output {
    /// The shared mesh instance `inst` places.
    pub fn shared(&self, inst: &Instance) -> Option<&SharedMesh> {
        self.shared_meshes.get(inst.mesh as usize)
    }

    /// Whether `inst` places a prototype (its vertices belong to the `VERTEX` group).
    pub fn is_prototype_instance(&self, inst: &Instance) -> bool {
        self.shared(inst).is_some_and(SharedMesh::is_prototype)
    }

    /// The weight of instance `i` (zero when weights are not stored).
    pub fn instance_weight(&self, i: usize) -> [f32; 4] {
        self.instance_weights.get(i).copied().unwrap_or([0.0; 4])
    }

    /// The frame of `inst` with its non-uniform factor.
    pub fn instance_affine(&self, inst: &Instance) -> Affine {
        let n = if inst.lin == 0 { None } else { self.lins.get(inst.lin as usize).map(|l| l.0) };
        Affine { f: inst.frame, n }
    }

    /// Object-to-world transform of `inst` (rotation, scale, translation; may be
    /// mirrored, and with a non-uniform factor need not be a similarity).
    pub fn instance_transform(&self, inst: &Instance) -> Mat4 {
        self.instance_affine(inst).to_mat4()
    }

    /// `∛det` of the non-uniform factor of `inst` (1 without one).
    fn instance_ndet(&self, inst: &Instance) -> f32 {
        if inst.lin == 0 {
            1.0
        } else {
            self.lins.get(inst.lin as usize).map_or(1.0, |l| l.1)
        }
    }

    /// The linear scale of `inst`'s frame (SPEC resolved semantics 7; with `∛|det N|`
    /// under a non-uniform scale), as `minsize` reads it.
    pub fn instance_scale(&self, inst: &Instance) -> f32 {
        inst.frame.scale_factor() * self.instance_ndet(inst).abs()
    }

    /// Whether `inst`'s frame mirrors.
    pub fn instance_mirrored(&self, inst: &Instance) -> bool {
        inst.frame.mirrored() ^ (self.instance_ndet(inst) < 0.0)
    }

    /// Vertices and triangles of a flat walk over `groups`, without making it.
    pub fn flat_counts(&self, groups: Groups) -> (usize, usize) {
        self.flat_counts_where(groups, |_| true)
    }

    /// [`Output::flat_counts`] of [`Output::for_each_piece_where`].
    pub fn flat_counts_where(&self, groups: Groups, expand: impl Fn(usize) -> bool) -> (usize, usize) {
        let (mut v, mut t) = (0, 0);
        if groups.vertex {
            v += self.mesh.n_vertices();
            t += self.mesh.triangles.len();
        }
        if groups.sweeps {
            v += self.sweeps.n_vertices();
            t += self.sweeps.triangles.len();
        }
        // Per shared mesh, what one instance adds (0 for a group left out).
        let per: Vec<(usize, usize)> = self
            .shared_meshes
            .iter()
            .map(|s| match (s.is_prototype() && groups.vertex) || (!s.is_prototype() && groups.isosurfaces) {
                true => (s.mesh.n_vertices(), s.mesh.triangles.len()),
                false => (0, 0),
            })
            .collect();
        // (By spans of one mesh: a span of a mesh left out is passed over whole.)
        for span in self.instances.spans() {
            if let Some(&(dv, dt)) = per.get(span.mesh as usize).filter(|p| **p != (0, 0)) {
                let k = span.range.filter(|&i| expand(i)).count();
                v += k * dv;
                t += k * dt;
            }
        }
        (v, t)
    }

    /// Walks the geometry of `groups` as flat pieces, in the order formats without
    /// instancing write it: the `VERTEX` triangles with every prototype instance
    /// expanded where it was made (the same vertices, bit for bit, as the evaluator
    /// emits when it runs the items one by one), then the sweeps, then every
    /// isosurface instance expanded. Instances are expanded one at a time into a
    /// scratch mesh, so a walk holds no copy of the model.
    pub fn for_each_piece<E>(&self, groups: Groups, f: impl FnMut(&Piece) -> Result<(), E>) -> Result<(), E> {
        self.for_each_piece_where(groups, |_| true, f)
    }

    /// [`Output::for_each_piece`] over the instances `expand(i)` keeps (by index into
    /// [`Output::instances`]); the others are left out (an exporter that places them
    /// otherwise).
    pub fn for_each_piece_where<E>(
        &self,
        groups: Groups,
        expand: impl Fn(usize) -> bool,
        mut f: impl FnMut(&Piece) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut base = 0u32;
        let mut scratch = Mesh::default();
        let whole = |f: &mut dyn FnMut(&Piece) -> Result<(), E>, m: &Mesh, base: &mut u32| {
            let piece = Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: *base };
            *base += m.n_vertices() as u32;
            f(&piece)
        };
        if groups.vertex {
            self.for_each_vertex_part(&expand, |part| match part {
                VertexPart::Piece(p) => {
                    base = p.base + p.vertices.len() as u32;
                    f(&p)
                }
                VertexPart::Prototype { instance, base: b, inst } => {
                    let Some(shared) = self.shared(&inst) else { return Ok(()) };
                    scratch.clear();
                    expand_prototype(&mut scratch, shared, &inst, self.instance_weight(instance));
                    base = b;
                    whole(&mut f, &scratch, &mut base)
                }
            })?;
        }
        if groups.sweeps {
            whole(&mut f, &self.sweeps, &mut base)?;
        }
        if groups.isosurfaces {
            for (i, inst) in self.instances.iter().enumerate() {
                let Some(shared) = self.shared(&inst).filter(|s| !s.is_prototype() && expand(i)) else { continue };
                scratch.clear();
                expand_isosurface(&mut scratch, &shared.mesh, self, &inst);
                whole(&mut f, &scratch, &mut base)?;
            }
        }
        Ok(())
    }

    /// The `VERTEX` group of a flat walk ([`Output::for_each_piece_where`]) without
    /// expanding the prototype instances: runs of [`Output::mesh`] as pieces, and each
    /// prototype instance `expand` keeps as its index and the flat index of its first
    /// vertex (an exporter that writes instances its own way expands them itself, in
    /// the same order).
    pub fn for_each_vertex_part<'s, E>(
        &'s self,
        expand: &dyn Fn(usize) -> bool,
        mut f: impl FnMut(VertexPart<'s>) -> Result<(), E>,
    ) -> Result<(), E> {
        let frames = self.instances.packed_frames();
        self.for_each_vertex_run(expand, |run| match run {
            VertexRun::Piece(p) => f(VertexPart::Piece(p)),
            VertexRun::Prototypes { instances, mut base, span } => {
                let per = self.shared_meshes.get(span.mesh as usize).map_or(0, |s| s.mesh.n_vertices() as u32);
                for (i, frame) in instances.clone().zip(frames.get(instances).unwrap_or(&[])) {
                    f(VertexPart::Prototype { instance: i, base, inst: span.instance(frame) })?;
                    base += per;
                }
                Ok(())
            }
        })
    }

    /// [`Output::for_each_vertex_part`] with consecutive prototype instances that
    /// share every field but their frames (of one [`Span`]) handed over as one run:
    /// instance `instances.start + k` becomes the flat vertices from `base + k * n`
    /// on, n being its prototype's vertices. An exporter expands each run's
    /// instances in a loop over their packed frames, the prototype looked up once.
    pub fn for_each_vertex_run<'s, E>(
        &'s self,
        expand: &dyn Fn(usize) -> bool,
        mut f: impl FnMut(VertexRun<'s>) -> Result<(), E>,
    ) -> Result<(), E> {
        let m = &self.mesh;
        // Mesh vertices [done, at) go before an instance made at `at`; a triangle
        // belongs to the run that holds its last vertex.
        let (mut done, mut tri, mut base) = (0usize, 0usize, 0u32);
        let run = |f: &mut dyn FnMut(VertexRun<'s>) -> Result<(), E>,
                   to: usize,
                   done: &mut usize,
                   tri: &mut usize,
                   base: &mut u32| {
            let end_tri = if to >= m.n_vertices() {
                m.triangles.len()
            } else {
                *tri + m.triangles[*tri..].partition_point(|t| t.iter().all(|&v| (v as usize) < to))
            };
            let piece = Piece { mesh: m, vertices: *done..to, triangles: *tri..end_tri, base: *base };
            *base += (to - *done) as u32;
            *done = to;
            *tri = end_tri;
            f(VertexRun::Piece(piece))
        };
        for span in self.instances.spans() {
            let Some(shared) = self.shared_meshes.get(span.mesh as usize).filter(|s| s.is_prototype()) else {
                continue;
            };
            let per = shared.mesh.n_vertices() as u32;
            // (Every instance of the span is made at the same `at`: the mesh's run
            // before it comes before the first one expanded.)
            let mut i = span.range.start;
            while i < span.range.end {
                if !expand(i) {
                    i += 1;
                    continue;
                }
                let first = i;
                while i < span.range.end && expand(i) {
                    i += 1;
                }
                let at = (span.at as usize).clamp(done, m.n_vertices());
                if at > done {
                    run(&mut f, at, &mut done, &mut tri, &mut base)?;
                }
                f(VertexRun::Prototypes { instances: first..i, base, span: span.clone() })?;
                base += per * (i - first) as u32;
            }
        }
        if done < m.n_vertices() || tri < m.triangles.len() {
            run(&mut f, m.n_vertices(), &mut done, &mut tri, &mut base)?;
        }
        Ok(())
    }

    /// The geometry of `groups` as one mesh in world space.
    pub fn flat_mesh(&self, groups: Groups) -> Mesh {
        let mut m = Mesh::default();
        let (v, t) = self.flat_counts(groups);
        m.reserve(v, t);
        let _ = self.for_each_piece::<()>(groups, |p| {
            m.append_range(p.mesh, p.vertices.clone(), p.triangles.clone());
            Ok(())
        });
        m
    }

    /// All geometry as one mesh in world space: VERTEX triangles, sweeps and every
    /// instance expanded (formats without instancing write this, streamed through
    /// [`Output::for_each_piece`]).
    pub fn flattened(&self) -> Mesh {
        self.flat_mesh(Groups::ALL)
    }

    /// The `VERTEX` triangles with prototype instances expanded in place: what the
    /// evaluator emits when it runs every item one by one.
    pub fn vertex_mesh(&self) -> Mesh {
        self.flat_mesh(Groups::VERTEX)
    }

    /// Expands every prototype instance into [`Output::mesh`], where it was made, and
    /// drops them: the output the evaluator makes with instancing off.
    pub fn expand_prototypes(&mut self) {
        if !self.instances.iter().any(|i| self.is_prototype_instance(&i)) {
            return;
        }
        self.mesh = self.vertex_mesh();
        let shared = &self.shared_meshes;
        let keep = |i: &Instance| shared.get(i.mesh as usize).is_some_and(|s| !s.is_prototype());
        self.instances.retain(keep);
        // Only prototypes read instance weights.
        self.instance_weights.clear();
    }

    /// How many positions of the geometry are not finite (vertices, line points,
    /// instance transforms; a prototype instance counts the vertices it expands to):
    /// exporters write them as 0, so the run warns.
    pub fn non_finite_positions(&self) -> usize {
        self.non_finite_positions_checking(true)
    }

    /// [`Output::non_finite_positions`], leaving out the prototype instances unless
    /// `prototypes` (the evaluator checks each frame by the bound as it makes the
    /// instance, and asks for them only if one failed it).
    pub fn non_finite_positions_checking(&self, prototypes: bool) -> usize {
        let bad = |p: &[f32; 3]| !p.iter().all(|c| c.is_finite());
        // Nearly always all finite: a branch-free pass (it vectorises) decides that.
        let all_finite = |ps: &[[f32; 3]]| ps.as_flattened().iter().fold(true, |ok, c| ok & c.is_finite());
        let mesh = |m: &Mesh| if all_finite(&m.positions) { 0 } else { m.positions.iter().filter(|p| bad(p)).count() };
        // Prototype instances: by a bound first (a finite frame of moderate size over a
        // mesh of moderate extent), expanded only where it does not hold. Per shared
        // mesh: a prototype's extent (`None`: not checked here), or an isosurface.
        enum Check {
            Prototype(Option<f32>),
            Isosurface,
        }
        let checks: Vec<Check> = self
            .shared_meshes
            .iter()
            .map(|s| match s.is_prototype() {
                true => Check::Prototype(prototypes.then(|| max_abs(&s.mesh.positions))),
                false => Check::Isosurface,
            })
            .collect();
        let mut scratch = Mesh::default();
        let mut instances = 0;
        // (Skipped when there is nothing to check: the instances of a big model are
        // most of its memory.)
        let walk = checks.iter().any(|c| !matches!(c, Check::Prototype(None)));
        let all = if walk { self.instances.iter() } else { self.instances.range(0..0) };
        for (i, inst) in all.enumerate() {
            match checks.get(inst.mesh as usize) {
                Some(Check::Prototype(Some(extent))) if !frame_surely_maps_finite(&inst.frame, *extent) => {
                    let Some(s) = self.shared(&inst) else { continue };
                    scratch.clear();
                    expand_prototype(&mut scratch, s, &inst, self.instance_weight(i));
                    instances += scratch.positions.iter().filter(|p| bad(p)).count();
                }
                Some(Check::Isosurface) => instances += usize::from(!self.instance_transform(&inst).is_finite()),
                _ => {}
            }
        }
        mesh(&self.mesh)
            + mesh(&self.sweeps)
            + self.shared_meshes.iter().filter(|s| !s.is_prototype()).map(|s| mesh(&s.mesh)).sum::<usize>()
            + self.lines.iter().map(|l| l.points.iter().filter(|p| bad(p)).count()).sum::<usize>()
            + instances
    }
}

/// The largest absolute coordinate of `positions` (infinite if one is not finite).
pub fn max_abs(positions: &[[f32; 3]]) -> f32 {
    positions.as_flattened().iter().fold(0.0f32, |m, c| if c.is_finite() { m.max(c.abs()) } else { f32::INFINITY })
}

/// Whether `f` surely maps every point within `extent` of the origin (per
/// coordinate) to finite coordinates: every component of q and q̂ is below 1e7 in
/// size (so its scale |q| |q̂| is below 4e14), of its translation and `extent`
/// below 1e15, so a mapped point is under 1e15 + 3 · 4e14 · 1e15 ≪ f32::MAX. NaN
/// fails the comparisons, so non-finite numbers fail too.
#[inline]
pub fn frame_surely_maps_finite(f: &Frame, extent: f32) -> bool {
    let small = |v: glam::Vec4, limit: f32| v.abs().cmplt(glam::Vec4::splat(limit)).all();
    small(glam::Vec4::from(f.q), 1e7)
        && small(glam::Vec4::from(f.qh), 1e7)
        && small(f.u.extend(0.0), 1e15)
        && extent < 1e15
}

/// Appends prototype instance `inst` (weight `weight`) to `m` in world space: the
/// vertices the evaluator would have emitted for the prototype's items, computed by
/// the same expressions in the same order (`eval/run.rs`, the `VERTEX` fast path and
/// `FACENORMALS`), so the bits are the same.
pub fn expand_prototype(m: &mut Mesh, shared: &SharedMesh, inst: &Instance, weight: [f32; 4]) {
    let p = &shared.mesh;
    let (lin, mirrored) = inst.frame.linear();
    let add = |a: [f32; 4], b: [f32; 4]| [a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]];
    let first = m.n_vertices();
    for i in 0..p.n_vertices() {
        let pos = inst.frame.u + lin * Vec3::from(p.positions[i]);
        let normal = (lin * Vec3::from(p.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]))).normalize_or(Vec3::Z);
        let color = add(inst.color, p.colors.get(i).copied().unwrap_or([0.0; 4])).map(|v| v.clamp(0.0, 1.0));
        let k = m.push_vertex(pos, normal, color, add(weight, p.weight(i)), inst.bone) as usize;
        if p.matte(i) {
            m.mark_matte(k..k + 1);
        }
    }
    let face_normals = match &shared.kind {
        SharedKind::Prototype { face_normals } => face_normals.as_slice(),
        SharedKind::Isosurface => &[],
    };
    for (t, tri) in p.triangles.iter().enumerate() {
        let k = first as u32;
        m.push_triangle([tri[0] + k, tri[1] + k, tri[2] + k], mirrored != p.mirrored.get(t).copied().unwrap_or(false));
        if let Some(Some(f)) = face_normals.get(t) {
            // FACENORMALS: the flat normal of the last three vertices, in the item's frame.
            let at = first + tri[2] as usize;
            if at >= 2 && at < m.n_vertices() {
                let q = |i: usize| Vec3::from_array(m.positions[i]);
                let (a, b, c) = (q(at - 2), q(at - 1), q(at));
                let mut n = (b - a).cross(c - a).normalize_or_zero();
                if inst.frame.compose(f).mirrored() {
                    n = -n;
                }
                for i in at - 2..=at {
                    m.normals[i] = n.to_array();
                }
            }
        }
    }
}

/// Appends isosurface instance `inst` of `shared` to `m` in world space: positions
/// through the transform, normals through its inverse transpose, the instance's
/// colour, zero weights.
pub fn expand_isosurface(m: &mut Mesh, shared: &Mesh, out: &Output, inst: &Instance) {
    let color = inst.color.map(|c| c.clamp(0.0, 1.0));
    let mirrored = out.instance_mirrored(inst);
    place_mesh(m, shared, &out.instance_transform(inst), Some(color), mirrored, inst.bone);
}

/// Appends `shared` placed by `transform` to `m`: positions through it, normals
/// through its inverse transpose (normalised), every vertex of colour `color` (or
/// the mesh's own colours when `None`) with zero weights and bone `bone`; triangles
/// keep their mirrored flags, flipped when `mirrored` (the transform mirrors).
pub fn place_mesh(m: &mut Mesh, shared: &Mesh, transform: &Mat4, color: Option<[f32; 4]>, mirrored: bool, bone: u32) {
    let base = m.positions.len() as u32;
    let normal_mat = transform.inverse().transpose();
    for (i, p) in shared.positions.iter().enumerate() {
        let wp = transform.transform_point3(Vec3::from(*p));
        let n = shared.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]);
        let wn = normal_mat.transform_vector3(Vec3::from(n)).normalize_or_zero();
        let c = color.unwrap_or_else(|| shared.colors.get(i).copied().unwrap_or([1.0; 4]));
        m.push_vertex(wp, wn, c, [0.0; 4], bone);
    }
    for (t, mir) in shared.triangles.iter().zip(shared.mirrored.iter().chain(std::iter::repeat(&false))) {
        m.push_triangle([t[0] + base, t[1] + base, t[2] + base], *mir != mirrored);
    }
}

/// (For `skip_serializing_if`.)
fn is_zero(n: &u64) -> bool {
    *n == 0
}
