//! How far a grammar's skeletons get without guidance ([`Prepared::reach`]), for the
//! unreachable-guide warning (docs/guided.md, "Unreachable guides").

use super::{to_d, Prepared, Store};
use crate::measure::Reach;
use mdg_vm::eval::{Call, Expander};
use rayon::prelude::*;

/// Unguided derivations sampled for the reach.
pub const REACH_SAMPLES: u32 = 256;
/// The seed of the reach's samples: a property of the grammar, not of `--seed`.
const REACH_SEED: u64 = 0x5EED_4EAC_4000_0001;

impl Prepared<'_> {
    /// The farthest distance from the start shape's origin that any bone tip of
    /// `samples` unguided derivations reaches, each of at most `steps` particle-steps
    /// (the search's generations: a particle takes one step per generation). Forward
    /// samples follow the grammar's own odds, so this is what the grammar typically
    /// reaches at most, not a bound: a rarer derivation may get farther.
    /// Deterministic (fixed streams).
    pub fn reach(&self, samples: u32, steps: u32) -> Reach {
        let origin = to_d(Call::start(self.b).state.f.u);
        let radius = (0..samples)
            .into_par_iter()
            .map_init(
                || (Expander::new(self.b), Vec::with_capacity(16), Vec::with_capacity(8)),
                |(ex, out, items), i| {
                    let mut local = Vec::new();
                    let mut store = Store { frozen: &[], id: 0, local: &mut local };
                    let mut p = self.initial(&mut store);
                    ex.reseed(REACH_SEED, i as u64);
                    for _ in 0..steps {
                        if p.pending.is_empty() {
                            break;
                        }
                        self.step(&mut p, &mut store, ex, out, items, false);
                    }
                    let m = self.wrap_up(&p, &store);
                    m.bones.iter().map(|b| (b.tip - origin).length()).fold(0.0, f64::max)
                },
            )
            .reduce(|| 0.0, f64::max);
        Reach { origin, radius, samples, steps }
    }
}
