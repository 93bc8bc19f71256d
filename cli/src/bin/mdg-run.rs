//! `mdg-run`: see [`mdg_cli::commands::run`].

use clap::Parser;

fn main() -> std::process::ExitCode {
    mdg_cli::commands::run::run(mdg_cli::commands::run::Args::parse())
}
