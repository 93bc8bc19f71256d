//! Expressions to stack code, once for every expression language, and compile-time
//! evaluation on the VM's own machine.
//!
//! [`lower`] walks an expression and emits code for the shared stack machine
//! (`mdg_vm::expr::Core`): operators, `!`, parentheses and calls of built-in math
//! functions are handled here; a language ([`Leaves`]) says what its numbers, names
//! and other calls mean. The geometric expressions (`crate::lower`), the creature
//! conditions (`crate::ext::creature`) and [`eval`] are its three languages, so
//! folding at compile time and evaluating at run time cannot disagree: a constant
//! is computed by running its code with `mdg_vm::expr::run`.

use crate::ast::{BinOp, Expr, ExprKind, Name, Number};
use mdg_vm::expr::{self, BinOp as VmBinOp, Core, Func, StackOp};

/// What a call lowers to.
pub enum Call {
    /// A call of this built-in function: [`lower`] emits its arguments and the call.
    Builtin(Func),
    /// The language emitted the call itself (or refused it): whether it succeeded.
    Done(bool),
}

/// The parts of an expression language that are its own.
pub trait Leaves<O: StackOp> {
    /// Emits a number literal; false if the language refuses it.
    fn num(&mut self, n: &Number, out: &mut Vec<O>) -> bool;
    /// Emits a name; false if the language does not know it.
    fn var(&mut self, v: &Name, out: &mut Vec<O>) -> bool;
    /// What the call `f(args)` (the whole expression `e`) is.
    fn call(&mut self, e: &Expr, f: &Name, args: &[Expr], out: &mut Vec<O>) -> Call;
}

/// The VM's operator for a source operator.
pub fn vm_binop(op: BinOp) -> VmBinOp {
    match op {
        BinOp::Or => VmBinOp::Or,
        BinOp::And => VmBinOp::And,
        BinOp::Lt => VmBinOp::Lt,
        BinOp::Le => VmBinOp::Le,
        BinOp::Gt => VmBinOp::Gt,
        BinOp::Ge => VmBinOp::Ge,
        BinOp::Eq => VmBinOp::Eq,
        BinOp::Ne => VmBinOp::Ne,
        BinOp::Add => VmBinOp::Add,
        BinOp::Sub => VmBinOp::Sub,
        BinOp::Mul => VmBinOp::Mul,
        BinOp::Div => VmBinOp::Div,
        BinOp::Pow => VmBinOp::Pow,
    }
}

/// Emits `e` in `lang`; false if any part was refused (every part is still walked,
/// so a language reports all its errors). An `Error` node emits 0.
pub fn lower<O: StackOp, L: Leaves<O> + ?Sized>(lang: &mut L, e: &Expr, out: &mut Vec<O>) -> bool {
    let op = |c: Core<O>| O::from_core(c);
    match &e.kind {
        ExprKind::Num(n) => lang.num(n, out),
        ExprKind::Var(v) => lang.var(v, out),
        ExprKind::Paren(x) => lower(lang, x, out),
        ExprKind::Neg(x) => {
            let ok = lower(lang, x, out);
            out.push(op(Core::Neg));
            ok
        }
        ExprKind::Not(x) => {
            let ok = lower(lang, x, out);
            out.extend([op(Core::Push(0.0)), op(Core::Bin(VmBinOp::Eq))]);
            ok
        }
        ExprKind::Binary(o, a, b) => {
            let ok = lower(lang, a, out) & lower(lang, b, out);
            out.push(op(Core::Bin(vm_binop(*o))));
            ok
        }
        ExprKind::Call(f, args) => match lang.call(e, f, args, out) {
            Call::Done(ok) => ok,
            Call::Builtin(func) => {
                let mut ok = true;
                for a in args {
                    ok &= lower(lang, a, out);
                }
                out.push(op(Core::Call(func as u8)));
                ok
            }
        },
        ExprKind::Error => {
            out.push(op(Core::Push(0.0)));
            false
        }
    }
}

/// Compile-time values: numbers as written (units are not applied), names through a
/// lookup, deterministic built-ins only.
struct Constant<'a> {
    var: &'a dyn Fn(&str) -> Option<f64>,
}

impl Leaves<expr::ExprOp> for Constant<'_> {
    fn num(&mut self, n: &Number, out: &mut Vec<expr::ExprOp>) -> bool {
        out.push(expr::ExprOp::Push(n.value));
        true
    }

    fn var(&mut self, v: &Name, out: &mut Vec<expr::ExprOp>) -> bool {
        match (self.var)(&v.text) {
            Some(x) => {
                out.push(expr::ExprOp::Push(x));
                true
            }
            None => false,
        }
    }

    fn call(&mut self, _: &Expr, f: &Name, args: &[Expr], _: &mut Vec<expr::ExprOp>) -> Call {
        match Func::from_name(&f.text) {
            Some(func) if !func.is_random() && args.len() == func.arity() => Call::Builtin(func),
            _ => Call::Done(false),
        }
    }
}

/// Evaluates `e`, looking variables up with `var`. `None` if a variable is unknown,
/// a function is unknown or called with the wrong number of arguments, or the
/// expression draws a random number.
pub fn eval(e: &Expr, var: &dyn Fn(&str) -> Option<f64>) -> Option<f64> {
    let mut code = Vec::new();
    if !lower(&mut Constant { var }, e, &mut code) {
        return None;
    }
    Some(expr::run(&code, &mut Vec::new(), |_| f64::NAN, |f, a| f.deterministic(a).unwrap_or(f64::NAN)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ast::BinOp;
    use crate::span::Span;

    fn e(kind: ExprKind) -> Expr {
        Expr { kind, span: Span::default() }
    }
    fn num(value: f64) -> Expr {
        e(ExprKind::Num(Number { value, unit: None, text: format!("{value}"), span: Span::default() }))
    }
    fn name(text: &str) -> Name {
        Name { text: text.into(), span: Span::default() }
    }
    fn bin(op: BinOp, a: Expr, b: Expr) -> Expr {
        e(ExprKind::Binary(op, Box::new(a), Box::new(b)))
    }
    fn call(f: &str, args: Vec<Expr>) -> Expr {
        e(ExprKind::Call(name(f), args))
    }

    #[test]
    fn constants_fold_with_the_vm_arithmetic() {
        let none = |_: &str| None;
        let n = |v: &str| (v == "n").then_some(3.0);
        assert_eq!(eval(&bin(BinOp::Add, num(1.0), bin(BinOp::Mul, num(2.0), num(3.0))), &none), Some(7.0));
        let not = e(ExprKind::Not(Box::new(bin(BinOp::Gt, num(2.0), num(1.0)))));
        assert_eq!(eval(&bin(BinOp::Add, not, call("max", vec![num(1.0), num(4.0)])), &none), Some(4.0));
        let n2 = bin(BinOp::Mul, e(ExprKind::Var(name("n"))), num(2.0));
        assert_eq!(eval(&n2, &n), Some(6.0));
        assert_eq!(eval(&n2, &none), None);
        assert_eq!(eval(&call("rand", vec![num(0.0), num(1.0)]), &none), None);
        assert_eq!(eval(&call("sin", vec![num(1.0), num(2.0)]), &none), None);
        assert_eq!(eval(&call("nosuch", vec![num(1.0)]), &none), None);
        assert_eq!(eval(&e(ExprKind::Error), &none), None);
    }
}
