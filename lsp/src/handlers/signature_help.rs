//! `textDocument/signatureHelp`: a rule's parameters while its arguments are typed.

use super::at_position;
use crate::backend::Backend;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The signature of the call around a position.
pub async fn signature_help(b: &Backend, p: SignatureHelpParams) -> Result<Option<SignatureHelp>> {
    let Some((doc, offset)) = at_position(b, &p.text_document_position_params).await else { return Ok(None) };
    b.run("signature help", || {
        let h = doc.signature_help(offset)?;
        // Parameter ranges are UTF-16 offsets into the label (ASCII here).
        let utf16 = |byte: u32| h.label[..byte as usize].encode_utf16().count() as u32;
        let parameters = h
            .params
            .iter()
            .map(|&(s, e)| ParameterInformation {
                label: ParameterLabel::LabelOffsets([utf16(s), utf16(e)]),
                documentation: None,
            })
            .collect();
        Some(SignatureHelp {
            signatures: vec![SignatureInformation {
                label: h.label.clone(),
                documentation: Some(Documentation::MarkupContent(MarkupContent {
                    kind: MarkupKind::Markdown,
                    value: h.doc.clone(),
                })),
                parameters: Some(parameters),
                active_parameter: Some(h.active as u32),
            }],
            active_signature: Some(0),
            active_parameter: Some(h.active as u32),
        })
    })
    .await
}
