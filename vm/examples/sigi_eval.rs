//! SIGI evaluation: the paper's Tables 1–4 (#S, %M, Size, C) over parameter sweeps, and
//! inference time per building, on the SIGI example buildings and the GDMC structures.
//!
//! ```sh
//! cargo run --release -p mdg-vm --example sigi_eval -- /work/shared/data
//! ```
//!
//! The data directory holds `sigi-examples/building*.txt` and `gdmc2023/*.nbt`. It is
//! never part of the repository or the test suite; the script says so when it is
//! missing. Each table aggregates every run of the full grid (3 shape specifications ×
//! 9 α values × 3 operations × overlap or not) whose parameter is the row's value,
//! over the buildings of one data set: the average and the median of the runs. Tables
//! come for both cost functions: the paper's product and the reference implementation's
//! sum (see `mdg_vm::grid::infer::Cost`). `--timing-only` stops after the timings.

use mdg_vm::grid::format;
use mdg_vm::grid::generate::{enclosure, generate, Bounds, GenerateOptions, Instance};
use mdg_vm::grid::induce::{induce, measures, Example, Measures};
use mdg_vm::grid::infer::{infer, Cost, InferOptions, Ops, Spec};
use mdg_vm::grid::voxel::VoxelModel;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

const ALPHAS: [f64; 9] = [0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 5.0, 100.0];
const SPECS: [Spec; 3] = [Spec::Rect, Spec::Planar, Spec::Solid];
const OPS: [Ops; 3] = [Ops::Merge, Ops::Split, Ops::Both];

struct Building {
    name: String,
    model: VoxelModel,
}

struct Run {
    building: usize,
    opts: InferOptions,
    m: Measures,
}

fn load(dir: &Path, ext: &str, prefix: &str) -> Result<Vec<Building>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("cannot list {}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with(prefix)))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let model = format::read(&p)?;
            let name = p.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            Ok(Building { name, model })
        })
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

fn row(label: &str, runs: &[&Run]) -> String {
    let col = |f: &dyn Fn(&Measures) -> f64| -> (f64, f64) {
        let v: Vec<f64> = runs.iter().map(|r| f(&r.m)).collect();
        (v.iter().sum::<f64>() / v.len().max(1) as f64, median(v))
    };
    let s = col(&|m| m.shapes as f64);
    let p = col(&|m| m.matching);
    let z = col(&|m| m.size);
    let c = col(&|m| m.complexity);
    format!(
        "| {label} | {:.2} | {:.1}% | {:.2} | {:.3} | {:.1} | {:.1}% | {:.2} | {:.3} | {} |",
        s.0,
        p.0,
        z.0,
        c.0,
        s.1,
        p.1,
        z.1,
        c.1,
        runs.len()
    )
}

const HEADER: &str = "| | #S | %M | Size | C | #S | %M | Size | C | runs |\n|---|---|---|---|---|---|---|---|---|---|";

fn tables(title: &str, cost: Cost, buildings: &[Building], runs: &[Run]) {
    println!("\n## {title}, {} cost ({} buildings; columns: average, then median)\n", cost.name(), buildings.len());
    println!("### Table 1: overlap (merge operation)\n\n{HEADER}");
    let merge: Vec<&Run> = runs.iter().filter(|r| r.opts.ops == Ops::Merge).collect();
    for (who, pick) in [("All", None), ("E1", Some(0)), ("E5", Some(4))] {
        if pick.is_some_and(|i| i >= buildings.len()) {
            continue;
        }
        for ov in [false, true] {
            let sel: Vec<&Run> = merge
                .iter()
                .copied()
                .filter(|r| r.opts.overlap == ov && pick.is_none_or(|i| r.building == i))
                .collect();
            let label = format!(
                "{} overlap {}",
                pick.map(|i| buildings[i].name.as_str()).unwrap_or(who),
                if ov { "yes" } else { "no" }
            );
            println!("{}", row(&label, &sel));
        }
    }
    println!("\n### Table 2: α\n\n{HEADER}");
    for a in ALPHAS {
        let sel: Vec<&Run> = runs.iter().filter(|r| r.opts.alpha == a).collect();
        println!("{}", row(&format!("α = {a}"), &sel));
    }
    println!("\n### Table 3: operations\n\n{HEADER}");
    for o in OPS {
        let sel: Vec<&Run> = runs.iter().filter(|r| r.opts.ops == o).collect();
        println!("{}", row(o.name(), &sel));
    }
    println!("\n### Table 4: shape specification\n\n{HEADER}");
    for s in SPECS {
        let sel: Vec<&Run> = runs.iter().filter(|r| r.opts.spec == s).collect();
        println!("{}", row(s.name(), &sel));
    }
}

fn sweep(buildings: &[Building], cost: Cost) -> Vec<Run> {
    let mut jobs = Vec::new();
    for b in 0..buildings.len() {
        for spec in SPECS {
            for alpha in ALPHAS {
                for ops in OPS {
                    for overlap in [false, true] {
                        jobs.push((b, InferOptions { spec, alpha, ops, overlap, cost, post_split: false }));
                    }
                }
            }
        }
    }
    jobs.into_par_iter()
        .map(|(b, opts)| {
            let model = &buildings[b].model;
            let inf = infer(model, &opts, &mut |_| {});
            Run { building: b, opts, m: measures(model, &inf) }
        })
        .collect()
}

fn timing(buildings: &[Building], cost: Cost) {
    let opts = InferOptions { spec: Spec::Rect, alpha: 1.0, ops: Ops::Both, overlap: false, cost, post_split: false };
    println!(
        "\n## Inference time ({} cost, rect, α = 1, both operations, no overlap; one thread, best of 5)\n",
        cost.name()
    );
    println!("| building | blocks | kinds | #S | %M | moves (merge/split) | time |\n|---|---|---|---|---|---|---|");
    let mut total = 0.0;
    for b in buildings {
        let mut best = f64::INFINITY;
        let mut last = None;
        for _ in 0..5 {
            let t = Instant::now();
            let inf = infer(&b.model, &opts, &mut |_| {});
            best = best.min(t.elapsed().as_secs_f64());
            last = Some(inf);
        }
        let Some(inf) = last else { continue };
        let m = measures(&b.model, &inf);
        total += best;
        println!(
            "| {} | {} | {} | {} | {:.1}% | {}/{} | {:.1} ms |",
            b.name,
            b.model.blocks.len(),
            b.model.kinds_used(),
            m.shapes,
            m.matching,
            inf.stats.merges,
            inf.stats.splits,
            best * 1e3
        );
    }
    println!("| **total** | | | | | | **{:.1} ms** |", total * 1e3);
}

/// Generation from each building's grammar (rect, α = 1, both, sum cost): the
/// enclosure constraint on the example itself (the shapes at their places) for three
/// `seal` radii, and 20 derivations of 50 steps with enclosure (seal 1).
fn generation(buildings: &[Building]) {
    println!("\n## Enclosure and generation (rect, α = 1, both operations, sum cost)\n");
    println!(
        "| building | shapes | rules | example kept, seal 0 | seal 1 | seal 2 | non-empty of 20 | mean blocks | mean time |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let opts = InferOptions {
        spec: Spec::Rect,
        alpha: 1.0,
        ops: Ops::Both,
        overlap: false,
        cost: Cost::Sum,
        post_split: false,
    };
    for b in buildings {
        let inf = infer(&b.model, &opts, &mut |_| {});
        let g = match induce(&[Example { name: b.name.clone(), model: &b.model }], &[inf], &b.name) {
            Ok(g) => g,
            Err(e) => {
                println!("| {} | induction failed: {e} |", b.name);
                continue;
            }
        };
        let placed: Vec<Instance> = g
            .shapes
            .iter()
            .enumerate()
            .map(|(i, s)| Instance {
                shape: i as u32,
                place: mdg_vm::grid::Placement::translation(s.at.unwrap_or([0; 3])),
            })
            .collect();
        let kept: Vec<String> = [0, 1, 2]
            .iter()
            .map(|&seal| match enclosure(&g, &placed, seal) {
                Ok((_, m, _)) => format!("{:.0}%", 100.0 * m.blocks.len() as f64 / b.model.blocks.len() as f64),
                Err(e) => e,
            })
            .collect();
        let (mut non_empty, mut blocks, mut secs) = (0, 0usize, 0.0);
        for seed in 1..=20 {
            let t = Instant::now();
            if let Ok(made) = generate(
                &g,
                &GenerateOptions { steps: 50, enclosure: true, seal: 1, seed, ..GenerateOptions::default() },
            ) {
                secs += t.elapsed().as_secs_f64();
                non_empty += (!made.model.blocks.is_empty()) as usize;
                blocks += made.model.blocks.len();
            }
        }
        println!(
            "| {} | {} | {} | {} | {} | {} | {non_empty} | {:.0} | {:.2} ms |",
            b.name,
            g.shapes.len(),
            g.rules.len(),
            kept[0],
            kept[1],
            kept[2],
            blocks as f64 / 20.0,
            secs * 1e3 / 20.0
        );
    }
}

/// The number of 6-connected pieces of a model.
fn pieces(m: &VoxelModel) -> usize {
    let cells: std::collections::HashSet<[i32; 3]> = m.blocks.iter().map(|b| b.pos).collect();
    let mut seen = std::collections::HashSet::new();
    let mut n = 0;
    for &c in &cells {
        if !seen.insert(c) {
            continue;
        }
        n += 1;
        let mut stack = vec![c];
        while let Some(p) = stack.pop() {
            for d in mdg_vm::grid::voxel::NEIGHBOURS {
                let q = mdg_vm::grid::add(p, d);
                if cells.contains(&q) && seen.insert(q) {
                    stack.push(q);
                }
            }
        }
    }
    n
}

/// One row of the derivation table: 10 derivations (seeds 1–10) from each building's
/// grammar.
fn derivation_row(buildings: &[Building], opts: &InferOptions, gen: &GenerateOptions, what: &str) {
    let made: Vec<(usize, usize, u32)> = buildings
        .par_iter()
        .flat_map(|b| {
            let inf = infer(&b.model, opts, &mut |_| {});
            let g = induce(&[Example { name: b.name.clone(), model: &b.model }], &[inf], &b.name).ok();
            (1..=10u64)
                .map(|seed| {
                    let m =
                        g.as_ref().and_then(|g| generate(g, &GenerateOptions { seed, ..*gen }).ok()).map(|m| m.model);
                    let ext = m
                        .as_ref()
                        .and_then(|m| m.bounds())
                        .map(|(lo, hi)| (0..3).map(|a| (hi[a] - lo[a] + 1) as u32).max().unwrap_or(0))
                        .unwrap_or(0);
                    m.map(|m| (m.blocks.len(), pieces(&m), ext)).unwrap_or((0, 0, 0))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    println!(
        "| {} | {} | {} | {} | {} | {} | {what} | {} | {} | {} | {} | {} | {} |",
        opts.cost.name(),
        opts.spec.name(),
        opts.alpha,
        opts.ops.name(),
        if opts.overlap { "yes" } else { "no" },
        if opts.post_split { "yes" } else { "no" },
        made.len(),
        made.iter().filter(|m| m.0 < 50).count(),
        made.iter().filter(|m| m.0 == 0).count(),
        median(made.iter().map(|m| m.0 as f64).collect()),
        made.iter().filter(|m| m.1 > 1).count(),
        made.iter().map(|m| m.2).max().unwrap_or(0)
    );
}

/// The derivation counts of the issue: per configuration, 10 derivations (seeds 1–10,
/// 50 steps, enclosure with seal 1) from each building's grammar; how many give fewer
/// than 50 blocks, how many none, how many have floating pieces, the largest extent.
fn derivations(buildings: &[Building]) {
    println!("\n## Derivations: {} buildings × 10 seeds, 50 steps, enclosure (seal 1)\n", buildings.len());
    println!(
        "| cost | spec | α | ops | overlap | post-split | generation | derivations | < 50 blocks | empty | median blocks | \
         with floating pieces | largest extent |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let base = InferOptions::default();
    let plain = GenerateOptions { bounds: Bounds::None, keep_largest: false, ..GenerateOptions::default() };
    let mut configs = vec![
        InferOptions { cost: Cost::Product, ops: Ops::Merge, ..base },
        InferOptions { cost: Cost::Product, ..base },
        InferOptions { cost: Cost::Sum, ops: Ops::Merge, ..base },
        base,
        InferOptions { post_split: true, ..base },
        InferOptions { ops: Ops::Merge, post_split: true, ..base },
        InferOptions { cost: Cost::Kinds, ..base },
        InferOptions { cost: Cost::Kinds, ops: Ops::Merge, ..base },
    ];
    for a in [0.25, 0.5, 2.0] {
        configs.push(InferOptions { alpha: a, ..base });
        configs.push(InferOptions { alpha: a, cost: Cost::Product, ..base });
    }
    configs.push(InferOptions { overlap: true, ..base });
    configs.push(InferOptions { overlap: true, ops: Ops::Merge, ..base });
    configs.push(InferOptions { spec: Spec::Planar, ops: Ops::Merge, ..base });
    configs.push(InferOptions { spec: Spec::Planar, ..base });
    for opts in configs {
        derivation_row(buildings, &opts, &plain, "plain");
    }
    // Generation options, on the default inference.
    let default = GenerateOptions::default();
    for (gen, what) in [
        (plain, "plain"),
        (GenerateOptions { keep_largest: false, ..default }, "bounds 2×"),
        (GenerateOptions { bounds: Bounds::None, ..default }, "largest piece"),
        (default, "bounds 2× + largest piece (default)"),
        (GenerateOptions { bounds: Bounds::Box([25; 3]), ..default }, "bounds 25³ + largest piece"),
        (GenerateOptions { random_start: true, ..default }, "default + random start"),
        (GenerateOptions { random_start: true, ..plain }, "plain + random start"),
    ] {
        derivation_row(buildings, &base, &gen, what);
    }
    let ps = InferOptions { post_split: true, ..base };
    derivation_row(buildings, &ps, &default, "default");
    derivation_row(buildings, &ps, &GenerateOptions { random_start: true, ..default }, "default + random start");
}

fn main() -> ExitCode {
    let Some(dir) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: sigi_eval DATA_DIR   (the folder with sigi-examples/ and gdmc2023/)");
        return ExitCode::from(2);
    };
    let (sigi_dir, gdmc_dir) = (dir.join("sigi-examples"), dir.join("gdmc2023"));
    if !sigi_dir.is_dir() && !gdmc_dir.is_dir() {
        eprintln!(
            "sigi_eval: {} has neither sigi-examples/ nor gdmc2023/ — the evaluation data is missing",
            dir.display()
        );
        return ExitCode::from(2);
    }
    let started = Instant::now();
    let mut sets = Vec::new();
    for (title, d, ext, prefix) in
        [("SIGI examples", &sigi_dir, "txt", "building"), ("GDMC 2023 structures", &gdmc_dir, "nbt", "")]
    {
        if !d.is_dir() {
            eprintln!("sigi_eval: {} is missing; skipping the {title}", d.display());
            continue;
        }
        match load(d, ext, prefix) {
            Ok(b) if !b.is_empty() => sets.push((title, b)),
            Ok(_) => eprintln!("sigi_eval: no buildings in {}", d.display()),
            Err(e) => {
                eprintln!("sigi_eval: {e}");
                return ExitCode::from(1);
            }
        }
    }
    println!("# SIGI evaluation\n\nData: {}", dir.display());
    if std::env::args().any(|a| a == "--derivations-only") {
        for (title, buildings) in &sets {
            println!("\n# {title}");
            derivations(buildings);
        }
        return ExitCode::SUCCESS;
    }
    for (title, buildings) in &sets {
        println!("\n# {title}");
        for cost in [Cost::Product, Cost::Sum] {
            timing(buildings, cost);
        }
    }
    if std::env::args().any(|a| a == "--timing-only") {
        return ExitCode::SUCCESS;
    }
    for (title, buildings) in &sets {
        println!("\n# {title}");
        generation(buildings);
    }
    for (title, buildings) in &sets {
        for cost in [Cost::Product, Cost::Sum] {
            let t = Instant::now();
            let runs = sweep(buildings, cost);
            tables(title, cost, buildings, &runs);
            println!(
                "\n({} runs in {:.1} s on {} threads)",
                runs.len(),
                t.elapsed().as_secs_f64(),
                rayon::current_num_threads()
            );
        }
    }
    eprintln!("sigi_eval: done in {:.1} s", started.elapsed().as_secs_f64());
    ExitCode::SUCCESS
}
