//! Guided search (SOSMC with guiding curves) end to end: the std tree grammar
//! compiles into a guided table that survives the bundle format, the search is
//! deterministic for any thread count, the reported model is the minimum-cost final
//! particle, the total cost does not depend on the expansion order, wrap-up and the
//! geometry phase, the `mdg-run` mode with guide files, and that models follow the
//! guides they were searched for.

use glam::DVec3;
use mdg_cli::modes::guided::GuidedArgs;
use mdg_cli::modes::Common;
use mdg_guided::{Guide, GuidedTable, ModelChoice, Prepared, SearchOptions, Stop};
use mdg_tests::{analyze_file, build_source, root};
use mdg_vm::bundle::{Bundle, Section};
use mdg_vm::eval::{evaluate, evaluate_calls, Call, EvalOptions, Expander};

fn std_tree() -> Bundle {
    let a = analyze_file(&root().join("std/examples/guided_tree.mdg"), true);
    assert!(!a.has_errors(), "{}", mdg_tests::render(&a));
    mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers")
}

fn table(b: &Bundle) -> GuidedTable {
    GuidedTable::from_bundle(b).expect("a valid section").expect("guided table")
}

fn rule(b: &Bundle, name: &str) -> u32 {
    b.rules.iter().position(|r| b.string(r.name) == name).expect("rule") as u32
}

fn opts(seed: u64) -> SearchOptions {
    SearchOptions {
        particles: (40, 10),
        generations: 40,
        heuristic_scale: 1.0,
        heuristic_fraction: 0.4,
        budget: None,
        resampling: mdg_guided::Resampling::Systematic,
        seed,
        threads: None,
        parallel_min: mdg_guided::PARALLEL_MIN_PARTICLES,
        clock: None,
        cancel: None,
        choice: ModelChoice::default(),
    }
}

#[test]
fn std_tree_compiles_to_a_guided_table_that_round_trips() {
    let b = std_tree();
    let t = table(&b);
    let names: Vec<&str> = t.skeleton.iter().map(|&r| b.string(b.rules[r as usize].name)).collect();
    assert_eq!(names, ["tree", "branch", "fork", "maybe_branch"]);
    assert_eq!(t.wrapups.len(), 3);
    assert!(t.wrapups.iter().all(|&(_, to)| to == rule(&b, "leaf")));
    assert_eq!(t.guides.len(), 3);
    assert_eq!(t.guides[0].name, "trunk");
    assert_eq!(t.guides[0].points.len(), 7);
    assert_eq!(t.guides[1].delta_a, 0.6);
    assert_eq!(t.settings.particles, (100, 15));
    assert_eq!(t.settings.generations, 100);
    assert_eq!(t.settings.budget_ms, Some(200.0));
    let back = mdg_vm::bundle::load(&mdg_vm::bundle::encode(&b)).expect("loads");
    assert_eq!(GuidedTable::from_bundle(&back).expect("a valid section").as_ref(), Some(&t));
}

#[test]
fn the_verifier_rejects_bad_tables() {
    let b = std_tree();
    let load = |t: GuidedTable| {
        let mut c = b.clone();
        t.store(&mut c.extensions);
        let back = mdg_vm::bundle::load(&mdg_vm::bundle::encode(&c)).map_err(|e| e.to_string())?;
        GuidedTable::from_bundle(&back).map(|_| ()).map_err(|e| e.to_string())
    };
    assert_eq!(load(table(&b)), Ok(()));
    let mut t = table(&b);
    t.skeleton.push(rule(&b, "wood_side"));
    assert!(load(t).expect_err("draws").contains("draws"));
    let mut t = table(&b);
    t.skeleton.push(b.rules.len() as u32);
    assert!(load(t).expect_err("range").contains("out of range"));
    let mut t = table(&b);
    t.guides[0].delta_a = 1.5;
    assert!(load(t).expect_err("delta").contains("delta_a"));
    let mut t = table(&b);
    t.guides[0].points.pop();
    assert!(load(t).expect_err("points").contains("3k + 1"));
    let mut t = table(&b);
    t.wrapups.push((rule(&b, "leaf"), rule(&b, "wood")));
    assert!(load(t).expect_err("wrap-up").contains("not a skeleton rule"));
}

#[test]
fn search_is_deterministic_for_any_thread_count() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    // Every generation in parallel (parallel_min 1) on 3 threads, against one thread.
    let run = |threads| p.search(&SearchOptions { threads: Some(threads), parallel_min: 1, ..opts(5) }, None);
    let (one, three) = (run(1), run(3));
    assert_eq!(one.model.cost, three.model.cost);
    assert_eq!(one.model.bones, three.model.bones);
    assert_eq!(one.model.calls, three.model.calls);
    assert_eq!(one.final_costs, three.final_costs);
    assert_eq!((one.particle_steps, one.expansions), (three.particle_steps, three.expansions));
    // The geometry is the same too, and another seed gives another tree.
    let eval = EvalOptions { seed: Some(5), ..EvalOptions::default() };
    assert_eq!(p.geometry(&one.model, &eval, true).vertex_mesh(), p.geometry(&three.model, &eval, true).vertex_mesh());
    let other = p.search(&SearchOptions { threads: Some(2), ..opts(6) }, None);
    assert_ne!(other.model.bones, one.model.bones);
}

#[test]
fn the_reported_model_is_the_lowest_cost_of_any_generation() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let opts = |seed| SearchOptions { choice: ModelChoice::LowestCost, ..opts(seed) };
    let mut earlier = 0;
    for seed in 1..=6 {
        // Each generation's lowest cost, as the progress report gives it.
        let lows = std::sync::Mutex::new(Vec::new());
        let report = |g: &mdg_guided::Progress| lows.lock().expect("lock").push(g.best_cost);
        let r = p.search(&opts(seed), Some(&report));
        let lows = lows.into_inner().expect("lock");
        assert_eq!(lows.len() as u32, r.generations);
        let min = lows.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(r.model.cost.total(), min, "seed {seed}: the model is the lowest of every generation");
        // The earliest generation that reached it.
        let first = lows.iter().position(|&c| c == min).expect("min") as u32 + 1;
        assert_eq!(r.model_generation, first, "seed {seed}");
        assert!(r.final_costs.len() >= 2);
        let final_min = r.final_costs.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(r.final_costs[r.chosen], final_min);
        assert!(r.final_costs[..r.chosen].iter().all(|&c| c > final_min), "the first of equal minima");
        assert!(min <= final_min);
        earlier += usize::from(r.model_generation < r.generations);
        // The model's cost, recomputed from its bones from scratch, agrees.
        let again = p.cost_of(&r.model.bones);
        assert!((again.total() - r.model.cost.total()).abs() < 1e-9, "{again:?} vs {:?}", r.model.cost);
    }
    eprintln!("{earlier} of 6 searches kept a model from before the last generation");
    let chosen: Vec<usize> = (1..=8).map(|s| p.search(&opts(s), None).chosen).collect();
    assert!(chosen.iter().any(|&c| c != 0), "the pick is not always the first particle: {chosen:?}");
}

/// A binary tree grammar that terminates (maxdepth), with random angles.
const BINARY: &str = "
startshape root
maxdepth 9
search { skeleton root node; }
guide g { points 0 0 0  0 0 1  0.5 0 2  1 0 3; delta_a 0.3; }
guide h { points 0 0 1  -1 0 1.5  -1.5 0 2  -2 0 3; scale_u 1; segment 0.3; }
rule root { node {} }
rule node {
  node {rz rand(0, 360) rx rand(10, 40) s rand(0.7, 0.9) z 1}
  node {rx rand(-40, -10) s 0.75 z 0.8}
}
";

#[test]
fn total_cost_is_independent_of_expansion_order() {
    let b = build_source(BINARY);
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let mut lcg = 12345u64;
    type Pick = Box<dyn FnMut(usize) -> usize>;
    let mut orders: Vec<(&str, Pick)> = vec![
        ("breadth first", Box::new(|_| 0)),
        ("depth first", Box::new(|n| n - 1)),
        (
            "random",
            Box::new(move |n| {
                lcg = lcg.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((lcg >> 33) as usize) % n
            }),
        ),
    ];
    let mut results = Vec::new();
    for (name, pick) in orders.iter_mut() {
        let (cost, mut bones) = p.expand_in_order(9, 100_000, pick.as_mut());
        bones.sort_by(|a, b| {
            (a.base.to_array(), a.tip.to_array())
                .partial_cmp(&(b.base.to_array(), b.tip.to_array()))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        results.push((*name, cost, bones));
    }
    let (_, c0, b0) = &results[0];
    assert_eq!(b0.len(), 510, "a full binary tree: 2 + 4 + … + 256 bones below the root node");
    for (name, c, bones) in &results[1..] {
        assert_eq!(bones, b0, "{name}: the same skeleton");
        for (x, y) in [(c.d, c0.d), (c.a, c0.a), (c.u, c0.u)] {
            assert!((x - y).abs() < 1e-9, "{name}: {c:?} vs {c0:?}");
        }
    }
    // And the utilisation term is not trivially zero here.
    assert!(c0.u < -1.0, "{c0:?}");
}

#[test]
fn leftover_skeleton_calls_are_wrapped_up() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let r = p.search(&SearchOptions { generations: 3, ..opts(2) }, None);
    assert_eq!(r.generations, 3);
    assert_eq!(r.stop, Stop::Generations);
    let m = &r.model;
    assert!(m.wrapped > 0, "a three-generation tree has pending calls");
    let leaf = rule(&b, "leaf");
    let leaves = m.calls.iter().filter(|c| c.rule == leaf).count();
    assert!(leaves >= m.wrapped);
    // No skeleton call reaches the geometry phase.
    assert!(m.calls.iter().all(|c| !p.is_skeleton(c.rule)));
    let out = p.geometry(m, &EvalOptions::default(), false);
    assert!(out.vertex_mesh().n_vertices() > 0);
    assert!(out.lines.is_empty());
}

#[test]
fn a_tiny_budget_stops_before_the_first_particle_step() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let r = p.search(&SearchOptions { budget: Some(std::time::Duration::from_nanos(1)), ..opts(1) }, None);
    assert_eq!(r.stop, Stop::Budget);
    assert_eq!((r.generations, r.particle_steps), (0, 0));
    // The model is the start, wrapped up: no bones.
    assert!(r.model.bones.is_empty());
}

/// The budget is checked inside a generation (before every particle-step): one
/// generation of 1,000,000 particles takes seconds, but a 300 ms budget ends the search
/// within it, dropping that generation for the one before. And it covers preparing
/// the guides when the caller starts the clock before preparing.
#[test]
fn the_budget_ends_a_long_generation_and_covers_preparation() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let budget = std::time::Duration::from_millis(300);
    let big = SearchOptions { particles: (20, 1_000_000), generations: 2, budget: Some(budget), ..opts(1) };
    let started = std::time::Instant::now();
    let r = p.search(&big, None);
    let took = started.elapsed();
    assert_eq!(r.stop, Stop::Budget);
    assert_eq!(r.generations, 1, "the cut generation is dropped");
    // The generation count and the steps show where it stopped; how soon after the
    // budget is a benchmark's business (wall time on a shared machine).
    assert!(took >= budget, "took {took:?}");
    assert!(r.particle_steps <= 20, "the first generation's steps only: {}", r.particle_steps);

    // The clock started long ago: no time is left once preparation is done.
    let long_ago = std::time::Instant::now() - std::time::Duration::from_secs(1);
    let deadline = long_ago + budget;
    let e = Prepared::new_within(&b, &t, &t.guides, Some(deadline)).err().expect("past the deadline");
    assert_eq!(e, mdg_guided::PrepareError::Guides(mdg_guided::GuidesError::OutOfTime { prepared: 0, total: 3 }));
    assert!(e.to_string().starts_with("the time budget ran out while preparing the guides (0 of 3 prepared)"), "{e}");
    let r = p.search(&SearchOptions { clock: Some(long_ago), ..big }, None);
    assert_eq!((r.stop, r.generations), (Stop::Budget, 0));
}

/// A search stops as soon as its cancel flag is set, like at its budget: set before
/// it starts, no generation runs; set between generations (here by the progress
/// report after the third), no further generation runs; set by another thread while a
/// generation of 1,000,000 particles runs, that generation is dropped within moments.
#[test]
fn a_cancelled_search_stops_at_the_next_particle_step() {
    use mdg_guided::Cancel;
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let cancel = Cancel::new();
    cancel.cancel();
    let r = p.search(&SearchOptions { cancel: Some(cancel), ..opts(1) }, None);
    assert_eq!((r.stop, r.generations, r.particle_steps), (Stop::Cancelled, 0, 0));

    let cancel = Cancel::new();
    let after_three = |pr: &mdg_guided::Progress| {
        if pr.generation == 3 {
            cancel.cancel();
        }
    };
    let r = p.search(&SearchOptions { cancel: Some(cancel.clone()), ..opts(1) }, Some(&after_three));
    assert_eq!((r.stop, r.generations), (Stop::Cancelled, 3));
    assert!(!r.model.bones.is_empty(), "the best of the three generations is kept");

    let cancel = Cancel::new();
    let big = SearchOptions { particles: (20, 1_000_000), generations: 2, cancel: Some(cancel.clone()), ..opts(1) };
    // The cancel comes 150 ms into the second generation, whatever the machine's
    // load made of the first (a full second generation takes seconds).
    let first_done = std::sync::atomic::AtomicBool::new(false);
    let note_first = |pr: &mdg_guided::Progress| {
        if pr.generation == 1 {
            first_done.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    };
    let started = std::time::Instant::now();
    let r = std::thread::scope(|s| {
        s.spawn(|| {
            while !first_done.load(std::sync::atomic::Ordering::SeqCst) {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            std::thread::sleep(std::time::Duration::from_millis(150));
            cancel.cancel();
        });
        p.search(&big, Some(&note_first))
    });
    let took = started.elapsed();
    assert_eq!((r.stop, r.generations), (Stop::Cancelled, 1), "the cut generation is dropped");
    // The dropped generation shows the cancel cut it short (a full one of 1,000,000
    // particles takes seconds); the time itself is only printed.
    eprintln!("took {took:?}");
}

#[test]
fn expected_vectors_point_along_the_branches() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    for name in ["branch", "fork", "tree"] {
        let e = p.expected(rule(&b, name)).expect("estimated");
        assert!(e.z > 0.15, "{name}: {e:?}");
        assert!(e.x.abs().max(e.y.abs()) * 3.0 < e.z, "{name}: the twist averages out sideways: {e:?}");
    }
    assert!(p.expected(rule(&b, "leaf")).is_none(), "not a skeleton rule");
}

/// Mean x of the bone tips of the model found with `guides`.
fn mean_tip_x(b: &Bundle, guides: &[Guide], seed: u64) -> f64 {
    let t = table(b);
    let p = Prepared::new(b, &t, guides).expect("prepared");
    let r = p.search(&SearchOptions { particles: (60, 15), generations: 60, ..opts(seed) }, None);
    let bones = &r.model.bones;
    assert!(!bones.is_empty(), "seed {seed}: no bones");
    bones.iter().map(|b| b.tip.x).sum::<f64>() / bones.len() as f64
}

#[test]
fn models_follow_their_guides() {
    let b = std_tree();
    // A trunk leaning to x = dx·1.8 and an arm further out, as long as the std guides.
    let lean = |dx: f64| {
        let trunk = Guide::new(
            "",
            vec![
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 1.5],
                [dx * 0.3, 0.0, 3.0],
                [dx * 0.8, 0.0, 4.0],
                [dx * 1.3, 0.0, 5.0],
                [dx * 1.8, 0.0, 5.6],
                [dx * 2.4, 0.0, 6.0],
            ],
        );
        let arm = Guide::new(
            "",
            vec![[dx * 0.2, 0.0, 2.5], [dx * 1.0, 0.0, 3.0], [dx * 2.0, 0.0, 3.4], [dx * 3.0, 0.0, 4.6]],
        );
        vec![trunk, arm]
    };
    let (mut right, mut left) = (0.0, 0.0);
    for seed in 1..=5 {
        let (r, l) = (mean_tip_x(&b, &lean(2.0), seed), mean_tip_x(&b, &lean(-2.0), seed));
        assert!(r > l, "seed {seed}: mean tip x {r} (right guides), {l} (left guides)");
        right += r / 5.0;
        left += l / 5.0;
    }
    assert!(right > 0.4 && left < -0.4, "mean tip x {right} (right guides), {left} (left guides)");
}

#[test]
fn search_beats_unguided_sampling_on_distance() {
    // The searched tree's bones lie closer to the guides than those of plain (unguided) trees.
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let mean_dist = |bones: &[mdg_guided::search::Bone]| {
        bones.iter().filter_map(|x| p.guides().nearest(x.base)).map(|n| n.dist).sum::<f64>() / bones.len() as f64
    };
    let mut guided = 0.0;
    let mut unguided = 0.0;
    for seed in 1..=4 {
        guided += mean_dist(&p.search(&opts(seed), None).model.bones);
        // One forward sample of as many steps: a tree grown without looking at the guides.
        let f = p.forward_best(1, 40, seed, None);
        unguided += mean_dist(&f.model.bones);
    }
    assert!(guided < unguided * 0.8, "guided {guided} vs unguided {unguided}");
}

fn common<'a>(file: &'a std::path::Path, stats: bool) -> Common<'a> {
    Common {
        file,
        output: None,
        seed: Some(3),
        stats,
        png: None,
        size: (64, 48),
        pictures: &mdg_cli::pictures::Software,
        eval: EvalOptions::default(),
        compile: Box::leak(Box::default()),
    }
}

#[test]
fn mdg_run_mode_exports_the_model_with_bones_and_guides() {
    let b = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    let args = GuidedArgs { generations: Some(30), particles: Some("30:10".into()), ..GuidedArgs::default() };
    let out = mdg_cli::modes::guided::run(&b, &args, &common(&file, true), &EvalOptions::default()).expect("runs");
    assert!(out.vertex_mesh().n_vertices() > 0);
    let guides: Vec<_> = out.lines.iter().filter(|l| l.namespace == "guides").collect();
    assert_eq!(guides.len(), 3);
    assert_eq!(guides[0].points[0], [0.0, 0.0, 0.0]);
    let bones = out.lines.iter().filter(|l| l.namespace == "bones").count();
    assert!(bones > 0);
    assert!(out.lines.iter().filter(|l| l.namespace == "bones").all(|l| l.points.len() == 2));
    // Same seed and options, same model.
    let again = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert_eq!(again.vertex_mesh(), out.vertex_mesh());
    let bare = GuidedArgs { no_skeleton_lines: true, ..args };
    let plain = mdg_cli::modes::guided::run(&b, &bare, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert!(plain.lines.is_empty());
    // The bundle evaluated without the search is a random tree (what the viewer shows).
    assert!(evaluate(&b, &EvalOptions::default()).vertex_mesh().n_vertices() > 0);
}

#[test]
fn guide_files_replace_the_source_guides() {
    let b = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    for name in ["arch", "windswept"] {
        let path = root().join(format!("std/examples/guides/{name}.json"));
        let text = std::fs::read_to_string(&path).expect("example guide file");
        let want = mdg_guided::guides_from_json(&text).expect("valid");
        let args = GuidedArgs { guides: Some(path), generations: Some(20), ..GuidedArgs::default() };
        let out = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
        let lines: Vec<_> = out.lines.iter().filter(|l| l.namespace == "guides").collect();
        assert_eq!(lines.len(), want.len(), "{name}");
        let first = want[0].points[0].map(|c| c as f32);
        assert_eq!(lines[0].points[0], first, "{name}");
    }
    let dir = std::env::temp_dir().join(format!("mdg-guided-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bad = dir.join("bad.json");
    std::fs::write(&bad, r#"{"guides": [{"points": [[0,0,0],[0,0,1]], "delta_a": 0.5}]}"#).expect("write");
    let args = GuidedArgs { guides: Some(bad.clone()), ..GuidedArgs::default() };
    let err = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default())
        .expect_err("too few points");
    assert!(err.message.contains("bad.json") && err.message.contains("at least 4"), "{err}");
    assert_eq!(err.exit, mdg_cli::failure::Exit::Input, "read and refused: an error in the input");
    let args = GuidedArgs { guides: Some(dir.join("missing.json")), ..GuidedArgs::default() };
    let err =
        mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect_err("missing");
    assert!(err.message.contains("cannot read") && err.exit == mdg_cli::failure::Exit::Usage, "{err:?}");
    let args = GuidedArgs { budget: Some("soon".into()), ..GuidedArgs::default() };
    let err =
        mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect_err("budget");
    assert!(err.message.contains("--budget") && err.exit == mdg_cli::failure::Exit::Usage, "{err:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn expander_returns_the_calls_a_body_makes() {
    let b = build_source(
        "startshape A
         rule A { 3 * {x 1} B {s 0.5} C {z 2} \\ C {y 1} VERTEX {} VERTEX {x 1} VERTEX {y 1} }
         rule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
         rule C { B {} }",
    );
    let mut ex = Expander::new(&b);
    let mut out = Vec::new();
    assert!(ex.expand(&Call::start(&b), &mut out));
    let (rb, rc) = (rule(&b, "B"), rule(&b, "C"));
    let got: Vec<(u32, [f32; 3], u32)> = out.iter().map(|c| (c.rule, c.state.f.u.to_array(), c.depth)).collect();
    assert_eq!(
        got,
        vec![
            (rb, [1.0, 0.0, 0.0], 1),
            (rb, [2.0, 0.0, 0.0], 1),
            (rb, [3.0, 0.0, 0.0], 1),
            (rc, [0.0, 0.0, 2.0], 1),
            // `\`: the second C continues from the first call's own frame.
            (rc, [0.0, 1.0, 2.0], 1),
        ]
    );
    assert!((out[0].state.f.scale_factor() - 0.5).abs() < 1e-6);
    // Evaluating the start call alone is plain evaluation.
    let plain = evaluate(&b, &EvalOptions::default());
    let calls = evaluate_calls(&b, &EvalOptions::default(), &[Call::start(&b)]);
    assert_eq!(plain.vertex_mesh(), calls.vertex_mesh());
}

#[test]
fn evaluate_calls_matches_evaluate_on_std_examples() {
    for name in ["tree", "sphereflake", "koch_snowflake"] {
        let a = analyze_file(&root().join(format!("std/examples/{name}.mdg")), true);
        let b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
        let o = EvalOptions::default();
        let (x, y) = (evaluate(&b, &o), evaluate_calls(&b, &o, &[Call::start(&b)]));
        assert_eq!(x.vertex_mesh(), y.vertex_mesh(), "{name}");
        assert_eq!(x.sweeps, y.sweeps, "{name}");
        assert_eq!(x.lines, y.lines, "{name}");
        assert_eq!(x.instances.len(), y.instances.len(), "{name}");
    }
}

#[test]
fn closest_guide_distance_is_exact_on_a_straight_guide() {
    // The cost's DIST on a straight, evenly parameterised guide is the distance to the line.
    let g = Guide::new("", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]);
    let set = mdg_guided::cost::Guides::new(&[g]).expect("guides");
    for (p, want) in [([1.0, 0.0, 1.0], 1.0), ([0.0, -2.5, 2.9], 2.5), ([3.0, 4.0, 1.5], 5.0)] {
        let n = set.nearest(DVec3::from_array(p)).expect("near");
        assert!((n.dist - want).abs() < 1e-12, "{p:?}: {}", n.dist);
    }
}

/// `mdg-run` runs every generation unless `--budget` is given: the `search`
/// section's `budget` (here 1 ms, far less than 3,000 generations take) is for
/// interactive use, so a batch run gives the same model on any machine. An explicit
/// `--budget` still ends the search, with its warning.
#[test]
fn mdg_run_ignores_the_section_budget_and_honours_an_explicit_one() {
    let src = std::fs::read_to_string(root().join("std/examples/guided_tree.mdg")).expect("example");
    assert!(src.contains("budget 200;") && src.contains("generations 100;"));
    let src = src.replace("budget 200;", "budget 1;").replace("generations 100;", "generations 3000;");
    let b = mdg_tests::build_source(&src);
    let file = root().join("std/examples/guided_tree.mdg");
    let warned =
        |out: &mdg_vm::output::Output| out.stats.warnings.iter().any(|w| w.contains("time budget ended the search"));
    let args = GuidedArgs::default();
    let out = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert!(!warned(&out), "{:?}", out.stats.warnings);
    let again = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert_eq!(again.vertex_mesh(), out.vertex_mesh(), "the same model every run");
    let args = GuidedArgs { budget: Some("1ms".into()), ..GuidedArgs::default() };
    let cut = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert!(warned(&cut), "{:?}", cut.stats.warnings);
}

/// Careless guides: one of zero length is a warning (it attracts nothing), a
/// `segment` that would cut a guide into more than 2^20 utilisation segments is an
/// error naming the guide (it used to be clamped silently), and a search that grows
/// no bones says so.
#[test]
fn careless_guides_and_boneless_searches_are_reported() {
    let b = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    let dir = std::env::temp_dir().join(format!("mdg-guided-careless-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let write = |name: &str, json: &str| {
        let p = dir.join(name);
        std::fs::write(&p, json).expect("write");
        p
    };
    let run = |guides: std::path::PathBuf| {
        let args = GuidedArgs { guides: Some(guides), generations: Some(10), ..GuidedArgs::default() };
        mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default())
    };
    let zero = write(
        "zero.json",
        r#"{"guides": [{"name": "dot", "points": [[1,1,1],[1,1,1],[1,1,1],[1,1,1]]}, {"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]]}]}"#,
    );
    let out = run(zero).expect("runs");
    assert!(
        out.stats.warnings.iter().any(|w| w.contains("dot has zero length: it attracts nothing")),
        "{:?}",
        out.stats.warnings
    );
    let fine =
        write("fine.json", r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]], "segment": 0.000001}]}"#);
    let e = run(fine).expect_err("too many segments");
    assert!(e.message.contains("guide 1: `segment` 0.000001 cuts the guide (length 3.0000) into 3000000 utilisation segments, more than 1048576"), "{e}");

    // A skeleton rule whose calls never move: no bone is ever made.
    let flat = mdg_tests::build_source(
        "startshape A\nmaxdepth 20\nsearch { skeleton A; generations 5; particles 4; }\n\
         guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }\nrule A { A {} leaf {} }\nrule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n",
    );
    let args = GuidedArgs::default();
    let out = mdg_cli::modes::guided::run(&flat, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    assert!(out.stats.warnings.iter().any(|w| w.contains("the model has no bones")), "{:?}", out.stats.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The paper's Appendix A grammar ships as written: the start is an ordinary branch
/// (bent 0–80°), `maybe_branch` is 1 : 1, and a search grows a skeleton from it.
#[test]
fn the_papers_own_tree_grammar_searches() {
    let path = root().join("std/examples/guided_tree_paper.mdg");
    let text = std::fs::read_to_string(&path).expect("example");
    assert!(
        text.contains("branch {rz rand(0, 360) rx rand(0, 80) s (0.7 * rand(0.9, 1.3))}\n}"),
        "the start is a branch"
    );
    assert!(text.contains("rule maybe_branch 1 {\n  branch") && text.contains("rule maybe_branch 1 {\n}"), "1 : 1");
    let a = analyze_file(&path, true);
    assert!(!a.has_errors(), "{}", mdg_tests::render(&a));
    let b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let r = p.search(&opts(4), None);
    assert!(r.model.bones.len() >= 3, "{} bones", r.model.bones.len());
    assert_eq!(r.model.cost.total(), p.search(&opts(4), None).model.cost.total(), "deterministic");
}

/// `--utilisation`: `paper` or `local` (the default); they pick different models;
/// anything else is an error naming the flag.
#[test]
fn the_utilisation_term_is_chosen_by_name() {
    let b = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    let run = |u: Option<&str>| {
        let args = GuidedArgs { utilisation: u.map(str::to_string), generations: Some(30), ..GuidedArgs::default() };
        mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default())
    };
    let default = run(None).expect("runs");
    assert_eq!(run(Some("local")).expect("runs").vertex_mesh(), default.vertex_mesh());
    assert_ne!(run(Some("paper")).expect("runs").vertex_mesh(), default.vertex_mesh());
    let e = run(Some("eq7")).expect_err("unknown");
    assert_eq!(e, mdg_cli::failure::Failure::usage("--utilisation eq7: expected `paper` or `local`"));
}

/// The std tree's source with `line` added to its `search` section.
fn std_tree_with(line: &str) -> Bundle {
    let text = std::fs::read_to_string(root().join("std/examples/guided_tree.mdg")).expect("std tree");
    let text = text.replacen("search {\n", &format!("search {{\n  {line}\n"), 1);
    assert!(text.contains(line));
    mdg_tests::build_source(&text)
}

/// `utilisation` in the `search` section: the same models as `--utilisation`, and
/// the flag overrides it.
#[test]
fn the_utilisation_key_equals_the_flag_and_the_flag_overrides_it() {
    let plain = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    let run = |b: &Bundle, u: Option<&str>| {
        let args = GuidedArgs { utilisation: u.map(str::to_string), generations: Some(30), ..GuidedArgs::default() };
        mdg_cli::modes::guided::run(b, &args, &common(&file, false), &EvalOptions::default()).expect("runs")
    };
    for (term, other) in [("local", "paper"), ("paper", "local")] {
        let keyed = std_tree_with(&format!("utilisation {term};"));
        let t = table(&keyed);
        assert_eq!(t.settings.utilisation, mdg_guided::Utilisation::from_name(term));
        // The key survives the bundle's bytes.
        let back = mdg_vm::bundle::load(&mdg_vm::bundle::encode(&keyed)).expect("round trip");
        assert_eq!(
            GuidedTable::from_bundle(&back).expect("a valid section").expect("table").settings.utilisation,
            t.settings.utilisation
        );
        let by_key = run(&keyed, None).vertex_mesh();
        assert_eq!(by_key, run(&plain, Some(term)).vertex_mesh(), "key {term} = flag {term}");
        assert_eq!(run(&keyed, Some(other)).vertex_mesh(), run(&plain, Some(other)).vertex_mesh(), "flag wins");
        assert_ne!(by_key, run(&keyed, Some(other)).vertex_mesh(), "{term} and {other} differ here");
    }
    // A program without the key leaves it out of the bundle (older bundles read the same).
    assert_eq!(table(&plain).settings.utilisation, None);
}

/// The default model is the lowest-cost model of any generation, or the final
/// generation's best when that uses more guide segments: never narrower than either,
/// and on the std guides often wider than the lowest-cost one.
#[test]
fn the_default_model_is_the_wider_of_the_lowest_cost_and_the_last() {
    let b = std_tree();
    let t = table(&b);
    let p = Prepared::new(&b, &t, &t.guides).expect("prepared");
    let mut wider = 0;
    for seed in 1..=6 {
        let pick = |choice| p.search(&SearchOptions { choice, ..opts(seed) }, None).model;
        let (lowest, last, model) =
            (pick(ModelChoice::LowestCost), pick(ModelChoice::Last), pick(ModelChoice::default()));
        let (l, f, m) = (p.segments_used(&lowest.bones), p.segments_used(&last.bones), p.segments_used(&model.bones));
        assert_eq!(m, l.max(f), "seed {seed}: {m} segments; lowest cost {l}, last {f}");
        let same = if f > l { &last } else { &lowest };
        assert_eq!(model.bones.len(), same.bones.len(), "seed {seed}");
        wider += usize::from(m > l);
    }
    assert!(wider >= 2, "the default took a wider model than the lowest cost in {wider} of 6 searches");
}

/// Coverage of a guide file's guides: the default search against one unguided
/// derivation (a forward sample of as many particle-steps), per seed.
fn coverages(b: &Bundle, file: &str, seeds: std::ops::RangeInclusive<u64>) -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(root().join(file)).expect("guide file");
    let guides = mdg_guided::guides_from_json(&text).expect("valid");
    let t = table(b);
    let p = Prepared::new(b, &t, &guides).expect("prepared");
    let o = SearchOptions::from_settings(&t.settings, 0);
    let cover = |bones: &[mdg_guided::search::Bone]| mdg_guided::measure::coverage(p.guides(), bones).total;
    let (mut guided, mut unguided) = (Vec::new(), Vec::new());
    for seed in seeds {
        guided.push(cover(&p.search(&SearchOptions { seed, budget: None, ..o.clone() }, None).model.bones));
        unguided.push(cover(&p.forward_best(1, o.generations, seed, None).model.bones));
    }
    (guided, unguided)
}

/// On curved guides (an S-curve, a spiral and a helix drawn for this, in
/// `tests/guides/`) the default search covers at least 0.3 of the guides and 1.5
/// times what unguided trees do (seeds 1–6, the std tree's own search settings).
/// With the paper's utilisation term and the lowest-cost model (the default before)
/// the spiral and helix fail it (docs/guided.md, "Coverage").
#[test]
fn the_default_search_follows_curved_guides() {
    let b = std_tree();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    for file in ["tests/guides/s_curve.json", "tests/guides/spiral.json", "tests/guides/helix.json"] {
        let (guided, unguided) = coverages(&b, file, 1..=6);
        let (g, u) = (mean(&guided), mean(&unguided));
        eprintln!("{file}: coverage {g:.3} guided, {u:.3} unguided");
        assert!(g >= 0.3 && g >= 1.5 * u, "{file}: coverage {g:.3} guided against {u:.3} unguided ({guided:?})");
    }
}

/// A guide (or its part) beyond the grammar's reach is reported by `mdg-run`, with
/// how far; the std example's own guides, and its guide files, are not.
#[test]
fn guides_beyond_the_grammars_reach_are_reported() {
    let b = std_tree();
    let file = root().join("std/examples/guided_tree.mdg");
    // (The reach is sampled with as many particle-steps as the search has generations:
    // the std tree's 100.)
    let out = mdg_cli::modes::guided::run(&b, &GuidedArgs::default(), &common(&file, false), &EvalOptions::default())
        .expect("runs");
    let far: Vec<&String> = out.stats.warnings.iter().filter(|w| w.contains("reach")).collect();
    assert!(far.is_empty(), "the std guides are reachable: {far:?}");
    for name in ["arch", "windswept"] {
        let args = GuidedArgs {
            guides: Some(root().join(format!("std/examples/guides/{name}.json"))),
            ..GuidedArgs::default()
        };
        let out = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
        assert!(!out.stats.warnings.iter().any(|w| w.contains("reach")), "{name}: {:?}", out.stats.warnings);
    }
    // A trunk guide drawn up to z 12, and one far off to the side.
    let dir = std::env::temp_dir().join(format!("mdg-reach-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("far.json");
    std::fs::write(
        &path,
        r#"{"guides": [{"name": "tall", "points": [[0,0,0],[0,0,4],[0,0,8],[0,0,12]]},
                       {"name": "aside", "points": [[20,0,0],[20,0,1],[20,0,2],[20,0,3]]}]}"#,
    )
    .expect("write");
    let args = GuidedArgs { guides: Some(path), generations: Some(20), ..GuidedArgs::default() };
    let out = mdg_cli::modes::guided::run(&b, &args, &common(&file, false), &EvalOptions::default()).expect("runs");
    let far: Vec<&String> = out.stats.warnings.iter().filter(|w| w.contains("beyond the grammar's reach")).collect();
    assert_eq!(far.len(), 2, "{:?}", out.stats.warnings);
    // `tall` from about half way (the reach is about 6 of its 12), up to about 6 beyond.
    assert!(
        far[0].starts_with("guided search: tall: 0.4") || far[0].starts_with("guided search: tall: 0.5"),
        "{}",
        far[0]
    );
    assert!(
        far[0].contains("1.00 of its length") && (far[0].contains("up to 5.") || far[0].contains("up to 6.")),
        "{}",
        far[0]
    );
    // `aside` all of it, 14 to 17 beyond.
    assert!(far[1].starts_with("guided search: aside: 0.00–1.00 of its length"), "{}", far[1]);
    let _ = std::fs::remove_dir_all(&dir);
}
