//! Seeded calls (`R {seed N}`, issue 41): a call's sub-derivation draws from the
//! stream of (run seed, N), and its caller's stream goes on as if it drew nothing.

use mdg_tests::build_source;
use mdg_vm::eval::{evaluate, EvalOptions};

/// A random, branching walk of cubes (its shape depends on every draw).
const WALK: &str = "@import primitives\nmaxdepth 12\n\
    rule W { cube {s 0.3} W {y 0.5 s 0.95 rz rand(-40, 40)} }\n\
    rule W 0.3 { cube {s 0.3} W {y 0.5 rz 30 s 0.8} W {y 0.5 rz -30 s 0.8} }\n";

/// The translations of the cubes whose x lies in `lo..hi`, moved by `-lo`, in order.
fn cubes_in(out: &mdg_vm::output::Output, lo: f32, hi: f32) -> Vec<[f32; 3]> {
    out.instances
        .iter()
        .map(|i| out.instance_transform(&i).w_axis)
        .filter(|w| w.x >= lo - 20.0 && w.x < hi - 20.0)
        .map(|w| [w.x - lo, w.y, w.z])
        .collect()
}

fn run(src: &str, seed: u64) -> mdg_vm::output::Output {
    let b = build_source(&format!("startshape S\n{WALK}{src}"));
    evaluate(&b, &EvalOptions { seed: Some(seed), ..EvalOptions::default() })
}

fn close(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.iter().zip(q).all(|(u, v)| (u - v).abs() < 1e-3))
}

#[test]
fn same_seed_same_subtree_other_seed_another() {
    let out = run("rule S { W {seed 5} W {x 100 seed 5} W {x 200 seed 6} W {x 300} W {x 400} }\n", 1);
    let (a, b, c) = (cubes_in(&out, 0.0, 100.0), cubes_in(&out, 100.0, 200.0), cubes_in(&out, 200.0, 300.0));
    assert!(a.len() > 3, "the walk draws something: {a:?}");
    assert!(close(&a, &b), "`seed 5` twice grows the same walk:\n{a:?}\n{b:?}");
    assert!(!close(&a, &c), "`seed 6` grows another");
    // Unseeded calls draw from the running stream: two in a row differ.
    assert!(!close(&cubes_in(&out, 300.0, 400.0), &cubes_in(&out, 400.0, 500.0)));
}

#[test]
fn the_caller_stream_goes_on_as_if_the_seeded_call_drew_nothing() {
    let with = run("rule S { W {seed 5} W {x 100} }\n", 3);
    let without = run("rule S { W {x 100} }\n", 3);
    let after = cubes_in(&with, 100.0, 200.0);
    assert!(after.len() > 3);
    assert!(close(&after, &cubes_in(&without, 100.0, 200.0)));
}

#[test]
fn the_seeded_stream_is_a_function_of_the_run_seed_and_n() {
    let src = "rule S { W {seed 5} }\n";
    let (a, b) = (run(src, 7), run(src, 7));
    assert_eq!(cubes_in(&a, 0.0, 100.0), cubes_in(&b, 0.0, 100.0), "deterministic");
    assert!(!close(&cubes_in(&a, 0.0, 100.0), &cubes_in(&run(src, 8), 0.0, 100.0)), "another run seed");
    // A seed computed at run time: the same value gives the same stream (both walks
    // start at depth 2, as `maxdepth` counts from the start shape).
    let constant = run("rule S { P {} }\nrule P { W {seed 5} }\n", 7);
    let by_param = run("rule S { P(5) {} }\nrule P(int k) { W {seed (k * 1)} }\n", 7);
    assert!(close(&cubes_in(&constant, 0.0, 100.0), &cubes_in(&by_param, 0.0, 100.0)));
}

#[test]
fn seeded_calls_nest_and_restore_in_order() {
    // An outer seeded call whose sub-tree holds seeded calls: still replayed whole.
    let src = "rule S { O {seed 1} O {x 100 seed 1} }\nrule O { W {seed 2} W {x 10} W {x 20 seed 3} }\n";
    let out = run(src, 11);
    let (a, b) = (cubes_in(&out, 0.0, 100.0), cubes_in(&out, 100.0, 200.0));
    assert!(a.len() > 9);
    assert!(close(&a, &b));
}

#[test]
fn breadth_first_runs_replay_seeded_sub_trees_too() {
    // Under `breadthfirst` a seeded call's sub-tree is spread over generations and
    // interleaved with other calls: it keeps its own stream (drawn in its own
    // breadth-first order), so `seed 5` twice still grows the same walk.
    let src = "breadthfirst\nrule S { W {seed 5} W {x 100 seed 5} W {x 200 seed 6} W {x 300} W {x 400} }\n";
    let out = run(src, 1);
    assert!(!out.stats.warnings.iter().any(|w| w.contains("seed")), "{:?}", out.stats.warnings);
    let (a, b, c) = (cubes_in(&out, 0.0, 100.0), cubes_in(&out, 100.0, 200.0), cubes_in(&out, 200.0, 300.0));
    assert!(a.len() > 3, "the walk draws something: {a:?}");
    assert!(close(&a, &b), "`seed 5` twice grows the same walk:\n{a:?}\n{b:?}");
    assert!(!close(&a, &c), "`seed 6` grows another");
    assert!(!close(&cubes_in(&out, 300.0, 400.0), &cubes_in(&out, 400.0, 500.0)));
    // Nested seeds, as depth first; and a seeded sub-tree does not depend on what
    // else is in the queue (here an extra unseeded walk before it).
    let nested =
        "breadthfirst\nrule S { O {seed 1} O {x 100 seed 1} }\nrule O { W {seed 2} W {x 10} W {x 20 seed 3} }\n";
    let out = run(nested, 11);
    let (a, b) = (cubes_in(&out, 0.0, 100.0), cubes_in(&out, 100.0, 200.0));
    assert!(a.len() > 9 && close(&a, &b));
    let alone = run("breadthfirst\nrule S { W {x 100 seed 5} }\n", 1);
    let crowded = run("breadthfirst\nrule S { W {x 300} W {x 100 seed 5} }\n", 1);
    assert!(close(&cubes_in(&alone, 100.0, 200.0), &cubes_in(&crowded, 100.0, 200.0)));
}
