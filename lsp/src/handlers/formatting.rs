//! `textDocument/formatting` and `textDocument/rangeFormatting`: `mdgc fmt`'s
//! layout, of the whole file or of the top-level items a range touches. They need
//! only the text, not an analysis; a file with syntax errors is left alone, and the
//! user is told why.

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::formatting::{format_edit, format_range_edit, FormatEditError};
use mdg_compiler::analysis::Edit;
use mdg_compiler::fmt::FormatError;
use mdg_compiler::span::FileId;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The edit that formats a document.
pub async fn formatting(b: &Backend, p: DocumentFormattingParams) -> Result<Option<Vec<TextEdit>>> {
    let Some(text) = b.docs.text(&p.text_document.uri) else { return Ok(None) };
    let result = b.run("formatting", || format_edit(FileId(0), &text)).await?;
    answer(b, &text, result).await
}

/// The edit that formats the top-level items (rules, directives, sections) that
/// overlap a range.
pub async fn range_formatting(b: &Backend, p: DocumentRangeFormattingParams) -> Result<Option<Vec<TextEdit>>> {
    let Some(text) = b.docs.text(&p.text_document.uri) else { return Ok(None) };
    let result = b
        .run("range formatting", || {
            let li = LineIndex::new(&text);
            format_range_edit(FileId(0), &text, li.offset(p.range.start), li.offset(p.range.end))
        })
        .await?;
    answer(b, &text, result).await
}

/// The edits of a formatting result; a refusal is said where the user looks.
async fn answer(
    b: &Backend,
    text: &str,
    result: std::result::Result<Option<Edit>, FormatEditError>,
) -> Result<Option<Vec<TextEdit>>> {
    match result {
        Ok(edit) => {
            let li = LineIndex::new(text);
            Ok(Some(
                edit.map(|e| vec![TextEdit { range: li.range(e.span.start, e.span.end), new_text: e.new_text }])
                    .unwrap_or_default(),
            ))
        }
        Err(error) => {
            // The rendered errors can be long; the first one says enough.
            let text = error.to_string();
            let first: String = text.lines().take(3).collect::<Vec<_>>().join("\n");
            let message = match error {
                FormatEditError::Format(FormatError::Syntax(_)) => {
                    format!("MDG: not formatting, the file has syntax errors:\n{first}")
                }
                _ => format!("MDG: not formatting: {first}"),
            };
            b.client.log_message(MessageType::INFO, &message).await;
            // Said where the user looks: formatting that silently does nothing looks broken.
            b.client.show_message(MessageType::WARNING, message).await;
            Ok(None)
        }
    }
}
