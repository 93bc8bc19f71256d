//! Source positions: file ids, byte spans, and the packed parser location.

use serde::Serialize;

/// Index of a file in [`crate::source::Sources`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
pub struct FileId(pub u32);

/// A byte range in one source file. Spans are half-open: `start..end`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize)]
pub struct Span {
    pub file: FileId,
    pub start: u32,
    pub end: u32,
}

impl Span {
    /// A span in `file` from `start` to `end`.
    pub fn new(file: FileId, start: u32, end: u32) -> Span {
        Span { file, start, end }
    }

    /// The smallest span covering both, when they are in the same file; otherwise `self`.
    /// Spans of macro expansions can mix the macro body's file and the call site's.
    pub fn to(self, other: Span) -> Span {
        if self.file == other.file {
            Span { file: self.file, start: self.start.min(other.start), end: self.end.max(other.end) }
        } else {
            self
        }
    }

    /// Whether `offset` (in this span's file) lies inside the span, ends included.
    pub fn contains(&self, offset: u32) -> bool {
        self.start <= offset && offset <= self.end
    }

    /// The byte range as `usize`s, for slicing the file text.
    pub fn range(&self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// The parser's location type: a file id and a byte offset packed into one `u64`,
/// so tokens coming from several files (macro bodies, arguments) can share one stream.
pub type Loc = u64;

/// Packs a file and offset into a [`Loc`].
pub fn loc(file: FileId, offset: u32) -> Loc {
    ((file.0 as u64) << 32) | offset as u64
}

/// The span between two parser locations (`@L`, `@R`).
pub fn span_of(l: Loc, r: Loc) -> Span {
    let (fl, ol) = ((l >> 32) as u32, l as u32);
    let (fr, or) = ((r >> 32) as u32, r as u32);
    if fl == fr {
        Span::new(FileId(fl), ol, or.max(ol))
    } else {
        Span::new(FileId(fl), ol, ol)
    }
}
