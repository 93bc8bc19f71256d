//! `workspace/executeCommand`. The only command, `mdg.debug.panic`, exists when
//! `MDG_LSP_PANIC_COMMAND=1`: it panics inside a handler so tests can check that the
//! server survives.

use crate::backend::Backend;
use tower_lsp_server::jsonrpc::{Error, Result};
use tower_lsp_server::ls_types::*;

/// The test command's name.
pub const PANIC_COMMAND: &str = "mdg.debug.panic";

/// Runs a command.
pub async fn execute_command(b: &Backend, p: ExecuteCommandParams) -> Result<Option<LSPAny>> {
    if p.command == PANIC_COMMAND && b.config.panic_command {
        return b.run("mdg.debug.panic", || -> Option<LSPAny> { panic!("panic requested by {PANIC_COMMAND}") }).await;
    }
    Err(Error::invalid_params(format!("unknown command `{}`", p.command)))
}
