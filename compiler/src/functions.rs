//! The call graph of user functions (`function NAME(a, b) { EXPR }`): which are
//! recursive (on a cycle of calls, directly or through others) and which of those
//! can never return (every way through the body calls the cycle again).
//!
//! A function that is not recursive is inlined where it is called
//! (`crate::lower`); a recursive one is compiled once per expression that calls it,
//! into the expression's function block, and called on the expression machine with
//! a depth and a call limit (`mdg_vm::expr::CallLimits`).

use crate::ast::{Expr, ExprKind, ItemKind, SPECIAL_FORMS};
use crate::expand::Expanded;
use mdg_vm::expr::Func;
use std::collections::BTreeSet;

/// The user functions' call graph: for each item index of a function with
/// parameters, the item indices of the user functions its body calls.
pub struct CallGraph {
    /// (item index, called item indices), in item order.
    edges: Vec<(usize, BTreeSet<usize>)>,
}

/// The item indices of the user functions `e` calls (by the names calls resolve to).
fn callees(ex: &Expanded, e: &Expr, out: &mut BTreeSet<usize>) {
    walk(e, &mut |x| {
        if let ExprKind::Call(f, _) = &x.kind {
            let builtin = Func::from_name(&f.text).is_some() || SPECIAL_FORMS.iter().any(|(n, _)| *n == f.text);
            if !builtin {
                if let Some((i, ..)) = ex.user_function(&f.text) {
                    out.insert(i);
                }
            }
        }
    });
}

/// Calls `visit` on `e` and every expression inside it.
fn walk(e: &Expr, visit: &mut dyn FnMut(&Expr)) {
    visit(e);
    match &e.kind {
        ExprKind::Num(_) | ExprKind::Var(_) | ExprKind::Error => {}
        ExprKind::Neg(x) | ExprKind::Not(x) | ExprKind::Paren(x) => walk(x, visit),
        ExprKind::Tuple(xs) => {
            for x in xs {
                walk(x, visit);
            }
        }
        ExprKind::Index(v, i) => {
            walk(v, visit);
            walk(i, visit);
        }
        ExprKind::Binary(_, a, b) => {
            walk(a, visit);
            walk(b, visit);
        }
        ExprKind::Let(bindings, body) => {
            for (_, v) in bindings {
                walk(v, visit);
            }
            walk(body, visit);
        }
        ExprKind::Call(_, args) => {
            for a in args {
                walk(a, visit);
            }
        }
    }
}

impl CallGraph {
    /// The graph of `ex`'s functions with parameters.
    pub fn new(ex: &Expanded) -> CallGraph {
        let edges = ex
            .items
            .iter()
            .enumerate()
            .filter_map(|(i, it)| match &it.item.kind {
                ItemKind::Function { params, body, .. } if !params.is_empty() => {
                    let mut out = BTreeSet::new();
                    callees(ex, body, &mut out);
                    Some((i, out))
                }
                _ => None,
            })
            .collect();
        CallGraph { edges }
    }

    fn calls(&self, i: usize) -> &BTreeSet<usize> {
        static NONE: BTreeSet<usize> = BTreeSet::new();
        self.edges.iter().find(|(j, _)| *j == i).map_or(&NONE, |(_, c)| c)
    }

    /// The functions `from` reaches through one or more calls.
    fn reach(&self, from: usize) -> BTreeSet<usize> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<usize> = self.calls(from).iter().copied().collect();
        while let Some(i) = todo.pop() {
            if seen.insert(i) {
                todo.extend(self.calls(i).iter().copied());
            }
        }
        seen
    }

    /// The recursive functions: those that reach themselves.
    pub fn recursive(&self) -> BTreeSet<usize> {
        self.edges.iter().map(|(i, _)| *i).filter(|&i| self.reach(i).contains(&i)).collect()
    }

    /// The functions on one cycle with `f` (itself included when recursive).
    fn cycle_of(&self, f: usize) -> BTreeSet<usize> {
        self.reach(f).into_iter().filter(|&g| self.reach(g).contains(&f)).collect()
    }

    /// Whether every evaluation of recursive function `f`'s body calls a function on
    /// its cycle again (so no call of it ever returns): `if`/`select` need every
    /// branch to, an operator or a call either operand or argument; a function
    /// inlined there (not recursive) counts with its body.
    pub fn never_returns(&self, ex: &Expanded, f: usize) -> bool {
        let cycle = self.cycle_of(f);
        let recursive = self.recursive();
        match ex.items.get(f).map(|it| &it.item.kind) {
            Some(ItemKind::Function { body, .. }) => must_call(ex, body, &cycle, &recursive, 0),
            _ => false,
        }
    }
}

/// Whether every evaluation of `e` calls a function of `cycle` (`depth` bounds the
/// inlined bodies followed, as inlining itself is bounded by the graph being
/// acyclic outside `recursive`).
fn must_call(ex: &Expanded, e: &Expr, cycle: &BTreeSet<usize>, recursive: &BTreeSet<usize>, depth: u32) -> bool {
    let rec = |x: &Expr| must_call(ex, x, cycle, recursive, depth);
    match &e.kind {
        ExprKind::Num(_) | ExprKind::Var(_) | ExprKind::Error => false,
        ExprKind::Neg(x) | ExprKind::Not(x) | ExprKind::Paren(x) => rec(x),
        ExprKind::Tuple(xs) => xs.iter().any(rec),
        ExprKind::Index(v, i) => rec(v) || rec(i),
        ExprKind::Binary(_, a, b) => rec(a) || rec(b),
        ExprKind::Let(bindings, body) => bindings.iter().any(|(_, v)| rec(v)) || rec(body),
        ExprKind::Call(f, args) if f.text == "if" => match args.as_slice() {
            [c, a, b] => rec(c) || (rec(a) && rec(b)),
            _ => false,
        },
        ExprKind::Call(f, args) if f.text == "select" => match args.split_first() {
            Some((i, choices)) => rec(i) || (!choices.is_empty() && choices.iter().all(rec)),
            None => false,
        },
        ExprKind::Call(f, args) => {
            if args.iter().any(rec) {
                return true;
            }
            if Func::from_name(&f.text).is_some() {
                return false;
            }
            match ex.user_function(&f.text) {
                Some((i, ..)) if cycle.contains(&i) => true,
                Some((i, _, _, body)) if !recursive.contains(&i) && depth < 64 => {
                    must_call(ex, body, cycle, recursive, depth + 1)
                }
                _ => false,
            }
        }
    }
}
