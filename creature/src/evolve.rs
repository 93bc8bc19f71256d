//! Generations of monsters (paper Algorithm 1) with structure-based diversity
//! control, and the hierarchical diversity measure (HDM) used to evaluate it.
//!
//! Each generation: offspring are made from the current set (base shapes) and the
//! current ∪ background sets (assist shapes) — selection, structure rules,
//! geometry rules, stability test — each with a random stream of its own, in
//! parallel; diversity control picks the presented set from them, the rest joins
//! the background set (kept diverse by the same mechanism), and the next current
//! set is a diverse subset of the presented, current and background sets.

use super::error::UnknownMonster;
use super::geometry::{layout, Layout, Library};
use super::rules::{derive, select, Applied, DeriveOptions, Rng};
use super::shape::Shape;
use super::silhouette::{alike, silhouette, Silhouette};
use super::table::{CreatureTable, RuleKind};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// One creature of a generation.
#[derive(Clone, Debug)]
pub struct Individual {
    /// `g{generation}-{index}` for presented monsters (`g0-…` are the regular
    /// creatures), `b{generation}-{index}` for background-only ones.
    pub id: String,
    pub shape: Shape,
    pub layout: Layout,
    /// Structure complexity C_s.
    pub complexity: f64,
    /// Ids of the base and assist shapes ("" for regular creatures).
    pub parents: (String, String),
    /// The rule applications that made it.
    pub applied: Vec<Applied>,
    /// The regular creature's name, for generation 0.
    pub name: String,
    /// Its lineage: the regular creature (index into the table's shapes) its
    /// line of base shapes starts from — its body plan.
    pub lineage: u32,
    /// What it looks like (see [`super::silhouette`]).
    pub silhouette: Silhouette,
}

/// One generation's result.
#[derive(Clone, Debug)]
pub struct Generation {
    pub index: u32,
    /// The presented (current) set.
    pub presented: Vec<Individual>,
    /// The background set after this generation.
    pub background: Vec<Individual>,
    /// Offspring made before diversity control.
    pub n_offspring: usize,
    /// Offspring attempts rejected by the stability test.
    pub n_unstable: usize,
    /// Offspring attempts rejected because a part touched nothing of its torso.
    pub n_detached: usize,
    /// Offspring slots that found no valid offspring within their attempts.
    pub n_failed: usize,
    /// Offspring dropped before diversity control because an earlier offspring
    /// of the generation has the same abstract shape.
    pub n_duplicates: usize,
    /// The diversity of the presented set.
    pub diversity: Diversity,
    /// The diversity of all offspring made (before diversity control).
    pub offspring_diversity: Diversity,
    /// Offspring dropped before diversity control because they look like another
    /// offspring of the generation (their silhouettes are alike).
    pub n_lookalikes: usize,
    /// Presented monsters per lineage (regular creature's name).
    pub lineages: BTreeMap<String, usize>,
    /// A note per lineage that died out of what the user sees in this generation:
    /// it was among the parents and in the last presented set, and has no monster
    /// in this one.
    pub extinct: Vec<String>,
}

impl Generation {
    /// `Some(explanation)` when a generation after the first made no offspring
    /// at all: every offspring slot ran out of tries.
    pub fn empty(&self, opts: &EvolveOptions) -> Option<String> {
        if self.index == 0 || !self.presented.is_empty() {
            return None;
        }
        let tries = self.n_failed * opts.attempts as usize;
        let mut why = format!(
            "generation {} is empty: none of its {} offspring found a monster in {} tries each ({} tries in all: {} did not stand, {} had a part touching nothing, the others changed nothing or had more than {} meta-parts)",
            self.index, self.n_failed, opts.attempts, tries, self.n_unstable, self.n_detached, opts.maxparts
        );
        if self.n_unstable * 2 >= tries && tries > 0 {
            why.push_str(
                "; creatures that cannot stand (swimmers, fliers) say `floats;` in their `shape`, or the grammar `stability off;` in `evolve` (see W0801)",
            );
        }
        Some(why)
    }
}

/// Offspring tries rejected, by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rejected {
    /// By the stability test.
    pub unstable: usize,
    /// Because a part touched nothing of the torso it is attached to.
    pub detached: usize,
}

/// Options of a run (defaults from the table's `evolve` block).
#[derive(Clone, Debug)]
pub struct EvolveOptions {
    pub seed: u64,
    pub population: u32,
    pub generations: u32,
    pub background: u32,
    pub offspring: u32,
    pub steps: u32,
    pub attempts: u32,
    pub maxparts: u32,
    /// Rule kinds left out (ablation).
    pub disabled: Vec<RuleKind>,
    /// Diversity control on (else the presented set is a uniform sample).
    pub diversity_control: bool,
    /// Reject offspring with a part touching nothing of its torso.
    pub require_contact: bool,
    /// Reject offspring that do not stand (the stability test), except those of
    /// `floats` creatures.
    pub stability: bool,
    /// Keep every lineage among the parents alive: offspring tries reserved for a
    /// lineage that made none, and a place in the presented and next current sets.
    pub lineages: bool,
    /// Drop offspring that look like another one (alike silhouettes) before
    /// diversity control; `false` keeps them (the behaviour before issue 43).
    pub drop_lookalikes: bool,
}

impl EvolveOptions {
    /// The table's settings.
    pub fn from_table(t: &CreatureTable) -> EvolveOptions {
        let e = &t.evolve;
        EvolveOptions {
            seed: e.seed,
            population: e.population,
            generations: e.generations,
            background: e.background,
            offspring: e.offspring,
            steps: e.steps,
            attempts: e.attempts,
            maxparts: e.maxparts,
            disabled: Vec::new(),
            diversity_control: true,
            require_contact: true,
            stability: e.stability,
            lineages: true,
            drop_lookalikes: true,
        }
    }
}

/// The state between generations: the last presented set, the current set
/// (parents of the next offspring) and the background set.
#[derive(Clone, Debug)]
pub struct Population {
    pub generation: u32,
    pub presented: Vec<Individual>,
    pub current: Vec<Individual>,
    pub background: Vec<Individual>,
}

/// Runs creature evolution over one table and its part library.
pub struct Evolution<'a> {
    pub table: &'a CreatureTable,
    pub lib: &'a Library,
    pub opts: EvolveOptions,
}

/// Progress: (generation, offspring done, offspring total).
pub type Progress<'p> = &'p (dyn Fn(u32, usize, usize) + Sync);

impl<'a> Evolution<'a> {
    pub fn new(table: &'a CreatureTable, lib: &'a Library, opts: EvolveOptions) -> Evolution<'a> {
        Evolution { table, lib, opts }
    }

    /// Generation 0: the regular creatures.
    pub fn initial(&self) -> Generation {
        let presented: Vec<Individual> = self
            .table
            .shapes
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let shape = Shape::from_def(self.table, d);
                let mut ind =
                    self.individual(shape, format!("g0-{i:02}"), (String::new(), String::new()), Vec::new(), i as u32);
                ind.name = d.name.clone();
                ind.silhouette = silhouette(self.lib, &ind.layout);
                ind
            })
            .collect();
        let diversity = diversity(self.table, &presented);
        let lineages = lineage_counts(self.table, &presented);
        Generation {
            index: 0,
            offspring_diversity: diversity.clone(),
            n_offspring: presented.len(),
            presented,
            background: Vec::new(),
            n_unstable: 0,
            n_detached: 0,
            n_failed: 0,
            n_duplicates: 0,
            diversity,
            n_lookalikes: 0,
            lineages,
            extinct: Vec::new(),
        }
    }

    /// The population after generation 0.
    pub fn start(&self) -> (Population, Generation) {
        let g0 = self.initial();
        let p = Population {
            generation: 0,
            presented: g0.presented.clone(),
            current: g0.presented.clone(),
            background: Vec::new(),
        };
        (p, g0)
    }

    /// A monster from its abstract shape (read from a run's record): laid out
    /// again, with its id and lineage.
    pub fn revive(&self, shape: Shape, id: String, lineage: u32) -> Individual {
        let mut ind = self.individual(shape, id, (String::new(), String::new()), Vec::new(), lineage);
        ind.silhouette = silhouette(self.lib, &ind.layout);
        ind
    }

    /// The population after generation `generation` when the user keeps `kept`
    /// of its monsters: they are the current set, `background` (the rest of the
    /// generation's presented set and its background set) the background set —
    /// what [`Evolution::keep`] makes after replaying the run.
    pub fn resume(&self, generation: u32, kept: Vec<Individual>, background: Vec<Individual>) -> Population {
        Population { generation, presented: kept.clone(), current: kept, background }
    }

    /// A monster laid out, its silhouette not yet made (offspring tries that fail
    /// the tests never need it).
    fn individual(
        &self,
        shape: Shape,
        id: String,
        parents: (String, String),
        applied: Vec<Applied>,
        lineage: u32,
    ) -> Individual {
        let layout = layout(self.table, self.lib, &shape);
        let complexity = shape.complexity();
        let silhouette = Silhouette::default();
        Individual { id, shape, layout, complexity, parents, applied, name: String::new(), lineage, silhouette }
    }

    /// Offspring `index` of generation `g` from `pop`: up to `attempts` tries of
    /// select → derive → lay out → stability test, with the offspring's own random
    /// stream. Returns the offspring (if any) and the tries rejected.
    pub fn offspring(&self, pop: &Population, g: u32, index: usize) -> (Option<Individual>, Rejected) {
        self.offspring_of(pop, g, index as u64, None)
    }

    /// [`Evolution::offspring`] with random stream `stream`, its base shape drawn
    /// from the current set's members of lineage `lineage` when given.
    fn offspring_of(
        &self,
        pop: &Population,
        g: u32,
        stream: u64,
        lineage: Option<u32>,
    ) -> (Option<Individual>, Rejected) {
        let mut rng = Rng::stream(self.opts.seed, g as u64, stream);
        let bases: Vec<&Individual> = pop.current.iter().filter(|i| lineage.is_none_or(|l| i.lineage == l)).collect();
        let assists: Vec<&Individual> = pop.current.iter().chain(&pop.background).collect();
        let base_metric: Vec<f64> = bases.iter().map(|i| i.complexity).collect();
        let assist_metric: Vec<f64> = assists.iter().map(|i| i.complexity).collect();
        let dopts = DeriveOptions {
            g,
            steps: self.opts.steps,
            strategy: self.table.select_rules,
            disabled: self.opts.disabled.clone(),
        };
        let mut unstable = Rejected::default();
        for _ in 0..self.opts.attempts {
            let Some(b) = select(self.table.select_shapes, &base_metric, &mut rng) else { return (None, unstable) };
            let base = bases[b];
            // The assist is another shape when there is one.
            let others: Vec<usize> = (0..assists.len()).filter(|&i| assists[i].id != base.id).collect();
            let a = if others.is_empty() {
                None
            } else {
                let m: Vec<f64> = others.iter().map(|&i| assist_metric[i]).collect();
                select(self.table.select_shapes, &m, &mut rng).map(|k| others[k])
            };
            let assist = a.map(|a| assists[a]).unwrap_or(base);
            let (shape, applied) = derive(self.table, &base.shape, &assist.shape, &dopts, &mut rng);
            if shape == base.shape || shape.n_metas() > self.opts.maxparts as usize {
                continue;
            }
            let parents = (base.id.clone(), assist.id.clone());
            let mut ind = self.individual(shape, String::new(), parents, applied, base.lineage);
            if self.opts.require_contact && !ind.layout.detached.is_empty() {
                unstable.detached += 1;
                continue;
            }
            if self.opts.stability && !ind.shape.floats && !ind.layout.stability.stable {
                unstable.unstable += 1;
                continue;
            }
            ind.silhouette = silhouette(self.lib, &ind.layout);
            return (Some(ind), unstable);
        }
        (None, unstable)
    }

    /// Makes generation `pop.generation + 1` and advances `pop` to it.
    pub fn step(&self, pop: &mut Population, progress: Option<Progress>) -> Generation {
        let g = pop.generation + 1;
        let total = self.opts.offspring as usize;
        let done = std::sync::atomic::AtomicUsize::new(0);
        let made: Vec<(Option<Individual>, Rejected)> = (0..total)
            .into_par_iter()
            .map(|i| {
                let r = self.offspring(pop, g, i);
                let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                if let Some(p) = progress {
                    p(g, d, total);
                }
                r
            })
            .collect();
        let mut n_unstable = made.iter().map(|m| m.1.unstable).sum();
        let mut n_detached = made.iter().map(|m| m.1.detached).sum();
        let n_failed = made.iter().filter(|m| m.0.is_none()).count();
        let mut offspring: Vec<Individual> = made.into_iter().filter_map(|m| m.0).collect();
        // The lineages among the parents (after `--keep`, the kept monsters'): a
        // lineage that made no offspring gets tries of its own, with its own
        // streams, its members as the base shapes.
        let parents: std::collections::BTreeSet<u32> = pop.current.iter().map(|i| i.lineage).collect();
        let shown: std::collections::BTreeSet<u32> = pop.presented.iter().map(|i| i.lineage).collect();
        if self.opts.lineages {
            for &l in &parents {
                if offspring.iter().any(|i| i.lineage == l) {
                    continue;
                }
                let tries = (total / parents.len().max(1)).max(3);
                let more: Vec<(Option<Individual>, Rejected)> = (0..tries)
                    .into_par_iter()
                    .map(|k| self.offspring_of(pop, g, (1u64 << 40) + ((l as u64) << 20) + k as u64, Some(l)))
                    .collect();
                n_unstable += more.iter().map(|m| m.1.unstable).sum::<usize>();
                n_detached += more.iter().map(|m| m.1.detached).sum::<usize>();
                offspring.extend(more.into_iter().filter_map(|m| m.0));
            }
        }
        let n_offspring = offspring.len();
        let offspring_diversity = diversity(self.table, &offspring);
        // Equal abstract shapes (the same parts on the same slots, arranged alike:
        // equal descriptions, whatever their ids) are one monster: keep the first.
        let mut seen = std::collections::BTreeSet::new();
        let offspring: Vec<Individual> =
            offspring.into_iter().filter(|i| seen.insert(i.shape.describe(self.table))).collect();
        let mut n_duplicates = n_offspring - offspring.len();
        // Monsters that look alike are one monster too: of a group of look-alikes
        // the one with the fewest meta-parts stays (what you see is what you get;
        // ties: the first made).
        let made_by: std::collections::BTreeSet<u32> = offspring.iter().map(|i| i.lineage).collect();
        let (mut offspring, mut n_lookalikes) =
            if self.opts.drop_lookalikes { drop_lookalikes(offspring) } else { (offspring, 0) };
        // Too few distinct monsters for the presented set: up to three more rounds
        // of offspring (streams `total`, `total + 1`, …), as long as they add some.
        for round in 1..=3usize {
            if offspring.len() >= self.opts.population as usize || n_offspring == 0 {
                break;
            }
            let more: Vec<Individual> = (total * round..total * (round + 1))
                .into_par_iter()
                .filter_map(|i| self.offspring(pop, g, i).0)
                .collect();
            let before = offspring.len();
            for ind in more {
                if !seen.insert(ind.shape.describe(self.table)) {
                    n_duplicates += 1;
                } else if self.opts.drop_lookalikes && offspring.iter().any(|k| look_alike(k, &ind)) {
                    n_lookalikes += 1;
                } else {
                    offspring.push(ind);
                }
            }
            if offspring.len() == before {
                break;
            }
        }
        let mut rng = Rng::stream(self.opts.seed, g as u64, u64::MAX);
        let mut picked = if self.opts.diversity_control {
            diversity_control(self.table, &offspring, self.opts.population as usize, &mut rng)
        } else {
            uniform_sample(offspring.len(), self.opts.population as usize, &mut rng)
        };
        if self.opts.lineages {
            keep_lineages(&offspring, &parents, &mut picked, self.opts.population as usize);
        }
        let offspring_left: std::collections::BTreeSet<u32> = offspring.iter().map(|i| i.lineage).collect();
        let mut presented = Vec::new();
        let mut rest = Vec::new();
        for (i, ind) in offspring.into_iter().enumerate() {
            if picked.contains(&i) {
                presented.push(ind);
            } else {
                rest.push(ind);
            }
        }
        for (k, ind) in presented.iter_mut().enumerate() {
            ind.id = format!("g{g}-{k:02}");
        }
        for (k, ind) in rest.iter_mut().enumerate() {
            ind.id = format!("b{g}-{k:02}");
        }
        let mut pool: Vec<Individual> = std::mem::take(&mut pop.background);
        pool.extend(rest);
        let keep = if self.opts.diversity_control {
            diversity_control(self.table, &pool, self.opts.background as usize, &mut rng)
        } else {
            uniform_sample(pool.len(), self.opts.background as usize, &mut rng)
        };
        let background: Vec<Individual> =
            pool.into_iter().enumerate().filter(|(i, _)| keep.contains(i)).map(|(_, x)| x).collect();
        // The next shape set: a diverse subset of the presented (accepted), the
        // current and the background sets (paper §4).
        let mut next: Vec<Individual> = presented.clone();
        next.extend(pop.current.iter().cloned());
        next.extend(background.iter().cloned());
        let mut chosen = if self.opts.diversity_control {
            diversity_control(self.table, &next, self.opts.population as usize, &mut rng)
        } else {
            uniform_sample(next.len(), self.opts.population as usize, &mut rng)
        };
        if self.opts.lineages {
            // Only lineages that made a monster this generation stay among the
            // parents by right; one that made none dies out (and is noted).
            let living: std::collections::BTreeSet<u32> = presented.iter().map(|i| i.lineage).collect();
            keep_lineages(&next, &living, &mut chosen, self.opts.population as usize);
        }
        let old_current = std::mem::take(&mut pop.current);
        pop.current = next.into_iter().enumerate().filter(|(i, _)| chosen.contains(i)).map(|(_, x)| x).collect();
        let extinct = parents
            .iter()
            .filter(|&&l| shown.contains(&l) && !presented.iter().any(|i| i.lineage == l))
            .map(|&l| {
                let members = old_current.iter().filter(|i| i.lineage == l).count();
                let why = if self.opts.drop_lookalikes && made_by.contains(&l) && !offspring_left.contains(&l) {
                    "each of its offspring looked like another monster (look-alikes are dropped)".to_string()
                } else if self.opts.lineages {
                    "none of its tries made a monster that changed, stands and touches".to_string()
                } else {
                    let made = presented.iter().chain(&background).filter(|i| i.lineage == l).count();
                    format!("diversity control left out its {made} offspring")
                };
                format!(
                    "lineage `{}` died out of the presented set in generation {g}: {why} ({members} of the {} parents were of it)",
                    lineage_name(self.table, l),
                    old_current.len()
                )
            })
            .collect();
        pop.background = background.clone();
        pop.presented = presented.clone();
        pop.generation = g;
        let diversity = diversity(self.table, &presented);
        let lineages = lineage_counts(self.table, &presented);
        Generation {
            index: g,
            presented,
            background,
            n_offspring,
            n_unstable,
            n_detached,
            n_failed,
            n_duplicates,
            diversity,
            offspring_diversity,
            n_lookalikes,
            lineages,
            extinct,
        }
    }

    /// Continues from chosen monsters (the user's preference): they become the
    /// current set; the rest of the presented set joins the background.
    pub fn keep(&self, pop: &mut Population, ids: &[String]) -> Result<(), UnknownMonster> {
        let mut kept = Vec::new();
        for id in ids {
            let all = pop.presented.iter().chain(&pop.current).chain(&pop.background);
            match all.clone().find(|i| &i.id == id) {
                Some(i) => kept.push(i.clone()),
                None => {
                    return Err(UnknownMonster {
                        id: id.clone(),
                        generation: pop.generation,
                        presented: pop.presented.iter().map(|i| i.id.clone()).collect(),
                    });
                }
            }
        }
        let rest: Vec<Individual> = pop
            .presented
            .iter()
            .filter(|i| !ids.contains(&i.id) && !pop.background.iter().any(|b| b.id == i.id))
            .cloned()
            .collect();
        pop.background.extend(rest);
        pop.current = kept;
        Ok(())
    }
}

/// The name of lineage `l`: its regular creature's.
pub fn lineage_name(t: &CreatureTable, l: u32) -> &str {
    t.shapes.get(l as usize).map(|s| s.name.as_str()).unwrap_or("?")
}

/// Monsters per lineage name.
pub fn lineage_counts(t: &CreatureTable, set: &[Individual]) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    for i in set {
        *m.entry(lineage_name(t, i.lineage).to_string()).or_insert(0) += 1;
    }
    m
}

/// Whether two monsters look alike: their silhouettes are [`alike`] in all three
/// views. What shows decides, not what they are made of: two monsters with other
/// part sets (a horse's head or a boar's on the same ogre among three stacked pairs
/// of arms) whose outlines agree are one monster to the eye, so structure never
/// makes look-alikes "distinct". Colour is not compared (docs/decisions.md).
pub fn look_alike(a: &Individual, b: &Individual) -> bool {
    alike(&a.silhouette, &b.silhouette)
}

/// The number of visibly different monsters of `set`, judged by silhouette alone:
/// how many stay when look-alikes are dropped ([`drop_lookalikes`]: in order of
/// fewest meta-parts, a monster counts unless it looks like one already counted).
/// Not a transitive closure: a chain of look-alikes, each a little different from
/// the last, does not collapse into one.
pub fn visibly_different(set: &[Individual]) -> usize {
    lookalike_survivors(set).len()
}

/// The indices of `set` that stay when look-alikes are dropped: in order of fewest
/// meta-parts (ties the earliest), a monster stays unless it looks like one that
/// stayed. The one judgement behind [`visibly_different`] and [`drop_lookalikes`].
fn lookalike_survivors(set: &[Individual]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..set.len()).collect();
    order.sort_by_key(|&i| (set[i].shape.n_metas(), i));
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        if !kept.iter().any(|&k| look_alike(&set[k], &set[i])) {
            kept.push(i);
        }
    }
    kept
}

/// `set` without the monsters that look like another one of it (their
/// silhouettes are alike, see [`look_alike`]): of each group the one with the fewest meta-parts
/// stays, ties the earliest. Returns the rest, in their order, and how many were
/// dropped.
pub fn drop_lookalikes(set: Vec<Individual>) -> (Vec<Individual>, usize) {
    let kept = lookalike_survivors(&set);
    let n = set.len() - kept.len();
    let keep: std::collections::BTreeSet<usize> = kept.into_iter().collect();
    (set.into_iter().enumerate().filter(|(i, _)| keep.contains(i)).map(|(_, x)| x).collect(), n)
}

/// Gives every lineage of `lineages` that has a member in `set` a place in
/// `picked` (indices into `set`, increasing): its member least like the picked
/// ones (by silhouette) takes the place of the picked member most like the rest of
/// the most numerous lineage, or a free place while fewer than `k` are picked.
pub fn keep_lineages(
    set: &[Individual],
    lineages: &std::collections::BTreeSet<u32>,
    picked: &mut Vec<usize>,
    k: usize,
) {
    use super::silhouette::distance as sd;
    let nearest = |i: usize, among: &[usize]| {
        among
            .iter()
            .filter(|&&j| j != i)
            .map(|&j| sd(&set[i].silhouette, &set[j].silhouette))
            .fold(f64::INFINITY, f64::min)
    };
    for &l in lineages {
        if picked.iter().any(|&i| set[i].lineage == l) {
            continue;
        }
        let Some(add) = (0..set.len())
            .filter(|&i| set[i].lineage == l && !picked.contains(&i))
            .max_by(|&a, &b| nearest(a, picked).total_cmp(&nearest(b, picked)).then(b.cmp(&a)))
        else {
            continue;
        };
        if picked.len() >= k {
            let mut counts: BTreeMap<u32, usize> = BTreeMap::new();
            for &i in picked.iter() {
                *counts.entry(set[i].lineage).or_insert(0) += 1;
            }
            let Some((&big, &n)) = counts.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0))) else { continue };
            if n < 2 {
                continue;
            }
            let members: Vec<usize> = picked.iter().copied().filter(|&i| set[i].lineage == big).collect();
            let Some(out) = members
                .iter()
                .copied()
                .min_by(|&a, &b| nearest(a, &members).total_cmp(&nearest(b, &members)).then(b.cmp(&a)))
            else {
                continue;
            };
            picked.retain(|&i| i != out);
        }
        picked.push(add);
        picked.sort_unstable();
    }
}

/// `k` distinct indices of `n`, uniformly (all when n ≤ k), in increasing order.
fn uniform_sample(n: usize, k: usize, rng: &mut Rng) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..n).collect();
    for i in 0..n.min(k) {
        let j = i + rng.below(n - i);
        idx.swap(i, j);
    }
    idx.truncate(k.min(n));
    idx.sort_unstable();
    idx
}

/// A shape's structure vector as one comparable key.
pub fn structure_key(t: &CreatureTable, s: &Shape) -> String {
    s.structure_vector(t).iter().map(|(k, v)| format!("{k}×{v}")).collect::<Vec<_>>().join(" ")
}

/// Groups `set` by structure vector: clusters of indices, in key order.
pub fn clusters(t: &CreatureTable, set: &[Individual]) -> Vec<Vec<usize>> {
    let mut m: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (i, ind) in set.iter().enumerate() {
        m.entry(structure_key(t, &ind.shape)).or_default().push(i);
    }
    m.into_values().collect()
}

/// The geometric descriptor inside a structure cluster (our stand-in for the light
/// field descriptor of Fit and Diverse): proportions of the grounded model —
/// width, depth and centre-of-mass height over height, the height itself, and the
/// mean and spread of the part centres' distances from the centre of mass over
/// height — and the multiset of part geometries it is built from (compared as a
/// set, see [`distance`]), so equal structures built from different parts differ.
#[derive(Clone, Debug, PartialEq)]
pub struct Descriptor {
    pub proportions: Vec<f64>,
    /// Library part index → how many of it are placed.
    pub parts: BTreeMap<u32, u32>,
}

/// See [`Descriptor`].
pub fn descriptor(ind: &Individual) -> Descriptor {
    let l = &ind.layout;
    let size = l.max - l.min;
    let h = size.z.max(1e-6) as f64;
    let com = l.stability.com;
    let d: Vec<f64> =
        l.placed.iter().map(|p| (p.transform.transform_point3(Vec3::ZERO) - com).length() as f64 / h).collect();
    let mean = d.iter().sum::<f64>() / d.len().max(1) as f64;
    let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len().max(1) as f64).sqrt();
    let mut parts = BTreeMap::new();
    for p in &l.placed {
        *parts.entry(p.part).or_insert(0) += 1;
    }
    Descriptor { proportions: vec![size.x as f64 / h, size.y as f64 / h, com.z as f64 / h, h, mean, sd], parts }
}

/// The distance between two descriptors: Euclidean over the proportions, and the
/// weighted Jaccard distance 1 − Σ min / Σ max of the part multisets (0 for the
/// same parts, 1 for disjoint ones), combined as √(d_p² + d_J²).
pub fn distance(a: &Descriptor, b: &Descriptor) -> f64 {
    let dp2: f64 = a.proportions.iter().zip(&b.proportions).map(|(x, y)| (x - y).powi(2)).sum();
    let (mut lo, mut hi) = (0u32, 0u32);
    for k in a.parts.keys().chain(b.parts.keys().filter(|k| !a.parts.contains_key(k))) {
        let (x, y) = (a.parts.get(k).copied().unwrap_or(0), b.parts.get(k).copied().unwrap_or(0));
        lo += x.min(y);
        hi += x.max(y);
    }
    let dj = if hi == 0 { 0.0 } else { 1.0 - lo as f64 / hi as f64 };
    (dp2 + dj * dj).sqrt()
}

/// The spread of a set of descriptors: √(Σ_{a,b} d(a,b)² / 2n²) — for a Euclidean
/// distance exactly the root-mean-square distance to the mean, defined for
/// [`distance`], which has no mean.
pub fn spread(desc: &[Descriptor]) -> f64 {
    let n = desc.len();
    if n < 2 {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in 0..n {
        for j in i + 1..n {
            sum += distance(&desc[i], &desc[j]).powi(2);
        }
    }
    // Σ over ordered pairs is twice the sum over unordered ones.
    (2.0 * sum / (2.0 * (n * n) as f64)).sqrt()
}

/// Structure-based diversity control (paper §4): cluster by structure vector,
/// give each cluster a share of `k` proportional to its size (every cluster at
/// least one while there are no more clusters than `k`; otherwise clusters are
/// drawn with probability proportional to size), and inside a cluster pick its
/// share by farthest-point sampling on the geometric descriptor. Returns indices
/// into `set`, increasing.
pub fn diversity_control(t: &CreatureTable, set: &[Individual], k: usize, rng: &mut Rng) -> Vec<usize> {
    if set.len() <= k {
        return (0..set.len()).collect();
    }
    let cl = clusters(t, set);
    let sizes: Vec<usize> = cl.iter().map(|c| c.len()).collect();
    let mut quota = vec![0usize; cl.len()];
    if cl.len() >= k {
        // More structures than places: k clusters, drawn by size without replacement.
        let mut w: Vec<f64> = sizes.iter().map(|&s| s as f64).collect();
        for _ in 0..k {
            let Some(i) = super::rules::roulette(&w, rng) else { break };
            quota[i] = 1;
            w[i] = 0.0;
        }
    } else {
        // One each, then the rest by largest remainder of the proportional share.
        let extra = k - cl.len();
        let room: Vec<usize> = sizes.iter().map(|s| s - 1).collect();
        let total_room: usize = room.iter().sum();
        let mut given = 0;
        let mut rema: Vec<(f64, usize)> = Vec::new();
        for (i, &r) in room.iter().enumerate() {
            let share = if total_room == 0 { 0.0 } else { extra as f64 * r as f64 / total_room as f64 };
            let whole = (share.floor() as usize).min(r);
            quota[i] = 1 + whole;
            given += whole;
            rema.push((share - whole as f64, i));
        }
        rema.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for (_, i) in rema.iter().cycle().take(rema.len() * 2) {
            if given >= extra {
                break;
            }
            if quota[*i] < sizes[*i] {
                quota[*i] += 1;
                given += 1;
            }
        }
    }
    let mut out = Vec::new();
    for (c, &q) in cl.iter().zip(&quota) {
        if q == 0 {
            continue;
        }
        let desc: Vec<Descriptor> = c.iter().map(|&i| descriptor(&set[i])).collect();
        let mut chosen = vec![rng.below(c.len())];
        while chosen.len() < q.min(c.len()) {
            let next = (0..c.len()).filter(|j| !chosen.contains(j)).max_by(|&a, &b| {
                let da = chosen.iter().map(|&s| distance(&desc[a], &desc[s])).fold(f64::INFINITY, f64::min);
                let db = chosen.iter().map(|&s| distance(&desc[b], &desc[s])).fold(f64::INFINITY, f64::min);
                da.total_cmp(&db).then(b.cmp(&a))
            });
            match next {
                Some(n) => chosen.push(n),
                None => break,
            }
        }
        out.extend(chosen.into_iter().map(|j| c[j]));
    }
    out.sort_unstable();
    out
}

/// The hierarchical diversity measure of a set (paper §5), counted on what is
/// visible: HDM = N + Σ_i D_i with N the number of visible clusters — monsters of
/// equal structure vectors, joined with the look-alike each monster would be dropped
/// for (see [`look_alike`]; stacked copies hiding one another, a tail hidden behind a body:
/// different structures that look the same are one) — and D_i = SD_i / max_j SD_j,
/// SD_i the [`spread`] of the geometric [`descriptor`]s of the visibly different
/// members of cluster i (look-alikes merged) (for a
/// Euclidean descriptor: the root-mean-square distance to the cluster mean).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diversity {
    pub hdm: f64,
    /// Visible clusters (the N of the HDM).
    pub clusters: usize,
    /// Visibly different monsters by silhouette alone ([`visibly_different`]),
    /// what a contact sheet shows.
    pub visible: usize,
    /// Structure clusters (equal structure vectors), the measure before
    /// silhouettes joined them.
    pub structures: usize,
    /// Mean structure complexity C_s of the set.
    pub mean_complexity: f64,
    /// Mean number of meta-parts.
    pub mean_metas: f64,
}

/// The visible clusters of `set` (see [`Diversity`]): indices, each cluster
/// increasing, clusters by their first member.
pub fn visible_clusters(t: &CreatureTable, set: &[Individual]) -> Vec<Vec<usize>> {
    let mut root: Vec<usize> = (0..set.len()).collect();
    fn find(root: &mut [usize], mut i: usize) -> usize {
        while root[i] != i {
            root[i] = root[root[i]];
            i = root[i];
        }
        i
    }
    let join = |root: &mut Vec<usize>, a: usize, b: usize| {
        let (ra, rb) = (find(root, a), find(root, b));
        if ra != rb {
            root[ra.max(rb)] = ra.min(rb);
        }
    };
    for c in clusters(t, set) {
        for w in c.windows(2) {
            join(&mut root, w[0], w[1]);
        }
    }
    // Every monster joins the look-alike that stays in its place when look-alikes
    // are dropped (the first alike one in order of fewest meta-parts), not every
    // monster it is alike to: a chain of look-alikes, each a little different from
    // the last, does not collapse into one cluster.
    let mut order: Vec<usize> = (0..set.len()).collect();
    order.sort_by_key(|&i| (set[i].shape.n_metas(), i));
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        match kept.iter().find(|&&k| look_alike(&set[k], &set[i])) {
            Some(&k) => join(&mut root, k, i),
            None => kept.push(i),
        }
    }
    let mut m: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for i in 0..set.len() {
        let r = find(&mut root, i);
        m.entry(r).or_default().push(i);
    }
    m.into_values().collect()
}

/// See [`Diversity`].
pub fn diversity(t: &CreatureTable, set: &[Individual]) -> Diversity {
    if set.is_empty() {
        return Diversity::default();
    }
    let cl = visible_clusters(t, set);
    // Inside a cluster, look-alikes are one monster (merged for the measure): the
    // spread is over the cluster's visibly different members.
    let sd: Vec<f64> = cl
        .iter()
        .map(|c| {
            let mut seen: Vec<usize> = Vec::new();
            for &i in c {
                if !seen.iter().any(|&k| look_alike(&set[k], &set[i])) {
                    seen.push(i);
                }
            }
            let desc: Vec<Descriptor> = seen.iter().map(|&i| descriptor(&set[i])).collect();
            spread(&desc)
        })
        .collect();
    let max = sd.iter().cloned().fold(0.0, f64::max);
    let sum_d: f64 = if max > 0.0 { sd.iter().map(|s| s / max).sum() } else { 0.0 };
    Diversity {
        hdm: cl.len() as f64 + sum_d,
        clusters: cl.len(),
        visible: visibly_different(set),
        structures: clusters(t, set).len(),
        mean_complexity: set.iter().map(|i| i.complexity).sum::<f64>() / set.len() as f64,
        mean_metas: set.iter().map(|i| i.shape.n_metas() as f64).sum::<f64>() / set.len() as f64,
    }
}
