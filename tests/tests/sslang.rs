//! Structure Synth's evaluation in MDG (issue 41): breadth-first order with
//! `maxobjects`, checked on the output's geometry.

use mdg_tests::{build_source, run_source};
use mdg_vm::eval::{evaluate, EvalOptions};

/// The z of each instance (the triangle rules below are prototypes), in output order.
fn first_z(out: &mdg_vm::output::Output) -> Vec<f32> {
    out.instances.iter().map(|i| out.instance_transform(&i).w_axis.z).collect()
}

/// A triangle at height z: `rule T { VERTEX {} VERTEX {x 1} VERTEX {y 1} }` under `{z …}`.
const TRI: &str = "rule T { VERTEX {} VERTEX {x 0.1} VERTEX {y 0.1} }\n";

#[test]
fn breadth_first_draws_generation_by_generation() {
    // Two branches that each climb: depth first draws one whole branch (z 1, 2, 3)
    // before the other (z 10, 11, 12); breadth first alternates by generation.
    let grammar = |order: &str| {
        format!(
            "startshape S\n{order}\nmaxdepth 4\n{TRI}rule S {{ A {{z 1}} A {{z 10}} }}\nrule A {{ T {{}} A {{z 1}} }}\n"
        )
    };
    let depth = run_source(&grammar(""));
    assert_eq!(first_z(&depth), vec![1.0, 2.0, 3.0, 10.0, 11.0, 12.0]);
    let breadth = run_source(&grammar("breadthfirst"));
    assert_eq!(first_z(&breadth), vec![1.0, 10.0, 2.0, 11.0, 3.0, 12.0]);
}

#[test]
fn maxobjects_ends_after_the_generation_and_says_so() {
    // Ten arms that never end by themselves: one cube per arm per generation.
    let src = "startshape arms\nbreadthfirst\nmaxobjects 95\n@import primitives\n\
               rule arms { 10 * {rz 36} arm {} }\nrule arm { cube {s 0.5} arm {x 0.6 rz 10 s 0.97} }\n";
    let out = run_source(src);
    // The generation that draws the 95th cube is finished: 100 cubes.
    assert_eq!(out.stats.triangles, 100 * 12, "{:?}", out.stats.warnings);
    let w = out.stats.warnings.iter().find(|w| w.starts_with("maxobjects 95 reached")).expect("a maxobjects warning");
    assert!(w.contains("100 objects drawn by the end of generation 11"), "{w}");
    assert!(w.contains("the 20 queued call(s) of generation 12"), "{w}");
}

#[test]
fn breadth_first_is_deterministic_and_follows_the_seed() {
    let src = "startshape S\nbreadthfirst\nmaxobjects 300\n@import primitives\n\
               rule S { 4 * {rz 90} B {} }\nrule B { cube {s 0.3} B {x 0.5 rz rand(-30, 30) s 0.95} }\n\
               rule B 0.2 { cube {s 0.3} B {x 0.5 rz 40} B {x 0.5 rz -40} }\n";
    let b = build_source(src);
    let run = |seed| {
        let out = evaluate(&b, &EvalOptions { seed: Some(seed), ..EvalOptions::default() });
        let at: Vec<[f32; 16]> = out.instances.iter().map(|i| out.instance_transform(&i).to_cols_array()).collect();
        (at, out.stats.triangles)
    };
    assert_eq!(run(3), run(3), "same seed, same output");
    assert_ne!(run(3).0, run(4).0, "another seed, another structure");
}

#[test]
fn breadth_first_passes_arguments_and_keeps_depth_limits() {
    // Arguments travel with the queued call; `maxdepth` is the generation limit.
    let src = format!(
        "startshape S\nbreadthfirst\nmaxdepth 4\n{TRI}rule S {{ A(5) {{}} }}\n\
         rule A(int n) {{ T {{z (n)}} A(n + 1) {{}} }}\n"
    );
    let out = run_source(&src);
    assert_eq!(first_z(&out), vec![5.0, 6.0, 7.0]);
    assert!(out.stats.warnings.iter().any(|w| w.starts_with("maxdepth 4 reached")), "{:?}", out.stats.warnings);
}

/// Cubes (12 triangles each) and spheres of a run: both are instances, and only
/// the cubes have triangles in the statistics.
fn cubes_and_spheres(out: &mdg_vm::output::Output) -> (u64, u64) {
    let cubes = out.stats.triangles / 12;
    (cubes, out.instances.len() as u64 - cubes)
}

#[test]
fn rule_local_maxdepth_retires_into_the_other_rule() {
    // A runs 3 times on the path S → A → B → A → B → A (through B, as Structure
    // Synth counts a definition's runs on the path); the 4th call of A runs E.
    let src = |order: &str| {
        format!(
            "startshape S\n{order}\n@import primitives\nrule S {{ A {{}} }}\n\
             rule A maxdepth 3 > E {{ cube {{s 0.2}} B {{x 1}} }}\nrule B {{ A {{}} }}\nrule E {{ SPHERE {{s 0.5}} }}\n"
        )
    };
    let depth = run_source(&src(""));
    assert_eq!(cubes_and_spheres(&depth), (3, 1), "{:?}", depth.stats.warnings);
    assert!(depth.stats.warnings.is_empty(), "{:?}", depth.stats.warnings);
    // Breadth first, the queued calls carry their path's counts: the same structure.
    let breadth = run_source(&src("breadthfirst"));
    assert_eq!(cubes_and_spheres(&breadth), (3, 1));
}

#[test]
fn rule_local_maxdepth_counts_each_path_and_each_definition() {
    // A binary tree retired after 4 levels: 1 + 2 + 4 + 8 cubes, and 16 spheres
    // where the 5th level would be (each branch counts its own path).
    let src = "startshape A\n@import primitives\n\
               rule A maxdepth 4 > E { cube {s 0.2} A {x 1 rz 30} A {x 1 rz -30} }\nrule E { SPHERE {s 0.1} }\n";
    assert_eq!(cubes_and_spheres(&run_source(src)), (15, 16));
    // Without `> OTHER` the retired calls run nothing, and a warning says so.
    let bare = run_source(&src.replace(" > E", ""));
    assert_eq!(cubes_and_spheres(&bare), (15, 0));
    assert!(
        bare.stats.warnings.iter().any(|w| w.contains("16 call(s) of a retired definition")),
        "{:?}",
        bare.stats.warnings
    );
}
