//! `textDocument/documentColor` and `textDocument/colorPresentation`: swatches on
//! `background r g b a`, on a call's colour deltas (the colour they give from
//! white) and on colour values (`#rrggbb`, `#tomato`), and a picked colour written
//! back in the same form (a colour value as `#rrggbb`).

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::span::Span;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The colour literals of a document.
pub async fn document_color(b: &Backend, p: DocumentColorParams) -> Result<Vec<ColorInformation>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(Vec::new()) };
    b.run("document colors", || {
        let li = LineIndex::new(doc.text());
        doc.colors()
            .into_iter()
            .map(|c| ColorInformation {
                range: li.range(c.span.start, c.span.end),
                color: Color {
                    red: c.rgba[0] as f32,
                    green: c.rgba[1] as f32,
                    blue: c.rgba[2] as f32,
                    alpha: c.rgba[3] as f32,
                },
            })
            .collect()
    })
    .await
}

/// How a picked colour is written over the literal at the range.
pub async fn color_presentation(b: &Backend, p: ColorPresentationParams) -> Result<Vec<ColorPresentation>> {
    let Some(doc) = b.document(&p.text_document.uri).await else { return Ok(Vec::new()) };
    b.run("color presentation", || {
        let li = LineIndex::new(doc.text());
        let span = Span::new(doc.main_file(), li.offset(p.range.start), li.offset(p.range.end));
        let c = p.color;
        let rgba = [c.red, c.green, c.blue, c.alpha].map(f64::from);
        doc.color_presentation(span, rgba)
            .map(|text| {
                vec![ColorPresentation {
                    label: text.clone(),
                    text_edit: Some(TextEdit { range: p.range, new_text: text }),
                    additional_text_edits: None,
                }]
            })
            .unwrap_or_default()
    })
    .await
}
