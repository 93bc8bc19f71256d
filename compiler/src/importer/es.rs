//! A Structure Synth (EisenScript, `.es`) program written as MDG: rules with
//! weights, `{ … }` transforms in written order, `N * { … }` loops as iterators,
//! `box`/`sphere`/… as std primitives placed as Structure Synth places its own
//! (the unit box spans 0…1), HSV colour changes, rule-local retirement as MDG's
//! (`rule R maxdepth N > S`), and Structure Synth's order: `breadthfirst` with
//! `maxobjects` (its `set maxobjects`, 100,000 when not set), or depth first after
//! `set recursion depth`.

use super::cflex::{lex, Tok, T};
use super::names::{num, Names};
use super::report::Report;
use super::Imported;
use std::collections::BTreeMap;
use std::fmt::Write;

/// One action: loops `(count, transform)` then a rule or primitive name.
struct Action {
    loops: Vec<(u32, Vec<Tf>)>,
    target: String,
    line: u32,
}

/// One transformation: name and numeric arguments (or a colour word).
struct Tf {
    name: String,
    args: Vec<f64>,
    word: Option<String>,
    line: u32,
}

struct RuleDef {
    name: String,
    weight: f64,
    maxdepth: Option<(u32, Option<String>)>,
    body: Vec<Action>,
}

const PRIMS: &[&str] = &["box", "sphere", "grid", "line", "point", "dot", "cylinder", "mesh", "cmesh", "template"];

pub(crate) fn import(file: &str, text: &str) -> Imported {
    let mut rep = Report::new(file, "structure-synth");
    let toks = expand_defines(lex(text, false).toks, &mut rep);
    let mut p = Es { toks: &toks, i: 0, rep: &mut rep };
    let mut rules: Vec<RuleDef> = Vec::new();
    let mut start: Vec<Action> = Vec::new();
    let mut directives: Vec<String> = Vec::new();
    while p.i < p.toks.len() {
        let line = p.line();
        match p.peek_id().as_deref() {
            Some("set") => {
                p.i += 1;
                let key = p.word().unwrap_or_default();
                let vals: Vec<Tok> = p.rest_of_line(line);
                p.set(&key, &vals, line, &mut directives);
            }
            Some("rule") => {
                p.i += 1;
                let name = p.word().unwrap_or_default();
                let mut weight = 1.0;
                let mut maxdepth = None;
                while let Some(w) = p.peek_id() {
                    match w.as_str() {
                        "w" | "weight" => {
                            p.i += 1;
                            weight = p.number().unwrap_or(1.0);
                        }
                        "md" | "maxdepth" => {
                            p.i += 1;
                            let n = p.number().unwrap_or(0.0).max(0.0) as u32;
                            let other = if p.eat(">") { p.word() } else { None };
                            maxdepth = Some((n, other));
                        }
                        _ => break,
                    }
                }
                let body = p.body();
                rules.push(RuleDef { name, weight, maxdepth, body });
            }
            Some(_) | None => {
                if let Some(a) = p.action() {
                    start.push(a);
                } else {
                    let t = super::cfparse::tok_text(p.toks.get(p.i).map(|t| &t.t));
                    p.rep.drop(line, &t, "not an EisenScript item here: skipped");
                    p.i += 1;
                }
            }
        }
    }
    let defined: Vec<String> = rules.iter().map(|r| r.name.clone()).collect();
    let mut names = Names::default();
    let mut out = String::new();
    let mut body = String::new();
    let mut e = Emit { rep: p.rep, names: &mut names, defined: &defined };
    let start_m = "es_start";
    let _ = writeln!(body, "rule {start_m} {{");
    for a in &start {
        e.action(a, &mut body);
    }
    body.push_str("}\n\n");
    // Retirement into a primitive (`md 10 > box`) goes through a rule that draws it.
    let mut retire_prims: Vec<String> = Vec::new();
    for r in &rules {
        let m = e.names.get(&r.name);
        let w = if rules.iter().filter(|o| o.name == r.name).count() > 1 {
            format!(" {}", num(r.weight))
        } else {
            String::new()
        };
        // Structure Synth's `md N > S` is MDG's rule-local retirement, exactly.
        let retire = match &r.maxdepth {
            Some((n, other)) => {
                let to = match other {
                    Some(o) if defined.contains(o) => format!(" > {}", e.names.get(o)),
                    Some(o) => {
                        if !retire_prims.contains(o) {
                            retire_prims.push(o.clone());
                        }
                        format!(" > es_retire_{}", o.replace("::", "_"))
                    }
                    None => String::new(),
                };
                format!(" maxdepth {}{to}", (*n).max(1))
            }
            None => String::new(),
        };
        let _ = writeln!(body, "rule {m}{w}{retire} {{");
        for a in &r.body {
            e.action(a, &mut body);
        }
        body.push_str("}\n\n");
    }
    for o in &retire_prims {
        let _ = writeln!(body, "rule es_retire_{} {{", o.replace("::", "_"));
        let a = Action { loops: Vec::new(), target: o.clone(), line: 0 };
        e.action(&a, &mut body);
        body.push_str("}\n\n");
    }
    let renamed = names.renamed();
    rep.finish();
    let _ = writeln!(out, "// Imported by `mdgc import` from {file} (Structure Synth).");
    if !rep.notes.is_empty() {
        let _ = writeln!(out, "// {} constructs approximated or left out: see the import report.", rep.notes.len());
    }
    for (s, m) in renamed {
        let _ = writeln!(out, "// `{s}` is `{m}` here (MDG reserves the name).");
    }
    out.push_str("\n@import primitives\n");
    // Structure Synth's start colour is hue 0, saturation 1, brightness 1 (red).
    out.push_str("startshape start\n");
    if !directives.iter().any(|d| d.starts_with("maxdepth")) {
        directives.push("maxdepth 1000".into());
    }
    // Structure Synth grows breadth first (unless `set recursion depth`) and stops at
    // `set maxobjects`, 100,000 objects when not set.
    if !directives.iter().any(|d| d == "depth first") {
        directives.push("breadthfirst".into());
        if !directives.iter().any(|d| d.starts_with("maxobjects")) {
            directives.push("maxobjects 100000".into());
        }
    } else {
        directives.retain(|d| d != "depth first");
    }
    for d in &directives {
        let _ = writeln!(out, "{d}");
    }
    let _ = write!(out, "\nrule start {{\n  {start_m} {{sat 1}}\n}}\n\n");
    out.push_str(&body);
    while out.ends_with("\n\n") {
        out.pop();
    }
    if !out.ends_with('\n') {
        out.push('\n');
    }
    Imported { mdg: out, report: rep, needs_pixel: false, min_size_px: 0.0 }
}

/// `#define NAME TOKENS…` (to the end of its line), substituted in later tokens.
fn expand_defines(toks: Vec<Tok>, rep: &mut Report) -> Vec<Tok> {
    let mut defs: BTreeMap<String, Vec<Tok>> = BTreeMap::new();
    let mut out = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        match &toks[i].t {
            T::Id(w) if w == "#define" => {
                let line = toks[i].line;
                let name = match toks.get(i + 1).map(|t| &t.t) {
                    Some(T::Id(n)) => n.clone(),
                    _ => String::new(),
                };
                i += 2;
                let mut val = Vec::new();
                while i < toks.len() && toks[i].line == line {
                    val.push(toks[i].clone());
                    i += 1;
                }
                if name.contains('(') || val.iter().any(|t| t.t == T::P("(")) && name.is_empty() {
                    rep.drop(line, "#define", "a define with parameters: left out");
                }
                defs.insert(name, val);
            }
            T::Id(w) if w.starts_with('#') && !is_colour(w) => {
                let line = toks[i].line;
                rep.drop(line, w, "a preprocessor line: left out");
                while i < toks.len() && toks[i].line == line {
                    i += 1;
                }
            }
            T::Id(w) if defs.contains_key(w) => {
                let line = toks[i].line;
                for t in defs.get(w).into_iter().flatten() {
                    out.push(Tok { t: t.t.clone(), line, space: true });
                }
                i += 1;
            }
            _ => {
                out.push(toks[i].clone());
                i += 1;
            }
        }
    }
    out
}

fn is_colour(w: &str) -> bool {
    crate::colour::parse(w).is_ok()
}

struct Es<'a> {
    toks: &'a [Tok],
    i: usize,
    rep: &'a mut Report,
}

impl Es<'_> {
    fn line(&self) -> u32 {
        self.toks.get(self.i).map(|t| t.line).unwrap_or(0)
    }
    fn peek_id(&self) -> Option<String> {
        match self.toks.get(self.i).map(|t| &t.t) {
            Some(T::Id(w)) => Some(w.clone()),
            _ => None,
        }
    }
    fn word(&mut self) -> Option<String> {
        let w = self.peek_id()?;
        self.i += 1;
        Some(w)
    }
    fn eat(&mut self, p: &str) -> bool {
        if matches!(self.toks.get(self.i).map(|t| &t.t), Some(T::P(q)) if *q == p) {
            self.i += 1;
            true
        } else {
            false
        }
    }
    fn rest_of_line(&mut self, line: u32) -> Vec<Tok> {
        let mut v = Vec::new();
        while self.i < self.toks.len() && self.toks[self.i].line == line {
            v.push(self.toks[self.i].clone());
            self.i += 1;
        }
        v
    }

    /// A number: signs, and `*`/`/` between numbers (`1/3`).
    fn number(&mut self) -> Option<f64> {
        let mut v = self.signed()?;
        loop {
            if self.eat("/") {
                v /= self.signed()?;
            } else if self.eat("*") {
                // `N * {` is a loop, never a product.
                if matches!(self.toks.get(self.i).map(|t| &t.t), Some(T::P("{"))) {
                    self.i -= 1;
                    return Some(v);
                }
                v *= self.signed()?;
            } else {
                return Some(v);
            }
        }
    }
    fn signed(&mut self) -> Option<f64> {
        let neg = if self.eat("-") {
            true
        } else {
            self.eat("+");
            false
        };
        match self.toks.get(self.i).map(|t| &t.t) {
            Some(T::Num(v)) => {
                let v = *v;
                self.i += 1;
                Some(if neg { -v } else { v })
            }
            _ => None,
        }
    }

    fn set(&mut self, key: &str, vals: &[Tok], line: u32, out: &mut Vec<String>) {
        let first_num = vals.iter().find_map(|t| if let T::Num(v) = t.t { Some(v) } else { None });
        let first_word = vals.iter().find_map(|t| if let T::Id(w) = &t.t { Some(w.clone()) } else { None });
        match (key, first_num, first_word) {
            ("maxdepth", Some(n), _) => out.push(format!("maxdepth {}", n as u64)),
            // (`breadthfirst` is written with it; see `import`.)
            ("maxobjects", Some(n), _) => out.push(format!("maxobjects {}", n as u64)),
            ("recursion", _, Some(w)) if w == "depth" => {
                // Depth first, `maxobjects` has no MDG form: its line is a note.
                if let Some(i) = out.iter().position(|d| d.starts_with("maxobjects")) {
                    out.remove(i);
                }
                out.push("depth first".into());
            }
            ("recursion", _, _) => {}
            ("minsize", Some(n), _) => out.push(format!("minsize {}", num(n))),
            ("maxsize", _, _) => self.rep.drop(line, "set maxsize", "MDG has no largest-size limit"),
            ("seed", Some(n), _) => out.push(format!("randseed {}", n as u64)),
            ("background", _, Some(w)) => {
                let c = if w.starts_with('#') { w.clone() } else { format!("#{w}") };
                if is_colour(&c) {
                    out.push(format!("background {c}"));
                } else {
                    self.rep.drop(line, "set background", format!("`{w}` is not a colour MDG knows"));
                }
            }
            ("translation" | "rotation" | "pivot" | "scale" | "perspective-angle", _, _) => {
                self.rep.drop(line, &format!("set {key}"), "camera settings: MDG's picture frames the model itself")
            }
            _ => self.rep.drop(line, &format!("set {key}"), "no MDG counterpart: left out"),
        }
    }

    fn body(&mut self) -> Vec<Action> {
        let mut v = Vec::new();
        if !self.eat("{") {
            return v;
        }
        while self.i < self.toks.len() && !self.eat("}") {
            match self.action() {
                Some(a) => v.push(a),
                None => {
                    let l = self.line();
                    let t = super::cfparse::tok_text(self.toks.get(self.i).map(|t| &t.t));
                    self.rep.drop(l, &t, "not an action: skipped");
                    self.i += 1;
                }
            }
        }
        v
    }

    /// `[N *] { TRANSFORMS } … NAME`, or `NAME`.
    fn action(&mut self) -> Option<Action> {
        let line = self.line();
        let mut loops = Vec::new();
        loop {
            let save = self.i;
            if let Some(n) = self.number() {
                if self.eat("*") && matches!(self.toks.get(self.i).map(|t| &t.t), Some(T::P("{"))) {
                    loops.push((n.max(0.0) as u32, self.transforms()));
                    continue;
                }
                self.i = save;
                return None;
            }
            if matches!(self.toks.get(self.i).map(|t| &t.t), Some(T::P("{"))) {
                loops.push((1, self.transforms()));
                continue;
            }
            break;
        }
        let target = self.word()?;
        if matches!(self.toks.get(self.i).map(|t| &t.t), Some(T::P("["))) {
            // `triangle[…]`: skip the coordinates.
            while self.i < self.toks.len() && !self.eat("]") {
                self.i += 1;
            }
        }
        Some(Action { loops, target, line })
    }

    fn transforms(&mut self) -> Vec<Tf> {
        let mut v = Vec::new();
        self.eat("{");
        while self.i < self.toks.len() && !self.eat("}") {
            let line = self.line();
            let Some(name) = self.word() else {
                self.i += 1;
                continue;
            };
            let mut args = Vec::new();
            let mut word = None;
            if matches!(name.as_str(), "color" | "c" | "blend") {
                word = self.word();
                if word.is_none() {
                    word = self.number().map(|v| v.to_string());
                }
            }
            while let Some(a) = self.number() {
                args.push(a);
            }
            v.push(Tf { name, args, word, line });
        }
        v
    }
}

struct Emit<'a> {
    rep: &'a mut Report,
    names: &'a mut Names,
    defined: &'a [String],
}

impl Emit<'_> {
    /// A call of rule `name`.
    fn call(&mut self, name: &str) -> String {
        self.names.get(name)
    }

    fn action(&mut self, a: &Action, out: &mut String) {
        let mut s = String::from("  ");
        for (n, tfs) in &a.loops {
            let adj = self.transforms(tfs);
            if *n == 1 && a.loops.len() == 1 {
                // `{ … } R`: the list goes on the call.
                let call = self.target(a);
                if let Some(c) = call {
                    let _ = writeln!(out, "  {}", compose(&c, &adj));
                }
                return;
            }
            let _ = write!(s, "{n} * {adj} ");
        }
        if let Some(c) = self.target(a) {
            let _ = writeln!(out, "{s}{}", compose(&c, "{}"));
        }
    }

    /// The called item: `(name, adjustments that place the primitive)`.
    fn target(&mut self, a: &Action) -> Option<(String, String)> {
        let (base, class) = match a.target.split_once("::") {
            Some((b, c)) => (b.to_string(), Some(c.to_string())),
            None => (a.target.clone(), None),
        };
        if class.is_some() && PRIMS.contains(&base.as_str()) {
            self.rep.drop(a.line, &a.target, "a render class (`::`): the plain primitive is drawn");
        }
        if self.defined.contains(&a.target) {
            return Some((self.call(&a.target), String::new()));
        }
        let placed = match base.as_str() {
            "box" => ("cube", "x 0.5 y 0.5 z 0.5"),
            "sphere" => ("SPHERE", "x 0.5 y 0.5 z 0.5 s 0.5"),
            "grid" => {
                self.rep.approx(a.line, "grid", "a wireframe box: drawn as a solid box");
                ("cube", "x 0.5 y 0.5 z 0.5")
            }
            "line" => {
                self.rep.approx(a.line, "line", "a line along x: drawn as a thin box");
                ("cube", "x 0.5 s 1 0.02 0.02")
            }
            "point" | "dot" => {
                self.rep.approx(a.line, &base, "a point: drawn as a small sphere");
                ("SPHERE", "s 0.02")
            }
            "cylinder" => {
                self.rep.approx(
                    a.line,
                    "cylinder",
                    "Structure Synth's cylinder: std's, radius 0.5 along z from 0 to 1",
                );
                ("cylinder", "x 0.5 y 0.5 z 0.5 s 0.5 0.5 1")
            }
            "triangle" | "mesh" | "cmesh" | "template" => {
                self.rep.drop(a.line, &base, "no MDG counterpart: left out");
                return None;
            }
            _ => {
                self.rep.drop(a.line, &a.target, "a call of an undefined rule: left out");
                return None;
            }
        };
        Some((placed.0.to_string(), placed.1.to_string()))
    }

    fn transforms(&mut self, tfs: &[Tf]) -> String {
        let mut parts = Vec::new();
        for t in tfs {
            let a = &t.args;
            let n = a.len();
            let line = t.line;
            match (t.name.as_str(), n) {
                ("x" | "y" | "z" | "rx" | "ry" | "rz", 1) => parts.push(format!("{} {}", t.name, num(a[0]))),
                ("s", 1) => parts.push(format!("s {}", num(a[0]))),
                ("s", 3) => parts.push(format!("s {} {} {}", num(a[0]), num(a[1]), num(a[2]))),
                ("fx" | "fy" | "fz", 0) => parts.push(t.name.clone()),
                ("hue" | "h", 1) => parts.push(format!("hue {}", num(a[0]))),
                ("sat" | "b" | "brightness", 1) => {
                    let k = if t.name == "sat" { "sat" } else { "b" };
                    // Structure Synth multiplies; MDG's change moves a fraction of the way.
                    let f = a[0];
                    if f > 1.0 {
                        self.rep.approx(
                            line,
                            &t.name,
                            "a factor above 1: MDG moves the value that fraction of the way to 1",
                        );
                    }
                    parts.push(format!("{k} {}", num((f - 1.0).clamp(-1.0, 1.0))));
                }
                ("a" | "alpha", 1) => {
                    self.rep.approx(line, &t.name, "alpha is MDG's additive `A` (Structure Synth multiplies)");
                    parts.push(format!("A {}", num(a[0] - 1.0)));
                }
                ("color" | "c", _) => match t.word.as_deref() {
                    Some("random") => {
                        self.rep.drop(line, "color random", "MDG has no random colour pool: the colour is kept")
                    }
                    Some(w) => {
                        let c = if w.starts_with('#') { w.to_string() } else { format!("#{w}") };
                        if is_colour(&c) {
                            parts.push(c);
                        } else {
                            self.rep.drop(line, "color", format!("`{w}` is not a colour MDG knows"));
                        }
                    }
                    None => self.rep.drop(line, "color", "a colour without a value"),
                },
                ("blend", _) => self.rep.drop(line, "blend", "MDG has no colour blending: the colour is kept"),
                ("m", _) => self.rep.drop(line, "m", "a matrix: MDG has no matrix adjustment"),
                _ => self.rep.drop(line, &t.name, format!("a transformation with {n} values: no MDG form")),
            }
        }
        format!("{{{}}}", parts.join(" "))
    }
}

/// `NAME {PLACE ADJ}`: the action's adjustments, then the primitive's placing.
fn compose(c: &(String, String), adj: &str) -> String {
    let inner = adj.trim_start_matches('{').trim_end_matches('}');
    let both = [inner, c.1.as_str()].iter().filter(|s| !s.is_empty()).cloned().collect::<Vec<_>>().join(" ");
    format!("{} {{{both}}}", c.0)
}
