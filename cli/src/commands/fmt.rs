//! `mdgc fmt [--check] FILE…`: format in place, or check.

use crate::failure::{Exit, Failure};
use std::path::PathBuf;
use std::process::ExitCode;

/// Format files in place (or check that they are formatted).
#[derive(clap::Args, Debug)]
pub struct Args {
    pub files: Vec<PathBuf>,
    /// Do not write; exit 1 if any file would change.
    #[arg(long)]
    pub check: bool,
}

pub fn run(args: Args) -> ExitCode {
    let mut changed = false;
    for f in &args.files {
        let text = match mdg_compiler::source::FileLoader::read(&mdg_compiler::source::FsLoader, f) {
            Ok(t) => t,
            Err(e) => return Failure::usage(format!("cannot read {}: {e}", f.display())).report("mdgc fmt"),
        };
        let formatted = match mdg_compiler::fmt::format_file(f, &text) {
            Ok(s) => s,
            Err(e @ mdg_compiler::fmt::FormatError::Syntax(_)) => {
                return Failure::input(format!("{}: not formatted, it has syntax errors:\n{e}", f.display()))
                    .report("mdgc fmt")
            }
            Err(e) => return Failure::input(format!("{}: not formatted: {e}", f.display())).report("mdgc fmt"),
        };
        if formatted != text {
            changed = true;
            if args.check {
                println!("{} is not formatted", mdg_compiler::diag::escape_text(&f.display().to_string()));
            } else if let Err(e) = mdg_export::write_atomic(f, formatted.as_bytes()) {
                return Failure::usage(format!("cannot write {}: {e}", f.display())).report("mdgc fmt");
            }
        }
    }
    if args.check && changed {
        ExitCode::from(Exit::Input)
    } else {
        ExitCode::SUCCESS
    }
}
