//! Evaluation: the paper's ablation (Fig. 13) — structure diversity per
//! generation with and without increase rules, over several seeds — on
//! std/examples/monsters.mdg. Prints a table (mean ± standard deviation over the
//! seeds) and the ratio without/with.
//!
//! Diversity measure: the hierarchical diversity measure of the paper,
//! HDM = N + Σ_i D_i, over each generation's offspring (every monster generated
//! and standing, before diversity control picks the presented set): N is the
//! number of structure clusters (monsters with equal structure vectors, i.e. the
//! same meta-part counts by type and slot) and D_i ∈ [0, 1] the spread of a
//! geometric descriptor inside cluster i over the largest spread (the light field
//! descriptor of the paper replaced by proportions of the grounded model; see
//! `mdg_vm::creature::evolve::descriptor`). The structure clusters of the
//! presented set are printed too.
//!
//! Run: `cargo run --release -p mdg-vm --example creature_eval [-- SEEDS GENERATIONS]`
//! (default 8 seeds, 6 generations); `-- touch` measures how many presented monsters
//! have a part touching nothing. The grammar is compiled by `mdgc` first
//! (`cargo run --release --bin mdgc -- build …`) unless `MDG_CREATURE_BUNDLE`
//! names a compiled `.mdgb`.

use mdg_vm::creature::evolve::{diversity, Evolution, EvolveOptions};
use mdg_vm::creature::geometry::Library;
use mdg_vm::creature::table::RuleKind;
use std::path::{Path, PathBuf};

fn bundle_path() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("MDG_CREATURE_BUNDLE") {
        return Ok(PathBuf::from(p));
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = root.join("target/monsters.mdgb");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = std::process::Command::new(cargo)
        .current_dir(&root)
        .args(["run", "-q", "--release", "--bin", "mdgc", "--", "build", "std/examples/monsters.mdg", "-o"])
        .arg(&out)
        .status()
        .map_err(|e| format!("cannot run mdgc: {e}"))?;
    if !status.success() {
        return Err("mdgc could not build std/examples/monsters.mdg".into());
    }
    Ok(out)
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// Per generation (1..=G): (offspring HDM, offspring clusters, presented clusters, mean C_s).
fn run(evo: &Evolution) -> Vec<[f64; 4]> {
    let (mut pop, _) = evo.start();
    (1..=evo.opts.generations)
        .map(|g| {
            // The offspring of generation g, before diversity control (the same
            // streams `step` uses, so this is exactly the set it chooses from).
            let offspring: Vec<_> =
                (0..evo.opts.offspring as usize).filter_map(|i| evo.offspring(&pop, g, i).0).collect();
            let d = diversity(evo.table, &offspring);
            let gen = evo.step(&mut pop, None);
            [d.hdm, d.clusters as f64, gen.diversity.clusters as f64, d.mean_complexity]
        })
        .collect()
}

/// `touch`: the share of presented monsters (generations 0–5, population 18,
/// seeds 1, 3, 7, 11, 42) with a part touching nothing of its torso, with the
/// copies of arrangements placed by their plain offsets (as before issue 22) and
/// seated on the torso's surface; evolution rejecting detached layouts or not.
fn touch(bundle: &mdg_vm::bundle::Bundle) -> Result<(), String> {
    let table = bundle.extensions.creatures.as_ref().ok_or("no creature table")?;
    let mut lib = Library::build(bundle, table)?;
    println!("| placement | contact test in evolution | presented monsters | with a detached part | rate | tries rejected as detached |");
    println!("|---|---|---|---|---|---|");
    for (seat, require) in [(false, false), (true, false), (true, true)] {
        lib.seat = seat;
        let (mut n, mut bad, mut rejected) = (0usize, 0usize, 0usize);
        for seed in [1u64, 3, 7, 11, 42] {
            let mut o = EvolveOptions::from_table(table);
            o.seed = seed;
            o.generations = 5;
            o.population = 18;
            o.offspring = 54;
            o.require_contact = require;
            let evo = Evolution::new(table, &lib, o);
            let (mut pop, g0) = evo.start();
            let mut gens = vec![g0];
            for _ in 0..5 {
                gens.push(evo.step(&mut pop, None));
            }
            for g in &gens {
                n += g.presented.len();
                bad += g.presented.iter().filter(|i| !i.layout.detached.is_empty()).count();
                rejected += g.n_detached;
            }
        }
        println!(
            "| {} | {} | {n} | {bad} | {:.1}% | {rejected} |",
            if seat { "seated on the surface" } else { "plain offsets" },
            if require { "on" } else { "off" },
            100.0 * bad as f64 / n.max(1) as f64
        );
    }
    Ok(())
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("touch") {
        let path = bundle_path()?;
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let bundle = mdg_vm::bundle::load(&bytes).map_err(|e| e.to_string())?;
        return touch(&bundle);
    }
    let seeds: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(8);
    let gens: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(6);
    let path = bundle_path()?;
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let bundle = mdg_vm::bundle::load(&bytes).map_err(|e| e.to_string())?;
    let table = bundle.extensions.creatures.as_ref().ok_or("no creature table")?;
    let lib = Library::build(&bundle, table)?;
    let mut results: [Vec<Vec<[f64; 4]>>; 2] = [Vec::new(), Vec::new()];
    for (variant, disabled) in [vec![], vec![RuleKind::Increase]].into_iter().enumerate() {
        for seed in 1..=seeds {
            let mut o = EvolveOptions::from_table(table);
            o.seed = seed;
            o.generations = gens;
            o.disabled = disabled.clone();
            results[variant].push(run(&Evolution::new(table, &lib, o)));
        }
    }
    let e = &table.evolve;
    println!(
        "Ablation of increase rules (paper Fig. 13): std/examples/monsters.mdg, {seeds} seeds, population {}, {} offspring per generation",
        e.population, e.offspring
    );
    println!("HDM = N + Σ D_i over each generation's offspring; N = structure clusters; mean ± sd over seeds\n");
    println!(
        "| generation | HDM, all rules | HDM, no increase | ratio | clusters (offspring) all / no incr. | clusters presented all / no incr. | mean C_s all / no incr. |"
    );
    println!("|---|---|---|---|---|---|---|");
    let col = |v: usize, g: usize, k: usize| -> Vec<f64> { results[v].iter().map(|r| r[g][k]).collect() };
    let mut ratios = Vec::new();
    for g in 0..gens as usize {
        let (a, sa) = mean_sd(&col(0, g, 0));
        let (b, sb) = mean_sd(&col(1, g, 0));
        ratios.push(b / a);
        println!(
            "| {} | {a:.2} ± {sa:.2} | {b:.2} ± {sb:.2} | {:.2} | {:.1} / {:.1} | {:.1} / {:.1} | {:.1} / {:.1} |",
            g + 1,
            b / a,
            mean_sd(&col(0, g, 1)).0,
            mean_sd(&col(1, g, 1)).0,
            mean_sd(&col(0, g, 2)).0,
            mean_sd(&col(1, g, 2)).0,
            mean_sd(&col(0, g, 3)).0,
            mean_sd(&col(1, g, 3)).0,
        );
    }
    println!("\nmean ratio (no increase / all rules) over generations: {:.2}", mean_sd(&ratios).0);
    Ok(())
}
