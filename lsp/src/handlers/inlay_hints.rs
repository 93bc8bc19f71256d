//! `textDocument/inlayHint`: per-step transforms of divisor iterators, and
//! parameter names at rule calls.

use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The hints in a range.
pub async fn inlay_hint(b: &Backend, p: InlayHintParams) -> Result<Option<Vec<InlayHint>>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("inlay hints", || {
        let li = LineIndex::new(doc.text());
        let (start, end) = (li.offset(p.range.start), li.offset(p.range.end));
        let hints = doc
            .inlay_hints(start, end)
            .into_iter()
            .map(|h| InlayHint {
                position: li.position(h.offset),
                label: InlayHintLabel::String(h.label),
                kind: h.parameter.then_some(InlayHintKind::PARAMETER),
                text_edits: None,
                tooltip: Some(InlayHintTooltip::String(h.tooltip)),
                padding_left: Some(!h.parameter),
                padding_right: Some(h.parameter),
                data: None,
            })
            .collect();
        Some(hints)
    })
    .await
}
