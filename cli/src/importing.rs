//! Evaluating imported grammars for `mdgc import` ([`mdg_compiler::importer`]
//! translates; it does not evaluate): the runs that size Context Free's minimum
//! size ([`measure`]) and the test's comparison runs ([`evaluate`]).

use mdg_compiler::expand::Options;
use mdg_compiler::importer::{bounds, Measure};
use mdg_vm::output::Output;
use std::path::Path;

/// An imported grammar that does not compile, with the compiler's diagnostics.
#[derive(Clone, Debug)]
pub struct NotCompiled {
    /// The diagnostics, rendered as `mdgc check` prints them.
    pub diagnostics: String,
}

impl std::fmt::Display for NotCompiled {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "the imported grammar does not compile:\n{}", self.diagnostics)
    }
}

/// Compiles and evaluates a grammar as if it were a file in `dir` (so its imports
/// resolve there), capped at `max_calls` rule calls and `max_vertices` vertices,
/// without instancing (the mesh holds every triangle, in world space).
pub fn evaluate(
    mdg: &str,
    dir: &Path,
    compile: &Options,
    max_calls: u64,
    max_vertices: u64,
) -> Result<Output, NotCompiled> {
    let path = dir.join("imported.mdg");
    let loader = mdg_compiler::source::FsLoader;
    let check = mdg_compiler::check::CheckOptions { require_start: true };
    let a = mdg_compiler::driver::analyze_text(&loader, &path, mdg, compile, check);
    let render = |d: &[mdg_compiler::diag::Diagnostic]| NotCompiled {
        diagnostics: mdg_compiler::diag::render_plain(d, &a.sources),
    };
    if a.has_errors() {
        return Err(render(&a.diagnostics));
    }
    let b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).map_err(|d| render(&d))?;
    let opts =
        mdg_vm::eval::EvalOptions { maxiter: Some(max_calls), max_vertices, instancing: false, ..Default::default() };
    Ok(mdg_vm::eval::evaluate(&b, &opts))
}

/// How far a grammar reaches (for [`mdg_compiler::importer::calibrate`]), from a
/// run capped at `max_calls` rule calls and 4,000,000 vertices.
pub fn measure(mdg: &str, dir: &Path, compile: &Options, max_calls: u64) -> Measure {
    match evaluate(mdg, dir, compile, max_calls, 4_000_000) {
        Err(_) => Measure::NotCompiled,
        Ok(out) => {
            let stopped = out.stats.warnings.iter().any(|w| w.contains("the run stopped"));
            match bounds(&out.mesh.positions) {
                Some((lo, hi)) => Measure::Extent { extent: (hi[0] - lo[0]).max(hi[1] - lo[1]), stopped },
                None => Measure::Nothing,
            }
        }
    }
}
