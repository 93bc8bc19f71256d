//! Expression code for structure-rule conditions and probabilities.
//!
//! The same stack machine as [`crate::expr`], over the creature variables
//! ([`VARIABLES`]) instead of the geometric ones, plus `parts(KIND)` (how many
//! super-parts of a kind the shape has). `rand`/`randn` are not allowed: a rule's
//! probability is the chance of its function branch, drawn by the evolution.

use crate::expr::{binop, call, BINOPS, FUNCTIONS};
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
    /// Pop b, pop a, push `a BINOPS[i] b`.
    Bin(u8),
    /// Pop `arity` arguments, push `FUNCTIONS[i](…)` (never `rand`/`randn`).
    Call(u8),
}

/// The values an expression reads.
pub trait Env {
    /// `VARIABLES[i]`.
    fn var(&self, i: u8) -> f64;
    /// `parts(kind)`.
    fn parts(&self, kind: u32) -> f64;
}

/// Evaluates verified code; malformed code gives NaN, never a panic.
pub fn eval(code: &[CondOp], env: &dyn Env, stack: &mut Vec<f64>) -> f64 {
    stack.clear();
    for op in code {
        match *op {
            CondOp::Push(v) => stack.push(v),
            CondOp::Var(i) => stack.push(env.var(i)),
            CondOp::Parts(k) => stack.push(env.parts(k)),
            CondOp::Neg => {
                if let Some(t) = stack.last_mut() {
                    *t = -*t;
                }
            }
            CondOp::Bin(o) => {
                let b = stack.pop().unwrap_or(f64::NAN);
                let a = stack.pop().unwrap_or(f64::NAN);
                stack.push(binop(o, a, b));
            }
            CondOp::Call(f) => {
                let Some(&(name, arity)) = FUNCTIONS.get(f as usize) else { return f64::NAN };
                let at = stack.len().saturating_sub(arity);
                let args: [f64; 3] = std::array::from_fn(|i| stack.get(at + i).copied().unwrap_or(f64::NAN));
                stack.truncate(at);
                stack.push(call(name, &args[..arity.min(3)]).unwrap_or(f64::NAN));
            }
        }
    }
    stack.pop().unwrap_or(f64::NAN)
}

/// Checks stack discipline and indices (`n_kinds` bounds `parts(…)`).
pub fn verify(code: &[CondOp], n_kinds: u32) -> Result<(), String> {
    let mut depth: i64 = 0;
    for (i, op) in code.iter().enumerate() {
        let (pop, push) = match *op {
            CondOp::Push(v) if !v.is_finite() => return Err(format!("non-finite constant at {i}")),
            CondOp::Push(_) => (0, 1),
            CondOp::Var(v) if v as usize >= VARIABLES.len() => return Err(format!("unknown variable {v} at {i}")),
            CondOp::Var(_) => (0, 1),
            CondOp::Parts(k) if k >= n_kinds => return Err(format!("unknown kind {k} at {i}")),
            CondOp::Parts(_) => (0, 1),
            CondOp::Neg => (1, 1),
            CondOp::Bin(o) if o as usize >= BINOPS.len() => return Err(format!("unknown operator {o} at {i}")),
            CondOp::Bin(_) => (2, 1),
            CondOp::Call(f) => match FUNCTIONS.get(f as usize) {
                Some((name, _)) if name.starts_with("rand") => return Err(format!("random function at {i}")),
                Some((_, arity)) => (*arity as i64, 1),
                None => return Err(format!("unknown function {f} at {i}")),
            },
        };
        if depth < pop {
            return Err(format!("stack underflow at {i}"));
        }
        depth = depth - pop + push;
    }
    if depth != 1 {
        return Err(format!("expression leaves {depth} values"));
    }
    Ok(())
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
    let mut stack = Vec::new();
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

#[cfg(test)]
mod tests {
    use super::*;

    fn g_expr(a: f64, b: f64) -> Vec<CondOp> {
        // a * exp(b * g)
        let exp = FUNCTIONS.iter().position(|(n, _)| *n == "exp").expect("exp") as u8;
        vec![CondOp::Push(a), CondOp::Push(b), CondOp::Var(0), CondOp::Bin(2), CondOp::Call(exp), CondOp::Bin(2)]
    }

    #[test]
    fn probability_inside_and_outside() {
        assert_eq!(probability_escape(&g_expr(0.4, -0.1), 1000, 8), None);
        let (at, p) = probability_escape(&g_expr(0.4, 0.1), 1000, 8).expect("grows past 1");
        // 0.4·e^{0.1 g} > 1 first at g = 10 (0.4·e^{0.9} = 0.98, 0.4·e^{1.0} = 1.087).
        assert_eq!(at, "g = 10");
        assert!((p - 0.4 * 1f64.exp()).abs() < 1e-12);
    }

    #[test]
    fn verify_rejects_underflow_and_random() {
        assert!(verify(&[CondOp::Bin(0)], 1).is_err());
        let rand = FUNCTIONS.iter().position(|(n, _)| *n == "rand").expect("rand") as u8;
        assert!(verify(&[CondOp::Push(0.0), CondOp::Push(1.0), CondOp::Call(rand)], 1).is_err());
        assert!(verify(&[CondOp::Parts(3)], 2).is_err());
        assert!(verify(&g_expr(0.5, 0.1), 1).is_ok());
    }
}
