//! Which particle a search returns as its model ([`ModelChoice`]), and the
//! candidates it keeps from generation to generation for that choice.
//!
//! A particle's *reach* is how many utilisation segments of the guides its bones
//! have used (a count above 0): the part of the guides its skeleton credits. The
//! lowest COST alone favours early, sparse skeletons (few bones that each collect a
//! fresh segment), so the default returns the last generation's best instead when
//! it reaches farther ([`ModelChoice::Wider`]; measured in docs/guided.md, "The
//! returned model"; docs/decisions.md).

use super::Particle;

/// How the search picks the model among the particles it saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModelChoice {
    /// The particle with the lowest COST seen after any generation (the earliest of
    /// equal ones).
    LowestCost,
    /// The final generation's lowest COST (the paper's).
    Last,
    /// Of [`ModelChoice::LowestCost`]'s model and [`ModelChoice::Last`]'s, the one
    /// whose reach is larger (on a tie, the lower COST).
    Wider,
    /// The lowest COST among the particles whose reach is at least `share` of the
    /// largest reach seen (0 < share ≤ 1); candidates are, per generation, the
    /// lowest-COST particle and the widest-reaching one, and the final generation.
    Reach(f64),
}

/// The share of the largest reach `reach` ([`ModelChoice::from_name`]) asks for.
pub const DEFAULT_REACH_SHARE: f64 = 0.9;

/// The default, [`ModelChoice::Wider`] (chosen by measurement: docs/guided.md).
impl Default for ModelChoice {
    fn default() -> ModelChoice {
        ModelChoice::Wider
    }
}

impl ModelChoice {
    /// Its name on the command line of the evaluation tools: `lowest`, `last`,
    /// `reach` (the default share) or `reach:SHARE`.
    pub fn from_name(s: &str) -> Option<ModelChoice> {
        match s {
            "lowest" => Some(ModelChoice::LowestCost),
            "last" => Some(ModelChoice::Last),
            "wider" => Some(ModelChoice::Wider),
            "reach" => Some(ModelChoice::Reach(DEFAULT_REACH_SHARE)),
            _ => {
                let share: f64 = s.strip_prefix("reach:")?.parse().ok()?;
                (share > 0.0 && share <= 1.0).then_some(ModelChoice::Reach(share))
            }
        }
    }
}

/// Utilisation segments a particle has used.
pub(super) fn reach(p: &Particle) -> u32 {
    p.counts.iter().filter(|&&c| c > 0).count() as u32
}

/// A kept particle: its COST, reach and generation.
pub(super) struct Candidate {
    pub cost: f64,
    pub reach: u32,
    pub generation: u32,
    pub particle: Particle,
}

/// The particles kept for the choice.
pub(super) struct Kept {
    choice: ModelChoice,
    list: Vec<Candidate>,
}

impl Kept {
    pub fn new(choice: ModelChoice) -> Kept {
        Kept { choice, list: Vec::new() }
    }

    /// Indices (into `costs`/`reaches`, one per particle of generation `generation`)
    /// of the particles worth keeping; the caller clones them into [`Kept::keep`].
    pub fn wanted(&self, costs: &[f64], reaches: &[u32]) -> Vec<usize> {
        let low = first_min(costs.iter().copied().enumerate());
        match self.choice {
            ModelChoice::Last => Vec::new(),
            ModelChoice::LowestCost | ModelChoice::Wider => low
                .filter(|&(_, c)| self.list.first().is_none_or(|b| c < b.cost))
                .map(|(k, _)| vec![k])
                .unwrap_or_default(),
            ModelChoice::Reach(_) => {
                // The widest reach, the lowest COST among equal reaches.
                let top = reaches.iter().copied().max().unwrap_or(0);
                let wide = first_min(costs.iter().copied().enumerate().filter(|&(k, _)| reaches[k] == top));
                let mut v: Vec<usize> = low.into_iter().chain(wide).map(|(k, _)| k).collect();
                v.dedup();
                v.retain(|&k| !self.dominated(costs[k], reaches[k]));
                v
            }
        }
    }

    /// Whether a kept candidate costs no more and reaches as far.
    fn dominated(&self, cost: f64, reach: u32) -> bool {
        self.list.iter().any(|c| c.cost <= cost && c.reach >= reach)
    }

    /// Keeps `c` (one that [`Kept::wanted`] asked for).
    pub fn keep(&mut self, c: Candidate) {
        match self.choice {
            ModelChoice::Last => {}
            ModelChoice::LowestCost | ModelChoice::Wider => self.list = vec![c],
            ModelChoice::Reach(_) => {
                if self.dominated(c.cost, c.reach) {
                    return;
                }
                self.list.retain(|k| !(c.cost <= k.cost && c.reach >= k.reach));
                self.list.push(c);
            }
        }
    }

    /// The kept particles (they refer to the store of pending calls: compaction
    /// rewrites them too).
    pub fn particles_mut(&mut self) -> impl Iterator<Item = &mut Particle> {
        self.list.iter_mut().map(|c| &mut c.particle)
    }

    /// Pending calls the kept particles refer to.
    pub fn pending(&self) -> usize {
        self.list.iter().map(|c| c.particle.pending.len()).sum()
    }

    /// The model among the kept particles and the final generation's (`finals`, of
    /// generation `generation`): `Ok(kept particle, its generation)` or `Err(index
    /// into finals)`. `None` when there is neither.
    pub fn choose<'a>(&'a self, finals: &[&Particle]) -> Option<Result<(&'a Particle, u32), usize>> {
        let final_costs: Vec<f64> = finals.iter().map(|p| p.cost.total()).collect();
        let last = first_min(final_costs.iter().copied().enumerate());
        match self.choice {
            ModelChoice::Last => last.map(|(k, _)| Err(k)),
            ModelChoice::Wider => match (self.list.first(), last) {
                (Some(b), Some((k, c))) => {
                    let (rb, rl) = (reach(&b.particle), reach(finals[k]));
                    if rl > rb || (rl == rb && c <= b.cost) {
                        Some(Err(k))
                    } else {
                        Some(Ok((&b.particle, b.generation)))
                    }
                }
                (Some(b), None) => Some(Ok((&b.particle, b.generation))),
                (None, Some((k, _))) => Some(Err(k)),
                (None, None) => None,
            },
            ModelChoice::LowestCost => match (self.list.first(), last) {
                (Some(b), Some((_, c))) if b.cost < c => Some(Ok((&b.particle, b.generation))),
                (Some(b), None) => Some(Ok((&b.particle, b.generation))),
                (_, Some((k, _))) => Some(Err(k)),
                (None, None) => None,
            },
            ModelChoice::Reach(share) => {
                let final_reach: Vec<u32> = finals.iter().map(|p| reach(p)).collect();
                let top = self.list.iter().map(|c| c.reach).chain(final_reach.iter().copied()).max()?;
                let enough = |r: u32| r as f64 >= share * top as f64;
                let kept =
                    first_min(self.list.iter().enumerate().filter(|(_, c)| enough(c.reach)).map(|(i, c)| (i, c.cost)));
                let fin = first_min(final_costs.iter().copied().enumerate().filter(|&(k, _)| enough(final_reach[k])));
                match (kept, fin) {
                    (Some((i, c)), Some((_, f))) if c <= f => {
                        let k = &self.list[i];
                        Some(Ok((&k.particle, k.generation)))
                    }
                    (Some((i, _)), None) => {
                        let k = &self.list[i];
                        Some(Ok((&k.particle, k.generation)))
                    }
                    (_, Some((k, _))) => Some(Err(k)),
                    (None, None) => None,
                }
            }
        }
    }
}

/// The first (index, value) with the smallest value; NaN never wins.
fn first_min(it: impl Iterator<Item = (usize, f64)>) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (k, c) in it {
        if c.is_nan() {
            continue;
        }
        if best.is_none_or(|(_, b)| c < b) {
            best = Some((k, c));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn choices_parse_by_name() {
        assert_eq!(ModelChoice::from_name("lowest"), Some(ModelChoice::LowestCost));
        assert_eq!(ModelChoice::from_name("last"), Some(ModelChoice::Last));
        assert_eq!(ModelChoice::from_name("reach"), Some(ModelChoice::Reach(DEFAULT_REACH_SHARE)));
        assert_eq!(ModelChoice::from_name("reach:0.75"), Some(ModelChoice::Reach(0.75)));
        for bad in ["reach:0", "reach:1.5", "reach:x", "best"] {
            assert_eq!(ModelChoice::from_name(bad), None, "{bad}");
        }
    }

    #[test]
    fn first_min_skips_nan_and_keeps_the_first() {
        let v = [3.0, f64::NAN, 1.0, 1.0];
        assert_eq!(first_min(v.iter().copied().enumerate()), Some((2, 1.0)));
        assert_eq!(first_min(std::iter::empty()), None);
    }
}
