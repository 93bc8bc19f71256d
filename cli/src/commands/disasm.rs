//! `mdgc disasm FILE.mdgb|FILE.mdg`: a bundle as readable text.

use super::{emit, MessageFormat};
use crate::failure::{Exit, Failure};
use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

/// Print a bundle (or a program, compiled first) as readable text.
#[derive(clap::Args, Debug)]
pub struct Args {
    pub file: PathBuf,
}

pub fn run(args: Args) -> ExitCode {
    let file = &args.file;
    let bundle = if file.extension().is_some_and(|e| e == "mdgb") {
        let bytes = match mdg_vm::input::read_bounded(file, mdg_vm::input::MAX_DATA_BYTES) {
            Ok(b) => b,
            Err(e) => return Failure::usage(format!("cannot read {}: {e}", file.display())).report("mdgc disasm"),
        };
        match mdg_vm::bundle::load(&bytes) {
            Ok(b) => b,
            Err(e) => return Failure::input(format!("{}: {e}", file.display())).report("mdgc disasm"),
        }
    } else {
        let opts = Options { std_dir: driver::default_std_dir(), ..Options::default() };
        match driver::build(&FsLoader, file, &opts) {
            Ok((b, _)) => b,
            Err(a) => {
                emit(&a, MessageFormat::Human);
                return ExitCode::from(Exit::Input);
            }
        }
    };
    print!("{}", mdg_vm::bundle::disassemble(&bundle));
    ExitCode::SUCCESS
}
