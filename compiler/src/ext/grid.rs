//! `grid` sections: grid shape grammars of voxel buildings (SIGI): keys, checks and
//! lowering (see [`super`]).
//!
//! ```mdg
//! grid house {
//!   palette {
//!     stone "1:0" 125 125 125;       // NAME "BLOCK" [R G B]
//!     glass "20:0";
//!   }
//!   shape wall {
//!     size 3 2 1;                    // x y z
//!     plane z;                       // flat along z: its sides face −z and +z
//!     at 0 0 0;                      // where it stands in the example
//!     blocks                         // top layer first; rows along x; `_` = no block
//!       stone glass stone
//!       stone stone stone;
//!   }
//!   shape side { size 1 2 3; plane x; at 3 0 0; blocks stone stone stone  stone stone stone; }
//!   match wall side turn 1;          // side is wall turned a quarter (same blocks)
//!   rule wall side at 3 0 0;         // wall → wall side: side placed at (3, 0, 0) in wall's frame
//!   start wall;
//!   generate { steps 50; enclosure on; seal 1; seed 7; }
//! }
//! ```
//!
//! Codes E09xx; unknown keys, wrong value counts and repeated keys are E0601–E0603.
//! The language is documented in docs/grid.md.

use super::LowerCx;
use super::{at_most_once, expect_count, known_entries, CheckCx, Key, Sec};
use crate::ast::{Entry, Name, Section, Value};
use crate::diag::{did_you_mean, Diagnostic};
use crate::expand::Expanded;
use crate::span::Span;
use mdg_grid::{
    connected, sort_blocks, turned_blocks, GenerateSettings, GridGrammar, GridRule, GridShape, PaletteEntry, Placement,
    ShapeBlock, ShapeMatch, MAX_GRAMMAR_BLOCKS, MAX_SHAPE_EXTENT, MAX_STEPS,
};
use std::collections::HashMap;

const GRID_KEYS: &[Key] = &[
    Key {
        name: "palette",
        values: "{ NAME \"BLOCK\" [R G B]; … }",
        doc: "The block kinds: one entry per kind, a name used in shapes' `blocks`, the block as the voxel formats \
              name it (`\"minecraft:oak_planks\"`, a legacy `\"5:0\"`, a colour `\"#a0b0c0\"`), and an optional \
              display colour (0–255 each; default from the block's name).",
    },
    Key {
        name: "shape",
        values: "NAME { size …; blocks …; [plane …;] [at …;] [example …;] } | NAME { like A [turn T]; [at …;] … }",
        doc: "A shape: a connected set of blocks in its own box. `blocks` lists the box's cells, top layer first, \
              each layer row by row (z from 0), each row along x; `_` is an empty cell. A shape with `like A \
              [turn T]` instead of `size` and `blocks` is shape A turned T quarter turns, and matches A.",
    },
    Key {
        name: "match",
        values: "A B [turn T]",
        doc: "Shape B is shape A turned T quarter turns about the vertical axis (T in 0..3, default 0): the same \
              blocks in the same configuration. Rules of A apply to B and the other way round (shared rules); \
              matches are checked.",
    },
    Key {
        name: "rule",
        values: "FROM TO at X Y Z [turn T]",
        doc: "A rule FROM → FROM TO: wherever FROM (or a shape matching it) is placed, TO may be added at offset \
              (X, Y, Z) in FROM's frame, turned T quarter turns (default 0).",
    },
    Key { name: "start", values: "SHAPE", doc: "The shape a generated building starts from (placed at its `at`)." },
    Key {
        name: "generate",
        values: "{ steps N; enclosure [on|off]; seal R; seed N; }",
        doc: "Generation defaults for `mdg-run` (its --steps, --enclosure/--no-enclosure, --seal and --seed \
              override them).",
    },
    Key {
        name: "examples",
        values: "\"FILE\"…",
        doc: "The example buildings the grammar was induced from; a shape's `example N` refers to the N-th (from 0).",
    },
];

const SHAPE_KEYS: &[Key] = &[
    Key {
        name: "like",
        values: "A [turn T]",
        doc: "The shape is shape A turned T quarter turns about the vertical axis (T in 0..3, default 0): its size, \
              blocks and plane follow from A's (a `plane` may still be given), and it matches A as `match A B turn T` \
              would say. A may itself be a `like` (resolved through); a cycle is an error, and so is `like` with \
              `size` or `blocks`.",
    },
    Key { name: "size", values: "X Y Z", doc: "The shape's box in blocks (each 1 or more)." },
    Key {
        name: "blocks",
        values: "NAME|_ …",
        doc: "X·Y·Z palette names or `_` (no block): layers from the top (y = Y−1) down, each layer's rows from \
              z = 0, each row along x. Line breaks are free; write one row a line.",
    },
    Key {
        name: "plane",
        values: "x|y|z|none",
        doc: "The axis the shape is flat along (its size there is 1): its two sides, for the enclosure constraint. \
              Without it a flat shape uses its one thin axis, and other shapes are never removed by enclosure; \
              `none` says a shape is solid even where it is one block thick (3D shapes, `mdgc induce --spec 3d`).",
    },
    Key { name: "at", values: "X Y Z", doc: "Where the shape's box corner stands in its example building." },
    Key { name: "example", values: "N", doc: "Which of the `examples` the shape came from (default 0)." },
    Key {
        name: "open",
        values: "(no value: `open;`)",
        doc: "The shape is open in its example (a roof, a chimney, a porch: air on both of its sides there): the \
              enclosure constraint never removes it. `mdgc induce` marks these.",
    },
];

const GENERATE_KEYS: &[Key] = &[
    Key { name: "steps", values: "N", doc: "Rule applications (default 50)." },
    Key {
        name: "enclosure",
        values: "[on|off]",
        doc: "After the steps, repeatedly remove flat shapes with outside air on both sides (default on).",
    },
    Key {
        name: "seal",
        values: "R",
        doc: "Openings up to 2·R blocks wide (doors, windows) do not let the outside in when the enclosure \
              constraint floods the air around the building (default 1; 0 is the paper's plain flood fill; at most 8).",
    },
    Key { name: "seed", values: "N", doc: "The random seed when the command line gives none." },
];

/// The keys accepted at `path` (see [`super::keys`]). Palette entries are named by the
/// user, so `palette { }` has no fixed keys.
pub fn keys(path: &[&str]) -> &'static [Key] {
    match path {
        ["grid"] => GRID_KEYS,
        ["grid", "shape"] => SHAPE_KEYS,
        ["grid", "generate"] => GENERATE_KEYS,
        _ => &[],
    }
}

/// Checks the program's sections of this kind.
pub fn check(sections: &[Sec], cx: &CheckCx, diags: &mut Vec<Diagnostic>) {
    for s in sections.iter().skip(1) {
        diags.push(
            Diagnostic::error("E0911", s.section.kind.span, "a second `grid` section")
                .with_label("a program has at most one grid grammar")
                .with_secondary(sections[0].section.kind.span, "the first one"),
        );
    }
    if let Some(s) = sections.first() {
        let _ = parse(s.section, cx.ex, diags);
    }
}

/// Rule names the section refers to: none (grid grammars name shapes, not MDG rules).
pub fn rule_refs(_sec: &Section) -> Vec<&Name> {
    Vec::new()
}

/// Lowers the sections into the bundle's table (the first section; checking allows one).
pub fn lower(sections: &[Sec], cx: &LowerCx) -> Option<GridGrammar> {
    let mut diags = Vec::new();
    let g = parse(sections.first()?.section, cx.ex, &mut diags)?;
    if diags.iter().any(|d| d.is_error()) {
        return None;
    }
    Some(g)
}

/// A whole number from a value (constants and `@param`s allowed).
fn int(ex: &Expanded, v: &Value) -> Option<i64> {
    let x = super::number(ex, v)?;
    (x.is_finite() && x.fract() == 0.0 && x.abs() < 9.0e15).then_some(x as i64)
}

fn word(v: &Value) -> Option<&Name> {
    match v {
        Value::Word(w) => Some(w),
        _ => None,
    }
}

/// How a message names what a value belongs to: `` `turn` `` for keys, or a phrase.
fn what(key: &str) -> String {
    if key.contains(' ') {
        key.to_string()
    } else {
        format!("`{key}`")
    }
}

/// E0912 for a value that is not a whole number in `range`.
fn int_in(
    ex: &Expanded,
    key: &str,
    v: &Value,
    range: std::ops::RangeInclusive<i64>,
    diags: &mut Vec<Diagnostic>,
) -> Option<i64> {
    match int(ex, v) {
        Some(x) if range.contains(&x) => Some(x),
        got => {
            let label = match got {
                Some(x) => format!("{x} is out of range"),
                None => "not a whole number".into(),
            };
            diags.push(
                Diagnostic::error(
                    "E0912",
                    v.span(),
                    format!("{} takes whole numbers from {} to {}", what(key), range.start(), range.end()),
                )
                .with_label(label),
            );
            None
        }
    }
}

/// A shape as parsed, with the spans checks point at.
struct ParsedShape {
    name: Name,
    shape: GridShape,
    /// `like A [turn T]`: size, blocks and (without `plane`) plane come from A, resolved
    /// after every shape is read.
    like: Option<Like>,
}

/// A shape's `like A [turn T]`.
struct Like {
    target: Name,
    turn: u8,
    /// The `plane` value when the shape gives one (checked against the derived size).
    plane: Option<Span>,
}

/// Parses (and checks) one `grid` section. Returns the grammar when it is complete;
/// every problem is reported in `diags`.
fn parse(sec: &Section, ex: &Expanded, diags: &mut Vec<Diagnostic>) -> Option<GridGrammar> {
    let before = diags.iter().filter(|d| d.is_error()).count();
    let entries = known_entries(&sec.entries, GRID_KEYS, "a `grid` section", diags);
    let single: Vec<&Entry> = entries
        .iter()
        .copied()
        .filter(|e| matches!(e.key.text.as_str(), "palette" | "start" | "generate" | "examples"))
        .collect();
    at_most_once(&single, diags);
    let mut g =
        GridGrammar { name: sec.name.as_ref().map(|n| n.text.clone()).unwrap_or_default(), ..Default::default() };
    let mut examples_span: Option<Span> = None;
    // Block names first: shapes use them.
    let mut palette_ids: HashMap<String, u32> = HashMap::new();
    let mut palette_spans: Vec<Span> = Vec::new();
    for e in entries.iter().filter(|e| e.key.text == "examples") {
        for v in &e.values {
            match v {
                Value::Str(s, _) => g.examples.push(s.clone()),
                other => diags.push(
                    Diagnostic::error("E0602", other.span(), "`examples` takes file names in quotes")
                        .with_label("not a string"),
                ),
            }
        }
        examples_span = Some(e.key.span);
    }
    match entries.iter().find(|e| e.key.text == "palette") {
        Some(e) => palette(e, ex, &mut g, &mut palette_ids, &mut palette_spans, diags),
        None => diags.push(
            Diagnostic::error("E0908", sec.kind.span, "a `grid` section without a `palette`")
                .with_label("no block kinds are declared")
                .with_note("add `palette { NAME \"BLOCK\"; … }`"),
        ),
    }
    let mut shapes: Vec<ParsedShape> = Vec::new();
    let mut shape_ids: HashMap<String, u32> = HashMap::new();
    // Shapes whose definition has errors: known by name (no cascade of "unknown
    // shape"), but left out.
    let mut broken: std::collections::HashSet<String> = std::collections::HashSet::new();
    for e in entries.iter().filter(|e| e.key.text == "shape") {
        let p = match shape(e, ex, &palette_ids, g.palette.len(), diags) {
            Ok(p) => p,
            Err(name) => {
                if let Some(n) = name {
                    broken.insert(n.text);
                }
                continue;
            }
        };
        if let Some(&prev) = shape_ids.get(&p.name.text) {
            diags.push(
                Diagnostic::error("E0905", p.name.span, format!("shape `{}` is defined twice", p.name.text))
                    .with_secondary(shapes[prev as usize].name.span, "first defined here"),
            );
            continue;
        }
        shape_ids.insert(p.name.text.clone(), shapes.len() as u32);
        shapes.push(p);
    }
    let n_examples = g.examples.len().max(1) as u32;
    for p in &shapes {
        if p.shape.example >= n_examples {
            let at = examples_span.unwrap_or(p.name.span);
            diags.push(
                Diagnostic::error(
                    "E0912",
                    p.name.span,
                    format!("shape `{}` comes from example {}, but there {}", p.name.text, p.shape.example, {
                        if g.examples.is_empty() {
                            "is no `examples` list (only example 0)".to_string()
                        } else {
                            format!("are {} examples", g.examples.len())
                        }
                    }),
                )
                .with_secondary(at, "the examples"),
            );
        }
    }
    let lookup = |n: &Name, diags: &mut Vec<Diagnostic>| -> Option<u32> {
        if let Some(&i) = shape_ids.get(&n.text) {
            return Some(i);
        }
        if broken.contains(&n.text) {
            return None;
        }
        let mut d = Diagnostic::error("E0902", n.span, format!("unknown shape `{}`", n.text));
        match did_you_mean(&n.text, shape_ids.keys().map(|s| s.as_str())) {
            Some(s) => d = d.with_label(format!("did you mean `{s}`?")),
            None => d = d.with_label("no shape has this name"),
        }
        diags.push(d);
        None
    };
    let turns = g.kind_turns();
    // `like` shapes: size, blocks and plane from their targets (through chains of
    // `like`), each with the match it declares. 0 unresolved, 1 on the current chain,
    // 2 done, 3 failed (reported, or depending on a broken shape).
    let mut state: Vec<u8> = shapes.iter().map(|p| if p.like.is_some() { 0 } else { 2 }).collect();
    let mut like_matches: Vec<ShapeMatch> = Vec::new();
    for i in 0..shapes.len() {
        let mut chain: Vec<usize> = Vec::new();
        let mut cur = i;
        let mut failed = false;
        while state[cur] == 0 {
            state[cur] = 1;
            chain.push(cur);
            let target = &shapes[cur].like.as_ref().expect("state 0 is a like").target;
            match lookup(target, diags) {
                Some(t) if state[t as usize] == 1 => {
                    // A cycle: from t round to cur.
                    let from = chain.iter().position(|&c| c == t as usize).unwrap_or(0);
                    let cycle = &chain[from..];
                    let names: Vec<&str> = cycle.iter().map(|&c| shapes[c].name.text.as_str()).collect();
                    let first = &shapes[cycle[0]];
                    let mut d = Diagnostic::error(
                        "E0914",
                        first.like.as_ref().map(|l| l.target.span).unwrap_or(first.name.span),
                        format!("shape `{}` is a `like` of itself", first.name.text),
                    )
                    .with_label(format!("{} → {}", names.join(" → "), names[0]))
                    .with_note("one shape of a class is written in full; the others refer to it");
                    for &c in &cycle[1..] {
                        if let Some(l) = &shapes[c].like {
                            d = d.with_secondary(
                                l.target.span,
                                format!("`{}` is like `{}`", shapes[c].name.text, l.target.text),
                            );
                        }
                    }
                    diags.push(d);
                    failed = true;
                    break;
                }
                Some(t) => cur = t as usize,
                None => {
                    failed = true;
                    break;
                }
            }
        }
        failed |= state[cur] == 3;
        for &c in chain.iter().rev() {
            if failed {
                state[c] = 3;
                continue;
            }
            let l = shapes[c].like.as_ref().expect("a like");
            let t = shape_ids[&l.target.text] as usize;
            let (blocks, size) = turned_blocks(&shapes[t].shape, l.turn, &turns);
            let plane = match l.plane {
                Some(span) => {
                    let plane = shapes[c].shape.plane;
                    if let Some(axis) = plane.filter(|&a| size[a as usize] != 1) {
                        let axis_name = mdg_grid::AXIS_NAMES[axis as usize];
                        diags.push(
                            Diagnostic::error(
                                "E0910",
                                span,
                                format!("shape `{}` is not flat along {axis_name}", shapes[c].name.text),
                            )
                            .with_label(format!(
                                "`{}` turned {} is {}×{}×{}",
                                l.target.text, l.turn, size[0], size[1], size[2]
                            )),
                        );
                        failed = true;
                        state[c] = 3;
                        continue;
                    }
                    plane
                }
                // A's flat axis, turned: odd turns swap x and z.
                None => shapes[t].shape.plane.map(|a| if l.turn % 2 == 1 && a != 1 { 2 - a } else { a }),
            };
            like_matches.push(ShapeMatch { a: t as u32, b: c as u32, turn: l.turn });
            let s = &mut shapes[c].shape;
            (s.blocks, s.size, s.plane) = (blocks, size, plane);
            state[c] = 2;
        }
    }
    // In shape order (a chain resolves from its end).
    like_matches.sort_by_key(|m| m.b);
    for e in entries.iter().filter(|e| e.key.text == "match") {
        let form = "`match A B [turn T]`";
        let (a, b, turn) = match e.values.as_slice() {
            [a, b] => (a, b, None),
            [a, b, t, n] if word(t).is_some_and(|w| w.text == "turn") => (a, b, Some(n)),
            _ => {
                diags.push(malformed(e, form));
                continue;
            }
        };
        let (Some(a), Some(b)) = (word(a), word(b)) else {
            diags.push(malformed(e, form));
            continue;
        };
        let turn = match turn {
            Some(v) => match int_in(ex, "turn", v, 0..=3, diags) {
                Some(t) => t as u8,
                None => continue,
            },
            None => 0,
        };
        let (Some(ia), Some(ib)) = (lookup(a, diags), lookup(b, diags)) else { continue };
        if state[ia as usize] != 2 || state[ib as usize] != 2 {
            continue;
        }
        let (sa, sb) = (&shapes[ia as usize].shape, &shapes[ib as usize].shape);
        let (blocks, size) = turned_blocks(sa, turn, &turns);
        if size != sb.size || blocks != sb.blocks {
            let why = if size != sb.size {
                format!(
                    "turned, `{}` is {}×{}×{} but `{}` is {}×{}×{}",
                    a.text, size[0], size[1], size[2], b.text, sb.size[0], sb.size[1], sb.size[2]
                )
            } else {
                format!("turned, `{}` has different blocks", a.text)
            };
            let mut d = Diagnostic::error(
                "E0906",
                b.span,
                format!(
                    "`{}` is not `{}` turned {turn} quarter turn{}",
                    b.text,
                    a.text,
                    if turn == 1 { "" } else { "s" }
                ),
            );
            // Another turn may be the right one.
            let right = (0..4u8).find(|&t| {
                let (bl, sz) = turned_blocks(sa, t, &turns);
                sz == sb.size && bl == sb.blocks
            });
            match (right, e.values.get(3)) {
                (Some(t), Some(v)) => {
                    d = d.with_label(format!("`{}` is `{}` turned {t}", b.text, a.text)).with_suggestion(
                        format!("replace with `{t}`"),
                        v.span(),
                        t.to_string(),
                    )
                }
                (Some(t), None) => d = d.with_label(format!("`{}` is `{}` turned {t}: add `turn {t}`", b.text, a.text)),
                (None, _) => d = d.with_label(why),
            }
            diags.push(d.with_note("matching shapes have the same blocks in the same configuration"));
            continue;
        }
        g.matches.push(ShapeMatch { a: ia, b: ib, turn });
    }
    for e in entries.iter().filter(|e| e.key.text == "rule") {
        let form = "`rule FROM TO at X Y Z [turn T]`";
        let vals = e.values.as_slice();
        let ok_shape = vals.len() == 6 || (vals.len() == 8 && word(&vals[6]).is_some_and(|w| w.text == "turn"));
        if !ok_shape || word(&vals[2]).is_none_or(|w| w.text != "at") {
            diags.push(malformed(e, form));
            continue;
        }
        let (Some(from), Some(to)) = (word(&vals[0]), word(&vals[1])) else {
            diags.push(malformed(e, form));
            continue;
        };
        let limit = mdg_grid::MAX_RULE_OFFSET as i64;
        let offset: Vec<Option<i64>> = vals[3..6].iter().map(|v| int_in(ex, "at", v, -limit..=limit, diags)).collect();
        let turn = match vals.get(7) {
            Some(v) => int_in(ex, "turn", v, 0..=3, diags),
            None => Some(0),
        };
        let (Some(fi), Some(ti)) = (lookup(from, diags), lookup(to, diags)) else { continue };
        let (Some(x), Some(y), Some(z), Some(t)) = (offset[0], offset[1], offset[2], turn) else { continue };
        g.rules.push(GridRule {
            from: fi,
            to: ti,
            place: Placement { turn: t as u8, offset: [x as i32, y as i32, z as i32] },
        });
    }
    match entries.iter().find(|e| e.key.text == "start") {
        Some(e) => {
            if expect_count(e, 1, 1, "one shape name", diags) {
                match word(&e.values[0]) {
                    Some(n) => {
                        if let Some(i) = lookup(n, diags) {
                            g.start = i;
                        }
                    }
                    None => diags.push(malformed(e, "`start SHAPE`")),
                }
            }
        }
        None => diags.push(
            Diagnostic::error("E0908", sec.kind.span, "a `grid` section without a `start` shape")
                .with_label("generation needs a shape to start from")
                .with_note("add `start SHAPE;`"),
        ),
    }
    if shapes.is_empty() && !entries.iter().any(|e| e.key.text == "shape") {
        diags.push(
            Diagnostic::error("E0908", sec.kind.span, "a `grid` section without shapes")
                .with_note("add `shape NAME { size X Y Z; blocks …; }`"),
        );
    }
    if let Some(e) = entries.iter().find(|e| e.key.text == "generate") {
        g.generate = generate(e, ex, diags);
    }
    let total: usize = shapes.iter().map(|p| p.shape.blocks.len()).sum();
    if total > MAX_GRAMMAR_BLOCKS {
        diags.push(Diagnostic::error(
            "E0912",
            sec.kind.span,
            format!("the shapes hold {total} blocks (at most {MAX_GRAMMAR_BLOCKS})"),
        ));
    }
    // With `like`, matches are ordered by their first shape (stable: `like`s in shape
    // order, then `match` lines in source order), as `mdgc induce` lists them.
    if !like_matches.is_empty() {
        like_matches.append(&mut g.matches);
        like_matches.sort_by_key(|m| m.a);
        g.matches = like_matches;
    }
    g.shapes = shapes.into_iter().map(|p| p.shape).collect();
    if diags.iter().filter(|d| d.is_error()).count() > before {
        return None;
    }
    g.validate().ok()?;
    Some(g)
}

fn malformed(e: &Entry, form: &str) -> Diagnostic {
    Diagnostic::error("E0907", e.span, format!("malformed `{}` entry", e.key.text))
        .with_label(format!("expected {form}"))
}

/// The `palette { NAME "BLOCK" [R G B]; … }` block.
fn palette(
    e: &Entry,
    ex: &Expanded,
    g: &mut GridGrammar,
    ids: &mut HashMap<String, u32>,
    spans: &mut Vec<Span>,
    diags: &mut Vec<Diagnostic>,
) {
    if let Some(v) = e.values.first() {
        diags.push(
            Diagnostic::error("E0602", v.span(), "`palette` takes no values").with_label("put the entries in `{ }`"),
        );
    }
    let Some((inner, _)) = &e.block else {
        diags.push(
            Diagnostic::error("E0904", e.span, "`palette` without entries")
                .with_label("expected `palette { NAME \"BLOCK\" [R G B]; … }`"),
        );
        return;
    };
    for p in inner {
        let name = &p.key;
        if name.text == "_" || name.text.contains('.') {
            diags.push(
                Diagnostic::error("E0904", name.span, format!("`{}` cannot name a block kind", name.text))
                    .with_label(if name.text == "_" { "`_` means \"no block\" in shapes" } else { "use a plain name" }),
            );
            continue;
        }
        if let Some(&prev) = ids.get(&name.text) {
            diags.push(
                Diagnostic::error("E0905", name.span, format!("palette entry `{}` is defined twice", name.text))
                    .with_secondary(spans[prev as usize], "first defined here"),
            );
            continue;
        }
        if p.block.is_some() {
            diags.push(
                Diagnostic::error("E0904", p.span, format!("palette entry `{}` has a block", name.text))
                    .with_label("expected `NAME \"BLOCK\" [R G B];`"),
            );
            continue;
        }
        let block = match p.values.first() {
            Some(Value::Str(s, span)) => {
                if s.is_empty() || s.chars().any(|c| c.is_whitespace()) {
                    diags.push(
                        Diagnostic::error("E0904", *span, "a block id cannot be empty or contain spaces")
                            .with_label("the voxel formats store ids without spaces"),
                    );
                    continue;
                }
                s.clone()
            }
            _ => {
                diags.push(
                    Diagnostic::error("E0904", p.span, format!("palette entry `{}` needs a block id", name.text))
                        .with_label("expected `NAME \"BLOCK\" [R G B];`, e.g. `stone \"minecraft:stone\";`"),
                );
                continue;
            }
        };
        let color = match &p.values[1..] {
            [] => mdg_grid::blocks::color_of(&block),
            [r, gg, b] => {
                let c: Vec<Option<i64>> =
                    [r, gg, b].iter().map(|v| int_in(ex, "a colour component", v, 0..=255, diags)).collect();
                match (c[0], c[1], c[2]) {
                    (Some(r), Some(gg), Some(b)) => [r as u8, gg as u8, b as u8],
                    _ => continue,
                }
            }
            more => {
                diags.push(
                    Diagnostic::error(
                        "E0904",
                        more[0].span(),
                        format!("palette entry `{}` has a malformed colour", name.text),
                    )
                    .with_label(format!(
                        "{} value{} after the block id; expected R G B",
                        more.len(),
                        if more.len() == 1 { "" } else { "s" }
                    )),
                );
                continue;
            }
        };
        ids.insert(name.text.clone(), g.palette.len() as u32);
        spans.push(name.span);
        g.palette.push(PaletteEntry { name: name.text.clone(), block, color });
    }
}

/// One `shape NAME { … }` entry.
fn shape(
    e: &Entry,
    ex: &Expanded,
    palette: &HashMap<String, u32>,
    n_kinds: usize,
    diags: &mut Vec<Diagnostic>,
) -> Result<ParsedShape, Option<Name>> {
    if !expect_count(e, 1, 1, "a shape name and a block `{ … }`", diags) {
        return Err(e.values.first().and_then(word).cloned());
    }
    let Some(name) = word(&e.values[0]).cloned() else {
        diags.push(malformed(e, "`shape NAME { … }`"));
        return Err(None);
    };
    let fail = Err(Some(name.clone()));
    let Some((inner, _)) = &e.block else {
        diags.push(
            Diagnostic::error("E0908", name.span, format!("shape `{}` has no body", name.text))
                .with_label("expected `shape NAME { size X Y Z; blocks …; }`"),
        );
        return fail;
    };
    let before = diags.len();
    let entries = known_entries(inner, SHAPE_KEYS, "a `shape`", diags);
    // After an unknown key (a typo of `size`, say), a missing key is no news.
    let report_missing = diags.len() == before;
    at_most_once(&entries, diags);
    let find = |k: &str| entries.iter().copied().find(|e| e.key.text == k);
    let mut ok = true;
    let like_entry = find("like");
    let like = match like_entry {
        Some(l) => {
            let (target, turn) = match l.values.as_slice() {
                [a] => (word(a), None),
                [a, t, n] if word(t).is_some_and(|w| w.text == "turn") => (word(a), Some(n)),
                _ => (None, None),
            };
            let Some(target) = target.cloned() else {
                diags.push(malformed(l, "`like A [turn T]`"));
                return fail;
            };
            let turn = match turn {
                Some(v) => match int_in(ex, "turn", v, 0..=3, diags) {
                    Some(t) => t as u8,
                    None => return fail,
                },
                None => 0,
            };
            let mut own = false;
            for k in ["size", "blocks"] {
                if let Some(own_entry) = find(k) {
                    diags.push(
                        Diagnostic::error(
                            "E0913",
                            own_entry.key.span,
                            format!("shape `{}` has both `like` and `{k}`", name.text),
                        )
                        .with_label(format!("its {k} follows from `{}`", target.text))
                        .with_secondary(l.key.span, "the shape is a reference here")
                        .with_note("remove `like` to write the shape in full, or remove its `size` and `blocks`"),
                    );
                    own = true;
                }
            }
            if own {
                return fail;
            }
            Some(Like { target, turn, plane: None })
        }
        None => None,
    };
    let size = match find("size") {
        _ if like.is_some() => Some([0; 3]),
        Some(s) if expect_count(s, 3, 3, "X Y Z", diags) => {
            let v: Vec<Option<i64>> =
                s.values.iter().map(|v| int_in(ex, "size", v, 1..=MAX_SHAPE_EXTENT as i64, diags)).collect();
            match (v[0], v[1], v[2]) {
                (Some(x), Some(y), Some(z)) => Some([x as u32, y as u32, z as u32]),
                _ => None,
            }
        }
        Some(_) => None,
        None => {
            if report_missing {
                diags.push(
                    Diagnostic::error("E0908", name.span, format!("shape `{}` has no `size`", name.text))
                        .with_label("expected `size X Y Z;`"),
                );
            }
            None
        }
    };
    let at = match find("at") {
        Some(a) if expect_count(a, 3, 3, "X Y Z", diags) => {
            let v: Vec<Option<i64>> = a
                .values
                .iter()
                .map(|v| {
                    int_in(ex, "at", v, -(mdg_grid::voxel::MAX_COORD as i64)..=mdg_grid::voxel::MAX_COORD as i64, diags)
                })
                .collect();
            match (v[0], v[1], v[2]) {
                (Some(x), Some(y), Some(z)) => Some([x as i32, y as i32, z as i32]),
                _ => {
                    ok = false;
                    None
                }
            }
        }
        Some(_) => {
            ok = false;
            None
        }
        None => None,
    };
    let example = match find("example") {
        Some(x) if expect_count(x, 1, 1, "an example index", diags) => {
            int_in(ex, "example", &x.values[0], 0..=u32::MAX as i64, diags).map(|v| v as u32)
        }
        Some(_) => None,
        None => Some(0),
    };
    let open = match find("open") {
        Some(o) if expect_count(o, 0, 0, "no value (`open;`)", diags) => true,
        Some(_) => {
            ok = false;
            false
        }
        None => false,
    };
    let plane_entry = find("plane");
    let plane = match plane_entry {
        Some(p) if expect_count(p, 1, 1, "an axis: x, y, z or none", diags) => {
            match word(&p.values[0]).map(|w| w.text.as_str()) {
                Some("x") => Some(Some(0u8)),
                Some("y") => Some(Some(1)),
                Some("z") => Some(Some(2)),
                Some("none") => Some(None),
                _ => {
                    diags.push(
                        Diagnostic::error("E0910", p.values[0].span(), "`plane` takes an axis: x, y, z or none")
                            .with_label("not an axis"),
                    );
                    None
                }
            }
        }
        Some(_) => None,
        None => Some(None),
    };
    if let Some(mut l) = like {
        let (Some(example), Some(plane)) = (example, plane) else { return fail };
        if !ok {
            return fail;
        }
        l.plane = plane_entry.map(|p| p.values[0].span());
        let shape = GridShape { name: name.text.clone(), size: [0; 3], blocks: Vec::new(), plane, at, example, open };
        return Ok(ParsedShape { name, shape, like: Some(l) });
    }
    let Some(blocks_entry) = find("blocks") else {
        if report_missing {
            diags.push(
                Diagnostic::error("E0908", name.span, format!("shape `{}` has no `blocks`", name.text))
                    .with_label("expected `blocks NAME|_ …;`"),
            );
        }
        return fail;
    };
    let (Some(size), Some(example), Some(plane)) = (size, example, plane) else { return fail };
    if !ok {
        return fail;
    }
    let cells = size.iter().map(|&s| s as u64).product::<u64>();
    if cells > MAX_GRAMMAR_BLOCKS as u64 {
        diags.push(Diagnostic::error(
            "E0912",
            name.span,
            format!("shape `{}` is {} cells (at most {MAX_GRAMMAR_BLOCKS})", name.text, cells),
        ));
        return fail;
    }
    if blocks_entry.values.len() as u64 != cells {
        let span = blocks_entry.values.get(cells as usize).map(|v| v.span()).unwrap_or(blocks_entry.key.span);
        diags.push(
            Diagnostic::error(
                "E0903",
                span,
                format!(
                    "shape `{}` is {}×{}×{} = {cells} cells, but `blocks` lists {}",
                    name.text,
                    size[0],
                    size[1],
                    size[2],
                    blocks_entry.values.len()
                ),
            )
            .with_label(if (blocks_entry.values.len() as u64) > cells { "one too many from here" } else { "too few" })
            .with_note("list every cell of the box, `_` for an empty one"),
        );
        return fail;
    }
    // Cells: layers from the top, rows from z = 0, along x.
    let mut blocks = Vec::new();
    let (sx, sy, sz) = (size[0] as usize, size[1] as usize, size[2] as usize);
    let mut bad = false;
    for (i, v) in blocks_entry.values.iter().enumerate() {
        let x = i % sx;
        let z = (i / sx) % sz;
        let y = sy - 1 - i / (sx * sz);
        let Some(w) = word(v) else {
            diags.push(
                Diagnostic::error("E0901", v.span(), "`blocks` takes palette names or `_`").with_label("not a name"),
            );
            bad = true;
            continue;
        };
        if w.text == "_" {
            continue;
        }
        match palette.get(&w.text) {
            Some(&k) if (k as usize) < n_kinds => {
                blocks.push(ShapeBlock { pos: [x as i32, y as i32, z as i32], kind: k });
            }
            _ => {
                let mut d = Diagnostic::error("E0901", w.span, format!("unknown block `{}`", w.text));
                match did_you_mean(&w.text, palette.keys().map(|s| s.as_str())) {
                    Some(s) => d = d.with_label(format!("did you mean `{s}`?")),
                    None => d = d.with_label("not in the palette"),
                }
                diags.push(d);
                bad = true;
            }
        }
    }
    if bad {
        return fail;
    }
    sort_blocks(&mut blocks);
    if blocks.is_empty() {
        diags.push(
            Diagnostic::error("E0909", name.span, format!("shape `{}` has no blocks", name.text))
                .with_label("every cell is `_`"),
        );
        return fail;
    }
    if !connected(&blocks) {
        diags.push(
            Diagnostic::error("E0909", name.span, format!("the blocks of shape `{}` are not connected", name.text))
                .with_label("a shape is one piece: blocks joined face to face")
                .with_note("split it into two shapes joined by a rule"),
        );
        return fail;
    }
    if let (Some(axis), Some(p)) = (plane, plane_entry) {
        if size[axis as usize] != 1 {
            diags.push(
                Diagnostic::error(
                    "E0910",
                    p.values[0].span(),
                    format!("shape `{}` is not flat along {}", name.text, mdg_grid::AXIS_NAMES[axis as usize]),
                )
                .with_label(format!(
                    "its size along {} is {}",
                    mdg_grid::AXIS_NAMES[axis as usize],
                    size[axis as usize]
                )),
            );
            return fail;
        }
    }
    // Without `plane`, a shape with exactly one thin axis is flat along it (`plane none`
    // keeps it solid).
    let explicit_none = plane_entry.is_some();
    let plane = plane.or_else(|| {
        if explicit_none {
            return None;
        }
        let thin: Vec<u8> = (0..3u8).filter(|&k| size[k as usize] == 1).collect();
        (thin.len() == 1).then(|| thin[0])
    });
    Ok(ParsedShape {
        name: name.clone(),
        shape: GridShape { name: name.text, size, blocks, plane, at, example, open },
        like: None,
    })
}

/// The `generate { … }` block.
fn generate(e: &Entry, ex: &Expanded, diags: &mut Vec<Diagnostic>) -> GenerateSettings {
    let mut s = GenerateSettings::default();
    if let Some(v) = e.values.first() {
        diags.push(
            Diagnostic::error("E0602", v.span(), "`generate` takes no values").with_label("put the entries in `{ }`"),
        );
    }
    let Some((inner, _)) = &e.block else {
        diags.push(
            Diagnostic::error("E0602", e.span, "`generate` takes a block")
                .with_label("expected `generate { steps N; enclosure on; seed N; }`"),
        );
        return s;
    };
    let entries = known_entries(inner, GENERATE_KEYS, "`generate`", diags);
    at_most_once(&entries, diags);
    for g in entries {
        match g.key.text.as_str() {
            "steps" if expect_count(g, 1, 1, "a number of rule applications", diags) => {
                if let Some(n) = int_in(ex, "steps", &g.values[0], 0..=MAX_STEPS as i64, diags) {
                    s.steps = n as u32;
                }
            }
            "seal" if expect_count(g, 1, 1, "a radius", diags) => {
                let max = mdg_grid::generate::MAX_SEAL as i64;
                if let Some(n) = int_in(ex, "seal", &g.values[0], 0..=max, diags) {
                    s.seal = n as u32;
                }
            }
            "seed" if expect_count(g, 1, 1, "a seed", diags) => {
                if let Some(n) = int_in(ex, "seed", &g.values[0], 0..=(1i64 << 53), diags) {
                    s.seed = Some(n as u64);
                }
            }
            "enclosure" if expect_count(g, 0, 1, "nothing, `on` or `off`", diags) => {
                match g.values.first().map(|v| word(v).map(|w| w.text.as_str())) {
                    None | Some(Some("on")) => s.enclosure = true,
                    Some(Some("off")) => s.enclosure = false,
                    Some(_) => diags.push(
                        Diagnostic::error("E0912", g.values[0].span(), "`enclosure` takes `on` or `off`")
                            .with_label("not `on` or `off`"),
                    ),
                }
            }
            _ => {}
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::CheckOptions;
    use crate::driver::analyze_text;
    use crate::source::MemLoader;
    use mdg_vm::bundle::Section as _;

    /// The grid table a program compiles to (no errors allowed).
    fn grammar(src: &str) -> GridGrammar {
        let a = analyze_text(
            &MemLoader::default(),
            std::path::Path::new("t.mdg"),
            src,
            &crate::expand::Options::default(),
            CheckOptions { require_start: true },
        );
        let rendered = crate::diag::render_plain(&a.diagnostics, &a.sources);
        assert!(!a.has_errors(), "{rendered}");
        let b = crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).expect("lowers");
        GridGrammar::from_bundle(&b).expect("a valid section").expect("a grid table")
    }

    #[test]
    fn rows_fill_the_box_top_layer_first() {
        let g = grammar(
            "startshape s\nrule s {}\ngrid {\n  palette { a \"a\"; b \"b\" 1 2 3; }\n  \
             shape box { size 2 2 2; blocks\n    a b\n    _ _\n    b _\n    a a; }\n  start box;\n}\n",
        );
        let s = &g.shapes[0];
        // Top layer (y = 1): row z = 0 is `a b`, row z = 1 empty; bottom layer: `b _`, `a a`.
        let cells: Vec<([i32; 3], &str)> =
            s.blocks.iter().map(|b| (b.pos, g.palette[b.kind as usize].name.as_str())).collect();
        assert_eq!(
            cells,
            vec![([0, 0, 0], "b"), ([0, 0, 1], "a"), ([1, 0, 1], "a"), ([0, 1, 0], "a"), ([1, 1, 0], "b")]
        );
        assert_eq!(g.palette[1].color, [1, 2, 3]);
        assert_eq!(s.plane, None, "no thin axis");
        assert_eq!(g.generate, GenerateSettings::default());
    }

    #[test]
    fn rules_matches_and_generation_settings_lower() {
        let g = grammar(
            "startshape s\nrule s {}\ngrid g {\n  palette { a \"a\"; }\n  \
             shape p { size 2 1 1; at 4 5 6; blocks a a; }\n  shape q { size 1 1 2; blocks a a; }\n  \
             match p q turn 3;\n  rule p q at -1 0 2 turn 1;\n  start q;\n  \
             generate { steps 7; enclosure off; seal 2; seed 9; }\n}\n",
        );
        assert_eq!(g.name, "g");
        assert_eq!(g.shapes[0].plane, None, "a line has two thin axes");
        assert_eq!(g.shapes[0].at, Some([4, 5, 6]));
        assert_eq!(g.matches, vec![ShapeMatch { a: 0, b: 1, turn: 3 }]);
        assert_eq!(g.rules, vec![GridRule { from: 0, to: 1, place: Placement { turn: 1, offset: [-1, 0, 2] } }]);
        assert_eq!(g.start, 1);
        assert_eq!(g.generate, GenerateSettings { steps: 7, enclosure: false, seal: 2, seed: Some(9) });
    }

    #[test]
    fn a_like_shape_is_its_target_turned_and_matches_it() {
        // Two interleaved classes, one member a chain (r like q like p), and a `match`
        // line among the `like`s: the same table as the grammar written out in full.
        let head = "startshape s\nrule s {}\ngrid g {\n  palette { a \"minecraft:stone\"; b \"minecraft:glass\"; }\n";
        let tail = "  rule p q at 2 0 0;\n  start p;\n}\n";
        let full = format!(
            "{head}  shape p {{ size 2 2 1; at 0 0 0; blocks a a b a; }}\n  shape w {{ size 1 1 1; blocks a; }}\n  \
             shape q {{ size 1 2 2; at 5 0 0; blocks a a a b; }}\n  shape v {{ size 1 1 1; blocks a; }}\n  \
             shape r {{ size 2 2 1; at 9 0 0; blocks a a a b; }}\n  \
             match p q turn 1;\n  match p r turn 2;\n  match w v;\n  match q r turn 1;\n{tail}"
        );
        let like = format!(
            "{head}  shape p {{ size 2 2 1; at 0 0 0; blocks a a b a; }}\n  shape w {{ size 1 1 1; blocks a; }}\n  \
             shape q {{ like p turn 1; at 5 0 0; }}\n  shape v {{ like w; }}\n  \
             match p r turn 2;\n  shape r {{ at 9 0 0; like q turn 1; }}\n{tail}"
        );
        let (gf, gl) = (grammar(&full), grammar(&like));
        assert_eq!(gl.shapes[2].plane, Some(0), "p's plane z turned once is x");
        // The `like`s' matches (p q 1), (w v 0), (q r 1) and the `match` line, stably by first shape.
        assert_eq!(
            gl.matches,
            vec![
                ShapeMatch { a: 0, b: 2, turn: 1 },
                ShapeMatch { a: 0, b: 4, turn: 2 },
                ShapeMatch { a: 1, b: 3, turn: 0 },
                ShapeMatch { a: 2, b: 4, turn: 1 },
            ]
        );
        assert_eq!(gl, gf);
    }

    #[test]
    fn every_key_has_documentation() {
        for path in [&["grid"][..], &["grid", "shape"], &["grid", "generate"]] {
            let keys = keys(path);
            assert!(!keys.is_empty());
            assert!(keys.iter().all(|k| !k.doc.is_empty() && !k.values.is_empty()), "{path:?}");
        }
        assert!(keys(&["grid", "palette"]).is_empty(), "palette entries are named by the user");
    }
}
