//! `mdgc check FILE…`: report every diagnostic.

use super::{emit, CommonOpts};
use crate::failure::{Exit, Failure};
use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::analyze;
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

/// Report every diagnostic in the given files.
#[derive(clap::Args, Debug)]
pub struct Args {
    pub files: Vec<PathBuf>,
    /// Check as a program: require a `startshape`.
    #[arg(long)]
    pub program: bool,
    #[command(flatten)]
    pub common: CommonOpts,
}

pub fn run(args: Args) -> ExitCode {
    if args.files.is_empty() {
        return Failure::usage("no files given").report("mdgc check");
    }
    let opts = match args.common.compile.options() {
        Ok(o) => o,
        Err(e) => return Failure::usage(e).report("mdgc"),
    };
    let mut errors = false;
    let mut analyses = Vec::new();
    for f in &args.files {
        let a = analyze(&FsLoader, f, &opts, CheckOptions { require_start: args.program });
        emit(&a, args.common.message_format);
        errors |= a.has_errors();
        analyses.push(a);
    }
    if let Err(e) = crate::args::check_declared_in_any(&analyses, &opts) {
        return Failure::usage(e).report("mdgc check");
    }
    if errors {
        ExitCode::from(Exit::Input)
    } else {
        ExitCode::SUCCESS
    }
}
