//! A Context Free program's tree ([`super::cfparse`]) written as MDG: `flat` art
//! with `CIRCLE`/`SQUARE`/`TRIANGLE`, Context Free's canonical adjustment order
//! made explicit, `loop`/`if`/`let` for CFDG 3's control flow, and the degrees of
//! Context Free's trigonometry converted. What MDG cannot say goes to the report.

use super::cfparse::{const_value, Adj, Expr, Item, Program, Shape, PATH_OPS};
use super::names::{num, Names};
use super::report::Report;
use std::collections::BTreeMap;
use std::fmt::Write;

pub(crate) const PRIMITIVES: &[&str] = &["CIRCLE", "SQUARE", "TRIANGLE"];

pub(crate) struct Emitter<'a> {
    pub prog: &'a Program,
    pub rep: &'a mut Report,
    pub names: Names,
    /// Names in scope in the rule being written: source name → MDG name.
    scope: Vec<(String, String)>,
    /// The vectors among them (parameters, locals): source name → size, latest last.
    vsizes: Vec<(String, usize)>,
    /// Shape parameters by shape name (for `X(=)`).
    params: BTreeMap<String, Vec<String>>,
    counter: u32,
    line: u32,
    /// Functions without parameters being inlined (a recursion among them is cut).
    inlining: Vec<String>,
    /// Whether the shape being written is a Context Free `path`.
    in_path: bool,
}

impl<'a> Emitter<'a> {
    pub(crate) fn new(prog: &'a Program, rep: &'a mut Report) -> Emitter<'a> {
        let params =
            prog.shapes.iter().map(|s| (s.name.clone(), s.params.iter().map(|p| p.1.clone()).collect())).collect();
        Emitter {
            prog,
            rep,
            names: Names::default(),
            scope: Vec::new(),
            vsizes: Vec::new(),
            params,
            counter: 0,
            line: 0,
            inlining: Vec::new(),
            in_path: false,
        }
    }

    fn fresh(&mut self, base: &str) -> String {
        self.counter += 1;
        format!("_{base}{}", self.counter)
    }

    /// The rules, functions and start rule (directives are the caller's).
    pub(crate) fn shapes(&mut self, out: &mut String) {
        // Functions with parameters, in source order (MDG functions may call later
        // ones and recurse); those without are inlined where they are called.
        let funcs: Vec<&(String, Vec<String>, Expr, u32)> =
            self.prog.functions.iter().filter(|f| !f.1.is_empty()).collect();
        for (name, params, body, line) in funcs {
            self.line = *line;
            let mdg = self.names.get(name);
            self.scope = params.iter().map(|p| (p.clone(), self.names.get(p))).collect();
            let types = self.prog.function_types.get(name).cloned().unwrap_or_default();
            self.vsizes = params
                .iter()
                .zip(&types)
                .filter_map(|(p, t)| crate::vectors::vector_size(t).map(|n| (p.clone(), n)))
                .collect();
            let ps: Vec<String> = self
                .scope
                .iter()
                .enumerate()
                .map(|(k, p)| match types.get(k).filter(|t| crate::vectors::vector_size(t).is_some()) {
                    Some(t) => format!("{t} {}", p.1),
                    None => p.1.clone(),
                })
                .collect();
            let e = self.expr(body);
            let _ = writeln!(out, "function {mdg}({}) {{ {e} }}\n", ps.join(", "));
        }
        let shapes: Vec<&Shape> = self.prog.shapes.iter().collect();
        for sh in shapes {
            if sh.rules.is_empty() {
                self.rep.drop(sh.line, "shape", format!("`{}` has no rules: it draws nothing", sh.name));
            }
            let weights = weights(&sh.rules.iter().map(|r| (r.weight, r.percent)).collect::<Vec<_>>());
            let name = self.names.get(&sh.name);
            self.in_path = self.prog.paths.contains(&sh.name);
            for (k, r) in sh.rules.iter().enumerate() {
                self.line = r.line;
                self.counter = 0;
                self.scope.clear();
                self.vsizes.clear();
                let mut ps = Vec::new();
                for (ty, p) in &sh.params {
                    let vector = crate::vectors::vector_size(ty);
                    if !matches!(ty.as_str(), "number" | "natural") && vector.is_none() {
                        self.rep.approx(sh.line, ty, format!("parameter `{p}` of type {ty} is written as a float"));
                    }
                    let m = self.names.get(p);
                    match vector {
                        Some(n) => {
                            ps.push(format!("{ty} {m}"));
                            self.vsizes.push((p.clone(), n));
                        }
                        None => ps.push(format!("float {m}")),
                    }
                    self.scope.push((p.clone(), m));
                }
                let head = if ps.is_empty() { name.clone() } else { format!("{name}({})", ps.join(", ")) };
                let w = if sh.rules.len() > 1 { format!(" {}", num(weights[k])) } else { String::new() };
                let _ = writeln!(out, "rule {head}{w} {{");
                for it in &r.body {
                    self.item(it, 1, out);
                }
                out.push_str("}\n\n");
            }
        }
    }

    pub(crate) fn item(&mut self, it: &Item, ind: usize, out: &mut String) {
        let pad = "  ".repeat(ind);
        match it {
            Item::Nothing => {}
            Item::Block(items) => {
                let _ = writeln!(out, "{pad}{{");
                let n = self.scope.len();
                for i in items {
                    self.item(i, ind + 1, out);
                }
                self.scope.truncate(n);
                let _ = writeln!(out, "{pad}}}");
            }
            Item::Let { name, value } => {
                let v = self.expr(value);
                let n = self.size_of(value, 0);
                self.vsizes.push((name.clone(), n));
                let m = self.fresh_local(name);
                let _ = writeln!(out, "{pad}let {m} = {v};");
            }
            Item::Call { name, args, same, adj, line } => {
                self.line = *line;
                if let Some(s) = self.call(name, args.as_deref(), *same, adj) {
                    let _ = writeln!(out, "{pad}{s}");
                }
            }
            Item::Loop { var, start, end, step, adj, body, line } => {
                self.line = *line;
                let n = self.scope.len();
                let s = start.as_ref().map(|e| self.expr(e)).unwrap_or_else(|| "0".into());
                let e = self.expr(end);
                let st = step.as_ref().map(|e| format!(", {}", self.expr(e))).unwrap_or_default();
                // MDG's loop list cannot read the loop's variable: it reads the start.
                let seen =
                    var.as_ref().is_some_and(|v| adj.terms.iter().any(|t| t.args.iter().any(|a| mentions(a, v))));
                if let (true, Some(v)) = (seen, var) {
                    self.rep.approx(*line, v, "the loop's own adjustment reads its variable: its start value is used");
                    self.scope.push((v.clone(), format!("({s})")));
                }
                let a = self.adj(adj);
                if seen {
                    self.scope.pop();
                }
                let v = match var {
                    Some(v) => self.fresh_local(v),
                    None => self.fresh("i"),
                };
                let _ = write!(out, "{pad}loop {v} = {s}, {e}{st} {a}");
                self.sub_item(body, ind + 1, out);
                self.scope.truncate(n);
            }
            Item::If { cond, then, els } => {
                let c = self.expr(cond);
                let _ = writeln!(out, "{pad}if ({c}) {{");
                self.branch(then, ind + 1, out);
                match els {
                    Some(e) => {
                        let _ = writeln!(out, "{pad}}} else {{");
                        self.branch(e, ind + 1, out);
                        let _ = writeln!(out, "{pad}}}");
                    }
                    None => {
                        let _ = writeln!(out, "{pad}}}");
                    }
                }
            }
            // MDG's `switch` is Context Free's (the value rounded down, ranges inclusive).
            Item::Switch { on, cases, default } => {
                let v = self.expr(on);
                let _ = writeln!(out, "{pad}switch ({v}) {{");
                for (labels, body) in cases {
                    let labels: Vec<String> = labels
                        .iter()
                        .map(|(a, b)| match b {
                            None => self.expr(a),
                            Some(b) => format!("{}..{}", self.expr(a), self.expr(b)),
                        })
                        .collect();
                    let _ = writeln!(out, "{pad}  case {}:", labels.join(", "));
                    self.branch(body, ind + 2, out);
                }
                if let Some(d) = default {
                    let _ = writeln!(out, "{pad}  else:");
                    self.branch(d, ind + 2, out);
                }
                let _ = writeln!(out, "{pad}}}");
            }
            Item::Transform { adj, body } => {
                let a = self.adj(adj);
                let _ = write!(out, "{pad}1 * {a}");
                self.sub_item(body, ind + 1, out);
            }
            Item::PathOp { op, line, .. } if !self.in_path => {
                // (`FILL` in a shape: Context Free draws nothing for it; in MDG it
                // would make the rule a path, its shapes outlines.)
                self.rep.drop(*line, op, "a path operation in a shape, not a path: Context Free draws nothing for it");
            }
            Item::PathOp { op, args, adj, line } => {
                self.line = *line;
                if let Some(s) = self.path_op(op, args, adj) {
                    let _ = writeln!(out, "{pad}{s}");
                }
            }
        }
    }

    /// A path operation in MDG's flat path form (reference §9, "Flat paths"):
    /// `OP(numbers) options {adjustments}`. CFDG 2's coordinates (`x`, `y`, `x1`…,
    /// `r`/`rx`/`ry`, `width`) and `p` words, and CFDG 3's `CF::` flags, become the
    /// arguments and the option word; the rest of the list stays a list.
    fn path_op(&mut self, op: &str, args: &[Expr], adj: &Adj) -> Option<String> {
        let line = self.line;
        // A vector argument gives its components (`MOVETO(p)`).
        let args = &self.components(args);
        // `MOVEREL`, `LINEREL`, `ARCREL`, `CURVEREL` keep their names (MDG has
        // them) and take the absolute operation's arguments and words.
        let name = op;
        let op = crate::paths::canonical(op).0;
        let mut words: Vec<String> = Vec::new();
        fn flags(e: &Expr, out: &mut Vec<String>) -> bool {
            match e {
                Expr::Name(n) if n.starts_with("CF::") => {
                    out.push(n[4..].to_ascii_lowercase());
                    true
                }
                Expr::Bin("+", a, b) | Expr::Bin("|", a, b) => {
                    let k = out.len();
                    if flags(a, out) && flags(b, out) {
                        true
                    } else {
                        out.truncate(k);
                        false
                    }
                }
                _ => false,
            }
        }
        let mut pos: Vec<&Expr> = Vec::new();
        for a in args {
            if !flags(a, &mut words) {
                pos.push(a);
            }
        }
        let point_op = op != "FILL" && op != "STROKE";
        let mut named: BTreeMap<&str, &Expr> = BTreeMap::new();
        let mut rest = Adj { ordered: adj.ordered, terms: Vec::new() };
        for t in &adj.terms {
            let n = t.name.as_str();
            let coord = matches!(n, "x" | "y" | "x1" | "y1" | "x2" | "y2" | "rx" | "ry")
                || (op == "ARCTO" && matches!(n, "r" | "rot" | "rotate"));
            if matches!(n, "p" | "param") {
                for a in &t.args {
                    if let Expr::Name(w) = a {
                        words.push(w.to_ascii_lowercase());
                    }
                }
            } else if n == "width" && op == "STROKE" {
                if let Some(a) = t.args.first() {
                    named.insert("width", a);
                }
            } else if coord && point_op && !t.target {
                if let Some(a) = t.args.first() {
                    named.insert(if n.starts_with('r') && n.len() > 1 && n != "rx" && n != "ry" { "r" } else { n }, a);
                }
                if t.args.len() > 1 && matches!(n, "x" | "y") {
                    self.rep.approx(line, n, "a path point's `x`/`y` with two values: the first is kept");
                }
            } else {
                rest.terms.push(t.clone());
            }
        }
        // Context Free's words in MDG's spelling.
        let mut mdg_words: Vec<&str> = Vec::new();
        let mut smooth = false;
        for w in &words {
            let m = match w.as_str() {
                "arclarge" | "large" => "large",
                "arccw" | "cw" => "cw",
                "align" => "align",
                "evenodd" => "evenodd",
                "miterjoin" => "miterjoin",
                "roundjoin" => "roundjoin",
                "beveljoin" => "beveljoin",
                "buttcap" => "buttcap",
                "roundcap" => "roundcap",
                "squarecap" => "squarecap",
                "iso" | "isowidth" => "iso",
                "continuous" => {
                    smooth = true;
                    continue;
                }
                other => {
                    self.rep.approx(line, other, format!("path option `{other}` has no MDG form: left out"));
                    continue;
                }
            };
            let ok = match op {
                "ARCTO" => matches!(m, "large" | "cw"),
                "CLOSEPOLY" => m == "align",
                "FILL" => m == "evenodd",
                "STROKE" => m.ends_with("join") || m.ends_with("cap") || m == "iso",
                _ => false,
            };
            if ok && !mdg_words.contains(&m) {
                mdg_words.push(m);
            }
        }
        // One join and one cap: the last one given wins.
        for kind in ["join", "cap"] {
            while mdg_words.iter().filter(|w| w.ends_with(kind)).count() > 1 {
                if let Some(k) = mdg_words.iter().position(|w| w.ends_with(kind)) {
                    mdg_words.remove(k);
                }
            }
        }
        let e = |me: &mut Self, x: Option<&&Expr>| x.map(|x| me.expr(x)).unwrap_or_else(|| "0".into());
        let a = |me: &mut Self, i: usize| e(me, pos.get(i));
        let n = |me: &mut Self, k: &str| e(me, named.get(k));
        let v3 = !pos.is_empty();
        let call: Vec<String> = match op {
            "MOVETO" | "LINETO" if v3 => vec![a(self, 0), a(self, 1)],
            "MOVETO" | "LINETO" => vec![n(self, "x"), n(self, "y")],
            "ARCTO" if v3 && pos.len() >= 5 => (0..5).map(|i| a(self, i)).collect(),
            "ARCTO" if v3 => vec![a(self, 0), a(self, 1), a(self, 2)],
            "ARCTO" if named.contains_key("rx") || named.contains_key("ry") => {
                let rx = named.get("rx").or(named.get("ry")).copied();
                let ry = named.get("ry").or(named.get("rx")).copied();
                vec![n(self, "x"), n(self, "y"), e(self, rx.as_ref()), e(self, ry.as_ref()), n(self, "r")]
            }
            "ARCTO" => vec![n(self, "x"), n(self, "y"), n(self, "r")],
            "CURVETO" if v3 => {
                // (x, y, x1, y1[, x2, y2]); with CF::Continuous (x, y[, x2, y2]).
                if pos.len() < 4 || (smooth && pos.len() < 6) {
                    smooth = true;
                }
                let k = if smooth {
                    if pos.len() >= 4 {
                        4
                    } else {
                        2
                    }
                } else if pos.len() >= 6 {
                    6
                } else {
                    4
                };
                (0..k).map(|i| a(self, i)).collect()
            }
            "CURVETO" => {
                let (c1, c2) = (
                    named.contains_key("x1") || named.contains_key("y1"),
                    named.contains_key("x2") || named.contains_key("y2"),
                );
                let mut v = vec![n(self, "x"), n(self, "y")];
                match (c1, c2) {
                    (true, true) => v.extend([n(self, "x1"), n(self, "y1"), n(self, "x2"), n(self, "y2")]),
                    (true, false) => v.extend([n(self, "x1"), n(self, "y1")]),
                    (false, true) => {
                        smooth = true;
                        v.extend([n(self, "x2"), n(self, "y2")]);
                    }
                    (false, false) => smooth = true,
                }
                v
            }
            "STROKE" if v3 => vec![a(self, 0)],
            "STROKE" => named.get("width").map(|w| vec![self.expr(w)]).unwrap_or_default(),
            _ => Vec::new(),
        };
        if op == "CURVETO" && smooth {
            mdg_words.insert(0, "smooth");
        }
        let list = self.adj(&rest);
        let argv = if call.is_empty() { String::new() } else { format!("({})", call.join(", ")) };
        let word = if mdg_words.is_empty() { String::new() } else { format!(" {}", mdg_words.join("_")) };
        Some(format!("{name}{argv}{word} {list}"))
    }

    /// The item of a loop or transform: a block or one item, never empty.
    fn sub_item(&mut self, it: &Item, ind: usize, out: &mut String) {
        let pad = "  ".repeat(ind - 1);
        let mut body = String::new();
        match it {
            Item::Block(items) => {
                let n = self.scope.len();
                for i in items {
                    self.item(i, ind, &mut body);
                }
                self.scope.truncate(n);
            }
            other => self.item(other, ind, &mut body),
        }
        let _ = write!(out, " {{\n{body}{pad}}}\n");
    }

    /// The body of an `if` branch (the braces are the caller's).
    fn branch(&mut self, it: &Item, ind: usize, out: &mut String) {
        let n = self.scope.len();
        match it {
            Item::Block(items) => {
                for i in items {
                    self.item(i, ind, out);
                }
            }
            other => self.item(other, ind, out),
        }
        self.scope.truncate(n);
    }

    fn fresh_local(&mut self, src: &str) -> String {
        let base = self.names.get(src);
        // MDG names in one rule do not shadow each other: number repeats.
        let m = if self.scope.iter().any(|(_, m)| *m == base) { format!("{base}_{}", self.scope.len()) } else { base };
        self.scope.push((src.to_string(), m.clone()));
        m
    }

    fn call(&mut self, name: &str, args: Option<&[Expr]>, same: bool, adj: &Adj) -> Option<String> {
        let line = self.line;
        if PATH_OPS.contains(&name) {
            self.rep.drop(line, name, "a path operation outside a path: left out");
            return None;
        }
        let prim = PRIMITIVES.contains(&name);
        let Some(sh) = self.prog.shapes.iter().find(|s| s.name == name && !s.rules.is_empty()) else {
            if !prim {
                self.rep.drop(
                    line,
                    name,
                    "a call of an undefined shape (a shape-typed parameter or variable has no MDG form): left out",
                );
                return None;
            }
            let a = self.adj(adj);
            return Some(format!("{name} {a}"));
        };
        // A shape of the program's own named like a primitive replaces it, as in
        // Context Free (it is renamed: MDG's built-in stays for the others).
        let mdg = self.names.get(&sh.name);
        let want = self.params.get(name).map(|p| p.len()).unwrap_or(0);
        let mut argv: Vec<String> = match args {
            Some(a) => a.iter().map(|e| self.expr(e)).collect(),
            None if same => {
                let ps = self.params.get(name).cloned().unwrap_or_default();
                ps.iter().map(|p| self.expr(&Expr::Name(p.clone()))).collect()
            }
            None => Vec::new(),
        };
        if argv.len() != want {
            self.rep.approx(
                line,
                name,
                format!("called with {} arguments for {want} parameters: missing ones are 0", argv.len()),
            );
            argv.resize(want, "0".into());
        }
        let a = self.adj(adj);
        Some(if argv.is_empty() { format!("{mdg} {a}") } else { format!("{mdg}({}) {a}", argv.join(", ")) })
    }

    /// An adjustment list in MDG's written order.
    pub(crate) fn adj(&mut self, adj: &Adj) -> String {
        let mut terms: Vec<&super::cfparse::Term> = adj.terms.iter().collect();
        if !adj.ordered {
            // Context Free's canonical order: translate, rotate, scale, skew, flip.
            terms.sort_by_key(|t| match t.name.as_str() {
                "x" | "y" | "z" => 0,
                "r" | "rot" | "rotate" => 1,
                "s" | "size" => 2,
                "skew" => 3,
                "f" | "flip" => 4,
                _ => 5,
            });
        }
        let mut parts: Vec<String> = Vec::new();
        for t in terms {
            let line = t.line;
            if t.target {
                self.rep.drop(line, &format!("{}|", t.name), "colour targets have no MDG form: the change is left out");
                continue;
            }
            // A vector argument gives its components (`s v` is `s v[0] v[1]`).
            let spread = self.components(&t.args);
            let args: Vec<String> = spread.iter().map(|e| self.arg(e)).collect();
            let consts: Vec<Option<f64>> = spread.iter().map(|e| self.const_of(e)).collect();
            let n = args.len();
            match (t.name.as_str(), n) {
                ("x", 1..=3) | ("y", 1) | ("z", 1) => parts.push(format!("{} {}", t.name, args.join(" "))),
                ("s" | "size", 1) => parts.push(format!("s {}", args[0])),
                ("s" | "size", 2) => {
                    // Z keeps the area's scale, so `minsize` compares what Context Free's does.
                    let z = match (consts[0], consts[1]) {
                        (Some(a), Some(b)) => num((a * b).abs().sqrt()),
                        _ => format!("(sqrt(abs({} * {})))", args[0], args[1]),
                    };
                    parts.push(format!("s {} {} {z}", args[0], args[1]));
                }
                ("s" | "size", 3) => parts.push(format!("s {}", args.join(" "))),
                ("r" | "rot" | "rotate", 1) => parts.push(format!("rz {}", args[0])),
                ("f" | "flip", 1) => parts.push(match consts[0] {
                    Some(a) => {
                        let r = a.to_radians();
                        format!("f {} {} 0", num(clean(-r.sin())), num(clean(r.cos())))
                    }
                    None => format!("f (-sin(radians({0}))) (cos(radians({0}))) 0", args[0]),
                }),
                ("h" | "hue", 1) => parts.push(format!("hue {}", args[0])),
                ("sat" | "saturation", 1) => parts.push(format!("sat {}", args[0])),
                ("b" | "brightness", 1) => parts.push(format!("b {}", args[0])),
                ("a" | "alpha", 1) => {
                    self.rep.approx(
                        line,
                        &t.name,
                        "alpha is MDG's additive `A` (Context Free's moves a fraction toward 0 or 1)",
                    );
                    parts.push(format!("A {}", args[0]));
                }
                ("skew", 2) => parts.push(format!("skew {} {}", args[0], args[1])),
                ("trans" | "transform", _) => {
                    self.rep.drop(line, &t.name, "an affine transform: MDG has no matrix adjustment")
                }
                ("z", 2..) | ("y", 2..) => parts.push(format!("{} {}", t.name, args[0])),
                _ => self.rep.drop(line, &t.name, format!("an adjustment with {n} values: no MDG form")),
            }
        }
        if parts.is_empty() {
            "{}".into()
        } else {
            format!("{{{}}}", parts.join(" "))
        }
    }

    /// How many components `e` has (1: a number), as far as the program says: vector
    /// literals, vector parameters and locals, globals and functions that are vectors.
    fn size_of(&self, e: &Expr, depth: u32) -> usize {
        if depth > 64 {
            return 1;
        }
        match e {
            Expr::Tuple(items) => items.iter().map(|x| self.size_of(x, depth + 1)).sum(),
            Expr::Name(n) => {
                if let Some((_, k)) = self.vsizes.iter().rev().find(|(s, _)| s == n) {
                    return *k;
                }
                if self.scope.iter().any(|(s, _)| s == n) {
                    return 1;
                }
                match self.prog.globals.iter().rev().find(|(g, _)| g == n) {
                    Some((_, g)) => self.size_of(g, depth + 1),
                    None => 1,
                }
            }
            Expr::Neg(a) => self.size_of(a, depth + 1),
            Expr::Bin(op, a, b) if matches!(*op, "+" | "-" | "*" | "/") => {
                self.size_of(a, depth + 1).max(self.size_of(b, depth + 1))
            }
            Expr::Call(f, args) if f == "if" => args.get(1).map_or(1, |x| self.size_of(x, depth + 1)),
            Expr::Call(f, args) if f == "select" => args.get(1).map_or(1, |x| self.size_of(x, depth + 1)),
            // (`inlining` holds the functions being sized: a recursion counts as 1.)
            Expr::Call(f, _) if self.inlining.contains(f) => 1,
            Expr::Call(f, args) if matches!(f.as_str(), "vec" | "cross") => match self.vector_function(f, args) {
                Some(e) => self.size_of(&e, depth + 1),
                None => 1,
            },
            Expr::Call(f, _) => match self.prog.functions.iter().find(|(n, _, _, _)| n == f) {
                Some((_, _, Expr::Tuple(items), _)) => items.len(),
                Some((n, ps, body, _)) => {
                    // The body's size with the function's own vector parameters.
                    let types = self.prog.function_types.get(n).cloned().unwrap_or_default();
                    let inner: Vec<(String, usize)> = ps
                        .iter()
                        .zip(&types)
                        .map(|(p, t)| (p.clone(), crate::vectors::vector_size(t).unwrap_or(1)))
                        .collect();
                    let mut quiet = Report::new("", "");
                    let mut sub = Emitter::new(self.prog, &mut quiet);
                    sub.vsizes = inner;
                    sub.inlining = self.inlining.clone();
                    sub.inlining.push(f.clone());
                    sub.scope = ps.iter().map(|p| (p.clone(), p.clone())).collect();
                    sub.size_of(body, depth + 1)
                }
                None => 1,
            },
            _ => 1,
        }
    }

    /// `vec(n, x)` (n copies of x), `dot(a, b)` and `cross(a, b)` as expressions of
    /// components; `None` for another call (or one whose sizes do not fit: reported
    /// as a function with no counterpart).
    fn vector_function(&self, f: &str, args: &[Expr]) -> Option<Expr> {
        let bin = |op: &'static str, a: Expr, b: Expr| Expr::Bin(op, Box::new(a), Box::new(b));
        match (f, args) {
            ("vec", [n, x]) => {
                let n = const_value(n).filter(|n| n.fract() == 0.0 && (2.0..=99.0).contains(n))? as usize;
                Some(Expr::Tuple(vec![x.clone(); n]))
            }
            ("dot", [a, b]) => {
                let (a, b) = (self.components(std::slice::from_ref(a)), self.components(std::slice::from_ref(b)));
                if a.len() != b.len() || a.len() < 2 {
                    return None;
                }
                a.into_iter().zip(b).map(|(x, y)| bin("*", x, y)).reduce(|s, t| bin("+", s, t))
            }
            ("cross", [a, b]) => {
                let (a, b) = (self.components(std::slice::from_ref(a)), self.components(std::slice::from_ref(b)));
                if a.len() != 3 || b.len() != 3 {
                    return None;
                }
                let c = |i: usize, j: usize| {
                    bin("-", bin("*", a[i].clone(), b[j].clone()), bin("*", a[j].clone(), b[i].clone()))
                };
                Some(Expr::Tuple(vec![c(1, 2), c(2, 0), c(0, 1)]))
            }
            _ => None,
        }
    }

    /// The arguments, a vector among them spread into its components.
    fn components(&self, args: &[Expr]) -> Vec<Expr> {
        let mut out = Vec::new();
        for a in args {
            // A global vector's own components (`rand(range)` is `rand(10, 20)`).
            let global = match a {
                Expr::Name(n) if !self.scope.iter().any(|(s, _)| s == n) => {
                    self.prog.globals.iter().rev().find(|(g, _)| g == n).map(|(_, e)| e)
                }
                _ => None,
            };
            if let Some(g @ Expr::Tuple(_)) = global {
                out.extend(self.components(std::slice::from_ref(g)));
                continue;
            }
            if let Expr::Call(f, xs) = a {
                if let Some(e @ Expr::Tuple(_)) = self.vector_function(f, xs) {
                    out.extend(self.components(std::slice::from_ref(&e)));
                    continue;
                }
            }
            match (a, self.size_of(a, 0)) {
                (Expr::Tuple(items), _) => out.extend(self.components(items)),
                (_, 1) => out.push(a.clone()),
                (_, n) => out.extend((0..n).map(|k| Expr::Index(Box::new(a.clone()), Box::new(Expr::Num(k as f64))))),
            }
        }
        out
    }

    fn const_of(&self, e: &Expr) -> Option<f64> {
        match e {
            Expr::Name(n) if !self.scope.iter().any(|(s, _)| s == n) => {
                self.prog.globals.iter().rev().find(|(g, _)| g == n).and_then(|(_, e)| const_value(e))
            }
            _ => const_value(e),
        }
    }

    /// An adjustment argument: a number, or an expression in parentheses.
    fn arg(&mut self, e: &Expr) -> String {
        if let Some(v) = self.const_of(e) {
            return num(v);
        }
        format!("({})", self.expr(e))
    }

    pub(crate) fn expr(&mut self, e: &Expr) -> String {
        let line = self.line;
        match e {
            Expr::Num(v) => num(*v),
            Expr::Name(n) => {
                if let Some((_, m)) = self.scope.iter().rev().find(|(s, _)| s == n) {
                    return m.clone();
                }
                if let Some((_, g)) = self.prog.globals.iter().rev().find(|(g, _)| g == n).cloned() {
                    if let Some(v) = const_value(&g) {
                        return num(v);
                    }
                    return format!("({})", self.expr(&g));
                }
                self.rep.approx(line, n, "a name MDG cannot read here: 0");
                "0".into()
            }
            Expr::Neg(a) => format!("-({})", self.expr(a)),
            Expr::Not(a) => format!("!({})", self.expr(a)),
            Expr::Tuple(items) => {
                let a: Vec<String> = items.iter().map(|e| self.expr(e)).collect();
                format!("({})", a.join(", "))
            }
            Expr::Index(v, i) => {
                let n = self.size_of(v, 0);
                if n == 1 {
                    // Not a vector here (a function the importer left out, say).
                    self.rep.approx(
                        line,
                        "v[i]",
                        "a component of a value that is not a vector here: the value is used",
                    );
                    return self.expr(v);
                }
                let base = match &**v {
                    Expr::Name(_) => self.expr(v),
                    _ => format!("({})", self.expr(v)),
                };
                match self.const_of(i) {
                    Some(k) => format!("{base}[{}]", num(k)),
                    // MDG's index is a constant: choose at run time with `select`.
                    None => {
                        let k = self.expr(i);
                        let comps: Vec<String> = (0..n.max(1)).map(|c| format!("{base}[{c}]")).collect();
                        format!("select({k}, {})", comps.join(", "))
                    }
                }
            }
            Expr::Bin(op, a, b) => {
                let (x, y) = (self.expr(a), self.expr(b));
                match *op {
                    "--" => format!("max(({x}) - ({y}), 0)"),
                    "<>" => format!("({x}) != ({y})"),
                    "^^" => format!("(({x}) != 0) != (({y}) != 0)"),
                    "%" => format!("mod({x}, {y})"),
                    "+-" | ".." => {
                        self.rep.approx(line, op, "a range has no MDG form: its first value is used");
                        x
                    }
                    _ => format!("({x}) {op} ({y})"),
                }
            }
            Expr::Call(f, args) => self.function(f, args),
        }
    }

    fn function(&mut self, f: &str, args: &[Expr]) -> String {
        let line = self.line;
        // Context Free's vector functions, written out in components.
        if let Some(e) = self.vector_function(f, args) {
            return self.expr(&e);
        }
        // A vector gives a built-in its components (`rand(range)` is `rand(10,
        // 20)`); a user function takes its arguments as they are.
        let args =
            if self.prog.functions.iter().any(|(n, _, _, _)| n == f) { args.to_vec() } else { self.components(args) };
        let args = args.as_slice();
        let a: Vec<String> = args.iter().map(|e| self.expr(e)).collect();
        let arg = |k: usize| a.get(k).cloned().unwrap_or_else(|| "0".into());
        match (f, a.len()) {
            ("sin" | "cos" | "tan", 1) => format!("{f}(radians({}))", arg(0)),
            ("asin" | "acos" | "atan", 1) => format!("degrees({f}({}))", arg(0)),
            ("atan2", 2) => format!("degrees(atan2({}, {}))", arg(0), arg(1)),
            ("sqrt" | "abs" | "exp" | "log" | "floor" | "ceil", 1) => format!("{f}({})", arg(0)),
            ("frac", 1) => format!("fract({})", arg(0)),
            ("log10", 1) => format!("(log({}) / log(10))", arg(0)),
            ("mod" | "fmod", 2) => format!("mod({}, {})", arg(0), arg(1)),
            ("div", 2) => format!("floor(({}) / ({}))", arg(0), arg(1)),
            ("hypot", 2) => format!("sqrt(({0}) * ({0}) + ({1}) * ({1}))", arg(0), arg(1)),
            ("sg", 1) => format!("(({0}) > 0) - (({0}) < 0)", arg(0)),
            ("sinh", 1) => format!("((exp({0}) - exp(-({0}))) / 2)", arg(0)),
            ("cosh", 1) => format!("((exp({0}) + exp(-({0}))) / 2)", arg(0)),
            ("tanh", 1) => format!("((exp(2 * ({0})) - 1) / (exp(2 * ({0})) + 1))", arg(0)),
            ("min" | "max", 2..) => {
                let mut s = arg(0);
                for x in &a[1..] {
                    s = format!("{f}({s}, {x})");
                }
                s
            }
            ("rand", 0) | ("rand::uniform", 0) => "rand(0, 1)".into(),
            ("rand", 1) => format!("rand(0, {})", arg(0)),
            ("rand", 2) => format!("rand({}, {})", arg(0), arg(1)),
            ("randint", 0) => "floor(rand(0, 2))".into(),
            ("randint", 1) => format!("floor(rand(0, {}))", arg(0)),
            ("randint", 2) => format!("floor(rand({}, {}))", arg(0), arg(1)),
            ("rand_static", n) => {
                self.rep.approx(line, "rand_static", "drawn per call (MDG has no once-per-program draw)");
                match n {
                    0 => "rand(0, 1)".into(),
                    1 => format!("rand(0, {})", arg(0)),
                    _ => format!("rand({}, {})", arg(0), arg(1)),
                }
            }
            // MDG's own, lazy as Context Free's: only the chosen branch is evaluated
            // (a recursive function's base case needs that).
            ("if", 3) => format!("if({}, {}, {})", arg(0), arg(1), arg(2)),
            ("select", n) if n >= 2 => format!("select({})", a.join(", ")),
            ("infinity", _) => "1e30".into(),
            _ => {
                if let Some((_, ps, body, _)) = self.prog.functions.iter().find(|(n, _, _, _)| n == f) {
                    if ps.is_empty() && a.is_empty() {
                        if self.inlining.iter().any(|c| c == f) {
                            self.rep.approx(
                                line,
                                f,
                                "a recursive function without parameters never ends: the recursive call is 0",
                            );
                            return "0".into();
                        }
                        let body = body.clone();
                        self.inlining.push(f.to_string());
                        let e = self.expr(&body);
                        self.inlining.pop();
                        return format!("({e})");
                    }
                    if ps.len() == a.len() {
                        let m = self.names.get(f);
                        return format!("{m}({})", a.join(", "));
                    }
                }
                self.rep.approx(line, f, "a function with no MDG counterpart: 0");
                "0".into()
            }
        }
    }
}

/// Rounds away the last-bit noise of sin/cos of whole degrees (`flip 90`).
fn clean(v: f64) -> f64 {
    let r = (v * 1e12).round() / 1e12;
    if r == 0.0 {
        0.0
    } else {
        r
    }
}

/// Context Free's weights: `N%` rules take that share, the others split the rest in
/// proportion to their weights.
pub(crate) fn weights(ws: &[(f64, bool)]) -> Vec<f64> {
    let pct: f64 = ws.iter().filter(|w| w.1).map(|w| w.0 / 100.0).sum();
    let plain: f64 = ws.iter().filter(|w| !w.1).map(|w| w.0).sum();
    if pct == 0.0 {
        return ws.iter().map(|w| w.0).collect();
    }
    let rest = (1.0 - pct).max(0.0);
    ws.iter()
        .map(|&(w, p)| {
            if p {
                w / 100.0
            } else if plain > 0.0 {
                rest * w / plain
            } else {
                0.0
            }
        })
        .collect()
}

/// Context Free's background: its adjustments applied to white (hue 0, saturation
/// 0, brightness 1, alpha 1), as `#rrggbb` (`None` when an argument is not a number).
pub(crate) fn background(adj: &Adj) -> Option<String> {
    let (mut h, mut s, mut b, mut a) = (0.0f64, 0.0f64, 1.0f64, 1.0f64);
    let toward = |v: f64, d: f64| if d > 0.0 { v + d * (1.0 - v) } else { v + d * v };
    for t in &adj.terms {
        let v = t.args.first().and_then(const_value)?;
        match t.name.as_str() {
            "h" | "hue" => h = (h + v).rem_euclid(360.0),
            "sat" | "saturation" => s = toward(s, v.clamp(-1.0, 1.0)),
            "b" | "brightness" => b = toward(b, v.clamp(-1.0, 1.0)),
            "a" | "alpha" => a = toward(a, v.clamp(-1.0, 1.0)),
            _ => {}
        }
    }
    let [r, g, bl] = crate::cfdg::hsb_to_rgb(h, s, b);
    let byte = |x: f64| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
    Some(if a < 1.0 {
        format!("#{:02x}{:02x}{:02x}{:02x}", byte(r), byte(g), byte(bl), byte(a))
    } else {
        format!("#{:02x}{:02x}{:02x}", byte(r), byte(g), byte(bl))
    })
}

/// Whether `e` reads the name `n`.
fn mentions(e: &Expr, n: &str) -> bool {
    match e {
        Expr::Name(m) => m == n,
        Expr::Num(_) => false,
        Expr::Call(_, a) | Expr::Tuple(a) => a.iter().any(|x| mentions(x, n)),
        Expr::Bin(_, a, b) | Expr::Index(a, b) => mentions(a, n) || mentions(b, n),
        Expr::Neg(a) | Expr::Not(a) => mentions(a, n),
    }
}
