//! Structure rules (increase, insert, replace, combine), the rule metric C_r, and
//! the selection strategies (rank, uniform, roulette) for shapes and rules.
//!
//! A rule rewrites a whole symmetry group at once: increasing one arm of a
//! humanoid increases the other, replacing one leg replaces both.

use super::cond::{self, Env};
use super::shape::{slot_and_partner, Attachment, MetaPart, Shape, SuperPart};
use super::table::{CreatureTable, Mode, RuleDef, RuleKind, Strategy};
use rand::{Rng as _, SeedableRng};
use rand_pcg::Pcg64;

/// The evolution's random stream (PCG-64; floats from the top 53 bits).
pub struct Rng(Pcg64);

impl Rng {
    /// A stream for `seed`.
    pub fn new(seed: u64) -> Rng {
        Rng(Pcg64::seed_from_u64(seed))
    }

    /// A stream of its own for item `index` of `stream` (offspring, generation, …),
    /// so results do not depend on the order or the thread they are made in.
    pub fn stream(seed: u64, stream: u64, index: u64) -> Rng {
        let mut h = seed ^ 0x9e37_79b9_7f4a_7c15;
        for v in [stream, index] {
            h = (h ^ v).wrapping_mul(0xff51_afd7_ed55_8ccd);
            h ^= h >> 33;
        }
        Rng::new(h)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform integer in 0..n (0 when n is 0).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            return 0;
        }
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }
}

/// Picks an index with probability proportional to `weights` (uniformly when
/// they are all zero). `None` for an empty list.
pub fn roulette(weights: &[f64], rng: &mut Rng) -> Option<usize> {
    if weights.is_empty() {
        return None;
    }
    let w: Vec<f64> = weights.iter().map(|&x| if x.is_finite() && x > 0.0 { x } else { 0.0 }).collect();
    let total: f64 = w.iter().sum();
    if total <= 0.0 {
        return Some(rng.below(w.len()));
    }
    let mut r = rng.uniform() * total;
    for (i, x) in w.iter().enumerate() {
        if r < *x {
            return Some(i);
        }
        r -= x;
    }
    w.iter().rposition(|&x| x > 0.0)
}

/// Selects one of `metrics.len()` members by `strategy` over their metric:
/// `uniform` ignores it, `roulette` is proportional to it, `rank` gives the member
/// of rank r (1 = lowest metric, ties by index) weight r, so the best is the most
/// likely without taking every pick.
pub fn select(strategy: Strategy, metrics: &[f64], rng: &mut Rng) -> Option<usize> {
    match strategy {
        Strategy::Uniform => (!metrics.is_empty()).then(|| rng.below(metrics.len())),
        Strategy::Roulette => roulette(metrics, rng),
        Strategy::Rank => {
            let mut order: Vec<usize> = (0..metrics.len()).collect();
            order.sort_by(|&a, &b| metrics[a].total_cmp(&metrics[b]).then(a.cmp(&b)));
            let mut w = vec![0.0; metrics.len()];
            for (r, &i) in order.iter().enumerate() {
                w[i] = (r + 1) as f64;
            }
            roulette(&w, rng)
        }
    }
}

/// The rule metric C_r (paper §3.2): for increase rules w1 = 0.5 when
/// C_s1 + C_s2 ≤ δ = 63.33, else w2 = 0.1; for combine and insert rules w1 = 0.4,
/// w2 = 0.1, δ = 72.3; for replace rules the constant 0.35.
pub fn rule_metric(kind: RuleKind, cs_base: f64, cs_assist: f64) -> f64 {
    let sum = cs_base + cs_assist;
    match kind {
        RuleKind::Increase => {
            if sum <= 63.33 {
                0.5
            } else {
                0.1
            }
        }
        RuleKind::Insert | RuleKind::Combine => {
            if sum <= 72.3 {
                0.4
            } else {
                0.1
            }
        }
        RuleKind::Replace => 0.35,
    }
}

/// What a condition or probability reads for one match.
pub struct ShapeEnv<'a> {
    pub table: &'a CreatureTable,
    pub shape: &'a Shape,
    pub g: u32,
    /// Meta-parts in the matched super-part.
    pub count: u32,
    pub complexity: f64,
}

impl Env for ShapeEnv<'_> {
    fn var(&self, i: u8) -> f64 {
        match i {
            0 => self.g as f64,
            1 => self.shape.supers.len() as f64,
            2 => self.shape.n_metas() as f64,
            3 => self.count as f64,
            4 => self.shape.n_torsos(self.table) as f64,
            5 => self.complexity,
            _ => f64::NAN,
        }
    }
    fn parts(&self, kind: u32) -> f64 {
        self.shape.supers.iter().filter(|s| s.kind == kind).count() as f64
    }
}

/// Where a rule can rewrite the base shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// `increase` / `replace`: super-part `sp` (and its symmetry group).
    Super { sp: usize },
    /// `insert`: kind `kind` into slot `slot` of torso super-part `torso`.
    Slot { torso: usize, slot: u32, kind: u32 },
    /// `combine`: remove the predecessor parts of torso `torso`, bring the assist's
    /// root torso; `child_slot` is set when the assist torso attaches to a slot of
    /// `torso`, `root_slot` when `torso` (the base root) attaches to a slot of it.
    Combine { torso: usize, child_slot: Option<u32>, root_slot: Option<u32> },
}

impl Target {
    fn count(&self, shape: &Shape) -> u32 {
        match self {
            Target::Super { sp } | Target::Slot { torso: sp, .. } | Target::Combine { torso: sp, .. } => {
                shape.supers.get(*sp).map(|s| s.metas.len() as u32).unwrap_or(0)
            }
        }
    }
}

fn category_of(t: &CreatureTable, sp: &SuperPart) -> Option<u32> {
    sp.metas.first().and_then(|m| t.parts.get(m.geometry as usize)).map(|p| p.category)
}

fn is_torso(t: &CreatureTable, kind: u32) -> bool {
    t.kinds.get(kind as usize).is_some_and(|k| k.torso)
}

fn torso_part<'a>(t: &'a CreatureTable, shape: &Shape, sp: usize) -> Option<&'a super::table::PartDef> {
    shape.supers.get(sp).and_then(|s| s.metas.first()).and_then(|m| t.parts.get(m.geometry as usize))
}

/// Every place rule `r` can rewrite `base` (with `assist` as the other parent),
/// before conditions: one target per symmetry group.
pub fn targets(t: &CreatureTable, r: &RuleDef, base: &Shape, assist: &Shape) -> Vec<Target> {
    let mut out = Vec::new();
    let cat_ok = |sp: &SuperPart| r.category.is_none() || category_of(t, sp) == r.category;
    let mut seen_sym = Vec::new();
    match r.kind {
        RuleKind::Increase | RuleKind::Replace => {
            for (i, sp) in base.supers.iter().enumerate() {
                if !r.predecessor.contains(&sp.kind) || !cat_ok(sp) || seen_sym.contains(&sp.sym) {
                    continue;
                }
                if r.kind == RuleKind::Increase {
                    if is_torso(t, sp.kind) || sp.metas.len() as u32 + r.add.max(1) > r.max {
                        continue;
                    }
                } else if replacement_candidates(t, r, base, i, assist).is_empty() {
                    continue;
                }
                seen_sym.push(sp.sym);
                out.push(Target::Super { sp: i });
            }
        }
        RuleKind::Insert => {
            for (i, sp) in base.supers.iter().enumerate() {
                if !r.predecessor.contains(&sp.kind) || !cat_ok(sp) {
                    continue;
                }
                let Some(part) = torso_part(t, base, i) else { continue };
                let attached: Vec<u32> = base.children(i as u32).map(|c| base.supers[c].kind).collect();
                let used: Vec<u32> =
                    base.children(i as u32).filter_map(|c| base.supers[c].attach.map(|a| a.slot)).collect();
                for (si, slot) in part.slots.iter().enumerate() {
                    if slot.mirror_of.is_some() || used.contains(&(si as u32)) {
                        continue;
                    }
                    for &k in &r.successor {
                        if slot.accepts.contains(&k) && !attached.contains(&k) && !is_torso(t, k) {
                            out.push(Target::Slot { torso: i, slot: si as u32, kind: k });
                        }
                    }
                }
            }
        }
        RuleKind::Combine => {
            let Some(other) = assist.supers.first() else { return out };
            let Some(other_part) = torso_part(t, assist, 0) else { return out };
            if r.from.is_some() && Some(other_part.category) != r.from {
                return out;
            }
            for (i, sp) in base.supers.iter().enumerate() {
                if !is_torso(t, sp.kind) || !cat_ok(sp) {
                    continue;
                }
                let Some(part) = torso_part(t, base, i) else { continue };
                if std::ptr::eq(part, other_part) {
                    continue;
                }
                let removed: Vec<usize> =
                    base.children(i as u32).filter(|&c| r.predecessor.contains(&base.supers[c].kind)).collect();
                if removed.is_empty() {
                    continue;
                }
                let used: Vec<u32> = base
                    .children(i as u32)
                    .filter(|c| !removed.contains(c))
                    .filter_map(|c| base.supers[c].attach.map(|a| a.slot))
                    .collect();
                let child_slot = if other_part.joint.is_some() {
                    part.slots
                        .iter()
                        .enumerate()
                        .find(|(si, s)| {
                            s.partner.is_none() && s.accepts.contains(&other.kind) && !used.contains(&(*si as u32))
                        })
                        .map(|(si, _)| si as u32)
                } else {
                    None
                };
                let taken: Vec<u32> = assist
                    .children(0)
                    .filter(|&c| r.take.contains(&assist.supers[c].kind))
                    .filter_map(|c| assist.supers[c].attach.map(|a| a.slot))
                    .collect();
                let root_slot = if child_slot.is_none() && i == 0 && part.joint.is_some() {
                    other_part
                        .slots
                        .iter()
                        .enumerate()
                        .find(|(si, s)| {
                            s.partner.is_none() && s.accepts.contains(&sp.kind) && !taken.contains(&(*si as u32))
                        })
                        .map(|(si, _)| si as u32)
                } else {
                    None
                };
                if child_slot.is_some() || root_slot.is_some() {
                    out.push(Target::Combine { torso: i, child_slot, root_slot });
                }
            }
        }
    }
    out
}

/// Parts a `replace` rule may put into super-part `sp`: of a successor kind (or,
/// without successors, any kind of the predecessor's allelic family), accepted by
/// the slot, from the rule's category if it names one, and not the geometry it has.
fn replacement_candidates(t: &CreatureTable, r: &RuleDef, base: &Shape, sp: usize, assist: &Shape) -> Vec<u32> {
    let Some(s) = base.supers.get(sp) else { return Vec::new() };
    let Some(a) = s.attach else { return Vec::new() };
    let Some(slot) = torso_part(t, base, a.parent as usize).and_then(|p| p.slots.get(a.slot as usize)) else {
        return Vec::new();
    };
    let kinds = if r.successor.is_empty() { t.family(s.kind) } else { r.successor.clone() };
    let current = s.metas.first().map(|m| m.geometry);
    part_candidates(t, &kinds, &slot.accepts, r.from, current, assist)
}

/// Library parts of one of `kinds` accepted by a slot (`accepts`), of category
/// `from` if given, other than `exclude`. Parts the assist shape has come first:
/// if it has any, only those are returned (the paper combines the two parents).
fn part_candidates(
    t: &CreatureTable,
    kinds: &[u32],
    accepts: &[u32],
    from: Option<u32>,
    exclude: Option<u32>,
    assist: &Shape,
) -> Vec<u32> {
    let ok = |p: u32| {
        let Some(d) = t.parts.get(p as usize) else { return false };
        kinds.contains(&d.kind)
            && accepts.contains(&d.kind)
            && from.is_none_or(|c| d.category == c)
            && Some(p) != exclude
            && !is_torso(t, d.kind)
    };
    let mut from_assist: Vec<u32> =
        assist.supers.iter().flat_map(|s| s.metas.iter().map(|m| m.geometry)).filter(|&p| ok(p)).collect();
    from_assist.sort_unstable();
    from_assist.dedup();
    if !from_assist.is_empty() {
        return from_assist;
    }
    (0..t.parts.len() as u32).filter(|&p| ok(p)).collect()
}

/// Targets of rule `r` whose conditions all hold.
pub fn valid_targets(t: &CreatureTable, r: &RuleDef, base: &Shape, assist: &Shape, g: u32) -> Vec<Target> {
    let complexity = base.complexity();
    let mut stack = mdg_vm::expr::Machine::default();
    targets(t, r, base, assist)
        .into_iter()
        .filter(|tg| {
            let env = ShapeEnv { table: t, shape: base, g, count: tg.count(base), complexity };
            r.conditions.iter().all(|c| {
                let v = cond::eval(&c.0, &env, &mut stack);
                v.is_finite() && v != 0.0
            })
        })
        .collect()
}

/// The probability of the function branch of `r` at `target`, clamped to [0, 1]
/// (NaN counts as 0; the compiler rejects expressions that can leave the range).
pub fn probability(t: &CreatureTable, r: &RuleDef, base: &Shape, target: &Target, g: u32) -> f64 {
    let env = ShapeEnv { table: t, shape: base, g, count: target.count(base), complexity: base.complexity() };
    let p = cond::eval(&r.probability.0, &env, &mut mdg_vm::expr::Machine::default());
    if p.is_nan() {
        0.0
    } else {
        p.clamp(0.0, 1.0)
    }
}

/// Applies the function branch of `r` at `target`; `None` when it cannot (no part
/// fits). The identity branch is the shape unchanged.
pub fn apply(
    t: &CreatureTable,
    r: &RuleDef,
    base: &Shape,
    assist: &Shape,
    target: &Target,
    rng: &mut Rng,
) -> Option<Shape> {
    let mut s = base.clone();
    match (r.kind, target) {
        (RuleKind::Increase, Target::Super { sp }) => {
            let sym = base.supers.get(*sp)?.sym;
            let add = r.add.max(1);
            for i in 0..s.supers.len() {
                if s.supers[i].sym != sym {
                    continue;
                }
                let first = s.supers[i].metas.first()?.clone();
                for _ in 0..add {
                    let m = s.new_meta(first.kind, first.geometry);
                    s.supers[i].metas.push(m);
                }
                s.supers[i].mode = if r.arrange == Mode::Def { Mode::Row } else { r.arrange };
            }
            Some(s)
        }
        (RuleKind::Replace, Target::Super { sp }) => {
            let cands = replacement_candidates(t, r, base, *sp, assist);
            let part = *cands.get(rng.below(cands.len()))?;
            let kind = t.parts.get(part as usize)?.kind;
            let sym = base.supers.get(*sp)?.sym;
            for i in 0..s.supers.len() {
                if s.supers[i].sym != sym {
                    continue;
                }
                s.supers[i].kind = kind;
                for m in &mut s.supers[i].metas {
                    *m = MetaPart { kind, id: m.id, geometry: part };
                }
            }
            Some(s)
        }
        (RuleKind::Insert, Target::Slot { torso, slot, kind }) => {
            let torso_geo = base.supers.get(*torso)?.metas.first()?.geometry;
            let accepts = t.parts.get(torso_geo as usize)?.slots.get(*slot as usize)?.accepts.clone();
            let cands = part_candidates(t, &[*kind], &accepts, r.from, None, assist);
            let part = *cands.get(rng.below(cands.len()))?;
            let sym = s.new_sym();
            for sl in slot_and_partner(t, torso_geo, *slot) {
                if s.children(*torso as u32).any(|c| s.supers[c].attach.is_some_and(|a| a.slot == sl)) {
                    continue;
                }
                let m = s.new_meta(*kind, part);
                s.supers.push(SuperPart {
                    kind: *kind,
                    metas: vec![m],
                    mode: Mode::Def,
                    attach: Some(Attachment { parent: *torso as u32, slot: sl }),
                    sym,
                });
            }
            Some(s)
        }
        (RuleKind::Combine, Target::Combine { torso, child_slot, root_slot }) => {
            combine(t, r, base, assist, *torso, *child_slot, *root_slot)
        }
        _ => None,
    }
}

/// `combine`: the base without the predecessor super-parts of `torso`, joined to
/// the assist's root torso and its super-parts of the `take` kinds.
fn combine(
    _t: &CreatureTable,
    r: &RuleDef,
    base: &Shape,
    assist: &Shape,
    torso: usize,
    child_slot: Option<u32>,
    root_slot: Option<u32>,
) -> Option<Shape> {
    let mut s = base.clone();
    let removed: Vec<usize> = s.children(torso as u32).filter(|&c| r.predecessor.contains(&s.supers[c].kind)).collect();
    s.remove(&removed);
    // `torso` precedes its children, so removing them leaves its index unchanged.
    let other = assist.supers.first()?;
    let taken: Vec<usize> = assist.children(0).filter(|&c| r.take.contains(&assist.supers[c].kind)).collect();
    // Fresh ids and symmetry groups for everything brought over.
    let mut sym_map: Vec<(u32, u32)> = Vec::new();
    let mut bring = |s: &mut Shape, sp: &SuperPart, attach: Option<Attachment>| -> SuperPart {
        let sym = match sym_map.iter().find(|(a, _)| *a == sp.sym) {
            Some((_, b)) => *b,
            None => {
                let b = s.new_sym();
                sym_map.push((sp.sym, b));
                b
            }
        };
        let metas = sp.metas.iter().map(|m| s.new_meta(m.kind, m.geometry)).collect();
        SuperPart { kind: sp.kind, metas, mode: sp.mode, attach, sym }
    };
    if let Some(slot) = child_slot {
        let new_torso = s.supers.len() as u32;
        let sp = bring(&mut s, other, Some(Attachment { parent: torso as u32, slot }));
        s.supers.push(sp);
        for &c in &taken {
            let a = assist.supers[c].attach.map(|a| Attachment { parent: new_torso, slot: a.slot });
            let sp = bring(&mut s, &assist.supers[c], a);
            s.supers.push(sp);
        }
        return Some(s);
    }
    let slot = root_slot?;
    // The assist torso becomes the root; the base hangs from its slot.
    let mut out = Shape { supers: Vec::new(), next_id: s.next_id, next_sym: s.next_sym, floats: s.floats };
    let root = bring(&mut out, other, None);
    out.supers.push(root);
    for &c in &taken {
        let a = assist.supers[c].attach.map(|a| Attachment { parent: 0, slot: a.slot });
        let sp = bring(&mut out, &assist.supers[c], a);
        out.supers.push(sp);
    }
    let offset = out.supers.len() as u32;
    for (i, sp) in s.supers.iter().enumerate() {
        let mut sp = sp.clone();
        sp.attach = match sp.attach {
            Some(a) => Some(Attachment { parent: a.parent + offset, slot: a.slot }),
            None if i == 0 => Some(Attachment { parent: 0, slot }),
            None => None,
        };
        out.supers.push(sp);
    }
    Some(out)
}

/// One rule application in an offspring's derivation.
#[derive(Clone, Debug, PartialEq)]
pub struct Applied {
    pub rule: String,
    /// The function branch was taken (else the identity branch).
    pub function: bool,
}

/// What a derivation needs besides the shapes.
pub struct DeriveOptions {
    pub g: u32,
    pub steps: u32,
    pub strategy: Strategy,
    /// Rules of these kinds are left out (the ablation of Fig. 13).
    pub disabled: Vec<RuleKind>,
}

/// Derives an offspring from `base` with `assist` (paper Algorithm 1, step 2): in
/// each of `steps` steps the priority tiers are visited from the highest; in each
/// tier one applicable rule is selected by the rule metric C_r and takes its
/// function branch with its probability.
pub fn derive(
    t: &CreatureTable,
    base: &Shape,
    assist: &Shape,
    o: &DeriveOptions,
    rng: &mut Rng,
) -> (Shape, Vec<Applied>) {
    let mut shape = base.clone();
    let mut log = Vec::new();
    let cs_assist = assist.complexity();
    let mut tiers: Vec<i32> = t.rules.iter().map(|r| r.priority).collect();
    tiers.sort_unstable_by(|a, b| b.cmp(a));
    tiers.dedup();
    for _ in 0..o.steps {
        for &tier in &tiers {
            let mut cands: Vec<(usize, Vec<Target>)> = Vec::new();
            for (ri, r) in t.rules.iter().enumerate() {
                if r.priority != tier || o.disabled.contains(&r.kind) {
                    continue;
                }
                let v = valid_targets(t, r, &shape, assist, o.g);
                if !v.is_empty() {
                    cands.push((ri, v));
                }
            }
            if cands.is_empty() {
                continue;
            }
            let cs = shape.complexity();
            let metrics: Vec<f64> = cands.iter().map(|(ri, _)| rule_metric(t.rules[*ri].kind, cs, cs_assist)).collect();
            let Some(pick) = select(o.strategy, &metrics, rng) else { continue };
            let (ri, tgts) = &cands[pick];
            let r = &t.rules[*ri];
            let target = &tgts[rng.below(tgts.len())];
            let p = probability(t, r, &shape, target, o.g);
            let function = rng.uniform() < p;
            if function {
                if let Some(next) = apply(t, r, &shape, assist, target, rng) {
                    shape = next;
                } else {
                    continue;
                }
            }
            log.push(Applied { rule: r.id.clone(), function });
        }
    }
    (shape, log)
}
