//! Benchmark: `mdgc check` work (lex, parse, expand, check) on a generated
//! 10,000-line grammar. Prints the median of several runs; the target is
//! ≤ 50 ms on the 2-core reference machine. Run: `cargo bench -p mdg-compiler --bench check`.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze_text;
use mdg_compiler::source::MemLoader;
use std::path::Path;
use std::time::Instant;

/// A 10,000-line program: 1,000 rules of 10 lines each, every construct that is cheap
/// to write many times (calls, iterators, continuation, selectors, expressions).
fn grammar() -> String {
    let mut s = String::from("startshape R0\nmaxdepth 40\n");
    for i in 0..1000 {
        let next = (i + 1) % 1000;
        s.push_str(&format!("rule R{i} 0.5 {{\n"));
        s.push_str(&format!("  R{next} {{x 1 ry 30 s 0.9 R 0.01}}\n"));
        s.push_str("  10/10 * {rz 36} VERTEX {z 0.1}\n");
        s.push_str(&format!("  R{next} [y (1 + 2 * 3) rx 45d] \\\n"));
        s.push_str("  LINETO {z 1}\n");
        s.push_str("  3 * {rx 120} { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
        s.push_str("  FACENORMALS {}\n");
        s.push_str(&format!("  R{next} {{fx s 0.5 ry rand(0, 360)}}\n"));
        s.push_str("  // a comment line\n");
        s.push_str("}\n");
    }
    s
}

fn main() {
    let src = grammar();
    let lines = src.lines().count();
    let loader = MemLoader::default();
    let path = Path::new("/bench/big.mdg");
    let mut times = Vec::new();
    for _ in 0..15 {
        let t = Instant::now();
        let a = analyze_text(&loader, path, &src, &Default::default(), CheckOptions::default());
        times.push(t.elapsed().as_secs_f64() * 1000.0);
        assert!(!a.has_errors(), "the generated grammar must check clean");
    }
    times.sort_by(|a, b| a.total_cmp(b));
    let median = times[times.len() / 2];
    println!(
        "check_10k_lines: {lines} lines, median {median:.2} ms over {} runs (min {:.2}, max {:.2}); target ≤ 50 ms",
        times.len(),
        times[0],
        times[times.len() - 1]
    );
}
