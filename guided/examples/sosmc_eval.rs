//! Guided-search evaluation (docs/guided.md): the guiding-curves paper's Fig. 4 on the
//! std tree grammar, the forward-sampling baseline, and projection plots.
//!
//! ```sh
//! cargo run --release -p mdg-guided --example sosmc_eval -- fig4 [--runs 500] [--guides program,A.json,B.json@calder,…]
//! cargo run --release -p mdg-guided --example sosmc_eval -- run [--guides F.json] [--seed N] [--no-heuristic] [--repeat N]
//! cargo run --release -p mdg-guided --example sosmc_eval -- plot OUT.png [GUIDES.json…] [--seed N] [--particles A:B]
//! cargo run --release -p mdg-guided --example sosmc_eval -- helix [--runs 40]
//! cargo run --release -p mdg-guided --example sosmc_eval -- curves [--runs 20] [--sets A.json,B.json,…] \
//!     [--configs paper:lowest,local:reach,…]
//! ```
//!
//! `curves`: per guide set (files from the workspace root; default the curved and
//! branching sets in `tests/guides/` and the grammar's own guides, `program`), per
//! seed 1…N, the coverage ([`mdg_guided::measure::coverage`]) of one unguided
//! derivation (a forward sample of as many particle-steps as the search has
//! generations) and of a search under each configuration `TERM:CHOICE` (`paper` or
//! `local`; `lowest`, `last`, `reach` or `reach:SHARE`, [`ModelChoice`]); prints mean
//! and median coverage, the ratio of means to unguided, and the mean COST and bones.
//!
//! `helix`: one helical guide (radius 1.2, 2.5 turns from z 0.3 to z 6); per seed a
//! search with the paper's utilisation term, one with the local variant
//! ([`Utilisation::Local`]) and an unguided tree (one forward sample); prints the cost,
//! the bones and the *coverage*: the fraction of 400 points spread along the helix
//! that have a bone within 0.35.
//!
//! The grammar is `std/examples/guided_tree.mdg`, compiled with `mdgc build` (the VM
//! does not depend on the compiler): from `$MDG_SOSMC_BUNDLE` if set (relative to the workspace root), else built into
//! `target/sosmc/guided_tree.mdgb` with `cargo run -p mdg-cli --bin mdgc`.
//!
//! `fig4`: for alignment offsets 0.6 and 0.5 (every guide's `delta_a`), `--runs` searches
//! (seeds 1…N) under each of: no heuristic and no ramp (constant generation size), ramp
//! only, ramp and heuristic, and the forward-sampling baseline (best of N complete
//! samples); all at the same budget of particle-steps (the schedule's, 5,750 for
//! particles 100 → 15 over 100 generations). It prints the median, quartiles and mean
//! of the final COST, and the median time per search; then the heuristic's gain paired
//! by seed (mean, 95% bootstrap interval, how many seeds it helped) and the difference
//! of the two offsets' gains. Per guide set: `--guides program,A.json,B.json@calder,…`:
//! `program` is the grammar's own guides, a file is a path from the workspace root
//! (`../shared/…` and absolute paths work; a missing file is an error naming it, before
//! any search); default the grammar's own, `arch.json` and `windswept.json`. A set is
//! searched with the grammar's `search` section (and `--heuristic-scale`, `--particles`,
//! `--generations`), or, with `@calder` after it, with Calder's playground search:
//! 100 generations, particles 100 → 15, heuristic scale 0.013 ramped to 0 over the
//! first 40%, EXPECTED from 4 samples of 20 expansions (≈ Calder's 10 growth steps).
//! Calder's benchmark curves (with its cost parameters) are in
//! `../shared/data/guides/calder_benchmark.json` where that folder exists (never
//! committed; `benches/sosmc_eval.sh` skips them without it).

use glam::{DVec3, Vec3};
use mdg_guided::{
    guides_from_json, Guide, GuidedTable, ModelChoice, Prepared, SearchOptions, SearchResult, Utilisation,
};
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::eval::EvalOptions;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// The compiled std tree grammar (shared with the benchmark).
#[path = "../benches/setup/mod.rs"]
mod setup;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn guides_of(b: &Bundle, file: Option<&str>) -> Result<Vec<Guide>, String> {
    match file {
        Some(f) => {
            let text = std::fs::read_to_string(f).map_err(|e| format!("{f}: {e}"))?;
            guides_from_json(&text).map_err(|e| format!("{f}: {e}"))
        }
        None => Ok(GuidedTable::from_bundle(b).map_err(|e| e.to_string())?.map(|t| t.guides).unwrap_or_default()),
    }
}

fn arg<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).map(|s| s.as_str())
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let x = q * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x - x.floor());
    if i + 1 < sorted.len() {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let r = match args.first().map(|s| s.as_str()) {
        Some("run") => run(&args[1..]),
        Some("fig4") => fig4(&args[1..]),
        Some("plot") => plot(&args[1..]),
        Some("helix") => helix(&args[1..]),
        Some("curves") => curves(&args[1..]),
        _ => Err("usage: sosmc_eval run|fig4|plot|helix|curves … (see the file's docs)".into()),
    };
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sosmc_eval: {e}");
            ExitCode::FAILURE
        }
    }
}

fn options(b: &Bundle, args: &[String]) -> Result<SearchOptions, String> {
    let table = &GuidedTable::from_bundle(b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let seed = arg(args, "--seed").map(|s| s.parse::<u64>().map_err(|e| e.to_string())).transpose()?.unwrap_or(1);
    let mut o = SearchOptions::from_settings(&table.settings, seed);
    o.budget = None;
    if args.iter().any(|a| a == "--no-heuristic") {
        o.heuristic_scale = 0.0;
    }
    if let Some(h) = arg(args, "--heuristic-scale") {
        o.heuristic_scale = h.parse().map_err(|_| "bad --heuristic-scale")?;
    }
    if let Some(g) = arg(args, "--generations") {
        o.generations = g.parse().map_err(|_| "bad --generations")?;
    }
    if let Some(p) = arg(args, "--particles") {
        let (a, b) = p.split_once(':').unwrap_or((p, p));
        o.particles = (a.parse().map_err(|_| "bad --particles")?, b.parse().map_err(|_| "bad --particles")?);
    }
    Ok(o)
}

fn run(args: &[String]) -> Result<(), String> {
    let b = setup::bundle()?;
    let table = GuidedTable::from_bundle(&b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let guides = guides_of(&b, arg(args, "--guides"))?;
    let p = Prepared::new(&b, &table, &guides).map_err(|e| e.to_string())?;
    let o = options(&b, args)?;
    // `--repeat N`: N searches (seeds seed … seed+N−1), each printed; for profiling.
    let repeat: u64 = arg(args, "--repeat").map(|s| s.parse().map_err(|_| "bad --repeat")).transpose()?.unwrap_or(1);
    for k in 0..repeat {
        let r = p.search(&SearchOptions { seed: o.seed + k, ..o.clone() }, None);
        print_result(&p, &r);
    }
    Ok(())
}

fn print_result(p: &Prepared, r: &SearchResult) {
    let m = &r.model;
    println!(
        "{} generations, {} particle-steps, {} expansions, {:.2} ms (prepare {:.2} ms)",
        r.generations,
        r.particle_steps,
        r.expansions,
        r.elapsed.as_secs_f64() * 1e3,
        p.prepare_time.as_secs_f64() * 1e3
    );
    println!(
        "cost {:.4} = d {:.4} + a {:.4} + u {:.4}; {} bones, {} calls, {} wrapped, {} dropped",
        m.cost.total(),
        m.cost.d,
        m.cost.a,
        m.cost.u,
        m.bones.len(),
        m.calls.len(),
        m.wrapped,
        m.dropped
    );
}

/// A helix of `turns` turns of radius `r` from z `z0` to `z1`, as a cubic Bézier chain
/// (four pieces a turn; handles (4/3)·tan(Δφ/4) of the tangent per radian).
fn helix_guide(r: f64, turns: f64, z0: f64, z1: f64) -> Guide {
    let pieces = (turns * 4.0).ceil() as usize;
    let dphi = turns * std::f64::consts::TAU / pieces as f64;
    let dz = (z1 - z0) / (turns * std::f64::consts::TAU);
    let at = |phi: f64| DVec3::new(r * phi.cos(), r * phi.sin(), z0 + dz * phi);
    let tangent = |phi: f64| DVec3::new(-r * phi.sin(), r * phi.cos(), dz);
    let h = 4.0 / 3.0 * (dphi / 4.0).tan();
    let mut points = vec![at(0.0).to_array()];
    for i in 0..pieces {
        let (a, b) = (i as f64 * dphi, (i + 1) as f64 * dphi);
        points.push((at(a) + tangent(a) * h).to_array());
        points.push((at(b) - tangent(b) * h).to_array());
        points.push(at(b).to_array());
    }
    let mut g: Guide = serde_json::from_str(r#"{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]]}"#).expect("guide");
    g.name = "helix".into();
    g.points = points;
    g
}

/// The distance from `p` to the segment `a`–`b`.
fn to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - p).length()
}

fn helix(args: &[String]) -> Result<(), String> {
    let runs: u64 = arg(args, "--runs").map(|s| s.parse().map_err(|_| "bad --runs")).transpose()?.unwrap_or(40);
    let b = setup::bundle()?;
    let table = GuidedTable::from_bundle(&b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let guide = helix_guide(1.2, 2.5, 0.3, 6.0);
    // 400 points along the helix (its parameter is proportional to arc length).
    let samples: Vec<DVec3> = (0..400)
        .map(|i| {
            let phi = (i as f64 + 0.5) / 400.0 * 2.5 * std::f64::consts::TAU;
            DVec3::new(1.2 * phi.cos(), 1.2 * phi.sin(), 0.3 + (6.0 - 0.3) * phi / (2.5 * std::f64::consts::TAU))
        })
        .collect();
    let coverage = |bones: &[mdg_guided::search::Bone]| {
        let near = |p: DVec3| bones.iter().any(|bo| to_segment(p, bo.base, bo.tip) < 0.35);
        samples.iter().filter(|p| near(**p)).count() as f64 / samples.len() as f64
    };
    let paper = Prepared::new(&b, &table, std::slice::from_ref(&guide)).map_err(|e| e.to_string())?;
    let local = Prepared::new(&b, &table, std::slice::from_ref(&guide))
        .map_err(|e| e.to_string())?
        .with_utilisation(Utilisation::Local);
    let o = options(&b, args)?;
    let mut rows: Vec<[f64; 9]> = Vec::new();
    for seed in 1..=runs {
        let rp = paper.search(&SearchOptions { seed, ..o.clone() }, None);
        let rl = local.search(&SearchOptions { seed, ..o.clone() }, None);
        let ru = paper.forward_best(1, o.generations, seed, None);
        let row = |r: &SearchResult| [coverage(&r.model.bones), r.model.cost.total(), r.model.bones.len() as f64];
        let (a, c, u) = (row(&rp), row(&rl), row(&ru));
        rows.push([a[0], a[1], a[2], c[0], c[1], c[2], u[0], u[1], u[2]]);
    }
    let col = |k: usize| {
        let mut v: Vec<f64> = rows.iter().map(|r| r[k]).collect();
        v.sort_by(f64::total_cmp);
        (quantile(&v, 0.5), v.iter().sum::<f64>() / v.len() as f64)
    };
    println!("{runs} seeds, one helical guide (r 1.2, 2.5 turns), coverage = share of the helix within 0.35 of a bone");
    println!("{:<28} {:>16} {:>16} {:>12}", "", "coverage med/mean", "cost med/mean", "bones med");
    for (name, k) in [("paper's utilisation (eq. 7)", 0), ("local utilisation", 3), ("unguided (forward sample)", 6)] {
        let (cm, ca) = col(k);
        let (sm, sa) = col(k + 1);
        let (bm, _) = col(k + 2);
        println!("{name:<28} {:>7.3} / {:<7.3} {:>7.2} / {:<7.2} {:>12.0}", cm, ca, sm, sa, bm);
    }
    Ok(())
}

/// The guide sets `curves` measures by default.
const CURVE_SETS: &str = "tests/guides/s_curve.json,tests/guides/spiral.json,tests/guides/helix.json,\
                          tests/guides/fork.json,tests/guides/arches.json,program";

fn curves(args: &[String]) -> Result<(), String> {
    let runs: u64 = arg(args, "--runs").map(|s| s.parse().map_err(|_| "bad --runs")).transpose()?.unwrap_or(20);
    let b = setup::bundle()?;
    let table = GuidedTable::from_bundle(&b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let o = options(&b, args)?;
    let mut configs = Vec::new();
    for c in arg(args, "--configs").unwrap_or("paper:lowest,local:lowest,paper:reach,local:reach").split(',') {
        let (t, k) = c.split_once(':').ok_or_else(|| format!("config `{c}`: expected TERM:CHOICE"))?;
        let term = Utilisation::from_name(t).ok_or_else(|| format!("config `{c}`: unknown term `{t}`"))?;
        let choice = ModelChoice::from_name(k).ok_or_else(|| format!("config `{c}`: unknown choice `{k}`"))?;
        configs.push((c.to_string(), term, choice));
    }
    println!(
        "coverage: share of {} points per guide within {} of a bone (length-weighted over a set); {runs} seeds",
        mdg_guided::measure::COVERAGE_POINTS,
        mdg_guided::measure::COVERAGE_RADIUS
    );
    for set in arg(args, "--sets").unwrap_or(CURVE_SETS).split(',') {
        let set = set.trim();
        let file = (set != "program").then(|| root().join(set));
        let guides = guides_of(&b, file.as_ref().and_then(|f| f.to_str()))?;
        let mut prepared = Vec::new();
        for (_, term, _) in &configs {
            prepared.push(Prepared::new(&b, &table, &guides).map_err(|e| e.to_string())?.with_utilisation(*term));
        }
        let base = Prepared::new(&b, &table, &guides).map_err(|e| e.to_string())?;
        let cov = |r: &SearchResult| mdg_guided::measure::coverage(base.guides(), &r.model.bones).total;
        let mut unguided = Vec::new();
        let mut rows: Vec<Vec<(f64, f64, f64)>> = vec![Vec::new(); configs.len()];
        for seed in 1..=runs {
            unguided.push(cov(&base.forward_best(1, o.generations, seed, None)));
            for (i, (_, _, choice)) in configs.iter().enumerate() {
                let r = prepared[i].search(&SearchOptions { seed, choice: *choice, ..o.clone() }, None);
                rows[i].push((cov(&r), r.model.cost.total(), r.model.bones.len() as f64));
            }
        }
        let stats = |v: &[f64]| {
            let mut s = v.to_vec();
            s.sort_by(f64::total_cmp);
            (s.iter().sum::<f64>() / s.len().max(1) as f64, quantile(&s, 0.5))
        };
        let (um, umed) = stats(&unguided);
        println!("{set}: unguided coverage mean {um:.3}, median {umed:.3}");
        for (i, (name, _, _)) in configs.iter().enumerate() {
            let c: Vec<f64> = rows[i].iter().map(|r| r.0).collect();
            let (cm, cmed) = stats(&c);
            let (costm, _) = stats(&rows[i].iter().map(|r| r.1).collect::<Vec<_>>());
            let (bm, _) = stats(&rows[i].iter().map(|r| r.2).collect::<Vec<_>>());
            let wins = c.iter().zip(&unguided).filter(|(a, b)| a > b).count();
            println!(
                "  {name:<18} coverage mean {cm:.3} median {cmed:.3}  ×{:.2} unguided  cost {costm:8.2}  bones {bm:5.1}  \
                 beats unguided on {wins}/{runs}",
                cm / um.max(1e-9)
            );
        }
    }
    Ok(())
}

/// Calder's playground search (`@calder` after a guide set in `fig4 --guides`): 100
/// generations, particles 100 → 15, heuristic scale 0.013 ramped to 0 over the first
/// 40% of the generations, and EXPECTED from 4 samples per skeleton rule of
/// [`CALDER_EXPECTED_EXPANSIONS`] expansions each.
const CALDER_SEARCH: (u32, (u32, u32), f64, f64) = (100, (100, 15), 0.013, 0.4);
/// Calder estimates each component's expected direction from 4 samples of 10 *growth
/// steps*; a growth step expands pending calls until one adds a bone (our
/// particle-step). Counted in the std tree grammar (20,000 samples per rule), 10 growth
/// steps take 20 expansions from `branch` (21 from `tree` and `fork`, 14 from
/// `maybe_branch`: `fork` and `maybe_branch` pass the origin on, and many samples run
/// out of calls), so `expected` counts 20.
const CALDER_EXPECTED_EXPANSIONS: u32 = 20;

/// One `fig4 --guides` entry: `program` (the grammar's own guides) or a JSON file (a
/// path from the workspace root, or absolute), optionally followed by `@calder`
/// (Calder's playground search parameters instead of the grammar's).
struct GuideSet {
    label: String,
    file: Option<PathBuf>,
    calder: bool,
}

fn guide_set(entry: &str) -> Result<GuideSet, String> {
    let (name, calder) = match entry.rsplit_once('@') {
        Some((name, "calder")) => (name, true),
        Some((_, other)) => return Err(format!("guide set `{entry}`: unknown parameters `@{other}` (only `@calder`)")),
        None => (entry, false),
    };
    let file = (name != "program").then(|| {
        // Relative paths are from the workspace root (`..` included); absolute ones as given.
        let root = root().canonicalize().unwrap_or_else(|_| root());
        root.join(name)
    });
    if let Some(f) = &file {
        if !f.is_file() {
            return Err(format!("guide set `{name}`: no such file {}", f.display()));
        }
    }
    Ok(GuideSet { label: entry.to_string(), file, calder })
}

fn fig4(args: &[String]) -> Result<(), String> {
    let runs: u64 = arg(args, "--runs").map(|s| s.parse().map_err(|_| "bad --runs")).transpose()?.unwrap_or(200);
    let b = setup::bundle()?;
    let table = GuidedTable::from_bundle(&b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let grammar = options(&b, args)?;
    let heuristic = arg(args, "--heuristic-scale").map(|h| h.parse::<f64>()).transpose().map_err(|_| "bad scale")?;
    // `--guides A.json,B.json@calder`: guide sets (`program` is the grammar's own);
    // default: the grammar's, then the two std guide files. Every file is checked
    // before the first search.
    let sets: Vec<GuideSet> = match arg(args, "--guides") {
        Some(list) => list.split(',').map(guide_set).collect::<Result<_, _>>()?,
        None => ["program", "std/examples/guides/arch.json", "std/examples/guides/windswept.json"]
            .into_iter()
            .map(guide_set)
            .collect::<Result<_, _>>()?,
    };
    println!("Fig. 4: {runs} runs per row (seeds 1..={runs}, the same seeds in every row)");
    for set in &sets {
        // The search parameters: the grammar's `search` section (and the command's
        // options), or Calder's playground search.
        let (mut base, mut table) = (grammar.clone(), table.clone());
        let h0 = if set.calder {
            let (generations, particles, scale, fraction) = CALDER_SEARCH;
            (base.generations, base.particles, base.heuristic_fraction) = (generations, particles, fraction);
            table.settings.expected = (4, CALDER_EXPECTED_EXPANSIONS);
            scale
        } else {
            heuristic.unwrap_or(if base.heuristic_scale > 0.0 { base.heuristic_scale } else { 1.0 })
        };
        base.heuristic_scale = h0;
        let steps = base.scheduled_steps();
        let flat = (steps as f64 / base.generations as f64).round() as u32;
        let source = guides_of(&b, set.file.as_ref().map(|f| f.to_string_lossy()).as_deref())?;
        println!();
        println!("guides: {} ({} curves)", set.label, source.len());
        println!(
            "search: {} ({} generations, particles {} → {}, equal budget of {steps} particle-steps per search; \
             heuristic scale {h0} ramped to 0 over the first {}% of the generations; EXPECTED from {} samples × {} expansions)",
            if set.calder { "Calder's playground" } else { "the grammar's" },
            base.generations,
            base.particles.0,
            base.particles.1,
            base.heuristic_fraction * 100.0,
            table.settings.expected.0,
            table.settings.expected.1,
        );
        println!(
            "{:<7} {:<34} {:>10} {:>10} {:>10} {:>10} {:>9}",
            "delta_a", "method", "median", "p25", "p75", "mean", "ms/run"
        );
        // Per offset, the per-seed paired gain of the heuristic (no heuristic − heuristic).
        let mut gains: Vec<Vec<f64>> = Vec::new();
        for delta in [0.6, 0.5] {
            let mut guides = source.clone();
            for g in &mut guides {
                g.delta_a = delta;
            }
            let p = Prepared::new(&b, &table, &guides).map_err(|e| e.to_string())?;
            let configs: [(&str, Option<SearchOptions>); 4] = [
                (
                    "no heuristic, constant size",
                    Some(SearchOptions { particles: (flat, flat), heuristic_scale: 0.0, ..base.clone() }),
                ),
                ("no heuristic, ramped size", Some(SearchOptions { heuristic_scale: 0.0, ..base.clone() })),
                ("heuristic, ramped size", Some(SearchOptions { heuristic_scale: h0, ..base.clone() })),
                ("forward sampling, best of N", None),
            ];
            let mut by_seed: Vec<Vec<f64>> = Vec::new();
            for (name, cfg) in configs.iter() {
                let mut costs = Vec::with_capacity(runs as usize);
                let mut times = Vec::with_capacity(runs as usize);
                for seed in 1..=runs {
                    let t = Instant::now();
                    let r = match cfg {
                        Some(o) => p.search(&SearchOptions { seed, ..o.clone() }, None),
                        None => p.forward_best(flat, base.generations, seed, None),
                    };
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                    costs.push(r.model.cost.total());
                }
                by_seed.push(costs.clone());
                costs.sort_by(f64::total_cmp);
                times.sort_by(f64::total_cmp);
                let mean = costs.iter().sum::<f64>() / costs.len() as f64;
                println!(
                    "{:<7} {:<34} {:>10.3} {:>10.3} {:>10.3} {:>10.3} {:>9.2}",
                    delta,
                    name,
                    quantile(&costs, 0.5),
                    quantile(&costs, 0.25),
                    quantile(&costs, 0.75),
                    mean,
                    quantile(&times, 0.5)
                );
            }
            let gain: Vec<f64> = by_seed[1].iter().zip(&by_seed[2]).map(|(a, h)| a - h).collect();
            let (lo, hi) = bootstrap_mean(&[&gain], |g| g[0]);
            let better = gain.iter().filter(|&&g| g > 0.0).count();
            println!(
                "{:<7} heuristic gain, paired by seed (no heuristic − heuristic): mean {:+.3} (95% bootstrap CI {:+.3} … {:+.3}); \
                 lower cost with the heuristic in {better} of {runs} seeds",
                delta,
                mean_of(&gain),
                lo,
                hi,
            );
            gains.push(gain);
        }
        let (lo, hi) = bootstrap_mean(&[&gains[0], &gains[1]], |g| g[0] - g[1]);
        println!(
            "difference of gains (offset 0.6 − offset 0.5): {:+.3} (95% bootstrap CI {:+.3} … {:+.3}, seeds resampled jointly)",
            mean_of(&gains[0]) - mean_of(&gains[1]),
            lo,
            hi
        );
    }
    Ok(())
}

fn mean_of(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// 95% percentile-bootstrap interval of `stat` of the means of `series` (per-seed
/// values, all of one length), resampling the seeds jointly (2,000 resamples, a
/// fixed stream so the table is reproducible).
fn bootstrap_mean(series: &[&[f64]], stat: impl Fn(&[f64]) -> f64) -> (f64, f64) {
    let n = series.first().map_or(0, |s| s.len());
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut next = |n: usize| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s % n.max(1) as u64) as usize
    };
    let mut stats = Vec::with_capacity(2000);
    for _ in 0..2000 {
        let picks: Vec<usize> = (0..n).map(|_| next(n)).collect();
        let means: Vec<f64> =
            series.iter().map(|v| picks.iter().map(|&i| v[i]).sum::<f64>() / n.max(1) as f64).collect();
        stats.push(stat(&means));
    }
    stats.sort_by(f64::total_cmp);
    (quantile(&stats, 0.025), quantile(&stats, 0.975))
}

/// A front view (x right, z up) of the model found for each guide file (or the
/// program's guides): triangles shaded by their normal, back to front, and the guides
/// in red on top; panels side by side at one scale.
fn plot(args: &[String]) -> Result<(), String> {
    let out = args.first().ok_or("plot OUT.png [GUIDES.json…]")?;
    let files: Vec<Option<&str>> = {
        let given: Vec<Option<&str>> =
            args[1..].iter().filter(|a| a.ends_with(".json")).map(|s| Some(s.as_str())).collect();
        if given.is_empty() {
            vec![None]
        } else {
            given
        }
    };
    let b = setup::bundle()?;
    let table = GuidedTable::from_bundle(&b).map_err(|e| e.to_string())?.ok_or("no search section")?;
    let base = options(&b, args)?;
    let seed = base.seed;
    // Search every panel first, then draw them all at one scale (x right, z up).
    let mut panels = Vec::new();
    for f in &files {
        let guides = guides_of(&b, *f)?;
        let p = Prepared::new(&b, &table, &guides).map_err(|e| e.to_string())?;
        let r = p.search(&base, None);
        print_result(&p, &r);
        let model = p.geometry(&r.model, &EvalOptions { seed: Some(seed), ..EvalOptions::default() }, false);
        let curves: Vec<Vec<DVec3>> = (0..p.guides().len()).map(|i| p.guides().path(i).polyline(48)).collect();
        panels.push((model.flattened(), curves));
    }
    let (mut x0, mut x1, mut z0, mut z1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (mesh, curves) in &panels {
        let pts = mesh.positions.iter().map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
        for q in pts.chain(curves.iter().flatten().copied()) {
            (x0, x1, z0, z1) = (x0.min(q.x), x1.max(q.x), z0.min(q.z), z1.max(q.z));
        }
    }
    let (pw, ph) = (560usize, 560usize);
    let span = ((x1 - x0).max(z1 - z0) * 1.08).max(1e-6);
    let (cx, cz) = ((x0 + x1) * 0.5, (z0 + z1) * 0.5);
    let (w, h) = (pw * panels.len(), ph);
    let mut img = vec![[255u8; 3]; w * h];
    for (k, (mesh, curves)) in panels.iter().enumerate() {
        let sx = |x: f64| (k * pw) as f64 + ((x - cx) / span + 0.5) * pw as f64;
        let sz = |z: f64| (0.5 - (z - cz) / span) * ph as f64;
        // Triangles back to front (the view looks along +y), shaded by their normal.
        let mut tris: Vec<([Vec3; 3], [f32; 4])> = mesh
            .triangles
            .iter()
            .map(|t| (t.map(|i| Vec3::from_array(mesh.positions[i as usize])), mesh.colors[t[0] as usize]))
            .collect();
        tris.sort_by(|a, b| {
            let ya = a.0.iter().map(|v| v.y).sum::<f32>();
            let yb = b.0.iter().map(|v| v.y).sum::<f32>();
            yb.total_cmp(&ya)
        });
        for (v, c) in &tris {
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            let shade = 0.55 + 0.45 * n.y.abs();
            let col = [0, 1, 2].map(|i| ((c[i].clamp(0.0, 1.0) * shade) * 255.0) as u8);
            let pts = v.map(|p| (sx(p.x as f64), sz(p.z as f64)));
            fill_triangle(&mut img, w, h, k * pw, (k + 1) * pw, pts, col);
        }
        for c in curves {
            for s in c.windows(2) {
                let (a, b) = ((sx(s[0].x), sz(s[0].z)), (sx(s[1].x), sz(s[1].z)));
                line(&mut img, w, h, k * pw, (k + 1) * pw, a, b, 1, [215, 35, 35]);
            }
        }
        // Panel border.
        for y in 0..h {
            img[y * w + k * pw] = [160, 160, 160];
        }
    }
    let bytes: Vec<u8> = img.iter().flat_map(|p| [p[0], p[1], p[2], 255]).collect();
    let png = mdg_vm::preview::encode_png(&bytes, w as u32, h as u32).map_err(|e| e.to_string())?;
    std::fs::write(out, png).map_err(|e| format!("{out}: {e}"))?;
    println!("wrote {out}");
    Ok(())
}

fn fill_triangle(img: &mut [[u8; 3]], w: usize, h: usize, xa: usize, xb: usize, p: [(f64, f64); 3], col: [u8; 3]) {
    let minx = p.iter().map(|q| q.0).fold(f64::INFINITY, f64::min).floor().max(xa as f64) as usize;
    let maxx = p.iter().map(|q| q.0).fold(f64::NEG_INFINITY, f64::max).ceil().min(xb as f64 - 1.0);
    let miny = p.iter().map(|q| q.1).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
    let maxy = p.iter().map(|q| q.1).fold(f64::NEG_INFINITY, f64::max).ceil().min(h as f64 - 1.0);
    if maxx < 0.0 || maxy < 0.0 {
        return;
    }
    let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[1].1 - p[0].1) * (p[2].0 - p[0].0);
    if area.abs() < 1e-12 {
        return;
    }
    for y in miny..=maxy as usize {
        for x in minx..=maxx as usize {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let e = |a: (f64, f64), b: (f64, f64)| (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0);
            let (w0, w1, w2) = (e(p[1], p[2]) / area, e(p[2], p[0]) / area, e(p[0], p[1]) / area);
            if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                img[y * w + x] = col;
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn line(
    img: &mut [[u8; 3]],
    w: usize,
    h: usize,
    xa: usize,
    xb: usize,
    a: (f64, f64),
    b: (f64, f64),
    r: i64,
    col: [u8; 3],
) {
    let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).clamp(1, 100_000);
    for k in 0..=n {
        let t = k as f64 / n as f64;
        let (x, y) = ((a.0 + (b.0 - a.0) * t) as i64, (a.1 + (b.1 - a.1) * t) as i64);
        for dy in -r..=r {
            for dx in -r..=r {
                let (px, py) = (x + dx, y + dy);
                if px >= xa as i64 && px < xb as i64 && py >= 0 && py < h as i64 && (px as usize) < w {
                    img[py as usize * w + px as usize] = col;
                }
            }
        }
    }
}
