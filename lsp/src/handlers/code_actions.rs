//! `textDocument/codeAction`: quick fixes from the compiler's suggestions and
//! "create rule" for undefined rules.

use super::workspace_edit;
use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The quick fixes for diagnostics in a range.
pub async fn code_action(b: &Backend, p: CodeActionParams) -> Result<Option<CodeActionResponse>> {
    let uri = &p.text_document.uri;
    let Some(doc) = b.document(uri).await else { return Ok(None) };
    b.run("code actions", || {
        let li = LineIndex::new(doc.text());
        let (start, end) = (li.offset(p.range.start), li.offset(p.range.end));
        let actions: Vec<CodeActionOrCommand> = doc
            .code_actions(start, end)
            .into_iter()
            .map(|a| {
                let diagnostic = super::diagnostics::convert(b, uri, &doc, &li, &a.diagnostic);
                CodeActionOrCommand::CodeAction(CodeAction {
                    title: a.title,
                    kind: Some(CodeActionKind::QUICKFIX),
                    diagnostics: Some(vec![diagnostic]),
                    edit: Some(workspace_edit(b, &doc, uri, &a.edits)),
                    is_preferred: Some(a.preferred),
                    ..Default::default()
                })
            })
            .collect();
        Some(actions)
    })
    .await
}
