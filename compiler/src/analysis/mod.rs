//! The editor-facing analysis API: one document's analysis, queried by byte offset.
//!
//! A [`Document`] is the result of [`crate::driver::analyze_text`] on one open file
//! plus a lazily built occurrence index. Every query takes and returns byte offsets
//! ([`Span`]s, whose `file` says which source file they are in); the language server
//! converts them to editor positions (UTF-16) at its edge. **Boundary:** no LSP types
//! and no IO here — the std library list for completion is passed in.
//!
//! One file per feature: [`hover`], [`navigation`] (definition, references),
//! [`rename`], [`completion`], [`symbols`] (document and workspace), [`semantic_tokens`],
//! [`folding`], [`formatting`], [`code_actions`], [`inlay_hints`], [`signature`],
//! [`lenses`], [`calls`] (call hierarchy), [`selection`], [`colors`] and [`diagnostics`];
//! [`docs`] holds the documentation of every built-in word.

pub mod calls;
pub mod code_actions;
pub mod colors;
pub mod completion;
pub mod diagnostics;
pub mod docs;
pub mod folding;
pub mod formatting;
pub mod hover;
pub mod index;
pub mod inlay_hints;
pub mod iterator;
pub mod lenses;
pub mod navigation;
pub mod rename;
pub mod selection;
pub mod semantic_tokens;
pub mod signature;
pub mod symbols;

#[cfg(test)]
mod fixture;
#[cfg(test)]
mod incremental;
#[cfg(test)]
mod robustness;

use crate::check::CheckOptions;
use crate::driver::{self, Analysis};
use crate::expand::Options;
use crate::source::FileLoader;
use crate::span::{FileId, Span};
use std::path::Path;
use std::sync::OnceLock;

pub use calls::{OutgoingCall, RuleDef};
pub use code_actions::CodeAction;
pub use colors::{ColorForm, ColorLiteral};
pub use completion::{CompletionConfig, CompletionItem, CompletionKind, Completions};
pub use folding::{Fold, FoldKind};
pub use hover::Hover;
pub use index::Symbol;
pub use inlay_hints::InlayHint;
pub use lenses::{LensKind, LensTarget};
pub use semantic_tokens::{SemanticKind, SemanticToken};
pub use signature::SignatureHelp;
pub use symbols::{DocumentSymbol, SymbolKind, WorkspaceSymbol};

/// A text edit: replace `span` (in the file `span.file`) with `new_text`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Edit {
    pub span: Span,
    pub new_text: String,
}

/// The largest document the language server analyses as the user types, in bytes
/// (2 MiB; a valid 2 MB grammar takes about 260 MB to analyse). Larger ones get
/// [`Document::too_large`].
pub const MAX_LIVE_BYTES: usize = 2 << 20;

/// One analysed document.
pub struct Document {
    analysis: Analysis,
    main: FileId,
    index: OnceLock<index::Index>,
}

impl Document {
    /// Analyses `text` as the file at `path`; imports are read through `loader`.
    /// Files are checked as libraries unless they have a `startshape`.
    pub fn new(loader: &dyn FileLoader, path: &Path, text: &str, opts: &Options) -> Document {
        let analysis = driver::analyze_text(loader, path, text, opts, CheckOptions::default());
        Document::from_analysis(analysis)
    }

    /// [`Document::new`] with less work or a cancel check; `None` if it was
    /// cancelled. With `effort.skip_shaders` the shader blocks are not compiled: the
    /// document serves every feature but has no GLSL diagnostics.
    pub fn with_effort(
        loader: &dyn FileLoader,
        path: &Path,
        text: &str,
        opts: &Options,
        effort: driver::Effort,
    ) -> Option<Document> {
        driver::analyze_text_with(loader, path, text, opts, CheckOptions::default(), effort)
            .map(Document::from_analysis)
    }

    /// A document too large to analyse as the user types (`len` bytes, more than
    /// `limit`): nothing of it is analysed, and one W0012 warning at its start says so
    /// and how to check it. A 15 MB grammar took 5.8 GB and 29 s per analysis.
    pub fn too_large(loader: &dyn FileLoader, path: &Path, len: usize, limit: usize, opts: &Options) -> Document {
        let mut analysis = driver::analyze_text(loader, path, "", opts, CheckOptions::default());
        let main = analysis.expanded.files.first().copied().unwrap_or_default();
        let mib = |n: usize| n as f64 / (1 << 20) as f64;
        analysis.diagnostics = vec![crate::diag::Diagnostic::warning(
            "W0012",
            Span::new(main, 0, 0),
            format!(
                "this document is {:.1} MiB: the editor analyses documents of up to {:.1} MiB as you type",
                mib(len),
                mib(limit)
            ),
        )
        .with_label("not analysed")
        .with_note(
            "check it with `mdgc check FILE`; the language server's limit is raised with the environment \
             variable `MDG_LSP_MAX_LIVE_BYTES` (bytes), or split the grammar into files joined with `@import`",
        )];
        Document::from_analysis(analysis)
    }

    /// Wraps a finished analysis.
    pub fn from_analysis(analysis: Analysis) -> Document {
        let main = analysis.expanded.files.first().copied().unwrap_or_default();
        Document { analysis, main, index: OnceLock::new() }
    }

    /// The underlying analysis.
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// The id of the document's own file.
    pub fn main_file(&self) -> FileId {
        self.main
    }

    /// The document's text.
    pub fn text(&self) -> &str {
        self.file_text(self.main)
    }

    /// The text of a file of this analysis ("" for an unknown id).
    pub fn file_text(&self, file: FileId) -> &str {
        self.analysis.sources.files.get(file.0 as usize).map(|f| f.text.as_str()).unwrap_or("")
    }

    /// The path of a file of this analysis.
    pub fn file_path(&self, file: FileId) -> Option<&Path> {
        self.analysis.sources.files.get(file.0 as usize).map(|f| f.path.as_path())
    }

    /// Every file that took part, the document first.
    pub fn files(&self) -> &[FileId] {
        &self.analysis.expanded.files
    }

    pub(crate) fn index(&self) -> &index::Index {
        self.index.get_or_init(|| index::Index::build(&self.analysis, self.main))
    }

    /// The source text a span covers.
    pub(crate) fn span_text(&self, span: Span) -> &str {
        self.analysis.sources.text(span)
    }
}

/// Formats a span as `file:line` (1-based), for hover text.
pub(crate) fn location_text(doc: &Document, span: Span) -> String {
    let Some(f) = doc.analysis.sources.files.get(span.file.0 as usize) else { return String::new() };
    let line = f.line_col(span.start.min(f.text.len() as u32)).0 + 1;
    if span.file == doc.main {
        format!("line {line}")
    } else {
        format!("{}:{line}", f.name)
    }
}
