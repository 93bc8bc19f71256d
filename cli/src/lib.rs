//! The MDG commands: `mdgc`, `mdg-run`, `mdg-view`, one module per command in
//! [`commands`], and `mdg-run`'s run modes for the extension sections in [`modes`].
//!
//! This crate is the one place with process concerns: argument parsing (clap), exit
//! codes, progress bars (indicatif), messages on stderr, and the wiring between the
//! libraries: it passes the compiler to the viewer ([`toolchain::Toolchain`]) and a
//! picture renderer to the modes ([`pictures::Pictures`]). The libraries (`compiler`,
//! `vm`, `viewer`) print nothing and never exit.

pub mod args;
pub mod batch;
pub mod commands;
pub mod failure;
pub mod importing;
pub mod modes;
pub mod pictures;
pub mod toolchain;

/// Prints a message from a library (the viewer's window, the Vulkan validation
/// layer) on stderr: the sink the commands hand to the libraries.
pub fn say(message: &str) {
    eprintln!("{message}");
}
