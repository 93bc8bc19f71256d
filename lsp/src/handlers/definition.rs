//! `textDocument/definition`: rules (all their definitions), namespaces, functions,
//! isosurfaces, macros, shaders and imported files, in any file.

use super::{at_position, uri};
use crate::backend::Backend;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The definitions of the symbol at a position.
pub async fn definition(b: &Backend, p: GotoDefinitionParams) -> Result<Option<GotoDefinitionResponse>> {
    let pos = &p.text_document_position_params;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    b.run("definition", || {
        let locations: Vec<Location> =
            doc.definition(offset).into_iter().filter_map(|s| b.location(&doc, uri(pos), s)).collect();
        match locations.len() {
            0 => None,
            1 => locations.into_iter().next().map(GotoDefinitionResponse::Scalar),
            _ => Some(GotoDefinitionResponse::Array(locations)),
        }
    })
    .await
}
