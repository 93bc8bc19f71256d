//! `mdgc build FILE.mdg [-o FILE.mdgb]`: compile a program to a bundle.

use super::{emit, CommonOpts};
use crate::failure::{Exit, Failure};
use mdg_compiler::driver;
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

/// Compile a program to a bundle (`.mdgb`).
#[derive(clap::Args, Debug)]
pub struct Args {
    pub file: PathBuf,
    /// Output bundle (default: beside the input, `.mdgb`).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub common: CommonOpts,
}

pub fn run(args: Args) -> ExitCode {
    let opts = match args.common.compile.options() {
        Ok(o) => o,
        Err(e) => return Failure::usage(e).report("mdgc"),
    };
    match driver::build(&FsLoader, &args.file, &opts) {
        Ok((bundle, a)) => {
            emit(&a, args.common.message_format);
            if let Err(e) = crate::args::check_declared(&a, &opts) {
                return Failure::usage(e).report("mdgc build");
            }
            let out = args.output.unwrap_or_else(|| args.file.with_extension("mdgb"));
            if let Some(f) = a.sources.files.iter().find(|f| mdg_export::same_file(&f.path, &out)) {
                let msg = format!(
                    "-o {}: that is an input ({}); choose another output file",
                    out.display(),
                    f.path.display()
                );
                return Failure::usage(msg).report("mdgc build");
            }
            let bytes = mdg_vm::bundle::encode(&bundle);
            if let Err(e) = mdg_export::write_atomic(&out, &bytes) {
                return Failure::usage(format!("cannot write {}: {e}", out.display())).report("mdgc build");
            }
            eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
            ExitCode::SUCCESS
        }
        Err(a) => {
            emit(&a, args.common.message_format);
            ExitCode::from(Exit::Input)
        }
    }
}
