//! `textDocument/publishDiagnostics`: every compiler diagnostic with its code,
//! notes and suggestion in the message, and secondary labels as related information.

use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::Document;
use mdg_compiler::diag::{self, Severity};
use tower_lsp_server::ls_types::*;

/// Publishes the diagnostics of `doc`, the analysis of `version` of `uri`.
pub async fn publish(b: &Backend, uri: &Uri, version: i32, doc: &Document) {
    let Ok(diags) = b.run("diagnostics", || convert_all(b, uri, doc)).await else { return };
    b.client.publish_diagnostics(uri.clone(), diags, Some(version)).await;
}

/// Every diagnostic of the document, converted.
pub fn convert_all(b: &Backend, uri: &Uri, doc: &Document) -> Vec<Diagnostic> {
    let li = LineIndex::new(doc.text());
    doc.diagnostics().iter().map(|d| convert(b, uri, doc, &li, d)).collect()
}

/// The link of a diagnostic code: its entry (`#e0301`) in `docs/diagnostics.md`, at
/// `$MDG_DOCS_URL` when set, else in the docs installed beside std.
pub fn code_href(b: &Backend, code: &str) -> Option<Uri> {
    let doc = b.config.diagnostics_doc.as_ref()?;
    format!("{}#{}", doc.as_str(), code.to_ascii_lowercase()).parse().ok()
}

/// One diagnostic, converted; `li` indexes the document's text.
pub fn convert(b: &Backend, uri: &Uri, doc: &Document, li: &LineIndex, d: &diag::Diagnostic) -> Diagnostic {
    let mut message = d.message.clone();
    if !d.label.is_empty() {
        message.push_str(&format!("\n{}", d.label));
    }
    for n in &d.notes {
        message.push_str(&format!("\nnote: {n}"));
    }
    if let Some(s) = &d.suggestion {
        message.push_str(&format!("\nhelp: {}", s.message));
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .secondary
        .iter()
        .filter_map(|l| {
            let location = b.location(doc, uri, l.span)?;
            let message = if l.message.is_empty() { "here".to_string() } else { l.message.clone() };
            Some(DiagnosticRelatedInformation { location, message })
        })
        .collect();
    Diagnostic {
        range: li.range(d.span.start, d.span.end),
        severity: Some(match d.severity {
            Severity::Error => DiagnosticSeverity::ERROR,
            Severity::Warning => DiagnosticSeverity::WARNING,
            Severity::Note => DiagnosticSeverity::INFORMATION,
        }),
        code: Some(NumberOrString::String(d.code.to_string())),
        code_description: code_href(b, d.code).map(|href| CodeDescription { href }),
        source: Some("mdg".to_string()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        tags: (d.code == "W0001" || d.code == "W0002").then(|| vec![DiagnosticTag::UNNECESSARY]),
        ..Default::default()
    }
}
