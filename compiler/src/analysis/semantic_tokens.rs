//! Semantic tokens: what each word of the document is — rule, drawable, adjustment,
//! directive, number (and its unit), comment, preprocessor word, section key and
//! string — for highlighting that a TextMate grammar cannot do (a rule call and a
//! drawable look alike).

use super::index::{Occ, Symbol};
use super::Document;
use crate::check::DRAWABLES;
use crate::lexer::Tok;
use crate::span::Span;

/// What a semantic token is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SemanticKind {
    Rule,
    Drawable,
    Isosurface,
    Adjustment,
    /// A directive or keyword (`rule`, `maxdepth`, `xyz`, `render`).
    Keyword,
    /// A selector or angle mode.
    Mode,
    Number,
    /// The unit suffix of a number (`d r o t`).
    Unit,
    Comment,
    /// `@import`, `@ifdef`, …
    Preprocessor,
    Macro,
    Namespace,
    /// A user function (`function NAME`).
    Function,
    /// A built-in expression function (`sin`).
    MathFunction,
    /// `x y z depth scale g` in expressions.
    Variable,
    /// A `@param` or `@define` name.
    Constant,
    /// A word of an `@import` line.
    Import,
    Shader,
    /// The continuation `\`.
    Operator,
    /// A key of an extension section.
    Property,
    /// A `"string"` (section values).
    String,
    /// A rule parameter.
    Parameter,
    /// A `let` binding or loop variable.
    Local,
}

/// One token: a span in the document (it may cross lines only for comments).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SemanticToken {
    pub span: Span,
    pub kind: SemanticKind,
    /// Whether this is the defining occurrence.
    pub declaration: bool,
}

impl Document {
    /// Every semantic token of the document, in order, not overlapping.
    pub fn semantic_tokens(&self) -> Vec<SemanticToken> {
        let idx = self.index();
        let mut raw: Vec<(SemanticToken, u8)> = Vec::new();
        let mut push = |span: Span, kind: SemanticKind, declaration: bool, rank: u8| {
            if span.end > span.start {
                raw.push((SemanticToken { span, kind, declaration }, rank));
            }
        };
        for o in &idx.main {
            let (kind, decl) = match &o.occ {
                Occ::Def(s) => (symbol_kind(s), true),
                Occ::Ref(s) => (symbol_kind(s), false),
                Occ::UnknownRule(_) => (SemanticKind::Rule, false),
                Occ::Import(_) => (SemanticKind::Import, false),
                Occ::Drawable(_) => (SemanticKind::Drawable, false),
                Occ::Adjustment(_) => (SemanticKind::Adjustment, false),
                Occ::Directive(_) | Occ::IsoEntry(_) | Occ::ProgramCommand(_) => (SemanticKind::Keyword, false),
                Occ::SelectorMode(_) | Occ::AngleMode(_) => (SemanticKind::Mode, false),
                Occ::Preprocessor(_) => (SemanticKind::Preprocessor, false),
                Occ::MathFunction(_) => (SemanticKind::MathFunction, false),
                Occ::Variable(_) => (SemanticKind::Variable, false),
                Occ::Define(_) => (SemanticKind::Constant, false),
                Occ::SectionKey(_) => (SemanticKind::Property, false),
                Occ::Iterator(_) | Occ::Number { .. } => continue,
            };
            let span = match kind {
                // `ns.rule`: the namespace part has its own token.
                SemanticKind::Rule | SemanticKind::Drawable => last_segment(self, o.span),
                _ => o.span,
            };
            push(span, kind, decl, o.occ_rank());
        }
        let text = self.text();
        let covered: std::collections::HashSet<u32> = idx.main.iter().map(|o| o.span.start).collect();
        for t in &idx.tokens {
            match t.kind {
                Tok::Number => {
                    let s = text.get(t.span.range()).unwrap_or("");
                    if s.ends_with(['d', 'r', 'o', 't']) {
                        push(Span::new(t.span.file, t.span.start, t.span.end - 1), SemanticKind::Number, false, 1);
                        push(Span::new(t.span.file, t.span.end - 1, t.span.end), SemanticKind::Unit, false, 1);
                    } else {
                        push(t.span, SemanticKind::Number, false, 1);
                    }
                }
                Tok::Backslash => push(t.span, SemanticKind::Operator, false, 1),
                Tok::Str => push(t.span, SemanticKind::String, false, 1),
                // Inside macro bodies names are not resolved; drawables are still known.
                Tok::Ident
                    if !covered.contains(&t.span.start)
                        && DRAWABLES.contains(&text.get(t.span.range()).unwrap_or("")) =>
                {
                    push(t.span, SemanticKind::Drawable, false, 1);
                }
                _ => {}
            }
        }
        for c in &idx.comments {
            push(c.span, SemanticKind::Comment, false, 1);
        }
        raw.sort_by_key(|(t, rank)| (t.span.start, *rank, std::cmp::Reverse(t.span.end)));
        let mut out: Vec<SemanticToken> = Vec::with_capacity(raw.len());
        let mut end = 0u32;
        for (t, _) in raw {
            if t.span.start >= end || out.is_empty() {
                end = t.span.end;
                out.push(t);
            }
        }
        out
    }
}

impl super::index::Occurrence {
    fn occ_rank(&self) -> u8 {
        match self.occ {
            Occ::Def(_) | Occ::Ref(_) => 0,
            _ => 1,
        }
    }
}

fn symbol_kind(s: &Symbol) -> SemanticKind {
    match s {
        Symbol::Rule(_) => SemanticKind::Rule,
        Symbol::Namespace(_) => SemanticKind::Namespace,
        Symbol::Function(_) => SemanticKind::Function,
        Symbol::Isosurface(_) => SemanticKind::Isosurface,
        Symbol::Macro(_) => SemanticKind::Macro,
        Symbol::Shader { .. } => SemanticKind::Shader,
        Symbol::Local { what, .. } if what.starts_with("parameter") => SemanticKind::Parameter,
        Symbol::Local { .. } => SemanticKind::Local,
    }
}

fn last_segment(doc: &Document, span: Span) -> Span {
    match doc.span_text(span).rfind('.') {
        Some(i) => Span::new(span.file, span.start + i as u32 + 1, span.end),
        None => span,
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    fn tokens(src: &str) -> String {
        let (d, _) = doc(src);
        d.semantic_tokens()
            .iter()
            .map(|t| format!("{:?}{} {:?}", t.kind, if t.declaration { "*" } else { "" }, d.span_text(t.span)))
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn classifies_every_kind_of_word() {
        let src = "\
// a comment
@import primitives
startshape A
angle degrees
namespace port { rule arm { VERTEX {} } }
rule A {
  30/30 * [ry 360] port.arm {s 0.5}
  cube {rz 0.25o} \\
  LINETO {x (sin(1))}
}";
        let expected = "\
Comment \"// a comment\"
Preprocessor \"@import\"
Import \"primitives\"
Keyword \"startshape\"
Rule \"A\"
Keyword \"angle\"
Mode \"degrees\"
Keyword \"namespace\"
Namespace* \"port\"
Keyword \"rule\"
Rule* \"arm\"
Drawable \"VERTEX\"
Keyword \"rule\"
Rule* \"A\"
Number \"30\"
Number \"30\"
Adjustment \"ry\"
Number \"360\"
Namespace \"port\"
Rule \"arm\"
Adjustment \"s\"
Number \"0.5\"
Rule \"cube\"
Adjustment \"rz\"
Number \"0.25\"
Unit \"o\"
Operator \"\\\\\"
Drawable \"LINETO\"
Adjustment \"x\"
MathFunction \"sin\"
Number \"1\"";
        assert_eq!(tokens(src), expected);
    }

    #[test]
    fn the_chain_backslash_of_an_iterator_is_an_operator() {
        let src = "rule A { 4/4 * {rz 360} \\ B {} }\nrule B { VERTEX {} }";
        let expected = "\
Keyword \"rule\"
Rule* \"A\"
Number \"4\"
Number \"4\"
Adjustment \"rz\"
Number \"360\"
Operator \"\\\\\"
Rule \"B\"
Keyword \"rule\"
Rule* \"B\"
Drawable \"VERTEX\"";
        assert_eq!(tokens(src), expected);
    }

    #[test]
    fn sections_keys_strings_and_values() {
        let src = "\
@define W 2
creature m {
  part p { rule leaf; mesh \"parts/a b.obj\"; slot s { at 0 0 (W * 2); turn 0.25o; } }
}
rule leaf { VERTEX {} }";
        let expected = "\
Preprocessor \"@define\"
Constant \"W\"
Keyword \"creature\"
Property \"part\"
Property \"rule\"
Rule \"leaf\"
Property \"mesh\"
String \"\\\"parts/a b.obj\\\"\"
Property \"slot\"
Property \"at\"
Number \"0\"
Number \"0\"
Constant \"W\"
Number \"2\"
Property \"turn\"
Number \"0.25\"
Unit \"o\"
Keyword \"rule\"
Rule* \"leaf\"
Drawable \"VERTEX\"";
        assert_eq!(tokens(src), expected);
    }

    #[test]
    fn tokens_are_ordered_and_disjoint_on_broken_text() {
        let (d, _) = doc("rule A { VERTEX {x 1 @macro M(\n rule { ] } 3t /* open");
        let toks = d.semantic_tokens();
        for w in toks.windows(2) {
            assert!(w[0].span.end <= w[1].span.start, "{w:?}");
        }
        assert!(toks.iter().all(|t| t.span.end as usize <= d.text().len()));
    }
}
