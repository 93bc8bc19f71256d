//! `textDocument/documentSymbol`: the outline.

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::{DocumentSymbol as Sym, SymbolKind as K};
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The nested outline of a document.
pub async fn document_symbols(b: &Backend, p: DocumentSymbolParams) -> Result<Option<DocumentSymbolResponse>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("document symbols", || {
        let li = LineIndex::new(doc.text());
        let syms = doc.document_symbols().iter().map(|s| convert(&li, s)).collect();
        Some(DocumentSymbolResponse::Nested(syms))
    })
    .await
}

/// The LSP kind of a symbol kind.
pub fn kind(k: K) -> SymbolKind {
    match k {
        K::Rule | K::RuleDefinition => SymbolKind::FUNCTION,
        K::Namespace => SymbolKind::NAMESPACE,
        K::Function => SymbolKind::METHOD,
        K::Isosurface => SymbolKind::CLASS,
        K::Macro => SymbolKind::CONSTANT,
        K::Shader => SymbolKind::FILE,
        K::Section => SymbolKind::STRUCT,
        K::SectionBlock => SymbolKind::OBJECT,
    }
}

#[allow(deprecated)] // `deprecated` is a required field of the LSP type.
fn convert(li: &LineIndex, s: &Sym) -> DocumentSymbol {
    DocumentSymbol {
        name: if s.name.is_empty() { "?".to_string() } else { s.name.clone() },
        detail: s.detail.clone(),
        kind: kind(s.kind),
        tags: None,
        deprecated: None,
        range: li.range(s.span.start, s.span.end),
        selection_range: li.range(s.selection.start, s.selection.end),
        children: (!s.children.is_empty()).then(|| s.children.iter().map(|c| convert(li, c)).collect()),
    }
}
