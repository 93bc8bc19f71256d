//! `mdg/preview` (the live preview's request): the model of an open document,
//! evaluated in the server by [`crate::preview::run`] on a blocking thread, cancelled
//! when the document changes or a newer request comes.

use crate::backend::Backend;
use crate::guard::guard;
use crate::preview::{run, PreviewParams, PreviewResult, Status};
use mdg_vm::eval::Cancel;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use tower_lsp_server::jsonrpc::{Error, Result};

/// `mdg/preview`: the model of an open document, evaluated here.
pub async fn preview(b: &Backend, p: PreviewParams) -> Result<PreviewResult> {
    let Some(snap) = b.docs.snapshot(&p.uri) else {
        let mut e = Error::invalid_params(format!("mdg/preview: {} is not open", p.uri.as_str()));
        e.data = None;
        return Err(e);
    };
    let (counter, generation) = b.previews.begin(&p.uri);
    let config = b.config.clone();
    let result = tokio::task::spawn_blocking(move || {
        let doc_counter = snap.counter.clone();
        let doc_generation = snap.generation;
        let cancel = Cancel(Arc::new(move || {
            counter.load(Ordering::SeqCst) != generation || doc_counter.load(Ordering::SeqCst) != doc_generation
        }));
        guard(|| {
            let mut r = run(&snap.loader, &snap.path, &config.options, &p, cancel);
            r.version = snap.version;
            r
        })
    })
    .await;
    match result {
        Ok(Ok(r)) => Ok(r),
        Ok(Err(panic)) => {
            b.log_panic("preview", &panic).await;
            Ok(PreviewResult {
                status: Status::Error,
                message: format!("mdg-lsp: the preview failed: {panic}"),
                ..PreviewResult::default()
            })
        }
        Err(e) => Err(Error { message: format!("mdg/preview: {e}").into(), ..Error::internal_error() }),
    }
}
