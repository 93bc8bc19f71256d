//! SIGI evaluation: the paper's Tables 1–4 (#S, %M, Size, C) over parameter sweeps, and
//! inference time per building, on the SIGI example buildings and the GDMC structures.
//!
//! ```sh
//! cargo run --release -p mdg-grid --example sigi_eval -- /work/shared/data
//! ```
//!
//! The data directory holds `sigi-examples/building*.txt` and `gdmc2023/*.nbt`. It is
//! never part of the repository or the test suite; the script says so when it is
//! missing. Each table aggregates every run of the full grid (3 shape specifications ×
//! 9 α values × 3 operations × overlap or not) whose parameter is the row's value,
//! over the buildings of one data set: the average and the median of the runs. Tables
//! come for both cost functions: the paper's product and the reference implementation's
//! sum (see `mdg_grid::infer::Cost`), the sum with and without post-split, and
//! beside them the paper's numbers. The SIGI tables aggregate the paper's nine examples
//! (building05 is not among them) and label E1 (building10) and E5 (building06) as the
//! paper does; %M comes both ways: oriented blocks turned with the shape, and blocks
//! compared by id (the paper's reference). `--timing-only` stops after the timings,
//! `--derivations-only` and `--pairs-only` print only the derivation counts or the
//! shared-style pairs.

use mdg_grid::build::generate;
use mdg_grid::format;
use mdg_grid::generate::{enclosure, Bounds, GenerateOptions, Instance};
use mdg_grid::induce::{induce, measures, shared_shapes, Example, Measures};
use mdg_grid::infer::{infer, Cost, InferOptions, Ops, Spec};
use mdg_grid::share::share;
use mdg_grid::voxel::VoxelModel;
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
            let model = format::read(&p).map_err(|e| e.to_string())?;
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

/// The paper's label of a SIGI example file (the two the paper names; building05 is
/// not among its nine examples).
fn paper_label(name: &str) -> Option<&'static str> {
    match name {
        "building10" => Some("E1"),
        "building06" => Some("E5"),
        _ => None,
    }
}

/// Average and median of each measure over the runs: #S, %M (turned), %M (ids), Size, C.
fn stats(runs: &[&Run]) -> [(f64, f64); 5] {
    let col = |f: &dyn Fn(&Measures) -> f64| -> (f64, f64) {
        let v: Vec<f64> = runs.iter().map(|r| f(&r.m)).collect();
        (v.iter().sum::<f64>() / v.len().max(1) as f64, median(v))
    };
    [
        col(&|m| m.shapes as f64),
        col(&|m| m.matching),
        col(&|m| m.matching_exact),
        col(&|m| m.size),
        col(&|m| m.complexity),
    ]
}

fn row(label: &str, runs: &[&Run]) -> String {
    let [s, p, e, z, c] = stats(runs);
    format!(
        "| {label} | {:.2} | {:.1}% | {:.1}% | {:.2} | {:.3} | {:.1} | {:.1}% | {:.1}% | {:.2} | {:.3} | {} |",
        s.0,
        p.0,
        e.0,
        z.0,
        c.0,
        s.1,
        p.1,
        e.1,
        z.1,
        c.1,
        runs.len()
    )
}

const HEADER: &str = "| | #S | %M | %M ids | Size | C | #S | %M | %M ids | Size | C | runs |\n\
                      |---|---|---|---|---|---|---|---|---|---|---|---|";

/// The paper's Tables 1–4 (average #S, %M, Size, C, then the medians), row by row.
const PAPER: [(&str, [f64; 8]); 18] = [
    ("All overlap no", [27.23, 27.8, 96.33, 0.15, 6.0, 21.9, 31.2, 0.11]),
    ("All overlap yes", [51.04, 31.2, 94.26, 0.16, 13.0, 33.3, 22.68, 0.13]),
    ("E1 overlap no", [7.75, 15.6, 31.59, 0.18, 1.0, 0.0, 25.0, 0.08]),
    ("E1 overlap yes", [6.71, 29.8, 33.80, 0.13, 5.0, 40.0, 21.0, 0.13]),
    ("E5 overlap no", [33.05, 28.1, 137.14, 0.14, 26.0, 8.8, 11.28, 0.15]),
    ("E5 overlap yes", [72.53, 26.9, 136.91, 0.17, 61.0, 27.0, 9.18, 0.16]),
    ("α = 0", [64.60, 52.0, 23.93, 0.199, 47.0, 57.4, 6.60, 0.168]),
    ("α = 0.25", [56.85, 46.5, 43.82, 0.165, 36.0, 51.2, 6.90, 0.165]),
    ("α = 0.5", [55.29, 41.7, 66.67, 0.180, 28.0, 42.3, 9.04, 0.152]),
    ("α = 0.75", [53.26, 39.3, 68.84, 0.177, 24.0, 40.0, 11.26, 0.137]),
    ("α = 1", [42.85, 33.2, 72.39, 0.159, 16.0, 33.3, 19.27, 0.127]),
    ("α = 1.5", [41.1, 30.4, 78.00, 0.157, 12.0, 30.0, 22.90, 0.124]),
    ("α = 2", [33.26, 23.7, 100.28, 0.144, 8.0, 22.2, 32.50, 0.111]),
    ("α = 5", [31.04, 23.6, 106.23, 0.139, 6.0, 21.4, 35.00, 0.109]),
    ("α = 100", [31.03, 23.6, 106.27, 0.139, 6.0, 21.4, 35.00, 0.109]),
    ("merge", [47.1, 34.2, 88.4, 0.170, 18.5, 33.3, 18.3, 0.148]),
    ("split", [28.9, 20.5, 106.54, 0.120, 5.0, 16.7, 44.57, 0.080]),
    ("both", [41.54, 34.0, 90.79, 0.167, 14.0, 33.3, 16.43, 0.147]),
];

/// Table 4 of the paper (shape specifications).
const PAPER_SPECS: [(&str, [f64; 8]); 3] = [
    ("rect", [71.0, 44.9, 12.10, 0.261, 43.0, 42.3, 7.48, 0.244]),
    ("2d", [38.5, 36.5, 31.68, 0.147, 10.0, 37.5, 29.13, 0.124]),
    ("3d", [4.4, 4.8, 256.10, 0.037, 1.0, 0.0, 252.00, 0.025]),
];

/// The buildings a table aggregates: for the SIGI examples the paper's nine (not
/// building05), else all.
fn in_tables(buildings: &[Building]) -> Vec<bool> {
    let sigi = buildings.iter().any(|b| paper_label(&b.name).is_some());
    buildings.iter().map(|b| !(sigi && b.name == "building05")).collect()
}

fn tables(title: &str, cost: Cost, post_split: bool, buildings: &[Building], runs: &[Run]) {
    let keep = in_tables(buildings);
    let runs: Vec<&Run> = runs.iter().filter(|r| keep[r.building] && r.opts.post_split == post_split).collect();
    let n = keep.iter().filter(|&&k| k).count();
    println!(
        "\n## {title}, {} cost{} ({n} buildings{}; columns: average, then median; %M ids: blocks compared by id, \
         not turned)\n",
        cost.name(),
        if post_split { ", post-split" } else { "" },
        if n < buildings.len() { ", the paper's nine: not building05" } else { "" }
    );
    println!("### Table 1: overlap (merge operation)\n\n{HEADER}");
    let merge: Vec<&Run> = runs.iter().copied().filter(|r| r.opts.ops == Ops::Merge).collect();
    // The paper's E1 and E5, or for other data the first and fifth building.
    let labelled: Vec<(usize, &str)> =
        buildings.iter().enumerate().filter_map(|(i, b)| paper_label(&b.name).map(|l| (i, l))).collect();
    let picks: Vec<(String, Option<usize>)> = if labelled.is_empty() {
        [0, 4].iter().filter(|&&i| i < buildings.len()).map(|&i| (buildings[i].name.clone(), Some(i))).collect()
    } else {
        let mut v = labelled.clone();
        v.sort_by_key(|x| x.1);
        v.iter().map(|&(i, l)| (format!("{l} ({})", buildings[i].name), Some(i))).collect()
    };
    for (who, pick) in std::iter::once(("All".to_string(), None)).chain(picks) {
        for ov in [false, true] {
            let sel: Vec<&Run> = merge
                .iter()
                .copied()
                .filter(|r| r.opts.overlap == ov && pick.is_none_or(|i| r.building == i))
                .collect();
            println!("{}", row(&format!("{who} overlap {}", if ov { "yes" } else { "no" }), &sel));
        }
    }
    println!("\n### Table 2: α\n\n{HEADER}");
    for a in ALPHAS {
        let sel: Vec<&Run> = runs.iter().copied().filter(|r| r.opts.alpha == a).collect();
        println!("{}", row(&format!("α = {a}"), &sel));
    }
    println!("\n### Table 3: operations\n\n{HEADER}");
    for o in OPS {
        let sel: Vec<&Run> = runs.iter().copied().filter(|r| r.opts.ops == o).collect();
        println!("{}", row(o.name(), &sel));
    }
    println!("\n### Table 4: shape specification\n\n{HEADER}");
    for s in SPECS {
        let sel: Vec<&Run> = runs.iter().copied().filter(|r| r.opts.spec == s).collect();
        println!("{}", row(s.name(), &sel));
    }
}

/// Ours beside the paper's: the paper's rows (Tables 1–4) and ours for the same
/// selection, average and median of #S, %M (turned), Size and C.
fn beside_paper(cost: Cost, post_split: bool, buildings: &[Building], runs: &[Run]) {
    let keep = in_tables(buildings);
    let runs: Vec<&Run> = runs.iter().filter(|r| keep[r.building] && r.opts.post_split == post_split).collect();
    let index = |l: &str| buildings.iter().position(|b| paper_label(&b.name) == Some(l));
    println!(
        "\n## Beside the paper: SIGI examples, {} cost{} (paper / ours; average, then median)\n",
        cost.name(),
        if post_split { ", post-split" } else { "" }
    );
    println!("| | #S | %M | Size | C | #S | %M | Size | C |\n|---|---|---|---|---|---|---|---|---|");
    for (label, p) in PAPER.iter().chain(PAPER_SPECS.iter()) {
        let words: Vec<&str> = label.split_whitespace().collect();
        let sel: Vec<&Run> = runs
            .iter()
            .copied()
            .filter(|r| match words.as_slice() {
                [who, "overlap", ov] => {
                    r.opts.ops == Ops::Merge
                        && r.opts.overlap == (*ov == "yes")
                        && (*who == "All" || index(who) == Some(r.building))
                }
                ["α", "=", a] => a.parse::<f64>().is_ok_and(|a| r.opts.alpha == a),
                [name] => r.opts.ops.name() == *name || r.opts.spec.name() == *name,
                _ => false,
            })
            .collect();
        let [s, m, _, z, c] = stats(&sel);
        println!(
            "| {label} | {} / {:.2} | {}% / {:.1}% | {} / {:.2} | {} / {:.3} | {} / {:.1} | {}% / {:.1}% | {} / {:.2} | {} / {:.3} |",
            p[0], s.0, p[1], m.0, p[2], z.0, p[3], c.0, p[4], s.1, p[5], m.1, p[6], z.1, p[7], c.1
        );
    }
}

fn sweep(buildings: &[Building], cost: Cost, post_splits: &[bool]) -> Vec<Run> {
    let mut jobs = Vec::new();
    for b in 0..buildings.len() {
        for spec in SPECS {
            for alpha in ALPHAS {
                for ops in OPS {
                    for overlap in [false, true] {
                        for &post_split in post_splits {
                            jobs.push((b, InferOptions { spec, alpha, ops, overlap, cost, post_split }));
                        }
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
            .map(|(i, s)| Instance { shape: i as u32, place: mdg_grid::Placement::translation(s.at.unwrap_or([0; 3])) })
            .collect();
        let kept: Vec<String> = [0, 1, 2]
            .iter()
            .map(|&seal| match enclosure(&g, &placed, seal) {
                Ok((_, m, _)) => format!("{:.0}%", 100.0 * m.blocks.len() as f64 / b.model.blocks.len() as f64),
                Err(e) => e.to_string(),
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

/// Shared style: pairs of SIGI examples induced into one grammar (rect, α = 1, both,
/// sum cost): how many shapes match a shape of the other example without and with
/// sub-shape matching (`mdgc induce --share N`), and how many of 20 derivations (random
/// start) build with shapes of both examples ("mixed").
fn pairs(buildings: &[Building]) {
    let find = |n: &str| buildings.iter().position(|b| b.name == n);
    let list = [
        ("building10", "building06"),
        ("building01", "building02"),
        ("building03", "building04"),
        ("building07", "building08"),
        ("building01", "building09"),
        ("building02", "building04"),
        ("building06", "building09"),
    ];
    println!("\n## Shared style: pairs (rect, α = 1, both operations, sum cost)\n");
    println!(
        "| pair | shapes | shared, whole shapes | --share 4 (cuts) | --share 3 | --share 2 |\n\
         |---|---|---|---|---|---|"
    );
    let opts = InferOptions::default();
    for (a, b) in list {
        let (Some(a), Some(b)) = (find(a), find(b)) else { continue };
        let models = [&buildings[a].model, &buildings[b].model];
        let base: Vec<_> = models.iter().map(|m| infer(m, &opts, &mut |_| {})).collect();
        let examples: Vec<Example> =
            [a, b].iter().map(|&i| Example { name: buildings[i].name.clone(), model: &buildings[i].model }).collect();
        let mut cells = Vec::new();
        let mut n_plain = 0;
        for min in [0usize, 4, 3, 2] {
            let mut infs = base.clone();
            let cuts = if min > 0 { share(&models, opts.spec, &mut infs, min).cuts } else { 0 };
            // Derivations (seeds 1–20, random start, default generation) whose building
            // holds shapes of both examples.
            let mixed = |g: &mdg_grid::GridGrammar| {
                (1..=20u64)
                    .filter(|&seed| {
                        let opts = GenerateOptions { seed, random_start: true, ..GenerateOptions::default() };
                        generate(g, &opts).is_ok_and(|m| {
                            let ex: std::collections::HashSet<u32> =
                                m.instances.iter().map(|i| g.shapes[i.shape as usize].example).collect();
                            ex.len() > 1
                        })
                    })
                    .count()
            };
            match induce(&examples, &infs, "pair") {
                Ok(g) if min == 0 => {
                    n_plain = g.shapes.len();
                    cells.push(format!("{}; mixed {}", shared_shapes(&g), mixed(&g)));
                }
                Ok(g) => {
                    cells.push(format!("{} of {} ({cuts}); mixed {}", shared_shapes(&g), g.shapes.len(), mixed(&g)))
                }
                Err(e) => cells.push(e.to_string()),
            }
        }
        println!("| {} + {} | {n_plain} | {} |", buildings[a].name, buildings[b].name, cells.join(" | "));
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
            for d in mdg_grid::voxel::NEIGHBOURS {
                let q = mdg_grid::add(p, d);
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
        (GenerateOptions { adjacency: true, ..default }, "default + adjacency"),
        (GenerateOptions { adjacency: true, enclosure: false, ..default }, "adjacency instead of enclosure"),
        (GenerateOptions { adjacency: true, enclosure: false, ..plain }, "plain, adjacency instead of enclosure"),
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
    if std::env::args().any(|a| a == "--pairs-only") {
        for (_, buildings) in &sets {
            if buildings.iter().any(|b| paper_label(&b.name).is_some()) {
                pairs(buildings);
            }
        }
        return ExitCode::SUCCESS;
    }
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
    for (_, buildings) in &sets {
        if buildings.iter().any(|b| paper_label(&b.name).is_some()) {
            pairs(buildings);
        }
    }
    // The product cost without post-split (α has little effect there); the sum, the
    // reference's, with and without.
    for (title, buildings) in &sets {
        for (cost, post_splits) in [(Cost::Product, &[false][..]), (Cost::Sum, &[false, true][..])] {
            let t = Instant::now();
            let runs = sweep(buildings, cost, post_splits);
            for &ps in post_splits {
                tables(title, cost, ps, buildings, &runs);
            }
            println!(
                "\n({} runs in {:.1} s on {} threads)",
                runs.len(),
                t.elapsed().as_secs_f64(),
                rayon::current_num_threads()
            );
            if buildings.iter().any(|b| paper_label(&b.name).is_some()) {
                for &ps in post_splits {
                    beside_paper(cost, ps, buildings, &runs);
                }
            }
        }
    }
    eprintln!("sigi_eval: done in {:.1} s", started.elapsed().as_secs_f64());
    ExitCode::SUCCESS
}
