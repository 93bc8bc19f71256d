//! `creature` sections: keys, checks and lowering (see [`super`]) — the creature
//! grammar of `papers/creature-grammar.txt` (language: `docs/creatures.md`).
//!
//! One function, [`build`], both checks a section and produces its
//! [`CreatureTable`]: the checker runs it for the diagnostics, lowering for the
//! table (with bundle rule indices), so the two cannot disagree.
//!
//! Codes: E0801 unknown part type, E0802 unknown slot, E0803 unknown part or
//! category, E0804 a rule that can never match, E0805 a probability that can leave
//! [0, 1], E0806 an allelic family of incompatible kinds, E0807 a part that does
//! not fit where it is put, E0808 a missing key, E0809 a key that does not belong,
//! E0810 an imported mesh that cannot be used, E0811 a part without a joint or a
//! non-torso with slots, E0812 a name defined twice, E0813 a section without parts
//! or creatures (or a second section), E0814 a bad condition or probability
//! expression, E0815 a geometric or evolution value out of range. E0601–E0603 and
//! E0301 come from the shared section machinery.
//!
//! The builder's work is split along the section's concerns: this file walks the
//! sections and holds the entry helpers and OBJ meshes; [`parts`] (parts, joints,
//! slots), [`shapes`] (regular creatures), [`rules`] (the four rule kinds),
//! [`conditions`] (condition code, probabilities, never-match and never-hold
//! analyses) and [`evolve`] (evolution settings and selection).

mod conditions;
mod evolve;
mod parts;
mod rules;
mod shapes;

use super::LowerCx;
use super::{at_most_once, expect_count, known_entries, numbers, words, CheckCx, Key, Sec};
use crate::ast::{Entry, Expr, ExprKind, Name, Section, Value};
use crate::diag::{did_you_mean, Diagnostic};
use crate::span::Span;
use mdg_creature::cond::{self, CondOp, VARIABLES};
use mdg_creature::table::{
    self as tb, AttachDef, Code, CreatureTable, EvolveSettings, Geometry, Kind, Mode, PartDef, PartMesh, RuleDef,
    RuleKind, ShapeDef, Slot, Strategy,
};
use mdg_vm::bundle::Section as _;

/// The largest coordinate, normal component or size a creature part may give.
pub const MAX_COORDINATE: f64 = 1e6;

const SECTION_KEYS: &[Key] = &[
    Key {
        name: "part",
        values: "NAME { … }",
        doc: "A meta-part: one piece of creature geometry (a torso, head, arm, …) with its type, category, geometry (`rule` or `mesh`), a `joint` where it attaches and, for torsos, `slot`s where other parts attach.",
    },
    Key {
        name: "family",
        values: "TYPE TYPE…",
        doc: "An allelic family: part types that can replace each other (`family arm wing;`, `family leg lowerlimb hindleg;`). Slots accepting one type accept the whole family. A type belongs to at most one family, and torsos do not mix with other types.",
    },
    Key {
        name: "shape",
        values: "NAME { … }",
        doc: "A regular creature the evolution starts from: `torso PART;` and `attach SLOT PART [COUNT [MODE]];` for each part on it. Attaching to a symmetric slot fills its mirror slot too.",
    },
    Key {
        name: "rule",
        values: "NAME { … }",
        doc: "A structure rule; NAME is its id. `kind increase|insert|replace|combine; priority N; predecessor TYPE…; condition (EXPR); probability P|(EXPR);` plus the keys of its kind. Its function branch is taken with the probability, else the identity branch.",
    },
    Key {
        name: "select",
        values: "shapes|rules rank|uniform|roulette",
        doc: "Selection rule for base/assist shapes (metric: structure complexity C_s) or for structure rules (metric: C_r). `rank`: linear ranking (the best is the most likely); `uniform`; `roulette`: proportional to the metric. Default `roulette`.",
    },
    Key {
        name: "evolve",
        values: "{ … }",
        doc: "Evolution settings: `population`, `generations`, `background`, `offspring`, `steps`, `attempts`, `maxparts`, `seed`.",
    },
];

const PART_KEYS: &[Key] = &[
    Key { name: "type", values: "TYPE", doc: "The meta-part type (m0): `torso`, `head`, `arm`, `wing`, `leg`, `tail`, … Only `torso` parts have slots." },
    Key { name: "category", values: "NAME", doc: "The creature category the part comes from: `humanoid`, `bird`, `quadruped`, …" },
    Key { name: "rule", values: "RULE", doc: "Geometry from an MDG rule, evaluated once per run in the part's own coordinates (z up, the creature facing −y, its left at +x)." },
    Key { name: "mesh", values: "\"FILE.obj\"", doc: "Geometry from a Wavefront OBJ file (path relative to this file, inside the project), embedded in the bundle at compile time." },
    Key { name: "color", values: "R G B", doc: "Colour of a `mesh` part (0–1 each; default 0.8 0.8 0.8)." },
    Key { name: "scale", values: "S", doc: "Extra uniform scale after scaling to the slot (the paper's S_s; default 1)." },
    Key { name: "support", values: "", doc: "The part stands on the ground (legs, feet): its lowest points are support points of the stability test." },
    Key { name: "joint", values: "{ at; normal; up; size; }", doc: "Where the part attaches: its centre, outward normal, up vector and size. Attaching turns the joint's normal against the slot's, matches the up vectors and scales the joint size to the slot size." },
    Key { name: "slot", values: "NAME { … }", doc: "A place on a torso where parts attach: `at X Y Z; normal X Y Z; up X Y Z; size S; accepts TYPE…; symmetric NAME; turn RX RY RZ; spacing D;`." },
];

const JOINT_KEYS: &[Key] = &[
    Key { name: "at", values: "X Y Z", doc: "Centre of the slot, in the part's coordinates." },
    Key { name: "normal", values: "X Y Z", doc: "Outward normal (need not be unit length)." },
    Key { name: "up", values: "X Y Z", doc: "Fixes the twist about the normal (default: +z made orthogonal to the normal, or −y, the creature's front, when the normal is vertical)." },
    Key { name: "size", values: "S", doc: "Size (diameter) of the slot; attached parts are scaled so their joint size matches it." },
];

const SLOT_KEYS: &[Key] = &[
    Key { name: "at", values: "X Y Z", doc: "Centre of the slot, in the part's coordinates." },
    Key { name: "normal", values: "X Y Z", doc: "Outward normal (need not be unit length)." },
    Key { name: "up", values: "X Y Z", doc: "Fixes the twist about the normal (default: +z made orthogonal to the normal, or −y, the creature's front, when the normal is vertical)." },
    Key { name: "size", values: "S", doc: "Size (diameter) of the slot; attached parts are scaled so their joint size matches it." },
    Key { name: "accepts", values: "TYPE…", doc: "Part types that may attach here (with their allelic families)." },
    Key { name: "symmetric", values: "NAME", doc: "Also declare slot NAME, the mirror image of this one across x = 0. Parts on the two form one symmetry group: rules rewrite them together." },
    Key { name: "turn", values: "RX RY RZ", doc: "Fine rotation of attached parts in the slot frame, degrees about x, y, z (the paper's R_x, R_y, R_z)." },
    Key { name: "spacing", values: "D", doc: "Distance between copies when a super-part holds several meta-parts (default: the attached part's own width)." },
];

const SHAPE_KEYS: &[Key] = &[
    Key { name: "torso", values: "PART", doc: "The creature's torso part." },
    Key { name: "attach", values: "SLOT PART [COUNT [MODE]]", doc: "Attach COUNT copies (default 1) of PART to the torso's SLOT, arranged by MODE (`row`, `stack`, `fan`). A symmetric slot's mirror gets a mirrored copy." },
    Key { name: "floats", values: "", doc: "The creature does not stand (a swimmer, a flier): it and the monsters evolved from it are not subject to the stability test." },
];

const RULE_KEYS: &[Key] = &[
    Key { name: "kind", values: "increase|insert|replace|combine", doc: "`increase`: add copies of a meta-part to a super-part; `insert`: add a super-part of a new type to a free torso slot; `replace`: exchange a super-part's meta-parts for an allelic type's; `combine`: replace the predecessor parts with another shape's torso and its parts (a Centaur)." },
    Key { name: "priority", values: "N", doc: "Rules of higher priority are tried first in every derivation step; one rule is selected per priority tier (default 0)." },
    Key { name: "predecessor", values: "TYPE…", doc: "The super-part types the rule rewrites (`insert`: the torso types it adds to; `combine`: the types it removes)." },
    Key { name: "category", values: "NAME", doc: "Only match super-parts whose parts come from this category." },
    Key { name: "condition", values: "(EXPR)", doc: "Must be non-zero for the rule to apply; may be given several times (all must hold). Variables: g, superparts, metaparts, count, torsos, complexity; `parts(TYPE)`." },
    Key { name: "probability", values: "P | (EXPR)", doc: "Probability of the function branch (default 1), may depend on the generation g and on one of the counts superparts, metaparts, count, torsos, `parts(TYPE)`. Checked to stay in [0, 1] for every generation up to 1000." },
    Key { name: "add", values: "N", doc: "`increase`: copies added per application (default 1: duplicate; 2: triplicate)." },
    Key { name: "arrange", values: "row|stack|fan", doc: "`increase`: the arrangement of the grown super-part (`row`: midl/midr side by side, `stack`: top/bottom, `fan`: spread by angle; default `row`)." },
    Key { name: "max", values: "N", doc: "`increase`: at most N meta-parts in one super-part (default 3)." },
    Key { name: "successor", values: "TYPE…", doc: "`insert`: the types inserted; `replace`: the types replaced with (default: any type of the predecessor's allelic family)." },
    Key { name: "from", values: "NAME", doc: "`insert`, `replace`: the category new parts come from; `combine`: the category of the other shape's torso." },
    Key { name: "take", values: "TYPE…", doc: "`combine`: the types brought along with the other shape's torso (e.g. `foreleg hindleg tail`)." },
];

const EVOLVE_KEYS: &[Key] = &[
    Key { name: "population", values: "N", doc: "Monsters presented per generation (default 18)." },
    Key {
        name: "generations",
        values: "N",
        doc: "Generations to evolve (default 5, at most 1000; `mdg-run --generations`).",
    },
    Key { name: "background", values: "N", doc: "Size of the background set (default 36)." },
    Key {
        name: "offspring",
        values: "N",
        doc: "Offspring made per generation before diversity control (default 3 × population).",
    },
    Key {
        name: "steps",
        values: "N",
        doc: "Derivation steps per offspring; each visits every priority tier once (default 2).",
    },
    Key {
        name: "attempts",
        values: "N",
        doc: "Tries per offspring until one changes the base shape and passes the stability test (default 24).",
    },
    Key { name: "maxparts", values: "N", doc: "Offspring with more meta-parts are rejected (default 24, at most 64)." },
    Key { name: "seed", values: "N", doc: "Seed of the evolution (default 1; `mdg-run --seed` overrides it)." },
    Key { name: "stability", values: "on|off", doc: "Whether offspring must pass the stability test (default `on`; `off` for a grammar of swimmers or fliers; a single creature says `floats;`)." },
];

/// The keys accepted at `path` (see [`super::keys`]).
pub fn keys(path: &[&str]) -> &'static [Key] {
    match path {
        ["creature"] => SECTION_KEYS,
        ["creature", "part"] => PART_KEYS,
        ["creature", "part", "joint"] => JOINT_KEYS,
        ["creature", "part", "slot"] => SLOT_KEYS,
        ["creature", "shape"] => SHAPE_KEYS,
        ["creature", "rule"] => RULE_KEYS,
        ["creature", "evolve"] => EVOLVE_KEYS,
        _ => &[],
    }
}

/// Checks the program's sections of this kind.
pub fn check(sections: &[Sec], cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    let mut resolve = |n: &Name, ns: Option<&str>, d: &mut Vec<Diagnostic>| cx.rule(n, ns, d).map(|_| 0);
    let _ = build(sections, cx.ex, &mut resolve, cx.sym.startshape.is_some(), diags);
}

/// Rule names the section refers to: the `rule RULE;` of every `part`.
pub fn rule_refs(sec: &Section) -> Vec<&Name> {
    let mut out = Vec::new();
    for e in &sec.entries {
        if e.key.text != "part" {
            continue;
        }
        for pe in e.block.iter().flat_map(|(b, _)| b) {
            if pe.key.text == "rule" {
                if let Some(Value::Word(w)) = pe.values.first() {
                    out.push(w);
                }
            }
        }
    }
    out
}

/// Lowers the sections into the bundle's table.
pub fn lower(sections: &[Sec], cx: &LowerCx) -> Option<CreatureTable> {
    let mut resolve = |n: &Name, ns: Option<&str>, _: &mut Vec<Diagnostic>| cx.rule(&n.text, ns);
    let mut diags = Vec::new();
    let t = build(sections, cx.ex, &mut resolve, cx.sym.startshape.is_some(), &mut diags)?;
    diags.iter().all(|d| !d.is_error()).then_some(t)
}

/// Resolves a geometry rule name to a bundle rule index (reporting E0301).
pub type RuleResolver<'r> = dyn FnMut(&Name, Option<&str>, &mut Vec<Diagnostic>) -> Option<u32> + 'r;

/// Checks the sections and builds the table; `None` when there is nothing to
/// build (errors are in `diags`). Every `creature` section of the program
/// contributes (std/creatures.mdg declares the parts, a program adds its
/// creatures and rules); `program` is false for a library (no start shape), which
/// need not have regular creatures.
pub fn build<'a>(
    sections: &[Sec<'a>],
    ex: &'a crate::expand::Expanded,
    resolve: &mut RuleResolver,
    program: bool,
    diags: &mut Vec<Diagnostic>,
) -> Option<CreatureTable> {
    let first = sections.first()?;
    let mut b = Builder { ex, ns: first.namespace, diags, t: CreatureTable::default() };
    let named = sections.iter().rev().find_map(|s| s.section.name.as_ref());
    b.t.name = named.map(|n| n.text.clone()).unwrap_or_default();
    b.sections(sections, resolve, program);
    Some(b.t)
}

struct Builder<'a, 'd> {
    ex: &'a crate::expand::Expanded,
    ns: Option<&'a str>,
    diags: &'d mut Vec<Diagnostic>,
    t: CreatureTable,
}

/// Part names with their spans, for messages.
struct Names {
    parts: Vec<(String, Span)>,
}

fn err(code: &'static str, span: Span, msg: impl Into<String>) -> Diagnostic {
    Diagnostic::error(code, span, msg)
}

impl<'a> Builder<'a, '_> {
    fn push(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    /// The one word value of `e`, or E0602.
    fn word<'e>(&mut self, e: &'e Entry, form: &str) -> Option<&'e Name> {
        if !expect_count(e, 1, 1, form, self.diags) {
            return None;
        }
        words(e, self.diags).and_then(|w| w.first().copied())
    }

    /// The numbers of `e` (exactly `n` of them), or E0602.
    fn nums(&mut self, e: &Entry, n: usize, form: &str) -> Option<Vec<f64>> {
        if !expect_count(e, n, n, form, self.diags) {
            return None;
        }
        numbers(self.ex, e, self.diags)
    }

    /// A whole number in `lo..=hi`, or E0602 / E0815.
    fn count(&mut self, e: &Entry, lo: u32, hi: u32) -> Option<u32> {
        let v = self.nums(e, 1, "one whole number")?[0];
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            let span = e.values.first().map(|v| v.span()).unwrap_or(e.span);
            self.push(
                err("E0815", span, format!("`{}` must be a whole number from {lo} to {hi}", e.key.text))
                    .with_label(format!("{v} is not")),
            );
            return None;
        }
        Some(v as u32)
    }

    /// E0602 when `e` has a `{ }` block it should not have.
    fn no_block(&mut self, e: &Entry) {
        if let Some((_, span)) = &e.block {
            self.push(err("E0602", *span, format!("`{}` takes no `{{ }}` block", e.key.text)));
        }
    }

    /// The block of `e` (E0808 when missing).
    fn block<'e>(&mut self, e: &'e Entry, what: &str) -> Option<&'e [Entry]> {
        match &e.block {
            Some((b, _)) => Some(b),
            None => {
                self.push(
                    err("E0808", e.span, format!("`{}` needs a `{{ … }}` block", e.key.text))
                        .with_note(format!("write `{} NAME {{ … }}` with the {what} inside", e.key.text)),
                );
                None
            }
        }
    }

    /// The name after `part`/`slot`/`shape`/`rule` (E0602 when missing).
    fn entry_name<'e>(&mut self, e: &'e Entry) -> Option<&'e Name> {
        match e.values.as_slice() {
            [Value::Word(w)] => Some(w),
            _ => {
                let span = e.values.first().map(|v| v.span()).unwrap_or(e.key.span);
                self.push(err("E0602", span, format!("`{}` takes a name and a `{{ … }}` block", e.key.text)));
                None
            }
        }
    }

    fn kind_index(&mut self, name: &Name) -> Option<u32> {
        if let Some(k) = self.t.kind(&name.text) {
            return Some(k);
        }
        let mut d = err("E0801", name.span, format!("unknown part type `{}`", name.text));
        let names: Vec<&str> = self.t.kinds.iter().map(|k| k.name.as_str()).collect();
        d = match did_you_mean(&name.text, names.iter().copied()) {
            Some(s) => d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                format!("replace with `{s}`"),
                name.span,
                s,
            ),
            None => d.with_label("no part has this type").with_note(format!("part types: {}", names.join(", "))),
        };
        self.push(d);
        None
    }

    fn kinds(&mut self, names: &[&Name]) -> Option<Vec<u32>> {
        let mut out = Vec::new();
        let mut ok = true;
        for n in names {
            match self.kind_index(n) {
                Some(k) if !out.contains(&k) => out.push(k),
                Some(_) => {}
                None => ok = false,
            }
        }
        ok.then_some(out)
    }

    fn category_index(&mut self, name: &Name) -> Option<u32> {
        if let Some(i) = self.t.categories.iter().position(|c| *c == name.text) {
            return Some(i as u32);
        }
        let mut d = err("E0803", name.span, format!("unknown category `{}`", name.text));
        d = match did_you_mean(&name.text, self.t.categories.iter().map(|s| s.as_str())) {
            Some(s) => d.with_label(format!("did you mean `{s}`?")),
            None => d
                .with_label("no part has this category")
                .with_note(format!("categories: {}", self.t.categories.join(", "))),
        };
        self.push(d);
        None
    }

    fn part_index(&mut self, name: &Name, names: &Names) -> Option<u32> {
        if let Some(i) = names.parts.iter().position(|(n, _)| *n == name.text) {
            return Some(i as u32);
        }
        let mut d = err("E0803", name.span, format!("unknown part `{}`", name.text));
        d = match did_you_mean(&name.text, names.parts.iter().map(|(n, _)| n.as_str())) {
            Some(s) => d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                format!("replace with `{s}`"),
                name.span,
                s,
            ),
            None => d.with_label("no `part` has this name"),
        };
        self.push(d);
        None
    }

    fn sections(&mut self, secs: &[Sec<'a>], resolve: &mut RuleResolver, program: bool) {
        let mut entries: Vec<&'a Entry> = Vec::new();
        let mut ns_of: Vec<Option<&'a str>> = Vec::new();
        for s in secs {
            for e in known_entries(&s.section.entries, SECTION_KEYS, "a `creature` section", self.diags) {
                entries.push(e);
                ns_of.push(s.namespace);
            }
        }
        let first_span = secs.first().map(|s| s.section.kind.span).unwrap_or_default();
        let last_span = secs.last().map(|s| s.section.kind.span).unwrap_or_default();
        // Types and categories are declared by the parts that use them.
        for e in entries.iter().filter(|e| e.key.text == "part") {
            for pe in e.block.iter().flat_map(|(b, _)| b) {
                if let (Some(Value::Word(w)), true) = (pe.values.first(), pe.values.len() == 1) {
                    if pe.key.text == "type" && self.t.kind(&w.text).is_none() {
                        self.t.kinds.push(Kind { name: w.text.clone(), torso: w.text == "torso" });
                    }
                    if pe.key.text == "category" && !self.t.categories.contains(&w.text) {
                        self.t.categories.push(w.text.clone());
                    }
                }
            }
        }
        let mut names = Names { parts: Vec::new() };
        for e in entries.iter().filter(|e| e.key.text == "part") {
            if let Some(n) = self.entry_name(e) {
                if let Some((_, prev)) = names.parts.iter().find(|(p, _)| *p == n.text) {
                    self.push(
                        err("E0812", n.span, format!("part `{}` is defined twice", n.text))
                            .with_secondary(*prev, "first defined here"),
                    );
                    continue;
                }
                names.parts.push((n.text.clone(), n.span));
            }
        }
        // Families first: slots accept whole families.
        let mut family_spans: Vec<(u32, Span)> = Vec::new();
        for e in entries.iter().filter(|e| e.key.text == "family") {
            self.family(e, &mut family_spans);
        }
        let mut part_defs: Vec<Option<PartDef>> = Vec::new();
        for (e, ns) in entries.iter().zip(&ns_of).filter(|(e, _)| e.key.text == "part") {
            let Some(n) = self.entry_name(e) else { continue };
            if !names.parts.iter().any(|(p, s)| *p == n.text && *s == n.span) {
                continue;
            }
            self.ns = *ns;
            let p = self.part(e, n, resolve);
            part_defs.push(p);
        }
        if names.parts.is_empty() {
            self.push(
                err("E0813", first_span, "the creature grammar has no parts")
                    .with_note("declare meta-parts with `part NAME { type …; category …; rule …; … }`"),
            );
        }
        let all_parts_ok = part_defs.iter().all(|p| p.is_some());
        self.t.parts = part_defs.into_iter().flatten().collect();
        let mut shape_names: Vec<(String, Span)> = Vec::new();
        for e in entries.iter().filter(|e| e.key.text == "shape") {
            let Some(n) = self.entry_name(e) else { continue };
            if let Some((_, prev)) = shape_names.iter().find(|(s, _)| *s == n.text) {
                self.push(
                    err("E0812", n.span, format!("shape `{}` is defined twice", n.text))
                        .with_secondary(*prev, "first defined here"),
                );
                continue;
            }
            shape_names.push((n.text.clone(), n.span));
            if all_parts_ok {
                if let Some(s) = self.shape(e, n, &names) {
                    self.t.shapes.push(s);
                }
            }
        }
        if shape_names.is_empty() && !names.parts.is_empty() && program {
            self.push(
                err("E0813", last_span, "the creature grammar has no regular creatures")
                    .with_note("the evolution starts from `shape NAME { torso PART; attach SLOT PART; … }`"),
            );
        }
        let mut selected: Vec<(&str, Span)> = Vec::new();
        let mut evolve_seen: Option<Span> = None;
        for e in &entries {
            match e.key.text.as_str() {
                "select" => self.select(e, &mut selected),
                "evolve" => {
                    if let Some(prev) = evolve_seen {
                        self.push(
                            err("E0603", e.key.span, "`evolve` is given twice")
                                .with_secondary(prev, "first given here"),
                        );
                        continue;
                    }
                    evolve_seen = Some(e.key.span);
                    self.evolve(e);
                }
                _ => {}
            }
        }
        self.cannot_stand(&shape_names);
        let mut rule_names: Vec<(String, Span)> = Vec::new();
        let mut rule_entries = Vec::new();
        for e in entries.iter().filter(|e| e.key.text == "rule") {
            let Some(n) = self.entry_name(e) else { continue };
            if let Some((_, prev)) = rule_names.iter().find(|(s, _)| *s == n.text) {
                self.push(
                    err("E0812", n.span, format!("rule `{}` is defined twice", n.text))
                        .with_secondary(*prev, "first defined here"),
                );
                continue;
            }
            rule_names.push((n.text.clone(), n.span));
            if let Some(r) = self.rule(e, n) {
                rule_entries.push((self.t.rules.len(), *e));
                self.t.rules.push(r);
            }
        }
        if all_parts_ok && !self.t.shapes.is_empty() {
            self.never_match(&rule_entries);
        }
        self.probabilities(&rule_entries);
    }

    fn family(&mut self, e: &Entry, spans: &mut Vec<(u32, Span)>) {
        self.no_block(e);
        if !expect_count(e, 2, usize::MAX, "two or more part types", self.diags) {
            return;
        }
        let Some(ws) = words(e, self.diags) else { return };
        let mut fam = Vec::new();
        for w in &ws {
            let Some(k) = self.kind_index(w) else { return };
            if let Some((_, prev)) = spans.iter().find(|(pk, _)| *pk == k) {
                self.push(
                    err("E0806", w.span, format!("part type `{}` is in two allelic families", w.text))
                        .with_secondary(*prev, "already in this family")
                        .with_note("allelic families are disjoint: merge the two into one"),
                );
                return;
            }
            if !fam.contains(&k) {
                fam.push(k);
            }
        }
        let torso: Vec<&&Name> = ws.iter().filter(|w| w.text == "torso").collect();
        if let (Some(t), true) = (torso.first(), torso.len() < ws.len()) {
            let other = ws.iter().find(|w| w.text != "torso").map(|w| w.text.as_str()).unwrap_or("?");
            self.push(
                err(
                    "E0806",
                    e.values.first().map(|v| v.span()).unwrap_or(e.span).to(e
                        .values
                        .last()
                        .map(|v| v.span())
                        .unwrap_or(e.span)),
                    "this allelic family mixes incompatible kinds",
                )
                .with_secondary(t.span, "a torso carries slots and is the root of a creature")
                .with_label(format!("`{other}` attaches to a torso by its joint; the two cannot replace each other")),
            );
            return;
        }
        for (w, k) in ws.iter().zip(&fam) {
            spans.push((*k, w.span));
        }
        self.t.families.push(fam);
    }

    fn mode(&mut self, v: &Value) -> Option<Mode> {
        if let Value::Word(w) = v {
            if let Some((_, m)) = Mode::NAMES.iter().find(|(n, _)| *n == w.text) {
                return Some(*m);
            }
        }
        self.push(err("E0602", v.span(), "the arrangement is `def`, `row`, `stack` or `fan`"));
        None
    }
}
/// Positions and triangles of an OBJ file.
pub type ObjMesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Why OBJ text is not a usable mesh; `line` counts from 1.
#[derive(Clone, Debug, PartialEq)]
pub enum ObjError {
    /// A vertex coordinate is not a number.
    BadNumber { line: usize, error: std::num::ParseFloatError },
    /// A vertex has fewer than three coordinates, or one is not finite.
    BadVertex { line: usize },
    /// A face's entry does not start with an integer.
    BadIndex { line: usize, text: String },
    /// A face names a vertex not defined before it (`count` so far).
    IndexOutOfRange { line: usize, index: i64, count: i64 },
    /// A face with fewer than three vertices.
    ShortFace { line: usize },
    /// The file has no face.
    NoFaces,
}

impl std::fmt::Display for ObjError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ObjError::BadNumber { line, error } => write!(f, "line {line}: {error}"),
            ObjError::BadVertex { line } => write!(f, "line {line}: a vertex needs three finite coordinates"),
            ObjError::BadIndex { line, text } => write!(f, "line {line}: bad vertex index `{text}`"),
            ObjError::IndexOutOfRange { line, index, count } => {
                write!(f, "line {line}: vertex index {index} out of range (1..{count})")
            }
            ObjError::ShortFace { line } => write!(f, "line {line}: a face needs three vertices"),
            ObjError::NoFaces => write!(f, "no faces"),
        }
    }
}

impl std::error::Error for ObjError {}

/// Parses Wavefront OBJ text: `v x y z` and `f a b c …` (polygons fanned into
/// triangles; `a/b/c` forms and negative indices accepted; other lines ignored).
/// Errors name the line.
pub fn parse_obj(text: &str) -> Result<ObjMesh, ObjError> {
    let mut pos: Vec<[f32; 3]> = Vec::new();
    let mut tris = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let (ln, line) = (ln + 1, line.split('#').next().unwrap_or("").trim());
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let v: Vec<f32> = it
                    .take(3)
                    .map(|s| s.parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|error| ObjError::BadNumber { line: ln, error })?;
                if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                    return Err(ObjError::BadVertex { line: ln });
                }
                pos.push([v[0], v[1], v[2]]);
            }
            Some("f") => {
                let mut idx = Vec::new();
                for s in it {
                    let first = s.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| ObjError::BadIndex { line: ln, text: s.to_string() })?;
                    let n = pos.len() as i64;
                    let k = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || k < 0 || k >= n {
                        return Err(ObjError::IndexOutOfRange { line: ln, index: i, count: n });
                    }
                    idx.push(k as u32);
                }
                if idx.len() < 3 {
                    return Err(ObjError::ShortFace { line: ln });
                }
                for k in 1..idx.len() - 1 {
                    tris.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if tris.is_empty() {
        return Err(ObjError::NoFaces);
    }
    Ok((pos, tris))
}

/// The `mesh "FILE.obj"` entries of a program's creature section, with the span
/// of each path, in table order.
pub fn mesh_refs(ex: &crate::expand::Expanded) -> Vec<(String, Span)> {
    let mut out = Vec::new();
    if let Some(sec) = super::sections(ex, "creature").first() {
        for e in sec.section.entries.iter().filter(|e| e.key.text == "part") {
            for pe in e.block.iter().flat_map(|(b, _)| b) {
                if let (true, [Value::Str(p, span)]) = (pe.key.text == "mesh", pe.values.as_slice()) {
                    out.push((p.clone(), *span));
                }
            }
        }
    }
    out
}

/// Reads every `mesh "FILE.obj"` of the program through `loader` and embeds it in
/// the bundle's creature table (E0810 when a file cannot be read, lies outside the
/// project and the std directory, or is not a usable OBJ). Paths are relative to
/// the file that names them.
pub fn embed_meshes(
    bundle: &mut mdg_vm::bundle::Bundle,
    ex: &crate::expand::Expanded,
    sources: &crate::source::Sources,
    loader: &dyn crate::source::FileLoader,
    std_dir: Option<&std::path::Path>,
) -> Vec<Diagnostic> {
    let mut diags = Vec::new();
    let refs = mesh_refs(ex);
    let Some((_, first)) = refs.first() else { return diags };
    let mut table = match CreatureTable::from_bundle(bundle) {
        Ok(Some(t)) => t,
        Ok(None) => return diags,
        Err(e) => {
            diags.push(err("E0810", *first, "cannot embed the meshes").with_label(e.to_string()));
            return diags;
        }
    };
    let root = ex
        .files
        .first()
        .and_then(|f| sources.files.get(f.0 as usize))
        .and_then(|f| f.path.parent().map(|p| p.to_path_buf()))
        .map(|p| if p.as_os_str().is_empty() { std::path::PathBuf::from(".") } else { p })
        .and_then(|p| loader.canonicalize(&p).ok());
    let std_root = std_dir.and_then(|d| loader.canonicalize(d).ok());
    for ((path, span), mesh) in refs.iter().zip(table.meshes.iter_mut()) {
        let from = sources.files.get(span.file.0 as usize).map(|f| f.path.clone()).unwrap_or_default();
        let candidate = from.parent().unwrap_or(std::path::Path::new(".")).join(path);
        let canon = match loader.canonicalize(&candidate) {
            Ok(c) => c,
            Err(e) => {
                diags.push(err("E0810", *span, format!("cannot find mesh `{path}`")).with_label(e));
                continue;
            }
        };
        let inside = |r: &Option<std::path::PathBuf>| r.as_ref().is_some_and(|r| canon.starts_with(r));
        if !inside(&root) && !inside(&std_root) {
            diags.push(
                err("E0810", *span, format!("mesh `{path}` is outside the project and the std library"))
                    .with_label(format!("resolves to {}", canon.display())),
            );
            continue;
        }
        let text = match loader.read(&canon) {
            Ok(t) => t,
            Err(e) => {
                diags.push(err("E0810", *span, format!("cannot read mesh `{path}`")).with_label(e));
                continue;
            }
        };
        match parse_obj(&text) {
            Ok((p, t)) => {
                mesh.positions = p;
                mesh.triangles = t;
            }
            Err(e) => diags
                .push(err("E0810", *span, format!("mesh `{path}` is not a usable OBJ file")).with_label(e.to_string())),
        }
    }
    table.store(&mut bundle.extensions);
    diags
}

#[cfg(test)]
mod tests;
