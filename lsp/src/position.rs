//! Byte offsets ↔ LSP positions (zero-based line, UTF-16 column): the one place
//! where the server leaves the analysis API's byte offsets.
//!
//! Out-of-range input is clamped, never an error: a position past the end of a
//! line is the end of that line, a line past the end is the end of the text, a
//! byte offset inside a character counts as that character's start and a column
//! inside a surrogate pair as the next character.

use tower_lsp_server::ls_types::{Position, Range};

/// Line starts of one text, for converting positions.
pub struct LineIndex<'a> {
    text: &'a str,
    line_starts: Vec<u32>,
}

impl<'a> LineIndex<'a> {
    /// Indexes `text`.
    pub fn new(text: &'a str) -> LineIndex<'a> {
        // Line breaks are `\n`, `\r\n` and a lone `\r`, for LSP and the compiler alike.
        LineIndex { text, line_starts: mdg_compiler::source::line_starts(text) }
    }

    /// The position of a byte offset.
    pub fn position(&self, offset: u32) -> Position {
        let mut offset = (offset as usize).min(self.text.len());
        while !self.text.is_char_boundary(offset) {
            offset -= 1;
        }
        let line = match self.line_starts.binary_search(&(offset as u32)) {
            Ok(l) => l,
            Err(l) => l - 1,
        };
        let start = self.line_starts[line] as usize;
        let character = self.text[start..offset].encode_utf16().count() as u32;
        Position { line: line as u32, character }
    }

    /// The byte offset of a position.
    pub fn offset(&self, pos: Position) -> u32 {
        let Some(&start) = self.line_starts.get(pos.line as usize) else {
            return self.text.len() as u32;
        };
        let end = self.line_starts.get(pos.line as usize + 1).map(|e| *e as usize - 1).unwrap_or(self.text.len());
        let line = &self.text[start as usize..end];
        let line = line.strip_suffix('\r').unwrap_or(line);
        let mut units = 0u32;
        for (i, c) in line.char_indices() {
            if units >= pos.character {
                return start + i as u32;
            }
            units += c.len_utf16() as u32;
        }
        start + line.len() as u32
    }

    /// The range of a byte span.
    pub fn range(&self, start: u32, end: u32) -> Range {
        Range { start: self.position(start), end: self.position(end.max(start)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pos(line: u32, character: u32) -> Position {
        Position { line, character }
    }

    #[test]
    fn ascii_round_trips() {
        let text = "rule A {\n  VERTEX {}\n}\n";
        let li = LineIndex::new(text);
        for offset in 0..=text.len() as u32 {
            assert_eq!(li.offset(li.position(offset)), offset);
        }
        assert_eq!(li.position(11), pos(1, 2));
        assert_eq!(li.position(text.len() as u32), pos(3, 0));
    }

    #[test]
    fn utf16_columns_count_surrogate_pairs() {
        // 'é' is 2 bytes and 1 UTF-16 unit; '😀' is 4 bytes and 2 units.
        let text = "// é😀x\nA";
        let li = LineIndex::new(text);
        let x = text.find('x').expect("x") as u32;
        assert_eq!(li.position(x), pos(0, 6));
        assert_eq!(li.offset(pos(0, 6)), x);
        assert_eq!(li.offset(pos(1, 0)), text.len() as u32 - 1);
        // A column inside the surrogate pair moves to the next character; a byte
        // offset inside a character moves to its start.
        let emoji = text.find('😀').expect("emoji") as u32;
        assert_eq!(li.offset(pos(0, 5)), x);
        assert_eq!(li.position(emoji + 1), li.position(emoji));
    }

    #[test]
    fn a_lone_cr_ends_a_line_as_lsp_and_the_compiler_count_it() {
        // LSP's line breaks are `\n`, `\r\n` and `\r`; the compiler's line table
        // (`source::line_starts`) counts the same, so positions agree with spans.
        let text = "ab\rcd\r\nef\ngh";
        let li = LineIndex::new(text);
        assert_eq!(li.position(3), pos(1, 0), "after the lone CR");
        assert_eq!(li.position(7), pos(2, 0), "after CR LF");
        assert_eq!(li.offset(pos(1, 9)), 5, "end of `cd`, before CR LF");
        assert_eq!(li.offset(pos(0, 9)), 2, "end of `ab`, before the CR");
        assert_eq!(li.offset(pos(3, 1)), 11);
    }

    #[test]
    fn out_of_range_is_clamped() {
        let text = "ab\r\ncd";
        let li = LineIndex::new(text);
        assert_eq!(li.offset(pos(0, 99)), 2, "end of line, before \\r\\n");
        assert_eq!(li.offset(pos(7, 0)), text.len() as u32);
        assert_eq!(li.position(999), pos(1, 2));
        let empty = LineIndex::new("");
        assert_eq!(empty.position(5), pos(0, 0));
        assert_eq!(empty.offset(pos(3, 3)), 0);
    }
}
