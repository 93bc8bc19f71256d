//! Parsing: tokens to syntax tree, never failing.
//!
//! A pre-pass folds `@macro … @endmacro` and `@expand NAME(…)` into single tokens
//! (their contents are token lists, not syntax), then the LALRPOP parser builds the
//! tree with error recovery. Every problem becomes a [`Diagnostic`]; the tree is
//! always returned.

use crate::ast::*;
use crate::diag::{Capped, Diagnostic, Suppressed};
use crate::lexer::{self, Comment, Tok, Token};
use crate::source::Sources;
use crate::span::{loc, span_of, FileId, Loc, Span};
use lalrpop_util::{ErrorRecovery, ParseError};
use std::cell::RefCell;
use std::collections::HashMap;

mod reuse;

pub use reuse::{Memo, Previous, Reused, Shift};

#[allow(clippy::all, clippy::unwrap_used, unused_parens, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/grammar.rs"));
}

/// One parsed file: its tree, comments and diagnostics.
pub struct Parsed {
    pub file: File,
    pub comments: Vec<Comment>,
    pub diagnostics: Vec<Diagnostic>,
    /// Diagnostics not kept (past [`MAX_ERRORS`](crate::diag::MAX_ERRORS) per stage).
    pub suppressed: Suppressed,
}

/// The grammar's recovered syntax errors, converted as they come and kept up to
/// [`MAX_ERRORS`](crate::diag::MAX_ERRORS): LALRPOP's own record of an error (the
/// expected tokens, the dropped ones) is about 2 KB, so junk input kept them all
/// used to cost gigabytes.
pub struct Recovered<'r> {
    sources: &'r Sources,
    eof: Span,
    /// An unclosed bracket explains an end-of-file error.
    unclosed: bool,
    /// Syntax errors after a nesting cut come from the cut itself.
    cut: Option<Span>,
    /// (file, line) of each repaired bracket: it explains an error on its line.
    bracket_lines: Vec<(FileId, u32)>,
    /// The line of the last error taken (kept or counted): another on it is a cascade.
    last_line: Option<(FileId, u32)>,
    syntax: Capped,
}

impl Recovered<'_> {
    /// Takes one recovered error (called by the grammar's `!` actions).
    pub fn push(&mut self, e: ErrorRecovery<Loc, Tok, ()>) {
        let d = convert_error(e.error, self.sources, self.eof);
        self.take(d);
    }

    fn line(&self, s: Span) -> Option<(FileId, u32)> {
        self.sources.files.get(s.file.0 as usize).map(|f| (s.file, f.line_col(s.start).0))
    }

    fn take(&mut self, d: Option<Diagnostic>) {
        let Some(d) = d else { return };
        // One mistake, one error: an unclosed bracket explains any end-of-file error,
        // and a second error on the same line as the previous one is a cascade.
        if d.code == "E0104" && self.unclosed {
            return;
        }
        if self.cut.is_some_and(|c| d.span.file == c.file && d.span.start >= c.start) {
            return;
        }
        let line = self.line(d.span);
        if line.is_some() && line == self.last_line {
            return;
        }
        // A repaired bracket explains an error on its own line.
        if line.is_some_and(|l| self.bracket_lines.contains(&l)) {
            return;
        }
        self.last_line = line;
        self.syntax.push(d);
    }
}

/// What the grammar's actions read text and side tables through.
pub struct Ctx<'c> {
    sources: &'c Sources,
    macros: RefCell<HashMap<Loc, MacroDef>>,
    expands: RefCell<HashMap<Loc, (Name, Vec<MacroArg>)>>,
    diags: RefCell<Capped>,
    /// The adjustment names in force, with the colour and weight components the
    /// file renames (`color red green blue alpha`), for grouping adjustment lists.
    components: crate::adjust::Components,
}

impl<'c> Ctx<'c> {
    fn new(sources: &'c Sources, tokens: &[Token]) -> Ctx<'c> {
        let mut components = crate::adjust::Components::default();
        for (i, t) in tokens.iter().enumerate() {
            let words = || -> Option<[String; 4]> {
                let w: Vec<String> = tokens
                    .get(i + 1..i + 5)?
                    .iter()
                    .filter(|t| t.kind == Tok::Ident)
                    .map(|t| sources.text(t.span).to_string())
                    .collect();
                w.try_into().ok()
            };
            match t.kind {
                Tok::KwColor => components.color = words().unwrap_or(components.color),
                Tok::KwWeight => components.weight = words().unwrap_or(components.weight),
                _ => {}
            }
        }
        Ctx { sources, macros: RefCell::default(), expands: RefCell::default(), diags: RefCell::default(), components }
    }

    /// See [`group_adjustments`].
    pub fn group_adjustments(&self, words: Vec<AdjWord>) -> Vec<Adj> {
        group_adjustments(words, &self.components)
    }

    fn text(&self, l: Loc, r: Loc) -> &'c str {
        self.sources.text(span_of(l, r))
    }

    /// A name token.
    pub fn name(&self, l: Loc, r: Loc) -> Name {
        Name { text: self.text(l, r).to_string(), span: span_of(l, r) }
    }

    /// A string token `"…"`: its text without the quotes.
    pub fn string(&self, l: Loc, r: Loc) -> Value {
        let t = self.text(l, r);
        let inner = t.strip_prefix('"').and_then(|t| t.strip_suffix('"')).unwrap_or(t);
        Value::Str(inner.to_string(), span_of(l, r))
    }

    /// A call token `NAME(`: the name without the parenthesis.
    pub fn call_name(&self, l: Loc, r: Loc) -> Name {
        let t = self.text(l, r);
        let span = span_of(l, r);
        Name {
            text: t.trim_end_matches('(').to_string(),
            span: Span::new(span.file, span.start, span.end.saturating_sub(1)),
        }
    }

    /// A number token.
    pub fn number(&self, l: Loc, r: Loc) -> Number {
        let text = self.text(l, r);
        let (value, unit) = lexer::parse_number(text);
        Number { value, unit, text: text.to_string(), span: span_of(l, r) }
    }

    /// The words of a directive line after its `@word`, each with its span.
    fn words(&self, l: Loc, r: Loc) -> Vec<Name> {
        let span = span_of(l, r);
        let text = self.sources.text(span);
        let mut out = Vec::new();
        let mut pos = 0usize;
        for (i, w) in text.split_whitespace().enumerate() {
            let off = text[pos..].find(w).map(|o| o + pos).unwrap_or(pos);
            pos = off + w.len();
            if i == 0 {
                continue;
            }
            out.push(Name {
                text: w.to_string(),
                span: Span::new(span.file, span.start + off as u32, span.start + pos as u32),
            });
        }
        out
    }

    fn malformed(&self, l: Loc, r: Loc, msg: &str) {
        self.diags.borrow_mut().push(Diagnostic::error("E0209", span_of(l, r), msg.to_string()));
    }

    /// `@import a b`.
    pub fn import<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        let words = self.words(l, r);
        if words.is_empty() {
            self.malformed(l, r, "`@import` needs at least one library name or path");
            return Pre::Bad;
        }
        Pre::Import(words)
    }

    /// `@define NAME [NUMBER]`.
    pub fn define<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        let words = self.words(l, r);
        let valid_name = |w: &Name| {
            let mut c = w.text.chars();
            c.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && c.all(|c| c.is_ascii_alphanumeric() || c == '_')
        };
        match words.as_slice() {
            [name] if valid_name(name) => Pre::Define { name: name.clone(), value: None },
            [name, v] if valid_name(name) => match v.text.parse::<f64>() {
                Ok(value) => Pre::Define {
                    name: name.clone(),
                    value: Some(Number { value, unit: None, text: v.text.clone(), span: v.span }),
                },
                Err(_) => {
                    self.malformed(l, r, "`@define NAME [NUMBER]`: the value must be a number");
                    Pre::Bad
                }
            },
            _ => {
                self.malformed(l, r, "expected `@define NAME [NUMBER]`");
                Pre::Bad
            }
        }
    }

    /// `@param TYPE NAME DEFAULT [MIN MAX]`, validated by the expander.
    pub fn param<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        Pre::Param(self.words(l, r))
    }

    /// `@presets a b c`.
    pub fn presets<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        let words = self.words(l, r);
        if words.is_empty() {
            self.malformed(l, r, "`@presets` needs at least one preset name");
            return Pre::Bad;
        }
        Pre::Presets(words)
    }

    /// `@vertexshader NAME … @endshader`.
    pub fn shader<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        let span = span_of(l, r);
        let text = self.sources.text(span);
        let vertex = text.starts_with("@vertexshader");
        let head = if vertex { "@vertexshader" } else { "@fragmentshader" };
        let after = &text[head.len()..];
        let name_start = after.len() - after.trim_start().len();
        let name_len = after[name_start..].find(char::is_whitespace).unwrap_or(after.len() - name_start);
        let name_text = &after[name_start..name_start + name_len];
        let name_off = span.start + (head.len() + name_start) as u32;
        let code_start = head.len() + name_start + name_len;
        let code_end = text.len() - "@endshader".len().min(text.len());
        if name_text.is_empty() || name_text.starts_with("@endshader") || code_start > code_end {
            self.malformed(l, r, "a shader block needs a name: `@vertexshader NAME … @endshader`");
            return Pre::Bad;
        }
        Pre::Shader {
            vertex,
            name: Name {
                text: name_text.to_string(),
                span: Span::new(span.file, name_off, name_off + name_len as u32),
            },
            code: text[code_start..code_end].to_string(),
            code_span: Span::new(span.file, span.start + code_start as u32, span.start + code_end as u32),
        }
    }

    /// A macro definition folded by the pre-pass.
    pub fn macro_def<T>(&self, l: Loc) -> Pre<T> {
        match self.macros.borrow_mut().remove(&l) {
            Some(m) => Pre::Macro(m),
            None => Pre::Bad,
        }
    }

    /// An `@expand` folded by the pre-pass.
    pub fn expand<T>(&self, l: Loc) -> Pre<T> {
        match self.expands.borrow_mut().remove(&l) {
            Some((name, args)) => Pre::Expand { name, args },
            None => Pre::Bad,
        }
    }

    /// An unknown `@word`.
    pub fn unknown_directive<T>(&self, l: Loc, r: Loc) -> Pre<T> {
        let full = self.text(l, r);
        let text = full.split_whitespace().next().unwrap_or(full);
        let span = span_of(l, r);
        let span = Span::new(span.file, span.start, span.start + text.len() as u32);
        let mut d = Diagnostic::error("E0210", span, format!("unknown preprocessor directive `{text}`"));
        if let Some(s) = crate::diag::did_you_mean(text, lexer::PREPROCESSOR_DIRECTIVES.iter().copied()) {
            d = d.with_suggestion(format!("did you mean `{s}`?"), span, s);
        }
        self.diags.borrow_mut().push(d);
        Pre::Bad
    }
}

/// Folds `@macro … @endmacro` and `@expand NAME(…)` into single tokens and reports
/// stray closing directives.
fn prepass(tokens: Vec<Token>, sources: &Sources, ctx: &Ctx) -> Vec<Token> {
    let mut out = Vec::with_capacity(tokens.len());
    let mut i = 0;
    let mut open_ifdefs: Vec<Token> = Vec::new();
    let text = |t: &Token| sources.text(t.span);
    while i < tokens.len() {
        let t = tokens[i];
        match t.kind {
            Tok::AtMacro => {
                // Header: `@macro NAME(a, b)` or `@macro NAME`.
                let mut j = i + 1;
                let mut params = Vec::new();
                let name = match tokens.get(j) {
                    Some(n) if n.kind == Tok::CallOpen => {
                        j += 1;
                        while let Some(p) = tokens.get(j) {
                            match p.kind {
                                Tok::Ident => params.push(Name { text: text(p).to_string(), span: p.span }),
                                Tok::Comma => {}
                                Tok::RParen => {
                                    j += 1;
                                    break;
                                }
                                _ => break,
                            }
                            j += 1;
                        }
                        let s = n.span;
                        Some(Name {
                            text: text(n).trim_end_matches('(').to_string(),
                            span: Span::new(s.file, s.start, s.end - 1),
                        })
                    }
                    Some(n) if n.kind == Tok::Ident => {
                        j += 1;
                        Some(Name { text: text(n).to_string(), span: n.span })
                    }
                    _ => None,
                };
                let Some(name) = name else {
                    ctx.diags.borrow_mut().push(Diagnostic::error(
                        "E0209",
                        t.span,
                        "expected a macro name: `@macro NAME(a, b) … @endmacro`",
                    ));
                    i += 1;
                    continue;
                };
                let body_start = j;
                while j < tokens.len() && tokens[j].kind != Tok::AtEndmacro {
                    j += 1;
                }
                if j >= tokens.len() {
                    ctx.diags.borrow_mut().push(
                        Diagnostic::error("E0206", t.span, format!("macro `{}` has no `@endmacro`", name.text))
                            .with_label("this macro is never closed"),
                    );
                    break;
                }
                let body: Vec<Token> = tokens[body_start..j].to_vec();
                let head_end = tokens[body_start - 1].span.end;
                let body_span = Span::new(t.span.file, head_end, tokens[j].span.start);
                let span = t.span.to(tokens[j].span);
                ctx.macros.borrow_mut().insert(loc(span.file, span.start), MacroDef { name, params, body, body_span });
                out.push(Token { kind: Tok::MacroDef, span });
                i = j + 1;
            }
            Tok::AtExpand => {
                let Some(n) = tokens.get(i + 1).filter(|n| matches!(n.kind, Tok::CallOpen | Tok::Ident)) else {
                    ctx.diags.borrow_mut().push(Diagnostic::error(
                        "E0209",
                        t.span,
                        "expected `@expand NAME(arguments)`",
                    ));
                    i += 1;
                    continue;
                };
                let mut j = i + 2;
                let mut args = Vec::new();
                let mut end = n.span;
                if n.kind == Tok::CallOpen {
                    let mut depth = 0i32;
                    let mut cur: Vec<Token> = Vec::new();
                    let mut closed = false;
                    while let Some(a) = tokens.get(j) {
                        j += 1;
                        match a.kind {
                            Tok::LParen | Tok::LBrace | Tok::LBracket | Tok::IndexOpen | Tok::CallOpen => depth += 1,
                            Tok::RBrace | Tok::RBracket => depth -= 1,
                            Tok::RParen if depth == 0 => {
                                end = a.span;
                                closed = true;
                                break;
                            }
                            Tok::RParen => depth -= 1,
                            Tok::Comma if depth == 0 => {
                                args.push(arg_of(std::mem::take(&mut cur)));
                                continue;
                            }
                            _ => {}
                        }
                        cur.push(*a);
                    }
                    if !closed {
                        ctx.diags.borrow_mut().push(
                            Diagnostic::error("E0104", n.span, "unexpected end of file")
                                .with_label("the arguments of this `@expand` are never closed; expected `)`"),
                        );
                    }
                    if !cur.is_empty() || !args.is_empty() {
                        args.push(arg_of(cur));
                    }
                }
                let name_text = text(n).trim_end_matches('(').to_string();
                let name_span = Span::new(n.span.file, n.span.start, n.span.start + name_text.len() as u32);
                let span = t.span.to(end);
                ctx.expands
                    .borrow_mut()
                    .insert(loc(span.file, span.start), (Name { text: name_text, span: name_span }, args));
                out.push(Token { kind: Tok::Expand, span });
                i = j;
            }
            Tok::AtIfdef => {
                open_ifdefs.push(t);
                out.push(t);
                i += 1;
            }
            Tok::AtElse | Tok::AtEndif if open_ifdefs.is_empty() => {
                ctx.diags.borrow_mut().push(
                    Diagnostic::error("E0207", t.span, format!("`{}` without a matching `@ifdef`", text(&t)))
                        .with_label("no `@ifdef` is open here"),
                );
                i += 1;
            }
            Tok::AtEndif => {
                open_ifdefs.pop();
                out.push(t);
                i += 1;
            }
            Tok::AtEndmacro | Tok::AtEndshader => {
                ctx.diags.borrow_mut().push(Diagnostic::error(
                    "E0207",
                    t.span,
                    format!("`{}` without a matching opening directive", text(&t)),
                ));
                i += 1;
            }
            _ => {
                out.push(t);
                i += 1;
            }
        }
    }
    // An `@ifdef` never closed: report it and close it at the end so the rest parses.
    for open in open_ifdefs.iter().rev() {
        ctx.diags.borrow_mut().push(
            Diagnostic::error("E0206", open.span, "`@ifdef` has no `@endif`")
                .with_label("this conditional is never closed"),
        );
        // (In a macro expansion the last token may come from another file: the macro's.)
        let end = out
            .last()
            .filter(|t| t.span.file == open.span.file)
            .map_or(open.span.end, |t| t.span.end.max(open.span.end));
        out.push(Token { kind: Tok::AtEndif, span: Span::new(open.span.file, end, end) });
    }
    out
}

fn arg_of(tokens: Vec<Token>) -> MacroArg {
    let span = match (tokens.first(), tokens.last()) {
        (Some(a), Some(b)) => a.span.to(b.span),
        _ => Span::default(),
    };
    MacroArg { tokens, span }
}

/// How deeply a file (or one macro expansion, with the nesting around it) may nest:
/// brackets, `@ifdef` blocks and operators (each operator may add a level to an
/// expression or iterator chain). Deeper input is cut with E0105, so no compiler pass
/// that walks the tree recursively can overflow its stack (2 MiB threads included).
pub const MAX_NESTING: usize = 256;

use crate::source::MAX_SOURCE_BYTES;

/// One open bracket (or `@ifdef`) during the nesting scan.
struct Level {
    /// The closer that ends this level: `}`, `]`, `)` or `@endif`.
    closer: Tok,
    /// Operators seen at this level since the last finished item.
    ops: usize,
    /// Whether the bracket follows `*` (an iterator's adjustments: its item comes next,
    /// one level deeper).
    after_star: bool,
    /// Whether the opener was dropped (so its closer is dropped too).
    dropped: bool,
}

/// Cuts whatever nests deeper than `budget` (see [`MAX_NESTING`]): the token that
/// crosses it and everything up to the end of its level are dropped, with one E0105.
/// Returns the kept tokens and the offset where cutting started (if it did).
fn limit_nesting(tokens: Vec<Token>, budget: usize, diags: &mut Vec<Diagnostic>) -> (Vec<Token>, Option<Span>) {
    let mut levels: Vec<Level> = Vec::new();
    let mut depth = 0usize; // levels.len() + the operators counted on them
    let mut skip_below: Option<usize> = None; // dropping while levels.len() > this
    let mut first: Option<Span> = None;
    let mut out = Vec::with_capacity(tokens.len());
    let mut prev = Tok::Semi;
    // Inside a `loop` header: its adjustment list, like an iterator's after `*`, does
    // not end the item (a chain of loops nests like a chain of iterators).
    let mut loop_header = false;
    for t in tokens {
        let closer = match t.kind {
            Tok::LBrace => Some(Tok::RBrace),
            Tok::LBracket | Tok::IndexOpen => Some(Tok::RBracket),
            Tok::LParen | Tok::CallOpen => Some(Tok::RParen),
            Tok::AtIfdef => Some(Tok::AtEndif),
            _ => None,
        };
        let is_op = matches!(
            t.kind,
            Tok::Plus
                | Tok::Minus
                | Tok::Star
                | Tok::Slash
                | Tok::Caret
                | Tok::Lt
                | Tok::Le
                | Tok::Gt
                | Tok::Ge
                | Tok::EqEq
                | Tok::Ne
                | Tok::KwLoop
        );
        if t.kind == Tok::KwLoop {
            loop_header = true;
        }
        let mut keep = skip_below.is_none();
        if let Some(c) = closer {
            let over = keep && depth + 1 > budget;
            let after_header = loop_header && c != Tok::RParen;
            if after_header {
                loop_header = false;
            }
            levels.push(Level {
                closer: c,
                ops: 0,
                after_star: prev == Tok::Star || after_header,
                dropped: over || !keep,
            });
            depth += 1;
            if over {
                skip_below = Some(levels.len() - 1);
                keep = false;
            }
        } else if matches!(t.kind, Tok::RBrace | Tok::RBracket | Tok::RParen | Tok::AtEndif) {
            // Pop back to the matching level (a closer with no opener is the parser's business).
            if let Some(pos) = levels.iter().rposition(|l| l.closer == t.kind) {
                let level = &levels[pos];
                let (dropped, finishes_item) = (level.dropped, !level.after_star && t.kind != Tok::RParen);
                for l in levels.drain(pos..) {
                    depth -= 1 + l.ops;
                }
                if skip_below.is_some_and(|s| levels.len() <= s) {
                    skip_below = None;
                }
                keep = !dropped && skip_below.is_none();
                // A finished call, block or list ends the item: operators before it no
                // longer nest what follows.
                if finishes_item {
                    if let Some(l) = levels.last_mut() {
                        depth -= l.ops;
                        l.ops = 0;
                    }
                }
            }
        } else if t.kind == Tok::Semi {
            if let Some(l) = levels.last_mut() {
                depth -= l.ops;
                l.ops = 0;
            }
        } else if is_op && keep {
            // Operators at the top level (outside any bracket) nest nothing.
            if let Some(l) = levels.last_mut() {
                if depth + 1 > budget {
                    skip_below = Some(levels.len() - 1);
                    keep = false;
                } else {
                    l.ops += 1;
                    depth += 1;
                }
            }
        }
        if !keep && first.is_none() {
            first = Some(t.span);
            diags.push(
                Diagnostic::error("E0105", t.span, format!("nesting too deep: more than {budget} levels"))
                    .with_label("the limit is reached here; the rest of this level is skipped")
                    .with_note(format!(
                        "brackets, `@ifdef` blocks, operators in one expression or iterator chain, and the macro \
                         expansions around them count as levels (at most {MAX_NESTING}); split the rule or expression"
                    )),
            );
        }
        if keep {
            out.push(t);
        }
        prev = t.kind;
    }
    (out, first)
}

/// The closer that ends an opener, or `None` for a token that opens nothing.
fn closer_of(t: Tok) -> Option<Tok> {
    match t {
        Tok::LBrace => Some(Tok::RBrace),
        Tok::LBracket | Tok::IndexOpen => Some(Tok::RBracket),
        Tok::LParen | Tok::CallOpen => Some(Tok::RParen),
        _ => None,
    }
}

fn closer_text(t: Tok) -> &'static str {
    match t {
        Tok::RBrace => "}",
        Tok::RBracket => "]",
        _ => ")",
    }
}

/// One open bracket during [`balance`].
#[derive(Clone, Copy)]
struct Open {
    tok: Token,
    closer: Tok,
    /// The `{` of a top-level `rule`'s body.
    rule_body: bool,
}

/// The span of an opener's bracket itself (a `NAME(` call token ends with it).
fn bracket_span(t: &Token) -> Span {
    Span::new(t.span.file, t.span.end.saturating_sub(1), t.span.end)
}

/// How many repairs the rest of `tokens` would need with `stack` open, substituting
/// every mismatched closer (the cheap model [`balance`] uses to choose a repair).
fn repairs_after(tokens: &[Token], stack: &[Tok]) -> usize {
    let mut stack = stack.to_vec();
    let mut n = 0;
    for t in tokens {
        if let Some(c) = closer_of(t.kind) {
            stack.push(c);
        } else if matches!(t.kind, Tok::RBrace | Tok::RBracket | Tok::RParen) {
            match stack.pop() {
                Some(c) if c == t.kind => {}
                Some(_) => n += 1,
                None => {}
            }
        }
    }
    n + usize::from(!stack.is_empty())
}

/// Repairs mismatched and unclosed brackets before parsing, one error each, the way
/// rustc does: a closer that does not match the innermost open bracket is reported
/// once ("mismatched closing delimiter", with the opener as a secondary label) and
/// treated as the closer that was meant, so the rest of the file parses normally.
/// Which closer was meant is decided by what the rest of the input needs: the
/// innermost bracket's (a typo, `B{x 2 ]`), or an outer one's when that leaves fewer
/// repairs for the rest (a forgotten closer, `rule A { B{x 2 }` … `}`): the missing
/// closers are inserted before it. A top-level `rule` at the start of a line, not
/// indented more than the line that opened a still-open rule body, ends that body (a
/// forgotten `}`), and brackets still open at the end of input are closed there; each
/// is one E0104. Closers with no opener at all are left to the parser.
fn balance(tokens: Vec<Token>, sources: &Sources) -> (Vec<Token>, Capped) {
    let mut out: Vec<Token> = Vec::with_capacity(tokens.len());
    let mut diags = Capped::default();
    let mut stack: Vec<Open> = Vec::new();
    let mut top_rule = false;
    let mut lookaheads = 0usize;
    let line_start_col = |span: Span| -> Option<(usize, usize)> {
        // (line, indentation of that line) of an offset, when `span` starts its line.
        let f = sources.files.get(span.file.0 as usize)?;
        let text = &f.text;
        let start = span.start as usize;
        let ls = text[..start.min(text.len())].rfind(['\n', '\r']).map_or(0, |i| i + 1);
        Some((ls, start - ls))
    };
    let indent_of = |span: Span| -> Option<usize> {
        let f = sources.files.get(span.file.0 as usize)?;
        let text = &f.text;
        let start = (span.start as usize).min(text.len());
        let ls = text[..start].rfind(['\n', '\r']).map_or(0, |i| i + 1);
        Some(text[ls..].len() - text[ls..].trim_start_matches([' ', '\t']).len())
    };
    let first_on_line = |t: &Token| -> Option<usize> {
        let (ls, col) = line_start_col(t.span)?;
        let f = sources.files.get(t.span.file.0 as usize)?;
        f.text[ls..t.span.start as usize].trim().is_empty().then_some(col)
    };
    let close_all = |stack: &mut Vec<Open>, out: &mut Vec<Token>, at: u32, file: FileId| {
        while let Some(o) = stack.pop() {
            out.push(Token { kind: o.closer, span: Span::new(file, at, at) });
        }
    };
    for (i, t) in tokens.iter().enumerate() {
        let t = *t;
        if t.kind == Tok::KwRule && stack.first().is_some_and(|o| o.rule_body) {
            let body = stack[0];
            let ends_body = body.tok.span.file == t.span.file
                && first_on_line(&t).zip(indent_of(body.tok.span)).is_some_and(|(col, ind)| col <= ind);
            if ends_body {
                let open = stack.last().copied().unwrap_or(body);
                diags.push(
                    Diagnostic::error("E0104", bracket_span(&open.tok), "unclosed delimiter")
                        .with_label(format!("this is never closed; expected `{}`", closer_text(open.closer)))
                        .with_secondary(t.span, "the next rule starts here"),
                );
                let at =
                    out.last()
                        .map_or(t.span.start, |p| if p.span.file == t.span.file { p.span.end } else { t.span.start });
                close_all(&mut stack, &mut out, at, t.span.file);
            }
        }
        if let Some(c) = closer_of(t.kind) {
            stack.push(Open { tok: t, closer: c, rule_body: stack.is_empty() && top_rule && t.kind == Tok::LBrace });
            out.push(t);
            continue;
        }
        if stack.is_empty() {
            match t.kind {
                Tok::KwRule => top_rule = true,
                // Another top-level item: a `{` after it is not a rule body.
                Tok::KwStartshape
                | Tok::KwSelector
                | Tok::KwLinerule
                | Tok::KwCamerarule
                | Tok::KwNamespace
                | Tok::KwFunction
                | Tok::KwIsosurface
                | Tok::KwProgram
                | Tok::KwUniform
                | Tok::KwSection => top_rule = false,
                _ => {}
            }
        }
        if !matches!(t.kind, Tok::RBrace | Tok::RBracket | Tok::RParen) {
            out.push(t);
            continue;
        }
        let Some(top) = stack.last().copied() else {
            out.push(t);
            continue;
        };
        if top.closer == t.kind {
            stack.pop();
            if stack.is_empty() {
                top_rule = false;
            }
            out.push(t);
            continue;
        }
        // A mismatched closer: a typo for the innermost closer, or the closer of an
        // outer bracket after forgotten inner ones.
        let outer = stack.iter().rposition(|o| o.closer == t.kind);
        let use_outer = outer.is_some_and(|pos| {
            lookaheads += 1;
            if lookaheads > 64 {
                return false;
            }
            let rest = &tokens[i + 1..];
            let kinds: Vec<Tok> = stack.iter().map(|o| o.closer).collect();
            let typo = repairs_after(rest, &kinds[..kinds.len() - 1]);
            let forgot = repairs_after(rest, &kinds[..pos]);
            forgot < typo
        });
        diags.push(
            Diagnostic::error("E0106", t.span, format!("mismatched closing delimiter: `{}`", closer_text(t.kind)))
                .with_label("mismatched closing delimiter")
                .with_secondary(
                    bracket_span(&top.tok),
                    if use_outer {
                        format!("this is never closed; expected `{}`", closer_text(top.closer))
                    } else {
                        format!(
                            "unclosed delimiter; `{}` is read as the `{}` it needs",
                            closer_text(t.kind),
                            closer_text(top.closer)
                        )
                    },
                ),
        );
        match (use_outer, outer) {
            (true, Some(pos)) => {
                while stack.len() > pos + 1 {
                    if let Some(o) = stack.pop() {
                        out.push(Token { kind: o.closer, span: Span::new(t.span.file, t.span.start, t.span.start) });
                    }
                }
                stack.pop();
                out.push(t);
            }
            _ => {
                stack.pop();
                out.push(Token { kind: top.closer, span: t.span });
            }
        }
        if stack.is_empty() {
            top_rule = false;
        }
    }
    if let Some(open) = stack.first().copied() {
        diags.push(
            Diagnostic::error("E0104", bracket_span(&open.tok), "unexpected end of file")
                .with_label(format!("this is never closed; expected `{}`", closer_text(open.closer))),
        );
        let (file, at) = match out.last() {
            Some(p) => (p.span.file, p.span.end),
            None => (open.tok.span.file, open.tok.span.end),
        };
        close_all(&mut stack, &mut out, at, file);
    }
    (out, diags)
}

fn describe_expected(expected: &[String]) -> String {
    let mut names: Vec<String> = expected
        .iter()
        .map(|e| match e.as_str() {
            "Ident" => "a name".to_string(),
            "Dotted" => "a name".to_string(),
            "SectionKw" => "`guide`".to_string(),
            "Str" => "a string".to_string(),
            "Num" => "a number".to_string(),
            "CallOpen" => "a call".to_string(),
            "Shader" => "a shader block".to_string(),
            "MacroDef" => "`@macro`".to_string(),
            "Expand" => "`@expand`".to_string(),
            s if s.starts_with("At") => format!("`@{}`", s[2..].to_lowercase()),
            s => format!("`{}`", s.trim_matches('"').replace("\\\\", "\\")),
        })
        .collect();
    names.sort();
    names.dedup();
    let has = |n: &str| names.iter().any(|x| x == n);
    // Keywords double as names, so "a name" often comes with every keyword.
    let keyword =
        |n: &String| n.len() > 2 && n.starts_with('`') && n[1..n.len() - 1].chars().all(|c| c.is_ascii_lowercase());
    if has("a name") && names.iter().all(|n| n == "a name" || keyword(n)) {
        return "a name".to_string();
    }
    // After a `switch` arm's label: the `:` is what is usually missing.
    if has("`:`") && has("`..`") {
        return "`:` after the labels (or `,`, `..`, an operator)".to_string();
    }
    // Long lists are summarised by the context they reveal.
    if names.len() > 6 {
        if has("`function`") && has("`rule`") {
            return "a directive, `rule` or another item".to_string();
        }
        if has("`{`") && has("`[`") && !has("a number") && !has("`}`") {
            return "`{` or `[` (an adjustment list)".to_string();
        }
        if has("`*`") || (has("`{`") && has("a number")) {
            return "a rule call, an iterator, a block or `}`".to_string();
        }
        if has("`(`") && has("a number") {
            return "an expression".to_string();
        }
        names.truncate(6);
        names.push("…".to_string());
    }
    names.join(", ")
}

fn convert_error(e: ParseError<Loc, Tok, ()>, sources: &Sources, eof: Span) -> Option<Diagnostic> {
    match e {
        ParseError::UnrecognizedToken { token: (l, tok, r), expected } => {
            let span = span_of(l, r);
            let shown = sources.text(span);
            let what = match tok {
                Tok::Ident | Tok::Dotted | Tok::Number => format!("`{shown}`"),
                Tok::MacroDef | Tok::Shader => tok.describe().to_string(),
                _ => tok.describe().to_string(),
            };
            Some(
                Diagnostic::error("E0101", span, format!("unexpected {what}"))
                    .with_label(format!("expected {}", describe_expected(&expected))),
            )
        }
        ParseError::ExtraToken { token: (l, tok, r) } => {
            Some(Diagnostic::error("E0101", span_of(l, r), format!("unexpected {}", tok.describe())))
        }
        ParseError::UnrecognizedEof { expected, .. } => Some(
            Diagnostic::error("E0104", eof, "unexpected end of file")
                .with_label(format!("expected {}", describe_expected(&expected))),
        ),
        ParseError::InvalidToken { location } => {
            Some(Diagnostic::error("E0103", span_of(location, location), "invalid token"))
        }
        ParseError::User { .. } => None,
    }
}

/// Which start symbol to parse with.
#[derive(Clone, Copy)]
enum Start {
    File,
    Items,
    BodyItems,
}

enum Out {
    File(File),
    Items(Vec<Item>),
    Body(Vec<BodyItem>),
}

/// A token stream made ready for the parser: macros folded, brackets balanced,
/// nesting limited; what the parser's error handling needs to know of it.
struct Prepared<'c> {
    ctx: Ctx<'c>,
    tokens: Vec<Token>,
    /// The diagnostics given in (the lexer's), with the nesting cut's.
    diags: Vec<Diagnostic>,
    /// How many of `ctx.diags` the pre-pass gave (the parser's actions add the rest).
    prepass_diags: usize,
    bracket: Capped,
    unclosed: bool,
    cut: Option<Span>,
    eof: Span,
}

fn prepare<'c>(
    tokens: Vec<Token>,
    sources: &'c Sources,
    file: FileId,
    mut diags: Vec<Diagnostic>,
    budget: usize,
) -> Prepared<'c> {
    let ctx = Ctx::new(sources, &tokens);
    let tokens = prepass(tokens, sources, &ctx);
    let prepass_diags = ctx.diags.borrow().list.len();
    let (tokens, bracket) = balance(tokens, sources);
    let unclosed = bracket.list.iter().any(|d| d.code == "E0104");
    let (tokens, cut) = limit_nesting(tokens, budget, &mut diags);
    let eof = match tokens.last() {
        Some(t) => Span::new(t.span.file, t.span.end, t.span.end),
        None => {
            let len = sources.files.get(file.0 as usize).map(|f| f.text.len() as u32).unwrap_or(0);
            Span::new(file, len, len)
        }
    };
    Prepared { ctx, tokens, diags, prepass_diags, bracket, unclosed, cut, eof }
}

/// Parses `tokens` (all of `p.tokens`, or a run of whole top-level items of them)
/// from `start`; the syntax errors, kept up to the limit.
fn parse_prepared(p: &Prepared, sources: &Sources, tokens: &[Token], start: Start) -> (Out, Capped) {
    let stream = tokens.iter().map(|t| Ok((loc(t.span.file, t.span.start), t.kind, loc(t.span.file, t.span.end))));
    let mut errors = Recovered {
        sources,
        eof: p.eof,
        unclosed: p.unclosed,
        cut: p.cut,
        bracket_lines: Vec::new(),
        last_line: None,
        syntax: Capped::default(),
    };
    errors.bracket_lines = p.bracket.list.iter().filter_map(|b| errors.line(b.span)).collect();
    let ctx = &p.ctx;
    let result = match start {
        Start::File => generated::FileParser::new().parse(ctx, &mut errors, stream).map(Out::File),
        Start::Items => generated::ItemsParser::new().parse(ctx, &mut errors, stream).map(Out::Items),
        Start::BodyItems => generated::BodyItemsParser::new().parse(ctx, &mut errors, stream).map(Out::Body),
    };
    let out = match result {
        Ok(out) => out,
        Err(e) => {
            let d = convert_error(e, sources, p.eof);
            errors.take(d);
            match start {
                Start::File => Out::File(File::default()),
                Start::Items => Out::Items(vec![]),
                Start::BodyItems => Out::Body(vec![]),
            }
        }
    };
    (out, errors.syntax)
}

/// The diagnostics of a parse, in the order a whole parse gives them: those given in
/// and the nesting cut's, the pre-pass's and the actions', the brackets', the syntax
/// errors.
fn parse_diagnostics(p: Prepared, syntax: Capped) -> (Vec<Diagnostic>, Suppressed) {
    let own = p.ctx.diags.take();
    let mut diags = p.diags;
    diags.extend(own.list);
    let suppressed = own.suppressed + p.bracket.suppressed + syntax.suppressed;
    diags.extend(p.bracket.list);
    diags.extend(syntax.list);
    (diags, suppressed)
}

fn run(
    tokens: Vec<Token>,
    sources: &Sources,
    file: FileId,
    start: Start,
    diags: Vec<Diagnostic>,
    budget: usize,
) -> (Out, Vec<Diagnostic>, Suppressed) {
    let mut p = prepare(tokens, sources, file, diags, budget);
    let tokens = std::mem::take(&mut p.tokens);
    let (out, syntax) = parse_prepared(&p, sources, &tokens, start);
    let (diags, suppressed) = parse_diagnostics(p, syntax);
    (out, diags, suppressed)
}

/// Parses one whole file that is already in `sources`.
pub fn parse_file(sources: &Sources, file: FileId) -> Parsed {
    match lex_file(sources, file, None) {
        Err(too_large) => too_large,
        Ok((tokens, lexed, _)) => {
            let (out, diagnostics, suppressed) =
                run(tokens, sources, file, Start::File, lexed.diagnostics, MAX_NESTING);
            let file_ast = match out {
                Out::File(f) => f,
                _ => File::default(),
            };
            Parsed { file: file_ast, comments: lexed.comments, diagnostics, suppressed: suppressed + lexed.suppressed }
        }
    }
}

/// [`parse_file`] for a file parsed again after an edit: the top-level items that
/// `prev` (the previous parse of the same file) parsed in text the edit left alone are
/// taken from it instead of being parsed again ([`reuse`]), and the text before the
/// edit and after it is not lexed again ([`lexer::relex`]). The result is what
/// [`parse_file`] gives; with it, what the next parse can reuse, and how much was.
pub fn parse_file_reusing(sources: &Sources, file: FileId, prev: Option<Previous>) -> (Parsed, Memo, Reused) {
    let before = prev.and_then(|p| Some((p.text, p.memo.lexed.as_ref()?)));
    let (tokens, lexed, raw) = match lex_file(sources, file, Some(before)) {
        Err(too_large) => return (too_large, Memo::default(), Reused::default()),
        Ok(l) => l,
    };
    let mut p = prepare(tokens, sources, file, lexed.diagnostics, MAX_NESTING);
    let (items, syntax, mut memo, reused) = match prev.and_then(|prev| reuse::reparse(&mut p, sources, file, prev)) {
        Some(r) => r,
        None => {
            let (items, syntax, memo) = reuse::whole(&mut p, sources, file);
            let parsed = items.len();
            (items, syntax, memo, Reused { items: 0, parsed, ..Reused::default() })
        }
    };
    memo.tokens = std::mem::take(&mut p.tokens);
    memo.lexed = raw;
    let (diagnostics, suppressed) = parse_diagnostics(p, syntax);
    let parsed = Parsed {
        file: File { items },
        comments: lexed.comments,
        diagnostics,
        suppressed: suppressed + lexed.suppressed,
    };
    (parsed, memo, reused)
}

/// The tokens of a file (Context Free's constructs rewritten) and what lexing gave;
/// `Err` with the whole parse of a file too large to read. With `keep`, the lexing
/// is also returned as the lexer gave it (for the next version's [`lexer::relex`]),
/// from `keep`'s previous version's text and lexing where there is one.
#[allow(clippy::type_complexity)]
fn lex_file(
    sources: &Sources,
    file: FileId,
    keep: Option<Option<(&str, &lexer::Lexed)>>,
) -> Result<(Vec<Token>, lexer::Lexed, Option<lexer::Lexed>), Parsed> {
    let text = &sources.file(file).text;
    if text.len() > MAX_SOURCE_BYTES {
        // The same error as for a file the loader refuses to read (`FsLoader`).
        let d = Diagnostic::error(
            "E0201",
            Span::new(file, 0, 0),
            format!(
                "cannot read `{}`: source file too large: {} bytes (at most {MAX_SOURCE_BYTES})",
                sources.file(file).name,
                text.len()
            ),
        )
        .with_note("split the grammar into files joined with `@import`");
        return Err(Parsed {
            file: File::default(),
            comments: Vec::new(),
            diagnostics: vec![d],
            suppressed: Suppressed::default(),
        });
    }
    let (mut lexed, raw) = match keep {
        None => (lexer::lex(text, file), None),
        Some(before) => {
            let lexed = match before {
                Some((old_text, old)) => lexer::relex(old_text, old, text, file),
                None => lexer::lex(text, file),
            };
            let raw = lexed.clone();
            (lexed, Some(raw))
        }
    };
    // Context Free's constructs: an error with the MDG spelling each, read as that spelling.
    let (tokens, cf) = crate::cfdg::rewrite(std::mem::take(&mut lexed.tokens), sources);
    for d in cf {
        if lexed.diagnostics.len() < crate::diag::MAX_ERRORS {
            lexed.diagnostics.push(d);
        } else {
            lexed.suppressed.add(d.span);
        }
    }
    Ok((tokens, lexed, raw))
}

/// Parses tokens (a macro expansion) as top-level items.
pub fn parse_items(sources: &Sources, file: FileId, tokens: Vec<Token>) -> (Vec<Item>, Vec<Diagnostic>) {
    let (items, diags, _) = parse_items_within(sources, file, tokens, MAX_NESTING);
    (items, diags)
}

/// [`parse_items`] with at most `budget` levels of nesting (what [`MAX_NESTING`] leaves
/// after the levels around the expansion), and how many diagnostics were not kept.
pub fn parse_items_within(
    sources: &Sources,
    file: FileId,
    tokens: Vec<Token>,
    budget: usize,
) -> (Vec<Item>, Vec<Diagnostic>, Suppressed) {
    match run(tokens, sources, file, Start::Items, vec![], budget) {
        (Out::Items(v), d, n) => (v, d, n),
        (_, d, n) => (vec![], d, n),
    }
}

/// Parses tokens (a macro expansion) as rule-body items.
pub fn parse_body_items(sources: &Sources, file: FileId, tokens: Vec<Token>) -> (Vec<BodyItem>, Vec<Diagnostic>) {
    let (items, diags, _) = parse_body_items_within(sources, file, tokens, MAX_NESTING);
    (items, diags)
}

/// [`parse_body_items`] with at most `budget` levels of nesting, and how many
/// diagnostics were not kept.
pub fn parse_body_items_within(
    sources: &Sources,
    file: FileId,
    tokens: Vec<Token>,
    budget: usize,
) -> (Vec<BodyItem>, Vec<Diagnostic>, Suppressed) {
    match run(tokens, sources, file, Start::BodyItems, vec![], budget) {
        (Out::Body(v), d, n) => (v, d, n),
        (_, d, n) => (vec![], d, n),
    }
}

/// One word of an adjustment list as parsed: an adjustment name, an argument, or a
/// recovered syntax error.
pub enum AdjWord {
    Name(Name),
    Arg(Arg),
    Error(Span),
}

/// Groups the words of an adjustment list into adjustments. A bare name is an
/// argument (a rule parameter, a local, a `@define`: `{y len rz a}`) while the
/// adjustment before it still needs arguments, or when it is no adjustment's name and
/// that adjustment takes more; otherwise it starts the next adjustment. So a name
/// that is also an adjustment's (`s`, `x`, `w`) is read as an argument only where one
/// is required; elsewhere it is written in parentheses: `{x 1 (s)}`.
pub fn group_adjustments(words: Vec<AdjWord>, comps: &crate::adjust::Components) -> Vec<Adj> {
    let mut out: Vec<Adj> = Vec::new();
    // The adjustment being filled and its (min, max) argument count.
    let mut open: Option<(usize, usize)> = None;
    for w in words {
        match w {
            AdjWord::Arg(a) => match out.last_mut() {
                Some(adj) if open.is_some() => {
                    adj.span = adj.span.to(a.span());
                    adj.args.push(a);
                }
                _ => {
                    // An argument with no adjustment before it: an adjustment without a
                    // name, reported by the checker as unknown.
                    let span = a.span();
                    out.push(Adj { name: Name { text: String::new(), span }, args: vec![a], span });
                    open = None;
                }
            },
            AdjWord::Name(n) => {
                let kind = comps.adj_kind(&n.text);
                let is_arg = match (open, out.last()) {
                    (Some((min, max)), Some(adj)) => {
                        let k = adj.args.len();
                        k < min || (kind.is_none() && k < max)
                    }
                    _ => false,
                };
                if is_arg {
                    if let Some(adj) = out.last_mut() {
                        adj.span = adj.span.to(n.span);
                        let span = n.span;
                        adj.args.push(Arg::Expr(Expr { kind: ExprKind::Var(n), span }));
                    }
                    continue;
                }
                // An unknown adjustment takes the numbers and parenthesised arguments
                // after it (the checker reports it); a bare name starts the next one.
                let arity = kind.map(|k| k.arity()).unwrap_or((0, 0));
                open = Some(arity);
                let span = n.span;
                // Room for the arguments it needs (pushing to an empty `Vec` makes
                // room for four).
                out.push(Adj { name: n, args: Vec::with_capacity(arity.0), span });
            }
            AdjWord::Error(span) => {
                // Most likely a malformed argument of the adjustment being filled: it
                // stands in for one, so its arity is not reported on top of the error.
                let needs = matches!((open, out.last()), (Some((min, _)), Some(adj)) if adj.args.len() < min.max(1));
                match out.last_mut() {
                    Some(adj) if needs => {
                        adj.span = adj.span.to(span);
                        adj.args.push(Arg::Expr(Expr { kind: ExprKind::Error, span }));
                    }
                    _ => out.push(Adj { name: Name { text: String::new(), span }, args: vec![], span }),
                }
                open = None;
            }
        }
    }
    // A pushed-to `Vec` starts with room for four arguments; most adjustments take
    // one. Trimmed, a call with a million adjustments keeps ~240 fewer bytes per
    // adjustment (issue 35: memory per source byte).
    for adj in &mut out {
        adj.args.shrink_to_fit();
    }
    out.shrink_to_fit();
    out
}
