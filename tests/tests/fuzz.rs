//! Bounded fuzzing in the test suite: the lexer, parser, checker and formatter never
//! panic on arbitrary input, and formatting stays idempotent. (Longer runs: the
//! `fuzz/` targets.) Inputs are random bytes, random token soup, and mutations of
//! corpus files; the PRNG is seeded, so failures reproduce.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze_text;
use mdg_compiler::fmt::format_source;
use mdg_compiler::source::MemLoader;
use mdg_tests::{mdg_files, Rng};
use std::path::Path;

const PIECES: &[&str] = &[
    "rule",
    "startshape",
    "selector",
    "namespace",
    "function",
    "isosurface",
    "program",
    "uniform",
    "angle",
    "color",
    "weight",
    "A",
    "B",
    "ns.A",
    "VERTEX",
    "LINETO",
    "x",
    "rx",
    "s",
    "fx",
    "{",
    "}",
    "[",
    "]",
    "(",
    ")",
    "*",
    "/",
    "\\",
    ":",
    ",",
    ";",
    "-",
    "+",
    "^",
    "1",
    "0",
    "2.5",
    ".25",
    "90d",
    "2t",
    "rand(",
    "sin(",
    "@import",
    "@define D",
    "@ifdef",
    "@else",
    "@endif",
    "@macro M(a)",
    "@endmacro",
    "@expand M(",
    "@param int n 3",
    "@vertexshader V",
    "@endshader",
    "// c\n",
    "/* c */",
    "\n",
    " ",
    "maxdepth",
    "depth",
    "%",
    "é",
];

fn exercise(text: &str) {
    let loader = MemLoader::default();
    let a = analyze_text(
        &loader,
        Path::new("/fuzz/main.mdg"),
        text,
        &Default::default(),
        CheckOptions { require_start: true },
    );
    // Rendering must not panic either.
    let _ = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
    if let Ok(once) = format_source(text) {
        let twice = format_source(&once).expect("formatted output must parse");
        assert_eq!(once, twice, "formatting not idempotent for input {text:?}");
    }
}

#[test]
fn random_token_soup_never_panics() {
    let mut rng = Rng(0x5EED_0001);
    for _ in 0..1500 {
        let n = rng.below(40);
        let text: String = (0..n).map(|_| PIECES[rng.below(PIECES.len())]).collect::<Vec<_>>().join(" ");
        exercise(&text);
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = Rng(0x5EED_0002);
    for _ in 0..1500 {
        let n = rng.below(64);
        let bytes: Vec<u8> = (0..n).map(|_| rng.bits() as u8).collect();
        exercise(&String::from_utf8_lossy(&bytes));
    }
}

#[test]
fn mutated_corpus_never_panics() {
    let mut rng = Rng(0x5EED_0003);
    let files = mdg_files("tests/check/ok");
    for path in files.iter().take(60) {
        let text = std::fs::read_to_string(path).expect("read");
        for _ in 0..25 {
            let mut chars: Vec<char> = text.chars().collect();
            for _ in 0..1 + rng.below(4) {
                if chars.is_empty() {
                    break;
                }
                let i = rng.below(chars.len());
                match rng.below(3) {
                    0 => {
                        chars.remove(i);
                    }
                    1 => chars.insert(i, PIECES[rng.below(PIECES.len())].chars().next().unwrap_or('{')),
                    _ => {
                        let j = rng.below(chars.len());
                        chars.swap(i, j);
                    }
                }
            }
            exercise(&chars.into_iter().collect::<String>());
        }
    }
}
