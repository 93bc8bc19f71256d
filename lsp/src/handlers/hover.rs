//! `textDocument/hover`.

use super::at_position;
use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The Markdown hover at a position.
pub async fn hover(b: &Backend, p: HoverParams) -> Result<Option<Hover>> {
    let Some((doc, offset)) = at_position(b, &p.text_document_position_params).await else { return Ok(None) };
    b.run("hover", || {
        let h = doc.hover(offset)?;
        let li = LineIndex::new(doc.text());
        Some(Hover {
            contents: HoverContents::Markup(MarkupContent { kind: MarkupKind::Markdown, value: h.markdown }),
            range: Some(li.range(h.span.start, h.span.end)),
        })
    })
    .await
}
