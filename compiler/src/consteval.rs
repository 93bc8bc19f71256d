//! Compile-time evaluation of expressions (iteration counts, `@param` arithmetic,
//! directive values). The arithmetic and the math functions are the VM's own
//! (`mdg_vm::expr`), so folding at compile time and evaluating at run time agree.

use crate::ast::{Expr, ExprKind};
use mdg_vm::expr::{binop, call, BINOPS};

/// Evaluates `e`, looking variables up with `var`. `None` if a variable is unknown,
/// a function is unknown, or the expression draws a random number.
pub fn eval(e: &Expr, var: &dyn Fn(&str) -> Option<f64>) -> Option<f64> {
    Some(match &e.kind {
        ExprKind::Num(n) => n.value,
        ExprKind::Var(v) => var(&v.text)?,
        ExprKind::Neg(x) => -eval(x, var)?,
        ExprKind::Not(x) => (eval(x, var)? == 0.0) as u8 as f64,
        ExprKind::Paren(x) => eval(x, var)?,
        ExprKind::Binary(op, a, b) => {
            let i = BINOPS.iter().position(|s| *s == op.symbol())?;
            binop(i as u8, eval(a, var)?, eval(b, var)?)
        }
        ExprKind::Call(f, args) => {
            let v: Option<Vec<f64>> = args.iter().map(|a| eval(a, var)).collect();
            call(&f.text, &v?)?
        }
        ExprKind::Error => return None,
    })
}
