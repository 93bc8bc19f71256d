//! Completion: what may be written at the cursor, with snippets.
//!
//! The context comes from the tokens before the cursor, not the tree, because the
//! text being typed rarely parses: brackets say whether the cursor is at the top
//! level, in a rule body, an adjustment list, an expression, an isosurface or a
//! program, and the previous token says what the statement expects next.

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

/// Where the cursor is, as far as completion cares.
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
    Nothing,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Frame {
    Namespace(String),
    Rule,
    Block,
    Adj,
    Expr { position_vars: bool },
    Iso,
    Program,
    Other,
}

fn is_word_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_' || c == '.' || c == '@'
}

impl Document {
    /// The completions at `offset`.
    pub fn completion(&self, offset: u32, config: &CompletionConfig) -> Completions {
        let text = self.text();
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
        let replace = Span::new(self.main_file(), start as u32, offset as u32);
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
        for (i, t) in before.iter().enumerate() {
            let top_level = matches!(stack.last(), None | Some(Frame::Namespace(_)));
            let prev = if i > 0 { Some(before[i - 1].kind) } else { None };
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
                            _ => Frame::Other,
                        },
                        Some(Frame::Rule) | Some(Frame::Block) => match prev {
                            Some(Tok::Ident) | Some(Tok::Dotted) | Some(Tok::Star) => Frame::Adj,
                            _ => Frame::Block,
                        },
                        Some(Frame::Iso) => Frame::Expr { position_vars: true },
                        Some(_) => Frame::Other,
                    };
                    stack.push(frame);
                    pending = None;
                }
                Tok::LBracket => stack.push(match stack.last() {
                    Some(Frame::Rule) | Some(Frame::Block) => Frame::Adj,
                    _ => Frame::Other,
                }),
                Tok::LParen | Tok::CallOpen => {
                    let position_vars = matches!(stack.last(), Some(Frame::Expr { position_vars: true }) | Some(Frame::Iso));
                    stack.push(Frame::Expr { position_vars });
                }
                Tok::RBrace | Tok::RBracket | Tok::RParen => {
                    stack.pop();
                    pending = None;
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
                    // `function` inside a selector line belongs to the selector.
                    if top_level && !(t.kind == Tok::KwFunction && pending.is_some_and(|p| before[p].kind == Tok::KwSelector)) =>
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
            Some(Frame::Other) => Context::Nothing,
        }
    }

    fn items_for(&self, context: &Context, config: &CompletionConfig, _offset: usize) -> Vec<CompletionItem> {
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
            }
            Context::Expression { position_vars } => {
                for (name, arity) in FUNCTIONS {
                    let args: Vec<String> = (1..=*arity).map(|i| format!("${i}")).collect();
                    out.push(builtin(
                        DocKind::Function,
                        name,
                        CompletionKind::Function,
                        &format!("{name}({})", args.join(", ")),
                    ));
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
            Context::Nothing => {}
        }
        out
    }

    /// Rules callable from namespace `ns`: that namespace's rules by their short
    /// names, then every rule by its full name.
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
            out.push(CompletionItem {
                insert_text: if call_braces { format!("{label} {{$0}}") } else { label.clone() },
                label,
                kind: CompletionKind::Rule,
                detail: Some(detail),
                documentation: None,
                snippet: call_braces,
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
        _ => match NUMERIC_DIRECTIVES.iter().find(|d| d.0 == name) {
            Some(&(_, lo, _, _)) => {
                let args: Vec<String> = (1..=lo).map(|i| format!("${{{i}:0}}")).collect();
                format!("{name} {}", args.join(" "))
            }
            None => name.to_string(),
        },
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
        Some(AdjKind::Color(_)) | Some(AdjKind::Weight(_)) => format!("{name} ${{1:-0.5}}"),
        _ => format!("{name} ${{1:1}}"),
    }
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
