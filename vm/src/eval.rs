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

use crate::anim::{frames_needed, MAX_TRACK_FRAMES};
use crate::bundle::{self, Bundle, Composite, Drawable, Op, Selector, Transform, CONT_NEXT, NONE};
use crate::expr::{self, ExprOp, Random};
use crate::geom::quat::{Affine, Frame};
use crate::geom::Mesh;
use crate::geom::{blend, marching, sweep};
use crate::output::{
    frame_surely_maps_finite, Bone, Camera, Instance, Output, Polyline, SharedKind, SharedMesh, Track,
};
use glam::{Mat3, Quat, Vec3, Vec4};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashMap;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Default limits, used when the grammar or the caller sets none (docs/limits.md).
/// They end a runaway grammar within seconds and 1 GB: 10,000,000 rule calls is 5
/// times the largest benchmark (the 2^20 tree) and 50 times the largest std example.
pub const DEFAULT_MAXITER: u64 = 10_000_000;
/// Default maximum stack depth (activations).
pub const DEFAULT_STACKSIZE: u32 = 100_000;
/// The cap on `maxiter` that a grammar cannot raise (`--max-iter`,
/// [`EvalOptions::max_iter`]): 10 times the default. 100,000,000 calls that draw
/// nothing take about 6 s of CPU; a call holds no memory.
pub const DEFAULT_MAX_ITER: u64 = 100_000_000;
/// The cap on `stacksize` that a grammar cannot raise (`--max-stack`,
/// [`EvalOptions::max_stack`]): 10 times the default. An activation takes about 110
/// bytes, so the stack stays under ~110 MB.
pub const DEFAULT_MAX_STACK: u32 = 1_000_000;
/// Default vertex budget (VERTEX and sweep vertices together): a run of 4,000,000
/// vertices peaks at about 360 MB with its `.glb` export (10 times the largest std
/// example); the 6- and 10-million-vertex benchmarks ask for more with
/// `--max-vertices` (the 10M sweep peaks at 1.13 GB).
pub const DEFAULT_MAX_VERTICES: u64 = 4_000_000;
/// Default frame budget of a convolution's iterator rule (see [`EvalOptions::max_frames`]).
pub const DEFAULT_MAX_FRAMES: u64 = 10_000_000;
/// Default largest isosurface grid, in cells.
pub const DEFAULT_MAX_ISO_CELLS: u64 = 16_000_000;
/// The most keyframes all bones together may have (each bone has one per frame of its
/// track at its fps): the output and a glTF file hold them all, so they are a memory
/// budget like the vertex budget (and never more than it: a smaller vertex budget
/// lowers this one too). Reaching it stops the run with a warning.
pub const MAX_KEYFRAMES: u64 = 10_000_000;
/// The colour state at the start of a run (R, G, B, A): white, opaque. Colour
/// adjustments add to it (`{G -1 B -1}` gives red); see docs/reference.md.
pub const START_COLOR: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
/// How deeply transform rules may need each other's frames while being sampled
/// (each level is a nested evaluation on the native stack).
pub const MAX_TRACK_NESTING: usize = 64;
/// Segments per BLENDTO.
pub const BLEND_SEGMENTS: usize = 8;
/// The most points one profile rule contributes (a profile is one ring of a tube:
/// real ones have tens of points). The rule's run stops there with a warning.
pub const MAX_PROFILE_POINTS: usize = 65_536;

/// Options of one evaluation.
#[derive(Clone, Debug)]
pub struct EvalOptions {
    /// Overrides the grammar's `randseed`.
    pub seed: Option<u64>,
    pub max_vertices: u64,
    pub time_budget: Option<Duration>,
    pub max_iso_cells: u64,
    /// Overrides `maxiter` (total rule calls).
    pub maxiter: Option<u64>,
    /// The most rule calls whatever the grammar (or `maxiter` above) asks for: the
    /// user's cap (`--max-iter`). A grammar's `maxiter` past it is lowered to it with
    /// a warning.
    pub max_iter: u64,
    /// The deepest stack whatever the grammar's `stacksize` asks for (`--max-stack`);
    /// likewise lowered with a warning.
    pub max_stack: u32,
    /// The frame budget: the most frames a convolution's iterator rule (and the
    /// transform rules sampled with it) may contribute before it is cut with a warning.
    pub max_frames: u64,
    /// Sample transform rules far enough to pose the model at this time too (in
    /// seconds; `mdg-run --time`), when it is beyond `duration`.
    pub time: Option<f64>,
    /// Record which op drew each mesh triangle ([`crate::output::Sites`]). Sites are
    /// per triangle, so this also turns instancing off.
    pub record_sites: bool,
    /// Emit one instance record per run of prototype items (`INST`) instead of their
    /// vertices (the default). Off, every item runs one by one: the output then has
    /// the same geometry with every prototype instance expanded in place (tests
    /// compare the two).
    pub instancing: bool,
    /// The output keeps prototype instances as instances (a `.glb` written with
    /// `--instances`): each costs the vertex budget one (its record, as an
    /// isosurface instance does) instead of its expanded vertices. The counters
    /// (`Stats::vertices`) still count the vertices the instances stand for.
    pub instances_stored: bool,
}

impl Default for EvalOptions {
    fn default() -> Self {
        EvalOptions {
            seed: None,
            max_vertices: DEFAULT_MAX_VERTICES,
            time_budget: None,
            max_iso_cells: DEFAULT_MAX_ISO_CELLS,
            maxiter: None,
            max_iter: DEFAULT_MAX_ITER,
            max_stack: DEFAULT_MAX_STACK,
            max_frames: DEFAULT_MAX_FRAMES,
            time: None,
            record_sites: false,
            instancing: true,
            instances_stored: false,
        }
    }
}

/// The state a frame carries: transform, colour, weight, fps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    pub f: Frame,
    pub color: [f32; 4],
    pub weight: [f32; 4],
    pub fps: f32,
    /// The frame's non-uniform factor N (`geom::quat::Affine`): an index into the
    /// evaluation's [`Lins`], 0 for none (every frame that has met no `s X Y Z`).
    pub lin: u32,
    /// `∛det N` (1 without one): the factor's share of the scale, and its sign the
    /// factor's mirroring, readable without the table.
    pub ndet: f32,
}

impl State {
    /// The state at the start of a run: identity frame, white, no weights.
    pub fn start(fps: f32) -> State {
        State { f: Frame::identity(), color: START_COLOR, weight: [0.0; 4], fps, lin: 0, ndet: 1.0 }
    }

    /// `self ∘ c`. The non-uniform factors of a frame live in `lins`, which gains an
    /// entry only when `c` itself holds a non-uniform scale.
    #[inline(always)]
    fn compose(&self, c: &Composite, lins: &mut Lins) -> State {
        let mut color = add(self.color, c.color);
        if let Some(h) = &c.hsb {
            color = apply_hsb(color, h);
        }
        let (f, lin, ndet) = if self.lin == 0 && c.n.is_none() {
            (self.f.compose(&composite_frame(c)), 0, 1.0)
        } else {
            self.compose_general(c, lins)
        };
        State { f, color, weight: add(self.weight, c.weight), fps: self.fps + c.fps, lin, ndet }
    }

    /// The frame part of [`State::compose`] when a non-uniform factor is involved.
    #[cold]
    #[inline(never)]
    fn compose_general(&self, c: &Composite, lins: &mut Lins) -> (Frame, u32, f32) {
        let child = Affine { f: composite_frame(c), n: c.n.map(|n| Mat3::from_cols_array(&n)) };
        let a = lins.affine(self).compose(&child);
        // N changes only when `c` brings a non-uniform scale of its own.
        match (c.n, a.n) {
            (Some(_), Some(n)) => {
                let (lin, ndet) = lins.put(n);
                (a.f, lin, ndet)
            }
            _ => (a.f, self.lin, self.ndet),
        }
    }

    /// `self ∘ f` for a plain frame (a convolution's or a sampled track's).
    fn then(&self, f: &Frame, lins: &Lins) -> State {
        if self.lin == 0 {
            State { f: self.f.compose(f), ..*self }
        } else {
            State { f: lins.affine(self).compose(&Affine::from(*f)).f, ..*self }
        }
    }

    /// The linear scale (SPEC resolved semantics 7; with `∛|det N|` under a
    /// non-uniform scale): what `minsize`, `scale` selection and `scale` read.
    #[inline]
    pub fn scale(&self) -> f32 {
        self.f.scale_factor() * self.ndet.abs()
    }

    /// Whether the frame mirrors.
    pub fn mirrored(&self) -> bool {
        self.f.mirrored() ^ (self.ndet < 0.0)
    }

    /// The colour as shown: every component clamped to 0..1.
    fn display_color(&self) -> [f32; 4] {
        self.color.map(|c| c.clamp(0.0, 1.0))
    }
}

/// The non-uniform factors N of one evaluation's frames, shared by the states that
/// carry the same one (index 0 is none). Entries are only added, by a composition
/// with a non-uniform scale.
#[derive(Debug)]
pub struct Lins(Vec<Mat3>);

impl Default for Lins {
    fn default() -> Self {
        Lins(vec![Mat3::IDENTITY])
    }
}

impl Lins {
    /// `s`'s frame with its factor.
    #[inline]
    fn affine(&self, s: &State) -> Affine {
        let n = if s.lin == 0 { None } else { self.0.get(s.lin as usize).copied() };
        Affine { f: s.f, n }
    }

    /// Stores `n`: its index and `∛det n`.
    fn put(&mut self, n: Mat3) -> (u32, f32) {
        self.0.push(n);
        ((self.0.len() - 1) as u32, n.determinant().cbrt())
    }
}

/// A rule call waiting to run: guided search keeps these instead of recursing
/// (see [`Expander`] and [`evaluate_calls`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Call {
    pub rule: u32,
    /// The state the rule's body runs in (the caller's state composed with the call's
    /// adjustments).
    pub state: State,
    /// The start shape is at depth 0; every call adds 1.
    pub depth: u32,
}

impl Call {
    /// The start shape's call: the identity frame, the start colour, depth 0.
    pub fn start(b: &Bundle) -> Call {
        Call { rule: b.settings.startshape, state: State::start(b.settings.fps), depth: 0 }
    }
}

/// The most calls and iterator runs one [`Expander::expand`] performs; a body that
/// makes more is cut there (so a huge iterator in a skeleton rule cannot stall a search).
pub const MAX_EXPANSION_CALLS: usize = 1 << 16;

/// Runs one rule call's body *without* descending into the calls it makes: each call
/// is returned (rule, state, depth) instead (guided search's skeleton phase, SPEC §11).
///
/// The body runs as in [`evaluate`]: the definition its selector picks, iterators,
/// continuations, `rand`/`randn` in adjustments (drawn from this expander's stream),
/// and the `maxdepth` and `minsize` limits, which drop the calls beyond them. What is
/// not evaluated is the callees, so a continuation `A \ B` where `A` is a call starts
/// `B` from `A`'s own frame (the frame of a drawable inside `A` is not known yet).
/// Drawables and isosurfaces are skipped: skeleton rules may not draw (the compiler
/// and the bundle verifier reject those that do). `sequential` and `pattern`
/// selectors start afresh with every expansion.
pub struct Expander<'b> {
    b: &'b Bundle,
    rng: Pcg,
    expr_stack: Vec<f64>,
    sequential: HashMap<u32, (usize, u32)>,
    loops: Vec<LoopRec>,
    /// The expanded body's frame (its parameters take their defaults: the compiler
    /// rejects skeleton rules with parameters and calls from them that pass arguments).
    slots: Vec<f64>,
    /// (The compiler rejects non-uniform scales in skeleton rules, so the states an
    /// expansion returns carry none; this only keeps a hand-made bundle harmless.)
    lins: Lins,
    weights: Weights,
    /// Computed values that were not finite numbers, and the fallbacks used.
    non_finite: NonFinite,
}

impl<'b> Expander<'b> {
    /// An expander over `b`, with the stream of [`Expander::reseed`]`(0, 0)`.
    pub fn new(b: &'b Bundle) -> Expander<'b> {
        let mut e = Expander {
            b,
            rng: Pcg(Pcg64::new(0, 0)),
            expr_stack: Vec::with_capacity(16),
            sequential: HashMap::new(),
            loops: Vec::new(),
            slots: Vec::new(),
            lins: Lins::default(),
            weights: Weights::new(b),
            non_finite: NonFinite::default(),
        };
        e.reseed(0, 0);
        e
    }

    /// The fallbacks the expansions so far used for computed values that were NaN or
    /// infinite (adjustment arguments, weights, selector values, counts), as
    /// warnings naming the rule and line; empty if none.
    pub fn warnings(&self) -> Vec<String> {
        self.non_finite.warnings(self.b)
    }

    /// Restarts the random stream: PCG-64 stream `stream` at a state derived from
    /// `seed`. Distinct (seed, stream) pairs give independent streams, so work split by
    /// (seed, stream) gives the same numbers in any order or on any thread.
    pub fn reseed(&mut self, seed: u64, stream: u64) {
        let mix = |mut z: u64| {
            // SplitMix64 finaliser: spreads nearby seeds over the whole state space.
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let hi = mix(seed ^ 0x6A09_E667_F3BC_C908);
        let lo = mix(seed.wrapping_add(0x9E37_79B9_7F4A_7C15));
        let state = ((hi as u128) << 64) | lo as u128;
        let s = mix(stream ^ 0xBB67_AE85_84CA_A73B);
        let inc = ((s as u128) << 64) | mix(stream.wrapping_add(0x3C6E_F372_FE94_F82B)) as u128;
        self.rng = Pcg(Pcg64::new(state, inc));
    }

    /// A uniform number in [0, 1) from the stream (53 random bits).
    pub fn uniform(&mut self) -> f64 {
        self.rng.uniform()
    }

    /// A uniform index in `0..n` (`n` > 0; 0 when `n` is 0).
    pub fn index(&mut self, n: usize) -> usize {
        ((self.rng.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// Runs the body of `call` and appends the calls it makes to `out`, in the order
    /// the body makes them. Returns `false` when the body was cut at
    /// [`MAX_EXPANSION_CALLS`] calls and iterator runs.
    pub fn expand(&mut self, call: &Call, out: &mut Vec<Call>) -> bool {
        let b = self.b;
        let code = &b.code;
        let s = &b.settings;
        let r = &b.rules[call.rule as usize];
        self.slots.clear();
        self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
        self.slots.resize(r.frame as usize, 0.0);
        let mut pc = select_def(
            b,
            call.rule,
            &call.state,
            call.depth,
            &self.slots,
            &mut self.rng,
            &mut self.sequential,
            &mut self.expr_stack,
            &mut self.weights,
            &mut self.non_finite,
        ) as usize;
        self.sequential.clear();
        self.loops.clear();
        let depth = call.depth.saturating_add(1);
        let mut base = call.state;
        let mut cont: Option<State> = None;
        let mut last = call.state;
        let mut made = 0usize;
        while let Some(&op) = code.get(pc) {
            match op {
                Op::Call { rule, xf, flags } => {
                    pc += 1;
                    let from = cont.take().unwrap_or(base);
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                    let child = from.compose(&c, &mut self.lins);
                    if flags & CONT_NEXT != 0 {
                        last = child;
                    }
                    if s.maxdepth > 0 && depth > s.maxdepth {
                        continue;
                    }
                    if s.minsize > 0.0 && child.scale() < s.minsize {
                        continue;
                    }
                    if made >= MAX_EXPANSION_CALLS {
                        return false;
                    }
                    made += 1;
                    out.push(Call { rule, state: child, depth });
                }
                Op::Draw { xf, .. } | Op::Iso { xf, .. } => {
                    pc += 1;
                    let from = cont.take().unwrap_or(base);
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                    last = from.compose(&c, &mut self.lins);
                }
                Op::Loop { step, end, chain, .. } | Op::LoopN { step, end, chain, .. } => {
                    let count = match op {
                        Op::LoopN { count: e, .. } => {
                            let at = cont.unwrap_or(base);
                            let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                            let n = env.eval(&b.exprs[e as usize], &mut self.rng, &mut self.expr_stack);
                            if n.is_nan() {
                                self.non_finite.note(Fallback::Count, Site::Op(pc as u32));
                            }
                            // Saturating: negative and NaN counts give no runs.
                            n as u64
                        }
                        Op::Loop { count, .. } => count,
                        _ => 0,
                    };
                    let from = cont.take().unwrap_or(base);
                    if count == 0 {
                        pc = end as usize + 1;
                        continue;
                    }
                    let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                    let c = if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 {
                        Composite::IDENTITY
                    } else {
                        eval_transform(b, step, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite)
                    };
                    let chain = chain & bundle::ops::LOOP_CHAIN != 0;
                    self.loops.push(LoopRec { remaining: count, step, saved_base: base, chain });
                    base = from.compose(&c, &mut self.lins);
                    pc += 1;
                }
                Op::EndLoop { begin } => {
                    cont = None;
                    let Some(l) = self.loops.last_mut() else {
                        pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        if made >= MAX_EXPANSION_CALLS {
                            return false;
                        }
                        let from = if l.chain { last } else { base };
                        let step = l.step;
                        let env = Env { at: &from, depth: call.depth, slots: &self.slots };
                        let c =
                            eval_transform(b, step, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
                        base = from.compose(&c, &mut self.lins);
                        pc = begin as usize + 1;
                        // Runs count like calls, so a huge iterator is cut too.
                        made += 1;
                    } else {
                        base = l.saved_base;
                        self.loops.pop();
                        pc += 1;
                    }
                }
                Op::Cont {} => {
                    pc += 1;
                    cont = Some(last);
                }
                // The items it covers are drawables, skipped one by one.
                Op::Arg { .. } | Op::Inst { .. } => pc += 1,
                Op::Set { slot, expr } => {
                    pc += 1;
                    let at = cont.unwrap_or(base);
                    let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                    let v = env.eval(&b.exprs[expr as usize], &mut self.rng, &mut self.expr_stack);
                    if let Some(s) = self.slots.get_mut(slot as usize) {
                        *s = v;
                    }
                }
                Op::Jump { target } => pc = target as usize,
                Op::JumpIfNot { expr, target } => {
                    let at = cont.unwrap_or(base);
                    let env = Env { at: &at, depth: call.depth, slots: &self.slots };
                    let v = env.eval(&b.exprs[expr as usize], &mut self.rng, &mut self.expr_stack);
                    pc = if expr::truthy(v) { pc + 1 } else { target as usize };
                }
                Op::Ret {} => break,
            }
        }
        true
    }
}

struct Pcg(Pcg64);

impl Random for Pcg {
    fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Data derived once per constant transform, for the `VERTEX` fast path.
struct XfInfo {
    frame: Frame,
    /// The transform's linear part applied to the `normal` directive's vector.
    normal: Vec3,
    mirrored: bool,
}

/// Whether [`Eval::run_fast`] can run `b`'s model: no rule has parameters, bones or
/// an iterator rule, and the code is only `INST` (with the items it covers), calls
/// and `LOOP`s with constant transforms (no non-uniform scale; no `\` after a call,
/// no chained runs), `ENDLOOP` and `RET`.
/// `xf_pure` is [`Eval::xf_pure`].
fn fast_path_applies(b: &Bundle, xf_pure: &[bool]) -> bool {
    let pure = |xf: u32| xf_pure.get(xf as usize).copied().unwrap_or(false);
    let rules_ok =
        b.rules.iter().all(|r| r.params.is_empty() && r.frame == 0 && r.transforms.is_empty() && r.iter == NONE);
    let mut pc = 0usize;
    while let Some(op) = b.code.get(pc) {
        pc += match *op {
            Op::Inst { count, .. } => 1 + count as usize,
            Op::Call { xf, flags, .. } if flags == 0 && pure(xf) => 1,
            Op::Loop { step, chain, .. } if chain & bundle::ops::LOOP_CHAIN == 0 && pure(step) => 1,
            Op::EndLoop { .. } | Op::Ret {} => 1,
            _ => return false,
        };
    }
    rules_ok
}

/// The state a constant `VERTEX` item (transform `c`, cached as `x`) leaves in
/// `last` when it starts from `from`: what composing `c` gives, without its linear
/// factor (the `VERTEX` fast path's frames have none).
#[inline]
fn vertex_state(from: &State, x: &XfInfo, c: &Composite) -> State {
    State {
        f: from.f.compose(&x.frame),
        color: add(from.color, c.color),
        weight: add(from.weight, c.weight),
        fps: from.fps + c.fps,
        ..*from
    }
}

/// `a + b` component-wise, four lanes at once (each lane one IEEE addition, as the
/// scalar sum would be).
#[inline(always)]
fn add(a: [f32; 4], b: [f32; 4]) -> [f32; 4] {
    (Vec4::from_array(a) + Vec4::from_array(b)).to_array()
}

/// The last frame whose linear map the `VERTEX` path computed, and that map: the
/// items of a body that run one by one share their frame, so it is computed once.
struct LinCache {
    frame: Frame,
    lin: (Mat3, bool),
}

impl LinCache {
    /// `f.linear()`, from the cache when `f` is the frame it holds (compared bit
    /// for bit: equal frames have equal maps).
    #[inline]
    fn get(&mut self, f: &Frame) -> (Mat3, bool) {
        let same = |a: &Frame, b: &Frame| {
            a.q.to_array().map(f32::to_bits) == b.q.to_array().map(f32::to_bits)
                && a.qh.to_array().map(f32::to_bits) == b.qh.to_array().map(f32::to_bits)
                && a.u.to_array().map(f32::to_bits) == b.u.to_array().map(f32::to_bits)
        };
        if !same(&self.frame, f) {
            *self = LinCache { frame: *f, lin: f.linear() };
        }
        self.lin
    }
}

/// A prototype of the bundle (an `INST` op): where its items are, and its mesh in the
/// output once an instance of it has been made.
struct ProtoSlot {
    /// The op after the `INST` (its first item) and how many items it covers.
    first: u32,
    count: u32,
    /// Index into `Output::shared_meshes`, or `NONE` until the first instance.
    mesh: u32,
    /// Vertices per instance.
    vertices: u32,
    /// The largest coordinate of its mesh (see [`frame_surely_maps_finite`]).
    extent: f32,
}

struct Act {
    pc: u32,
    /// The activation's frame is `slots[slot_base..slot_top]` (parameters, then locals);
    /// `ARG`s for the next call are pushed above it.
    slot_base: u32,
    slot_top: u32,
    base: State,
    depth: u32,
    loops_at: u32,
    /// The innermost bone (0 = the root): vertices emitted here carry it.
    bone: u32,
    /// Set when this activation runs a convolution rule's body once per frame.
    conv: Option<Box<Conv>>,
}

/// The remaining runs of a convolution rule's body.
struct Conv {
    /// `I[i]·A[i]·B[i]` for every frame index i of the iterator rule.
    frames: Rc<Vec<Frame>>,
    /// The next frame index to run.
    next: usize,
    /// The body's first op (the definition chosen at the call).
    pc: u32,
    /// R's state at the call; run i is under its frame composed with `frames[i]`.
    origin: State,
}

struct LoopRec {
    remaining: u64,
    step: u32,
    saved_base: State,
    chain: bool,
}

#[derive(Clone, Copy)]
struct Pen {
    state: State,
    lifted: bool,
    line: Option<usize>,
    /// The bone the pen's position was set in: a sweep's first ring and a line's
    /// point there belong to it.
    bone: u32,
}

#[derive(Default)]
struct LimitCounts {
    maxdepth: u64,
    minsize: u64,
    stacksize: u64,
    /// The CALL op of the first call each per-branch limit refused (`maxdepth`,
    /// `minsize`, stack size): its warning names that rule and line.
    first_refused: [Option<u32>; 3],
    maxiter: bool,
    vertices: bool,
    time: bool,
    /// Keyframes of the bones made so far (see [`MAX_KEYFRAMES`]).
    keyframes: u64,
    animation: bool,
}

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
    profiles: HashMap<u32, std::rc::Rc<[Vec3]>>,
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
    maxiter: u64,
    stacksize: u32,
    expr_stack: Vec<f64>,
    /// The value stack of rule parameters and locals (see [`Act::slot_base`]): grown
    /// once to the deepest derivation's need, never allocated per call.
    slots: Vec<f64>,
    profile_points: Vec<Vec3>,
    progress: Option<&'b dyn Fn(u64)>,
    xf_info: Vec<Option<XfInfo>>,
    /// Per transform: a constant without a non-uniform scale (composing it has no
    /// effect but its result).
    xf_pure: Vec<bool>,
    /// Whether any op reads the continuation register (CONT, chained loops, RESET);
    /// if not, the VERTEX fast path need not compute the full frame for it.
    needs_last: bool,
    /// The bundle's prototypes, by `INST` ordinal.
    protos: Vec<ProtoSlot>,
    /// Whether `INST` makes instances (see [`EvalOptions::instancing`]).
    instancing: bool,
    /// Whether model runs take [`Eval::run_fast`] (instancing on, so no sites, and
    /// [`fast_path_applies`]).
    fast: bool,
    /// Vertices of the prototype instances made so far (they count as vertices for
    /// the budget and the statistics, as they would have run one by one).
    instanced_vertices: u64,
    /// Prototype instances made so far (the vertex budget's count of them when
    /// [`EvalOptions::instances_stored`]).
    prototype_instances: u64,
    /// Whether an instance refers to a non-uniform factor (then `lins` goes into the
    /// output).
    lins_used: bool,
    /// A prototype instance's frame failed the finiteness bound (its vertices are
    /// counted one by one at the end).
    suspect_instances: bool,
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
    conv_cache: HashMap<u32, Rc<Vec<Frame>>>,
    /// The non-uniform factors of this evaluation's states.
    lins: Lins,
    weights: Weights,
    /// With `record_sites`: the op that ran last, the mesh's triangle count when it
    /// began, and each op's index in `out.sites.sites`.
    site_pc: u32,
    site_mark: usize,
    site_ids: HashMap<u32, u32>,
    /// Rule definitions by first op (see [`def_starts`]), made on first use: naming
    /// the rule of an op is then a binary search, not a walk over every rule (40,000
    /// rules with a prototype each took seconds).
    def_starts: Option<Vec<(u32, u32)>>,
    /// Computed values that were not finite numbers, and the fallbacks used.
    non_finite: NonFinite,
}

/// Evaluates a verified bundle from its start shape.
pub fn evaluate(b: &Bundle, opts: &EvalOptions) -> Output {
    evaluate_with_progress(b, opts, None)
}

/// Like [`evaluate`], calling `progress(rule_calls)` now and then (for a progress bar).
pub fn evaluate_with_progress(b: &Bundle, opts: &EvalOptions, progress: Option<&dyn Fn(u64)>) -> Output {
    let mut e = Eval::new(b, opts, progress);
    let start = State::start(b.settings.fps);
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
    fn new(b: &'b Bundle, opts: &EvalOptions, progress: Option<&'b dyn Fn(u64)>) -> Eval<'b> {
        let s = &b.settings;
        let seed = opts.seed.unwrap_or(s.randseed);
        let start = State::start(s.fps);
        // (Sites are per triangle: recording them turns instancing off.)
        let instancing = opts.instancing && !opts.record_sites;
        let xf_pure: Vec<bool> =
            b.transforms.iter().map(|t| matches!(t, Transform::Const(c) if c.n.is_none())).collect();
        let fast = instancing && fast_path_applies(b, &xf_pure);
        let mut e = Eval {
            b,
            opts: opts.clone(),
            rng: Pcg(Pcg64::seed_from_u64(seed)),
            out: Output { background: s.background, ..Output::default() },
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
            maxiter: opts.maxiter.unwrap_or(if s.maxiter > 0 { s.maxiter } else { DEFAULT_MAXITER }).min(opts.max_iter),
            stacksize: (if s.stacksize > 0 { s.stacksize } else { DEFAULT_STACKSIZE }).min(opts.max_stack),
            expr_stack: Vec::with_capacity(16),
            slots: Vec::new(),
            profile_points: Vec::new(),
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
            weights: Weights::new(b),
            site_pc: 0,
            site_mark: 0,
            site_ids: HashMap::new(),
            def_starts: None,
            non_finite: NonFinite::default(),
            stop_pc: None,
            protos: b
                .code
                .iter()
                .enumerate()
                .filter_map(|(pc, op)| match *op {
                    Op::Inst { count, .. } => Some(ProtoSlot {
                        first: pc as u32 + 1,
                        count,
                        mesh: NONE,
                        extent: 0.0,
                        vertices: b.code[pc + 1..]
                            .iter()
                            .take(count as usize)
                            .filter(|op| matches!(op, Op::Draw { kind: Drawable::Vertex, .. }))
                            .count() as u32,
                    }),
                    _ => None,
                })
                .collect(),
            instancing,
            fast,
            instanced_vertices: 0,
            prototype_instances: 0,
            lins_used: false,
            suspect_instances: false,
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
                    // transpose, nor for HSB, which is no delta.)
                    Transform::Const(c) if c.n.is_none() && c.hsb.is_none() => {
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

impl<'b> Eval<'b> {
    /// `from` composed with transform `xf` (at `depth`, in the frame `slots[base..top]`).
    #[inline(always)]
    fn apply(&mut self, xf: u32, from: &State, depth: u32, base: u32, top: u32) -> State {
        let b = self.b;
        // A constant transform is composed where it lies (a composite is too big to copy).
        if let Transform::Const(c) = &b.transforms[xf as usize] {
            return from.compose(c, &mut self.lins);
        }
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let env = Env { at: from, depth, slots };
        let c = eval_transform(b, xf, &mut self.rng, &mut self.expr_stack, &env, &mut self.non_finite);
        from.compose(&c, &mut self.lins)
    }

    /// Expression `e` at state `at` and `depth` in the frame `slots[base..top]`.
    #[inline]
    fn value(&mut self, e: u32, at: &State, depth: u32, base: u32, top: u32) -> f64 {
        let slots = self.slots.get(base as usize..top as usize).unwrap_or(&[]);
        let code: &[ExprOp] = &self.b.exprs[e as usize];
        // (Tried before the environment is built: most arguments are `n - 1`.)
        if let Some(v) = expr::quick(code, slots) {
            return v;
        }
        Env { at, depth, slots }.eval_full(code, &mut self.rng, &mut self.expr_stack)
    }

    /// The definition of `rule_idx` for a call in state `child` at `depth` whose
    /// arguments are `slots[args..]`.
    fn select(&mut self, rule_idx: u32, child: &State, depth: u32, args: usize) -> u32 {
        let slots = self.slots.get(args..).unwrap_or(&[]);
        select_def(
            self.b,
            rule_idx,
            child,
            depth,
            slots,
            &mut self.rng,
            &mut self.sequential,
            &mut self.expr_stack,
            &mut self.weights,
            &mut self.non_finite,
        )
    }

    /// Pushes a frame for a run that starts at `rule` (no caller passes arguments: the
    /// parameters take their defaults); returns its base.
    fn default_frame(&mut self, rule: u32) -> (u32, u32) {
        let r = &self.b.rules[rule as usize];
        let base = self.slots.len();
        self.slots.extend(r.params.iter().map(|d| d.unwrap_or(0.0)));
        self.slots.resize(base + r.frame as usize, 0.0);
        (base as u32, self.slots.len() as u32)
    }

    /// Runs `rule` from `start` until its whole derivation is done.
    fn run(&mut self, rule: u32, start: State, mode: Mode) {
        self.run_from(rule, start, 0, mode)
    }

    /// Runs a call of `rule` in state `start` at `depth` until its whole derivation is done.
    fn run_from(&mut self, rule: u32, start: State, depth: u32, mode: Mode) {
        if self.fast && mode == Mode::Model {
            return self.run_fast(rule, start, depth);
        }
        // Two copies of the loop: the one without sites has no per-op check for them.
        if self.opts.record_sites {
            self.run_loop::<true>(rule, start, depth, mode)
        } else {
            self.run_loop::<false>(rule, start, depth, mode)
        }
    }

    /// [`Eval::run_from`], recording sites when `SITES`.
    fn run_loop<const SITES: bool>(&mut self, rule: u32, start: State, depth: u32, mode: Mode) {
        let b = self.b;
        let (slot_base, slot_top) = self.default_frame(rule);
        let pc = self.select(rule, &start, depth, slot_base as usize);
        let first = if b.rules[rule as usize].iter != NONE {
            // The start shape (or a sampled rule) is itself a convolution.
            let frames = self.convolution(rule);
            let Some(f) = frames.first().copied() else {
                self.slots.truncate(slot_base as usize);
                return;
            };
            let base = start.then(&f, &self.lins);
            Act {
                pc,
                slot_base,
                slot_top,
                base,
                depth,
                loops_at: 0,
                bone: 0,
                conv: Some(Box::new(Conv { frames, next: 1, pc, origin: start })),
            }
        } else {
            let bone = if mode == Mode::Model && !b.rules[rule as usize].transforms.is_empty() {
                self.new_bone(rule, &start, 0)
            } else {
                0
            };
            Act { pc, slot_base, slot_top, base: start, depth, loops_at: 0, bone, conv: None }
        };
        // `maxdepth` (0: none) as the depth past which calls are refused.
        let maxdepth = if b.settings.maxdepth > 0 { b.settings.maxdepth } else { u32::MAX };
        // The running activation; `stack` holds its callers.
        let mut act: Act = first;
        let mut stack: Vec<Act> = Vec::new();
        // The continuation state after `\`: set by CONT and taken by the next item of
        // the same body (a call takes it before its callee runs, so one register serves
        // every activation).
        let mut cont: Option<State> = None;
        let mut lin_cache = LinCache { frame: Frame::identity(), lin: Frame::identity().linear() };
        let mut loops: Vec<LoopRec> = Vec::new();
        let code = &b.code;
        let record_sites = SITES;
        // (A nested run, sampling a transform rule, returns to the op that started it.)
        let outer_site = self.site_pc;
        loop {
            if record_sites {
                self.note_site(act.pc);
            }
            if self.stopped || self.halt {
                if self.stopped && self.stop_pc.is_none() {
                    // The op that tripped the limit (every op advances `pc` first).
                    self.stop_pc = Some(act.pc.saturating_sub(1));
                }
                break;
            }
            let op = code[act.pc as usize];
            match op {
                Op::Call { rule, xf, flags } => {
                    act.pc += 1;
                    let depth = act.depth + 1;
                    if depth > maxdepth && flags & CONT_NEXT == 0 && self.xf_pure[xf as usize] {
                        // Refused before its frame is composed: the frame would be
                        // thrown away, and composing a constant changes nothing else.
                        cont = None;
                        self.refuse_deep_call(act.pc - 1);
                        let args = act.slot_top as usize;
                        if self.slots.len() > args {
                            self.slots.truncate(args);
                        }
                        continue;
                    }
                    let parent_bone = act.bone;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let child = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    if flags & CONT_NEXT != 0 {
                        self.last = child;
                    }
                    // The ARGs before this CALL are the callee's first slots (the
                    // verifier checked their number).
                    let r = &b.rules[rule as usize];
                    let args = act.slot_top as usize;
                    if !self.admit(&child, depth, stack.len() + 1, act.pc - 1) {
                        if self.slots.len() > args {
                            self.slots.truncate(args);
                        }
                        continue;
                    }
                    // (Rules without parameters or locals touch no slot.)
                    if self.slots.len() != args + r.params.len() {
                        self.slots.resize(args + r.params.len(), f64::NAN);
                    }
                    let pc = match r.defs.as_slice() {
                        [only] => only.start,
                        _ => self.select(rule, &child, depth, args),
                    };
                    if r.frame as usize != r.params.len() {
                        self.slots.resize(args + r.frame as usize, 0.0);
                    }
                    let (slot_base, slot_top) = (args as u32, (args + r.frame as usize) as u32);
                    let loops_at = loops.len() as u32;
                    if r.iter != NONE {
                        // Convolution: the body runs once per frame of the iterator rule.
                        let frames = self.convolution(rule);
                        let Some(f) = frames.first().copied() else {
                            self.slots.truncate(args);
                            continue;
                        };
                        let base = child.then(&f, &self.lins);
                        let conv = Some(Box::new(Conv { frames, next: 1, pc, origin: child }));
                        let callee = Act { pc, slot_base, slot_top, base, depth, loops_at, bone: parent_bone, conv };
                        stack.push(std::mem::replace(&mut act, callee));
                    } else {
                        let bone = if mode == Mode::Model && !r.transforms.is_empty() {
                            self.new_bone(rule, &child, parent_bone)
                        } else {
                            parent_bone
                        };
                        let callee = Act { pc, slot_base, slot_top, base: child, depth, loops_at, bone, conv: None };
                        stack.push(std::mem::replace(&mut act, callee));
                    }
                }
                Op::Draw { kind: Drawable::Vertex, xf, ns, profile, flags: _ }
                    if mode == Mode::Model && self.xf_info[xf as usize].is_some() =>
                {
                    // VERTEX with a constant transform: position, normal and mirroring
                    // from the cached linear maps, without composing quaternions.
                    act.pc += 1;
                    // `from` is borrowed, not copied: this runs once per vertex.
                    let (from, lin) = match &cont {
                        Some(c) => (c, c.f.linear()),
                        None => (&act.base, lin_cache.get(&act.base.f)),
                    };
                    let Transform::Const(c) = &b.transforms[xf as usize] else {
                        cont = None;
                        continue;
                    };
                    if from.lin != 0 {
                        // Under a non-uniform scale, the general path (a normal takes the
                        // inverse transpose of the whole linear map).
                        let s = from.compose(c, &mut self.lins);
                        cont = None;
                        self.last = s;
                        let bone = act.bone;
                        self.draw(Drawable::Vertex, s, ns, profile, mode, bone);
                        continue;
                    }
                    let Some(x) = &self.xf_info[xf as usize] else {
                        cont = None;
                        continue;
                    };
                    let p = from.f.u + lin.0 * x.frame.u;
                    let n = (lin.0 * x.normal).normalize_or(Vec3::Z);
                    let color = add(from.color, c.color).map(|v| v.clamp(0.0, 1.0));
                    let weight = add(from.weight, c.weight);
                    let mirrored = lin.1 != x.mirrored;
                    let m = &mut self.out.mesh;
                    let k = m.push_vertex(p, n, color, weight, act.bone) + 1;
                    if k.is_multiple_of(3) {
                        m.push_triangle([k - 3, k - 2, k - 1], mirrored);
                    }
                    if self.needs_last {
                        self.last = vertex_state(from, x, c);
                    }
                    cont = None;
                }
                Op::Draw { kind, xf, ns, profile, flags: _ } => {
                    act.pc += 1;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let s = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    self.last = s;
                    let bone = act.bone;
                    self.draw(kind, s, ns, profile, mode, bone);
                }
                Op::Iso { iso, xf, flags: _ } => {
                    act.pc += 1;
                    let from = cont.as_ref().unwrap_or(&act.base);
                    let s = self.apply(xf, from, act.depth, act.slot_base, act.slot_top);
                    cont = None;
                    self.last = s;
                    if mode == Mode::Model {
                        let bone = act.bone;
                        self.instance(iso, &s, act.pc - 1, bone);
                    }
                }
                Op::Loop { step, end, chain, .. } | Op::LoopN { step, end, chain, .. } => {
                    let count = match op {
                        Op::LoopN { count: e, .. } => {
                            let at = cont.unwrap_or(act.base);
                            let n = self.value(e, &at, act.depth, act.slot_base, act.slot_top);
                            if n.is_nan() {
                                self.non_finite.note(Fallback::Count, Site::Op(act.pc));
                            }
                            // Saturating: negative and NaN counts give no runs.
                            n as u64
                        }
                        Op::Loop { count, .. } => count,
                        _ => 0,
                    };
                    let from = cont.take().unwrap_or(act.base);
                    if count == 0 {
                        act.pc = end + 1;
                        continue;
                    }
                    // Context Free's `loop`: the first run is under the frame itself.
                    let next = if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 {
                        from.compose(&Composite::IDENTITY, &mut self.lins)
                    } else {
                        self.apply(step, &from, act.depth, act.slot_base, act.slot_top)
                    };
                    let chain = chain & bundle::ops::LOOP_CHAIN != 0;
                    loops.push(LoopRec { remaining: count, step, saved_base: act.base, chain });
                    act.base = next;
                    if chain {
                        // A run that reaches no drawable ends where it started.
                        self.last = act.base;
                    }
                    act.pc += 1;
                }
                Op::EndLoop { begin: _ } => {
                    // A continuation chain is scoped to its body: it does not leak into
                    // the next run or out of the block.
                    cont = None;
                    let Some(l) = loops.last_mut() else {
                        act.pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        let chain = l.chain;
                        let from = if chain { self.last } else { act.base };
                        let step = l.step;
                        act.base = self.apply(step, &from, act.depth, act.slot_base, act.slot_top);
                        if chain {
                            self.last = act.base;
                        }
                        // Back to the op after LOOP.
                        if let Op::EndLoop { begin } = op {
                            act.pc = begin + 1;
                        }
                        // Iterator runs count as calls, so `maxiter` also ends huge loops.
                        self.count_run();
                    } else {
                        act.base = l.saved_base;
                        loops.pop();
                        act.pc += 1;
                    }
                }
                Op::Inst { proto, count } => {
                    act.pc += 1;
                    // An instance where it gives the very triangles the items would: a
                    // model run, in a similarity frame, from the body's frame (no
                    // continuation), with a whole number of triangles before it.
                    // Otherwise the items run one by one.
                    if !self.instancing
                        || mode != Mode::Model
                        || cont.is_some()
                        || act.base.lin != 0
                        || !self.out.mesh.n_vertices().is_multiple_of(3)
                    {
                        continue;
                    }
                    let bone = act.bone;
                    self.emit_instance(proto, &act.base, bone);
                    act.pc += count;
                    if self.needs_last {
                        // `last` as the run's last item leaves it.
                        if let Op::Draw { kind, xf, .. } = code[act.pc as usize - 1] {
                            if let (Transform::Const(c), Some(x)) =
                                (&b.transforms[xf as usize], &self.xf_info[xf as usize])
                            {
                                self.last = if kind == Drawable::Vertex {
                                    vertex_state(&act.base, x, c)
                                } else {
                                    act.base.compose(c, &mut self.lins)
                                };
                            }
                        }
                    }
                }
                Op::Cont {} => {
                    act.pc += 1;
                    cont = Some(self.last);
                }
                Op::Arg { expr } => {
                    act.pc += 1;
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    self.slots.push(v);
                }
                Op::Set { slot, expr } => {
                    act.pc += 1;
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    if let Some(s) = self.slots.get_mut(act.slot_base as usize + slot as usize) {
                        *s = v;
                    }
                }
                Op::Jump { target } => act.pc = target,
                Op::JumpIfNot { expr, target } => {
                    let at = cont.as_ref().unwrap_or(&act.base);
                    let v = self.value(expr, at, act.depth, act.slot_base, act.slot_top);
                    act.pc = if expr::truthy(v) { act.pc + 1 } else { target };
                }
                Op::Ret {} => {
                    let at = act.loops_at as usize;
                    loops.truncate(at);
                    if let Some(conv) = act.conv.as_mut() {
                        if let Some(f) = conv.frames.get(conv.next) {
                            // The next run of a convolution body, under R's frame · frame i.
                            act.base = conv.origin.then(f, &self.lins);
                            cont = None;
                            act.pc = conv.pc;
                            conv.next += 1;
                            // Body runs count as calls, so `maxiter` also bounds them.
                            self.count_run();
                            continue;
                        }
                    }
                    let base = act.slot_base as usize;
                    if self.slots.len() > base {
                        self.slots.truncate(base);
                    }
                    match stack.pop() {
                        Some(caller) => act = caller,
                        None => break,
                    }
                }
            }
        }
        if record_sites {
            self.note_site(outer_site);
        }
        // A run ended by a limit leaves its frames: the caller's slots end here.
        self.slots.truncate(slot_base as usize);
    }

    /// [`Eval::run_from`] in a model run of a bundle whose code is only prototype
    /// instances, calls and iterators with constant transforms, and returns
    /// ([`fast_path_applies`]): the same steps, in the same order, with the same
    /// arithmetic as the general loop (so the same output), for activations that
    /// need no parameter slots, bones, convolutions or continuations.
    fn run_fast(&mut self, rule: u32, start: State, depth: u32) {
        /// One activation: the op to run, the body's (or iterator run's) state, the
        /// depth, and where its iterators begin in `loops`.
        struct FastAct {
            pc: u32,
            depth: u32,
            loops_at: u32,
            base: State,
        }
        let b = self.b;
        let code = &b.code;
        let maxdepth = if b.settings.maxdepth > 0 { b.settings.maxdepth } else { u32::MAX };
        let args = self.slots.len();
        let pc = self.select(rule, &start, depth, args);
        let mut act = FastAct { pc, depth, loops_at: 0, base: start };
        let mut stack: Vec<FastAct> = Vec::new();
        let mut loops: Vec<LoopRec> = Vec::new();
        // (A run stops only where a call or an iterator run is counted: the limit is
        // checked there, and the op that tripped it named, as the general loop does.)
        let stop = |e: &mut Self, pc: u32| {
            e.stop_pc.get_or_insert(pc);
        };
        if self.stopped {
            return;
        }
        loop {
            match code[act.pc as usize] {
                Op::Inst { proto, count } => {
                    self.emit_instance(proto, &act.base, 0);
                    act.pc += 1 + count;
                }
                Op::Call { rule, xf, .. } => {
                    act.pc += 1;
                    let depth = act.depth + 1;
                    if depth > maxdepth {
                        self.refuse_deep_call(act.pc - 1);
                        if self.stopped {
                            stop(self, act.pc - 1);
                            break;
                        }
                        continue;
                    }
                    let Transform::Const(c) = &b.transforms[xf as usize] else { break };
                    let child = act.base.compose(c, &mut self.lins);
                    if !self.admit(&child, depth, stack.len() + 1, act.pc - 1) {
                        if self.stopped {
                            stop(self, act.pc - 1);
                            break;
                        }
                        continue;
                    }
                    let pc = match b.rules[rule as usize].defs.as_slice() {
                        [only] => only.start,
                        _ => self.select(rule, &child, depth, args),
                    };
                    let callee = FastAct { pc, depth, loops_at: loops.len() as u32, base: child };
                    stack.push(std::mem::replace(&mut act, callee));
                }
                Op::Loop { count, step, end, chain } => {
                    if count == 0 {
                        act.pc = end + 1;
                        continue;
                    }
                    let from = act.base;
                    // Context Free's `loop`: the first run is under the frame itself.
                    let next = match &b.transforms[step as usize] {
                        _ if chain & bundle::ops::LOOP_FIRST_PLAIN != 0 => {
                            from.compose(&Composite::IDENTITY, &mut self.lins)
                        }
                        Transform::Const(c) => from.compose(c, &mut self.lins),
                        Transform::Dynamic { .. } => break,
                    };
                    loops.push(LoopRec { remaining: count, step, saved_base: act.base, chain: false });
                    act.base = next;
                    act.pc += 1;
                }
                Op::EndLoop { begin } => {
                    let Some(l) = loops.last_mut() else {
                        act.pc += 1;
                        continue;
                    };
                    l.remaining -= 1;
                    if l.remaining > 0 {
                        let Transform::Const(c) = &b.transforms[l.step as usize] else { break };
                        act.base = act.base.compose(c, &mut self.lins);
                        act.pc = begin + 1;
                        // Iterator runs count as calls, so `maxiter` also ends huge loops.
                        self.count_run();
                        if self.stopped {
                            // (The general loop names the LOOP op: the run stops after
                            // jumping back to it.)
                            stop(self, begin);
                            break;
                        }
                    } else {
                        act.base = l.saved_base;
                        loops.pop();
                        act.pc += 1;
                    }
                }
                Op::Ret {} => {
                    loops.truncate(act.loops_at as usize);
                    match stack.pop() {
                        Some(caller) => act = caller,
                        None => break,
                    }
                }
                // Not in a bundle the fast path takes (see `fast_path_applies`).
                _ => break,
            }
        }
    }

    /// Adds an instance of prototype `proto` in state `base` (bone `bone`): the one
    /// record its items stand for (see the `INST` op).
    #[inline]
    fn emit_instance(&mut self, proto: u32, base: &State, bone: u32) {
        let Some(slot) = self.protos.get(proto as usize) else { return };
        let (mut mesh, vertices, mut extent) = (slot.mesh, slot.vertices, slot.extent);
        if mesh == NONE {
            mesh = self.make_prototype(proto as usize);
            extent = self.protos.get(proto as usize).map_or(0.0, |s| s.extent);
        }
        // The finiteness bound, while the frame is at hand (see `finish`).
        self.suspect_instances |= !frame_surely_maps_finite(&base.f, extent);
        let out = &mut self.out;
        if base.weight != [0.0; 4] || !out.instance_weights.is_empty() {
            out.instance_weights.resize(out.instances.len(), [0.0; 4]);
            out.instance_weights.push(base.weight);
        }
        let at = out.mesh.n_vertices() as u32;
        out.instances.push(Instance { frame: base.f, color: base.color, mesh, bone, lin: 0, at });
        self.instanced_vertices += u64::from(vertices);
        self.prototype_instances += 1;
    }

    /// The rule holding op `pc` (see [`rule_in`]).
    fn rule_of(&mut self, pc: u32) -> Option<&'b str> {
        let b = self.b;
        rule_in(self.def_starts.get_or_insert_with(|| def_starts(b)), b, pc)
    }

    /// The rule and source line of the op at `pc`.
    fn site_of(&mut self, pc: u32) -> crate::output::Site {
        let (file, line) = self.b.source_of(pc).map(|(f, l)| (f.to_string(), l)).unwrap_or_default();
        crate::output::Site { rule: self.rule_of(pc).unwrap_or_default().to_string(), file, line }
    }

    /// Builds prototype `p`'s mesh from its items (positions, normals, colour and
    /// weight deltas in the run's frame; see [`SharedKind::Prototype`]), adds it to
    /// the output's shared meshes and returns its index.
    #[cold]
    fn make_prototype(&mut self, p: usize) -> u32 {
        let b = self.b;
        let Some(slot) = self.protos.get(p) else { return NONE };
        let (first, count) = (slot.first as usize, slot.count as usize);
        let mut m = Mesh::default();
        let mut face_normals = Vec::new();
        for op in b.code.iter().skip(first).take(count) {
            let Op::Draw { kind, xf, .. } = *op else { continue };
            let (Some(Transform::Const(c)), Some(Some(x))) =
                (b.transforms.get(xf as usize), self.xf_info.get(xf as usize))
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
        let name = self.rule_of(first as u32).unwrap_or("").to_string();
        self.out.shared_meshes.push(SharedMesh { name, mesh: m, kind: SharedKind::Prototype { face_normals } });
        let mesh = self.out.shared_meshes.len() as u32 - 1;
        let extent = crate::output::max_abs(&self.out.shared_meshes[mesh as usize].mesh.positions);
        if let Some(slot) = self.protos.get_mut(p) {
            slot.mesh = mesh;
            slot.extent = extent;
        }
        mesh
    }

    /// With `record_sites`, before the op at `pc` runs: the triangles made since the
    /// last note were drawn by the op that ran last.
    fn note_site(&mut self, pc: u32) {
        let t = self.out.mesh.triangles.len();
        if t != self.site_mark {
            let site = match self.site_ids.get(&self.site_pc) {
                Some(&i) => i,
                None => {
                    // Ops of one line of one rule (the VERTEXes of a face) are one site.
                    let new = self.site_of(self.site_pc);
                    let sites = &mut self.out.sites.sites;
                    let i = sites.iter().rposition(|s| *s == new).unwrap_or_else(|| {
                        sites.push(new);
                        sites.len() - 1
                    }) as u32;
                    self.site_ids.insert(self.site_pc, i);
                    i
                }
            };
            let runs = &mut self.out.sites.runs;
            if runs.last().is_none_or(|r| r[1] != site) {
                runs.push([self.site_mark as u32, site]);
            }
            self.site_mark = t;
        }
        self.site_pc = pc;
    }

    /// Counts an iterator run or a convolution's body run as a call, so `maxiter`
    /// bounds them too (checking the budgets now and then).
    #[inline]
    fn count_run(&mut self) {
        self.calls += 1;
        if self.calls > self.maxiter {
            self.limits.maxiter = true;
            self.stopped = true;
        }
        if self.calls & 0xFFF == 0 {
            self.check_budgets();
        }
    }

    /// A call refused by `maxdepth` before its frame was made: counted as
    /// [`Eval::admit`] counts it (the run-wide limits come first).
    fn refuse_deep_call(&mut self, pc: u32) {
        if self.count_call() {
            self.limits.maxdepth += 1;
            self.limits.first_refused[0].get_or_insert(pc);
        }
    }

    /// Counts a call against the run-wide limits (checking the budgets now and
    /// then); whether the run goes on.
    #[inline]
    fn count_call(&mut self) -> bool {
        self.calls += 1;
        if self.calls & 0xFFF == 0 {
            self.check_budgets();
            if let Some(p) = self.progress {
                p(self.calls);
            }
            if self.stopped {
                // A budget ran out: this call is not made (the warning names its line).
                return false;
            }
        }
        if self.calls > self.maxiter {
            self.limits.maxiter = true;
            self.stopped = true;
            return false;
        }
        true
    }

    /// Whether a call may proceed; counts the limits that stop it.
    /// `pc` is the CALL op's (for the warning's rule and line).
    fn admit(&mut self, child: &State, depth: u32, stack_len: usize, pc: u32) -> bool {
        if !self.count_call() {
            return false;
        }
        self.admit_rest(child, depth, stack_len, pc)
    }

    /// The per-branch limits of a call: `maxdepth`, `minsize`, the stack size.
    #[inline]
    fn admit_rest(&mut self, child: &State, depth: u32, stack_len: usize, pc: u32) -> bool {
        let s = &self.b.settings;
        let refused = if s.maxdepth > 0 && depth > s.maxdepth {
            self.limits.maxdepth += 1;
            0
        } else if s.minsize > 0.0 && child.scale() < s.minsize {
            self.limits.minsize += 1;
            1
        } else if stack_len >= self.stacksize as usize {
            self.limits.stacksize += 1;
            2
        } else {
            return true;
        };
        self.limits.first_refused[refused].get_or_insert(pc);
        false
    }

    /// The vertices the run has made so far, as the vertex budget counts them: a
    /// prototype instance as its expanded vertices, or as one record when the output
    /// keeps it instanced ([`EvalOptions::instances_stored`]).
    fn vertices_made(&self) -> u64 {
        let instances = if self.opts.instances_stored { self.prototype_instances } else { self.instanced_vertices };
        (self.out.mesh.n_vertices() + self.out.sweeps.n_vertices()) as u64 + self.extra_vertices + instances
    }

    fn check_budgets(&mut self) {
        if self.vertices_made() > self.opts.max_vertices {
            self.limits.vertices = true;
            self.stopped = true;
        }
        if let Some(t) = self.opts.time_budget {
            if self.started.elapsed() > t {
                self.limits.time = true;
                self.stopped = true;
            }
        }
    }

    /// The points of profile rule `rule`, made on first use: at most
    /// [`Eval::profile_limit`] (the run of the rule is halted there, with a warning
    /// at the end), so a runaway profile costs neither memory nor time.
    fn profile(&mut self, rule: u32) -> std::rc::Rc<[Vec3]> {
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
        let pts: std::rc::Rc<[Vec3]> = std::mem::replace(&mut self.profile_points, saved).into();
        self.profiles.insert(rule, pts.clone());
        pts
    }

    /// The most points one profile keeps: [`MAX_PROFILE_POINTS`], and never more
    /// than half the vertex budget (a sweep makes two rings of them).
    fn profile_limit(&self) -> usize {
        (MAX_PROFILE_POINTS as u64).min(self.opts.max_vertices / 2).max(2) as usize
    }

    /// Whether `more` vertices fit in the vertex budget; if not, the run stops there
    /// (before they are made) with the budget's warning.
    fn room_for(&mut self, more: usize) -> bool {
        if self.vertices_made().saturating_add(more as u64) > self.opts.max_vertices {
            self.limits.vertices = true;
            self.stopped = true;
            return false;
        }
        true
    }

    /// Makes a bone for a call of model rule `rule` (which has transform rules) in
    /// state `child`, inside bone `parent`; returns its index.
    fn new_bone(&mut self, rule: u32, child: &State, parent: u32) -> u32 {
        let b = self.b;
        let r = &b.rules[rule as usize];
        let fps = if child.fps.is_finite() && child.fps > 0.0 { child.fps } else { 0.0 };
        let needed = frames_needed(self.horizon, fps);
        self.limits.keyframes = self.limits.keyframes.saturating_add(needed as u64);
        if self.limits.keyframes > self.keyframe_budget() {
            self.limits.animation = true;
            self.stopped = true;
        }
        let tracks = r.transforms.iter().map(|&x| self.track(x, needed)).collect();
        let bones = &mut self.out.animation.bones;
        if bones.is_empty() {
            bones.push(Bone { rule: String::new(), parent: 0, rest: Frame::identity(), fps: 0.0, tracks: Vec::new() });
        }
        bones.push(Bone { rule: b.string(r.name).to_string(), parent, rest: child.f, fps, tracks });
        (bones.len() - 1) as u32
    }

    /// The keyframe budget: [`MAX_KEYFRAMES`], or the vertex budget when smaller.
    fn keyframe_budget(&self) -> u64 {
        MAX_KEYFRAMES.min(self.opts.max_vertices)
    }

    /// Records a warning once.
    fn warn_once(&mut self, msg: String) {
        if !self.out.stats.warnings.contains(&msg) {
            self.out.stats.warnings.push(msg);
        }
    }

    /// "FILE:LINE: " of a rule's first definition, or "".
    fn rule_at(&self, rule: u32) -> String {
        let b = self.b;
        b.rules[rule as usize]
            .defs
            .first()
            .and_then(|d| b.source_of(d.start))
            .map(|(f, l)| format!("{f}:{l}: "))
            .unwrap_or_default()
    }

    /// The track of transform rule `rule` with at least `needed` frames (or all of
    /// them, if it ends sooner): from the cache, extended by a fresh sampling run when
    /// a cut track is too short. Returns its index in `out.animation.tracks`.
    fn track(&mut self, rule: u32, needed: usize) -> u32 {
        self.track_within(rule, needed, MAX_TRACK_FRAMES)
    }

    /// [`Eval::track`] with at most `max` frames sampled (a convolution samples its
    /// rules up to its frame budget instead of [`MAX_TRACK_FRAMES`]).
    fn track_within(&mut self, rule: u32, needed: usize, max: usize) -> u32 {
        let b = self.b;
        let name = b.string(b.rules[rule as usize].name).to_string();
        if needed > max {
            self.warn_once(format!(
                "{}transform rule `{name}`: only its first {max} frames are sampled",
                self.rule_at(rule)
            ));
        }
        let needed = needed.clamp(1, max.max(1));
        if let Some(&k) = self.track_ids.get(&rule) {
            let t = &self.out.animation.tracks[k as usize];
            if t.complete || t.frames.len() >= needed || self.computing.contains(&rule) {
                return k;
            }
            let (frames, complete) = self.sample(rule, needed);
            let t = &mut self.out.animation.tracks[k as usize];
            t.frames = frames;
            t.complete = complete;
            return k;
        }
        let tracks = &self.out.animation.tracks;
        let k = tracks.len() as u32;
        let why = if self.computing.contains(&rule) {
            Some("needs its own frames while they are being sampled (a cycle through `*` or `:`)".to_string())
        } else if self.computing.len() >= MAX_TRACK_NESTING {
            Some(format!("is sampled inside {MAX_TRACK_NESTING} other transform rules being sampled"))
        } else {
            None
        };
        if let Some(why) = why {
            self.warn_once(format!("{}transform rule `{name}` {why}; there it has no frames", self.rule_at(rule)));
            self.out.animation.tracks.push(Track { rule: name, frames: Vec::new(), complete: true });
            return k;
        }
        let (frames, complete) = self.sample(rule, needed);
        let k = self.out.animation.tracks.len() as u32;
        self.out.animation.tracks.push(Track { rule: name, frames, complete });
        self.track_ids.insert(rule, k);
        k
    }

    /// Evaluates transform rule `rule` from the identity, recording at most `limit`
    /// frames; returns them and whether the rule ended by itself (not cut at `limit`).
    /// The run has its own random stream (from the seed and the rule), its own
    /// sequential-selection state and no effect on pens or the continuation register.
    fn sample(&mut self, rule: u32, limit: usize) -> (Vec<Frame>, bool) {
        self.computing.push(rule);
        let seed = self.seed ^ (rule as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let saved_rng = std::mem::replace(&mut self.rng, Pcg(Pcg64::seed_from_u64(seed)));
        let saved_seq = std::mem::take(&mut self.sequential);
        let saved_sink = std::mem::take(&mut self.frame_sink);
        let saved_limit = std::mem::replace(&mut self.frame_limit, limit);
        let saved_halt = std::mem::replace(&mut self.halt, false);
        let saved_last = self.last;
        self.run(rule, State::start(self.b.settings.fps), Mode::Transform);
        // A run stopped by a limit did not end by itself either.
        let complete = !self.halt && !self.stopped;
        let frames = std::mem::replace(&mut self.frame_sink, saved_sink);
        self.rng = saved_rng;
        self.sequential = saved_seq;
        self.frame_limit = saved_limit;
        self.halt = saved_halt;
        self.last = saved_last;
        self.computing.pop();
        (frames, complete)
    }

    /// The frames a convolution rule's body runs under (`I[i]·A[i]·B[i]` for every
    /// frame index i of its iterator rule I; A, B… sampled by index and clamped to
    /// their last frame). A terminating I contributes **all** its frames (SPEC §8:
    /// `duration·fps` bounds the animation, not a convolution); one that has not ended
    /// within the frame budget (`EvalOptions::max_frames`) is cut there with a warning.
    fn convolution(&mut self, rule: u32) -> Rc<Vec<Frame>> {
        let b = self.b;
        if let Some(c) = self.conv_cache.get(&rule) {
            return c.clone();
        }
        let budget = self.opts.max_frames.clamp(1, usize::MAX as u64) as usize;
        let r = &b.rules[rule as usize];
        let it = self.track_within(r.iter, budget, budget) as usize;
        let t = &self.out.animation.tracks[it];
        let n = t.frames.len().min(budget);
        if !t.complete && !self.stopped {
            let msg = format!(
                "{}convolution `{}`: iterator rule `{}` did not end within the frame budget of {budget} frames; only those are used (an iterator rule must terminate; raise the budget with `--max-frames N`)",
                self.rule_at(r.iter),
                b.string(r.name),
                b.string(b.rules[r.iter as usize].name),
            );
            self.warn_once(msg);
        }
        let parts: Vec<u32> = r.transforms.iter().map(|&x| self.track_within(x, n, budget)).collect();
        let tracks = &self.out.animation.tracks;
        // (Sampling the parts can have re-sampled the iterator's track: a run stopped by
        // a limit meanwhile leaves it shorter. Take what it holds.)
        let frames: Vec<Frame> = tracks[it]
            .frames
            .iter()
            .take(n)
            .enumerate()
            .map(|(i, f)| parts.iter().fold(*f, |acc, &k| acc.compose(&tracks[k as usize].clamped(i as u64))))
            .collect();
        let frames = Rc::new(frames);
        self.conv_cache.insert(rule, frames.clone());
        frames
    }

    fn draw(&mut self, kind: Drawable, s: State, ns: u32, profile: u32, mode: Mode, bone: u32) {
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

    fn new_line(&mut self, ns: usize, start: Vec3, bone: u32) -> usize {
        let name = self.b.string(self.b.settings.namespaces[ns]).to_string();
        let mut line = Polyline { namespace: name, ..Polyline::default() };
        line.push(start, bone);
        self.extra_vertices += 1;
        self.out.lines.push(line);
        let l = self.out.lines.len() - 1;
        self.pens[ns].line = Some(l);
        l
    }

    fn instance(&mut self, iso: u32, s: &State, pc: u32, bone: u32) {
        let mesh = match self.iso_meshes.get(&iso) {
            Some(m) => *m,
            None => {
                let decl = &self.b.isosurfaces[iso as usize];
                let grid =
                    marching::Grid { min: Vec3::from_array(decl.min), max: Vec3::from_array(decl.max), res: decl.res };
                let code = &self.b.exprs[decl.function as usize];
                let rng = std::cell::RefCell::new(Pcg(Pcg64::seed_from_u64(0)));
                let stack = std::cell::RefCell::new(Vec::new());
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

    fn finish(mut self) -> Output {
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
        let bad = self.out.non_finite_positions_checking(self.suspect_instances);
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
        self.out
    }
}

/// The name of the rule whose definition holds the op at `pc`.
fn rule_of_op(b: &Bundle, pc: u32) -> Option<&str> {
    rule_in(&def_starts(b), b, pc)
}

/// Every rule definition's first op and the rule's name, sorted by op.
fn def_starts(b: &Bundle) -> Vec<(u32, u32)> {
    let mut v: Vec<(u32, u32)> = b.rules.iter().flat_map(|r| r.defs.iter().map(move |d| (d.start, r.name))).collect();
    v.sort_unstable();
    v
}

/// The name of the rule whose definition holds op `pc`: the definition starting
/// last at or before it.
fn rule_in<'b>(starts: &[(u32, u32)], b: &'b Bundle, pc: u32) -> Option<&'b str> {
    let i = starts.partition_point(|&(s, _)| s <= pc);
    starts.get(i.checked_sub(1)?).map(|&(_, n)| b.string(n))
}

/// " in rule `NAME` (FILE:LINE)" for the op at `pc`: the rule whose definition holds
/// it and the source line of the op, or "" when the bundle has no such information.
fn where_op(b: &Bundle, pc: u32) -> String {
    let name = rule_of_op(b, pc).map(str::to_string);
    match (name, b.source_of(pc)) {
        (Some(n), Some((f, l))) => format!(" in rule `{n}` ({f}:{l})"),
        (Some(n), None) => format!(" in rule `{n}`"),
        (None, Some((f, l))) => format!(" at {f}:{l}"),
        (None, None) => String::new(),
    }
}

/// Evaluates transform `xf`: a constant composite, or a dynamic list with its random
/// draws taken from `rng`.
/// Where an expression is evaluated: the state its position and scale are read from,
/// the rule depth, and the running rule's frame.
struct Env<'a> {
    at: &'a State,
    depth: u32,
    slots: &'a [f64],
}

impl Env<'_> {
    #[inline]
    fn eval(&self, code: &[ExprOp], rng: &mut Pcg, stack: &mut Vec<f64>) -> f64 {
        match expr::quick(code, self.slots) {
            Some(v) => v,
            None => self.eval_full(code, rng, stack),
        }
    }

    /// [`Env::eval`] on the expression stack (code [`expr::quick`] does not take).
    fn eval_full(&self, code: &[ExprOp], rng: &mut Pcg, stack: &mut Vec<f64>) -> f64 {
        let p = self.at.f.u;
        let vars = [p.x as f64, p.y as f64, p.z as f64, self.depth as f64, self.at.scale() as f64, 0.0];
        expr::eval(code, &vars, self.slots, rng, stack)
    }
}

/// Values computed at run time that were NaN or infinite where a finite number is
/// needed, each replaced by a fallback the run reports once per kind, at the first
/// place it happened.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct NonFinite {
    /// Per [`Fallback`]: how many, and where the first was.
    count: [u64; 5],
    first: [Option<Site>; 5],
}

/// What a value that was not a finite number was replaced by.
#[derive(Clone, Copy, Debug)]
enum Fallback {
    /// An adjustment argument that was NaN: 0.
    NanArgument,
    /// An adjustment argument that was infinite: 0.
    InfiniteArgument,
    /// A definition weight: 0.
    Weight,
    /// A function selector's value: the first definition.
    Selector,
    /// A NaN iterator count: no runs.
    Count,
}

/// Where a fallback happened: in an adjustment list (a dynamic transform), a rule's
/// selection, or an op.
#[derive(Clone, Copy, Debug)]
enum Site {
    Transform(u32),
    Rule(u32),
    Op(u32),
}

impl NonFinite {
    #[cold]
    #[inline(never)]
    fn note(&mut self, what: Fallback, at: Site) {
        let k = what as usize;
        self.count[k] += 1;
        self.first[k].get_or_insert(at);
    }

    /// An adjustment argument `v` of transform `xf` that is not finite.
    #[cold]
    #[inline(never)]
    fn argument(&mut self, xf: u32, v: f64) {
        let what = if v.is_nan() { Fallback::NanArgument } else { Fallback::InfiniteArgument };
        self.note(what, Site::Transform(xf));
    }

    /// The warnings for what was noted, each naming the rule and line of its first
    /// occurrence.
    fn warnings(&self, b: &Bundle) -> Vec<String> {
        let op_at = |pc: usize| where_op(b, pc as u32);
        let at = |site: Site| match site {
            Site::Transform(xf) => b
                .code
                .iter()
                .position(|op| match *op {
                    Op::Call { xf: x, .. } | Op::Draw { xf: x, .. } | Op::Iso { xf: x, .. } => x == xf,
                    Op::Loop { step, .. } | Op::LoopN { step, .. } => step == xf,
                    _ => false,
                })
                .map(op_at)
                .unwrap_or_default(),
            Site::Rule(r) => b
                .rules
                .get(r as usize)
                .map(|rule| match rule.defs.first() {
                    Some(d) => where_op(b, d.start),
                    None => format!(" in rule `{}`", b.string(rule.name)),
                })
                .unwrap_or_default(),
            Site::Op(pc) => op_at(pc as usize),
        };
        let mut w = Vec::new();
        for (k, (&n, first)) in self.count.iter().zip(&self.first).enumerate() {
            let Some(site) = *first else { continue };
            let at = at(site);
            w.push(match k {
                0 => format!(
                    "{n} adjustment argument(s) computed as NaN (not a number: `0/0`, `log(-1)`, `sqrt(-1)`…){at}: used as 0"
                ),
                1 => format!(
                    "{n} adjustment argument(s) computed as infinite (an overflow or a division by 0){at}: used as 0"
                ),
                2 => format!("{n} definition weight(s) computed as NaN or infinite{at}: used as 0"),
                3 => format!(
                    "{n} selector function value(s) computed as NaN or infinite{at}: the first definition was chosen"
                ),
                _ => format!("{n} iterator count(s) computed as NaN{at}: no runs"),
            });
        }
        w
    }
}

#[inline]
fn eval_transform(
    b: &Bundle,
    xf: u32,
    rng: &mut Pcg,
    stack: &mut Vec<f64>,
    env: &Env,
    bad: &mut NonFinite,
) -> Composite {
    match &b.transforms[xf as usize] {
        Transform::Const(c) => *c,
        Transform::Dynamic { adjs, divisor } => {
            // As `compose_prims` over the evaluated arguments (same operations, same
            // order of random draws), without building the argument lists.
            let mut f = Affine::identity();
            let mut c = Composite::IDENTITY;
            for a in adjs {
                let mut vals = [0.0f32; 3];
                for (v, arg) in vals.iter_mut().zip(&a.args) {
                    *v = match arg {
                        bundle::Arg::Const(v) => *v,
                        bundle::Arg::Expr(e) => {
                            let code: &[ExprOp] = &b.exprs[*e as usize];
                            let v = env.eval(code, rng, stack);
                            if v.is_finite() {
                                v as f32
                            } else {
                                bad.argument(xf, v);
                                0.0
                            }
                        }
                    };
                }
                apply_prim(&mut f, &mut c, a.kind, a.axis, &vals, a.args.len(), *divisor);
            }
            set_frame(&mut c, &f);
            c
        }
    }
}

/// The weights of definitions computed per call (`rule leaf(int n) (1 / (n + 1))`):
/// which rules have any, and room for one call's values.
struct Weights {
    /// Per rule, its definitions' constant weights (what a selector reads unless the
    /// rule has weight expressions).
    constant: Vec<Vec<f32>>,
    dynamic: Vec<bool>,
    values: Vec<f32>,
}

impl Weights {
    fn new(b: &Bundle) -> Weights {
        let constant = b.rules.iter().map(|r| r.defs.iter().map(|d| d.weight).collect()).collect();
        let dynamic = b.rules.iter().map(|r| r.defs.iter().any(|d| d.weight_expr != NONE)).collect();
        Weights { constant, dynamic, values: Vec::new() }
    }
}

/// Picks the definition of `rule_idx` its selector chooses for a call in state `child`
/// at `depth`; returns its first op.
#[allow(clippy::too_many_arguments)]
fn select_def(
    b: &Bundle,
    rule_idx: u32,
    child: &State,
    depth: u32,
    args: &[f64],
    rng: &mut Pcg,
    sequential: &mut HashMap<u32, (usize, u32)>,
    stack: &mut Vec<f64>,
    weights: &mut Weights,
    bad: &mut NonFinite,
) -> u32 {
    let rule = &b.rules[rule_idx as usize];
    let defs = &rule.defs;
    if defs.len() == 1 {
        return defs[0].start;
    }
    let p = child.f.u;
    let vars = || [p.x as f64, p.y as f64, p.z as f64, depth as f64, child.scale() as f64, 0.0];
    // Weights over the parameters, each evaluated once per call, in definition order
    // (so `rand()` in a weight draws the same numbers whichever definition wins).
    let dynamic = weights.dynamic.get(rule_idx as usize).copied().unwrap_or(false);
    if dynamic {
        weights.values.clear();
        let vars = vars();
        for d in defs {
            let w = match b.exprs.get(d.weight_expr as usize) {
                Some(code) if d.weight_expr != NONE => {
                    let v = expr::eval(code, &vars, args, rng, stack);
                    if v.is_finite() {
                        v as f32
                    } else {
                        bad.note(Fallback::Weight, Site::Rule(rule_idx));
                        0.0
                    }
                }
                _ => d.weight,
            };
            weights.values.push(w);
        }
    }
    // (The function selector's value is drawn here, after the weights, as before.)
    let function = match rule.selector {
        Selector::Function(e) => {
            let v = expr::eval(&b.exprs[e as usize], &vars(), args, rng, stack);
            if !v.is_finite() {
                bad.note(Fallback::Selector, Site::Rule(rule_idx));
            }
            v
        }
        _ => 0.0,
    };
    let w = if dynamic { &weights.values } else { &weights.constant[rule_idx as usize] };
    let i = pick(w, rule, rule_idx, child, depth, function, rng, sequential);
    defs[i].start
}

/// The index of the definition `rule`'s selector picks, with `w[i]` the weight of
/// definition `i` and `function` the value of a function selector.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn pick(
    w: &[f32],
    rule: &bundle::Rule,
    rule_idx: u32,
    child: &State,
    depth: u32,
    function: f64,
    rng: &mut Pcg,
    sequential: &mut HashMap<u32, (usize, u32)>,
) -> usize {
    let n = w.len();
    // The first index whose weight `better` prefers to every other one's.
    let first_best = |better: fn(f32, f32) -> bool| (0..n).fold(0, |b, i| if better(w[i], w[b]) { i } else { b });
    let threshold = |v: f64| -> usize {
        // Smallest weight ≥ v, else the largest (SPEC resolved semantics 5).
        let mut best: Option<usize> = None;
        for (i, &x) in w.iter().enumerate() {
            if x as f64 >= v && best.is_none_or(|b| x < w[b]) {
                best = Some(i);
            }
        }
        best.unwrap_or_else(|| first_best(|a, b| a > b))
    };
    match rule.selector {
        Selector::Random => {
            let total: f64 = w.iter().map(|x| x.max(0.0) as f64).sum();
            if total <= 0.0 {
                0
            } else {
                let r = rng.uniform() * total;
                let mut acc = 0.0;
                let mut pick = n - 1;
                for (i, x) in w.iter().enumerate() {
                    acc += x.max(0.0) as f64;
                    if r < acc {
                        pick = i;
                        break;
                    }
                }
                pick
            }
        }
        Selector::Depth => threshold(depth as f64),
        Selector::Scale => {
            let s = child.scale() as f64;
            let mut best: Option<usize> = None;
            for (i, &x) in w.iter().enumerate() {
                if (x as f64) <= s && best.is_none_or(|b| x > w[b]) {
                    best = Some(i);
                }
            }
            best.unwrap_or_else(|| first_best(|a, b| a < b))
        }
        Selector::Sequential => {
            let entry = sequential.entry(rule_idx).or_insert((0, 0));
            // Skip definitions with a zero count (at most one full cycle).
            for _ in 0..n {
                if (w[entry.0].max(0.0) as u32) > entry.1 {
                    break;
                }
                *entry = ((entry.0 + 1) % n, 0);
            }
            let i = entry.0;
            entry.1 += 1;
            if entry.1 >= w[i].max(0.0) as u32 {
                *entry = ((i + 1) % n, 0);
            }
            i
        }
        Selector::Pattern => {
            let entry = sequential.entry(rule_idx).or_insert((0, 0));
            let i = entry.0 % n;
            entry.0 = (i + 1) % n;
            i
        }
        Selector::Function(_) => {
            if function.is_finite() {
                threshold(function)
            } else {
                0
            }
        }
    }
}

/// Composes primitive adjustments (constant arguments) into one composite, each
/// argument divided into `divisor` steps (scale: the divisor-th root; flips kept).
/// The compiler folds constant lists with this same function, so run-time and
/// compile-time composites agree bit for bit.
pub fn compose_prims(prims: &[bundle::PrimAdj], divisor: f32) -> Composite {
    let mut f = Affine::identity();
    let mut c = Composite::IDENTITY;
    for p in prims {
        let mut vals = [0.0f32; 3];
        for (v, a) in vals.iter_mut().zip(&p.args) {
            if let bundle::Arg::Const(x) = a {
                *v = *x;
            }
        }
        apply_prim(&mut f, &mut c, p.kind, p.axis, &vals, p.args.len(), divisor);
    }
    set_frame(&mut c, &f);
    c
}

/// The frame of a composite (without its non-uniform factor, [`Composite::n`]).
#[inline]
fn composite_frame(c: &Composite) -> Frame {
    Frame { q: Quat::from_array(c.q), qh: Quat::from_array(c.qh), u: Vec3::from_array(c.u) }
}

/// Stores `a` in composite `c`.
fn set_frame(c: &mut Composite, a: &Affine) {
    c.q = a.f.q.to_array();
    c.qh = a.f.qh.to_array();
    c.u = a.f.u.to_array();
    c.n = a.n.map(|n| n.to_cols_array());
}

/// Applies HSB adjustments `h` (see [`Composite::hsb`]) to an RGBA colour: the colour
/// is clamped to 0..1 (HSB is defined there), converted to hue, saturation and
/// brightness (HSV), adjusted, and converted back. Alpha is kept.
fn apply_hsb(c: [f32; 4], h: &[f32; 5]) -> [f32; 4] {
    let [r, g, b] = [c[0], c[1], c[2]].map(|v| v.clamp(0.0, 1.0));
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let d = max - min;
    let hue = if d <= 0.0 {
        0.0
    } else if max == r {
        60.0 * ((g - b) / d).rem_euclid(6.0)
    } else if max == g {
        60.0 * ((b - r) / d + 2.0)
    } else {
        60.0 * ((r - g) / d + 4.0)
    };
    let sat = if max > 0.0 { d / max } else { 0.0 };
    let hue = (hue + h[0]).rem_euclid(360.0);
    let sat = (sat * h[1] + h[2]).clamp(0.0, 1.0);
    let v = (max * h[3] + h[4]).clamp(0.0, 1.0);
    // HSV to RGB.
    let k = |n: f32| {
        let k = (n + hue / 60.0).rem_euclid(6.0);
        v - v * sat * k.min(4.0 - k).clamp(0.0, 1.0)
    };
    [k(5.0), k(3.0), k(1.0), c[3]]
}

/// Composes the affine channel map `(m, a)` (`v ↦ m v + a`) after the one at `h[i..i+2]`.
fn then_affine(h: &mut [f32; 5], i: usize, m: f32, a: f32) {
    h[i + 1] = m * h[i + 1] + a;
    h[i] *= m;
}

/// Applies one primitive adjustment with argument values `args` (`n_args` of them
/// given; missing ones are 0) to the frame `f` and the deltas `c` (see [`compose_prims`]).
#[inline]
fn apply_prim(
    f: &mut Affine,
    c: &mut Composite,
    kind: bundle::AdjOp,
    axis: u8,
    args: &[f32; 3],
    n_args: usize,
    divisor: f32,
) {
    let arg = |i: usize| if i < n_args { args[i] } else { 0.0 };
    use bundle::AdjOp;
    match kind {
        AdjOp::Translate => {
            let v = match axis {
                0 => Vec3::new(arg(0), 0.0, 0.0),
                1 => Vec3::new(0.0, arg(0), 0.0),
                2 => Vec3::new(0.0, 0.0, arg(0)),
                _ => Vec3::new(arg(0), arg(1), arg(2)),
            };
            *f = f.translate(v / divisor);
        }
        AdjOp::Rotate => {
            let axes = [Vec3::X, Vec3::Y, Vec3::Z];
            if axis == 3 {
                for (i, a) in axes.iter().enumerate().take(n_args.min(3)) {
                    *f = f.rotate(Quat::from_axis_angle(*a, arg(i) / divisor));
                }
            } else {
                *f = f.rotate(Quat::from_axis_angle(axes[axis as usize % 3], arg(0) / divisor));
            }
        }
        AdjOp::Scale => {
            let root = |s: f32| if divisor == 1.0 { s } else { s.signum() * s.abs().powf(1.0 / divisor) };
            *f = if n_args >= 2 {
                // `s X Y [Z]` (Z defaults to 1, as Context Free's `s X Y`).
                let z = if n_args >= 3 { arg(2) } else { 1.0 };
                f.scale3(Vec3::new(root(arg(0)), root(arg(1)), root(z)))
            } else {
                f.scale(root(arg(0)))
            };
        }
        AdjOp::Flip => {
            let n = match axis {
                0 => Vec3::X,
                1 => Vec3::Y,
                2 => Vec3::Z,
                _ => Vec3::new(arg(0), arg(1), arg(2)),
            };
            *f = f.reflect(n);
        }
        AdjOp::Color => c.color[axis as usize & 3] += arg(0) / divisor,
        AdjOp::Hsb => {
            // Hue, saturation (axis 1) or brightness (axis 2), Context Free's
            // semantics: `hue h` adds h degrees; `sat s`/`b s` with s in -1..1 move the
            // channel the fraction s of the way to 1 (s > 0) or to 0 (s < 0). An
            // iterator's step is the divisor-th root of that map, so the steps of
            // `M/N * {sat s}` compose to exactly `sat s`.
            let h = c.hsb.get_or_insert(bundle::HSB_IDENTITY);
            if axis == 0 {
                h[0] += arg(0) / divisor;
            } else {
                let s = arg(0).clamp(-1.0, 1.0);
                let keep = if divisor == 1.0 { 1.0 - s.abs() } else { (1.0 - s.abs()).powf(1.0 / divisor) };
                let i = if axis == 1 { 1 } else { 3 };
                then_affine(h, i, keep, if s > 0.0 { 1.0 - keep } else { 0.0 });
            }
        }
        AdjOp::Weight => c.weight[axis as usize & 3] += arg(0) / divisor,
        AdjOp::Fps => c.fps += arg(0) / divisor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn affine(c: &Composite) -> Affine {
        Affine { f: composite_frame(c), n: c.n.map(|n| Mat3::from_cols_array(&n)) }
    }

    fn close(a: [f32; 4], b: [f32; 4]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    fn hsb(kind_axis: &[(u8, f32)], divisor: f32) -> [f32; 5] {
        let prims: Vec<bundle::PrimAdj> = kind_axis
            .iter()
            .map(|&(axis, v)| bundle::PrimAdj { kind: bundle::AdjOp::Hsb, axis, args: vec![bundle::Arg::Const(v)] })
            .collect();
        compose_prims(&prims, divisor).hsb.expect("an HSB part")
    }

    #[test]
    fn hue_turns_and_saturation_and_brightness_move_toward_their_ends() {
        let red = [1.0, 0.0, 0.0, 1.0];
        assert!(close(apply_hsb(red, &hsb(&[(0, 120.0)], 1.0)), [0.0, 1.0, 0.0, 1.0]));
        assert!(close(apply_hsb(red, &hsb(&[(0, -120.0)], 1.0)), [0.0, 0.0, 1.0, 1.0]));
        // Brightness halfway to 0, then saturation halfway to 0 (Context Free's `b -0.5 sat -0.5`).
        assert!(close(apply_hsb(red, &hsb(&[(2, -0.5)], 1.0)), [0.5, 0.0, 0.0, 1.0]));
        assert!(close(apply_hsb(red, &hsb(&[(1, -0.5)], 1.0)), [1.0, 0.5, 0.5, 1.0]));
        // White has no hue; saturating it toward 1 gives red (hue 0).
        assert!(close(apply_hsb([1.0; 4], &hsb(&[(0, 77.0)], 1.0)), [1.0; 4]));
        assert!(close(apply_hsb([1.0; 4], &hsb(&[(1, 1.0)], 1.0)), [1.0, 0.0, 0.0, 1.0]));
        // Alpha is kept; out-of-range channels are clamped first.
        assert!(close(apply_hsb([2.0, -1.0, 0.0, 0.25], &hsb(&[(0, 0.0)], 1.0)), [1.0, 0.0, 0.0, 0.25]));
    }

    #[test]
    fn a_list_of_hsb_changes_folds_into_one_and_iterator_steps_compose_to_the_whole() {
        // Two `sat 0.5` in a row: 0 → 0.5 → 0.75.
        let h = hsb(&[(1, 0.5), (1, 0.5)], 1.0);
        assert!((h[1] * 0.0 + h[2] - 0.75).abs() < 1e-6);
        // Four steps of `4/4 * {b -0.5}`... each the 4th root: together exactly `b -0.5`.
        let whole = hsb(&[(2, -0.5)], 1.0);
        let step = hsb(&[(2, -0.5)], 4.0);
        let (mut m, mut a) = (1.0f32, 0.0f32);
        for _ in 0..4 {
            (m, a) = (step[3] * m, step[3] * a + step[4]);
        }
        assert!((m - whole[3]).abs() < 1e-6 && (a - whole[4]).abs() < 1e-6);
        let step = hsb(&[(1, 0.6)], 3.0);
        let (mut m, mut a) = (1.0f32, 0.0f32);
        for _ in 0..3 {
            (m, a) = (step[1] * m, step[1] * a + step[2]);
        }
        let whole = hsb(&[(1, 0.6)], 1.0);
        assert!((m - whole[1]).abs() < 1e-5 && (a - whole[2]).abs() < 1e-5);
    }

    #[test]
    fn a_non_uniform_scale_is_per_axis_and_its_steps_are_roots() {
        let prims = [bundle::PrimAdj {
            kind: bundle::AdjOp::Scale,
            axis: 0,
            args: vec![bundle::Arg::Const(8.0), bundle::Arg::Const(1.0), bundle::Arg::Const(27.0)],
        }];
        let f = affine(&compose_prims(&prims, 1.0));
        assert!((f.apply_vector(Vec3::X) - Vec3::new(8.0, 0.0, 0.0)).length() < 1e-5);
        assert!((f.apply_vector(Vec3::Z) - Vec3::new(0.0, 0.0, 27.0)).length() < 1e-4);
        let step = affine(&compose_prims(&prims, 3.0));
        let three = step.compose(&step).compose(&step);
        for v in [Vec3::X, Vec3::Y, Vec3::Z] {
            assert!((three.apply_vector(v) - f.apply_vector(v)).length() < 1e-4);
        }
        // `s X Y` leaves z alone.
        let two = [bundle::PrimAdj {
            kind: bundle::AdjOp::Scale,
            axis: 0,
            args: vec![bundle::Arg::Const(0.1), bundle::Arg::Const(1.0)],
        }];
        let g = affine(&compose_prims(&two, 1.0));
        assert!((g.apply_vector(Vec3::new(1.0, 1.0, 1.0)) - Vec3::new(0.1, 1.0, 1.0)).length() < 1e-6);
    }
}
