//! `textDocument/documentLink`: each word of an `@import` line links to the file it
//! brings in (std libraries included).

use crate::backend::Backend;
use crate::position::LineIndex;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The links of a document.
pub async fn document_links(b: &Backend, p: DocumentLinkParams) -> Result<Option<Vec<DocumentLink>>> {
    let uri = &p.text_document.uri;
    let Some(doc) = b.document(uri).await else { return Ok(None) };
    b.run("document links", || {
        let li = LineIndex::new(doc.text());
        let links = doc
            .import_links()
            .into_iter()
            .filter_map(|(span, file)| {
                let path = doc.file_path(file)?;
                Some(DocumentLink {
                    range: li.range(span.start, span.end),
                    target: b.uri_of(&doc, uri, file),
                    tooltip: Some(path.display().to_string()),
                    data: None,
                })
            })
            .collect();
        Some(links)
    })
    .await
}
