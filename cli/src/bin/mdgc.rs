//! `mdgc`: check, format, build, disassemble and induce MDG grammars; explain a
//! diagnostic code; import Context Free and Structure Synth programs. Each subcommand is a module of [`mdg_cli::commands`].

use clap::{Parser, Subcommand};
use mdg_cli::commands::{build, check, disasm, explain, fmt, import, induce};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "mdgc", version, about = "The MDG compiler: check, format and build shape grammars")]
#[command(
    after_help = "Examples:\n  mdgc check std/examples/tree.mdg\n  mdgc check --message-format json a.mdg b.mdg\n  mdgc fmt --check std/*.mdg\n  mdgc explain E0301\n  mdgc import ziggy.cfdg -o ziggy.mdg\n\nExit codes: 0 clean (warnings allowed), 1 errors found (or `fmt --check` found\nunformatted files), 2 usage or IO errors."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Check(check::Args),
    Build(build::Args),
    Disasm(disasm::Args),
    Induce(induce::Args),
    Import(import::Args),
    Fmt(fmt::Args),
    Explain(explain::Args),
}

fn main() -> ExitCode {
    // Compiled shaders are kept in the user cache directory (std's are compiled once).
    mdg_compiler::shaders::DiskCache::install_default();
    match Cli::parse().command {
        Command::Check(a) => check::run(a),
        Command::Build(a) => build::run(a),
        Command::Disasm(a) => disasm::run(a),
        Command::Induce(a) => induce::run(a),
        Command::Import(a) => import::run(a),
        Command::Fmt(a) => fmt::run(a),
        Command::Explain(a) => explain::run(a),
    }
}
