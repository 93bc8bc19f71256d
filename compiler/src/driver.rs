//! One entry point for a whole analysis: load, preprocess, parse, check, compile
//! shaders.
//!
//! `mdgc`, `mdg-run` and the language server all go through [`analyze`], so they
//! report the same diagnostics for the same source.

use crate::check::{self, CheckOptions, Checked};
use crate::diag::Diagnostic;
use crate::expand::{self, Expanded, Options};
use crate::source::{FileLoader, Sources};
use crate::span::FileId;
use std::path::{Path, PathBuf};

/// A finished analysis.
pub struct Analysis {
    pub sources: Sources,
    pub expanded: Expanded,
    pub checked: Checked,
    /// SPIR-V of each shader block, index-aligned with `expanded.shaders` (`None`
    /// where GLSL errors were reported); see [`crate::shaders`].
    pub spirv: Vec<Option<Vec<u32>>>,
    /// All diagnostics, sorted by file and position, duplicates removed, at most
    /// 100 errors and 100 warnings (then an N0001 note saying how many more).
    pub diagnostics: Vec<Diagnostic>,
    /// Whether the shader blocks were left uncompiled because glslang had not
    /// compiled them yet ([`Effort::cached_shaders_only`]): no SPIR-V and no GLSL
    /// diagnostics, which a full analysis would add.
    pub shaders_pending: bool,
}

impl Analysis {
    /// Whether any diagnostic is an error.
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(|d| d.is_error())
    }
}

/// The std directory: `$MDG_STD`, else `std/` in an ancestor of the running
/// executable (a build in the checkout's `target/`), else the std built into this
/// compiler, written once to a cache directory ([`crate::stdlib`]). An installed
/// binary never reads the source checkout it was built from.
pub fn default_std_dir() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("MDG_STD") {
        return Some(PathBuf::from(p));
    }
    if let Ok(exe) = std::env::current_exe() {
        for anc in exe.ancestors().skip(1).take(4) {
            let cand = anc.join("std");
            if cand.join("primitives.mdg").is_file() {
                return Some(cand);
            }
        }
    }
    crate::stdlib::materialize()
}

/// How much of an analysis to do, and when to give it up. The default is the whole
/// analysis, never given up.
#[derive(Clone, Copy, Default)]
pub struct Effort<'a> {
    /// Leave the shader blocks uncompiled (no SPIR-V, no GLSL diagnostics): what the
    /// language server's structural features need, without waiting for glslang.
    pub skip_shaders: bool,
    /// Polled between the phases and while a shader compiles: once it says true, the
    /// analysis stops and [`analyze_text_with`] returns `None` (the language server's
    /// analysis of a version the user has already replaced).
    pub cancelled: crate::shaders::Cancel<'a>,
    /// Take the shader blocks' results from the caches only (memory, disk): where a
    /// block would need glslang (a first start, an edited block), leave them all
    /// uncompiled and set [`Analysis::shaders_pending`] instead of waiting for it.
    pub cached_shaders_only: bool,
    /// The previous analysis of the same file: the top-level items of the main file
    /// that an edit left alone are taken from its parse instead of being parsed again
    /// (the result is the same; [`crate::parse::parse_file_reusing`]).
    pub previous: Option<&'a Analysis>,
    /// Record what the next version's analysis can reuse: the checker's per-rule
    /// results ([`crate::check_cache`]; the language server's analyses, unless
    /// `MDG_LSP_WHOLE_PARSE=1`). Rules of `previous` are replayed only if it
    /// recorded them.
    pub record: bool,
}

impl Effort<'_> {
    fn stop(&self) -> bool {
        self.cancelled.is_some_and(|c| c())
    }
}

fn finish(sources: Sources, expanded: Expanded, opts: CheckOptions, effort: Effort) -> Option<Analysis> {
    if effort.stop() {
        return None;
    }
    // The previous version's check is replayed rule by rule where nothing it read
    // changed; this one's is recorded for the next version.
    let previous = effort.previous.map(|a| check::Previous { expanded: &a.expanded, checked: &a.checked });
    let checked = check::check_with(&expanded, opts, previous, effort.record);
    if effort.stop() {
        return None;
    }
    let none = || (vec![None; expanded.shaders.len()], Vec::new());
    let mut pending = false;
    let shaders = if effort.skip_shaders {
        none()
    } else if effort.cached_shaders_only {
        crate::shaders::compile_all_cached(&expanded, &sources).unwrap_or_else(|| {
            pending = true;
            none()
        })
    } else {
        crate::shaders::compile_all(&expanded, &sources, effort.cancelled)?
    };
    let mut a = assemble(sources, expanded, checked, shaders);
    a.shaders_pending = pending;
    Some(a)
}

/// The whole analysis (never cancelled).
fn finish_all(sources: Sources, expanded: Expanded, opts: CheckOptions) -> Analysis {
    let checked = check::check(&expanded, opts);
    // Shader blocks are compiled for every analysis, not only in `build`, so that
    // `mdgc check` and the editor report GLSL errors too (cached per block).
    let shaders = crate::shaders::compile_all(&expanded, &sources, None)
        .unwrap_or_else(|| (vec![None; expanded.shaders.len()], Vec::new()));
    assemble(sources, expanded, checked, shaders)
}

/// The diagnostics of every phase, limited, sorted and deduplicated.
fn assemble(
    sources: Sources,
    expanded: Expanded,
    checked: Checked,
    (spirv, shader_diags): crate::shaders::Compiled,
) -> Analysis {
    // A main file that could not be read has no `startshape` to miss: say only why.
    let unread = sources.files.first().is_some_and(|f| f.text.is_empty())
        && expanded.diagnostics.iter().any(|d| d.code == "E0201" && d.span.file == crate::span::FileId(0));
    // A Context Free construct (E0110) explains what the checker says inside it (the
    // arguments of `startshape tree(8)`, read as `startshape tree`).
    let cf: Vec<crate::span::Span> =
        expanded.diagnostics.iter().filter(|d| d.code == "E0110").map(|d| d.span).collect();
    let inside_cf =
        |d: &Diagnostic| cf.iter().any(|s| s.file == d.span.file && s.start <= d.span.start && d.span.end <= s.end);
    let checked_diags = checked.diagnostics.iter().filter(|d| !(unread && d.code == "E0306")).filter(|d| !inside_cf(d));
    let mut diagnostics: Vec<Diagnostic> =
        expanded.diagnostics.iter().chain(checked_diags).chain(shader_diags.iter()).cloned().collect();
    // At most 100 errors and 100 warnings: the first ones found, as a compiler that
    // stops at an error limit reports them (preprocessing and syntax before checking,
    // so the cut of a deep nesting is never pushed out by what the checker then says
    // about the levels before it), then a last note with how many more.
    let more = crate::diag::limit_report(&mut diagnostics, expanded.suppressed);
    diagnostics.sort_by(|a, b| (a.span.file, a.span.start, a.code).cmp(&(b.span.file, b.span.start, b.code)));
    diagnostics.dedup_by(|a, b| a.span == b.span && a.code == b.code && a.message == b.message);
    diagnostics.extend(more);
    Analysis { sources, expanded, checked, spirv, diagnostics, shaders_pending: false }
}

/// Analyzes the file at `path`.
pub fn analyze(loader: &dyn FileLoader, path: &Path, opts: &Options, check: CheckOptions) -> Analysis {
    let mut sources = Sources::default();
    let expanded = expand::expand_path(&mut sources, loader, path, opts);
    finish_all(sources, expanded, check)
}

/// Analyzes `text` as if it were the file at `path` (imports read through `loader`).
pub fn analyze_text(loader: &dyn FileLoader, path: &Path, text: &str, opts: &Options, check: CheckOptions) -> Analysis {
    let mut sources = Sources::default();
    let id: FileId = sources.add(path, path.display().to_string(), text);
    let expanded = expand::expand_file(&mut sources, loader, id, opts);
    finish_all(sources, expanded, check)
}

/// [`analyze_text`] with less work or a cancel check ([`Effort`]); `None` if it was
/// cancelled.
pub fn analyze_text_with(
    loader: &dyn FileLoader,
    path: &Path,
    text: &str,
    opts: &Options,
    check: CheckOptions,
    effort: Effort,
) -> Option<Analysis> {
    let mut sources = Sources::default();
    let id: FileId = sources.add(path, path.display().to_string(), text);
    let prev = effort.previous.and_then(|a| {
        let f = a.sources.files.first().filter(|f| f.path == path && a.expanded.files.first() == Some(&id))?;
        Some(crate::parse::Previous { text: &f.text, items: &a.expanded.main_ast.items, memo: &a.expanded.main_memo })
    });
    let expanded = expand::expand_file_reusing(&mut sources, loader, id, opts, prev);
    finish(sources, expanded, check, effort)
}

/// Compiles the program at `path` to a bundle. On errors, returns the analysis
/// (with its diagnostics) instead.
pub fn build(
    loader: &dyn FileLoader,
    path: &Path,
    opts: &Options,
) -> Result<(mdg_vm::bundle::Bundle, Analysis), Box<Analysis>> {
    let a = analyze(loader, path, opts, CheckOptions { require_start: true });
    if a.has_errors() {
        return Err(Box::new(a));
    }
    match crate::lower::lower(&a.expanded, &a.checked.symbols, &a.sources) {
        Ok(mut b) => {
            crate::shaders::attach(&mut b, &a.spirv);
            // Meshes imported by creature parts go into the bundle, so it is
            // self-contained (read through the same loader, contained like @import).
            let d =
                crate::ext::creature::embed_meshes(&mut b, &a.expanded, &a.sources, loader, opts.std_dir.as_deref());
            if d.iter().any(|d| d.is_error()) {
                let mut a = a;
                a.diagnostics.extend(d);
                return Err(Box::new(a));
            }
            let mut a = a;
            a.diagnostics.extend(d);
            Ok((b, a))
        }
        Err(d) => {
            let mut a = a;
            a.diagnostics.extend(d);
            Err(Box::new(a))
        }
    }
}
