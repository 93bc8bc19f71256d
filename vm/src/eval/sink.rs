//! The variation points of the one interpreter loop ([`Eval::interpret`]) and its
//! registers: which run is which is a type ([`Sink`]), so the loop is compiled once
//! per kind of run with every check that does not apply removed at compile time.
//!
//! | sink | sites | fast path | calls |
//! |---|---|---|---|
//! | [`Plain`] | no | no | run |
//! | [`Sited`] | recorded | no | run |
//! | [`Simple`] | no | yes | run |
//! | [`Collect`] | no | no | collected, not run (guided search) |
//! | [`Queue`] | either | no | queued, run breadth first (`breadthfirst`) |

use super::*;

/// What a kind of run changes in the interpreter loop.
pub(super) trait Sink {
    /// Each op's source site and the derivation tree are recorded (those asked for).
    const SITES: bool = false;
    /// The bundle passed [`fast_path_applies`] and the run is a model run: no
    /// parameter slots, bones, convolutions or non-uniform scales, and every `INST`
    /// is an instance, so none of their checks is made.
    const SIMPLE: bool = false;
    /// [`Sink::SIMPLE`], and no call or iterator changes anything but the frame
    /// (see [`lean_path_applies`]): the callers' activations are only their frame,
    /// program counter and depth ([`LeanAct`]), and a call composes only the frame.
    const LEAN: bool = false;
    /// Calls are handed to [`Sink::call`] instead of being run, and nothing is
    /// drawn: the body of the first activation only (the guided search's skeleton).
    const COLLECTS: bool = false;
    /// Calls are queued ([`Sink::enqueue`]) and run later, breadth first: the body
    /// of the first activation only, which starts with [`Sink::start_args`].
    const QUEUES: bool = false;

    /// A call the body makes, with its state and depth (only when
    /// [`Sink::COLLECTS`]); `false` ends the run.
    #[inline]
    fn call(&mut self, _rule: RuleId, _state: &State, _depth: u32) -> bool {
        true
    }

    /// How many calls wait in the queue (only when [`Sink::QUEUES`]): the bound
    /// `stacksize` puts on them.
    #[inline]
    fn pending(&self) -> usize {
        0
    }

    /// An admitted call, its state, depth, bone, arguments and its path's counts
    /// of retiring definitions (only when [`Sink::QUEUES`]).
    #[inline]
    fn enqueue(&mut self, _rule: RuleId, _state: &State, _depth: u32, _bone: u32, _args: &[f64], _path: &[u32]) {}

    /// The derivation node of the caller of the call queued next (only when
    /// [`Sink::QUEUES`] and the tree is recorded).
    #[inline]
    fn caller_node(&mut self, _node: u32) {}

    /// The derivation node of the call the run starts with's caller (NONE: a root).
    #[inline]
    fn parent_node(&self) -> u32 {
        NONE
    }

    /// A seeded call's stream (`seed N`), for the call queued next (only when
    /// [`Sink::QUEUES`]): that call's sub-tree draws from it.
    #[inline]
    fn seed_next(&mut self, _stream: Pcg) {}

    /// The arguments and bone of the call the run starts with (only when
    /// [`Sink::QUEUES`]; otherwise the parameters take their defaults, bone 0).
    #[inline]
    fn start_args(&self) -> Option<(&[f64], u32)> {
        None
    }

    /// Before an iterator's next run (only when [`Sink::COLLECTS`]); `false` ends
    /// the run.
    #[inline]
    fn next_run(&mut self) -> bool {
        true
    }
}

/// The general loop, recording nothing.
pub(super) struct Plain;
impl Sink for Plain {}

/// The general loop, recording sites and the derivation tree (those asked for).
pub(super) struct Sited;
impl Sink for Sited {
    const SITES: bool = true;
}

/// The constant-transform fast path (see [`fast_path_applies`]).
pub(super) struct Simple;
impl Sink for Simple {
    const SIMPLE: bool = true;
}

/// The fast path where only frames change (see [`Sink::LEAN`]).
pub(super) struct Lean;
impl Sink for Lean {
    const SIMPLE: bool = true;
    const LEAN: bool = true;
}

/// The guided search's expansion: the calls one body makes, in order, at most
/// [`MAX_EXPANSION_CALLS`] calls and iterator runs (then `cut` is set).
pub(super) struct Collect<'o> {
    pub(super) out: &'o mut Vec<Call>,
    pub(super) made: usize,
    pub(super) cut: bool,
}

impl Collect<'_> {
    /// Counts one call or iterator run; `false` (and `cut`) past the limit.
    #[inline]
    fn count(&mut self) -> bool {
        if self.made >= MAX_EXPANSION_CALLS {
            self.cut = true;
            return false;
        }
        self.made += 1;
        true
    }
}

impl Sink for Collect<'_> {
    const COLLECTS: bool = true;

    #[inline]
    fn call(&mut self, rule: RuleId, state: &State, depth: u32) -> bool {
        if !self.count() {
            return false;
        }
        self.out.push(Call { rule: rule.0, state: *state, depth });
        true
    }

    #[inline]
    fn next_run(&mut self) -> bool {
        self.count()
    }
}

/// The interpreter loop's registers: the running activation and its callers, the
/// continuation register, the open iterators, and the derivation nodes.
pub(super) struct Regs {
    pub(super) act: Act,
    /// The running activation's callers.
    pub(super) stack: Vec<Act>,
    /// The running activation's callers under [`Sink::LEAN`] (`stack` is unused),
    /// but those that made a tail call.
    pub(super) lean: Vec<Caller>,
    /// The depth of the run's first activation.
    pub(super) start_depth: u32,
    /// Under [`Sink::LEAN`], the run's instances' fields but frame and mesh (the
    /// start state's colour, the run's bone, no non-uniform factor, the mesh's
    /// vertex count, none of which a lean run changes), and whether they carry no
    /// weights (the start's are zero and none was recorded before).
    pub(super) fixed: Option<(Fixed, bool)>,
    /// The running activation's bone (0 = the root): vertices emitted there carry it.
    pub(super) bone: u32,
    /// The callers' bones, where a call made a new one: (the callee's level, its
    /// caller's bone).
    pub(super) bones: Vec<(u32, u32)>,
    /// The activations that run a convolution rule's body once per frame.
    pub(super) convs: Vec<Conv>,
    /// The value of a `SEED` op, for the `CALL` that follows it.
    pub(super) seed: Option<f64>,
    /// The callers' random streams and sequential-selection counters, where a call
    /// was seeded (`seed N`): (the callee's level, what its return restores).
    pub(super) seeds: Vec<(u32, Reseeded)>,
    /// The levels of the activations that run as subpaths (a path's call of a
    /// path, `CALL` flag [`crate::bundle::SUBPATH`]).
    pub(super) subpaths: Vec<u32>,
    /// The continuation state after `\`: set by CONT and taken by the next item of
    /// the same body (a call takes it before its callee runs, so one register serves
    /// every activation).
    pub(super) cont: Option<State>,
    pub(super) lin_cache: LinCache,
    pub(super) loops: Vec<LoopRec>,
    /// The derivation node of the running activation, and those of its callers
    /// (with [`Sink::SITES`]).
    pub(super) node: u32,
    pub(super) nodes: Vec<u32>,
    /// `maxdepth` (0: none) as the depth past which calls are refused.
    pub(super) maxdepth: u32,
    /// Whether the derivation tree is recorded.
    pub(super) tree: bool,
    pub(super) mode: Mode,
}
