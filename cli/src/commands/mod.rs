//! One file per command. Each has its clap `Args` and a `run` returning the exit
//! code; the binaries in `src/bin/` only parse and dispatch.
//!
//! Exit codes, everywhere: 0 success (warnings allowed), 1 errors in the input (or
//! `fmt --check` found unformatted files), 2 usage or IO errors, 3 Vulkan
//! validation errors (`mdg-view`), 75 a batch shard held by another run. A failed
//! command is a [`crate::failure::Failure`], which picks the code and prints the
//! message.

pub mod build;
pub mod check;
pub mod disasm;
pub mod explain;
pub mod fmt;
pub mod import;
pub mod induce;
pub mod run;
pub mod view;

use crate::args::CompileArgs;
use clap::ValueEnum;
use mdg_compiler::diag::{render_json, render_plain};
use mdg_compiler::driver;

/// How to print diagnostics.
#[derive(Clone, Copy, Debug, Default, ValueEnum, PartialEq)]
pub enum MessageFormat {
    #[default]
    Human,
    Json,
}

/// Options of the commands that compile: the message format and [`CompileArgs`].
#[derive(clap::Args, Clone, Debug, Default)]
pub struct CommonOpts {
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value = "human")]
    pub message_format: MessageFormat,
    #[command(flatten)]
    pub compile: CompileArgs,
}

/// Prints an analysis's diagnostics: human on stderr, JSON on stdout.
pub fn emit(a: &driver::Analysis, format: MessageFormat) {
    match format {
        MessageFormat::Human => eprint!("{}", render_plain(&a.diagnostics, &a.sources)),
        MessageFormat::Json => print!("{}", render_json(&a.diagnostics, &a.sources)),
    }
}
