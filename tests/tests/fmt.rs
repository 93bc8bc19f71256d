//! Formatter properties over the corpus, std and the parser tests: formatting is
//! idempotent, keeps every comment, and the output parses to the same tree.

use mdg_compiler::fmt::format_source;
use mdg_compiler::parse::parse_file;
use mdg_compiler::source::Sources;
use mdg_tests::{dump_without_spans, mdg_files};

fn tree(text: &str) -> String {
    let mut s = Sources::default();
    let id = s.add("x.mdg", "x.mdg", text);
    dump_without_spans(&parse_file(&s, id).file)
}

fn comments(text: &str) -> Vec<String> {
    let lexed = mdg_compiler::lexer::lex(text, mdg_compiler::span::FileId(0));
    lexed.comments.iter().map(|c| text[c.span.range()].trim_end().to_string()).collect()
}

#[test]
fn format_is_idempotent_and_preserves_trees() {
    let mut files = Vec::new();
    for dir in ["tests/check/ok", "tests/check/ok/lib", "tests/parse/ok", "std", "std/examples"] {
        files.extend(mdg_files(dir));
    }
    assert!(files.len() > 50);
    let mut failures = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).expect("read");
        let once = match format_source(&text) {
            Ok(t) => t,
            Err(e) => {
                failures.push(format!("{}: {e}", path.display()));
                continue;
            }
        };
        let twice = format_source(&once).unwrap_or_default();
        if once != twice {
            failures.push(format!("{}: not idempotent:\n--- once\n{once}\n--- twice\n{twice}", path.display()));
        }
        if tree(&text) != tree(&once) {
            failures.push(format!("{}: formatting changed the tree:\n{once}", path.display()));
        }
        if comments(&text) != comments(&once) {
            failures.push(format!("{}: formatting lost or reordered comments", path.display()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn format_layout_example() {
    let src = "startshape A // start\nrule A{ B{x 1 ry 90}\\ 3*[rz 120]{B{}}\n}\n\n\n// lib\nrule B {VERTEX{}}";
    let want = "startshape A // start\nrule A {\n  B {x 1 ry 90} \\\n  3 * [rz 120] {\n    B {}\n  }\n}\n\n// lib\nrule B {\n  VERTEX {}\n}\n";
    assert_eq!(format_source(src).expect("formats"), want);
}

#[test]
fn format_refuses_syntax_errors() {
    let err = format_source("rule A { B{ }").expect_err("unclosed brace");
    assert!(matches!(&err, mdg_compiler::fmt::FormatError::Syntax(d) if d.contains("E0104")), "{err:?}");
}
