//! Latency benchmark (not a test): edit → diagnostics on a generated 2,000-line
//! grammar, through the real `mdg-lsp` binary over stdio. 200 edits, each waiting
//! for the `publishDiagnostics` of its version; prints p50 and p95 (target p95 ≤
//! 20 ms). Then a longer soak: 40,000 unpaced edits in rounds, printing the
//! server's memory after each round (it must level off).
//!
//! Run: `cargo bench -p mdg-lsp --bench latency`.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{scratch, uri, Client};
use std::time::{Duration, Instant};

/// A program of about `lines` lines: chained rules with iterators, a namespace,
/// an isosurface and a selector, using std.
fn grammar(lines: usize) -> String {
    let n_rules = lines / 6;
    let mut s = String::from("startshape r0\nmaxdepth 12\n@import primitives\nselector r1 random\n");
    s.push_str("isosurface BLOB { xyz -1 1 8 ; function { x*x + y*y + z*z - 1 } }\n");
    for i in 0..n_rules {
        let next = (i + 1) % n_rules;
        s.push_str(&format!(
            "rule r{i} {{\n  VERTEX {{x 1}} VERTEX {{y 1}} VERTEX {{z 1 R -0.1}}\n  r{next} {{x 1 rz 10 s 0.9}}\n  30/30 * [ry 360] cube {{s 0.1}}\n}}\n\n"
        ));
    }
    s.push_str("rule r1 0.5 { BLOB {} }\n");
    s
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

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

    // Soak: unpaced edits in rounds; after each round the final version's
    // diagnostics, and the server's memory, which must level off.
    let t0 = Instant::now();
    let mut rss = vec![c.rss_kib().unwrap_or(0)];
    let rounds = 8;
    let per_round = 5_000;
    for _ in 0..rounds {
        for i in 0..per_round {
            version += 1;
            let text = if i % 2 == 0 { &broken } else { &base };
            c.change(&u, version, text);
            if i % 1000 == 0 {
                c.clear();
            }
        }
        c.diagnostics(&u, version);
        rss.push(c.rss_kib().unwrap_or(0));
    }
    let rss_text: Vec<String> = rss.iter().map(|k| format!("{}", k / 1024)).collect();
    println!(
        "soak: {} unpaced edits in {:.2} s; server RSS (MiB) at start and after each {per_round}: {}",
        rounds * per_round,
        t0.elapsed().as_secs_f64(),
        rss_text.join(" → ")
    );
    assert!(c.shutdown_and_exit().success());
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}
