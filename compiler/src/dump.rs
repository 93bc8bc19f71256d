//! Readable tree dumps of the syntax tree, for parser tests (`tests/parse/*/*.tree`).
//!
//! One node per line, indented by depth, spans as `@start..end`.

use crate::ast::*;
use std::fmt::Write;

/// Dumps a file's tree.
pub fn dump_file(file: &File) -> String {
    let mut d = Dumper { out: String::new(), depth: 0 };
    for item in &file.items {
        d.item(item);
    }
    d.out
}

struct Dumper {
    out: String,
    depth: usize,
}

impl Dumper {
    fn line(&mut self, text: &str) {
        for _ in 0..self.depth {
            self.out.push_str("  ");
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    fn nested(&mut self, head: &str, f: impl FnOnce(&mut Self)) {
        self.line(head);
        self.depth += 1;
        f(self);
        self.depth -= 1;
    }

    fn item(&mut self, item: &Item) {
        let at = format!("@{}..{}", item.span.start, item.span.end);
        match &item.kind {
            ItemKind::Startshape(n) => self.line(&format!("Startshape {} {at}", n.text)),
            ItemKind::Rule(r) => {
                let mut head = format!("Rule {}", r.name.text);
                if let Some(p) = &r.params {
                    let list: Vec<String> = p
                        .params
                        .iter()
                        .map(|d| {
                            let def = if d.default.is_some() { "=…" } else { "" };
                            format!("{} {}{def}", d.ty.text, d.name.text)
                        })
                        .collect();
                    let _ = write!(head, "({})", list.join(", "));
                }
                if let Some(i) = &r.iter {
                    let _ = write!(head, " *{}", i.text);
                }
                for t in &r.transforms {
                    let _ = write!(head, " :{}", t.text);
                }
                if let Some(e) = &r.weight_expr {
                    let _ = write!(head, " weight=({})", crate::fmt::expr(e));
                }
                if let Some(w) = &r.weight {
                    let _ = write!(head, " weight={}{}", if w.negative { "-" } else { "" }, w.number.text);
                }
                self.nested(&format!("{head} {at}"), |d| d.body(&r.body));
            }
            ItemKind::Selector { rules, mode } => {
                let names: Vec<&str> = rules.iter().map(|n| n.text.as_str()).collect();
                self.nested(&format!("Selector {} {at}", names.join(",")), |d| match mode {
                    SelectorMode::Word(w) => d.line(&format!("Mode {}", w.text)),
                    SelectorMode::FunctionRef(f) => d.line(&format!("FunctionRef {}", f.text)),
                    SelectorMode::FunctionBody(e) => d.nested("FunctionBody", |d| d.expr(e)),
                });
            }
            ItemKind::Linerule(n) => self.line(&format!("Linerule {} {at}", n.text)),
            ItemKind::Camerarule(n) => self.line(&format!("Camerarule {} {at}", n.text)),
            ItemKind::Namespace { name, items } => self.nested(&format!("Namespace {} {at}", name.text), |d| {
                for i in items {
                    d.item(i);
                }
            }),
            ItemKind::Directive { name, args } => {
                self.nested(&format!("Directive {} {at}", name.text), |d| {
                    for a in args {
                        d.dir_arg(a);
                    }
                });
            }
            ItemKind::Function { name, params, types, body } => {
                let ps = crate::fmt::typed_params(params, types);
                let ps = if ps.is_empty() { String::new() } else { format!("({}) ", ps.join(", ")) };
                self.nested(&format!("Function {} {ps}{at}", name.text), |d| d.expr(body))
            }
            ItemKind::Isosurface { name, entries } => self.nested(&format!("Isosurface {} {at}", name.text), |d| {
                for e in entries {
                    match e {
                        IsoEntry::Axis { axis, args, .. } => d.nested(&format!("Axis {}", axis.text), |d| {
                            for a in args {
                                d.dir_arg(a);
                            }
                        }),
                        IsoEntry::FunctionRef(f) => d.line(&format!("FunctionRef {}", f.text)),
                        IsoEntry::FunctionBody(e) => d.nested("FunctionBody", |d| d.expr(e)),
                    }
                }
            }),
            ItemKind::Program { words } => {
                let w: Vec<&str> = words.iter().map(|n| n.text.as_str()).collect();
                self.line(&format!("Program [{}] {at}", w.join(" ")));
            }
            ItemKind::Section(sec) => {
                let name = sec.name.as_ref().map(|n| format!(" {}", n.text)).unwrap_or_default();
                self.nested(&format!("Section {}{name} {at}", sec.kind.text), |d| d.entries(&sec.entries));
            }
            ItemKind::Pre(p) => self.pre(p, &at, |d, i: &Item| d.item(i)),
            ItemKind::Error => self.line(&format!("Error {at}")),
        }
    }

    fn entries(&mut self, entries: &[Entry]) {
        for e in entries {
            let at = format!("@{}..{}", e.span.start, e.span.end);
            self.nested(&format!("Entry {} {at}", e.key.text), |d| {
                for v in &e.values {
                    match v {
                        Value::Num(n) => d.line(&format!("Num {}", n.text)),
                        Value::Neg(n) => d.line(&format!("Neg {}", n.text)),
                        Value::Word(w) => d.line(&format!("Word {}", w.text)),
                        Value::Str(s, _) => d.line(&format!("Str {s:?}")),
                        Value::Expr(e) => d.expr(e),
                    }
                }
                if let Some((inner, _)) = &e.block {
                    d.nested("Block", |d| d.entries(inner));
                }
            });
        }
    }

    fn pre<T>(&mut self, p: &Pre<T>, at: &str, each: impl Fn(&mut Self, &T) + Copy) {
        let words = |v: &[Name]| v.iter().map(|n| n.text.as_str()).collect::<Vec<_>>().join(" ");
        match p {
            Pre::Import(v) => self.line(&format!("Import [{}] {at}", words(v))),
            Pre::Define { name, value } => self.line(&format!(
                "Define {}{} {at}",
                name.text,
                value.as_ref().map(|v| format!(" = {}", v.text)).unwrap_or_default()
            )),
            Pre::Param(v) => self.line(&format!("Param [{}] {at}", words(v))),
            Pre::Presets(v) => self.line(&format!("Presets [{}] {at}", words(v))),
            Pre::Shader { vertex, name, code, .. } => self.line(&format!(
                "Shader {} {} ({} lines) {at}",
                if *vertex { "vertex" } else { "fragment" },
                name.text,
                code.lines().count()
            )),
            Pre::Macro(m) => {
                self.line(&format!("Macro {}({}) {} tokens {at}", m.name.text, words(&m.params), m.body.len()))
            }
            Pre::Expand { name, args } => {
                let a: Vec<String> = args.iter().map(|a| format!("{} tokens", a.tokens.len())).collect();
                self.line(&format!("Expand {}({}) {at}", name.text, a.join(", ")));
            }
            Pre::IfDef { name, then, otherwise } => self.nested(&format!("IfDef {} {at}", name.text), |d| {
                for t in then {
                    each(d, t);
                }
                if let Some(o) = otherwise {
                    d.nested("Else", |d| {
                        for t in o {
                            each(d, t);
                        }
                    });
                }
            }),
            Pre::Bad => self.line(&format!("BadDirective {at}")),
        }
    }

    fn body(&mut self, items: &[BodyItem]) {
        for i in items {
            self.body_item(i);
        }
    }

    fn body_item(&mut self, item: &BodyItem) {
        let at = format!("{}@{}..{}", if item.cont { "\\ " } else { "" }, item.span.start, item.span.end);
        match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                let p = profile.as_ref().map(|p| format!(" profile={}", p.text)).unwrap_or_default();
                self.nested(&format!("Call {}{p} {at}", name.text), |d| {
                    if let Some(args) = args {
                        d.nested(&format!("Args @{}..{}", args.span.start, args.span.end), |d| {
                            for a in &args.args {
                                d.expr(a);
                            }
                        });
                    }
                    d.adj_list(adj)
                });
            }
            BodyKind::If { cond, then, then_span, otherwise } => {
                self.nested(&format!("If {at}"), |d| {
                    d.nested("Cond", |d| d.expr(cond));
                    d.nested(&format!("Then @{}..{}", then_span.start, then_span.end), |d| d.body(then));
                    if let Some(o) = otherwise {
                        d.nested("Else", |d| d.body_item(o));
                    }
                });
            }
            BodyKind::Let { name, value } => self.nested(&format!("Let {} {at}", name.text), |d| d.expr(value)),
            BodyKind::Loop { var, range, adj, item } => {
                let LoopRange { start, end, step } = &**range;
                self.nested(&format!("Loop {} {at}", var.text), |d| {
                    d.expr(start);
                    d.expr(end);
                    if let Some(s) = step {
                        d.nested("Step", |d| d.expr(s));
                    }
                    d.adj_list(adj);
                    d.body_item(item);
                });
            }
            BodyKind::Iterate { count, divisor, adj, chain, item } => {
                let c = count_text(count);
                let dv = divisor.as_ref().map(|d| format!("/{}", count_text(d))).unwrap_or_default();
                let ch = if *chain { " chained" } else { "" };
                self.nested(&format!("Iterate {c}{dv}{ch} {at}"), |d| {
                    if let Count::Expr(e) = count {
                        d.nested("Count", |d| d.expr(e));
                    }
                    d.adj_list(adj);
                    d.body_item(item);
                });
            }
            BodyKind::Block(items) => self.nested(&format!("Block {at}"), |d| d.body(items)),
            BodyKind::Switch(s) => self.nested(&format!("Switch {at}"), |d| {
                d.nested("Value", |d| d.expr(&s.value));
                for arm in &s.arms {
                    d.nested(&format!("Case @{}..{}", arm.span.start, arm.span.end), |d| {
                        for l in &arm.labels {
                            match &l.hi {
                                None => d.nested("Label", |d| d.expr(&l.lo)),
                                Some(h) => d.nested("Range", |d| {
                                    d.expr(&l.lo);
                                    d.expr(h);
                                }),
                            }
                        }
                        d.body(&arm.body);
                    });
                }
                if let Some((items, span)) = &s.otherwise {
                    d.nested(&format!("Else @{}..{}", span.start, span.end), |d| d.body(items));
                }
            }),
            BodyKind::Pre(p) => self.pre(p, &at, |d, i: &BodyItem| d.body_item(i)),
            BodyKind::Error => self.line(&format!("Error {at}")),
        }
    }

    fn adj_list(&mut self, adj: &AdjList) {
        let b = if adj.square { "[]" } else { "{}" };
        self.nested(&format!("Adjust {b} @{}..{}", adj.span.start, adj.span.end), |d| {
            for a in &adj.adjs {
                let simple: Vec<String> = a
                    .args
                    .iter()
                    .map(|x| match x {
                        Arg::Num(n) => n.text.clone(),
                        Arg::Neg(n) => format!("-{}", n.text),
                        Arg::Expr(_) => "<expr>".to_string(),
                    })
                    .collect();
                d.nested(format!("{} {}", a.name.text, simple.join(" ")).trim_end(), |d| {
                    for x in &a.args {
                        if let Arg::Expr(e) = x {
                            d.expr(e);
                        }
                    }
                });
            }
        });
    }

    fn dir_arg(&mut self, a: &DirArg) {
        match a {
            DirArg::Num(n) => self.line(&format!("Num {}", n.text)),
            DirArg::Neg(n) => self.line(&format!("Num -{}", n.text)),
            DirArg::Word(w) => self.line(&format!("Word {}", w.text)),
            DirArg::Expr(e) => self.expr(e),
        }
    }

    fn expr(&mut self, e: &Expr) {
        match &e.kind {
            ExprKind::Num(n) => self.line(&format!("Num {}", n.text)),
            ExprKind::Var(v) => self.line(&format!("Var {}", v.text)),
            ExprKind::Neg(x) => self.nested("Neg", |d| d.expr(x)),
            ExprKind::Not(x) => self.nested("Not", |d| d.expr(x)),
            ExprKind::Binary(op, a, b) => self.nested(&format!("Binary {}", op.symbol()), |d| {
                d.expr(a);
                d.expr(b);
            }),
            ExprKind::Call(f, args) => self.nested(&format!("Call {}", f.text), |d| {
                for a in args {
                    d.expr(a);
                }
            }),
            ExprKind::Let(bindings, body) => self.nested("Let", |d| {
                for (n, v) in bindings {
                    d.nested(&format!("Bind {}", n.text), |d| d.expr(v));
                }
                d.expr(body);
            }),
            ExprKind::Paren(x) => self.nested("Paren", |d| d.expr(x)),
            ExprKind::Tuple(xs) => self.nested("Tuple", |d| {
                for x in xs {
                    d.expr(x);
                }
            }),
            ExprKind::Index(v, i) => self.nested("Index", |d| {
                d.expr(v);
                d.expr(i);
            }),
            ExprKind::Error => self.line("ErrorExpr"),
        }
    }
}

fn count_text(c: &Count) -> String {
    match c {
        Count::Num(n) => n.text.clone(),
        Count::Neg(n) => format!("-{}", n.text),
        Count::Expr(_) => "(expr)".to_string(),
    }
}
