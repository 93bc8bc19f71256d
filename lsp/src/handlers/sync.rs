//! Document synchronisation: open, change (full text, version-checked), save, close.

use super::analysis::refresh;
use crate::backend::Backend;
use tower_lsp_server::ls_types::*;

/// `textDocument/didOpen`: store the text and analyse it.
pub async fn did_open(b: &Backend, p: DidOpenTextDocumentParams) {
    let uri = p.text_document.uri;
    let version = p.text_document.version;
    let oversized = b.oversize.take(uri.as_str());
    b.docs.open(uri.clone(), version, p.text_document.text, oversized);
    refresh(b, uri.clone()).await;
    refresh_dependents(b, &uri).await;
}

/// `textDocument/didChange`: apply the edits in order, then analyse the new version.
pub async fn did_change(b: &Backend, p: DidChangeTextDocumentParams) {
    let uri = p.text_document.uri;
    let version = p.text_document.version;
    let oversized = b.oversize.take(uri.as_str());
    if let Err(e) = b.docs.change(&uri, version, p.content_changes, oversized) {
        b.client.log_message(MessageType::WARNING, format!("mdg-lsp: {e}")).await;
        return;
    }
    refresh(b, uri.clone()).await;
    refresh_dependents(b, &uri).await;
}

/// `textDocument/didSave`: files importing this one may change on disk too.
pub async fn did_save(b: &Backend, p: DidSaveTextDocumentParams) {
    refresh_dependents(b, &p.text_document.uri).await;
}

/// `textDocument/didClose`: forget the document and clear its diagnostics.
pub async fn did_close(b: &Backend, p: DidCloseTextDocumentParams) {
    let uri = p.text_document.uri;
    b.docs.close(&uri);
    b.previews.forget(&uri);
    b.client.publish_diagnostics(uri.clone(), Vec::new(), None).await;
    super::workspace::closed(b, &uri).await;
    refresh_dependents(b, &uri).await;
}

/// Re-analyses the documents that import `uri`'s file: open ones, then closed
/// ones of the workspace (whose diagnostics an edit may break or mend).
async fn refresh_dependents(b: &Backend, uri: &Uri) {
    let path = crate::documents::path_of(uri);
    for dep in b.docs.dependents(uri, &path) {
        refresh(b, dep).await;
    }
    super::workspace::refresh_importers(b, uri).await;
}
