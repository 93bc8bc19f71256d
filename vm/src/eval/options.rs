//! The evaluator's options and default limits (docs/limits.md).

use super::*;

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

/// The colour a run starts with under the `flat` directive: Context Free's black.
pub const FLAT_START_COLOR: [f32; 4] = [0.0, 0.0, 0.0, 1.0];
/// How deeply transform rules may need each other's frames while being sampled
/// (each level is a nested evaluation on the native stack).
pub const MAX_TRACK_NESTING: usize = 64;
/// The deepest path of rule calls that gets a node of its own in the recorded
/// derivation ([`EvalOptions::record_derivation`]); deeper calls are counted in
/// the node at this depth.
pub const DERIVATION_MAX_DEPTH: u32 = 64;
/// The most nodes a recorded derivation has (a grammar whose rules alternate at
/// random has exponentially many paths); calls of further paths are counted in
/// their nearest node. At about 80 bytes a node in the editor's JSON, 100 KB.
pub const DERIVATION_MAX_NODES: usize = 1200;
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
    /// The limits on recursive function calls in one evaluation of an expression
    /// (`--max-call-depth`, `--max-calls`); past them the value is NaN, with a warning.
    pub calls: crate::expr::CallLimits,
    /// Sample transform rules far enough to pose the model at this time too (in
    /// seconds; `mdg-run --time`), when it is beyond `duration`.
    pub time: Option<f64>,
    /// Record which op drew each mesh and sweep triangle and each instance, at which
    /// derivation depth ([`crate::output::Sites`]). Sites are per triangle, so this
    /// also turns prototype instancing off.
    pub record_sites: bool,
    /// Record the tree of rule calls ([`crate::output::Derivation`]): calls and
    /// geometry per path of rules, aggregated. Off (the default) the evaluator runs
    /// the loop without any recording.
    pub record_derivation: bool,
    /// Emit one instance record per run of prototype items (`INST`) instead of their
    /// vertices (the default). Off, every item runs one by one: the output then has
    /// the same geometry with every prototype instance expanded in place (tests
    /// compare the two).
    pub instancing: bool,
    /// Asked with the budgets (every 4,096 calls): true stops the run at once, with
    /// no warning (the caller no longer wants it: the editor's preview after an edit).
    pub cancel: Option<Cancel>,
    /// The output keeps prototype instances as instances (a `.glb` written with
    /// `--instances`): each costs the vertex budget one (its record, as an
    /// isosurface instance does) instead of its expanded vertices. The counters
    /// (`Stats::vertices`) still count the vertices the instances stand for.
    pub instances_stored: bool,
}

/// A cancellation check for [`EvalOptions::cancel`].
#[derive(Clone)]
pub struct Cancel(pub std::sync::Arc<dyn Fn() -> bool + Send + Sync>);

impl std::fmt::Debug for Cancel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Cancel(..)")
    }
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
            calls: crate::expr::CallLimits::default(),
            time: None,
            record_sites: false,
            record_derivation: false,
            instancing: true,
            cancel: None,
            instances_stored: false,
        }
    }
}
