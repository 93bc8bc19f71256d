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
//! `mdg_creature::evolve::descriptor`). The structure clusters of the
//! presented set are printed too.
//!
//! Run: `cargo run --release -p mdg-creature --example creature_eval [-- SEEDS GENERATIONS]`
//! (default 8 seeds, 6 generations); `-- touch` measures how many presented monsters
//! have a part touching nothing; `-- fig13 [SEEDS GENERATIONS]` prints the ratio per
//! generation with the offspring counts it rests on (for any creature grammar: set
//! `MDG_CREATURE_BUNDLE`). The grammar is compiled by `mdgc` first
//! (`cargo run --release --bin mdgc -- build …`) unless `MDG_CREATURE_BUNDLE`
//! names a compiled `.mdgb`.

use mdg_creature::evolve::{Evolution, EvolveOptions};
use mdg_creature::table::RuleKind;
use std::path::Path;

/// The monsters grammar, its table and part library (shared with the benchmark).
#[path = "../benches/setup/mod.rs"]
mod setup;

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt())
}

/// Per generation (1..=G): (offspring HDM, offspring clusters, presented HDM,
/// presented clusters, offspring made, monsters presented).
fn run(evo: &Evolution) -> Vec<[f64; 6]> {
    let (mut pop, _) = evo.start();
    (1..=evo.opts.generations)
        .map(|_| {
            let g = evo.step(&mut pop, None);
            let (o, d) = (&g.offspring_diversity, &g.diversity);
            [o.hdm, o.clusters as f64, d.hdm, d.clusters as f64, g.n_offspring as f64, g.presented.len() as f64]
        })
        .collect()
}

/// `touch`: the share of presented monsters (generations 0–5, population 18,
/// seeds 1, 3, 7, 11, 42) with a part touching nothing of its torso, with the
/// copies of arrangements placed by their plain offsets (as before issue 22) and
/// seated on the torso's surface; evolution rejecting detached layouts or not.
fn touch(bundle: &mdg_vm::bundle::Bundle) -> Result<(), String> {
    let (table, mut lib) = setup::library(bundle)?;
    let table = &table;
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

/// `time`: the time of one layout (geometry rules, seating, grounding, stability)
/// and of its contact test, over the presented monsters of seed 3, generations 0–5.
fn time(bundle: &mdg_vm::bundle::Bundle) -> Result<(), String> {
    use mdg_creature::geometry::{detached, layout};
    let (table, mut lib) = setup::library(bundle)?;
    let table = &table;
    let mut o = EvolveOptions::from_table(table);
    o.seed = 3;
    let evo = Evolution::new(table, &lib, o);
    let (mut pop, g0) = evo.start();
    let mut shapes: Vec<_> = g0.presented.iter().map(|i| i.shape.clone()).collect();
    // Whole generations (selection, structure rules, layout, contact and stability
    // tests, retries, diversity control), per offspring made; run with
    // RAYON_NUM_THREADS=1 for the time of one thread.
    let (mut made, t) = (0usize, std::time::Instant::now());
    let mut sets = Vec::new();
    for _ in 0..5 {
        let g = evo.step(&mut pop, None);
        made += g.n_offspring;
        let mut set = g.presented.clone();
        set.extend(g.background.iter().take(g.n_offspring.saturating_sub(g.presented.len())).cloned());
        sets.push(set);
        shapes.extend(g.presented.into_iter().map(|i| i.shape));
    }
    let whole = t.elapsed().as_secs_f64() * 1e3 / made.max(1) as f64;
    println!(
        "generations 1-5: {whole:.3} ms per offspring ({made} offspring, {} thread(s))",
        rayon::current_num_threads()
    );
    // The silhouettes' part of it: one silhouette per offspring made, and the
    // comparisons of a generation's offspring (look-alikes dropped, the visible
    // clusters and the visibly different count of the offspring measure), per
    // offspring, on sets of the generation's size.
    {
        use mdg_creature::evolve::{drop_lookalikes, visible_clusters, visibly_different};
        use mdg_creature::silhouette::silhouette;
        let all: Vec<_> = sets.iter().flatten().collect();
        let t = std::time::Instant::now();
        for _ in 0..5 {
            for i in &all {
                std::hint::black_box(silhouette(&lib, &i.layout));
            }
        }
        let render = t.elapsed().as_secs_f64() * 1e3 / (5 * all.len().max(1)) as f64;
        let t = std::time::Instant::now();
        for set in &sets {
            std::hint::black_box(drop_lookalikes(set.clone()));
            std::hint::black_box(visible_clusters(table, set));
            std::hint::black_box(visibly_different(set));
        }
        let n: usize = sets.iter().map(Vec::len).sum();
        let compare = t.elapsed().as_secs_f64() * 1e3 / n.max(1) as f64;
        println!(
            "silhouettes: {render:.3} ms to make one, {compare:.3} ms of comparisons per offspring (look-alikes dropped, visible clusters, visibly different count) (sets of {:.0}); {:.1}% of a generation's time per offspring",
            n as f64 / sets.len().max(1) as f64,
            100.0 * (render + compare) / whole
        );
    }
    for seat in [false, true] {
        lib.seat = seat;
        let t = std::time::Instant::now();
        let layouts: Vec<_> = (0..5).flat_map(|_| shapes.iter().map(|s| layout(table, &lib, s))).collect();
        let per = t.elapsed().as_secs_f64() * 1e3 / layouts.len() as f64;
        let t = std::time::Instant::now();
        for (l, s) in layouts.iter().zip(shapes.iter().cycle()) {
            std::hint::black_box(detached(&lib, s, &l.placed));
        }
        let contact = t.elapsed().as_secs_f64() * 1e3 / layouts.len() as f64;
        println!(
            "seat {seat}: layout {per:.3} ms (of which the contact test {contact:.3} ms) per monster, {} monsters",
            shapes.len()
        );
    }
    Ok(())
}

/// The paper's Fig. 13 with the sample sizes: per generation, the HDM of all
/// offspring (and of the presented set) without increase rules over the HDM with
/// all rules, each mean over seeds 1..=`seeds`, with the number of offspring (and
/// presented monsters) each variant made, summed over the seeds. The grammar's own
/// population and offspring count.
fn fig13(bundle: &mdg_vm::bundle::Bundle, path: &Path, seeds: u64, gens: u32) -> Result<(), String> {
    let (table, lib) = setup::library(bundle)?;
    let table = &table;
    let base = EvolveOptions::from_table(table);
    println!(
        "Fig. 13 on {}: seeds 1–{seeds}, generations 1–{gens}, population {}, {} offspring per generation",
        path.display(),
        base.population,
        base.offspring
    );
    // results[variant][seed][generation]
    let mut results: [Vec<Vec<[f64; 6]>>; 2] = [Vec::new(), Vec::new()];
    for (variant, disabled) in [vec![], vec![RuleKind::Increase]].into_iter().enumerate() {
        for seed in 1..=seeds {
            let mut o = base.clone();
            o.seed = seed;
            o.generations = gens;
            o.disabled = disabled.clone();
            results[variant].push(run(&Evolution::new(table, &lib, o)));
        }
    }
    println!("| generation | offspring HDM, all rules | no increase | ratio | offspring (all + no increase) | presented HDM, all / no increase | ratio | presented (all + no increase) |");
    println!("|---|---|---|---|---|---|---|---|");
    let col = |v: usize, g: usize, k: usize| results[v].iter().map(|r| r[g][k]).collect::<Vec<f64>>();
    let mut sums = [0.0f64; 8];
    for g in 0..gens as usize {
        let (a, b) = (mean_sd(&col(0, g, 0)).0, mean_sd(&col(1, g, 0)).0);
        let (pa, pb) = (mean_sd(&col(0, g, 2)).0, mean_sd(&col(1, g, 2)).0);
        let (na, nb): (f64, f64) = (col(0, g, 4).iter().sum(), col(1, g, 4).iter().sum());
        let (ma, mb): (f64, f64) = (col(0, g, 5).iter().sum(), col(1, g, 5).iter().sum());
        println!(
            "| {} | {a:.2} | {b:.2} | **{:.2}** | {na:.0} + {nb:.0} | {pa:.2} / {pb:.2} | {:.2} | {ma:.0} + {mb:.0} |",
            g + 1,
            b / a,
            pb / pa
        );
        for (s, v) in sums.iter_mut().zip([a, b, pa, pb, na, nb, ma, mb]) {
            *s += v;
        }
    }
    let n = gens.max(1) as f64;
    println!(
        "| mean of 1–{gens} | {:.2} | {:.2} | **{:.2}** | {:.0} + {:.0} | {:.2} / {:.2} | {:.2} | {:.0} + {:.0} |",
        sums[0] / n,
        sums[1] / n,
        sums[1] / sums[0],
        sums[4],
        sums[5],
        sums[2] / n,
        sums[3] / n,
        sums[3] / sums[2],
        sums[6],
        sums[7]
    );
    Ok(())
}

/// `pairs SEED GENERATIONS [POPULATION] [before]`: the presented monsters of the
/// last generation and their nearest pairs by silhouette distance (to tune the
/// look-alike threshold against what the contact sheet shows). `before`: look-alikes
/// kept and lineages free, as `--allow-lookalikes --no-lineages`.
fn pairs(bundle: &mdg_vm::bundle::Bundle, args: &[String]) -> Result<(), String> {
    use mdg_creature::silhouette::distance;
    let (table, lib) = setup::library(bundle)?;
    let table = &table;
    let mut o = EvolveOptions::from_table(table);
    o.seed = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    o.generations = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(5);
    if let Some(p) = args.get(4).and_then(|s| s.parse::<u32>().ok()) {
        if o.offspring == o.population * 3 {
            o.offspring = p * 3;
        }
        o.population = p;
    }
    let before = args.iter().any(|a| a == "before");
    o.drop_lookalikes = !before;
    o.lineages = !before;
    let evo = Evolution::new(table, &lib, o.clone());
    let (mut pop, mut g) = evo.start();
    for _ in 0..o.generations {
        g = evo.step(&mut pop, None);
    }
    let p = &g.presented;
    println!(
        "generation {}: {} presented, {} visibly different, visible clusters {}, structures {}, HDM {:.2}, look-alikes dropped {}",
        g.index,
        p.len(),
        g.diversity.visible,
        g.diversity.clusters,
        g.diversity.structures,
        g.diversity.hdm,
        g.n_lookalikes
    );
    for i in p {
        println!("{} ({} metas) {}", i.id, i.shape.n_metas(), i.shape.describe(table));
    }
    let mut d: Vec<(f64, usize, usize)> = Vec::new();
    for a in 0..p.len() {
        for b in a + 1..p.len() {
            d.push((distance(&p[a].silhouette, &p[b].silhouette), a, b));
        }
    }
    d.sort_by(|x, y| x.0.total_cmp(&y.0));
    // Per view: front, side, the sheet's three-quarter view.
    let view = |s: &mdg_creature::silhouette::Silhouette, v: usize| {
        let mut one = mdg_creature::silhouette::Silhouette::default();
        one.views[v] = s.views[v];
        one
    };
    for (dist, a, b) in d.iter().take(30) {
        let per: Vec<String> = (0..3)
            .map(|v| format!("{:.3}", 3.0 * distance(&view(&p[*a].silhouette, v), &view(&p[*b].silhouette, v))))
            .collect();
        println!("{dist:.3} {} {} views {}", p[*a].id, p[*b].id, per.join(" "));
    }
    Ok(())
}

/// `lineages SEEDS`: per seed, the presented monsters per lineage in generations
/// 1–4 without lineages kept (look-alikes dropped), and the notes of lineages that
/// died out — to find a run where a body plan is crowded out.
fn lineages(bundle: &mdg_vm::bundle::Bundle, seeds: u64) -> Result<(), String> {
    let (table, lib) = setup::library(bundle)?;
    let table = &table;
    for seed in 1..=seeds {
        let mut o = EvolveOptions::from_table(table);
        o.seed = seed;
        o.lineages = false;
        let evo = Evolution::new(table, &lib, o);
        let (mut pop, _) = evo.start();
        let rows: Vec<String> = (1..=4)
            .map(|_| {
                let g = evo.step(&mut pop, None);
                format!("{:?} {}", g.lineages, g.extinct.len())
            })
            .collect();
        println!("seed {seed}: {}", rows.join(" | "));
    }
    Ok(())
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().collect();
    if args.get(1).map(String::as_str) == Some("lineages") {
        let (_, bundle) = setup::load()?;
        return lineages(&bundle, args.get(2).and_then(|s| s.parse().ok()).unwrap_or(12));
    }
    if args.get(1).map(String::as_str) == Some("pairs") {
        let (_, bundle) = setup::load()?;
        return pairs(&bundle, &args);
    }
    if args.get(1).map(String::as_str) == Some("time") {
        let (_, bundle) = setup::load()?;
        return time(&bundle);
    }
    if args.get(1).map(String::as_str) == Some("touch") {
        let (_, bundle) = setup::load()?;
        return touch(&bundle);
    }
    if args.get(1).map(String::as_str) == Some("fig13") {
        let (path, bundle) = setup::load()?;
        let seeds: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
        let gens: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(5);
        return fig13(&bundle, &path, seeds, gens);
    }
    let seeds: Vec<u64> = match args.get(1).and_then(|s| s.parse::<u64>().ok()) {
        Some(n) => (1..=n).collect(),
        None => vec![1, 3, 7, 11, 42],
    };
    let gens: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let (_, bundle) = setup::load()?;
    let (table, lib) = setup::library(&bundle)?;
    let table = &table;
    let population = 18u32;
    println!(
        "Ablation of increase rules (paper Fig. 13): std/examples/monsters.mdg, seeds {seeds:?}, {gens} generations, population {population}"
    );
    println!("HDM = N + Σ D_i (N structure clusters, D_i the spread of the geometric descriptor in cluster i over the largest); mean ± sd over seeds and generations 1–{gens}\n");
    println!("| sample | n (mean, both variants) | HDM, all rules | HDM, no increase | ratio | ratio per generation | clusters all / no incr. |");
    println!("|---|---|---|---|---|---|---|");
    for offspring in [54u32, 162, 540] {
        // results[variant][seed][generation]
        let mut results: [Vec<Vec<[f64; 6]>>; 2] = [Vec::new(), Vec::new()];
        for (variant, disabled) in [vec![], vec![RuleKind::Increase]].into_iter().enumerate() {
            for &seed in &seeds {
                let mut o = EvolveOptions::from_table(table);
                o.seed = seed;
                o.generations = gens;
                o.population = population;
                o.offspring = offspring;
                o.disabled = disabled.clone();
                results[variant].push(run(&Evolution::new(table, &lib, o)));
            }
        }
        // The presented set (18) once, from the runs with 54 offspring (the default).
        let samples: &[(usize, usize, &str)] =
            if offspring == 54 { &[(2, 3, "presented set"), (0, 1, "offspring")] } else { &[(0, 1, "offspring")] };
        for &(hdm, clusters, what) in samples {
            let all: Vec<f64> = results[0].iter().flat_map(|r| r.iter().map(|g| g[hdm])).collect();
            let none: Vec<f64> = results[1].iter().flat_map(|r| r.iter().map(|g| g[hdm])).collect();
            let size = if hdm == 2 { 5 } else { 4 };
            let n: Vec<f64> = results.iter().flatten().flat_map(|r| r.iter().map(|g| g[size])).collect();
            let per_gen: Vec<String> = (0..gens as usize)
                .map(|g| {
                    let a = mean_sd(&results[0].iter().map(|r| r[g][hdm]).collect::<Vec<_>>()).0;
                    let b = mean_sd(&results[1].iter().map(|r| r[g][hdm]).collect::<Vec<_>>()).0;
                    format!("{:.2}", b / a)
                })
                .collect();
            let ca: Vec<f64> = results[0].iter().flat_map(|r| r.iter().map(|g| g[clusters])).collect();
            let cb: Vec<f64> = results[1].iter().flat_map(|r| r.iter().map(|g| g[clusters])).collect();
            let ((a, sa), (b, sb)) = (mean_sd(&all), mean_sd(&none));
            println!(
                "| {what} of {offspring} | {:.0} | {a:.2} ± {sa:.2} | {b:.2} ± {sb:.2} | {:.2} | {} | {:.1} / {:.1} |",
                mean_sd(&n).0,
                b / a,
                per_gen.join(" "),
                mean_sd(&ca).0,
                mean_sd(&cb).0
            );
        }
    }
    Ok(())
}
