//! `mdg-run` on a grammar with a `grid` section.

use super::Common;
use mdg_vm::bundle::Bundle;
use std::process::ExitCode;

/// Options of `mdg-run` for `grid` grammars.
#[derive(clap::Args, Debug, Default)]
pub struct GridArgs {}

/// Runs the mode; writes its files and reports what it wrote.
pub fn run(_bundle: &Bundle, _args: &GridArgs, _common: &Common) -> ExitCode {
    eprintln!("mdg-run: grid grammars are not implemented yet");
    ExitCode::from(1)
}
