//! `mdg-run` on a grammar with `guide` / `search` sections: the SOSMC search, then
//! the geometry phase.

use super::Common;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;

/// Guided-search options of `mdg-run`.
#[derive(clap::Args, Debug, Default)]
pub struct GuidedArgs {}

/// Runs the search and returns the model to export.
pub fn run(_bundle: &Bundle, _args: &GuidedArgs, _common: &Common) -> Result<Output, String> {
    Err("guided search is not implemented yet".into())
}
