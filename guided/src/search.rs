//! The SOSMC search over skeleton derivations (paper §3–4), the wrap-up, and the
//! geometry phase.
//!
//! A particle is a partial skeleton derivation: the calls still pending (skeleton
//! calls not yet expanded, each with its frame, the guide nearest to its origin and
//! its heuristic term), the utilisation counts, the cost so far, and a pointer to the
//! newest record of its history. History records are shared: a record holds what one
//! expansion added (its bones and the calls it deferred to the geometry phase) and a
//! pointer to the record before it, so copying a particle is copying its pending list
//! and counts, and growing it adds one record (copy-and-add, paper §4.1). The pending
//! calls themselves are stored once per search (in segments, one per thread and
//! generation, compacted when mostly unreferenced); a particle's pending list holds
//! 16-byte references with the calls' heuristic terms.
//!
//! One *particle-step* expands pending skeleton calls, each chosen uniformly at random
//! among the pending ones, until one of them added a bone (calls that only pass the
//! origin on — `fork` in the std tree — add none) or none is left. Generation g has
//! N_g particles (a linear ramp from `particles.0` to `particles.1`) and heuristic
//! scale h_g (a linear ramp from `heuristic_scale` to 0 over the first
//! `heuristic_fraction` of the generations). After each particle's step its weight is
//! the likelihood ratio exp(−[(COST + h_g·H)_now − (COST + h_{g−1}·H)_before]); then
//! N_{g+1} particles are resampled. The search stops after the last generation, at
//! the time budget or when cancelled (both checked before every particle-step), or
//! when no particle has pending calls. The model is the final particle with the
//! lowest COST (first on ties): leftover skeleton calls become their wrap-up rule's calls (calls of a rule
//! without a wrap-up are dropped), and the geometry phase evaluates every deferred
//! call with [`mdg_vm::eval::evaluate_calls`].
//!
//! Determinism: particle j of generation g draws from its own PCG-64 stream (seed, g,
//! j), and resampling from one stream of its own, so results do not depend on the
//! number of threads or their scheduling. The particle-steps of a generation are split
//! among a [`Team`] of threads that stays awake for the whole search (`threads`, or
//! rayon's thread count); the weights and resampling run on the calling thread.

use super::cost::{Cost, Guides, Near, Utilisation};
use super::resample::{resample, weights_from_log};
use super::team::Team;
use super::{Guide, GuidedTable, PrepareError, Resampling, SearchSettings};
use choice::{reach, Candidate, Kept};
pub use choice::{ModelChoice, DEFAULT_REACH_SHARE};

mod choice;
mod reach;
use glam::{DVec3, Vec3};
use mdg_vm::bundle::{Bundle, NONE};
use mdg_vm::eval::{evaluate_calls, Call, EvalOptions, Expander};
use mdg_vm::output::{Output, Polyline};
use rayon::prelude::*;
pub use reach::REACH_SAMPLES;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::{Duration, Instant};

/// Most expansions in one particle-step (a grammar whose skeleton calls never move
/// the origin would otherwise never finish a step).
pub const MAX_EXPANSIONS_PER_STEP: u32 = 256;
/// The seed of the EXPECTED estimate: a property of the grammar, not of `--seed`.
const EXPECTED_SEED: u64 = 0x5EED_E4EC_7ED0_0001;
/// A forward sample: the particle, the store segment of its pending calls, its
/// particle-steps and expansions.
type Sample = (Particle, Vec<Pending>, u64, u64);
/// Pending calls stored beyond twice those referenced before the store is compacted.
const COMPACT_SLACK: usize = 4096;
/// Stream of the resampling draws.
const RESAMPLE_STREAM: u64 = u64::MAX;

/// Options of one search.
#[derive(Clone, Debug, PartialEq)]
pub struct SearchOptions {
    /// Particles in the first and the last generation.
    pub particles: (u32, u32),
    pub generations: u32,
    /// Starting HEURISTICSCALE (0 turns the heuristic off).
    pub heuristic_scale: f64,
    /// Fraction of the generations over which HEURISTICSCALE ramps down to 0.
    pub heuristic_fraction: f64,
    /// Stop once this much time has passed since `clock` (checked before every
    /// particle-step: a generation the budget cuts short is dropped, and the model is
    /// the best of the generations before).
    pub budget: Option<Duration>,
    /// When the budget's clock started (`None`: when the search starts). A caller
    /// that prepares the guides first passes the instant before preparing
    /// ([`Prepared::new_within`]), so the budget covers both.
    pub clock: Option<Instant>,
    pub resampling: Resampling,
    pub seed: u64,
    /// Worker threads (`None`: rayon's global pool). Results do not depend on it.
    pub threads: Option<usize>,
    /// Generations with fewer particles than this run on the calling thread alone;
    /// larger ones are split among the threads (see [`super::team`] and
    /// docs/guided.md). Results do not depend on it.
    pub parallel_min: usize,
    /// Stop as soon as this is cancelled (checked where the budget is: before every
    /// particle-step and between generations). An editor cancels a search whose
    /// guides were changed again before it finished.
    pub cancel: Option<Cancel>,
    /// Which particle becomes the model ([`ModelChoice`]).
    pub choice: ModelChoice,
}

/// A flag that stops a running search from another thread ([`SearchOptions::cancel`]).
/// Clones share the flag; two are equal when they are the same flag.
#[derive(Clone, Debug, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A flag not yet set.
    pub fn new() -> Cancel {
        Cancel::default()
    }

    /// Asks every search holding this flag to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

impl PartialEq for Cancel {
    fn eq(&self, other: &Cancel) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Default [`SearchOptions::parallel_min`].
pub const PARALLEL_MIN_PARTICLES: usize = 8;

impl SearchOptions {
    /// The options of a `search` section, with `seed`.
    pub fn from_settings(s: &SearchSettings, seed: u64) -> SearchOptions {
        SearchOptions {
            particles: s.particles,
            generations: s.generations,
            heuristic_scale: s.heuristic_scale,
            heuristic_fraction: s.heuristic_fraction,
            // Validated settings hold at most MAX_BUDGET_MS; anything else is clamped
            // (NaN to the default) rather than panicking in `Duration`.
            budget: s.budget_ms.map(|ms| {
                let ms = if ms.is_nan() { super::DEFAULT_BUDGET_MS } else { ms.clamp(0.0, super::MAX_BUDGET_MS) };
                Duration::from_secs_f64(ms / 1000.0)
            }),
            resampling: s.resampling,
            seed,
            threads: None,
            parallel_min: PARALLEL_MIN_PARTICLES,
            clock: None,
            cancel: None,
            choice: ModelChoice::default(),
        }
    }

    /// N_g: the number of particles in generation `g` (linear ramp, rounded).
    pub fn particles_at(&self, g: u32) -> usize {
        let (a, b) = (self.particles.0.max(1) as f64, self.particles.1.max(1) as f64);
        if self.generations <= 1 {
            return a as usize;
        }
        let f = g.min(self.generations - 1) as f64 / (self.generations - 1) as f64;
        (a + (b - a) * f).round().max(1.0) as usize
    }

    /// h_g: the heuristic scale in generation `g` (linear ramp to 0 over the first
    /// `heuristic_fraction` of the generations).
    pub fn heuristic_at(&self, g: u32) -> f64 {
        let span = self.heuristic_fraction * self.generations as f64;
        if span.is_nan() || span <= 0.0 {
            return 0.0;
        }
        self.heuristic_scale * (1.0 - g as f64 / span).max(0.0)
    }

    /// Σ N_g over all generations: the particle-steps of a search that is not cut short.
    pub fn scheduled_steps(&self) -> u64 {
        (0..self.generations).map(|g| self.particles_at(g) as u64).sum()
    }
}

/// Why the search stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// All generations ran.
    Generations,
    /// The time budget ran out (the result then depends on the machine's speed).
    Budget,
    /// No particle had pending skeleton calls left.
    Complete,
    /// [`SearchOptions::cancel`] was set (the result is the best seen before).
    Cancelled,
}

/// A bone of the skeleton, in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bone {
    pub base: DVec3,
    pub tip: DVec3,
    /// The callee (the rule whose origin is the tip).
    pub rule: u32,
}

/// A finished derivation: the chosen particle after wrap-up.
#[derive(Clone, Debug)]
pub struct Model {
    /// COST of the skeleton (no heuristic: nothing is pending after wrap-up).
    pub cost: Cost,
    /// Every bone, in the order added.
    pub bones: Vec<Bone>,
    /// The geometry phase's calls: those the skeleton deferred (in expansion order),
    /// then the wrap-up calls.
    pub calls: Vec<Call>,
    /// Leftover skeleton calls that became wrap-up calls, and those dropped (their
    /// rule has no wrap-up).
    pub wrapped: usize,
    pub dropped: usize,
}

/// What a search did and found.
#[derive(Clone, Debug)]
pub struct SearchResult {
    /// The lowest-COST model of any generation (the earliest of equal ones): the cost
    /// of the last generation rises again in long searches, so the best one seen is
    /// kept.
    pub model: Model,
    /// COST of every particle of the final generation.
    pub final_costs: Vec<f64>,
    /// Index of the lowest among them (the first of equal ones).
    pub chosen: usize,
    /// The generation the model comes from: after how many generations its particle
    /// was what it is (`generations` when it is the final generation's).
    pub model_generation: u32,
    /// Generations run.
    pub generations: u32,
    /// Particle-steps taken (one per particle per generation, while it had pending calls).
    pub particle_steps: u64,
    /// Skeleton calls expanded.
    pub expansions: u64,
    pub stop: Stop,
    pub elapsed: Duration,
}

/// Reported after every generation.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Generations done, and the planned number.
    pub generation: u32,
    pub generations: u32,
    /// The lowest COST among the particles.
    pub best_cost: f64,
}

/// What one particle-step added to a particle, in order: bones and deferred calls
/// (the first few inline, so a step allocates one record).
struct Record {
    prev: Option<Arc<Record>>,
    inline: [Option<Item>; RECORD_INLINE],
    more: Vec<Item>,
}

/// Items a record holds without a second allocation (a typical step adds a bone, the
/// wood it defers and perhaps a leaf).
const RECORD_INLINE: usize = 4;

impl Record {
    /// A record of `items` (drained; the buffer is kept for the next step).
    fn new(prev: Option<Arc<Record>>, items: &mut Vec<Item>) -> Record {
        let mut inline: [Option<Item>; RECORD_INLINE] = Default::default();
        let mut drain = items.drain(..);
        for slot in inline.iter_mut() {
            *slot = drain.next();
        }
        let more: Vec<Item> = drain.collect();
        Record { prev, inline, more }
    }

    fn items(&self) -> impl Iterator<Item = &Item> {
        self.inline.iter().flatten().chain(self.more.iter())
    }
}

enum Item {
    Bone(Bone),
    Deferred(Call),
}

impl Drop for Record {
    fn drop(&mut self) {
        // Unlink iteratively: a long history must not recurse on the native stack.
        let mut next = self.prev.take();
        while let Some(rc) = next {
            match Arc::try_unwrap(rc) {
                Ok(mut r) => next = r.prev.take(),
                Err(_) => break,
            }
        }
    }
}

/// A pending call: the call and the guide nearest to its origin. Stored once in the
/// search's [`Store`]; particles hold [`PRef`]s to it, so copying a particle copies 16
/// bytes per pending call instead of the call's whole state.
#[derive(Clone, Copy, Debug)]
struct Pending {
    call: Call,
    near: Option<Near>,
}

/// A particle's reference to a pending call: where the call is stored (segment in the
/// high 32 bits, index in the low ones) and its heuristic term (unscaled).
#[derive(Clone, Copy, Debug)]
struct PRef {
    at: u64,
    h: f64,
}

/// Where a thread reads and writes pending calls during a round: the frozen segments
/// (shared, read-only) and its own segment (`id`), which it appends to.
struct Store<'a> {
    frozen: &'a [Vec<Pending>],
    id: u32,
    local: &'a mut Vec<Pending>,
}

impl Store<'_> {
    fn get(&self, at: u64) -> &Pending {
        let (seg, i) = ((at >> 32) as u32, at as u32 as usize);
        if seg == self.id {
            &self.local[i]
        } else {
            &self.frozen[seg as usize][i]
        }
    }

    fn add(&mut self, p: Pending, h: f64) -> PRef {
        self.local.push(p);
        PRef { at: ((self.id as u64) << 32) | (self.local.len() - 1) as u64, h }
    }
}

/// Rewrites the particles' references into one new segment holding only the calls they
/// still refer to (each once), and returns it: the frozen segments grow by every call a
/// step makes, most of which resampling leaves unreferenced.
fn compact<'p>(frozen: &[Vec<Pending>], particles: impl IntoIterator<Item = &'p mut Particle>) -> Vec<Pending> {
    let mut map: Vec<Vec<u32>> = frozen.iter().map(|s| vec![u32::MAX; s.len()]).collect();
    let mut seg = Vec::new();
    for p in particles {
        for r in &mut p.pending {
            let (s, i) = ((r.at >> 32) as usize, r.at as u32 as usize);
            let m = &mut map[s][i];
            if *m == u32::MAX {
                *m = seg.len() as u32;
                seg.push(frozen[s][i]);
            }
            r.at = *m as u64;
        }
    }
    seg
}

struct Particle {
    history: Option<Arc<Record>>,
    pending: Vec<PRef>,
    counts: Vec<u32>,
    cost: Cost,
    /// The log-likelihood term it was last weighted with: COST + h·H.
    score: f64,
}

impl Clone for Particle {
    fn clone(&self) -> Particle {
        Particle {
            history: self.history.clone(),
            pending: self.pending.clone(),
            counts: self.counts.clone(),
            cost: self.cost,
            score: self.score,
        }
    }

    /// Reuses this particle's buffers (no allocation when they are large enough).
    fn clone_from(&mut self, src: &Particle) {
        self.history.clone_from(&src.history);
        self.pending.clone_from(&src.pending);
        self.counts.clone_from(&src.counts);
        self.cost = src.cost;
        self.score = src.score;
    }
}

impl Particle {
    fn heuristic(&self) -> f64 {
        self.pending.iter().map(|p| p.h).sum()
    }
}

/// What one team member works with: the pending calls its steps made in this round
/// (segment `job.first + t` once frozen), its expander and scratch buffers (kept from
/// one generation to the next).
struct Slot<'b> {
    local: Vec<Pending>,
    ex: Expander<'b>,
    out: Vec<Call>,
    items: Vec<Item>,
}

/// Particle j of the generation being stepped, and its result (expansions, whether
/// it was active, log weight).
#[derive(Default)]
struct Cell {
    p: Option<Particle>,
    r: (u32, bool, f64),
}

/// The generation a round steps: generation g of n particles, heuristic scale h.
#[derive(Clone, Copy)]
struct Job {
    g: u32,
    n: usize,
    h: f64,
    seed: u64,
    /// The segment id of member 0's new pending calls (member t's is `first + t`).
    first: u32,
    /// Which of the two cell arrays holds the previous generation (the other one
    /// receives this generation).
    src: usize,
    /// When the time budget ends: members take no particle after it.
    deadline: Option<Instant>,
}

/// The state a search's team shares: the generation being stepped (set by the lead
/// between rounds), the previous generation's particles and the picks resampling made
/// of them, the cells the new generation goes to, the next one to take, and one slot
/// per member. Members take particles one at a time from `next`: particle j is a copy
/// of the previous generation's particle `picks[j]` (into the buffers of the particle
/// that was in cell j two generations ago), then stepped. A member that is slow (or
/// descheduled) leaves the rest to the others; which member takes a particle does not
/// change the results (each particle has its own random stream).
struct Shared<'b> {
    job: RwLock<Job>,
    /// The pending calls of earlier rounds, by segment.
    frozen: RwLock<Vec<Vec<Pending>>>,
    /// Two arrays of cells, the previous generation and the one being stepped, which
    /// swap roles every generation (`job.src`).
    cells: [Vec<RwLock<Cell>>; 2],
    picks: RwLock<Vec<usize>>,
    next: AtomicUsize,
    cur: Vec<Mutex<Slot<'b>>>,
    /// Set by a member that found the deadline passed or the search cancelled: the
    /// round was cut short.
    cut: AtomicBool,
    /// The search's cancel flag ([`SearchOptions::cancel`]).
    cancel: Option<Cancel>,
}

fn read<T>(l: &RwLock<T>) -> RwLockReadGuard<'_, T> {
    l.read().unwrap_or_else(|e| e.into_inner())
}

fn write<T>(l: &RwLock<T>) -> RwLockWriteGuard<'_, T> {
    l.write().unwrap_or_else(|e| e.into_inner())
}

fn lock<T>(l: &Mutex<T>) -> MutexGuard<'_, T> {
    l.lock().unwrap_or_else(|e| e.into_inner())
}

/// A bundle and guides prepared for searching: skeleton and wrap-up tables, the
/// guides' curves, and the EXPECTED vectors (estimated once, by forward sampling).
pub struct Prepared<'b> {
    b: &'b Bundle,
    skeleton: Vec<bool>,
    wrapup: Vec<u32>,
    guides: Guides,
    /// EXPECTED(n) per rule in the rule's own frame (`None`: not a skeleton rule, or
    /// its samples made no bones).
    expected: Vec<Option<DVec3>>,
    /// Time spent preparing (mostly the EXPECTED estimate).
    pub prepare_time: Duration,
}

fn to_d(v: Vec3) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

pub use crate::MAX_UTILISATION_COUNTS;

impl<'b> Prepared<'b> {
    /// Prepares `b`'s guided table with `guides` (those of the table, or a guide file's).
    pub fn new(b: &'b Bundle, table: &GuidedTable, guides: &[Guide]) -> Result<Prepared<'b>, PrepareError> {
        Prepared::new_within(b, table, guides, None)
    }

    /// [`Prepared::new`] that gives up once `deadline` has passed (checked between
    /// guides: ten thousand curves take seconds to prepare).
    pub fn new_within(
        b: &'b Bundle,
        table: &GuidedTable,
        guides: &[Guide],
        deadline: Option<Instant>,
    ) -> Result<Prepared<'b>, PrepareError> {
        let started = Instant::now();
        if guides.is_empty() {
            return Err(PrepareError::NoGuides);
        }
        table.verify(b)?;
        let n = b.rules.len();
        let mut skeleton = vec![false; n];
        for &r in &table.skeleton {
            skeleton[r as usize] = true;
        }
        let mut wrapup = vec![NONE; n];
        for &(from, to) in &table.wrapups {
            wrapup[from as usize] = to;
        }
        let mut guides = Guides::new_within(guides, deadline)?;
        guides.utilisation = table.settings.utilisation.unwrap_or_default();
        let mut p = Prepared { b, skeleton, wrapup, guides, expected: vec![None; n], prepare_time: Duration::ZERO };
        p.expected = p.estimate_expected(table.settings.expected);
        p.prepare_time = started.elapsed();
        Ok(p)
    }

    /// The prepared guides.
    pub fn guides(&self) -> &Guides {
        &self.guides
    }

    /// These guides with another utilisation term ([`Utilisation`]) than the `search`
    /// section's (`mdg-run --utilisation`, `L` in `mdg-view`).
    pub fn with_utilisation(mut self, u: Utilisation) -> Prepared<'b> {
        self.guides.utilisation = u;
        self
    }

    /// EXPECTED(rule), if estimated.
    pub fn expected(&self, rule: u32) -> Option<DVec3> {
        self.expected.get(rule as usize).copied().flatten()
    }

    /// Whether `rule` is a skeleton rule.
    pub fn is_skeleton(&self, rule: u32) -> bool {
        self.skeleton.get(rule as usize).copied().unwrap_or(false)
    }

    /// EXPECTED(n) for every skeleton rule n (eq. 9): the mean over `samples` forward
    /// samples from n at the identity of each sample's mean bone vector (TIP − BASE),
    /// each sample expanding up to `steps` skeleton calls chosen uniformly at random.
    /// Samples without bones are left out. Deterministic (fixed streams).
    fn estimate_expected(&self, (samples, steps): (u32, u32)) -> Vec<Option<DVec3>> {
        let b = self.b;
        let rules: Vec<u32> = (0..b.rules.len() as u32).filter(|&r| self.is_skeleton(r)).collect();
        let jobs: Vec<(u32, u32)> = rules.iter().flat_map(|&r| (0..samples).map(move |s| (r, s))).collect();
        let means: Vec<Option<DVec3>> = jobs
            .par_iter()
            .map_init(
                || (Expander::new(b), Vec::new(), Vec::new()),
                |(ex, pending, out), &(rule, sample)| {
                    ex.reseed(EXPECTED_SEED ^ rule as u64, sample as u64);
                    pending.clear();
                    let start = Call::start(b);
                    pending.push(Call { rule, state: start.state, depth: 0 });
                    let (mut sum, mut n) = (DVec3::ZERO, 0u32);
                    for _ in 0..steps {
                        if pending.is_empty() {
                            break;
                        }
                        let k = ex.index(pending.len());
                        let call: Call = pending.swap_remove(k);
                        out.clear();
                        ex.expand(&call, out);
                        let base = to_d(call.state.f.u);
                        for c in out.iter() {
                            if self.is_skeleton(c.rule) {
                                let v = to_d(c.state.f.u) - base;
                                if v.length() > super::cost::MIN_BONE_LENGTH {
                                    sum += v;
                                    n += 1;
                                }
                                pending.push(*c);
                            }
                        }
                    }
                    (n > 0).then(|| sum / n as f64)
                },
            )
            .collect();
        let mut expected = vec![None; b.rules.len()];
        for (i, &r) in rules.iter().enumerate() {
            let per = &means[i * samples as usize..(i + 1) * samples as usize];
            let (sum, k) = per.iter().flatten().fold((DVec3::ZERO, 0u32), |(s, k), v| (s + *v, k + 1));
            expected[r as usize] = (k > 0).then(|| sum / k as f64);
        }
        expected
    }

    fn pending(&self, call: Call, with_h: bool) -> (Pending, f64) {
        self.pending_at(call, self.guides.nearest(to_d(call.state.f.u)), with_h)
    }

    /// A pending call whose origin's nearest guide is known; its heuristic term only
    /// `with_h` (once the heuristic scale is 0 it stays 0, and the terms are unused).
    fn pending_at(&self, call: Call, near: Option<Near>, with_h: bool) -> (Pending, f64) {
        let h = match (near, self.expected(call.rule)) {
            (Some(n), Some(e)) if with_h => {
                let world = to_d(call.state.f.apply_vector(Vec3::new(e.x as f32, e.y as f32, e.z as f32)));
                self.guides.heuristic(&n, world)
            }
            _ => 0.0,
        };
        (Pending { call, near }, h)
    }

    fn initial(&self, store: &mut Store) -> Particle {
        let start = Call::start(self.b);
        let mut p = Particle {
            history: None,
            pending: Vec::new(),
            counts: vec![0; self.guides.n_segments()],
            cost: Cost::default(),
            score: 0.0,
        };
        if self.is_skeleton(start.rule) {
            let (q, h) = self.pending(start, true);
            p.pending.push(store.add(q, h));
        } else {
            p.history = Some(Arc::new(Record::new(None, &mut vec![Item::Deferred(start)])));
        }
        p
    }

    /// One particle-step: expand uniformly chosen pending calls until one adds a bone
    /// (or none is left). Returns the number of expansions. New pending calls get their
    /// heuristic terms only `with_h`.
    fn step(
        &self,
        p: &mut Particle,
        store: &mut Store,
        ex: &mut Expander,
        out: &mut Vec<Call>,
        items: &mut Vec<Item>,
        with_h: bool,
    ) -> u32 {
        let mut expansions = 0;
        items.clear();
        let mut added = false;
        while !added && !p.pending.is_empty() && expansions < MAX_EXPANSIONS_PER_STEP {
            let k = ex.index(p.pending.len());
            let parent = *store.get(p.pending.swap_remove(k).at);
            out.clear();
            ex.expand(&parent.call, out);
            expansions += 1;
            let base = to_d(parent.call.state.f.u);
            for c in out.iter() {
                if !self.is_skeleton(c.rule) {
                    items.push(Item::Deferred(*c));
                    continue;
                }
                let tip = to_d(c.state.f.u);
                let (child, h) = if tip == base {
                    // Same origin: same nearest guide, no bone.
                    self.pending_at(*c, parent.near, with_h)
                } else {
                    let (child, h) = self.pending(*c, true);
                    if let Some(near) = &parent.near {
                        if let Some(cost) = self.guides.bone_cost(near, base, tip, child.near.as_ref(), &mut p.counts) {
                            p.cost += cost;
                            items.push(Item::Bone(Bone { base, tip, rule: c.rule }));
                            added = true;
                        }
                    }
                    (child, h)
                };
                p.pending.push(store.add(child, h));
            }
        }
        if !items.is_empty() {
            p.history = Some(Arc::new(Record::new(p.history.take(), items)));
        }
        expansions
    }

    /// Checks that a search with `opts` fits in memory: each particle of the two
    /// generations kept keeps one utilisation count per segment of every guide, so
    /// `2 × particles × segments` must stay within [`MAX_UTILISATION_COUNTS`] (long
    /// guides with short segments and many particles made gigabytes). Call it before
    /// [`Prepared::search`].
    pub fn check_size(&self, opts: &SearchOptions) -> Result<(), PrepareError> {
        let largest = u64::from(opts.particles.0.max(opts.particles.1).max(1));
        let segments = self.guides.n_segments() as u64;
        let counts = 2 * largest * segments;
        if counts > MAX_UTILISATION_COUNTS {
            return Err(PrepareError::TooLarge { counts, particles: largest, segments });
        }
        Ok(())
    }

    /// Runs the search.
    pub fn search(&self, opts: &SearchOptions, progress: Option<&(dyn Fn(&Progress) + Sync)>) -> SearchResult {
        let threads = opts.threads.unwrap_or_else(rayon::current_num_threads).max(1);
        let largest = opts.particles.0.max(opts.particles.1) as usize;
        let members = if threads > 1 && largest >= opts.parallel_min.max(1) { threads } else { 1 };
        let b = self.b;
        let sh = Shared {
            job: RwLock::new(Job { g: 0, n: 0, h: 0.0, seed: opts.seed, first: 0, src: 0, deadline: None }),
            frozen: RwLock::new(Vec::new()),
            // No generation has more particles than the larger end of the ramp.
            cells: [0, 1].map(|_| (0..largest.max(1)).map(|_| RwLock::new(Cell::default())).collect()),
            picks: RwLock::new(Vec::new()),
            next: AtomicUsize::new(0),
            cur: (0..members)
                .map(|_| {
                    Mutex::new(Slot {
                        local: Vec::new(),
                        ex: Expander::new(b),
                        out: Vec::with_capacity(16),
                        items: Vec::with_capacity(8),
                    })
                })
                .collect(),
            cut: AtomicBool::new(false),
            cancel: opts.cancel.clone(),
        };
        let member = |t: usize| self.member(&sh, t);
        Team::run(members, &member, |team| self.lead(team, &sh, opts, progress))
    }

    /// Member `t`'s part of a generation: each particle it takes, copied from its
    /// parent and stepped.
    fn member(&self, sh: &Shared<'b>, t: usize) {
        let Job { g, n, h, seed, first, src, deadline } = *read(&sh.job);
        let (from, to) = (&sh.cells[src], &sh.cells[1 - src]);
        let picks = read(&sh.picks);
        let frozen = read(&sh.frozen);
        let mut slot = lock(&sh.cur[t]);
        let Slot { local, ex, out, items } = &mut *slot;
        let mut store = Store { frozen: &frozen, id: first + t as u32, local };
        loop {
            if deadline.is_some_and(|d| Instant::now() >= d) || sh.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
                sh.cut.store(true, Ordering::Relaxed);
                break;
            }
            let j = sh.next.fetch_add(1, Ordering::Relaxed);
            let (Some(cell), Some(source)) = (to.get(j).filter(|_| j < n), picks.get(j).and_then(|&k| from.get(k)))
            else {
                break;
            };
            let mut cell = write(cell);
            match (&mut cell.p, &read(source).p) {
                (Some(buf), Some(p)) => buf.clone_from(p),
                (buf, Some(p)) => *buf = Some(p.clone()),
                (_, None) => continue,
            }
            let Cell { p: Some(p), r } = &mut *cell else { continue };
            let active = !p.pending.is_empty();
            ex.reseed(seed, ((g as u64) << 32) | j as u64);
            let e = self.step(p, &mut store, ex, out, items, h > 0.0);
            let now = p.cost.total() + h * p.heuristic();
            let lw = -(now - p.score);
            p.score = now;
            *r = (e, active, lw);
        }
    }

    /// The generations: each stepped by the team, weighted and resampled here.
    fn lead(
        &self,
        team: &Team,
        sh: &Shared<'b>,
        opts: &SearchOptions,
        progress: Option<&(dyn Fn(&Progress) + Sync)>,
    ) -> SearchResult {
        let started = Instant::now();
        let deadline = opts.budget.and_then(|b| opts.clock.unwrap_or(started).checked_add(b));
        let mut master = Expander::new(self.b);
        master.reseed(opts.seed, RESAMPLE_STREAM);
        let mut seg0 = Vec::new();
        let mut first = self.initial(&mut Store { frozen: &[], id: 0, local: &mut seg0 });
        write(&sh.frozen).push(seg0);
        first.score = first.cost.total() + opts.heuristic_at(0) * first.heuristic();
        // Generation 0: every particle a copy of the first.
        let mut src = 0;
        if let Some(c) = sh.cells[src].first() {
            write(c).p = Some(first);
        }
        *write(&sh.picks) = vec![0; opts.particles_at(0)];
        let (mut steps, mut expansions) = (0u64, 0u64);
        let mut generation = 0u32;
        let mut stop = Stop::Generations;
        let mut results: Vec<(u32, bool, f64)> = Vec::new();
        // The particles kept for the choice of the model, with their generations.
        let mut kept = Kept::new(opts.choice);
        // The population is always `picks` into the previous generation (`src`).
        let is_done = |p: &Option<Particle>| p.as_ref().is_none_or(|p| p.pending.is_empty());
        while generation < opts.generations {
            if read(&sh.picks).iter().all(|&k| sh.cells[src].get(k).is_none_or(|c| is_done(&read(c).p))) {
                stop = Stop::Complete;
                break;
            }
            if opts.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
                stop = Stop::Cancelled;
                break;
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                stop = Stop::Budget;
                break;
            }
            let g = generation;
            let n = read(&sh.picks).len().min(sh.cells[src].len());
            let first = read(&sh.frozen).len() as u32;
            *write(&sh.job) = Job { g, n, h: opts.heuristic_at(g), seed: opts.seed, first, src, deadline };
            sh.next.store(0, Ordering::Relaxed);
            // Small generations stay on this thread (handing them over costs more
            // than it saves).
            if n < opts.parallel_min.max(1) {
                self.member(sh, 0);
            } else {
                team.round();
            }
            // Cut short by the budget or a cancel: this generation is dropped (the
            // previous one and the best seen stand).
            if sh.cut.load(Ordering::Relaxed) {
                stop =
                    if opts.cancel.as_ref().is_some_and(Cancel::is_cancelled) { Stop::Cancelled } else { Stop::Budget };
                break;
            }
            src = 1 - src;
            let stepped = &sh.cells[src][..n];
            results.clear();
            results.extend(stepped.iter().map(|c| read(c).r));
            let mut frozen = write(&sh.frozen);
            for cur in &sh.cur {
                let mut slot = lock(cur);
                // Member t's new calls become segment `first + t` (empty if it did not run).
                // (The next round's buffer starts at this one's size: no regrowing.)
                let size = slot.local.len();
                frozen.push(std::mem::replace(&mut slot.local, Vec::with_capacity(size + size / 4)));
            }
            drop(frozen);
            for (e, active, _) in &results {
                expansions += *e as u64;
                steps += *active as u64;
            }
            generation += 1;
            // This generation's costs and reaches (a missing particle never wins);
            // what the choice of the model wants of them is kept.
            let (mut costs, mut reaches) = (vec![f64::NAN; n], vec![0; n]);
            for (k, c) in stepped.iter().enumerate() {
                if let Some(p) = read(c).p.as_ref() {
                    costs[k] = p.cost.total();
                    reaches[k] = if matches!(opts.choice, ModelChoice::Reach(_)) { reach(p) } else { 0 };
                }
            }
            for k in kept.wanted(&costs, &reaches) {
                if let Some(p) = read(&stepped[k]).p.as_ref() {
                    let (cost, reach) = (costs[k], reaches[k]);
                    kept.keep(Candidate { cost, reach, generation, particle: p.clone() });
                }
            }
            if let Some(f) = progress {
                let best_cost = costs.iter().copied().filter(|c| !c.is_nan()).fold(f64::INFINITY, f64::min);
                f(&Progress { generation, generations: opts.generations, best_cost });
            }
            let picks = if generation < opts.generations {
                let lw: Vec<f64> = results.iter().map(|r| r.2).collect();
                let w = weights_from_log(&lw);
                let m = opts.particles_at(generation);
                resample(opts.resampling, &w, m, &mut || master.uniform())
            } else {
                (0..n).collect()
            };
            // Keep the stored calls within a small multiple of those still referenced
            // (by the picked particles: the others are only ever overwritten). Counting
            // the referenced ones locks every picked cell, so it waits until the store
            // holds more than the slack alone allows.
            let mut frozen = write(&sh.frozen);
            let stored: usize = frozen.iter().map(Vec::len).sum();
            if stored > COMPACT_SLACK {
                let mut picked: Vec<usize> = picks.clone();
                picked.dedup();
                let mut guards: Vec<_> = picked.iter().filter_map(|&k| stepped.get(k)).map(write).collect();
                let live: usize =
                    guards.iter().filter_map(|c| c.p.as_ref()).map(|p| p.pending.len()).sum::<usize>() + kept.pending();
                if stored > 2 * live + COMPACT_SLACK {
                    // (The particles kept for the choice refer to the store too.)
                    let particles = guards.iter_mut().filter_map(|c| c.p.as_mut()).chain(kept.particles_mut());
                    let seg = compact(&frozen, particles);
                    *frozen = vec![seg];
                }
            }
            drop(frozen);
            *write(&sh.picks) = picks;
        }
        // The model: as `opts.choice` says, among the kept particles and the final ones.
        let picks = read(&sh.picks);
        let guards: Vec<_> = sh.cells[src].iter().map(read).collect();
        let finals: Vec<&Particle> = picks.iter().filter_map(|&k| guards.get(k).and_then(|c| c.p.as_ref())).collect();
        let final_costs: Vec<f64> = finals.iter().map(|p| p.cost.total()).collect();
        let chosen = argmin(&final_costs);
        let frozen = read(&sh.frozen);
        let store = Store { frozen: &frozen, id: u32::MAX, local: &mut Vec::new() };
        let (model, model_generation) = match kept.choose(&finals) {
            Some(Ok((p, g))) => (self.wrap_up(p, &store), g),
            Some(Err(k)) => (self.wrap_up(finals[k], &store), generation),
            None => (
                Model { cost: Cost::default(), bones: Vec::new(), calls: Vec::new(), wrapped: 0, dropped: 0 },
                generation,
            ),
        };
        SearchResult {
            model,
            final_costs,
            chosen,
            model_generation,
            generations: generation,
            particle_steps: steps,
            expansions,
            stop,
            elapsed: started.elapsed(),
        }
    }

    /// The forward-sampling baseline: `samples` independent derivations of `steps`
    /// particle-steps each (no weights, no resampling), each wrapped up; returns the
    /// one with the lowest COST. Stops early at `budget`. Sample i uses stream i of `seed`.
    pub fn forward_best(&self, samples: u32, steps: u32, seed: u64, budget: Option<Duration>) -> SearchResult {
        let started = Instant::now();
        let b = self.b;
        let runs: Vec<Option<Sample>> = (0..samples)
            .into_par_iter()
            .map_init(
                || (Expander::new(b), Vec::with_capacity(16), Vec::with_capacity(8)),
                |(ex, out, items), i| {
                    if budget.is_some_and(|t| started.elapsed() >= t) {
                        return None;
                    }
                    let mut local = Vec::new();
                    let mut store = Store { frozen: &[], id: 0, local: &mut local };
                    let mut p = self.initial(&mut store);
                    ex.reseed(seed, i as u64);
                    let (mut n, mut e) = (0u64, 0u64);
                    for _ in 0..steps {
                        if p.pending.is_empty() {
                            break;
                        }
                        e += self.step(&mut p, &mut store, ex, out, items, false) as u64;
                        n += 1;
                    }
                    Some((p, local, n, e))
                },
            )
            .collect();
        let mut done: Vec<Sample> = runs.into_iter().flatten().collect();
        let final_costs: Vec<f64> = done.iter().map(|r| r.0.cost.total()).collect();
        let chosen = argmin(&final_costs);
        let mut local = Vec::new();
        let model = match done.get_mut(chosen) {
            Some((p, seg, _, _)) => self.wrap_up(p, &Store { frozen: &[], id: 0, local: seg }),
            None => {
                let mut store = Store { frozen: &[], id: 0, local: &mut local };
                let p = self.initial(&mut store);
                self.wrap_up(&p, &store)
            }
        };
        SearchResult {
            model,
            final_costs,
            chosen,
            model_generation: steps,
            generations: steps,
            particle_steps: done.iter().map(|r| r.2).sum(),
            expansions: done.iter().map(|r| r.3).sum(),
            stop: if done.len() < samples as usize { Stop::Budget } else { Stop::Generations },
            elapsed: started.elapsed(),
        }
    }

    /// The wrap-up phase: a particle's history and leftover calls as a finished model.
    fn wrap_up(&self, p: &Particle, store: &Store) -> Model {
        let mut records = Vec::new();
        let mut at = p.history.as_deref();
        while let Some(r) = at {
            records.push(r);
            at = r.prev.as_deref();
        }
        let mut bones = Vec::new();
        let mut calls = Vec::new();
        for r in records.iter().rev() {
            for it in r.items() {
                match it {
                    Item::Bone(b) => bones.push(*b),
                    Item::Deferred(c) => calls.push(*c),
                }
            }
        }
        let (mut wrapped, mut dropped) = (0, 0);
        for r in &p.pending {
            let q = store.get(r.at);
            match self.wrapup.get(q.call.rule as usize) {
                Some(&to) if to != NONE => {
                    calls.push(Call { rule: to, ..q.call });
                    wrapped += 1;
                }
                _ => dropped += 1,
            }
        }
        Model { cost: p.cost, bones, calls, wrapped, dropped }
    }

    /// The geometry phase: evaluates the model's calls without optimisation. With
    /// `lines`, also adds the guides (namespace `guides`, 24 points per segment) and
    /// the bones (namespace `bones`, one two-point line each) as line geometry.
    pub fn geometry(&self, model: &Model, opts: &EvalOptions, lines: bool) -> Output {
        let mut out = evaluate_calls(self.b, opts, &model.calls);
        if lines {
            out.lines.extend(self.line_geometry(model));
        }
        out
    }

    /// The guides and the model's bones as polylines (namespaces `guides` and `bones`).
    pub fn line_geometry(&self, model: &Model) -> Vec<Polyline> {
        let f = |v: DVec3| [v.x as f32, v.y as f32, v.z as f32];
        let mut lines = Vec::new();
        for i in 0..self.guides.len() {
            let pts = self.guides.path(i).polyline(24);
            lines.push(Polyline {
                namespace: "guides".into(),
                points: pts.into_iter().map(f).collect(),
                bones: vec![],
            });
        }
        for bone in &model.bones {
            lines.push(Polyline { namespace: "bones".into(), points: vec![f(bone.base), f(bone.tip)], bones: vec![] });
        }
        lines
    }

    /// COST of a set of bones computed from scratch, in the given order (for checking
    /// that the search's incremental sums are right and order-independent).
    pub fn cost_of(&self, bones: &[Bone]) -> Cost {
        let mut counts = vec![0u32; self.guides.n_segments()];
        let mut total = Cost::default();
        for bone in bones {
            if let Some(near) = self.guides.nearest(bone.base) {
                let tip_near = self.guides.nearest(bone.tip);
                if let Some(c) = self.guides.bone_cost(&near, bone.base, bone.tip, tip_near.as_ref(), &mut counts) {
                    total += c;
                }
            }
        }
        total
    }

    /// The utilisation segments a set of bones uses (its *reach*, [`ModelChoice::Reach`]).
    pub fn segments_used(&self, bones: &[Bone]) -> usize {
        let mut counts = vec![0u32; self.guides.n_segments()];
        for bone in bones {
            if let Some(near) = self.guides.nearest(bone.base) {
                let tip_near = self.guides.nearest(bone.tip);
                self.guides.bone_cost(&near, bone.base, bone.tip, tip_near.as_ref(), &mut counts);
            }
        }
        counts.iter().filter(|&&c| c > 0).count()
    }

    /// Expands the start shape's skeleton completely (up to `max_expansions`), choosing
    /// the next pending call with `pick(pending count) → index` and drawing every
    /// expansion's random numbers from a stream of its own (keyed by the call's
    /// position in the derivation tree), so any order of expansion builds the same
    /// skeleton. Returns the incrementally summed cost and the bones (for tests of
    /// order independence).
    pub fn expand_in_order(
        &self,
        seed: u64,
        max_expansions: u32,
        pick: &mut dyn FnMut(usize) -> usize,
    ) -> (Cost, Vec<Bone>) {
        let mut ex = Expander::new(self.b);
        let mut local = Vec::new();
        let mut store = Store { frozen: &[], id: 0, local: &mut local };
        let mut p = self.initial(&mut store);
        // Each pending call's key: a path in the derivation tree, hashed.
        let mut keys: Vec<u64> = p.pending.iter().map(|_| 1).collect();
        let mut out = Vec::new();
        let mut bones = Vec::new();
        for _ in 0..max_expansions {
            if p.pending.is_empty() {
                break;
            }
            let k = pick(p.pending.len()).min(p.pending.len() - 1);
            let parent = *store.get(p.pending.remove(k).at);
            let key = keys.remove(k);
            ex.reseed(seed, key);
            out.clear();
            ex.expand(&parent.call, &mut out);
            let base = to_d(parent.call.state.f.u);
            for (i, c) in out.iter().enumerate() {
                if !self.is_skeleton(c.rule) {
                    continue;
                }
                let tip = to_d(c.state.f.u);
                let (child, h) = self.pending(*c, true);
                if let Some(near) = &parent.near {
                    if let Some(cost) = self.guides.bone_cost(near, base, tip, child.near.as_ref(), &mut p.counts) {
                        p.cost += cost;
                        bones.push(Bone { base, tip, rule: c.rule });
                    }
                }
                p.pending.push(store.add(child, h));
                keys.push(key.wrapping_mul(0x100_0000_01B3).wrapping_add(i as u64 + 1).rotate_left(17));
            }
        }
        (p.cost, bones)
    }
}

/// The first index of the smallest value (NaN counts as +∞).
fn argmin(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &x) in v.iter().enumerate() {
        let b = v[best];
        if x < b || (b.is_nan() && !x.is_nan()) {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests;
