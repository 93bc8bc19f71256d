//! A model to show: a grammar compiled (or a `.mdgb` bundle loaded), evaluated, and
//! the files it was read from (for hot reload).

use crate::Error;
use mdg_compiler::diag::render_plain;
use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use mdg_vm::bundle::Bundle;
use mdg_vm::eval::{evaluate, EvalOptions};
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
    pub seed: Option<u64>,
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

/// Compiles `path` (`.mdg`) or loads it (`.mdgb`) and evaluates it. Returns the
/// model and every source file read (the main file first).
pub fn load(path: &Path, opts: &LoadOptions) -> Result<(Model, Vec<PathBuf>), Box<LoadFailure>> {
    let fail = |error: Error, files: Vec<PathBuf>| Box::new(LoadFailure { error, files });
    let is_bundle = path.extension().is_some_and(|e| e == "mdgb");
    let (bundle, files, warnings) = if is_bundle {
        let bytes = std::fs::read(path)
            .map_err(|e| fail(Error::Io(format!("cannot read {}: {e}", path.display())), vec![path.into()]))?;
        let b = mdg_vm::bundle::load(&bytes)
            .map_err(|e| fail(Error::Compile(format!("{}: {e}", path.display())), vec![path.into()]))?;
        (b, vec![path.to_path_buf()], String::new())
    } else {
        let copts = Options {
            defines: opts.presets.clone(),
            params: opts.params.clone(),
            std_dir: opts.std_dir.clone().or_else(driver::default_std_dir),
        };
        match driver::build(&FsLoader, path, &copts) {
            Ok((b, a)) => {
                let files = a.sources.files.iter().map(|f| f.path.clone()).collect();
                (b, files, render_plain(&a.diagnostics, &a.sources))
            }
            Err(a) => {
                let mut files: Vec<PathBuf> = a.sources.files.iter().map(|f| f.path.clone()).collect();
                if files.is_empty() {
                    files.push(path.to_path_buf());
                }
                return Err(fail(Error::Compile(render_plain(&a.diagnostics, &a.sources)), files));
            }
        }
    };
    let eval_opts = EvalOptions { seed: opts.seed, ..EvalOptions::default() };
    let output = evaluate(&bundle, &eval_opts);
    Ok((Model { bundle, output, warnings }, files))
}
