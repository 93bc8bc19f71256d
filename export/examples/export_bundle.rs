//! Evaluates a compiled bundle (`mdgc build X.mdg -o X.mdgb`) once and writes it in
//! one format: what an exporter costs beside the evaluation, for instruction counts
//! under callgrind (`mdg_vm::eval::evaluate` and `mdg_export::write_file_with`
//! inclusive, divided by the instances).
//!
//! ```sh
//! cargo run --release -p mdg-export --example export_bundle -- tree.mdgb glb out.glb [--instances]
//! ```

use mdg_export::{glb::GlbOptions, write_file_with, Format};
use mdg_vm::eval::{evaluate, EvalOptions};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let instances = args.iter().any(|a| a == "--instances");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let [path, format, out_path] = pos.as_slice() else {
        eprintln!("usage: export_bundle BUNDLE FORMAT OUT [--instances]");
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
    let out = evaluate(&b, &EvalOptions { max_vertices: 50_000_000, ..EvalOptions::default() });
    if let Err(e) = write_file_with(format, &out, &GlbOptions { instances }, std::path::Path::new(out_path)) {
        eprintln!("export_bundle: {e}");
        std::process::exit(1);
    }
    println!("{} vertices, {} rule calls, {} instances", out.stats.vertices, out.stats.rule_calls, out.instances.len());
}
