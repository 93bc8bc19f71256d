//! Evaluation of expressions with a variable environment: compile-time constants
//! (counts, `@param` values) and, in the VM's terms, functions of x, y, z, depth, scale, g.

use crate::ast::{BinOp, Expr, ExprKind};

/// Evaluates `e`, looking variables up with `var`. `None` if a variable is unknown,
/// a function is unknown, or the expression draws a random number.
pub fn eval(e: &Expr, var: &dyn Fn(&str) -> Option<f64>) -> Option<f64> {
    Some(match &e.kind {
        ExprKind::Num(n) => n.value,
        ExprKind::Var(v) => var(&v.text)?,
        ExprKind::Neg(x) => -eval(x, var)?,
        ExprKind::Paren(x) => eval(x, var)?,
        ExprKind::Binary(op, a, b) => binary(*op, eval(a, var)?, eval(b, var)?),
        ExprKind::Call(f, args) => {
            let v: Option<Vec<f64>> = args.iter().map(|a| eval(a, var)).collect();
            call(&f.text, &v?)?
        }
        ExprKind::Error => return None,
    })
}

/// Applies a binary operator.
pub fn binary(op: BinOp, a: f64, b: f64) -> f64 {
    let t = |c: bool| if c { 1.0 } else { 0.0 };
    match op {
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => a / b,
        BinOp::Pow => a.powf(b),
        BinOp::Lt => t(a < b),
        BinOp::Le => t(a <= b),
        BinOp::Gt => t(a > b),
        BinOp::Ge => t(a >= b),
        BinOp::Eq => t(a == b),
        BinOp::Ne => t(a != b),
    }
}

/// Applies a deterministic math function (not `rand`/`randn`).
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
