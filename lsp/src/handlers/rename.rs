//! `textDocument/prepareRename` and `textDocument/rename`.

use super::{at_position, uri, workspace_edit};
use crate::position::LineIndex;
use crate::server::Backend;
use tower_lsp_server::jsonrpc::{Error, Result};
use tower_lsp_server::ls_types::*;

/// The name a rename at this position would change.
pub async fn prepare_rename(b: &Backend, p: TextDocumentPositionParams) -> Result<Option<PrepareRenameResponse>> {
    let Some((doc, offset)) = at_position(b, &p).await else { return Ok(None) };
    b.run("prepare rename", || match doc.prepare_rename(offset) {
        Ok((span, placeholder)) => {
            let range = LineIndex::new(doc.text()).range(span.start, span.end);
            Ok(Some(PrepareRenameResponse::RangeWithPlaceholder { range, placeholder }))
        }
        Err(message) => Err(Error::invalid_params(message)),
    })
    .await?
}

/// The edits renaming the symbol at a position, in every file it occurs in.
pub async fn rename(b: &Backend, p: RenameParams) -> Result<Option<WorkspaceEdit>> {
    let pos = &p.text_document_position;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    b.run("rename", || match doc.rename(offset, &p.new_name) {
        Ok(edits) => Ok(Some(workspace_edit(b, &doc, uri(pos), &edits))),
        Err(message) => Err(Error::invalid_params(message)),
    })
    .await?
}
