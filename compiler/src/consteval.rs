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

use crate::ast::{BinOp, Expr, ExprKind, Name, Number, SPECIAL_FORMS};
use mdg_vm::expr::{self, BinOp as VmBinOp, Core, Func, StackOp};

/// What a call lowers to.
pub enum Call {
    /// A call of this built-in function: [`lower`] emits its arguments and the call.
    Builtin(Func),
    /// The language emitted the call itself (or refused it): whether it succeeded.
    Done(bool),
    /// The call is this expression (a user function's body with its arguments in
    /// place): [`lower`] emits it where the call is, in the caller's `let` scope.
    Inline(Expr),
    /// A call of a recursive function, compiled once into the expression's function
    /// block (`key` tells functions apart: the same key, the same function):
    /// [`lower`] emits the arguments and a call of the body.
    Compiled { key: usize, params: Vec<Name>, body: Expr },
}

/// The parts of an expression language that are its own.
pub trait Leaves<O: StackOp> {
    /// Emits a number literal; false if the language refuses it.
    fn num(&mut self, n: &Number, out: &mut Vec<O>) -> bool;
    /// Emits a name; false if the language does not know it.
    fn var(&mut self, v: &Name, out: &mut Vec<O>) -> bool;
    /// What the call `f(args)` (the whole expression `e`) is.
    fn call(&mut self, e: &Expr, f: &Name, args: &[Expr], out: &mut Vec<O>) -> Call;
    /// Called with true before the bodies of [`Call::Compiled`] functions are
    /// emitted, false after: a body reads its parameters, never the caller's names.
    fn in_function(&mut self, _inside: bool) {}
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
///
/// `if(c, a, b)` and `select(i, a, b, …)` ([`SPECIAL_FORMS`]) emit skips around
/// their branches, so only the chosen one runs (and draws random numbers); a
/// `let(…)` binding stays on the stack, read back with `Pick`, and the bindings are
/// slid off under the body's value at the end.
///
/// Recursive functions ([`Call::Compiled`]) are emitted once each, before the
/// expression, as a block the expression skips (`Funcs`): each body is `Enter`,
/// the body with its parameters read from the stack like `let` bindings, `Slide`
/// and `Ret`; calls (`Fn`) count from their own position, so the code can be
/// spliced into other code.
pub fn lower<O: StackOp, L: Leaves<O> + ?Sized>(lang: &mut L, e: &Expr, out: &mut Vec<O>) -> bool {
    let mut fns = Functions::default();
    let mut main = Vec::new();
    let mut ok = go(lang, e, &mut main, &mut Bound { names: Vec::new(), depth: 0, fns: &mut fns, buffer: 0 });
    if fns.list.is_empty() {
        out.extend(main);
        return ok;
    }
    // Bodies may call further functions, which join the list.
    lang.in_function(true);
    let mut bodies: Vec<Vec<O>> = Vec::new();
    let mut k = 0;
    while let Some((_, params, body)) = fns.list.get(k).cloned() {
        let arity = params.len();
        let mut code = vec![O::from_core(Core::Enter(operand(arity)))];
        let names = params.iter().enumerate().map(|(i, p)| (p.text.clone(), i)).collect();
        ok &= go(lang, &body, &mut code, &mut Bound { names, depth: arity, fns: &mut fns, buffer: k + 1 });
        code.extend([O::from_core(Core::Slide(operand(arity))), O::from_core(Core::Ret)]);
        bodies.push(code);
        k += 1;
    }
    lang.in_function(false);
    let block: usize = bodies.iter().map(Vec::len).sum();
    let mut starts = Vec::new();
    let mut at = out.len() + 1;
    for b in &bodies {
        starts.push(at);
        at += b.len();
    }
    let main_at = at;
    out.push(O::from_core(Core::Funcs(operand(block))));
    for b in bodies {
        out.extend(b);
    }
    out.extend(main);
    for (buffer, pos, callee) in fns.sites {
        let site = if buffer == 0 { main_at + pos } else { starts[buffer - 1] + pos };
        let rel = starts[callee] as i64 - site as i64;
        out[site] = O::from_core(Core::Fn(i32::try_from(rel).unwrap_or(i32::MAX)));
    }
    ok
}

/// The recursive functions an expression calls, in the order first called, and
/// where each call is.
#[derive(Default)]
struct Functions {
    /// (key, parameters, body).
    list: Vec<(usize, Vec<Name>, Expr)>,
    /// (code buffer: 0 the expression, k + 1 body k; position in it; callee index).
    sites: Vec<(usize, usize, usize)>,
}

/// The `let(…)` names in scope (innermost last) with the stack entry each lives in,
/// counted from the bottom of the expression's own part of the stack, and how many
/// entries that part holds where the next value will be pushed; the recursive
/// functions called so far, and which code is being emitted (`buffer`, as in
/// [`Functions::sites`]).
struct Bound<'f> {
    names: Vec<(String, usize)>,
    depth: usize,
    fns: &'f mut Functions,
    buffer: usize,
}

/// An operand of a skip, pick or slide (code beyond 4 G instructions is refused by
/// the expression limits long before).
fn operand(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Emits a skip with a placeholder operand; [`patch`] sets it.
fn skip_from<O: StackOp>(out: &mut Vec<O>, c: Core<O>) -> usize {
    out.push(O::from_core(c));
    out.len() - 1
}

/// Points the skip at `at` to the end of `out`.
fn patch<O: StackOp>(out: &mut [O], at: usize) {
    let n = operand(out.len() - at - 1);
    let c = match out[at].core() {
        Core::SkipUnless(_) => Core::SkipUnless(n),
        _ => Core::Skip(n),
    };
    out[at] = O::from_core(c);
}

fn go<O: StackOp, L: Leaves<O> + ?Sized>(lang: &mut L, e: &Expr, out: &mut Vec<O>, b: &mut Bound<'_>) -> bool {
    let op = |c: Core<O>| O::from_core(c);
    let d = b.depth;
    // Emits `x` with `at` entries on the stack.
    let sub = |lang: &mut L, x: &Expr, out: &mut Vec<O>, b: &mut Bound<'_>, at: usize| {
        b.depth = at;
        go(lang, x, out, b)
    };
    let ok = match &e.kind {
        ExprKind::Num(n) => lang.num(n, out),
        ExprKind::Var(v) => match b.names.iter().rev().find(|(n, _)| *n == v.text) {
            Some((_, at)) => {
                out.push(op(Core::Pick(operand(d - 1 - at))));
                true
            }
            None => lang.var(v, out),
        },
        ExprKind::Paren(x) => sub(lang, x, out, b, d),
        ExprKind::Neg(x) => {
            let ok = sub(lang, x, out, b, d);
            out.push(op(Core::Neg));
            ok
        }
        ExprKind::Not(x) => {
            let ok = sub(lang, x, out, b, d);
            out.extend([op(Core::Push(0.0)), op(Core::Bin(VmBinOp::Eq))]);
            ok
        }
        ExprKind::Binary(o, x, y) => {
            let ok = sub(lang, x, out, b, d) & sub(lang, y, out, b, d + 1);
            out.push(op(Core::Bin(vm_binop(*o))));
            ok
        }
        ExprKind::Let(bindings, body) => {
            let mut ok = true;
            let outer = b.names.len();
            for (i, (name, value)) in bindings.iter().enumerate() {
                ok &= sub(lang, value, out, b, d + i);
                b.names.push((name.text.clone(), d + i));
            }
            ok &= sub(lang, body, out, b, d + bindings.len());
            b.names.truncate(outer);
            out.push(op(Core::Slide(operand(bindings.len()))));
            ok
        }
        ExprKind::Call(f, args) if f.text == "if" && args.len() == 3 => {
            let ok = sub(lang, &args[0], out, b, d);
            let unless = skip_from(out, Core::SkipUnless(0));
            let ok = ok & sub(lang, &args[1], out, b, d);
            let end = skip_from(out, Core::Skip(0));
            patch(out, unless);
            let ok = ok & sub(lang, &args[2], out, b, d);
            patch(out, end);
            ok
        }
        ExprKind::Call(f, args) if f.text == "select" && args.len() >= 2 => {
            // The index stays under the branches: branch k runs when index < k + 1
            // (so it is floored and clamped; NaN takes the last branch).
            let mut ok = sub(lang, &args[0], out, b, d);
            let branches = &args[1..];
            let mut ends = Vec::new();
            for (k, branch) in branches.iter().enumerate() {
                if k + 1 == branches.len() {
                    ok &= sub(lang, branch, out, b, d + 1);
                    break;
                }
                out.extend([op(Core::Pick(0)), op(Core::Push((k + 1) as f64)), op(Core::Bin(VmBinOp::Lt))]);
                let unless = skip_from(out, Core::SkipUnless(0));
                ok &= sub(lang, branch, out, b, d + 1);
                ends.push(skip_from(out, Core::Skip(0)));
                patch(out, unless);
            }
            for at in ends {
                patch(out, at);
            }
            out.push(op(Core::Slide(1)));
            ok
        }
        ExprKind::Call(f, args) if SPECIAL_FORMS.iter().any(|(n, _)| *n == f.text) => {
            // A wrong number of arguments (the checker says so): walk them for their
            // own errors, emit 0.
            for a in args {
                sub(lang, a, &mut Vec::new(), b, d);
            }
            out.push(op(Core::Push(0.0)));
            false
        }
        ExprKind::Call(f, args) => match lang.call(e, f, args, out) {
            Call::Done(ok) => ok,
            Call::Inline(body) => sub(lang, &body, out, b, d),
            Call::Compiled { key, params, body } => {
                let mut ok = args.len() == params.len();
                for (i, a) in args.iter().enumerate() {
                    ok &= sub(lang, a, out, b, d + i);
                }
                if ok {
                    let callee = match b.fns.list.iter().position(|(k, ..)| *k == key) {
                        Some(i) => i,
                        None => {
                            b.fns.list.push((key, params, body));
                            b.fns.list.len() - 1
                        }
                    };
                    b.fns.sites.push((b.buffer, out.len(), callee));
                    out.push(op(Core::Fn(0)));
                } else {
                    // A wrong number of arguments (the checker says so): 0.
                    out.extend([op(Core::Push(0.0)), op(Core::Slide(operand(args.len())))]);
                }
                ok
            }
            Call::Builtin(func) => {
                let mut ok = true;
                for (i, a) in args.iter().enumerate() {
                    ok &= sub(lang, a, out, b, d + i);
                }
                out.push(op(Core::Call(func as u8)));
                ok
            }
        },
        // A vector is not a value: `crate::vectors` rewrites them into scalars first.
        ExprKind::Error | ExprKind::Tuple(_) | ExprKind::Index(..) => {
            out.push(op(Core::Push(0.0)));
            false
        }
    };
    b.depth = d + 1;
    ok
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
    Some(expr::run(&code, &mut expr::Machine::default(), |_| f64::NAN, |f, a| f.deterministic(a).unwrap_or(f64::NAN)))
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

    #[test]
    fn if_select_and_let_fold() {
        let n = |v: &str| (v == "n").then_some(3.0);
        let var = |v: &str| e(ExprKind::Var(name(v)));
        let cond = call("if", vec![bin(BinOp::Gt, var("n"), num(5.0)), num(1.0), num(2.0)]);
        assert_eq!(eval(&cond, &n), Some(2.0));
        assert_eq!(eval(&call("select", vec![var("n"), num(1.0), num(2.0)]), &n), Some(2.0));
        // let(a = n; let(a = a + 1; a) + a) = 4 + 3: the inner binding shadows, then ends.
        let inner = e(ExprKind::Let(vec![(name("a"), bin(BinOp::Add, var("a"), num(1.0)))], Box::new(var("a"))));
        let outer = e(ExprKind::Let(vec![(name("a"), var("n"))], Box::new(bin(BinOp::Add, inner, var("a")))));
        assert_eq!(eval(&outer, &n), Some(7.0));
        // The untaken branch may hold what cannot fold; the taken one may not.
        let rand = call("rand", vec![num(0.0), num(1.0)]);
        assert_eq!(eval(&call("if", vec![num(1.0), num(4.0), rand.clone()]), &n), None);
        assert_eq!(eval(&call("if", vec![num(1.0), num(4.0), num(0.0)]), &n), Some(4.0));
    }
}
