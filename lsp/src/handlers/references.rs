//! `textDocument/references`.

use super::{at_position, uri};
use crate::server::Backend;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// Every use of the symbol at a position, in every file of the analysis.
pub async fn references(b: &Backend, p: ReferenceParams) -> Result<Option<Vec<Location>>> {
    let pos = &p.text_document_position;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    b.run("references", || {
        let spans = doc.references(offset, p.context.include_declaration);
        Some(spans.into_iter().filter_map(|s| b.location(&doc, uri(pos), s)).collect())
    })
    .await
}
