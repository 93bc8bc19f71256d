//! Code actions: the compiler's suggested edits (did-you-mean replacements, remove
//! an unused rule, drop a unit suffix) and "create rule" for an undefined rule.

use super::{Document, Edit};
use crate::diag::Diagnostic;
use crate::span::Span;

/// Codes whose primary span is the name of an undefined rule.
const UNDEFINED_RULE: &[&str] = &["E0301", "E0305", "E0307", "E0308"];

/// A fix for a diagnostic.
#[derive(Clone, Debug, PartialEq)]
pub struct CodeAction {
    pub title: String,
    pub edits: Vec<Edit>,
    /// Whether an editor may apply it without asking (the obvious fix).
    pub preferred: bool,
    /// The diagnostic it fixes.
    pub diagnostic: Diagnostic,
}

impl Document {
    /// The fixes for diagnostics touching the byte range `start..end` of the document.
    pub fn code_actions(&self, start: u32, end: u32) -> Vec<CodeAction> {
        let mut out = Vec::new();
        for d in self.diagnostics() {
            if d.span.file != self.main_file() || d.span.end < start || d.span.start > end {
                continue;
            }
            if let Some(s) = &d.suggestion {
                let removal = s.replacement.is_empty();
                let title = if d.code == "W0001" {
                    format!("Remove unused rule `{}`", self.rule_name_in(&d))
                } else if s.message.starts_with("did you mean") {
                    format!("Replace with `{}`", s.replacement)
                } else {
                    capitalize(&s.message)
                };
                let span = if removal { self.whole_lines(s.span) } else { s.span };
                out.push(CodeAction {
                    title,
                    edits: vec![Edit { span, new_text: s.replacement.clone() }],
                    preferred: !removal,
                    diagnostic: d.clone(),
                });
            }
            if UNDEFINED_RULE.contains(&d.code) {
                let name = self.span_text(d.span).to_string();
                let valid = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                    && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
                if valid {
                    let text = self.text();
                    let lead = if text.is_empty() || text.ends_with("\n\n") {
                        ""
                    } else if text.ends_with('\n') {
                        "\n"
                    } else {
                        "\n\n"
                    };
                    let at = Span::new(self.main_file(), text.len() as u32, text.len() as u32);
                    out.push(CodeAction {
                        title: format!("Create rule `{name}`"),
                        edits: vec![Edit {
                            span: at,
                            new_text: format!(
                                "{lead}rule {name} {{\n  VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}}\n}}\n"
                            ),
                        }],
                        preferred: d.suggestion.is_none(),
                        diagnostic: d.clone(),
                    });
                }
            }
        }
        out
    }

    /// The name a W0001 diagnostic is about.
    fn rule_name_in(&self, d: &Diagnostic) -> String {
        d.message.split('`').nth(1).unwrap_or_else(|| self.span_text(d.span)).to_string()
    }

    /// `span` grown to whole lines when only whitespace surrounds it on them.
    fn whole_lines(&self, span: Span) -> Span {
        let text = self.text();
        let (s, e) = (span.start as usize, (span.end as usize).min(text.len()));
        let line_start = text[..s].rfind('\n').map(|i| i + 1).unwrap_or(0);
        let line_end = text[e..].find('\n').map(|i| e + i + 1).unwrap_or(text.len());
        if text[line_start..s].trim().is_empty() && text[e..line_end].trim().is_empty() {
            Span::new(span.file, line_start as u32, line_end as u32)
        } else {
            span
        }
    }
}

fn capitalize(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::doc;

    fn fix(src: &str, title: &str) -> String {
        let (d, at) = doc(src);
        let actions = d.code_actions(at, at);
        let a = actions.iter().find(|a| a.title == title).unwrap_or_else(|| {
            panic!("no action {title:?} in {:?}", actions.iter().map(|a| &a.title).collect::<Vec<_>>())
        });
        let mut out = d.text().to_string();
        for e in a.edits.iter().rev() {
            out.replace_range(e.span.range(), &e.new_text);
        }
        out
    }

    #[test]
    fn did_you_mean_replaces_the_name() {
        assert_eq!(
            fix("startshape A\nrule A { tre$0 {} }\nrule tree { VERTEX {} }", "Replace with `tree`"),
            "startshape A\nrule A { tree {} }\nrule tree { VERTEX {} }"
        );
        assert_eq!(
            fix("maxdpth$0 4\nrule A { VERTEX {} }", "Replace with `maxdepth`"),
            "maxdepth 4\nrule A { VERTEX {} }"
        );
        assert_eq!(fix("rule A { VERTEX {rxx$0 3} }", "Replace with `rx`"), "rule A { VERTEX {rx 3} }");
    }

    #[test]
    fn removes_an_unused_rule_with_its_lines() {
        let src = "startshape A\nrule A { VERTEX {} }\nrule un$0used {\n  VERTEX {}\n}\nrule B { VERTEX {} }\n";
        assert_eq!(
            fix(&src.replace("rule B { VERTEX {} }\n", ""), "Remove unused rule `unused`"),
            "startshape A\nrule A { VERTEX {} }\n"
        );
    }

    #[test]
    fn creates_a_missing_rule() {
        let out = fix("startshape A\nrule A { branch$0 {} }", "Create rule `branch`");
        assert_eq!(
            out,
            "startshape A\nrule A { branch {} }\n\nrule branch {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n}\n"
        );
        let (d, _) = doc(&out);
        assert!(d.diagnostics().is_empty(), "{:?}", d.diagnostics());
        let out = fix("startshape mai$0n\n", "Create rule `main`");
        assert!(out.ends_with("rule main {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n}\n"), "{out}");
    }

    #[test]
    fn adds_the_import_of_a_std_name() {
        // Thesis Listing 4.1 calls SPHERE as if it were built in.
        let out = fix("startshape A\nrule A { SPH$0ERE {} }", "Add `@import primitives`");
        assert_eq!(out, "@import primitives\nstartshape A\nrule A { SPHERE {} }");
        let (d, _) = doc(&out);
        assert!(d.diagnostics().is_empty(), "{:?}", d.diagnostics());
    }

    #[test]
    fn adds_to_a_std_rule_on_purpose() {
        // W0015: a rule named like std's `square` adds to it; the fix says so with `+=`.
        let src = "@import primitives\nstartshape A\nrule A { square {} }\nrule squ$0are { VERTEX {} }\n";
        let out = fix(src, "Add to `square` on purpose: `rule square +=`");
        assert_eq!(out, "@import primitives\nstartshape A\nrule A { square {} }\nrule square += { VERTEX {} }\n");
        let (d, _) = doc(&out);
        assert!(d.diagnostics().is_empty(), "{:?}", d.diagnostics());
        // W0016: `+=` with nothing to add to; the fix removes only `+=`.
        let out = fix("startshape t\nrule t(int n = 1) +$0= 0.5 { VERTEX {} }\n", "Remove `+=`");
        assert_eq!(out, "startshape t\nrule t(int n = 1) 0.5 { VERTEX {} }\n");
    }

    #[test]
    fn writes_context_free_constructs_in_mdg() {
        let clean = |out: &str| {
            let (d, _) = doc(out);
            let errors: Vec<_> = d.diagnostics().into_iter().filter(|d| d.is_error()).collect();
            assert!(errors.is_empty(), "{out}\n{errors:?}");
        };
        let v = "VERTEX {} VERTEX {x 1} VERTEX {y 1}";
        let out = fix(&format!("startshape A\nsha$0pe A {{ {v} }}\n"), "Write `rule`");
        assert_eq!(out, format!("startshape A\nrule A {{ {v} }}\n"));
        clean(&out);
        let out = fix(
            &format!("startshape A\nshape A$0\nrule 2 {{ {v} }}\nrule {{ {v} }}\n"),
            "Name each definition `rule A`",
        );
        assert_eq!(out, format!("startshape A\nrule A 2 {{ {v} }}\nrule A {{ {v} }}\n"));
        clean(&out);
        let out = fix(
            &format!("startshape A\nCF::Minim$0umSize = 0.01\nrule A {{ {v} A {{s 0.5}} }}\n"),
            "Write `minsize 0.01`",
        );
        assert_eq!(out, format!("startshape A\nminsize 0.01\nrule A {{ {v} A {{s 0.5}} }}\n"));
        clean(&out);
        let out = fix(&format!("startshape A\nrule A {{ lo$0op 5 [x 1] B {{}} }}\nrule B {{ {v} }}\n"), "Write `5 *`");
        assert_eq!(out, format!("startshape A\nrule A {{ 5 * [x 1] B {{}} }}\nrule B {{ {v} }}\n"));
        clean(&out);
        let out = fix(
            &format!("startshape t$0ree(8)\nrule tree(int n) {{ {v} }}\n"),
            "Start with a rule `start_tree` that calls it",
        );
        assert_eq!(
            out,
            format!("startshape start_tree\n\nrule start_tree {{ tree(8) {{}} }}\nrule tree(int n) {{ {v} }}\n")
        );
        clean(&out);
        // `switch` is MDG's own, in Context Free's spelling: no error, no fix.
        for src in [
            format!(
                "startshape A\nrule A {{ B(1) {{}} }}\nrule B(int k) {{\n  swi$0tch (k) {{\n    case 1: C {{}}\n    case 2, 3: {{ C {{}} C {{x 1}} }}\n    else: C {{y 1}}\n  }}\n}}\nrule C {{ {v} }}\n"
            ),
            format!(
                "startshape A\nrule A {{ B(1) {{}} }}\nrule B(int k) {{ swi$0tch (k) {{ case 2..4: C {{}} else: C {{x 1}} }} }}\nrule C {{ {v} }}\n"
            ),
        ] {
            let (d, at) = doc(&src);
            let titles: Vec<String> = d.code_actions(at, at).into_iter().map(|a| a.title).collect();
            assert!(titles.iter().all(|t| !t.contains("`if` chain")), "{titles:?}");
            clean(&src.replace("$0", ""));
        }
        let out = fix(
            &format!("startshape A\nrule A {{ B(4) {{}} }}\nrule B(int n) {{ {v} B(=$0) {{s 0.5}} }}\nmaxdepth 3\n"),
            "Write `n`",
        );
        assert_eq!(
            out,
            format!("startshape A\nrule A {{ B(4) {{}} }}\nrule B(int n) {{ {v} B(n) {{s 0.5}} }}\nmaxdepth 3\n")
        );
        clean(&out);
        let out = fix(
            &format!("startshape A\nrule A {{ VERTEX {{x (rand$0int(1, 4))}} {v} }}\n"),
            "Write `floor(rand(1, 4))`",
        );
        assert_eq!(out, format!("startshape A\nrule A {{ VERTEX {{x (floor(rand(1, 4)))}} {v} }}\n"));
        clean(&out);
    }

    #[test]
    fn no_actions_away_from_diagnostics() {
        let (d, at) = doc("startshape A\nrule A {$0 VERTEX {} }\nrule B { nope {} }");
        assert!(d.code_actions(at, at).is_empty());
    }
}
