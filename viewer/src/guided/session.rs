//! A guided-search session: the editor's guides, the grammar they steer, the seed,
//! and the searches in flight. The window asks for a search after every change
//! ([`Session::request`]), passes each answer back ([`Session::accept`]) and shows
//! what is accepted; the session keeps track of which answer is the newest, so an
//! older search never replaces a newer one on screen.

use super::edit::Editor;
use super::search::{run_search, SearchError, SearchRequest, Searched, Summary, Timings};
use super::worker::{Preempt, Worker};
use mdg_guided::measure::Reach;
use mdg_guided::{Cancel, Guide, GuidedTable, Utilisation};
use mdg_vm::bundle::{Bundle, Section as _};
use mdg_vm::eval::EvalOptions;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

/// A search's answer: `None` when it was replaced or cancelled before it finished.
pub type Outcome = Option<Result<Searched, SearchError>>;

/// Why a session did not start, or did not save.
#[derive(Debug)]
pub enum SessionError {
    /// The grammar cannot be searched.
    Search(SearchError),
    /// The search thread did not start.
    Thread(crate::ThreadError),
    /// The guide file could not be written.
    Write { path: PathBuf, error: std::io::Error },
}

impl std::fmt::Display for SessionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SessionError::Search(e) => write!(f, "{e}"),
            SessionError::Thread(e) => write!(f, "{e}"),
            SessionError::Write { path, error } => write!(f, "cannot write {}: {error}", path.display()),
        }
    }
}

impl std::error::Error for SessionError {}

/// Where the guides came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GuideSource {
    /// The grammar's `guide` sections (a hot reload takes the new ones, unless
    /// they were edited in the window).
    Grammar,
    /// A guide file (watched: a change replaces them).
    File(PathBuf),
}

/// How a session starts.
#[derive(Clone, Debug)]
pub struct SessionOptions {
    /// The seed (`--seed`, else the grammar's `randseed`).
    pub seed: u64,
    /// The geometry phase's limits.
    pub eval: EvalOptions,
    /// Guides from a file (`--guides`) instead of the grammar's.
    pub guides: Option<(PathBuf, Vec<Guide>)>,
    /// Where `S` saves the guides.
    pub save_to: PathBuf,
}

/// What the window should do with an answer.
pub enum Accepted {
    /// Show this model: it is newer than the one on screen.
    Show(Box<Searched>),
    /// The newest search failed: say why and keep the model.
    Failed(SearchError),
    /// Nothing to show (replaced, cancelled, or older than the one on screen).
    Nothing,
}

/// The session.
pub struct Session {
    pub editor: Editor,
    bundle: Arc<Bundle>,
    seed: u64,
    /// The utilisation term chosen with `L` (`None`: the `search` section's).
    utilisation: Option<Utilisation>,
    /// The bundle's reach, once a search has estimated it.
    reach: Arc<OnceLock<Reach>>,
    eval: EvalOptions,
    source: GuideSource,
    /// The editor's revision when its guides last matched the source.
    source_revision: u64,
    save_to: PathBuf,
    worker: Worker<SearchRequest, Result<Searched, SearchError>>,
    /// Requests not answered yet.
    outstanding: BTreeSet<u64>,
    /// The newest request, and the editor revision it searched.
    requested: u64,
    requested_revision: u64,
    /// The request whose model is on screen.
    shown: u64,
    /// What the model on screen is and how long its search took.
    pub summary: Option<Summary>,
    pub timings: Timings,
}

impl Session {
    /// A session on `bundle` (which has a `search` section). `deliver` receives
    /// every search's id and answer from the search thread; the window hands them
    /// back to [`Session::accept`].
    pub fn start(
        bundle: Arc<Bundle>,
        opts: SessionOptions,
        deliver: impl Fn(u64, Outcome) + Send + Sync + 'static,
    ) -> Result<Session, SessionError> {
        let table = GuidedTable::from_bundle(&bundle)
            .map_err(|e| SessionError::Search(SearchError::Section(e)))?
            .ok_or(SessionError::Search(SearchError::NoSection))?;
        let (guides, source) = match opts.guides {
            Some((path, guides)) => (guides, GuideSource::File(path)),
            None => (table.guides.clone(), GuideSource::Grammar),
        };
        let worker =
            Worker::start("mdg-search", |req: SearchRequest, cancel: &Cancel| guarded_search(&req, cancel), deliver)
                .map_err(SessionError::Thread)?;
        Ok(Session {
            editor: Editor::new(guides),
            bundle,
            seed: opts.seed,
            utilisation: None,
            reach: Arc::default(),
            eval: opts.eval,
            source,
            source_revision: 0,
            save_to: opts.save_to,
            worker,
            outstanding: BTreeSet::new(),
            requested: 0,
            requested_revision: 0,
            shown: 0,
            summary: None,
            timings: Timings::default(),
        })
    }

    fn request_now(&self) -> SearchRequest {
        SearchRequest {
            bundle: self.bundle.clone(),
            guides: self.editor.guides().to_vec(),
            seed: self.seed,
            eval: self.eval.clone(),
            utilisation: self.utilisation,
            reach: self.reach.clone(),
        }
    }

    /// Searches the current guides on this thread (the first model, before the
    /// window opens, and `mdg-view --png`).
    pub fn search_now(&mut self) -> Result<Searched, SearchError> {
        let s = guarded_search(&self.request_now(), &Cancel::new())?;
        self.summary = Some(s.summary.clone());
        self.timings = s.timings;
        self.requested_revision = self.editor.revision();
        Ok(s)
    }

    /// Asks for a search of the current guides. `Preempt::Wait` lets a running
    /// search finish first (while a point is dragged), `Preempt::Cancel` stops it.
    pub fn request(&mut self, preempt: Preempt) {
        let id = self.worker.submit(self.request_now(), preempt);
        self.outstanding.insert(id);
        self.requested = id;
        self.requested_revision = self.editor.revision();
    }

    /// Asks for a search if the guides changed since the last one.
    pub fn request_if_changed(&mut self, preempt: Preempt) -> bool {
        if self.editor.revision() == self.requested_revision {
            return false;
        }
        self.request(preempt);
        true
    }

    /// Takes a search's answer: what to show, if anything.
    pub fn accept(&mut self, id: u64, outcome: Outcome) -> Accepted {
        self.outstanding.remove(&id);
        match outcome {
            Some(Ok(s)) if id > self.shown => {
                self.shown = id;
                self.summary = Some(s.summary.clone());
                self.timings = s.timings;
                Accepted::Show(Box::new(s))
            }
            Some(Err(e)) if id == self.requested => Accepted::Failed(e),
            _ => Accepted::Nothing,
        }
    }

    /// Whether every search asked for has answered.
    pub fn is_idle(&self) -> bool {
        self.outstanding.is_empty()
    }

    /// Whether the guides differ from where they came from (the grammar or the file).
    pub fn is_edited(&self) -> bool {
        self.editor.revision() != self.source_revision
    }

    /// The grammar was compiled again: search with it from now on. Guides from the
    /// grammar that were not edited in the window become the new grammar's.
    pub fn set_bundle(&mut self, bundle: Arc<Bundle>) {
        if self.source == GuideSource::Grammar && !self.is_edited() {
            if let Ok(Some(t)) = GuidedTable::from_bundle(&bundle) {
                if self.editor.replace(t.guides.clone()) {
                    self.source_revision = self.editor.revision();
                }
            }
        }
        self.bundle = bundle;
        self.reach = Arc::default();
    }

    /// The guide file changed: take its guides (undoable). Returns whether they
    /// differ from the editor's.
    pub fn file_changed(&mut self, guides: Vec<Guide>) -> bool {
        let changed = self.editor.replace(guides);
        self.source_revision = self.editor.revision();
        changed
    }

    /// The next seed.
    pub fn reseed(&mut self) -> u64 {
        self.seed = self.seed.wrapping_add(1);
        self.seed
    }

    /// The utilisation term searches use: the one chosen with `L`, else the `search`
    /// section's, else the default.
    pub fn utilisation(&self) -> Utilisation {
        let grammar = GuidedTable::from_bundle(&self.bundle).ok().flatten().and_then(|t| t.settings.utilisation);
        self.utilisation.or(grammar).unwrap_or_default()
    }

    /// `L`: the next utilisation term ([`Utilisation::cycled`]); it stays through
    /// reloads. The caller asks for a search.
    pub fn cycle_utilisation(&mut self) -> Utilisation {
        let next = self.utilisation().cycled();
        self.utilisation = Some(next);
        next
    }

    /// Where `S` saves.
    pub fn save_path(&self) -> &Path {
        &self.save_to
    }

    /// Writes the guides to the save path as a guide file (atomically). Returns a
    /// message for the log.
    pub fn save(&mut self) -> Result<String, SessionError> {
        let json = self.editor.to_json();
        mdg_export::write_atomic(&self.save_to, json.as_bytes())
            .map_err(|error| SessionError::Write { path: self.save_to.clone(), error })?;
        if self.source == GuideSource::File(self.save_to.clone()) {
            self.source_revision = self.editor.revision();
        }
        Ok(format!("saved {} guides to {}", self.editor.guides().len(), self.save_to.display()))
    }

    /// The title bar's text after the file name: what the search found and what is
    /// selected.
    pub fn title(&self) -> String {
        let found = match &self.summary {
            Some(s) => s.line(),
            None => "searching…".into(),
        };
        format!("{found} — {}", self.editor.status())
    }
}

/// [`run_search`], with a panic in it reported as an error rather than ending the
/// search thread.
fn guarded_search(req: &SearchRequest, cancel: &Cancel) -> Result<Searched, SearchError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_search(req, cancel)))
        .unwrap_or(Err(SearchError::Panicked))
}
