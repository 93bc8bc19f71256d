//! Expression code: a small stack machine for `function` bodies, function
//! selectors, isosurface functions and run-time adjustment arguments.
//!
//! Also the one table of math functions the compiler's checker and constant folder use.

use serde::Serialize;

/// Math functions: name and arity. The index is the function id in `CALL`.
/// `rand` and `randn` draw from the run's seeded stream.
pub const FUNCTIONS: &[(&str, usize)] = &[
    ("sin", 1),
    ("cos", 1),
    ("tan", 1),
    ("asin", 1),
    ("acos", 1),
    ("atan", 1),
    ("atan2", 2),
    ("sqrt", 1),
    ("abs", 1),
    ("min", 2),
    ("max", 2),
    ("pow", 2),
    ("exp", 1),
    ("log", 1),
    ("floor", 1),
    ("ceil", 1),
    ("fract", 1),
    ("mod", 2),
    ("clamp", 3),
    ("mix", 3),
    ("step", 2),
    ("smoothstep", 3),
    ("rand", 2),
    ("randn", 2),
    ("radians", 1),
    ("degrees", 1),
];

/// Variables an expression may read at run time, by index.
pub const VARIABLES: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

/// Binary operators, by index: `+ - * / ^ < <= > >= == != && ||`. `&&` and `||`
/// read 0 (and NaN) as false, anything else as true, and give 1 or 0; both sides are
/// always evaluated (so the random stream does not depend on a condition).
pub const BINOPS: &[&str] = &["+", "-", "*", "/", "^", "<", "<=", ">", ">=", "==", "!=", "&&", "||"];

/// One expression instruction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum ExprOp {
    /// Push a constant.
    Push(f64),
    /// Push variable `VARIABLES[i]`.
    Var(u8),
    /// Negate the top.
    Neg,
    /// Pop b, pop a, push `a BINOPS[i] b`.
    Bin(u8),
    /// Pop `arity` arguments, push `FUNCTIONS[i](…)`.
    Call(u8),
    /// Push slot `i` of the running rule's frame (a parameter, a `let` binding or a
    /// loop variable; see `bundle::Rule::frame`).
    Slot(u16),
}

/// Whether a value counts as true (`if`, `&&`, `||`): not 0 and not NaN.
#[inline]
pub fn truthy(v: f64) -> bool {
    v != 0.0 && !v.is_nan()
}

/// Applies binary operator `BINOPS[op]`.
pub fn binop(op: u8, a: f64, b: f64) -> f64 {
    let t = |c: bool| if c { 1.0 } else { 0.0 };
    match op {
        0 => a + b,
        1 => a - b,
        2 => a * b,
        3 => a / b,
        4 => a.powf(b),
        5 => t(a < b),
        6 => t(a <= b),
        7 => t(a > b),
        8 => t(a >= b),
        9 => t(a == b),
        10 => t(a != b),
        11 => t(truthy(a) && truthy(b)),
        _ => t(truthy(a) || truthy(b)),
    }
}

/// Applies a deterministic math function by name (`None` for unknown names and for
/// `rand`/`randn`, which need the run's random stream).
pub fn call(name: &str, a: &[f64]) -> Option<f64> {
    let arg = |i: usize| a.get(i).copied();
    Some(match name {
        "sin" => arg(0)?.sin(),
        "cos" => arg(0)?.cos(),
        "tan" => arg(0)?.tan(),
        "asin" => arg(0)?.asin(),
        "acos" => arg(0)?.acos(),
        "atan" => arg(0)?.atan(),
        "atan2" => arg(0)?.atan2(arg(1)?),
        "sqrt" => arg(0)?.sqrt(),
        "abs" => arg(0)?.abs(),
        "min" => arg(0)?.min(arg(1)?),
        "max" => arg(0)?.max(arg(1)?),
        "pow" => arg(0)?.powf(arg(1)?),
        "exp" => arg(0)?.exp(),
        "log" => arg(0)?.ln(),
        "floor" => arg(0)?.floor(),
        "ceil" => arg(0)?.ceil(),
        "fract" => arg(0)?.fract(),
        "radians" => arg(0)?.to_radians(),
        "degrees" => arg(0)?.to_degrees(),
        "mod" => arg(0)?.rem_euclid(arg(1)?),
        "clamp" => arg(0)?.clamp(arg(1)?.min(arg(2)?), arg(2)?.max(arg(1)?)),
        "mix" => arg(0)? + (arg(1)? - arg(0)?) * arg(2)?,
        "step" => {
            if arg(1)? < arg(0)? {
                0.0
            } else {
                1.0
            }
        }
        "smoothstep" => {
            let (e0, e1, x) = (arg(0)?, arg(1)?, arg(2)?);
            let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
            t * t * (3.0 - 2.0 * t)
        }
        _ => return None,
    })
}

/// A source of random numbers for `rand`/`randn` (the evaluator's seeded stream).
pub trait Random {
    /// Uniform in [0, 1).
    fn uniform(&mut self) -> f64;
    /// Standard normal.
    fn normal(&mut self) -> f64;
}

/// The value of the shapes of expression a call argument or a condition over
/// parameters nearly always has (`n`, `n - 1`, `len * 0.8`, `n > 0`, a constant),
/// computed without the stack or the variables; `None` for any other code. Gives
/// exactly what [`eval`] gives.
#[inline(always)]
pub fn quick(code: &[ExprOp], slots: &[f64]) -> Option<f64> {
    let slot = |i: u16| slots.get(i as usize).copied().unwrap_or(f64::NAN);
    match *code {
        [ExprOp::Slot(i)] => Some(slot(i)),
        [ExprOp::Slot(i), ExprOp::Push(c), ExprOp::Bin(o)] => Some(binop(o, slot(i), c)),
        [ExprOp::Push(c), ExprOp::Slot(i), ExprOp::Bin(o)] => Some(binop(o, c, slot(i))),
        [ExprOp::Push(c)] => Some(c),
        _ => None,
    }
}

/// Evaluates verified expression code with `vars` (indexed like [`VARIABLES`]) and
/// the running rule's frame `slots`. Verified code never underflows; on malformed
/// code (or a slot beyond `slots`) the result is NaN, never a panic.
pub fn eval(code: &[ExprOp], vars: &[f64; 6], slots: &[f64], rng: &mut dyn Random, stack: &mut Vec<f64>) -> f64 {
    stack.clear();
    for op in code {
        match *op {
            ExprOp::Push(v) => stack.push(v),
            ExprOp::Slot(i) => stack.push(slots.get(i as usize).copied().unwrap_or(f64::NAN)),
            ExprOp::Var(i) => stack.push(vars.get(i as usize).copied().unwrap_or(f64::NAN)),
            ExprOp::Neg => {
                if let Some(t) = stack.last_mut() {
                    *t = -*t;
                }
            }
            ExprOp::Bin(o) => {
                let b = stack.pop().unwrap_or(f64::NAN);
                let a = stack.pop().unwrap_or(f64::NAN);
                stack.push(binop(o, a, b));
            }
            ExprOp::Call(f) => {
                let Some(&(name, arity)) = FUNCTIONS.get(f as usize) else { return f64::NAN };
                let at = stack.len().saturating_sub(arity);
                let args: [f64; 3] = std::array::from_fn(|i| stack.get(at + i).copied().unwrap_or(f64::NAN));
                stack.truncate(at);
                let v = match name {
                    "rand" => args[0] + (args[1] - args[0]) * rng.uniform(),
                    "randn" => args[0] + args[1] * rng.normal(),
                    _ => call(name, &args[..arity]).unwrap_or(f64::NAN),
                };
                stack.push(v);
            }
        }
    }
    stack.pop().unwrap_or(f64::NAN)
}

/// The highest slot `code` reads, plus one (0 when it reads none): the bundle
/// verifier checks it against the frame of every rule that uses the expression.
pub fn slots_needed(code: &[ExprOp]) -> usize {
    code.iter().map(|op| if let ExprOp::Slot(i) = op { *i as usize + 1 } else { 0 }).max().unwrap_or(0)
}

/// Checks stack discipline: never underflows, ends with exactly one value.
pub fn verify(code: &[ExprOp]) -> Result<(), String> {
    let mut depth: i64 = 0;
    for (i, op) in code.iter().enumerate() {
        let (pop, push) = match op {
            ExprOp::Push(v) => {
                if !v.is_finite() {
                    return Err(format!("non-finite constant at {i}"));
                }
                (0, 1)
            }
            ExprOp::Var(v) => {
                if *v as usize >= VARIABLES.len() {
                    return Err(format!("unknown variable {v} at {i}"));
                }
                (0, 1)
            }
            ExprOp::Slot(_) => (0, 1),
            ExprOp::Neg => (1, 1),
            ExprOp::Bin(o) => {
                if *o as usize >= BINOPS.len() {
                    return Err(format!("unknown operator {o} at {i}"));
                }
                (2, 1)
            }
            ExprOp::Call(f) => match FUNCTIONS.get(*f as usize) {
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
