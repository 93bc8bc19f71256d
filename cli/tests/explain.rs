//! `mdgc explain CODE`: every registered code prints its title, explanation and
//! example; an unknown code exits 2 with a message saying so.

use mdg_compiler::codes::CODES;
use std::process::{Command, Output};

fn mdgc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mdgc")).args(args).output().expect("run mdgc")
}

#[test]
fn explain_prints_every_code() {
    for c in CODES {
        let out = mdgc(&["explain", c.code]);
        assert!(out.status.success(), "mdgc explain {}: {:?}", c.code, out.status);
        let text = String::from_utf8(out.stdout).expect("utf-8");
        assert!(text.starts_with(&format!("{} (", c.code)), "{}: {text}", c.code);
        assert!(text.contains(c.title), "{}: no title in {text}", c.code);
        let first = c.explanation.lines().next().expect("explanation");
        assert!(text.contains(first), "{}: no explanation in {text}", c.code);
        if let mdg_compiler::codes::Example::Editor(what) | mdg_compiler::codes::Example::Command(what) = c.example {
            // Made by the language server: the example says for what document.
            assert!(text.contains(&format!("Example: {what}")), "{}: no example in {text}", c.code);
            continue;
        }
        let example_line = c.example.text().lines().find(|l| !l.trim().is_empty()).expect("example");
        assert!(text.contains(&format!("    {example_line}")), "{}: no example in {text}", c.code);
    }
}

#[test]
fn explain_e0102() {
    let out = mdgc(&["explain", "e0102"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert!(text.starts_with("E0102 (error): unterminated block comment\n"), "{text}");
    assert!(text.contains("/* this comment never ends"), "{text}");
}

#[test]
fn unknown_code_exits_2() {
    for bad in ["E9999", "X0101", "rule"] {
        let out = mdgc(&["explain", bad]);
        assert_eq!(out.status.code(), Some(2), "mdgc explain {bad}");
        assert!(out.stdout.is_empty());
        let err = String::from_utf8(out.stderr).expect("utf-8");
        assert!(err.contains(&format!("`{bad}` is not a diagnostic code")), "{err}");
    }
    // No code at all is a usage error too.
    assert_eq!(mdgc(&["explain"]).status.code(), Some(2));
}

#[test]
fn list_shows_every_code() {
    let out = mdgc(&["explain", "--list"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).expect("utf-8");
    assert_eq!(text.lines().count(), CODES.len());
    for c in CODES {
        assert!(text.contains(&format!("{}  ", c.code)) && text.contains(c.title), "{} missing from --list", c.code);
    }
}
