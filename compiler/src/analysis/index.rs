//! The occurrence index: every name, keyword and built-in word of a document with
//! what it refers to, built once per analysis and searched by byte offset.
//!
//! Two walks feed it. The main file's own tree (as written, both branches of every
//! `@ifdef`) gives the syntax-level occurrences the editor shows: adjustments,
//! drawables, directives, iterator headers, numbers with units, the keys of
//! extension sections with their paths. The expanded program
//! (every imported file, macro expansions resolved) gives the symbol occurrences —
//! definitions and references of rules, namespaces, functions, isosurfaces and
//! shaders — in every file. Macros are found by lexing, since their bodies are not
//! syntax. Names are resolved exactly as the checker resolves them.

use crate::ast::*;
use crate::check::Symbols;
use crate::driver::Analysis;
use crate::expand::Expanded;
use crate::lexer::{self, Comment, Tok, Token};
use crate::source::Sources;
use crate::span::{FileId, Span};

/// A named thing that can be defined and referred to.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Symbol {
    /// A rule, by full name (`ns.name`).
    Rule(String),
    Namespace(String),
    Function(String),
    Isosurface(String),
    Macro(String),
    Shader {
        vertex: bool,
        name: String,
    },
    /// A rule parameter, `let` binding or loop variable: its name and the span of its
    /// declaration (which makes it unique), and what it is (`parameter`, `local`,
    /// `loop variable`, with the parameter's type: `parameter int`).
    Local {
        name: String,
        decl: Span,
        what: String,
    },
}

impl Symbol {
    /// The full name.
    pub fn name(&self) -> &str {
        match self {
            Symbol::Rule(n)
            | Symbol::Namespace(n)
            | Symbol::Function(n)
            | Symbol::Isosurface(n)
            | Symbol::Macro(n)
            | Symbol::Shader { name: n, .. }
            | Symbol::Local { name: n, .. } => n,
        }
    }

    /// What kind of symbol this is, in words.
    pub fn kind_word(&self) -> &'static str {
        match self {
            Symbol::Rule(_) => "rule",
            Symbol::Namespace(_) => "namespace",
            Symbol::Function(_) => "function",
            Symbol::Isosurface(_) => "isosurface",
            Symbol::Macro(_) => "macro",
            Symbol::Shader { vertex: true, .. } => "vertex shader",
            Symbol::Shader { vertex: false, .. } => "fragment shader",
            Symbol::Local { what, .. } if what.starts_with("parameter") => "parameter",
            Symbol::Local { what, .. } if what.starts_with("loop") => "loop variable",
            Symbol::Local { .. } => "local",
        }
    }
}

/// An iterator header `COUNT[/DIVISOR] * {ADJ}`, kept for hover and inlay hints.
#[derive(Clone, Debug, PartialEq)]
pub struct IterInfo {
    pub count: Count,
    pub divisor: Option<Count>,
    pub adj: AdjList,
    /// `M * {T} \\ ITEM`: the runs chain (each continues from the previous one's end).
    pub chain: bool,
}

/// What an occurrence is.
#[derive(Clone, Debug, PartialEq)]
pub enum Occ {
    Def(Symbol),
    Ref(Symbol),
    /// A call of a rule that does not exist (E0301).
    UnknownRule(String),
    /// A word of an `@import` line and the file it brought in.
    Import(Option<FileId>),
    Drawable(String),
    Adjustment(String),
    Directive(String),
    SelectorMode(String),
    AngleMode(String),
    /// A preprocessor word, with its `@`.
    Preprocessor(String),
    IsoEntry(String),
    ProgramCommand(String),
    MathFunction(String),
    Variable(String),
    /// A name defined with `@define`, `@param` or tested by `@ifdef`.
    Define(String),
    /// An iterator header; the span covers count to adjustment list.
    Iterator(Box<IterInfo>),
    /// A number with a unit suffix.
    Number {
        value: f64,
        unit: char,
    },
    /// The key of an entry of a §11 extension section, with its path: the section's
    /// kind, the keys of the blocks around it, then the key itself
    /// (`["creature", "part", "slot"]`); see [`crate::ext::keys`].
    SectionKey(Vec<String>),
}

impl Occ {
    fn rank(&self) -> u8 {
        match self {
            Occ::Def(_) | Occ::Ref(_) => 0,
            _ => 1,
        }
    }
}

/// One occurrence: a span and what is there.
#[derive(Clone, Debug, PartialEq)]
pub struct Occurrence {
    pub span: Span,
    pub occ: Occ,
}

/// A rule call with an argument list in the main file (for parameter-name hints).
#[derive(Clone, Debug, PartialEq)]
pub struct CallSite {
    /// The callee's full name.
    pub rule: String,
    /// Each argument's span.
    pub args: Vec<Span>,
}

/// The index of one analysis.
pub struct Index {
    /// The main file's rule calls with argument lists.
    pub calls: Vec<CallSite>,
    /// Occurrences in the main file, sorted by start.
    pub main: Vec<Occurrence>,
    /// Definitions and references of symbols in every file.
    pub symbols: Vec<Occurrence>,
    /// The main file's tokens and comments, as lexed (macro bodies not folded).
    pub tokens: Vec<Token>,
    pub comments: Vec<Comment>,
}

impl Index {
    /// Builds the index of an analysis whose main file is `main`.
    pub fn build(a: &Analysis, main: FileId) -> Index {
        let sym = &a.checked.symbols;
        let mut all = Vec::new();
        // The expanded program: symbols in every file.
        {
            let mut w = Walker {
                sym,
                ex: &a.expanded,
                sources: &a.sources,
                out: &mut all,
                syntax: false,
                scope: Vec::new(),
                calls: Vec::new(),
            };
            for e in &a.expanded.items {
                w.item(&e.item, e.namespace.as_deref());
            }
        }
        // The main file as written: everything, inactive branches included.
        let calls = {
            let mut w = Walker {
                sym,
                ex: &a.expanded,
                sources: &a.sources,
                out: &mut all,
                syntax: true,
                scope: Vec::new(),
                calls: Vec::new(),
            };
            w.items(&a.expanded.main_ast.items, None);
            w.calls
        };
        for sh in &a.expanded.shaders {
            all.push(Occurrence {
                span: sh.name.span,
                occ: Occ::Def(Symbol::Shader { vertex: sh.vertex, name: sh.name.text.clone() }),
            });
        }
        let main_text = a.sources.files.get(main.0 as usize).map(|f| f.text.as_str()).unwrap_or("");
        let lexed = lexer::lex(main_text, main);
        let mut section_bodies = Vec::new();
        section_spans(&a.expanded.main_ast.items, &mut section_bodies);
        keywords(&lexed.tokens, main_text, &section_bodies, &mut all);
        macros(&lexed.tokens, main_text, &mut all);
        for &file in a.expanded.files.iter().filter(|f| **f != main) {
            let text = &a.sources.file(file).text;
            if text.contains("@macro") || text.contains("@expand") {
                let toks = lexer::lex(text, file).tokens;
                macros(&toks, text, &mut all);
            }
        }
        all.sort_by(|x, y| sort_key(x).cmp(&sort_key(y)));
        all.dedup();
        let symbols = all.iter().filter(|o| o.occ.rank() == 0).cloned().collect();
        let main = all.into_iter().filter(|o| o.span.file == main).collect();
        Index { calls, main, symbols, tokens: lexed.tokens, comments: lexed.comments }
    }

    /// The innermost occurrence at `offset` in the main file (a cursor just after a
    /// word still touches it).
    pub fn at(&self, offset: u32) -> Option<&Occurrence> {
        self.main
            .iter()
            .filter(|o| o.span.contains(offset))
            .min_by_key(|o| (o.span.end - o.span.start, o.occ.rank(), o.span.start != offset))
    }

    /// The symbol at `offset` (a definition or a reference) and its span.
    pub fn symbol_at(&self, offset: u32) -> Option<(&Symbol, Span)> {
        self.main
            .iter()
            .filter(|o| o.span.contains(offset))
            .filter_map(|o| match &o.occ {
                Occ::Def(s) | Occ::Ref(s) => Some((s, o.span)),
                _ => None,
            })
            .min_by_key(|(_, s)| (s.end - s.start, s.start != offset))
    }

    /// Every definition of `sym`, in file and source order.
    pub fn definitions<'a>(&'a self, sym: &'a Symbol) -> impl Iterator<Item = Span> + 'a {
        self.symbols.iter().filter(move |o| matches!(&o.occ, Occ::Def(s) if s == sym)).map(|o| o.span)
    }

    /// Every reference to `sym`.
    pub fn references<'a>(&'a self, sym: &'a Symbol) -> impl Iterator<Item = Span> + 'a {
        self.symbols.iter().filter(move |o| matches!(&o.occ, Occ::Ref(s) if s == sym)).map(|o| o.span)
    }
}

fn sort_key(o: &Occurrence) -> (Span, u8, Option<(bool, &Symbol)>) {
    let sym = match &o.occ {
        Occ::Def(s) => Some((false, s)),
        Occ::Ref(s) => Some((true, s)),
        _ => None,
    };
    (o.span, o.occ.rank(), sym)
}

/// `ns.name`, or `name` at global scope.
pub fn qualify(ns: Option<&str>, name: &str) -> String {
    match ns {
        Some(ns) => format!("{ns}.{name}"),
        None => name.to_string(),
    }
}

/// The bodies (`{ … }`) of the sections among `items`, in namespaces and `@ifdef`
/// branches too.
fn section_spans(items: &[Item], out: &mut Vec<Span>) {
    for item in items {
        match &item.kind {
            ItemKind::Section(sec) => out.push(sec.body_span),
            ItemKind::Namespace { items, .. } => section_spans(items, out),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                section_spans(then, out);
                if let Some(o) = otherwise {
                    section_spans(o, out);
                }
            }
            _ => {}
        }
    }
}

/// Keywords and preprocessor words of the main file, from its tokens. Inside a
/// section's body (`sections`) keywords are keys or values, not keywords.
fn keywords(tokens: &[Token], text: &str, sections: &[Span], out: &mut Vec<Occurrence>) {
    for t in tokens {
        if sections.iter().any(|s| s.file == t.span.file && s.start < t.span.start && t.span.end <= s.end) {
            continue;
        }
        let s = text.get(t.span.range()).unwrap_or("");
        let word_span = |w: &str| Span::new(t.span.file, t.span.start, t.span.start + w.len() as u32);
        match t.kind {
            Tok::KwRule
            | Tok::KwStartshape
            | Tok::KwSelector
            | Tok::KwLinerule
            | Tok::KwCamerarule
            | Tok::KwNamespace
            | Tok::KwFunction
            | Tok::KwIsosurface
            | Tok::KwProgram
            | Tok::KwUniform
            | Tok::KwAngle
            | Tok::KwColor
            | Tok::KwWeight
            | Tok::KwSection
            | Tok::KwIf
            | Tok::KwElse
            | Tok::KwLet
            | Tok::KwLoop => out.push(Occurrence { span: t.span, occ: Occ::Directive(s.to_string()) }),
            Tok::AtImport
            | Tok::AtDefine
            | Tok::AtParam
            | Tok::AtPresets
            | Tok::AtIfdef
            | Tok::AtElse
            | Tok::AtEndif
            | Tok::AtMacro
            | Tok::AtEndmacro
            | Tok::AtExpand
            | Tok::AtEndshader
            | Tok::Shader => {
                let word = s.split_whitespace().next().unwrap_or("");
                out.push(Occurrence { span: word_span(word), occ: Occ::Preprocessor(word.to_string()) });
                if t.kind == Tok::Shader && s.ends_with("@endshader") {
                    let end = t.span.end;
                    out.push(Occurrence {
                        span: Span::new(t.span.file, end - "@endshader".len() as u32, end),
                        occ: Occ::Preprocessor("@endshader".to_string()),
                    });
                }
                if t.kind == Tok::AtParam {
                    // `@param TYPE NAME …`: the name is the third word.
                    if let Some((off, w)) = words(s).nth(2) {
                        let start = t.span.start + off as u32;
                        out.push(Occurrence {
                            span: Span::new(t.span.file, start, start + w.len() as u32),
                            occ: Occ::Define(w.to_string()),
                        });
                    }
                }
            }
            _ => {}
        }
    }
}

/// The words of a line with their byte offsets.
pub fn words(s: &str) -> impl Iterator<Item = (usize, &str)> {
    s.split_whitespace().map(move |w| (w.as_ptr() as usize - s.as_ptr() as usize, w))
}

/// Macro definitions (`@macro NAME`) and uses (`@expand NAME`) of one file.
fn macros(tokens: &[Token], text: &str, out: &mut Vec<Occurrence>) {
    for pair in tokens.windows(2) {
        let (at, name) = (pair[0], pair[1]);
        let def = match at.kind {
            Tok::AtMacro => true,
            Tok::AtExpand => false,
            _ => continue,
        };
        let span = match name.kind {
            Tok::Ident => name.span,
            Tok::CallOpen => Span::new(name.span.file, name.span.start, name.span.end.saturating_sub(1)),
            _ => continue,
        };
        let text = text.get(span.range()).unwrap_or("").to_string();
        let sym = Symbol::Macro(text);
        out.push(Occurrence { span, occ: if def { Occ::Def(sym) } else { Occ::Ref(sym) } });
    }
}

struct Walker<'a, 'o> {
    sym: &'a Symbols,
    ex: &'a Expanded,
    sources: &'a Sources,
    out: &'o mut Vec<Occurrence>,
    /// Whether to record syntax-level occurrences too (the main file's own tree).
    syntax: bool,
    /// The parameters and locals in scope in the rule body being walked.
    scope: Vec<Symbol>,
    /// Calls with arguments (syntax walk only).
    calls: Vec<CallSite>,
}

impl Walker<'_, '_> {
    fn push(&mut self, span: Span, occ: Occ) {
        self.out.push(Occurrence { span, occ });
    }

    fn syn(&mut self, span: Span, occ: Occ) {
        if self.syntax {
            self.out.push(Occurrence { span, occ });
        }
    }

    fn items(&mut self, items: &[Item], ns: Option<&str>) {
        for item in items {
            self.item(item, ns);
        }
    }

    fn item(&mut self, item: &Item, ns: Option<&str>) {
        match &item.kind {
            ItemKind::Startshape(n) | ItemKind::Linerule(n) | ItemKind::Camerarule(n) => self.rule_ref(n, ns),
            ItemKind::Rule(r) => {
                if !r.name.text.is_empty() {
                    self.push(r.name.span, Occ::Def(Symbol::Rule(qualify(ns, &r.name.text))));
                }
                if let Some(i) = &r.iter {
                    self.rule_ref(i, ns);
                }
                for t in &r.transforms {
                    self.rule_ref(t, ns);
                }
                if let Some(w) = &r.weight {
                    self.number(&w.number);
                }
                self.scope.clear();
                for p in r.params.iter().flat_map(|p| &p.params) {
                    self.syn(p.ty.span, Occ::Directive(p.ty.text.clone()));
                    if let Some(d) = &p.default {
                        self.expr(d);
                    }
                    self.bind(&p.name, format!("parameter {}", p.ty.text));
                }
                if let Some(e) = &r.weight_expr {
                    self.expr(e);
                }
                self.body(&r.body, ns);
                self.scope.clear();
            }
            ItemKind::Selector { rules, mode } => {
                for r in rules {
                    self.rule_ref(r, ns);
                }
                match mode {
                    SelectorMode::Word(w) => self.syn(w.span, Occ::SelectorMode(w.text.clone())),
                    SelectorMode::FunctionRef(f) => self.function_ref(f, ns),
                    SelectorMode::FunctionBody(e) => self.expr(e),
                }
            }
            ItemKind::Namespace { name, items } => {
                let full = qualify(ns, &name.text);
                self.push(name.span, Occ::Def(Symbol::Namespace(full.clone())));
                self.items(items, Some(&full));
            }
            ItemKind::Directive { name, args } => {
                self.syn(name.span, Occ::Directive(name.text.clone()));
                match (name.text.as_str(), args.as_slice()) {
                    ("angle", [DirArg::Word(w)]) => self.syn(w.span, Occ::AngleMode(w.text.clone())),
                    ("uniform", [_, DirArg::Word(rule), DirArg::Word(_)]) => self.rule_ref(rule, ns),
                    _ => {}
                }
                for a in args {
                    match a {
                        DirArg::Num(n) | DirArg::Neg(n) => self.number(n),
                        DirArg::Expr(e) => self.expr(e),
                        DirArg::Word(_) => {}
                    }
                }
            }
            ItemKind::Function { name, body, .. } => {
                self.push(name.span, Occ::Def(Symbol::Function(qualify(ns, &name.text))));
                self.expr(body);
            }
            ItemKind::Isosurface { name, entries } => {
                self.push(name.span, Occ::Def(Symbol::Isosurface(qualify(ns, &name.text))));
                for e in entries {
                    match e {
                        IsoEntry::Axis { axis, args, .. } => {
                            self.syn(axis.span, Occ::IsoEntry(axis.text.clone()));
                            for a in args {
                                if let DirArg::Expr(e) = a {
                                    self.expr(e);
                                }
                            }
                        }
                        // The checker resolves isosurface functions at global scope.
                        IsoEntry::FunctionRef(f) => self.function_ref(f, None),
                        IsoEntry::FunctionBody(e) => self.expr(e),
                    }
                }
            }
            ItemKind::Section(sec) => {
                let refs = crate::ext::rule_refs(sec);
                for n in &refs {
                    self.rule_ref(n, ns);
                }
                if self.syntax {
                    let rule_spans: Vec<Span> = refs.iter().map(|n| n.span).collect();
                    let mut path = vec![sec.kind.text.clone()];
                    self.entries(&sec.entries, &mut path, &|w| rule_spans.contains(&w));
                }
            }
            ItemKind::Program { words } => {
                let mut i = 0;
                while i < words.len() {
                    let w = &words[i];
                    match w.text.as_str() {
                        "vertexshader" | "fragmentshader" => {
                            self.syn(w.span, Occ::ProgramCommand(w.text.clone()));
                            if let Some(s) = words.get(i + 1) {
                                let vertex = w.text == "vertexshader";
                                self.push(s.span, Occ::Ref(Symbol::Shader { vertex, name: s.text.clone() }));
                            }
                            i += 2;
                        }
                        "target" | "render" => {
                            self.syn(w.span, Occ::ProgramCommand(w.text.clone()));
                            i += 1;
                        }
                        _ => i += 1,
                    }
                }
            }
            ItemKind::Pre(p) => self.pre(p, &mut |w: &mut Self, items: &[Item]| w.items(items, ns)),
            ItemKind::Error => {}
        }
    }

    /// The keys of a section's entries (with their paths) and what their values hold:
    /// numbers with units, expressions, `@define`/`@param` names. `is_rule` says
    /// which words the section's module reads as rule names (already indexed).
    fn entries(&mut self, entries: &[Entry], path: &mut Vec<String>, is_rule: &dyn Fn(Span) -> bool) {
        for e in entries {
            path.push(e.key.text.clone());
            self.syn(e.key.span, Occ::SectionKey(path.clone()));
            for v in &e.values {
                match v {
                    Value::Num(n) | Value::Neg(n) => self.number(n),
                    Value::Expr(x) => self.expr(x),
                    Value::Word(w) if !is_rule(w.span) && self.is_constant(&w.text) => {
                        self.syn(w.span, Occ::Define(w.text.clone()))
                    }
                    Value::Word(_) | Value::Str(..) => {}
                }
            }
            if let Some((inner, _)) = &e.block {
                self.entries(inner, path, is_rule);
            }
            path.pop();
        }
    }

    /// Whether `name` is a `@define` or `@param` of the program.
    fn is_constant(&self, name: &str) -> bool {
        self.ex.defines.contains_key(name) || self.ex.params.iter().any(|p| p.name.text == name)
    }

    fn pre<T>(&mut self, p: &Pre<T>, nested: &mut dyn FnMut(&mut Self, &[T])) {
        match p {
            Pre::Import(names) => {
                for n in names {
                    let display = if n.text.contains('/') || n.text.ends_with(".mdg") {
                        n.text.clone()
                    } else {
                        format!("std/{}.mdg", n.text)
                    };
                    let file = self
                        .sources
                        .files
                        .iter()
                        .enumerate()
                        .skip(1)
                        .find(|(_, f)| f.name == display)
                        .map(|(i, _)| FileId(i as u32));
                    self.syn(n.span, Occ::Import(file));
                }
            }
            Pre::Define { name, .. } => self.syn(name.span, Occ::Define(name.text.clone())),
            Pre::IfDef { name, then, otherwise } => {
                self.syn(name.span, Occ::Define(name.text.clone()));
                nested(self, then);
                if let Some(o) = otherwise {
                    nested(self, o);
                }
            }
            Pre::Shader { vertex, name, .. } => {
                self.push(name.span, Occ::Def(Symbol::Shader { vertex: *vertex, name: name.text.clone() }));
            }
            // Macros are indexed from tokens; parameters and presets carry no symbols.
            Pre::Macro(_) | Pre::Expand { .. } | Pre::Param(_) | Pre::Presets(_) | Pre::Bad => {}
        }
    }

    /// Declares a local (a definition occurrence) in the current scope.
    fn bind(&mut self, name: &Name, what: String) {
        let sym = Symbol::Local { name: name.text.clone(), decl: name.span, what };
        self.push(name.span, Occ::Def(sym.clone()));
        self.scope.push(sym);
    }

    fn body(&mut self, items: &[BodyItem], ns: Option<&str>) {
        let at = self.scope.len();
        for item in items {
            self.body_item(item, ns);
        }
        self.scope.truncate(at);
    }

    fn body_item(&mut self, item: &BodyItem, ns: Option<&str>) {
        {
            match &item.kind {
                BodyKind::Call { name, args, profile, adj } => {
                    self.call_name(name, ns);
                    if let (true, Some(a), Some(rule)) = (self.syntax, args, self.sym.resolve(&name.text, ns)) {
                        self.calls.push(CallSite { rule, args: a.args.iter().map(|e| e.span).collect() });
                    }
                    if let Some(p) = profile {
                        self.rule_ref(p, ns);
                    }
                    for a in args.iter().flat_map(|a| &a.args) {
                        self.expr(a);
                    }
                    self.adj_list(adj);
                }
                BodyKind::If { cond, then, otherwise, .. } => {
                    self.expr(cond);
                    self.body(then, ns);
                    if let Some(o) = otherwise {
                        self.body(std::slice::from_ref(o), ns);
                    }
                }
                BodyKind::Let { name, value } => {
                    self.expr(value);
                    self.bind(name, "local".to_string());
                }
                BodyKind::Loop { var, range, adj, item: inner } => {
                    let LoopRange { start, end, step } = &**range;
                    self.expr(start);
                    self.expr(end);
                    if let Some(s) = step {
                        self.expr(s);
                    }
                    self.adj_list(adj);
                    let at = self.scope.len();
                    self.bind(var, "loop variable".to_string());
                    self.body(std::slice::from_ref(inner), ns);
                    self.scope.truncate(at);
                }
                BodyKind::Iterate { count, divisor, adj, chain, item: inner } => {
                    let header = count.span().to(adj.span);
                    self.syn(
                        header,
                        Occ::Iterator(Box::new(IterInfo {
                            count: count.clone(),
                            divisor: divisor.clone(),
                            adj: adj.clone(),
                            chain: *chain,
                        })),
                    );
                    self.count(count);
                    if let Some(d) = divisor {
                        self.count(d);
                    }
                    self.adj_list(adj);
                    self.body(std::slice::from_ref(inner), ns);
                }
                BodyKind::Block(items) => self.body(items, ns),
                // As written (the expanded program has its `let` and `if` chain, whose
                // added names are empty spans).
                BodyKind::Switch(s) => {
                    self.syn(s.keyword, Occ::Directive("switch".to_string()));
                    self.expr(&s.value);
                    for arm in &s.arms {
                        let case = Span::new(arm.span.file, arm.span.start, arm.span.start + 4);
                        self.syn(case, Occ::Directive("case".to_string()));
                        for e in arm.labels.iter().flat_map(CaseLabel::exprs) {
                            self.expr(e);
                        }
                        self.body(&arm.body, ns);
                    }
                    if let Some((items, _)) = &s.otherwise {
                        self.body(items, ns);
                    }
                }
                BodyKind::Pre(p) => self.pre(p, &mut |w: &mut Self, items: &[BodyItem]| w.body(items, ns)),
                BodyKind::Error => {}
            }
        }
    }

    /// A name in call position: a drawable, an isosurface or a rule.
    fn call_name(&mut self, name: &Name, ns: Option<&str>) {
        if self.sym.is_drawable(&name.text) {
            if self.sym.isosurfaces.contains_key(&name.text) {
                self.push(name.span, Occ::Ref(Symbol::Isosurface(name.text.clone())));
                return;
            }
            let (prefix, last) = match name.text.rsplit_once('.') {
                Some((p, l)) => (Some(p), l),
                None => (None, name.text.as_str()),
            };
            let last_span = Span::new(name.span.file, name.span.end - last.len() as u32, name.span.end);
            self.syn(last_span, Occ::Drawable(last.to_string()));
            if let Some(prefix) = prefix {
                let inner = ns.map(|n| format!("{n}.{prefix}")).filter(|q| self.sym.namespaces.contains_key(q));
                let full = inner.or_else(|| self.sym.namespaces.contains_key(prefix).then(|| prefix.to_string()));
                if let Some(full) = full {
                    self.namespace_prefix(name, &full);
                }
            }
            return;
        }
        self.rule_ref(name, ns);
    }

    fn rule_ref(&mut self, name: &Name, ns: Option<&str>) {
        match self.sym.resolve(&name.text, ns) {
            Some(full) => {
                if let Some((ns_full, _)) = full.rsplit_once('.') {
                    let ns_full = ns_full.to_string();
                    self.namespace_prefix(name, &ns_full);
                }
                self.push(name.span, Occ::Ref(Symbol::Rule(full)));
            }
            None => self.syn(name.span, Occ::UnknownRule(name.text.clone())),
        }
    }

    /// References to the namespaces named by the prefix segments of a dotted name,
    /// given the full name of the namespace the whole prefix resolved to.
    fn namespace_prefix(&mut self, name: &Name, ns_full: &str) {
        let written: Vec<&str> = name.text.split('.').collect();
        let n_written = written.len() - 1;
        let resolved: Vec<&str> = ns_full.split('.').collect();
        if n_written == 0 || resolved.len() < n_written {
            return;
        }
        let skip = resolved.len() - n_written;
        let mut offset = name.span.start;
        for (j, seg) in written.iter().take(n_written).enumerate() {
            let full = resolved[..skip + j + 1].join(".");
            let span = Span::new(name.span.file, offset, offset + seg.len() as u32);
            self.push(span, Occ::Ref(Symbol::Namespace(full)));
            offset += seg.len() as u32 + 1;
        }
    }

    fn function_ref(&mut self, f: &Name, ns: Option<&str>) {
        if let Some(full) = self.sym.resolve_function(&f.text, ns) {
            self.push(f.span, Occ::Ref(Symbol::Function(full)));
        }
    }

    fn adj_list(&mut self, adj: &AdjList) {
        for a in &adj.adjs {
            if !a.name.text.is_empty() {
                self.syn(a.name.span, Occ::Adjustment(a.name.text.clone()));
            }
            for arg in &a.args {
                match arg {
                    Arg::Num(n) | Arg::Neg(n) => self.number(n),
                    Arg::Expr(e) => self.expr(e),
                }
            }
        }
    }

    fn count(&mut self, c: &Count) {
        match c {
            Count::Num(n) | Count::Neg(n) => self.number(n),
            Count::Expr(e) => self.expr(e),
        }
    }

    fn number(&mut self, n: &Number) {
        if let Some(unit) = n.unit {
            self.syn(n.span, Occ::Number { value: n.value, unit });
        }
    }

    /// An expression: its locals in every walk, its other names in the syntax walk.
    fn expr(&mut self, e: &Expr) {
        match &e.kind {
            ExprKind::Num(n) => self.number(n),
            ExprKind::Var(v) if self.scope.iter().any(|s| s.name() == v.text) => {
                if let Some(sym) = self.scope.iter().rev().find(|s| s.name() == v.text).cloned() {
                    self.push(v.span, Occ::Ref(sym));
                }
            }
            ExprKind::Var(v) => {
                let occ = if crate::check::FUNCTION_VARS.contains(&v.text.as_str()) {
                    Occ::Variable(v.text.clone())
                } else {
                    Occ::Define(v.text.clone())
                };
                self.syn(v.span, occ);
            }
            ExprKind::Neg(x) | ExprKind::Paren(x) | ExprKind::Not(x) => self.expr(x),
            ExprKind::Binary(_, a, b) => {
                self.expr(a);
                self.expr(b);
            }
            ExprKind::Call(f, args) => {
                self.syn(f.span, Occ::MathFunction(f.text.clone()));
                for a in args {
                    self.expr(a);
                }
            }
            ExprKind::Let(bindings, body) => {
                let at = self.scope.len();
                for (n, v) in bindings {
                    self.expr(v);
                    self.bind(n, "let(…) binding".to_string());
                }
                self.expr(body);
                self.scope.truncate(at);
            }
            ExprKind::Tuple(xs) => {
                for x in xs {
                    self.expr(x);
                }
            }
            ExprKind::Index(v, i) => {
                self.expr(v);
                self.expr(i);
            }
            ExprKind::Error => {}
        }
    }
}
