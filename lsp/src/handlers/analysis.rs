//! The analysis of an open document off the message loop: the one loop that runs
//! per document, shared by document synchronisation (`sync`) and the workspace's
//! file watcher (`workspace`), which both sit above it.

use crate::backend::Backend;
use crate::guard::guard;
use std::sync::Arc;
use tower_lsp_server::ls_types::*;

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
