//! One file per LSP feature. Each handler converts positions to byte offsets, asks
//! the analysis API under the panic guard, and converts the answer back.

pub mod analysis;
pub mod call_hierarchy;
pub mod capabilities;
pub mod code_actions;
pub mod code_lens;
pub mod colors;
pub mod commands;
pub mod completion;
pub mod definition;
pub mod diagnostics;
pub mod document_links;
pub mod document_symbols;
pub mod folding;
pub mod formatting;
pub mod highlight;
pub mod hover;
pub mod inlay_hints;
pub mod preview;
pub mod references;
pub mod rename;
pub mod selection_range;
pub mod semantic_tokens;
pub mod signature_help;
pub mod sync;
pub mod workspace;
pub mod workspace_symbols;

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::Document;
use std::sync::Arc;
use tower_lsp_server::ls_types::{TextDocumentPositionParams, Uri};

/// The document and byte offset of a position request, if the document is open.
pub(crate) async fn at_position(b: &Backend, p: &TextDocumentPositionParams) -> Option<(Arc<Document>, u32)> {
    let doc = b.document(&p.text_document.uri).await?;
    let offset = LineIndex::new(doc.text()).offset(p.position);
    Some((doc, offset))
}

/// The URI of a position request.
pub(crate) fn uri(p: &TextDocumentPositionParams) -> &Uri {
    &p.text_document.uri
}

/// Byte-offset edits (in any file of the analysis) as a workspace edit.
pub(crate) fn workspace_edit(
    b: &Backend,
    doc: &Document,
    main_uri: &Uri,
    edits: &[mdg_compiler::analysis::Edit],
) -> tower_lsp_server::ls_types::WorkspaceEdit {
    use tower_lsp_server::ls_types::TextEdit;
    let mut changes: std::collections::HashMap<Uri, Vec<TextEdit>> = std::collections::HashMap::new();
    for e in edits {
        let Some(uri) = b.uri_of(doc, main_uri, e.span.file) else { continue };
        let li = LineIndex::new(doc.file_text(e.span.file));
        changes
            .entry(uri)
            .or_default()
            .push(TextEdit { range: li.range(e.span.start, e.span.end), new_text: e.new_text.clone() });
    }
    tower_lsp_server::ls_types::WorkspaceEdit { changes: Some(changes), ..Default::default() }
}
