//! `workspace/symbol`: symbols of every file of the workspace index and every open
//! document, with the files they import.

use super::workspace::{all_views, file_canon, own_files};
use crate::backend::Backend;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The symbols matching a query.
pub async fn workspace_symbols(b: &Backend, p: WorkspaceSymbolParams) -> Result<Option<WorkspaceSymbolResponse>> {
    let views = all_views(b).await;
    b.run("workspace symbols", || {
        let own = own_files(&views);
        let mut seen = std::collections::HashSet::new();
        let mut out = Vec::new();
        for v in &views {
            for s in v.doc.workspace_symbols(&p.query) {
                let Some(path) = file_canon(&v.doc, s.span.file) else { continue };
                if !v.speaks_for(&path, &own) {
                    continue;
                }
                let Some(location) = b.location(&v.doc, &v.uri, s.span) else { continue };
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
