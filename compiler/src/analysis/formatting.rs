//! Formatting: the same canonical layout as `mdgc fmt`, as one minimal edit.

use super::{Document, Edit};
use crate::fmt::FormatError;
use crate::span::{FileId, Span};

/// Why a formatting edit is not offered.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum FormatEditError {
    /// The file cannot be formatted (syntax errors, or its formatted text would be
    /// refused).
    Format(FormatError),
    /// Formatting changes how many top-level items the file has, so a range of them
    /// cannot be formatted alone.
    ItemCount { before: usize, after: usize },
}

impl From<FormatError> for FormatEditError {
    fn from(e: FormatError) -> Self {
        FormatEditError::Format(e)
    }
}

impl std::fmt::Display for FormatEditError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FormatEditError::Format(e) => write!(f, "{e}"),
            FormatEditError::ItemCount { before, after } => write!(
                f,
                "the file has {before} top-level items but formats into {after}; format the whole document instead"
            ),
        }
    }
}

impl std::error::Error for FormatEditError {}

impl Document {
    /// The edit that formats the document: `Ok(None)` when it is already formatted,
    /// `Err` (rendered syntax errors) when it does not parse.
    pub fn format(&self) -> Result<Option<Edit>, FormatEditError> {
        format_edit(self.main_file(), self.text())
    }
}

/// The edit that formats `text` (the contents of `file`): the formatted text
/// replacing only the part that changes, so the editor keeps the cursor in place.
pub fn format_edit(file: FileId, text: &str) -> Result<Option<Edit>, FormatEditError> {
    let formatted = crate::fmt::format_source(text)?;
    if formatted == text {
        return Ok(None);
    }
    let prefix = common_prefix(text, &formatted);
    let suffix = common_suffix(&text[prefix..], &formatted[prefix..]);
    let span = Span::new(file, prefix as u32, (text.len() - suffix) as u32);
    Ok(Some(Edit { span, new_text: formatted[prefix..formatted.len() - suffix].to_string() }))
}

/// The edit that formats only the top-level items (rules, directives, sections…)
/// that overlap the bytes `start..end` of `text` (an empty range: the item it is
/// in), each laid out as `mdgc fmt` lays it out in the whole file. `Ok(None)` when
/// they are formatted already or the range touches no item; `Err` says why not.
pub fn format_range_edit(file: FileId, text: &str, start: u32, end: u32) -> Result<Option<Edit>, FormatEditError> {
    let formatted = crate::fmt::format_source(text)?;
    let before = top_items(text);
    let after = top_items(&formatted);
    if before.len() != after.len() {
        return Err(FormatEditError::ItemCount { before: before.len(), after: after.len() });
    }
    let hit = |s: &Span| s.start <= end && start <= s.end;
    let Some(first) = before.iter().position(hit) else { return Ok(None) };
    let last = before.iter().rposition(hit).unwrap_or(first);
    let from = line_start_if_blank(text, before[first].start);
    let to = before[last].end as usize;
    let new_from = line_start_if_blank(&formatted, after[first].start);
    let new_to = after[last].end as usize;
    let (old, new) = (&text[from..to], &formatted[new_from..new_to]);
    if old == new {
        return Ok(None);
    }
    let prefix = common_prefix(old, new);
    let suffix = common_suffix(&old[prefix..], &new[prefix..]);
    let span = Span::new(file, (from + prefix) as u32, (to - suffix) as u32);
    Ok(Some(Edit { span, new_text: new[prefix..new.len() - suffix].to_string() }))
}

/// The spans of the top-level items of a text that parses.
fn top_items(text: &str) -> Vec<Span> {
    let mut sources = crate::source::Sources::default();
    let id = sources.add("<fmt>", "<input>", text);
    crate::parse::parse_file(&sources, id).file.items.iter().map(|i| i.span).collect()
}

/// The start of the line of `offset` when only blanks come before it there, else `offset`.
fn line_start_if_blank(text: &str, offset: u32) -> usize {
    let offset = (offset as usize).min(text.len());
    let line = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    if text[line..offset].chars().all(|c| c == ' ' || c == '\t') {
        line
    } else {
        offset
    }
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
        assert!(matches!(
            format_edit(FileId(0), "rule A { VERTEX {"),
            Err(FormatEditError::Format(FormatError::Syntax(e))) if e.contains("error[")
        ));
    }
}

#[cfg(test)]
mod range_tests {
    use super::*;

    fn apply(text: &str, e: &Edit) -> String {
        let mut out = text.to_string();
        out.replace_range(e.span.range(), &e.new_text);
        out
    }

    #[test]
    fn only_the_items_the_range_touches() {
        let src =
            "startshape A\nrule A {   VERTEX {} }\nnamespace n {\n    rule b {VERTEX {}}\n}\nrule C {VERTEX {}}\n";
        // A cursor inside the namespace: the whole namespace (one item) and nothing else.
        let at = src.find("rule b").unwrap_or(0) as u32;
        let e = format_range_edit(FileId(0), src, at, at).expect("parses").expect("changes");
        assert_eq!(
            apply(src, &e),
            "startshape A\nrule A {   VERTEX {} }\nnamespace n {\n  rule b {\n    VERTEX {}\n  }\n}\nrule C {VERTEX {}}\n"
        );
        // A range over two items formats both.
        let (s, t) = (src.find("rule A").unwrap_or(0) as u32, src.find("rule C").unwrap_or(0) as u32 + 2);
        let e = format_range_edit(FileId(0), src, s, t).expect("parses").expect("changes");
        assert_eq!(apply(src, &e), crate::fmt::format_source(src).expect("fmt"));
        // Formatted already: no edit.
        assert_eq!(format_range_edit(FileId(0), src, 0, 3), Ok(None));
        assert!(format_range_edit(FileId(0), "rule A { VERTEX {", 0, 1).is_err());
    }
}
