//! Vectors in expressions (Context Free's): `(a, b)` and `(a, b, c)` literals,
//! `vector2`…`vector99` parameters of rules and functions, `v[i]` with a constant
//! index, `+ - * /` componentwise or with a number, and adjustments that take a
//! vector (`x v`, `s v`: its components are the adjustment's arguments).
//!
//! A vector is a group of scalars known at compile time, never a value at run time:
//! [`scalarize`] rewrites a program that writes vectors into one that does not,
//! before it is checked and lowered, so the expression machine, its verifier and the
//! bundle are unchanged. A `vector2 v` parameter is two parameters `v[0]` and `v[1]`
//! (a call passes two arguments), a vector `let` is one binding per component, a
//! vector expression is one scalar expression per component (so `v[1]` is a
//! compile-time selection), and a function that takes or returns a vector is
//! inlined at each call, its parameters replaced by the arguments' components.
//!
//! The errors this pass reports: E0332 (a vector where a number is expected), E0333
//! (a vector of another size, or a number, where a vector is expected), E0334 (an
//! index that is not a constant, or out of range), E0335 (a function with vectors
//! that calls itself). Everything else is the checker's, on the rewritten program:
//! its spans are the source's, so its diagnostics point at what was written.

use crate::ast::*;
use crate::diag::Diagnostic;
use crate::expand::{ExpItem, Expanded};
use crate::span::Span;
use std::collections::{BTreeSet, HashMap};
use std::sync::Arc;

/// The largest vector (Context Free's limit).
pub const MAX_SIZE: usize = 99;

/// The most operations one written-out call of a function with vectors may give
/// (E0336): nested calls repeat their arguments, so they can grow exponentially.
pub const MAX_WRITTEN_OUT: usize = 200_000;

/// The number of components a type word names: `vector2` … `vector99`.
pub fn vector_size(word: &str) -> Option<usize> {
    let digits = word.strip_prefix("vector")?;
    let n: usize = digits.parse().ok()?;
    (digits == n.to_string() && (2..=MAX_SIZE).contains(&n)).then_some(n)
}

/// The program with its vectors rewritten into scalars, and the errors found doing
/// so; `None` when the program writes no vector (nothing to do).
pub fn scalarize(ex: &Expanded) -> Option<(Expanded, Vec<Diagnostic>)> {
    if !ex.items.iter().any(|i| item_uses_vectors(&i.item)) {
        return None;
    }
    let mut s = Scalarizer::new(ex);
    let items = ex
        .items
        .iter()
        .map(|i| ExpItem { item: s.item(&i.item, i.namespace.as_deref()), namespace: i.namespace.clone() })
        .collect();
    s.unread_params();
    let out = Expanded {
        items,
        shaders: ex.shaders.clone(),
        params: ex.params.clone(),
        defines: ex.defines.clone(),
        presets: ex.presets.clone(),
        expansions: ex.expansions.clone(),
        files: ex.files.clone(),
        main_ast: File::default(),
        diagnostics: Vec::new(),
        suppressed: Default::default(),
        main_memo: Default::default(),
        reused: Default::default(),
    };
    Some((out, s.diags))
}

/// Whether an item writes a vector (a vector type, literal or index).
fn item_uses_vectors(item: &Item) -> bool {
    let mut found = false;
    match &item.kind {
        ItemKind::Rule(r) => {
            if r.params.iter().flat_map(|p| &p.params).any(|p| vector_size(&p.ty.text).is_some()) {
                return true;
            }
            let mut f = |e: &Expr| found |= expr_uses_vectors(e);
            for p in r.params.iter().flat_map(|p| &p.params) {
                if let Some(d) = &p.default {
                    f(d);
                }
            }
            walk_body(&r.body, &mut |b| body_exprs(b, &mut f));
        }
        ItemKind::Function { types, body, .. } => {
            found = types.iter().any(Option::is_some) || expr_uses_vectors(body);
        }
        ItemKind::Namespace { items, .. } => found = items.iter().any(item_uses_vectors),
        _ => {}
    }
    found
}

/// Calls `f` on the expressions of one body item (not of the items nested in it).
fn body_exprs(b: &BodyItem, f: &mut dyn FnMut(&Expr)) {
    let adj = |a: &AdjList, f: &mut dyn FnMut(&Expr)| {
        for x in &a.adjs {
            for arg in &x.args {
                if let Arg::Expr(e) = arg {
                    f(e);
                }
            }
        }
    };
    match &b.kind {
        BodyKind::Call { args, adj: a, .. } => {
            for e in args.iter().flat_map(|c| &c.args) {
                f(e);
            }
            adj(a, f);
        }
        BodyKind::If { cond, .. } => f(cond),
        BodyKind::Let { value, .. } => f(value),
        BodyKind::Loop { range, adj: a, .. } => {
            f(&range.start);
            f(&range.end);
            if let Some(s) = &range.step {
                f(s);
            }
            adj(a, f);
        }
        BodyKind::Iterate { count, divisor, adj: a, .. } => {
            for c in std::iter::once(count).chain(divisor.as_ref()) {
                if let Count::Expr(e) = c {
                    f(e);
                }
            }
            adj(a, f);
        }
        _ => {}
    }
}

fn expr_uses_vectors(e: &Expr) -> bool {
    match &e.kind {
        ExprKind::Tuple(_) | ExprKind::Index(..) => true,
        ExprKind::Num(_) | ExprKind::Var(_) | ExprKind::Error => false,
        ExprKind::Neg(x) | ExprKind::Not(x) | ExprKind::Paren(x) => expr_uses_vectors(x),
        ExprKind::Binary(_, a, b) => expr_uses_vectors(a) || expr_uses_vectors(b),
        ExprKind::Call(_, xs) => xs.iter().any(expr_uses_vectors),
        ExprKind::Let(bs, body) => bs.iter().any(|(_, v)| expr_uses_vectors(v)) || expr_uses_vectors(body),
    }
}

/// The names a `let(…)` may not bind (E0329, the checker's): kept as written in an
/// inlined body, so the checker still says so.
const RESERVED: &[&str] = &["x", "y", "z", "depth", "scale", "g"];

/// A function as the pass sees it.
struct Function<'a> {
    name: &'a Name,
    params: &'a [Name],
    /// Each parameter's size (1: a number).
    sizes: Vec<usize>,
    body: &'a Expr,
    /// Whether calls are inlined here: it takes or returns a vector.
    vector: bool,
}

/// A name in scope: its components (one for a number), as scalar expressions.
type Env = Vec<(String, Vec<Expr>)>;

struct Scalarizer<'a> {
    ex: &'a Expanded,
    diags: Vec<Diagnostic>,
    /// Functions by full and bare name.
    functions: HashMap<String, usize>,
    fns: Vec<Function<'a>>,
    /// Rule parameter sizes by full name (rules with a parameter list).
    rules: HashMap<String, Vec<usize>>,
    /// The functions being inlined, innermost last (for E0335).
    inlining: Vec<usize>,
    /// Counts renamed `let` bindings in inlined bodies (`a#3`).
    renames: usize,
    /// Vector names read (by their declaration's span).
    read: BTreeSet<(u32, u32, u32)>,
    /// Vector parameters declared: rule, name, declaration span.
    vector_params: Vec<(String, String, Span)>,
    /// Vector parameters read by some definition: (rule, name).
    params_read: BTreeSet<(String, String)>,
}

fn key(s: Span) -> (u32, u32, u32) {
    (s.file.0, s.start, s.end)
}

fn qualify(ns: Option<&str>, name: &str) -> String {
    match ns {
        Some(ns) => format!("{ns}.{name}"),
        None => name.to_string(),
    }
}

fn e(kind: ExprKind, span: Span) -> Expr {
    Expr { kind, span }
}

/// The variable `name[k]` (a component's name in the rewritten program).
fn component(name: &str, k: usize, span: Span) -> Expr {
    e(ExprKind::Var(Name { text: format!("{name}[{k}]"), span }), span)
}

/// "a number", "a `vector2`".
fn size_name(n: usize) -> String {
    if n == 1 {
        "a number".to_string()
    } else {
        format!("a `vector{n}`")
    }
}

impl<'a> Scalarizer<'a> {
    fn new(ex: &'a Expanded) -> Scalarizer<'a> {
        let mut s = Scalarizer {
            ex,
            diags: Vec::new(),
            functions: HashMap::new(),
            fns: Vec::new(),
            rules: HashMap::new(),
            inlining: Vec::new(),
            renames: 0,
            read: BTreeSet::new(),
            vector_params: Vec::new(),
            params_read: BTreeSet::new(),
        };
        for it in &ex.items {
            s.collect(&it.item, it.namespace.as_deref());
        }
        // Whether a function returns a vector needs the sizes of the functions it
        // calls: settle it by rounds (a round marks functions whose body is a vector).
        loop {
            let mut changed = false;
            for i in 0..s.fns.len() {
                if !s.fns[i].vector && s.returns_vector(i) {
                    s.fns[i].vector = true;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        s
    }

    fn collect(&mut self, item: &'a Item, ns: Option<&str>) {
        match &item.kind {
            ItemKind::Rule(r) => {
                if let Some(p) = &r.params {
                    let full = qualify(ns, &r.name.text);
                    let sizes = p.params.iter().map(|d| vector_size(&d.ty.text).unwrap_or(1)).collect();
                    self.rules.entry(full).or_insert(sizes);
                }
            }
            ItemKind::Function { name, params, types, body } if !params.is_empty() => {
                let sizes: Vec<usize> =
                    types.iter().map(|t| t.as_ref().and_then(|t| vector_size(&t.text)).unwrap_or(1)).collect();
                let vector = sizes.iter().any(|&n| n > 1);
                let i = self.fns.len();
                self.fns.push(Function { name, params, sizes, body, vector });
                self.functions.entry(qualify(ns, &name.text)).or_insert(i);
                self.functions.entry(name.text.clone()).or_insert(i);
            }
            ItemKind::Namespace { name, items } => {
                let full = qualify(ns, &name.text);
                for it in items {
                    self.collect(it, Some(&full));
                }
            }
            _ => {}
        }
    }

    /// Whether function `i`'s body is a vector (without reporting anything).
    fn returns_vector(&self, i: usize) -> bool {
        let f = &self.fns[i];
        let sizes: HashMap<&str, usize> =
            f.params.iter().map(|p| p.text.as_str()).zip(f.sizes.iter().copied()).collect();
        self.size_of(f.body, &sizes, &mut vec![i]) > 1
    }

    /// The size of an expression, as far as can be told without reporting (used to
    /// tell which functions return vectors).
    fn size_of(&self, x: &Expr, sizes: &HashMap<&str, usize>, stack: &mut Vec<usize>) -> usize {
        match &x.kind {
            ExprKind::Tuple(xs) => xs.iter().map(|x| self.size_of(x, sizes, stack)).sum(),
            ExprKind::Var(v) => sizes.get(v.text.as_str()).copied().unwrap_or(1),
            ExprKind::Paren(x) | ExprKind::Neg(x) => self.size_of(x, sizes, stack),
            ExprKind::Binary(BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div, a, b) => {
                self.size_of(a, sizes, stack).max(self.size_of(b, sizes, stack))
            }
            ExprKind::Call(f, xs) if f.text == "if" || f.text == "select" => {
                xs.iter().skip(1).map(|x| self.size_of(x, sizes, stack)).max().unwrap_or(1)
            }
            ExprKind::Call(f, _) => match self.functions.get(&f.text) {
                Some(&j) if !stack.contains(&j) && self.fns[j].vector => {
                    stack.push(j);
                    let g = &self.fns[j];
                    let inner: HashMap<&str, usize> =
                        g.params.iter().map(|p| p.text.as_str()).zip(g.sizes.iter().copied()).collect();
                    let n = self.size_of(g.body, &inner, stack);
                    stack.pop();
                    n
                }
                _ => 1,
            },
            ExprKind::Let(bs, body) => {
                let mut inner = sizes.clone();
                for (n, v) in bs {
                    let k = self.size_of(v, &inner, stack);
                    inner.insert(n.text.as_str(), k);
                }
                self.size_of(body, &inner, stack)
            }
            _ => 1,
        }
    }

    // ---- items ----

    fn item(&mut self, item: &Item, ns: Option<&str>) -> Item {
        let kind = match &item.kind {
            ItemKind::Rule(r) => ItemKind::Rule(Arc::new(self.rule(r, ns))),
            ItemKind::Function { name, params, types, body } => self.function(name, params, types, body),
            ItemKind::Namespace { name, items } => {
                let full = qualify(ns, &name.text);
                ItemKind::Namespace {
                    name: name.clone(),
                    items: items.iter().map(|i| self.item(i, Some(&full))).collect(),
                }
            }
            k => k.clone(),
        };
        Item { kind, span: item.span }
    }

    /// A function's item: a number function's body rewritten; a vector function
    /// (inlined at every call) kept with its parameters spread and its components as
    /// the choices of a `select`, so the checker still reads every part of its body.
    fn function(&mut self, name: &Name, params: &[Name], types: &[Option<Name>], body: &Expr) -> ItemKind {
        let sizes: Vec<usize> =
            types.iter().map(|t| t.as_ref().map_or(Some(1), |t| self.param_type(t))).map(|n| n.unwrap_or(1)).collect();
        let mut env = Env::new();
        let mut flat = Vec::new();
        for (p, &n) in params.iter().zip(&sizes) {
            if n > 1 {
                env.push((p.text.clone(), (0..n).map(|k| component(&p.text, k, p.span)).collect()));
                flat.extend((0..n).map(|k| Name { text: format!("{}[{k}]", p.text), span: p.span }));
            } else {
                flat.push(p.clone());
            }
        }
        let me = self.functions.get(&name.text).copied().filter(|&i| self.fns[i].vector);
        if let Some(i) = me {
            self.inlining.push(i);
        }
        let mut comps = self.comps(body, &mut env);
        if me.is_some() {
            self.inlining.pop();
        }
        let body = if comps.len() == 1 {
            comps.remove(0)
        } else {
            let zero =
                e(ExprKind::Num(Number { value: 0.0, unit: None, text: "0".into(), span: body.span }), body.span);
            let mut args = vec![zero];
            args.extend(comps);
            e(ExprKind::Call(Name { text: "select".into(), span: name.span }, args), body.span)
        };
        ItemKind::Function { name: name.clone(), params: flat, types: Vec::new(), body }
    }

    /// The size a function parameter's type word names (E0325 for another word).
    fn param_type(&mut self, t: &Name) -> Option<usize> {
        match t.text.as_str() {
            "float" | "int" | "bool" | "number" => Some(1),
            w => {
                match vector_size(w) {
                    Some(n) => Some(n),
                    None => {
                        self.diags.push(
                        Diagnostic::error("E0325", t.span, format!("unknown parameter type `{w}`"))
                            .with_label("not a type")
                            .with_note("a function's parameters are numbers, or vectors: `vector2`, `vector3`, … `vector99`"),
                    );
                        None
                    }
                }
            }
        }
    }

    fn rule(&mut self, r: &Rule, ns: Option<&str>) -> Rule {
        let full = qualify(ns, &r.name.text);
        let mut env = Env::new();
        let params = r.params.as_ref().map(|p| {
            let mut out = Vec::new();
            for d in &p.params {
                match vector_size(&d.ty.text) {
                    Some(n) => {
                        let defaults = d.default.as_ref().map(|x| {
                            let c = self.comps(x, &mut Env::new());
                            self.want(c, n, x.span, "this default")
                        });
                        for k in 0..n {
                            out.push(ParamDecl {
                                ty: Name { text: "float".into(), span: d.ty.span },
                                name: Name { text: format!("{}[{k}]", d.name.text), span: d.name.span },
                                default: defaults.as_ref().map(|c| c[k].clone()),
                                span: d.span,
                            });
                        }
                        env.push((
                            d.name.text.clone(),
                            (0..n).map(|k| component(&d.name.text, k, d.name.span)).collect(),
                        ));
                        self.vector_params.push((full.clone(), d.name.text.clone(), d.name.span));
                    }
                    None => {
                        let default = d.default.as_ref().map(|x| self.scalar(x, &mut Env::new(), "a default"));
                        out.push(ParamDecl { default, ..d.clone() });
                        env.push((d.name.text.clone(), vec![e(ExprKind::Var(d.name.clone()), d.name.span)]));
                    }
                }
            }
            Params { params: out, span: p.span }
        });
        let weight_expr = r.weight_expr.as_ref().map(|x| self.scalar(x, &mut env, "a weight"));
        let body = self.body(&r.body, &mut env, ns);
        for (rule, name, span) in &self.vector_params {
            if rule == &full && self.read.contains(&key(*span)) {
                self.params_read.insert((rule.clone(), name.clone()));
            }
        }
        Rule { params, weight_expr, body, ..r.clone() }
    }

    /// W0006 for a vector parameter no definition reads (the checker leaves
    /// components alone: see `check.rs`).
    fn unread_params(&mut self) {
        let mut seen = BTreeSet::new();
        for (rule, name, span) in std::mem::take(&mut self.vector_params) {
            if self.params_read.contains(&(rule.clone(), name.clone())) || name.starts_with('_') {
                continue;
            }
            if seen.insert((rule, name.clone())) {
                self.diags.push(
                    Diagnostic::warning("W0006", span, format!("parameter `{name}` is never used"))
                        .with_label("never read")
                        .with_note(format!("use it, remove it, or name it `_{name}`")),
                );
            }
        }
    }

    fn body(&mut self, items: &[BodyItem], env: &mut Env, ns: Option<&str>) -> Vec<BodyItem> {
        let mark = env.len();
        let mut out = Vec::new();
        for item in items {
            self.body_item(item, env, ns, &mut out);
        }
        self.close(env, mark);
        out
    }

    /// Ends a scope: W0006 for its vector `let`s never read.
    fn close(&mut self, env: &mut Env, mark: usize) {
        for (name, comps) in env.drain(mark.min(env.len())..) {
            if comps.len() > 1 {
                let span = comps[0].span;
                if !self.read.contains(&key(span)) && !name.starts_with('_') {
                    self.diags.push(
                        Diagnostic::warning("W0006", span, format!("local `{name}` is never used"))
                            .with_label("never read")
                            .with_note(format!("use it, remove it, or name it `_{name}`")),
                    );
                }
            }
        }
    }

    /// One body item, written to `out` (a vector `let` is one `let` per component).
    fn body_item(&mut self, item: &BodyItem, env: &mut Env, ns: Option<&str>, out: &mut Vec<BodyItem>) {
        let kind = match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                let args =
                    args.as_ref().map(|c| CallArgs { args: self.call_args(name, &c.args, env, ns), span: c.span });
                BodyKind::Call { name: name.clone(), args, profile: profile.clone(), adj: self.adj(adj, env) }
            }
            BodyKind::If { cond, then, then_span, otherwise } => {
                let cond = self.scalar(cond, env, "a condition");
                let then = self.body(then, env, ns);
                let otherwise = otherwise.as_ref().map(|o| {
                    let mut one = Vec::new();
                    let mark = env.len();
                    self.body_item(o, env, ns, &mut one);
                    self.close(env, mark);
                    Box::new(single(one, o.span))
                });
                BodyKind::If { cond, then, then_span: *then_span, otherwise }
            }
            BodyKind::Let { name, value } => {
                let comps = self.comps(value, env);
                if comps.len() > 1 {
                    let n = comps.len();
                    for (k, c) in comps.into_iter().enumerate() {
                        let kind = BodyKind::Let {
                            name: Name { text: format!("{}[{k}]", name.text), span: name.span },
                            value: c,
                        };
                        out.push(BodyItem { kind, cont: false, span: item.span });
                    }
                    env.push((name.text.clone(), (0..n).map(|k| component(&name.text, k, name.span)).collect()));
                    return;
                }
                env.push((name.text.clone(), vec![e(ExprKind::Var(name.clone()), name.span)]));
                BodyKind::Let { name: name.clone(), value: comps.into_iter().next().unwrap_or_else(|| value.clone()) }
            }
            BodyKind::Loop { var, range, adj, item: inner } => {
                let range = Box::new(LoopRange {
                    start: self.scalar(&range.start, env, "a loop bound"),
                    end: self.scalar(&range.end, env, "a loop bound"),
                    step: range.step.as_ref().map(|s| self.scalar(s, env, "a loop step")),
                });
                let mark = env.len();
                env.push((var.text.clone(), vec![e(ExprKind::Var(var.clone()), var.span)]));
                let adj = self.adj(adj, env);
                let mut one = Vec::new();
                self.body_item(inner, env, ns, &mut one);
                env.truncate(mark);
                BodyKind::Loop { var: var.clone(), range, adj, item: Box::new(single(one, inner.span)) }
            }
            BodyKind::Iterate { count, divisor, adj, chain, item: inner } => {
                let count = self.count(count, env);
                let divisor = divisor.as_ref().map(|d| self.count(d, env));
                let adj = self.adj(adj, env);
                let mut one = Vec::new();
                let mark = env.len();
                self.body_item(inner, env, ns, &mut one);
                self.close(env, mark);
                BodyKind::Iterate { count, divisor, adj, chain: *chain, item: Box::new(single(one, inner.span)) }
            }
            BodyKind::Block(items) => BodyKind::Block(self.body(items, env, ns)),
            k => k.clone(),
        };
        out.push(BodyItem { kind, cont: item.cont, span: item.span });
    }

    fn count(&mut self, c: &Count, env: &mut Env) -> Count {
        match c {
            Count::Expr(x) => match self.scalar(x, env, "a count") {
                // Reported; a count of 1 keeps the checker from reporting its type too.
                c if failed(std::slice::from_ref(&c)) => {
                    Count::Num(Number { value: 1.0, unit: None, text: "1".into(), span: x.span })
                }
                c => Count::Expr(c),
            },
            c => c.clone(),
        }
    }

    /// An adjustment list: a vector argument gives its components as arguments.
    fn adj(&mut self, a: &AdjList, env: &mut Env) -> AdjList {
        let adjs = a
            .adjs
            .iter()
            .map(|x| {
                let mut args = Vec::new();
                for arg in &x.args {
                    match arg {
                        Arg::Expr(v) => args.extend(self.comps(v, env).into_iter().map(Arg::Expr)),
                        a => args.push(a.clone()),
                    }
                }
                Adj { name: x.name.clone(), args, span: x.span }
            })
            .collect();
        AdjList { square: a.square, adjs, span: a.span }
    }

    /// A rule call's arguments: each one the size of its parameter (E0333), spread.
    fn call_args(&mut self, name: &Name, args: &[Expr], env: &mut Env, ns: Option<&str>) -> Vec<Expr> {
        let sizes = ns
            .and_then(|ns| self.rules.get(&qualify(Some(ns), &name.text)))
            .or_else(|| self.rules.get(&name.text))
            .cloned();
        let mut out = Vec::new();
        for (i, a) in args.iter().enumerate() {
            let c = self.comps(a, env);
            match sizes.as_ref().and_then(|s| s.get(i)) {
                Some(&n) if n != c.len() => {
                    let what = format!("argument {} of `{}`", i + 1, name.text);
                    out.extend(self.want(c, n, a.span, &what));
                }
                _ => out.extend(c),
            }
        }
        out
    }

    /// `c` if it has `n` components; else E0333 (or E0332 for a vector where a
    /// number is wanted) and `n` error expressions.
    fn want(&mut self, c: Vec<Expr>, n: usize, span: Span, what: &str) -> Vec<Expr> {
        if c.len() == n {
            return c;
        }
        if failed(&c) {
            // Reported where it failed.
            return (0..n).map(|_| e(ExprKind::Error, span)).collect();
        }
        if n == 1 {
            self.diags.push(vector_for_number(span, c.len(), what));
        } else if c.len() == 1 {
            self.diags.push(
                Diagnostic::error("E0333", span, format!("{what} must be {}, not a number", size_name(n)))
                    .with_label(format!("{} expected", size_name(n)))
                    .with_note(format!(
                        "write the {n} components in parentheses: `({})`",
                        (0..n).map(|k| format!("a{k}")).collect::<Vec<_>>().join(", ")
                    )),
            );
        } else {
            self.diags.push(
                Diagnostic::error(
                    "E0333",
                    span,
                    format!("{what} must be {}, not {}", size_name(n), size_name(c.len())),
                )
                .with_label(format!("{} components, {n} expected", c.len())),
            );
        }
        (0..n).map(|_| e(ExprKind::Error, span)).collect()
    }

    /// A number: E0332 for a vector.
    fn scalar(&mut self, x: &Expr, env: &mut Env, what: &str) -> Expr {
        let c = self.comps(x, env);
        self.want(c, 1, x.span, what).remove(0)
    }

    // ---- expressions ----

    /// The components of `x`, each a scalar expression (one for a number).
    fn comps(&mut self, x: &Expr, env: &mut Env) -> Vec<Expr> {
        let span = x.span;
        match &x.kind {
            ExprKind::Num(_) | ExprKind::Error => vec![x.clone()],
            ExprKind::Var(v) => match env.iter().rev().find(|(n, _)| *n == v.text) {
                Some((_, c)) => {
                    if let Some(first) = c.first() {
                        self.read.insert(key(first.span));
                    }
                    c.iter().map(|c| keep_span(c.clone(), span)).collect()
                }
                None => vec![x.clone()],
            },
            ExprKind::Paren(inner) => {
                let c = self.comps(inner, env);
                if c.len() == 1 && !failed(&c) {
                    c.into_iter().map(|c| e(ExprKind::Paren(Box::new(c)), span)).collect()
                } else {
                    c
                }
            }
            ExprKind::Tuple(xs) => {
                let mut c = Vec::new();
                for x in xs {
                    c.extend(self.comps(x, env));
                    if c.len() > MAX_SIZE {
                        // Vectors inside vectors could double a size at each step.
                        self.diags.push(
                            Diagnostic::error("E0333", span, format!("a vector of more than {MAX_SIZE} components"))
                                .with_label("too large")
                                .with_note(format!("vectors have 2 to {MAX_SIZE} components, as in Context Free")),
                        );
                        return vec![e(ExprKind::Error, span)];
                    }
                }
                c
            }
            ExprKind::Neg(inner) => {
                self.comps(inner, env).into_iter().map(|c| e(ExprKind::Neg(Box::new(c)), span)).collect()
            }
            ExprKind::Not(inner) => {
                let c = self.scalar(inner, env, "the operand of `!`");
                vec![e(ExprKind::Not(Box::new(c)), span)]
            }
            ExprKind::Binary(op, a, b) => self.binary(*op, a, b, span, env),
            ExprKind::Index(v, i) => {
                let c = self.comps(v, env);
                match self.index(i, &c, v.span) {
                    Some(k) => c.into_iter().nth(k).into_iter().collect(),
                    None => vec![e(ExprKind::Error, span)],
                }
            }
            ExprKind::Let(bindings, body) => {
                let mark = env.len();
                let inlined = !self.inlining.is_empty();
                let mut out = Vec::new();
                for (n, v) in bindings {
                    let c = self.comps(v, env);
                    let base = if inlined && !RESERVED.contains(&n.text.as_str()) && !n.text.contains('.') {
                        self.renames += 1;
                        format!("{}#v{}", n.text, self.renames)
                    } else {
                        n.text.clone()
                    };
                    if c.len() == 1 {
                        out.push((
                            Name { text: base.clone(), span: n.span },
                            c.into_iter().next().unwrap_or_else(|| v.clone()),
                        ));
                        env.push((n.text.clone(), vec![e(ExprKind::Var(Name { text: base, span: n.span }), n.span)]));
                    } else {
                        let k = c.len();
                        for (j, c) in c.into_iter().enumerate() {
                            out.push((Name { text: format!("{base}[{j}]"), span: n.span }, c));
                        }
                        env.push((n.text.clone(), (0..k).map(|j| component(&base, j, n.span)).collect()));
                    }
                }
                let body = self.comps(body, env);
                env.truncate(mark);
                body.into_iter().map(|b| e(ExprKind::Let(out.clone(), Box::new(b)), span)).collect()
            }
            ExprKind::Call(f, args) => self.call(f, args, span, env),
        }
    }

    fn binary(&mut self, op: BinOp, a: &Expr, b: &Expr, span: Span, env: &mut Env) -> Vec<Expr> {
        let ca = self.comps(a, env);
        let cb = self.comps(b, env);
        let join = |x: Expr, y: Expr| e(ExprKind::Binary(op, Box::new(x), Box::new(y)), span);
        if ca.len() == 1 && cb.len() == 1 {
            return ca.into_iter().zip(cb).map(|(x, y)| join(x, y)).collect();
        }
        if failed(&ca) || failed(&cb) {
            let n = if failed(&ca) { cb.len() } else { ca.len() };
            return (0..n).map(|_| e(ExprKind::Error, span)).collect();
        }
        if !matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) {
            let (bad, n) = if ca.len() > 1 { (a.span, ca.len()) } else { (b.span, cb.len()) };
            self.diags.push(vector_for_number(bad, n, &format!("an operand of `{}`", op.symbol())).with_note(
                "vectors take `+ - * /` (componentwise, or with a number); compare their components: `v[0] < w[0]`",
            ));
            return vec![e(ExprKind::Error, span)];
        }
        // Context Free's rules: `+ -` of two vectors of one size, `* /` also of a
        // vector and a number (either side).
        let scales = matches!(op, BinOp::Mul | BinOp::Div);
        match (ca.len(), cb.len()) {
            (n, m) if n == m => ca.into_iter().zip(cb).map(|(x, y)| join(x, y)).collect(),
            (1, _) if scales => cb.into_iter().map(|y| join(ca[0].clone(), y)).collect(),
            (_, 1) if scales => ca.into_iter().map(|x| join(x, cb[0].clone())).collect(),
            (n, m) => {
                let note = if scales {
                    "both sides must have the same size, or one be a number"
                } else {
                    "`+` and `-` take two vectors of the same size (as in Context Free); to add a number to each component, write it as a vector: `v + (1, 1)`"
                };
                self.diags.push(
                    Diagnostic::error(
                        "E0333",
                        span,
                        format!("`{}` of {} and {}", op.symbol(), size_name(n), size_name(m)),
                    )
                    .with_label(format!("{n} and {m} components"))
                    .with_note(note),
                );
                vec![e(ExprKind::Error, span)]
            }
        }
    }

    /// A constant index into `n` components: E0334 when it is not a constant, not a
    /// whole number or out of range, E0332-like when `n` is 1 (indexing a number).
    fn index(&mut self, i: &Expr, c: &[Expr], base: Span) -> Option<usize> {
        let n = c.len();
        if failed(c) {
            return None;
        }
        if n == 1 {
            self.diags.push(
                Diagnostic::error("E0334", base, "only a vector can be indexed")
                    .with_label("a number")
                    .with_note("`v[i]` takes component i of a vector such as `(a, b)` or a `vector2` parameter"),
            );
            return None;
        }
        let defines = &self.ex.defines;
        let value = crate::consteval::eval(i, &|name| defines.get(name).copied().flatten());
        match value {
            None => {
                self.diags.push(
                    Diagnostic::error("E0334", i.span, "a vector index must be a constant")
                        .with_label("known only when the grammar runs")
                        .with_note(format!(
                            "vectors exist only while compiling, so the component is chosen then; to choose at run time write `select(i, {})`",
                            (0..n.min(4)).map(|k| format!("v[{k}]")).collect::<Vec<_>>().join(", ") + if n > 4 { ", …" } else { "" }
                        )),
                );
                None
            }
            Some(v) if v.fract() == 0.0 && v >= 0.0 && (v as usize) < n => Some(v as usize),
            Some(v) => {
                self.diags.push(
                    Diagnostic::error("E0334", i.span, format!("index {v} is out of range"))
                        .with_label(format!("the vector has {n} components: 0 to {}", n - 1)),
                );
                None
            }
        }
    }

    fn call(&mut self, f: &Name, args: &[Expr], span: Span, env: &mut Env) -> Vec<Expr> {
        if f.text == "if" || f.text == "select" {
            let mut args = args.iter();
            let Some(first) = args.next() else { return vec![e(ExprKind::Call(f.clone(), Vec::new()), span)] };
            let sel =
                self.scalar(first, env, if f.text == "if" { "the condition of `if`" } else { "the index of `select`" });
            let branches: Vec<(Span, Vec<Expr>)> = args.map(|a| (a.span, self.comps(a, env))).collect();
            let n = branches.iter().map(|(_, c)| c.len()).max().unwrap_or(1);
            let mut cols: Vec<Vec<Expr>> = vec![vec![sel]; n];
            for (s, c) in branches {
                let c = if c.len() == n { c } else { self.want(c, n, s, &format!("a branch of `{}`", f.text)) };
                for (k, c) in c.into_iter().enumerate() {
                    cols[k].push(c);
                }
            }
            return cols.into_iter().map(|a| e(ExprKind::Call(f.clone(), a), span)).collect();
        }
        let user = self.functions.get(&f.text).copied();
        match user {
            Some(i) if self.fns[i].vector => self.inline(i, f, args, span, env),
            _ => {
                let what = match user {
                    Some(_) => format!("an argument of `{}` (a number parameter)", f.text),
                    None => format!("an argument of `{}`", f.text),
                };
                let args = args.iter().map(|a| self.scalar(a, env, &what)).collect();
                vec![e(ExprKind::Call(f.clone(), args), span)]
            }
        }
    }

    /// A call of a function with vectors: its body, each parameter replaced by the
    /// argument's components.
    fn inline(&mut self, i: usize, f: &Name, args: &[Expr], span: Span, env: &mut Env) -> Vec<Expr> {
        if self.inlining.contains(&i) {
            let name = self.fns[i].name.text.clone();
            self.diags.push(
                Diagnostic::error("E0335", span, format!("function `{name}` takes or returns a vector and calls itself"))
                    .with_label("a recursive call")
                    .with_note("a function with vectors is written out at each call, so it cannot be recursive; recursive functions take and return numbers"),
            );
            let g = &self.fns[i];
            let sizes: HashMap<&str, usize> =
                g.params.iter().map(|p| p.text.as_str()).zip(g.sizes.iter().copied()).collect();
            let n = self.size_of(g.body, &sizes, &mut vec![i]);
            return (0..n).map(|_| e(ExprKind::Error, span)).collect();
        }
        let (params, sizes, body) = {
            let g = &self.fns[i];
            (g.params, g.sizes.clone(), g.body)
        };
        if args.len() != params.len() {
            // The checker says how many (E0401) on the call as written.
            self.diags.push(
                Diagnostic::error(
                    "E0401",
                    span,
                    format!("function `{}` takes {} arguments; {} were given", f.text, params.len(), args.len()),
                )
                .with_label("wrong number of arguments"),
            );
            return vec![e(ExprKind::Error, span)];
        }
        let mut inner = Env::new();
        for ((p, &n), a) in params.iter().zip(&sizes).zip(args) {
            let c = self.comps(a, env);
            let c = self.want(c, n, a.span, &format!("argument `{}` of `{}`", p.text, f.text));
            let c = c.into_iter().map(|c| e(ExprKind::Paren(Box::new(c)), a.span)).collect();
            inner.push((p.text.clone(), c));
        }
        self.inlining.push(i);
        let out = self.comps(body, &mut inner);
        self.inlining.pop();
        // Each written-out call repeats its arguments where the body reads them, so
        // calls nested in each other's arguments grow as a power of their depth.
        let size: usize = out.iter().map(nodes).sum();
        if size > MAX_WRITTEN_OUT && !failed(&out) {
            self.diags.push(
                Diagnostic::error(
                    "E0336",
                    span,
                    format!("this call of `{}` writes out to more than {MAX_WRITTEN_OUT} operations", f.text),
                )
                .with_label(format!("{size} operations"))
                .with_note("a function with vectors is written out at each call, its arguments repeated where it reads them; bind a nested call's value with `let` first"),
            );
            return (0..out.len()).map(|_| e(ExprKind::Error, span)).collect();
        }
        // Spans of the body's parts point at the function; the call's value is here.
        out.into_iter().map(|c| e(ExprKind::Paren(Box::new(c)), span)).collect()
    }
}

/// E0332: a vector of `n` components where a number is expected.
fn vector_for_number(span: Span, n: usize, what: &str) -> Diagnostic {
    Diagnostic::error("E0332", span, format!("{what} must be a number, not {}", size_name(n)))
        .with_label(format!("a vector of {n} components"))
        .with_note("take one component with `v[0]`")
}

/// The number of nodes of an expression.
fn nodes(x: &Expr) -> usize {
    1 + match &x.kind {
        ExprKind::Num(_) | ExprKind::Var(_) | ExprKind::Error => 0,
        ExprKind::Neg(a) | ExprKind::Not(a) | ExprKind::Paren(a) => nodes(a),
        ExprKind::Binary(_, a, b) | ExprKind::Index(a, b) => nodes(a) + nodes(b),
        ExprKind::Call(_, xs) | ExprKind::Tuple(xs) => xs.iter().map(nodes).sum(),
        ExprKind::Let(bs, body) => bs.iter().map(|(_, v)| nodes(v)).sum::<usize>() + nodes(body),
    }
}

/// Whether a value is an error already reported (every component `Error`).
fn failed(c: &[Expr]) -> bool {
    !c.is_empty() && c.iter().all(|x| matches!(x.kind, ExprKind::Error))
}

/// A variable's component with the span of the place that reads it.
fn keep_span(c: Expr, span: Span) -> Expr {
    match c.kind {
        ExprKind::Var(n) => e(ExprKind::Var(Name { text: n.text, span }), span),
        k => e(k, span),
    }
}

/// One body item from what [`Scalarizer::body_item`] wrote (a block when several).
fn single(mut items: Vec<BodyItem>, span: Span) -> BodyItem {
    if items.len() == 1 {
        return items.remove(0);
    }
    BodyItem { kind: BodyKind::Block(items), cont: false, span }
}
