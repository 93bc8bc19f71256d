//! `mdgc`: check, format and build MDG grammars.
//!
//! Exit codes: 0 clean (warnings allowed), 1 errors found (or `fmt --check` found
//! unformatted files), 2 usage or IO errors.

use clap::{Parser, Subcommand, ValueEnum};
use mdg_compiler::check::CheckOptions;
use mdg_compiler::diag::{render_json, render_plain};
use mdg_compiler::driver::{self, analyze};
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "mdgc", version, about = "The MDG compiler: check, format and build shape grammars")]
#[command(
    after_help = "Examples:\n  mdgc check std/examples/tree.mdg\n  mdgc check --message-format json a.mdg b.mdg\n  mdgc fmt --check std/*.mdg"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum, PartialEq)]
enum MessageFormat {
    Human,
    Json,
}

#[derive(clap::Args)]
struct CommonOpts {
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value = "human")]
    message_format: MessageFormat,
    #[command(flatten)]
    compile: mdg_compiler::cli::CompileArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Report every diagnostic in the given files.
    Check {
        files: Vec<PathBuf>,
        /// Check as a program: require a `startshape`.
        #[arg(long)]
        program: bool,
        #[command(flatten)]
        common: CommonOpts,
    },
    /// Compile a program to a bundle (`.mdgb`).
    Build {
        file: PathBuf,
        /// Output bundle (default: beside the input, `.mdgb`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        common: CommonOpts,
    },
    /// Print a bundle (or a program, compiled first) as readable text.
    Disasm { file: PathBuf },
    /// Format files in place (or check that they are formatted).
    Fmt {
        files: Vec<PathBuf>,
        /// Do not write; exit 1 if any file would change.
        #[arg(long)]
        check: bool,
    },
}

fn options(common: &CommonOpts) -> Result<Options, String> {
    common.compile.options()
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Check { files, program, common } => {
            if files.is_empty() {
                eprintln!("mdgc check: no files given");
                return ExitCode::from(2);
            }
            let opts = match options(&common) {
                Ok(o) => o,
                Err(e) => {
                    eprintln!("mdgc: {e}");
                    return ExitCode::from(2);
                }
            };
            let mut errors = false;
            for f in &files {
                let a = analyze(&FsLoader, f, &opts, CheckOptions { require_start: program });
                emit(&a, common.message_format);
                errors |= a.has_errors();
            }
            if errors {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            }
        }
        Command::Build { file, output, common } => {
            let opts = match options(&common) {
                Ok(o) => o,
                Err(e) => {
                    eprintln!("mdgc: {e}");
                    return ExitCode::from(2);
                }
            };
            match driver::build(&FsLoader, &file, &opts) {
                Ok((bundle, a)) => {
                    emit(&a, common.message_format);
                    let out = output.unwrap_or_else(|| file.with_extension("mdgb"));
                    let bytes = mdg_vm::bundle::encode(&bundle);
                    if let Err(e) = write_atomic(&out, &bytes) {
                        eprintln!("mdgc build: cannot write {}: {e}", out.display());
                        return ExitCode::from(2);
                    }
                    eprintln!("wrote {} ({} bytes)", out.display(), bytes.len());
                    ExitCode::SUCCESS
                }
                Err(a) => {
                    emit(&a, common.message_format);
                    ExitCode::from(1)
                }
            }
        }
        Command::Disasm { file } => {
            let bundle = if file.extension().is_some_and(|e| e == "mdgb") {
                let bytes = match std::fs::read(&file) {
                    Ok(b) => b,
                    Err(e) => {
                        eprintln!("mdgc disasm: cannot read {}: {e}", file.display());
                        return ExitCode::from(2);
                    }
                };
                match mdg_vm::bundle::load(&bytes) {
                    Ok(b) => b,
                    Err(e) => {
                        eprintln!("mdgc disasm: {}: {e}", file.display());
                        return ExitCode::from(1);
                    }
                }
            } else {
                let opts = Options { std_dir: driver::default_std_dir(), ..Options::default() };
                match driver::build(&FsLoader, &file, &opts) {
                    Ok((b, _)) => b,
                    Err(a) => {
                        emit(&a, MessageFormat::Human);
                        return ExitCode::from(1);
                    }
                }
            };
            print!("{}", mdg_vm::bundle::disassemble(&bundle));
            ExitCode::SUCCESS
        }
        Command::Fmt { files, check } => {
            let mut changed = false;
            for f in &files {
                let text = match std::fs::read_to_string(f) {
                    Ok(t) => t,
                    Err(e) => {
                        eprintln!("mdgc fmt: cannot read {}: {e}", f.display());
                        return ExitCode::from(2);
                    }
                };
                let formatted = match mdg_compiler::fmt::format_source(&text) {
                    Ok(s) => s,
                    Err(e) => {
                        eprintln!("mdgc fmt: {}: not formatted, it has syntax errors:\n{e}", f.display());
                        return ExitCode::from(1);
                    }
                };
                if formatted != text {
                    changed = true;
                    if check {
                        println!("{} is not formatted", f.display());
                    } else if let Err(e) = write_atomic(f, formatted.as_bytes()) {
                        eprintln!("mdgc fmt: cannot write {}: {e}", f.display());
                        return ExitCode::from(2);
                    }
                }
            }
            if check && changed {
                ExitCode::from(1)
            } else {
                ExitCode::SUCCESS
            }
        }
    }
}

fn emit(a: &driver::Analysis, format: MessageFormat) {
    match format {
        MessageFormat::Human => eprint!("{}", render_plain(&a.diagnostics, &a.sources)),
        MessageFormat::Json => print!("{}", render_json(&a.diagnostics, &a.sources)),
    }
}

fn write_atomic(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    mdg_vm::export::write_atomic(path, bytes)
}
