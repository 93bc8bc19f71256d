//! Rule selection: the definition a call runs, by weight or selector.

use super::*;

/// The weights of definitions computed per call (`rule leaf(int n) (1 / (n + 1))`):
/// which rules have any, and room for one call's values.
pub(super) struct Weights {
    /// Per rule, its definitions' constant weights (what a selector reads unless the
    /// rule has weight expressions).
    pub(super) constant: Vec<Vec<f32>>,
    pub(super) dynamic: Vec<bool>,
    pub(super) values: Vec<f32>,
    /// Per rule with a depth selector and constant weights, the first op of the
    /// definition chosen at each depth `0..len` (see [`depth_table`]); empty for
    /// the other rules. Deeper calls are selected as any call is.
    pub(super) by_depth: Vec<Vec<u32>>,
}

/// The most depths a precomputed depth selection covers per rule (a selector whose
/// weights are larger is read from the table up to here, and chosen by scanning
/// the weights past it).
pub(super) const DEPTH_TABLE_MAX: usize = 4096;

impl Weights {
    pub(super) fn new(b: &Bundle) -> Weights {
        let constant: Vec<Vec<f32>> = b.rules.iter().map(|r| r.defs.iter().map(|d| d.weight).collect()).collect();
        let dynamic: Vec<bool> = b.rules.iter().map(|r| r.defs.iter().any(|d| d.weight_expr != NONE)).collect();
        let by_depth = b
            .rules
            .iter()
            .zip(&constant)
            .zip(&dynamic)
            .map(|((r, w), &dynamic)| match r.selector {
                Selector::Depth if !dynamic && r.defs.len() > 1 => {
                    depth_table(w).into_iter().map(|i| r.defs[i].start).collect()
                }
                _ => Vec::new(),
            })
            .collect();
        Weights { constant, dynamic, values: Vec::new(), by_depth }
    }
}

/// The definition a depth selector with constant weights `w` picks at each depth
/// from 0 to the first depth past every weight (every deeper call picks what that
/// one does), at most [`DEPTH_TABLE_MAX`] depths: computed once at load by the very
/// rule a call would apply ([`threshold`]).
pub(super) fn depth_table(w: &[f32]) -> Vec<usize> {
    let largest = w.iter().copied().filter(|x| x.is_finite()).fold(0.0f32, f32::max);
    let len = (largest.max(0.0) as usize).saturating_add(2).min(DEPTH_TABLE_MAX);
    (0..len).map(|d| threshold(w, d as f64)).collect()
}

/// The definition whose weight is the smallest one ≥ `v`, else the one with the
/// largest weight (SPEC resolved semantics 5); the first of equal ones.
fn threshold(w: &[f32], v: f64) -> usize {
    let mut best: Option<usize> = None;
    for (i, &x) in w.iter().enumerate() {
        if x as f64 >= v && best.is_none_or(|b| x < w[b]) {
            best = Some(i);
        }
    }
    best.unwrap_or_else(|| (0..w.len()).fold(0, |b, i| if w[i] > w[b] { i } else { b }))
}

/// Picks the definition of `rule_idx` its selector chooses for a call in state `child`
/// at `depth`; returns its first op.
#[allow(clippy::too_many_arguments)]
pub(super) fn select_def(
    b: &Bundle,
    rule: RuleId,
    child: &State,
    depth: u32,
    args: &[f64],
    rng: &mut Pcg,
    sequential: &mut HashMap<u32, (usize, u32)>,
    stack: &mut expr::Machine,
    weights: &mut Weights,
    bad: &mut NonFinite,
) -> u32 {
    let (rule_idx, rule) = (rule.0, &b.rules[rule]);
    let defs = &rule.defs;
    if defs.len() == 1 {
        return defs[0].start;
    }
    let p = child.f.u;
    let vars = || [p.x as f64, p.y as f64, p.z as f64, depth as f64, child.scale() as f64, 0.0];
    // Weights over the parameters, each evaluated once per call, in definition order
    // (so `rand()` in a weight draws the same numbers whichever definition wins).
    let dynamic = weights.dynamic.get(rule_idx as usize).copied().unwrap_or(false);
    if dynamic {
        weights.values.clear();
        let vars = vars();
        for d in defs {
            let w = match b.exprs.get(d.weight_expr as usize) {
                Some(code) if d.weight_expr != NONE => {
                    let v = expr::eval(code, &vars, args, rng, stack);
                    if v.is_finite() {
                        v as f32
                    } else {
                        bad.note(Fallback::Weight, Site::Rule(rule_idx));
                        0.0
                    }
                }
                _ => d.weight,
            };
            weights.values.push(w);
        }
    }
    // (The function selector's value is drawn here, after the weights, as before.)
    let function = match rule.selector {
        Selector::Function(e) => {
            let v = expr::eval(&b.exprs[e as usize], &vars(), args, rng, stack);
            if !v.is_finite() {
                bad.note(Fallback::Selector, Site::Rule(rule_idx));
            }
            v
        }
        _ => 0.0,
    };
    let w = if dynamic { &weights.values } else { &weights.constant[rule_idx as usize] };
    let i = pick(w, rule, rule_idx, child, depth, function, rng, sequential);
    defs[i].start
}

/// The index of the definition `rule`'s selector picks, with `w[i]` the weight of
/// definition `i` and `function` the value of a function selector.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn pick(
    w: &[f32],
    rule: &bundle::Rule,
    rule_idx: u32,
    child: &State,
    depth: u32,
    function: f64,
    rng: &mut Pcg,
    sequential: &mut HashMap<u32, (usize, u32)>,
) -> usize {
    let n = w.len();
    // The first index whose weight `better` prefers to every other one's.
    let first_best = |better: fn(f32, f32) -> bool| (0..n).fold(0, |b, i| if better(w[i], w[b]) { i } else { b });
    let threshold = |v: f64| threshold(w, v);
    match rule.selector {
        Selector::Random => {
            let total: f64 = w.iter().map(|x| x.max(0.0) as f64).sum();
            if total <= 0.0 {
                0
            } else {
                let r = rng.uniform() * total;
                let mut acc = 0.0;
                let mut pick = n - 1;
                for (i, x) in w.iter().enumerate() {
                    acc += x.max(0.0) as f64;
                    if r < acc {
                        pick = i;
                        break;
                    }
                }
                pick
            }
        }
        Selector::Depth => threshold(depth as f64),
        Selector::Scale => {
            let s = child.scale() as f64;
            let mut best: Option<usize> = None;
            for (i, &x) in w.iter().enumerate() {
                if (x as f64) <= s && best.is_none_or(|b| x > w[b]) {
                    best = Some(i);
                }
            }
            best.unwrap_or_else(|| first_best(|a, b| a < b))
        }
        Selector::Sequential => {
            let entry = sequential.entry(rule_idx).or_insert((0, 0));
            // Skip definitions with a zero count (at most one full cycle).
            for _ in 0..n {
                if (w[entry.0].max(0.0) as u32) > entry.1 {
                    break;
                }
                *entry = ((entry.0 + 1) % n, 0);
            }
            let i = entry.0;
            entry.1 += 1;
            if entry.1 >= w[i].max(0.0) as u32 {
                *entry = ((i + 1) % n, 0);
            }
            i
        }
        Selector::Pattern => {
            let entry = sequential.entry(rule_idx).or_insert((0, 0));
            let i = entry.0 % n;
            entry.0 = (i + 1) % n;
            i
        }
        Selector::Function(_) => {
            if function.is_finite() {
                threshold(function)
            } else {
                0
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_depth_table_picks_what_the_scan_picks_at_every_depth() {
        // Smallest weight ≥ depth (the first of equal ones), else the largest.
        let w = [3.0, 0.0, 1.5, 1.5];
        let t = depth_table(&w);
        assert_eq!(t, vec![1, 2, 0, 0, 0]);
        // Past the table every depth picks what its last entry picks.
        for d in 0..40u32 {
            let want = threshold(&w, d as f64);
            assert_eq!(t.get(d as usize).copied().unwrap_or(t[t.len() - 1]), want, "depth {d}");
        }
        // Huge weights: the table stops at its cap (the scan takes over there).
        let big = depth_table(&[1e9, 0.0]);
        assert_eq!(big.len(), DEPTH_TABLE_MAX);
        assert_eq!((big[0], big[1], big[DEPTH_TABLE_MAX - 1]), (1, 0, 0));
        // NaN and negative weights: as the scan treats them.
        let odd = [f32::NAN, -2.0, 1.0];
        assert_eq!(depth_table(&odd), (0..3).map(|d| threshold(&odd, d as f64)).collect::<Vec<_>>());
    }
}
