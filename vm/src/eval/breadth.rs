//! Breadth-first evaluation (`breadthfirst`, reference §3): calls wait in a queue
//! and run generation by generation, as Structure Synth grows a structure, instead
//! of depth first on the activation stack.
//!
//! A body runs as the first activation of [`Eval::interpret`] with the [`Queue`]
//! sink: every call it makes (admitted by `maxdepth`, `minsize`, `maxiter` and the
//! queue's bound, `stacksize`) is queued with its state, depth, bone and arguments,
//! not run; the queue is first in, first out, so a call at depth d runs after every
//! call at depth d − 1. The definition a queued call runs is picked when it leaves
//! the queue. A body that draws (a vertex, a prototype instance, a sweep, an
//! isosurface or a pen line) is one *object*; with `maxobjects N` the run ends at
//! the end of the generation in which the N-th object was drawn (the generation is
//! finished, as Structure Synth does, so a symmetric structure stays symmetric), and
//! the calls still queued are not run (a warning says how many). The derivation
//! tree is recorded as depth first (each queued call carries its caller's node).
//!
//! A seeded call (`seed N`) starts a stream of its own, a pure function of the
//! run's seed and N, with its own sequential-selection counters; every call its
//! sub-tree queues carries that stream's number, and a body runs on the stream it
//! carries. So a seeded sub-tree draws its numbers in its own breadth-first order,
//! whatever else the queue holds between its calls, and two calls with the same N
//! grow the same sub-tree, as depth first. Unseeded calls draw from the run's stream.

use super::*;
use std::collections::VecDeque;

/// Sequential-selection counters (as [`Eval`]'s).
pub(super) type Sequential = HashMap<u32, (usize, u32)>;

/// A call waiting in the queue.
pub(super) struct Pending {
    pub(super) rule: RuleId,
    pub(super) state: State,
    pub(super) depth: u32,
    pub(super) bone: u32,
    /// How many of the queue's `args` are this call's arguments.
    pub(super) nargs: u32,
    /// The seeded stream its sub-tree draws from (an index into
    /// [`Queue::streams`]), or NONE: the run's.
    pub(super) stream: u32,
    /// Its caller's derivation node (NONE: a root, or no tree recorded).
    pub(super) node: u32,
}

/// The sink of a breadth-first body: the calls it makes go into the queue. `SITES`
/// records each op's source site (and, with a tree recorded, each call's node).
#[derive(Default)]
pub(super) struct Queue<const SITES: bool> {
    pub(super) pending: VecDeque<Pending>,
    /// The queued calls' arguments, in queue order.
    pub(super) args: VecDeque<f64>,
    /// The queued calls' counts of retiring definitions on their paths (as many
    /// per call as the bundle has retiring definitions), in queue order.
    pub(super) paths: VecDeque<u32>,
    /// The arguments and bone of the call whose body is running.
    pub(super) current: Vec<f64>,
    pub(super) bone: u32,
    /// The seeded sub-trees' streams and sequential-selection counters.
    pub(super) streams: Vec<(Pcg, Sequential)>,
    /// The stream of the body running (NONE: the run's).
    pub(super) stream: u32,
    /// A seeded stream for the call queued next.
    pub(super) next: Option<Pcg>,
    /// The caller's derivation node for the call queued next, and the running
    /// call's caller's.
    pub(super) next_node: u32,
    pub(super) parent: u32,
}

impl<const SITES: bool> Sink for Queue<SITES> {
    const SITES: bool = SITES;
    const QUEUES: bool = true;

    #[inline]
    fn pending(&self) -> usize {
        self.pending.len()
    }

    #[inline]
    fn enqueue(&mut self, rule: RuleId, state: &State, depth: u32, bone: u32, args: &[f64], path: &[u32]) {
        self.args.extend(args.iter().copied());
        self.paths.extend(path.iter().copied());
        let stream = match self.next.take() {
            Some(rng) => {
                self.streams.push((rng, HashMap::new()));
                (self.streams.len() - 1) as u32
            }
            None => self.stream,
        };
        let node = std::mem::replace(&mut self.next_node, NONE);
        self.pending.push_back(Pending { rule, state: *state, depth, bone, nargs: args.len() as u32, stream, node });
    }

    #[inline]
    fn caller_node(&mut self, node: u32) {
        self.next_node = node;
    }

    #[inline]
    fn parent_node(&self) -> u32 {
        self.parent
    }

    #[inline]
    fn seed_next(&mut self, stream: Pcg) {
        self.next = Some(stream);
    }

    #[inline]
    fn start_args(&self) -> Option<(&[f64], u32)> {
        Some((&self.current, self.bone))
    }
}

/// Why a breadth-first run ended early under `maxobjects` (for the warning).
#[derive(Clone, Copy)]
pub(super) struct ObjectsReached {
    /// The generation (depth) whose calls were not run.
    pub(super) generation: u32,
    pub(super) objects: u64,
    pub(super) left: usize,
}

impl<'b> Eval<'b> {
    /// Runs a call of `rule` in state `start` at `depth` breadth first (see the
    /// module's documentation).
    pub(super) fn run_breadth(&mut self, rule: u32, start: State, depth: u32) {
        // (The derivation tree is recorded as depth first: each queued call
        // carries its caller's node.)
        if self.opts.record_sites || self.tree.is_some() {
            self.run_queue(&mut Queue::<true>::default(), rule, start, depth);
        } else {
            self.run_queue(&mut Queue::<false>::default(), rule, start, depth);
        }
    }

    fn run_queue<const SITES: bool>(&mut self, q: &mut Queue<SITES>, rule: u32, start: State, depth: u32) {
        let r = &self.b.rules[RuleId(rule)];
        let defaults: Vec<f64> = r.params.iter().map(|d| d.unwrap_or(0.0)).collect();
        let path = self.retire.counts.clone();
        q.stream = NONE;
        q.next_node = NONE;
        q.enqueue(RuleId(rule), &start, depth, 0, &defaults, &path);
        let maxobjects = self.b.settings.maxobjects;
        let mut generation = depth;
        let mut objects = 0u64;
        while let Some(p) = q.pending.pop_front() {
            if self.stopped || self.halt {
                break;
            }
            if p.depth > generation {
                generation = p.depth;
                if maxobjects > 0 && objects >= maxobjects {
                    let left = q.pending.len() + 1;
                    self.limits.objects = Some(ObjectsReached { generation, objects, left });
                    break;
                }
            }
            q.current.clear();
            let n = (p.nargs as usize).min(q.args.len());
            q.current.extend(q.args.drain(..n));
            q.bone = p.bone;
            for c in self.retire.counts.iter_mut() {
                *c = q.paths.pop_front().unwrap_or(0);
            }
            let before = self.vertices_made();
            // A seeded sub-tree's body runs on its stream, the run's put aside.
            q.stream = p.stream;
            q.parent = p.node;
            if let Some((rng, seq)) = q.streams.get_mut(p.stream as usize) {
                std::mem::swap(&mut self.rng, rng);
                std::mem::swap(&mut self.sequential, seq);
            }
            self.interpret(q, p.rule.0, p.state, p.depth, Mode::Model);
            if let Some((rng, seq)) = q.streams.get_mut(p.stream as usize) {
                std::mem::swap(&mut self.rng, rng);
                std::mem::swap(&mut self.sequential, seq);
            }
            if self.vertices_made() > before {
                objects += 1;
            }
        }
    }
}
