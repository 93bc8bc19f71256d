//! A model to show: a grammar compiled (or a `.mdgb` bundle loaded), evaluated, and
//! the files it was read from (for hot reload).

use crate::program::Programs;
use crate::Error;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::{Path, PathBuf};

/// How to load a model.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Where `@import NAME` looks (default: `$MDG_STD` or the bundled std/).
    pub std_dir: Option<PathBuf>,
    /// `@param` overrides, NAME=VALUE.
    pub params: Vec<(String, String)>,
    /// Presets (defined names).
    pub presets: Vec<String>,
    /// The seed and the limits of the evaluation.
    pub eval: mdg_vm::eval::EvalOptions,
    /// The caller runs the guided search of a grammar with a `search` section
    /// itself ([`crate::guided`]): the loader leaves its output empty instead of
    /// evaluating it unguided.
    pub guided_search: bool,
}

/// A compiled and evaluated grammar.
pub struct Model {
    pub bundle: Bundle,
    pub output: Output,
    /// Warnings printed while compiling (rendered), empty when clean.
    pub warnings: String,
}

/// The result of a failed load: the message and the files that took part (so a
/// watcher can still wait for them to change).
pub struct LoadFailure {
    pub error: Error,
    pub files: Vec<PathBuf>,
}

/// Compiles and evaluates grammars, and compiles the fallback shader programs, for
/// the viewer. The viewer compiles nothing itself: the CLI implements this with the
/// MDG compiler and passes it in (the window's hot reload calls it again).
pub trait Loader: Send + Sync {
    /// Compiles `path` (`.mdg`) or loads it (`.mdgb`) and evaluates it. Returns the
    /// model and every source file read (the main file first).
    fn load(&self, path: &Path, opts: &LoadOptions) -> Result<(Model, Vec<PathBuf>), Box<LoadFailure>>;
    /// std's Phong program (from `std_dir`'s `shaders.mdg` when given) and the line
    /// program.
    fn programs(&self, std_dir: Option<&Path>) -> Result<Programs, Error>;
}
