//! Seeded calls (`R {seed N}`, reference §6 "Randomness"): the sub-derivation of
//! such a call draws from a random stream that is a pure function of the run's
//! seed and N, and starts with fresh sequential-selection counters; when it
//! returns, the caller's stream and counters are put back, so the caller goes on as
//! if the call had drawn nothing. Two calls with the same N (and the same state and
//! arguments) therefore grow the same sub-tree, up to their frames.

use super::*;

/// What a seeded call's return restores: the caller's stream and counters.
pub(super) struct Reseeded {
    rng: Pcg,
    sequential: HashMap<u32, (usize, u32)>,
}

/// The stream of seed value `v` in a run of seed `run`: `v` as a 64-bit float
/// (−0 read as 0, so `seed 0` and `seed -0` agree), mixed with the run's seed.
pub(super) fn seeded_stream(run: u64, v: f64) -> Pcg {
    let v = if v == 0.0 { 0.0f64 } else { v };
    // SplitMix64's finaliser over both words: nearby seeds give unrelated streams.
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let s = mix(run ^ mix(v.to_bits().wrapping_add(0x9E37_79B9_7F4A_7C15)));
    Pcg(Pcg64::seed_from_u64(s))
}

impl<'b> Eval<'b> {
    /// Switches to the stream of seed value `v` with fresh sequential counters;
    /// returns what the seeded call's return restores.
    pub(super) fn reseed(&mut self, v: f64) -> Reseeded {
        let rng = std::mem::replace(&mut self.rng, seeded_stream(self.seed, v));
        Reseeded { rng, sequential: std::mem::take(&mut self.sequential) }
    }

    /// Where the activation at `level` was a seeded call's: puts the caller's stream
    /// and counters back.
    pub(super) fn unseed(&mut self, m: &mut Regs, level: u32) {
        if m.seeds.last().is_some_and(|&(l, _)| l == level) {
            if let Some((_, r)) = m.seeds.pop() {
                self.rng = r.rng;
                self.sequential = r.sequential;
            }
        }
    }
}
