//! Context Free (CFDG 3) constructs written in an MDG file.
//!
//! A user porting a `.cfdg` program meets these first: `shape X`, `CF::MinimumSize =
//! 0.01`, `loop 5 [x 1]`, `startshape tree(8)`, `X(=)`, `n -- 1`, `path`,
//! `import`. Each gets error E0110 with the MDG spelling as its fix (a suggestion, so
//! the language server offers it as a quick fix), and the token stream is rewritten
//! into that spelling where it can be, so the rest of the file parses and checks as
//! the user meant: one mistake, one error, and no false W0006 for parameters that
//! an `X(=)` reads. Context Free's `switch` is MDG's too: this pass only marks its
//! words (`Rewriter::switch`), which the grammar cannot tell from names by itself.

use crate::diag::Diagnostic;
use crate::lexer::{Tok, Token};
use crate::source::Sources;
use crate::span::Span;

/// `CF::NAME` settings with an MDG directive: (name, directive).
const CF_DIRECTIVES: &[(&str, &str)] = &[("MinimumSize", "minsize"), ("StartShape", "startshape")];

/// `CF::NAME` settings with no MDG equivalent, with what to do instead.
const CF_OTHERS: &[(&str, &str)] = &[
    ("MaxShapes", "MDG bounds a run with `mdgc … --max-vertices N` and the `maxiter` directive (rule calls)"),
    ("Size", "the model has no canvas: the picture frames the whole model (`--camera` sets the view)"),
    ("Tile", "MDG has no tiling: repeat the design with an iterator (`5 * {x 1} …`)"),
    ("Symmetry", "MDG has no symmetry setting: draw the copies with an iterator (`6 * {rz 60} …`) or `f` reflections"),
    ("Frame", "animation is MDG's `fps` and `duration` directives (reference §11)"),
    ("FrameTime", "animation is MDG's `fps` and `duration` directives (reference §11)"),
    ("Impure", "MDG has no impure mode: remove the line"),
    ("AllowOverlap", "MDG never merges overlapping shapes: remove the line"),
    ("Alpha", "MDG always keeps alpha: remove the line"),
    ("ColorDepth", "MDG's pictures are 8 bits a channel: remove the line"),
    ("BorderDynamic", "the model has no border: remove the line"),
    ("BorderFixed", "the model has no border: remove the line"),
    ("MaxNatural", "MDG's `int` has no separate bound: remove the line"),
];

struct Rewriter<'s> {
    sources: &'s Sources,
    toks: Vec<Token>,
    out: Vec<Token>,
    diags: Vec<Diagnostic>,
    /// The parameter name tokens of the rule being read (for `X(=)`).
    params: Vec<Token>,
    /// For each opening bracket, the index of the one closing it (same kind; a call
    /// token `NAME(` opens a parenthesis). Built once, so hostile input stays linear.
    matching: Vec<Option<usize>>,
    /// For each index, the first `{` at or after it.
    next_brace: Vec<usize>,
}

/// Rewrites the Context Free constructs of one file's tokens; see the module doc.
pub fn rewrite(tokens: Vec<Token>, sources: &Sources) -> (Vec<Token>, Vec<Diagnostic>) {
    let n = tokens.len();
    let mut matching = vec![None; n];
    let mut stacks: [Vec<usize>; 3] = Default::default();
    for (i, t) in tokens.iter().enumerate() {
        let (family, open) = match t.kind {
            Tok::LBrace => (0, true),
            Tok::RBrace => (0, false),
            Tok::LBracket | Tok::IndexOpen => (1, true),
            Tok::RBracket => (1, false),
            Tok::LParen | Tok::CallOpen => (2, true),
            Tok::RParen => (2, false),
            _ => continue,
        };
        if open {
            stacks[family].push(i);
        } else if let Some(o) = stacks[family].pop() {
            matching[o] = Some(i);
        }
    }
    let mut next_brace = vec![n; n + 1];
    for i in (0..n).rev() {
        next_brace[i] = if tokens[i].kind == Tok::LBrace { i } else { next_brace[i + 1] };
    }
    let mut r = Rewriter {
        sources,
        toks: tokens,
        out: Vec::with_capacity(n),
        diags: Vec::new(),
        params: Vec::new(),
        matching,
        next_brace,
    };
    r.run();
    (r.out, r.diags)
}

fn error(span: Span, message: String) -> Diagnostic {
    Diagnostic::error("E0110", span, message).with_label("Context Free's spelling")
}

impl Rewriter<'_> {
    fn kind(&self, i: usize) -> Option<Tok> {
        self.toks.get(i).map(|t| t.kind)
    }

    fn text(&self, i: usize) -> &str {
        self.toks.get(i).map(|t| self.sources.text(t.span)).unwrap_or("")
    }

    /// The source text from token `a`'s start to token `b`'s end.
    fn src(&self, a: usize, b: usize) -> String {
        match (self.toks.get(a), self.toks.get(b)) {
            (Some(x), Some(y)) if y.span.end >= x.span.start => {
                self.sources.text(Span::new(x.span.file, x.span.start, y.span.end)).to_string()
            }
            _ => String::new(),
        }
    }

    fn span(&self, a: usize, b: usize) -> Span {
        let (x, y) = (self.toks[a].span, self.toks[b.max(a)].span);
        Span::new(x.file, x.start, y.end.max(x.start))
    }

    fn line(&self, i: usize) -> u32 {
        let s = self.toks[i].span;
        self.sources.files.get(s.file.0 as usize).map(|f| f.line_col(s.start).0).unwrap_or(0)
    }

    /// A zero-width token of `kind` at the start of token `i` (its text is never read).
    fn synth(&self, kind: Tok, i: usize) -> Token {
        let s = self.toks[i.min(self.toks.len() - 1)].span;
        Token { kind, span: Span::new(s.file, s.start, s.start) }
    }

    /// The index of the bracket closing the one at `open` (of the same kind).
    fn closing(&self, open: usize) -> Option<usize> {
        self.matching.get(open).copied().flatten()
    }

    /// The first `{` at or after `i`.
    fn brace_from(&self, i: usize) -> Option<usize> {
        self.next_brace.get(i).copied().filter(|k| *k < self.toks.len())
    }

    /// Whether token `i` is a name some MDG item takes (`startshape shape`,
    /// `linerule path`, `selector a, shape random`), not the start of an item.
    fn is_item_name(&self, i: usize) -> bool {
        i > 0
            && matches!(
                self.kind(i - 1),
                Some(
                    Tok::KwRule
                        | Tok::KwStartshape
                        | Tok::KwLinerule
                        | Tok::KwCamerarule
                        | Tok::KwSelector
                        | Tok::Comma
                )
            )
    }

    fn run(&mut self) {
        let mut depth = 0usize;
        let mut i = 0usize;
        while i < self.toks.len() {
            let t = self.toks[i];
            let next = self.kind(i + 1);
            let handled = match t.kind {
                Tok::Ident
                    if depth == 0 && self.text(i) == "shape" && matches!(next, Some(Tok::Ident | Tok::CallOpen)) =>
                {
                    self.shape(i)
                }
                Tok::Ident
                    if depth == 0
                        && !self.is_item_name(i)
                        && self.text(i) == "CF"
                        && next == Some(Tok::Colon)
                        && self.kind(i + 2) == Some(Tok::Colon)
                        && self.kind(i + 3) == Some(Tok::Ident) =>
                {
                    self.cf_setting(i)
                }
                Tok::Ident
                    if depth == 0 && !self.is_item_name(i) && self.text(i) == "path" && next == Some(Tok::Ident) =>
                {
                    self.path(i)
                }
                Tok::Ident
                    if depth == 0
                        && !self.is_item_name(i)
                        && matches!(self.text(i), "import" | "include")
                        && next == Some(Tok::Str) =>
                {
                    self.import(i)
                }
                Tok::KwRule if depth == 0 => {
                    self.note_params(i);
                    None
                }
                Tok::KwStartshape if depth == 0 => self.startshape(i),
                Tok::KwLoop if depth > 0 => self.counted_loop(i),
                Tok::CallOpen if depth > 0 && next == Some(Tok::Assign) && self.kind(i + 2) == Some(Tok::RParen) => {
                    self.same_arguments(i)
                }
                // (The cheap tests first: this runs for every name in every body.)
                Tok::Ident if depth > 0 && next == Some(Tok::LParen) && self.text(i) == "switch" => {
                    self.switch(i, i + 1)
                }
                Tok::CallOpen if depth > 0 && t.span.end - t.span.start == 7 && self.text(i) == "switch(" => {
                    self.switch(i, i)
                }
                Tok::LBracket
                    if depth > 0
                        && next == Some(Tok::LBracket)
                        && self.toks.get(i + 1).is_some_and(|n| n.span.start == t.span.end) =>
                {
                    self.ordered_list(i)
                }
                // A binary `a -- b` (after an operand, not a run of minus signs).
                Tok::Minus
                    if depth > 0
                        && next == Some(Tok::Minus)
                        && self.toks.get(i + 1).is_some_and(|n| n.span.start == t.span.end)
                        && i > 0
                        && matches!(self.kind(i - 1), Some(Tok::Number | Tok::Ident | Tok::RParen))
                        && self.kind(i + 2) != Some(Tok::Minus) =>
                {
                    let span = self.span(i, i + 1);
                    self.diags.push(
                        error(span, "`--` is Context Free's natural subtraction: MDG writes `-`".to_string())
                            .with_note("here `--` would read as minus a negative number, an addition")
                            .with_suggestion("write `-`", span, "-".to_string()),
                    );
                    self.out.push(t);
                    Some(i + 2)
                }
                _ => None,
            };
            match handled {
                Some(n) => i = n,
                None => {
                    match t.kind {
                        Tok::LBrace => depth += 1,
                        Tok::RBrace => depth = depth.saturating_sub(1),
                        _ => {}
                    }
                    self.out.push(t);
                    i += 1;
                }
            }
        }
    }

    /// Remembers the parameter names of `rule NAME(TYPE a, TYPE b = 1) …` at `i`.
    fn note_params(&mut self, i: usize) {
        self.params.clear();
        let open = i + 1;
        if self.kind(open) != Some(Tok::CallOpen) {
            if !(self.kind(open) == Some(Tok::Ident) && self.kind(open + 1) == Some(Tok::LParen)) {
                return;
            }
            return self.params_from(open + 1);
        }
        self.params_from(open)
    }

    fn params_from(&mut self, open: usize) {
        let Some(close) = self.closing(open) else { return };
        let mut group: Vec<usize> = Vec::new();
        let mut names = Vec::new();
        let mut depth = 0usize;
        for j in open + 1..=close {
            let k = self.toks[j].kind;
            if depth == 0 && (k == Tok::Comma || j == close) {
                if let [_, name, ..] = group.as_slice() {
                    if self.toks[*name].kind == Tok::Ident {
                        names.push(self.toks[*name]);
                    }
                }
                group.clear();
                continue;
            }
            match k {
                Tok::LParen | Tok::CallOpen => depth += 1,
                Tok::RParen => depth = depth.saturating_sub(1),
                _ => {}
            }
            group.push(j);
        }
        self.params = names;
    }

    /// `shape X { … }` and `shape X` followed by `rule [WEIGHT] { … }` definitions.
    fn shape(&mut self, i: usize) -> Option<usize> {
        let name = i + 1;
        // The multi-definition form: `shape X rule 0.5 { … } rule { … }`.
        if self.kind(name) == Some(Tok::Ident) && self.kind(name + 1) == Some(Tok::KwRule) {
            let mut j = name + 1;
            let mut inserts = Vec::new();
            let mut end = name;
            while self.kind(j) == Some(Tok::KwRule) {
                let Some(open) = self.brace_from(j + 1) else { break };
                let Some(close) = self.closing(open) else { break };
                inserts.push(j);
                end = close;
                j = close + 1;
            }
            if inserts.is_empty() {
                return None;
            }
            let nm = self.text(name).to_string();
            let mut fixed = String::new();
            let mut from = self.toks[inserts[0]].span.start;
            for k in &inserts {
                let at = self.toks[*k].span.end;
                fixed.push_str(self.sources.text(Span::new(self.toks[i].span.file, from, at)));
                fixed.push(' ');
                fixed.push_str(&nm);
                from = at;
            }
            fixed.push_str(self.sources.text(Span::new(self.toks[i].span.file, from, self.toks[end].span.end)));
            self.diags.push(
                error(
                    self.span(i, name),
                    format!("`shape {nm}` with `rule` definitions is Context Free's: MDG names each definition, `rule {nm} … {{ … }}`"),
                )
                .with_suggestion(format!("name each definition `rule {nm}`"), self.span(i, end), fixed),
            );
            for k in name + 1..=end {
                let t = self.toks[k];
                self.out.push(t);
                if inserts.contains(&k) {
                    self.note_params(k);
                    self.out.push(self.toks[name]);
                }
            }
            return Some(end + 1);
        }
        let t = self.toks[i];
        self.diags.push(
            error(t.span, "`shape` is Context Free's: MDG defines a rule with `rule`".to_string()).with_suggestion(
                "write `rule`",
                t.span,
                "rule".to_string(),
            ),
        );
        self.out.push(Token { kind: Tok::KwRule, span: t.span });
        self.note_params(i);
        Some(i + 1)
    }

    /// `CF::NAME = VALUE`.
    fn cf_setting(&mut self, i: usize) -> Option<usize> {
        let name_i = i + 3;
        let name = self.text(name_i).to_string();
        // The value: an adjustment list, or the rest of the line.
        let mut end = name_i;
        let mut value = None;
        if self.kind(name_i + 1) == Some(Tok::Assign) && name_i + 2 < self.toks.len() {
            let first = name_i + 2;
            end = match self.kind(first) {
                Some(Tok::LBracket | Tok::LBrace) => self.closing(first).unwrap_or(first),
                _ => {
                    let line = self.line(name_i + 1);
                    let mut e = first;
                    while e + 1 < self.toks.len() && self.line(e + 1) == line {
                        e += 1;
                    }
                    e
                }
            };
            value = Some((first, end));
        }
        let whole = self.span(i, end);
        let value_text = value.map(|(a, b)| self.src(a, b)).unwrap_or_default();
        let head = self.span(i, name_i);
        let mut d = error(head, format!("`CF::{name}` is Context Free's setting"));
        if let Some((_, dir)) = CF_DIRECTIVES.iter().find(|(n, _)| *n == name) {
            d.message = format!("`CF::{name}` is Context Free's setting: MDG writes the directive `{dir}`");
            if value.is_some() {
                d = d.with_suggestion(format!("write `{dir} {value_text}`"), whole, format!("{dir} {value_text}"));
            }
        } else if name == "Background" {
            d.message = format!("`CF::{name}` is Context Free's setting: MDG writes `background R G B [A]`");
            match value.and_then(|(a, b)| self.background(a, b)) {
                Some(rgba) => {
                    d = d.with_suggestion(format!("write `{rgba}`"), whole, rgba);
                }
                None => {
                    d = d.with_note(
                        "the colour is red, green and blue from 0 to 1 (and alpha): `background 0 0 0` is black",
                    )
                }
            }
        } else if let Some((_, what)) = CF_OTHERS.iter().find(|(n, _)| *n == name) {
            d.message = format!("`CF::{name}` is Context Free's setting, with no MDG equivalent");
            d = d.with_note(*what);
        } else {
            d = d.with_note("MDG's settings are directives (`minsize 0.01`, `background 0 0 0`; reference §3)");
        }
        self.diags.push(d);
        Some(end + 1)
    }

    /// `background R G B [A]` for Context Free's `[b X sat Y hue Z a W]` on its white
    /// default, when the list has only those adjustments with number arguments.
    fn background(&self, open: usize, close: usize) -> Option<String> {
        if !matches!(self.kind(open), Some(Tok::LBracket | Tok::LBrace)) {
            return None;
        }
        let (mut h, mut s, mut b, mut a) = (0.0f64, 0.0f64, 1.0f64, 1.0f64);
        let mut j = open + 1;
        let adjust = |v: f64, d: f64| if d > 0.0 { v + d * (1.0 - v) } else { v + d * v };
        while j < close {
            let word = self.text(j).to_string();
            let (neg, num) = if self.kind(j + 1) == Some(Tok::Minus) { (true, j + 2) } else { (false, j + 1) };
            if self.kind(num) != Some(Tok::Number) {
                return None;
            }
            let v = self.text(num).parse::<f64>().ok()?;
            let v = if neg { -v } else { v };
            match word.as_str() {
                "hue" | "h" => h = (h + v).rem_euclid(360.0),
                "sat" | "saturation" => s = adjust(s, v.clamp(-1.0, 1.0)),
                "b" | "brightness" => b = adjust(b, v.clamp(-1.0, 1.0)),
                "a" | "alpha" => a = adjust(a, v.clamp(-1.0, 1.0)),
                _ => return None,
            }
            j = num + 1;
        }
        let [r, g, bl] = hsb_to_rgb(h, s, b);
        let n = |x: f64| {
            let t = format!("{:.3}", x);
            let t = t.trim_end_matches('0').trim_end_matches('.').to_string();
            if t == "-0" {
                "0".to_string()
            } else {
                t
            }
        };
        let mut out = format!("background {} {} {}", n(r), n(g), n(bl));
        if a < 1.0 {
            out.push_str(&format!(" {}", n(a)));
        }
        Some(out)
    }

    /// `path NAME { … }`: no MDG equivalent.
    fn path(&mut self, i: usize) -> Option<usize> {
        let open = self.brace_from(i + 2)?;
        let close = self.closing(open)?;
        self.diags.push(
            error(self.span(i, i + 1), format!("`path {}` is Context Free's spelling", self.text(i + 1))).with_note(
                "MDG's flat paths are rules: `rule NAME { MOVETO(0, 0) {} LINETO(1, 0) {} … FILL {} }`, every \
                 drawable with its `{}` (reference §9, \"Flat paths\"); `mdgc import` converts a whole program",
            ),
        );
        Some(close + 1)
    }

    /// `import "file.cfdg"` / `include "file.cfdg"`.
    fn import(&mut self, i: usize) -> Option<usize> {
        let file = self.text(i + 1).trim_matches('"').to_string();
        let mdg = match file.strip_suffix(".cfdg") {
            Some(stem) => format!("{stem}.mdg"),
            None => file.clone(),
        };
        let span = self.span(i, i + 1);
        self.diags.push(
            error(span, format!("`{}` is Context Free's: MDG writes `@import {mdg}`", self.text(i))).with_suggestion(
                format!("write `@import {mdg}`"),
                span,
                format!("@import {mdg}"),
            ),
        );
        Some(i + 2)
    }

    /// `startshape X(ARGS) [ADJ]`.
    fn startshape(&mut self, i: usize) -> Option<usize> {
        let name = i + 1;
        let (call_end, name_text) = match self.kind(name)? {
            Tok::CallOpen => (self.closing(name)?, self.text(name).trim_end_matches('(').to_string()),
            Tok::Ident => (name, self.text(name).to_string()),
            _ => return None,
        };
        let adj = match self.kind(call_end + 1) {
            Some(Tok::LBracket | Tok::LBrace) if self.line(call_end + 1) == self.line(i) => {
                Some((call_end + 1, self.closing(call_end + 1)?))
            }
            _ => None,
        };
        if call_end == name && adj.is_none() {
            return None;
        }
        let end = adj.map(|a| a.1).unwrap_or(call_end);
        let call = self.src(name, call_end);
        let adj_text = match adj {
            Some((a, b)) => {
                let t = self.src(a, b);
                format!(
                    "{{{}}}",
                    t.trim_start_matches('[').trim_end_matches(']').trim_start_matches('{').trim_end_matches('}')
                )
            }
            None => "{}".to_string(),
        };
        let start = format!("start_{name_text}");
        let what = if adj.is_some() && call_end == name { "an adjustment" } else { "arguments" };
        self.diags.push(
            error(
                self.span(i, end),
                format!("a start shape with {what} is Context Free's: MDG's start shape is a rule name"),
            )
            .with_note(format!("a rule that calls `{call}` is the start shape"))
            .with_suggestion(
                format!("start with a rule `{start}` that calls it"),
                self.span(i, end),
                format!("startshape {start}\n\nrule {start} {{ {call} {adj_text} }}"),
            ),
        );
        let t = self.toks[name];
        self.out.push(self.toks[i]);
        let span = Span::new(t.span.file, t.span.start, t.span.start + name_text.len() as u32);
        self.out.push(Token { kind: Tok::Ident, span });
        Some(end + 1)
    }

    /// `loop N [ADJ]` (and `loop i = N [ADJ]`).
    fn counted_loop(&mut self, i: usize) -> Option<usize> {
        let var = self.kind(i + 1) == Some(Tok::Ident) && self.kind(i + 2) == Some(Tok::Assign);
        let first = if var { i + 3 } else { i + 1 };
        // The count: tokens up to the adjustment list, outside parentheses.
        let mut depth = 0usize;
        let mut j = first;
        let mut comma = false;
        loop {
            match self.kind(j)? {
                Tok::LParen | Tok::CallOpen => depth += 1,
                Tok::RParen => depth = depth.checked_sub(1)?,
                Tok::LBracket | Tok::LBrace if depth == 0 => break,
                Tok::Comma if depth == 0 => comma = true,
                Tok::RBrace | Tok::RBracket | Tok::Semi | Tok::KwLoop => return None,
                _ => {}
            }
            j += 1;
        }
        if j == first || comma {
            return None;
        }
        let count = self.src(first, j - 1);
        if var {
            // `loop i = N [ADJ]`: Context Free's i runs 0 … N - 1.
            let v = self.text(i + 1).to_string();
            let span = self.span(i, j - 1);
            self.diags.push(
                error(span, format!("`loop {v} = {count}` (one bound) is Context Free's: MDG writes both bounds"))
                    .with_suggestion(format!("write `loop {v} = 0, {count}`"), span, format!("loop {v} = 0, {count}")),
            );
            // Recovery: `loop i = (N) - (N), N`, a start of 0 made of the tokens at hand.
            self.out.extend_from_slice(&self.toks[i..first]);
            let paren = |out: &mut Vec<Token>, s: &Self| {
                out.push(s.synth(Tok::LParen, first));
                out.extend_from_slice(&s.toks[first..j]);
                out.push(s.synth(Tok::RParen, j));
            };
            let mut out = std::mem::take(&mut self.out);
            paren(&mut out, self);
            out.push(self.synth(Tok::Minus, j));
            paren(&mut out, self);
            out.push(self.synth(Tok::Comma, j));
            out.extend_from_slice(&self.toks[first..j]);
            self.out = out;
            return Some(j);
        }
        let span = self.span(i, j - 1);
        self.diags.push(
            error(span, format!("`loop {count}` is Context Free's: MDG's iterator is `{count} * [ADJ] ITEM`"))
                .with_note(format!(
                    "MDG applies the adjustment before the first run too, so `{count} * [x 1]` starts one step on; \
                     `loop i = 0, {count} [ADJ]` starts at the untransformed frame as Context Free does"
                ))
                .with_suggestion(format!("write `{count} *`"), span, format!("{count} *")),
        );
        self.out.extend_from_slice(&self.toks[first..j]);
        let star = self.synth(Tok::Star, j);
        self.out.push(star);
        Some(j)
    }

    /// `[[ … ]]`: Context Free's adjustments in the written order, which is what every
    /// MDG list does.
    fn ordered_list(&mut self, i: usize) -> Option<usize> {
        let inner_close = self.closing(i + 1)?;
        let outer_close = self.closing(i)?;
        let adjacent = self.toks[inner_close].span.end == self.toks[outer_close].span.start;
        if outer_close != inner_close + 1 || !adjacent {
            return None;
        }
        let inner = if inner_close > i + 2 { self.src(i + 2, inner_close - 1) } else { String::new() };
        let span = self.span(i, outer_close);
        self.diags.push(
            error(span, "`[[ … ]]` is Context Free's list in the written order: every MDG list keeps it".to_string())
                .with_suggestion(format!("write `{{{inner}}}`"), span, format!("{{{inner}}}")),
        );
        // Read as the inner list.
        self.out.push(self.toks[i + 1]);
        self.out.extend_from_slice(&self.toks[i + 2..inner_close]);
        self.out.push(self.toks[inner_close]);
        Some(outer_close + 1)
    }

    /// `X(=)`: the calling rule's own arguments.
    fn same_arguments(&mut self, i: usize) -> Option<usize> {
        let eq = self.toks[i + 1];
        let names: Vec<String> = self.params.iter().map(|t| self.sources.text(t.span).to_string()).collect();
        let mut d = error(
            self.span(i, i + 2),
            format!("`{}=)` is Context Free's (the calling rule's own arguments): MDG writes them", self.text(i)),
        );
        if names.is_empty() {
            d = d.with_note("the rule around this call has no parameters to pass");
        } else {
            let list = names.join(", ");
            d = d.with_suggestion(format!("write `{list}`"), eq.span, list);
        }
        self.diags.push(d);
        self.out.push(self.toks[i]);
        let params = self.params.clone();
        for (k, p) in params.iter().enumerate() {
            if k > 0 {
                self.out.push(self.synth(Tok::Comma, i + 1));
            }
            // The name read at the `=` (its text is the parameter's).
            self.out.push(Token { kind: p.kind, span: p.span });
        }
        Some(i + 2)
    }

    /// `switch (E) { case A: … case B, C..D: … else: … }`: MDG's own `switch`, in
    /// Context Free's spelling. Retags `switch`, each arm's `case` and the default
    /// arm's `else` (so a rule named `switch` or `case` stays a name). The arms'
    /// tokens then flow on through this pass like any others.
    fn switch(&mut self, i: usize, open: usize) -> Option<usize> {
        let close_e = self.closing(open)?;
        let lbrace = close_e + 1;
        if self.kind(lbrace) != Some(Tok::LBrace) {
            return None;
        }
        let rbrace = self.closing(lbrace)?;
        // A call of a rule named `switch` (`switch(1) {x 1}`): the block of a `switch`
        // opens with an arm.
        let arm_first = (self.kind(lbrace + 1) == Some(Tok::Ident) && self.text(lbrace + 1) == "case")
            || (self.kind(lbrace + 1) == Some(Tok::KwElse) && self.kind(lbrace + 2) == Some(Tok::Colon));
        if !arm_first {
            return None;
        }
        let mut depth = 0usize;
        for j in lbrace + 1..rbrace {
            let k = self.toks[j].kind;
            if depth == 0 {
                if k == Tok::Ident && self.text(j) == "case" {
                    self.toks[j].kind = Tok::KwCase;
                } else if k == Tok::KwElse && self.kind(j + 1) == Some(Tok::Colon) {
                    self.toks[j].kind = Tok::KwDefault;
                }
            }
            match k {
                Tok::LBrace | Tok::LBracket | Tok::IndexOpen | Tok::LParen | Tok::CallOpen => depth += 1,
                Tok::RBrace | Tok::RBracket | Tok::RParen => depth = depth.saturating_sub(1),
                _ => {}
            }
        }
        let s = self.toks[i].span;
        if self.kind(i) == Some(Tok::CallOpen) {
            // `switch(`: the keyword, then its parenthesis.
            self.out.push(Token { kind: Tok::KwSwitch, span: Span::new(s.file, s.start, s.end - 1) });
            self.out.push(Token { kind: Tok::LParen, span: Span::new(s.file, s.end - 1, s.end) });
        } else {
            self.out.push(Token { kind: Tok::KwSwitch, span: s });
        }
        Some(i + 1)
    }
}

/// Context Free's hue (degrees), saturation and brightness as red, green and blue.
pub fn hsb_to_rgb(h: f64, s: f64, b: f64) -> [f64; 3] {
    let h = h.rem_euclid(360.0) / 60.0;
    let c = b * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, bl) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = b - c;
    [r + m, g + m, bl + m]
}

/// Context Free's functions that MDG writes otherwise: the MDG expression for the call
/// `name(args)` (arguments as printed source), with what Context Free's function does.
/// Meaning, not spelling: `randint` is `floor(rand(…))`, not `randn`.
pub fn function(name: &str, args: &[String]) -> Option<(String, &'static str)> {
    // An argument inside a larger expression, parenthesised unless it is one word.
    let p = |s: &String| {
        if s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.') {
            s.clone()
        } else {
            format!("({s})")
        }
    };
    Some(match (name, args) {
        ("randint", []) => ("floor(rand(0, 2))".to_string(), "Context Free's `randint()` is 0 or 1"),
        ("randint", [b]) => {
            (format!("floor(rand(0, {b}))"), "Context Free's `randint(n)` is a whole number from 0 up to n, n excluded")
        }
        ("randint", [a, b]) => (
            format!("floor(rand({a}, {b}))"),
            "Context Free's `randint(a, b)` is a whole number from a up to b, b excluded",
        ),
        ("div", [a, b]) => {
            (format!("floor({} / {})", p(a), p(b)), "Context Free's `div(a, b)` is whole-number division")
        }
        ("log10", [x]) => {
            (format!("log({x}) / log(10)"), "Context Free's `log10` is the base-10 logarithm; MDG's `log` is natural")
        }
        ("hypot", [a, b]) => (
            format!("sqrt({} * {} + {} * {})", p(a), p(a), p(b), p(b)),
            "Context Free's `hypot(a, b)` is the length √(a² + b²)",
        ),
        ("cosh", [x]) => (format!("(exp({x}) + exp(-{})) / 2", p(x)), "Context Free's `cosh` is the hyperbolic cosine"),
        ("sinh", [x]) => (format!("(exp({x}) - exp(-{})) / 2", p(x)), "Context Free's `sinh` is the hyperbolic sine"),
        ("sg", [x]) => {
            (format!("step(0, {x}) * 2 - 1"), "Context Free's `sg` is the sign (this MDG form gives 1 at 0)")
        }
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use crate::source::Sources;

    /// Every prefix and every one-character cut of a program full of Context Free's
    /// constructs is rewritten without a panic, and each token rewritten keeps a span
    /// inside the file.
    #[test]
    fn truncated_and_cut_context_free_never_panics() {
        let program = "startshape tree(8) [hue 3]\nCF::MinimumSize = 0.01\nCF::Background = [b -1 sat 0.5]\n\
            import \"a.cfdg\"\nshape leaf\nrule 2 { SQUARE [] }\nrule { CIRCLE [] }\n\
            shape tree(natural n) {\n  loop 3 [x 1] leaf []\n  loop i = n [y 1] leaf []\n  tree(n--1) []\n  tree(=) [[x 1 r 2]]\n\
            switch (n) { case 1: leaf [] case 2, 3..4: { leaf [] } else: leaf [] }\n}\npath p { MOVETO(0, 0) }\n";
        let mut cuts: Vec<String> =
            (0..=program.len()).filter(|i| program.is_char_boundary(*i)).map(|i| program[..i].to_string()).collect();
        cuts.extend((0..program.len()).map(|i| format!("{}{}", &program[..i], &program[i + 1..])));
        for text in cuts {
            let mut sources = Sources::default();
            let id = sources.add("t.mdg", "t.mdg", text.as_str());
            let tokens = crate::lexer::lex(&text, id).tokens;
            let (out, diags) = super::rewrite(tokens, &sources);
            for t in &out {
                assert!(t.span.end as usize <= text.len() && t.span.start <= t.span.end, "{text:?}");
            }
            for d in &diags {
                assert!(d.span.end as usize <= text.len(), "{text:?}");
            }
            // And the whole pipeline takes it.
            let _ = crate::parse::parse_file(&sources, id);
        }
    }
}
