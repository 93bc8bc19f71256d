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

use super::{at_most_once, expect_count, known_entries, numbers, words, CheckCx, Key, Sec};
use crate::ast::{Entry, Expr, ExprKind, Name, Section, Value};

use crate::diag::{did_you_mean, Diagnostic};
use crate::lower::LowerCx;
use crate::span::Span;
use mdg_vm::creature::cond::{self, CondOp, VARIABLES};
use mdg_vm::creature::table::{
    self as tb, AttachDef, Code, CreatureTable, EvolveSettings, Geometry, Kind, Mode, PartDef, PartMesh, RuleDef,
    RuleKind, ShapeDef, Slot, Strategy,
};
use mdg_vm::expr::{BINOPS, FUNCTIONS};

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

/// A name for the mirror image of slot `name`: `_l` ↔ `_r`, else `NAME_r`.
fn mirror_name(name: &str) -> String {
    if let Some(b) = name.strip_suffix("_l") {
        format!("{b}_r")
    } else if let Some(b) = name.strip_suffix("_r") {
        format!("{b}_l")
    } else {
        format!("{name}_r")
    }
}

/// Evaluations [`cond::never_hold`] may spend on one rule's conditions.
const NEVER_HOLD_BUDGET: u64 = 4_000_000;

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

    /// W0801: a regular creature subject to the stability test that cannot pass it
    /// (none of its parts is a `support` part, so it has no support points).
    fn cannot_stand(&mut self, shape_names: &[(String, Span)]) {
        // Not after errors: a shape missing a bad attach is no evidence.
        if !self.t.evolve.stability || self.diags.iter().any(|d| d.is_error()) {
            return;
        }
        let mut found = Vec::new();
        for s in &self.t.shapes {
            if s.floats {
                continue;
            }
            let support = |p: u32| self.t.parts.get(p as usize).is_some_and(|p| p.support);
            if support(s.torso) || s.attach.iter().any(|a| support(a.part)) {
                continue;
            }
            let Some((_, span)) = shape_names.iter().find(|(n, _)| *n == s.name) else { continue };
            let d = Diagnostic::warning(
                "W0801",
                *span,
                format!("regular creature `{}` cannot pass the stability test", s.name),
            )
            .with_label("none of its parts is a `support` part: it has nothing to stand on")
            .with_note("a swimmer or a flier says `floats;` in its shape (or the grammar `stability off;` in `evolve`); a walker needs `support;` parts (legs)");
            found.push(d);
        }
        self.diags.extend(found);
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

    fn vec3(&mut self, e: &Entry) -> Option<[f32; 3]> {
        let v = self.nums(e, 3, "three numbers X Y Z")?;
        self.within_range(e, &v)?;
        Some([v[0] as f32, v[1] as f32, v[2] as f32])
    }

    /// E0815 unless every value is within ±[`MAX_COORDINATE`] (beyond it, f32
    /// geometry loses the precision normals and slots need, or overflows).
    fn within_range(&mut self, e: &Entry, v: &[f64]) -> Option<()> {
        if let Some(i) = v.iter().position(|x| x.abs() > MAX_COORDINATE) {
            let span = e.values.get(i).map(|v| v.span()).unwrap_or(e.span);
            self.push(
                err("E0815", span, format!("`{}` values must be within ±{MAX_COORDINATE}", e.key.text))
                    .with_label(format!("{} is out of range", v[i])),
            );
            return None;
        }
        Some(())
    }

    fn positive(&mut self, e: &Entry) -> Option<f32> {
        let v = self.nums(e, 1, "one number")?[0];
        self.within_range(e, &[v])?;
        if v <= 0.0 {
            let span = e.values.first().map(|v| v.span()).unwrap_or(e.span);
            self.push(
                err("E0815", span, format!("`{}` must be positive", e.key.text)).with_label(format!("{v} is not")),
            );
            return None;
        }
        Some(v as f32)
    }

    /// `joint { … }` or `slot NAME { … }`.
    fn slot<'e>(&mut self, e: &'e Entry, name: String, is_slot: bool) -> Option<(Slot, Option<&'e Name>)> {
        let block = self.block(e, if is_slot { "slot's keys" } else { "joint's keys" })?;
        let allowed = if is_slot { SLOT_KEYS } else { JOINT_KEYS };
        let what = if is_slot { "a `slot`" } else { "a `joint`" };
        let es = known_entries(block, allowed, what, self.diags);
        at_most_once(&es, self.diags);
        let mut s = Slot {
            name,
            at: [0.0; 3],
            normal: [0.0; 3],
            up: [0.0; 3],
            size: 0.0,
            accepts: Vec::new(),
            mirror_of: None,
            partner: None,
            turn: [0.0; 3],
            spacing: 0.0,
        };
        let (mut have_at, mut have_normal, mut have_size, mut have_accepts) = (false, false, false, false);
        let mut up: Option<([f32; 3], Span)> = None;
        let mut normal_span = e.key.span;
        let mut symmetric = None;
        let mut ok = true;
        for x in &es {
            self.no_block(x);
            match x.key.text.as_str() {
                "at" => match self.vec3(x) {
                    Some(v) => (s.at, have_at) = (v, true),
                    None => ok = false,
                },
                "normal" => match self.vec3(x) {
                    Some(v) => {
                        (s.normal, have_normal) = (v, true);
                        normal_span = x.span;
                    }
                    None => ok = false,
                },
                "up" => match self.vec3(x) {
                    Some(v) => up = Some((v, x.span)),
                    None => ok = false,
                },
                "size" => match self.positive(x) {
                    Some(v) => (s.size, have_size) = (v, true),
                    None => ok = false,
                },
                "accepts" => {
                    self.no_block(x);
                    if !expect_count(x, 1, usize::MAX, "one or more part types", self.diags) {
                        ok = false;
                        continue;
                    }
                    match words(x, self.diags).and_then(|w| self.kinds(&w)) {
                        Some(ks) => {
                            have_accepts = true;
                            for k in ks {
                                for f in self.t.family(k) {
                                    if !s.accepts.contains(&f) {
                                        s.accepts.push(f);
                                    }
                                }
                            }
                        }
                        None => ok = false,
                    }
                }
                "symmetric" => match self.word(x, "the name of the mirror slot") {
                    Some(n) => symmetric = Some(n),
                    None => ok = false,
                },
                "turn" => match self.vec3(x) {
                    Some(v) => s.turn = v.map(|d| d.to_radians()),
                    None => ok = false,
                },
                "spacing" => match self.positive(x) {
                    Some(v) => s.spacing = v,
                    None => ok = false,
                },
                _ => {}
            }
        }
        let mut missing: Vec<&str> = Vec::new();
        if !have_at {
            missing.push("at");
        }
        if !have_normal {
            missing.push("normal");
        }
        if !have_size {
            missing.push("size");
        }
        if is_slot && !have_accepts {
            missing.push("accepts");
        }
        if !missing.is_empty() {
            self.push(
                err(
                    "E0808",
                    e.key.span,
                    format!(
                        "this {} is missing `{}`",
                        what.trim_start_matches("a ").trim_matches('`'),
                        missing.join("`, `")
                    ),
                )
                .with_note(format!(
                    "{what} needs `at X Y Z; normal X Y Z; size S;`{}",
                    if is_slot { " and `accepts TYPE…;`" } else { "" }
                )),
            );
            return None;
        }
        if !ok {
            return None;
        }
        let n = glam::Vec3::from(s.normal);
        if n.length() < 1e-6 {
            self.push(err("E0815", normal_span, "a slot's normal must not be zero"));
            return None;
        }
        let n = n.normalize();
        let up_v = match up {
            Some((u, _)) => glam::Vec3::from(u),
            None if n.z.abs() < 0.95 => glam::Vec3::Z,
            None => glam::Vec3::NEG_Y,
        };
        let u = up_v - n * up_v.dot(n);
        if u.length() < 1e-4 {
            let span = up.map(|u| u.1).unwrap_or(normal_span);
            self.push(
                err("E0815", span, "a slot's `up` must not be parallel to its normal")
                    .with_label("it fixes the twist about the normal"),
            );
            return None;
        }
        s.normal = n.to_array();
        s.up = u.normalize().to_array();
        Some((s, symmetric))
    }

    fn part(&mut self, e: &Entry, name: &Name, resolve: &mut RuleResolver) -> Option<PartDef> {
        let block = self.block(e, "part's keys")?;
        let es = known_entries(block, PART_KEYS, "a `part`", self.diags);
        let singles: Vec<&Entry> = es.iter().filter(|x| x.key.text != "slot").copied().collect();
        at_most_once(&singles, self.diags);
        let mut kind = None;
        let mut category = None;
        let mut geometry: Option<(Geometry, Span)> = None;
        let mut color: Option<([f32; 4], Span)> = None;
        let mut scale = 1.0f32;
        let mut support = false;
        let mut joint = None;
        let mut slots: Vec<Slot> = Vec::new();
        let mut slot_spans: Vec<Span> = Vec::new();
        let mut ok = true;
        for x in &es {
            if !matches!(x.key.text.as_str(), "joint" | "slot") {
                self.no_block(x);
            }
            match x.key.text.as_str() {
                "type" => kind = self.word(x, "one part type").and_then(|w| self.t.kind(&w.text)),
                "category" => {
                    category = self
                        .word(x, "one category name")
                        .and_then(|w| self.t.categories.iter().position(|c| *c == w.text))
                        .map(|i| i as u32)
                }
                "rule" | "mesh" => {
                    if let Some((_, prev)) = &geometry {
                        self.push(
                            err("E0809", x.key.span, "a part has one geometry: `rule` or `mesh`, not both")
                                .with_secondary(*prev, "geometry given here"),
                        );
                        ok = false;
                        continue;
                    }
                    if x.key.text == "rule" {
                        let Some(w) = self.word(x, "the name of an MDG rule") else {
                            ok = false;
                            continue;
                        };
                        match resolve(w, self.ns, self.diags) {
                            Some(r) => geometry = Some((Geometry::Rule(r), x.key.span)),
                            None => ok = false,
                        }
                    } else {
                        if !expect_count(x, 1, 1, "a file name in quotes", self.diags) {
                            ok = false;
                            continue;
                        }
                        match x.values.first() {
                            Some(Value::Str(path, span))
                                if std::path::Path::new(path).is_absolute() || path.is_empty() =>
                            {
                                self.push(
                                    err("E0810", *span, format!("mesh path `{path}` must be relative"))
                                        .with_label("meshes are read relative to the file that names them")
                                        .with_note("a mesh must lie inside the project (the main file's directory) or the std directory"),
                                );
                                ok = false;
                            }
                            Some(Value::Str(path, span)) => {
                                let index = self.t.meshes.len() as u32;
                                self.t.meshes.push(PartMesh {
                                    path: path.clone(),
                                    positions: Vec::new(),
                                    triangles: Vec::new(),
                                    color: [0.8, 0.8, 0.8, 1.0],
                                });
                                let _ = span;
                                geometry = Some((Geometry::Mesh(index), x.key.span));
                            }
                            Some(v) => {
                                self.push(
                                    err("E0602", v.span(), "`mesh` takes a file name in quotes")
                                        .with_label("not a string"),
                                );
                                ok = false;
                            }
                            None => ok = false,
                        }
                    }
                }
                "color" => match self.nums(x, 3, "three numbers R G B") {
                    Some(v) => color = Some(([v[0] as f32, v[1] as f32, v[2] as f32, 1.0], x.span)),
                    None => ok = false,
                },
                "scale" => match self.positive(x) {
                    Some(v) => scale = v,
                    None => ok = false,
                },
                "support" if expect_count(x, 0, 0, "no values", self.diags) => support = true,
                "joint" => {
                    if !x.values.is_empty() {
                        self.push(err("E0602", x.values[0].span(), "`joint` takes only a `{ … }` block"));
                        ok = false;
                        continue;
                    }
                    match self.slot(x, "joint".into(), false) {
                        Some((j, _)) => joint = Some((j, x.key.span)),
                        None => ok = false,
                    }
                }
                "slot" => {
                    let Some(n) = self.entry_name(x) else {
                        ok = false;
                        continue;
                    };
                    let Some((s, sym)) = self.slot(x, n.text.clone(), true) else {
                        ok = false;
                        continue;
                    };
                    if let Some(i) = slots.iter().position(|o| o.name == s.name) {
                        let d = if slots[i].mirror_of.is_some() {
                            err("E0812", n.span, format!("slot `{}` is declared by `symmetric` already", n.text))
                                .with_secondary(slot_spans[i], "`symmetric` declares the mirror slot here")
                                .with_note(format!(
                                    "`symmetric {}` makes the mirror image of its slot: remove this `slot {} {{ … }}`",
                                    n.text, n.text
                                ))
                        } else {
                            err("E0812", n.span, format!("slot `{}` is defined twice in part `{}`", n.text, name.text))
                                .with_secondary(slot_spans[i], "first defined here")
                        };
                        self.push(d);
                        ok = false;
                        continue;
                    }
                    let orig = slots.len() as u32;
                    slots.push(s.clone());
                    slot_spans.push(n.span);
                    if let Some(m) = sym {
                        if m.text == n.text {
                            self.push(
                                err("E0812", m.span, format!("slot `{}` cannot be its own mirror slot", n.text))
                                    .with_label("`symmetric` names the mirror slot it declares")
                                    .with_note(format!(
                                        "give the mirror image its own name, e.g. `symmetric {}`",
                                        mirror_name(&n.text)
                                    )),
                            );
                            ok = false;
                            continue;
                        }
                        if let Some(i) = slots.iter().position(|o| o.name == m.text) {
                            if slots[i].mirror_of.is_none() && slots[i].partner.is_none() {
                                self.push(
                                    err("E0812", m.span, format!("`symmetric {}` declares a slot that exists", m.text))
                                        .with_secondary(slot_spans[i], "declared here already")
                                        .with_note(format!(
                                            "`symmetric {}` makes the mirror image of slot `{}` itself: remove the separate `slot {} {{ … }}`",
                                            m.text, n.text, m.text
                                        )),
                                );
                                ok = false;
                                continue;
                            }
                            self.push(
                                err(
                                    "E0812",
                                    m.span,
                                    format!("slot `{}` is defined twice in part `{}`", m.text, name.text),
                                )
                                .with_secondary(slot_spans[i], "first defined here"),
                            );
                            ok = false;
                            continue;
                        }
                        if s.at[0].abs() < 1e-6 && s.normal[0].abs() < 1e-6 {
                            self.push(
                                err("E0815", m.span, format!("slot `{}` is its own mirror image", n.text))
                                    .with_label("a symmetric slot must lie off the plane x = 0 or point away from it"),
                            );
                            ok = false;
                            continue;
                        }
                        let mx = |v: [f32; 3]| [-v[0], v[1], v[2]];
                        slots.push(Slot {
                            name: m.text.clone(),
                            at: mx(s.at),
                            normal: mx(s.normal),
                            up: mx(s.up),
                            mirror_of: Some(orig),
                            partner: Some(orig),
                            ..s.clone()
                        });
                        slot_spans.push(m.span);
                        slots[orig as usize].partner = Some(orig + 1);
                    }
                }
                _ => {}
            }
        }
        let mut missing = Vec::new();
        if !es.iter().any(|x| x.key.text == "type") {
            missing.push("type");
        }
        if !es.iter().any(|x| x.key.text == "category") {
            missing.push("category");
        }
        if !es.iter().any(|x| x.key.text == "rule" || x.key.text == "mesh") {
            missing.push("rule` or `mesh");
        }
        if !missing.is_empty() {
            self.push(
                err("E0808", name.span, format!("part `{}` is missing `{}`", name.text, missing.join("`, `")))
                    .with_note(
                    "a part needs `type TYPE; category NAME;` and its geometry: `rule RULE;` or `mesh \"FILE.obj\";`",
                ),
            );
            return None;
        }
        if let (Some((_, span)), Some(Geometry::Rule(_))) = (&color, geometry.as_ref().map(|g| &g.0)) {
            self.push(
                err("E0809", *span, "`color` is for `mesh` parts")
                    .with_label("a `rule` part has the colours its rule draws"),
            );
            ok = false;
        }
        let (kind, category, (geometry, _)) = (kind?, category?, geometry?);
        let is_torso = self.t.kinds.get(kind as usize).is_some_and(|k| k.torso);
        if !is_torso {
            if let Some(first) = slot_spans.first() {
                self.push(
                    err(
                        "E0811",
                        *first,
                        format!("only torsos have slots; `{}` is a `{}`", name.text, self.t.kinds[kind as usize].name),
                    )
                    .with_note("other parts attach to a torso by their `joint`"),
                );
                return None;
            }
            if joint.is_none() {
                self.push(
                    err("E0811", name.span, format!("part `{}` has no `joint`", name.text))
                        .with_label("every part but a torso attaches to a torso by its joint")
                        .with_note("add `joint { at X Y Z; normal X Y Z; size S; }` at the end that touches the torso"),
                );
                return None;
            }
        }
        if let (Some((_, span)), Geometry::Mesh(m)) = (&color, &geometry) {
            if let Some(mesh) = self.t.meshes.get_mut(*m as usize) {
                let c = color.map(|c| c.0).unwrap_or([0.8; 4]);
                if c[..3].iter().any(|v| !(0.0..=1.0).contains(v)) {
                    self.push(err("E0815", *span, "colour components must be in 0–1"));
                    return None;
                }
                mesh.color = c;
            }
        }
        if !ok {
            return None;
        }
        Some(PartDef {
            name: name.text.clone(),
            kind,
            category,
            geometry,
            joint: joint.map(|j| j.0),
            slots,
            support,
            scale,
        })
    }

    fn shape(&mut self, e: &Entry, name: &Name, names: &Names) -> Option<ShapeDef> {
        let block = self.block(e, "creature's torso and attachments")?;
        let es = known_entries(block, SHAPE_KEYS, "a `shape`", self.diags);
        let torsos: Vec<&Entry> = es.iter().filter(|x| x.key.text == "torso").copied().collect();
        at_most_once(&torsos, self.diags);
        let Some(te) = torsos.first() else {
            self.push(
                err("E0808", name.span, format!("shape `{}` has no `torso`", name.text)).with_note("add `torso PART;`"),
            );
            return None;
        };
        self.no_block(te);
        let tn = self.word(te, "one part name")?;
        let torso = self.part_index(tn, names)?;
        let tp = self.t.parts.get(torso as usize)?.clone();
        if !self.t.kinds[tp.kind as usize].torso {
            self.push(
                err("E0807", tn.span, format!("`{}` is not a torso", tn.text))
                    .with_label(format!("its type is `{}`", self.t.kinds[tp.kind as usize].name)),
            );
            return None;
        }
        let mut attach: Vec<AttachDef> = Vec::new();
        let mut used: Vec<(u32, Span)> = Vec::new();
        for x in es.iter().filter(|x| x.key.text == "attach") {
            self.no_block(x);
            if !expect_count(x, 2, 4, "SLOT PART [COUNT [MODE]]", self.diags) {
                continue;
            }
            let (Some(Value::Word(sn)), Some(Value::Word(pn))) = (x.values.first(), x.values.get(1)) else {
                let bad =
                    x.values.iter().take(2).find(|v| !matches!(v, Value::Word(_))).map(|v| v.span()).unwrap_or(x.span);
                self.push(err("E0602", bad, "`attach` takes SLOT PART [COUNT [MODE]]").with_label("not a name"));
                continue;
            };
            let Some(mut slot) = tp.slots.iter().position(|s| s.name == sn.text).map(|i| i as u32) else {
                let mut d = err("E0802", sn.span, format!("part `{}` has no slot `{}`", tp.name, sn.text));
                d = match did_you_mean(&sn.text, tp.slots.iter().map(|s| s.name.as_str())) {
                    Some(s) => d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                        format!("replace with `{s}`"),
                        sn.span,
                        s,
                    ),
                    None => d.with_note(format!(
                        "its slots: {}",
                        tp.slots.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
                    )),
                };
                self.push(d);
                continue;
            };
            if let Some(m) = tp.slots[slot as usize].mirror_of {
                slot = m;
            }
            let Some(part) = self.part_index(pn, names) else {
                continue;
            };
            let pk = self.t.parts[part as usize].kind;
            let sl = &tp.slots[slot as usize];
            if !sl.accepts.contains(&pk) || self.t.kinds[pk as usize].torso {
                let accepts: Vec<&str> = sl.accepts.iter().map(|k| self.t.kinds[*k as usize].name.as_str()).collect();
                self.push(
                    err("E0807", pn.span, format!("slot `{}` does not accept `{}`", sn.text, pn.text))
                        .with_label(format!("a `{}`", self.t.kinds[pk as usize].name))
                        .with_note(format!("slot `{}` accepts: {}", sn.text, accepts.join(", "))),
                );
                continue;
            }
            if let Some((_, prev)) = used.iter().find(|(s, _)| *s == slot) {
                self.push(
                    err("E0812", sn.span, format!("slot `{}` is filled twice", sn.text))
                        .with_secondary(*prev, "filled here (or by its mirror slot)"),
                );
                continue;
            }
            used.push((slot, sn.span));
            let count = match x.values.get(2) {
                Some(v) => match crate::ext::number(self.ex, v) {
                    Some(c) if c.fract() == 0.0 && (1.0..=tb::MAX_COUNT as f64).contains(&c) => c as u32,
                    _ => {
                        self.push(err(
                            "E0815",
                            v.span(),
                            format!("COUNT must be a whole number from 1 to {}", tb::MAX_COUNT),
                        ));
                        continue;
                    }
                },
                None => 1,
            };
            let mode = match x.values.get(3) {
                Some(v) => match self.mode(v) {
                    Some(m) => m,
                    None => {
                        continue;
                    }
                },
                None if count > 1 => Mode::Row,
                None => Mode::Def,
            };
            attach.push(AttachDef { slot, part, count, mode });
        }
        let floats = match es.iter().find(|x| x.key.text == "floats") {
            Some(x) => {
                self.no_block(x);
                expect_count(x, 0, 0, "no values", self.diags)
            }
            None => false,
        };
        // An attach in error is left out (and reported); the others stay, so rules
        // on the parts they attach are not reported as never matching.
        Some(ShapeDef { name: name.text.clone(), torso, attach, floats })
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

    fn select(&mut self, e: &Entry, seen: &mut Vec<(&'static str, Span)>) {
        self.no_block(e);
        if !expect_count(e, 2, 2, "`shapes` or `rules`, then `rank`, `uniform` or `roulette`", self.diags) {
            return;
        }
        let Some(ws) = words(e, self.diags) else { return };
        let what: &'static str = match ws[0].text.as_str() {
            "shapes" => "shapes",
            "rules" => "rules",
            _ => {
                self.push(
                    err("E0602", ws[0].span, "`select` takes `shapes` or `rules` first").with_label("what is selected"),
                );
                return;
            }
        };
        let Some((_, strategy)) = Strategy::NAMES.iter().find(|(n, _)| *n == ws[1].text) else {
            let mut d = err("E0602", ws[1].span, "the selection rule is `rank`, `uniform` or `roulette`");
            if let Some(s) = did_you_mean(&ws[1].text, Strategy::NAMES.iter().map(|(n, _)| *n)) {
                d = d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                    format!("replace with `{s}`"),
                    ws[1].span,
                    s,
                );
            }
            self.push(d);
            return;
        };
        if let Some((_, prev)) = seen.iter().find(|(w, _)| *w == what) {
            self.push(
                err("E0603", e.key.span, format!("`select {what}` is given twice"))
                    .with_secondary(*prev, "first given here"),
            );
            return;
        }
        seen.push((what, e.key.span));
        if what == "shapes" {
            self.t.select_shapes = *strategy;
        } else {
            self.t.select_rules = *strategy;
        }
    }

    fn evolve(&mut self, e: &Entry) {
        if !e.values.is_empty() {
            self.push(err("E0602", e.values[0].span(), "`evolve` takes only a `{ … }` block"));
        }
        let Some(block) = self.block(e, "evolution settings") else { return };
        let es = known_entries(block, EVOLVE_KEYS, "`evolve`", self.diags);
        at_most_once(&es, self.diags);
        let mut s = EvolveSettings::default();
        let mut offspring_given = false;
        for x in &es {
            self.no_block(x);
            let v = match x.key.text.as_str() {
                "population" | "background" => {
                    self.count(x, if x.key.text == "population" { 1 } else { 0 }, tb::MAX_POPULATION)
                }
                "generations" => self.count(x, 0, tb::MAX_GENERATIONS),
                "offspring" => self.count(x, 1, tb::MAX_POPULATION * 4),
                "steps" => self.count(x, 1, tb::MAX_STEPS),
                "attempts" => self.count(x, 1, tb::MAX_ATTEMPTS),
                "maxparts" => self.count(x, 2, tb::MAX_PARTS),
                "seed" => self.count(x, 0, u32::MAX),
                "stability" => {
                    match x.values.first() {
                        Some(Value::Word(w)) if x.values.len() == 1 && (w.text == "on" || w.text == "off") => {
                            s.stability = w.text == "on"
                        }
                        _ => self.push(err("E0602", x.span, "`stability` is `on` or `off`")),
                    }
                    None
                }
                _ => None,
            };
            let Some(v) = v else { continue };
            match x.key.text.as_str() {
                "population" => s.population = v,
                "background" => s.background = v,
                "generations" => s.generations = v,
                "offspring" => {
                    s.offspring = v;
                    offspring_given = true;
                }
                "steps" => s.steps = v,
                "attempts" => s.attempts = v,
                "maxparts" => s.maxparts = v,
                "seed" => s.seed = v as u64,
                _ => {}
            }
        }
        if !offspring_given {
            s.offspring = s.population * 3;
        }
        self.t.evolve = s;
    }

    fn rule(&mut self, e: &Entry, name: &Name) -> Option<RuleDef> {
        let block = self.block(e, "rule's keys")?;
        let es = known_entries(block, RULE_KEYS, "a structure `rule`", self.diags);
        let singles: Vec<&Entry> = es.iter().filter(|x| x.key.text != "condition").copied().collect();
        at_most_once(&singles, self.diags);
        let find = |k: &str| es.iter().find(|x| x.key.text == k).copied();
        let Some(ke) = find("kind") else {
            self.push(
                err("E0808", name.span, format!("rule `{}` has no `kind`", name.text))
                    .with_note("add `kind increase;`, `kind insert;`, `kind replace;` or `kind combine;`"),
            );
            return None;
        };
        let kw = self.word(ke, "`increase`, `insert`, `replace` or `combine`")?;
        let Some((_, kind)) = RuleKind::NAMES.iter().find(|(n, _)| *n == kw.text) else {
            let mut d = err("E0602", kw.span, "a rule's `kind` is `increase`, `insert`, `replace` or `combine`");
            if let Some(s) = did_you_mean(&kw.text, RuleKind::NAMES.iter().map(|(n, _)| *n)) {
                d = d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                    format!("replace with `{s}`"),
                    kw.span,
                    s,
                );
            }
            self.push(d);
            return None;
        };
        let kind = *kind;
        // Keys that belong to other kinds of rule.
        let mut ok = true;
        for x in &es {
            let belongs = match x.key.text.as_str() {
                "add" | "arrange" | "max" => kind == RuleKind::Increase,
                "successor" => matches!(kind, RuleKind::Insert | RuleKind::Replace),
                "from" => kind != RuleKind::Increase,
                "take" => kind == RuleKind::Combine,
                _ => true,
            };
            if !belongs {
                self.push(
                    err(
                        "E0809",
                        x.key.span,
                        format!(
                            "`{}` does not belong in {} `{}` rule",
                            x.key.text,
                            if kind == RuleKind::Increase { "an" } else { "a" },
                            kind.name()
                        ),
                    )
                    .with_note(key_kinds(&x.key.text)),
                );
                ok = false;
            }
        }
        let mut r = RuleDef {
            id: name.text.clone(),
            kind,
            priority: 0,
            predecessor: Vec::new(),
            category: None,
            conditions: Vec::new(),
            probability: Code(vec![CondOp::Push(1.0)]),
            add: 1,
            arrange: Mode::Row,
            max: 3,
            successor: Vec::new(),
            from: None,
            take: Vec::new(),
        };
        let Some(pe) = find("predecessor") else {
            self.push(
                err("E0808", name.span, format!("rule `{}` has no `predecessor`", name.text))
                    .with_note("add `predecessor TYPE…;`: the super-part types it rewrites"),
            );
            return None;
        };
        if kind == RuleKind::Insert && find("successor").is_none() {
            self.push(
                err("E0808", name.span, format!("insert rule `{}` has no `successor`", name.text))
                    .with_note("add `successor TYPE…;`: the part types it inserts"),
            );
            ok = false;
        }
        for x in &es {
            self.no_block(x);
            match x.key.text.as_str() {
                "priority" => {
                    if let Some(v) = self.nums(x, 1, "one whole number") {
                        if v[0].fract() != 0.0 || v[0].abs() > 1e6 {
                            self.push(err("E0815", x.values[0].span(), "a priority is a whole number"));
                            ok = false;
                        } else {
                            r.priority = v[0] as i32;
                        }
                    } else {
                        ok = false;
                    }
                }
                "predecessor" | "successor" | "take" => {
                    if !expect_count(x, 1, usize::MAX, "one or more part types", self.diags) {
                        ok = false;
                        continue;
                    }
                    match words(x, self.diags).and_then(|w| self.kinds(&w)) {
                        Some(ks) => match x.key.text.as_str() {
                            "predecessor" => r.predecessor = ks,
                            "successor" => r.successor = ks,
                            _ => r.take = ks,
                        },
                        None => ok = false,
                    }
                }
                "category" | "from" => match self.word(x, "one category name").and_then(|w| self.category_index(w)) {
                    Some(c) if x.key.text == "category" => r.category = Some(c),
                    Some(c) => r.from = Some(c),
                    None => ok = false,
                },
                "condition" => {
                    if !expect_count(x, 1, 1, "one expression in parentheses", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.code(&x.values[0], true) {
                        Some(c) => r.conditions.push(c),
                        None => ok = false,
                    }
                }
                "probability" => {
                    if !expect_count(x, 1, 1, "a number or an expression in parentheses", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.code(&x.values[0], false) {
                        Some(c) => {
                            // Keeps the exhaustive range check (E0805) small: g and one count.
                            let (vars, parts) = cond::reads(&c.0);
                            let counts: Vec<&str> = vars
                                .iter()
                                .filter(|&&v| v != 0)
                                .map(|&v| VARIABLES[v as usize])
                                .chain(parts.then_some("parts(…)"))
                                .collect();
                            if counts.len() > 1 {
                                self.push(
                                    err(
                                        "E0814",
                                        x.values[0].span(),
                                        "a probability may read `g` and at most one count",
                                    )
                                    .with_label(format!("it reads {}", counts.join(", ")))
                                    .with_note("move the other tests into a `condition`"),
                                );
                                ok = false;
                            } else {
                                r.probability = c;
                            }
                        }
                        None => ok = false,
                    }
                }
                "add" => match self.count(x, 1, tb::MAX_COUNT - 1) {
                    Some(v) => r.add = v,
                    None => ok = false,
                },
                "max" => match self.count(x, 2, tb::MAX_COUNT) {
                    Some(v) => r.max = v,
                    None => ok = false,
                },
                "arrange" => {
                    if !expect_count(x, 1, 1, "`row`, `stack` or `fan`", self.diags) {
                        ok = false;
                        continue;
                    }
                    match self.mode(&x.values[0]) {
                        Some(m) => r.arrange = m,
                        None => ok = false,
                    }
                }
                _ => {}
            }
        }
        let _ = pe;
        ok.then_some(r)
    }

    /// Compiles a condition or probability value.
    fn code(&mut self, v: &Value, condition: bool) -> Option<Code> {
        let mut out = Vec::new();
        match v {
            Value::Num(n) => {
                if n.unit.is_some() {
                    self.push(
                        err("E0814", n.span, "a probability is a plain number").with_label("no unit suffix here"),
                    );
                    return None;
                }
                out.push(CondOp::Push(n.value));
            }
            Value::Neg(n) => out.push(CondOp::Push(-n.value)),
            Value::Expr(e) => {
                if !self.expr(e, condition, &mut out) {
                    return None;
                }
            }
            Value::Word(w) => {
                let mut tmp = Vec::new();
                let e = Expr { kind: ExprKind::Var(w.clone()), span: w.span };
                if !self.expr(&e, condition, &mut tmp) {
                    return None;
                }
                out = tmp;
            }
            Value::Str(_, span) => {
                self.push(
                    err("E0602", *span, "expected a number or an expression in parentheses").with_label("not a string"),
                );
                return None;
            }
        }
        Some(Code(out))
    }

    fn expr(&mut self, e: &Expr, condition: bool, out: &mut Vec<CondOp>) -> bool {
        match &e.kind {
            ExprKind::Num(n) => {
                if n.unit.is_some() {
                    self.push(err("E0814", n.span, "numbers in creature expressions take no unit suffix"));
                    return false;
                }
                out.push(CondOp::Push(n.value));
                true
            }
            ExprKind::Var(v) => {
                if let Some(i) = VARIABLES.iter().position(|x| *x == v.text) {
                    if i as u8 == cond::COMPLEXITY && !condition {
                        self.push(
                            err("E0814", v.span, "a probability cannot read `complexity`")
                                .with_label("only conditions may")
                                .with_note("probabilities are checked at every value of their variables; C_s is not a whole number"),
                        );
                        return false;
                    }
                    out.push(CondOp::Var(i as u8));
                    return true;
                }
                if let Some(c) = self.ex.constant(&v.text) {
                    out.push(CondOp::Push(c));
                    return true;
                }
                let allowed: Vec<&str> =
                    VARIABLES.iter().copied().filter(|n| condition || *n != "complexity").collect();
                let mut d = err("E0814", v.span, format!("unknown name `{}` in a creature expression", v.text));
                d = match did_you_mean(&v.text, allowed.iter().copied()) {
                    Some(s) => d.with_label(format!("did you mean `{s}`?")).with_suggestion(
                        format!("replace with `{s}`"),
                        v.span,
                        s,
                    ),
                    None => d.with_note(format!("variables: {}; and `parts(TYPE)`", allowed.join(", "))),
                };
                self.push(d);
                false
            }
            ExprKind::Neg(x) => {
                let ok = self.expr(x, condition, out);
                out.push(CondOp::Neg);
                ok
            }
            ExprKind::Paren(x) => self.expr(x, condition, out),
            ExprKind::Not(x) => {
                let ok = self.expr(x, condition, out);
                let eq = BINOPS.iter().position(|s| *s == "==").unwrap_or(0);
                out.extend([CondOp::Push(0.0), CondOp::Bin(eq as u8)]);
                ok
            }
            ExprKind::Binary(op, a, b) => {
                let ok = self.expr(a, condition, out) & self.expr(b, condition, out);
                let i = BINOPS.iter().position(|s| *s == op.symbol()).unwrap_or(0);
                out.push(CondOp::Bin(i as u8));
                ok
            }
            ExprKind::Call(f, args) => {
                if f.text == "parts" {
                    return match args.as_slice() {
                        [Expr { kind: ExprKind::Var(k), .. }] => match self.kind_index(k) {
                            Some(k) => {
                                out.push(CondOp::Parts(k));
                                true
                            }
                            None => false,
                        },
                        _ => {
                            self.push(err("E0814", e.span, "`parts` takes one part type: `parts(wing)`"));
                            false
                        }
                    };
                }
                let Some(fi) = FUNCTIONS.iter().position(|(n, _)| *n == f.text) else {
                    let names = FUNCTIONS.iter().map(|(n, _)| *n).filter(|n| !n.starts_with("rand")).chain(["parts"]);
                    let mut d = err("E0814", f.span, format!("unknown function `{}`", f.text));
                    if let Some(s) = did_you_mean(&f.text, names) {
                        d = d.with_label(format!("did you mean `{s}`?"));
                    }
                    self.push(d);
                    return false;
                };
                let (fname, arity) = FUNCTIONS[fi];
                if fname.starts_with("rand") {
                    self.push(
                        err("E0814", f.span, format!("`{fname}` is not allowed in a rule's condition or probability"))
                            .with_label("the evolution draws the branch itself")
                            .with_note("write the chance of the function branch as the probability"),
                    );
                    return false;
                }
                if args.len() != arity {
                    self.push(err(
                        "E0814",
                        e.span,
                        format!("`{fname}` takes {arity} argument{}", if arity == 1 { "" } else { "s" }),
                    ));
                    return false;
                }
                let mut ok = true;
                for a in args {
                    ok &= self.expr(a, condition, out);
                }
                out.push(CondOp::Call(fi as u8));
                ok
            }
            ExprKind::Error => false,
        }
    }

    /// E0805: a probability that leaves [0, 1] at some generation (up to
    /// [`tb::MAX_GENERATIONS`]) and count (up to `maxparts`).
    fn probabilities(&mut self, rules: &[(usize, &Entry)]) {
        for (ri, e) in rules {
            let Some(r) = self.t.rules.get(*ri) else { continue };
            let Some(pe) = e.block.iter().flat_map(|(b, _)| b).find(|x| x.key.text == "probability") else { continue };
            let span = pe.values.first().map(|v| v.span()).unwrap_or(pe.span);
            if let Some((at, p)) =
                cond::probability_escape(&r.probability.0, tb::MAX_GENERATIONS, self.t.evolve.maxparts)
            {
                let value = if p.is_nan() { "not a number".to_string() } else { format!("{p:.4}") };
                let label = if at.is_empty() { format!("it is {value}") } else { format!("at {at} it is {value}") };
                self.push(
                    err("E0805", span, format!("the probability of rule `{}` can leave [0, 1]", r.id))
                        .with_label(label)
                        .with_note(format!(
                            "checked at every generation g = 0..{} and every count 1..{} (maxparts)",
                            tb::MAX_GENERATIONS,
                            self.t.evolve.maxparts
                        )),
                );
            }
        }
    }

    /// E0804: rules whose predecessor no evolved shape can ever present; W0802:
    /// rules whose conditions hold for no shape.
    fn never_match(&mut self, rules: &[(usize, &Entry)]) {
        let t = &self.t;
        let is_torso = |k: u32| t.kinds.get(k as usize).is_some_and(|k| k.torso);
        let parts_of = |k: u32, cat: Option<u32>| {
            t.parts.iter().filter(move |p| p.kind == k && cat.is_none_or(|c| p.category == c)).count()
        };
        // Kinds some shape can have: the regular creatures', then what rules add.
        let mut reach: Vec<u32> = Vec::new();
        for s in &t.shapes {
            if let Some(p) = t.parts.get(s.torso as usize) {
                reach.push(p.kind);
            }
            for a in &s.attach {
                if let Some(p) = t.parts.get(a.part as usize) {
                    reach.push(p.kind);
                }
            }
        }
        loop {
            let before = reach.len();
            for r in &t.rules {
                if !r.predecessor.iter().any(|k| reach.contains(k)) {
                    continue;
                }
                match r.kind {
                    RuleKind::Insert => {
                        for &k in &r.successor {
                            let slot_ok = t.parts.iter().any(|p| {
                                r.predecessor.contains(&p.kind)
                                    && reach.contains(&p.kind)
                                    && p.slots.iter().any(|s| s.accepts.contains(&k))
                            });
                            if slot_ok && parts_of(k, r.from) > 0 {
                                reach.push(k);
                            }
                        }
                    }
                    RuleKind::Replace => {
                        let live: Vec<u32> = r.predecessor.iter().copied().filter(|k| reach.contains(k)).collect();
                        for pk in live {
                            let succ = if r.successor.is_empty() { t.family(pk) } else { r.successor.clone() };
                            reach.extend(succ.into_iter().filter(|&k| parts_of(k, r.from) > 0));
                        }
                    }
                    _ => {}
                }
            }
            reach.sort_unstable();
            reach.dedup();
            if reach.len() == before {
                break;
            }
        }
        let mut found = Vec::new();
        for (ri, e) in rules {
            let Some(r) = t.rules.get(*ri) else { continue };
            let name = |k: u32| t.kinds.get(k as usize).map(|k| k.name.as_str()).unwrap_or("?");
            let preds: Vec<u32> = r.predecessor.clone();
            let live: Vec<u32> = preds.iter().copied().filter(|k| reach.contains(k)).collect();
            let why: Option<String> = if live.is_empty() {
                Some(format!(
                    "no creature can have a `{}`: no regular creature has one and no rule adds one",
                    preds.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `")
                ))
            } else if let Some(c) = r.category.filter(|&c| live.iter().all(|&k| parts_of(k, Some(c)) == 0)) {
                Some(format!(
                    "no `{}` part is in category `{}`",
                    live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                    t.categories.get(c as usize).map(|s| s.as_str()).unwrap_or("?")
                ))
            } else {
                match r.kind {
                    RuleKind::Increase if live.iter().all(|&k| is_torso(k)) => {
                        Some("increase rules copy parts attached to a torso, never a torso".to_string())
                    }
                    RuleKind::Increase if r.max < 1 + r.add => {
                        Some(format!("`max {}` leaves no room to add {} to a part", r.max, r.add))
                    }
                    RuleKind::Insert if !live.iter().any(|&k| is_torso(k)) => {
                        Some("insert rules add parts to a torso: the predecessor must be `torso`".to_string())
                    }
                    RuleKind::Insert => {
                        let fits = r.successor.iter().any(|&k| {
                            !is_torso(k)
                                && parts_of(k, r.from) > 0
                                && t.parts.iter().any(|p| {
                                    live.contains(&p.kind)
                                        && r.category.is_none_or(|c| p.category == c)
                                        && p.slots.iter().any(|s| s.accepts.contains(&k))
                                })
                        });
                        (!fits).then(|| {
                            format!(
                                "no slot of a `{}` part accepts `{}`{}",
                                live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                                r.successor.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `"),
                                if r.from.is_some() { " from that category" } else { "" }
                            )
                        })
                    }
                    RuleKind::Replace => {
                        let alternatives = live.iter().any(|&pk| {
                            let succ = if r.successor.is_empty() { t.family(pk) } else { r.successor.clone() };
                            let n: usize = succ.iter().map(|&k| parts_of(k, r.from)).sum();
                            // Replacing a part by itself is no replacement.
                            n > usize::from(succ.contains(&pk) && r.from.is_none_or(|c| parts_of(pk, Some(c)) > 0))
                                || n > 1
                        });
                        (!alternatives).then(|| {
                            format!(
                                "`{}` has no allelic alternative to be replaced with",
                                live.iter().map(|&k| name(k)).collect::<Vec<_>>().join("` or `")
                            )
                        })
                    }
                    RuleKind::Combine => {
                        let slot_for_torso = t.parts.iter().enumerate().any(|(i, p)| {
                            is_torso(p.kind)
                                && p.slots.iter().any(|s| s.partner.is_none() && s.accepts.iter().any(|&k| is_torso(k)))
                                && t.parts
                                    .iter()
                                    .enumerate()
                                    .any(|(j, q)| j != i && is_torso(q.kind) && q.joint.is_some())
                        });
                        let removable = t.parts.iter().any(|p| {
                            is_torso(p.kind) && p.slots.iter().any(|s| s.accepts.iter().any(|k| live.contains(k)))
                        });
                        if !slot_for_torso {
                            Some(
                                "no torso has a slot accepting a torso that another torso's joint could fill"
                                    .to_string(),
                            )
                        } else if !removable {
                            Some("no torso carries these parts to remove".to_string())
                        } else {
                            None
                        }
                    }
                    _ => None,
                }
            };
            if let Some(why) = why {
                let pe = e.block.iter().flat_map(|(b, _)| b).find(|x| x.key.text == "predecessor");
                let span = pe.map(|p| p.span).unwrap_or(e.key.span);
                found.push(err("E0804", span, format!("rule `{}` can never match", r.id)).with_label(why));
            } else if !r.conditions.is_empty() {
                // W0802: its predecessor can match, but its conditions hold together
                // for no shape (every generation and count the evolution allows;
                // kinds no creature can have count 0).
                let absent: Vec<u32> = (0..t.kinds.len() as u32).filter(|k| !reach.contains(k)).collect();
                let bounds = cond::Bounds { max_g: tb::MAX_GENERATIONS, max_parts: t.evolve.maxparts, absent };
                let codes: Vec<&[CondOp]> = r.conditions.iter().map(|c| c.0.as_slice()).collect();
                if cond::never_hold(&codes, &bounds, NEVER_HOLD_BUDGET) == Some(true) {
                    let ce: Vec<&Entry> =
                        e.block.iter().flat_map(|(b, _)| b).filter(|x| x.key.text == "condition").collect();
                    let span = ce.first().map(|c| c.span).unwrap_or(e.key.span);
                    let mut d = Diagnostic::warning("W0802", span, format!("rule `{}` can never match", r.id))
                        .with_label(if ce.len() > 1 {
                            "these conditions hold together for no shape"
                        } else {
                            "this condition holds for no shape"
                        })
                        .with_note(format!(
                            "checked at every generation g = 1..{} and every count a shape of at most {} meta-parts (maxparts) can have{}",
                            tb::MAX_GENERATIONS,
                            t.evolve.maxparts,
                            if bounds.absent.is_empty() { "" } else { "; parts(…) of a type no creature can have is 0" }
                        ));
                    for c in ce.iter().skip(1) {
                        d = d.with_secondary(c.span, "and this one");
                    }
                    found.push(d);
                }
            }
        }
        self.diags.extend(found);
    }
}

/// Which rule kinds a kind-specific key belongs to (for E0809 notes).
fn key_kinds(key: &str) -> String {
    match key {
        "add" | "arrange" | "max" => format!("`{key}` is for `increase` rules"),
        "successor" => "`successor` is for `insert` and `replace` rules".into(),
        "from" => "`from` is for `insert`, `replace` and `combine` rules".into(),
        "take" => "`take` is for `combine` rules".into(),
        _ => String::new(),
    }
}

/// Positions and triangles of an OBJ file.
pub type ObjMesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// Parses Wavefront OBJ text: `v x y z` and `f a b c …` (polygons fanned into
/// triangles; `a/b/c` forms and negative indices accepted; other lines ignored).
/// Errors name the line.
pub fn parse_obj(text: &str) -> Result<ObjMesh, String> {
    let mut pos: Vec<[f32; 3]> = Vec::new();
    let mut tris = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let v: Vec<f32> = it
                    .take(3)
                    .map(|s| s.parse::<f32>())
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("line {}: {e}", ln + 1))?;
                if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                    return Err(format!("line {}: a vertex needs three finite coordinates", ln + 1));
                }
                pos.push([v[0], v[1], v[2]]);
            }
            Some("f") => {
                let mut idx = Vec::new();
                for s in it {
                    let first = s.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| format!("line {}: bad vertex index `{s}`", ln + 1))?;
                    let n = pos.len() as i64;
                    let k = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || k < 0 || k >= n {
                        return Err(format!("line {}: vertex index {i} out of range (1..{n})", ln + 1));
                    }
                    idx.push(k as u32);
                }
                if idx.len() < 3 {
                    return Err(format!("line {}: a face needs three vertices", ln + 1));
                }
                for k in 1..idx.len() - 1 {
                    tris.push([idx[0], idx[k], idx[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if tris.is_empty() {
        return Err("no faces".into());
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
    let Some(table) = bundle.extensions.creatures.as_mut() else { return diags };
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
            Err(e) => diags.push(err("E0810", *span, format!("mesh `{path}` is not a usable OBJ file")).with_label(e)),
        }
    }
    diags
}

#[cfg(test)]
mod tests {
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
            &format!(
                "{slot} symmetric arm_r; }}\n slot arm_r {{ at -0.2 0 0.5; normal -1 0 0; size 0.1; accepts head; }}"
            ),
            "",
        ));
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(d[0].message.contains("is declared by `symmetric` already"), "{d:?}");
        let (_, d) = table_of(&grammar(
            &format!(
                "slot arm_r {{ at -0.2 0 0.5; normal -1 0 0; size 0.1; accepts head; }}\n {slot} symmetric arm_r; }}"
            ),
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
        assert!(parse_obj("v 0 0 0\nf 0 1 2\n").is_err());
        assert!(parse_obj("v nan 0 0\n").is_err());
    }
}
