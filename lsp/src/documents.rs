//! The open documents, under one lock: text, version and the latest analysis.
//!
//! Handlers run concurrently, so edits are applied here in the order they are
//! accepted and each carries its version: a change whose version is not newer than
//! the document's is stale and dropped, and an analysis is stored (and its
//! diagnostics published) only if the document still has the version it analysed.

use crate::loader::OverlayLoader;
use crate::position::LineIndex;
use mdg_compiler::analysis::Document;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use tower_lsp_server::ls_types::{TextDocumentContentChangeEvent, Uri};

/// One open document.
pub struct DocState {
    pub version: i32,
    pub text: Arc<str>,
    pub path: PathBuf,
    /// `path` in the workspace index's form ([`crate::workspace::canon`]).
    pub canon: PathBuf,
    /// The latest analysis and the version it analysed.
    pub analysis: Option<(i32, Arc<Document>)>,
    /// Whether an analysis loop is running for this document (at most one is).
    pub analyzing: bool,
    /// Whether the running loop must analyse once more although the version is the
    /// same (a file it imports changed meanwhile).
    pub again: bool,
    /// Counts what makes an analysis outdated (an edit, a changed import, closing):
    /// a running analysis whose snapshot saw an older count gives up.
    pub generation: Arc<AtomicU64>,
    /// An analysis without compiled shaders ([`Documents::quick`]) and the
    /// generation it analysed: what requests use while the full one is running.
    pub quick: Option<(u64, Arc<Document>)>,
    /// The size of a text too large to be passed on ([`crate::transport`]): `text`
    /// is then empty and stands for nothing.
    pub oversized: Option<usize>,
}

/// What an analysis of one version needs, taken under the lock.
pub struct Snapshot {
    pub version: i32,
    /// The document's generation when the snapshot was taken, and the counter.
    pub generation: u64,
    pub counter: Arc<AtomicU64>,
    pub path: PathBuf,
    pub text: Arc<str>,
    /// The text's size in bytes (for a document whose text was not passed on, the
    /// size of the message that carried it).
    pub size: usize,
    /// Every open document, for imports of unsaved files.
    pub loader: OverlayLoader,
    /// The document's latest analysis (of any version): the parts of the text an
    /// edit left alone are not parsed again.
    pub previous: Option<Arc<Document>>,
}

impl Snapshot {
    /// Whether the document has changed since the snapshot (or was closed), so that
    /// an analysis of it is no longer wanted.
    pub fn outdated(&self) -> bool {
        self.counter.load(Ordering::SeqCst) != self.generation
    }
}

/// All open documents.
#[derive(Default)]
pub struct Documents {
    map: Mutex<HashMap<Uri, DocState>>,
}

/// The file path a document URI stands for (a made-up one for `untitled:` and
/// other non-file URIs, so relative imports simply fail to resolve).
pub fn path_of(uri: &Uri) -> PathBuf {
    if uri.scheme().as_str().eq_ignore_ascii_case("file") {
        if let Some(p) = uri.to_file_path() {
            return p.into_owned();
        }
    }
    let name: String =
        uri.as_str().chars().map(|c| if c.is_ascii_alphanumeric() || c == '.' { c } else { '_' }).collect();
    PathBuf::from("/untitled").join(name)
}

/// Whether a document's latest analysis read the file at `path` (or `canon`) besides its own.
fn reads(d: &DocState, path: &Path, canon: &Path) -> bool {
    d.analysis.as_ref().is_some_and(|(_, a)| {
        a.files().iter().skip(1).any(|f| a.file_path(*f).is_some_and(|p| p == path || p == canon))
    })
}

/// The open documents as a loader.
fn overlay(map: &HashMap<Uri, DocState>) -> OverlayLoader {
    let mut loader = OverlayLoader::default();
    // A document whose text was not passed on is read from disk by its importers.
    for d in map.values().filter(|d| d.oversized.is_none()) {
        loader.insert(&d.path, d.text.clone());
    }
    loader
}

impl Documents {
    fn lock(&self) -> MutexGuard<'_, HashMap<Uri, DocState>> {
        // A panic never happens while the lock is held, but if one did the map is
        // still consistent: every update is a single assignment.
        self.map.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Opens (or reopens) a document; `oversized` is the size of a text that was
    /// not passed on (`text` is then empty).
    pub fn open(&self, uri: Uri, version: i32, text: String, oversized: Option<usize>) {
        let path = path_of(&uri);
        let canon = crate::workspace::canon(&path);
        self.lock().insert(
            uri,
            DocState {
                version,
                text: Arc::from(text),
                path,
                canon,
                analysis: None,
                analyzing: false,
                again: false,
                generation: Arc::default(),
                quick: None,
                oversized,
            },
        );
    }

    /// Closes a document (its running analyses give up).
    pub fn close(&self, uri: &Uri) {
        if let Some(d) = self.lock().remove(uri) {
            d.generation.fetch_add(1, Ordering::SeqCst);
        }
    }

    /// Applies changes that bring a document to `version`. Errors if the document is
    /// not open or the version is not newer (a stale or reordered notification).
    /// `oversized`: as for [`Documents::open`].
    pub fn change(
        &self,
        uri: &Uri,
        version: i32,
        changes: Vec<TextDocumentContentChangeEvent>,
        oversized: Option<usize>,
    ) -> Result<(), String> {
        let mut map = self.lock();
        let doc = map.get_mut(uri).ok_or_else(|| format!("change to a document that is not open: {}", uri.as_str()))?;
        if version <= doc.version {
            return Err(format!("stale change to {} (version {version}, have {})", uri.as_str(), doc.version));
        }
        let mut text: String = doc.text.to_string();
        for c in changes {
            match c.range {
                None => text = c.text,
                Some(r) => {
                    let li = LineIndex::new(&text);
                    let (s, e) = (li.offset(r.start) as usize, li.offset(r.end) as usize);
                    let (s, e) = (s.min(e), e.max(s));
                    text.replace_range(s..e, &c.text);
                }
            }
        }
        doc.text = Arc::from(text);
        doc.oversized = oversized;
        doc.version = version;
        doc.generation.fetch_add(1, Ordering::SeqCst);
        Ok(())
    }

    /// What analysing the current version of `uri` needs.
    pub fn snapshot(&self, uri: &Uri) -> Option<Snapshot> {
        let map = self.lock();
        let doc = map.get(uri)?;
        let loader = overlay(&map);
        Some(Snapshot {
            version: doc.version,
            generation: doc.generation.load(Ordering::SeqCst),
            counter: doc.generation.clone(),
            path: doc.path.clone(),
            text: doc.text.clone(),
            size: doc.oversized.unwrap_or(doc.text.len()),
            loader,
            previous: doc
                .quick
                .as_ref()
                .map(|(_, a)| a.clone())
                .or_else(|| doc.analysis.as_ref().map(|(_, a)| a.clone())),
        })
    }

    /// A loader that reads the open documents' text before the disk.
    pub fn overlay(&self) -> OverlayLoader {
        overlay(&self.lock())
    }

    /// Every open document's URI and canonical path.
    pub fn open_documents(&self) -> Vec<(Uri, PathBuf)> {
        let mut v: Vec<(Uri, PathBuf)> = self.lock().iter().map(|(u, d)| (u.clone(), d.canon.clone())).collect();
        v.sort_by(|a, b| a.0.as_str().cmp(b.0.as_str()));
        v
    }

    /// The URI of the open document whose canonical path is `canon`.
    pub fn uri_of_canon(&self, canon: &Path) -> Option<Uri> {
        self.lock().iter().find(|(_, d)| d.canon == canon).map(|(u, _)| u.clone())
    }

    /// The current version of `uri`, if it is open.
    #[cfg(test)]
    pub fn version(&self, uri: &Uri) -> Option<i32> {
        self.lock().get(uri).map(|d| d.version)
    }

    /// The current text of `uri` (`None` for a text that was not passed on).
    pub fn text(&self, uri: &Uri) -> Option<Arc<str>> {
        self.lock().get(uri).filter(|d| d.oversized.is_none()).map(|d| d.text.clone())
    }

    /// Claims the document's analysis loop: false if one is already running (it
    /// will analyse once more, with the newest text of the document and its imports,
    /// before it stops).
    pub fn begin_analysis(&self, uri: &Uri) -> bool {
        match self.lock().get_mut(uri) {
            Some(d) if !d.analyzing => {
                d.analyzing = true;
                true
            }
            Some(d) => {
                d.again = true;
                // What the running analysis read has changed: it gives up.
                d.generation.fetch_add(1, Ordering::SeqCst);
                false
            }
            None => false,
        }
    }

    /// Ends the analysis loop if `version` is still the newest and nothing it read
    /// changed meanwhile (or the document was closed); false means the loop must go on.
    pub fn end_analysis(&self, uri: &Uri, version: i32) -> bool {
        match self.lock().get_mut(uri) {
            Some(d) if d.version != version || d.again => {
                d.again = false;
                false
            }
            Some(d) => {
                d.analyzing = false;
                true
            }
            None => true,
        }
    }

    /// Stores the analysis of `version`; false (and nothing stored) if the document
    /// has moved on or was closed.
    pub fn store(&self, uri: &Uri, version: i32, analysis: Arc<Document>) -> bool {
        match self.lock().get_mut(uri) {
            Some(d) if d.version == version => {
                d.analysis = Some((version, analysis));
                // The full analysis replaces the quick one.
                d.quick = None;
                true
            }
            _ => false,
        }
    }

    /// The analysis of the current version, if there is one.
    pub fn current_analysis(&self, uri: &Uri) -> Option<Arc<Document>> {
        let map = self.lock();
        let d = map.get(uri)?;
        match &d.analysis {
            Some((v, a)) if *v == d.version => Some(a.clone()),
            _ => None,
        }
    }

    /// Whether the document's latest full analysis (of any version) had GLSL
    /// diagnostics (E0501, E0502).
    pub fn last_had_glsl_diagnostics(&self, uri: &Uri) -> bool {
        self.lock()
            .get(uri)
            .and_then(|d| d.analysis.as_ref())
            .is_some_and(|(_, a)| a.analysis().diagnostics.iter().any(|d| d.code == "E0501" || d.code == "E0502"))
    }

    /// The analysis without compiled shaders of the current text, if there is one.
    pub fn quick(&self, uri: &Uri) -> Option<Arc<Document>> {
        let map = self.lock();
        let d = map.get(uri)?;
        match &d.quick {
            Some((g, a)) if *g == d.generation.load(Ordering::SeqCst) => Some(a.clone()),
            _ => None,
        }
    }

    /// Stores an analysis without compiled shaders of the snapshot `snap`; false if
    /// the document has changed since.
    pub fn store_quick(&self, uri: &Uri, snap: &Snapshot, analysis: Arc<Document>) -> bool {
        match self.lock().get_mut(uri) {
            Some(d) if d.generation.load(Ordering::SeqCst) == snap.generation => {
                d.quick = Some((snap.generation, analysis));
                true
            }
            _ => false,
        }
    }

    /// Open documents other than `uri` whose latest analysis read the file at `path`.
    pub fn dependents(&self, uri: &Uri, path: &Path) -> Vec<Uri> {
        let canon = crate::workspace::canon(path);
        let map = self.lock();
        map.iter().filter(|(u, d)| *u != uri && reads(d, path, &canon)).map(|(u, _)| u.clone()).collect()
    }

    /// Whether the latest analysis of `uri` read the file at `canon` (besides its own).
    pub fn reads(&self, uri: &Uri, canon: &Path) -> bool {
        self.lock().get(uri).is_some_and(|d| reads(d, canon, canon))
    }

    /// The URI of the open document at `path`, if any.
    pub fn uri_of(&self, path: &Path) -> Option<Uri> {
        self.lock().iter().find(|(_, d)| d.path == path).map(|(u, _)| u.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::str::FromStr;
    use tower_lsp_server::ls_types::{Position, Range};

    fn uri() -> Uri {
        Uri::from_str("file:///tmp/x.mdg").expect("uri")
    }

    fn change(range: Option<((u32, u32), (u32, u32))>, text: &str) -> TextDocumentContentChangeEvent {
        TextDocumentContentChangeEvent {
            range: range.map(|((a, b), (c, d))| Range {
                start: Position { line: a, character: b },
                end: Position { line: c, character: d },
            }),
            range_length: None,
            text: text.to_string(),
        }
    }

    #[test]
    fn changes_apply_in_order_and_stale_ones_are_dropped() {
        let docs = Documents::default();
        docs.open(uri(), 1, "rule A {}\n".to_string(), None);
        docs.change(
            &uri(),
            2,
            vec![change(Some(((0, 5), (0, 6))), "B"), change(Some(((1, 0), (1, 0))), "// é\n")],
            None,
        )
        .expect("v2");
        assert_eq!(docs.text(&uri()).as_deref(), Some("rule B {}\n// é\n"));
        assert!(docs.change(&uri(), 2, vec![change(None, "old")], None).is_err());
        assert!(docs.change(&uri(), 1, vec![change(None, "older")], None).is_err());
        docs.change(&uri(), 5, vec![change(None, "new")], None).expect("v5");
        assert_eq!((docs.text(&uri()).as_deref(), docs.version(&uri())), (Some("new"), Some(5)));
    }

    #[test]
    fn analyses_are_stored_only_for_the_current_version() {
        let docs = Documents::default();
        docs.open(uri(), 1, "rule A { VERTEX {} }".to_string(), None);
        let snap = docs.snapshot(&uri()).expect("open");
        let doc = Arc::new(Document::new(&snap.loader, &snap.path, &snap.text, &Default::default()));
        docs.change(&uri(), 2, vec![change(None, "rule A { }")], None).expect("v2");
        assert!(!docs.store(&uri(), 1, doc.clone()));
        assert!(docs.current_analysis(&uri()).is_none());
        assert!(docs.store(&uri(), 2, doc));
        assert!(docs.current_analysis(&uri()).is_some());
    }

    #[test]
    fn one_analysis_loop_per_document() {
        let docs = Documents::default();
        docs.open(uri(), 1, String::new(), None);
        assert!(docs.begin_analysis(&uri()));
        assert!(!docs.begin_analysis(&uri()), "a second loop is refused");
        docs.change(&uri(), 2, vec![change(None, "x")], None).expect("v2");
        assert!(!docs.end_analysis(&uri(), 1), "version 2 still needs analysing");
        assert!(docs.end_analysis(&uri(), 2));
        assert!(docs.begin_analysis(&uri()));
        // A refused refresh (an import changed) makes the running loop go round once more.
        assert!(!docs.begin_analysis(&uri()));
        assert!(!docs.end_analysis(&uri(), 2), "once more for the changed import");
        assert!(docs.end_analysis(&uri(), 2));
    }

    #[test]
    fn an_edit_a_changed_import_or_closing_outdates_a_snapshot() {
        let docs = Documents::default();
        docs.open(uri(), 1, "rule A {}".to_string(), None);
        let snap = docs.snapshot(&uri()).expect("open");
        assert!(!snap.outdated());
        docs.change(&uri(), 2, vec![change(None, "rule B {}")], None).expect("v2");
        assert!(snap.outdated(), "an edit");
        // A file it imports changed while its analysis runs (the refresh is refused).
        let snap = docs.snapshot(&uri()).expect("open");
        assert!(docs.begin_analysis(&uri()));
        assert!(!snap.outdated(), "starting the analysis changes nothing");
        assert!(!docs.begin_analysis(&uri()));
        assert!(snap.outdated(), "a changed import");
        let snap = docs.snapshot(&uri()).expect("open");
        docs.close(&uri());
        assert!(snap.outdated(), "closing");
        // A quick analysis is kept only for the text it analysed.
        docs.open(uri(), 1, "rule A { VERTEX {} }".to_string(), None);
        let snap = docs.snapshot(&uri()).expect("open");
        let doc = Arc::new(Document::new(&snap.loader, &snap.path, &snap.text, &Default::default()));
        assert!(docs.store_quick(&uri(), &snap, doc.clone()));
        assert!(docs.quick(&uri()).is_some());
        docs.change(&uri(), 2, vec![change(None, "rule A { }")], None).expect("v2");
        assert!(docs.quick(&uri()).is_none(), "the edit outdates it");
        assert!(!docs.store_quick(&uri(), &snap, doc), "an outdated one is not stored");
    }

    #[test]
    fn untitled_documents_get_a_path() {
        let u = Uri::from_str("untitled:Untitled-1").expect("uri");
        assert_eq!(path_of(&u), PathBuf::from("/untitled/untitled_Untitled_1"));
        assert_eq!(path_of(&uri()), PathBuf::from("/tmp/x.mdg"));
    }
}
