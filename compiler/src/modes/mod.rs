//! `mdg-run`'s modes for the SPEC §11 extensions. A bundle with a `creature` or a
//! `grid` section runs that mode instead of plain evaluation; one with guided-search
//! sections runs the search, then the usual export.

pub mod creature;
pub mod grid;
pub mod guided;

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
}

/// Renders a model to PNG bytes at `size` (the picture every mode writes: `--png`,
/// contact sheets, galleries). One place, so every mode's pictures look alike.
pub fn render_png(out: &mdg_vm::output::Output, size: (u32, u32)) -> Result<Vec<u8>, String> {
    let opts = mdg_vm::preview::PreviewOptions { width: size.0, height: size.1, ..Default::default() };
    let rgba = mdg_vm::preview::render(out, &opts);
    mdg_vm::preview::encode_png(&rgba, size.0, size.1).map_err(|e| format!("cannot encode PNG: {e}"))
}
