//! `guide` and `search` sections: keys, checks and lowering (see [`super`]).
//!
//! ```mdg
//! search {
//!   skeleton branch fork;        // skeleton rules: their calls form bones
//!   wrapup branch leaf;          // a leftover `branch` call becomes a `leaf` call
//!   particles 100 15;            // first and last generation size
//!   generations 100;
//!   heuristic 1 0.4;             // starting scale, ramped to 0 over the first 40%
//!   budget 200;                  // milliseconds (`none`: no time limit)
//! }
//! guide trunk {
//!   points 0 0 0  0 0 1  0.5 0 2  1.5 0 2.5;   // 3k+1 control points
//!   scale_d 0 0.5 1; scale_a 1; delta_a 0.6; scale_u 0.5; segment 0.25;
//! }
//! ```
//!
//! Codes E07xx; unknown keys, wrong value counts and repeated keys are E0601–E0603
//! (see [`super`]). The language is documented in docs/guided.md.

use super::LowerCx;
use super::{at_most_once, expect_count, known_entries, numbers, words, CheckCx, Key, Sec};
use crate::ast::{BodyItem, BodyKind, Entry, ItemKind, Name, Section, Value};
use crate::diag::Diagnostic;
use crate::span::Span;
use mdg_guided::{Guide, GuidedTable, Resampling, SearchSettings, Utilisation};

const SEARCH_KEYS: &[Key] = &[
    Key {
        name: "skeleton",
        values: "RULE…",
        doc: "Skeleton rules. A call made by a skeleton rule forms a bone from the caller's origin (BASE) to the \
              callee's origin (TIP); the search expands skeleton calls one at a time and scores the bones against \
              the guides. A skeleton rule may not draw: calls it makes to other rules are deferred to the geometry \
              phase. May be given more than once.",
    },
    Key {
        name: "wrapup",
        values: "RULE TARGET",
        doc: "Wrap-up production: when the search stops, every pending call of skeleton rule RULE becomes a call of \
              TARGET (a rule that is not a skeleton rule) in the same frame. Pending calls of a skeleton rule \
              without a wrap-up are dropped. One entry per rule.",
    },
    Key {
        name: "particles",
        values: "FIRST [LAST]",
        doc: "Particles in the first and in the last generation, ramped linearly in between (default 100 15).",
    },
    Key {
        name: "generations",
        values: "N",
        doc: "Number of generations: each expands one pending skeleton call per particle (until one adds a bone) \
              and resamples (default 100).",
    },
    Key {
        name: "heuristic",
        values: "SCALE [FRACTION]",
        doc: "Starting HEURISTICSCALE and the fraction of the generations over which it ramps down to 0 \
              (default 1 0.4). `heuristic 0` turns the heuristic off.",
    },
    Key {
        name: "budget",
        values: "MILLISECONDS | none",
        doc: "Stop the search between generations once this much time has passed (default 200). The result then \
              depends on the machine's speed; `none` leaves only the generations limit.",
    },
    Key {
        name: "resample",
        values: "systematic | multinomial",
        doc: "How each generation is drawn from the weighted previous one (default systematic).",
    },
    Key {
        name: "expected",
        values: "SAMPLES [EXPANSIONS]",
        doc: "Forward samples per skeleton rule for its EXPECTED direction (the heuristic, paper eq. 9), and the \
              most expansions in each (default 64 32).",
    },
    Key {
        name: "utilisation",
        values: "paper | local",
        doc: "The utilisation term (paper eq. 7): `paper` credits a bone with every guide segment between the points \
              closest to its base and to its tip; `local` only with the arc within the bone's own length of its \
              base, so a short bone cannot collect a curve's whole bend (the default: docs/guided.md). \
              `mdg-run --utilisation` overrides it; `L` cycles it in `mdg-view`.",
    },
];

const GUIDE_KEYS: &[Key] = &[
    Key {
        name: "points",
        values: "X Y Z …",
        doc: "Control points of a piecewise cubic Bézier path: 3k + 1 points (4, 7, 10, …) as x y z triples; \
              segment i runs through points 3i … 3i+3.",
    },
    Key {
        name: "scale_d",
        values: "D0 D1 D2",
        doc: "Distance cost COST_d = D0 + D1·DIST + D2·DIST², DIST the distance from a bone's base to its closest \
              guide (default 0 0.5 1).",
    },
    Key {
        name: "scale_a",
        values: "A",
        doc: "Alignment cost multiplier: COST_a = (−bone direction · guide tangent + delta_a)·scale_a (default 1).",
    },
    Key {
        name: "delta_a",
        values: "OFFSET",
        doc: "Alignment offset in [−1, 1]: how well aligned a bone must be to lower the cost (default 0.6).",
    },
    Key {
        name: "scale_u",
        values: "U",
        doc: "Utilisation reward ≥ 0: each curve segment a bone spans lowers the cost by scale_u·e^(−times used \
              before) (default 1).",
    },
    Key {
        name: "segment",
        values: "LENGTH",
        doc: "Length of the utilisation segments along the guide, > 0 (default 0.25).",
    },
];

/// The keys accepted at `path` (see [`super::keys`]).
pub fn keys(path: &[&str]) -> &'static [Key] {
    match path {
        ["search"] => SEARCH_KEYS,
        ["guide"] => GUIDE_KEYS,
        _ => &[],
    }
}

/// A resolved skeleton declaration.
struct Skel {
    full: String,
    at: Span,
}

/// Checks the program's sections of this kind.
pub fn check(sections: &[Sec], cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    let searches: Vec<&Sec> = sections.iter().filter(|s| s.section.kind.text == "search").collect();
    let guides: Vec<&Sec> = sections.iter().filter(|s| s.section.kind.text == "guide").collect();
    for s in searches.iter().skip(1) {
        diags.push(
            Diagnostic::error("E0706", s.section.kind.span, "a second `search` section")
                .with_label("a program has at most one")
                .with_secondary(searches[0].section.kind.span, "the first one"),
        );
    }
    if searches.is_empty() {
        if let Some(g) = guides.first() {
            diags.push(
                Diagnostic::error("E0712", g.section.kind.span, "guides without a `search` section")
                    .with_label("nothing declares the skeleton rules these guides steer")
                    .with_note("add `search { skeleton RULE…; }`"),
            );
        }
    }
    if let Some(s) = searches.first() {
        check_search(s, cx, diags);
    }
    for s in searches.iter().skip(1) {
        known_entries(&s.section.entries, SEARCH_KEYS, "a `search` section", diags);
    }
    for g in &guides {
        check_guide(g, cx, diags);
    }
}

fn check_search(sec: &Sec, cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    let s = sec.section;
    let ns = sec.namespace;
    let entries = known_entries(&s.entries, SEARCH_KEYS, "a `search` section", diags);
    let single: Vec<&Entry> =
        entries.iter().copied().filter(|e| !matches!(e.key.text.as_str(), "skeleton" | "wrapup")).collect();
    at_most_once(&single, diags);
    // Skeleton rules first: wrap-ups refer to them.
    let mut skel: Vec<Skel> = Vec::new();
    for e in entries.iter().filter(|e| e.key.text == "skeleton") {
        if !expect_count(e, 1, usize::MAX, "one or more rule names", diags) {
            continue;
        }
        let Some(names) = words(e, diags) else { continue };
        for n in names {
            if let Some(full) = cx.rule(n, ns, diags) {
                if !skel.iter().any(|k| k.full == full) {
                    skel.push(Skel { full, at: n.span });
                }
            }
        }
    }
    if skel.is_empty() && !entries.iter().any(|e| e.key.text == "skeleton") {
        diags.push(
            Diagnostic::error("E0712", s.kind.span, "a `search` section without skeleton rules")
                .with_label("no `skeleton` entry")
                .with_note("add `skeleton RULE…;` naming the rules whose calls form bones"),
        );
    }
    for k in &skel {
        skeleton_rule_ok(k, cx, diags);
    }
    let is_skel = |full: &str| skel.iter().any(|k| k.full == full);
    let mut wrapped: Vec<(String, Span)> = Vec::new();
    for e in entries.iter().filter(|e| e.key.text == "wrapup") {
        if !expect_count(e, 2, 2, "a skeleton rule and the rule its leftover calls become", diags) {
            continue;
        }
        let Some(names) = words(e, diags) else { continue };
        let (from, to) = (names[0], names[1]);
        let from_full = cx.rule(from, ns, diags);
        let to_full = cx.rule(to, ns, diags);
        if let Some(f) = &from_full {
            if !is_skel(f) {
                diags.push(
                    Diagnostic::error(
                        "E0702",
                        from.span,
                        format!("wrap-up for `{}`, which is not a skeleton rule", from.text),
                    )
                    .with_label("only skeleton calls are left over when the search stops")
                    .with_note(format!("add `{}` to `skeleton`, or remove this wrap-up", from.text)),
                );
            } else if let Some((_, first)) = wrapped.iter().find(|(w, _)| w == f) {
                diags.push(
                    Diagnostic::error("E0711", from.span, format!("`{}` has a second wrap-up", from.text))
                        .with_label("a leftover call becomes one rule")
                        .with_secondary(*first, "first wrap-up here"),
                );
            } else {
                wrapped.push((f.clone(), from.span));
            }
        }
        if let Some(t) = &to_full {
            if is_skel(t) {
                diags.push(
                    Diagnostic::error("E0709", to.span, format!("wrap-up to `{}`, which is a skeleton rule", to.text))
                        .with_label("a wrap-up must leave the skeleton")
                        .with_note("wrap up into a rule that draws (a leaf, a tip) and is not listed in `skeleton`"),
                );
            }
        }
    }
    for e in &entries {
        match e.key.text.as_str() {
            "particles" => {
                if !expect_count(e, 1, 2, "one or two particle counts", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    for (x, val) in v.iter().zip(&e.values) {
                        if x.fract() != 0.0 || *x < 1.0 || *x > 1e6 {
                            range_error(val.span(), "particles", "a whole number from 1 to 1000000", diags);
                        }
                    }
                }
            }
            "generations" => {
                if !expect_count(e, 1, 1, "a number of generations", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    if v[0].fract() != 0.0 || v[0] < 1.0 || v[0] > 1e7 {
                        range_error(e.values[0].span(), "generations", "a whole number from 1 to 10000000", diags);
                    }
                }
            }
            "heuristic" => {
                if !expect_count(e, 1, 2, "a scale and an optional ramp fraction", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    if !(v[0].is_finite() && v[0] >= 0.0) {
                        range_error(e.values[0].span(), "heuristic scale", "a finite number ≥ 0", diags);
                    }
                    if let Some(f) = v.get(1) {
                        if !(0.0..=1.0).contains(f) {
                            range_error(e.values[1].span(), "heuristic ramp fraction", "a number in [0, 1]", diags);
                        }
                    }
                }
            }
            "budget" => {
                if !expect_count(e, 1, 1, "milliseconds or `none`", diags) {
                    continue;
                }
                match &e.values[0] {
                    Value::Word(w) if w.text == "none" => {}
                    v => match cx.number(v) {
                        Some(x) if x.is_finite() && x > 0.0 && x <= mdg_guided::MAX_BUDGET_MS => {}
                        Some(_) => range_error(
                            v.span(),
                            "budget",
                            "a positive number of milliseconds, at most 10000000000 (10000000 s), or `none`",
                            diags,
                        ),
                        None => diags.push(
                            Diagnostic::error("E0602", v.span(), "`budget` takes milliseconds or `none`")
                                .with_label("not a constant number"),
                        ),
                    },
                }
            }
            "resample" => {
                if !expect_count(e, 1, 1, "`systematic` or `multinomial`", diags) {
                    continue;
                }
                let ok = matches!(&e.values[0], Value::Word(w) if Resampling::from_name(&w.text).is_some());
                if !ok {
                    diags.push(
                        Diagnostic::error(
                            "E0602",
                            e.values[0].span(),
                            "`resample` takes `systematic` or `multinomial`",
                        )
                        .with_label("unknown resampling scheme"),
                    );
                }
            }
            "utilisation" => {
                if !expect_count(e, 1, 1, "`paper` or `local`", diags) {
                    continue;
                }
                let ok = matches!(&e.values[0], Value::Word(w) if Utilisation::from_name(&w.text).is_some());
                if !ok {
                    diags.push(
                        Diagnostic::error("E0602", e.values[0].span(), "`utilisation` takes `paper` or `local`")
                            .with_label("unknown utilisation term"),
                    );
                }
            }
            "expected" => {
                if !expect_count(e, 1, 2, "a number of samples and an optional number of expansions", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    for (x, val) in v.iter().zip(&e.values) {
                        if x.fract() != 0.0 || *x < 1.0 || *x > 1e6 {
                            range_error(val.span(), "expected", "a whole number from 1 to 1000000", diags);
                        }
                    }
                }
            }
            _ => {}
        }
    }
    // The search starts from the start shape, which must be a skeleton call.
    if let Some((start, span)) = &cx.sym.startshape {
        if !skel.is_empty() && !is_skel(start) {
            diags.push(
                Diagnostic::error("E0708", *span, format!("the start shape `{start}` is not a skeleton rule"))
                    .with_label("guided search starts by expanding the start shape")
                    .with_secondary(s.kind.span, "the skeleton rules are declared here")
                    .with_note(format!("add `{start}` to `skeleton` (it may call other rules to draw)")),
            );
        }
    }
}

fn range_error(span: Span, what: &str, want: &str, diags: &mut Vec<Diagnostic>) {
    diags.push(Diagnostic::error("E0707", span, format!("{what} out of range")).with_label(format!("expected {want}")));
}

/// E0701 for a skeleton rule whose definitions draw, E0710 for one that is animated
/// or a convolution.
fn skeleton_rule_ok(k: &Skel, cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    let Some(defs) = cx.sym.rules.get(&k.full) else { return };
    for d in defs {
        let Some(item) = cx.ex.items.get(d.item) else { continue };
        let ItemKind::Rule(r) = &item.item.kind else { continue };
        if r.iter.is_some() || !r.transforms.is_empty() {
            diags.push(
                Diagnostic::error(
                    "E0710",
                    r.name.span,
                    format!("skeleton rule `{}` is animated or a convolution", k.full),
                )
                .with_label("a skeleton rule runs once per expansion, without transform rules")
                .with_secondary(k.at, "declared a skeleton rule here"),
            );
            return;
        }
        if let Some(p) = &r.params {
            diags.push(
                Diagnostic::error("E0713", p.span, format!("skeleton rule `{}` takes parameters", k.full))
                    .with_label("skeleton rules take no parameters")
                    .with_secondary(k.at, "declared a skeleton rule here")
                    .with_note("pending skeleton calls carry no arguments; pass values to the geometry rules through `@define` constants, or make the parameter a selector on depth"),
            );
            return;
        }
        let mut calls = Vec::new();
        body_calls(&r.body, &mut calls);
        if let Some(args) = calls.iter().find_map(|(_, a)| a.filter(|a| !a.args.is_empty())) {
            diags.push(
                Diagnostic::error("E0713", args.span, format!("skeleton rule `{}` passes arguments", k.full))
                    .with_label("calls from a skeleton rule pass no arguments (the callee takes its defaults)")
                    .with_secondary(k.at, "declared a skeleton rule here"),
            );
            return;
        }
        if let Some(at) = first_non_uniform_scale(&r.body, cx) {
            diags.push(
                Diagnostic::error("E0714", at, format!("skeleton rule `{}` scales non-uniformly", k.full))
                    .with_label("a skeleton call keeps a similarity frame: one scale for all three axes")
                    .with_secondary(k.at, "declared a skeleton rule here")
                    .with_note("scale the geometry rules the skeleton calls instead, or use one factor (`s S`)"),
            );
            return;
        }
        if let Some(at) = first_drawable(&r.body, cx) {
            diags.push(
                Diagnostic::error("E0701", at, format!("skeleton rule `{}` draws", k.full))
                    .with_label("a skeleton rule may not draw")
                    .with_secondary(k.at, "declared a skeleton rule here")
                    .with_note("draw in a rule that is not a skeleton rule and call it from here: such calls are deferred to the geometry phase"),
            );
            return;
        }
    }
}

/// Every call in a body, in order (iterators, loops, blocks and `if` branches included).
fn body_calls<'b>(items: &'b [BodyItem], out: &mut Vec<(&'b Name, Option<&'b crate::ast::CallArgs>)>) {
    crate::ast::walk_body(items, &mut |it| {
        if let BodyKind::Call { name, args, .. } = &it.kind {
            out.push((name, args.as_ref()));
        }
    });
}

/// The span of the first drawable call in a body.
/// The first `s X Y [Z]` in a body.
fn first_non_uniform_scale(items: &[BodyItem], cx: &CheckCx) -> Option<Span> {
    let mut at = None;
    crate::ast::walk_body(items, &mut |it| {
        let adj = match &it.kind {
            BodyKind::Call { adj, .. } | BodyKind::Loop { adj, .. } | BodyKind::Iterate { adj, .. } => adj,
            _ => return,
        };
        let scale = |a: &&crate::ast::Adj| {
            a.args.len() > 1 && cx.sym.components.adj_kind(&a.name.text) == Some(crate::adjust::AdjKind::Scale)
        };
        at = at.or_else(|| adj.adjs.iter().find(scale).map(|a| a.span));
    });
    at
}

fn first_drawable(items: &[BodyItem], cx: &CheckCx) -> Option<Span> {
    let mut calls = Vec::new();
    body_calls(items, &mut calls);
    calls.into_iter().find(|(n, _)| cx.sym.is_drawable(&n.text)).map(|(n, _)| n.span)
}

fn check_guide(sec: &Sec, cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    let s = sec.section;
    let entries = known_entries(&s.entries, GUIDE_KEYS, "a `guide` section", diags);
    at_most_once(&entries, diags);
    let mut has_points = false;
    for e in &entries {
        match e.key.text.as_str() {
            "points" => {
                has_points = true;
                let Some(v) = numbers(cx.ex, e, diags) else { continue };
                if v.len() % 3 != 0 {
                    let span = e.values.get(v.len() - v.len() % 3).map(|v| v.span()).unwrap_or(e.span);
                    diags.push(Diagnostic::error("E0602", span, "`points` takes x y z triples").with_label(format!(
                        "{} value{} left over",
                        v.len() % 3,
                        if v.len() % 3 == 1 { "" } else { "s" }
                    )));
                    continue;
                }
                if let Some((_, val)) =
                    v.iter().zip(&e.values).find(|(x, _)| x.is_nan() || x.abs() > mdg_guided::MAX_GUIDE_COORD)
                {
                    range_error(val.span(), "control point", "a coordinate from -1000000000 to 1000000000", diags);
                    continue;
                }
                let n = v.len() / 3;
                let whole = e.values.first().zip(e.values.last()).map(|(a, b)| a.span().to(b.span())).unwrap_or(e.span);
                if n < 4 {
                    diags.push(
                        Diagnostic::error(
                            "E0703",
                            whole,
                            format!("a guide with {n} control point{}", if n == 1 { "" } else { "s" }),
                        )
                        .with_label("a cubic Bézier path needs at least 4")
                        .with_note("give 3k + 1 points (x y z each): 4 for one cubic segment, 7 for two, …"),
                    );
                } else if (n - 1) % 3 != 0 {
                    diags.push(
                        Diagnostic::error("E0704", whole, format!("a guide with {n} control points"))
                            .with_label("a piecewise cubic Bézier path has 3k + 1 (4, 7, 10, …)")
                            .with_note("consecutive segments share their end points: segment i uses points 3i … 3i+3"),
                    );
                }
            }
            "scale_d" => {
                if !expect_count(e, 3, 3, "three coefficients D0 D1 D2", diags) {
                    continue;
                }
                numbers(cx.ex, e, diags);
            }
            "scale_a" => {
                if !expect_count(e, 1, 1, "a number", diags) {
                    continue;
                }
                numbers(cx.ex, e, diags);
            }
            "delta_a" => {
                if !expect_count(e, 1, 1, "a number in [-1, 1]", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    if !(-1.0..=1.0).contains(&v[0]) {
                        diags.push(
                            Diagnostic::error(
                                "E0705",
                                e.values[0].span(),
                                format!("delta_a {} is outside [-1, 1]", v[0]),
                            )
                            .with_label("the alignment offset is compared with a dot product of unit vectors")
                            .with_note("1 rewards only perfectly aligned bones, −1 rewards any bone"),
                        );
                    }
                }
            }
            "scale_u" => {
                if !expect_count(e, 1, 1, "a number ≥ 0", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    if v[0] < 0.0 {
                        range_error(e.values[0].span(), "scale_u", "a number ≥ 0 (it is a reward)", diags);
                    }
                }
            }
            "segment" => {
                if !expect_count(e, 1, 1, "a length", diags) {
                    continue;
                }
                if let Some(v) = numbers(cx.ex, e, diags) {
                    if v[0] <= 0.0 {
                        range_error(e.values[0].span(), "segment", "a positive length", diags);
                    }
                }
            }
            _ => {}
        }
    }
    if !has_points {
        let at = s.name.as_ref().map(|n| n.span).unwrap_or(s.kind.span);
        diags.push(
            Diagnostic::error("E0703", at, "a guide with no control points")
                .with_label("no `points` entry")
                .with_note("add `points X Y Z …;` with 3k + 1 points (4, 7, 10, …)"),
        );
    }
}

/// Rule names the section refers to.
pub fn rule_refs(sec: &Section) -> Vec<&Name> {
    if sec.kind.text != "search" {
        return Vec::new();
    }
    sec.entries
        .iter()
        .filter(|e| matches!(e.key.text.as_str(), "skeleton" | "wrapup"))
        .flat_map(|e| e.values.iter())
        .filter_map(|v| match v {
            Value::Word(w) => Some(w),
            _ => None,
        })
        .collect()
}

/// Lowers the sections into the bundle's table (`None` without a `search` section).
pub fn lower(sections: &[Sec], cx: &LowerCx) -> Option<GuidedTable> {
    let search = sections.iter().find(|s| s.section.kind.text == "search")?;
    let ns = search.namespace;
    let mut t = GuidedTable { settings: SearchSettings::default(), ..GuidedTable::default() };
    let nums = |e: &Entry| -> Vec<f64> { e.values.iter().filter_map(|v| cx.number(v)).collect() };
    for e in &search.section.entries {
        match e.key.text.as_str() {
            "skeleton" => {
                for v in &e.values {
                    if let Value::Word(w) = v {
                        if let Some(r) = cx.rule(&w.text, ns) {
                            if !t.skeleton.contains(&r) {
                                t.skeleton.push(r);
                            }
                        }
                    }
                }
            }
            "wrapup" => {
                if let [Value::Word(a), Value::Word(b)] = e.values.as_slice() {
                    if let (Some(from), Some(to)) = (cx.rule(&a.text, ns), cx.rule(&b.text, ns)) {
                        t.wrapups.push((from, to));
                    }
                }
            }
            "particles" => {
                let v = nums(e);
                if let Some(&a) = v.first() {
                    let b = v.get(1).copied().unwrap_or(a);
                    t.settings.particles = (a as u32, b as u32);
                }
            }
            "generations" => {
                if let Some(&g) = nums(e).first() {
                    t.settings.generations = g as u32;
                }
            }
            "heuristic" => {
                let v = nums(e);
                if let Some(&h) = v.first() {
                    t.settings.heuristic_scale = h;
                }
                if let Some(&f) = v.get(1) {
                    t.settings.heuristic_fraction = f;
                }
            }
            "budget" => {
                t.settings.budget_ms = match e.values.first() {
                    Some(Value::Word(w)) if w.text == "none" => None,
                    Some(v) => cx.number(v).or(t.settings.budget_ms),
                    None => t.settings.budget_ms,
                };
            }
            "resample" => {
                if let Some(Value::Word(w)) = e.values.first() {
                    if let Some(r) = Resampling::from_name(&w.text) {
                        t.settings.resampling = r;
                    }
                }
            }
            "utilisation" => {
                if let Some(Value::Word(w)) = e.values.first() {
                    t.settings.utilisation = Utilisation::from_name(&w.text);
                }
            }
            "expected" => {
                let v = nums(e);
                if let Some(&a) = v.first() {
                    t.settings.expected.0 = a as u32;
                }
                if let Some(&b) = v.get(1) {
                    t.settings.expected.1 = b as u32;
                }
            }
            _ => {}
        }
    }
    for g in sections.iter().filter(|s| s.section.kind.text == "guide") {
        let name = g.section.name.as_ref().map(|n| n.text.clone()).unwrap_or_default();
        let mut guide = Guide::new(&name, Vec::new());
        for e in &g.section.entries {
            let v = nums(e);
            match (e.key.text.as_str(), v.as_slice()) {
                ("points", _) => guide.points = v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                ("scale_d", &[a, b, c]) => guide.scale_d = [a, b, c],
                ("scale_a", &[a]) => guide.scale_a = a,
                ("delta_a", &[a]) => guide.delta_a = a,
                ("scale_u", &[a]) => guide.scale_u = a,
                ("segment", &[a]) => guide.segment = a,
                _ => {}
            }
        }
        t.guides.push(guide);
    }
    Some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::CheckOptions;
    use crate::driver::{analyze_text, Analysis};
    use crate::source::MemLoader;
    use mdg_vm::bundle::Section as _;

    fn analyze(src: &str) -> Analysis {
        analyze_text(
            &MemLoader::default(),
            std::path::Path::new("t.mdg"),
            src,
            &crate::expand::Options::default(),
            CheckOptions { require_start: true },
        )
    }

    /// The guided table a program compiles to (no errors allowed), and the bundle.
    fn table(src: &str) -> (GuidedTable, mdg_vm::bundle::Bundle) {
        let a = analyze(src);
        assert!(!a.has_errors(), "{}", crate::diag::render_plain(&a.diagnostics, &a.sources));
        let b = crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
        (GuidedTable::from_bundle(&b).expect("a valid section").expect("a guided table"), b)
    }

    fn codes(src: &str) -> Vec<&'static str> {
        analyze(src).diagnostics.iter().map(|d| d.code).collect()
    }

    const RULES: &str = "minsize 0.1
rule tree { wood {} tree {z 1 s 0.6} }
rule wood { VERTEX {} VERTEX {x 0.1} VERTEX {z 1} }
";

    #[test]
    fn sections_lower_into_the_table() {
        let src = format!(
            "startshape tree
             search {{ skeleton tree; wrapup tree wood; particles 40 8; generations 12; heuristic 2.5 0.25;
                       budget none; resample multinomial; expected 10 5; utilisation local; }}
             guide up {{ points 0 0 0  0 0 1  0 0 2  0 0 3  0 1 4  0 2 5  0 3 6; scale_d 1 2 3; scale_a 0.5;
                         delta_a -0.25; scale_u 2; segment 0.5; }}
             guide {{ points 1 0 0  1 0 1  1 0 2  (1 + 2) 0 3; }}
             {RULES}"
        );
        let (t, b) = table(&src);
        let name = |r: u32| b.string(b.rules[r as usize].name).to_string();
        assert_eq!(t.skeleton.iter().map(|&r| name(r)).collect::<Vec<_>>(), ["tree"]);
        assert_eq!(
            t.wrapups.iter().map(|&(a, c)| (name(a), name(c))).collect::<Vec<_>>(),
            [("tree".into(), "wood".into())]
        );
        let s = &t.settings;
        assert_eq!((s.particles, s.generations, s.heuristic_scale, s.heuristic_fraction), ((40, 8), 12, 2.5, 0.25));
        assert_eq!((s.budget_ms, s.resampling, s.expected), (None, Resampling::Multinomial, (10, 5)));
        assert_eq!(s.utilisation, Some(Utilisation::Local));
        assert_eq!(t.guides.len(), 2);
        let g = &t.guides[0];
        assert_eq!(g.name, "up");
        assert_eq!(g.points.len(), 7);
        assert_eq!(g.points[6], [0.0, 3.0, 6.0]);
        assert_eq!((g.scale_d, g.scale_a, g.delta_a, g.scale_u, g.segment), ([1.0, 2.0, 3.0], 0.5, -0.25, 2.0, 0.5));
        // Defaults, and constant expressions as values.
        let d = &t.guides[1];
        assert_eq!(d.name, "");
        assert_eq!(d.points[3], [3.0, 0.0, 3.0]);
        assert_eq!((d.scale_d, d.delta_a, d.scale_u), (mdg_guided::DEFAULT_SCALE_D, 0.6, 1.0));
        // The bundle verifier accepts it.
        assert!(t.verify(&b).is_ok());
    }

    #[test]
    fn search_settings_default_when_not_given() {
        let (t, _) = table(&format!("startshape tree\nsearch {{ skeleton tree; }}\n{RULES}"));
        assert_eq!(t.settings, SearchSettings::default());
        assert!(t.guides.is_empty(), "guides may come from a file");
        assert!(t.wrapups.is_empty());
    }

    #[test]
    fn checks_report_their_codes() {
        let guide = "guide g { points 0 0 0  0 0 1  0 0 2  0 0 3; }";
        let prog =
            |search: &str, extra: &str| format!("startshape tree\nsearch {{ {search} }}\n{guide}\n{extra}\n{RULES}");
        assert_eq!(codes(&prog("skeleton tree;", "")), Vec::<&str>::new());
        assert_eq!(codes(&prog("skeleton tree wood;", "")), ["E0701"], "wood draws");
        assert_eq!(codes(&prog("skeleton tree; wrapup wood tree;", "")), ["E0702", "E0709"]);
        assert_eq!(codes(&prog("skeleton tree; heuristic -1;", "")), ["E0707"]);
        assert_eq!(codes(&prog("skeleton tree; heuristic 1 2;", "")), ["E0707"]);
        assert_eq!(codes(&prog("skeleton tree; generations 2.5;", "")), ["E0707"]);
        assert_eq!(codes(&prog("skeleton tree; budget 0;", "")), ["E0707"]);
        assert_eq!(codes(&prog("skeleton tree; budget 1e23;", "")), ["E0707"], "past Duration's range");
        assert_eq!(codes(&prog("skeleton tree; budget 10000000001;", "")), ["E0707"]);
        assert_eq!(codes(&prog("skeleton tree; budget 10000000000;", "")), Vec::<&str>::new());
        assert_eq!(
            codes(&prog("skeleton tree;", "guide h { points 0 0 0 0 0 1 0 0 2 0 0 1e308; }")),
            ["E0707"],
            "a coordinate past MAX_GUIDE_COORD"
        );
        assert_eq!(codes(&prog("skeleton tree; budget soon;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; resample stratified;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; utilisation eq7;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; utilisation 1;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; utilisation paper local;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; utilisation paper; utilisation local;", "")), ["E0603"]);
        assert_eq!(codes(&prog("skeleton tree; utilisation paper;", "")), Vec::<&str>::new());
        assert_eq!(codes(&prog("skeleton tree; particles;", "")), ["E0602"]);
        assert_eq!(codes(&prog("skeleton tree; partcles 4;", "")), ["E0601"]);
        assert_eq!(codes(&prog("generations 4;", "")), ["E0712"], "no skeleton rules");
        assert_eq!(
            codes(&prog("skeleton tree;", "guide h { points 0 0 0; segment 0; scale_u -1; }")),
            ["E0703", "E0707", "E0707"]
        );
        assert_eq!(codes(&prog("skeleton tree;", "guide h { segment 1; }")), ["E0703"]);
        assert_eq!(
            codes(&prog("skeleton tree;", "guide h { points 0 0 0 1 1 1 2 2 2 3 3 3; delta_a -2; }")),
            ["E0705"]
        );
    }

    #[test]
    fn keys_have_docs_and_rule_refs_name_rules() {
        for kind in ["search", "guide"] {
            let ks = keys(&[kind]);
            assert!(ks.len() >= 6, "{kind}");
            assert!(ks.iter().all(|k| !k.doc.is_empty() && !k.values.is_empty()));
        }
        assert!(keys(&["search", "skeleton"]).is_empty());
        let a =
            analyze(&format!("startshape tree\nsearch {{ skeleton tree; wrapup tree wood; generations 3; }}\n{RULES}"));
        let sec = a
            .expanded
            .items
            .iter()
            .find_map(|i| match &i.item.kind {
                crate::ast::ItemKind::Section(s) => Some(s),
                _ => None,
            })
            .expect("the search section");
        let names: Vec<&str> = rule_refs(sec).iter().map(|n| n.text.as_str()).collect();
        assert_eq!(names, ["tree", "tree", "wood"]);
    }
}
