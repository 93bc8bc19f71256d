//! `mdg-lsp`: the MDG language server, over stdio.
//!
//! A thin layer over the compiler's analysis API (`mdg_compiler::analysis`), which
//! speaks byte offsets; positions become UTF-16 only in [`position`]. Each LSP
//! feature has its own file in [`handlers`].

mod backend;
mod documents;
mod guard;
mod handlers;
mod loader;
mod position;
mod preview;
mod server;
mod transport;
mod workspace;

use backend::{Backend, Config};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use tower_lsp_server::{LspService, Server};

/// Stack of each analysis thread (see `main`).
const ANALYSIS_STACK: usize = 32 << 20;

fn main() -> ExitCode {
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--version" | "-V" => {
                println!("mdg-lsp {}", env!("CARGO_PKG_VERSION"));
                return ExitCode::SUCCESS;
            }
            "--help" | "-h" => {
                println!("mdg-lsp {}: the MDG language server. It speaks LSP on stdin/stdout; start it from an editor.\n\nEnvironment: MDG_STD=DIR selects the std library; MDG_DOCS_URL=URL (a published docs/ folder) is where diagnostic codes link (URL/diagnostics.md#CODE), else the docs installed beside std; MDG_SPIRV_CACHE=0 turns off the cache of compiled shaders ($XDG_CACHE_HOME/mdg/spirv or ~/.cache/mdg/spirv).", env!("CARGO_PKG_VERSION"));
                return ExitCode::SUCCESS;
            }
            // Clients may say how to talk; stdio is the only way.
            "--stdio" => {}
            other => {
                eprintln!("mdg-lsp: unknown argument `{other}` (try --help)");
                return ExitCode::from(2);
            }
        }
    }
    // Panics are caught per request and reported to the client; on stderr a line
    // is enough (capturing a backtrace in a debug build costs seconds and memory).
    std::panic::set_hook(Box::new(|info| eprintln!("mdg-lsp: {info}")));
    // Compiled shaders are kept in the user cache directory (std's are compiled once).
    mdg_compiler::shaders::DiskCache::install_default();
    // Analyses run on the blocking pool. Their recursion over a program nested to the
    // parse limit (256 levels of blocks, `if`s and loops) needs more than the 2 MiB
    // tokio gives a thread in a debug build; the CLI's main thread has 8 MiB.
    let runtime =
        match tokio::runtime::Builder::new_current_thread().enable_all().thread_stack_size(ANALYSIS_STACK).build() {
            Ok(rt) => rt,
            Err(e) => {
                eprintln!("mdg-lsp: cannot start the runtime: {e}");
                return ExitCode::FAILURE;
            }
        };
    let shutdown = Arc::new(AtomicBool::new(false));
    let flag = shutdown.clone();
    let config = Config::from_env();
    // glslang's first compilation pays for its initialisation (0.6–0.8 s), and std's
    // `shaders` library for its own: both now, off the message loop, before the
    // client has even initialised, so the first file's shaders do not wait.
    backend::warm_glsl(config.options.clone());
    // Documents too large to analyse are not parsed on the message loop (see `transport`).
    let oversize = Arc::new(transport::Oversize::new(config.max_live_bytes));
    let input = transport::filter(std::io::stdin(), oversize.clone());
    runtime.block_on(async move {
        let (service, socket) = LspService::build(move |client| Backend::new(client, config, flag, oversize))
            .custom_method("mdg/preview", Backend::preview)
            .finish();
        Server::new(input, tokio::io::stdout(), socket).serve(service).await;
    });
    // The stdin reader is a blocking thread that would keep the runtime (and the
    // process) alive; exit now. The LSP exit code: 0 after `shutdown`, else 1.
    let code = if shutdown.load(Ordering::SeqCst) { 0 } else { 1 };
    backend::join_warm_glsl();
    // glslang's static destructors must not run under a compilation: wait for the
    // compile threads, but not for ever (one abandoned past its deadline may never
    // end; see `mdg_compiler::shaders`).
    mdg_compiler::shaders::wait_for_compiles(mdg_compiler::shaders::COMPILE_DEADLINE);
    std::process::exit(code)
}
