//! `mdgc import`'s translators: a Context Free program (`.cfdg`, CFDG 2 or 3
//! syntax) or a Structure Synth program (`.es`) written as an MDG grammar that
//! today's compiler accepts, with a [`Report`] of every construct that had to be
//! approximated or left out (with its source line).
//!
//! Context Free ends most recursions at its minimum size, 0.3 pixels of the final
//! picture; MDG's `minsize` is in model units. [`import_cf`] writes `minsize` from
//! the size of a pixel: the canvas's (`size`/`CF::Size`) if the program fixes one,
//! else [`Options::pixel`], which [`calibrate`] finds by evaluating the grammar and
//! fitting its bounding box into the picture, as Context Free fits its own.
//!
//! The library reads no files itself: includes come through a callback.

mod cfemit;
mod cflex;
mod cfparse;
mod es;
mod names;
pub mod report;

use crate::expand::Options as CompileOptions;
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
                    rep.notes.push(Note { line, construct: n.construct, action: n.action, detail: format!("in {f}:{}: {}", n.line, n.detail) });
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
                em.rep.drop(line, "startshape", format!("the start shape `{name}` is a path or undefined: the grammar draws nothing"));
                let _ = writeln!(head, "startshape start_{m}");
                let _ = write!(start_rule, "rule start_{m} {{\n}}\n\n");
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
    let _ = writeln!(out, "// Imported by `mdgc import` from {} (Context Free, CFDG {} syntax).", file, if prog.v3 { 3 } else { 2 });
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
    Imported { mdg: out, report: rep, needs_pixel }
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
    let v3 = lexed.toks.iter().any(|t| {
        matches!(&t.t, cflex::T::Id(w) if w == "shape" || w.starts_with("CF::")) || t.t == cflex::T::P("[[")
    });
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
    fn start_call(&mut self, name: &str, args: Option<&[cfparse::Expr]>, adj: &cfparse::Adj, line: u32) -> Option<String> {
        let item = cfparse::Item::Call { name: name.to_string(), args: args.map(|a| a.to_vec()), same: false, adj: adj.clone(), line };
        let mut s = String::new();
        self.item(&item, 0, &mut s);
        Some(s.trim().to_string())
    }
}

/// How far a grammar reaches: its bounding box's larger side (x or y), from an
/// evaluation capped at `max_calls` rule calls. `None` if it does not compile or
/// draws nothing.
pub fn extent(mdg: &str, dir: &Path, compile: &CompileOptions, max_calls: u64) -> Option<f64> {
    let out = evaluate(mdg, dir, compile, max_calls).ok()?;
    let (lo, hi) = bounds(&out.mesh.positions)?;
    Some((hi[0] - lo[0]).max(hi[1] - lo[1]))
}

/// Compiles and evaluates an imported grammar as if it were a file in `dir`,
/// capped at `max_calls` rule calls and 4,000,000 vertices, without instancing
/// (the mesh holds every triangle, in world space). `Err`: the compiler's
/// diagnostics, as text.
pub fn evaluate(mdg: &str, dir: &Path, compile: &CompileOptions, max_calls: u64) -> Result<mdg_vm::output::Output, String> {
    let path = dir.join("imported.mdg");
    let loader = crate::source::FsLoader;
    let a = crate::driver::analyze_text(&loader, &path, mdg, compile, crate::check::CheckOptions { require_start: true });
    if a.has_errors() {
        return Err(crate::diag::render_plain(&a.diagnostics, &a.sources));
    }
    let b = crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources)
        .map_err(|d| crate::diag::render_plain(&d, &a.sources))?;
    let opts = mdg_vm::eval::EvalOptions {
        maxiter: Some(max_calls),
        max_vertices: 4_000_000,
        instancing: false,
        ..Default::default()
    };
    Ok(mdg_vm::eval::evaluate(&b, &opts))
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

/// Imports a Context Free program whose pixel size is not known by evaluating it:
/// twice, each time with `minsize` from the extent the last run reached, capped at
/// `max_calls` rule calls (Context Free, too, sizes its minimum from the extent
/// drawn so far). Other programs are imported as they are.
pub fn calibrate(
    file: &str,
    text: &str,
    dialect: Dialect,
    opts: &Options,
    read: Reader,
    dir: &Path,
    compile: &CompileOptions,
    max_calls: u64,
) -> Imported {
    let mut imp = import(file, text, dialect, opts, read);
    if !imp.needs_pixel {
        return imp;
    }
    let mut o = opts.clone();
    for _ in 0..2 {
        match extent(&imp.mdg, dir, compile, max_calls) {
            Some(e) if e > 0.0 && e.is_finite() => {
                o.pixel = Some(e / opts.pixels.max(1.0));
                imp = import(file, text, dialect, &o, read);
            }
            _ => break,
        }
    }
    imp
}
