//! Evaluates a compiled bundle (`mdgc build X.mdg -o X.mdgb`) once and writes it in
//! one format: what an exporter costs beside the evaluation, for instruction counts
//! under callgrind (`mdg_vm::eval::evaluate` and `mdg_export::write_file_with`
//! inclusive, divided by the instances).
//!
//! ```sh
//! cargo run --release -p mdg-export --example export_bundle -- tree.mdgb glb out.glb [--instances] [--max-vertices=N] [--max-iter=N]
//! ```
//!
//! With `--instances` the run keeps prototype instances as instances (each costs the
//! vertex budget one, as `mdg-run --instances`); `--max-vertices=N` raises the budget
//! (50,000,000 by default) and `--max-iter=N` the rule calls (the grammar's `maxiter`
//! and its cap): the largest-tree runs of issue 38 need all three.

use mdg_export::{glb::GlbOptions, write_file_with, Format};
use mdg_vm::eval::{evaluate, EvalOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let instances = args.iter().any(|a| a == "--instances");
    let count = |flag: &str| {
        args.iter().find_map(|a| a.strip_prefix(flag)).map(|n| {
            n.parse::<u64>().unwrap_or_else(|_| {
                eprintln!("export_bundle: {flag}{n}: not a count");
                std::process::exit(2);
            })
        })
    };
    let max_vertices = count("--max-vertices=").unwrap_or(50_000_000);
    let max_iter = count("--max-iter=");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let [path, format, out_path] = pos.as_slice() else {
        eprintln!("usage: export_bundle BUNDLE FORMAT OUT [--instances] [--max-vertices=N] [--max-iter=N]");
        std::process::exit(2);
    };
    let Some(format) = Format::from_extension(format) else {
        eprintln!("export_bundle: no format {format}");
        std::process::exit(2);
    };
    let bytes = std::fs::read(path).unwrap_or_else(|e| {
        eprintln!("export_bundle: {path}: {e}");
        std::process::exit(1);
    });
    let b = mdg_vm::bundle::load(&bytes).unwrap_or_else(|e| {
        eprintln!("export_bundle: {path}: {e}");
        std::process::exit(1);
    });
    let mut opts = EvalOptions { max_vertices, instances_stored: instances, ..EvalOptions::default() };
    if let Some(n) = max_iter {
        (opts.maxiter, opts.max_iter) = (Some(n), n);
    }
    let out = evaluate(&b, &opts);
    for w in &out.stats.warnings {
        eprintln!("warning: {w}");
    }
    if let Err(e) = write_file_with(format, &out, &GlbOptions { instances }, std::path::Path::new(out_path)) {
        eprintln!("export_bundle: {e}");
        std::process::exit(1);
    }
    println!("{} vertices, {} rule calls, {} instances", out.stats.vertices, out.stats.rule_calls, out.instances.len());
}
