//! `mdgc explain CODE`: a diagnostic code's title, explanation and example (as
//! `rustc --explain` does); `mdgc explain --list`: every code with its title.

use crate::failure::Failure;
use mdg_compiler::codes;
use std::process::ExitCode;

/// Explain a diagnostic code (E0301, W0001, …).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The code, as diagnostics show it in brackets (`error[E0301]`).
    #[arg(required_unless_present = "list")]
    pub code: Option<String>,
    /// List every code with its severity and title.
    #[arg(long, conflicts_with = "code")]
    pub list: bool,
}

pub fn run(args: Args) -> ExitCode {
    if args.list {
        for c in codes::CODES {
            let sev = c.severity.name();
            println!("{}  {sev:<7}  {}", c.code, c.title);
        }
        return ExitCode::SUCCESS;
    }
    let code = args.code.unwrap_or_default();
    match codes::lookup(code.trim()) {
        Some(c) => {
            print!("{}", codes::explain(c));
            ExitCode::SUCCESS
        }
        None => Failure::usage(format!(
            "`{code}` is not a diagnostic code (codes look like E0301 or W0001; `mdgc explain --list` lists them)"
        ))
        .report("mdgc explain"),
    }
}
