//! `mdgc import`'s translators: a Context Free program (`.cfdg`, CFDG 2 or 3
//! syntax) or a Structure Synth program (`.es`) written as an MDG grammar that
//! today's compiler accepts, with a [`Report`] of every construct that had to be
//! approximated or left out (with its source line).
//!
//! Context Free ends most recursions at its minimum size, 0.3 pixels of the final
//! picture; MDG's `minsize` is in model units. [`import_cf`] writes `minsize` from
//! the size of a pixel: the canvas's (`size`/`CF::Size`) if the program fixes one,
//! else [`Options::pixel`], which [`calibrate`] finds from evaluations of the grammar
//! (the caller's: this crate does not evaluate) by fitting its bounding box into
//! the picture, as Context Free fits its own.
//!
//! The library reads no files itself: includes come through a callback.

mod cfemit;
mod cflex;
mod cfparse;
mod es;
mod names;
pub mod report;

pub use report::{Action, Note, Report};
use std::fmt::Write;
use std::path::Path;

/// Which language a file is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    ContextFree,
    StructureSynth,
}

impl Dialect {
    /// By the file's extension: `.cfdg` or `.es` (any case).
    pub fn of_path(p: &Path) -> Option<Dialect> {
        match p.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "cfdg" => Some(Dialect::ContextFree),
            "es" => Some(Dialect::StructureSynth),
            _ => None,
        }
    }
}

/// Options of an import.
#[derive(Clone, Debug)]
pub struct Options {
    /// The side of the picture Context Free would draw, in pixels (`cfdg -s`).
    pub pixels: f64,
    /// The size of one of those pixels in model units; `None`: not known (then
    /// `minsize` is 0.001 of a unit, and [`calibrate`] should be run).
    pub pixel: Option<f64>,
}

impl Default for Options {
    fn default() -> Self {
        Options { pixels: 500.0, pixel: None }
    }
}

/// An imported program.
#[derive(Clone, Debug)]
pub struct Imported {
    /// The MDG grammar.
    pub mdg: String,
    pub report: Report,
    /// Whether `minsize` came from a pixel size that was not known ([`calibrate`]
    /// replaces it).
    pub needs_pixel: bool,
    /// Context Free's minimum size in pixels (0.3, or `CF::MinimumSize`).
    pub min_size_px: f64,
}

/// Reads an included file by the name the program gives (`None`: not found).
pub type Reader<'a> = &'a dyn Fn(&str) -> Option<String>;

/// Imports a program of either dialect.
pub fn import(file: &str, text: &str, dialect: Dialect, opts: &Options, read: Reader) -> Imported {
    match dialect {
        Dialect::ContextFree => import_cf(file, text, opts, read),
        Dialect::StructureSynth => es::import(file, text),
    }
}

/// Imports a Context Free program.
pub fn import_cf(file: &str, text: &str, opts: &Options, read: Reader) -> Imported {
    let mut rep = Report::new(file, "context-free");
    let mut prog = cfparse::Program::default();
    parse_cf_into(text, &mut prog, &mut rep, true);
    // Included files add their shapes (their start shapes are not used).
    let mut seen: Vec<String> = Vec::new();
    let mut k = 0;
    while k < prog.includes.len() {
        let (f, line) = prog.includes[k].clone();
        k += 1;
        if seen.contains(&f) {
            continue;
        }
        seen.push(f.clone());
        match read(&f) {
            Some(t) => {
                let start = prog.start.take();
                let mut sub = Report::new(&f, "context-free");
                parse_cf_into(&t, &mut prog, &mut sub, false);
                prog.start = start;
                for n in sub.notes {
                    rep.notes.push(Note {
                        line,
                        construct: n.construct,
                        action: n.action,
                        detail: format!("in {f}:{}: {}", n.line, n.detail),
                    });
                }
            }
            None => rep.drop(line, "import", format!("`{f}` could not be read: its shapes are missing")),
        }
    }
    let mut out = String::new();
    let mut em = cfemit::Emitter::new(&prog, &mut rep);
    let mut body = String::new();
    em.shapes(&mut body);
    let mut head = String::new();
    let mut start_rule = String::new();
    match prog.start.clone() {
        Some((name, args, adj, line)) => {
            let is_shape = prog.shapes.iter().any(|s| s.name == name && !s.rules.is_empty());
            let is_prim = cfemit::PRIMITIVES.contains(&name.as_str()) && !is_shape;
            let m = em.names.get(&name);
            if !is_shape && !is_prim {
                em.rep.drop(
                    line,
                    "startshape",
                    format!("the start shape `{name}` is a path or undefined: the grammar draws nothing"),
                );
                let _ = writeln!(head, "startshape start_{m}");
                let _ = write!(start_rule, "rule start_{m} {{\n}}\n\n");
            } else if !prog.symmetry.is_empty() {
                // `CF::Symmetry`: the design drawn once per copy, the same random
                // design each time (one `seed` for all: a replayed sub-derivation).
                let call = em.start_call(&name, args.as_deref(), &adj, line).unwrap_or_default();
                let call = with_seed(&call, SYMMETRY_SEED);
                let _ = writeln!(head, "startshape start_{m}");
                let _ = writeln!(start_rule, "rule start_{m} {{");
                for copy in &prog.symmetry {
                    match symmetry_list(*copy) {
                        Some(list) => {
                            let _ = writeln!(start_rule, "  1 * {{{list}}} {call}");
                        }
                        None => {
                            let _ = writeln!(start_rule, "  {call}");
                        }
                    }
                }
                let _ = write!(start_rule, "}}\n\n");
            } else if args.is_some() || !adj.terms.is_empty() || is_prim {
                let call = em.start_call(&name, args.as_deref(), &adj, line).unwrap_or_default();
                let _ = writeln!(head, "startshape start_{m}");
                let _ = write!(start_rule, "rule start_{m} {{\n  {call}\n}}\n\n");
            } else {
                let _ = writeln!(head, "startshape {m}");
            }
        }
        None => em.rep.drop(0, "startshape", "the program has no start shape: the grammar is a library"),
    }
    let renamed = em.names.renamed();
    drop(em);
    head.push_str("flat\n");
    let (pixel, needs_pixel) = match (prog.canvas, opts.pixel) {
        (Some((w, h)), _) => (w.abs().max(h.abs()) / opts.pixels, false),
        (None, Some(p)) => (p, false),
        (None, None) => (0.001 * 500.0 / opts.pixels.max(1.0), true),
    };
    let px = prog.min_size_px.unwrap_or(0.3);
    if px > 0.0 {
        let _ = writeln!(head, "minsize {}", names::num(sig(px * pixel)));
    } else {
        rep.drop(0, "CF::MinimumSize", "zero: no `minsize` (the run's limits end endless recursions)");
    }
    if let Some((adj, line)) = &prog.background {
        match cfemit::background(adj) {
            Some(c) => {
                let _ = writeln!(head, "background {c}");
            }
            None => rep.drop(*line, "background", "a background with computed values: left at white"),
        }
    }
    for (l, c) in parse_strays(text) {
        rep.drop(l, &c.to_string(), "a character Context Free reads as nothing here: skipped");
    }
    rep.finish();
    let _ = writeln!(
        out,
        "// Imported by `mdgc import` from {} (Context Free, CFDG {} syntax).",
        file,
        if prog.v3 { 3 } else { 2 }
    );
    let _ = writeln!(
        out,
        "// Context Free's minimum size ({} px) is `minsize` for a {}-pixel picture.",
        names::num(px),
        names::num(opts.pixels)
    );
    if !rep.notes.is_empty() {
        let _ = writeln!(out, "// {} constructs approximated or left out: see the import report.", rep.notes.len());
    }
    for (s, m) in renamed {
        let _ = writeln!(out, "// `{s}` is `{m}` here (MDG reserves the name).");
    }
    out.push('\n');
    out.push_str(&head);
    out.push('\n');
    out.push_str(&start_rule);
    out.push_str(&body);
    while out.ends_with("\n\n") {
        out.pop();
    }
    if !out.ends_with('\n') {
        out.push('\n');
    }
    Imported { mdg: out, report: rep, needs_pixel, min_size_px: px }
}

/// The `seed` the copies of a `CF::Symmetry` share.
const SYMMETRY_SEED: u32 = 1;

/// A call (`NAME(args) {adj}`) with `seed N` added to its adjustment list.
fn with_seed(call: &str, n: u32) -> String {
    match call.strip_suffix("{}") {
        Some(head) => format!("{head}{{seed {n}}}"),
        None => match call.strip_suffix('}') {
            Some(head) => format!("{head} seed {n}}}"),
            None => format!("{call} {{seed {n}}}"),
        },
    }
}

/// The MDG list of one copy of a rosette (turn in degrees, mirror line's angle,
/// centre): the point map centre · mirror · turn · centre⁻¹, as Context Free's
/// `processDihedral` composes it; `None` for the identity.
fn symmetry_list((turn, mirror, x, y): (f64, Option<f64>, f64, f64)) -> Option<String> {
    let n = |v: f64| names::num(if v.abs() < 1e-12 { 0.0 } else { sig12(v) });
    let mut mid = Vec::new();
    if let Some(a) = mirror {
        let r = a.to_radians();
        mid.push(format!("f {} {} 0", n(-r.sin()), n(r.cos())));
    }
    if turn != 0.0 {
        mid.push(format!("rz {}", n(turn)));
    }
    if mid.is_empty() {
        return None;
    }
    let shift = |sx: f64, sy: f64| {
        let mut v = Vec::new();
        if sx != 0.0 {
            v.push(format!("x {}", n(sx)));
        }
        if sy != 0.0 {
            v.push(format!("y {}", n(sy)));
        }
        v
    };
    let mut list = shift(x, y);
    list.extend(mid);
    list.extend(shift(-x, -y));
    Some(list.join(" "))
}

/// Rounds to 12 significant digits (so `sin(180°)` and friends print short).
fn sig12(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let m = 10f64.powi(11 - v.abs().log10().floor() as i32);
    (v * m).round() / m
}

/// Rounds to 6 significant digits (a `minsize` needs no more).
fn sig(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let m = 10f64.powi(5 - v.abs().log10().floor() as i32);
    (v * m).round() / m
}

fn parse_cf_into(text: &str, prog: &mut cfparse::Program, rep: &mut Report, main: bool) {
    let lexed = cflex::lex(text, true);
    let v3 = lexed
        .toks
        .iter()
        .any(|t| matches!(&t.t, cflex::T::Id(w) if w == "shape" || w.starts_with("CF::")) || t.t == cflex::T::P("[["));
    if main {
        prog.v3 = v3;
    }
    let mut p = cfparse::Parser::new(&lexed.toks, rep, prog);
    p.program();
}

fn parse_strays(text: &str) -> Vec<(u32, char)> {
    cflex::lex(text, true).stray
}

impl cfemit::Emitter<'_> {
    /// The start rule's one call (`startshape X(8) [hue 120]`).
    fn start_call(
        &mut self,
        name: &str,
        args: Option<&[cfparse::Expr]>,
        adj: &cfparse::Adj,
        line: u32,
    ) -> Option<String> {
        let item = cfparse::Item::Call {
            name: name.to_string(),
            args: args.map(|a| a.to_vec()),
            same: false,
            adj: adj.clone(),
            line,
        };
        let mut s = String::new();
        self.item(&item, 0, &mut s);
        Some(s.trim().to_string())
    }
}

/// What evaluating a grammar showed [`calibrate`] (the caller evaluates: this
/// crate does not).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Measure {
    /// The grammar does not compile.
    NotCompiled,
    /// It drew nothing.
    Nothing,
    /// The larger side (x or y) of its bounding box, and whether a cap stopped the
    /// run (then the box is only of what was drawn before).
    Extent { extent: f64, stopped: bool },
}

/// The bounding box of points (`None` for none).
pub fn bounds(points: &[[f32; 3]]) -> Option<([f64; 3], [f64; 3])> {
    let first = points.first()?;
    let mut lo = first.map(f64::from);
    let mut hi = lo;
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(p[k]));
            hi[k] = hi[k].max(f64::from(p[k]));
        }
    }
    Some((lo, hi))
}

/// Imports a Context Free program whose pixel size is not known by evaluating it
/// with a `minsize` m (`measure` evaluates, capped), and again with m twice the
/// minsize that run's extent asks for, until the minsize asked for is between m / 8
/// and m (at most 10 runs; a run that a cap stopped saw only part of the design, so
/// m is made coarser instead; one that drew nothing, finer). Context Free, too, sizes its
/// minimum from the extent of what it draws. Other programs are imported as
/// they are.
pub fn calibrate(
    file: &str,
    text: &str,
    dialect: Dialect,
    opts: &Options,
    read: Reader,
    measure: &dyn Fn(&str) -> Measure,
) -> Imported {
    let first = import(file, text, dialect, opts, read);
    if !first.needs_pixel || first.min_size_px <= 0.0 {
        return first;
    }
    let px = first.min_size_px;
    let pixels = opts.pixels.max(1.0);
    let with = |m: f64| import(file, text, dialect, &Options { pixel: Some(m / px), ..opts.clone() }, read);
    let mut m = 0.1;
    let (mut best, mut fallback) = (None, None);
    for _ in 0..10 {
        match measure(&with(m).mdg) {
            Measure::NotCompiled => return first,
            Measure::Nothing => m /= 16.0,
            Measure::Extent { extent: e, stopped: true } => {
                fallback = Some(px * e / pixels);
                m *= 4.0;
            }
            Measure::Extent { extent: e, stopped: false } => {
                // A run at up to 8 times the wanted minsize sees nearly the same box
                // at a fraction of the cost (the detail it leaves out is small).
                let want = px * e / pixels;
                best = Some(want);
                if want <= 0.0 || (want * 8.0 >= m && want <= m * 1.2) {
                    break;
                }
                m = 2.0 * want;
            }
        }
    }
    match best.or(fallback) {
        Some(m) if m > 0.0 && m.is_finite() => with(m),
        _ => first,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cf(text: &str) -> Imported {
        import_cf("t.cfdg", text, &Options { pixels: 500.0, pixel: Some(0.01) }, &|_| None)
    }

    /// The triangles an imported grammar draws (evaluation is the caller's in the
    /// library; the test does it itself).
    fn triangles(mdg: &str) -> usize {
        let std = Path::new(env!("CARGO_MANIFEST_DIR")).join("../std");
        let opts = crate::expand::Options { std_dir: Some(std), ..Default::default() };
        let loader = crate::source::FsLoader;
        let a = crate::driver::analyze_text(
            &loader,
            Path::new("t.mdg"),
            mdg,
            &opts,
            crate::check::CheckOptions { require_start: true },
        );
        assert!(!a.has_errors(), "{}\n{mdg}", crate::diag::render_plain(&a.diagnostics, &a.sources));
        let b = crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources);
        let b = b.unwrap_or_else(|_| panic!("lowering failed:\n{mdg}"));
        let o = mdg_vm::eval::EvalOptions { instancing: false, ..Default::default() };
        mdg_vm::eval::evaluate(&b, &o).mesh.triangles.len()
    }

    #[test]
    fn cfdg2_loops_lists_and_weights() {
        let i = cf("startshape Top\nrule Top { 6 * {r 60} CIRCLE {x 1} Leaf [r 45 x 1] }\nrule Leaf 2 { SQUARE {r 45 x 1 s 2} }\nrule Leaf { }\n");
        assert!(i.mdg.contains("  loop _i1 = 0, 6 {rz 60} {\n    CIRCLE {x 1}\n  }\n"), "{}", i.mdg);
        // CFDG 2: `{ }` is canonical (translate first), `[ ]` as written.
        assert!(i.mdg.contains("Leaf {rz 45 x 1}"), "{}", i.mdg);
        assert!(i.mdg.contains("SQUARE {x 1 rz 45 s 2}"), "{}", i.mdg);
        assert!(i.mdg.contains("rule Leaf 2 {") && i.mdg.contains("rule Leaf 1 {"), "{}", i.mdg);
        assert!(i.mdg.contains("flat\nminsize 0.003\n"), "{}", i.mdg);
        assert!(i.report.notes.is_empty(), "{:?}", i.report.notes);
    }

    #[test]
    fn cfdg3_shapes_parameters_and_reported_constructs() {
        let text = "startshape Tree(3)\nCF::Background = [b -1]\nshape Tree(natural n) {\n  SQUARE [[r 10 x 1]]\n  \
                    TRIANGLE [flip 90 skew 10 20]\n  if (n > 0) Tree(n -- 1) [y 1 s 0.5 1]\n}\n";
        let i = cf(text);
        assert!(i.mdg.contains("startshape start_Tree\n"), "{}", i.mdg);
        assert!(i.mdg.contains("rule start_Tree {\n  Tree(3) {}\n}"), "{}", i.mdg);
        assert!(i.mdg.contains("background #000000"), "{}", i.mdg);
        assert!(i.mdg.contains("rule Tree(float n) {"), "{}", i.mdg);
        assert!(i.mdg.contains("SQUARE {rz 10 x 1}"), "{}", i.mdg);
        assert!(i.mdg.contains("TRIANGLE {skew 10 20 f -1 0 0}"), "{}", i.mdg);
        assert!(i.mdg.contains("Tree(max((n) - (1), 0)) {y 1 s 0.5 1 0.7071067811865476}"), "{}", i.mdg);
        assert!(i.report.notes.iter().all(|n| n.construct != "skew"), "{:?}", i.report.notes);
    }

    #[test]
    fn relative_path_operations_are_imported_as_mdg_s_own() {
        // CFDG 2's named coordinates and CFDG 3's positional ones.
        let i = cf("startshape P\npath P {\n  MOVEREL {x 1}\n  LINEREL {y 2}\n  ARCREL {x -1 r 1 p cw}\n  \
                    CURVEREL {x 1 y 1 x1 0.5}\n  CLOSEPOLY {}\n  FILL {}\n}\n");
        for want in ["MOVEREL(1, 0) {}", "LINEREL(0, 2) {}", "ARCREL(-(1), 0, 1) cw {}", "CURVEREL(1, 1, 0.5, 0) {}"] {
            assert!(i.mdg.contains(want), "{want}\n{}", i.mdg);
        }
        let i =
            cf("startshape P\npath P {\n  MOVETO(0, 0)\n  LINEREL(1, 0)\n  CURVEREL(0, 1, 1, 1, CF::Continuous)\n  \
                    ARCREL(-1, -1, 1, CF::ArcLarge)\n  STROKE(0.1)[]\n}\n");
        for want in ["LINEREL(1, 0) {}", "CURVEREL(0, 1, 1, 1) smooth {}", "ARCREL(-(1), -(1), 1) large {}"] {
            assert!(i.mdg.contains(want), "{want}\n{}", i.mdg);
        }
        assert!(i.report.notes.iter().all(|n| !n.construct.ends_with("REL")), "{:?}", i.report.notes);
        assert!(triangles(&i.mdg) > 0, "{}", i.mdg);
    }

    /// Vectors are written as MDG's (they were cut to their first component): typed
    /// parameters, literals, indexes and slices, unparenthesized vectors, `vec`,
    /// `dot`, `cross`, a vector spread into adjustments and built-ins; the result
    /// compiles and draws the squares `cfdg` draws (the first `Dot` has size 0).
    #[test]
    fn vectors_are_imported_as_vectors() {
        let text = "startshape S\nvector2 polar(rad, a) = rad * cos(a), rad * sin(a)\nrange = 10, 20\n\
                    vector2 add(vector2 a, vector2 c) = (a[0] + c[0], a[1] + c[1])\n\
                    shape S {\n  p = vec(2, 0.5) + (0, 0.5)\n  w2 = 1, 2, 3\n  loop i = (0, 6, 1) [] Dot(i, polar(2, i * 60)) [r rand(range)]\n\
                    Dot(1, (2, 3)) [x add(p, w2[1, 2]) s dot(p, p)]\n  SQUARE [x cross((1, 0, 0), (0, 1, 0))]\n}\n\
                    shape Dot(number k, vector2 at) {\n  SQUARE [x at s k]\n}\n";
        let i = cf(text);
        for want in [
            "function polar(rad, a) { ((rad) * (cos(radians(a))), (rad) * (sin(radians(a)))) }",
            "function add(vector2 a, vector2 c) {",
            "rule Dot(float k, vector2 at) {",
            "loop i = 0, 6, 1 {} {",
            "Dot(i, polar(2, (i) * (60))) {rz (rand(10, 20))}",
            "Dot(1, (2, 3))",
            "let p = ((0.5, 0.5)) + ((0, 0.5));",
            "let w2 = (1, 2, 3);",
            "add(p, (w2[1], w2[2]))",
            "s (((p[0]) * (p[0])) + ((p[1]) * (p[1])))",
            "SQUARE {x 0 0 1}",
            "SQUARE {x (at[0]) (at[1]) s (k)}",
        ] {
            assert!(i.mdg.contains(want), "{want}\n{}", i.mdg);
        }
        assert!(!i.mdg.contains("vec("), "{}", i.mdg);
        assert!(i.report.notes.is_empty(), "{:?}", i.report.notes);
        assert_eq!(triangles(&i.mdg), 2 * 7);
    }

    #[test]
    fn subpaths_are_calls_in_the_path() {
        // Context Free's subpathtest2 (five stars stroked as one path) and a ring
        // from a primitive's outline: `path NAME [adj]` is a call in MDG's path.
        let i =
            cf("startshape stars\npath star {\n  MOVETO(0,1)\n  loop 4 [r 144]\n    LINETO(cos(234), sin(234))\n  \
                    CLOSEPOLY()\n}\npath stars {\n  loop 5 [r 72]\n    path star[y 1.6]\n  STROKE[]\n}\n\
                    path ring {\n  path CIRCLE []\n  path CIRCLE [s 0.5]\n  FILL(CF::EvenOdd) []\n}\n");
        assert!(i.mdg.contains("star {y 1.6}"), "{}", i.mdg);
        assert!(i.mdg.contains("CIRCLE {s 0.5}"), "{}", i.mdg);
        assert!(i.report.notes.iter().all(|n| n.construct != "path"), "{:?}", i.report.notes);
        // A stroke's `iso` (CFDG 3's flag, CFDG 2's `p` word) is MDG's own word.
        let i = cf("startshape P\npath P {\n  MOVETO(0, 0)\n  LINETO(1, 0)\n  STROKE(0.1, CF::IsoWidth + CF::RoundCap)[s 2 1]\n}\n\
                    path Q {\n  MOVETO {}\n  LINETO {x 1}\n  STROKE {p iso}\n}\n");
        assert!(
            i.mdg.contains("STROKE(0.1) roundcap_iso {s 2 1") || i.mdg.contains("STROKE(0.1) iso_roundcap {s 2 1"),
            "{}",
            i.mdg
        );
        assert!(i.mdg.contains("STROKE iso {}"), "{}", i.mdg);
        assert!(
            i.report.notes.iter().all(|n| n.construct != "iso" && n.construct != "isowidth"),
            "{:?}",
            i.report.notes
        );
        assert!(triangles(&i.mdg) > 0, "{}", i.mdg);
        // Context Free's `tests/filltest`: a FILL in a shape (not a path) draws
        // nothing there; here it would make the rule a path and its CIRCLE an outline.
        let i = cf("startshape foo\nrule foo {\n10* {x 1 z 1} {\n CIRCLE {b 1}\n FILL {a -0.95 z -0.5}\n }\n}\n");
        assert!(!i.mdg.contains("FILL"), "{}", i.mdg);
        assert_eq!(triangles(&i.mdg), 10 * 32);
    }

    #[test]
    fn rosette_symmetry_replays_the_start_shape_with_one_seed() {
        // Context Free's snowflake: `CF::Symmetry = CF::Dihedral, 6` draws the
        // design 12 times (6 turns, each also mirrored), the same random design
        // each time: the start rule calls it 12 times with one `seed`.
        let text = "startshape S\nCF::Symmetry = CF::Dihedral, 6\nshape S\nrule { SQUARE [] S [y 0.95 s 0.97] }\n\
                    rule 0.03 { SQUARE [] S [r 60] S [r -60] S [y 0.95 s 0.97] }\n";
        let i = cf(text);
        assert!(i.mdg.contains("startshape start_S\n"), "{}", i.mdg);
        assert_eq!(i.mdg.matches("seed 1}").count(), 12, "{}", i.mdg);
        assert!(i.mdg.contains("1 * {f 0 1 0} S {seed 1}"), "{}", i.mdg);
        assert!(i.mdg.contains("1 * {rz 60} S {seed 1}"), "{}", i.mdg);
        assert!(i.report.notes.iter().all(|n| n.construct != "CF::Symmetry"), "{:?}", i.report.notes);
        // Cyclic about a centre, and a start shape with its own adjustment.
        let i = cf("startshape S [s 2]\nCF::Symmetry = CF::Cyclic, 2, 1, 0\nshape S { CIRCLE [x 1] }\n");
        assert!(i.mdg.contains("1 * {x 1 rz 180 x -1} S {s 2 seed 1}"), "{}", i.mdg);
        assert_eq!(triangles(&i.mdg), 2 * 32);
    }

    #[test]
    fn a_shape_named_like_a_primitive_replaces_it() {
        let i = cf("startshape Top\nrule Top { TRIANGLE {} CIRCLE {} }\nrule TRIANGLE { SQUARE {} }\n");
        assert!(i.mdg.contains("rule TRIANGLE_ {") && i.mdg.contains("  TRIANGLE_ {}\n  CIRCLE {}"), "{}", i.mdg);
    }

    #[test]
    fn imported_grammars_compile_and_count_as_context_free_does() {
        // 1 + 3 + 9 + 27 squares: the recursion ends at n = 0 (no minimum size).
        let i = cf(
            "startshape T(3)\nshape T(natural n) { SQUARE [] if (n > 0) { loop 3 [r 120] T(n - 1) [y 2 s 0.4] } }\n",
        );
        assert_eq!(triangles(&i.mdg), 2 * 40);
    }

    #[test]
    fn recursive_functions_and_lazy_choices_are_imported_as_they_are() {
        // fib(5) = 5 squares in a row, then fact(3) = 6 circles: each a recursive
        // function with its base case chosen by a lazy `if`/`select`.
        let i = cf(concat!(
            "startshape Top\n",
            "number fib(number n) = if(n < 2, n, fib(n - 1) + fib(n - 2))\n",
            "number fact(number n) = select(n > 1, 1, n * fact(n - 1))\n",
            "shape Top { loop fib(5) [x 1] SQUARE [] loop fact(3) [y 1] CIRCLE [] }\n",
        ));
        assert!(
            i.mdg.contains("function fib(n) { if((n) < (2), n, (fib((n) - (1))) + (fib((n) - (2)))) }"),
            "{}",
            i.mdg
        );
        assert!(i.mdg.contains("select((n) > (1), 1,"), "{}", i.mdg);
        assert!(i.report.notes.iter().all(|n| !n.detail.contains("recursive")), "{:?}", i.report.notes);
        assert_eq!(triangles(&i.mdg), 5 * 2 + 6 * 32);
    }

    #[test]
    fn structure_synth_retirement_and_primitives() {
        let text = "R1\nset maxobjects 100\nrule R1 maxdepth 2 > c2 {\n  { s 1/3 x -1 } R1\n  { s 1/3 x 1 } R1\n  \
                    2 * { y 1 hue 10 sat 0.5 } R1\n}\nrule c2 { { color #fff } box }\n";
        let i = import("t.es", text, Dialect::StructureSynth, &Options::default(), &|_| None);
        // Structure Synth's `md 2 > c2` is MDG's rule-local retirement.
        assert!(i.mdg.contains("rule R1 maxdepth 2 > c2 {\n"), "{}", i.mdg);
        assert!(i.mdg.contains("R1 {s 0.3333333333333333 x -1}"), "{}", i.mdg);
        assert!(i.mdg.contains("2 * {y 1 hue 10 sat -0.5} R1 {}"), "{}", i.mdg);
        assert!(i.mdg.contains("cube {#fff x 0.5 y 0.5 z 0.5}"), "{}", i.mdg);
        // Its order and `set maxobjects`, with nothing to report.
        assert!(i.mdg.contains("maxobjects 100\n") && i.mdg.contains("breadthfirst\n"), "{}", i.mdg);
        assert!(!i.report.notes.iter().any(|n| n.construct == "set maxobjects"));
        // Four calls of R1 a level, two levels, then a box each: 16 cubes of 12 triangles.
        assert_eq!(triangles(&i.mdg), 16 * 12);
    }
}
