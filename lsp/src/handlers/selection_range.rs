//! `textDocument/selectionRange`: for each position, the word, then each enclosing
//! node of the syntax tree, then the file.

use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The nested ranges at each position.
pub async fn selection_range(b: &Backend, p: SelectionRangeParams) -> Result<Option<Vec<SelectionRange>>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("selection range", || {
        let li = LineIndex::new(doc.text());
        let out = p
            .positions
            .iter()
            .map(|pos| {
                let spans = doc.selection_ranges(li.offset(*pos));
                let mut range: Option<SelectionRange> = None;
                for s in spans.iter().rev() {
                    range = Some(SelectionRange { range: li.range(s.start, s.end), parent: range.map(Box::new) });
                }
                range.unwrap_or(SelectionRange { range: Range { start: *pos, end: *pos }, parent: None })
            })
            .collect();
        Some(out)
    })
    .await
}
