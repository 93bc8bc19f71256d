//! Unit tests of the creature grammar on a small hand-made part library (boxes
//! with slots): structure rules, symmetry groups, C_s, stability, determinism.

use super::cond::CondOp;
use super::evolve::{Evolution, EvolveOptions};
use super::geometry::{layout, Library};
use super::rules::{apply, rule_metric, select, targets, valid_targets, Rng, Target};
use super::shape::Shape;
use super::table::*;
use mdg_vm::bundle::Bundle;

/// An axis-aligned box mesh from `lo` to `hi`.
fn cuboid(lo: [f32; 3], hi: [f32; 3]) -> PartMesh {
    let mut positions = Vec::new();
    for k in 0..8 {
        positions.push([
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    // Outward, counter-clockwise faces.
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut triangles = Vec::new();
    for q in quads {
        triangles.push([q[0], q[1], q[2]]);
        triangles.push([q[0], q[2], q[3]]);
    }
    PartMesh { path: String::new(), positions, triangles, color: [0.8, 0.8, 0.8, 1.0] }
}

fn slot(name: &str, at: [f32; 3], normal: [f32; 3], up: [f32; 3], size: f32, accepts: &[u32]) -> Slot {
    Slot {
        name: name.into(),
        at,
        normal,
        up,
        size,
        accepts: accepts.to_vec(),
        mirror_of: None,
        partner: None,
        turn: [0.0; 3],
        spacing: 0.0,
    }
}

/// Adds `s` and its mirror image across x = 0 (as the compiler does for `symmetric`).
fn pair(slots: &mut Vec<Slot>, s: Slot, mirror: &str) {
    let i = slots.len() as u32;
    let mx = |v: [f32; 3]| [-v[0], v[1], v[2]];
    let m = Slot {
        name: mirror.into(),
        at: mx(s.at),
        normal: mx(s.normal),
        up: mx(s.up),
        mirror_of: Some(i),
        partner: Some(i),
        ..s.clone()
    };
    slots.push(Slot { partner: Some(i + 1), ..s });
    slots.push(m);
}

// Kinds.
const TORSO: u32 = 0;
const HEAD: u32 = 1;
const ARM: u32 = 2;
const WING: u32 = 3;
const LEG: u32 = 4;
const LOWERLIMB: u32 = 5;
const FORELEG: u32 = 6;
const HINDLEG: u32 = 7;
const TAIL: u32 = 8;
// Parts.
const H_TORSO: u32 = 0;
const H_HEAD: u32 = 1;
const H_ARM: u32 = 2;
const H_LEG: u32 = 3;
const Q_TORSO: u32 = 6;
const Q_HEAD: u32 = 7;
const Q_FORELEG: u32 = 8;
const Q_HINDLEG: u32 = 9;
const Q_TAIL: u32 = 10;

fn joint(normal: [f32; 3], up: [f32; 3], size: f32) -> Option<Slot> {
    Some(slot("joint", [0.0; 3], normal, up, size, &[]))
}

fn part(
    name: &str,
    kind: u32,
    category: u32,
    mesh: u32,
    joint: Option<Slot>,
    slots: Vec<Slot>,
    support: bool,
) -> PartDef {
    PartDef { name: name.into(), kind, category, geometry: Geometry::Mesh(mesh), joint, slots, support, scale: 1.0 }
}

/// A humanoid, a bird's wing and leg and a quadruped, all boxes.
fn table() -> CreatureTable {
    let names = ["torso", "head", "arm", "wing", "leg", "lowerlimb", "foreleg", "hindleg", "tail"];
    let kinds = names.iter().map(|n| Kind { name: n.to_string(), torso: *n == "torso" }).collect();
    let down = [0.0, 0.0, -1.0];
    let up_z = [0.0, 0.0, 1.0];
    let fwd = [0.0, -1.0, 0.0];
    let mut h_slots = vec![slot("neck", [0.0, 0.0, 0.6], up_z, fwd, 0.1, &[HEAD])];
    pair(&mut h_slots, slot("shoulder_l", [0.2, 0.0, 0.5], [1.0, 0.0, 0.0], up_z, 0.1, &[ARM, WING]), "shoulder_r");
    pair(&mut h_slots, slot("hip_l", [0.1, 0.0, 0.0], down, fwd, 0.12, &[LEG, LOWERLIMB, HINDLEG]), "hip_r");
    pair(&mut h_slots, slot("back_l", [0.1, 0.1, 0.45], [0.0, 1.0, 0.0], up_z, 0.1, &[ARM, WING]), "back_r");
    let mut q_slots = vec![slot("neck", [0.0, -0.5, 0.1], up_z, fwd, 0.2, &[HEAD])];
    pair(&mut q_slots, slot("foreleg_l", [0.12, -0.35, -0.15], down, fwd, 0.15, &[FORELEG]), "foreleg_r");
    pair(
        &mut q_slots,
        slot("hindleg_l", [0.12, 0.35, -0.15], down, fwd, 0.15, &[LEG, LOWERLIMB, HINDLEG]),
        "hindleg_r",
    );
    q_slots.push(slot("tail", [0.0, 0.5, 0.05], [0.0, 1.0, 0.0], up_z, 0.1, &[TAIL]));
    q_slots.push(slot("withers", [0.0, -0.35, 0.15], up_z, fwd, 0.3, &[TORSO]));
    let parts = vec![
        part("h_torso", TORSO, 0, 0, joint(down, fwd, 0.3), h_slots, false),
        part("h_head", HEAD, 0, 1, joint(down, fwd, 0.1), vec![], false),
        part("h_arm", ARM, 0, 2, joint([-1.0, 0.0, 0.0], up_z, 0.1), vec![], false),
        part("h_leg", LEG, 0, 3, joint(up_z, fwd, 0.12), vec![], true),
        part("b_wing", WING, 1, 2, joint([-1.0, 0.0, 0.0], up_z, 0.1), vec![], false),
        part("b_leg", LOWERLIMB, 1, 3, joint(up_z, fwd, 0.12), vec![], true),
        part("q_torso", TORSO, 2, 4, None, q_slots, false),
        part("q_head", HEAD, 2, 1, joint(down, fwd, 0.2), vec![], false),
        part("q_foreleg", FORELEG, 2, 5, joint(up_z, fwd, 0.15), vec![], true),
        part("q_hindleg", HINDLEG, 2, 5, joint(up_z, fwd, 0.15), vec![], true),
        part("q_tail", TAIL, 2, 6, joint([0.0, -1.0, 0.0], up_z, 0.1), vec![], false),
    ];
    let meshes = vec![
        cuboid([-0.2, -0.1, 0.0], [0.2, 0.1, 0.6]),      // 0 humanoid torso
        cuboid([-0.1, -0.1, 0.0], [0.1, 0.1, 0.2]),      // 1 head
        cuboid([0.0, -0.05, -0.05], [0.5, 0.05, 0.05]),  // 2 arm / wing
        cuboid([-0.06, -0.1, -0.8], [0.06, 0.06, 0.0]),  // 3 leg, with a foot
        cuboid([-0.2, -0.5, -0.15], [0.2, 0.5, 0.15]),   // 4 quadruped torso
        cuboid([-0.06, -0.06, -0.7], [0.06, 0.06, 0.0]), // 5 quadruped leg
        cuboid([-0.04, 0.0, -0.04], [0.04, 0.4, 0.04]),  // 6 tail
    ];
    let shapes = vec![
        ShapeDef {
            name: "humanoid".into(),
            floats: false,
            torso: H_TORSO,
            attach: vec![
                AttachDef { slot: 0, part: H_HEAD, count: 1, mode: Mode::Def },
                AttachDef { slot: 1, part: H_ARM, count: 1, mode: Mode::Def },
                AttachDef { slot: 3, part: H_LEG, count: 1, mode: Mode::Def },
            ],
        },
        ShapeDef {
            name: "quadruped".into(),
            floats: false,
            torso: Q_TORSO,
            attach: vec![
                AttachDef { slot: 0, part: Q_HEAD, count: 1, mode: Mode::Def },
                AttachDef { slot: 1, part: Q_FORELEG, count: 1, mode: Mode::Def },
                AttachDef { slot: 3, part: Q_HINDLEG, count: 1, mode: Mode::Def },
                AttachDef { slot: 5, part: Q_TAIL, count: 1, mode: Mode::Def },
            ],
        },
    ];
    let p = |v: f64| Code(vec![CondOp::Push(v)]);
    let rule = |id: &str, kind: RuleKind, pred: &[u32]| RuleDef {
        id: id.into(),
        kind,
        priority: 0,
        predecessor: pred.to_vec(),
        category: None,
        conditions: vec![],
        probability: p(1.0),
        add: 1,
        arrange: Mode::Row,
        max: 3,
        successor: vec![],
        from: None,
        take: vec![],
    };
    let rules = vec![
        RuleDef { arrange: Mode::Row, ..rule("two_heads", RuleKind::Increase, &[HEAD]) },
        RuleDef { arrange: Mode::Stack, ..rule("more_arms", RuleKind::Increase, &[ARM]) },
        RuleDef { successor: vec![WING], from: Some(1), ..rule("wings", RuleKind::Insert, &[TORSO]) },
        RuleDef { successor: vec![LOWERLIMB], ..rule("bird_legs", RuleKind::Replace, &[LEG]) },
        RuleDef { from: Some(2), take: vec![FORELEG, HINDLEG, TAIL], ..rule("centaur", RuleKind::Combine, &[LEG]) },
    ];
    CreatureTable {
        name: "test".into(),
        kinds,
        categories: vec!["humanoid".into(), "bird".into(), "quadruped".into()],
        parts,
        families: vec![vec![ARM, WING], vec![LEG, LOWERLIMB, HINDLEG]],
        shapes,
        rules,
        select_shapes: Strategy::Roulette,
        select_rules: Strategy::Roulette,
        evolve: EvolveSettings {
            population: 6,
            generations: 3,
            background: 8,
            offspring: 12,
            ..EvolveSettings::default()
        },
        meshes,
    }
}

fn humanoid(t: &CreatureTable) -> Shape {
    Shape::from_def(t, &t.shapes[0])
}

fn quadruped(t: &CreatureTable) -> Shape {
    Shape::from_def(t, &t.shapes[1])
}

fn rule<'a>(t: &'a CreatureTable, id: &str) -> &'a RuleDef {
    t.rules.iter().find(|r| r.id == id).expect("rule")
}

#[test]
fn the_fixture_verifies() {
    table().verify(&Bundle::empty()).expect("valid table");
}

#[test]
fn refusals_say_where_and_what_as_data() {
    use super::error::{CondError, Place, Problem, ShapeError, TableError};
    let mut t = table();
    t.rules[1].probability = Code(vec![CondOp::Parts(99)]);
    let e = t.verify(&Bundle::empty()).expect_err("no kind 99");
    let cond = CondError::UnknownKind { kind: 99, at: 0 };
    assert_eq!(e, TableError::at(Place::Rule("more_arms".into()), Problem::Condition(cond)));
    assert_eq!(e.to_string(), "rule `more_arms`: unknown kind 99 at 0");
    let mut t = table();
    t.parts[0].slots[0].normal = [0.0, 0.0, 2.0];
    let e = t.verify(&Bundle::empty()).expect_err("normal of length 2");
    let name = t.parts[0].name.clone();
    let slot = t.parts[0].slots[0].name.clone();
    assert_eq!(e, TableError::at(Place::Slot { part: name.clone(), slot: slot.clone() }, Problem::NotOrthonormal));
    assert_eq!(e.to_string(), format!("part `{name}` slot `{slot}`: normal and up must be orthonormal"));
    let t = table();
    let mut s = humanoid(&t);
    s.supers[1].metas[0].id = s.next_id;
    let id = s.next_id;
    assert_eq!(s.check(&t), Err(ShapeError::MetaDoesNotFit { sup: 1, id }));
    assert_eq!(s.check(&t).map_err(|e| e.to_string()), Err(format!("S1: meta-part {id} does not fit")));
    s.supers.clear();
    assert_eq!(s.check(&t), Err(ShapeError::NoSuperParts));
    let lib = Library::build(&Bundle::empty(), &t).expect("library");
    let evo = Evolution::new(&t, &lib, EvolveOptions::from_table(&t));
    let (mut pop, _) = evo.start();
    let e = evo.keep(&mut pop, &["g0-99".into()]).expect_err("no such monster");
    assert_eq!((e.id.as_str(), e.generation, e.presented.len()), ("g0-99", 0, pop.presented.len()));
    assert!(e.to_string().starts_with("no monster `g0-99` in generation 0 (presented: "), "{e}");
}

#[test]
fn regular_creature_structure() {
    let t = table();
    assert_eq!(
        humanoid(&t).describe(&t),
        "S0 torso[h_torso] def ; S1 head[h_head] def @neck→S0 ; S2 arm[h_arm] def @shoulder_l→S0 ; \
         S3 arm[h_arm] def @shoulder_r→S0 ; S4 leg[h_leg] def @hip_l→S0 ; S5 leg[h_leg] def @hip_r→S0"
    );
}

#[test]
fn increase_adds_a_copy_to_both_members_of_a_symmetry_group() {
    let t = table();
    let h = humanoid(&t);
    let r = rule(&t, "more_arms");
    let tg = targets(&t, r, &h, &h);
    // One target per symmetry group: the two arms are one.
    assert_eq!(tg, vec![Target::Super { sp: 2 }]);
    let s = apply(&t, r, &h, &h, &tg[0], &mut Rng::new(1)).expect("applies");
    assert_eq!(
        s.describe(&t),
        "S0 torso[h_torso] def ; S1 head[h_head] def @neck→S0 ; S2 arm[h_arm,h_arm] top_bottom @shoulder_l→S0 ; \
         S3 arm[h_arm,h_arm] top_bottom @shoulder_r→S0 ; S4 leg[h_leg] def @hip_l→S0 ; S5 leg[h_leg] def @hip_r→S0"
    );
    let heads = apply(&t, rule(&t, "two_heads"), &h, &h, &Target::Super { sp: 1 }, &mut Rng::new(1)).expect("heads");
    assert_eq!(heads.supers[1].metas.len(), 2);
    assert_eq!(heads.supers[1].mode.label(2), "midl_midr");
    assert_eq!(heads.supers[1].mode.position(0, 2), "midl");
    // A third application reaches `max 3`; a fourth has no target.
    let r2 = rule(&t, "two_heads");
    let three = apply(&t, r2, &heads, &h, &Target::Super { sp: 1 }, &mut Rng::new(1)).expect("three");
    assert_eq!(three.supers[1].metas.len(), 3);
    assert!(targets(&t, r2, &three, &h).is_empty());
}

#[test]
fn insert_fills_a_free_slot_and_its_mirror() {
    let t = table();
    let h = humanoid(&t);
    let q = quadruped(&t);
    let r = rule(&t, "wings");
    let tg = targets(&t, r, &h, &q);
    assert_eq!(tg, vec![Target::Slot { torso: 0, slot: 5, kind: WING }]);
    let s = apply(&t, r, &h, &q, &tg[0], &mut Rng::new(3)).expect("applies");
    assert_eq!(
        s.describe(&t),
        "S0 torso[h_torso] def ; S1 head[h_head] def @neck→S0 ; S2 arm[h_arm] def @shoulder_l→S0 ; \
         S3 arm[h_arm] def @shoulder_r→S0 ; S4 leg[h_leg] def @hip_l→S0 ; S5 leg[h_leg] def @hip_r→S0 ; \
         S6 wing[b_wing] def @back_l→S0 ; S7 wing[b_wing] def @back_r→S0"
    );
    assert_eq!(s.supers[6].sym, s.supers[7].sym, "the two wings are one symmetry group");
    // A torso that has a wing gets no second one.
    assert!(targets(&t, r, &s, &q).is_empty());
}

#[test]
fn replace_exchanges_allelic_parts_on_both_sides() {
    let t = table();
    let h = humanoid(&t);
    let r = rule(&t, "bird_legs");
    let tg = targets(&t, r, &h, &h);
    assert_eq!(tg, vec![Target::Super { sp: 4 }]);
    let s = apply(&t, r, &h, &h, &tg[0], &mut Rng::new(5)).expect("applies");
    assert_eq!(
        s.describe(&t),
        "S0 torso[h_torso] def ; S1 head[h_head] def @neck→S0 ; S2 arm[h_arm] def @shoulder_l→S0 ; \
         S3 arm[h_arm] def @shoulder_r→S0 ; S4 lowerlimb[b_leg] def @hip_l→S0 ; S5 lowerlimb[b_leg] def @hip_r→S0"
    );
}

#[test]
fn combine_makes_a_centaur() {
    let t = table();
    let h = humanoid(&t);
    let q = quadruped(&t);
    let r = rule(&t, "centaur");
    let tg = targets(&t, r, &h, &q);
    // The humanoid torso has no slot for a torso, but it has a joint and the
    // quadruped torso a `withers` slot: the quadruped torso becomes the root.
    assert_eq!(tg, vec![Target::Combine { torso: 0, child_slot: None, root_slot: Some(6) }]);
    let s = apply(&t, r, &h, &q, &tg[0], &mut Rng::new(1)).expect("applies");
    assert_eq!(
        s.describe(&t),
        "S0 torso[q_torso] def ; S1 foreleg[q_foreleg] def @foreleg_l→S0 ; S2 foreleg[q_foreleg] def @foreleg_r→S0 ; \
         S3 hindleg[q_hindleg] def @hindleg_l→S0 ; S4 hindleg[q_hindleg] def @hindleg_r→S0 ; S5 tail[q_tail] def @tail→S0 ; \
         S6 torso[h_torso] def @withers→S0 ; S7 head[h_head] def @neck→S6 ; S8 arm[h_arm] def @shoulder_l→S6 ; S9 arm[h_arm] def @shoulder_r→S6"
    );
    // Meta-part ids stay unique.
    let mut ids: Vec<u32> = s.supers.iter().flat_map(|sp| sp.metas.iter().map(|m| m.id)).collect();
    let n = ids.len();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), n);
    // Combining the other way (the quadruped as base) has nothing to remove.
    assert!(targets(&t, r, &q, &h).is_empty());
}

#[test]
fn symmetry_groups_stay_in_step_under_random_derivations() {
    let t = table();
    let mut rng = Rng::new(42);
    let start = [humanoid(&t), quadruped(&t)];
    for trial in 0..200 {
        let mut s = start[trial % 2].clone();
        let assist = start[(trial + 1) % 2].clone();
        for _ in 0..6 {
            let cands: Vec<(usize, Vec<Target>)> = t
                .rules
                .iter()
                .enumerate()
                .map(|(i, r)| (i, valid_targets(&t, r, &s, &assist, 1)))
                .filter(|(_, v)| !v.is_empty())
                .collect();
            if cands.is_empty() {
                break;
            }
            let (ri, tg) = &cands[rng.below(cands.len())];
            let target = &tg[rng.below(tg.len())];
            if let Some(next) = apply(&t, &t.rules[*ri], &s, &assist, target, &mut rng) {
                s = next;
            }
        }
        // Every symmetry group: same kind, same count, same arrangement, same
        // geometry, on mirror-partner slots of the same torso.
        let mut groups: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
        for (i, sp) in s.supers.iter().enumerate() {
            groups.entry(sp.sym).or_default().push(i);
        }
        for members in groups.values() {
            let a = &s.supers[members[0]];
            for &m in &members[1..] {
                let b = &s.supers[m];
                assert_eq!((a.kind, a.metas.len(), a.mode), (b.kind, b.metas.len(), b.mode), "{}", s.describe(&t));
                let geo = |x: &super::shape::SuperPart| x.metas.iter().map(|m| m.geometry).collect::<Vec<_>>();
                assert_eq!(geo(a), geo(b));
                let (aa, ba) = (a.attach.expect("attached"), b.attach.expect("attached"));
                assert_eq!(aa.parent, ba.parent);
                let torso = &t.parts[s.supers[aa.parent as usize].metas[0].geometry as usize];
                assert_eq!(torso.slots[aa.slot as usize].partner, Some(ba.slot));
            }
            assert!(members.len() <= 2);
        }
    }
}

#[test]
fn complexity_matches_hand_computed_values() {
    let t = table();
    let h = humanoid(&t);
    // 6 nodes, 5 edges; valencies 5,1,1,1,1,1 (mean 5/3):
    // 0.95·5 + (10/3)² + 5·(2/3)² = 4.75 + 120/9.
    assert!((h.complexity() - (4.75 + 120.0 / 9.0)).abs() < 1e-12, "{}", h.complexity());
    // Two heads: 7 nodes, 6 edges; 6,1,…,1 (mean 12/7): 5.7 + (30/7)² + 6·(5/7)² = 5.7 + 1050/49.
    let two = apply(&t, rule(&t, "two_heads"), &h, &h, &Target::Super { sp: 1 }, &mut Rng::new(1)).expect("heads");
    assert!((two.complexity() - (5.7 + 1050.0 / 49.0)).abs() < 1e-12);
    // The centaur: torso q (valency 6: 2 forelegs, 2 hind legs, tail, rider) and
    // torso h (valency 4: head, 2 arms, the q torso); 10 nodes, 9 edges, mean 1.8:
    // 0.95·9 + (6 − 1.8)² + (4 − 1.8)² + 8·(1 − 1.8)² = 8.55 + 17.64 + 4.84 + 5.12.
    let c = apply(
        &t,
        rule(&t, "centaur"),
        &h,
        &quadruped(&t),
        &Target::Combine { torso: 0, child_slot: None, root_slot: Some(6) },
        &mut Rng::new(1),
    )
    .expect("centaur");
    assert!((c.complexity() - (8.55 + 17.64 + 4.84 + 5.12)).abs() < 1e-9, "{}", c.complexity());
    // A lone torso: no edges, no variance.
    let mut lone = h.clone();
    lone.remove(&[1, 2, 3, 4, 5]);
    assert_eq!(lone.complexity(), 0.0);
}

#[test]
fn rule_metric_uses_the_papers_constants() {
    assert_eq!(rule_metric(RuleKind::Increase, 30.0, 33.33), 0.5);
    assert_eq!(rule_metric(RuleKind::Increase, 30.0, 33.34), 0.1);
    assert_eq!(rule_metric(RuleKind::Insert, 36.0, 36.3), 0.4);
    assert_eq!(rule_metric(RuleKind::Combine, 40.0, 40.0), 0.1);
    assert_eq!(rule_metric(RuleKind::Replace, 1000.0, 0.0), 0.35);
}

#[test]
fn selection_strategies_follow_their_metrics() {
    let metrics = [1.0, 0.0, 3.0];
    let mut counts = [[0usize; 3]; 3];
    let mut rng = Rng::new(9);
    for (k, s) in [Strategy::Uniform, Strategy::Roulette, Strategy::Rank].into_iter().enumerate() {
        for _ in 0..30_000 {
            counts[k][select(s, &metrics, &mut rng).expect("one")] += 1;
        }
    }
    let frac = |k: usize, i: usize| counts[k][i] as f64 / 30_000.0;
    // Uniform: a third each. Roulette: 1/4, 0, 3/4. Rank (ranks 2, 1, 3): 2/6, 1/6, 3/6.
    for i in 0..3 {
        assert!((frac(0, i) - 1.0 / 3.0).abs() < 0.02);
    }
    assert!((frac(1, 0) - 0.25).abs() < 0.02 && counts[1][1] == 0 && (frac(1, 2) - 0.75).abs() < 0.02);
    assert!((frac(2, 0) - 2.0 / 6.0).abs() < 0.02 && (frac(2, 1) - 1.0 / 6.0).abs() < 0.02);
}

#[test]
fn stability_accepts_a_standing_quadruped_and_rejects_one_without_legs() {
    let t = table();
    let lib = Library::build(&Bundle::empty(), &t).expect("library");
    let q = quadruped(&t);
    let standing = layout(&t, &lib, &q);
    assert!(standing.stability.stable, "{:?}", standing.stability);
    assert_eq!(standing.stability.hull.len(), 4, "four hooves, one corner each… {:?}", standing.stability.hull);
    assert!(standing.stability.margin > 0.05);
    // The feet are on the ground: the lowest point is at z = 0.
    assert!(standing.min.z.abs() < 1e-5);
    let mut legless = q.clone();
    let legs: Vec<usize> =
        (0..legless.supers.len()).filter(|&i| matches!(legless.supers[i].kind, FORELEG | HINDLEG)).collect();
    legless.remove(&legs);
    let fallen = layout(&t, &lib, &legless);
    assert!(!fallen.stability.stable);
    assert!(fallen.stability.hull.is_empty());
    // Only the front legs: the centre of mass (mid-body) is behind their line.
    let mut front_only = q.clone();
    let hind: Vec<usize> = (0..front_only.supers.len()).filter(|&i| front_only.supers[i].kind == HINDLEG).collect();
    front_only.remove(&hind);
    assert!(!layout(&t, &lib, &front_only).stability.stable);
}

#[test]
fn geometry_rules_attach_by_slot_centre_size_and_normal() {
    let t = table();
    let lib = Library::build(&Bundle::empty(), &t).expect("library");
    let h = humanoid(&t);
    let l = layout(&t, &lib, &h);
    // The left arm (meta-part 2): its joint (part origin) sits on the shoulder
    // slot centre, it points along the slot normal (+x), scaled 0.1/0.1 = 1.
    let arm = l.placed.iter().find(|p| p.meta == 2).expect("arm");
    let torso = l.placed.iter().find(|p| p.meta == 0).expect("torso");
    let slot_world = torso.transform.transform_point3(glam::Vec3::new(0.2, 0.0, 0.5));
    assert!((arm.transform.transform_point3(glam::Vec3::ZERO) - slot_world).length() < 1e-5);
    let dir = arm.transform.transform_vector3(glam::Vec3::X);
    assert!((dir - glam::Vec3::X).length() < 1e-5, "{dir}");
    // The right arm is its mirror image.
    let right = l.placed.iter().find(|p| p.meta == 3).expect("right arm");
    assert!((right.transform.transform_vector3(glam::Vec3::X) + glam::Vec3::X).length() < 1e-5);
    assert!(glam::Mat3::from_mat4(right.transform).determinant() < 0.0);
    // Legs scale to the hip slot: 0.12 / 0.12.
    let leg = l.placed.iter().find(|p| p.part == H_LEG).expect("leg");
    assert!((glam::Mat3::from_mat4(leg.transform).determinant().abs() - 1.0).abs() < 1e-5);
    // The quadruped's head (joint size 0.2) on a humanoid neck (0.1) is scaled by 0.5.
    let mut swapped = h.clone();
    swapped.supers[1].metas[0].geometry = Q_HEAD;
    let ls = layout(&t, &lib, &swapped);
    let head = ls.placed.iter().find(|p| p.part == Q_HEAD).expect("head");
    assert!((glam::Mat3::from_mat4(head.transform).determinant().abs() - 0.125).abs() < 1e-5);
}

#[test]
fn same_seed_same_generations_for_any_thread_count() {
    let t = table();
    let lib = Library::build(&Bundle::empty(), &t).expect("library");
    let run = |threads: usize, seed: u64| -> Vec<String> {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| {
            let mut o = EvolveOptions::from_table(&t);
            o.seed = seed;
            let evo = Evolution::new(&t, &lib, o);
            let (mut pop, _) = evo.start();
            let mut out = Vec::new();
            for _ in 0..3 {
                let g = evo.step(&mut pop, None);
                for i in &g.presented {
                    let xf: Vec<[f32; 16]> = i.layout.placed.iter().map(|p| p.transform.to_cols_array()).collect();
                    out.push(format!("{} {} {:?} {:?}", i.id, i.shape.describe(&t), i.parents, xf));
                }
                out.push(format!("hdm {}", g.diversity.hdm));
            }
            out
        })
    };
    let a = run(1, 5);
    assert!(a.len() > 6);
    assert_eq!(a, run(4, 5));
    assert_eq!(a, run(2, 5));
    assert_ne!(a, run(2, 6), "another seed gives other monsters");
}

#[test]
fn copies_of_an_arrangement_are_seated_on_the_torso_and_touch_it() {
    use super::geometry::{detached, touches};
    let t = table();
    let mut lib = Library::build(&Bundle::empty(), &t).expect("library");
    // Five arms in a row on the left shoulder: the plain spacing (the arm's width)
    // puts the outer ones beside the torso, which is only 0.2 deep.
    let mut h = humanoid(&t);
    let arm = h.supers.iter().position(|s| s.kind == ARM).expect("arm");
    for _ in 0..4 {
        let m = h.new_meta(ARM, H_ARM);
        h.supers[arm].metas.push(m);
    }
    h.supers[arm].mode = Mode::Row;
    lib.seat = false;
    let plain = layout(&t, &lib, &h);
    assert!(!plain.detached.is_empty(), "the outer arms hang in the air");
    lib.seat = true;
    let seated = layout(&t, &lib, &h);
    assert!(seated.detached.is_empty(), "{:?}", seated.detached);
    let torso = seated.placed.iter().find(|p| p.meta == 0).expect("torso");
    let to_torso = torso.transform.inverse();
    for m in &h.supers[arm].metas {
        let p = seated.placed.iter().find(|p| p.meta == m.id).expect("placed");
        // The joint (the arm's origin) is on the torso's side face x = 0.2, within its depth.
        let j = to_torso.transform_point3(p.transform.transform_point3(glam::Vec3::ZERO));
        assert!((j.x - 0.2).abs() < 1e-4 && j.y.abs() <= 0.1 + 1e-4, "{j}");
        assert!(touches(&lib, p, torso));
    }
    // Moved off the torso by 0.1 a part touches nothing.
    let mut off = seated.placed.clone();
    let k = off.iter().position(|p| p.part == H_HEAD).expect("head");
    off[k].transform = glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, 0.1)) * off[k].transform;
    assert_eq!(detached(&lib, &h, &off), vec![off[k].meta]);
}

#[test]
fn monsters_with_other_parts_and_the_same_silhouette_are_one_monster() {
    use super::evolve::{diversity, drop_lookalikes, look_alike};
    use super::silhouette::distance;
    // The fixture's bird leg is the humanoid leg's box (mesh 3): a humanoid whose
    // legs were replaced by bird legs has other parts (h_leg ↔ b_leg, neither set
    // within the other) and exactly the same outline. What shows decides.
    let t = table();
    let lib = Library::build(&Bundle::empty(), &t).expect("library");
    let evo = Evolution::new(&t, &lib, EvolveOptions::from_table(&t));
    let h = humanoid(&t);
    let r = rule(&t, "bird_legs");
    let birdlegs = apply(&t, r, &h, &h, &Target::Super { sp: 4 }, &mut Rng::new(5)).expect("applies");
    let a = evo.revive(h, "a".into(), 0);
    let b = evo.revive(birdlegs, "b".into(), 0);
    let parts = |i: &super::evolve::Individual| {
        i.layout.placed.iter().map(|p| p.part).collect::<std::collections::BTreeSet<u32>>()
    };
    assert!(!parts(&a).is_subset(&parts(&b)) && !parts(&b).is_subset(&parts(&a)));
    assert_eq!(distance(&a.silhouette, &b.silhouette), 0.0);
    assert!(look_alike(&a, &b), "same silhouette, other parts: one monster");
    let (kept, dropped) = drop_lookalikes(vec![a.clone(), b.clone()]);
    assert_eq!((kept.len(), dropped), (1, 1));
    assert_eq!(kept[0].id, "a", "ties: the first made stays");
    // The measure counts one visibly different monster.
    assert_eq!(diversity(&t, &[a, b]).visible, 1);
}
