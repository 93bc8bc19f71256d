//! Shared helpers for the end-to-end tests: paths, corpus listing, snapshots,
//! inline expectations and span-free tree dumps.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::{analyze, Analysis};
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use std::path::{Path, PathBuf};

pub mod alloc;

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().expect("workspace root")
}

/// The std library directory.
pub fn std_dir() -> PathBuf {
    root().join("std")
}

/// Sorted `.mdg` files directly in `dir` (relative to the workspace root).
pub fn mdg_files(dir: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join(dir))
        .map(|rd| {
            rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "mdg")).collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Compiler options used by the tests (std from the workspace).
pub fn options() -> Options {
    Options { std_dir: Some(std_dir()), ..Options::default() }
}

/// Analyzes a file with the test options.
pub fn analyze_file(path: &Path, require_start: bool) -> Analysis {
    analyze(&FsLoader, path, &options(), CheckOptions { require_start })
}

/// Renders diagnostics with paths relative to the workspace root.
pub fn render(a: &Analysis) -> String {
    let text = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
    let prefix = format!("{}/", root().display());
    text.replace(&prefix, "")
}

/// Compares `actual` with the snapshot file at `path`; with `UPDATE_EXPECT=1` rewrites it.
/// Returns an error message on mismatch.
pub fn snapshot(path: &Path, actual: &str) -> Result<(), String> {
    if std::env::var_os("UPDATE_EXPECT").is_some() {
        std::fs::write(path, actual).map_err(|e| e.to_string())?;
        return Ok(());
    }
    let expected = std::fs::read_to_string(path)
        .map_err(|_| format!("missing snapshot {} (run with UPDATE_EXPECT=1)", path.display()))?;
    if expected != actual {
        return Err(format!("snapshot {} differs:\n--- expected\n{expected}\n--- actual\n{actual}", path.display()));
    }
    Ok(())
}

/// Inline expectations `//~ CODE` in a source: (1-based line, code) pairs.
pub fn expectations(text: &str) -> Vec<(u32, String)> {
    let mut v = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if let Some(pos) = line.find("//~") {
            for code in line[pos + 3..].split_whitespace() {
                v.push((i as u32 + 1, code.to_string()));
            }
        }
    }
    v.sort();
    v
}

/// The (1-based line, code) of every diagnostic in the analysis's main file.
pub fn actual_diagnostics(a: &Analysis) -> Vec<(u32, String)> {
    let main = a.expanded.files.first().copied().unwrap_or_default();
    let mut v: Vec<(u32, String)> = a
        .diagnostics
        .iter()
        .map(|d| {
            let line = if d.span.file == main { a.sources.file(d.span.file).line_col(d.span.start).0 + 1 } else { 0 };
            (line, d.code.to_string())
        })
        .collect();
    v.sort();
    v
}

/// A tree dump with spans removed, for comparing trees of differently laid-out text.
pub fn dump_without_spans(file: &mdg_compiler::ast::File) -> String {
    let dump = mdg_compiler::dump::dump_file(file);
    dump.lines()
        .map(|l| {
            l.split(' ')
                .filter(|w| !(w.starts_with('@') && w[1..].chars().next().is_some_and(|c| c.is_ascii_digit())))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The workspace's one test generator (xorshift64*), for bounded fuzz loops.
pub use mdg_vm::rng::Rng;

/// Compiles `text` (as if at `tests/inline.mdg`, std imports available) to a bundle.
pub fn build_source(text: &str) -> mdg_vm::bundle::Bundle {
    let path = root().join("tests/inline.mdg");
    let a =
        mdg_compiler::driver::analyze_text(&FsLoader, &path, text, &options(), CheckOptions { require_start: true });
    assert!(!a.has_errors(), "{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
    let mut b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowering");
    mdg_compiler::shaders::attach(&mut b, &a.spirv);
    b
}

/// Compiles and evaluates `text` with default options.
pub fn run_source(text: &str) -> mdg_vm::output::Output {
    mdg_vm::eval::evaluate(&build_source(text), &mdg_vm::eval::EvalOptions::default())
}
