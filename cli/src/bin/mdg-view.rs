//! `mdg-view`: see [`mdg_cli::commands::view`].

use clap::Parser;

fn main() -> std::process::ExitCode {
    // Compiled shaders are kept in the user cache directory (std's are compiled once).
    mdg_compiler::shaders::DiskCache::install_default();
    mdg_cli::commands::view::run(mdg_cli::commands::view::Args::parse())
}
