//! Rename: every definition and reference of a rule (or namespace, function,
//! isosurface, macro, shader) in every file of the analysis, std excepted.
//!
//! A dotted reference `ns.A` is renamed in its last segment only, so renaming rule
//! `ns.A` to `B` gives `ns.B`, and renaming namespace `ns` edits only the prefixes.

use super::index::Symbol;
use super::{Document, Edit};
use crate::span::Span;

// Keywords cannot be names: a rename to one is refused.
use crate::lexer::KEYWORDS;

/// Why a rename is refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RenameError {
    /// No rule or other symbol at the position.
    NoSymbol,
    /// The new name is not an identifier, or is a keyword.
    InvalidName(String),
    /// A rule with the new (full, dotted) name exists.
    Exists(String),
    /// The std library (file `file`) uses the `kind` named `name`.
    InStd { kind: &'static str, name: String, file: String },
    /// The symbol has no definition.
    NotDefined(String),
}

impl std::fmt::Display for RenameError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenameError::NoSymbol => write!(f, "there is no rule or other symbol here to rename"),
            RenameError::InvalidName(n) => write!(f, "`{n}` is not a valid name"),
            RenameError::Exists(n) => write!(f, "a rule named `{n}` already exists"),
            RenameError::InStd { kind, name, file } => {
                write!(f, "the {kind} `{name}` is used in the std library ({file}), which cannot be edited")
            }
            RenameError::NotDefined(n) => write!(f, "`{n}` is not defined"),
        }
    }
}

impl std::error::Error for RenameError {}

impl Document {
    /// The span of the name at `offset` that a rename would change, and its text.
    pub fn prepare_rename(&self, offset: u32) -> Result<(Span, String), RenameError> {
        let (sym, span) = self.index().symbol_at(offset).ok_or(RenameError::NoSymbol)?;
        self.check_renamable(sym)?;
        let span = last_segment(self, span);
        Ok((span, self.span_text(span).to_string()))
    }

    /// The edits that rename the symbol at `offset` to `new_name`.
    pub fn rename(&self, offset: u32, new_name: &str) -> Result<Vec<Edit>, RenameError> {
        let (sym, _) = self.index().symbol_at(offset).ok_or(RenameError::NoSymbol)?;
        self.rename_symbol(&sym.clone(), new_name)
    }

    /// The edits that rename `sym` to `new_name` in every file of this analysis
    /// (std excepted: a symbol std uses is refused). A workspace rename asks this of
    /// the analysis of every file that sees the symbol and merges the edits.
    pub fn rename_symbol(&self, sym: &Symbol, new_name: &str) -> Result<Vec<Edit>, RenameError> {
        let idx = self.index();
        self.check_renamable(sym)?;
        let valid = new_name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && new_name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !valid || KEYWORDS.contains(&new_name) || crate::lexer::CONTROL_KEYWORDS.contains(&new_name) {
            return Err(RenameError::InvalidName(new_name.to_string()));
        }
        if let Symbol::Rule(full) = sym {
            let renamed = match full.rsplit_once('.') {
                Some((ns, _)) => format!("{ns}.{new_name}"),
                None => new_name.to_string(),
            };
            if renamed != *full && self.analysis.checked.symbols.rules.contains_key(&renamed) {
                return Err(RenameError::Exists(renamed));
            }
        }
        let mut spans: Vec<Span> = idx.definitions(sym).chain(idx.references(sym)).collect();
        spans.sort();
        spans.dedup();
        Ok(spans.into_iter().map(|s| Edit { span: last_segment(self, s), new_text: new_name.to_string() }).collect())
    }

    fn check_renamable(&self, sym: &Symbol) -> Result<(), RenameError> {
        let idx = self.index();
        for span in idx.definitions(sym).chain(idx.references(sym)) {
            if let Some(f) = self.analysis.sources.files.get(span.file.0 as usize) {
                if f.name.starts_with("std/") && span.file != self.main_file() {
                    return Err(RenameError::InStd {
                        kind: sym.kind_word(),
                        name: sym.name().to_string(),
                        file: f.name.clone(),
                    });
                }
            }
        }
        if idx.definitions(sym).next().is_none() {
            return Err(RenameError::NotDefined(sym.name().to_string()));
        }
        Ok(())
    }
}

/// The last dotted segment of a name's span.
fn last_segment(doc: &Document, span: Span) -> Span {
    let text = doc.span_text(span);
    match text.rfind('.') {
        Some(i) => Span::new(span.file, span.start + i as u32 + 1, span.end),
        None => span,
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{doc, doc_with, show};
    use super::RenameError;

    fn apply(text: &str, mut edits: Vec<(usize, usize, String)>) -> String {
        edits.sort();
        let mut out = text.to_string();
        for (s, e, t) in edits.into_iter().rev() {
            out.replace_range(s..e, &t);
        }
        out
    }

    #[test]
    fn renames_definitions_and_uses() {
        let src = "startshape A\nselector leaf random\nrule A { le$0af {} 3 * {x 1} leaf {} }\nrule leaf 2 { VERTEX {} }\nrule leaf { leaf {} }\n";
        let (d, at) = doc(src);
        let edits = d.rename(at, "twig").expect("rename");
        let main = d.main_file();
        assert!(edits.iter().all(|e| e.span.file == main));
        let out = apply(
            d.text(),
            edits.into_iter().map(|e| (e.span.start as usize, e.span.end as usize, e.new_text)).collect(),
        );
        assert_eq!(out, "startshape A\nselector twig random\nrule A { twig {} 3 * {x 1} twig {} }\nrule twig 2 { VERTEX {} }\nrule twig { twig {} }\n");
    }

    #[test]
    fn a_parameter_is_renamed_in_its_rule_only() {
        let src = "rule tree(int $0n) {\n  VERTEX {y n}\n  if (n > 0) { tree(n - 1) {s 0.5} }\n}\nrule other(int n) { VERTEX {y n} }\n";
        let (d, at) = doc(src);
        let edits = d.rename(at, "levels").expect("rename");
        let out = apply(
            d.text(),
            edits.into_iter().map(|e| (e.span.start as usize, e.span.end as usize, e.new_text)).collect(),
        );
        assert_eq!(
            out,
            "rule tree(int levels) {\n  VERTEX {y levels}\n  if (levels > 0) { tree(levels - 1) {s 0.5} }\n}\nrule other(int n) { VERTEX {y n} }\n"
        );
        // From a use, too; and never to a keyword.
        let at_use = d.text().find("n - 1").expect("a use") as u32;
        assert_eq!(d.rename(at_use, "m").expect("rename").len(), 4);
        assert!(d.rename(at_use, "loop").is_err());
    }

    #[test]
    fn dotted_names_change_in_the_last_segment() {
        let (d, at) = doc("namespace n { rule a$0rm { VERTEX {} } }\nstartshape A\nrule A { n.arm {} }");
        let (span, text) = d.prepare_rename(at).expect("prepare");
        assert_eq!((show(&d, span), text.as_str()), ("main.mdg:1:20 \"arm\"".to_string(), "arm"));
        let edits = d.rename(at, "leg").expect("rename");
        let out = apply(
            d.text(),
            edits.into_iter().map(|e| (e.span.start as usize, e.span.end as usize, e.new_text)).collect(),
        );
        assert_eq!(out, "namespace n { rule leg { VERTEX {} } }\nstartshape A\nrule A { n.leg {} }");
    }

    #[test]
    fn edits_reach_imported_files() {
        let (d, at) = doc_with(
            "@import lib.mdg\nstartshape A\nrule A { sh$0ape {} }",
            &[("lib.mdg", "rule shape { VERTEX {} }\n")],
        );
        let edits = d.rename(at, "form").expect("rename");
        let shown: Vec<String> = edits.iter().map(|e| show(&d, e.span)).collect();
        assert_eq!(shown, ["main.mdg:3:10 \"shape\"", "lib.mdg:1:6 \"shape\""]);
    }

    #[test]
    fn a_symbol_of_one_analysis_is_renamed_in_another() {
        // The library alone, and a program importing it: the symbol found in the
        // library's analysis names the same rule in the importer's.
        let lib = "rule shape { VERTEX {} }\n";
        let (l, at) = doc_with("rule sh$0ape { VERTEX {} }\n", &[]);
        let (sym, _) = l.symbol_at(at).expect("symbol");
        let (d, _) = doc_with("@import lib.mdg\nstartshape A\nrule A { shape {} shape {x 1} }", &[("lib.mdg", lib)]);
        let defs: Vec<String> = d.symbol_definitions(&sym).into_iter().map(|s| show(&d, s)).collect();
        assert_eq!(defs, ["lib.mdg:1:6 \"shape\""]);
        assert_eq!(d.symbol_references(&sym, false).len(), 2);
        assert_eq!(d.symbol_references(&sym, true).len(), 3);
        let edits = d.rename_symbol(&sym, "form").expect("rename");
        let shown: Vec<String> = edits.iter().map(|e| show(&d, e.span)).collect();
        assert_eq!(shown, ["main.mdg:3:10 \"shape\"", "main.mdg:3:19 \"shape\"", "lib.mdg:1:6 \"shape\""]);
        let (c, _) = doc_with(
            "@import lib.mdg\nstartshape A\nrule A { shape {} }\nrule form { VERTEX {} }",
            &[("lib.mdg", lib)],
        );
        assert_eq!(c.rename_symbol(&sym, "form"), Err(RenameError::Exists("form".into())));
    }

    #[test]
    fn refuses_bad_names_clashes_std_and_builtins() {
        let (d, at) = doc("startshape A\nrule A { B$0 {} }\nrule B { VERTEX {} }\nrule C { VERTEX {} }");
        assert_eq!(d.rename(at, "9x"), Err(RenameError::InvalidName("9x".into())));
        assert_eq!(d.rename(at, "rule"), Err(RenameError::InvalidName("rule".into())));
        assert_eq!(d.rename(at, "C"), Err(RenameError::Exists("C".into())));
        let (d, at) = doc("@import primitives\nstartshape A\nrule A { cu$0be {} }");
        let e = d.rename(at, "box").expect_err("std");
        assert!(matches!(&e, RenameError::InStd { kind: "rule", file, .. } if file == "std/primitives.mdg"), "{e:?}");
        assert!(e.to_string().contains("std/primitives.mdg"), "{e}");
        let (d, at) = doc("rule A { VERT$0EX {} }");
        assert_eq!(d.prepare_rename(at), Err(RenameError::NoSymbol));
    }
}
