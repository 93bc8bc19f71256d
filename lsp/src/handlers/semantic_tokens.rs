//! `textDocument/semanticTokens/full`: the analysis's byte-span tokens, split at
//! line ends and delta-encoded in UTF-16 columns.

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::SemanticKind as K;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

const TYPES: &[SemanticTokenType] = &[
    SemanticTokenType::FUNCTION,    // 0 rule, user function, shader
    SemanticTokenType::TYPE,        // 1 drawable
    SemanticTokenType::CLASS,       // 2 isosurface
    SemanticTokenType::PROPERTY,    // 3 adjustment, section key
    SemanticTokenType::KEYWORD,     // 4 directive, keyword, unit suffix
    SemanticTokenType::ENUM_MEMBER, // 5 selector and angle modes
    SemanticTokenType::NUMBER,      // 6
    SemanticTokenType::COMMENT,     // 7
    SemanticTokenType::MACRO,       // 8 preprocessor words and macros
    SemanticTokenType::NAMESPACE,   // 9
    SemanticTokenType::VARIABLE,    // 10 expression variables and constants
    SemanticTokenType::STRING,      // 11 import names, strings
    SemanticTokenType::OPERATOR,    // 12 continuation
    SemanticTokenType::PARAMETER,   // 13 rule parameters
];

const MODIFIERS: &[SemanticTokenModifier] =
    &[SemanticTokenModifier::DECLARATION, SemanticTokenModifier::DEFAULT_LIBRARY, SemanticTokenModifier::READONLY];

const DECLARATION: u32 = 1;
const DEFAULT_LIBRARY: u32 = 2;
const READONLY: u32 = 4;

/// The legend announced in `initialize`.
pub fn legend() -> SemanticTokensLegend {
    SemanticTokensLegend { token_types: TYPES.to_vec(), token_modifiers: MODIFIERS.to_vec() }
}

/// Token type index and modifier bits of a kind.
fn encode(k: K) -> (u32, u32) {
    match k {
        K::Rule | K::Function | K::Shader => (0, 0),
        K::Drawable => (1, DEFAULT_LIBRARY),
        K::Isosurface => (2, 0),
        K::Adjustment => (3, DEFAULT_LIBRARY),
        K::Keyword | K::Unit => (4, 0),
        K::Mode => (5, DEFAULT_LIBRARY),
        K::Number => (6, 0),
        K::Comment => (7, 0),
        K::Preprocessor | K::Macro => (8, 0),
        K::Namespace => (9, 0),
        K::MathFunction => (0, DEFAULT_LIBRARY),
        K::Variable => (10, DEFAULT_LIBRARY | READONLY),
        K::Constant => (10, READONLY),
        K::Import => (11, 0),
        K::Operator => (12, 0),
        K::Property => (3, 0),
        K::String => (11, 0),
        K::Parameter => (13, 0),
        K::Local => (10, 0),
    }
}

/// All tokens of a document.
pub async fn semantic_tokens_full(b: &Backend, p: SemanticTokensParams) -> Result<Option<SemanticTokensResult>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("semantic tokens", || Some(SemanticTokensResult::Tokens(encode_tokens(&doc, 0, u32::MAX)))).await
}

/// The tokens that overlap a range (the visible part of a long file, first).
pub async fn semantic_tokens_range(
    b: &Backend,
    p: SemanticTokensRangeParams,
) -> Result<Option<SemanticTokensRangeResult>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(None) };
    b.run("semantic tokens", || {
        let li = LineIndex::new(doc.text());
        let (start, end) = (li.offset(p.range.start), li.offset(p.range.end));
        Some(SemanticTokensRangeResult::Tokens(encode_tokens(&doc, start, end)))
    })
    .await
}

/// The tokens overlapping the byte range `[from, to)`, split at line ends and
/// delta-encoded from the start of the document.
fn encode_tokens(doc: &mdg_compiler::analysis::Document, from: u32, to: u32) -> SemanticTokens {
    let text = doc.text();
    let li = LineIndex::new(text);
    let mut data = Vec::new();
    let (mut last_line, mut last_col) = (0u32, 0u32);
    for t in doc.semantic_tokens() {
        if t.span.end <= from || t.span.start >= to {
            continue;
        }
        let (ty, mut mods) = encode(t.kind);
        if t.declaration {
            mods |= DECLARATION;
        }
        let end = (t.span.end as usize).min(text.len());
        let mut s = (t.span.start as usize).min(end);
        while s < end {
            let line_end = text[s..end].find('\n').map(|i| s + i).unwrap_or(end);
            let piece = text[s..line_end].trim_end_matches('\r');
            if !piece.is_empty() {
                let pos = li.position(s as u32);
                let delta_line = pos.line - last_line;
                let delta_start = if delta_line == 0 { pos.character - last_col } else { pos.character };
                data.push(SemanticToken {
                    delta_line,
                    delta_start,
                    length: piece.encode_utf16().count() as u32,
                    token_type: ty,
                    token_modifiers_bitset: mods,
                });
                (last_line, last_col) = (pos.line, pos.character);
            }
            s = line_end + 1;
        }
    }
    SemanticTokens { result_id: None, data }
}
