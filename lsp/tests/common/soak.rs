//! The random-edit soak shared by the soak test (10,000 edits) and the soak
//! benchmark (100,000): insertions of grammar fragments (brackets, preprocessor
//! lines, unterminated comments, non-ASCII text) and deletions, sent as `didChange`
//! as fast as the pipe takes them, with feature requests at random positions in
//! between. The server must not crash or panic, must answer every request, must
//! publish diagnostics for the final version, and its memory must stay flat.
#![allow(dead_code)]

use super::{scratch, uri, Client};
use mdg_vm::rng::Rng;
use serde_json::{json, Value};
use std::time::{Duration, Instant};

const FRAGMENTS: &[&str] = &[
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
];

const START: &str = "startshape A\n@import primitives\nrule A {\n  leaf {x 1}\n  30/30 * [ry 360] cube {s 0.1}\n}\nrule leaf 2 { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\nrule leaf { leaf {s 0.5} }\n";

/// One random edit: an insertion of a fragment or a deletion, the document kept
/// under 3,000 bytes.
fn edit(rng: &mut Rng, text: &mut String) {
    let mut t = std::mem::take(text);
    if rng.below(3) == 0 && !t.is_empty() {
        let a = boundary(rng, &t);
        let len = 1 + rng.below(24);
        let b = t[a..].char_indices().nth(len).map(|(j, _)| a + j).unwrap_or(t.len());
        t.replace_range(a..b, "");
    } else {
        let at = boundary(rng, &t);
        t.insert_str(at, FRAGMENTS[rng.below(FRAGMENTS.len())]);
    }
    while t.len() > 3000 {
        let cut = t.char_indices().nth(t.chars().count() / 2).map(|(j, _)| j).unwrap_or(0);
        t.replace_range(cut..t.len(), "");
    }
    *text = t;
}

/// A random char boundary of `text`.
fn boundary(rng: &mut Rng, text: &str) -> usize {
    let n = text.chars().count();
    let k = rng.below(n + 1);
    text.char_indices().nth(k).map(|(i, _)| i).unwrap_or(text.len())
}

/// A random (UTF-16) position in `text`.
fn position(rng: &mut Rng, text: &str) -> Value {
    let at = boundary(rng, text);
    let before = &text[..at];
    json!({"line": before.matches('\n').count(), "character": before.rsplit('\n').next().unwrap_or("").encode_utf16().count()})
}

/// What a soak measured.
pub struct Soak {
    pub edits: usize,
    pub elapsed: Duration,
    /// (edits done, server resident memory in KiB) every `sample_every` edits, each
    /// taken after a round trip, so the server has caught up.
    pub rss: Vec<(usize, u64)>,
}

impl Soak {
    /// Memory at the first sample and the largest after it, in KiB.
    pub fn early_and_peak(&self) -> Option<(u64, u64)> {
        let early = self.rss.first()?.1;
        let peak = self.rss.iter().skip(1).map(|s| s.1).max().unwrap_or(early);
        Some((early, peak))
    }

    /// Whether the server's memory levelled off: the largest sample of the second half
    /// is within an eighth plus 16 MiB of the largest of the first half. Warm-up growth
    /// (caches, and the allocator's per-thread arenas, of which a loaded machine makes
    /// more: 34 MiB after 1,000 edits and 98 after 5,000 was seen under a load average
    /// of 13 on 2 cores, flat after) falls in the first half; a leak per edit grows on
    /// through the second. Err says what grew.
    pub fn levelled_off(&self) -> Result<(), String> {
        let half = self.rss.len() / 2;
        let peak = |s: &[(usize, u64)]| s.iter().map(|s| s.1).max().unwrap_or(0);
        let (first, second) = (peak(&self.rss[..half]), peak(&self.rss[half..]));
        if half == 0 || second <= first + first / 8 + 16 * 1024 {
            Ok(())
        } else {
            Err(format!("memory grew from {first} KiB (first half) to {second} KiB (second half): {:?}", self.rss))
        }
    }
}

/// Runs `edits` random edits against a fresh server and checks that it survived.
pub fn run(edits: usize, sample_every: usize) -> Soak {
    let started = Instant::now();
    let dir = scratch(&format!("soak{edits}"));
    let u = uri(&dir.join("soak.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    let mut text = START.to_string();
    let mut version = 1i64;
    c.open(&u, version, &text);
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let mut pending_requests: Vec<i64> = Vec::new();
    let mut rss = Vec::new();
    for i in 0..edits {
        edit(&mut rng, &mut text);
        version += 1;
        c.change(&u, version, &text);
        if i % 97 == 0 {
            let p = json!({"textDocument": {"uri": u}, "position": position(&mut rng, &text)});
            let td = json!({"textDocument": {"uri": u}});
            let whole = json!({"start": {"line": 0, "character": 0}, "end": {"line": 10_000, "character": 0}});
            pending_requests.push(match rng.below(11) {
                0 => c.request_async("textDocument/hover", p),
                1 => c.request_async("textDocument/completion", p),
                2 => c.request_async("textDocument/definition", p),
                3 => c.request_async("textDocument/references", json!({"textDocument": {"uri": u}, "position": p["position"], "context": {"includeDeclaration": true}})),
                4 => c.request_async("textDocument/semanticTokens/full", td),
                5 => c.request_async("textDocument/foldingRange", td),
                6 => c.request_async("textDocument/documentSymbol", td),
                7 => c.request_async("textDocument/codeAction", json!({"textDocument": {"uri": u}, "range": whole, "context": {"diagnostics": []}})),
                8 => c.request_async("textDocument/inlayHint", json!({"textDocument": {"uri": u}, "range": whole})),
                9 => c.request_async("textDocument/formatting", json!({"textDocument": {"uri": u}, "options": {"tabSize": 2, "insertSpaces": true}})),
                _ => c.request_async("textDocument/rename", json!({"textDocument": {"uri": u}, "position": p["position"], "newName": "renamed"})),
            });
        }
        if (i + 1) % sample_every == 0 {
            // A round trip, so the server has handled everything sent so far.
            let id = c.request_async("workspace/symbol", json!({"query": ""}));
            c.response(id);
            for id in pending_requests.drain(..) {
                let r = c.response(id);
                if let Some(e) = r.get("error") {
                    // Rename may refuse (invalid params); anything else is a failure.
                    assert_eq!(e["code"], -32602, "request {id} failed: {r}");
                }
            }
            // (Not after the last edit: the final version's diagnostics may already
            // have arrived with the responses, and they are waited for below.)
            if i + 1 < edits {
                c.clear();
            }
            if let Some(k) = c.rss_kib() {
                rss.push((i + 1, k));
            }
        }
    }
    for id in pending_requests {
        let r = c.response(id);
        if let Some(e) = r.get("error") {
            assert_eq!(e["code"], -32602, "request {id} failed: {r}");
        }
    }
    // The final version is analysed and published, and the server still answers.
    c.diagnostics(&u, version);
    let h =
        c.request("textDocument/hover", json!({"textDocument": {"uri": u}, "position": {"line": 0, "character": 1}}));
    assert!(h.get("error").is_none(), "{h}");
    c.clear();
    assert!(!c.logs.iter().any(|l| l.contains("panic")), "panics: {:?}", c.logs);
    assert!(c.shutdown_and_exit().success());
    Soak { edits, elapsed: started.elapsed(), rss }
}
