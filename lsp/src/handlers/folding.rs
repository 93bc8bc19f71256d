//! `textDocument/foldingRange`: line ranges; a closing `}` on its own line stays visible.

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::FoldKind;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The folding ranges of a document.
pub async fn folding_range(b: &Backend, p: FoldingRangeParams) -> Result<Option<Vec<FoldingRange>>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("folding", || {
        let text = doc.text();
        let li = LineIndex::new(text);
        let mut out = Vec::new();
        for f in doc.folding_ranges() {
            let start_line = li.position(f.span.start).line;
            let mut end_line = li.position(f.span.end).line;
            let closing = text[..(f.span.end as usize).min(text.len())].trim_end();
            let line_start = closing.rfind('\n').map(|i| i + 1).unwrap_or(0);
            if f.kind == FoldKind::Region
                && matches!(closing[line_start..].trim(), "}" | "]" | "@endif" | "@endmacro" | "@endshader")
            {
                end_line = end_line.saturating_sub(1);
            }
            if end_line > start_line {
                out.push(FoldingRange {
                    start_line,
                    end_line,
                    kind: Some(match f.kind {
                        FoldKind::Region => FoldingRangeKind::Region,
                        FoldKind::Comment => FoldingRangeKind::Comment,
                        FoldKind::Imports => FoldingRangeKind::Imports,
                    }),
                    ..Default::default()
                });
            }
        }
        Some(out)
    })
    .await
}
