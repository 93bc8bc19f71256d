//! How a command fails: the one place that turns what went wrong (a usage error,
//! a library's typed error) into the message printed and the process's exit status.
//!
//! Exit statuses, everywhere: 0 success (warnings allowed), 1 errors in the input
//! (or `fmt --check` found unformatted files), 2 usage or IO errors, 3 Vulkan
//! validation errors (`mdg-view`) or an empty creature generation, 75 (`EX_TEMPFAIL`) a batch shard another run
//! holds. The libraries' errors are data; the `From` impls below say which status
//! each one ends with, so a command writes `?` and never a number.

use std::process::ExitCode;

/// The exit status of a failed command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Exit {
    /// 1: errors in the input (a grammar, a bundle, a model, an example).
    Input,
    /// 2: a bad argument, or a file that could not be read or written.
    Usage,
    /// 3: the Vulkan validation layer reported errors.
    Validation,
    /// 3: a creature evolution made an empty generation (docs/creatures.md).
    Extinct,
    /// 75 (`EX_TEMPFAIL`): another run holds the batch shard; try again later.
    Busy,
}

impl Exit {
    /// The process's exit status.
    pub fn code(self) -> u8 {
        match self {
            Exit::Input => 1,
            Exit::Usage => 2,
            Exit::Validation | Exit::Extinct => 3,
            Exit::Busy => 75,
        }
    }
}

impl From<Exit> for ExitCode {
    fn from(e: Exit) -> ExitCode {
        ExitCode::from(e.code())
    }
}

/// A failed command: the message and the status it exits with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    pub exit: Exit,
    pub message: String,
}

impl Failure {
    /// Errors in the input (exit 1).
    pub fn input(message: impl std::fmt::Display) -> Failure {
        Failure { exit: Exit::Input, message: message.to_string() }
    }

    /// A usage or IO error (exit 2).
    pub fn usage(message: impl std::fmt::Display) -> Failure {
        Failure { exit: Exit::Usage, message: message.to_string() }
    }

    /// Another run holds the shard (exit 75).
    pub fn busy(message: impl std::fmt::Display) -> Failure {
        Failure { exit: Exit::Busy, message: message.to_string() }
    }

    /// A failure whose message is printed already (a grammar's diagnostics, as the
    /// compiler renders them): [`Failure::report`] prints nothing more.
    pub fn shown(exit: Exit) -> Failure {
        Failure { exit, message: String::new() }
    }

    /// The same failure with `context` before its message (`cannot read x.json`).
    pub fn context(self, context: impl std::fmt::Display) -> Failure {
        Failure { message: format!("{context}: {}", self.message), ..self }
    }

    /// Prints `PROG: MESSAGE` on stderr (control characters in the message, which
    /// often quotes a path or text from the input, escaped) and gives the status.
    pub fn report(&self, prog: &str) -> ExitCode {
        if !self.message.is_empty() {
            eprintln!("{prog}: {}", mdg_compiler::diag::escape_text(&self.message));
        }
        ExitCode::from(self.exit.code())
    }
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

/// A file that could not be read: a usage or IO error.
impl From<mdg_vm::input::ReadError> for Failure {
    fn from(e: mdg_vm::input::ReadError) -> Failure {
        Failure::usage(e.to_string())
    }
}

/// Text that is not UTF-8: the file given is not a grammar (usage).
impl From<mdg_compiler::source::DecodeError> for Failure {
    fn from(e: mdg_compiler::source::DecodeError) -> Failure {
        Failure::usage(e.to_string())
    }
}

/// A bundle that does not load or verify: errors in the input.
impl From<mdg_vm::bundle::LoadError> for Failure {
    fn from(e: mdg_vm::bundle::LoadError) -> Failure {
        Failure::input(e.to_string())
    }
}

/// A file that cannot be formatted: errors in the input.
impl From<mdg_compiler::fmt::FormatError> for Failure {
    fn from(e: mdg_compiler::fmt::FormatError) -> Failure {
        Failure::input(e.to_string())
    }
}

/// No grammar induced: an example that cannot be read is a usage or IO error;
/// the rest are errors in the input (the examples), and the written grammar's own
/// checks.
impl From<mdg_compiler::induce::InduceError> for Failure {
    fn from(e: mdg_compiler::induce::InduceError) -> Failure {
        if e.is_io() {
            Failure::usage(e.to_string())
        } else {
            Failure::input(e.to_string())
        }
    }
}

/// A `--script` that does not parse: a usage error.
impl From<mdg_viewer::script::ScriptError> for Failure {
    fn from(e: mdg_viewer::script::ScriptError) -> Failure {
        Failure::usage(e.to_string())
    }
}

/// A `--guides` file: unreadable is an IO error, invalid is an input error.
impl From<mdg_viewer::guided::watch::GuideFileError> for Failure {
    fn from(e: mdg_viewer::guided::watch::GuideFileError) -> Failure {
        use mdg_viewer::guided::watch::GuideFileError;
        match e {
            GuideFileError::Read { .. } => Failure::usage(e.to_string()),
            GuideFileError::Invalid { .. } => Failure::input(e.to_string()),
        }
    }
}

/// A model that could not be written: the destination's fault (a missing folder,
/// a full disk) is an IO error, the model's (too many bones or triangles for the
/// format) an error in the input.
impl From<mdg_export::ExportError> for Failure {
    fn from(e: mdg_export::ExportError) -> Failure {
        if e.is_io() {
            Failure::usage(e.to_string())
        } else {
            Failure::input(e.to_string())
        }
    }
}

/// A creature part library that cannot be built (a part without triangles):
/// errors in the input (the grammar).
impl From<mdg_creature::error::LibraryError> for Failure {
    fn from(e: mdg_creature::error::LibraryError) -> Failure {
        Failure::input(e.to_string())
    }
}

/// A grid grammar that generates no building (it does not verify, or its
/// production is too large for the enclosure constraint): errors in the input.
impl From<mdg_grid::generate::GenerateError> for Failure {
    fn from(e: mdg_grid::generate::GenerateError) -> Failure {
        Failure::input(e.to_string())
    }
}

/// A guided search that gave no model: errors in the input (the grammar or guides).
impl From<mdg_viewer::guided::search::SearchError> for Failure {
    fn from(e: mdg_viewer::guided::search::SearchError) -> Failure {
        Failure::input(format!("guided search: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_errors_map_to_their_exit_status_and_keep_their_message() {
        let read = mdg_vm::input::ReadError::TooLarge { len: 20, max: 10 };
        assert_eq!(Failure::from(read), Failure::usage("file too large: 20 bytes (at most 10)"));
        let load = mdg_vm::bundle::LoadError("bad magic".into());
        assert_eq!(Failure::from(load), Failure::input("invalid bundle: bad magic"));
        let busy = Failure::busy("held by pid 7");
        assert_eq!((busy.exit.code(), Exit::Validation.code()), (75, 3));
        let f = Failure::from(mdg_compiler::source::DecodeError::Utf16).context("cannot read standard input");
        assert_eq!(f.exit, Exit::Usage);
        assert!(f.message.starts_with("cannot read standard input: the file is UTF-16"), "{f}");
    }

    #[test]
    fn grid_and_creature_errors_are_errors_in_the_input_with_their_message() {
        let lib = mdg_creature::error::LibraryError::NoMesh { part: "arm".into() };
        assert_eq!(Failure::from(lib), Failure::input("part `arm`: no mesh"));
        let grid = mdg_grid::generate::GenerateError::TooLarge { cells: 70_000_000 };
        let f = Failure::from(grid);
        assert_eq!(f.exit, Exit::Input);
        assert!(
            f.message.starts_with("the production is too large for the enclosure constraint (70000000 cells"),
            "{f}"
        );
    }
}
