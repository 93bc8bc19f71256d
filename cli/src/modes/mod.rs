//! `mdg-run`'s modes for the SPEC §11 extensions. A bundle with a `creature` or a
//! `grid` section runs that mode instead of plain evaluation; one with guided-search
//! sections runs the search, then the usual export.

pub mod creature;
pub mod grid;
pub mod guided;

use crate::pictures::Pictures;
use std::path::Path;

/// The options every mode shares with plain evaluation.
pub struct Common<'a> {
    /// The grammar file as given on the command line.
    pub file: &'a Path,
    /// `-o`, if given.
    pub output: Option<&'a Path>,
    /// `--seed`, if given.
    pub seed: Option<u64>,
    /// `--stats`.
    pub stats: bool,
    /// `--png`, if given.
    pub png: Option<&'a Path>,
    /// `--size` (width, height).
    pub size: (u32, u32),
    /// What draws every picture a mode writes (`--png`, contact sheets, galleries),
    /// so every mode's pictures look alike.
    pub pictures: &'a dyn Pictures,
    /// The evaluation limits from the command line (`--max-vertices`,
    /// `--time-budget`, `--max-iter`, …): every evaluation a mode makes uses them.
    pub eval: mdg_vm::eval::EvalOptions,
    /// What the grammar was compiled with (`--std`, `--param`, `--preset`), for a
    /// mode that reads the source again.
    pub compile: &'a mdg_compiler::expand::Options,
}
