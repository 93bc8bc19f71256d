//! Document synchronisation: open, change (full text, version-checked), save, close.

use crate::backend::Backend;
use crate::guard::guard;
use std::sync::Arc;
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

/// Analyses the newest version of `uri` off the message loop, stores it and
/// publishes its diagnostics, then again while newer versions have arrived.
/// At most one such loop runs per document: edits that come faster than
/// analyses are folded into the next one, so typing never queues work.
pub async fn refresh(b: &Backend, uri: Uri) {
    if !b.docs.begin_analysis(&uri) {
        return;
    }
    loop {
        let docs = b.docs.clone();
        let config = b.config.clone();
        let u = uri.clone();
        let result = tokio::task::spawn_blocking(move || {
            let snap = docs.snapshot(&u)?;
            Some((snap.version, guard(|| Backend::analyze(&snap, &config, false).map(Arc::new))))
        })
        .await;
        let version = match result {
            Ok(Some((version, Ok(Some(doc))))) => {
                if b.docs.store(&uri, version, doc.clone()) {
                    super::diagnostics::publish(b, &uri, version, &doc).await;
                }
                version
            }
            // Given up: the document changed meanwhile (the loop goes round again).
            Ok(Some((version, Ok(None)))) => version,
            Ok(Some((version, Err(panic)))) => {
                b.log_panic("analysis", &panic).await;
                version
            }
            // Closed meanwhile.
            Ok(None) => i32::MIN,
            Err(e) => {
                b.log_panic("analysis", &e.to_string()).await;
                i32::MIN
            }
        };
        if b.docs.end_analysis(&uri, version) {
            return;
        }
    }
}
