//! Completion: what may be written at the cursor, with snippets.
//!
//! The context comes from the tokens before the cursor, not the tree, because the
//! text being typed rarely parses: brackets say whether the cursor is at the top
//! level, in a rule body, an adjustment list, an expression, an isosurface or a
//! program, and the previous token says what the statement expects next. Inside a
//! §11 extension section the brackets give the path of keys (`creature` → `part` →
//! `slot`): at the start of an entry the keys of that path are offered, from
//! [`crate::ext::keys`]; a value gets rule names only where the section's module
//! reads a rule name ([`crate::ext::rule_refs`] on the text with a probe word there).

use super::docs::{self, DocKind};
use super::index::{qualify, Occ, Symbol};
use super::Document;
use crate::check::{AdjKind, ANGLE_MODES, DRAWABLES, FUNCTIONS, NUMERIC_DIRECTIVES, PROFILE_DRAWABLES, SELECTOR_MODES};
use crate::lexer::{Tok, Token};
use crate::span::Span;

/// What completion needs from outside the analysis.
#[derive(Clone, Debug, Default)]
pub struct CompletionConfig {
    /// Names of the std library files (`primitives`, `lines`, …) for `@import`.
    pub std_libraries: Vec<String>,
}

/// What a completion item is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompletionKind {
    Rule,
    Drawable,
    Isosurface,
    Adjustment,
    Directive,
    Preprocessor,
    SelectorMode,
    AngleMode,
    Function,
    Variable,
    Constant,
    Library,
    Snippet,
    Keyword,
    Shader,
    Macro,
    /// A key of an extension section.
    Key,
    /// A palette name of a colour value (`#tomato`); its detail is its `#rrggbb`.
    Colour,
}

/// One completion.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompletionItem {
    pub label: String,
    pub kind: CompletionKind,
    pub detail: Option<String>,
    /// Markdown.
    pub documentation: Option<String>,
    /// The text to insert; a snippet (`$1`, `${1:x}`, `$0`) when `snippet`.
    pub insert_text: String,
    pub snippet: bool,
}

/// Completions at a position: the span they replace (the word typed so far) and the items in order of preference.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Completions {
    pub replace: Span,
    pub items: Vec<CompletionItem>,
}

/// Where the cursor is, as far as completion cares. `SectionKey`: at the start of an
/// entry of a section, whose keys are those at `path` (`["creature", "part"]`).
#[derive(Clone, Debug, PartialEq, Eq)]
enum Context {
    TopLevel,
    Body { ns: Option<String>, call_braces: bool },
    RuleName { ns: Option<String> },
    Adjustment,
    Expression { position_vars: bool },
    Isosurface,
    Program,
    Shader { vertex: bool },
    SelectorMode,
    AngleMode,
    FunctionName,
    Import,
    Preprocessor,
    SectionKey { path: Vec<String> },
    Nothing,
}

/// An open bracket. `Section`: a section's `{ … }` or a nested block, with the path
/// of keys to it and the first word of the entry being written (`None` at its start).
#[derive(Clone, Debug, PartialEq, Eq)]
enum Frame {
    Namespace(String),
    Rule,
    Block,
    Adj,
    Expr { position_vars: bool },
    Iso,
    Program,
    Section { path: Vec<String>, key: Option<String> },
    Other,
}

fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == '.' || c == '@'
}

/// The word typed before `offset` (clamped to a char boundary): its start and the offset.
fn word_before(text: &str, offset: u32) -> (usize, usize) {
    let mut offset = (offset as usize).min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let start = text[..offset]
        .char_indices()
        .rev()
        .find(|(_, c)| !is_word_char(*c))
        .map(|(i, c)| i + c.len_utf8())
        .unwrap_or(0);
    (start, offset)
}

impl Document {
    /// The completions at `offset`.
    pub fn completion(&self, offset: u32, config: &CompletionConfig) -> Completions {
        let (start, offset) = word_before(self.text(), offset);
        let replace = Span::new(self.main_file(), start as u32, offset as u32);
        // After `#` in an adjustment list: the palette's names (a colour value).
        if start > 0 && self.text().as_bytes()[start - 1] == b'#' {
            let items = match self.context(start - 1, offset) {
                Context::Adjustment => palette_items(),
                _ => Vec::new(),
            };
            return Completions { replace, items };
        }
        let context = self.context(start, offset);
        let items = self.items_for(&context, config, offset);
        Completions { replace, items }
    }

    fn context(&self, start: usize, offset: usize) -> Context {
        let text = self.text();
        let idx = self.index();
        let inside = |s: Span| (s.start as usize) < offset && offset <= s.end as usize;
        if idx.comments.iter().any(|c| inside(c.span) && (c.block || offset <= c.span.end as usize)) {
            return Context::Nothing;
        }
        if idx.tokens.iter().any(|t| t.kind == Tok::Shader && inside(t.span) && (offset as u32) < t.span.end) {
            return Context::Nothing;
        }
        // Inside a "string" (the closing quote still ahead).
        if idx.tokens.iter().any(|t| t.kind == Tok::Str && inside(t.span) && (offset as u32) < t.span.end) {
            return Context::Nothing;
        }
        let line_start = text[..start].rfind('\n').map(|i| i + 1).unwrap_or(0);
        let line_before = &text[line_start..start];
        if line_before.trim_start().starts_with("@import") {
            return Context::Import;
        }
        if text[start..offset].starts_with('@') {
            return if line_before.trim().is_empty() { Context::Preprocessor } else { Context::Nothing };
        }
        let first_on_line = line_before.trim().is_empty();
        let before: Vec<Token> = idx.tokens.iter().copied().filter(|t| t.span.end as usize <= start).collect();
        let mut stack: Vec<Frame> = Vec::new();
        let mut pending: Option<usize> = None;
        let ns_of = |stack: &[Frame]| {
            stack.iter().rev().find_map(|f| match f {
                Frame::Namespace(n) => Some(n.clone()),
                _ => None,
            })
        };
        // `if (…) {` opens a block, `tree(…) {` an adjustment list; `loop i = a, b {` an
        // adjustment list too.
        let mut closed_if = false;
        let mut open_ifs: Vec<bool> = Vec::new();
        let mut loop_header = false;
        for (i, t) in before.iter().enumerate() {
            let top_level = matches!(stack.last(), None | Some(Frame::Namespace(_)));
            let prev = if i > 0 { Some(before[i - 1].kind) } else { None };
            // The first word of a section entry is its key.
            if let Some(Frame::Section { key: key @ None, .. }) = stack.last_mut() {
                if !matches!(t.kind, Tok::Semi | Tok::LBrace | Tok::RBrace) {
                    *key = Some(self.span_text(t.span).to_string());
                }
            }
            match t.kind {
                Tok::LBrace => {
                    let frame = match stack.last() {
                        None | Some(Frame::Namespace(_)) => match pending.map(|p| before[p].kind) {
                            Some(Tok::KwRule) => Frame::Rule,
                            Some(Tok::KwNamespace) => {
                                let name = pending.and_then(|p| before.get(p + 1)).map(|n| self.span_text(n.span).to_string());
                                Frame::Namespace(qualify(ns_of(&stack).as_deref(), &name.unwrap_or_default()))
                            }
                            Some(Tok::KwFunction) | Some(Tok::KwSelector) => Frame::Expr { position_vars: true },
                            Some(Tok::KwIsosurface) => Frame::Iso,
                            Some(Tok::KwProgram) => Frame::Program,
                            Some(Tok::KwSection) => Frame::Section {
                                path: pending.map(|p| self.span_text(before[p].span).to_string()).into_iter().collect(),
                                key: None,
                            },
                            _ => Frame::Other,
                        },
                        Some(Frame::Section { path, key }) => {
                            let mut path = path.clone();
                            path.push(key.clone().unwrap_or_default());
                            Frame::Section { path, key: None }
                        }
                        Some(Frame::Rule) | Some(Frame::Block) => match prev {
                            _ if loop_header => Frame::Adj,
                            Some(Tok::Ident) | Some(Tok::Dotted) | Some(Tok::Star) => Frame::Adj,
                            Some(Tok::RParen) if !closed_if => Frame::Adj,
                            _ => Frame::Block,
                        },
                        Some(Frame::Iso) => Frame::Expr { position_vars: true },
                        Some(_) => Frame::Other,
                    };
                    stack.push(frame);
                    pending = None;
                    loop_header = false;
                }
                Tok::LBracket => {
                    loop_header = false;
                    stack.push(match stack.last() {
                        Some(Frame::Rule) | Some(Frame::Block) => Frame::Adj,
                        _ => Frame::Other,
                    })
                }
                Tok::KwLoop => loop_header = true,
                Tok::LParen | Tok::CallOpen => {
                    let position_vars = matches!(stack.last(), Some(Frame::Expr { position_vars: true }) | Some(Frame::Iso));
                    open_ifs.push(prev == Some(Tok::KwIf));
                    stack.push(Frame::Expr { position_vars });
                }
                Tok::RParen => {
                    // A rule's parameter list `rule tree(…)` keeps the rule pending.
                    stack.pop();
                    closed_if = open_ifs.pop().unwrap_or(false);
                }
                Tok::RBrace | Tok::RBracket => {
                    let closed = stack.pop();
                    pending = None;
                    // A nested block ends its entry.
                    if let (Some(Frame::Section { .. }), Some(Frame::Section { key, .. })) = (closed, stack.last_mut()) {
                        *key = None;
                    }
                }
                Tok::Semi => {
                    if let Some(Frame::Section { key, .. }) = stack.last_mut() {
                        *key = None;
                    }
                }
                Tok::KwRule
                | Tok::KwNamespace
                | Tok::KwFunction
                | Tok::KwSelector
                | Tok::KwIsosurface
                | Tok::KwProgram
                | Tok::KwStartshape
                | Tok::KwLinerule
                | Tok::KwCamerarule
                | Tok::KwUniform
                | Tok::KwAngle
                | Tok::KwColor
                | Tok::KwWeight
                | Tok::KwSection
                    // `function` inside a selector line belongs to the selector; a section
                    // word that names a rule, namespace, function or isosurface is a name.
                    if top_level
                        && !(t.kind == Tok::KwFunction && pending.is_some_and(|p| before[p].kind == Tok::KwSelector))
                        && !(t.kind == Tok::KwSection
                            && matches!(
                                prev,
                                Some(Tok::KwRule)
                                    | Some(Tok::KwNamespace)
                                    | Some(Tok::KwFunction)
                                    | Some(Tok::KwIsosurface)
                                    | Some(Tok::Star)
                                    | Some(Tok::Colon)
                            )) =>
                {
                    pending = Some(i);
                }
                _ => {}
            }
        }
        let prev = before.last().map(|t| t.kind);
        let prev_text = before.last().map(|t| self.span_text(t.span)).unwrap_or("");
        let ns = ns_of(&stack);
        let next_char = text[offset..].trim_start_matches([' ', '\t']).chars().next();
        let call_braces = !matches!(next_char, Some('{') | Some('['));
        match stack.last() {
            None | Some(Frame::Namespace(_)) => {
                let same_line = before.last().is_some_and(|t| !text[t.span.end as usize..start].contains('\n'));
                if same_line {
                    match prev {
                        Some(Tok::KwStartshape)
                        | Some(Tok::KwLinerule)
                        | Some(Tok::KwCamerarule)
                        | Some(Tok::KwRule) => {
                            return Context::RuleName { ns };
                        }
                        Some(Tok::KwAngle) => return Context::AngleMode,
                        _ => {}
                    }
                    if let Some(p) = pending.filter(|p| before[*p].kind == Tok::KwSelector) {
                        let tail = &before[p + 1..];
                        return match prev {
                            Some(Tok::KwSelector) | Some(Tok::Comma) => Context::RuleName { ns },
                            Some(Tok::KwFunction) => Context::FunctionName,
                            Some(Tok::Ident) | Some(Tok::Dotted)
                                if tail.iter().all(|t| matches!(t.kind, Tok::Ident | Tok::Dotted | Tok::Comma)) =>
                            {
                                Context::SelectorMode
                            }
                            _ => Context::Nothing,
                        };
                    }
                }
                if first_on_line {
                    Context::TopLevel
                } else {
                    Context::Nothing
                }
            }
            Some(Frame::Rule) | Some(Frame::Block) => {
                let profile = prev == Some(Tok::Ident)
                    && PROFILE_DRAWABLES.contains(&prev_text.rsplit('.').next().unwrap_or(""))
                    && !first_on_line;
                if profile {
                    Context::RuleName { ns }
                } else {
                    Context::Body { ns, call_braces }
                }
            }
            Some(Frame::Adj) => Context::Adjustment,
            Some(Frame::Expr { position_vars }) => Context::Expression { position_vars: *position_vars },
            Some(Frame::Iso) => Context::Isosurface,
            Some(Frame::Program) => match prev_text {
                "vertexshader" if prev == Some(Tok::Ident) => Context::Shader { vertex: true },
                "fragmentshader" if prev == Some(Tok::Ident) => Context::Shader { vertex: false },
                _ => Context::Program,
            },
            Some(Frame::Section { path, key: None }) => Context::SectionKey { path: path.clone() },
            Some(Frame::Section { key: Some(_), .. }) => {
                if self.section_value_is_rule(start, offset) {
                    Context::RuleName { ns }
                } else {
                    Context::Nothing
                }
            }
            Some(Frame::Other) => Context::Nothing,
        }
    }

    /// Whether the section module reads the word at `start..offset` (a value of a
    /// section entry) as a rule name: the text with a probe word there is parsed and
    /// [`crate::ext::rule_refs`] asked about the probe. The entry may be unfinished,
    /// so the probe is also tried with a `;` after it.
    fn section_value_is_rule(&self, start: usize, offset: usize) -> bool {
        const PROBE: &str = "mdg_completion_probe";
        let text = self.text();
        let end = text[offset..].find(|c: char| !is_word_char(c)).map(|i| offset + i).unwrap_or(text.len());
        for tail in ["", ";"] {
            let mut sources = crate::source::Sources::default();
            let probed = format!("{}{PROBE}{tail}{}", &text[..start], &text[end..]);
            let path = self.file_path(self.main_file()).map(|p| p.to_path_buf()).unwrap_or_default();
            let file = sources.add(path, "completion probe", probed);
            let parsed = crate::parse::parse_file(&sources, file);
            let mut sections = Vec::new();
            sections_in(&parsed.file.items, &mut sections);
            let at_probe = |v: &crate::ast::Value| matches!(v, crate::ast::Value::Word(w) if w.span.start as usize == start && w.text == PROBE);
            for sec in sections {
                if entries_have(&sec.entries, &at_probe) {
                    return crate::ext::rule_refs(sec)
                        .iter()
                        .any(|n| n.span.start as usize == start && n.text == PROBE);
                }
            }
        }
        false
    }

    fn items_for(&self, context: &Context, config: &CompletionConfig, offset: usize) -> Vec<CompletionItem> {
        let mut out = Vec::new();
        match context {
            Context::TopLevel => {
                for name in crate::check::directive_names() {
                    out.push(builtin(DocKind::Directive, name, CompletionKind::Directive, &directive_snippet(name)));
                }
                for d in docs::of_kind(DocKind::Preprocessor) {
                    out.push(builtin(
                        DocKind::Preprocessor,
                        d.name,
                        CompletionKind::Preprocessor,
                        &preprocessor_snippet(d.name),
                    ));
                }
            }
            Context::Preprocessor => {
                for d in docs::of_kind(DocKind::Preprocessor) {
                    out.push(builtin(
                        DocKind::Preprocessor,
                        d.name,
                        CompletionKind::Preprocessor,
                        &preprocessor_snippet(d.name),
                    ));
                }
                for name in self.macro_names() {
                    out.push(CompletionItem {
                        label: format!("@expand {name}"),
                        kind: CompletionKind::Macro,
                        detail: Some("macro".to_string()),
                        documentation: None,
                        insert_text: format!("@expand {name}($1)"),
                        snippet: true,
                    });
                }
            }
            Context::Body { ns, call_braces } => {
                self.rule_items(ns.as_deref(), *call_braces, &mut out);
                for name in DRAWABLES {
                    let insert = if *call_braces { format!("{name} {{$0}}") } else { name.to_string() };
                    out.push(builtin(DocKind::Drawable, name, CompletionKind::Drawable, &insert));
                }
                for name in self.analysis.checked.symbols.isosurfaces.keys() {
                    out.push(CompletionItem {
                        label: name.clone(),
                        kind: CompletionKind::Isosurface,
                        detail: Some("isosurface".to_string()),
                        documentation: None,
                        insert_text: if *call_braces { format!("{name} {{$0}}") } else { name.clone() },
                        snippet: *call_braces,
                    });
                }
                out.push(snippet(
                    "iterator",
                    "M * {T} ITEM: run ITEM M times, each run under one more T",
                    "${1:4} * {${2:rz 90}} $0",
                ));
                out.push(snippet(
                    "iterator with divisor",
                    "M/N * {T} ITEM: step by T/N, e.g. go round once in N steps",
                    "${1:30}/${2:30} * [${3:ry 360}] $0",
                ));
                out.push(snippet("block", "{ BODY }: group items (for iterators)", "{\n\t$0\n}"));
                out.push(snippet("if", "if (CONDITION) { BODY } else { BODY }", "if (${1:n > 0}) {\n\t$0\n}"));
                out.push(snippet(
                    "if else",
                    "if (CONDITION) { BODY } else { BODY }",
                    "if (${1:n > 0}) {\n\t$2\n} else {\n\t$0\n}",
                ));
                out.push(snippet(
                    "switch",
                    "switch (EXPRESSION) { case A: ITEMS … else: ITEMS }: Context Free's switch",
                    "switch (${1:n}) {\n\tcase ${2:0}:\n\t\t$3\n\telse:\n\t\t$0\n}",
                ));
                out.push(snippet("let", "let NAME = EXPRESSION; a local binding", "let ${1:name} = ${2:0};"));
                out.push(snippet(
                    "loop",
                    "loop NAME = START, END {ADJ} ITEM: Context Free's loop with a variable",
                    "loop ${1:i} = ${2:0}, ${3:10} {${4:x 1}} $0",
                ));
                self.local_items(offset, &mut out);
            }
            Context::RuleName { ns } => self.rule_items(ns.as_deref(), false, &mut out),
            Context::Adjustment => {
                let comps = &self.analysis.checked.symbols.components;
                for name in comps.all_names() {
                    let kind = comps.adj_kind(name);
                    let canonical = match kind {
                        Some(AdjKind::Color(i)) => ["R", "G", "B", "A"][i as usize],
                        Some(AdjKind::Weight(i)) => ["u", "v", "w", "q"][i as usize],
                        _ => name,
                    };
                    let mut item = builtin(
                        DocKind::Adjustment,
                        canonical,
                        CompletionKind::Adjustment,
                        &adjustment_snippet(name, kind),
                    );
                    item.label = name.to_string();
                    out.push(item);
                }
                // A bare name after an adjustment is its argument: `{y len}`.
                self.local_items(offset, &mut out);
            }
            Context::Expression { position_vars } => {
                self.local_items(offset, &mut out);
                for (name, arity) in FUNCTIONS {
                    let args: Vec<String> = (1..=*arity).map(|i| format!("${i}")).collect();
                    out.push(builtin(
                        DocKind::Function,
                        name,
                        CompletionKind::Function,
                        &format!("{name}({})", args.join(", ")),
                    ));
                }
                for (name, insert) in [
                    ("if", "if(${1:condition}, ${2:then}, ${3:else})"),
                    ("select", "select(${1:i}, ${2:a}, ${3:b})"),
                    ("let", "let(${1:name} = ${2:value}; ${3:expression})"),
                ] {
                    out.push(builtin(DocKind::Function, name, CompletionKind::Function, insert));
                }
                let ex = &self.analysis.expanded;
                for p in &ex.params {
                    out.push(CompletionItem {
                        label: p.name.text.clone(),
                        kind: CompletionKind::Constant,
                        detail: Some(format!("@param {} = {}", p.ty, super::iterator::fmt_num(p.value))),
                        documentation: None,
                        insert_text: p.name.text.clone(),
                        snippet: false,
                    });
                }
                for (name, v) in &ex.defines {
                    if let Some(v) = v {
                        out.push(CompletionItem {
                            label: name.clone(),
                            kind: CompletionKind::Constant,
                            detail: Some(format!("@define = {}", super::iterator::fmt_num(*v))),
                            documentation: None,
                            insert_text: name.clone(),
                            snippet: false,
                        });
                    }
                }
                if *position_vars {
                    for v in crate::check::FUNCTION_VARS {
                        out.push(builtin(DocKind::Variable, v, CompletionKind::Variable, v));
                    }
                }
            }
            Context::Isosurface => {
                for (name, insert) in [
                    ("xyz", "xyz ${1:-1.1} ${2:1.1} ${3:32} ;"),
                    ("x", "x ${1:-1.1} ${2:1.1} ${3:32} ;"),
                    ("y", "y ${1:-1.1} ${2:1.1} ${3:32} ;"),
                    ("z", "z ${1:-1.1} ${2:1.1} ${3:32} ;"),
                    ("function", "function { ${0:x*x + y*y + z*z - 1} }"),
                ] {
                    out.push(builtin(DocKind::IsoEntry, name, CompletionKind::Keyword, insert));
                }
            }
            Context::Program => {
                for (name, insert) in [
                    ("vertexshader", "vertexshader ${1:vs}"),
                    ("fragmentshader", "fragmentshader ${1:fs}"),
                    ("target", "target screen"),
                    ("render", "render"),
                ] {
                    out.push(builtin(DocKind::ProgramCommand, name, CompletionKind::Keyword, insert));
                }
            }
            Context::Shader { vertex } => {
                for sh in self.analysis.expanded.shaders.iter().filter(|s| s.vertex == *vertex) {
                    out.push(CompletionItem {
                        label: sh.name.text.clone(),
                        kind: CompletionKind::Shader,
                        detail: Some(if *vertex { "vertex shader" } else { "fragment shader" }.to_string()),
                        documentation: None,
                        insert_text: sh.name.text.clone(),
                        snippet: false,
                    });
                }
            }
            Context::SelectorMode => {
                for m in SELECTOR_MODES {
                    let insert = if *m == "function" { "function ${1:name}" } else { m };
                    out.push(builtin(DocKind::SelectorMode, m, CompletionKind::SelectorMode, insert));
                }
            }
            Context::AngleMode => {
                for m in ANGLE_MODES {
                    out.push(builtin(DocKind::AngleMode, m, CompletionKind::AngleMode, m));
                }
            }
            Context::FunctionName => {
                for name in self.analysis.checked.symbols.functions.keys() {
                    out.push(CompletionItem {
                        label: name.clone(),
                        kind: CompletionKind::Function,
                        detail: Some("function".to_string()),
                        documentation: None,
                        insert_text: name.clone(),
                        snippet: false,
                    });
                }
            }
            Context::Import => {
                for lib in &config.std_libraries {
                    out.push(CompletionItem {
                        label: lib.clone(),
                        kind: CompletionKind::Library,
                        detail: Some(format!("std/{lib}.mdg")),
                        documentation: None,
                        insert_text: lib.clone(),
                        snippet: false,
                    });
                }
            }
            Context::SectionKey { path } => {
                let path: Vec<&str> = path.iter().map(String::as_str).collect();
                for k in crate::ext::keys(&path) {
                    let mut inner = path.clone();
                    inner.push(k.name);
                    let block = !crate::ext::keys(&inner).is_empty();
                    out.push(CompletionItem {
                        label: k.name.to_string(),
                        kind: CompletionKind::Key,
                        detail: Some(if k.values.is_empty() {
                            k.name.to_string()
                        } else {
                            format!("{} {}", k.name, k.values)
                        }),
                        documentation: Some(k.doc.to_string()),
                        insert_text: key_snippet(k.name, k.values, block),
                        snippet: true,
                    });
                }
            }
            Context::Nothing => {}
        }
        out
    }

    /// Rules callable from namespace `ns`: that namespace's rules by their short
    /// names, then every rule by its full name.
    /// The parameters and locals declared before `offset` in the rule around it.
    fn local_items(&self, offset: usize, out: &mut Vec<CompletionItem>) {
        let offset = offset as u32;
        let main = self.main_file();
        let Some(rule) = rule_around(&self.analysis.expanded.main_ast.items, offset) else { return };
        let mut seen = std::collections::BTreeSet::new();
        for o in &self.index().main {
            let Occ::Def(Symbol::Local { name, decl, what }) = &o.occ else { continue };
            if decl.file != main || decl.start >= offset || !rule.contains(decl.start) || !seen.insert(name.clone()) {
                continue;
            }
            out.push(CompletionItem {
                label: name.clone(),
                kind: CompletionKind::Variable,
                detail: Some(what.clone()),
                documentation: None,
                insert_text: name.clone(),
                snippet: false,
            });
        }
    }

    fn rule_items(&self, ns: Option<&str>, call_braces: bool, out: &mut Vec<CompletionItem>) {
        let sym = &self.analysis.checked.symbols;
        let mut push = |label: String, full: &str| {
            let n_defs = sym.rules.get(full).map(|d| d.len()).unwrap_or(0);
            let file = sym.rules.get(full).and_then(|d| d.first()).map(|d| d.name_span.file);
            let from = match file {
                Some(f) if f != self.main_file() => format!(" · {}", self.analysis.sources.file(f).name),
                _ => String::new(),
            };
            let detail =
                if n_defs == 1 { format!("rule{from}") } else { format!("rule · {n_defs} definitions{from}") };
            // A rule with parameters is inserted with a placeholder per parameter
            // it needs (those without defaults).
            let sig = sym.signatures.get(full);
            let args: Vec<String> = sig
                .map(|s| {
                    s.params
                        .iter()
                        .take(s.required())
                        .enumerate()
                        .map(|(i, p)| format!("${{{}:{}}}", i + 1, p.name))
                        .collect()
                })
                .unwrap_or_default();
            let call = if args.is_empty() { label.clone() } else { format!("{label}({})", args.join(", ")) };
            let detail = match sig.filter(|s| !s.params.is_empty()) {
                Some(s) => format!("{} · {detail}", s.label(&label)),
                None => detail,
            };
            out.push(CompletionItem {
                insert_text: if call_braces { format!("{call} {{$0}}") } else { call.clone() },
                snippet: call_braces || !args.is_empty(),
                label,
                kind: CompletionKind::Rule,
                detail: Some(detail),
                documentation: None,
            });
        };
        if let Some(ns) = ns {
            let prefix = format!("{ns}.");
            for full in sym.rules.keys() {
                if let Some(short) = full.strip_prefix(&prefix) {
                    if !short.contains('.') {
                        push(short.to_string(), full);
                    }
                }
            }
        }
        for full in sym.rules.keys() {
            push(full.clone(), full);
        }
    }

    fn macro_names(&self) -> Vec<String> {
        let mut v: Vec<String> = self
            .index()
            .symbols
            .iter()
            .filter_map(|o| match &o.occ {
                Occ::Def(Symbol::Macro(m)) => Some(m.clone()),
                _ => None,
            })
            .collect();
        v.sort();
        v.dedup();
        v
    }
}

/// The span of the rule definition (in namespaces and `@ifdef` branches too) that
/// contains `offset`.
fn rule_around(items: &[crate::ast::Item], offset: u32) -> Option<Span> {
    use crate::ast::{ItemKind, Pre};
    for item in items {
        if !(item.span.start <= offset && offset <= item.span.end) {
            continue;
        }
        match &item.kind {
            ItemKind::Rule(_) => return Some(item.span),
            ItemKind::Namespace { items, .. } => return rule_around(items, offset),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                return rule_around(then, offset).or_else(|| otherwise.as_deref().and_then(|o| rule_around(o, offset)))
            }
            _ => {}
        }
    }
    None
}

fn builtin(kind: DocKind, name: &str, ckind: CompletionKind, insert: &str) -> CompletionItem {
    let doc = docs::lookup(kind, name);
    CompletionItem {
        label: name.to_string(),
        kind: ckind,
        detail: doc.map(|d| d.signature.to_string()),
        documentation: doc.map(|d| d.text.to_string()),
        insert_text: insert.to_string(),
        snippet: insert.contains('$'),
    }
}

fn snippet(label: &str, doc: &str, body: &str) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: CompletionKind::Snippet,
        detail: Some(doc.to_string()),
        documentation: None,
        insert_text: body.to_string(),
        snippet: true,
    }
}

fn directive_snippet(name: &str) -> String {
    match name {
        "rule" => "rule ${1:name} {\n\t$0\n}".to_string(),
        "startshape" | "linerule" | "camerarule" => format!("{name} ${{1:rule}}"),
        "selector" => "selector ${1:rule} ${2|random,frequency,depth,scale,sequential,pattern|}".to_string(),
        "namespace" => "namespace ${1:name} {\n\t$0\n}".to_string(),
        "function" => "function ${1:name} { ${0:x*x + y*y + z*z - 1} }".to_string(),
        "isosurface" => {
            "isosurface ${1:NAME} {\n\txyz ${2:-1.1} ${3:1.1} ${4:32} ;\n\tfunction { ${0:x*x + y*y + z*z - 1} }\n}"
                .to_string()
        }
        "program" => {
            "program {\n\tvertexshader ${1:vs}\n\tfragmentshader ${2:fs}\n\ttarget screen\n\trender\n}".to_string()
        }
        "angle" => "angle ${1|degrees,radians,orbits,arcdegrees,frequency|}".to_string(),
        "color" => "color ${1:R} ${2:G} ${3:B} ${4:A}".to_string(),
        "weight" => "weight ${1:u} ${2:v} ${3:w} ${4:q}".to_string(),
        "uniform" => "uniform ${1:name} ${2:0} ${3:0} ${4:0} ${5:1}".to_string(),
        "guide" | "search" | "creature" | "grid" => format!("{name} ${{1:name}} {{\n\t$0\n}}"),
        _ => match NUMERIC_DIRECTIVES.iter().find(|d| d.0 == name) {
            Some(&(_, lo, _, _)) => {
                let args: Vec<String> = (1..=lo).map(|i| format!("${{{i}:0}}")).collect();
                format!("{name} {}", args.join(" "))
            }
            None => name.to_string(),
        },
    }
}

/// The sections among `items`, in namespaces and `@ifdef` branches too.
fn sections_in<'a>(items: &'a [crate::ast::Item], out: &mut Vec<&'a crate::ast::Section>) {
    use crate::ast::{ItemKind, Pre};
    for item in items {
        match &item.kind {
            ItemKind::Section(sec) => out.push(sec),
            ItemKind::Namespace { items, .. } => sections_in(items, out),
            ItemKind::Pre(Pre::IfDef { then, otherwise, .. }) => {
                sections_in(then, out);
                if let Some(o) = otherwise {
                    sections_in(o, out);
                }
            }
            _ => {}
        }
    }
}

/// Whether some value of `entries` (nested blocks included) satisfies `f`.
fn entries_have(entries: &[crate::ast::Entry], f: &dyn Fn(&crate::ast::Value) -> bool) -> bool {
    entries.iter().any(|e| e.values.iter().any(f) || e.block.as_ref().is_some_and(|(inner, _)| entries_have(inner, f)))
}

/// `KEY ${1:VALUES};`, or `KEY ${1:VALUES} {↵ $0 ↵}` for a key that opens a block.
fn key_snippet(name: &str, values: &str, block: bool) -> String {
    let escaped = values.replace('\\', "\\\\").replace('$', "\\$").replace('}', "\\}");
    let head = if values.is_empty() { name.to_string() } else { format!("{name} ${{1:{escaped}}}") };
    if block {
        format!("{head} {{\n\t$0\n}}")
    } else {
        format!("{head};$0")
    }
}

fn preprocessor_snippet(name: &str) -> String {
    match name {
        "@import" => "@import ${1:primitives}",
        "@define" => "@define ${1:NAME}",
        "@ifdef" => "@ifdef ${1:NAME}\n$0\n@endif",
        "@macro" => "@macro ${1:NAME}(${2:a})\n$0\n@endmacro",
        "@expand" => "@expand ${1:NAME}($2)",
        "@param" => "@param ${1|int,float,bool|} ${2:name} ${3:1}",
        "@presets" => "@presets ${1:name}",
        "@vertexshader" => "@vertexshader ${1:name}\n#version 450\n$0\n@endshader",
        "@fragmentshader" => "@fragmentshader ${1:name}\n#version 450\n$0\n@endshader",
        other => other,
    }
    .to_string()
}

fn adjustment_snippet(name: &str, kind: Option<AdjKind>) -> String {
    match kind {
        Some(AdjKind::Flip(3)) => format!("{name} ${{1:1}} ${{2:0}} ${{3:0}}"),
        Some(AdjKind::Flip(_)) | Some(AdjKind::Turn(..)) => name.to_string(),
        Some(AdjKind::Rotate(_)) => format!("{name} ${{1:90}}"),
        Some(AdjKind::Scale) => format!("{name} ${{1:0.5}}"),
        Some(AdjKind::Skew) => format!("{name} ${{1:15}} ${{2:0}}"),
        Some(AdjKind::Color(_)) | Some(AdjKind::Weight(_)) => format!("{name} ${{1:-0.5}}"),
        _ => format!("{name} ${{1:1}}"),
    }
}

/// The palette's names, for a colour value being typed after its `#`.
fn palette_items() -> Vec<CompletionItem> {
    crate::colour::names()
        .map(|name| {
            let rgb = crate::colour::named(name).unwrap_or([0, 0, 0]);
            let hex = format!("#{:02x}{:02x}{:02x}", rgb[0], rgb[1], rgb[2]);
            CompletionItem {
                label: name.to_string(),
                kind: CompletionKind::Colour,
                documentation: Some(format!("`#{name}` = `{hex}`: sets the colour absolutely.")),
                detail: Some(hex),
                insert_text: name.to_string(),
                snippet: false,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;
    use super::*;

    fn labels(src: &str) -> Vec<String> {
        let (d, at) = doc(src);
        let config = CompletionConfig { std_libraries: vec!["lines".into(), "primitives".into()] };
        d.completion(at, &config).items.into_iter().map(|i| i.label).collect()
    }

    fn has(src: &str, want: &[&str]) {
        let got = labels(src);
        for w in want {
            assert!(got.iter().any(|g| g == w), "`{w}` missing from {got:?} for {src:?}");
        }
    }

    fn lacks(src: &str, unwanted: &[&str]) {
        let got = labels(src);
        for w in unwanted {
            assert!(!got.iter().any(|g| g == w), "`{w}` unexpected in {got:?} for {src:?}");
        }
    }

    #[test]
    fn parameters_and_locals_in_scope_are_offered() {
        let rules = "rule tree(int n, float len = 1) {\n  let half = len / 2;\n  $0\n  let later = 1;\n}\nrule other(int k) { VERTEX {} }";
        // In the body: control-flow snippets, the parameters and the earlier `let`.
        has(rules, &["if", "let", "loop", "n", "len", "half"]);
        lacks(rules, &["later", "k"]);
        // In an expression and after an adjustment (a bare name is its argument).
        has("rule tree(int n) { VERTEX {x (n$0)} }", &["n", "sin"]);
        has("rule tree(float len) { VERTEX {y $0} }", &["len", "rz"]);
        // Outside rules, none.
        lacks("rule tree(int n) { VERTEX {} }\nfunction f { $0 }", &["n"]);
    }

    #[test]
    fn rules_with_parameters_insert_their_required_arguments() {
        let (d, at) =
            doc("rule A {\n  $0\n}\nrule tree(int n, float len = 1) { VERTEX {x len} VERTEX {y n} VERTEX {} }");
        let config = CompletionConfig { std_libraries: vec![] };
        let items = d.completion(at, &config).items;
        let tree = items.iter().find(|i| i.label == "tree").expect("tree offered");
        assert_eq!(tree.insert_text, "tree(${1:n}) {$0}");
        assert!(tree.detail.as_deref().unwrap_or("").starts_with("tree(int n, float len = 1)"), "{:?}", tree.detail);
    }

    #[test]
    fn palette_names_after_a_hash_in_an_adjustment_list() {
        let (d, at) = doc("rule A { VERTEX {x 1 #tom$0} }");
        let c = d.completion(at, &CompletionConfig::default());
        assert_eq!(d.span_text(c.replace), "tom", "the word after `#` is replaced");
        let tomato = c.items.iter().find(|i| i.label == "tomato").expect("tomato offered");
        assert_eq!(tomato.insert_text, "tomato");
        assert_eq!(tomato.detail.as_deref(), Some("#ff6347"));
        assert_eq!(tomato.kind, CompletionKind::Colour);
        assert_eq!(c.items.len(), crate::colour::names().count(), "only palette names");
        has("rule A { VERTEX {#$0} }", &["black", "white", "rebeccapurple"]);
        lacks("rule A { VERTEX {#$0} }", &["rx", "R"]);
        // Not outside adjustment lists (a `#` there is no colour).
        lacks("rule A { #$0 }", &["tomato"]);
    }

    #[test]
    fn top_level_directives_and_preprocessor() {
        has("startshape A\nrule A { VERTEX {} }\nmax$0", &["maxdepth", "rule", "isosurface", "@import"]);
        lacks("startshape A\nrule A { VERTEX {} }\nmax$0", &["VERTEX", "rx", "A"]);
        has("@im$0", &["@import", "@macro"]);
    }

    #[test]
    fn rule_bodies_offer_rules_drawables_and_iterators() {
        let src = "isosurface BALL { xyz -1 1 8 ; function { x*x - 1 } }\nrule A {\n  VERTEX {}\n  $0\n}\nrule tree { VERTEX {} }";
        has(src, &["A", "tree", "VERTEX", "LINETO", "BALL", "iterator", "iterator with divisor"]);
        lacks(src, &["rx", "maxdepth"]);
        let (d, at) = doc("rule A { tr$0 }\nrule tree { VERTEX {} }");
        let c = d.completion(at, &CompletionConfig::default());
        assert_eq!(d.span_text(c.replace), "tr");
        let tree = c.items.iter().find(|i| i.label == "tree").expect("tree");
        assert_eq!((tree.insert_text.as_str(), tree.snippet), ("tree {$0}", true));
        let (d, at) = doc("rule A { tr$0 {x 1} }\nrule tree { VERTEX {} }");
        let c = d.completion(at, &CompletionConfig::default());
        let tree = c.items.iter().find(|i| i.label == "tree").expect("tree");
        assert_eq!(tree.insert_text, "tree");
    }

    #[test]
    fn adjustment_lists_offer_adjustments() {
        has("rule A { VERTEX {x 1 r$0} }", &["rx", "ry", "s", "fx", "R", "u"]);
        has("rule A { 4 * {$0} VERTEX {} }", &["rz"]);
        has("rule A { VERTEX [$0] }", &["rz"]);
        lacks("rule foo { VERTEX {x 1 $0} }", &["VERTEX", "foo"]);
        has("color red green blue alpha\nrule A { VERTEX {$0} }", &["green"]);
        let (d, at) = doc("rule A { VERTEX {r$0} }");
        let c = d.completion(at, &CompletionConfig::default());
        let rx = c.items.iter().find(|i| i.label == "rx").expect("rx");
        assert_eq!(rx.insert_text, "rx ${1:90}");
        assert_eq!(rx.detail.as_deref(), Some("rx A"));
    }

    #[test]
    fn namespaces_offer_short_names() {
        let src = "namespace n {\n  rule arm { VERTEX {} }\n  rule body { $0 }\n}\nrule top { VERTEX {} }";
        let got = labels(src);
        assert!(got.iter().any(|l| l == "arm"), "{got:?}");
        assert!(got.iter().any(|l| l == "n.arm"), "{got:?}");
        assert!(got.iter().any(|l| l == "top"), "{got:?}");
    }

    #[test]
    fn selectors_startshape_angle_and_profiles() {
        let rules = "\nrule A 1 { VERTEX {} }\nrule A 2 { VERTEX {} }\nfunction f { z }";
        has(&format!("selector A $0{rules}"), &["random", "depth", "function"]);
        lacks(&format!("selector A $0{rules}"), &["A"]);
        has(&format!("selector $0{rules}"), &["A"]);
        has(&format!("selector A function $0{rules}"), &["f"]);
        has(&format!("startshape $0{rules}"), &["A"]);
        has("angle $0", &["radians", "orbits"]);
        has("rule A { LINETO $0 {} }\nrule tube { VERTEX {} }", &["tube"]);
    }

    #[test]
    fn imports_offer_the_std_library() {
        assert_eq!(labels("@import $0"), ["lines", "primitives"]);
        assert_eq!(labels("@import lines pri$0"), ["lines", "primitives"]);
    }

    fn context_at(src: &str) -> Context {
        let (d, at) = doc(src);
        let (start, offset) = word_before(d.text(), at);
        d.context(start, offset)
    }

    fn section_key(path: &[&str]) -> Context {
        Context::SectionKey { path: path.iter().map(|s| s.to_string()).collect() }
    }

    #[test]
    fn section_contexts_follow_the_brackets() {
        assert_eq!(context_at("guide x {\n  $0\n}"), section_key(&["guide"]));
        assert_eq!(context_at("search {\n  zz 1;\n  sk$0"), section_key(&["search"]));
        assert_eq!(context_at("grid {\n  zz 1 { a; }\n  $0\n}"), section_key(&["grid"]));
        assert_eq!(
            context_at("creature m { part p { type t; slot s { at 0 0 1; } $0 } }"),
            section_key(&["creature", "part"])
        );
        assert_eq!(
            context_at("creature m { part p { slot s { at 0 0 (1 + 2); $0"),
            section_key(&["creature", "part", "slot"])
        );
        assert_eq!(context_at("creature m {\n  rule grow {\n    $0\n  }\n}"), section_key(&["creature", "rule"]));
        assert_eq!(context_at("namespace n {\n  guide g { $0 }\n}"), section_key(&["guide"]));
        // Values: rule names only where the section reads a rule name.
        assert_eq!(context_at("guide x { zz_no_such_key 0 $0 }"), Context::Nothing);
        assert_eq!(context_at("guide g { zz_file \"a$0b\"; }"), Context::Nothing);
        // Section words as names, and items after a section.
        assert_eq!(context_at("rule grid {\n  $0\n}"), Context::Body { ns: None, call_braces: true });
        assert_eq!(context_at("rule A : grid {\n  $0\n}"), Context::Body { ns: None, call_braces: true });
        assert_eq!(context_at("guide g { zz 1; }\nrule A { $0 }"), Context::Body { ns: None, call_braces: true });
        assert_eq!(context_at("guide g { zz 1; }\n$0"), Context::TopLevel);
    }

    #[test]
    fn section_entries_offer_their_keys_with_docs_and_snippets() {
        fn check(path: &mut Vec<&'static str>, depth: usize, n_paths: &mut usize) {
            let keys = crate::ext::keys(path);
            if keys.is_empty() || depth > 6 {
                return;
            }
            *n_paths += 1;
            // `KIND x { KEY n { … { $0 } } }` reaches the path.
            let mut src = format!("{} x {{ ", path[0]);
            for k in &path[1..] {
                src.push_str(&format!("{k} n {{ "));
            }
            src.push_str("zz 1;\n$0");
            let (d, at) = doc(&src);
            let items = d.completion(at, &CompletionConfig::default()).items;
            assert_eq!(items.len(), keys.len(), "{src}: {items:?}");
            for (item, k) in items.iter().zip(keys) {
                path.push(k.name);
                let block = !crate::ext::keys(path).is_empty();
                assert_eq!(item.label, k.name);
                assert_eq!(item.kind, CompletionKind::Key);
                assert_eq!(item.detail.as_deref(), Some(format!("{} {}", k.name, k.values).trim_end()));
                assert_eq!(item.documentation.as_deref(), Some(k.doc));
                assert_eq!((item.insert_text.clone(), item.snippet), (key_snippet(k.name, k.values, block), true));
                check(path, depth + 1, n_paths);
                path.pop();
            }
        }
        let mut n_paths = 0;
        for kind in crate::lexer::SECTION_KINDS {
            check(&mut vec![kind], 0, &mut n_paths);
        }
        let top = crate::lexer::SECTION_KINDS.iter().filter(|k| !crate::ext::keys(&[k]).is_empty()).count();
        assert!(n_paths >= top, "{n_paths} paths with keys");
    }

    #[test]
    fn key_snippets() {
        assert_eq!(key_snippet("delta_a", "OFFSET", false), "delta_a ${1:OFFSET};$0");
        assert_eq!(key_snippet("part", "NAME", true), "part ${1:NAME} {\n\t$0\n}");
        assert_eq!(key_snippet("evolve", "", true), "evolve {\n\t$0\n}");
        assert_eq!(key_snippet("wrap", "", false), "wrap;$0");
        assert_eq!(key_snippet("cost", "$X {a} \\", false), "cost ${1:\\$X {a\\} \\\\};$0");
    }

    #[test]
    fn section_kinds_at_the_top_level() {
        has("rule A { VERTEX {} }\ngu$0", &["guide", "search", "creature", "grid"]);
        let (d, at) = doc("rule A { VERTEX {} }\ncre$0");
        let c = d.completion(at, &CompletionConfig::default());
        let item = c.items.iter().find(|i| i.label == "creature").expect("creature");
        assert_eq!(item.insert_text, "creature ${1:name} {\n\t$0\n}");
        assert!(item.detail.as_deref().unwrap_or("").starts_with("creature [NAME] {"), "{item:?}");
        assert!(item.documentation.as_deref().unwrap_or("").contains("docs/creatures.md"), "{item:?}");
    }

    #[test]
    fn rule_names_where_the_section_reads_a_rule_name() {
        // For every key path, a word as the key's first value: rule names are offered
        // exactly where `ext::rule_refs` reads that word as a rule name.
        fn walk(path: &mut Vec<&'static str>, depth: usize, found: &mut usize, total: &mut usize) {
            for k in crate::ext::keys(path) {
                path.push(k.name);
                let mut src = format!("{} x {{ ", path[0]);
                for p in &path[1..path.len() - 1] {
                    src.push_str(&format!("{p} n {{ "));
                }
                src.push_str(&format!("{} le$0af;", k.name));
                src.push_str(&" }".repeat(path.len() - 1));
                src.push_str("\nrule leaf { VERTEX {} }\n");
                let (plain, _) = super::super::fixture::cursor(&src);
                let (d, _) = doc(&plain);
                let mut sections = Vec::new();
                sections_in(&d.analysis.expanded.main_ast.items, &mut sections);
                let is_rule = sections.iter().any(|s| crate::ext::rule_refs(s).iter().any(|n| n.text == "leaf"));
                let offered = labels(&src).iter().any(|l| l == "leaf");
                assert_eq!(offered, is_rule, "{src}");
                *found += is_rule as usize;
                *total += 1;
                if depth < 6 {
                    walk(path, depth + 1, found, total);
                }
                path.pop();
            }
        }
        let (mut found, mut total) = (0, 0);
        for kind in crate::lexer::SECTION_KINDS {
            walk(&mut vec![kind], 0, &mut found, &mut total);
        }
        eprintln!("{found} of {total} key positions take rule names");
        // Where a rule name is expected, the partial word is replaced.
        let (d, at) = doc("namespace n {\n  rule leaf { VERTEX {} }\n  search { skeleton le$0 }\n}");
        if crate::ext::rule_refs(&parse_section("search { skeleton leaf; }")).len() == 1 {
            let c = d.completion(at, &CompletionConfig::default());
            let got: Vec<&str> = c.items.iter().map(|i| i.label.as_str()).collect();
            assert!(got.contains(&"leaf") && got.contains(&"n.leaf"), "{got:?}");
            assert_eq!(d.span_text(c.replace), "le");
        }
    }

    fn parse_section(text: &str) -> crate::ast::Section {
        let (d, _) = doc(text);
        let mut sections = Vec::new();
        sections_in(&d.analysis.expanded.main_ast.items, &mut sections);
        sections.first().map(|s| (*s).clone()).expect("a section")
    }

    #[test]
    fn expressions_isosurfaces_programs_and_comments() {
        has("@param int n 4 1 9\nrule A { VERTEX {x ($0)} }", &["sin", "n"]);
        lacks("rule A { VERTEX {x ($0)} }", &["depth"]);
        has("function f { $0 }", &["sin", "x", "depth"]);
        has("isosurface S {\n  $0\n}", &["xyz", "function"]);
        has("@vertexshader vs\nx\n@endshader\nprogram { vertexshader $0 }", &["vs"]);
        assert!(labels("// rule A { $0").is_empty());
        assert!(labels("/* rule A { $0 */").is_empty());
    }
}
