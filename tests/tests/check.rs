//! Checker tests over the corpus.
//!
//! `tests/check/ok/*.mdg` must check with no diagnostics at all. Each
//! `tests/check/err/*.mdg` carries inline expectations `//~ CODE` on the line where
//! each diagnostic's primary span starts; the actual diagnostics must match exactly,
//! and their rendered text is snapshot-tested in a `.stderr` file beside it.
//! A first line `// mdgc: build` checks the file as a program (start shape required).

use mdg_tests::{actual_diagnostics, analyze_file, expectations, mdg_files, render, root, snapshot};

#[test]
fn corpus_ok_is_clean() {
    let files = mdg_files("tests/check/ok");
    assert!(files.len() >= 40, "the ok corpus needs at least 40 programs, has {}", files.len());
    let mut failures = Vec::new();
    for path in files {
        let a = analyze_file(&path, true);
        if !a.diagnostics.is_empty() {
            failures.push(render(&a));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn corpus_err_matches_expectations() {
    let files = mdg_files("tests/check/err");
    assert!(files.len() >= 40, "the err corpus needs at least 40 programs, has {}", files.len());
    let mut failures = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).expect("read");
        let program = text.starts_with("// mdgc: build");
        let a = analyze_file(&path, program);
        let want = expectations(&text);
        let got = actual_diagnostics(&a);
        let rendered = render(&a);
        if want.is_empty() {
            failures.push(format!("{}: no `//~ CODE` expectation", path.display()));
        }
        if want != got {
            failures.push(format!("{}: expected {want:?}, got {got:?}\n{rendered}", path.display()));
        }
        if let Err(e) = snapshot(&path.with_extension("stderr"), &rendered) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Every registered diagnostic code (compiler/src/codes.rs, which docs/diagnostics.md
/// is generated from) is exercised by some test file.
#[test]
fn every_code_is_tested() {
    let codes: Vec<&str> = mdg_compiler::codes::CODES.iter().map(|c| c.code).collect();
    assert!(codes.len() > 30);
    let mut all = String::new();
    for dir in ["tests/check/err", "tests/parse/err"] {
        for f in mdg_files(dir) {
            all.push_str(&std::fs::read_to_string(f.with_extension("stderr")).unwrap_or_default());
            all.push_str(&std::fs::read_to_string(f.with_extension("diag")).unwrap_or_default());
        }
    }
    // Codes whose input cannot be a corpus file (E0212 needs a chain of 65 imported
    // files, W0012 a document of more than 2 MiB in the language server, W0901–W0903
    // come from `mdgc induce` on example buildings) are shown by
    // a named test instead, which must assert on the code.
    // W0901–W0903 are `mdgc induce`'s warnings about an induced grammar (no source).
    const TESTED_ELSEWHERE: &[(&str, &str)] = &[
        ("E0212", "tests/tests/hostile.rs"),
        ("W0012", "lsp/tests/hostile.rs"),
        ("W0901", "cli/tests/induce.rs"),
        ("W0902", "cli/tests/induce.rs"),
        ("W0903", "cli/tests/induce.rs"),
    ];
    for (code, file) in TESTED_ELSEWHERE {
        let text = std::fs::read_to_string(root().join(file)).expect("test file");
        assert!(text.contains(&format!("\"{code}\"")), "{file} does not test {code}");
    }
    let missing: Vec<&&str> = codes
        .iter()
        .filter(|c| !all.contains(&format!("[{c}]")) && !TESTED_ELSEWHERE.iter().any(|(t, _)| t == *c))
        .collect();
    assert!(missing.is_empty(), "codes with no test showing their rendered text: {missing:?}");
}

#[test]
fn std_library_checks_clean() {
    let mut failures = Vec::new();
    for path in mdg_files("std") {
        let a = analyze_file(&path, false);
        if !a.diagnostics.is_empty() {
            failures.push(render(&a));
        }
    }
    let examples = mdg_files("std/examples");
    assert!(examples.len() >= 12, "std/examples needs at least 12 programs");
    for path in examples {
        let a = analyze_file(&path, true);
        if !a.diagnostics.is_empty() {
            failures.push(render(&a));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
