//! `textDocument/documentHighlight`: the symbol's occurrences in this document.

use super::at_position;
use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// Definitions (write) and uses (read) of the symbol at a position.
pub async fn highlight(b: &Backend, p: DocumentHighlightParams) -> Result<Option<Vec<DocumentHighlight>>> {
    let Some((doc, offset)) = at_position(b, &p.text_document_position_params).await else { return Ok(None) };
    b.run("highlight", || {
        let li = LineIndex::new(doc.text());
        let v: Vec<DocumentHighlight> = doc
            .highlights(offset)
            .into_iter()
            .map(|(s, def)| DocumentHighlight {
                range: li.range(s.start, s.end),
                kind: Some(if def { DocumentHighlightKind::WRITE } else { DocumentHighlightKind::READ }),
            })
            .collect();
        (!v.is_empty()).then_some(v)
    })
    .await
}
