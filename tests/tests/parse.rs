//! Data-driven parser tests: every `tests/parse/{ok,err}/*.mdg` has a `.tree` dump
//! beside it (and `err` files a `.diag` with the rendered syntax errors).
//! Regenerate with `UPDATE_EXPECT=1 cargo test -p mdg-tests --test parse`.

use mdg_compiler::parse::parse_file;
use mdg_compiler::source::Sources;
use mdg_tests::{mdg_files, root, snapshot};

fn check_spans(dump: &str, len: usize) -> Result<(), String> {
    for line in dump.lines() {
        for w in line.split(' ') {
            if let Some(r) = w.strip_prefix('@') {
                if let Some((a, b)) = r.split_once("..") {
                    let (a, b): (usize, usize) =
                        (a.parse().map_err(|_| line.to_string())?, b.parse().map_err(|_| line.to_string())?);
                    if a > b || b > len {
                        return Err(format!("span out of bounds or reversed: {line}"));
                    }
                }
            }
        }
    }
    Ok(())
}

fn run(dir: &str, expect_errors: bool) {
    let files = mdg_files(dir);
    assert!(!files.is_empty(), "no files in {dir}");
    let mut failures = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).expect("read");
        let mut sources = Sources::default();
        let name = path.strip_prefix(root()).unwrap_or(&path).display().to_string();
        let id = sources.add(&path, name, text.clone());
        let parsed = parse_file(&sources, id);
        let dump = mdg_compiler::dump::dump_file(&parsed.file);
        if let Err(e) = check_spans(&dump, text.len()) {
            failures.push(format!("{}: {e}", path.display()));
        }
        if let Err(e) = snapshot(&path.with_extension("tree"), &dump) {
            failures.push(e);
        }
        let diags = mdg_compiler::diag::render_plain(&parsed.diagnostics, &sources);
        if expect_errors {
            let n_errors = parsed.diagnostics.iter().filter(|d| d.is_error()).count();
            if n_errors != 1 {
                failures
                    .push(format!("{}: expected exactly one syntax error, got {n_errors}:\n{diags}", path.display()));
            }
            if let Err(e) = snapshot(&path.with_extension("diag"), &diags) {
                failures.push(e);
            }
        } else if !parsed.diagnostics.is_empty() {
            failures.push(format!("{}: unexpected diagnostics:\n{diags}", path.display()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn parse_ok() {
    run("tests/parse/ok", false);
}

#[test]
fn parse_err() {
    run("tests/parse/err", true);
}
