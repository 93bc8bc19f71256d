//! `textDocument/references`: every use of the symbol in the workspace — in each
//! open or indexed file that sees one of its definitions, not only the files this
//! document's analysis read.

use super::workspace::{file_canon, own_files, views};
use super::{at_position, uri};
use crate::backend::Backend;
use std::collections::HashSet;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// Every use of the symbol at a position, sorted by file and position.
pub async fn references(b: &Backend, p: ReferenceParams) -> Result<Option<Vec<Location>>> {
    let pos = &p.text_document_position;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    let Some((sym, _)) = b.run("references", || doc.symbol_at(offset)).await? else { return Ok(Some(Vec::new())) };
    let views = views(b, uri(pos), doc, &sym).await;
    b.run("references", || {
        let own = own_files(&views);
        let mut seen = HashSet::new();
        let mut out: Vec<Location> = Vec::new();
        for v in &views {
            for s in v.doc.symbol_references(&sym, p.context.include_declaration) {
                let Some(path) = file_canon(&v.doc, s.file) else { continue };
                if !v.speaks_for(&path, &own) {
                    continue;
                }
                let Some(loc) = b.location(&v.doc, &v.uri, s) else { continue };
                if seen.insert((loc.uri.as_str().to_string(), loc.range.start, loc.range.end)) {
                    out.push(loc);
                }
            }
        }
        out.sort_by(|a, b| (a.uri.as_str(), a.range.start).cmp(&(b.uri.as_str(), b.range.start)));
        Some(out)
    })
    .await
}
