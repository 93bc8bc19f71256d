//! `textDocument/completion`: items in the analysis's order, with snippets and a
//! replace range covering the word typed so far.

use super::at_position;
use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::CompletionKind as K;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The completions at a position.
pub async fn completion(b: &Backend, p: CompletionParams) -> Result<Option<CompletionResponse>> {
    let Some((doc, offset)) = at_position(b, &p.text_document_position).await else { return Ok(None) };
    b.run("completion", || {
        let c = doc.completion(offset, &b.config.completion);
        let range = LineIndex::new(doc.text()).range(c.replace.start, c.replace.end);
        let items: Vec<CompletionItem> = c
            .items
            .into_iter()
            .enumerate()
            .map(|(i, item)| CompletionItem {
                kind: Some(kind(item.kind)),
                detail: item.detail,
                documentation: item
                    .documentation
                    .map(|d| Documentation::MarkupContent(MarkupContent { kind: MarkupKind::Markdown, value: d })),
                sort_text: Some(format!("{i:04}")),
                filter_text: Some(item.label.clone()),
                insert_text_format: Some(if item.snippet {
                    InsertTextFormat::SNIPPET
                } else {
                    InsertTextFormat::PLAIN_TEXT
                }),
                text_edit: Some(CompletionTextEdit::Edit(TextEdit { range, new_text: item.insert_text })),
                label: item.label,
                ..Default::default()
            })
            .collect();
        Some(CompletionResponse::List(CompletionList { is_incomplete: false, items }))
    })
    .await
}

fn kind(k: K) -> CompletionItemKind {
    match k {
        K::Rule => CompletionItemKind::FUNCTION,
        K::Drawable | K::Isosurface => CompletionItemKind::CLASS,
        K::Adjustment => CompletionItemKind::PROPERTY,
        K::Directive | K::Keyword => CompletionItemKind::KEYWORD,
        K::Preprocessor | K::Macro => CompletionItemKind::KEYWORD,
        K::SelectorMode | K::AngleMode => CompletionItemKind::ENUM_MEMBER,
        K::Function => CompletionItemKind::FUNCTION,
        K::Variable => CompletionItemKind::VARIABLE,
        K::Constant => CompletionItemKind::CONSTANT,
        K::Library => CompletionItemKind::MODULE,
        K::Snippet => CompletionItemKind::SNIPPET,
        K::Shader => CompletionItemKind::FILE,
        K::Key => CompletionItemKind::PROPERTY,
        K::Colour => CompletionItemKind::COLOR,
    }
}
