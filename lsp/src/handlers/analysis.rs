//! The analysis of an open document off the message loop: the one loop that runs
//! per document, shared by document synchronisation (`sync`) and the workspace's
//! file watcher (`workspace`), which both sit above it.
//!
//! Diagnostics never wait for glslang's start or a shader's first compile: a
//! version is analysed with the shader results the SPIR-V caches hold, and where a
//! block needs glslang those diagnostics (all but the GLSL ones) are published at
//! once, then again with the GLSL ones when the shaders have compiled. (Not when
//! the document's last analysis had GLSL diagnostics: while a shader error is
//! being mended, showing it gone for the compile's few milliseconds would flicker.)

use crate::backend::{Backend, Shaders};
use crate::documents::Snapshot;
use crate::guard::guard;
use mdg_compiler::analysis::Document;
use std::sync::Arc;
use tower_lsp_server::ls_types::*;

/// What one analysis of a snapshot gave: the snapshot and the analysis (`None`: given
/// up) or the panic's message; `None` if the document was closed.
type Outcome = Option<(Snapshot, std::result::Result<Option<Arc<Document>>, String>)>;

/// Analyses the current version of `uri` on the blocking pool; `snap` reuses a
/// snapshot taken before (the same version, analysed further).
async fn analyze(b: &Backend, uri: &Uri, snap: Option<Snapshot>, shaders: Shaders) -> Outcome {
    let docs = b.docs.clone();
    let config = b.config.clone();
    let u = uri.clone();
    let result = tokio::task::spawn_blocking(move || {
        let snap = match snap {
            Some(s) => s,
            None => docs.snapshot(&u)?,
        };
        let doc = guard(|| Backend::analyze(&snap, &config, shaders).map(Arc::new));
        Some((snap, doc))
    })
    .await;
    match result {
        Ok(r) => r,
        Err(e) => {
            b.log_panic("analysis", &e.to_string()).await;
            None
        }
    }
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
        let mut result = analyze(b, &uri, None, Shaders::Cached).await;
        if let Some((snap, Ok(Some(doc)))) = &result {
            if doc.analysis().shaders_pending {
                // The shaders wait for glslang: publish the rest now (unless GLSL
                // errors are showing), then analyse again with them compiled.
                if !b.docs.last_had_glsl_diagnostics(&uri) && b.docs.store_quick(&uri, snap, doc.clone()) {
                    super::diagnostics::publish(b, &uri, snap.version, doc).await;
                }
                if let Some((snap, _)) = result.take() {
                    result = analyze(b, &uri, Some(snap), Shaders::Compile).await;
                }
            }
        }
        let version = match result.map(|(snap, doc)| (snap.version, doc)) {
            Some((version, Ok(Some(doc)))) => {
                if b.docs.store(&uri, version, doc.clone()) {
                    super::diagnostics::publish(b, &uri, version, &doc).await;
                }
                version
            }
            // Given up: the document changed meanwhile (the loop goes round again).
            Some((version, Ok(None))) => version,
            Some((version, Err(panic))) => {
                b.log_panic("analysis", &panic).await;
                version
            }
            // Closed meanwhile (or the task failed, logged).
            None => i32::MIN,
        };
        if b.docs.end_analysis(&uri, version) {
            return;
        }
    }
}
