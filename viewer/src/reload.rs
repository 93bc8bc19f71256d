//! Hot reload: watches the grammar and every file it imports (notify), recompiles
//! and re-evaluates on a worker thread when one changes, and hands the result to the
//! window. A failed compile is reported with its diagnostics; the window keeps the
//! last good model.
//!
//! Directories are watched rather than files, because editors often save by writing
//! a new file and renaming it over the old one, which ends a watch on the file.

use crate::model::{LoadOptions, Loader, Model};
use notify::{RecursiveMode, Watcher as _};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

/// Why files are not watched.
#[derive(Debug)]
pub enum WatchError {
    /// The system's watcher could not be made or set on `path` (`None`: on the
    /// grammar's files).
    Watch { path: Option<PathBuf>, error: notify::Error },
    /// The path has no directory to watch.
    NoDirectory(PathBuf),
    /// The watching thread did not start.
    Thread(crate::ThreadError),
}

impl std::fmt::Display for WatchError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WatchError::Watch { path: None, error } => write!(f, "cannot watch files: {error}"),
            WatchError::Watch { path: Some(p), error } => write!(f, "cannot watch {}: {error}", p.display()),
            WatchError::NoDirectory(p) => write!(f, "{}: no directory", p.display()),
            WatchError::Thread(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for WatchError {}

/// What a reload produced.
pub enum Reloaded {
    Model(Box<Model>),
    /// Rendered diagnostics (or another error message).
    Failed(String),
}

enum Msg {
    Fs(notify::Result<notify::Event>),
    /// New load options (a `@param` changed in the window).
    Options(LoadOptions),
    Stop,
}

/// The running watcher; dropping it stops the worker thread.
pub struct ReloadHandle {
    tx: mpsc::Sender<Msg>,
    thread: Option<JoinHandle<()>>,
}

/// `dir/name` with the directory canonicalised (the file itself may be gone
/// mid-save).
pub(crate) fn normalise(p: &Path) -> PathBuf {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    match (abs.parent(), abs.file_name()) {
        (Some(dir), Some(name)) => dir.canonicalize().map(|d| d.join(name)).unwrap_or(abs),
        _ => abs,
    }
}

/// How long to wait for more events after the first (one save is several events).
const DEBOUNCE: Duration = Duration::from_millis(120);

impl ReloadHandle {
    /// Starts watching `files` (the main file first) and reloading `path` on change;
    /// `deliver` receives each result (from the worker thread).
    pub fn start(
        path: PathBuf,
        files: Vec<PathBuf>,
        mut opts: LoadOptions,
        loader: Arc<dyn Loader>,
        deliver: impl Fn(Reloaded) + Send + 'static,
    ) -> Result<ReloadHandle, WatchError> {
        let (tx, rx) = mpsc::channel::<Msg>();
        let fs_tx = tx.clone();
        let mut watcher = notify::recommended_watcher(move |ev| {
            let _ = fs_tx.send(Msg::Fs(ev));
        })
        .map_err(|error| WatchError::Watch { path: None, error })?;
        let mut watched_dirs: BTreeSet<PathBuf> = BTreeSet::new();
        let mut files: BTreeSet<PathBuf> = files.iter().chain(std::iter::once(&path)).map(|f| normalise(f)).collect();
        let watch =
            |watcher: &mut notify::RecommendedWatcher, files: &BTreeSet<PathBuf>, dirs: &mut BTreeSet<PathBuf>| {
                let want: BTreeSet<PathBuf> = files.iter().filter_map(|f| f.parent().map(Path::to_path_buf)).collect();
                for d in dirs.difference(&want).cloned().collect::<Vec<_>>() {
                    let _ = watcher.unwatch(&d);
                    dirs.remove(&d);
                }
                for d in want {
                    if !dirs.contains(&d) && watcher.watch(&d, RecursiveMode::NonRecursive).is_ok() {
                        dirs.insert(d);
                    }
                }
            };
        watch(&mut watcher, &files, &mut watched_dirs);
        let thread = std::thread::Builder::new()
            .name("mdg-reload".into())
            .spawn(move || {
                let relevant = |files: &BTreeSet<PathBuf>, m: &Msg| match m {
                    Msg::Fs(Ok(ev)) => {
                        !matches!(ev.kind, notify::EventKind::Access(_))
                            && ev.paths.iter().any(|p| files.contains(&normalise(p)))
                    }
                    _ => false,
                };
                while let Ok(msg) = rx.recv() {
                    let msg = match msg {
                        Msg::Stop => return,
                        Msg::Options(o) => {
                            opts = o;
                            continue;
                        }
                        m => m,
                    };
                    if !relevant(&files, &msg) {
                        continue;
                    }
                    // Let the save finish: swallow events until quiet.
                    loop {
                        match rx.recv_timeout(DEBOUNCE) {
                            Ok(Msg::Stop) => return,
                            Ok(Msg::Options(o)) => opts = o,
                            Ok(_) => continue,
                            Err(mpsc::RecvTimeoutError::Timeout) => break,
                            Err(mpsc::RecvTimeoutError::Disconnected) => return,
                        }
                    }
                    let (result, new_files) = match loader.load(&path, &opts) {
                        Ok((m, f)) => (Reloaded::Model(Box::new(m)), f),
                        Err(fail) => (Reloaded::Failed(fail.error.to_string()), fail.files),
                    };
                    files = new_files.iter().chain(std::iter::once(&path)).map(|f| normalise(f)).collect();
                    watch(&mut watcher, &files, &mut watched_dirs);
                    deliver(result);
                }
            })
            .map_err(|error| WatchError::Thread(crate::ThreadError { what: "the reload thread".into(), error }))?;
        Ok(ReloadHandle { tx, thread: Some(thread) })
    }
}

impl ReloadHandle {
    /// Reloads with these options from now on.
    pub fn set_options(&self, opts: LoadOptions) {
        let _ = self.tx.send(Msg::Options(opts));
    }
}

impl Drop for ReloadHandle {
    fn drop(&mut self) {
        let _ = self.tx.send(Msg::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
