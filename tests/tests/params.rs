//! Rules with parameters, `if`/`else`, `let` and `loop` (docs/reference.md, "Rules
//! with parameters"): each program gives exactly the geometry of an equivalent
//! program written without them, and the bytecode is checked by the verifier.

use mdg_tests::{build_source, run_source};
use mdg_vm::bundle::{self, Op};
use mdg_vm::eval::{evaluate, EvalOptions};

/// The mesh of a run, positions and triangles, for exact comparison.
fn mesh(src: &str) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let out = run_source(src);
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    (out.vertex_mesh().positions, out.vertex_mesh().triangles)
}

const TRIANGLE: &str = "rule tri { VERTEX {} VERTEX {x 0.2} VERTEX {y 0.2} }\n";

/// `depth`-selected definitions, one per level (what a grammar without parameters
/// writes): level `d` draws and, below 4, calls itself twice.
fn depth_selected_tree() -> String {
    let mut s = String::from("startshape tree\nselector tree depth\n");
    s.push_str(TRIANGLE);
    for d in 0..=4 {
        let kids = if d < 4 { "tree {y 1 rz 25 s 0.75} tree {y 1 rz -25 s 0.75}" } else { "" };
        s.push_str(&format!("rule tree {d} {{ tri {{}} {kids} }}\n"));
    }
    s
}

#[test]
fn a_tree_with_a_depth_parameter_equals_the_depth_selected_tree() {
    let with_params = format!(
        "startshape top\n{TRIANGLE}rule top {{ tree(4) {{}} }}\n\
         rule tree(int n) {{\n  tri {{}}\n  if (n > 0) {{\n    tree(n - 1) {{y 1 rz 25 s 0.75}}\n    tree(n - 1) {{y 1 rz -25 s 0.75}}\n  }}\n}}\n"
    );
    let a = mesh(&with_params);
    let b = mesh(&depth_selected_tree());
    assert_eq!(a.0.len(), 3 * 31, "31 triangles in a binary tree of depth 4");
    assert_eq!(a, b);
}

#[test]
fn a_float_parameter_in_adjustments_equals_the_constants_it_carries() {
    // Each level's length is 0.8 of its parent's: y len, s len.
    let with_params = format!(
        "startshape top\n{TRIANGLE}rule top {{ arm(3, 1) {{}} }}\n\
         rule arm(int n, float len) {{\n  tri {{s len}}\n  if (n > 0) {{ arm(n - 1, len * 0.8) {{y len rz 30}} }}\n}}\n"
    );
    let mut plain = format!("startshape a3\n{TRIANGLE}");
    let lens = [1.0f64, 0.8, 0.8 * 0.8, 0.8 * 0.8 * 0.8];
    for (i, n) in (0..=3).rev().enumerate() {
        let kid = if n > 0 { format!("a{} {{y {} rz 30}}", n - 1, lens[i]) } else { String::new() };
        plain.push_str(&format!("rule a{n} {{ tri {{s {}}} {kid} }}\n", lens[i]));
    }
    let (a, b) = (mesh(&with_params), mesh(&plain));
    assert_eq!(a.0.len(), b.0.len());
    for (p, q) in a.0.iter().zip(&b.0) {
        for k in 0..3 {
            assert!((p[k] - q[k]).abs() < 1e-6, "{p:?} vs {q:?}");
        }
    }
}

#[test]
fn a_parameter_counted_loop_equals_the_constant_iterator() {
    let counted = format!(
        "startshape top\n{TRIANGLE}rule top {{ ring(7) {{}} }}\nrule ring(int k) {{ (k) * {{rz 30 x 1}} tri {{}} }}\n"
    );
    let constant = format!("startshape ring\n{TRIANGLE}rule ring {{ 7 * {{rz 30 x 1}} tri {{}} }}\n");
    assert_eq!(mesh(&counted), mesh(&constant));
    // `loop` is Context Free's: the first run is under the frame itself, the
    // adjustment applies between runs.
    let looped = format!(
        "startshape top\n{TRIANGLE}rule top {{ ring(7) {{}} }}\nrule ring(int k) {{ loop i = 0, k {{rz 30 x 1}} tri {{s (1 + i * 0)}} }}\n"
    );
    let unrolled = format!("startshape ring\n{TRIANGLE}rule ring {{ tri {{}} 6 * {{rz 30 x 1}} tri {{}} }}\n");
    assert_eq!(mesh(&looped), mesh(&unrolled));
}

#[test]
fn the_loop_variable_counts_from_start_by_step() {
    // i = 1, 3, 5: triangles at x = 1, 3, 5 (no adjustment accumulates).
    let src = format!("startshape row\n{TRIANGLE}rule row {{ loop i = 1, 6, 2 {{}} tri {{x i}} }}\n");
    let (p, _) = mesh(&src);
    let xs: Vec<f32> = p.chunks(3).map(|t| t[0][0]).collect();
    assert_eq!(xs, vec![1.0, 3.0, 5.0]);
    // A negative step counts down; an empty range runs nothing.
    let down = format!(
        "startshape row\n{TRIANGLE}rule row {{ loop i = 3, 0, -1 {{}} tri {{x i}} loop j = 5, 5 {{}} tri {{x j}} }}\n"
    );
    let (p, _) = mesh(&down);
    let xs: Vec<f32> = p.chunks(3).map(|t| t[0][0]).collect();
    assert_eq!(xs, vec![3.0, 2.0, 1.0]);
}

#[test]
fn recursion_ended_by_if_equals_recursion_ended_by_maxdepth() {
    let by_if = format!(
        "startshape top\n{TRIANGLE}rule top {{ spiral(30) {{}} }}\nrule spiral(int n) {{ tri {{}} if (n > 0) {{ spiral(n - 1) {{x 0.3 rz 20 s 0.95}} }} }}\n"
    );
    let by_depth = format!(
        "startshape top\nmaxdepth 32\n{TRIANGLE}rule top {{ spiral {{}} }}\nrule spiral {{ tri {{}} spiral {{x 0.3 rz 20 s 0.95}} }}\n"
    );
    let a = mesh(&by_if);
    let out = run_source(&by_depth);
    assert_eq!(a, (out.vertex_mesh().positions, out.vertex_mesh().triangles));
}

#[test]
fn else_if_chains_and_let_bindings_pick_the_right_branch() {
    // k = 0, 1, 2, 3 → branches a, b, c, c: x offsets 0, 10, 20, 20.
    let src = format!(
        "startshape row\n{TRIANGLE}rule row {{ loop k = 0, 4 {{y 1}} pick(k) {{}} }}\n\
         rule pick(int k) {{\n  let twice = k * 2;\n  if (twice == 0) {{ tri {{}} }} else if (twice < 3 && !(k == 0)) {{ tri {{x 10}} }} else {{ tri {{x 20}} }}\n}}\n"
    );
    let (p, _) = mesh(&src);
    let xs: Vec<f32> = p.chunks(3).map(|t| t[0][0]).collect();
    assert_eq!(xs, vec![0.0, 10.0, 20.0, 20.0]);
}

#[test]
fn defaults_fill_missing_arguments_and_the_start_shape() {
    let src =
        format!("startshape box\n{TRIANGLE}rule box(float size = 2, int n = 3) {{ (n) * {{z 1}} tri {{s size}} }}\n");
    let (p, _) = mesh(&src);
    assert_eq!(p.len(), 9, "n = 3 triangles from the defaults");
    let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(near(p[1], [0.4, 0.0, 1.0]), "size = 2 scales the 0.2 edge, the first run is at z 1: {:?}", p[1]);
    let partial = format!("startshape top\n{TRIANGLE}rule top {{ box(1) {{}} }}\nrule box(float size = 2, int n = 3) {{ (n) * {{z 1}} tri {{s size}} }}\n");
    let (p, _) = mesh(&partial);
    assert_eq!(p.len(), 9);
    assert!(near(p[1], [0.2, 0.0, 1.0]), "{:?}", p[1]);
}

#[test]
fn depth_and_scale_are_readable_in_adjustments() {
    // Four levels (maxdepth 4 counts the start shape): each call moves by the depth of
    // the rule that makes it.
    let src = format!("startshape a\nmaxdepth 4\n{TRIANGLE}rule a {{ tri {{}} a {{x (depth)}} }}\n");
    let p = run_source(&src).vertex_mesh().positions;
    let xs: Vec<f32> = p.chunks(3).map(|t| t[0][0]).collect();
    // The call from depth d moves by d: 0, 0 + 0, 0 + 1, 1 + 2.
    assert_eq!(xs, vec![0.0, 0.0, 1.0, 3.0]);
}

#[test]
fn random_arguments_are_drawn_per_call_and_runs_are_deterministic() {
    let src = format!(
        "startshape top\n{TRIANGLE}rule top {{ 5 * {{y 1}} blob(rand(0.5, 2)) {{}} }}\nrule blob(float size) {{ tri {{s size}} }}\n"
    );
    let b = build_source(&src);
    let x = evaluate(&b, &EvalOptions { seed: Some(7), ..Default::default() });
    let y = evaluate(&b, &EvalOptions { seed: Some(7), ..Default::default() });
    assert_eq!(x.vertex_mesh().positions, y.vertex_mesh().positions);
    let sizes: Vec<f32> = x.vertex_mesh().positions.chunks(3).map(|t| t[1][0] - t[0][0]).collect();
    assert!(sizes.iter().all(|s| (0.1..=0.4).contains(s)), "{sizes:?}");
    assert!(sizes.windows(2).any(|w| w[0] != w[1]), "one draw per call: {sizes:?}");
}

#[test]
fn bundles_with_parameters_round_trip_and_the_verifier_rejects_bad_slots_and_arguments() {
    let b = build_source(&format!(
        "startshape top\n{TRIANGLE}rule top {{ t(2) {{}} }}\nrule t(int n, float k = 1.5) {{ let m = n + k; tri {{s m}} if (n > 0) {{ t(n - 1) {{x 1}} }} }}\n"
    ));
    let bytes = bundle::encode(&b);
    assert_eq!(bundle::load(&bytes).expect("loads"), b);
    let t = b.rules.iter().position(|r| b.string(r.name) == "t").expect("rule t");
    assert_eq!(b.rules[t].params.len(), 2);
    assert_eq!(b.rules[t].params, [None, Some(1.5)]);
    assert_eq!(b.rules[t].frame, 3, "n, k and m");

    // A SET beyond the frame.
    let mut bad = b.clone();
    let set = bad.code.iter().position(|op| matches!(op, Op::Set { .. })).expect("a SET");
    if let Op::Set { slot, .. } = &mut bad.code[set] {
        *slot = mdg_vm::bundle::SlotId(9);
    }
    assert!(bundle::verify(&bad).is_err(), "slot beyond the frame");
    // A CALL with one ARG too few.
    let mut bad = b.clone();
    let arg = bad.code.iter().position(|op| matches!(op, Op::Arg { .. })).expect("an ARG");
    bad.code[arg] = Op::Cont {};
    assert!(bundle::verify(&bad).is_err(), "missing argument");
    // A jump out of its definition.
    let mut bad = b.clone();
    let jz = bad.code.iter().position(|op| matches!(op, Op::JumpIfNot { .. })).expect("a JUMPZ");
    if let Op::JumpIfNot { target, .. } = &mut bad.code[jz] {
        *target = mdg_vm::bundle::OpIndex(0);
    }
    assert!(bundle::verify(&bad).is_err(), "backward jump");
}

#[test]
fn grammars_without_parameters_compile_to_the_same_code_as_before() {
    // No ARG, SET or jump appears in a program that uses none of the new constructs,
    // and rules keep an empty frame (the evaluator's fast paths see the same code).
    let b = build_source(&depth_selected_tree());
    assert!(b.code.iter().all(|op| !matches!(
        op,
        Op::Arg { .. } | Op::Set { .. } | Op::Jump { .. } | Op::JumpIfNot { .. } | Op::LoopN { .. }
    )));
    assert!(b.rules.iter().all(|r| r.params.is_empty() && r.frame == 0));
}

#[test]
fn deeply_nested_ifs_and_loops_are_cut_at_the_nesting_limit_without_overflowing() {
    // 300 levels of `if` and of `loop`, checked on a thread with the language
    // server's 2 MiB stack: the nesting limit (E0105) ends them, nothing overflows
    // (tests/tests/hostile.rs takes both kinds through every pass below the limit).
    for (open, close) in [("if (true) { ", " }"), ("loop i = 0, 2 {} { ", " }")] {
        let src = format!(
            "startshape A\nrule A {{ {}VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}}{} }}\n",
            open.repeat(300),
            close.repeat(300)
        );
        let codes = std::thread::Builder::new()
            .stack_size(2 << 20)
            .spawn(move || {
                let path = mdg_tests::root().join("tests/inline.mdg");
                let a = mdg_compiler::driver::analyze_text(
                    &mdg_compiler::source::FsLoader,
                    &path,
                    &src,
                    &mdg_tests::options(),
                    mdg_compiler::check::CheckOptions { require_start: true },
                );
                a.diagnostics.iter().map(|d| d.code).collect::<Vec<_>>()
            })
            .expect("thread")
            .join()
            .expect("no overflow");
        assert!(codes.contains(&"E0105"), "{codes:?}");
    }
}

/// Positions of a run, for comparison within `tol`.
fn positions_close(a: &[[f32; 3]], b: &[[f32; 3]], tol: f32) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| (0..3).all(|k| (p[k] - q[k]).abs() <= tol))
}

#[test]
fn a_non_uniform_scale_stretches_the_frames_own_axes_and_what_follows_it() {
    // A unit triangle under `s 3 0.5`, then turned: the same as its stretched corners.
    let scaled = "startshape A\nrule A { T {x 1 s 3 0.5 rz 90} }\nrule T { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
    // rz 90 after the scale turns inside the stretched frame: x → (0, 0.5·1)… in world terms
    // local x maps to (0, 0.5), local y to (−3, 0).
    let plain = "startshape A\nrule A { VERTEX {x 1} VERTEX {x 1 y 0.5} VERTEX {x -2} }\n";
    let (a, b) = (mesh(scaled), mesh(plain));
    assert!(positions_close(&a.0, &b.0, 1e-5), "{:?} vs {:?}", a.0, b.0);
    // Along a chain: each level stretches x by 2 and moves 1 along its own x.
    let chain = "startshape A\nmaxdepth 3\nrule A { VERTEX {} A {x 1 s 2 1 1} }\n";
    let xs: Vec<f32> = run_source(chain).vertex_mesh().positions.iter().map(|p| p[0]).collect();
    assert_eq!(xs, [0.0, 1.0, 3.0, 7.0]);
}

#[test]
fn a_non_uniform_scale_gives_normals_perpendicular_to_the_stretched_surface() {
    // `s 1 2 1 rx 45`: the local xy plane is spanned by (1, 0, 0) and (0, 2c, c), c = cos 45°,
    // so its normal is (0, −1, 2)/√5; mapping the normal like a vector would give (0, −2, 1)/√5.
    let src = "startshape A\nnormal 0 0 1\nrule A { VERTEX {s 1 2 1 rx 45} VERTEX {x 1} VERTEX {y 1} }\n";
    let out = run_source(src);
    let n = out.vertex_mesh().normals[0];
    let want = [0.0, -1.0 / 5f32.sqrt(), 2.0 / 5f32.sqrt()];
    assert!((0..3).all(|k| (n[k] - want[k]).abs() < 1e-5), "{n:?}");
}

#[test]
fn hue_saturation_and_brightness_adjust_the_colour_as_context_free_does() {
    let colour = |adj: &str| {
        let src = format!("startshape A\nrule A {{ VERTEX {{{adj}}} VERTEX {{x 1}} VERTEX {{y 1}} }}\n");
        run_source(&src).vertex_mesh().colors[0]
    };
    let close = |a: [f32; 4], b: [f32; 4]| (0..4).all(|k| (a[k] - b[k]).abs() < 1e-5);
    assert!(close(colour("G -1 B -1 hue 120"), [0.0, 1.0, 0.0, 1.0]), "red turned 120° is green");
    assert!(close(colour("G -1 B -1 b -0.5"), [0.5, 0.0, 0.0, 1.0]), "half the brightness");
    assert!(close(colour("G -1 B -1 sat -0.5"), [1.0, 0.5, 0.5, 1.0]), "half the saturation");
    assert!(close(colour("hue 120"), [1.0; 4]), "white has no hue to turn");
    // Three iterator steps of a third of `hue 120` each reach the same green.
    let src =
        "startshape A\nrule A { r {G -1 B -1} }\nrule r { 3 * {hue 40} { VERTEX {} VERTEX {x 1} VERTEX {y 1} } }\n";
    let out = run_source(src);
    assert!(close(out.vertex_mesh().colors[8], [0.0, 1.0, 0.0, 1.0]), "{:?}", out.vertex_mesh().colors[8]);
}

#[test]
fn a_weight_over_the_parameters_chooses_per_call() {
    // Weight n for the second definition: never with n = 0, always with the first at weight 0.
    let src = |n: i32| {
        format!(
            "startshape A\nrule A {{ 100 * {{x 1}} leaf({n}) {{}} }}\n\
             rule leaf(int n) (1 - min(n, 1)) {{ VERTEX {{}} VERTEX {{x 0.5}} VERTEX {{y 0.5}} }}\n\
             rule leaf(int n) (n) {{ 2 * {{z 1}} {{ VERTEX {{}} VERTEX {{x 0.5}} VERTEX {{y 0.5}} }} }}\n"
        )
    };
    assert_eq!(run_source(&src(0)).vertex_mesh().triangles.len(), 100);
    assert_eq!(run_source(&src(3)).vertex_mesh().triangles.len(), 200);
    let b = build_source(&src(3));
    let r = b.rules.iter().find(|r| b.string(r.name) == "leaf").expect("leaf");
    assert!(r.defs.iter().all(|d| d.weight_expr != bundle::NONE));
}
