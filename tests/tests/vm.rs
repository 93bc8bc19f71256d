//! VM conformance: geometry is checked against independent computations, with the
//! tolerance stated at each check (f32 evaluation: 1e-4 absolute on unit-sized models
//! unless said otherwise).

use glam::Vec3;
use mdg_tests::{build_source, run_source};
use mdg_vm::eval::{evaluate, EvalOptions};

const TOL: f32 = 1e-4;

fn v(p: [f32; 3]) -> Vec3 {
    Vec3::from_array(p)
}

/// Distinct points, merging those closer than `tol`.
fn distinct(points: impl IntoIterator<Item = Vec3>, tol: f32) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = Vec::new();
    for p in points {
        if !out.iter().any(|q| q.distance(p) < tol) {
            out.push(p);
        }
    }
    out
}

#[test]
fn icosahedron_from_iterators_and_t_angles_is_exact() {
    let out = run_source("@import polyhedra\nstartshape I\nrule I { icosahedron {} }\n");
    // Vertices: SPHERE instances; edges: the pen lines (MOVETO + LINETO per edge).
    let verts = distinct(out.instances.iter().map(|i| out.instance_transform(&i).w_axis.truncate()), TOL);
    assert_eq!(verts.len(), 12, "an icosahedron has 12 vertices");
    for p in &verts {
        assert!((p.length() - 1.0).abs() < TOL, "vertex {p} not on the unit circumsphere");
    }
    let mut edges: Vec<(Vec3, Vec3)> = Vec::new();
    for l in &out.lines {
        for w in l.points.windows(2) {
            let (a, b) = (v(w[0]), v(w[1]));
            if !edges.iter().any(|(c, d)| {
                (c.distance(a) < TOL && d.distance(b) < TOL) || (c.distance(b) < TOL && d.distance(a) < TOL)
            }) {
                edges.push((a, b));
            }
        }
    }
    assert_eq!(edges.len(), 30, "an icosahedron has 30 edges");
    let edge = 4.0 / (10.0 + 2.0 * 5f32.sqrt()).sqrt(); // edge length for circumradius 1
    for (a, b) in &edges {
        assert!((a.distance(*b) - edge).abs() < TOL, "edge {a}–{b} has length {}, want {edge}", a.distance(*b));
        assert!(verts.iter().any(|p| p.distance(*a) < TOL) && verts.iter().any(|p| p.distance(*b) < TOL));
    }
}

/// An independent turtle: expands the L-system A → B−A−B, B → A+B+A and walks it.
fn turtle_arrowhead(order: u32) -> Vec<Vec3> {
    let mut s = String::from("A");
    for _ in 0..order {
        s = s
            .chars()
            .map(|c| match c {
                'A' => "B-A-B".to_string(),
                'B' => "A+B+A".to_string(),
                c => c.to_string(),
            })
            .collect();
    }
    let (mut p, mut heading) = (glam::DVec3::ZERO, 0f64);
    let mut pts = vec![Vec3::ZERO];
    for c in s.chars() {
        match c {
            'A' | 'B' => {
                p += glam::DVec3::new(heading.to_radians().cos(), heading.to_radians().sin(), 0.0);
                pts.push(p.as_vec3());
            }
            '+' => heading += 60.0,
            '-' => heading -= 60.0,
            _ => {}
        }
    }
    pts
}

#[test]
fn depth_selection_and_continuation_reproduce_an_l_system() {
    for order in [1u32, 3, 5] {
        let src = format!(
            "startshape A\nselector A, B depth\n\
             rule A {r} {{ B {{}} \\ A {{rz -60}} \\ B {{rz -60}} }}\n\
             rule A {n} {{ LINETO {{x 1}} }}\n\
             rule B {r} {{ A {{}} \\ B {{rz 60}} \\ A {{rz 60}} }}\n\
             rule B {n} {{ LINETO {{x 1}} }}\n",
            r = order as i64 - 1,
            n = order
        );
        let out = run_source(&src);
        let want = turtle_arrowhead(order);
        assert_eq!(out.lines.len(), 1, "one pen line");
        let got: Vec<Vec3> = out.lines[0].points.iter().map(|p| v(*p)).collect();
        assert_eq!(got.len(), want.len(), "order {order}: point count");
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            // Error accumulates along the curve: allow 1e-4 per segment walked.
            assert!(g.distance(*w) < TOL * (1 + i) as f32, "order {order}, point {i}: {g} vs turtle {w}");
        }
    }
}

#[test]
fn divisor_steps_make_the_stated_number_of_turns() {
    // 2000/400 * [rz 360]: 2000 steps of 360/400 degrees = 5 turns.
    let out = run_source("startshape A\nrule A { 2000/400 * [rz 360] LINETO {x 1} }\n");
    let pts: Vec<Vec3> = out.lines[0].points.iter().map(|p| v(*p)).collect();
    assert_eq!(pts.len(), 2001);
    let mut turns = 0.0f64;
    for w in pts[1..].windows(2) {
        let (a, b) = (w[0], w[1]);
        let d = (b.y as f64).atan2(b.x as f64) - (a.y as f64).atan2(a.x as f64);
        turns += (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    }
    turns /= std::f64::consts::TAU;
    // Run i is under F·S^i: the first point is already rotated by one step.
    assert!((turns - 1999.0 / 400.0).abs() < 1e-3, "turns = {turns}");
    let first = pts[1];
    let step = (360.0f32 / 400.0).to_radians();
    assert!(
        first.distance(Vec3::new(step.cos(), step.sin(), 0.0)) < TOL,
        "iterator applies the step before the first run: {first}"
    );
    // Scale divides as an N-th root: 4/4 * {s 16} grows by 2 per run.
    let out = run_source("startshape A\nrule A { 4/4 * {s 16} VERTEX {x 1} }\n");
    let xs: Vec<f32> = out.vertex_mesh().positions.iter().map(|p| p[0]).collect();
    for (i, x) in xs.iter().enumerate() {
        assert!((x - 2f32.powi(i as i32 + 1)).abs() < 1e-3, "run {i}: x = {x}");
    }
}

fn signed_volume(m: &mdg_vm::output::Mesh) -> f32 {
    m.oriented_triangles()
        .map(|t| {
            let (a, b, c) =
                (v(m.positions[t[0] as usize]), v(m.positions[t[1] as usize]), v(m.positions[t[2] as usize]));
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

#[test]
fn flips_mirror_and_exported_faces_stay_outward() {
    let plain = run_source("@import primitives\nstartshape A\nrule A { cube {x 3} }\n");
    let flipped = run_source("@import primitives\nstartshape A\nrule A { cube {fx x 3} }\n");
    // fx maps (x, y, z) to (−x, y, z), applied before the translation: the cube lands at x = −3.
    let c = |m: &mdg_vm::output::Mesh| m.positions.iter().map(|p| v(*p)).sum::<Vec3>() / m.positions.len() as f32;
    assert!(c(&plain.vertex_mesh()).distance(Vec3::new(3.0, 0.0, 0.0)) < TOL);
    assert!(c(&flipped.vertex_mesh()).distance(Vec3::new(-3.0, 0.0, 0.0)) < TOL);
    assert!(flipped.vertex_mesh().mirrored.iter().all(|m| *m), "every triangle of the flipped cube is marked mirrored");
    // With the exporters' winding correction both cubes enclose a positive volume of 1.
    assert!(
        (signed_volume(&plain.vertex_mesh()) - 1.0).abs() < 1e-3,
        "plain volume {}",
        signed_volume(&plain.vertex_mesh())
    );
    assert!(
        (signed_volume(&flipped.vertex_mesh()) - 1.0).abs() < 1e-3,
        "flipped volume {}",
        signed_volume(&flipped.vertex_mesh())
    );
    // fx fx is the identity.
    let twice = run_source("@import primitives\nstartshape A\nrule A { cube {fx fx x 3} }\n");
    assert_eq!(twice.vertex_mesh().positions, plain.vertex_mesh().positions);
    assert!(twice.vertex_mesh().mirrored.iter().all(|m| !*m));
    // Exported face normals (recomputed from the oriented triangles) point away from the centre.
    let m = &flipped.vertex_mesh();
    let centre = c(m);
    for t in m.oriented_triangles() {
        let (a, b, cc) = (v(m.positions[t[0] as usize]), v(m.positions[t[1] as usize]), v(m.positions[t[2] as usize]));
        let n = (b - a).cross(cc - a);
        assert!(n.dot((a + b + cc) / 3.0 - centre) > 0.0, "inward face in the mirrored cube");
    }
}

#[test]
fn rotations_are_right_handed_and_adjustments_apply_in_written_order() {
    let out = run_source("startshape A\nrule A { VERTEX {rx 90 z 1} VERTEX {z 1 rx 90} VERTEX {s 2 x 1} }\n");
    let p: Vec<Vec3> = out.vertex_mesh().positions.iter().map(|p| v(*p)).collect();
    assert!(p[0].distance(Vec3::new(0.0, -1.0, 0.0)) < TOL, "rx 90 sends +z to −y: {}", p[0]);
    assert!(p[1].distance(Vec3::new(0.0, 0.0, 1.0)) < TOL, "{}", p[1]);
    assert!(p[2].distance(Vec3::new(2.0, 0.0, 0.0)) < TOL, "s 2 then x 1 moves by 2: {}", p[2]);
}

#[test]
fn unit_suffixes_and_angle_modes() {
    let out = run_source(
        "startshape A\nangle radians\nrule A { VERTEX {rz 90d x 1} VERTEX {rz 0.25o x 1} VERTEX {rz 1t x 1} VERTEX {rz 1.5707963 x 1} }\n",
    );
    let p: Vec<Vec3> = out.vertex_mesh().positions.iter().map(|p| v(*p)).collect();
    assert!(p[0].distance(Vec3::Y) < TOL);
    assert!(p[1].distance(Vec3::Y) < TOL);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(p[2].distance(Vec3::new(h, h, 0.0)) < TOL, "1t is atan(1) = 45°: {}", p[2]);
    assert!(p[3].distance(Vec3::Y) < TOL, "plain numbers read as radians");
}

/// `if(…)`, `select(…)` and `let(…)` (reference §14): values, the stream untouched
/// by untaken branches, and a function's `let` that does not capture its argument.
#[test]
fn expression_forms_choose_lazily_and_bind_once() {
    let xs = |src: &str| -> Vec<f32> { run_source(src).vertex_mesh().positions.iter().map(|p| p[0]).collect() };
    let lazy = xs("startshape A\nrule A { VERTEX {x if(1, 5, rand(0, 1))} VERTEX {x select(0, 6, randn(0, 1))} VERTEX {x rand(0, 1)} }\n");
    let plain = xs("startshape A\nrule A { VERTEX {x 5} VERTEX {x 6} VERTEX {x rand(0, 1)} }\n");
    assert_eq!(lazy, plain, "the untaken branches drew nothing");
    let got = xs(concat!(
        "startshape A\nfunction f(p) { let(t = 2; p + t) }\n",
        "rule A { B(0.5) {} B(1.5) {} B(9) {} B(-1) {} }\n",
        "rule B(float i) { VERTEX {x select(i, 10, 20, let(a = i; b = a * a; b + a))} VERTEX {x let(t = 10; f(t) + t)} }\n",
    ));
    assert_eq!(got, [10.0, 22.0, 20.0, 22.0, 90.0, 22.0, 10.0, 22.0]);
    // A count folded at compile time.
    assert_eq!(xs("startshape A\nrule A { (let(k = 2; k + if(k > 1, 1, 5))) * {x 1} VERTEX {} }\n").len(), 3);
}

/// Vectors (reference §14, "Vectors"): literals, `vector2` parameters with defaults,
/// functions that take and return vectors, constant indexes, `+ - * /` as Context
/// Free has them and adjustments that spread a vector give the positions the same
/// grammar written with numbers gives.
#[test]
fn vectors_evaluate_as_their_components() {
    let xyz = |src: &str| -> Vec<[f32; 3]> { run_source(src).vertex_mesh().positions.clone() };
    let vectors = xyz(concat!(
        "startshape A\n",
        "function polar(r, a) { (r * cos(a), r * sin(a)) }\n",
        "function cmul(vector2 a, vector2 b) { (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]) }\n",
        "rule A { let c = (1, 2); B((3, 4)) {x c} B() {} B(cmul(c, (0, 1)) * 2) {} B(polar(2, 0) + (0.5, -c[1] / 4)) {} ",
        "C((1, 2, 3)) {} }\n",
        "rule B(vector2 p = (7, 8)) { VERTEX {x p z (p - (1, 1))[1]} VERTEX {y (p[1] / 2)} }\n",
        "rule C(vector3 v) { VERTEX {x (v / 2)} VERTEX {x let(w = (v[2], v[0]); w * w)} }\n",
    ));
    let numbers = xyz(concat!(
        "startshape A\n",
        "rule A { B(3, 4) {x 1 2} B(7, 8) {} B(-4, 2) {} B(2.5, -0.5) {} C(1, 2, 3) {} }\n",
        "rule B(float p0, float p1) { VERTEX {x p0 p1 z (p1 - 1)} VERTEX {y (p1 / 2)} }\n",
        "rule C(float v0, float v1, float v2) { VERTEX {x (v0 / 2) (v1 / 2) (v2 / 2)} VERTEX {x (v2 * v2) (v0 * v0)} }\n",
    ));
    assert_eq!(vectors.len(), 10);
    assert_eq!(vectors, numbers);
}

/// Recursive functions (reference §14): factorial, Fibonacci, mutual recursion and a
/// call of a later function evaluate; a runaway recursion ends at the call limits
/// with a warning naming the option, its value NaN (used as 0, said too).
#[test]
fn recursive_functions_evaluate_within_their_limits() {
    let src = concat!(
        "startshape A\n",
        "function fact(n) { if(n <= 1, 1, n * fact(n - 1)) }\n",
        "function fib(n) { if(n < 2, n, fib(n - 1) + fib(n - 2)) }\n",
        "function even(n) { if(n <= 0, 1, odd(n - 1)) }\n",
        "function odd(n) { if(n <= 0, 0, even(n - 1)) }\n",
        "rule A { B(5) {} B(10) {} }\n",
        "rule B(int n) { VERTEX {x fact(n) y fib(n) z (even(n) + 10 * odd(n + 1))} }\n",
    );
    let out = run_source(src);
    let got: Vec<[f32; 3]> = out.vertex_mesh().positions.clone();
    assert_eq!(got, [[120.0, 5.0, 0.0], [3628800.0, 55.0, 11.0]], "{:?}", out.stats.warnings);
    assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
    // Deep: fine under the default depth; past a lower one, NaN and the warning.
    let deep = "startshape A\nfunction sum(n) { if(n <= 0, 0, n + sum(n - 1)) }\nrule A { VERTEX {x sum(5000)} }\n";
    let b = build_source(deep);
    let out = evaluate(&b, &EvalOptions::default());
    assert_eq!(out.vertex_mesh().positions[0][0], 12502500.0);
    let low = mdg_vm::expr::CallLimits { depth: 100, ..Default::default() };
    let out = evaluate(&b, &EvalOptions { calls: low, ..EvalOptions::default() });
    assert_eq!(out.vertex_mesh().positions[0][0], 0.0, "NaN, used as 0");
    let w = out.stats.warnings.join("\n");
    assert!(w.contains("nested deeper than 100") && w.contains("--max-call-depth"), "{w}");
    // Exponential: shallow, but past the call limit.
    let fib =
        "startshape A\nfunction fib(n) { if(n < 2, n, fib(n - 1) + fib(n - 2)) }\nrule A { VERTEX {x fib(40)} }\n";
    let out = evaluate(&build_source(fib), &EvalOptions::default());
    let w = out.stats.warnings.join("\n");
    assert!(w.contains("more than 1000000 function calls") && w.contains("--max-calls"), "{w}");
}

/// `skew X Y` (reference §5): Context Free's skew along the frame's own axes, the
/// same from a constant list, a list computed at run time and an iterator's steps;
/// the frames after it stay affine (a translation after the skew is skewed too).
#[test]
fn skew_maps_points_as_context_free_does() {
    let xy = |src: &str| -> Vec<[f32; 2]> {
        let out = run_source(src);
        assert!(out.stats.warnings.is_empty(), "{:?}", out.stats.warnings);
        out.vertex_mesh().positions.iter().map(|p| [(p[0] * 1e4).round() / 1e4, (p[1] * 1e4).round() / 1e4]).collect()
    };
    let tri = "rule T { VERTEX {y 1} VERTEX {x 1} VERTEX {x 1 y 1} }\n";
    let want = [[1.0, 1.0], [1.0, 0.0], [2.0, 1.0]];
    assert_eq!(xy(&format!("startshape A\nrule A {{ T {{skew 45 0}} }}\n{tri}")), want);
    assert_eq!(xy(&format!("startshape A\nrule A {{ T {{skew (45 + rand(0, 0)) 0}} }}\n{tri}")), want);
    assert_eq!(xy(&format!("startshape A\nrule A {{ 4/4 * {{skew 45 0}} T {{}} }}\n{tri}"))[9..], want);
    // y += tan 45° · x; and with a rotation first, the skew is in the turned frame.
    assert_eq!(xy(&format!("startshape A\nrule A {{ T {{skew 0 45}} }}\n{tri}")), [[0.0, 1.0], [1.0, 1.0], [1.0, 2.0]]);
    assert_eq!(
        xy(&format!("startshape A\nrule A {{ T {{rz 90 skew 45 0}} }}\n{tri}")),
        [[-1.0, 1.0], [0.0, 1.0], [-1.0, 2.0]]
    );
}

#[test]
fn continuation_in_iterators_chains_runs() {
    // Without `\` every run starts from the iterator's frame; with it, from the last run's end.
    let plain = run_source("startshape A\nrule A { 3 * {rz 90} LINETO {x 1} }\n");
    let chained = run_source("startshape A\nrule A { 3 * {rz 90} LINETO {x 1} \\ VERTEX {} }\n");
    let p = |o: &mdg_vm::output::Output| o.lines[0].points.iter().map(|p| v(*p)).collect::<Vec<_>>();
    let a = p(&plain);
    assert!(a[1].distance(Vec3::Y) < TOL && a[2].distance(-Vec3::X) < TOL && a[3].distance(-Vec3::Y) < TOL, "{a:?}");
    let b = p(&chained);
    // Run 1 at rz 90: (0,1); run 2 from there, rz 90 more then x 1: (−1,1); run 3: (−1,0).
    assert!(b[1].distance(Vec3::Y) < TOL, "{b:?}");
    assert!(b[2].distance(Vec3::new(-1.0, 1.0, 0.0)) < TOL, "{b:?}");
    assert!(b[3].distance(Vec3::new(-1.0, 0.0, 0.0)) < TOL, "{b:?}");
    // The item after the chained iterator continues from its last drawable.
    assert!(v(chained.vertex_mesh().positions[0]).distance(Vec3::new(-1.0, 0.0, 0.0)) < TOL);
}

#[test]
fn selectors_depth_scale_sequential_function() {
    // Sequential: definitions used in order, each `weight` times, then wrap.
    let out = run_source(
        "startshape S\nselector A sequential\nrule S { 5 * {x 1} A {} }\nrule A 2 { VERTEX {y 1} }\nrule A 1 { VERTEX {y 2} }\n",
    );
    let ys: Vec<f32> = out.vertex_mesh().positions.iter().map(|p| p[1]).collect();
    assert_eq!(ys, vec![1.0, 1.0, 2.0, 1.0, 1.0]);
    // Scale: the largest weight ≤ the linear scale, else the smallest.
    let out = run_source(
        "startshape S\nselector A scale\nrule S { A {s 3} A {s 0.5} A {s 0.1} }\nrule A 1 { VERTEX {y 1} }\nrule A 0.4 { VERTEX {y 2} }\nrule A 2 { VERTEX {y 3} }\n",
    );
    let ys: Vec<f32> = out.vertex_mesh().positions.iter().map(|p| p[1]).collect();
    // Scale 3 picks weight 2 (y 3 → 9); 0.5 picks 0.4 (y 2 → 1); 0.1 has none ≤ it, so the smallest, 0.4 (y 2 → 0.2).
    for (y, want) in ys.iter().zip([9.0, 1.0, 0.2]) {
        assert!((y - want).abs() < TOL, "{ys:?}");
    }
    // Function: the value selects like depth selection.
    let out = run_source(
        "startshape S\nselector A function { x }\nrule S { A {x 0.5} A {x 1.5} A {x 9} }\nrule A 1 { VERTEX {y 1} }\nrule A 2 { VERTEX {y 2} }\n",
    );
    let ys: Vec<f32> = out.vertex_mesh().positions.iter().map(|p| p[1]).collect();
    assert_eq!(ys, vec![1.0, 2.0, 2.0]);
}

#[test]
fn limits_end_runs_cleanly_and_keep_output() {
    let grow = "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} A {x 1} }\n";
    let b = build_source(grow);
    let out = evaluate(&b, &EvalOptions { maxiter: Some(1000), ..EvalOptions::default() });
    assert!(out.stats.warnings.iter().any(|w| w.contains("maxiter 1000")), "{:?}", out.stats.warnings);
    assert!(out.vertex_mesh().n_vertices() >= 3 * 999, "output so far is kept");
    let out = evaluate(&b, &EvalOptions { max_vertices: 3000, ..EvalOptions::default() });
    assert!(out.stats.warnings.iter().any(|w| w.contains("vertex budget")), "{:?}", out.stats.warnings);
    let out = evaluate(
        &b,
        &EvalOptions {
            time_budget: Some(std::time::Duration::from_millis(50)),
            maxiter: Some(u64::MAX),
            max_vertices: u64::MAX,
            ..EvalOptions::default()
        },
    );
    assert!(
        out.stats.warnings.iter().any(|w| w.contains("time budget"))
            || out.stats.warnings.iter().any(|w| w.contains("stack")),
        "{:?}",
        out.stats.warnings
    );
    let out = run_source("startshape A\nmaxdepth 5\nrule A { VERTEX {} A {z 1} }\n");
    assert_eq!(out.vertex_mesh().n_vertices(), 6);
    limit_warning(&out, "maxdepth 5 reached in rule `A` (", "inline.mdg:3): 1 branch(es) ended there");
    let out = run_source("startshape A\nminsize 0.1\nrule A { VERTEX {} A {s 0.5} }\n");
    assert_eq!(out.vertex_mesh().n_vertices(), 4, "scales 1, 0.5, 0.25, 0.125 pass; 0.0625 < 0.1 stops");
    limit_warning(&out, "minsize 0.1 reached in rule `A` (", "inline.mdg:3): 1 branch(es) ended there");
    // Two calls per level: depths 0..=5 draw 63 vertices, and the 64 calls at depth 6 end.
    let out = run_source("startshape A\nmaxdepth 5\nrule A { VERTEX {} A {z 1} A {x 1} }\n");
    assert_eq!(out.vertex_mesh().n_vertices(), 63);
    limit_warning(&out, "maxdepth 5 reached in rule `A` (", "inline.mdg:3): 64 branch(es) ended there");
    let out = run_source("startshape A\nminsize 0.1\nrule A { VERTEX {} A {s 0.5} A {s 0.5 x 1} }\n");
    assert_eq!(out.vertex_mesh().n_vertices(), 15, "scales 1 … 0.125: 1 + 2 + 4 + 8");
    limit_warning(&out, "minsize 0.1 reached in rule `A` (", "inline.mdg:3): 16 branch(es) ended there");
    let out = run_source("startshape A\nstacksize 10\nrule A { VERTEX {} A {z 1} }\n");
    assert_eq!(out.vertex_mesh().n_vertices(), 10);
    limit_warning(
        &out,
        "stack size 10 reached in rule `A` (",
        "inline.mdg:3): 1 branch(es) ended there (raise the limit with `stacksize N` in the grammar, up to the cap set by `--max-stack N`)",
    );
    // The line is the call's, in the rule that makes it (here on line 5, in `B`).
    let out = run_source("startshape A\nmaxdepth 3\nrule A { B {} }\nrule B {\n  VERTEX {} A {z 1}\n}\n");
    limit_warning(&out, "maxdepth 3 reached in rule `B` (", "inline.mdg:5): 1 branch(es) ended there");
    // An iterator with 10^12 runs ends at maxiter.
    let out = run_source("startshape A\nmaxiter 10000\nrule A { 1000000000000 * {x 1} FACENORMALS {} }\n");
    assert!(out.stats.warnings.iter().any(|w| w.contains("maxiter")), "{:?}", out.stats.warnings);
}

/// The only warning of `out` starts with `head` and ends with `tail` (the file's
/// path, in between, depends on the checkout).
fn limit_warning(out: &mdg_vm::output::Output, head: &str, tail: &str) {
    let w = &out.stats.warnings;
    assert!(w.len() == 1 && w[0].starts_with(head) && w[0].ends_with(tail), "{w:?}: want {head}…{tail}");
}

#[test]
fn runtime_warnings_name_the_mdg_line() {
    let b = build_source(
        "startshape A\nisosurface BIG { xyz -1 1 1000; function { x*x + y*y + z*z - 1 } }\nrule A {\n  BIG {}\n}\n",
    );
    let out = evaluate(&b, &EvalOptions { max_iso_cells: 1_000_000, ..EvalOptions::default() });
    assert!(
        out.stats.warnings.iter().any(|w| w.contains("inline.mdg:4") && w.contains("BIG")),
        "{:?}",
        out.stats.warnings
    );
}

#[test]
fn same_source_and_seed_give_identical_bytes() {
    let src = "startshape T\nmaxdepth 8\nrule T { VERTEX {} VERTEX {x 1} VERTEX {y 1} T {z 1 ry rand(0, 90) s 0.8} }\nrule T 0.3 { T {rx randn(30, 5)} }\n";
    let a = mdg_vm::bundle::encode(&build_source(src));
    let b = mdg_vm::bundle::encode(&build_source(src));
    assert_eq!(a, b, "bundles differ");
    let bundle = mdg_vm::bundle::load(&a).expect("loads");
    let glb = |seed| {
        let out = evaluate(&bundle, &EvalOptions { seed: Some(seed), ..EvalOptions::default() });
        let mut bytes = Vec::new();
        mdg_export::write(mdg_export::Format::Glb, &out, &mut bytes).expect("export");
        bytes
    };
    assert_eq!(glb(7), glb(7), "same seed, different meshes");
    assert_ne!(glb(7), glb(8), "different seeds should differ for a random grammar");
}

#[test]
fn mutated_bundles_are_rejected_or_run_safely() {
    let mut rng = mdg_tests::Rng(0xB0B);
    let sources = [
        "@import polyhedra\nstartshape I\nrule I { icosahedron {} 3 * {x 2} octahedron {s 0.5} }\n",
        "startshape T\nmaxdepth 6\nselector T depth\nrule T 3 { T {x 1 ry rand(0, 9)} \\ T {s 0.5} }\nrule T 6 { LINETO {z 1} }\n",
    ];
    let limits =
        EvalOptions { maxiter: Some(5_000), max_vertices: 50_000, max_iso_cells: 50_000, ..EvalOptions::default() };
    let (mut rejected, mut ran) = (0, 0);
    for src in sources {
        let good = mdg_vm::bundle::encode(&build_source(src));
        for round in 0..1500 {
            let mut bytes = good.clone();
            match round % 3 {
                0 => {
                    // Random flips, check value untouched: must be rejected.
                    for _ in 0..1 + rng.below(4) {
                        let i = rng.below(bytes.len());
                        bytes[i] ^= 1 << rng.below(8);
                    }
                }
                1 => bytes.truncate(rng.below(bytes.len())),
                _ => {
                    // Flips in the payload with the check value recomputed: exercises the decoder and verifier.
                    for _ in 0..1 + rng.below(4) {
                        let i = 24 + rng.below(bytes.len() - 24);
                        bytes[i] = rng.bits() as u8;
                    }
                    let check = mdg_vm::bundle::fnv1a(&bytes[24..]);
                    bytes[8..16].copy_from_slice(&check.to_le_bytes());
                }
            }
            match mdg_vm::bundle::load(&bytes) {
                Err(_) => rejected += 1,
                Ok(b) => {
                    let _ = evaluate(&b, &limits);
                    ran += 1;
                }
            }
        }
    }
    assert!(rejected > 1500, "most mutations must be rejected ({rejected} rejected, {ran} ran)");
}

#[test]
fn json_dump_has_the_documented_keys() {
    let out = run_source("@import primitives\nstartshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} MOVETO {} LINETO {z 2} SPHERE {x 5 s 0.5} }\n");
    let mut bytes = Vec::new();
    mdg_export::write(mdg_export::Format::Json, &out, &mut bytes).expect("json");
    let j: serde_json::Value = serde_json::from_slice(&bytes).expect("valid JSON");
    assert_eq!(j["vertices"].as_array().map(|a| a.len()), Some(3));
    assert_eq!(j["triangles"][0], serde_json::json!([0, 1, 2]));
    assert_eq!(j["lines"][0]["points"], serde_json::json!([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]]));
    assert_eq!(j["instances"][0]["name"], "SPHERE");
    assert_eq!(j["instances"][0]["position"], serde_json::json!([5.0, 0.0, 0.0]));
    assert!((j["instances"][0]["scale"].as_f64().unwrap_or(0.0) - 0.5).abs() < 1e-6);
    assert!(j["stats"]["rule_calls"].as_u64().is_some());
}

/// `record_sites`: every mesh triangle maps to the rule and source line that drew it
/// (a face's VERTEXes on one line are one site); nothing is recorded unless asked,
/// and recording changes no geometry.
#[test]
fn sites_name_the_rule_and_line_of_every_triangle() {
    let src = "startshape A\n\
               rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} B {z 1} C {z 2} }\n\
               rule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n\
               rule C { B {} \n VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
    let b = build_source(src);
    let plain = evaluate(&b, &EvalOptions::default());
    assert!(plain.sites.runs.is_empty() && plain.sites.sites.is_empty());
    // (B is a prototype: drawn item by item here, so each triangle has its line.)
    let out = evaluate(&b, &EvalOptions { record_sites: true, instancing: false, ..EvalOptions::default() });
    assert_eq!(out.vertex_mesh(), plain.vertex_mesh(), "recording sites changes no geometry");
    let t = out.vertex_mesh().triangles.len() as u32;
    assert_eq!(t, 1 + 2 + 2 + 1);
    let named: Vec<(String, u32)> =
        (0..t).map(|i| out.sites.of(i).map(|s| (s.rule.clone(), s.line)).expect("a site")).collect();
    let want = [("A", 2), ("B", 3), ("B", 3), ("B", 3), ("B", 3), ("C", 5)];
    assert_eq!(named, want.map(|(r, l)| (r.to_string(), l)).to_vec());
    assert!(out.sites.sites.iter().all(|s| s.file == "inline.mdg"), "{:?}", out.sites.sites);
    // One site per (rule, line): A, B, C.
    assert_eq!(out.sites.sites.len(), 3);
}

/// A grammar with VERTEX triangles at two depths, sweeps and isosurface instances.
const DERIVED: &str = "@import primitives lines\nstartshape A\n\
                       rule A {\n face3 {}\n 2 * {x 2} B {}\n SPHERE {z 3 s 0.2}\n}\n\
                       rule B {\n face3 {z 1}\n C {}\n}\n\
                       rule C {\n MOVETO thick_tube {}\n LINETO thick_tube {z 1}\n}\n\
                       rule face3 { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";

/// Sites cover the sweeps and the isosurface instances too, each with the depth of
/// the activation that made it.
#[test]
fn sites_cover_sweeps_and_instances_with_their_depth() {
    let b = build_source(DERIVED);
    // (Prototype instancing off: face3 is drawn vertex by vertex, its triangles each
    // with a site; `prototype_instances_keep_their_sites` has it on.)
    let plain = evaluate(&b, &EvalOptions { instancing: false, ..EvalOptions::default() });
    let out = evaluate(&b, &EvalOptions { instancing: false, record_sites: true, ..EvalOptions::default() });
    assert_eq!((&out.mesh, &out.sweeps, &out.instances), (&plain.mesh, &plain.sweeps, &plain.instances));
    assert!(!out.sweeps.triangles.is_empty() && out.instances.len() == 1);
    let site = |run: [u32; 4]| {
        let s = &out.sites.sites[run[1] as usize];
        (s.rule.clone(), s.line, run[2])
    };
    // face3's triangle in A (depth 1), then the one in each B (depth 2).
    let faces: Vec<_> = (0..3).map(|t| site(out.sites.run_of_triangle(t).expect("a run"))).collect();
    assert_eq!(faces, [("face3".to_string(), 16, 1), ("face3".to_string(), 16, 2), ("face3".to_string(), 16, 2)]);
    // Every sweep triangle: C's LINETO line, depth 2 (A → B → C).
    for t in 0..out.sweeps.triangles.len() as u32 {
        assert_eq!(site(out.sites.run_of_sweep(t).expect("a run")), ("C".to_string(), 14, 2), "sweep triangle {t}");
    }
    assert_eq!(site(out.sites.run_of_instance(0).expect("a run")), ("A".to_string(), 6, 0));
    assert!(out.derivation.is_none() && plain.derivation.is_none());
}

/// `record_derivation`: one node per path of rules, the calls and triangles of each
/// matching the model; recording changes no geometry.
#[test]
fn the_derivation_tree_counts_calls_and_geometry_per_path() {
    let b = build_source(DERIVED);
    let plain = evaluate(&b, &EvalOptions { instancing: false, ..EvalOptions::default() });
    let opts = EvalOptions { record_derivation: true, record_sites: true, instancing: false, ..EvalOptions::default() };
    let out = evaluate(&b, &opts);
    assert_eq!((&out.mesh, &out.sweeps, &out.instances), (&plain.mesh, &plain.sweeps, &plain.instances));
    let d = out.derivation.as_ref().expect("a derivation");
    let path = |n: &mdg_vm::output::DerivNode| {
        let mut names = vec![d.rules[n.rule as usize].rule.clone()];
        let mut p = n.parent;
        while let Some(i) = p {
            names.insert(0, d.rules[d.nodes[i as usize].rule as usize].rule.clone());
            p = d.nodes[i as usize].parent;
        }
        names.join("/")
    };
    let sphere = out.shared_meshes[0].mesh.triangles.len() as u64;
    let sweeps = out.sweeps.triangles.len() as u64;
    let got: Vec<(String, u32, u64, u64, u64)> =
        d.nodes.iter().map(|n| (path(n), n.depth, n.calls, n.triangles, n.total)).collect();
    let want = vec![
        ("A".to_string(), 0, 1, sphere, sphere + 3 + sweeps),
        ("A/face3".to_string(), 1, 1, 1, 1),
        ("A/B".to_string(), 1, 2, 0, 2 + sweeps),
        ("A/B/face3".to_string(), 2, 2, 2, 2),
        ("A/B/C".to_string(), 2, 2, sweeps, sweeps),
    ];
    assert_eq!(got, want);
    // The whole model, as a flat walk counts it.
    assert_eq!(d.triangles, out.flat_counts(mdg_vm::output::Groups::ALL).1 as u64);
    assert!(!d.cut);
    // (A rule's line is its first definition's first op's.)
    assert_eq!((d.rules[0].rule.as_str(), d.rules[0].line), ("A", 4));
    // The sites name the node of each triangle.
    let node_of = |t: u32| path(&d.nodes[out.sites.run_of_triangle(t).expect("a run")[3] as usize]);
    assert_eq!([node_of(0), node_of(1)], ["A/face3", "A/B/face3"]);
    // Without sites the tree is the same (face3 is then a prototype instance, counted
    // by its mesh's triangles), and so is the model.
    let alone = evaluate(&b, &EvalOptions { record_derivation: true, ..EvalOptions::default() });
    assert_eq!(alone.derivation.as_ref(), Some(d));
    assert!(alone.sites.runs.is_empty());
    let default = evaluate(&b, &EvalOptions::default());
    assert_eq!((&alone.mesh, &alone.sweeps, &alone.instances), (&default.mesh, &default.sweeps, &default.instances));
}

/// Under `breadthfirst` the derivation tree is recorded too, and is the same tree
/// (one node per path of rules) as depth first: only the nodes' order differs.
#[test]
fn breadth_first_runs_record_the_same_derivation_tree() {
    let src = "startshape A\n{order}rule A { B {} B {x 2} C {y 2} }\nrule B { C {} SQUARE {s 0.5} }\n\
               rule C { SQUARE {} 2 * [x 1] D {} }\nrule D { TRIANGLE {} }\n";
    let tree = |order: &str, sites: bool| {
        let b = build_source(&src.replace("{order}", order));
        let opts = EvalOptions { record_derivation: true, record_sites: sites, ..EvalOptions::default() };
        let out = evaluate(&b, &opts);
        assert!(!out.stats.warnings.iter().any(|w| w.contains("derivation")), "{:?}", out.stats.warnings);
        let d = out.derivation.expect("a derivation");
        let path = |n: &mdg_vm::output::DerivNode| {
            let mut names = vec![d.rules[n.rule as usize].rule.clone()];
            let mut p = n.parent;
            while let Some(i) = p {
                names.insert(0, d.rules[d.nodes[i as usize].rule as usize].rule.clone());
                p = d.nodes[i as usize].parent;
            }
            names.join("/")
        };
        let mut got: Vec<(String, u32, u64, u64, u64)> =
            d.nodes.iter().map(|n| (path(n), n.depth, n.calls, n.triangles, n.total)).collect();
        got.sort();
        (got, d.triangles)
    };
    let depth_first = tree("", true);
    assert_eq!(depth_first.0.len(), 11, "{:?}", depth_first.0);
    assert_eq!(tree("breadthfirst\n", true), depth_first);
    assert_eq!(tree("breadthfirst\n", false), depth_first);
}

/// Recorded sites keep prototype instancing (the editor's preview gets the model
/// instanced, as `mdg-run --instances` writes it): each instance has the rule,
/// depth and derivation node its triangles have when the prototype is drawn item
/// by item, and the model and the derivation tree are the same either way.
#[test]
fn prototype_instances_keep_their_sites() {
    let b = build_source(DERIVED);
    let opts = EvalOptions { record_derivation: true, record_sites: true, ..EvalOptions::default() };
    let inst = evaluate(&b, &opts);
    let baked = evaluate(&b, &EvalOptions { instancing: false, ..opts.clone() });
    let prototypes = inst.instances.iter().filter(|i| inst.is_prototype_instance(i)).count();
    assert_eq!(prototypes, 3, "face3 in A and in each B is an instance");
    assert!(inst.mesh.triangles.is_empty() && !baked.mesh.triangles.is_empty());
    assert_eq!(inst.vertex_mesh(), baked.vertex_mesh(), "the same model");
    assert_eq!(inst.derivation, baked.derivation, "the same derivation tree");
    // Instance k of face3 drew baked triangle k: the same rule, depth and node.
    let (mut k, mut named) = (0u32, 0);
    for (i, instance) in inst.instances.iter().enumerate() {
        let r = inst.sites.run_of_instance(i as u32).expect("a run for every instance");
        let site = &inst.sites.sites[r[1] as usize];
        if !inst.is_prototype_instance(&instance) {
            assert_eq!((site.rule.as_str(), r[2]), ("A", 0), "the SPHERE");
            continue;
        }
        let t = baked.sites.run_of_triangle(k).expect("a run");
        let want = &baked.sites.sites[t[1] as usize];
        assert_eq!((&site.rule, &site.file, r[2], r[3]), (&want.rule, &want.file, t[2], t[3]), "instance {i}");
        k += 1;
        named += 1;
    }
    assert_eq!(named, 3);
}

/// Paths past the depth limit are counted in the deepest node above them, and the
/// tree says it was cut; the totals still match the model.
#[test]
fn a_deep_derivation_is_cut_at_the_depth_limit() {
    use mdg_vm::eval::DERIVATION_MAX_DEPTH;
    let src = "startshape R\nmaxdepth 200\nrule R { VERTEX {} VERTEX {x 1} VERTEX {y 1} R {z 1 s 0.99} }\n";
    let out = evaluate(&build_source(src), &EvalOptions { record_derivation: true, ..EvalOptions::default() });
    let d = out.derivation.as_ref().expect("a derivation");
    assert!(d.cut);
    assert_eq!(d.nodes.len() as u32, DERIVATION_MAX_DEPTH + 1);
    let last = d.nodes.last().expect("a node");
    assert_eq!(last.depth, DERIVATION_MAX_DEPTH);
    // Every call (depths 0 to 200) drew one triangle.
    assert_eq!(out.flat_counts(mdg_vm::output::Groups::ALL).1, 201);
    assert_eq!(last.calls + last.deeper, 201 - u64::from(DERIVATION_MAX_DEPTH));
    assert_eq!(d.triangles, 201);
    assert_eq!(d.nodes[0].total, d.triangles);
}

#[test]
fn numbers_that_overflow_f32_are_encoded_finite_so_the_bundle_loads() {
    // 1e308 is a finite f64 but infinite as f32: the encoder writes it as the largest
    // finite f32, so the bundle the compiler writes loads (the loader refuses
    // non-finite numbers).
    for src in [
        "startshape A\nrule A { VERTEX {z 1e308} VERTEX {x 1} VERTEX {y 1} }\n",
        "startshape A\nrule A { B {s 1e300 x -1e308} }\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n",
    ] {
        let b = build_source(src);
        let bytes = mdg_vm::bundle::encode(&b);
        let loaded = mdg_vm::bundle::load(&bytes).unwrap_or_else(|e| panic!("{src}: {e}"));
        let out = evaluate(&loaded, &EvalOptions::default());
        assert_eq!(out.vertex_mesh().n_vertices(), 3, "{src}");
    }
}

/// Signed area of a mesh's triangles seen from +z (counter-clockwise positive).
fn area_z(m: &mdg_vm::output::Mesh) -> f32 {
    m.oriented_triangles()
        .map(|t| {
            let (a, b, c) =
                (v(m.positions[t[0] as usize]), v(m.positions[t[1] as usize]), v(m.positions[t[2] as usize]));
            (b - a).cross(c - a).z / 2.0
        })
        .sum()
}

#[test]
fn flat_primitives_vertices_are_matte_and_no_others() {
    // Std flat's vertices are marked (the picture draws them without a highlight),
    // whether made as instances (similarity frames) or one by one (`s 2 1`), with
    // instancing on or off; the cube's and a user rule's are not.
    let src = "@import primitives\nstartshape A\nrule A {\n  SQUARE {}\n  SQUARE {s 2 1}\n  3 * {x 1} CIRCLE {}\n  cube {y 3}\n  tri {y -3}\n}\nrule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
    let b = build_source(src);
    for instancing in [true, false] {
        let opts = mdg_vm::eval::EvalOptions { instancing, ..Default::default() };
        let out = mdg_vm::eval::evaluate(&b, &opts);
        let m = out.vertex_mesh();
        let matte: Vec<bool> = (0..m.n_vertices()).map(|i| m.matte(i)).collect();
        let want: Vec<bool> = [vec![true; 6 + 6 + 3 * 96], vec![false; 36 + 3]].concat();
        assert_eq!(matte, want, "instancing {instancing}");
    }
}

#[test]
fn context_free_flat_primitives_are_built_in_at_its_sizes() {
    // No import: CIRCLE, SQUARE and TRIANGLE are there as in Context Free, flat in
    // the xy-plane, facing +z, centred on the frame's origin.
    let circle = run_source("startshape A\nrule A { CIRCLE {} }\n");
    let m = circle.vertex_mesh();
    let r = m.positions.iter().map(|p| v(*p).length()).fold(0f32, f32::max);
    assert!((r - 0.5).abs() < TOL, "CIRCLE has diameter 1: radius {r}");
    assert!(m.positions.iter().all(|p| p[2].abs() < TOL), "CIRCLE is flat");
    // A 32-gon inscribed in radius 0.5: area 32/2 · 0.25 · sin(2π/32), within 1% of π/4.
    let want = 16.0 * 0.25 * (std::f32::consts::TAU / 32.0).sin();
    assert!((area_z(&m) - want).abs() < 1e-3, "CIRCLE area {} (want {want})", area_z(&m));

    let square = run_source("startshape A\nrule A { SQUARE {} }\n");
    let m = square.vertex_mesh();
    assert!((area_z(&m) - 1.0).abs() < TOL, "SQUARE has side 1: area {}", area_z(&m));
    assert!(m.positions.iter().all(|p| (p[0].abs() - 0.5).abs() < TOL && (p[1].abs() - 0.5).abs() < TOL));

    // Context Free's TRIANGLE: equilateral, side 1, centroid at the origin, a vertex up.
    let tri = run_source("startshape A\nrule A { TRIANGLE {} }\n");
    let m = tri.vertex_mesh();
    let p: Vec<Vec3> = m.positions.iter().map(|p| v(*p)).collect();
    assert_eq!(p.len(), 3);
    for i in 0..3 {
        let side = p[i].distance(p[(i + 1) % 3]);
        assert!((side - 1.0).abs() < TOL, "TRIANGLE side {side}");
    }
    assert!((p.iter().copied().sum::<Vec3>() / 3.0).length() < TOL, "TRIANGLE centroid at the origin");
    assert!(p.iter().any(|q| (q.y - 1.0 / 3f32.sqrt()).abs() < TOL && q.x.abs() < TOL), "a vertex up: {p:?}");
    assert!(area_z(&m) > 0.0, "TRIANGLE faces +z");
}

/// Red, green and blue of hue `h` degrees at full saturation and brightness.
fn hue_rgb(h: f32) -> [f32; 3] {
    let k = |n: f32| {
        let k = (n + h / 60.0).rem_euclid(6.0);
        1.0 - k.min(4.0 - k).clamp(0.0, 1.0)
    };
    [k(5.0), k(3.0), k(1.0)]
}

#[test]
fn hue_turns_accumulate_on_greys_as_in_context_free() {
    // Context Free's rainbow: the hue turns of S accumulate on the (white) parent,
    // and each CIRCLE shows them once it is given saturation.
    let out = run_source("startshape S\nmaxdepth 8\nrule S { SQUARE {sat 1 b 1} S {x 1.2 hue 30} }\n");
    let m = out.vertex_mesh();
    assert_eq!(m.positions.len(), 8 * 6, "8 squares");
    for i in 0..8 {
        let c = m.colors[i * 6];
        let want = hue_rgb(30.0 * i as f32);
        let x = m.positions[i * 6][0];
        assert!((x - (1.2 * i as f32 - 0.5)).abs() < 1e-3, "square {i} at x {x}");
        assert!(
            (0..3).all(|k| (c[k] - want[k]).abs() < 1e-3),
            "square {i}: colour {c:?}, want hue {} = {want:?}",
            30 * i
        );
    }
    // A grey keeps its hue through RGBA deltas that leave it grey, and a grammar of
    // RGBA deltas alone draws what the thesis says (white plus the deltas).
    let out = run_source("startshape A\nrule A { B {hue 120 R -0.5 G -0.5 B -0.5} }\nrule B { SQUARE {sat 1} }\n");
    let c = out.vertex_mesh().colors[0];
    assert!(
        (c[0]).abs() < 1e-3 && (c[1] - 0.5).abs() < 1e-3 && (c[2]).abs() < 1e-3,
        "a grey turned 120°, then saturated: {c:?}"
    );
    let out = run_source("startshape A\nrule A { SQUARE {R -0.25 B -1} }\n");
    let c = out.vertex_mesh().colors[0];
    assert!((c[0] - 0.75).abs() < 1e-6 && (c[1] - 1.0).abs() < 1e-6 && c[2].abs() < 1e-6, "RGBA deltas: {c:?}");
}

/// A grammar whose paths of rules multiply (a → b → a, a → c → a) is cut at the
/// node limit: every call still counted once, every triangle once.
#[test]
fn a_branching_derivation_is_cut_at_the_node_limit() {
    use mdg_vm::eval::DERIVATION_MAX_NODES;
    let src = "startshape a\nmaxdepth 24\n\
               rule a { VERTEX {} VERTEX {x 1} VERTEX {y 1} b {z 1} c {z 2} }\n\
               rule b { a {x 1} }\nrule c { a {y 1} }\n";
    let out = evaluate(&build_source(src), &EvalOptions { record_derivation: true, ..EvalOptions::default() });
    let d = out.derivation.as_ref().expect("a derivation");
    assert!(d.cut);
    assert_eq!(d.nodes.len(), DERIVATION_MAX_NODES);
    // `a` runs at depths 0, 2, …, 24: 2^13 - 1 calls, one triangle each; b and c
    // run 2^12 - 1 times each.
    let triangles = (1u64 << 13) - 1;
    assert_eq!(out.flat_counts(mdg_vm::output::Groups::ALL).1 as u64, triangles);
    assert_eq!((d.triangles, d.nodes[0].total), (triangles, triangles));
    assert_eq!(d.nodes.iter().map(|n| n.triangles).sum::<u64>(), triangles);
    let calls: u64 = d.nodes.iter().map(|n| n.calls + n.deeper).sum();
    assert_eq!(calls, triangles + 2 * ((1 << 12) - 1));
}

#[test]
fn colour_values_set_the_colour_and_later_adjustments_compose_with_it() {
    let colour = |src: &str| {
        let out = run_source(&format!("startshape A\nrule A {{ {src} }}\nrule B {{ SQUARE {{}} }}\n"));
        out.vertex_mesh().colors[0]
    };
    let close = |c: [f32; 4], want: [f32; 4]| (0..4).all(|k| (c[k] - want[k]).abs() < 1e-3);
    // The hex forms and a palette name.
    let c = colour("SQUARE {#ff8800}");
    assert!(close(c, [1.0, 136.0 / 255.0, 0.0, 1.0]), "#ff8800: {c:?}");
    let c = colour("SQUARE {#f008}");
    assert!(close(c, [1.0, 0.0, 0.0, 136.0 / 255.0]), "#f008: {c:?}");
    let c = colour("SQUARE {#0000ff80}");
    assert!(close(c, [0.0, 0.0, 1.0, 128.0 / 255.0]), "#0000ff80: {c:?}");
    let c = colour("SQUARE {#tomato}");
    assert!(close(c, [1.0, 99.0 / 255.0, 71.0 / 255.0, 1.0]), "#tomato: {c:?}");
    // Written order: what comes before the value is replaced, what comes after adjusts it.
    let c = colour("SQUARE {R -1 b -1 #0f0}");
    assert!(close(c, [0.0, 1.0, 0.0, 1.0]), "deltas before the value: {c:?}");
    // After it, the list's rule: RGBA deltas add, then HSB applies (green plus red
    // 0.25, then brightness halved).
    let c = colour("SQUARE {#0f0 b -0.5 R 0.25}");
    assert!(close(c, [0.125, 0.5, 0.0, 1.0]), "b and R after the value: {c:?}");
    // The value holds for the whole subtree; a child's hue turn starts from its hue.
    let c = colour("B {#00f} ");
    assert!(close(c, [0.0, 0.0, 1.0, 1.0]), "inherited: {c:?}");
    let c = colour("C {#f00} } rule C { SQUARE {hue 120}");
    assert!(close(c, [0.0, 1.0, 0.0, 1.0]), "red turned 120°: {c:?}");
    // A grey value forgets the hue the frame kept: saturating it gives red (hue 0).
    let c = colour("C {hue 240 #808080} } rule C { SQUARE {sat 1}");
    assert!(close(c, [128.0 / 255.0, 0.0, 0.0, 1.0]), "a grey value's hue: {c:?}");
    // An iterator's steps set the same value; a random argument elsewhere in the list
    // (composed at run time) paints alike.
    let out = run_source("startshape A\nrule A { 3 * {x 1 #00f b -0.5} SQUARE {} }\n");
    let m = out.vertex_mesh();
    for i in 0..3 {
        assert!(close(m.colors[i * 6], [0.0, 0.0, 0.5, 1.0]), "step {i}: {:?}", m.colors[i * 6]);
    }
    let c = colour("SQUARE {x rand(0, 1) #00f}");
    assert!(close(c, [0.0, 0.0, 1.0, 1.0]), "a run-time list: {c:?}");
}

#[test]
fn flat_starts_black_on_white_and_orders_triangles_by_z_then_derivation() {
    let out = run_source(
        "startshape A\nflat\nrule A { SQUARE {} SQUARE {x 1 z 1 #f00} SQUARE {x 2 z -1 #00f} SQUARE {x 3 b 1} }\n",
    );
    assert!(out.flat, "the directive reaches the output");
    assert_eq!(out.background, [1.0, 1.0, 1.0, 1.0], "Context Free's white background");
    let m = out.vertex_mesh();
    // Per triangle: its first vertex's x (which square) and colour, in paint order.
    let order: Vec<(i32, [f32; 4])> = m
        .triangles
        .iter()
        .map(|t| ((m.positions[t[0] as usize][0] + 0.5).floor() as i32, m.colors[t[0] as usize]))
        .collect();
    let squares: Vec<i32> = order.iter().map(|o| o.0).collect();
    assert_eq!(squares, [2, 2, 0, 0, 3, 3, 1, 1], "z -1 first, then z 0 in derivation order, then z 1");
    assert_eq!(order[2].1, [0.0, 0.0, 0.0, 1.0], "black from the start (Context Free's)");
    assert_eq!(order[4].1, [1.0, 1.0, 1.0, 1.0], "`b 1` on black is white");
    let out = run_source("startshape A\nflat\nbackground #ff000080\nrule A { SQUARE {} }\n");
    assert_eq!(out.background, [1.0, 0.0, 0.0, 128.0 / 255.0], "a colour value as the background");
    let out = run_source("startshape A\nbackground #navy\nrule A { SQUARE {} }\n");
    assert_eq!(out.background, [0.0, 0.0, 128.0 / 255.0, 1.0], "a colour name as the background");
    // Without `flat`: white from the start, the default background, derivation order.
    let out = run_source("startshape A\nrule A { SQUARE {} SQUARE {x 1 z 1} SQUARE {x 2 z -1} }\n");
    assert!(!out.flat);
    assert_eq!(out.vertex_mesh().colors[0], [1.0; 4]);
    assert_eq!(out.background, [0.12, 0.12, 0.14, 1.0]);
}

/// The area the mesh's triangles cover in the xy-plane (counter-clockwise positive,
/// mirrored triangles turned as the exporters turn them), and its box.
fn xy_area_and_box(m: &mdg_vm::output::Mesh) -> (f32, [f32; 4]) {
    let mut area = 0.0;
    let mut b = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    for t in m.oriented_triangles() {
        let p = t.map(|i| m.positions[i as usize]);
        area += 0.5 * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]));
        for q in p {
            b = [b[0].min(q[0]), b[1].min(q[1]), b[2].max(q[0]), b[3].max(q[1])];
        }
    }
    (area, b)
}

#[test]
fn flat_paths_fill_and_stroke_the_areas_they_enclose() {
    // A 2 × 2 square, filled moved by FILL's own adjustment and scaled by the call.
    let out = run_source(
        "startshape A\nrule A { sq {x 10 s 3} }\n\
         rule sq { MOVETO(-1, -1) {} LINETO(1, -1) {} LINETO(1, 1) {} LINETO(-1, 1) {} FILL {y 1} }\n",
    );
    let (area, b) = xy_area_and_box(&out.mesh);
    assert!((area - 36.0).abs() < 1e-3, "{area}");
    assert!(b.iter().zip([7.0, 0.0, 13.0, 6.0]).all(|(a, e)| (a - e).abs() < 1e-4), "{b:?}");
    assert_eq!((out.stats.paths, out.stats.path_triangles as usize), (1, out.mesh.triangles.len()));
    // A pentagram: even-odd leaves out the centre pentagon that non-zero fills.
    let star = |rule: &str| {
        let src =
            format!("startshape S\nrule S {{ MOVETO(0, 1) {{}} 4 * [rz 144] LINETO(0, 1) {{}} FILL {rule} {{}} }}\n");
        xy_area_and_box(&run_source(&src).mesh).0
    };
    let pent_r = 0.381_966_f32; // the inner pentagon's circumradius, 1/φ²
    let pentagon = 2.5 * pent_r * pent_r * 72f32.to_radians().sin();
    assert!((star("") - star("evenodd") - pentagon).abs() < 1e-3, "{} {}", star(""), star("evenodd"));
    // A unit circle of two arcs (no FILL: a path fills itself at its end), and its
    // outline stroked 0.2 wide: the ring between radii 0.9 and 1.1.
    let circle = xy_area_and_box(
        &run_source("startshape C\nrule C { MOVETO(1, 0) {} ARCTO(-1, 0, 1) {} ARCTO(1, 0, 1) {} }\n").mesh,
    )
    .0;
    assert!((circle - std::f32::consts::PI).abs() < 0.01, "{circle}");
    let ring = xy_area_and_box(&run_source(
        "startshape C\nrule C { MOVETO(1, 0) {} ARCTO(-1, 0, 1) {} ARCTO(1, 0, 1) {} CLOSEPOLY {} STROKE(0.2) {} }\n",
    )
    .mesh)
    .0;
    let want = std::f32::consts::PI * (1.1f32 * 1.1 - 0.9 * 0.9);
    assert!((ring - want).abs() < 0.01 * want, "{ring} {want}");
    // A rule with only MOVETO/LINETO is still the pen's 3D line: no triangles.
    let line = run_source("startshape L\nrule L { MOVETO {} LINETO {x 1} }\n");
    assert!(line.mesh.triangles.is_empty() && line.lines.len() == 1 && line.stats.paths == 0);
}

#[test]
fn subpaths_add_a_path_or_a_primitive_outline_to_the_calling_path() {
    // Context Free's `path CIRCLE [s 0.5]`: in a path, a call of CIRCLE adds the
    // circle's outline (diameter 1 under the call's adjustment), no disc. With
    // even-odd the inner circle is a hole in the outer one.
    let ring = run_source(
        "startshape R\nrule R { MOVETO(1, 0) {} ARCTO(-1, 0, 1) {} ARCTO(1, 0, 1) {} CLOSEPOLY {} \
         CIRCLE {s 1} FILL evenodd {} }\n",
    );
    let (area, b) = xy_area_and_box(&ring.mesh);
    let want = std::f32::consts::PI * (1.0 - 0.25);
    assert!((area - want).abs() < 0.01 * want, "{area} {want}");
    assert!(b.iter().zip([-1.0, -1.0, 1.0, 1.0]).all(|(a, e)| (a - e).abs() < 3e-3), "{b:?}");
    assert_eq!(ring.stats.paths, 1);
    // SQUARE and TRIANGLE outlines, moved and scaled by the call: a 2 × 2 square
    // and a triangle of side 2 (area √3), filled non-zero, apart.
    let out = run_source("startshape P\nrule P { SQUARE {s 2} TRIANGLE {x 3 s 2} FILL {} }\n");
    let (area, b) = xy_area_and_box(&out.mesh);
    assert!((area - (4.0 + 3f32.sqrt())).abs() < 1e-3, "{area}");
    assert!(b.iter().zip([-1.0, -1.0, 4.0, 1.154_700_5]).all(|(a, e)| (a - e).abs() < 1e-4), "{b:?}");
    assert_eq!(out.stats.paths, 1);
    // A path's call of another path that paints nothing adds that path's points
    // (in the call's frame) instead of filling it: five stars stroked as one path.
    let stars = run_source(
        "startshape stars\nrule star { MOVETO(0, 1) {} 4 * [rz 144] LINETO(0, 1) {} CLOSEPOLY {} }\n\
         rule stars { 5 * [rz 72] star {y 1.618} STROKE {} }\n",
    );
    assert_eq!(stars.stats.paths, 1, "one STROKE, no implied FILL of each star");
    let alone = run_source(
        "startshape S\nrule S { star {y 1.618} }\nrule star { MOVETO(0, 1) {} 4 * [rz 144] LINETO(0, 1) {} CLOSEPOLY {} }\n",
    );
    assert_eq!(alone.stats.paths, 1, "called as a shape, a path that paints nothing is filled");
    let (a1, _) = xy_area_and_box(&stars.mesh);
    let one = run_source(
        "startshape stars\nrule star { MOVETO(0, 1) {} 4 * [rz 144] LINETO(0, 1) {} CLOSEPOLY {} }\n\
         rule stars { star {y 1.618} STROKE {} }\n",
    );
    let (a0, _) = xy_area_and_box(&one.mesh);
    assert!(a1 > 4.0 * a0, "five stroked stars: {a1} against one {a0}");
}

#[test]
fn an_iso_stroke_keeps_its_width_under_a_non_uniform_scale() {
    // An L of legs 1 (up) and 1 (right), butt caps, drawn under {s 4 1}: the
    // right leg is 4 long in the world. Context Free's `iso`: the pen is round,
    // w·√|det| = 0.1·2 = 0.2 wide everywhere, so the L covers 0.2 · (1 + 4).
    let run = |word: &str, adj: &str| {
        let out = run_source(&format!(
            "startshape A\nrule A {{ L {{{adj}}} }}\n\
             rule L {{ MOVETO(0, 1) {{}} LINETO(0, 0) {{}} LINETO(1, 0) {{}} STROKE(0.1) {word} {{}} }}\n"
        ));
        assert_eq!(out.stats.paths, 1);
        xy_area_and_box(&out.mesh)
    };
    let (area, b) = run("iso", "s 4 1");
    assert!((area - 1.0).abs() < 1e-3, "{area}");
    assert!(b.iter().zip([-0.1, -0.1, 4.0, 1.0]).all(|(a, e)| (a - e).abs() < 1e-4), "{b:?}");
    // Without it the pen is stretched: 0.4 wide across the upright leg, 0.1 across the other.
    let (area, b) = run("", "s 4 1");
    assert!((area - 0.8).abs() < 1e-3, "{area}");
    assert!((b[0] + 0.2).abs() < 1e-4 && (b[1] + 0.05).abs() < 1e-4, "{b:?}");
    // Under a uniform scale (and a turn) both are the same stroke.
    let (a0, _) = run("iso", "rz 30 s 2");
    let (a1, _) = run("", "rz 30 s 2");
    assert!((a0 - a1).abs() < 1e-3 * a1, "{a0} {a1}");
}

#[test]
fn relative_path_ops_are_the_absolute_ones_from_the_current_point() {
    // Each pair draws the same path, absolute and relative (CFDG 3's LINEREL,
    // MOVEREL, ARCREL, CURVEREL: the point, and a curve's control points, relative
    // to the current point, in the drawable's frame).
    let pairs = [
        (
            "MOVETO(1, 1) {} LINETO(3, 1) {} LINETO(3, 2) {} LINETO(1, 2) {}",
            "MOVEREL(1, 1) {} LINEREL(2, 0) {} LINEREL(0, 1) {} LINEREL(-2, 0) {}",
        ),
        ("MOVETO(1, 0) {} ARCTO(-1, 0, 1.5) {} ARCTO(1, 0, 2, 1.5, 30) large_cw {}", "MOVETO(1, 0) {} ARCREL(-2, 0, 1.5) {} ARCREL(2, 0, 2, 1.5, 30) large_cw {}"),
        (
            "MOVETO(1, 1) {} CURVETO(3, 1, 2, 3) {} CURVETO(5, 1) smooth {} CURVETO(7, 1, 6, 0, 6.5, 3) {} \
             CURVETO(9, 1, 8, 2) smooth {}",
            "MOVETO(1, 1) {} CURVEREL(2, 0, 1, 2) {} CURVEREL(2, 0) smooth {} CURVEREL(2, 0, 1, -1, 1.5, 2) {} \
             CURVEREL(2, 0, 1, 1) smooth {}",
        ),
        // After CLOSEPOLY the current point is the closed subpath's start.
        (
            "MOVETO(0, 0) {} LINETO(1, 0) {} LINETO(1, 1) {} CLOSEPOLY {} MOVETO(2, 0) {} LINETO(3, 0) {} LINETO(3, 1) {}",
            "MOVETO(0, 0) {} LINEREL(1, 0) {} LINEREL(0, 1) {} CLOSEPOLY {} MOVEREL(2, 0) {} LINEREL(1, 0) {} \
             LINEREL(0, 1) {}",
        ),
    ];
    for (abs, rel) in pairs {
        // Stroked and filled, in a turned and scaled frame: the same area and box
        // (the points are kept in single precision, so not the same triangles).
        let run = |body: &str| {
            let out = run_source(&format!(
                "startshape A\nrule A {{ P {{x 1 rz 30 s 2}} }}\nrule P {{ {body} STROKE(0.1) {{}} FILL {{}} }}\n"
            ));
            assert_eq!(out.stats.paths, 2, "{body}");
            xy_area_and_box(&out.mesh)
        };
        let ((a0, b0), (a1, b1)) = (run(abs), run(rel));
        assert!(a0 > 1.0 && (a0 - a1).abs() < 1e-4 * a0, "{rel}: {a0} {a1}");
        assert!(b0.iter().zip(b1).all(|(x, y)| (x - y).abs() < 1e-4), "{rel}: {b0:?} {b1:?}");
    }
    // The offset turns with the drawable's frame (an iterator turns its first run
    // too): a turtle square of side 1, up, left, down and right.
    let out = run_source("startshape S\nrule S { MOVETO(0, 0) {} 4 * [rz 90] LINEREL(1, 0) {} FILL {} }\n");
    let (area, b) = xy_area_and_box(&out.mesh);
    assert!((area - 1.0).abs() < 1e-4, "{area}");
    assert!(b.iter().zip([-1.0, 0.0, 0.0, 1.0]).all(|(a, e)| (a - e).abs() < 1e-4), "{b:?}");
}

/// The fast path's frame-only activations (`Lean`: no call or iterator changes
/// colour, weight or fps) and the fast path that composes whole states (`Simple`)
/// give the very instances, counts and warnings the general loop gives (sites
/// recorded, which takes it off the fast path): depth selection (by the lean
/// calls' tables, past their end, and at the cap), call-less leaves, `minsize`,
/// `maxdepth`, `maxiter` (ending the run at a refused call or an admitted one),
/// iterators and a stack limit; a colour change keeps whole states.
#[test]
fn the_fast_paths_give_what_the_general_loop_gives() {
    let tree = |head: &str, adj: &str| {
        format!(
            "startshape T\n{head}\nrule T {{\n  VERTEX [x -0.5 y -0.5] VERTEX [x 0.5 y -0.5] VERTEX [x 0.5 y 0.5]\n  \
             T [y 1 rz 25 s 0.75{adj}]\n  T [y 1 rz -25 s 0.8{adj}]\n}}\n"
        )
    };
    let sources = [
        tree("maxdepth 9", ""),
        tree("maxdepth 30\nminsize 0.05", ""),
        tree("maxdepth 12\nstacksize 6", ""),
        tree("maxdepth 12\nmaxiter 4097", ""),
        tree("maxdepth 12\nmaxiter 5001", ""),
        tree("maxdepth 12\nmaxiter 4096", ""),
        tree("maxdepth 11\nmaxiter 8190", ""),
        tree("maxdepth 8", " hue 10 A -0.01"),
        "startshape T\nselector T depth\nmaxdepth 6\n\
         rule T 0 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] }\n\
         rule T 2 { VERTEX [x 1] VERTEX [y 1] VERTEX [z 1] 3 * [rz 120] { T [s 0.4 x 1] } }\n"
            .to_string(),
        // (Leaves at `maxdepth` with no call, and with calls after a loop.)
        "startshape T\nselector T depth\nmaxdepth 2\n\
         rule T 0 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] T [s 0.5 z 1] }\n\
         rule T 1 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] T [s 0.5 z 1] }\n\
         rule T 2 { VERTEX [x 1] VERTEX [y 1] VERTEX [z 1] }\n"
            .to_string(),
        "startshape T\nmaxdepth 7\n\
         rule T { VERTEX [x 1] VERTEX [y 1] VERTEX [] 2 * [rz 90] { T [s 0.5 x 1] } T [s 0.5 y 1] }\n"
            .to_string(),
        // (Prototypes of different sizes: a lean run that counts its instances one
        // by one.)
        "startshape T\nselector T depth\nmaxdepth 9\n\
         rule T 0 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] }\n\
         rule T 1 { VERTEX [x 1] VERTEX [y 1] VERTEX [] VERTEX [x 2] VERTEX [y 2] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] }\n"
            .to_string(),
        // (Frames that overflow, and frames past the finiteness bound that stay
        // finite: the bound of a lean run's frames is tested when the run is over.)
        "startshape T\nmaxdepth 40\nrule T { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 30 x 1] }\n".to_string(),
        "startshape T\nmaxdepth 40\nrule T { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [x 1e14] }\n".to_string(),
        // (A prototype whose extent alone fails the bound.)
        "startshape T\nmaxdepth 12\nrule T { VERTEX [x 1e30] VERTEX [y 1] VERTEX [] T [s 10] }\n".to_string(),
        "startshape T\nmaxdepth 9\nrule T { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.3 x 1] T [s 0.5 y 1] T [s 60 z 1] }\n"
            .to_string(),
        // (One definition per depth, the deepest with no call: a depth table read
        // past its end, call-less leaves, and a mesh column made dense.)
        format!(
            "startshape T\nselector T depth\n{}rule T 9 {{ VERTEX [x 1] VERTEX [y 1] VERTEX [] }}\n",
            (0..9)
                .map(|d| format!("rule T {d} {{ VERTEX [x {}] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] }}\n", d + 1))
                .collect::<String>()
        ),
        "startshape T\nselector T depth\nmaxdepth 12\n\
         rule T 1 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 y 1] }\n\
         rule T 3 { VERTEX [x 1] VERTEX [y 1] VERTEX [z 1] T [s 0.5 x 1] T [s 0.5 y 1] }\n"
            .to_string(),
        // (A depth table at its cap, read by the general selection past it, and a
        // rule chosen at random beside it.)
        "startshape T\nselector T depth\nmaxdepth 10\n\
         rule T 0 { VERTEX [x 1] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] L [s 0.5 y 1] }\n\
         rule T 5000 { VERTEX [x 1] VERTEX [y 1] VERTEX [z 1] T [s 0.5 x 1] L [s 0.5 y 1] }\n\
         rule L 0.5 { VERTEX [x 2] VERTEX [y 1] VERTEX [] T [s 0.5 x 1] T [s 0.5 z 1] }\n\
         rule L 0.5 { VERTEX [x 1] VERTEX [y 2] VERTEX [] }\n"
            .to_string(),
    ];
    // (The vertex budget, looked at every 4,096 calls, counts a lean run's
    // instances while it runs, as vertices or as records.)
    let budgets = [
        EvalOptions::default(),
        EvalOptions { max_vertices: 5_000, ..EvalOptions::default() },
        EvalOptions { max_vertices: 5_000, instances_stored: true, ..EvalOptions::default() },
        EvalOptions { max_vertices: 13_000, ..EvalOptions::default() },
    ];
    let runs = sources.iter().flat_map(|src| budgets.iter().map(move |o| (src, o)));
    for (src, opts) in runs {
        let b = build_source(src);
        let fast = evaluate(&b, opts);
        let general = evaluate(&b, &EvalOptions { record_sites: true, ..opts.clone() });
        let bits = |o: &mdg_vm::output::Output| -> Vec<Vec<u32>> {
            o.instances
                .iter()
                .map(|i| {
                    let f = i.frame;
                    let mut v: Vec<u32> =
                        [f.q.to_array(), f.qh.to_array(), i.color].concat().iter().map(|c| c.to_bits()).collect();
                    v.extend(f.u.to_array().map(f32::to_bits));
                    v.extend([i.mesh, i.bone, i.lin, i.at]);
                    v
                })
                .collect()
        };
        assert!(fast.instances.len() > 10, "{src}: {} instances", fast.instances.len());
        assert!(bits(&fast) == bits(&general), "{src}: the instances differ");
        let counts = |o: &mdg_vm::output::Output| {
            (o.stats.rule_calls, o.stats.max_depth, o.stats.vertices, o.stats.triangles, o.stats.warnings.clone())
        };
        assert_eq!(counts(&fast), counts(&general), "{src}, max_vertices {}", opts.max_vertices);
    }
}

/// An identity block (`{ … }`: `LOOP count=1` with the identity step) that the
/// evaluator enters without an iterator record, where composing the identity
/// keeps every bit of the state, gives what its counted run of one gives: the
/// same programs with each such `LOOP` made a `LOOPN` whose count is the
/// expression `1` (never entered that way, and off the fast paths) make the same
/// instances, vertices, counts and warnings. The programs nest blocks in
/// iterators and recursion, put a non-uniform scale (whose states do not keep the
/// identity: their blocks open records) under blocks that do not have one, end
/// runs by limits inside blocks, and change colours.
#[test]
fn identity_blocks_give_what_a_counted_run_of_one_gives() {
    use mdg_vm::bundle::{ExprId, Op};
    use mdg_vm::expr::ExprOp;
    let sources = [
        "startshape grid\nrule grid {\n  30 * {x 1} 20 * {y 1} {\n    VERTEX [x -0.5 y -0.5] VERTEX [x 0.5 y -0.5] \
         VERTEX [x 0.5 y 0.5]\n  }\n}\n",
        "startshape T\nmaxdepth 5\nrule T {\n  3 * [rz 120 x -0] { VERTEX [x -0.5 y -0.5 b -0] VERTEX [x 0.5 y -0.5] \
         VERTEX [x 0.5 y 0.5] { T [s 0.5 x 1 s -1 1 1] VERTEX [z -0] VERTEX [x 1] VERTEX [y 1] } }\n  \
         { VERTEX [] VERTEX [x 1] VERTEX [y 1] }\n}\n",
        "startshape T\nmaxdepth 5\nrule T {\n  4 * [x 1 rz 90 hue 30 sat 0.5 b 0.1] { VERTEX [x -0.5 y -0.5] \
         VERTEX [x 0.5 y -0.5] VERTEX [x 0.5 y 0.5] 2 * [y 1] { T [s 0.4 r 180] } }\n  \
         VERTEX [x 1] \\ { VERTEX [] VERTEX [x 1] VERTEX [y 1] }\n}\n",
        "startshape T\nmaxdepth 4\nrule T {\n  5 * [x 1] 5 * [y 1] { VERTEX [x -0.5 y -0.5] VERTEX [x 0.5 y -0.5] \
         VERTEX [x 0.5 y 0.5] T [s 0.2 z -0 rx 180] }\n}\n",
        "startshape T\nmaxdepth 9\nrule T {\n  { VERTEX [x 1] VERTEX [y 1] VERTEX [] { T [s 0.5 x 1] } }\n  \
         2 * [rz 90] { T [s 0.5 y 1] { VERTEX [x 2] VERTEX [y 2] VERTEX [] } }\n}\n",
        "startshape T\nmaxdepth 9\nmaxiter 3000\nrule T {\n  3 * [x 1] { VERTEX [x 1] VERTEX [y 1] VERTEX [] \
         { T [s 0.5 x 1] T [s 0.5 y 1 s 1 2 1] } }\n}\n",
        // (Flips whose frames have a `-0.0` every other depth: a block's record
        // open in a caller under the same block entered without one.)
        "startshape T\nmaxdepth 6\nrule T {\n  VERTEX [x 1] VERTEX [y 1] VERTEX []\n  \
         { T [fx] VERTEX [x 2] VERTEX [y 2] VERTEX [] }\n  2 * [x 1] { T [y 1 fy] }\n}\n",
        // (Frames that overflow.)
        "startshape T\nmaxdepth 3\nrule T {\n  { VERTEX [x 1] VERTEX [y 1] VERTEX [] { T [x 1e38 x 1e38 s 1e30] } }\n}\n",
    ];
    // (Some state at a block does not keep the identity, by a signed zero or an
    // infinity in its frame: the test can fail both ways.)
    let special = |o: &mdg_vm::output::Output| {
        o.instances.iter().any(|i| {
            let f = i.frame;
            [f.q.to_array(), f.qh.to_array()]
                .concat()
                .into_iter()
                .chain(f.u.to_array())
                .any(|c| c.to_bits() == 0x8000_0000 || !c.is_finite())
        })
    };
    let specials: Vec<bool> =
        sources.iter().map(|src| special(&evaluate(&build_source(src), &EvalOptions::default()))).collect();
    assert!(specials.iter().filter(|&&s| s).count() >= 2, "{specials:?}");
    let budgets = [EvalOptions::default(), EvalOptions { max_vertices: 5_000, ..EvalOptions::default() }];
    for src in sources {
        let b = build_source(src);
        let mut counted = b.clone();
        let one = ExprId(counted.exprs.len() as u32);
        counted.exprs.push(vec![ExprOp::Push(1.0)]);
        let mut blocks = 0;
        for op in &mut counted.code {
            if let Op::Loop { count: 1, step, end, chain } = *op {
                *op = Op::LoopN { count: one, step, end, chain };
                blocks += 1;
            }
        }
        assert!(blocks > 0, "{src}: no block");
        for opts in &budgets {
            let reference = evaluate(&counted, opts);
            for o in [opts.clone(), EvalOptions { record_sites: true, ..opts.clone() }] {
                let out = evaluate(&b, &o);
                let bits = |o: &mdg_vm::output::Output| -> (Vec<u32>, Vec<u32>) {
                    let frames = o
                        .instances
                        .iter()
                        .flat_map(|i| {
                            let f = i.frame;
                            let mut v: Vec<f32> = [f.q.to_array(), f.qh.to_array(), i.color].concat();
                            v.extend(f.u.to_array());
                            v.into_iter().map(f32::to_bits).chain([i.mesh, i.bone, i.lin, i.at])
                        })
                        .collect();
                    let m = &o.mesh;
                    let vertices = m.positions.iter().chain(&m.normals).flatten().chain(m.colors.iter().flatten());
                    (frames, vertices.map(|c| c.to_bits()).collect())
                };
                assert!(bits(&out) == bits(&reference), "{src}: the outputs differ");
                let counts = |o: &mdg_vm::output::Output| {
                    (
                        o.stats.rule_calls,
                        o.stats.max_depth,
                        o.stats.vertices,
                        o.stats.triangles,
                        o.stats.warnings.clone(),
                    )
                };
                assert_eq!(counts(&out), counts(&reference), "{src}");
            }
        }
    }
}
