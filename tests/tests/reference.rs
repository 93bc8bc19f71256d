//! The language reference cannot drift from the compiler: every ```mdg block in
//! `docs/reference.md` must check with no diagnostics.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze_text;
use mdg_compiler::source::FsLoader;
use mdg_tests::{options, root};

#[test]
fn reference_examples_check_clean() {
    check_doc("docs/reference.md", 30);
}

#[test]
fn context_free_porting_examples_check_clean() {
    check_doc("docs/from-context-free.md", 5);
}

/// Every ```mdg block of the document `rel` checks with no diagnostics; it has at
/// least `min` of them.
fn check_doc(rel: &str, min: usize) {
    let doc = std::fs::read_to_string(root().join(rel)).expect(rel);
    let mut blocks = Vec::new();
    let mut cur: Option<(usize, String)> = None;
    for (i, line) in doc.lines().enumerate() {
        match &mut cur {
            None if line.trim_start().starts_with("```mdg") => cur = Some((i + 1, String::new())),
            Some((start, text)) if line.trim_start().starts_with("```") => {
                blocks.push((*start, std::mem::take(text)));
                cur = None;
            }
            Some((_, text)) => {
                text.push_str(line);
                text.push('\n');
            }
            None => {}
        }
    }
    assert!(blocks.len() >= min, "{rel} has only {} mdg examples", blocks.len());
    let mut failures = Vec::new();
    for (line, text) in blocks {
        let path = root().join(format!("{rel}.mdg"));
        let a = analyze_text(&FsLoader, &path, &text, &options(), CheckOptions::default());
        if !a.diagnostics.is_empty() {
            failures
                .push(format!("{rel} line {line}:\n{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources)));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
