//! `workspace/symbol`: symbols of every open document and the files they import.

use crate::server::Backend;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The symbols matching a query, over all open documents' analyses.
pub async fn workspace_symbols(b: &Backend, p: WorkspaceSymbolParams) -> Result<Option<WorkspaceSymbolResponse>> {
    let analyses = b.docs.analyses();
    b.run("workspace symbols", || {
        let mut seen = std::collections::HashSet::new();
        let mut out = Vec::new();
        for (uri, doc) in &analyses {
            for s in doc.workspace_symbols(&p.query) {
                let Some(location) = b.location(doc, uri, s.span) else { continue };
                if !seen.insert((
                    location.uri.as_str().to_string(),
                    location.range.start.line,
                    location.range.start.character,
                )) {
                    continue;
                }
                out.push(WorkspaceSymbol {
                    name: s.name,
                    kind: super::document_symbols::kind(s.kind),
                    tags: None,
                    container_name: s.container,
                    location: OneOf::Left(location),
                    data: None,
                });
            }
        }
        Some(WorkspaceSymbolResponse::Nested(out))
    })
    .await
}
