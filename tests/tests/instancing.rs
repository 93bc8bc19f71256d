//! Instances as the evaluator's output (issue 20) give the model that running every
//! item one by one gives: for every std example `evaluate` runs, for the benchmark
//! workloads at reduced size, a grid of squares and `tests/instancing/prototypes.mdg`
//! (every kind of prototype instance), the instanced path (`INST` ops emit one
//! prototype instance per run) and the flat path (`EvalOptions::instancing` off)
//! give the same triangles, sweeps, lines, isosurface instances and counters.
//!
//! Compared, with the tolerances stated in the constants below: vertex and triangle
//! counts, every position (within [`POSITION_TOLERANCE`] of the extent, the largest
//! absolute coordinate), normal (within [`NORMAL_TOLERANCE`]), colour, weight and
//! bone, and the oriented triangles (the winding exporters write) — of
//! `Output::vertex_mesh()` of the instanced run against `Output::mesh` of the flat
//! one, and of `Output::flattened()` of both (the meshes themselves where no
//! prototype instance was made); for animated grammars also at two times through
//! `Output::posed`. Where the flat run drew items that an `INST` op covers, the
//! instanced run must have made prototype instances (else the comparison would
//! compare the flat path with itself), except in the examples listed, with the
//! reason, in [`LEFT_TO_THE_ITEMS`].

use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::{analyze_text, Analysis};
use mdg_compiler::source::FsLoader;
use mdg_tests::{analyze_file, mdg_files, options, root};
use mdg_vm::bundle::{Bundle, Op, SectionKind};
use mdg_vm::eval::{evaluate, EvalOptions};
use mdg_vm::output::{Mesh, Output, SharedKind};
use std::collections::BTreeSet;

/// Largest difference allowed between a position of the two paths, relative to the
/// model's extent (its largest absolute coordinate). The expansion is meant to be
/// bit for bit; the tolerance is the issue's.
const POSITION_TOLERANCE: f32 = 1e-6;
/// Largest difference allowed per normal component (normals are unit vectors).
const NORMAL_TOLERANCE: f32 = 1e-6;

fn lower(name: &str, a: &Analysis) -> Bundle {
    assert!(!a.has_errors(), "{name} does not compile:\n{}", mdg_tests::render(a));
    mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).unwrap_or_else(|e| panic!("{name}: {e:?}"))
}

/// A benchmark workload with its text rewritten by `(from, to)` pairs (each must
/// apply: the test fails if a workload changes under it).
fn workload(file: &str, edits: &[(&str, &str)]) -> (String, Bundle) {
    let path = root().join("benches/workloads").join(file);
    let mut text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    for (from, to) in edits {
        assert!(text.contains(from), "{file}: `{from}` not found (the workload changed)");
        text = text.replace(from, to);
    }
    let a = analyze_text(&FsLoader, &path, &text, &options(), CheckOptions { require_start: true });
    let name =
        format!("{file} ({})", edits.iter().map(|(_, to)| to.trim().replace('\n', " ")).collect::<Vec<_>>().join(", "));
    let b = lower(&name, &a);
    (name, b)
}

/// Every std example that `evaluate` runs as a model (the creature and grid modes
/// make their models their own way; a `search` grammar's plain evaluation is a model).
fn std_examples() -> Vec<(String, Bundle)> {
    let mut v = Vec::new();
    for path in mdg_files("std/examples") {
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let b = lower(&name, &analyze_file(&path, true));
        if b.extensions.has(SectionKind::Creatures) || b.extensions.has(SectionKind::Grid) {
            continue;
        }
        v.push((name, b));
    }
    assert!(v.len() >= 12, "std examples: {}", v.len());
    v
}

/// Std examples whose prototype items all run item by item, and why: the evaluator
/// instances a run only where that gives the very triangles the items would.
const LEFT_TO_THE_ITEMS: &[(&str, &str)] =
    &[("pebbles", "every prototype (disc, cube) is called in a non-uniform frame, `s X Y Z`")];

/// The source lines (file, line) of the ops that `INST` ops cover: the prototype
/// items of the grammar (and of the std rules it imports, used or not).
fn prototype_lines(b: &Bundle) -> BTreeSet<(String, u32)> {
    let mut lines = BTreeSet::new();
    for (pc, op) in b.code.iter().enumerate() {
        if let Op::Inst { count, .. } = *op {
            for item in pc as u32 + 1..=pc as u32 + count.0 {
                if let Some((file, line)) = b.source_of(item) {
                    lines.insert((file.to_string(), line));
                }
            }
        }
    }
    lines
}

/// Whether the flat run (evaluated with sites recorded) drew a triangle with an op
/// on a line that an `INST` op covers: then the instanced run must have made
/// prototype instances.
fn drew_prototype_items(b: &Bundle, flat: &Output) -> bool {
    let lines = prototype_lines(b);
    flat.sites.sites.iter().any(|s| lines.contains(&(s.file.clone(), s.line)))
}

fn prototype_instances(out: &Output) -> usize {
    out.instances.iter().filter(|i| out.is_prototype_instance(i)).count()
}

/// Bits of a float with every NaN alike (so NaN = NaN, and 0.0 ≠ -0.0 is not
/// forgiven: the paths are meant to be bit for bit).
fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn extent(m: &Mesh) -> f32 {
    m.positions.iter().flatten().filter(|c| c.is_finite()).fold(0.0f32, |e, c| e.max(c.abs()))
}

/// `got` (instanced path) against `want` (flat path): `Err` with the first
/// differences found.
fn compare(what: &str, got: &Mesh, want: &Mesh) -> Result<(), String> {
    let (nv, nt) = (want.n_vertices(), want.triangles.len());
    if got.n_vertices() != nv || got.triangles.len() != nt {
        return Err(format!(
            "{what}: {} vertices {} triangles, the flat path {nv} and {nt}",
            got.n_vertices(),
            got.triangles.len()
        ));
    }
    let tol = POSITION_TOLERANCE * extent(want).max(f32::MIN_POSITIVE);
    let mut diffs = Vec::new();
    let mut note = |d: String| {
        if diffs.len() < 5 {
            diffs.push(d);
        }
    };
    let near = |a: f32, b: f32, tol: f32| same(a, b) || (a - b).abs() <= tol;
    for i in 0..nv {
        let (p, q) = (got.positions[i], want.positions[i]);
        if !(0..3).all(|k| near(p[k], q[k], tol)) {
            note(format!("vertex {i}: position {p:?}, flat {q:?} (tolerance {tol:e})"));
        }
        let (n, m) = (got.normals.get(i).copied(), want.normals.get(i).copied());
        let normals_ok = match (n, m) {
            (Some(n), Some(m)) => (0..3).all(|k| near(n[k], m[k], NORMAL_TOLERANCE)),
            (n, m) => n == m,
        };
        if !normals_ok {
            note(format!("vertex {i}: normal {n:?}, flat {m:?}"));
        }
        let (c, d) = (got.colors.get(i).copied(), want.colors.get(i).copied());
        if !match (c, d) {
            (Some(c), Some(d)) => (0..4).all(|k| same(c[k], d[k])),
            (c, d) => c == d,
        } {
            note(format!("vertex {i}: colour {c:?}, flat {d:?}"));
        }
        if got.weight(i) != want.weight(i) {
            note(format!("vertex {i}: weight {:?}, flat {:?}", got.weight(i), want.weight(i)));
        }
        if got.bone(i) != want.bone(i) {
            note(format!("vertex {i}: bone {}, flat {}", got.bone(i), want.bone(i)));
        }
    }
    for (t, (a, b)) in got.oriented_triangles().zip(want.oriented_triangles()).enumerate() {
        if a != b {
            note(format!("triangle {t}: {a:?}, flat {b:?} (as exporters wind them)"));
        }
    }
    if diffs.is_empty() {
        Ok(())
    } else {
        Err(format!("{what}:\n    {}", diffs.join("\n    ")))
    }
}

/// What the two paths must share besides the `VERTEX` triangles: sweeps, lines,
/// isosurface instances (each with its mesh), the counters.
fn compare_rest(name: &str, inst: &Output, flat: &Output) -> Vec<String> {
    let mut problems = Vec::new();
    if let Err(e) = compare(&format!("{name}: sweeps"), &inst.sweeps, &flat.sweeps) {
        problems.push(e);
    }
    if inst.lines != flat.lines {
        problems.push(format!("{name}: the pen lines differ"));
    }
    let isosurfaces = |o: &Output| -> Vec<_> {
        o.instances
            .iter()
            .enumerate()
            .filter(|(_, i)| !o.is_prototype_instance(i))
            .map(|(k, i)| {
                let shared = o.shared(&i).map(|s| (s.name.clone(), s.mesh.clone()));
                let lin = o.lins.get(i.lin as usize).filter(|_| i.lin != 0).map(|l| (l.0.to_cols_array(), l.1));
                (i.frame, i.color, i.bone, lin, shared, o.instance_weight(k))
            })
            .collect()
    };
    let (a, b) = (isosurfaces(inst), isosurfaces(flat));
    if a != b {
        problems.push(format!("{name}: isosurface instances differ ({} and {} on the flat path)", a.len(), b.len()));
    }
    if prototype_instances(flat) != 0 {
        problems.push(format!("{name}: the flat path made {} prototype instances", prototype_instances(flat)));
    }
    let (s, t) = (&inst.stats, &flat.stats);
    let counters = |s: &mdg_vm::output::Stats| (s.rule_calls, s.vertices, s.triangles, s.max_depth, s.warnings.clone());
    if counters(s) != counters(t) {
        problems.push(format!("{name}: stats {:?}, the flat path {:?}", counters(s), counters(t)));
    }
    if inst.animation != flat.animation || inst.background != flat.background || inst.debug != flat.debug {
        problems.push(format!("{name}: animation, background or DEBUG reports differ"));
    }
    problems
}

/// Evaluates `b` both ways and compares; returns the problems found and the number
/// of prototype instances the instanced path made.
fn check(name: &str, b: &Bundle) -> (Vec<String>, usize) {
    let inst = evaluate(b, &EvalOptions { instancing: true, ..EvalOptions::default() });
    // Sites (which op drew each triangle) tell which prototype items the flat run
    // drew; recording them changes nothing else.
    let flat = evaluate(b, &EvalOptions { instancing: false, record_sites: true, ..EvalOptions::default() });
    let mut problems = Vec::new();
    let made = prototype_instances(&inst);
    let refused = LEFT_TO_THE_ITEMS.iter().find(|(n, _)| *n == name);
    match refused {
        None if made == 0 && drew_prototype_items(b, &flat) => problems
            .push(format!("{name}: the flat run drew prototype items (INST) but the instanced run made no instance")),
        Some((_, why)) if made != 0 => problems.push(format!(
            "{name}: made {made} prototype instances, but LEFT_TO_THE_ITEMS says it makes none ({why}): update the list"
        )),
        _ => {}
    }
    if made == 0 {
        // Nothing to expand: the meshes themselves (the rest is compared below), without
        // copying a big model (coral's) three more times.
        if let Err(e) = compare(&format!("{name}: mesh"), &inst.mesh, &flat.mesh) {
            problems.push(e);
        }
    } else {
        if let Err(e) = compare(&format!("{name}: vertex_mesh()"), &inst.vertex_mesh(), &flat.mesh) {
            problems.push(e);
        }
        if let Err(e) = compare(&format!("{name}: flattened()"), &inst.flattened(), &flat.flattened()) {
            problems.push(e);
        }
    }
    problems.extend(compare_rest(name, &inst, &flat));
    // Animated: the poses at two times (posed expands instances of moving bones).
    if inst.animation.bones.len() > 1 {
        let duration = f64::from(inst.animation.duration.max(1.0));
        for t in [0.0, 0.37 * duration] {
            let (p, q) = (inst.posed(t), flat.posed(t));
            if let Err(e) = compare(&format!("{name}: posed({t:.2}).vertex_mesh()"), &p.vertex_mesh(), &q.mesh) {
                problems.push(e);
            }
            if let Err(e) = compare(&format!("{name}: posed({t:.2}).flattened()"), &p.flattened(), &q.flattened()) {
                problems.push(e);
            }
        }
    }
    (problems, made)
}

/// What the instanced outputs of a set of grammars exercised, so that a corpus that
/// stops covering a path is noticed.
#[derive(Default, Debug)]
struct Coverage {
    mirrored: usize,
    colour_deltas: usize,
    face_normals: usize,
    weights: usize,
    on_bones: usize,
}

impl Coverage {
    fn add(&mut self, b: &Bundle) {
        let out = evaluate(b, &EvalOptions::default());
        for (k, i) in out.instances.iter().enumerate() {
            let Some(shared) = out.shared(&i).filter(|s| s.is_prototype()) else { continue };
            self.mirrored += usize::from(i.frame.mirrored());
            self.colour_deltas += usize::from(shared.mesh.colors.iter().any(|c| *c != [0.0; 4]));
            if let SharedKind::Prototype { face_normals } = &shared.kind {
                self.face_normals += usize::from(face_normals.iter().any(Option::is_some));
            }
            self.weights += usize::from(out.instance_weight(k) != [0.0; 4] || !shared.mesh.weights.is_empty());
            self.on_bones += usize::from(i.bone != 0);
        }
    }
}

#[test]
fn std_examples_give_the_same_triangles_instanced_and_flat() {
    let mut problems = Vec::new();
    let mut coverage = Coverage::default();
    let mut with_instances = 0;
    for (name, b) in std_examples() {
        let started = std::time::Instant::now();
        let (p, made) = check(&name, &b);
        eprintln!("{name}: {made} prototype instances, compared in {:.2} s", started.elapsed().as_secs_f64());
        problems.extend(p);
        with_instances += usize::from(made > 0);
        coverage.add(&b);
    }
    eprintln!("prototype instances that are mirrored, have colour deltas, FACENORMALS, weights, bones: {coverage:?}");
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
    // The corpus exercises the expansion's branches (a test of nothing passes too).
    assert!(with_instances >= 8, "only {with_instances} std examples make prototype instances");
    assert!(coverage.mirrored > 0, "no mirrored prototype instance in the std examples: {coverage:?}");
    assert!(coverage.face_normals > 0, "no prototype with FACENORMALS in the std examples: {coverage:?}");
    assert!(coverage.on_bones > 0, "no prototype instance on an animated bone in the std examples: {coverage:?}");
}

/// `tests/instancing/prototypes.mdg` has every kind of prototype instance, including
/// those no std example makes (items with colour and weight deltas, items mirrored
/// inside the prototype) and calls the evaluator must leave to the items.
#[test]
fn every_kind_of_prototype_instance_gives_the_same_triangles() {
    let b = lower("prototypes.mdg", &analyze_file(&root().join("tests/instancing/prototypes.mdg"), true));
    let (problems, made) = check("prototypes.mdg", &b);
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
    let mut coverage = Coverage::default();
    coverage.add(&b);
    eprintln!("prototypes.mdg: {made} prototype instances, {coverage:?}");
    // tri 15 (3 + 8 in a loop + 2 in `chain` + 2 on bones), tinted 5, weighted 1,
    // flipped 2, shaded 2, cube 1; none in `squashed` (a non-uniform frame) or
    // `loose` (after half a triangle), none of `hsb` (not a prototype).
    assert_eq!(made, 26);
    assert!(coverage.mirrored >= 4, "{coverage:?}");
    assert!(coverage.colour_deltas >= 5, "{coverage:?}");
    assert!(coverage.face_normals >= 2, "{coverage:?}");
    assert!(coverage.weights >= 1, "{coverage:?}");
    assert!(coverage.on_bones >= 3, "{coverage:?}");
}

#[test]
fn benchmark_workloads_give_the_same_triangles_instanced_and_flat() {
    // The grid-of-squares workload (the benchmark's 700 × 700 at 100 × 100).
    let grid = analyze_file(&root().join("tests/instancing/grid_of_squares.mdg"), true);
    let workloads = vec![
        workload("tree.mdg", &[("maxdepth 19", "maxdepth 12")]),
        workload("tree_param.mdg", &[("int n = 19", "int n = 12")]),
        workload("tree_depth.mdg", &[("startshape T\n", "startshape T\nmaxdepth 12\n")]),
        // Order 6 (3^6 segments): the thresholds as benches/run rewrites them.
        workload(
            "sierpinski.mdg",
            &[
                ("rule A 11", "rule A 7"),
                ("rule A 12", "rule A 8"),
                ("rule B 11", "rule B 7"),
                ("rule B 12", "rule B 8"),
            ],
        ),
        ("grid of squares 100 × 100".to_string(), lower("grid of squares", &grid)),
    ];
    let mut problems = Vec::new();
    for (name, b) in &workloads {
        let started = std::time::Instant::now();
        let (p, made) = check(name, b);
        eprintln!("{name}: {made} prototype instances, compared in {:.2} s", started.elapsed().as_secs_f64());
        problems.extend(p);
        // Every workload but the sweep-made Sierpinski curve is one prototype per call.
        let expected = match name.split(' ').next() {
            Some("tree.mdg" | "tree_param.mdg" | "tree_depth.mdg") => Some((1 << 13) - 1),
            Some("grid") => Some(100 * 100),
            _ => None,
        };
        if let Some(n) = expected {
            if made != n {
                problems.push(format!("{name}: {made} prototype instances, expected {n}"));
            }
        }
    }
    assert!(problems.is_empty(), "{} problems:\n{}", problems.len(), problems.join("\n"));
}

/// The binary chunk of a `.glb` (after the JSON chunk).
fn glb_binary(b: &[u8]) -> &[u8] {
    let json_len = u32::from_le_bytes(b[12..16].try_into().expect("4 bytes")) as usize;
    let o = 20 + json_len;
    if o >= b.len() {
        return &[];
    }
    &b[o + 8..]
}

/// The flat `.glb` writer expands each prototype instance from its frame itself (one
/// record per vertex, straight into the file): its binary chunk must be byte for byte
/// the one written from the same output with every prototype expanded into the mesh
/// first (`Output::expand_prototypes`, the evaluator's own expansion), for the
/// prototypes of every kind (mirrored, colour deltas, FACENORMALS, bones).
#[test]
fn the_flat_glb_expands_prototypes_as_the_evaluator_does() {
    let mut sources = vec![(
        "prototypes.mdg".to_string(),
        lower("prototypes.mdg", &analyze_file(&root().join("tests/instancing/prototypes.mdg"), true)),
    )];
    sources.extend(std_examples());
    sources.push(workload("tree.mdg", &[("maxdepth 19", "maxdepth 10")]));
    let mut compared = 0;
    let mut problems = Vec::new();
    for (name, b) in &sources {
        let out = evaluate(b, &EvalOptions::default());
        if prototype_instances(&out) == 0 {
            continue;
        }
        let mut expanded = out.clone();
        expanded.expand_prototypes();
        let (mut a, mut e) = (Vec::new(), Vec::new());
        mdg_export::write(mdg_export::Format::Glb, &out, &mut a).expect("writes");
        mdg_export::write(mdg_export::Format::Glb, &expanded, &mut e).expect("writes");
        if glb_binary(&a) != glb_binary(&e) {
            problems.push(format!("{name}: the binary chunks differ ({} and {} bytes)", a.len(), e.len()));
        }
        compared += 1;
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(compared >= 8, "only {compared} outputs with prototype instances");
}
