//! Formatting: the same canonical layout as `mdgc fmt`, as one minimal edit.

use super::{Document, Edit};
use crate::span::{FileId, Span};

impl Document {
    /// The edit that formats the document: `Ok(None)` when it is already formatted,
    /// `Err` (rendered syntax errors) when it does not parse.
    pub fn format(&self) -> Result<Option<Edit>, String> {
        format_edit(self.main_file(), self.text())
    }
}

/// The edit that formats `text` (the contents of `file`): the formatted text
/// replacing only the part that changes, so the editor keeps the cursor in place.
pub fn format_edit(file: FileId, text: &str) -> Result<Option<Edit>, String> {
    let formatted = crate::fmt::format_source(text)?;
    if formatted == text {
        return Ok(None);
    }
    let prefix = common_prefix(text, &formatted);
    let suffix = common_suffix(&text[prefix..], &formatted[prefix..]);
    let span = Span::new(file, prefix as u32, (text.len() - suffix) as u32);
    Ok(Some(Edit { span, new_text: formatted[prefix..formatted.len() - suffix].to_string() }))
}

/// The length in bytes of the longest common prefix, on a char boundary.
fn common_prefix(a: &str, b: &str) -> usize {
    a.char_indices().zip(b.chars()).find(|((_, ca), cb)| ca != cb).map(|((i, _), _)| i).unwrap_or(a.len().min(b.len()))
}

/// The length in bytes of the longest common suffix, on a char boundary.
fn common_suffix(a: &str, b: &str) -> usize {
    let mut n = 0;
    for (ca, cb) in a.chars().rev().zip(b.chars().rev()) {
        if ca != cb {
            break;
        }
        n += ca.len_utf8();
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(text: &str, e: &Edit) -> String {
        let mut out = text.to_string();
        out.replace_range(e.span.range(), &e.new_text);
        out
    }

    #[test]
    fn formats_like_mdgc_fmt_with_a_small_edit() {
        let src = "startshape A\nrule A {\nVERTEX {x 1}   VERTEX {y 1}\n}\n";
        let e = format_edit(FileId(0), src).expect("parses").expect("changes");
        assert_eq!(apply(src, &e), crate::fmt::format_source(src).expect("fmt"));
        assert!(e.span.start > 0, "the unchanged start is kept: {e:?}");
        let formatted = apply(src, &e);
        assert_eq!(format_edit(FileId(0), &formatted), Ok(None));
    }

    #[test]
    fn formats_sections() {
        let src = "guide left {points 0 0 0\n  0 0 1 ; delta_a 0.6;}\ncreature m { part p { type t; slot s { at 0 0 1; } } }\n";
        let e = format_edit(FileId(0), src).expect("parses").expect("changes");
        let formatted = apply(src, &e);
        assert_eq!(formatted, crate::fmt::format_source(src).expect("fmt"));
        assert!(
            formatted.contains("  part p {\n    type t;\n    slot s {\n      at 0 0 1;\n    }\n  }\n"),
            "{formatted}"
        );
        assert_eq!(format_edit(FileId(0), &formatted), Ok(None));
        assert!(format_edit(FileId(0), "guide g { points 0 0").is_err());
    }

    #[test]
    fn unicode_and_syntax_errors() {
        let src = "// é ü 😀\nrule A {   VERTEX {} }\n";
        let e = format_edit(FileId(0), src).expect("parses").expect("changes");
        assert_eq!(apply(src, &e), crate::fmt::format_source(src).expect("fmt"));
        assert!(format_edit(FileId(0), "rule A { VERTEX {").is_err());
    }
}
