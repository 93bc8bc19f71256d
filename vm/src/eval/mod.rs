//! The evaluator: runs a verified bundle depth-first with an explicit stack.
//!
//! Each activation holds the rule body's program counter, the frame items start from
//! (the body's frame, or the current iterator run's frame), its depth, and the
//! continuation register. The native stack is never used for recursion, so deep
//! grammars cannot overflow it. Limits (`maxdepth`, `minsize`, `stacksize`,
//! `maxiter`, a vertex budget and a time budget) end branches or the run cleanly,
//! keep everything produced so far, and are reported as warnings.
//!
//! Animation (thesis §4.4–4.5, SPEC §8): a call of a model rule with transform rules
//! (`rule A : X1 : X2`) makes a *bone*; every vertex emitted inside its derivation
//! carries the innermost bone's index. A transform rule's frames are sampled once by
//! evaluating it from the identity in transform mode (each `FRAME {adj}` records
//! the current frame composed with `adj`) and cached as a track in the output; an
//! infinite rule is cut at the frames the run needs and extended if a later use needs
//! more (each track has its own random stream, so a re-run repeats the same prefix).
//! A call of a convolution rule (`rule R * I : A : B`) runs R's body once per frame
//! index i of I under `R's frame · I[i]·A[i]·B[i]`. See [`crate::anim`] for sampling.
//!
//! Random numbers come from PCG-64 (`rand_pcg::Pcg64`) seeded with the seed, turned
//! into floats by this module (53 high bits for uniforms, Box–Muller for normals), so
//! a seed gives the same stream on every machine and rand version.
//!
//! The module is split by concern: `options` (what a caller sets, the default
//! limits), `state` (the state a frame carries and its algebra), `run` (the
//! interpreter loop, its ops and activation records), `sink` (what a kind of run
//! changes in that loop: sites, the fast path, the guided search's expansion), `select` (which definition a
//! call runs), `env` (expressions, random numbers, run-time transforms, non-finite
//! values), `draw` (geometry and prototype instances), `tracks` (bones, sampled
//! transform rules, convolutions), `budget` (limits and their counts), `sites`
//! (source positions of ops), `lean` (the fast path where only frames change),
//! `block` (identity blocks entered without an iterator's record)
//! and `guided` (one body's expansion for the guided search). This file holds the evaluation's state (`Eval`'s fields), its entry
//! points and the assembly of the output.
//!
//! An iterator's runs (`N * {T}`) are under `F·T`, `F·T·T`, …: that running frame
//! is composed in `f64` ([`Frame64`], see [`crate::geom::frame64`]) and stored in
//! the `f32` frame the body runs under, so its error does not grow with the count.
//! (A chained iterator, `N * {T} \ ITEM`, continues from each run's `f32` end
//! state, and a frame under a non-uniform scale composes in `f32`.)

use crate::anim::{frames_needed, MAX_TRACK_FRAMES};
use crate::bundle::ops::path_arity;
use crate::bundle::{
    self, Bundle, Composite, Drawable, ExprId, NsId, Op, OpCount, OpIndex, Profile, ProtoId, RuleId, Selector,
    Transform, TransformId, CONT_NEXT, NONE, SUBPATH,
};
use crate::expr::{self, ExprOp, Random};
use crate::geom::frame64::Frame64;
use crate::geom::quat::{Affine, Frame, PreparedFrame};
use crate::geom::Mesh;
use crate::geom::{blend, marching, sweep};
use crate::output::{Bone, Camera, Fixed, Instance, Output, Polyline, SharedKind, SharedMesh, Track};
use glam::{Mat3, Quat, Vec3, Vec4};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod block;
mod breadth;
mod budget;
mod draw;
mod env;
mod guided;
mod lean;
mod options;
mod path;
mod retire;
mod run;
mod seed;
mod select;
mod sink;
mod sites;
mod state;
mod tracks;

use block::*;
use breadth::*;
use budget::*;
use draw::*;
use env::*;
pub use guided::{Call, Expander, MAX_EXPANSION_CALLS};
use lean::*;
pub use options::*;
use path::*;
use retire::*;
use run::*;
use seed::*;
use select::*;
use sink::*;
use sites::*;
use state::*;
pub use state::{compose_prims, Lins, State};

/// What `run` collects: full geometry, only the points of a profile rule, or only
/// the frames of a transform rule.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Model,
    Profile,
    Transform,
}

struct Eval<'b> {
    b: &'b Bundle,
    opts: EvalOptions,
    rng: Pcg,
    out: Output,
    pens: Vec<Pen>,
    last: State,
    sequential: HashMap<u32, (usize, u32)>,
    profiles: HashMap<u32, Arc<[Vec3]>>,
    /// Profile rules cut at [`MAX_PROFILE_POINTS`] (or the vertex budget), for the
    /// warning.
    profiles_cut: Vec<(u32, usize)>,
    iso_meshes: HashMap<u32, Option<u32>>,
    /// What the output holds beyond the mesh and sweeps: the vertices of every shared
    /// (isosurface) mesh, one per instance (its transform) and every line point.
    /// Counted against `max_vertices` with the rest.
    extra_vertices: u64,
    /// Isosurface cells polygonised so far in this run (against `max_iso_cells`).
    iso_cells: u64,
    limits: LimitCounts,
    stopped: bool,
    started: Instant,
    calls: u64,
    /// The next count of `calls` at which a call or run is looked at more closely:
    /// the next multiple of 4,096 (the budgets' check) or one past `maxiter`,
    /// whichever comes first (see [`next_check`]).
    next_check: u64,
    maxiter: u64,
    stacksize: u32,
    expr_stack: expr::Machine,
    /// The value stack of rule parameters and locals (see [`Act::slot_base`]): grown
    /// once to the deepest derivation's need, never allocated per call.
    slots: Vec<f64>,
    profile_points: Vec<Vec3>,
    /// The flat path being built ([`path`]).
    path: PathState,
    progress: Option<&'b (dyn Fn(u64) + Sync)>,
    xf_info: Vec<Option<XfInfo>>,
    /// Per transform: a constant without a non-uniform scale (composing it has no
    /// effect but its result).
    xf_pure: Vec<bool>,
    /// Whether any op reads the continuation register (CONT, chained loops, RESET);
    /// if not, the VERTEX fast path need not compute the full frame for it.
    needs_last: bool,
    /// The bundle's prototypes, by `INST` ordinal.
    protos: Vec<ProtoSlot>,
    /// Vertex ranges of `out.mesh` that flat primitives' items emitted one by one
    /// (a prototype run not made an instance), marked matte at the end.
    matte_runs: Vec<std::ops::Range<usize>>,
    /// Whether `INST` makes instances (see [`EvalOptions::instancing`]).
    instancing: bool,
    /// Whether model runs take the fast path, the loop with the [`Simple`] sink
    /// (instancing on, no sites or derivation recorded, and [`fast_path_applies`]).
    fast: bool,
    /// Each constant transform's frame prepared for composing ([`PreparedFrame`]),
    /// where it has no non-uniform scale.
    prepared: Vec<Option<PreparedFrame>>,
    /// Whether fast-path runs take the [`Lean`] sink from a plain start
    /// ([`lean_path_applies`], [`plain_start`]).
    lean: bool,
    /// Per op: whether it is an identity block's `LOOP` (see [`identity_blocks`]).
    blocks: Vec<bool>,
    /// Under [`Lean`]: per op, for an `INST` whose items are followed only by calls
    /// and the body's `RET`, how many calls (else [`NONE`]; see [`leaf_calls`]).
    leaf_calls: Vec<u32>,
    /// Under [`Lean`]: per op after a `CALL`, the call's callee's body when the rule
    /// has one definition or its depth table, and whether it is a tail call (see
    /// [`lean_calls`]).
    lean_calls: LeanCalls,
    /// Under [`Lean`]: whether some `INST` is a call-less leaf (its [`leaf_calls`]
    /// are 0): then lean runs return from it without the dispatch (a run where none
    /// is does not test for it).
    lean_leaves: bool,
    /// Under [`Lean`]: whether the code has a `LOOP` (an iterator or an identity
    /// block): then lean runs take its runs themselves (a run where none is does
    /// not look for them).
    lean_loops: bool,
    /// Vertices of the prototype instances made so far (they count as vertices for
    /// the budget and the statistics, as they would have run one by one).
    instanced_vertices: u64,
    /// Prototype instances made so far (the vertex budget's count of them when
    /// [`EvalOptions::instances_stored`]).
    prototype_instances: u64,
    /// The vertices of every prototype, when they all have as many.
    proto_vertices: Option<u32>,
    /// While a lean run whose prototypes all have `proto_vertices` runs: its first
    /// instance. Its instances are counted (`instanced_vertices`,
    /// `prototype_instances`) when it is over, not one by one (see
    /// [`Eval::uncounted_instances`]).
    uncounted_from: Option<usize>,
    /// Whether an instance refers to a non-uniform factor (then `lins` goes into the
    /// output).
    lins_used: bool,
    /// Lane by lane, whether every prototype instance's frame so far passed the
    /// finiteness bound ([`frame_surely_maps_finite`]; the prototype's extent in the
    /// last lane of the translation's test): if one did not, the vertices are
    /// counted one by one at the end.
    instances_small: glam::BVec4A,
    /// The run's seed (transform rules derive their own streams from it).
    seed: u64,
    /// Transform rule → its track in `out.animation.tracks`.
    track_ids: HashMap<u32, u32>,
    /// Transform rules whose frames are being sampled (to break cycles).
    computing: Vec<u32>,
    /// Frames recorded by the transform rule being sampled.
    frame_sink: Vec<Frame>,
    /// How many frames that rule may record before its run is cut.
    frame_limit: usize,
    /// Set when the rule being sampled reached `frame_limit`: its run ends.
    halt: bool,
    /// Tracks cover `0 ≤ t ≤ horizon` seconds: `duration`, or `--time` beyond it.
    horizon: f64,
    /// The op that was running when a limit stopped the run (for the warning).
    stop_pc: Option<u32>,
    /// Convolution rule → the products `I[i]·A[i]·B[i]`.
    conv_cache: HashMap<u32, Arc<Vec<Frame>>>,
    /// The non-uniform factors of this evaluation's states.
    lins: Lins,
    weights: Weights,
    /// With `record_sites` or `record_derivation`: the op that ran last, its
    /// activation's depth and derivation node, the counts of mesh and sweep triangles
    /// and of instances when it began, and each op's index in `out.sites.sites`.
    site_pc: u32,
    site_depth: u32,
    site_node: u32,
    site_mark: usize,
    sweep_mark: usize,
    inst_mark: usize,
    site_ids: HashMap<u32, u32>,
    /// With `record_derivation`: the tree being recorded.
    tree: Option<TreeRec>,
    /// Rule definitions by first op (see [`def_starts`]), made on first use: naming
    /// the rule of an op is then a binary search, not a walk over every rule (40,000
    /// rules with a prototype each took seconds).
    def_starts: Option<Vec<(u32, u32)>>,
    /// Computed values that were not finite numbers, and the fallbacks used.
    non_finite: NonFinite,
    /// The open iterators' records of the last run, kept for the next one (a run
    /// takes them, so a nested run starts with none).
    spare_loops: Vec<LoopRec>,
    /// Rule-local retirement (`rule R maxdepth N > S`): the counts on the path.
    retire: Retirement,
}

/// Evaluates a verified bundle from its start shape.
pub fn evaluate(b: &Bundle, opts: &EvalOptions) -> Output {
    evaluate_with_progress(b, opts, None)
}

/// Like [`evaluate`], calling `progress(rule_calls)` now and then (for a progress bar).
pub fn evaluate_with_progress(b: &Bundle, opts: &EvalOptions, progress: Option<&(dyn Fn(u64) + Sync)>) -> Output {
    let mut e = Eval::new(b, opts, progress);
    let start = State::start_in(&b.settings);
    e.run(b.settings.startshape, start, Mode::Model);
    e.camera_and_finish()
}

/// Evaluates the given calls one after the other, each to the end of its derivation,
/// into one output (the geometry phase of guided search: the calls a skeleton left
/// for it, see [`Expander`]). Pens, the continuation register and the random stream
/// carry over from one call to the next, as if the calls were items of one body; the
/// limits, the camera rule and the warnings are those of [`evaluate`].
pub fn evaluate_calls(b: &Bundle, opts: &EvalOptions, calls: &[Call]) -> Output {
    let mut e = Eval::new(b, opts, None);
    for c in calls {
        if e.stopped {
            break;
        }
        e.run_from(c.rule, c.state, c.depth, Mode::Model);
    }
    e.camera_and_finish()
}

impl<'b> Eval<'b> {
    fn new(b: &'b Bundle, opts: &EvalOptions, progress: Option<&'b (dyn Fn(u64) + Sync)>) -> Eval<'b> {
        let s = &b.settings;
        let seed = opts.seed.unwrap_or(s.randseed);
        let start = State::start_in(s);
        // (`flat` keeps instancing: its picture paints the flat walk, prototype
        // instances expanded where they were made, in order; `Eval::paint_order`
        // expands them only where shapes at different z must be sorted. Recorded
        // sites keep it too: a prototype instance is credited to its `INST` op, as an
        // isosurface instance to its op, by instance runs.)
        let instancing = opts.instancing;
        let xf_pure: Vec<bool> =
            b.transforms.iter().map(|t| matches!(t, Transform::Const(c) if c.n.is_none())).collect();
        let fast = instancing && !opts.record_sites && !opts.record_derivation && fast_path_applies(b, &xf_pure);
        let weights = Weights::new(b);
        let lean = fast && lean_path_applies(b);
        let leaf_calls = if lean { leaf_calls(b) } else { Vec::new() };
        let lean_calls = if lean { lean_calls(b, &weights.by_depth) } else { LeanCalls::default() };
        let mut e = Eval {
            b,
            opts: opts.clone(),
            rng: Pcg(Pcg64::seed_from_u64(seed)),
            out: Output { background: s.background, flat: s.flat, ..Output::default() },
            pens: vec![Pen { state: start, lifted: false, line: None, bone: 0 }; s.namespaces.len()],
            last: start,
            sequential: HashMap::new(),
            profiles: HashMap::new(),
            profiles_cut: Vec::new(),
            iso_meshes: HashMap::new(),
            extra_vertices: 0,
            iso_cells: 0,
            limits: LimitCounts::default(),
            stopped: false,
            started: Instant::now(),
            calls: 0,
            next_check: 0,
            maxiter: opts.maxiter.unwrap_or(if s.maxiter > 0 { s.maxiter } else { DEFAULT_MAXITER }).min(opts.max_iter),
            stacksize: (if s.stacksize > 0 { s.stacksize } else { DEFAULT_STACKSIZE }).min(opts.max_stack),
            expr_stack: expr::Machine::new(opts.calls),
            slots: Vec::new(),
            profile_points: Vec::new(),
            path: PathState::default(),
            progress,
            seed,
            track_ids: HashMap::new(),
            computing: Vec::new(),
            frame_sink: Vec::new(),
            frame_limit: 0,
            halt: false,
            horizon: match opts.time {
                Some(t) if t.is_finite() && t > s.duration as f64 => t,
                _ => (s.duration as f64).max(0.0),
            },
            conv_cache: HashMap::new(),
            lins: Lins::default(),
            weights,
            site_pc: 0,
            site_depth: 0,
            site_node: 0,
            site_mark: 0,
            sweep_mark: 0,
            inst_mark: 0,
            site_ids: HashMap::new(),
            tree: opts.record_derivation.then(TreeRec::default),
            def_starts: None,
            non_finite: NonFinite::default(),
            spare_loops: Vec::new(),
            retire: Retirement::new(b),
            stop_pc: None,
            matte_runs: Vec::new(),
            protos: b
                .code
                .iter()
                .enumerate()
                .filter_map(|(pc, op)| match *op {
                    Op::Inst { count, .. } => Some(ProtoSlot {
                        first: pc as u32 + 1,
                        count: count.0,
                        mesh: NONE,
                        extent: 0.0,
                        matte: draw::in_std_flat(b, pc as u32 + 1),
                        vertices: b.code[pc + 1..]
                            .iter()
                            .take(count.index())
                            .filter(|op| matches!(op, Op::Draw { kind: Drawable::Vertex, .. }))
                            .count() as u32,
                    }),
                    _ => None,
                })
                .collect(),
            instancing,
            fast,
            lean,
            blocks: identity_blocks(b),
            lean_leaves: leaf_calls.contains(&0),
            lean_loops: b.code.iter().any(|op| matches!(op, Op::Loop { .. } | Op::LoopN { .. })),
            leaf_calls,
            lean_calls,
            prepared: b
                .transforms
                .iter()
                .map(|t| match t {
                    Transform::Const(c) if c.n.is_none() => Some(PreparedFrame::new(&composite_frame(c))),
                    _ => None,
                })
                .collect(),
            instanced_vertices: 0,
            prototype_instances: 0,
            proto_vertices: None,
            uncounted_from: None,
            lins_used: false,
            instances_small: glam::BVec4A::splat(true),
            needs_last: b.code.iter().any(|op| match op {
                Op::Loop { chain, .. } | Op::LoopN { chain, .. } => chain & bundle::ops::LOOP_CHAIN != 0,
                Op::Cont {} | Op::Draw { kind: Drawable::Reset, .. } => true,
                _ => false,
            }),
            xf_pure,
            xf_info: b
                .transforms
                .iter()
                .map(|t| match t {
                    // (Not for a non-uniform scale, whose normals need the inverse
                    // transpose, nor for HSB or a set colour, which are no deltas.)
                    Transform::Const(c) if c.n.is_none() && c.hsb.is_none() && c.set.is_none() => {
                        let frame = composite_frame(c);
                        let (lin, mirrored) = frame.linear();
                        Some(XfInfo { frame, normal: lin * Vec3::from_array(s.normal), mirrored })
                    }
                    Transform::Const(_) => None,
                    Transform::Dynamic { .. } => None,
                })
                .collect(),
        };
        e.out.animation.duration = s.duration;
        e.proto_vertices = match e.protos.split_first() {
            Some((p, rest)) if rest.iter().all(|q| q.vertices == p.vertices) => Some(p.vertices),
            _ => None,
        };
        e
    }

    /// Samples the camera rule (if any) and returns the output with its counters.
    fn camera_and_finish(mut self) -> Output {
        let s = &self.b.settings;
        if s.camerarule != NONE && !self.stopped {
            let fps = if s.fps.is_finite() && s.fps > 0.0 { s.fps } else { 0.0 };
            let track = self.track(s.camerarule, frames_needed(self.horizon, fps));
            self.out.animation.camera = Some(Camera { track, fps, fov: s.camerafov, near: s.near, far: s.far });
        }
        self.finish()
    }
}

/// The key `Eval::paint_order` sorts triangle `t` of `positions` by: the sum of its
/// vertices' z (three times its centroid's), 0 for a vertex out of range.
fn z_key(positions: &[[f32; 3]], t: &[u32; 3]) -> f32 {
    t.iter().map(|&i| positions.get(i as usize).map_or(0.0, |p| p[2])).sum::<f32>()
}

/// Whether the `VERTEX` group's flat walk (prototype instances expanded where they
/// were made) has its triangles in [`z_key`] order (a NaN key is out of order).
/// Mostly without expanding an instance: a prototype whose vertices all lie at
/// z = 0, placed by a frame whose x and y axes have no z part, puts every vertex at
/// the frame's z exactly (`u.z + lin * p` with `0 · x` and `0 · y`), so each of its
/// triangles has the key `u.z + u.z + u.z`; any other instance is expanded into a
/// scratch mesh for its keys.
fn flat_walk_in_z_order(out: &Output) -> bool {
    use crate::output::{expand_prototype, VertexRun};
    let in_plane: Vec<bool> = out
        .shared_meshes
        .iter()
        .map(|s| {
            s.is_prototype() && s.mesh.positions.iter().all(|p| p[2] == 0.0 && p[0].is_finite() && p[1].is_finite())
        })
        .collect();
    let mut last = f32::NEG_INFINITY;
    let mut next = |key: f32| {
        let ok = last <= key;
        last = key;
        ok
    };
    let mut scratch = Mesh::default();
    let frames = out.instances.packed_frames();
    let walk = out.for_each_vertex_run(&|_| true, |run| {
        let ok = match run {
            VertexRun::Piece(p) => {
                p.triangles.clone().all(|t| p.mesh.triangles.get(t).is_some_and(|t| next(z_key(&p.mesh.positions, t))))
            }
            VertexRun::Prototypes { instances, span, .. } => {
                let plane = in_plane.get(span.mesh as usize).copied().unwrap_or(false);
                let frames = frames.get(instances.clone()).unwrap_or(&[]);
                instances.zip(frames).all(|(i, f)| {
                    let inst = span.instance(f);
                    let (lin, _) = inst.frame.linear();
                    if plane && lin.x_axis.z == 0.0 && lin.y_axis.z == 0.0 {
                        let z = inst.frame.u.z;
                        return next([z, z, z].iter().sum::<f32>());
                    }
                    let Some(shared) = out.shared(&inst) else { return true };
                    scratch.clear();
                    expand_prototype(&mut scratch, shared, &inst, out.instance_weight(i));
                    scratch.triangles.iter().all(|t| next(z_key(&scratch.positions, t)))
                })
            }
        };
        if ok {
            Ok(())
        } else {
            Err(())
        }
    });
    walk.is_ok()
}

impl<'b> Eval<'b> {
    /// Under `flat`: the mesh's triangles stably sorted by the z of their centroids,
    /// so a picture painted in triangle order puts higher z on top and, at equal z,
    /// later derivations on top (Context Free's `z` and drawing order). Not when
    /// sites are recorded (they are per run of triangles): derivation order then,
    /// with a warning when a sort would have changed it.
    fn paint_order(&mut self) {
        if flat_walk_in_z_order(&self.out) {
            return;
        }
        if self.opts.record_sites {
            self.out.stats.warnings.push(
                "`flat`: shapes at different z are painted in derivation order while sites are recorded (a picture without --sites paints them by z)".into(),
            );
            return;
        }
        // Prototype instances (kept while the walk is in order: Context Free's art
        // without `z`, nearly all of it) are expanded in place, as the output
        // instancing off makes, and every triangle sorted.
        self.out.expand_prototypes();
        let m = &mut self.out.mesh;
        let keys: Vec<f32> = m.triangles.iter().map(|t| z_key(&m.positions, t)).collect();
        let mut order: Vec<usize> = (0..m.triangles.len()).collect();
        order.sort_by(|&a, &b| keys[a].total_cmp(&keys[b]));
        m.triangles = order.iter().map(|&i| m.triangles[i]).collect();
        if m.mirrored.len() == keys.len() {
            m.mirrored = order.iter().map(|&i| m.mirrored[i]).collect();
        }
    }

    fn finish(mut self) -> Output {
        for r in std::mem::take(&mut self.matte_runs) {
            self.out.mesh.mark_matte(r);
        }
        if self.b.settings.flat {
            self.paint_order();
        }
        let s = &self.b.settings;
        // Where the first refused call of each limit is (" in rule `R` (FILE:LINE)").
        let [depth_at, size_at, stack_at] =
            self.limits.first_refused.map(|pc| pc.map(|pc| where_op(self.b, pc)).unwrap_or_default());
        let w = &mut self.out.stats.warnings;
        // A grammar cannot switch its own protection off: its limits past the
        // caller's caps were lowered to them (in `Eval::new`).
        if self.opts.maxiter.is_none() && s.maxiter > self.opts.max_iter {
            w.push(format!(
                "the grammar's `maxiter {}` is above the cap of {} rule calls: capped at {} (a grammar cannot raise its limits past the command line's; raise the cap with `--max-iter N`)",
                s.maxiter, self.opts.max_iter, self.opts.max_iter
            ));
        }
        if s.stacksize > self.opts.max_stack {
            let more = if s.stacksize == u32::MAX { " or more" } else { "" };
            w.push(format!(
                "the grammar's `stacksize {}{more}` is above the cap of {} activations: capped at {} (a grammar cannot raise its limits past the command line's; raise the cap with `--max-stack N`)",
                s.stacksize, self.opts.max_stack, self.opts.max_stack
            ));
        }
        if self.limits.maxdepth > 0 {
            w.push(format!(
                "maxdepth {} reached{depth_at}: {} branch(es) ended there",
                s.maxdepth, self.limits.maxdepth
            ));
        }
        if self.retire.ended > 0 {
            let at = self.retire.first_ended.map(|pc| where_op(self.b, pc)).unwrap_or_default();
            w.push(format!(
                "rule-local maxdepth reached{at}: {} call(s) of a retired definition with no `> OTHER` rule ran nothing",
                self.retire.ended
            ));
        }
        if self.limits.minsize > 0 {
            w.push(format!("minsize {} reached{size_at}: {} branch(es) ended there", s.minsize, self.limits.minsize));
        }
        for &(rule, n) in &self.profiles_cut {
            let name = self.b.rules.get(rule as usize).map(|r| self.b.string(r.name)).unwrap_or("?");
            w.push(format!(
                "profile rule `{name}` makes more than {n} points: only the first {n} are used (a profile holds at most {MAX_PROFILE_POINTS} points, and half the vertex budget; raise the budget with `--max-vertices N`)"
            ));
        }
        if self.limits.stacksize > 0 {
            w.push(format!(
                "stack size {} reached{stack_at}: {} branch(es) ended there (raise the limit with `stacksize N` in the grammar, up to the cap set by `--max-stack N`)",
                self.stacksize, self.limits.stacksize
            ));
        }
        let at = self.stop_pc.map(|pc| where_op(self.b, pc)).unwrap_or_default();
        let w = &mut self.out.stats.warnings;
        if self.limits.maxiter {
            w.push(format!(
                "maxiter {} reached{at}: the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)",
                self.maxiter
            ));
        }
        if let Some(o) = self.limits.objects {
            w.push(format!(
                "maxobjects {} reached: {} objects drawn by the end of generation {}; the {} queued call(s) of generation {} and later were not run (raise the limit with `maxobjects N` in the grammar)",
                s.maxobjects, o.objects, o.generation - 1, o.left, o.generation
            ));
        }
        if self.limits.vertices {
            w.push(format!(
                "vertex budget {} reached{at}: the run stopped; the output so far is kept (raise the limit with `--max-vertices N`)",
                self.opts.max_vertices
            ));
        }
        if self.limits.time {
            w.push(format!(
                "time budget reached{at}: the run stopped; the output so far is kept (raise the limit with `--time-budget TIME`, e.g. `--time-budget 30s`)"
            ));
        }
        if self.limits.animation {
            let n = MAX_KEYFRAMES.min(self.opts.max_vertices);
            w.push(format!(
                "animation budget of {n} keyframes reached{at}: the run stopped; the output so far is kept (at most {MAX_KEYFRAMES}; a smaller `--max-vertices N` lowers it)"
            ));
        }
        if self.lins_used {
            // Isosurface instances under non-uniform scales refer to these.
            self.out.lins = std::mem::take(&mut self.lins.0).into_iter().map(|n| (n, n.determinant().cbrt())).collect();
        }
        let non_finite = self.non_finite.warnings(self.b);
        self.out.stats.warnings.extend(non_finite);
        let (cut, limits) = (self.expr_stack.cut, self.opts.calls);
        if cut.depth > 0 {
            self.out.stats.warnings.push(format!(
                "{} expression evaluation(s) stopped: recursive function calls nested deeper than {} (raise the limit with `--max-call-depth N`); their value is NaN",
                cut.depth, limits.depth
            ));
        }
        if cut.calls > 0 {
            self.out.stats.warnings.push(format!(
                "{} expression evaluation(s) stopped: more than {} function calls in one evaluation (raise the limit with `--max-calls N`); their value is NaN",
                cut.calls, limits.calls
            ));
        }
        let bad = self.out.non_finite_positions_checking(!self.instances_small.all());
        if bad > 0 {
            self.out.stats.warnings.push(format!(
                "{bad} position(s) are not finite numbers (a translation or scale overflowed): the files write them as 0"
            ));
        }
        let st = &mut self.out.stats;
        st.rule_calls = self.calls.min(self.maxiter);
        st.vertices = (self.out.mesh.n_vertices() + self.out.sweeps.n_vertices()) as u64 + self.instanced_vertices;
        st.triangles =
            (self.out.mesh.triangles.len() + self.out.sweeps.triangles.len()) as u64 + self.instanced_vertices / 3;
        st.elapsed_ms = self.started.elapsed().as_secs_f64() * 1000.0;
        if let Some(tree) = self.tree.take() {
            self.out.derivation = Some(tree.finish(self.b));
        }
        self.out
    }
}
