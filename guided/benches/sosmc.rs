//! Guided-search benchmark: the Calder-sized workload (std tree grammar, its three
//! guides, particles 100 → 15 over 100 generations ≈ 5,750 particle-steps), median
//! wall time over many seeds; the final cost there versus a 200 ms budget spent on
//! 20× the particles; and the one-time preparation (EXPECTED estimate, curves).
//!
//! ```sh
//! cargo bench -p mdg-guided --bench sosmc            # RAYON_NUM_THREADS=1 for one thread
//! ```
//!
//! The grammar is `std/examples/guided_tree.mdg` compiled by `mdgc build` (the VM does
//! not depend on the compiler; see `benches/setup/mod.rs`): `$MDG_SOSMC_BUNDLE` if set
//! (relative to the workspace root), else built into `target/sosmc/guided_tree.mdgb`
//! with `cargo run -p mdg-cli --bin mdgc`.

use mdg_guided::{GuidedTable, Prepared, SearchOptions};
use mdg_vm::bundle::Section as _;
use std::time::{Duration, Instant};

/// The compiled std tree grammar (shared with `examples/sosmc_eval.rs`).
mod setup;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        f64::NAN
    } else if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

fn main() {
    // `cargo bench` passes `--bench`; nothing to parse.
    let b = match setup::bundle() {
        Ok(b) => b,
        Err(e) => {
            eprintln!("sosmc bench: {e}");
            std::process::exit(1);
        }
    };
    let Ok(Some(table)) = GuidedTable::from_bundle(&b) else {
        eprintln!("sosmc bench: the grammar has no valid search section");
        std::process::exit(1);
    };
    let threads = rayon::current_num_threads();
    let mut prep = Vec::new();
    let mut prepared = None;
    for _ in 0..5 {
        let t = Instant::now();
        match Prepared::new(&b, &table, &table.guides) {
            Ok(p) => prepared = Some(p),
            Err(e) => {
                eprintln!("sosmc bench: {e}");
                std::process::exit(1);
            }
        }
        prep.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let Some(p) = prepared else { return };
    let calder = SearchOptions { budget: None, ..SearchOptions::from_settings(&table.settings, 0) };
    // Warm-up (fills the curves' cell caches, as any earlier search in a session would).
    for seed in 0..3 {
        p.search(&SearchOptions { seed: 1000 + seed, ..calder.clone() }, None);
    }
    let runs = 41u64;
    let (mut ms, mut cost, mut steps) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 1..=runs {
        let t = Instant::now();
        let r = p.search(&SearchOptions { seed, ..calder.clone() }, None);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        cost.push(r.model.cost.total());
        steps.push(r.particle_steps as f64);
    }
    let (med_ms, med_cost, med_steps) = (median(&mut ms), median(&mut cost), median(&mut steps));
    println!(
        "Calder-sized search ({} particle-steps scheduled, median {med_steps:.0} taken; 3 curves; {threads} thread(s)): \
         median {med_ms:.2} ms over {runs} seeds (min {:.2}, max {:.2}); target ≤ 5 ms, Calder ~200 ms",
        calder.scheduled_steps(),
        ms[0],
        ms[ms.len() - 1]
    );
    // The same 41 searches again: the closest-point cells the first pass filled (built
    // lazily, once per grammar and guides) are now all there, as in an editor session
    // that searches again and again.
    let mut warm = Vec::new();
    for seed in 1..=runs {
        let t = Instant::now();
        p.search(&SearchOptions { seed, ..calder.clone() }, None);
        warm.push(t.elapsed().as_secs_f64() * 1e3);
    }
    println!(
        "  the same 41 searches again, every closest-point cell they visit already built: median {:.2} ms",
        median(&mut warm)
    );
    // The same search given 200 ms: 20× the particles, stopped by the budget.
    let big = SearchOptions {
        particles: (calder.particles.0 * 20, calder.particles.1 * 20),
        budget: Some(Duration::from_millis(200)),
        ..calder.clone()
    };
    let (mut bcost, mut bsteps, mut bms) = (Vec::new(), Vec::new(), Vec::new());
    for seed in 1..=11u64 {
        let t = Instant::now();
        let r = p.search(&SearchOptions { seed, ..big.clone() }, None);
        bms.push(t.elapsed().as_secs_f64() * 1e3);
        bcost.push(r.model.cost.total());
        bsteps.push(r.particle_steps as f64);
    }
    println!(
        "final cost (median): {med_cost:.3} at ~5,750 particle-steps; {:.3} with a 200 ms budget \
         ({:.0} particle-steps, particles ×20, median {:.0} ms, 11 seeds)",
        median(&mut bcost),
        median(&mut bsteps),
        median(&mut bms)
    );
    println!(
        "preparation (once per grammar and guides: EXPECTED by forward sampling, curve trees): median {:.2} ms",
        median(&mut prep)
    );
}
