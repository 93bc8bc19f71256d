//! Expression code for structure-rule conditions and probabilities.
//!
//! The same stack machine as [`mdg_vm::expr`], over the creature variables
//! ([`VARIABLES`]) instead of the geometric ones, plus `parts(KIND)` (how many
//! super-parts of a kind the shape has). `rand`/`randn` are not allowed: a rule's
//! probability is the chance of its function branch, drawn by the evolution.

use super::error::CondError;
use mdg_vm::expr::{self, BinOp, CodeError, Core, StackOp};
use serde::{Deserialize, Serialize};

/// Variables a condition or probability may read, by index.
///
/// - `g`: the generation being made (1 for the first offspring generation);
/// - `superparts`, `metaparts`, `torsos`: counts in the base shape;
/// - `count`: meta-parts in the matched super-part;
/// - `complexity`: the base shape's structure complexity C_s (conditions only).
pub const VARIABLES: &[&str] = &["g", "superparts", "metaparts", "count", "torsos", "complexity"];

/// Index of `complexity` in [`VARIABLES`]: not an integer, so probabilities may not
/// read it (the compiler checks them at every integer value of the others).
pub const COMPLEXITY: u8 = 5;

/// One instruction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum CondOp {
    Push(f64),
    /// Push `VARIABLES[i]`.
    Var(u8),
    /// Push the number of super-parts of kind `k`.
    Parts(u32),
    Neg,
    /// Pop b, pop a, push `a op b`.
    Bin(BinOp),
    /// Pop `arity` arguments, push `FUNCTIONS[i](…)` (never `rand`/`randn`).
    Call(u8),
    /// Skip the next `n` instructions (`if(…)`, `select(…)`).
    Skip(u32),
    /// Pop; when false, skip the next `n` instructions.
    SkipUnless(u32),
    /// Push a copy of the entry `k` below the top (`let(…)`, `select(…)`).
    Pick(u32),
    /// Pop the top, drop `n` entries under it, push the top back.
    Slide(u32),
    /// The shared machine's function block, body start, call and return
    /// ([`mdg_vm::expr::ExprOp::Funcs`]…); conditions call no user functions today.
    Funcs(u32),
    Enter(u32),
    Fn(i32),
    Ret,
}

/// The values an expression reads.
pub trait Env {
    /// `VARIABLES[i]`.
    fn var(&self, i: u8) -> f64;
    /// `parts(kind)`.
    fn parts(&self, kind: u32) -> f64;
}

impl StackOp for CondOp {
    #[inline(always)]
    fn core(self) -> Core<Self> {
        match self {
            CondOp::Push(v) => Core::Push(v),
            CondOp::Neg => Core::Neg,
            CondOp::Bin(o) => Core::Bin(o),
            CondOp::Call(f) => Core::Call(f),
            CondOp::Skip(n) => Core::Skip(n),
            CondOp::SkipUnless(n) => Core::SkipUnless(n),
            CondOp::Pick(k) => Core::Pick(k),
            CondOp::Slide(n) => Core::Slide(n),
            CondOp::Funcs(n) => Core::Funcs(n),
            CondOp::Enter(a) => Core::Enter(a),
            CondOp::Fn(rel) => Core::Fn(rel),
            CondOp::Ret => Core::Ret,
            leaf @ (CondOp::Var(_) | CondOp::Parts(_)) => Core::Leaf(leaf),
        }
    }

    fn from_core(c: Core<Self>) -> Self {
        match c {
            Core::Push(v) => CondOp::Push(v),
            Core::Neg => CondOp::Neg,
            Core::Bin(o) => CondOp::Bin(o),
            Core::Call(f) => CondOp::Call(f),
            Core::Skip(n) => CondOp::Skip(n),
            Core::SkipUnless(n) => CondOp::SkipUnless(n),
            Core::Pick(k) => CondOp::Pick(k),
            Core::Slide(n) => CondOp::Slide(n),
            Core::Funcs(n) => CondOp::Funcs(n),
            Core::Enter(a) => CondOp::Enter(a),
            Core::Fn(rel) => CondOp::Fn(rel),
            Core::Ret => CondOp::Ret,
            Core::Leaf(op) => op,
        }
    }
}

/// Evaluates verified code on the shared machine ([`expr::run`]); malformed code
/// gives NaN, never a panic.
pub fn eval(code: &[CondOp], env: &dyn Env, stack: &mut expr::Machine) -> f64 {
    expr::run(
        code,
        stack,
        |leaf| match leaf {
            CondOp::Var(i) => env.var(i),
            CondOp::Parts(k) => env.parts(k),
            _ => f64::NAN,
        },
        |f, args| f.deterministic(args).unwrap_or(f64::NAN),
    )
}

/// Checks stack discipline and indices (`n_kinds` bounds `parts(…)`) with
/// [`expr::check`]; `rand`/`randn` are refused.
pub fn verify(code: &[CondOp], n_kinds: u32) -> Result<(), CondError> {
    expr::check(
        code,
        |at, leaf| match leaf {
            CondOp::Var(var) if var as usize >= VARIABLES.len() => Err(CodeError::UnknownVariable { var, at }.into()),
            CondOp::Parts(kind) if kind >= n_kinds => Err(CondError::UnknownKind { kind, at }),
            _ => Ok(()),
        },
        |at, f| if f.is_random() { Err(CondError::RandomFunction { at }) } else { Ok(()) },
    )
}

/// The variables an expression reads (indices into [`VARIABLES`]) and whether it
/// calls `parts(…)`.
pub fn reads(code: &[CondOp]) -> (Vec<u8>, bool) {
    let mut vars: Vec<u8> = code
        .iter()
        .filter_map(|op| match op {
            CondOp::Var(i) => Some(*i),
            _ => None,
        })
        .collect();
    vars.sort_unstable();
    vars.dedup();
    (vars, code.iter().any(|op| matches!(op, CondOp::Parts(_))))
}

/// A fixed environment (tests and the compiler's probability check).
#[derive(Clone, Copy, Debug, Default)]
pub struct Values {
    pub vars: [f64; 6],
    pub parts: f64,
}

impl Env for Values {
    fn var(&self, i: u8) -> f64 {
        self.vars.get(i as usize).copied().unwrap_or(f64::NAN)
    }
    fn parts(&self, _kind: u32) -> f64 {
        self.parts
    }
}

/// The first assignment of integer values to the variables `code` reads (g in
/// 0..=`max_g`, the counts in 1..=`max_count`) at which the value is outside
/// [0, 1] or not a number: `(assignment as "name = v" pairs, value)`. `None` when
/// it stays inside at every point. The search is exhaustive (every variable it
/// may read is an integer), so `None` is a proof. `complexity` is not allowed and
/// reported at its first use.
pub fn probability_escape(code: &[CondOp], max_g: u32, max_count: u32) -> Option<(String, f64)> {
    let (vars, uses_parts) = reads(code);
    let mut ranges: Vec<(u8, u32, u32)> = vars
        .iter()
        .map(|&v| if v == 0 { (v, 0, max_g) } else { (v, if v == COMPLEXITY { 0 } else { 1 }, max_count) })
        .collect();
    if uses_parts {
        // `parts(…)` varies like a count; index 255 stands for it.
        ranges.push((255, 0, max_count));
    }
    let mut stack = expr::Machine::default();
    let mut idx: Vec<u32> = ranges.iter().map(|r| r.1).collect();
    loop {
        let mut env = Values::default();
        for (r, &v) in ranges.iter().zip(&idx) {
            if r.0 == 255 {
                env.parts = v as f64;
            } else if let Some(slot) = env.vars.get_mut(r.0 as usize) {
                *slot = v as f64;
            }
        }
        let p = eval(code, &env, &mut stack);
        if !(0.0..=1.0).contains(&p) {
            let at: Vec<String> = ranges
                .iter()
                .zip(&idx)
                .map(|(r, v)| {
                    if r.0 == 255 {
                        format!("parts(…) = {v}")
                    } else {
                        format!("{} = {v}", VARIABLES.get(r.0 as usize).copied().unwrap_or("?"))
                    }
                })
                .collect();
            return Some((at.join(", "), p));
        }
        // Next assignment (odometer order).
        let mut i = 0;
        loop {
            let r = ranges.get(i)?;
            if idx[i] < r.2 {
                idx[i] += 1;
                break;
            }
            idx[i] = r.1;
            i += 1;
        }
    }
}

/// What the compiler knows of the shapes a rule could be applied to, for
/// [`never_hold`].
#[derive(Clone, Debug)]
pub struct Bounds {
    /// The largest generation (`g` runs 1..=max_g).
    pub max_g: u32,
    /// The most meta-parts a shape may have (`maxparts`).
    pub max_parts: u32,
    /// Kinds no shape can ever have: `parts(kind)` is 0 for them.
    pub absent: Vec<u32>,
}

/// Whether the conjunction of `conditions` is false for every shape the bounds
/// allow: every generation 1..=max_g and every value of the counts the conditions
/// read with 1 ≤ torsos ≤ superparts ≤ metaparts ≤ max_parts, 1 ≤ count ≤
/// metaparts and 0 ≤ parts(kind) ≤ superparts (0 for an absent kind): more than shapes can
/// be, never less, so a `true` holds for every real shape. The check
/// is exhaustive, so `true` is a proof; `None` when it cannot be made (a condition
/// reads `complexity`, a real number, or the enumeration would exceed `budget`
/// evaluations).
pub fn never_hold(conditions: &[&[CondOp]], b: &Bounds, budget: u64) -> Option<bool> {
    let mut vars: Vec<u8> = Vec::new();
    let mut kinds: Vec<u32> = Vec::new();
    for c in conditions {
        vars.extend(reads(c).0);
        kinds.extend(c.iter().filter_map(|op| match op {
            CondOp::Parts(k) if !b.absent.contains(k) => Some(*k),
            _ => None,
        }));
    }
    vars.sort_unstable();
    vars.dedup();
    kinds.sort_unstable();
    kinds.dedup();
    if vars.contains(&COMPLEXITY) {
        return None;
    }
    // The counts, outermost first, so that each one's range depends on those
    // before it: superparts, metaparts, torsos, count, then parts(…).
    const G: u8 = 0;
    const SUPER: u8 = 1;
    const META: u8 = 2;
    const COUNT: u8 = 3;
    const TORSOS: u8 = 4;
    let reads_any = |v: u8| vars.contains(&v);
    // Shape counts are read when a condition reads them or a later range needs them.
    let need_meta = reads_any(META) || reads_any(COUNT);
    let need_super = reads_any(SUPER) || need_meta || reads_any(TORSOS) || !kinds.is_empty();
    let m = b.max_parts.max(1);
    let mut evaluations: u64 = 0;
    let mut stack = expr::Machine::default();
    struct At<'a> {
        vars: [f64; 6],
        kinds: &'a [u32],
        parts: Vec<f64>,
    }
    impl Env for At<'_> {
        fn var(&self, i: u8) -> f64 {
            self.vars.get(i as usize).copied().unwrap_or(f64::NAN)
        }
        fn parts(&self, kind: u32) -> f64 {
            self.kinds.iter().position(|&k| k == kind).map_or(0.0, |i| self.parts[i])
        }
    }
    let mut at = At { vars: [0.0; 6], kinds: &kinds, parts: vec![0.0; kinds.len()] };
    let gs: Vec<u32> = if reads_any(G) { (1..=b.max_g.max(1)).collect() } else { vec![1] };
    let supers: Vec<u32> = if need_super { (1..=m).collect() } else { vec![1] };
    for &sp in &supers {
        let metas: Vec<u32> = if need_meta { (sp..=m).collect() } else { vec![sp] };
        for &mp in &metas {
            let torsos: Vec<u32> = if reads_any(TORSOS) { (1..=sp).collect() } else { vec![1] };
            let counts: Vec<u32> = if reads_any(COUNT) { (1..=mp).collect() } else { vec![1] };
            for &tr in &torsos {
                for &ct in &counts {
                    // parts(…) of each kind read: 0 ≤ n ≤ superparts (an odometer).
                    let top = sp;
                    let mut idx = vec![0u32; kinds.len()];
                    loop {
                        for &g in &gs {
                            evaluations += 1;
                            if evaluations > budget {
                                return None;
                            }
                            at.vars = [g as f64, sp as f64, mp as f64, ct as f64, tr as f64, 0.0];
                            for (slot, &v) in at.parts.iter_mut().zip(&idx) {
                                *slot = v as f64;
                            }
                            // As the evolution reads a condition: finite and non-zero.
                            if conditions.iter().all(|c| {
                                let v = eval(c, &at, &mut stack);
                                v.is_finite() && v != 0.0
                            }) {
                                return Some(false);
                            }
                        }
                        let mut i = 0;
                        while let Some(x) = idx.get_mut(i) {
                            if *x < top {
                                *x += 1;
                                break;
                            }
                            *x = 0;
                            i += 1;
                        }
                        if i == idx.len() {
                            break;
                        }
                    }
                }
            }
        }
    }
    Some(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_vm::expr::{BinOp, Func};

    fn g_expr(a: f64, b: f64) -> Vec<CondOp> {
        // a * exp(b * g)
        let exp = Func::Exp as u8;
        vec![
            CondOp::Push(a),
            CondOp::Push(b),
            CondOp::Var(0),
            CondOp::Bin(BinOp::Mul),
            CondOp::Call(exp),
            CondOp::Bin(BinOp::Mul),
        ]
    }

    #[test]
    fn probability_inside_and_outside() {
        assert_eq!(probability_escape(&g_expr(0.4, -0.1), 1000, 8), None);
        let (at, p) = probability_escape(&g_expr(0.4, 0.1), 1000, 8).expect("grows past 1");
        // 0.4·e^{0.1 g} > 1 first at g = 10 (0.4·e^{0.9} = 0.98, 0.4·e^{1.0} = 1.087).
        assert_eq!(at, "g = 10");
        assert!((p - 0.4 * 1f64.exp()).abs() < 1e-12);
    }

    fn bin(op: &str) -> CondOp {
        CondOp::Bin(BinOp::from_symbol(op).expect("op"))
    }

    #[test]
    fn conditions_that_never_hold() {
        let b = Bounds { max_g: 1000, max_parts: 24, absent: vec![7] };
        let gt = |v: u8, n: f64| vec![CondOp::Var(v), CondOp::Push(n), bin(">")];
        let lt = |v: u8, n: f64| vec![CondOp::Var(v), CondOp::Push(n), bin("<")];
        // superparts > 30 with at most 24 meta-parts: never.
        assert_eq!(never_hold(&[&gt(1, 30.0)], &b, 10_000_000), Some(true));
        assert_eq!(never_hold(&[&gt(1, 20.0)], &b, 10_000_000), Some(false));
        // superparts > 10 and metaparts < 8: metaparts >= superparts, so never.
        assert_eq!(never_hold(&[&gt(1, 10.0), &lt(2, 8.0)], &b, 10_000_000), Some(true));
        assert_eq!(never_hold(&[&gt(1, 5.0), &lt(2, 8.0)], &b, 10_000_000), Some(false));
        // g > 1000: past the last generation.
        assert_eq!(never_hold(&[&gt(0, 1000.0)], &b, 10_000_000), Some(true));
        // parts(7) > 0 where kind 7 is absent; parts(3) > 0 is possible.
        let parts = |k: u32| vec![CondOp::Parts(k), CondOp::Push(0.0), bin(">")];
        assert_eq!(never_hold(&[&parts(7)], &b, 10_000_000), Some(true));
        assert_eq!(never_hold(&[&parts(3)], &b, 10_000_000), Some(false));
        // complexity is a real number: no proof.
        assert_eq!(never_hold(&[&gt(5, 1e9)], &b, 10_000_000), None);
        // Over budget: no proof.
        assert_eq!(never_hold(&[&gt(0, 2000.0), &gt(2, 99.0), &gt(3, 99.0)], &b, 1000), None);
    }

    #[test]
    fn verify_rejects_underflow_and_random() {
        assert!(verify(&[CondOp::Bin(BinOp::Add)], 1).is_err());
        let rand = Func::Rand as u8;
        assert!(verify(&[CondOp::Push(0.0), CondOp::Push(1.0), CondOp::Call(rand)], 1).is_err());
        assert!(verify(&[CondOp::Parts(3)], 2).is_err());
        assert!(verify(&g_expr(0.5, 0.1), 1).is_ok());
    }
}
