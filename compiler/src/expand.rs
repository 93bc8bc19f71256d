//! Resolves the preprocessor: `@import`, `@ifdef`, `@macro`/`@expand`, `@define`,
//! `@param`, `@presets` and shader blocks, producing a flat list of items.
//!
//! Imports are contained: a path may not leave the project root (the main file's
//! directory) or the std directory, symlinks resolved. Macro expansions are parsed in
//! the context where `@expand` stands; diagnostics inside them are labelled with the
//! expansion site.

use crate::ast::*;
use crate::diag::{did_you_mean, Diagnostic};
use crate::lexer::{Tok, Token};
use crate::parse;
use crate::source::{FileLoader, Sources};
use crate::span::{FileId, Span};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Options that change what the preprocessor produces.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Names defined as if by `@define` (e.g. chosen presets).
    pub defines: Vec<String>,
    /// `--param NAME=VALUE` overrides.
    pub params: Vec<(String, String)>,
    /// Where `@import NAME` finds `NAME.mdg`.
    pub std_dir: Option<PathBuf>,
}

/// How deep macro expansions may nest before we call it recursion.
pub const MAX_EXPANSION_DEPTH: usize = 32;
/// How many macro expansions one compilation may perform.
pub const MAX_EXPANSIONS: usize = 10_000;
/// How many tokens all macro expansions of one compilation may produce together (a
/// macro whose argument doubles at each level would otherwise make 2^32).
pub const MAX_EXPANDED_TOKENS: usize = 1_000_000;
/// Most files in one chain of imports (the main file importing a file importing a
/// file …). Imports are walked on the native stack: 1,000 chained files overflowed
/// the language server's 2 MiB analysis threads, 5,000 the compiler's main thread.
pub const MAX_IMPORT_DEPTH: usize = 64;

/// A parameter declared with `@param`.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub name: Name,
    /// `int`, `float` or `bool`.
    pub ty: String,
    pub default: f64,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// The value in force (the default, or a `--param` override).
    pub value: f64,
}

/// A shader block.
#[derive(Clone, Debug, PartialEq)]
pub struct Shader {
    pub vertex: bool,
    pub name: Name,
    pub code: String,
    pub code_span: Span,
}

/// A top-level item after expansion, with its namespace.
#[derive(Clone, Debug, PartialEq)]
pub struct ExpItem {
    pub item: Item,
    /// The enclosing namespace (`None` at global scope).
    pub namespace: Option<String>,
}

/// One macro expansion, for labelling diagnostics inside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Expansion {
    pub macro_name: String,
    pub call_span: Span,
    pub body_span: Span,
}

/// The preprocessed program.
#[derive(Default)]
pub struct Expanded {
    pub items: Vec<ExpItem>,
    pub shaders: Vec<Shader>,
    pub params: Vec<Param>,
    /// `@define`d names and their optional values.
    pub defines: BTreeMap<String, Option<f64>>,
    pub presets: Vec<Name>,
    pub expansions: Vec<Expansion>,
    /// Every file that took part (the main file first).
    pub files: Vec<FileId>,
    /// The parsed main file (for the formatter and the language server).
    pub main_ast: File,
    /// The diagnostics of files and expansions are kept up to
    /// [`MAX_ERRORS`](crate::diag::MAX_ERRORS) in all; the rest are counted in `suppressed`.
    pub diagnostics: Vec<Diagnostic>,
    pub suppressed: crate::diag::Suppressed,
    /// What the next parse of the main file can reuse of this one's, and how much of
    /// this one was reused ([`expand_file_reusing`]).
    pub main_memo: parse::Memo,
    pub reused: parse::Reused,
}

impl Expanded {
    /// A function declared with parameters (`function NAME(a, b) { EXPR }`) that a
    /// call `NAME(…)` names: its index among the items, parameters and body.
    pub fn user_function(
        &self,
        name: &str,
    ) -> Option<(usize, &crate::ast::Name, &[crate::ast::Name], &crate::ast::Expr)> {
        self.items.iter().enumerate().find_map(|(i, ExpItem { item, namespace })| match &item.kind {
            crate::ast::ItemKind::Function { name: n, params, body, .. } if !params.is_empty() => {
                let full = match namespace {
                    Some(ns) => format!("{ns}.{}", n.text),
                    None => n.text.clone(),
                };
                (full == name || n.text == name).then_some((i, n, params.as_slice(), body))
            }
            _ => None,
        })
    }

    /// The value of a compile-time constant: a `@param`, a valued `@define`, `true` (1)
    /// or `false` (0).
    pub fn constant(&self, name: &str) -> Option<f64> {
        if let Some(p) = self.params.iter().find(|p| p.name.text == name) {
            return Some(p.value);
        }
        match self.defines.get(name) {
            Some(v) => *v,
            None => match name {
                "true" => Some(1.0),
                "false" => Some(0.0),
                _ => None,
            },
        }
    }
}

struct Expander<'a> {
    sources: &'a mut Sources,
    loader: &'a dyn FileLoader,
    opts: &'a Options,
    root: Option<PathBuf>,
    std_root: Option<PathBuf>,
    out: Expanded,
    macros: HashMap<String, MacroDef>,
    imported: HashSet<PathBuf>,
    import_stack: Vec<PathBuf>,
    depth: usize,
    /// Levels of the tree around the item being expanded (namespaces, rule bodies,
    /// blocks, iterators): a macro expansion here may nest only what
    /// [`parse::MAX_NESTING`] leaves.
    nest: usize,
    n_expansions: usize,
    /// Tokens produced by expansions so far (see [`MAX_EXPANDED_TOKENS`]).
    n_tokens: usize,
    /// Set after the first E0208: a recursive macro can branch, so once one is found no
    /// further expansion happens (otherwise the cost is exponential in the depth limit).
    expansion_stopped: bool,
    /// Diagnostics kept from parsing files and expansions (see [`Expander::absorb`]).
    parse_diags: usize,
}

/// Loads `path` as the main file and expands it.
pub fn expand_path(sources: &mut Sources, loader: &dyn FileLoader, path: &Path, opts: &Options) -> Expanded {
    let name = path.display().to_string();
    match loader.read(path) {
        Ok(text) => {
            let id = sources.add(path, name, text);
            expand_file(sources, loader, id, opts)
        }
        Err(e) => {
            let id = sources.add(path, name.clone(), "");
            let mut out = Expanded::default();
            out.diagnostics.push(Diagnostic::error("E0201", Span::new(id, 0, 0), format!("cannot read `{name}`: {e}")));
            out
        }
    }
}

/// Expands a file already in `sources`.
pub fn expand_file(sources: &mut Sources, loader: &dyn FileLoader, main: FileId, opts: &Options) -> Expanded {
    expand_file_reusing(sources, loader, main, opts, None)
}

/// [`expand_file`] after an edit: the main file's parse reuses the top-level items of
/// `prev` (its previous parse) that the edit left alone ([`parse::parse_file_reusing`]).
/// The result is [`expand_file`]'s.
pub fn expand_file_reusing(
    sources: &mut Sources,
    loader: &dyn FileLoader,
    main: FileId,
    opts: &Options,
    prev: Option<parse::Previous>,
) -> Expanded {
    let main_path = sources.file(main).path.clone();
    let root = main_path
        .parent()
        .map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p })
        .and_then(|p| loader.canonicalize(p).ok());
    let std_root = opts.std_dir.as_ref().and_then(|d| loader.canonicalize(d).ok());
    let mut ex = Expander {
        sources,
        loader,
        opts,
        root,
        std_root,
        out: Expanded::default(),
        macros: HashMap::new(),
        imported: HashSet::new(),
        import_stack: Vec::new(),
        depth: 0,
        nest: 0,
        n_expansions: 0,
        n_tokens: 0,
        expansion_stopped: false,
        parse_diags: 0,
    };
    for d in &opts.defines {
        ex.out.defines.insert(d.clone(), None);
    }
    if let Ok(c) = loader.canonicalize(&main_path) {
        ex.imported.insert(c.clone());
        ex.import_stack.push(c);
    }
    let (parsed, memo, reused) = parse::parse_file_reusing(ex.sources, main, prev);
    ex.out.main_memo = memo;
    ex.out.reused = reused;
    ex.absorb(parsed.diagnostics, parsed.suppressed);
    ex.out.files.push(main);
    // Parameters and defines are collected first so `@ifdef` can see them anywhere.
    ex.collect_constants(&parsed.file.items);
    ex.top_items(parsed.file.items.clone(), None);
    ex.flat_primitives(main);
    ex.out.main_ast = parsed.file;
    ex.label_expansions();
    ex.out
}

/// Whether a rule body holds a preprocessor construct (`@expand`, `@ifdef`, …) or a
/// `switch` (which expansion replaces by what it means) at any depth: only then does
/// its expansion differ from it.
fn has_pre(body: &[BodyItem]) -> bool {
    let mut found = false;
    walk_body(body, &mut |b| found |= matches!(b.kind, BodyKind::Pre(_) | BodyKind::Switch(_)));
    found
}

/// Context Free's flat primitives, built in: std `flat` defines them, imported
/// without an `@import` when a program calls one it does not define.
pub const FLAT_PRIMITIVES: &[&str] = &["CIRCLE", "SQUARE", "TRIANGLE"];

impl<'a> Expander<'a> {
    /// Imports std `flat` when a rule calls `CIRCLE`, `SQUARE` or `TRIANGLE` and no
    /// file defines it.
    fn flat_primitives(&mut self, main: FileId) {
        let mut called = false;
        let mut defined = false;
        for it in &self.out.items {
            if let ItemKind::Rule(r) = &it.item.kind {
                defined |= it.namespace.is_none() && FLAT_PRIMITIVES.contains(&r.name.text.as_str());
                walk_body(&r.body, &mut |b| {
                    if let BodyKind::Call { name, .. } = &b.kind {
                        called |= FLAT_PRIMITIVES.contains(&name.text.as_str());
                    }
                });
            }
        }
        if called && !defined {
            self.import(&Name { text: "flat".to_string(), span: Span::new(main, 0, 0) });
        }
    }

    /// Collects `@param`s and top-level macro definitions before expansion, so both
    /// may be used above the line that declares them.
    fn collect_constants(&mut self, items: &[Item]) {
        for item in items {
            match &item.kind {
                ItemKind::Pre(Pre::Param(words)) => self.param(words, item.span),
                ItemKind::Pre(Pre::Macro(m)) => self.define_macro(m.clone()),
                _ => {}
            }
        }
    }

    fn param(&mut self, words: &[Name], span: Span) {
        let bad = |msg: &str| Diagnostic::error("E0209", span, msg.to_string());
        let (ty, name, rest) = match words {
            [ty, name, rest @ ..] => (ty, name, rest),
            _ => {
                self.out.diagnostics.push(bad("expected `@param int|float|bool NAME DEFAULT [MIN MAX]`"));
                return;
            }
        };
        if self.out.params.iter().any(|p| p.name.text == name.text) {
            return;
        }
        let num = |w: &Name| -> Option<f64> {
            match w.text.as_str() {
                "true" => Some(1.0),
                "false" => Some(0.0),
                t => t.parse().ok(),
            }
        };
        let parsed: Option<Vec<f64>> = rest.iter().map(num).collect();
        // Rust reads `nan`, `inf` and `1e400` as numbers; a parameter is a finite one.
        if let Some(w) = rest.iter().find(|w| num(w).is_some_and(|v| !v.is_finite())) {
            self.out.diagnostics.push(
                Diagnostic::error("E0209", w.span, format!("`@param` value `{}` is not a finite number", w.text))
                    .with_label("not a finite number"),
            );
            return;
        }
        let Some(values) = parsed else {
            self.out.diagnostics.push(bad("`@param` values must be numbers (or true/false for bool)"));
            return;
        };
        let ok_count = match ty.text.as_str() {
            "int" | "float" => values.len() == 1 || values.len() == 3,
            "bool" => values.len() == 1,
            _ => {
                let mut d = Diagnostic::error("E0209", ty.span, format!("unknown parameter type `{}`", ty.text))
                    .with_label("expected `int`, `float` or `bool`");
                if let Some(s) = did_you_mean(&ty.text, ["int", "float", "bool"]) {
                    d = d.with_suggestion(format!("did you mean `{s}`?"), ty.span, s);
                }
                self.out.diagnostics.push(d);
                return;
            }
        };
        if !ok_count {
            self.out
                .diagnostics
                .push(bad("expected `@param int|float NAME DEFAULT [MIN MAX]` or `@param bool NAME true|false`"));
            return;
        }
        let default = values[0];
        let (min, max) = if values.len() == 3 { (Some(values[1]), Some(values[2])) } else { (None, None) };
        let mut value = default;
        if let Some((_, v)) = self.opts.params.iter().find(|(n, _)| *n == name.text) {
            let parsed = match v.as_str() {
                "true" => Some(1.0),
                "false" => Some(0.0),
                t => t.parse::<f64>().ok(),
            };
            match parsed {
                Some(p) if p.is_finite() => value = p,
                Some(_) => self.out.diagnostics.push(Diagnostic::error(
                    "E0209",
                    name.span,
                    format!("`--param {}={v}`: the value is not a finite number", name.text),
                )),
                None => self.out.diagnostics.push(Diagnostic::error(
                    "E0209",
                    name.span,
                    format!("`--param {}={v}`: the value is not a number", name.text),
                )),
            }
        }
        if ty.text == "int" {
            value = value.round();
        }
        if let (Some(lo), Some(hi)) = (min, max) {
            // (Finite bounds, checked above; the language's clamp never panics.)
            value = mdg_vm::expr::clamp(value, lo, hi);
        }
        if ty.text == "bool" && value != 0.0 {
            self.out.defines.entry(name.text.clone()).or_insert(None);
        }
        self.out.params.push(Param { name: name.clone(), ty: ty.text.clone(), default, min, max, value });
    }

    fn top_items(&mut self, items: Vec<Item>, ns: Option<String>) {
        for item in items {
            match item.kind {
                ItemKind::Pre(pre) => self.top_pre(pre, item.span, &ns),
                ItemKind::Namespace { name, items } => {
                    let full = match &ns {
                        Some(p) => format!("{p}.{}", name.text),
                        None => name.text.clone(),
                    };
                    self.out.items.push(ExpItem {
                        item: Item { kind: ItemKind::Namespace { name, items: vec![] }, span: item.span },
                        namespace: ns.clone(),
                    });
                    self.nest += 1;
                    self.top_items(items, Some(full));
                    self.nest -= 1;
                }
                ItemKind::Rule(mut rule) => {
                    // A body without preprocessor constructs expands to itself: the
                    // rule is shared with the parse, not copied.
                    if has_pre(&rule.body) {
                        let r = std::sync::Arc::make_mut(&mut rule);
                        self.nest += 1;
                        r.body = self.body(std::mem::take(&mut r.body));
                        self.nest -= 1;
                    }
                    self.out.items.push(ExpItem {
                        item: Item { kind: ItemKind::Rule(rule), span: item.span },
                        namespace: ns.clone(),
                    });
                }
                kind => self.out.items.push(ExpItem { item: Item { kind, span: item.span }, namespace: ns.clone() }),
            }
        }
    }

    fn top_pre(&mut self, pre: Pre<Item>, span: Span, ns: &Option<String>) {
        match pre {
            Pre::Import(names) => {
                for n in names {
                    self.import(&n);
                }
            }
            Pre::Define { name, value } => {
                self.out.defines.insert(name.text, value.map(|v| v.value));
            }
            Pre::Param(_) => {}
            Pre::Presets(p) => self.out.presets.extend(p),
            Pre::Shader { vertex, name, code, code_span } => {
                self.out.shaders.push(Shader { vertex, name, code, code_span });
            }
            Pre::Macro(m) => self.define_macro(m),
            Pre::Expand { name, args } => {
                if let Some(tokens) = self.expand_tokens(&name, &args, span) {
                    let file = name.span.file;
                    let budget = parse::MAX_NESTING.saturating_sub(self.nest);
                    let (items, diags, suppressed) = parse::parse_items_within(self.sources, file, tokens, budget);
                    self.absorb(diags, suppressed);
                    self.depth += 1;
                    self.collect_constants(&items);
                    self.top_items(items, ns.clone());
                    self.depth -= 1;
                }
            }
            Pre::IfDef { name, then, otherwise } => {
                let chosen = if self.out.defines.contains_key(&name.text) { Some(then) } else { otherwise };
                if let Some(items) = chosen {
                    self.collect_constants(&items);
                    self.top_items(items, ns.clone());
                }
            }
            Pre::Bad => {}
        }
    }

    fn body(&mut self, items: Vec<BodyItem>) -> Vec<BodyItem> {
        let mut out = Vec::with_capacity(items.len());
        for item in items {
            self.body_item(item, &mut out);
        }
        out
    }

    fn body_item(&mut self, item: BodyItem, out: &mut Vec<BodyItem>) {
        // Kept small, with the work in functions of their own: iterators and blocks
        // recurse through here once per nesting level (see `nested_item`).
        match item.kind {
            BodyKind::Pre(pre) => self.pre_item(pre, item.span, item.cont, out),
            kind @ (BodyKind::Iterate { .. } | BodyKind::Loop { .. } | BodyKind::If { .. } | BodyKind::Block(_)) => {
                out.push(self.nested_item(BodyItem { kind, ..item }));
            }
            // From here on a `switch` is what it means (its `let` and `if` chain).
            BodyKind::Switch(s) => {
                let lowered = BodyItem { cont: item.cont, ..s.lowered };
                out.push(self.nested_item(lowered));
            }
            kind => out.push(BodyItem { kind, ..item }),
        }
    }

    /// A preprocessor construct in a rule body.
    #[inline(never)]
    fn pre_item(&mut self, pre: Pre<BodyItem>, span: Span, cont: bool, out: &mut Vec<BodyItem>) {
        let item = BodyItem { kind: BodyKind::Error, cont, span };
        match pre {
            Pre::Expand { name, args } => {
                if let Some(tokens) = self.expand_tokens(&name, &args, item.span) {
                    let budget = parse::MAX_NESTING.saturating_sub(self.nest);
                    let (items, diags, suppressed) =
                        parse::parse_body_items_within(self.sources, name.span.file, tokens, budget);
                    self.absorb(diags, suppressed);
                    self.depth += 1;
                    let mut expanded = self.body(items);
                    self.depth -= 1;
                    if item.cont {
                        if let Some(last) = expanded.last_mut() {
                            last.cont = true;
                        }
                    }
                    out.extend(expanded);
                }
            }
            Pre::IfDef { name, then, otherwise } => {
                let chosen = if self.out.defines.contains_key(&name.text) { Some(then) } else { otherwise };
                if let Some(items) = chosen {
                    for i in items {
                        self.body_item(i, out);
                    }
                }
            }
            Pre::Macro(m) => self.define_macro(m),
            Pre::Define { name, value } => {
                self.out.defines.insert(name.text, value.map(|v| v.value));
            }
            Pre::Import(_) | Pre::Param(_) | Pre::Presets(_) | Pre::Shader { .. } => {
                self.out.diagnostics.push(
                    Diagnostic::error("E0209", item.span, "this directive belongs at the top level, not inside a rule")
                        .with_label("move it out of the rule body"),
                );
            }
            Pre::Bad => {}
        }
    }

    /// An item with items inside (iterator, loop, `if`, block), expanded inside.
    /// Apart from `body_item` so that its frame, on the stack once per nesting level,
    /// stays small: a program may nest to the parse limit on the language server's
    /// 2 MiB analysis threads.
    #[inline(never)]
    fn nested_item(&mut self, item: BodyItem) -> BodyItem {
        let span = item.span;
        let kind = match item.kind {
            BodyKind::Iterate { count, divisor, adj, chain, item: inner } => {
                let inner = self.single(*inner, span);
                BodyKind::Iterate { count, divisor, adj, chain, item: Box::new(inner) }
            }
            BodyKind::Loop { var, range, adj, item: inner } => {
                let inner = self.single(*inner, span);
                BodyKind::Loop { var, range, adj, item: Box::new(inner) }
            }
            BodyKind::If { cond, then, then_span, otherwise } => {
                self.nest += 1;
                let then = self.body(then);
                self.nest -= 1;
                let otherwise = otherwise.map(|o| Box::new(self.single(*o, span)));
                BodyKind::If { cond, then, then_span, otherwise }
            }
            BodyKind::Block(items) => {
                self.nest += 1;
                let items = self.body(items);
                self.nest -= 1;
                BodyKind::Block(items)
            }
            kind => kind,
        };
        BodyItem { kind, ..item }
    }

    /// Expands an item that must stay one item (an iterator's or `else`'s): what a
    /// macro turns it into is wrapped in a block.
    fn single(&mut self, inner: BodyItem, at: Span) -> BodyItem {
        let mut v = Vec::new();
        self.nest += 1;
        self.body_item(inner, &mut v);
        self.nest -= 1;
        if v.len() == 1 {
            v.pop().unwrap_or(BodyItem { kind: BodyKind::Error, cont: false, span: at })
        } else {
            let span = v.first().map(|f| f.span).unwrap_or(at);
            BodyItem { kind: BodyKind::Block(v), cont: false, span }
        }
    }

    fn define_macro(&mut self, m: MacroDef) {
        if let Some(prev) = self.macros.get(&m.name.text) {
            if prev.name.span != m.name.span {
                self.out.diagnostics.push(
                    Diagnostic::error("E0211", m.name.span, format!("macro `{}` is defined twice", m.name.text))
                        .with_secondary(prev.name.span, "first defined here"),
                );
            }
            return;
        }
        self.macros.insert(m.name.text.clone(), m);
    }

    /// The tokens of one expansion with parameters substituted, or `None` after an error.
    fn expand_tokens(&mut self, name: &Name, args: &[MacroArg], call_span: Span) -> Option<Vec<Token>> {
        let Some(m) = self.macros.get(&name.text).cloned() else {
            let mut d = Diagnostic::error("E0204", name.span, format!("unknown macro `{}`", name.text));
            if let Some(s) = did_you_mean(&name.text, self.macros.keys().map(|k| k.as_str())) {
                d = d.with_suggestion(format!("did you mean `{s}`?"), name.span, s.to_string());
            }
            self.out.diagnostics.push(d);
            return None;
        };
        if m.params.len() != args.len() {
            self.out.diagnostics.push(
                Diagnostic::error(
                    "E0205",
                    call_span,
                    format!(
                        "macro `{}` takes {} argument(s) but {} were given",
                        m.name.text,
                        m.params.len(),
                        args.len()
                    ),
                )
                .with_secondary(m.name.span, "defined here"),
            );
            return None;
        }
        if self.expansion_stopped {
            return None;
        }
        let param = |t: &Token| {
            (t.kind == Tok::Ident).then(|| m.params.iter().position(|p| p.text == self.sources.text(t.span))).flatten()
        };
        let size: usize = m.body.iter().map(|t| param(t).map_or(1, |i| args[i].tokens.len())).sum();
        if self.depth >= MAX_EXPANSION_DEPTH
            || self.n_expansions >= MAX_EXPANSIONS
            || self.n_tokens.saturating_add(size) > MAX_EXPANDED_TOKENS
        {
            self.expansion_stopped = true;
            self.out.diagnostics.push(
                Diagnostic::error("E0208", call_span, format!("expansion of macro `{}` nests too deeply", m.name.text))
                    .with_note(format!(
                        "expansions may nest {MAX_EXPANSION_DEPTH} deep, number {MAX_EXPANSIONS} and make \
                         {MAX_EXPANDED_TOKENS} tokens in all; is the macro recursive?"
                    )),
            );
            return None;
        }
        self.n_expansions += 1;
        self.n_tokens += size;
        self.out.expansions.push(Expansion { macro_name: m.name.text.clone(), call_span, body_span: m.body_span });
        let mut tokens = Vec::with_capacity(size);
        for t in &m.body {
            match param(t) {
                Some(i) => tokens.extend_from_slice(&args[i].tokens),
                None => tokens.push(*t),
            }
        }
        Some(tokens)
    }

    fn import(&mut self, name: &Name) {
        let from = self.sources.file(name.span.file).path.clone();
        let is_path = name.text.contains('/') || name.text.ends_with(".mdg");
        let candidate = if is_path {
            from.parent().unwrap_or(Path::new(".")).join(&name.text)
        } else {
            match &self.opts.std_dir {
                Some(d) => d.join(format!("{}.mdg", name.text)),
                None => {
                    self.out.diagnostics.push(
                        Diagnostic::error(
                            "E0201",
                            name.span,
                            format!("cannot import `{}`: the std library was not found", name.text),
                        )
                        .with_note("set MDG_STD to the std directory, or import a relative path like `lib/x.mdg`"),
                    );
                    return;
                }
            }
        };
        let canon = match self.loader.canonicalize(&candidate) {
            Ok(c) => c,
            Err(_) => {
                let mut d = Diagnostic::error("E0201", name.span, format!("cannot find `{}` to import", name.text))
                    .with_label(format!("looked for {}", candidate.display()));
                if !is_path {
                    if let Some(dir) = &self.opts.std_dir {
                        let names = std_names(dir);
                        if let Some(s) = did_you_mean(&name.text, names.iter().map(|s| s.as_str())) {
                            d = d.with_suggestion(format!("did you mean `{s}`?"), name.span, s.to_string());
                        }
                    }
                }
                self.out.diagnostics.push(d);
                return;
            }
        };
        let contained = |root: &Option<PathBuf>| root.as_ref().is_some_and(|r| canon.starts_with(r));
        if !contained(&self.root) && !contained(&self.std_root) {
            self.out.diagnostics.push(
                Diagnostic::error(
                    "E0202",
                    name.span,
                    format!("`{}` is outside the project and the std library", name.text),
                )
                .with_label(format!("resolves to {}", canon.display()))
                .with_note("imports may only read files under the main file's directory or the std directory"),
            );
            return;
        }
        if self.import_stack.contains(&canon) {
            self.out.diagnostics.push(
                Diagnostic::error("E0203", name.span, format!("`{}` imports itself (an import cycle)", name.text))
                    .with_note(format!(
                        "cycle: {}",
                        self.import_stack
                            .iter()
                            .chain(std::iter::once(&canon))
                            .map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default())
                            .collect::<Vec<_>>()
                            .join(" → ")
                    )),
            );
            return;
        }
        if !self.imported.insert(canon.clone()) {
            return;
        }
        if self.import_stack.len() >= MAX_IMPORT_DEPTH {
            let name_of = |p: &PathBuf| p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
            let n = self.import_stack.len();
            let chain: Vec<String> = self.import_stack.iter().take(3).map(name_of).collect();
            let tail: Vec<String> = self.import_stack.iter().skip(n.saturating_sub(2).max(3)).map(name_of).collect();
            self.out.diagnostics.push(
                Diagnostic::error(
                    "E0212",
                    name.span,
                    format!("imports nest too deeply: `{}` would be file {} of one import chain", name.text, n + 1),
                )
                .with_label(format!("a chain of imports may hold {MAX_IMPORT_DEPTH} files"))
                .with_note(format!("chain: {} → … → {} → {}", chain.join(" → "), tail.join(" → "), name_of(&canon)))
                .with_note("import the files from one file instead of each from the one before"),
            );
            return;
        }
        let text = match self.loader.read(&canon) {
            Ok(t) => t,
            Err(e) => {
                self.out.diagnostics.push(Diagnostic::error(
                    "E0201",
                    name.span,
                    format!("cannot read `{}`: {e}", name.text),
                ));
                return;
            }
        };
        let display = if is_path { name.text.clone() } else { format!("std/{}.mdg", name.text) };
        let id = self.sources.add(canon.clone(), display, text);
        self.out.files.push(id);
        let parsed = parse::parse_file(self.sources, id);
        self.absorb(parsed.diagnostics, parsed.suppressed);
        self.import_stack.push(canon);
        self.collect_constants(&parsed.file.items);
        self.top_items(parsed.file.items, None);
        self.import_stack.pop();
    }

    /// Takes the diagnostics of a parsed file or expansion, and the count of those its
    /// parser did not keep: kept while the expansion holds fewer than
    /// [`MAX_ERRORS`](crate::diag::MAX_ERRORS) from parsing, else counted (10,000
    /// expansions of a macro with one bad token would otherwise keep 10,000).
    fn absorb(&mut self, diags: Vec<Diagnostic>, suppressed: crate::diag::Suppressed) {
        self.out.suppressed += suppressed;
        for d in diags {
            if self.parse_diags < crate::diag::MAX_ERRORS {
                self.parse_diags += 1;
                self.out.diagnostics.push(d);
            } else {
                self.out.suppressed.add(d.span);
            }
        }
    }

    /// Adds "in this expansion" labels to diagnostics inside macro bodies.
    fn label_expansions(&mut self) {
        // Only the first expansion of each macro body can match (as with `find` over
        // all of them), so look among those: thousands of expansions of a few macros
        // made this quadratic (seconds for a 2 KB file).
        let mut seen = HashSet::new();
        let expansions: Vec<Expansion> =
            self.out.expansions.iter().filter(|e| seen.insert(e.body_span)).cloned().collect();
        for d in &mut self.out.diagnostics {
            if let Some(e) = expansions.iter().find(|e| {
                e.body_span.file == d.span.file && e.body_span.start <= d.span.start && d.span.end <= e.body_span.end
            }) {
                d.secondary.push(crate::diag::Label {
                    span: e.call_span,
                    message: format!("in this expansion of macro `{}`", e.macro_name),
                });
            }
        }
    }
}

fn std_names(dir: &Path) -> Vec<String> {
    if dir == Path::new(crate::stdlib::EMBEDDED_ROOT) {
        return crate::stdlib::libraries().into_iter().map(|(n, _)| n.to_string()).collect();
    }
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter_map(|e| e.file_name().to_str().and_then(|n| n.strip_suffix(".mdg")).map(|s| s.to_string()))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The names `@ifdef` tests anywhere in `sources`' files that took part (chosen
/// branches or not): a `--preset` such a test reads is used even without `@presets`.
fn ifdef_names(expanded: &Expanded, sources: &Sources) -> HashSet<String> {
    let mut names = HashSet::new();
    for &f in &expanded.files {
        let lexed = crate::lexer::lex(&sources.file(f).text, f);
        for w in lexed.tokens.windows(2) {
            if w[0].kind == Tok::AtIfdef && w[1].kind == Tok::Ident {
                names.insert(sources.text(w[1].span).to_string());
            }
        }
    }
    names
}

/// The `--param NAME=V` and `--preset P` of `opts` that do nothing in this program,
/// each as the flag (`--param x=1`) and a message naming it, with "did you mean"
/// (edit distance) or the declared names: a parameter must be declared by `@param`;
/// a preset by `@presets` or tested by an `@ifdef` (of any branch). The commands
/// report these as usage errors; they used to be ignored.
pub fn unused_command_line(expanded: &Expanded, sources: &Sources, opts: &Options) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let params: Vec<&str> = expanded.params.iter().map(|p| p.name.text.as_str()).collect();
    for (name, value) in &opts.params {
        if params.contains(&name.as_str()) {
            continue;
        }
        let flag = format!("--param {name}={value}");
        out.push((flag.clone(), format!("{flag}: {}", unknown("@param", name, &params))));
    }
    let tested = ifdef_names(expanded, sources);
    let mut presets: Vec<&str> = expanded.presets.iter().map(|p| p.text.as_str()).collect();
    presets.extend(tested.iter().map(String::as_str));
    presets.sort_unstable();
    presets.dedup();
    for name in &opts.defines {
        if presets.contains(&name.as_str()) {
            continue;
        }
        let flag = format!("--preset {name}");
        out.push((flag.clone(), format!("{flag}: {}", unknown("@presets", name, &presets))));
    }
    out
}

/// "the grammar declares no `@param` `x` (did you mean `y`? | it declares: a, b | it declares none)".
fn unknown(what: &str, name: &str, declared: &[&str]) -> String {
    let hint = match did_you_mean(name, declared.iter().copied()) {
        Some(s) => format!("did you mean `{s}`?"),
        None if declared.is_empty() => format!("it declares no {what}"),
        None => format!("it declares {}", declared.iter().map(|d| format!("`{d}`")).collect::<Vec<_>>().join(", ")),
    };
    format!("the grammar has no {what} `{name}`, so this would do nothing ({hint})")
}
