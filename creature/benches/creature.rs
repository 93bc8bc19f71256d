//! Benchmark: median time to create one offspring with the creature grammar
//! (select base and assist shapes, structure rules, geometry rules, stability
//! test; retries included) on std/examples/monsters.mdg, single-threaded. The
//! issue's target is ≤ 1 ms; the paper's C++ prototype takes about 0.5 s.
//!
//! Run: `cargo bench -p mdg-creature --bench creature`. The VM does not depend on the
//! compiler, so the grammar is compiled by `mdgc` first (see `benches/setup/mod.rs`:
//! `cargo run --release --bin mdgc -- build …` unless `MDG_CREATURE_BUNDLE` names
//! a compiled `.mdgb`). The library's build time is measured with the table's decoding.

use mdg_creature::evolve::{Evolution, EvolveOptions};
use mdg_creature::geometry::assemble;
use mdg_vm::output::Mesh;
use std::time::Instant;

/// The monsters grammar, its table and part library (shared with `examples/creature_eval.rs`).
mod setup;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

fn main() -> Result<(), String> {
    let (_, bundle) = setup::load()?;
    let t0 = Instant::now();
    let (table, lib) = setup::library(&bundle)?;
    let lib_ms = t0.elapsed().as_secs_f64() * 1e3;
    let table = &table;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(|e| e.to_string())?;
    pool.install(|| {
        let mut opts = EvolveOptions::from_table(table);
        opts.seed = 1;
        let evo = Evolution::new(table, &lib, opts);
        let (mut pop, _) = evo.start();
        // Time offspring of generations 1 to 5, each from the population before it.
        let mut per_offspring = Vec::new();
        let mut assemble_ms = Vec::new();
        let mut vertices = Vec::new();
        for g in 1..=5u32 {
            for i in 0..120usize {
                let t = Instant::now();
                let (child, _) = evo.offspring(&pop, g, i);
                per_offspring.push(t.elapsed().as_secs_f64() * 1e3);
                if let Some(c) = child {
                    let t = Instant::now();
                    let mut mesh = Mesh::default();
                    assemble(&lib, &c.layout.placed, glam::Vec3::ZERO, &mut mesh);
                    assemble_ms.push(t.elapsed().as_secs_f64() * 1e3);
                    vertices.push(mesh.n_vertices() as f64);
                }
            }
            evo.step(&mut pop, None);
        }
        let n = per_offspring.len();
        let p90 = {
            let mut v = per_offspring.clone();
            v.sort_by(f64::total_cmp);
            v[(n * 9) / 10]
        };
        println!("creature grammar, std/examples/monsters.mdg, 1 thread, {n} offspring over 5 generations");
        println!("  part library (evaluated once per run):   {lib_ms:9.1} ms");
        println!("  per offspring, median (target <= 1 ms): {:9.4} ms   (p90 {p90:.4} ms)", median(&mut per_offspring));
        println!(
            "  mesh assembly of an offspring, median:   {:9.4} ms   ({:.0} vertices, for export only)",
            median(&mut assemble_ms),
            median(&mut vertices)
        );
    });
    Ok(())
}
