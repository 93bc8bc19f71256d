//! `mdgc induce`: example buildings to a grid grammar written as MDG source.
//!
//! The VM does the work ([`mdg_grid::infer`] infers shapes per example,
//! [`mdg_grid::induce`] builds the grammar); this module reads the examples, and
//! prints the grammar as a `grid` section that [`crate::ext::grid`] compiles back to
//! the same table (a tested round trip). The text is laid out as `mdgc fmt` prints it,
//! with each shape's `blocks` one row a line, so a person can read and edit it, and each
//! class of matching shapes written once (its other members are `like` references).

use mdg_grid::induce::{induce, measures, Example, Measures};
use mdg_grid::infer::{infer, InferOptions, Inference, Progress};
use mdg_grid::voxel::VoxelModel;
use mdg_grid::{turned_blocks, GridGrammar, ShapeMatch, AXIS_NAMES};
use mdg_vm::bundle::Section as _;
use std::fmt::Write as _;
use std::path::Path;

/// What induction did, per example.
#[derive(Clone, Debug)]
pub struct ExampleReport {
    pub name: String,
    pub blocks: usize,
    pub measures: Measures,
    pub merges: usize,
    pub splits: usize,
    pub seconds: f64,
    /// Shapes of this example cut to share a piece with another example
    /// ([`mdg_grid::share`]).
    pub shared_cuts: usize,
}

/// The default smallest piece (blocks) that sub-shape matching cuts out of shapes of
/// two examples to share it (`mdgc induce --share`; 0 turns it off).
pub const DEFAULT_SHARE: usize = 3;

/// Why no grammar was induced or written.
#[derive(Debug)]
pub enum InduceError {
    /// An example could not be read, or was read and refused (the error names the file).
    Read(mdg_grid::format::ReadError),
    /// An example holds no block.
    Empty(std::path::PathBuf),
    /// The induced grammar is over a grid grammar's limits (blocks in all shapes, a
    /// shape's extent): why.
    OverLimits(mdg_grid::induce::InductionError),
    /// The written grammar would be `len` bytes, over the source file limit `max`.
    TooLarge { len: usize, max: usize, shapes: usize, blocks: usize },
    /// The written grammar does not compile back to the induced one (a bug): the
    /// compiler's diagnostics on it, rendered (empty when it compiled to another grammar).
    NotRoundTrip(String),
}

impl std::fmt::Display for InduceError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InduceError::Read(e) => write!(f, "{e}"),
            InduceError::Empty(p) => write!(f, "{}: no blocks", p.display()),
            InduceError::OverLimits(why) => {
                write!(f, "error[E0912]: the induced grammar is over a grid grammar's limits: {why}")
            }
            InduceError::TooLarge { len, max, shapes, blocks } => write!(
                f,
                "error[E0201]: the written grammar would be {len} bytes, over the {} MiB limit of a source file \
                 ({shapes} shapes, {blocks} blocks in all); induce from fewer or smaller examples, or with a larger \
                 --alpha",
                max >> 20
            ),
            InduceError::NotRoundTrip(diagnostics) => {
                write!(f, "{diagnostics}internal error: the written grammar does not compile back to the induced one")
            }
        }
    }
}

impl InduceError {
    /// Whether an example could not be read at all (missing, not a regular file, an
    /// unknown extension): a usage or IO error, where the others are errors in the input.
    pub fn is_io(&self) -> bool {
        matches!(self, InduceError::Read(e) if e.is_io())
    }
}

impl std::error::Error for InduceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            InduceError::Read(e) => Some(e),
            InduceError::OverLimits(e) => Some(e),
            _ => None,
        }
    }
}

/// Reads the examples, infers shapes and induces the grammar. `progress` hears about
/// each example (its index) and each search pass.
pub fn induce_files(
    paths: &[&Path],
    opts: &InferOptions,
    name: &str,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<(GridGrammar, Vec<ExampleReport>), InduceError> {
    let (models, _) = read_examples(paths)?;
    induce_models(&models, opts, DEFAULT_SHARE, name, progress)
}

/// Reads example buildings (any voxel format): (file name, model) each; an empty one
/// is an error. Also returns notes on what the files hold that the models do not keep
/// (block entities, explicit air), each starting with the file's name.
#[allow(clippy::type_complexity)]
pub fn read_examples(paths: &[&Path]) -> Result<(Vec<(String, VoxelModel)>, Vec<String>), InduceError> {
    let mut models: Vec<(String, VoxelModel)> = Vec::new();
    let mut all_notes = Vec::new();
    for p in paths {
        let (m, notes) = mdg_grid::format::read_with_notes(p).map_err(InduceError::Read)?;
        all_notes.extend(notes.into_iter().map(|n| format!("{}: {n}", p.display())));
        if m.blocks.is_empty() {
            return Err(InduceError::Empty(p.to_path_buf()));
        }
        let file = p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string());
        models.push((file, m));
    }
    Ok((models, all_notes))
}

/// [`induce_files`] on models already read (name, model), with the smallest shared
/// piece of sub-shape matching (`share` blocks; 0: off).
pub fn induce_models(
    models: &[(String, VoxelModel)],
    opts: &InferOptions,
    share: usize,
    name: &str,
    progress: &mut dyn FnMut(usize, Progress),
) -> Result<(GridGrammar, Vec<ExampleReport>), InduceError> {
    let original_blocks: Vec<usize> = models.iter().map(|(_, m)| m.blocks.len()).collect();
    // A door's two halves are one block for inference and matching (written back as two).
    let joined: Vec<(String, VoxelModel)> =
        models.iter().map(|(n, m)| (n.clone(), mdg_grid::doors::merge_doors(m).0)).collect();
    let models = &joined[..];
    let mut inferences: Vec<Inference> = Vec::new();
    let mut reports = Vec::new();
    for (i, (file, m)) in models.iter().enumerate() {
        let t = std::time::Instant::now();
        let inf = infer(m, opts, &mut |p| progress(i, p));
        reports.push(ExampleReport {
            name: file.clone(),
            blocks: original_blocks[i],
            measures: measures(m, &inf),
            merges: inf.stats.merges,
            splits: inf.stats.splits,
            seconds: t.elapsed().as_secs_f64(),
            shared_cuts: 0,
        });
        inferences.push(inf);
    }
    if share > 0 && models.len() > 1 {
        let refs: Vec<&VoxelModel> = models.iter().map(|(_, m)| m).collect();
        let before: Vec<usize> = inferences.iter().map(|i| i.shapes.len()).collect();
        let t = std::time::Instant::now();
        let stats = mdg_grid::share::share(&refs, opts.spec, &mut inferences, share);
        let seconds = t.elapsed().as_secs_f64() / models.len() as f64;
        for (i, r) in reports.iter_mut().enumerate() {
            if inferences[i].shapes.len() != before[i] {
                r.measures = measures(&models[i].1, &inferences[i]);
            }
            r.shared_cuts = stats.cut_per_example[i];
            r.seconds += seconds;
        }
    }
    let examples: Vec<Example> = models.iter().map(|(n, m)| Example { name: n.clone(), model: m }).collect();
    // The grid section's limits (blocks in all shapes, a shape's extent) are the only
    // way a valid example set fails here: the code of a grid value out of range.
    let g = induce(&examples, &inferences, name).map_err(InduceError::OverLimits)?;
    Ok((g, reports))
}

/// Quotes a string for MDG source (strings cannot hold `"` or line breaks).
fn quoted(s: &str) -> String {
    let clean: String = s.chars().map(|c| if c == '"' || c == '\n' || c == '\r' { '_' } else { c }).collect();
    format!("\"{clean}\"")
}

/// The grammar as MDG source: a start rule `site` (every program needs one; it draws
/// nothing here, and `mdg-run` adds what it draws under the building) and the `grid`
/// section. `comment` lines go on top as `//` comments. Each class of matching shapes
/// is written once: its first member in full, the others as `like` references.
pub fn write_source(g: &GridGrammar, comment: &[String]) -> String {
    write_source_with(g, comment, true)
}

/// [`write_source`]; with `like` false every shape is written in full (its `size` and
/// `blocks`) and every match as a `match` line (`mdgc induce --full`).
pub fn write_source_with(g: &GridGrammar, comment: &[String], like: bool) -> String {
    let mut s = String::new();
    for c in comment {
        let _ = writeln!(s, "// {c}");
    }
    s.push_str("// Every program needs a start rule; `mdg-run` generates from the `grid` section and draws\n");
    s.push_str("// whatever `site` draws (nothing here) under the building.\n");
    s.push_str("startshape site\nrule site {}\n\n");
    let name = if g.name.is_empty() { String::new() } else { format!(" {}", g.name) };
    let _ = writeln!(s, "grid{name} {{");
    if !g.examples.is_empty() {
        let ex: Vec<String> = g.examples.iter().map(|e| quoted(e)).collect();
        let _ = writeln!(s, "  examples {};", ex.join(" "));
    }
    s.push_str("  palette {\n");
    for p in &g.palette {
        let _ = writeln!(s, "    {} {} {} {} {};", p.name, quoted(&p.block), p.color[0], p.color[1], p.color[2]);
    }
    s.push_str("  }\n");
    // Each shape's matches and rules under it when the grammar lists them by source
    // shape (induced grammars do); else all of them after the shapes.
    let grouped = g.matches.windows(2).all(|w| w[0].a <= w[1].a) && g.rules.windows(2).all(|w| w[0].from <= w[1].from);
    let (mut next_match, mut next_rule) = (0, 0);
    let likes = if like { like_plan(g) } else { vec![None; g.shapes.len()] };
    let used: Vec<bool> = {
        let mut u = vec![false; g.matches.len()];
        for &m in likes.iter().flatten() {
            u[m] = true;
        }
        u
    };
    for (si, shape) in g.shapes.iter().enumerate() {
        let _ = writeln!(s, "  shape {} {{", shape.name);
        if let Some(m) = likes[si].map(|m| &g.matches[m]) {
            let a = &g.shapes[m.a as usize];
            if m.turn == 0 {
                let _ = writeln!(s, "    like {};", a.name);
            } else {
                let _ = writeln!(s, "    like {} turn {};", a.name, m.turn);
            }
            if shape.plane != like_plane(a.plane, m.turn) {
                let axis = shape.plane.map(|p| AXIS_NAMES[p as usize]).unwrap_or("none");
                let _ = writeln!(s, "    plane {axis};");
            }
            if let Some(at) = shape.at {
                let _ = writeln!(s, "    at {} {} {};", at[0], at[1], at[2]);
            }
            if shape.example != 0 {
                let _ = writeln!(s, "    example {};", shape.example);
            }
            if shape.open {
                s.push_str("    open;\n");
            }
            s.push_str("  }\n");
        } else {
            write_full_shape(&mut s, g, shape);
        }
        if grouped {
            while next_match < g.matches.len() && g.matches[next_match].a as usize <= si {
                if !used[next_match] {
                    write_match(&mut s, g, next_match);
                }
                next_match += 1;
            }
            while next_rule < g.rules.len() && g.rules[next_rule].from as usize <= si {
                write_rule(&mut s, g, next_rule);
                next_rule += 1;
            }
        }
    }
    for (m, &u) in used.iter().enumerate().skip(next_match) {
        if !u {
            write_match(&mut s, g, m);
        }
    }
    for r in next_rule..g.rules.len() {
        write_rule(&mut s, g, r);
    }
    if let Some(start) = g.shapes.get(g.start as usize) {
        let _ = writeln!(s, "  start {};", start.name);
    }
    let gen = &g.generate;
    s.push_str("  generate {\n");
    let _ = writeln!(s, "    steps {};", gen.steps);
    let _ = writeln!(s, "    enclosure {};", if gen.enclosure { "on" } else { "off" });
    let _ = writeln!(s, "    seal {};", gen.seal);
    if let Some(seed) = gen.seed {
        let _ = writeln!(s, "    seed {seed};");
    }
    s.push_str("  }\n}\n");
    // The layout above is the formatter's; run it anyway so the file is canonical.
    crate::fmt::format_source(&s).unwrap_or(s)
}

/// The plane a `like` shape gets from its target's `plane` turned `turn` quarter turns
/// (odd turns swap x and z), as the grid section derives it.
fn like_plane(plane: Option<u8>, turn: u8) -> Option<u8> {
    plane.map(|a| if turn % 2 == 1 && a != 1 { 2 - a } else { a })
}

/// Per shape, the match (index into `g.matches`) it is written as `like` of: shape B of
/// a match A B with A earlier (a class's first member is written in full, every other
/// member as a reference to it). None for every shape when the grid section would
/// order the matches of that text differently from `g` (its `like`s in shape order,
/// then `match` lines, stably by first shape), so the text always compiles back to `g`.
fn like_plan(g: &GridGrammar) -> Vec<Option<usize>> {
    let n = g.shapes.len();
    let mut plan: Vec<Option<usize>> = vec![None; n];
    let turns = g.kind_turns();
    for (mi, m) in g.matches.iter().enumerate() {
        let (a, b) = (m.a as usize, m.b as usize);
        if a < b && b < n && plan[b].is_none() {
            let (blocks, size) = turned_blocks(&g.shapes[a], m.turn, &turns);
            if size == g.shapes[b].size && blocks == g.shapes[b].blocks {
                plan[b] = Some(mi);
            }
        }
    }
    let mut order: Vec<ShapeMatch> = plan.iter().flatten().map(|&m| g.matches[m]).collect();
    order.extend(g.matches.iter().enumerate().filter(|(i, _)| !plan.contains(&Some(*i))).map(|(_, m)| *m));
    order.sort_by_key(|m| m.a);
    if order != g.matches {
        return vec![None; n];
    }
    plan
}

/// A shape with its `size`, `plane`, `at`, `example` and `blocks`.
fn write_full_shape(s: &mut String, g: &GridGrammar, shape: &mdg_grid::GridShape) {
    {
        let [sx, sy, sz] = shape.size;
        let _ = writeln!(s, "    size {sx} {sy} {sz};");
        match shape.plane {
            Some(p) => {
                let _ = writeln!(s, "    plane {};", AXIS_NAMES[p as usize]);
            }
            // A shape one block thick along exactly one axis reads as flat along it
            // unless it says it is solid.
            None if shape.size.iter().filter(|&&e| e == 1).count() == 1 => s.push_str("    plane none;\n"),
            None => {}
        }
        if let Some(at) = shape.at {
            let _ = writeln!(s, "    at {} {} {};", at[0], at[1], at[2]);
        }
        if shape.example != 0 {
            let _ = writeln!(s, "    example {};", shape.example);
        }
        if shape.open {
            s.push_str("    open;\n");
        }
        // Cells top layer first, rows from z = 0, along x; a line per row (per layer
        // when rows are one block long).
        let mut cells = vec!["_"; (sx * sy * sz) as usize];
        for b in &shape.blocks {
            let [x, y, z] = b.pos.map(|c| c as u32);
            let i = ((sy - 1 - y) * sz + z) * sx + x;
            if let (Some(c), Some(p)) = (cells.get_mut(i as usize), g.palette.get(b.kind as usize)) {
                *c = p.name.as_str();
            }
        }
        let per_line = if sx > 1 { sx } else { sz } as usize;
        s.push_str("    blocks");
        for line in cells.chunks(per_line.max(1)) {
            let _ = write!(s, "\n      {}", line.join(" "));
        }
        s.push_str(";\n  }\n");
    }
}

fn write_match(s: &mut String, g: &GridGrammar, i: usize) {
    let m = &g.matches[i];
    let (a, b) = (&g.shapes[m.a as usize].name, &g.shapes[m.b as usize].name);
    let _ = writeln!(s, "  match {a} {b} turn {};", m.turn);
}

fn write_rule(s: &mut String, g: &GridGrammar, i: usize) {
    let r = &g.rules[i];
    let (a, b) = (&g.shapes[r.from as usize].name, &g.shapes[r.to as usize].name);
    let [x, y, z] = r.place.offset;
    let _ = write!(s, "  rule {a} {b} at {x} {y} {z}");
    if r.place.turn != 0 {
        let _ = write!(s, " turn {}", r.place.turn);
    }
    s.push_str(";\n");
}

/// [`write_source`], checked: the text must fit a source file (16 MiB, error `E0201` as
/// for any source over the limit) and compile back to exactly `g` (anything else is a
/// bug of the writer or the grid section, reported as an internal error). `path` names
/// the file in diagnostics.
pub fn write_checked(g: &GridGrammar, comment: &[String], path: &Path) -> Result<String, InduceError> {
    write_checked_with(g, comment, path, true)
}

/// [`write_checked`] of [`write_source_with`].
pub fn write_checked_with(g: &GridGrammar, comment: &[String], path: &Path, like: bool) -> Result<String, InduceError> {
    let text = write_source_with(g, comment, like);
    let max = crate::source::MAX_SOURCE_BYTES;
    if text.len() > max {
        return Err(InduceError::TooLarge {
            len: text.len(),
            max,
            shapes: g.shapes.len(),
            blocks: g.shapes.iter().map(|s| s.blocks.len()).sum::<usize>(),
        });
    }
    let opts = crate::expand::Options { std_dir: crate::driver::default_std_dir(), ..Default::default() };
    let a = crate::driver::analyze_text(
        &crate::source::FsLoader,
        path,
        &text,
        &opts,
        crate::check::CheckOptions { require_start: true },
    );
    let back = if a.has_errors() {
        None
    } else {
        crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources)
            .ok()
            .and_then(|b| GridGrammar::from_bundle(&b).ok().flatten())
    };
    if back.as_ref() != Some(g) {
        return Err(InduceError::NotRoundTrip(crate::diag::render_plain(&a.diagnostics, &a.sources)));
    }
    Ok(text)
}
