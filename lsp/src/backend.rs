//! The server state ([`Backend`]: the client handle, the documents, the
//! configuration) and what every handler shares: analysing a document, running
//! feature code under the panic guard, mapping spans to locations.

use crate::documents::{Documents, Snapshot};
use crate::guard::guard;
use crate::position::LineIndex;
use crate::workspace::Workspace;
use mdg_compiler::analysis::{CompletionConfig, Document};
use mdg_compiler::driver::Effort;
use mdg_compiler::expand::Options;
use mdg_compiler::span::{FileId, Span};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use tower_lsp_server::jsonrpc::{Error, Result};
use tower_lsp_server::ls_types::*;
use tower_lsp_server::Client;

/// Settings fixed at start-up.
pub struct Config {
    /// Preprocessor options (where the std library is).
    pub options: Options,
    pub completion: CompletionConfig,
    /// Whether the `mdg.debug.panic` command exists (for testing panic isolation).
    pub panic_command: bool,
    /// `docs/diagnostics.md`, where a diagnostic's code links to (its entry's anchor
    /// added): under `$MDG_DOCS_URL` (the URL of a `docs/` folder) when set, else the
    /// file beside the std library.
    pub diagnostics_doc: Option<Uri>,
    /// The largest open document analysed as the user types, in bytes
    /// (`$MDG_LSP_MAX_LIVE_BYTES`, default `analysis::MAX_LIVE_BYTES`).
    pub max_live_bytes: usize,
    /// Whether an edited document's analysis reuses the previous version's: its
    /// parse the unchanged items, its check the unchanged rules' results
    /// (`MDG_LSP_WHOLE_PARSE=1` turns it off: every version parsed and checked whole,
    /// for measuring and as a way out should the reuse ever be wrong).
    pub reuse_parses: bool,
}

impl Config {
    /// The configuration from the environment: std from `$MDG_STD` or beside the
    /// executable; `MDG_LSP_PANIC_COMMAND=1` enables the test command.
    pub fn from_env() -> Config {
        let std_dir = mdg_compiler::driver::default_std_dir();
        let mut std_libraries: Vec<String> = std_dir
            .as_ref()
            .and_then(|d| std::fs::read_dir(d).ok())
            .map(|rd| {
                rd.filter_map(|e| e.ok())
                    .filter_map(|e| e.file_name().to_str().and_then(|n| n.strip_suffix(".mdg")).map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        std_libraries.sort();
        let published = std::env::var("MDG_DOCS_URL")
            .ok()
            .filter(|u| !u.trim().is_empty())
            .and_then(|u| format!("{}/diagnostics.md", u.trim().trim_end_matches('/')).parse::<Uri>().ok());
        let diagnostics_doc = published.or_else(|| {
            std_dir
                .as_ref()
                .and_then(|d| d.parent())
                .map(|root| root.join("docs/diagnostics.md"))
                .filter(|p| p.is_file())
                .and_then(Uri::from_file_path)
        });
        let max_live_bytes = std::env::var("MDG_LSP_MAX_LIVE_BYTES")
            .ok()
            .and_then(|v| v.trim().parse::<usize>().ok())
            .unwrap_or(mdg_compiler::analysis::MAX_LIVE_BYTES);
        Config {
            max_live_bytes,
            reuse_parses: !std::env::var("MDG_LSP_WHOLE_PARSE").is_ok_and(|v| v == "1"),
            diagnostics_doc,
            options: Options { std_dir, ..Options::default() },
            completion: CompletionConfig { std_libraries },
            panic_command: std::env::var("MDG_LSP_PANIC_COMMAND").is_ok_and(|v| v == "1"),
        }
    }
}

/// How far an analysis compiles the shader blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shaders {
    /// Not at all (no GLSL diagnostics): what requests use, never waiting for glslang.
    Skip,
    /// From the SPIR-V caches only: where a block needs glslang, none are compiled
    /// and the analysis says so (`shaders_pending`).
    Cached,
    /// Compiled, waiting for glslang where needed.
    Compile,
}

/// The server: the client handle, the documents and the configuration.
#[derive(Clone)]
pub struct Backend {
    pub client: Client,
    pub docs: Arc<Documents>,
    /// Every `.mdg` file of the workspace folders, open or not.
    pub workspace: Arc<Workspace>,
    pub config: Arc<Config>,
    /// Set by `shutdown`; decides the exit code after `exit`.
    pub shutdown_requested: Arc<AtomicBool>,
    /// Sizes of documents whose text the input filter did not pass on.
    pub oversize: Arc<crate::transport::Oversize>,
    /// Each document's preview generation (`mdg/preview`, newest wins).
    pub previews: Arc<crate::preview::Previews>,
}

impl Backend {
    /// A server talking to `client`.
    pub fn new(
        client: Client,
        config: Config,
        shutdown_requested: Arc<AtomicBool>,
        oversize: Arc<crate::transport::Oversize>,
    ) -> Backend {
        Backend {
            client,
            docs: Arc::new(Documents::default()),
            workspace: Arc::new(Workspace::default()),
            config: Arc::new(config),
            shutdown_requested,
            oversize,
            previews: Arc::new(crate::preview::Previews::default()),
        }
    }

    /// Analyses `snap` (on the current thread); a document over the live-analysis
    /// limit is not analysed (one W0012 warning says so). `None` if the document
    /// changed meanwhile (the analysis gave up). `shaders` says how far the shader
    /// blocks are compiled.
    pub fn analyze(snap: &Snapshot, config: &Config, shaders: Shaders) -> Option<Document> {
        if snap.size > config.max_live_bytes {
            return Some(Document::too_large(
                &snap.loader,
                &snap.path,
                snap.size,
                config.max_live_bytes,
                &config.options,
            ));
        }
        let outdated = || snap.outdated();
        let effort = Effort {
            skip_shaders: shaders == Shaders::Skip,
            cancelled: Some(&outdated),
            cached_shaders_only: shaders == Shaders::Cached,
            previous: snap.previous.as_deref().filter(|_| config.reuse_parses).map(Document::analysis),
            record: config.reuse_parses,
        };
        Document::with_effort(&snap.loader, &snap.path, &snap.text, &config.options, effort)
    }

    /// An analysis of the current text of `uri` for a request: the full one if it
    /// is done, else one without compiled shaders, made now if need be, so that a
    /// request never waits for glslang (the full analysis runs in
    /// [`crate::handlers::analysis::refresh`]). `None` if the document is not open or
    /// changed while it was analysed.
    pub async fn document(&self, uri: &Uri) -> Option<Arc<Document>> {
        if let Some(d) = self.docs.current_analysis(uri).or_else(|| self.docs.quick(uri)) {
            return Some(d);
        }
        let snap = self.docs.snapshot(uri)?;
        let config = self.config.clone();
        let result = tokio::task::spawn_blocking(move || {
            let doc = guard(|| Backend::analyze(&snap, &config, Shaders::Skip));
            (snap, doc)
        })
        .await;
        match result {
            Ok((snap, Ok(Some(doc)))) => {
                let doc = Arc::new(doc);
                self.docs.store_quick(uri, &snap, doc.clone());
                Some(doc)
            }
            Ok((_, Ok(None))) => None,
            Ok((_, Err(panic))) => {
                self.log_panic("analysis", &panic).await;
                None
            }
            Err(e) => {
                self.log_panic("analysis", &e.to_string()).await;
                None
            }
        }
    }

    /// Runs feature code under the panic guard: a panic is logged and becomes an
    /// internal-error response.
    pub async fn run<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        match guard(f) {
            Ok(v) => Ok(v),
            Err(panic) => {
                self.log_panic(what, &panic).await;
                let mut e = Error::internal_error();
                e.message = format!("mdg-lsp: {what} failed: {panic}").into();
                Err(e)
            }
        }
    }

    /// Logs a caught panic to the client.
    pub async fn log_panic(&self, what: &str, message: &str) {
        self.client.log_message(MessageType::ERROR, format!("mdg-lsp: panic in {what}: {message}")).await;
    }

    /// The URI of a file of an analysis: the document's own URI for its main file.
    pub fn uri_of(&self, doc: &Document, main_uri: &Uri, file: FileId) -> Option<Uri> {
        if file == doc.main_file() {
            return Some(main_uri.clone());
        }
        let path = doc.file_path(file)?;
        self.docs.uri_of(path).or_else(|| Uri::from_file_path(path))
    }

    /// The LSP location of a span of an analysis.
    pub fn location(&self, doc: &Document, main_uri: &Uri, span: Span) -> Option<Location> {
        let uri = self.uri_of(doc, main_uri, span.file)?;
        let li = LineIndex::new(doc.file_text(span.file));
        Some(Location { uri, range: li.range(span.start, span.end) })
    }
}

/// The thread warming glslang, joined before the process exits: glslang's static
/// destructors must not run while it compiles. The join is bounded: the compile
/// itself runs on glslang's own thread, which the warm-up waits for at most
/// `shaders::COMPILE_DEADLINE`.
static WARM_GLSL: Mutex<Option<std::thread::JoinHandle<()>>> = Mutex::new(None);

/// On a thread of its own, started with the process (before the client opens a
/// file): compiles a trivial shader, which initialises glslang, then checks the std
/// library's `shaders` (through the SPIR-V caches), so the first file importing it
/// finds them compiled.
pub fn warm_glsl(options: Options) {
    let spawned = std::thread::Builder::new().name("mdg-lsp glslang warm-up".into()).spawn(move || {
        let _ = guard(|| {
            mdg_compiler::shaders::compile_glsl("#version 450\nvoid main() { gl_Position = vec4(0.0); }\n", true)
        });
        if options.std_dir.as_ref().is_some_and(|d| d.join("shaders.mdg").is_file()) {
            let path = std::path::PathBuf::from("mdg-lsp-warm-up.mdg");
            let loader = mdg_compiler::source::MemLoader {
                files: [(path.clone(), "@import shaders\n".to_string())].into(),
                disk_fallback: true,
            };
            let check = mdg_compiler::check::CheckOptions { require_start: false };
            let _ = guard(|| mdg_compiler::driver::analyze(&loader, &path, &options, check));
        }
    });
    if let (Ok(handle), Ok(mut slot)) = (spawned, WARM_GLSL.lock()) {
        *slot = Some(handle);
    }
}

/// Waits for the glslang warm-up to finish (before `exit`).
pub fn join_warm_glsl() {
    let handle = WARM_GLSL.lock().ok().and_then(|mut s| s.take());
    if let Some(h) = handle {
        let _ = h.join();
    }
}
