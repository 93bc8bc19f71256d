//! `mdg-view`: see [`mdg_cli::commands::view`].

use clap::Parser;

fn main() -> std::process::ExitCode {
    mdg_cli::commands::view::run(mdg_cli::commands::view::Args::parse())
}
