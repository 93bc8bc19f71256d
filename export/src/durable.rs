//! Writes whose last step, flushing to disk and renaming into place, is left to the
//! caller ([`deferring`]): a batch that writes a file per seed (`mdg-run --seeds`)
//! flushes each one on its main thread while the workers evaluate the next seeds. The file appears under its name only once [`Pending::finish`] has
//! flushed it, so readers still see the old file or the whole new one.

use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// A file written into its temporary name, not yet flushed nor renamed.
#[derive(Debug)]
pub struct Pending {
    file: Option<std::fs::File>,
    tmp: PathBuf,
    path: PathBuf,
    dir: PathBuf,
}

impl Pending {
    /// The name the file will have.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Where the file is until it is finished (its temporary name): the bytes
    /// written, for reading back.
    pub fn written(&self) -> &Path {
        &self.tmp
    }

    /// Flushes the file to disk, renames it into place and makes the rename durable
    /// (what [`crate::write_atomic_with`] does at once when nothing defers it).
    pub fn finish(mut self) -> std::io::Result<()> {
        // (On an error `drop` removes the temporary file.)
        if let Some(f) = self.file.take() {
            f.sync_all()?;
        }
        std::fs::rename(&self.tmp, &self.path)?;
        self.tmp = PathBuf::new();
        crate::settle(&self.dir, &self.path);
        Ok(())
    }
}

impl Drop for Pending {
    /// A write never finished leaves nothing behind.
    fn drop(&mut self) {
        if !self.tmp.as_os_str().is_empty() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

thread_local! {
    static DEFERRED: RefCell<Option<Vec<Pending>>> = const { RefCell::new(None) };
}

/// Runs `f` with this thread's atomic writes ([`crate::write_atomic_with`]) left
/// pending: each file is written into its temporary name and handed back, in the
/// order written, to be [`Pending::finish`]ed (or dropped: then it is removed).
pub fn deferring<R>(f: impl FnOnce() -> R) -> (R, Vec<Pending>) {
    let outer = DEFERRED.with(|d| d.borrow_mut().replace(Vec::new()));
    let r = f();
    let pending = DEFERRED.with(|d| std::mem::replace(&mut *d.borrow_mut(), outer)).unwrap_or_default();
    (r, pending)
}

/// Keeps the write of `tmp` (complete, `file` still open) as pending when this
/// thread defers its writes; otherwise hands `file` back.
pub(crate) fn defer(file: std::fs::File, tmp: &Path, path: &Path, dir: &Path) -> Option<std::fs::File> {
    DEFERRED.with(|d| match d.borrow_mut().as_mut() {
        Some(list) => {
            list.push(Pending {
                file: Some(file),
                tmp: tmp.to_path_buf(),
                path: path.to_path_buf(),
                dir: dir.to_path_buf(),
            });
            None
        }
        None => Some(file),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deferred_writes_appear_when_finished_and_vanish_when_dropped() {
        let dir = std::env::temp_dir().join(format!("mdg-durable-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch");
        let (a, b) = (dir.join("a.txt"), dir.join("b.txt"));
        std::fs::write(&a, "old").expect("old a");
        let (r, pending) =
            deferring(|| crate::write_atomic(&a, b"new a").and_then(|()| crate::write_atomic(&b, b"new b")));
        assert!(r.is_ok());
        assert_eq!(pending.iter().map(Pending::path).collect::<Vec<_>>(), [a.as_path(), b.as_path()]);
        // Nothing moved yet: the old `a`, no `b`; two temporary files.
        assert_eq!(std::fs::read_to_string(&a).expect("a"), "old");
        assert!(!b.exists());
        assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 3);
        let mut pending = pending.into_iter();
        pending.next().expect("a").finish().expect("finish a");
        assert_eq!(std::fs::read_to_string(&a).expect("a"), "new a");
        drop(pending);
        assert!(!b.exists());
        let left: Vec<_> = std::fs::read_dir(&dir).expect("dir").flatten().map(|e| e.file_name()).collect();
        assert_eq!(left, ["a.txt"], "the dropped write leaves no temporary file");
        // Outside `deferring`, writes finish at once.
        crate::write_atomic(&b, b"now").expect("b");
        assert_eq!(std::fs::read_to_string(&b).expect("b"), "now");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
