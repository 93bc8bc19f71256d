//! `textDocument/prepareRename` and `textDocument/rename`. A rename edits every
//! open or indexed file that sees the symbol's definition, so renaming a rule in a
//! library renames its uses in every importer, open or not.

use super::workspace::{file_canon, own_files, views};
use super::{at_position, uri};
use crate::backend::Backend;
use crate::position::LineIndex;
use std::collections::{HashMap, HashSet};
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
        Err(e) => Err(Error::invalid_params(e.to_string())),
    })
    .await?
}

/// The edits renaming the symbol at a position, in every file of the workspace it
/// occurs in. Refused (with the file named) if any of those files would break.
pub async fn rename(b: &Backend, p: RenameParams) -> Result<Option<WorkspaceEdit>> {
    let pos = &p.text_document_position;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    let sym = match b.run("rename", || doc.symbol_at(offset)).await? {
        Some((sym, _)) => sym,
        // No symbol: the analysis says why.
        None => {
            return match doc.rename(offset, &p.new_name) {
                Ok(_) => Ok(None),
                Err(e) => Err(Error::invalid_params(e.to_string())),
            }
        }
    };
    let views = views(b, uri(pos), doc, &sym).await;
    b.run("rename", || {
        let own = own_files(&views);
        let mut changes: HashMap<Uri, Vec<TextEdit>> = HashMap::new();
        let mut seen = HashSet::new();
        for (i, v) in views.iter().enumerate() {
            let edits = v.doc.rename_symbol(&sym, &p.new_name).map_err(|e| {
                let message = e.to_string();
                let file = v.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
                // The requesting file's own refusal needs no file name.
                Error::invalid_params(if i == 0 { message } else { format!("{message} (in {file})") })
            })?;
            for e in edits {
                let Some(path) = file_canon(&v.doc, e.span.file) else { continue };
                if !v.speaks_for(&path, &own) {
                    continue;
                }
                let Some(u) = b.uri_of(&v.doc, &v.uri, e.span.file) else { continue };
                let range = LineIndex::new(v.doc.file_text(e.span.file)).range(e.span.start, e.span.end);
                if seen.insert((u.as_str().to_string(), range.start, range.end)) {
                    changes.entry(u).or_default().push(TextEdit { range, new_text: e.new_text });
                }
            }
        }
        Ok(Some(WorkspaceEdit { changes: Some(changes), ..Default::default() }))
    })
    .await?
}
