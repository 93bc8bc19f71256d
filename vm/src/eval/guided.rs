//! Guided search's expansion: one rule body run to the calls it makes, without
//! recursing ([`Expander`], [`Call`]).

use super::*;

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
        Call { rule: b.settings.startshape, state: State::start_in(&b.settings), depth: 0 }
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
    /// The evaluator whose interpreter loop runs the bodies (with a [`Collect`]
    /// sink): its random stream, selection state, expression stack and frame slots.
    /// (The compiler rejects skeleton rules with parameters and calls from them that
    /// pass arguments, so the body's frame holds its defaults.)
    pub(super) e: Eval<'b>,
}

impl<'b> Expander<'b> {
    /// An expander over `b`, with the stream of [`Expander::reseed`]`(0, 0)`.
    pub fn new(b: &'b Bundle) -> Expander<'b> {
        let mut x = Expander { e: Eval::new(b, &EvalOptions::default(), None) };
        x.reseed(0, 0);
        x
    }

    /// The fallbacks the expansions so far used for computed values that were NaN or
    /// infinite (adjustment arguments, weights, selector values, counts), as
    /// warnings naming the rule and line; empty if none.
    pub fn warnings(&self) -> Vec<String> {
        self.e.non_finite.warnings(self.e.b)
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
        self.e.rng = Pcg(Pcg64::new(state, inc));
    }

    /// A uniform number in [0, 1) from the stream (53 random bits).
    pub fn uniform(&mut self) -> f64 {
        self.e.rng.uniform()
    }

    /// A uniform index in `0..n` (`n` > 0; 0 when `n` is 0).
    pub fn index(&mut self, n: usize) -> usize {
        ((self.e.rng.uniform() * n as f64) as usize).min(n.saturating_sub(1))
    }

    /// Runs the body of `call` and appends the calls it makes to `out`, in the order
    /// the body makes them. Returns `false` when the body was cut at
    /// [`MAX_EXPANSION_CALLS`] calls and iterator runs.
    pub fn expand(&mut self, call: &Call, out: &mut Vec<Call>) -> bool {
        let e = &mut self.e;
        e.slots.clear();
        e.sequential.clear();
        e.last = call.state;
        let mut sink = Collect { out, made: 0, cut: false };
        e.interpret(&mut sink, call.rule, call.state, call.depth, Mode::Model);
        !sink.cut
    }
}
