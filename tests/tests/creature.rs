//! End-to-end tests of the creature grammar with the std part library
//! (std/creatures.mdg) and std/examples/monsters.mdg: compile, evolve, stability
//! of the real quadruped, determinism, imported OBJ meshes, the `mdg-run` mode's
//! files, `--keep`, bundle round trip, editor hooks.

use mdg_cli::modes::creature::{options, run, CreatureArgs};
use mdg_cli::modes::Common;
use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze;
use mdg_compiler::ext::creature as ext;
use mdg_compiler::source::FsLoader;
use mdg_creature::evolve::{Evolution, EvolveOptions};
use mdg_creature::geometry::{layout, Library};
use mdg_creature::shape::Shape;
use mdg_creature::table::RuleKind;
use mdg_creature::CreatureTable;
use mdg_tests::{options as compile_options, root, run_source};
use mdg_vm::bundle::{Bundle, Section};
use std::path::Path;

fn monsters() -> Bundle {
    let path = root().join("std/examples/monsters.mdg");
    let a = analyze(&FsLoader, &path, &compile_options(), CheckOptions { require_start: true });
    assert!(!a.has_errors(), "{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
    mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers")
}

fn shape_named(b: &Bundle, name: &str) -> Shape {
    let t = &CreatureTable::from_bundle(b).expect("a valid section").expect("table");
    let def = t.shapes.iter().find(|s| s.name == name).expect("shape");
    Shape::from_def(t, def)
}

#[test]
fn monsters_compile_into_a_verified_table_that_round_trips() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("creature table");
    assert_eq!(
        t.shapes.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
        ["humanoid", "bird", "quadruped", "ogre", "heron", "boar"]
    );
    for k in ["torso", "head", "arm", "wing", "leg", "lowerlimb", "foreleg", "hindleg", "tail"] {
        assert!(t.kind(k).is_some(), "std parts have a `{k}`");
    }
    for kind in [RuleKind::Increase, RuleKind::Insert, RuleKind::Replace, RuleKind::Combine] {
        assert!(t.rules.iter().any(|r| r.kind == kind), "monsters.mdg uses {kind:?} rules");
    }
    let bytes = mdg_vm::bundle::encode(&b);
    let back = mdg_vm::bundle::load(&bytes).expect("decodes and verifies");
    assert_eq!(CreatureTable::from_bundle(&back).expect("a valid section").as_ref(), Some(t));
    // A corrupt index is rejected by the section's verifier, not a panic later.
    let mut bad = b.clone();
    let mut broken = t.clone();
    broken.shapes[0].torso = 999;
    broken.store(&mut bad.extensions);
    let back = mdg_vm::bundle::load(&mdg_vm::bundle::encode(&bad)).expect("the rest of the bundle is intact");
    assert!(CreatureTable::from_bundle(&back).is_err_and(|e| e.to_string().contains("creatures: ")));
}

#[test]
fn the_std_quadruped_stands_and_falls_without_its_legs() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    for name in ["humanoid", "bird", "quadruped"] {
        let l = layout(t, &lib, &shape_named(&b, name));
        assert!(l.stability.stable, "the regular {name} stands: {:?}", l.stability);
    }
    let q = shape_named(&b, "quadruped");
    let standing = layout(t, &lib, &q);
    assert!(standing.stability.hull.len() >= 4);
    assert!(standing.stability.margin > 0.05, "{:?}", standing.stability.margin);
    let legs: Vec<usize> = (0..q.supers.len())
        .filter(|&i| ["foreleg", "hindleg"].contains(&t.kinds[q.supers[i].kind as usize].name.as_str()))
        .collect();
    assert_eq!(legs.len(), 4);
    let mut legless = q.clone();
    legless.remove(&legs);
    let l = layout(t, &lib, &legless);
    assert!(!l.stability.stable, "a quadruped without legs cannot stand");
    // With only its hind legs it tips over too.
    let mut hind = q.clone();
    hind.remove(&legs[..2]);
    assert!(!layout(t, &lib, &hind).stability.stable);
}

#[test]
fn evolution_is_deterministic_and_makes_monsters() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let run = |seed: u64| {
        let mut o = EvolveOptions::from_table(t);
        o.seed = seed;
        o.generations = 3;
        let evo = Evolution::new(t, &lib, o);
        let (mut pop, _) = evo.start();
        (0..3)
            .map(|_| {
                let g = evo.step(&mut pop, None);
                g.presented
                    .iter()
                    .map(|i| {
                        (i.id.clone(), i.shape.describe(t), i.layout.placed.len(), i.layout.stability.com.to_array())
                    })
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>()
    };
    let a = run(11);
    assert_eq!(a, run(11));
    assert_ne!(a, run(12));
    let last = a.last().expect("generation 3");
    assert_eq!(last.len(), 18);
    // Monsters: more parts than any regular creature (at most 7 meta-parts).
    let bigger = last.iter().filter(|m| m.2 > 7).count();
    assert!(bigger >= 9, "{bigger} of 18 monsters grew");
}

/// Compiles `main.mdg` in `dir` (with the std library) and embeds its meshes.
fn build_with_meshes(dir: &Path) -> (Option<Bundle>, Vec<mdg_compiler::diag::Diagnostic>) {
    let a = analyze(&FsLoader, &dir.join("main.mdg"), &compile_options(), CheckOptions { require_start: true });
    assert!(!a.has_errors(), "{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
    let mut b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
    let d = ext::embed_meshes(&mut b, &a.expanded, &a.sources, &FsLoader, Some(&root().join("std")));
    (Some(b), d)
}

#[test]
fn obj_meshes_are_embedded_at_compile_time() {
    let base = std::env::temp_dir().join(format!("mdg-creature-obj-{}", std::process::id()));
    let dir = base.join("project");
    std::fs::create_dir_all(dir.join("parts")).expect("dirs");
    let obj = "# a unit cube\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
               f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
    let src = r#"
startshape show
rule show { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
creature blocks {
  part box { type torso; category block; mesh "parts/box.obj"; color 0.8 0.3 0.2;
    slot top { at 0.5 0.5 1; normal 0 0 1; size 0.5; accepts head; }
  }
  part lid { type head; category block; mesh "parts/box.obj"; joint { at 0.5 0.5 0; normal 0 0 -1; size 1; } }
  shape tower { torso box; attach top lid; }
}
"#;
    std::fs::write(dir.join("parts/box.obj"), obj).expect("obj");
    std::fs::write(dir.join("main.mdg"), src).expect("mdg");
    let (b, d) = build_with_meshes(&dir);
    assert!(d.is_empty(), "{d:?}");
    let b = b.expect("bundle");
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    assert_eq!(t.meshes.len(), 2);
    assert_eq!(t.meshes[0].positions.len(), 8);
    assert_eq!(t.meshes[0].triangles.len(), 12);
    assert_eq!(t.meshes[0].color, [0.8, 0.3, 0.2, 1.0]);
    // The tower: the lid (joint size 1) on a slot of size 0.5 is half as big and
    // sits on top of the box, so the model is 1.5 high.
    let lib = Library::build(&b, t).expect("library");
    let l = layout(t, &lib, &Shape::from_def(t, &t.shapes[0]));
    assert!(((l.max.z - l.min.z) - 1.5).abs() < 1e-5, "{:?} {:?}", l.min, l.max);
    // Self-contained: the bundle still loads after an encode/decode round trip.
    let back = mdg_vm::bundle::load(&mdg_vm::bundle::encode(&b)).expect("loads");
    assert_eq!(CreatureTable::from_bundle(&back).expect("a valid section").as_ref().map(|t| t.meshes.len()), Some(2));

    // `mdg-run` on the source embeds them itself when the bundle lacks them.
    let a = analyze(&FsLoader, &dir.join("main.mdg"), &compile_options(), CheckOptions { require_start: true });
    let bare = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
    assert!(CreatureTable::from_bundle(&bare)
        .expect("a valid section")
        .as_ref()
        .is_some_and(|t| t.meshes[0].triangles.is_empty()));
    let out = base.join("out");
    let file = dir.join("main.mdg");
    let common = Common {
        file: &file,
        output: Some(&out),
        seed: None,
        stats: false,
        png: None,
        size: (64, 64),
        pictures: &mdg_cli::pictures::Software,
        eval: mdg_vm::eval::EvalOptions::default(),
        compile: Box::leak(Box::default()),
    };
    let args = CreatureArgs { generations: Some(0), ..CreatureArgs::default() };
    assert_eq!(run(&bare, &args, &common), Ok(()));
    assert!(out.join("gen0/g0-00.glb").is_file());

    // A missing file, a malformed one and one outside the project are E0810.
    std::fs::write(dir.join("parts/bad.obj"), "v 0 0 0\nf 1 2 3\n").expect("bad obj");
    std::fs::create_dir_all(base.join("elsewhere")).expect("dir");
    std::fs::write(base.join("elsewhere/box.obj"), obj).expect("outside obj");
    for (path, want) in [
        ("parts/none.obj", "cannot find mesh"),
        ("parts/bad.obj", "not a usable OBJ"),
        ("../elsewhere/box.obj", "outside the project"),
    ] {
        let src2 = src.replace("\"parts/box.obj\"; color", &format!("\"{path}\"; color"));
        std::fs::write(dir.join("main.mdg"), &src2).expect("mdg");
        let (_, d) = build_with_meshes(&dir);
        assert_eq!(d.len(), 1, "{path}: {d:?}");
        assert_eq!(d[0].code, "E0810");
        assert!(d[0].message.contains(want), "{path}: {}", d[0].message);
    }
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn obj_parser_reports_bad_lines() {
    assert!(ext::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").is_ok());
    assert!(ext::parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").is_ok());
    let fails = |text: &str, want: &str| matches!(ext::parse_obj(text), Err(e) if e.to_string().contains(want));
    assert!(fails("v 0 0\n", "line 1"));
    assert!(fails("v 0 0 0\nf 1 2 7\n", "line 2"));
    assert!(fails("v 0 0 0\n", "no faces"));
}

#[test]
fn the_mode_writes_models_pictures_and_a_gallery_and_keeps_chosen_monsters() {
    let b = monsters();
    let out = std::env::temp_dir().join(format!("mdg-creature-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let file = root().join("std/examples/monsters.mdg");
    let common = Common {
        file: &file,
        output: Some(&out),
        seed: Some(4),
        stats: false,
        png: None,
        size: (800, 600),
        pictures: &mdg_cli::pictures::Software,
        eval: mdg_vm::eval::EvalOptions::default(),
        compile: Box::leak(Box::default()),
    };
    let args = CreatureArgs { generations: Some(2), population: Some(6), ..CreatureArgs::default() };
    assert_eq!(run(&b, &args, &common), Ok(()));
    let html = std::fs::read_to_string(out.join("index.html")).expect("gallery");
    for g in 0..=2 {
        assert!(out.join(format!("gen{g}/sheet.png")).is_file());
    }
    let glbs: Vec<_> = std::fs::read_dir(out.join("gen2"))
        .expect("gen2")
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "glb"))
        .collect();
    assert_eq!(glbs.len(), 6);
    let glb = std::fs::read(out.join("gen2/g2-00.glb")).expect("glb");
    assert_eq!(&glb[..4], b"glTF");
    assert!(html.contains("g2-05") && html.contains("structure:") && html.contains("HDM"));
    assert!(html.contains("S0 torso["), "the gallery shows each monster's structure");
    // The models are valid glTF (Khronos validator, as for the std examples).
    if std::env::var_os("MDG_SKIP_NODE_TESTS").is_none() {
        let validator = root().join("tests/gltf/validate.mjs");
        assert!(root().join("tests/gltf/node_modules/gltf-validator").is_dir(), "run `npm ci --prefix tests/gltf`");
        let status = std::process::Command::new("node")
            .arg(&validator)
            .arg(out.join("gen2/g2-00.glb"))
            .arg(out.join("gen0/g0-02.glb"))
            .status()
            .expect("run node");
        assert!(status.success(), "glTF validation failed");
    }
    // The run's record: grammar hash, options, every monster's abstract shape;
    // the gallery has a checkbox per monster and the command they build.
    let record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("run.json")).expect("run.json")).expect("json");
    assert_eq!(record["grammar"]["sha256"].as_str().map(str::len), Some(64));
    assert_eq!(record["options"]["seed"], 4);
    assert_eq!(record["options"]["population"], 6);
    assert_eq!(record["generations"][2]["presented"].as_array().map(Vec::len), Some(6));
    assert!(record["generations"][2]["presented"][0]["shape"]["supers"].is_array());
    assert!(html.contains("<input type=\"checkbox\" class=\"keep\" value=\"g2-05\">"));
    assert!(html.contains("--keep IDS --from ") && html.contains("--seed 4 --population 6"));
    // Continue from two monsters of generation 2: generations 3 and 4 follow.
    let more = out.join("more");
    let common = Common { output: Some(&more), ..common };
    let keep = CreatureArgs { keep: vec!["g2-01".into(), "g2-04".into()], from: Some(out.clone()), ..args.clone() };
    assert_eq!(run(&b, &keep, &common), Ok(()));
    let html = std::fs::read_to_string(more.join("index.html")).expect("gallery");
    assert!(html.contains("continued from g2-01, g2-04"));
    assert!(more.join("gen4/g4-00.glb").is_file() && !more.join("gen1").exists());
    // The kept monsters are the parents of generation 3.
    assert!(html.contains("base g2-01") || html.contains("base g2-04"));
    // Continuing from the record is continuing the replayed run.
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let o = options(t, &args, Some(4)).expect("options");
    let evo = Evolution::new(t, &lib, o.clone());
    let (mut pop, _) = evo.start();
    evo.step(&mut pop, None);
    evo.step(&mut pop, None);
    let replayed = mdg_cli::modes::creature::continue_from(&evo, &mut pop, &keep.keep, 1).expect("replay");
    let more_record: serde_json::Value =
        serde_json::from_slice(&std::fs::read(more.join("run.json")).expect("run.json")).expect("json");
    let from_record: Vec<&str> = more_record["generations"][0]["presented"]
        .as_array()
        .expect("generation 3")
        .iter()
        .map(|m| m["structure"].as_str().expect("structure"))
        .collect();
    let from_replay: Vec<String> = replayed[0].presented.iter().map(|i| i.shape.describe(t)).collect();
    assert_eq!(from_record, from_replay);
    // An unknown id is a clear error, and so are other options or another grammar.
    let bad = CreatureArgs { keep: vec!["g2-77".into()], from: Some(out.clone()), ..args.clone() };
    assert_eq!(run(&b, &bad, &common).map_err(|f| f.exit), Err(mdg_cli::failure::Exit::Usage));
    let other = CreatureArgs { population: Some(7), ..keep.clone() };
    assert_eq!(run(&b, &other, &common).map_err(|f| f.exit), Err(mdg_cli::failure::Exit::Usage));
    let no_record = CreatureArgs { from: Some(more.join("gen3")), ..keep.clone() };
    assert_eq!(run(&b, &no_record, &common).map_err(|f| f.exit), Err(mdg_cli::failure::Exit::Usage));
    let forged = out.join("forged");
    std::fs::create_dir_all(&forged).expect("dir");
    let mut r = record.clone();
    r["grammar"]["sha256"] = serde_json::json!("0".repeat(64));
    std::fs::write(forged.join("run.json"), serde_json::to_vec(&r).expect("json")).expect("write");
    let forged_args = CreatureArgs { from: Some(forged), ..keep.clone() };
    assert_eq!(run(&b, &forged_args, &common).map_err(|f| f.exit), Err(mdg_cli::failure::Exit::Usage));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn command_line_options_override_the_evolve_block() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let args = CreatureArgs {
        generations: Some(7),
        population: Some(10),
        without_rules: vec!["increase".into()],
        ..CreatureArgs::default()
    };
    let o = options(t, &args, Some(99)).expect("options");
    assert_eq!((o.generations, o.population, o.offspring, o.seed), (7, 10, 30, 99));
    assert_eq!(o.disabled, vec![RuleKind::Increase]);
    assert!(o.diversity_control);
    let off = CreatureArgs { no_diversity_control: true, ..CreatureArgs::default() };
    assert!(!options(t, &off, None).expect("options").diversity_control);
    let bad = CreatureArgs { without_rules: vec!["grow".into()], ..CreatureArgs::default() };
    assert!(options(t, &bad, None).is_err());
    let bad = CreatureArgs { generations: Some(5000), ..CreatureArgs::default() };
    assert!(options(t, &bad, None).is_err());
}

#[test]
fn editor_hooks_know_the_keys_and_the_rule_references() {
    let keys = mdg_compiler::ext::keys(&["creature", "rule"]);
    for k in ["kind", "priority", "predecessor", "condition", "probability"] {
        let key = keys.iter().find(|x| x.name == k).expect("documented key");
        assert!(!key.doc.is_empty());
    }
    assert!(mdg_compiler::ext::keys(&["creature", "part", "slot"]).iter().any(|k| k.name == "symmetric"));
    let path = root().join("std/creatures.mdg");
    let a = analyze(&FsLoader, &path, &compile_options(), CheckOptions { require_start: false });
    assert!(a.diagnostics.is_empty());
    let sec = mdg_compiler::ext::sections(&a.expanded, "creature");
    let refs: Vec<&str> =
        sec.iter().flat_map(|s| mdg_compiler::ext::rule_refs(s.section)).map(|n| n.text.as_str()).collect();
    assert!(refs.contains(&"h_torso") && refs.contains(&"q_hindleg") && refs.len() == 28, "{refs:?}");
}

/// Variety: the std library has at least two parts of every (type, category) it
/// has a part of, each with its own geometry rule.
#[test]
fn std_library_has_two_variants_per_type_and_category() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("a creature table");
    let mut per: std::collections::BTreeMap<(String, String), Vec<u32>> = Default::default();
    for p in &t.parts {
        let key = (t.kinds[p.kind as usize].name.clone(), t.categories[p.category as usize].clone());
        let mdg_creature::table::Geometry::Rule(r) = p.geometry else { panic!("{}: not a rule", p.name) };
        per.entry(key).or_default().push(r);
    }
    assert_eq!(per.len(), 14, "{:?}", per.keys());
    for (key, rules) in &per {
        let mut distinct = rules.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert!(distinct.len() >= 2, "{key:?} has {} variant(s)", distinct.len());
    }
}

/// The std/sdf.mdg helpers inline to the formula written out: the same mesh, bit
/// for bit, as the hand-written distance (an ellipsoid and a capsule, smoothly
/// united).
#[test]
fn sdf_helpers_give_the_written_out_surface() {
    let helpers = "@import sdf\nstartshape A\nisosurface I { xyz -1.5 1.5 24 ; function { \
        smooth_union(ellipsoid(x, y, z, 0.1, 0, 0, 1, 0.5, 0.5), capsule(x, y, z, 0, 0, 0, 1.2, 0, 0.6, 0.2, 0.05), 0.1) } }\n\
        rule A { I {} }\n";
    let t = "clamp((x * 1.2 + y * 0 + z * 0.6) / 1.7999999999999998, 0, 1)";
    let written = format!(
        "startshape A\nisosurface I {{ xyz -1.5 1.5 24 ; function {{ \
        -0.1 * log(exp(-((sqrt(((x - 0.1))^2 + (y / 0.5)^2 + (z / 0.5)^2) - 1) * 0.5) / 0.1) \
        + exp(-(sqrt((x - {t} * 1.2)^2 + (y - {t} * 0)^2 + (z - {t} * 0.6)^2) - (0.2 + -0.15000000000000002 * {t})) / 0.1)) }} }}\n\
        rule A {{ I {{}} }}\n"
    );
    let a = run_source(helpers);
    let b = run_source(&written);
    let verts = |o: &mdg_vm::output::Output| format!("{:?}", o.shared_meshes);
    assert!(a.shared_meshes.first().is_some_and(|s| s.mesh.positions.len() > 500), "a surface is made");
    assert_eq!(verts(&a), verts(&b));
}

#[test]
fn the_documented_example_compiles_and_evolves() {
    let doc = std::fs::read_to_string(root().join("docs/creatures.md")).expect("docs/creatures.md");
    let start = doc.find("```mdg\n").expect("an mdg example") + 7;
    let len = doc[start..].find("```").expect("closed");
    let b = mdg_tests::build_source(&doc[start..start + len]);
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    assert_eq!(t.shapes.len(), 2);
    assert_eq!(t.rules.len(), 3);
    let lib = Library::build(&b, t).expect("library");
    let evo = Evolution::new(t, &lib, EvolveOptions::from_table(t));
    let (mut pop, _) = evo.start();
    let g = evo.step(&mut pop, None);
    // A humanoid and a horse with heads, wings and a Centaur: look-alikes (copies
    // hiding one another, a second head behind the first) are not presented twice,
    // so fewer than twelve may show (5 at this seed: one step from two creatures
    // makes few monsters that look different).
    assert!((4..=12).contains(&g.presented.len()), "{}", g.presented.len());
}

/// Evolves `generations` generations of `monsters.mdg` from `seed` without the
/// contact test (so a detached part would be presented, not rejected): every
/// presented and background monster.
fn evolve_without_contact_test(
    t: &mdg_creature::table::CreatureTable,
    lib: &Library,
    seed: u64,
    generations: u32,
) -> Vec<mdg_creature::evolve::Individual> {
    let mut o = EvolveOptions::from_table(t);
    o.seed = seed;
    o.require_contact = false;
    let evo = Evolution::new(t, lib, o);
    let (mut pop, g0) = evo.start();
    let mut all = g0.presented;
    for _ in 0..generations {
        let g = evo.step(&mut pop, None);
        all.extend(g.presented);
        all.extend(g.background);
    }
    all
}

#[test]
fn every_placed_part_touches_its_torso_over_many_seeds() {
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let mut lib = Library::build(&b, t).expect("library");
    let (mut parts, mut monsters) = (0, 0);
    for seed in [1, 2, 3, 5, 7, 11, 42] {
        for ind in evolve_without_contact_test(t, &lib, seed, 3) {
            assert!(
                ind.layout.detached.is_empty(),
                "seed {seed}, {}: meta-parts {:?} touch nothing of their torso ({})",
                ind.id,
                ind.layout.detached,
                ind.shape.describe(t)
            );
            // The same check, spelled out: every part is within ε of its torso.
            for sp in &ind.shape.supers {
                let Some(a) = sp.attach else { continue };
                let parent = ind.shape.supers[a.parent as usize].metas[0].id;
                let pp = ind.layout.placed.iter().find(|p| p.meta == parent).expect("torso placed");
                for m in &sp.metas {
                    let cp = ind.layout.placed.iter().find(|p| p.meta == m.id).expect("part placed");
                    assert!(mdg_creature::geometry::touches(&lib, cp, pp));
                    parts += 1;
                }
            }
            monsters += 1;
        }
    }
    assert!(monsters > 300 && parts > 3000, "{monsters} monsters, {parts} parts");
    // No presented set holds one abstract shape twice, with diversity control or without.
    for control in [true, false] {
        let mut o = EvolveOptions::from_table(t);
        o.seed = 5;
        o.diversity_control = control;
        let evo = Evolution::new(t, &lib, o);
        let (mut pop, _) = evo.start();
        for _ in 0..4 {
            let g = evo.step(&mut pop, None);
            let mut shapes: Vec<String> = g.presented.iter().map(|i| i.shape.describe(t)).collect();
            shapes.sort_unstable();
            let n = shapes.len();
            shapes.dedup();
            assert_eq!(shapes.len(), n, "generation {} presents a monster twice", g.index);
        }
    }
    // The test can fail: with the plain arrangement offsets (copies not seated on
    // the torso's surface) some outer copies hang in the air.
    lib.seat = false;
    let detached: usize = [1, 3, 7]
        .iter()
        .flat_map(|&seed| evolve_without_contact_test(t, &lib, seed, 3))
        .filter(|i| !i.layout.detached.is_empty())
        .count();
    assert!(detached > 0, "plain offsets leave some parts touching nothing");
}

/// The JSON chunk of a `.glb`.
fn glb_json(bytes: &[u8]) -> serde_json::Value {
    assert_eq!(&bytes[..4], b"glTF");
    let len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).expect("glTF JSON")
}

/// A monster of generation 2 with a row or stack of copies and mirrored parts.
fn a_monster(t: &mdg_creature::table::CreatureTable, lib: &Library) -> mdg_creature::evolve::Individual {
    let mut o = EvolveOptions::from_table(t);
    o.seed = 3;
    let evo = Evolution::new(t, lib, o);
    let (mut pop, _) = evo.start();
    evo.step(&mut pop, None);
    let g = evo.step(&mut pop, None);
    g.presented.into_iter().find(|i| i.shape.supers.iter().any(|s| s.metas.len() > 1)).expect("a monster with copies")
}

#[test]
fn a_monster_glb_has_one_named_node_per_part_sharing_one_mesh_per_library_part() {
    use mdg_creature::geometry::{node_name, write_glb};
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let ind = a_monster(t, &lib);
    let bytes = write_glb(t, &lib, &ind.id, &ind.shape, &ind.layout.placed).expect("glb");
    let json = glb_json(&bytes);
    let nodes = json["nodes"].as_array().expect("nodes");
    // One root (the y-up turn, named after the monster) holding the root torso;
    // every part is a node.
    let roots = json["scenes"][0]["nodes"].as_array().expect("scene");
    assert_eq!(roots.len(), 1);
    let root = &nodes[roots[0].as_u64().expect("index") as usize];
    assert_eq!(root["name"], ind.id.as_str());
    assert_eq!(nodes.len(), ind.layout.placed.len() + 1);
    let mut names: Vec<&str> = nodes.iter().filter_map(|n| n["name"].as_str()).filter(|n| *n != ind.id).collect();
    let mut expected: Vec<String> = ind.layout.placed.iter().map(|p| node_name(t, &ind.shape, p.meta)).collect();
    names.sort_unstable();
    expected.sort_unstable();
    assert_eq!(names, expected);
    assert!(names.iter().any(|n| n.starts_with("S0.torso[0] ")), "{names:?}");
    assert!(names.iter().all(|n| n.contains('[') && n.contains("] ")), "{names:?}");
    // Every mesh is a library part (or its mirror image), written once.
    let meshes: Vec<&str> =
        json["meshes"].as_array().expect("meshes").iter().map(|m| m["name"].as_str().expect("name")).collect();
    let mut distinct = meshes.clone();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(distinct.len(), meshes.len(), "{meshes:?}");
    assert!(meshes.len() < ind.layout.placed.len(), "parts share meshes: {meshes:?}");
    for m in &meshes {
        let part = m.strip_suffix(" mirrored").unwrap_or(m);
        assert!(t.parts.iter().any(|p| p.name == part), "{m}");
    }
    // Shared meshes make the file smaller than the baked monster.
    let mut baked = mdg_vm::output::Mesh::default();
    mdg_creature::geometry::assemble(&lib, &ind.layout.placed, glam::Vec3::ZERO, &mut baked);
    let mut one = Vec::new();
    mdg_export::glb::write_glb(&mdg_creature::geometry::output_of(baked, [1.0; 4]), &mut one).expect("glb");
    assert!(bytes.len() < one.len(), "{} bytes as parts, {} baked", bytes.len(), one.len());
    // Deterministic.
    assert_eq!(bytes, write_glb(t, &lib, &ind.id, &ind.shape, &ind.layout.placed).expect("glb"));
}

/// A presented monster of seed 3 with a second torso that carries parts of its own
/// (a rider on a quadruped's withers, or a humanoid on a horse's body).
fn a_rider(t: &mdg_creature::table::CreatureTable, lib: &Library) -> mdg_creature::evolve::Individual {
    let mut o = EvolveOptions::from_table(t);
    o.seed = 3;
    let evo = Evolution::new(t, lib, o);
    let (mut pop, _) = evo.start();
    for _ in 0..6 {
        let g = evo.step(&mut pop, None);
        let rider = g.presented.into_iter().find(|i| {
            (1..i.shape.supers.len())
                .any(|k| t.kinds[i.shape.supers[k].kind as usize].torso && i.shape.children(k as u32).next().is_some())
        });
        if let Some(r) = rider {
            return r;
        }
    }
    panic!("no monster with a rider in six generations of seed 3");
}

/// glTF node `n`'s local matrix (TRS, or the identity).
fn local_matrix(n: &serde_json::Value) -> glam::Mat4 {
    let v = |k: &str, d: &[f32]| -> Vec<f32> {
        n[k].as_array().map(|a| a.iter().map(|x| x.as_f64().expect("f") as f32).collect()).unwrap_or(d.to_vec())
    };
    let (t, r, s) = (v("translation", &[0.0; 3]), v("rotation", &[0.0, 0.0, 0.0, 1.0]), v("scale", &[1.0; 3]));
    glam::Mat4::from_scale_rotation_translation(
        glam::Vec3::new(s[0], s[1], s[2]),
        glam::Quat::from_xyzw(r[0], r[1], r[2], r[3]),
        glam::Vec3::new(t[0], t[1], t[2]),
    )
}

#[test]
fn a_monster_glb_hangs_every_part_from_its_torso_with_part_materials_and_sides() {
    use mdg_creature::geometry::{node_name, write_glb};
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    for ind in [a_rider(t, &lib), a_monster(t, &lib)] {
        let json = glb_json(&write_glb(t, &lib, &ind.id, &ind.shape, &ind.layout.placed).expect("glb"));
        let nodes = json["nodes"].as_array().expect("nodes");
        let mut parent = vec![None; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            for c in n["children"].as_array().into_iter().flatten() {
                parent[c.as_u64().expect("index") as usize] = Some(i);
            }
        }
        let world = |mut i: usize| {
            let mut m = local_matrix(&nodes[i]);
            while let Some(p) = parent[i] {
                m = local_matrix(&nodes[p]) * m;
                i = p;
            }
            m
        };
        let by_name =
            |name: &str| nodes.iter().position(|n| n["name"] == name).unwrap_or_else(|| panic!("no `{name}`"));
        let size = (ind.layout.max - ind.layout.min).length();
        let y_up = glam::Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        for sp in &ind.shape.supers {
            let torso = sp.attach.map(|a| ind.shape.supers[a.parent as usize].metas[0].id);
            for m in &sp.metas {
                let me = by_name(&node_name(t, &ind.shape, m.id));
                // The node hangs from its torso's node (the root torso from the root).
                match torso {
                    Some(torso) => assert_eq!(
                        parent[me].map(|p| nodes[p]["name"].clone()),
                        Some(serde_json::json!(node_name(t, &ind.shape, torso))),
                        "{}: {}",
                        ind.id,
                        nodes[me]["name"]
                    ),
                    None => assert_eq!(parent[me].map(|p| nodes[p]["name"].clone()), Some(ind.id.as_str().into())),
                }
                // Its local transforms compose to where MDG placed it (a mirrored
                // placement refers to the mirrored mesh).
                let p = ind.layout.placed.iter().find(|p| p.meta == m.id).expect("placed");
                let mirror = if glam::Mat3::from_mat4(p.transform).determinant() < 0.0 {
                    glam::Mat4::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0))
                } else {
                    glam::Mat4::IDENTITY
                };
                let want = y_up * p.transform * mirror;
                let got = world(me);
                for c in 0..4 {
                    assert!(
                        (got.col(c) - want.col(c)).length() < 1e-4 * size.max(1.0),
                        "{} {}: {got} against {want}",
                        ind.id,
                        nodes[me]["name"]
                    );
                }
                // Its material is named after its part.
                let mesh = &json["meshes"][nodes[me]["mesh"].as_u64().expect("mesh") as usize];
                let material =
                    &json["materials"][mesh["primitives"][0]["material"].as_u64().expect("material") as usize];
                assert_eq!(material["name"], t.parts[m.geometry as usize].name.as_str(), "{}", nodes[me]["name"]);
            }
        }
        // Parts on mirror slots carry Blender's side suffixes, in pairs whose names
        // differ only in the suffix.
        let names: Vec<&str> = nodes.iter().filter_map(|n| n["name"].as_str()).collect();
        let left: Vec<&&str> = names.iter().filter(|n| n.ends_with(".L")).collect();
        assert!(!left.is_empty(), "{}: {names:?}", ind.id);
        for l in left {
            let r = format!("{}.R", &l[..l.len() - 2]);
            assert!(names.contains(&r.as_str()), "{}: `{l}` without `{r}` in {names:?}", ind.id);
        }
        assert_eq!(
            json["materials"].as_array().expect("materials").iter().filter(|m| m.get("name").is_none()).count(),
            0
        );
    }
}

/// The Python interpreter of the venv holding `bpy` (installed by `.ci/run`).
fn bpy_python() -> std::path::PathBuf {
    if let Some(p) = std::env::var_os("MDG_BPY_PYTHON") {
        return p.into();
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(std::path::PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| std::path::PathBuf::from(h).join(".cache")))
        .unwrap_or_else(|| ".cache".into());
    cache.join("mdg/bpy-venv/bin/python")
}

#[test]
fn blender_imports_monsters_as_named_parts_standing_upright() {
    use mdg_creature::geometry::{node_name, write_glb};
    if std::env::var_os("MDG_SKIP_CLIENT_TESTS").is_some() {
        return;
    }
    let python = bpy_python();
    let ok = std::process::Command::new(&python).args(["-c", "import bpy"]).output().is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "Blender's `bpy` is missing ({}): `bash .ci/run` installs it; set MDG_SKIP_CLIENT_TESTS=1 to skip",
        python.display()
    );
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let dir = std::env::temp_dir().join(format!("mdg-creature-blender-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let mut monsters = vec![a_monster(t, &lib), a_rider(t, &lib)];
    let mut humanoid = Evolution::new(t, &lib, EvolveOptions::from_table(t)).initial().presented;
    monsters.push(humanoid.remove(0));
    let is_torso = |k: u32| t.kinds[k as usize].torso;
    let mut jobs = Vec::new();
    for m in &monsters {
        let path = dir.join(format!("{}.glb", m.id));
        std::fs::write(&path, write_glb(t, &lib, &m.id, &m.shape, &m.layout.placed).expect("glb")).expect("write");
        // Every torso is dragged once (Blender moves the object with its children).
        let torsos: Vec<String> =
            m.shape.supers.iter().filter(|s| is_torso(s.kind)).map(|s| node_name(t, &m.shape, s.metas[0].id)).collect();
        jobs.push(serde_json::json!({ "name": m.id, "glb": path, "move": torsos }));
    }
    let (jobs_path, result_path) = (dir.join("jobs.json"), dir.join("result.json"));
    std::fs::write(&jobs_path, serde_json::to_vec(&jobs).expect("json")).expect("write");
    let out = std::process::Command::new(&python)
        .arg(root().join("tests/clients/blender_creature.py"))
        .arg(&jobs_path)
        .arg(&result_path)
        .output()
        .expect("run Blender");
    assert!(out.status.success(), "Blender: {}", String::from_utf8_lossy(&out.stderr));
    let result: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&result_path).expect("result")).expect("json");
    for m in &monsters {
        let r = &result["results"][m.id.as_str()];
        assert!(r.get("error").is_none(), "{}: {}", m.id, r["error"]);
        let objects = r["objects"].as_array().expect("objects");
        let meshes: Vec<&serde_json::Value> = objects.iter().filter(|o| o["type"] == "MESH").collect();
        assert_eq!(meshes.len(), m.layout.placed.len(), "{}: one object per part", m.id);
        let size = (m.layout.max - m.layout.min).length();
        for p in &m.layout.placed {
            let name = node_name(t, &m.shape, p.meta);
            let o =
                meshes.iter().find(|o| o["name"] == name.as_str()).unwrap_or_else(|| panic!("{}: no `{name}`", m.id));
            // Where MDG put the part (z up, feet on the ground): Blender is z up too,
            // so the imported object's world box is the same box.
            let (mut lo, mut hi) = (glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN));
            for q in &lib.parts[p.part as usize].mesh.positions {
                let w = p.transform.transform_point3(glam::Vec3::from(*q));
                lo = lo.min(w);
                hi = hi.max(w);
            }
            let got = |k: &str| -> glam::Vec3 {
                let v: Vec<f32> = o[k].as_array().expect("box").iter().map(|x| x.as_f64().expect("f") as f32).collect();
                glam::Vec3::new(v[0], v[1], v[2])
            };
            assert!(
                (got("min") - lo).length() < 1e-3 * size && (got("max") - hi).length() < 1e-3 * size,
                "{} `{name}`: Blender box {:?}..{:?}, MDG {lo}..{hi}",
                m.id,
                got("min"),
                got("max")
            );
            let part = &t.parts[p.part as usize].name;
            assert!(o["mesh"].as_str().expect("mesh").starts_with(part.as_str()), "{name}: mesh {}", o["mesh"]);
        }
        // Upright: the feet at z = 0, the head above the torso's centre.
        let min_z = meshes.iter().map(|o| o["min"][2].as_f64().expect("z")).fold(f64::MAX, f64::min);
        // (MDG grounds the model on a sample of surface points, one per 1/14 of a
        // part's diagonal, so the lowest vertex may be a little below z = 0.)
        assert!(min_z.abs() < 1e-2 * size as f64, "{}: lowest point {min_z}", m.id);
        let centre_z = |prefix: &str| {
            meshes
                .iter()
                .find(|o| o["name"].as_str().expect("name").split_once('.').is_some_and(|(_, r)| r.starts_with(prefix)))
                .map(|o| (o["min"][2].as_f64().expect("z") + o["max"][2].as_f64().expect("z")) / 2.0)
        };
        if let (Some(head), Some(torso)) = (centre_z("head["), centre_z("torso[0]")) {
            assert!(head > torso, "{}: the head ({head}) stands above the torso ({torso})", m.id);
        }
        // Parts of one library part share one Blender mesh.
        let data: std::collections::BTreeSet<&str> = meshes.iter().map(|o| o["mesh"].as_str().expect("mesh")).collect();
        if m.shape.supers.iter().any(|s| s.metas.len() > 1) {
            assert!(data.len() < meshes.len(), "{}: shared meshes {data:?}", m.id);
        }
        // Materials are named after the parts.
        for o in &meshes {
            let part = o["mesh"].as_str().expect("mesh").trim_end_matches(" mirrored");
            assert_eq!(o["materials"], serde_json::json!([part]), "{}: {}", m.id, o["name"]);
        }
        // Dragging a torso moves the parts attached to it (and to the torsos riding
        // on it), and nothing else.
        let (mut dragged, mut stayed) = (0, 0);
        for (si, sp) in m.shape.supers.iter().enumerate().filter(|(_, s)| is_torso(s.kind)) {
            let name = node_name(t, &m.shape, sp.metas[0].id);
            let moved = &r["moved"][name.as_str()];
            assert!(moved.is_object(), "{}: Blender has no `{name}`", m.id);
            for (k, other) in m.shape.supers.iter().enumerate() {
                // Whether super-part k is si or hangs from it, through torsos.
                let mut at = k;
                let mut below = at == si;
                while let (false, Some(a)) = (below, m.shape.supers[at].attach) {
                    at = a.parent as usize;
                    below = at == si;
                }
                for meta in &other.metas {
                    let o = node_name(t, &m.shape, meta.id);
                    let before = meshes.iter().find(|x| x["name"] == o.as_str()).expect("object");
                    let dx = moved[o.as_str()][0][0].as_f64().expect("x") - before["min"][0].as_f64().expect("x");
                    let dy = moved[o.as_str()][0][1].as_f64().expect("y") - before["min"][1].as_f64().expect("y");
                    let want = if below { 1.0 } else { 0.0 };
                    assert!(
                        (dx - want).abs() < 1e-4 && dy.abs() < 1e-4,
                        "{}: dragging `{name}` moved `{o}` by ({dx}, {dy})",
                        m.id
                    );
                    if below {
                        dragged += 1;
                    } else {
                        stayed += 1;
                    }
                }
            }
        }
        assert!(dragged >= m.shape.n_metas(), "{}: {dragged} parts followed their torsos", m.id);
        if m.shape.n_torsos(t) > 1 {
            assert!(stayed > 0, "{}: dragging the rider leaves the body's own parts where they are", m.id);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A grammar of fliers without legs (std bird parts): `floats` is `floats;` or "".
fn fliers(floats: &str) -> String {
    format!(
        r#"@import creatures
startshape show
rule show {{
  b_torso {{}}
}}
creature sky {{
  shape flier {{ torso b_torso; attach neck b_head; attach wing_l b_wing; attach tail b_tail; {floats} }}
  rule heads {{ kind increase; predecessor head; max 3; }}
  rule wings {{ kind increase; predecessor wing; arrange stack; max 3; }}
  evolve {{ population 4; generations 2; seed 1; }}
}}
"#
    )
}

#[test]
fn creatures_that_do_not_stand_are_warned_about_an_empty_generation_is_an_error_and_floats_evolves() {
    // The checker warns: nothing to stand on.
    let path = root().join("tests/inline.mdg");
    let a = mdg_compiler::driver::analyze_text(
        &FsLoader,
        &path,
        &fliers(""),
        &compile_options(),
        CheckOptions { require_start: true },
    );
    assert!(!a.has_errors());
    assert!(a.diagnostics.iter().any(|d| d.code == "W0801"), "{:?}", a.diagnostics);
    let a = mdg_compiler::driver::analyze_text(
        &FsLoader,
        &path,
        &fliers("floats;"),
        &compile_options(),
        CheckOptions { require_start: true },
    );
    assert!(a.diagnostics.iter().all(|d| d.code != "W0801"));
    // Without `floats` no offspring stands: the mode stops with exit status 3.
    let out = std::env::temp_dir().join(format!("mdg-creature-fliers-{}", std::process::id()));
    let common = Common {
        file: &path,
        output: Some(&out),
        seed: None,
        stats: false,
        png: None,
        size: (800, 600),
        pictures: &mdg_cli::pictures::Software,
        eval: mdg_vm::eval::EvalOptions::default(),
        compile: Box::leak(Box::default()),
    };
    let b = mdg_tests::build_source(&fliers(""));
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let evo = Evolution::new(t, &lib, EvolveOptions::from_table(t));
    let (mut pop, _) = evo.start();
    let g = evo.step(&mut pop, None);
    let why = g.empty(&evo.opts).expect("an empty generation");
    assert!(why.contains("generation 1 is empty") && why.contains("floats"), "{why}");
    assert_eq!(run(&b, &CreatureArgs::default(), &common).map_err(|f| f.exit), Err(mdg_cli::failure::Exit::Extinct));
    // With `floats;` they evolve.
    let b = mdg_tests::build_source(&fliers("floats;"));
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    assert!(t.shapes[0].floats);
    let lib = Library::build(&b, t).expect("library");
    let evo = Evolution::new(t, &lib, EvolveOptions::from_table(t));
    let (mut pop, _) = evo.start();
    let g = evo.step(&mut pop, None);
    // (Two increase rules and two steps make only a few distinct fliers.)
    assert!(!g.presented.is_empty() && g.presented.len() <= 4, "{}", g.presented.len());
    assert!(g.presented.iter().all(|i| i.shape.floats && !i.layout.stability.stable));
    assert_eq!(run(&b, &CreatureArgs::default(), &common), Ok(()));
    // So does the grammar with `stability off;`.
    let b = mdg_tests::build_source(&fliers("").replace("seed 1;", "seed 1; stability off;"));
    assert!(!&CreatureTable::from_bundle(&b).expect("a valid section").expect("table").evolve.stability);
    let _ = std::fs::remove_dir_all(&out);
}

fn grammar(rel: &str) -> Bundle {
    let path = root().join(rel);
    let a = analyze(&FsLoader, &path, &compile_options(), CheckOptions { require_start: true });
    assert!(!a.has_errors(), "{}", mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
    mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers")
}

/// The humanoid's presented monsters per generation of the spider grammar (seed 4,
/// four generations of 12), and the notes of lineages that died out.
fn spider_run(lineages: bool) -> Vec<(usize, usize, Vec<String>)> {
    let b = grammar("tests/creatures/spiders.mdg");
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let mut o = EvolveOptions::from_table(t);
    o.seed = 4;
    o.lineages = lineages;
    // Without lineages kept, look-alikes kept too (`--no-lineages
    // --allow-lookalikes`): the spiders' many near-identical variants crowd the
    // presented set. (Dropping look-alikes alone leaves the humanoid line its place
    // at this seed: the spiders look too much alike to fill the set.)
    o.drop_lookalikes = lineages;
    let evo = Evolution::new(t, &lib, o);
    let (mut pop, _) = evo.start();
    (1..=4)
        .map(|_| {
            let g = evo.step(&mut pop, None);
            let n = |l: &str| g.lineages.get(l).copied().unwrap_or(0);
            (n("humanoid"), n("spider"), g.extinct)
        })
        .collect()
}

#[test]
fn a_body_plan_the_spiders_crowd_out_keeps_its_place_and_its_end_is_noted() {
    // Without lineages kept alive and with look-alikes kept, the spiders (C_s 66
    // against the humanoid's 18, roulette selection) crowd the humanoid line out of
    // the presented set in generation 4, and a note says so.
    let free = spider_run(false);
    assert!(free[0].0 >= 3, "{free:?}");
    assert_eq!(free[3].0, 0, "{free:?}");
    assert!(
        free[3].2.iter().any(|n| n.contains("lineage `humanoid` died out of the presented set in generation 4")),
        "{free:?}"
    );
    // Noted once, when it goes.
    assert!(free.iter().take(3).all(|g| g.2.is_empty()), "{free:?}");
    // Kept alive (the default): both lineages in every presented set, no note.
    let kept = spider_run(true);
    for (g, (humanoids, spiders, notes)) in kept.iter().enumerate() {
        assert!(*humanoids >= 1 && *spiders >= 1, "generation {}: {kept:?}", g + 1);
        assert!(notes.is_empty(), "{notes:?}");
    }
}

#[test]
fn a_lineage_the_user_does_not_keep_is_dropped_without_a_note() {
    let b = grammar("tests/creatures/spiders.mdg");
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let mut o = EvolveOptions::from_table(t);
    o.seed = 4;
    let evo = Evolution::new(t, &lib, o);
    let (mut pop, _) = evo.start();
    let g1 = evo.step(&mut pop, None);
    let spiders: Vec<String> = g1
        .presented
        .iter()
        .filter(|i| t.shapes[i.lineage as usize].name == "spider")
        .map(|i| i.id.clone())
        .take(3)
        .collect();
    assert!(!spiders.is_empty());
    evo.keep(&mut pop, &spiders).expect("keep");
    // The offspring's base shapes are the kept spiders: the humanoid line is not
    // among the parents, has no place kept, and its absence is no news.
    let g = evo.step(&mut pop, None);
    assert_eq!(g.lineages.get("humanoid"), None, "{:?}", g.lineages);
    assert!(g.extinct.is_empty(), "{:?}", g.extinct);
}

#[test]
fn without_increase_rules_the_spiders_offspring_are_less_diverse() {
    // The paper's Fig. 13 on the spider grammar, seeds 1–5 and two generations (the
    // first rows of the table in docs/creatures.md §8): the offspring's visible HDM,
    // summed over the seeds, per generation. One seed alone is too small a sample
    // (at seed 2 the variant without increase rules is ahead in generation 1).
    let b = grammar("tests/creatures/spiders.mdg");
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let hdm = |disabled: Vec<RuleKind>| {
        let mut sums = [(0.0f64, 0usize); 2];
        for seed in 1..=5 {
            let mut o = EvolveOptions::from_table(t);
            o.seed = seed;
            o.disabled = disabled.clone();
            let evo = Evolution::new(t, &lib, o);
            let (mut pop, _) = evo.start();
            for s in sums.iter_mut() {
                let g = evo.step(&mut pop, None);
                s.0 += g.offspring_diversity.hdm;
                s.1 += g.n_offspring;
            }
        }
        sums
    };
    let (all, none) = (hdm(Vec::new()), hdm(vec![RuleKind::Increase]));
    for (a, n) in all.iter().zip(&none) {
        assert!(n.1 >= 150 && a.1 >= 150, "offspring made: {all:?} {none:?}");
        assert!(n.0 < 0.9 * a.0, "HDM without increase rules {} against {} with", n.0, a.0);
    }
}

#[test]
fn look_alikes_count_once_in_the_diversity_and_are_not_presented_twice() {
    use mdg_creature::evolve::look_alike;
    let b = monsters();
    let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
    let lib = Library::build(&b, t).expect("library");
    let run = |drop: bool| {
        let mut o = EvolveOptions::from_table(t);
        o.seed = 3;
        o.population = 18;
        o.offspring = 54;
        o.drop_lookalikes = drop;
        o.lineages = drop;
        let evo = Evolution::new(t, &lib, o);
        let (mut pop, _) = evo.start();
        (0..5).map(|_| evo.step(&mut pop, None)).collect::<Vec<_>>()
    };
    // As before issue 43 (look-alikes kept): generation 5 presents a heron with two
    // streamer tails fanned behind each other beside the same heron with one; 18
    // structures, but the measure counts what is visible.
    let before = run(false);
    let g5 = before.last().expect("generation 5");
    assert_eq!(g5.diversity.structures, 18);
    assert!(g5.diversity.clusters < 18, "{:?}", g5.diversity);
    assert!(g5.diversity.hdm < 18.0, "{:?}", g5.diversity);
    // By default no presented set holds two look-alikes.
    let after = run(true);
    for g in &after {
        let p = &g.presented;
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                assert!(!look_alike(&p[i], &p[j]), "generation {}: {} and {}", g.index, p[i].id, p[j].id);
            }
        }
        assert_eq!(g.diversity.clusters, g.diversity.structures, "generation {}", g.index);
    }
    assert!(after.iter().map(|g| g.n_lookalikes).sum::<usize>() > 0);
}

/// The monsters of `set` a person tells apart by silhouette alone, judged without
/// the evolution's code: in order of fewest meta-parts (then first), one counts
/// unless its silhouette is alike to one already counted.
fn silhouette_groups(set: &[mdg_creature::evolve::Individual]) -> usize {
    use mdg_creature::silhouette::alike;
    let mut order: Vec<&mdg_creature::evolve::Individual> = set.iter().collect();
    order.sort_by_key(|i| i.shape.n_metas());
    let mut counted: Vec<&mdg_creature::evolve::Individual> = Vec::new();
    for i in order {
        if counted.iter().all(|k| !alike(&k.silhouette, &i.silhouette)) {
            counted.push(i);
        }
    }
    counted.len()
}

#[test]
fn the_sheets_distinct_count_is_the_silhouette_only_judgement() {
    // The sheets of docs/creatures.md: monsters.mdg seed 3 (population 18,
    // generation 5) and the spider grammar seed 4 (generation 4). Every presented
    // monster is visibly different from every other by its silhouette alone, and
    // the measure's count of visibly different monsters is that judgement — also
    // on the offspring, where look-alikes abound.
    for (rel, seed, population, generations) in
        [("std/examples/monsters.mdg", 3, 18, 5), ("tests/creatures/spiders.mdg", 4, 12, 4)]
    {
        let b = grammar(rel);
        let t = &CreatureTable::from_bundle(&b).expect("a valid section").expect("table");
        let lib = Library::build(&b, t).expect("library");
        let mut o = EvolveOptions::from_table(t);
        o.seed = seed;
        o.population = population;
        o.offspring = 3 * population;
        o.generations = generations;
        let evo = Evolution::new(t, &lib, o.clone());
        let (mut pop, _) = evo.start();
        let mut last = None;
        for _ in 0..generations {
            last = Some(evo.step(&mut pop, None));
        }
        let g = last.expect("a generation");
        let p = &g.presented;
        assert_eq!(g.diversity.visible, silhouette_groups(p), "{rel}");
        assert_eq!(g.diversity.visible, p.len(), "{rel}: a look-alike presented");
        assert!(p.len() >= (population as usize * 2) / 3, "{rel}: only {} presented", p.len());
        // With look-alikes kept (as before), the count is still the judgement.
        o.drop_lookalikes = false;
        o.lineages = false;
        let evo = Evolution::new(t, &lib, o);
        let (mut pop, _) = evo.start();
        for _ in 0..generations {
            let g = evo.step(&mut pop, None);
            assert_eq!(g.diversity.visible, silhouette_groups(&g.presented), "{rel}");
        }
    }
}
