//! The workspace index: every `.mdg` file under the workspace folders, analysed
//! as the compiler would see it (from disk, with the open documents' unsaved text
//! laid over it), and each file's import closure.
//!
//! The reverse `@import` graph is read off the closures: the importers of a file
//! are the indexed files whose closure holds it (transitively, since a closure is
//! everything that took part in the analysis). References, rename and workspace
//! symbols ask the analyses of those files; an edit re-analyses the closed
//! importers of the edited file so their diagnostics can be published.
//!
//! This module only keeps state and does IO-free bookkeeping plus the file walk;
//! the server drives it from [`crate::handlers::workspace`].

use crate::loader::OverlayLoader;
use mdg_compiler::analysis::Document;
use mdg_compiler::expand::Options;
use mdg_compiler::source::{normalize, FileLoader};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use tokio::sync::watch;

/// At most this many files are indexed (the walk stops there, and says so).
pub const MAX_FILES: usize = 5000;
/// Files larger than this are not indexed (they are still analysed when opened).
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// Directories the walk does not enter, besides hidden ones.
const SKIPPED_DIRS: &[&str] = &["node_modules", "target"];
/// At most this many directory entries (files and folders) are looked at by one
/// walk: a workspace folder of `/` or a home directory would otherwise be walked
/// whole before the first cross-file request is answered (`rootUri` `/` took 42 s).
pub const MAX_WALK_ENTRIES: usize = 40_000;
/// Folders deeper than this below a workspace folder are not entered.
pub const MAX_WALK_DEPTH: usize = 32;
/// Pseudo-filesystems (and runtime state) the walk never enters: their files are
/// not sources, and reading some of them blocks or never ends.
const PSEUDO_FS: &[&str] = &["/proc", "/sys", "/dev", "/run"];

/// What a walk found ([`scan`]).
#[derive(Debug, Default)]
pub struct Scan {
    /// The `.mdg` files, sorted.
    pub files: Vec<PathBuf>,
    /// Whether it stopped at [`MAX_FILES`] files.
    pub too_many_files: bool,
    /// Whether it stopped at [`MAX_WALK_ENTRIES`] entries.
    pub too_many_entries: bool,
    /// Whether folders deeper than [`MAX_WALK_DEPTH`] were left out.
    pub too_deep: bool,
}

impl Scan {
    /// Why the walk stopped early, in words; `None` if it did not.
    pub fn stopped(&self) -> Option<String> {
        let mut why = Vec::new();
        if self.too_many_files {
            why.push(format!("at {MAX_FILES} files"));
        }
        if self.too_many_entries {
            why.push(format!("after looking at {MAX_WALK_ENTRIES} files and folders"));
        }
        if self.too_deep {
            why.push(format!("at folders nested {MAX_WALK_DEPTH} deep"));
        }
        (!why.is_empty()).then(|| why.join(" and "))
    }
}

/// One indexed file.
pub struct Entry {
    /// Its analysis from disk (open documents overlaid) when it was last indexed.
    pub doc: Arc<Document>,
    /// The canonical paths of the other files of its analysis (its import closure).
    pub closure: BTreeSet<PathBuf>,
    /// Whether non-empty diagnostics were published for it as a closed file.
    pub published: bool,
}

#[derive(Default)]
struct State {
    roots: Vec<PathBuf>,
    files: BTreeMap<PathBuf, Entry>,
    /// Closed files waiting to be re-analysed, and whether a loop is draining them.
    pending: BTreeSet<PathBuf>,
    draining: bool,
}

/// The index, shared by the handlers.
pub struct Workspace {
    state: Mutex<State>,
    ready: watch::Sender<bool>,
    /// Whether the client registers file watchers on request.
    pub dynamic_watchers: AtomicBool,
}

impl Default for Workspace {
    fn default() -> Workspace {
        Workspace { state: Mutex::default(), ready: watch::channel(false).0, dynamic_watchers: AtomicBool::new(false) }
    }
}

/// A path in the form the index keys files by: canonical where the file (or, for a
/// deleted file, its directory) exists, else normalized.
pub fn canon(path: &Path) -> PathBuf {
    if let Ok(c) = std::fs::canonicalize(path) {
        return c;
    }
    match (path.parent().and_then(|p| std::fs::canonicalize(p).ok()), path.file_name()) {
        (Some(dir), Some(name)) => dir.join(name),
        _ => normalize(path),
    }
}

/// Whether a path names an MDG source file.
pub fn is_mdg(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "mdg")
}

/// The `.mdg` files under `roots`, sorted, at most [`MAX_FILES`]. The walk is
/// breadth-first (files near a folder's top first) and bounded: at most
/// [`MAX_WALK_ENTRIES`] entries looked at and [`MAX_WALK_DEPTH`] levels; hidden
/// directories, `node_modules`, `target` and pseudo-filesystems (`/proc`, `/sys`,
/// `/dev`, `/run`) are skipped and symbolic links to directories are not followed,
/// so the walk ends soon on any tree. [`Scan`] says where it stopped.
pub fn scan(roots: &[PathBuf]) -> Scan {
    scan_within(roots, MAX_WALK_ENTRIES)
}

/// [`scan`] with another entry bound.
pub fn scan_within(roots: &[PathBuf], max_entries: usize) -> Scan {
    let mut found = BTreeSet::new();
    let mut report = Scan::default();
    let mut queue: std::collections::VecDeque<(PathBuf, usize)> = roots.iter().map(|r| (r.clone(), 0)).collect();
    let mut entries = 0usize;
    'walk: while let Some((dir, depth)) = queue.pop_front() {
        if PSEUDO_FS.iter().any(|p| dir == Path::new(p)) {
            continue;
        }
        let Ok(rd) = std::fs::read_dir(&dir) else { continue };
        let mut list = Vec::new();
        for e in rd {
            entries += 1;
            if entries > max_entries {
                report.too_many_entries = true;
                break;
            }
            if let Ok(e) = e {
                list.push(e);
            }
        }
        list.sort_by_key(|e| e.file_name());
        for e in list {
            let Ok(ft) = e.file_type() else { continue };
            let name = e.file_name();
            let name = name.to_string_lossy();
            let path = e.path();
            if ft.is_dir() {
                if !name.starts_with('.') && !SKIPPED_DIRS.contains(&name.as_ref()) {
                    if depth + 1 > MAX_WALK_DEPTH {
                        report.too_deep = true;
                    } else {
                        queue.push_back((path, depth + 1));
                    }
                }
            } else if is_mdg(&path) && std::fs::metadata(&path).is_ok_and(|m| m.is_file() && m.len() <= MAX_FILE_BYTES)
            {
                if found.len() >= MAX_FILES {
                    report.too_many_files = true;
                    break 'walk;
                }
                found.insert(canon(&path));
            }
        }
        if report.too_many_entries {
            break;
        }
    }
    report.files = found.into_iter().collect();
    report
}

/// Analyses the file at `path` (through `loader`, so open documents shadow the
/// disk): its analysis and import closure, or `None` if it cannot be read or is too large.
pub fn analyze(path: &Path, loader: &OverlayLoader, options: &Options) -> Option<(Arc<Document>, BTreeSet<PathBuf>)> {
    if !loader.open.contains_key(path) && std::fs::metadata(path).map_or(true, |m| m.len() > MAX_FILE_BYTES) {
        return None;
    }
    let text = loader.read(path).ok()?;
    let doc = Document::new(loader, path, &text, options);
    let closure = closure_of(&doc);
    Some((Arc::new(doc), closure))
}

/// The canonical paths of the files an analysis read besides its own.
pub fn closure_of(doc: &Document) -> BTreeSet<PathBuf> {
    doc.files().iter().skip(1).filter_map(|f| doc.file_path(*f)).map(canon).collect()
}

impl Workspace {
    fn lock(&self) -> MutexGuard<'_, State> {
        // Every update is a single insertion or removal, so a poisoned lock still
        // guards a consistent state.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets the workspace folders.
    pub fn set_roots(&self, roots: Vec<PathBuf>) {
        self.lock().roots = roots;
    }

    /// The workspace folders.
    pub fn roots(&self) -> Vec<PathBuf> {
        self.lock().roots.clone()
    }

    /// Adds and removes workspace folders; removed folders' files leave the index
    /// (their paths are returned, so their diagnostics can be cleared).
    pub fn change_roots(&self, added: Vec<PathBuf>, removed: &[PathBuf]) -> Vec<(PathBuf, Entry)> {
        let mut st = self.lock();
        st.roots.retain(|r| !removed.contains(r));
        for a in added {
            if !st.roots.contains(&a) {
                st.roots.push(a);
            }
        }
        let roots = st.roots.clone();
        let gone: Vec<PathBuf> = st.files.keys().filter(|p| !roots.iter().any(|r| p.starts_with(r))).cloned().collect();
        gone.into_iter().filter_map(|p| st.files.remove(&p).map(|e| (p, e))).collect()
    }

    /// Whether `path` (canonical) lies in a workspace folder.
    pub fn in_roots(&self, path: &Path) -> bool {
        self.lock().roots.iter().any(|r| path.starts_with(r))
    }

    /// Marks the first indexing finished.
    pub fn set_ready(&self) {
        self.ready.send_replace(true);
    }

    /// Waits until the first indexing has finished.
    pub async fn wait_ready(&self) {
        let mut rx = self.ready.subscribe();
        // An error means the sender is gone, which cannot happen while `self` lives.
        let _ = rx.wait_for(|r| *r).await;
    }

    /// Stores a file's analysis, keeping its `published` flag; false if it was
    /// already indexed and `only_new` is set (the first indexing never overwrites
    /// a newer analysis made because of an edit).
    pub fn store(&self, path: PathBuf, doc: Arc<Document>, closure: BTreeSet<PathBuf>, only_new: bool) -> bool {
        let mut st = self.lock();
        let published = match st.files.get(&path) {
            Some(_) if only_new => return false,
            Some(e) => e.published,
            None => false,
        };
        st.files.insert(path, Entry { doc, closure, published });
        true
    }

    /// Records whether non-empty diagnostics are now shown for a closed file;
    /// returns whether they were before.
    pub fn set_published(&self, path: &Path, published: bool) -> bool {
        match self.lock().files.get_mut(path) {
            Some(e) => std::mem::replace(&mut e.published, published),
            None => false,
        }
    }

    /// Removes a file from the index.
    pub fn remove(&self, path: &Path) -> Option<Entry> {
        self.lock().files.remove(path)
    }

    /// Whether a file is indexed.
    pub fn contains(&self, path: &Path) -> bool {
        self.lock().files.contains_key(path)
    }

    /// The indexed files whose import closure holds one of `paths` (canonical): the
    /// reverse import graph, transitively.
    pub fn importers(&self, paths: &[PathBuf]) -> Vec<PathBuf> {
        self.lock()
            .files
            .iter()
            .filter(|(p, e)| !paths.contains(p) && paths.iter().any(|x| e.closure.contains(x)))
            .map(|(p, _)| p.clone())
            .collect()
    }

    /// The indexed files that are one of `paths` or import one of them, with their analyses.
    pub fn seeing(&self, paths: &BTreeSet<PathBuf>) -> Vec<(PathBuf, Arc<Document>)> {
        self.lock()
            .files
            .iter()
            .filter(|(p, e)| paths.contains(*p) || e.closure.iter().any(|x| paths.contains(x)))
            .map(|(p, e)| (p.clone(), e.doc.clone()))
            .collect()
    }

    /// Every indexed file with its analysis.
    pub fn all(&self) -> Vec<(PathBuf, Arc<Document>)> {
        self.lock().files.iter().map(|(p, e)| (p.clone(), e.doc.clone())).collect()
    }

    /// The indexed files whose analysis has errors (an import that did not resolve
    /// may resolve once a file is created).
    pub fn with_errors(&self) -> Vec<PathBuf> {
        self.lock().files.iter().filter(|(_, e)| e.doc.analysis().has_errors()).map(|(p, _)| p.clone()).collect()
    }

    /// Queues closed files for re-analysis; true if the caller must drain the queue
    /// (no loop is draining it yet).
    pub fn queue(&self, paths: impl IntoIterator<Item = PathBuf>) -> bool {
        let mut st = self.lock();
        st.pending.extend(paths);
        if st.draining || st.pending.is_empty() {
            return false;
        }
        st.draining = true;
        true
    }

    /// The next file to re-analyse; `None` ends the draining loop.
    pub fn next_pending(&self) -> Option<PathBuf> {
        let mut st = self.lock();
        let next = st.pending.pop_first();
        if next.is_none() {
            st.draining = false;
        }
        next
    }

    /// Whether the client registers watchers dynamically.
    pub fn dynamic_watchers(&self) -> bool {
        self.dynamic_watchers.load(Ordering::SeqCst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_walk_skips_hidden_and_build_folders_and_sorts() {
        let dir = std::env::temp_dir().join(format!("mdg-lsp-scan-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for d in ["lib", ".git", "node_modules/x", "target", "b"] {
            std::fs::create_dir_all(dir.join(d)).expect("dir");
        }
        for f in ["b/z.mdg", "a.mdg", "lib/l.mdg", ".git/h.mdg", "node_modules/x/n.mdg", "target/t.mdg", "notes.txt"] {
            std::fs::write(dir.join(f), "").expect("write");
        }
        let root = canon(&dir);
        let Scan { files, too_many_files: truncated, .. } = scan(std::slice::from_ref(&root));
        let rel: Vec<String> =
            files.iter().map(|p| p.strip_prefix(&root).expect("under root").display().to_string()).collect();
        assert_eq!(rel, ["a.mdg", "b/z.mdg", "lib/l.mdg"]);
        assert!(!truncated);
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// A huge root (`/`, a home directory) is walked only so far: 50,000 files in
    /// it, and the walk stops after MAX_WALK_ENTRIES of them and says so; files near
    /// the top are found first. `/proc`, `/sys` and `/dev` are never entered.
    #[test]
    fn the_walk_of_a_huge_root_is_bounded_and_says_so() {
        let dir = std::env::temp_dir().join(format!("mdg-lsp-huge-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for d in 0..50 {
            let sub = dir.join(format!("d{d:02}"));
            std::fs::create_dir_all(&sub).expect("dir");
            for f in 0..1000 {
                std::fs::File::create(sub.join(format!("f{f:04}.txt"))).expect("create");
            }
        }
        std::fs::write(dir.join("top.mdg"), "").expect("write");
        std::fs::write(dir.join("d49").join("deep.mdg"), "").expect("write");
        let root = canon(&dir);
        let s = scan(std::slice::from_ref(&root));
        assert!(s.too_many_entries && !s.too_many_files, "{s:?}");
        assert_eq!(s.files, [root.join("top.mdg")], "the file at the top is found, the one past the bound is not");
        assert!(s.stopped().is_some_and(|w| w.contains("40000 files and folders")), "{:?}", s.stopped());
        // Within a larger bound the whole tree is walked.
        let all = scan_within(std::slice::from_ref(&root), 60_000);
        assert!(!all.too_many_entries && all.stopped().is_none());
        assert_eq!(all.files.len(), 2);
        std::fs::remove_dir_all(&dir).expect("cleanup");
        // Pseudo-filesystems are skipped, even as a root.
        let pseudo = scan(&[PathBuf::from("/proc"), PathBuf::from("/sys"), PathBuf::from("/dev")]);
        assert!(pseudo.files.is_empty() && pseudo.stopped().is_none(), "{pseudo:?}");
    }

    #[test]
    fn closed_files_over_a_mebibyte_are_not_indexed() {
        let dir = std::env::temp_dir().join(format!("mdg-lsp-big-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        // Sparse files: one of exactly the limit, one a byte past it.
        for (name, len) in [("at.mdg", MAX_FILE_BYTES), ("over.mdg", MAX_FILE_BYTES + 1)] {
            std::fs::File::create(dir.join(name)).expect("create").set_len(len).expect("set_len");
        }
        let root = canon(&dir);
        let Scan { files, too_many_files: truncated, .. } = scan(std::slice::from_ref(&root));
        assert_eq!(files, [root.join("at.mdg")], "the larger file is left out of the walk");
        assert!(!truncated);
        let over = root.join("over.mdg");
        let closed = OverlayLoader::default();
        assert!(analyze(&over, &closed, &Options::default()).is_none(), "a closed large file is not analysed");
        // Opened, it is analysed (the editor's text, whatever the file's size).
        let mut open = OverlayLoader::default();
        open.open.insert(over.clone(), Arc::from("startshape A\nrule A { VERTEX {} }\n"));
        assert!(analyze(&over, &open, &Options::default()).is_some(), "an open document is analysed");
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn importers_come_from_the_closures() {
        let dir = std::env::temp_dir().join(format!("mdg-lsp-graph-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let dir = canon(&dir);
        std::fs::write(dir.join("lib.mdg"), "rule shape { VERTEX {} }\n").expect("write");
        std::fs::write(dir.join("mid.mdg"), "@import lib.mdg\nrule mid { shape {} }\n").expect("write");
        std::fs::write(dir.join("top.mdg"), "@import mid.mdg\nstartshape A\nrule A { mid {} }\n").expect("write");
        std::fs::write(dir.join("alone.mdg"), "startshape A\nrule A { VERTEX {} }\n").expect("write");
        let ws = Workspace::default();
        let loader = OverlayLoader::default();
        for name in ["lib.mdg", "mid.mdg", "top.mdg", "alone.mdg"] {
            let p = dir.join(name);
            let (doc, closure) = analyze(&p, &loader, &Options::default()).expect("analysed");
            assert!(ws.store(p, doc, closure, true));
        }
        let names = |v: Vec<PathBuf>| -> Vec<String> {
            v.iter().map(|p| p.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect()
        };
        assert_eq!(names(ws.importers(&[dir.join("lib.mdg")])), ["mid.mdg", "top.mdg"]);
        assert_eq!(names(ws.importers(&[dir.join("top.mdg")])), Vec::<String>::new());
        let seeing = ws.seeing(&BTreeSet::from([dir.join("mid.mdg")]));
        assert_eq!(names(seeing.into_iter().map(|(p, _)| p).collect()), ["mid.mdg", "top.mdg"]);
        // The first indexing does not overwrite; an edit's re-analysis does.
        let (doc, closure) = analyze(&dir.join("alone.mdg"), &loader, &Options::default()).expect("analysed");
        assert!(!ws.store(dir.join("alone.mdg"), doc.clone(), closure.clone(), true));
        assert!(ws.store(dir.join("alone.mdg"), doc, closure, false));
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn the_queue_has_one_drainer() {
        let ws = Workspace::default();
        assert!(!ws.queue(Vec::new()), "nothing to drain");
        assert!(ws.queue([PathBuf::from("/a.mdg")]));
        assert!(!ws.queue([PathBuf::from("/b.mdg"), PathBuf::from("/a.mdg")]), "the running loop takes them");
        assert_eq!(ws.next_pending(), Some(PathBuf::from("/a.mdg")));
        assert_eq!(ws.next_pending(), Some(PathBuf::from("/b.mdg")));
        assert_eq!(ws.next_pending(), None);
        assert!(ws.queue([PathBuf::from("/c.mdg")]), "a new loop starts");
    }
}
