//! Robustness: every feature at random offsets of randomly edited documents —
//! unbalanced brackets, half-written preprocessor lines, unterminated comments and
//! sections, non-ASCII text — must answer without panicking, in bounded time.

use super::fixture::doc;
use super::CompletionConfig;
use mdg_vm::rng::Rng;
use std::time::{Duration, Instant};

/// Fragments of MDG, whole and broken, inserted at random places.
pub const FRAGMENTS: &[&str] = &[
    "rule ",
    "A",
    "B",
    "leaf",
    " ",
    "\n",
    "{",
    "}",
    "[",
    "]",
    "(",
    ")",
    "VERTEX {}",
    "x 1",
    "rz 45",
    "s 0.5",
    "0.25o",
    "2t",
    "-",
    "30/30 * [ry 360] ",
    "4 * {rz 90} ",
    "\\",
    "startshape A\n",
    "maxdepth 8\n",
    "selector leaf depth\n",
    "namespace n { ",
    "n.A {}",
    "@import primitives\n",
    "@import lib/missing.mdg\n",
    "@macro M(a)\nVERTEX {x a}\n@endmacro\n",
    "@expand M(1)\n",
    "@macro ",
    "@ifdef X\n",
    "@else\n",
    "@endif\n",
    "@define X 2\n",
    "@param int n 4 1 9\n",
    "(n)",
    "@bogus\n",
    "/*",
    "*/",
    "// c\n",
    "é",
    "😀",
    "\u{200b}",
    "function f { x*x }\n",
    "isosurface S { xyz -1 1 4 ; function f }\n",
    "S {}",
    "@endshader\n",
    "@vertexshader vs\nvoid main() {}\n@endshader\n",
    "program { vertexshader vs render }\n",
    "rand(0, 1)",
    "#",
    ";",
    "cube {}",
    "guide g { ",
    "search {\n  skeleton leaf;\n}\n",
    "creature c {\n  part p { rule leaf; slot s { at 0 0 1; } }\n}\n",
    "part p { ",
    "points 0 0 0 0 0 1;",
    "\"a.obj\"",
    "\"",
    "grid ",
];

/// One random edit of `text` (an insertion of a fragment or a deletion), kept under 3,000 bytes.
pub fn edit(rng: &mut Rng, text: &mut String) {
    edit_once(rng, text);
}

fn edit_once(rng: &mut Rng, text: &mut String) {
    let boundary = |rng: &mut Rng, text: &str| {
        let k = rng.below(text.chars().count() + 1);
        text.char_indices().nth(k).map(|(i, _)| i).unwrap_or(text.len())
    };
    if rng.below(3) == 0 && !text.is_empty() {
        let a = boundary(rng, text);
        let len = 1 + rng.below(24);
        let b = text[a..].char_indices().nth(len).map(|(j, _)| a + j).unwrap_or(text.len());
        text.replace_range(a..b, "");
    } else {
        let at = boundary(rng, text);
        text.insert_str(at, FRAGMENTS[rng.below(FRAGMENTS.len())]);
    }
    while text.len() > 3000 {
        let cut = text.char_indices().nth(text.chars().count() / 2).map(|(j, _)| j).unwrap_or(0);
        text.replace_range(cut..text.len(), "");
    }
}

#[test]
fn every_feature_survives_random_edits() {
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let mut text = "startshape A\n@import primitives\nrule A {\n  leaf {x 1}\n  30/30 * [ry 360] cube {s 0.1}\n}\nrule leaf 2 { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n".to_string();
    let config = CompletionConfig { std_libraries: vec!["primitives".into()] };
    let started = Instant::now();
    for step in 0..400 {
        edit(&mut rng, &mut text);
        let t0 = Instant::now();
        let (d, _) = doc(&text);
        let len = d.text().len() as u32;
        let _ = d.diagnostics();
        let _ = d.semantic_tokens();
        let _ = d.folding_ranges();
        let _ = d.document_symbols();
        let _ = d.workspace_symbols("a");
        let _ = d.inlay_hints(0, len);
        let _ = d.code_actions(0, len);
        let _ = d.format();
        for _ in 0..8 {
            let at = rng.below(len as usize + 1) as u32;
            let _ = d.hover(at);
            let _ = d.definition(at);
            let _ = d.references(at, true);
            let _ = d.completion(at, &config);
            let _ = d.rename(at, "renamed");
        }
        let took = t0.elapsed();
        // Hang guard (no wall-clock bound under 30 s: loaded machines).
        assert!(took < Duration::from_secs(30), "step {step} took {took:?} on:\n{text}");
    }
    eprintln!("robustness: 400 edits in {:.2?}", started.elapsed());
}

/// Every prefix of a document full of sections (each an unfinished edit: open
/// blocks, half a string, a key without values), and every offset of the whole.
#[test]
fn sections_survive_every_prefix_and_offset() {
    let text = "@define W 2\nsearch {\n  skeleton leaf;\n  wrapup leaf cube;\n}\nguide left {\n  points 0 0 0  0 0 1  0.5 0 2  1.5 0 (W);\n  delta_a 0.6;\n}\nnamespace n {\n  creature m {\n    part p { type torso; rule leaf; mesh \"é/a.obj\"; slot neck { at 0 0 1.4; } }\n    rule grow { zz 1; }\n  }\n}\ngrid g { zz { } ; }\nrule leaf { VERTEX {} }\n";
    let config = CompletionConfig::default();
    let ends: Vec<usize> = text.char_indices().map(|(i, _)| i).chain([text.len()]).collect();
    let mut rng = Rng(7);
    for &end in &ends {
        let (d, _) = doc(&text[..end]);
        let len = d.text().len() as u32;
        let _ = (d.diagnostics(), d.semantic_tokens(), d.folding_ranges(), d.document_symbols(), d.format());
        for at in [len, len.saturating_sub(1), rng.below(len as usize + 1) as u32] {
            let _ = (d.hover(at), d.completion(at, &config), d.definition(at), d.rename(at, "renamed"));
        }
    }
    let (d, _) = doc(text);
    for &at in &ends {
        let at = at as u32;
        let _ = (d.hover(at), d.completion(at, &config), d.references(at, true));
    }
}
