//! `mdg-run` on a grammar with a `creature` section.

use super::Common;
use mdg_vm::bundle::Bundle;
use std::process::ExitCode;

/// Options of `mdg-run` for `creature` grammars.
#[derive(clap::Args, Debug, Default)]
pub struct CreatureArgs {}

/// Runs the mode; writes its files and reports what it wrote.
pub fn run(_bundle: &Bundle, _args: &CreatureArgs, _common: &Common) -> ExitCode {
    eprintln!("mdg-run: creature grammars are not implemented yet");
    ExitCode::from(1)
}
