//! The formatter: prints a file's syntax tree in the canonical layout, keeping
//! every comment.
//!
//! Layout: one item per line, two-space indentation, `{ }` bodies opened on the
//! item's line, at most one blank line kept between items. Numbers, macro bodies and
//! shader code are printed exactly as written. A comment before an item stays before
//! it; a comment after an item on the same line stays on that line; a comment inside
//! an item's adjustments or expression moves before the next item. The output parses
//! to the same tree, and formatting is idempotent (both tested over the corpus).

use crate::ast::*;
use crate::diag::render_plain;
use crate::lexer::Comment;
use crate::parse;
use crate::source::{Sources, MAX_SOURCE_BYTES};
use crate::span::Span;

/// Formats source text; fails (with rendered diagnostics) if the file has syntax errors,
/// or if the formatted text is one the compiler would refuse (over the source size
/// limit, or nested past the limit once laid out), so a formatted file always compiles
/// as the original did.
pub fn format_source(text: &str) -> Result<String, FormatError> {
    format_within("<input>", text, MAX_SOURCE_BYTES)
}

/// [`format_source`] for the file at `path`: its diagnostics name it
/// (`broken.mdg:2:5`), as `mdgc check`'s do.
pub fn format_file(path: &std::path::Path, text: &str) -> Result<String, FormatError> {
    format_within(&path.display().to_string(), text, MAX_SOURCE_BYTES)
}

/// Why a file is left as it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FormatError {
    /// It has syntax errors: their diagnostics, rendered (`name:line:col`).
    Syntax(String),
    /// The formatted text would be `len` bytes, more than the `max` the compiler reads.
    TooLarge { len: usize, max: usize },
    /// The formatted text would not parse (a formatter bug): its diagnostics, rendered.
    Unparsable(String),
}

impl std::fmt::Display for FormatError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FormatError::Syntax(rendered) => write!(f, "{rendered}"),
            FormatError::TooLarge { len, max } => write!(
                f,
                "formatting would make the file {len} bytes, more than the {max} bytes the compiler reads (E0201); \
                 the file is left as it is: split it into files joined with `@import`"
            ),
            FormatError::Unparsable(rendered) => write!(
                f,
                "formatting would make a file the compiler refuses; the file is left as it is (please report \
                 this):\n{rendered}"
            ),
        }
    }
}

impl std::error::Error for FormatError {}

/// The parse of `text`, or the syntax diagnostics that stop formatting, rendered.
fn syntax_errors(name: &str, text: &str) -> Result<parse::Parsed, String> {
    let mut sources = Sources::default();
    let id = sources.add(name, name, text);
    let parsed = parse::parse_file(&sources, id);
    let syntax: Vec<_> = parsed
        .diagnostics
        .iter()
        // (E0201 here: a text over the source size limit, which is not parsed at all;
        // E0210: an unknown `@word` takes the rest of its line, so moving what follows
        // it onto its line would change the tree.)
        .filter(|d| d.code.starts_with("E01") || matches!(d.code, "E0201" | "E0206" | "E0207" | "E0210"))
        .cloned()
        .collect();
    if syntax.is_empty() {
        Ok(parsed)
    } else {
        Err(render_plain(&syntax, &sources))
    }
}

/// [`format_source`] with the size limit as a parameter (tests use a small one).
fn format_within(name: &str, text: &str, max_bytes: usize) -> Result<String, FormatError> {
    let out = layout(text, syntax_errors(name, text).map_err(FormatError::Syntax)?);
    if out.len() > max_bytes {
        return Err(FormatError::TooLarge { len: out.len(), max: max_bytes });
    }
    if let Err(e) = syntax_errors(&format!("{name} (formatted)"), &out) {
        return Err(FormatError::Unparsable(e));
    }
    Ok(out)
}

/// The canonical layout of a parsed file.
fn layout(text: &str, parsed: parse::Parsed) -> String {
    let mut p = Printer { src: text, comments: parsed.comments, next: 0, out: String::new(), indent: 0, last_end: 0 };
    p.items(&parsed.file.items, text.len() as u32);
    let mut out = p.out.trim_end().to_string();
    out.push('\n');
    if out.trim().is_empty() {
        return String::new();
    }
    out
}

struct Printer<'a> {
    src: &'a str,
    comments: Vec<Comment>,
    next: usize,
    out: String,
    indent: usize,
    /// End of the last thing printed from the source (for blank-line detection).
    last_end: u32,
}

impl<'a> Printer<'a> {
    fn pad(&mut self) {
        for _ in 0..self.indent {
            self.out.push_str("  ");
        }
    }

    fn text(&self, s: Span) -> &'a str {
        self.src.get(s.range()).unwrap_or("")
    }

    /// Whether the source has a blank line between `from` and `to`: a whole line
    /// (between two newlines) holding only whitespace.
    fn blank_between(&self, from: u32, to: u32) -> bool {
        let gap = self.src.get(from as usize..to as usize).unwrap_or("");
        let segs: Vec<&str> = gap.split('\n').collect();
        segs.len() >= 3 && segs[1..segs.len() - 1].iter().any(|l| l.trim().is_empty())
    }

    /// Prints every comment starting before `before` on lines of its own.
    fn leading_comments(&mut self, before: u32) {
        while let Some(c) = self.comments.get(self.next).cloned() {
            if c.span.start >= before {
                break;
            }
            self.next += 1;
            if self.blank_between(self.last_end, c.span.start) && !self.out.is_empty() && !self.out.ends_with("{\n") {
                self.out.push('\n');
            }
            self.pad();
            let t = self.text(c.span).trim_end().to_string();
            self.out.push_str(&t);
            self.out.push('\n');
            self.last_end = c.span.end;
        }
    }

    /// Prints comments still pending before `start` where we are (inside an item,
    /// before a part printed verbatim with its own comments), each ending its line, so
    /// every comment keeps its place in the order.
    fn inline_comments_before(&mut self, start: u32) {
        while let Some(c) = self.comments.get(self.next).cloned() {
            if c.span.start >= start {
                break;
            }
            self.next += 1;
            if !self.out.is_empty() && !self.out.ends_with(' ') && !self.out.ends_with('\n') {
                self.out.push(' ');
            }
            let t = self.text(c.span).trim_end().to_string();
            self.out.push_str(&t);
            self.out.push('\n');
            self.pad();
            self.last_end = c.span.end;
        }
    }

    /// Appends comments that start on the same source line right after `end`.
    fn trailing_comments(&mut self, end: u32) {
        while let Some(c) = self.comments.get(self.next).cloned() {
            let gap = self.src.get(end as usize..c.span.start as usize).unwrap_or("\n");
            if c.span.start < end || gap.contains('\n') || !gap.trim().is_empty() {
                break;
            }
            self.next += 1;
            if self.out.ends_with('\n') {
                self.out.pop();
            }
            self.out.push(' ');
            let t = self.text(c.span).trim_end().to_string();
            self.out.push_str(&t);
            self.out.push('\n');
            self.last_end = c.span.end;
        }
    }

    fn start_item(&mut self, span: Span) {
        self.leading_comments(span.start);
        if self.blank_between(self.last_end, span.start) && !self.out.is_empty() && !self.out.ends_with("{\n") {
            self.out.push('\n');
        }
        self.pad();
    }

    fn end_item(&mut self, span: Span) {
        self.out.push('\n');
        self.last_end = span.end;
        self.trailing_comments(span.end);
    }

    fn items(&mut self, items: &[Item], end: u32) {
        for item in items {
            self.item(item);
        }
        self.leading_comments(end);
    }

    fn open_block(&mut self) {
        self.out.push_str("{\n");
        self.indent += 1;
    }

    fn close_block(&mut self, end: u32) {
        self.leading_comments(end);
        self.indent -= 1;
        self.pad();
        self.out.push('}');
    }

    fn item(&mut self, item: &Item) {
        self.start_item(item.span);
        match &item.kind {
            ItemKind::Startshape(n) => self.out.push_str(&format!("startshape {}", n.text)),
            ItemKind::Linerule(n) => self.out.push_str(&format!("linerule {}", n.text)),
            ItemKind::Camerarule(n) => self.out.push_str(&format!("camerarule {}", n.text)),
            ItemKind::Rule(r) => {
                let mut head = format!("rule {}", r.name.text);
                if let Some(p) = &r.params {
                    head.push_str(&params(p));
                }
                if let Some(i) = &r.iter {
                    head.push_str(&format!(" * {}", i.text));
                }
                for t in &r.transforms {
                    head.push_str(&format!(" : {}", t.text));
                }
                if r.adds.is_some() {
                    head.push_str(" +=");
                }
                if let Some(w) = &r.weight {
                    head.push_str(&format!(" {}{}", if w.negative { "-" } else { "" }, w.number.text));
                }
                if let Some(e) = &r.weight_expr {
                    head.push_str(&format!(" ({})", expr(e)));
                }
                if let Some(t) = &r.retire {
                    head.push_str(&format!(" {} {}", t.keyword.text, t.depth.text));
                    if let Some(o) = &t.other {
                        head.push_str(&format!(" > {}", o.text));
                    }
                }
                self.out.push_str(&head);
                self.out.push(' ');
                self.body_block(&r.body, r.body_span.end);
            }
            ItemKind::Selector { rules, mode } => {
                let names: Vec<&str> = rules.iter().map(|n| n.text.as_str()).collect();
                self.out.push_str(&format!("selector {} ", names.join(", ")));
                match mode {
                    SelectorMode::Word(w) => self.out.push_str(&w.text),
                    SelectorMode::FunctionRef(f) => self.out.push_str(&format!("function {}", f.text)),
                    SelectorMode::FunctionBody(e) => self.out.push_str(&format!("function {{ {} }}", expr(e))),
                }
            }
            ItemKind::Namespace { name, items } => {
                self.out.push_str(&format!("namespace {} ", name.text));
                self.open_block();
                for i in items {
                    self.item(i);
                }
                self.close_block(item.span.end);
            }
            ItemKind::Directive { name, args } => {
                self.out.push_str(&name.text);
                for a in args {
                    self.out.push(' ');
                    self.out.push_str(&dir_arg(a));
                }
            }
            ItemKind::Function { name, params, types, body } if !params.is_empty() => {
                let ps = typed_params(params, types);
                self.out.push_str(&format!("function {}({}) {{ {} }}", name.text, ps.join(", "), expr(body)))
            }
            ItemKind::Function { name, body, .. } => {
                self.out.push_str(&format!("function {} {{ {} }}", name.text, expr(body)))
            }
            ItemKind::Isosurface { name, entries } => {
                self.out.push_str(&format!("isosurface {} ", name.text));
                self.open_block();
                for e in entries {
                    self.pad();
                    match e {
                        IsoEntry::Axis { axis, args, .. } => {
                            self.out.push_str(&axis.text);
                            for a in args {
                                self.out.push(' ');
                                self.out.push_str(&dir_arg(a));
                            }
                        }
                        IsoEntry::FunctionRef(f) => self.out.push_str(&format!("function {}", f.text)),
                        IsoEntry::FunctionBody(e) => self.out.push_str(&format!("function {{ {} }}", expr(e))),
                    }
                    self.out.push('\n');
                }
                self.close_block(item.span.end);
            }
            ItemKind::Program { words } => {
                self.out.push_str("program ");
                self.open_block();
                let mut first = true;
                for w in words {
                    let starts = matches!(w.text.as_str(), "vertexshader" | "fragmentshader" | "target" | "render");
                    if starts || first {
                        if !first {
                            self.out.push('\n');
                        }
                        self.pad();
                    } else {
                        self.out.push(' ');
                    }
                    self.out.push_str(&w.text);
                    first = false;
                }
                if !first {
                    self.out.push('\n');
                }
                self.close_block(item.span.end);
            }
            ItemKind::Section(sec) => {
                self.out.push_str(&sec.kind.text);
                if let Some(n) = &sec.name {
                    self.out.push(' ');
                    self.out.push_str(&n.text);
                }
                self.out.push(' ');
                self.entries(&sec.entries, sec.body_span.end);
            }
            ItemKind::Pre(p) => self.pre(p, item.span, |me, i: &Item| me.item(i)),
            ItemKind::Error => {
                let t = self.text(item.span).to_string();
                self.out.push_str(&t);
            }
        }
        self.end_item(item.span);
    }

    /// `{ ENTRY… }` of a section: one entry a line; values that began a new line in
    /// the source (a point list, rows of blocks) keep their line breaks.
    fn entries(&mut self, entries: &[Entry], end: u32) {
        self.open_block();
        for e in entries {
            self.start_item(e.span);
            self.out.push_str(&e.key.text);
            let mut prev = e.key.span.end;
            for v in &e.values {
                let gap = self.src.get(prev as usize..v.span().start as usize).unwrap_or("");
                if gap.contains('\n') {
                    self.out.push('\n');
                    self.indent += 1;
                    self.pad();
                    self.indent -= 1;
                } else {
                    self.out.push(' ');
                }
                self.out.push_str(&value(v));
                prev = v.span().end;
            }
            match &e.block {
                Some((inner, span)) => {
                    self.out.push(' ');
                    self.entries(inner, span.end);
                }
                None => self.out.push(';'),
            }
            self.end_item(e.span);
        }
        self.close_block(end);
    }

    fn pre<T>(&mut self, p: &Pre<T>, span: Span, each: impl Fn(&mut Self, &T) + Copy) {
        let words = |v: &[Name]| v.iter().map(|n| n.text.as_str()).collect::<Vec<_>>().join(" ");
        match p {
            Pre::Import(v) => self.out.push_str(&format!("@import {}", words(v))),
            Pre::Define { name, value } => {
                self.out.push_str(&format!("@define {}", name.text));
                if let Some(v) = value {
                    self.out.push_str(&format!(" {}", v.text));
                }
            }
            Pre::Param(v) => self.out.push_str(&format!("@param {}", words(v))),
            Pre::Presets(v) => self.out.push_str(&format!("@presets {}", words(v))),
            Pre::Shader { .. } | Pre::Macro(_) | Pre::Bad => {
                // Shader code and macro bodies are not MDG syntax trees: keep them verbatim.
                self.inline_comments_before(span.start);
                let t = self.text(span).to_string();
                self.out.push_str(&t);
                // Comments inside were printed with the text.
                while self.comments.get(self.next).is_some_and(|c| c.span.start < span.end) {
                    self.next += 1;
                }
            }
            Pre::Expand { name, args } => {
                self.inline_comments_before(span.start);
                let a: Vec<&str> = args.iter().map(|a| self.text(a.span).trim()).collect();
                let has_comment = self.comments[self.next.min(self.comments.len())..]
                    .iter()
                    .take_while(|c| c.span.start < span.end)
                    .any(|c| c.span.start >= span.start);
                if has_comment || a.iter().any(|t| t.contains('@')) {
                    // A comment inside the parentheses (even outside every argument, or
                    // a line comment that would swallow the `)`), or a directive that
                    // takes the rest of its line: keep the text.
                    let t = self.text(span).to_string();
                    self.out.push_str(&t);
                } else {
                    self.out.push_str(&format!("@expand {}({})", name.text, a.join(", ")));
                }
                // Arguments are printed verbatim, comments included.
                while self.comments.get(self.next).is_some_and(|c| c.span.start < span.end) {
                    self.next += 1;
                }
            }
            Pre::IfDef { name, then, otherwise } => {
                self.out.push_str(&format!("@ifdef {}\n", name.text));
                self.last_end = name.span.end;
                for t in then {
                    each(self, t);
                }
                if let Some(o) = otherwise {
                    self.pad();
                    self.out.push_str("@else\n");
                    for t in o {
                        each(self, t);
                    }
                }
                self.leading_comments(span.end);
                self.pad();
                self.out.push_str("@endif");
            }
        }
    }

    fn body_block(&mut self, items: &[BodyItem], end: u32) {
        let has_comments = self.comments.get(self.next).is_some_and(|c| c.span.start < end);
        if items.is_empty() && !has_comments {
            self.out.push_str("{}");
            return;
        }
        self.open_block();
        for i in items {
            self.body_item(i);
        }
        self.close_block(end);
    }

    fn body_item(&mut self, item: &BodyItem) {
        self.start_item(item.span);
        self.body_kind(item);
        if item.cont {
            // `@import`, `@define`, `@param` and `@presets` take the rest of their line:
            // their continuation goes on the next one.
            if matches!(
                &item.kind,
                BodyKind::Pre(Pre::Import(_) | Pre::Define { .. } | Pre::Param(_) | Pre::Presets(_))
            ) {
                self.out.push('\n');
                self.pad();
                self.out.push('\\');
            } else {
                self.out.push_str(" \\");
            }
        }
        self.end_item(item.span);
    }

    /// `switch (E) {`, each arm's `case …:` a line of its own with its items one
    /// level further in (an arm that is one `{ … }` block opens it on that line),
    /// and `}`.
    fn switch(&mut self, s: &Switch) {
        self.out.push_str(&format!("switch ({}) ", expr(&s.value)));
        self.open_block();
        for arm in &s.arms {
            self.start_item(arm.span);
            let labels: Vec<String> = arm
                .labels
                .iter()
                .map(|l| match &l.hi {
                    None => expr(&l.lo),
                    Some(h) => format!("{}..{}", expr(&l.lo), expr(h)),
                })
                .collect();
            self.out.push_str(&format!("case {}:", labels.join(", ")));
            self.arm_items(&arm.body, arm.span.start);
        }
        if let Some((items, span)) = &s.otherwise {
            self.start_item(*span);
            self.out.push_str("else:");
            self.arm_items(items, span.start);
        }
        self.close_block(s.body_span.end);
    }

    /// An arm's items, after its `case …:` or `else:`.
    fn arm_items(&mut self, items: &[BodyItem], start: u32) {
        if let [b @ BodyItem { kind: BodyKind::Block(inner), cont: false, .. }] = items {
            self.out.push(' ');
            self.body_block(inner, b.span.end);
            self.end_item(b.span);
            return;
        }
        self.out.push('\n');
        self.last_end = start;
        self.indent += 1;
        for i in items {
            self.body_item(i);
        }
        self.indent -= 1;
    }

    fn body_kind(&mut self, item: &BodyItem) {
        match &item.kind {
            BodyKind::Call { name, args, profile, adj } => {
                self.out.push_str(&name.text);
                if let Some(a) = args {
                    let a: Vec<String> = a.args.iter().map(expr).collect();
                    self.out.push_str(&format!("({})", a.join(", ")));
                }
                if let Some(p) = profile {
                    self.out.push(' ');
                    self.out.push_str(&p.text);
                }
                self.out.push(' ');
                self.out.push_str(&adj_list(adj));
            }
            BodyKind::Iterate { count, divisor, adj, chain, item: inner } => {
                self.out.push_str(&count_text(count));
                if let Some(d) = divisor {
                    self.out.push('/');
                    self.out.push_str(&count_text(d));
                }
                self.out.push_str(" * ");
                self.out.push_str(&adj_list(adj));
                self.out.push_str(if *chain { " \\ " } else { " " });
                self.body_kind(inner);
            }
            BodyKind::Block(items) => self.body_block(items, item.span.end),
            BodyKind::Switch(s) => self.switch(s),
            BodyKind::If { cond, then, then_span, otherwise } => {
                self.out.push_str(&format!("if ({}) ", expr(cond)));
                self.body_block(then, then_span.end);
                if let Some(o) = otherwise {
                    self.out.push_str(" else ");
                    self.body_kind(o);
                }
            }
            BodyKind::Let { name, value } => self.out.push_str(&format!("let {} = {};", name.text, expr(value))),
            BodyKind::Loop { var, range, adj, item: inner } => {
                let LoopRange { start, end, step } = &**range;
                self.out.push_str(&format!("loop {} = {}, {}", var.text, expr(start), expr(end)));
                if let Some(s) = step {
                    self.out.push_str(&format!(", {}", expr(s)));
                }
                self.out.push(' ');
                self.out.push_str(&adj_list(adj));
                self.out.push(' ');
                self.body_kind(inner);
            }
            BodyKind::Pre(p) => {
                // The item's span ends after its continuation `\`, which is printed
                // separately: verbatim text (shader, macro) must stop before it.
                let mut span = item.span;
                if item.cont {
                    let text = self.text(span);
                    let trimmed = text.trim_end();
                    if let Some(t) = trimmed.strip_suffix('\\') {
                        span.end = span.start + t.trim_end().len() as u32;
                    }
                }
                self.pre(p, span, |me, i: &BodyItem| me.body_item(i))
            }
            BodyKind::Error => {
                let t = self.text(item.span).to_string();
                self.out.push_str(&t);
            }
        }
    }
}

/// A function's parameters as written: `vector2 c`, `n`.
pub(crate) fn typed_params(params: &[Name], types: &[Option<Name>]) -> Vec<String> {
    params
        .iter()
        .enumerate()
        .map(|(i, p)| match types.get(i).and_then(Option::as_ref) {
            Some(t) => format!("{} {}", t.text, p.text),
            None => p.text.clone(),
        })
        .collect()
}

/// A rule's parameter list: `(int n, float len = 1)`.
fn params(p: &Params) -> String {
    let list: Vec<String> = p
        .params
        .iter()
        .map(|d| match &d.default {
            Some(e) => format!("{} {} = {}", d.ty.text, d.name.text, expr(e)),
            None => format!("{} {}", d.ty.text, d.name.text),
        })
        .collect();
    format!("({})", list.join(", "))
}

fn count_text(c: &Count) -> String {
    match c {
        Count::Num(n) => n.text.clone(),
        Count::Neg(n) => format!("-{}", n.text),
        Count::Expr(e) => expr(e),
    }
}

/// One adjustment as written: `rz 25`, `x (a + 1)`.
pub fn adjustment(adj: &Adj) -> String {
    let mut s = adj.name.text.clone();
    for arg in &adj.args {
        s.push(' ');
        s.push_str(&match arg {
            Arg::Num(n) => n.text.clone(),
            Arg::Neg(n) => format!("-{}", n.text),
            Arg::Expr(e) => expr(e),
        });
    }
    s
}

fn adj_list(a: &AdjList) -> String {
    let inner: Vec<String> = a.adjs.iter().map(adjustment).collect();
    let (o, c) = if a.square { ('[', ']') } else { ('{', '}') };
    format!("{o}{}{c}", inner.join(" "))
}

fn dir_arg(a: &DirArg) -> String {
    match a {
        DirArg::Num(n) => n.text.clone(),
        DirArg::Neg(n) => format!("-{}", n.text),
        DirArg::Word(w) => w.text.clone(),
        DirArg::Expr(e) => expr(e),
    }
}

fn value(v: &Value) -> String {
    match v {
        Value::Num(n) => n.text.clone(),
        Value::Neg(n) => format!("-{}", n.text),
        Value::Word(w) => w.text.clone(),
        Value::Expr(e) => expr(e),
        Value::Str(s, _) => format!("\"{s}\""),
    }
}

/// Prints an expression (parentheses are explicit nodes, so none are added).
pub fn expr(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Num(n) => n.text.clone(),
        ExprKind::Var(v) => v.text.clone(),
        ExprKind::Neg(x) => format!("-{}", expr(x)),
        ExprKind::Not(x) => format!("!{}", expr(x)),
        ExprKind::Binary(op, a, b) => format!("{} {} {}", expr(a), op.symbol(), expr(b)),
        ExprKind::Call(f, args) => {
            let a: Vec<String> = args.iter().map(expr).collect();
            format!("{}({})", f.text, a.join(", "))
        }
        ExprKind::Let(bindings, body) => {
            let b: Vec<String> = bindings.iter().map(|(n, v)| format!("{} = {}; ", n.text, expr(v))).collect();
            format!("let({}{})", b.concat(), expr(body))
        }
        ExprKind::Paren(x) => format!("({})", expr(x)),
        ExprKind::Tuple(xs) => {
            let a: Vec<String> = xs.iter().map(expr).collect();
            format!("({})", a.join(", "))
        }
        ExprKind::Index(v, i) => format!("{}[{}]", expr(v), expr(i)),
        ExprKind::Error => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_would_grow_past_the_size_limit_is_left_as_it_is() {
        // One line of 200 calls becomes 200 indented lines: about 1.4 times longer.
        let text = format!("rule A {{ {}}}\nrule B {{ }}\n", "B {} ".repeat(200));
        let limit = text.len() + 100;
        let e = format_within("<input>", &text, limit).expect_err("grows past the limit");
        assert!(matches!(e, FormatError::TooLarge { max, .. } if max == limit), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("more than") && e.contains("left as it is"), "{e}");
        let ok = format_within("<input>", &text, 10 * text.len()).expect("fits");
        assert!(ok.len() > limit && ok.lines().count() > 200);
        assert_eq!(format_source(&ok).as_deref(), Ok(ok.as_str()), "idempotent");
    }
}
