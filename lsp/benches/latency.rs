//! Latency benchmark (not a test): edit → diagnostics on a generated 2,000-line
//! grammar, through the real `mdg-lsp` binary over stdio. 200 edits, each waiting
//! for the `publishDiagnostics` of its version; prints p50 and p95 (target p95 ≤
//! 20 ms). Then the soak: 100,000 random edits with feature requests in between
//! (`tests/common/soak.rs`), printing the server's memory every 10,000 edits (it
//! must stay flat). Between them, the latencies the hostile tests
//! (`tests/hostile.rs`) check only by the order of messages: requests on a document
//! whose shader glslang compiles for seconds (target ≤ 2 s, where waiting for the
//! compile would take its 5 s deadline), and an edit that makes the compile give up
//! (its diagnostics, target ≤ 3 s).
//!
//! Run: `cargo bench -p mdg-lsp --bench latency`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{benchmark_grammar as grammar, percentile, scratch, uri, Client};
use std::time::{Duration, Instant};

fn main() {
    let dir = scratch("bench");
    let u = uri(&dir.join("big.mdg"));
    let base = grammar(2000);
    let n_lines = base.lines().count();
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, &base);
    let first = c.diagnostics(&u, 1);
    assert!(first.is_empty(), "the generated grammar should be clean: {first:?}");

    // Alternate between misspelling an adjustment in the middle of the file (one
    // E0303) and fixing it.
    let target = "  r170 {x 1 rz 10 s 0.9}";
    assert!(base.contains(target));
    let broken = base.replacen(target, "  r170 {x 1 rzz 10 s 0.9}", 1);
    let mut times = Vec::with_capacity(200);
    let mut version = 1;
    for i in 0..200 {
        version += 1;
        let text = if i % 2 == 0 { &broken } else { &base };
        let t0 = Instant::now();
        c.change(&u, version, text);
        let diags = c.diagnostics(&u, version);
        times.push(t0.elapsed());
        assert_eq!(diags.len(), usize::from(i % 2 == 0), "edit {i}");
    }
    times.sort();
    let (p50, p95, max) = (percentile(&times, 0.5), percentile(&times, 0.95), times[times.len() - 1]);
    println!("edit → diagnostics, {n_lines}-line grammar, 200 edits: p50 {:.2} ms, p95 {:.2} ms, max {:.2} ms (target p95 ≤ 20 ms)", ms(p50), ms(p95), ms(max));

    assert!(c.shutdown_and_exit().success());

    slow_shader(&dir);

    // Soak: 100,000 random edits (the soak test's, ten times longer) with feature
    // requests in between, against a fresh server; its memory every 10,000 edits
    // must stay flat.
    let soak = common::soak::run(100_000, 10_000);
    let mib: Vec<String> = soak.rss.iter().map(|(_, k)| format!("{:.1}", *k as f64 / 1024.0)).collect();
    let (early, peak) = soak.early_and_peak().unwrap_or((0, 0));
    let last = soak.rss.last().map(|s| s.1).unwrap_or(0);
    println!(
        "soak: {} random edits in {:.1} s ({:.0} edits/s); server RSS (MiB) every 10,000 edits: {}; growth after the first sample: {:+.1} MiB peak, {:+.1} MiB at the end",
        soak.edits,
        soak.elapsed.as_secs_f64(),
        soak.edits as f64 / soak.elapsed.as_secs_f64(),
        mib.join(" → "),
        (peak as f64 - early as f64) / 1024.0,
        (last as f64 - early as f64) / 1024.0
    );
    assert!(peak < early + early / 2 + 32 * 1024, "memory is not flat: {:?}", soak.rss);
}

/// 2^23 statements made by 24 doubling `#define`s: with the shader limits off (a test
/// hook), glslang runs into its 5 s deadline on them.
fn slow_statements() -> String {
    let mut statements = String::from("#define S0 x = x * 0.5 + sin(x) * cos(x) - 1.0;\n");
    for i in 1..24 {
        statements.push_str(&format!("#define S{i} S{} S{}\n", i - 1, i - 1));
    }
    statements.push_str("void main() { float x = 1.0; S23 gl_Position = vec4(x); }");
    // As the hostile tests write it (tests/hostile.rs: `with_shader`).
    format!(
        "startshape A\n@vertexshader vs\n#version 450\n{statements}\n@endshader\n\
         rule A {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}} }}\n"
    )
}

/// While a document's shader compiles: four requests on it (symbols, folding, tokens,
/// hover), then an edit to a plain grammar and its diagnostics.
fn slow_shader(dir: &std::path::Path) {
    let u = uri(&dir.join("slow.mdg"));
    let mut c = Client::spawn_with(&[("MDG_TEST_NO_SHADER_LIMITS", "1")]);
    c.initialize(dir);
    c.open(&u, 1, &slow_statements());
    std::thread::sleep(Duration::from_millis(300));
    let asked = Instant::now();
    for method in ["textDocument/documentSymbol", "textDocument/foldingRange", "textDocument/semanticTokens/full"] {
        c.call(method, serde_json::json!({"textDocument": {"uri": u}}));
    }
    c.call(
        "textDocument/hover",
        serde_json::json!({"textDocument": {"uri": u}, "position": {"line": 0, "character": 13}}),
    );
    let answered = asked.elapsed();
    let edited = Instant::now();
    c.change(&u, 2, "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    let d = c.diagnostics(&u, 2);
    let took = edited.elapsed();
    assert!(d.is_empty(), "{d:?}");
    println!(
        "while a shader compiles (5 s deadline): 4 requests answered in {:.1} ms (target ≤ 2 s), an edit's diagnostics in {:.1} ms (target ≤ 3 s)",
        ms(answered),
        ms(took)
    );
    assert!(c.shutdown_and_exit().success());
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}
