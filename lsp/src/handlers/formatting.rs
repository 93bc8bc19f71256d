//! `textDocument/formatting`: `mdgc fmt`'s layout. It needs only the text, not an
//! analysis; a file with syntax errors is left alone, and the user is told why.

use crate::position::LineIndex;
use crate::server::Backend;
use mdg_compiler::analysis::formatting::format_edit;
use mdg_compiler::span::FileId;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The edit that formats a document.
pub async fn formatting(b: &Backend, p: DocumentFormattingParams) -> Result<Option<Vec<TextEdit>>> {
    let Some(text) = b.docs.text(&p.text_document.uri) else { return Ok(None) };
    let result = b
        .run("formatting", || {
            format_edit(FileId(0), &text).map(|e| {
                e.map(|e| {
                    let li = LineIndex::new(&text);
                    vec![TextEdit { range: li.range(e.span.start, e.span.end), new_text: e.new_text }]
                })
            })
        })
        .await?;
    match result {
        Ok(edits) => Ok(Some(edits.unwrap_or_default())),
        Err(errors) => {
            // The rendered errors can be long; the first one says enough.
            let first: String = errors.lines().take(3).collect::<Vec<_>>().join("\n");
            let message = format!("MDG: not formatting, the file has syntax errors:\n{first}");
            b.client.log_message(MessageType::INFO, &message).await;
            // Said where the user looks: formatting that silently does nothing looks broken.
            b.client.show_message(MessageType::WARNING, message).await;
            Ok(None)
        }
    }
}
