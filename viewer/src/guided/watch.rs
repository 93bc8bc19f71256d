//! Watching a guide file (`mdg-view --guides FILE.json`): when it changes, it is
//! read and checked again on a background thread and the guides (or the reason they
//! cannot be used) are handed to the window. As for the grammar's files, the
//! directory is watched, so editors that save by renaming a new file over the old
//! one are seen.

use crate::reload::{normalise, WatchError};
use mdg_guided::{guides_from_json, Guide};
use mdg_vm::input::ReadError;
use notify::{RecursiveMode, Watcher as _};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

/// How long to wait for more events after the first (one save is several events).
const DEBOUNCE: Duration = Duration::from_millis(120);

/// Why a guide file's guides cannot be used; the message names the file.
#[derive(Debug)]
pub enum GuideFileError {
    /// The file could not be read.
    Read { path: PathBuf, error: ReadError },
    /// The file is not a valid guide file: why.
    Invalid { path: PathBuf, why: String },
}

impl std::fmt::Display for GuideFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GuideFileError::Read { path, error } => write!(f, "cannot read {}: {error}", path.display()),
            GuideFileError::Invalid { path, why } => write!(f, "{}: {why}", path.display()),
        }
    }
}

impl std::error::Error for GuideFileError {}

/// Reads and checks a guide file; the error's message starts with its path.
pub fn read_guides(path: &Path) -> Result<Vec<Guide>, GuideFileError> {
    let text = mdg_vm::input::read_text_bounded(path, mdg_vm::input::MAX_DATA_BYTES)
        .map_err(|error| GuideFileError::Read { path: path.to_path_buf(), error })?;
    guides_from_json(&text).map_err(|why| GuideFileError::Invalid { path: path.to_path_buf(), why: why.to_string() })
}

enum Msg {
    Fs(notify::Result<notify::Event>),
    Stop,
}

/// The running watcher; dropping it stops its thread.
pub struct GuideWatch {
    tx: mpsc::Sender<Msg>,
    thread: Option<JoinHandle<()>>,
}

impl GuideWatch {
    /// Watches `path`; `deliver` receives the guides read after each change (from
    /// the watcher's thread).
    pub fn start(
        path: PathBuf,
        deliver: impl Fn(Result<Vec<Guide>, GuideFileError>) + Send + 'static,
    ) -> Result<GuideWatch, WatchError> {
        let file = normalise(&path);
        let dir = file.parent().map(Path::to_path_buf).ok_or_else(|| WatchError::NoDirectory(path.clone()))?;
        let (tx, rx) = mpsc::channel::<Msg>();
        let fs_tx = tx.clone();
        let mut watcher = notify::recommended_watcher(move |ev| {
            let _ = fs_tx.send(Msg::Fs(ev));
        })
        .map_err(|error| WatchError::Watch { path: Some(path.clone()), error })?;
        watcher
            .watch(&dir, RecursiveMode::NonRecursive)
            .map_err(|error| WatchError::Watch { path: Some(dir.clone()), error })?;
        let thread = std::thread::Builder::new()
            .name("mdg-guides".into())
            .spawn(move || {
                // The watcher lives as long as the thread.
                let _watcher = watcher;
                let relevant = |m: &Msg| match m {
                    Msg::Fs(Ok(ev)) => {
                        !matches!(ev.kind, notify::EventKind::Access(_))
                            && ev.paths.iter().any(|p| normalise(p) == file)
                    }
                    _ => false,
                };
                while let Ok(msg) = rx.recv() {
                    if matches!(msg, Msg::Stop) {
                        return;
                    }
                    if !relevant(&msg) {
                        continue;
                    }
                    loop {
                        match rx.recv_timeout(DEBOUNCE) {
                            Ok(Msg::Stop) => return,
                            Ok(_) => continue,
                            Err(mpsc::RecvTimeoutError::Timeout) => break,
                            Err(mpsc::RecvTimeoutError::Disconnected) => return,
                        }
                    }
                    // A file removed mid-save comes back with the rename: only an
                    // existing file is read.
                    if file.exists() {
                        deliver(read_guides(&file));
                    }
                }
            })
            .map_err(|error| WatchError::Thread(crate::ThreadError { what: "the guide watcher".into(), error }))?;
        Ok(GuideWatch { tx, thread: Some(thread) })
    }
}

impl Drop for GuideWatch {
    fn drop(&mut self) {
        let _ = self.tx.send(Msg::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_changed_guide_file_is_read_again_and_a_broken_one_reported() {
        let dir = std::env::temp_dir().join(format!("mdg-guide-watch-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("mkdir");
        let file = dir.join("g.json");
        let one = r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]]}]}"#;
        std::fs::write(&file, one).expect("write");
        assert_eq!(read_guides(&file).expect("valid").len(), 1);
        let (tx, rx) = mpsc::channel();
        let w = GuideWatch::start(file.clone(), move |r| {
            let _ = tx.send(r);
        })
        .expect("watch");
        std::thread::sleep(Duration::from_millis(200));
        let two = r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]]}, {"points": [[1,0,0],[1,0,1],[1,0,2],[1,0,3]]}]}"#;
        std::fs::write(&file, two).expect("write");
        // Hang guards (60 s: the watcher polls, and a loaded machine is slow).
        let got = rx.recv_timeout(Duration::from_secs(60)).expect("an answer");
        assert_eq!(got.expect("valid").len(), 2);
        std::fs::write(&file, r#"{"guides": [{"points": [[0,0,0]]}]}"#).expect("write");
        let got = rx.recv_timeout(Duration::from_secs(60)).expect("an answer");
        let e = got.expect_err("too few points");
        assert!(matches!(&e, GuideFileError::Invalid { path, .. } if path.ends_with("g.json")), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("g.json") && e.contains("at least 4"), "{e}");
        let missing = dir.join("missing.json");
        assert!(matches!(read_guides(&missing), Err(GuideFileError::Read { error: ReadError::Io(_), .. })));
        drop(w);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
