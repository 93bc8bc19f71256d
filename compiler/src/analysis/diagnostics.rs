//! The document's diagnostics, all placed in the document itself.
//!
//! Diagnostics in the document are kept as they are. One in another file (an
//! imported library, a macro body elsewhere) is shown where that file enters the
//! document — a secondary label in the document, else the `@import` that brings the
//! file in — with its own place as a secondary label, so nothing is lost.

use super::index::Occ;
use super::Document;
use crate::diag::{Diagnostic, Label};
use crate::span::Span;

impl Document {
    /// Every diagnostic of the analysis, with its primary span in the document.
    pub fn diagnostics(&self) -> Vec<Diagnostic> {
        let main = self.main_file();
        let diags = &self.analysis.diagnostics;
        if diags.iter().all(|d| d.span.file == main) {
            return diags.clone();
        }
        diags.iter().map(|d| if d.span.file == main { d.clone() } else { self.relocate(d) }).collect()
    }

    fn relocate(&self, d: &Diagnostic) -> Diagnostic {
        let main = self.main_file();
        let file = &self.analysis.sources.file(d.span.file).name;
        let anchor = d.secondary.iter().find(|l| l.span.file == main).map(|l| l.span).or_else(|| {
            let imports = self.index().main.iter().filter_map(|o| match o.occ {
                Occ::Import(f) => Some((o.span, f)),
                _ => None,
            });
            let imports: Vec<(Span, Option<crate::span::FileId>)> = imports.collect();
            imports.iter().find(|(_, f)| *f == Some(d.span.file)).or(imports.first()).map(|(s, _)| *s)
        });
        let mut out = d.clone();
        out.span = anchor.unwrap_or(Span::new(main, 0, 0));
        out.message = format!("{} (in {file})", d.message);
        out.secondary.insert(0, Label { span: d.span, message: d.label.clone() });
        out.label = String::new();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc_with;

    #[test]
    fn errors_in_imported_files_point_at_the_import() {
        let (d, _) =
            doc_with("@import lib.mdg\nstartshape A\nrule A { VERTEX {} }", &[("lib.mdg", "rule B { nope {} }\n")]);
        let diags = d.diagnostics();
        assert_eq!(diags.len(), 1, "{diags:?}");
        let e = &diags[0];
        assert_eq!((e.code, d.span_text(e.span)), ("E0301", "lib.mdg"));
        assert_eq!(e.message, "unknown rule `nope` (in lib.mdg)");
        assert_eq!(d.span_text(e.secondary[0].span), "nope");
        assert_ne!(e.secondary[0].span.file, d.main_file());
    }

    #[test]
    fn document_diagnostics_are_unchanged() {
        let (d, _) = doc_with("startshape A\nrule A { nope {} }", &[]);
        assert_eq!(d.diagnostics(), d.analysis().diagnostics);
    }
}
