//! Evaluates a compiled bundle (`mdgc build X.mdg -o X.mdgb`) once and prints its
//! counts: the evaluator alone, without compiling or exporting, for instruction
//! counts under callgrind (`benches/run` compares grammars with and without rule
//! parameters this way).
//!
//! ```sh
//! cargo run --release -p mdg-vm --example eval_bundle -- tree.mdgb [MAX_VERTICES]
//! ```

use mdg_vm::eval::{evaluate, EvalOptions};

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: eval_bundle BUNDLE [MAX_VERTICES]");
        std::process::exit(2);
    };
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("eval_bundle: {path}: {e}");
            std::process::exit(1);
        }
    };
    let b = match mdg_vm::bundle::load(&bytes) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("eval_bundle: {path}: {e}");
            std::process::exit(1);
        }
    };
    let max_vertices = args.next().and_then(|s| s.parse().ok()).unwrap_or(50_000_000);
    let out = evaluate(&b, &EvalOptions { max_vertices, ..EvalOptions::default() });
    // Peak resident memory of the process so far (the bundle and the evaluation).
    let peak = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM:")).map(str::to_string))
        .and_then(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()))
        .map(|kib| format!(", peak RSS {:.1} MiB", kib / 1024.0))
        .unwrap_or_default();
    println!(
        "{} vertices, {} rule calls, {} instances{peak}",
        out.stats.vertices,
        out.stats.rule_calls,
        out.instances.len()
    );
}
