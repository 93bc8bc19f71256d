//! Tests of the creature section: checks, lowering, never-match and never-hold analyses.
use super::*;
use crate::check::CheckOptions;
use crate::source::MemLoader;

fn table_of(src: &str) -> (CreatureTable, Vec<Diagnostic>) {
    let a = crate::driver::analyze_text(
        &MemLoader::default(),
        std::path::Path::new("/t/main.mdg"),
        src,
        &Default::default(),
        CheckOptions::default(),
    );
    let secs = super::super::sections(&a.expanded, "creature");
    let mut diags = Vec::new();
    let mut resolve =
        |n: &Name, ns: Option<&str>, _: &mut Vec<Diagnostic>| a.checked.symbols.resolve(&n.text, ns).map(|_| 7);
    let t = build(&secs, &a.expanded, &mut resolve, false, &mut diags).expect("a table");
    (t, a.diagnostics)
}

const SRC: &str = r#"
rule blob { VERTEX {} VERTEX {x 1} VERTEX {y 1} }
creature c {
  family arm wing;
  part body { type torso; category a; rule blob;
slot side_l { at 0.3 0.1 1; normal 1 0 1; size 0.2; accepts arm; symmetric side_r; turn 0 90 0; }
  }
  part arm { type arm; category a; rule blob; joint { at 0 0 0; normal -2 0 0; size 0.1; } }
  part wing { type wing; category b; rule blob; scale 1.5; joint { at 0 0 0; normal -1 0 0; up 0 1 1; size 0.1; } }
  shape s { torso body; attach side_r arm 2 stack; floats; }
  rule r { kind replace; predecessor arm; probability (0.5 + 0 * g); }
  select rules rank;
  evolve { population 4; }
}
"#;

#[test]
fn a_section_lowers_to_a_table() {
    let (t, d) = table_of(SRC);
    assert!(d.is_empty(), "{d:?}");
    assert_eq!(
        t.kinds.iter().map(|k| (k.name.as_str(), k.torso)).collect::<Vec<_>>(),
        [("torso", true), ("arm", false), ("wing", false)]
    );
    assert_eq!(t.families, vec![vec![1, 2]]);
    assert!(t.shapes[0].floats, "a creature without legs says `floats`");
    let body = &t.parts[0];
    assert_eq!(body.geometry, Geometry::Rule(7));
    // `symmetric` declares the mirror slot; `accepts arm` takes the whole family.
    let (l, r) = (&body.slots[0], &body.slots[1]);
    assert_eq!((l.name.as_str(), r.name.as_str()), ("side_l", "side_r"));
    assert_eq!((l.partner, r.partner, r.mirror_of), (Some(1), Some(0), Some(0)));
    assert_eq!(r.at, [-0.3, 0.1, 1.0]);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    assert!((l.normal[0] - s).abs() < 1e-6 && (l.normal[2] - s).abs() < 1e-6);
    assert_eq!(l.accepts, vec![1, 2]);
    assert!((l.turn[1] - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
    // The default up is +z made orthogonal to the normal.
    assert!((glam::Vec3::from(l.up) - glam::Vec3::new(-s, 0.0, s)).length() < 1e-6);
    // A joint's up is made orthogonal to its normal; normals become unit vectors.
    let wing = &t.parts[2];
    let j = wing.joint.as_ref().expect("joint");
    assert_eq!(j.normal, [-1.0, 0.0, 0.0]);
    assert!((glam::Vec3::from(j.up) - glam::Vec3::new(0.0, s, s)).length() < 1e-6);
    assert_eq!(wing.scale, 1.5);
    // Attaching to the mirror slot names the original; count and mode kept.
    assert_eq!(t.shapes[0].attach, vec![AttachDef { slot: 0, part: 1, count: 2, mode: Mode::Stack }]);
    assert_eq!(t.select_rules, Strategy::Rank);
    assert_eq!(t.select_shapes, Strategy::Roulette);
    assert_eq!((t.evolve.population, t.evolve.offspring), (4, 12));
    assert_eq!(t.rules[0].kind, RuleKind::Replace);
}

#[test]
fn every_key_table_is_documented_once() {
    for path in [
        &["creature"][..],
        &["creature", "part"],
        &["creature", "part", "joint"],
        &["creature", "part", "slot"],
        &["creature", "shape"],
        &["creature", "rule"],
        &["creature", "evolve"],
    ] {
        let ks = keys(path);
        assert!(!ks.is_empty(), "{path:?}");
        for (i, k) in ks.iter().enumerate() {
            assert!(!k.doc.is_empty() && ks[..i].iter().all(|o| o.name != k.name), "{path:?} {}", k.name);
        }
    }
    assert!(keys(&["creature", "nothing"]).is_empty());
}

/// A one-torso grammar with `slots` on the torso and `attach` in its creature.
fn grammar(slots: &str, attach: &str) -> String {
    format!(
        r#"
rule blob {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}} }}
creature c {{
  part body {{ type torso; category a; rule blob;
slot neck {{ at 0 0 1; normal 0 0 1; size 0.2; accepts head; }}
{slots}
  }}
  part head {{ type head; category a; rule blob; support; joint {{ at 0 0 0; normal 0 0 -1; size 0.2; }} }}
  shape s {{ torso body; attach neck head; {attach} }}
  rule two {{ kind increase; predecessor head; }}
}}
"#
    )
}

#[test]
fn a_bad_attach_keeps_the_shape_and_a_misused_symmetric_is_explained() {
    // The bad attach is reported; the good one stays, so `two` can match.
    let (t, d) = table_of(&grammar("", "attach nose head;"));
    let codes: Vec<&str> = d.iter().map(|d| d.code).collect();
    assert_eq!(codes, ["E0802"], "{d:?}");
    assert_eq!(t.shapes[0].attach.len(), 1);
    let slot = "slot arm_l { at 0.2 0 0.5; normal 1 0 0; size 0.1; accepts head;";
    let (_, d) = table_of(&grammar(&format!("{slot} symmetric arm_l; }}"), ""));
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(d[0].message.contains("cannot be its own mirror slot"), "{d:?}");
    assert!(d[0].notes.iter().any(|n| n.contains("symmetric arm_r")), "{d:?}");
    let (_, d) = table_of(&grammar(
        &format!("{slot} symmetric arm_r; }}\n slot arm_r {{ at -0.2 0 0.5; normal -1 0 0; size 0.1; accepts head; }}"),
        "",
    ));
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(d[0].message.contains("is declared by `symmetric` already"), "{d:?}");
    let (_, d) = table_of(&grammar(
        &format!("slot arm_r {{ at -0.2 0 0.5; normal -1 0 0; size 0.1; accepts head; }}\n {slot} symmetric arm_r; }}"),
        "",
    ));
    assert_eq!(d.len(), 1, "{d:?}");
    assert!(d[0].message.contains("declares a slot that exists"), "{d:?}");
}

#[test]
fn obj_polygons_are_fanned_into_triangles() {
    let (p, t) = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2/2/2 3/3/3 4/4/4\n").expect("obj");
    assert_eq!(p.len(), 4);
    assert_eq!(t, vec![[0, 1, 2], [0, 2, 3]]);
    let (_, t) = parse_obj("v 0 0 0\nv 1 0 0\nv 1 1 0\nf -3 -2 -1 # comment\n").expect("relative");
    assert_eq!(t, vec![[0, 1, 2]]);
    assert_eq!(parse_obj("v 0 0 0\nf 0 1 2\n"), Err(ObjError::IndexOutOfRange { line: 2, index: 0, count: 1 }));
    assert_eq!(parse_obj("v nan 0 0\n"), Err(ObjError::BadVertex { line: 1 }));
}
