//! Go to definition, find references and highlights, for rules, namespaces,
//! functions, isosurfaces, macros and shaders, across imported files and std.

use super::index::{Occ, Symbol};
use super::Document;
use crate::span::Span;

impl Document {
    /// The definitions of the symbol at `offset` (a rule may have several), or the
    /// file an `@import` word brings in (its start). Spans may be in any file.
    pub fn definition(&self, offset: u32) -> Vec<Span> {
        let idx = self.index();
        if let Some(o) = idx.at(offset) {
            if let Occ::Import(Some(file)) = o.occ {
                return vec![Span::new(file, 0, 0)];
            }
        }
        match idx.symbol_at(offset) {
            Some((sym, _)) => idx.definitions(sym).collect(),
            None => Vec::new(),
        }
    }

    /// Every use of the symbol at `offset`, with its definitions when
    /// `include_declaration`; sorted by file and position.
    pub fn references(&self, offset: u32, include_declaration: bool) -> Vec<Span> {
        let idx = self.index();
        let Some((sym, _)) = idx.symbol_at(offset) else { return Vec::new() };
        let mut out: Vec<Span> = idx.references(sym).collect();
        if include_declaration {
            out.extend(idx.definitions(sym));
        }
        out.sort();
        out.dedup();
        out
    }

    /// The occurrences in this document of the symbol at `offset`: (span, whether it
    /// is a definition).
    pub fn highlights(&self, offset: u32) -> Vec<(Span, bool)> {
        let idx = self.index();
        let Some((sym, _)) = idx.symbol_at(offset) else { return Vec::new() };
        let mut out: Vec<(Span, bool)> = idx
            .main
            .iter()
            .filter_map(|o| match &o.occ {
                Occ::Def(s) if s == sym => Some((o.span, true)),
                Occ::Ref(s) if s == sym => Some((o.span, false)),
                _ => None,
            })
            .collect();
        out.sort();
        out.dedup();
        out
    }

    /// Every word of an `@import` line in the document that brought a file in: its
    /// span and the file (for document links).
    pub fn import_links(&self) -> Vec<(Span, crate::span::FileId)> {
        self.index()
            .main
            .iter()
            .filter_map(|o| match o.occ {
                Occ::Import(Some(file)) => Some((o.span, file)),
                _ => None,
            })
            .collect()
    }

    /// The symbol at `offset`, for callers that need to know what it is.
    pub fn symbol_at(&self, offset: u32) -> Option<(Symbol, Span)> {
        self.index().symbol_at(offset).map(|(s, sp)| (s.clone(), sp))
    }

    /// Every definition of `sym` in this analysis (any file), sorted. With
    /// [`Document::symbol_references`], this lets a caller holding the analyses of
    /// several files (a workspace) ask each about a symbol found in another.
    pub fn symbol_definitions(&self, sym: &Symbol) -> Vec<Span> {
        let mut out: Vec<Span> = self.index().definitions(sym).collect();
        out.sort();
        out.dedup();
        out
    }

    /// Every use of `sym` in this analysis, with its definitions when
    /// `include_declaration`; sorted by file and position.
    pub fn symbol_references(&self, sym: &Symbol, include_declaration: bool) -> Vec<Span> {
        let idx = self.index();
        let mut out: Vec<Span> = idx.references(sym).collect();
        if include_declaration {
            out.extend(idx.definitions(sym));
        }
        out.sort();
        out.dedup();
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{doc, doc_with, show};
    use super::super::Document;

    fn shown(d: &Document, spans: Vec<crate::span::Span>) -> Vec<String> {
        spans.into_iter().map(|s| show(d, s)).collect()
    }

    #[test]
    fn rule_definitions_all_of_them() {
        let (d, at) = doc("startshape A\nrule A { le$0af {} }\nrule leaf 2 { VERTEX {} }\nrule leaf { VERTEX {} }\n");
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:3:6 \"leaf\"", "main.mdg:4:6 \"leaf\""]);
    }

    #[test]
    fn definition_across_imports_and_std() {
        let (d, at) = doc_with(
            "@import lib/shapes.mdg primitives\nstartshape A\nrule A { tri {} SPH$0ERE {} }",
            &[("lib/shapes.mdg", "// shapes\nrule tri { VERTEX {} }\n")],
        );
        let got = shown(&d, d.definition(at));
        assert_eq!(got, ["primitives.mdg:11:12 \"SPHERE\""]);
        let at_tri = d.text().find("tri").expect("tri") as u32;
        assert_eq!(shown(&d, d.definition(at_tri)), ["shapes.mdg:2:6 \"tri\""]);
        let at_import = d.text().find("shapes").expect("import") as u32;
        let file = d.definition(at_import);
        assert_eq!(file.len(), 1);
        assert_eq!(
            d.file_path(file[0].file).map(|p| p.display().to_string()),
            Some("/test/lib/shapes.mdg".to_string())
        );
    }

    #[test]
    fn namespaces_functions_isosurfaces_macros_shaders() {
        let (d, at) =
            doc("namespace port { rule arm { VERTEX {} } }\nstartshape A\nrule A { po$0rt.arm {} port.LINETO {} }");
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:1:11 \"port\""]);
        assert_eq!(shown(&d, d.references(at, false)), ["main.mdg:3:10 \"port\"", "main.mdg:3:22 \"port\""]);
        let at_arm = d.text().find("arm {}").expect("arm") as u32 + 1;
        assert_eq!(shown(&d, d.definition(at_arm)), ["main.mdg:1:23 \"arm\""]);

        let (d, at) =
            doc("function band { z }\nselector b function ba$0nd\nrule b 1 { VERTEX {} }\nrule b 2 { VERTEX {} }");
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:1:10 \"band\""]);

        let (d, at) = doc("isosurface BALL { xyz -1 1 8 ; function { x*x - 1 } }\nrule A { BALL {} BA$0LL {x 1} }");
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:1:12 \"BALL\""]);
        assert_eq!(d.references(at, true).len(), 3);

        let (d, at) = doc("@macro TRI(s)\nVERTEX {x s}\n@endmacro\nrule A {\n@expand TR$0I(1)\n}\n");
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:1:8 \"TRI\""]);

        let (d, at) = doc(
            "@vertexshader vs\nvoid main() {}\n@endshader\nprogram { vertexshader v$0s render }\nrule A { VERTEX {} }",
        );
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:1:15 \"vs\""]);
    }

    #[test]
    fn rules_made_by_macros_are_found() {
        let src = "@macro BALL(rulename)\nrule rulename { VERTEX {} }\n@endmacro\n@expand BALL(fine)\nstartshape A\nrule A { fi$0ne {} }";
        let (d, at) = doc(src);
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:4:14 \"fine\""]);
    }

    #[test]
    fn references_in_every_file_and_inactive_branches() {
        let (d, at) = doc_with(
            "@import lib.mdg\nstartshape A\nrule A { sh$0ared {} }\n@ifdef NEVER\nrule B { shared {} }\n@endif\n",
            &[("lib.mdg", "rule shared { VERTEX {} }\nrule other { shared {} }\n")],
        );
        assert_eq!(
            shown(&d, d.references(at, true)),
            [
                "main.mdg:3:10 \"shared\"",
                "main.mdg:5:10 \"shared\"",
                "lib.mdg:1:6 \"shared\"",
                "lib.mdg:2:14 \"shared\""
            ]
        );
        assert_eq!(d.highlights(at).len(), 2);
    }

    #[test]
    fn namespaced_calls_resolve_like_the_checker() {
        let src = "rule arm { VERTEX {} }\nnamespace n {\n  rule arm { VERTEX {} }\n  rule body { ar$0m {} }\n}\nstartshape n.body";
        let (d, at) = doc(src);
        assert_eq!(shown(&d, d.definition(at)), ["main.mdg:3:8 \"arm\""]);
    }

    #[test]
    fn import_words_link_to_their_files() {
        let (d, _) = doc_with(
            "@import lib.mdg primitives\nstartshape A\nrule A { cube {} }",
            &[("lib.mdg", "rule x { VERTEX {} }\n")],
        );
        let links: Vec<(String, String)> = d
            .import_links()
            .into_iter()
            .map(|(s, f)| {
                (
                    show(&d, s),
                    d.file_path(f)
                        .and_then(|p| p.file_name())
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default(),
                )
            })
            .collect();
        assert_eq!(
            links,
            [
                ("main.mdg:1:9 \"lib.mdg\"".to_string(), "lib.mdg".to_string()),
                ("main.mdg:1:17 \"primitives\"".to_string(), "primitives.mdg".to_string())
            ]
        );
    }

    #[test]
    fn nothing_to_find_on_builtins() {
        let (d, at) = doc("rule A { VER$0TEX {} }");
        assert!(d.definition(at).is_empty());
        assert!(d.references(at, true).is_empty());
    }
}
