//! NaN and infinity computed by a grammar (issue 35): `log(-1)`, `0/0`, `sqrt(x - 1)`
//! and `1e308 * 10` are one expression away, and every place that takes a computed
//! number must survive them — no panic in the compiler's constant folding, in
//! evaluation (adjustments, `if`, isosurface functions), or in a bundle run — and
//! the compiled bundle must run as the source does.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::{analyze_text, Analysis};
use mdg_compiler::expand::Options;
use mdg_compiler::source::MemLoader;
use mdg_tests::{build_source, run_source};
use mdg_vm::bundle::{self, Bundle};
use mdg_vm::eval::{evaluate, EvalOptions};
use mdg_vm::output::Output;
use std::path::Path;

/// Compiled, encoded and decoded: what `mdgc build` writes and `mdg-run FILE.mdgb` runs.
fn through_a_bundle(b: &Bundle) -> Bundle {
    bundle::load(&bundle::encode(b)).expect("the bundle loads")
}

fn analyze_mem(text: &str) -> Analysis {
    analyze_text(
        &MemLoader::default(),
        Path::new("/nan/main.mdg"),
        text,
        &Options::default(),
        CheckOptions { require_start: true },
    )
}

fn positions(out: &Output) -> Vec<[f32; 3]> {
    out.flattened().positions
}

/// The bits of every position, so NaN compares equal to NaN.
fn bits(out: &Output) -> Vec<[u32; 3]> {
    positions(out).iter().map(|p| p.map(f32::to_bits)).collect()
}

// ---------------------------------------------------------------- clamp with NaN bounds

/// `t` is 0: `sqrt(t - 1)` and `log(t - 1)` are NaN at run time.
const CLAMP_IN_AN_ADJUSTMENT: &str = "startshape A
rule A { B(0) {} }
rule B(float t) { VERTEX {} VERTEX {x 1} VERTEX {y clamp(1, sqrt(t - 1), log(t - 1)) x 2} }
";

#[test]
fn clamp_with_nan_bounds_in_an_adjustment_runs() {
    let out = run_source(CLAMP_IN_AN_ADJUSTMENT);
    // The NaN argument is used as 0 (as an infinite one is); `x 2` still applies.
    assert_eq!(positions(&out), vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]);
}

const CLAMP_IN_AN_IF: &str = "startshape A
rule A { B(0) {} }
rule B(float t) {
  if (clamp(1, sqrt(t - 1), log(t - 1)) > 0) { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
  else { VERTEX {} VERTEX {x 2} VERTEX {y 2} }
}
";

#[test]
fn clamp_with_nan_bounds_in_an_if_runs_and_nan_is_false() {
    let out = run_source(CLAMP_IN_AN_IF);
    // clamp(…) is NaN, NaN > 0 is false: the else branch.
    assert_eq!(positions(&out), vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]);
}

const CLAMP_IN_AN_ISOSURFACE: &str = "startshape A
isosurface BALL { xyz -1 1 8 ; function { clamp(x*x + y*y + z*z - 0.5, log(-1), 0/0) } }
isosurface CUT { xyz -1 1 8 ; function { clamp(x*x + y*y + z*z - 0.5, -1, log(x)) } }
rule A { BALL {} CUT {} }
";

#[test]
fn clamp_with_nan_bounds_in_an_isosurface_function_runs() {
    let out = run_source(CLAMP_IN_AN_ISOSURFACE);
    let ball = out.shared_meshes.iter().find(|s| s.name == "BALL").expect("BALL built");
    // NaN everywhere: no sign change, no surface.
    assert!(ball.mesh.triangles.is_empty(), "{} triangles", ball.mesh.triangles.len());
    // NaN where x ≤ 0 (log), a surface where x > 0: only part of the sphere.
    let cut = out.shared_meshes.iter().find(|s| s.name == "CUT").expect("CUT built");
    assert!(!cut.mesh.triangles.is_empty());
    assert!(cut.mesh.positions.iter().all(|p| p.iter().all(|c| c.is_finite())));
}

#[test]
fn clamp_with_nan_bounds_runs_from_a_compiled_bundle() {
    for text in [CLAMP_IN_AN_ADJUSTMENT, CLAMP_IN_AN_IF, CLAMP_IN_AN_ISOSURFACE] {
        let b = build_source(text);
        let direct = evaluate(&b, &EvalOptions::default());
        let loaded = evaluate(&through_a_bundle(&b), &EvalOptions::default());
        assert_eq!(bits(&direct), bits(&loaded), "{text}");
    }
}

/// Constant folding: `mdgc build` computes these at compile time (`consteval::eval`
/// for an argument, `lower::fold` for an inlined function with parameters).
const CLAMP_FOLDED: &str = "startshape A
function lim(v, a, b) { clamp(v, a, b) }
isosurface S { xyz -1 1 4 ; function { x*x + y*y + z*z - 0.5 + lim(1, log(-1), 0/0) } }
rule A {
  VERTEX {} VERTEX {x 1} VERTEX {y clamp(1, log(-1), 0/0) x 3}
  VERTEX {} VERTEX {x 1} VERTEX {y lim(1, sqrt(-1), 0/0) x 4}
  S {}
}
";

#[test]
fn clamp_with_nan_bounds_folds_at_compile_time() {
    let a = analyze_mem(CLAMP_FOLDED);
    assert!(!a.has_errors(), "{:?}", a.diagnostics);
    let b = build_source(CLAMP_FOLDED);
    let out = evaluate(&b, &EvalOptions::default());
    let p = positions(&out);
    assert_eq!(p[2], [3.0, 0.0, 0.0]);
    assert_eq!(p[5], [4.0, 0.0, 0.0]);
    let s = out.shared_meshes.iter().find(|s| s.name == "S").expect("S built");
    assert!(s.mesh.triangles.is_empty());
}

/// A constant that folds to NaN or infinity gives what the same value computed at
/// run time gives, and the source and its bundle run alike (the bundle used to hold
/// 0 where the source run had NaN).
#[test]
fn folded_nan_and_infinite_arguments_run_as_computed_ones_and_as_the_bundle() {
    let folded = "startshape A
rule A { VERTEX {} VERTEX {x 1} VERTEX {y (0/0) x 2} VERTEX {} VERTEX {x 1} VERTEX {y (1e308 * 10) x 3} }
";
    let computed = "startshape A
rule A { B(0) {} }
rule B(float t) { VERTEX {} VERTEX {x 1} VERTEX {y (t/t) x 2} VERTEX {} VERTEX {x 1} VERTEX {y (1e308 * 10 + t) x 3} }
";
    let b = build_source(folded);
    let from_source = evaluate(&b, &EvalOptions::default());
    let from_bundle = evaluate(&through_a_bundle(&b), &EvalOptions::default());
    let at_run_time = run_source(computed);
    assert_eq!(bits(&from_source), bits(&from_bundle));
    assert_eq!(bits(&from_source), bits(&at_run_time));
    assert_eq!(positions(&at_run_time)[2], [2.0, 0.0, 0.0]);
    assert_eq!(positions(&at_run_time)[5], [3.0, 0.0, 0.0]);
}

// ---------------------------------------------------------------- @param and --param

fn analyze_with_params(text: &str, params: &[(&str, &str)]) -> Analysis {
    let opts =
        Options { params: params.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(), ..Options::default() };
    analyze_text(&MemLoader::default(), Path::new("/nan/main.mdg"), text, &opts, CheckOptions { require_start: true })
}

/// `nan`, `inf` and `infinity` read as numbers by Rust's parser: as `@param` bounds
/// they made `f64::clamp` panic in `mdgc check` (and in the editor).
#[test]
fn param_values_that_are_not_finite_numbers_are_refused() {
    for values in ["1 nan nan", "1 0 NaN", "nan", "1 -inf inf", "infinity", "1 0 1e400"] {
        let text =
            format!("@param float k {values}\nstartshape A\nrule A {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y k}} }}\n");
        let a = analyze_with_params(&text, &[]);
        let e: Vec<_> = a.diagnostics.iter().filter(|d| d.code == "E0209").collect();
        assert_eq!(e.len(), 1, "{values}: {:?}", a.diagnostics);
        assert!(e[0].message.contains("finite"), "{values}: {}", e[0].message);
    }
    let text = "@param float k 1 0 2\nstartshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y k} }\n";
    for v in ["nan", "inf", "-infinity", "1e999"] {
        let a = analyze_with_params(text, &[("k", v)]);
        let e: Vec<_> = a.diagnostics.iter().filter(|d| d.code == "E0209").collect();
        assert_eq!(e.len(), 1, "--param k={v}: {:?}", a.diagnostics);
        assert!(
            e[0].message.contains(&format!("--param k={v}")) && e[0].message.contains("finite"),
            "{}",
            e[0].message
        );
    }
    assert!(!analyze_with_params(text, &[("k", "1.5")]).has_errors());
}

// ---------------------------------------------------------------- warnings and the dump

fn warnings_with<'a>(out: &'a Output, needle: &str) -> Vec<&'a String> {
    out.stats.warnings.iter().filter(|w| w.contains(needle)).collect()
}

/// A NaN or infinite adjustment argument computed at run time is used as 0, and the
/// run says so once, naming the rule and the line (as the overflow warning does).
#[test]
fn nan_and_infinite_adjustment_arguments_are_warned_with_their_rule_and_line() {
    let out = run_source(CLAMP_IN_AN_ADJUSTMENT);
    let w = warnings_with(&out, "NaN");
    assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
    assert!(w[0].contains("rule `B`") && w[0].contains("inline.mdg:3") && w[0].contains("used as 0"), "{}", w[0]);
    let out = run_source(
        "startshape A
rule A { 5 * {x 1} B(0) {} }
rule B(float t) {
  VERTEX {} VERTEX {x 1} VERTEX {y (1e308 * 10 + t)}
}
",
    );
    let w = warnings_with(&out, "infinite");
    assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
    assert!(w[0].starts_with("5 adjustment argument(s)"), "{}", w[0]);
    assert!(w[0].contains("rule `B`") && w[0].contains("inline.mdg:4"), "{}", w[0]);
    // A finite run has no such warning.
    assert!(run_source(
        "startshape A\nrule A { B(2) {} }\nrule B(float t) { VERTEX {} VERTEX {x 1} VERTEX {y (log(t))} }\n"
    )
    .stats
    .warnings
    .is_empty());
}

/// The JSON dump writes a position that is not a finite number as the other formats
/// do (0, with the run's warning), not as `null`.
#[test]
fn the_json_dump_writes_non_finite_positions_as_0_like_the_other_formats() {
    let out = run_source("startshape A\nrule A { B {s 1e30} }\nrule B { VERTEX {x 1e30} VERTEX {} VERTEX {y 1} }\n");
    assert!(!warnings_with(&out, "not finite").is_empty(), "{:?}", out.stats.warnings);
    let mut json = Vec::new();
    mdg_export::json::write_json(&out, &mut json).expect("dump");
    let json = String::from_utf8(json).expect("utf-8");
    assert!(!json.contains("null"), "{json}");
    assert!(json.starts_with("{\"vertices\":[[0.0,0.0,0.0],[0.0,0.0,0.0],[0.0,"), "{json}");
    let mut obj = Vec::new();
    mdg_export::write(mdg_export::Format::Obj, &out, &mut obj).expect("obj");
    assert!(String::from_utf8_lossy(&obj).contains("\nv 0 0 -0"), "the OBJ writes 0 too");
}

/// The other places a run uses a fallback for a value that is not a finite number
/// say so too: a definition weight (used as 0), a selector function (the first
/// definition), an iterator count (NaN runs nothing).
#[test]
fn nan_weights_selector_values_and_counts_are_warned() {
    let out = run_source(
        "startshape A
rule A { B(0) {} }
rule B(float t) (log(t - 1)) { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
rule B(float t) (1) { VERTEX {} VERTEX {x 2} VERTEX {y 2} }
",
    );
    let w = warnings_with(&out, "weight");
    assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
    assert!(w[0].contains("rule `B`") && w[0].contains("used as 0"), "{}", w[0]);
    // The NaN weight is 0, so the other definition runs.
    assert_eq!(positions(&out)[1], [2.0, 0.0, 0.0]);

    let out = run_source(
        "startshape A
selector B function { log(depth - 5) }
rule A { B {} }
rule B 1 { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
rule B 2 { VERTEX {} VERTEX {x 2} VERTEX {y 2} }
",
    );
    let w = warnings_with(&out, "selector");
    assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
    assert!(w[0].contains("rule `B`") && w[0].contains("first definition"), "{}", w[0]);

    let out = run_source(
        "startshape A
rule A { B(0) {} }
rule B(int n) { VERTEX {} VERTEX {x 1} VERTEX {y 1} (floor(log(n - 1))) * {x 1} C {} }
rule C { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
",
    );
    let w = warnings_with(&out, "count");
    assert_eq!(w.len(), 1, "{:?}", out.stats.warnings);
    assert!(w[0].contains("rule `B`") && w[0].contains("inline.mdg:3") && w[0].contains("no runs"), "{}", w[0]);
    assert_eq!(positions(&out).len(), 3);
}

/// Compile-time values that must be finite: an iterator divisor (NaN passed the
/// `> 0` test and made every step NaN) and an isosurface's range (NaN passed the
/// `min < max` test, and ±1e39 is infinite as the f32 the grid stores).
#[test]
fn nan_or_infinite_divisors_and_isosurface_ranges_are_refused() {
    let codes = |text: &str| -> Vec<&'static str> { analyze_mem(text).diagnostics.iter().map(|d| d.code).collect() };
    for divisor in ["(0/0)", "(log(-1))", "(1e308 * 10)"] {
        let text = format!("startshape A\nrule A {{ 5/{divisor} * {{x 1}} B {{}} }}\nrule B {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}} }}\n");
        assert_eq!(codes(&text), vec!["E0402"], "divisor {divisor}");
    }
    for range in ["(0/0) 1 8", "-1 (0/0) 8", "(log(-1)) (sqrt(-1)) 8", "-1e39 1 8", "-1 (1e308 * 10) 8"] {
        let text = format!("startshape A\nisosurface S {{ xyz {range} ; function {{ x*x + y*y + z*z - 0.5 }} }}\nrule A {{ S {{}} }}\n");
        assert_eq!(codes(&text), vec!["E0406"], "range {range}");
    }
}
