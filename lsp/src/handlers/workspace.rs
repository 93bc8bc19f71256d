//! The workspace beyond the open files: the folders indexed on start, watched-file
//! changes (`workspace/didChangeWatchedFiles`), folder changes, the diagnostics of
//! closed importers an edit breaks, and the set of analyses a cross-file request
//! (references, rename, workspace symbols) asks. The index itself is
//! [`crate::workspace`].

use crate::backend::Backend;
use crate::documents::path_of;
use crate::guard::guard;
use crate::workspace::{analyze, canon, is_mdg, scan};
use mdg_compiler::analysis::{Document, Symbol};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Instant;
use tower_lsp_server::ls_types::*;

/// `initialize`: the workspace folders (or the root) and whether the client
/// registers file watchers on request.
pub fn configure(b: &Backend, p: &InitializeParams) {
    #[allow(deprecated)] // `root_uri` is what clients without folders send.
    let uris: Vec<Uri> = match (&p.workspace_folders, &p.root_uri) {
        (Some(folders), _) if !folders.is_empty() => folders.iter().map(|f| f.uri.clone()).collect(),
        (_, Some(root)) => vec![root.clone()],
        _ => Vec::new(),
    };
    let roots = uris.iter().filter(|u| u.scheme().as_str().eq_ignore_ascii_case("file")).map(|u| canon(&path_of(u)));
    b.workspace.set_roots(roots.collect());
    let dynamic = p
        .capabilities
        .workspace
        .as_ref()
        .and_then(|w| w.did_change_watched_files.as_ref())
        .and_then(|d| d.dynamic_registration)
        .unwrap_or(false);
    b.workspace.dynamic_watchers.store(dynamic, Ordering::SeqCst);
}

/// `initialized`: asks the client to watch `.mdg` files and indexes the folders,
/// both in the background (requests are served meanwhile; cross-file ones wait
/// for the index).
pub fn start(b: &Backend) {
    let b = b.clone();
    tokio::spawn(async move {
        if b.workspace.dynamic_watchers() {
            let options = DidChangeWatchedFilesRegistrationOptions {
                watchers: vec![FileSystemWatcher {
                    glob_pattern: GlobPattern::String("**/*.mdg".to_string()),
                    kind: None,
                }],
            };
            let registration = Registration {
                id: "mdg-watch-sources".to_string(),
                method: "workspace/didChangeWatchedFiles".to_string(),
                register_options: serde_json::to_value(options).ok(),
            };
            if let Err(e) = b.client.register_capability(vec![registration]).await {
                b.client.log_message(MessageType::WARNING, format!("mdg-lsp: cannot watch files: {e}")).await;
            }
        }
        let roots = b.workspace.roots();
        index(&b, roots).await;
        b.workspace.set_ready();
    });
}

/// Indexes every `.mdg` file under `roots` not indexed yet, and logs how long it took.
async fn index(b: &Backend, roots: Vec<PathBuf>) {
    if roots.is_empty() {
        return;
    }
    let t0 = Instant::now();
    let listed = tokio::task::spawn_blocking(move || scan(&roots)).await;
    let Ok(listed) = listed else { return };
    if let Some(why) = listed.stopped() {
        // A huge folder (`/`, a home directory): say so where the user looks.
        b.client
            .show_message(
                MessageType::WARNING,
                format!(
                    "mdg-lsp: the workspace is large; its walk for .mdg files stopped {why}. Files beyond are \
                     analysed when opened; open a smaller folder for workspace-wide references and symbols."
                ),
            )
            .await;
    }
    let mut count = 0;
    for path in &listed.files {
        if analyze_and_store(b, path, true).await.is_some() {
            count += 1;
        }
    }
    let more = match listed.stopped() {
        Some(why) => format!(" (the walk stopped {why}; the rest are analysed when opened)"),
        None => String::new(),
    };
    b.client
        .log_message(
            MessageType::INFO,
            format!("mdg-lsp: indexed {count} files of the workspace in {} ms{more}", t0.elapsed().as_millis()),
        )
        .await;
}

/// Analyses a file from disk (open documents overlaid) off the message loop and
/// stores it (unless `only_new` and it is indexed already); its analysis, or `None`
/// if it cannot be read (or the analysis panicked, which is logged).
async fn analyze_and_store(b: &Backend, path: &Path, only_new: bool) -> Option<Arc<Document>> {
    let loader = b.docs.overlay();
    let config = b.config.clone();
    let p = path.to_path_buf();
    let result = tokio::task::spawn_blocking(move || guard(|| analyze(&p, &loader, &config.options))).await;
    match result {
        Ok(Ok(Some((doc, closure)))) => {
            b.workspace.store(path.to_path_buf(), doc.clone(), closure, only_new);
            Some(doc)
        }
        Ok(Ok(None)) => None,
        Ok(Err(panic)) => {
            b.log_panic(&format!("analysis of {}", path.display()), &panic).await;
            None
        }
        Err(e) => {
            b.log_panic(&format!("analysis of {}", path.display()), &e.to_string()).await;
            None
        }
    }
}

/// Re-analyses closed files (importers of an edited file, files changed on disk)
/// and publishes their diagnostics: non-empty ones, and empty ones where errors
/// were shown before. Requests that arrive while a loop is draining are folded into it.
pub async fn refresh_closed(b: &Backend, paths: Vec<PathBuf>) {
    if !b.workspace.queue(paths) {
        return;
    }
    while let Some(path) = b.workspace.next_pending() {
        if b.docs.uri_of_canon(&path).is_some() || !(b.workspace.contains(&path) || b.workspace.in_roots(&path)) {
            continue;
        }
        match analyze_and_store(b, &path, false).await {
            Some(doc) => publish_closed(b, &path, &doc).await,
            None => forget(b, &path).await,
        }
    }
}

/// Publishes the diagnostics of a closed file's analysis.
async fn publish_closed(b: &Backend, path: &Path, doc: &Document) {
    let Some(uri) = Uri::from_file_path(path) else { return };
    let Ok(diags) = b.run("diagnostics", || super::diagnostics::convert_all(b, &uri, doc)).await else { return };
    // Opened meanwhile: the open document's own diagnostics rule.
    if b.docs.uri_of_canon(path).is_some() {
        return;
    }
    let shown = b.workspace.set_published(path, !diags.is_empty());
    if shown || !diags.is_empty() {
        b.client.publish_diagnostics(uri, diags, None).await;
    }
}

/// Drops a file from the index, clearing diagnostics shown for it.
async fn forget(b: &Backend, path: &Path) {
    if let Some(entry) = b.workspace.remove(path) {
        if entry.published && b.docs.uri_of_canon(path).is_none() {
            if let Some(uri) = Uri::from_file_path(path) {
                b.client.publish_diagnostics(uri, Vec::new(), None).await;
            }
        }
    }
}

/// After an edit, save, open or close of `uri`: re-checks the closed files that
/// import it.
pub async fn refresh_importers(b: &Backend, uri: &Uri) {
    let path = canon(&path_of(uri));
    let importers = b.workspace.importers(std::slice::from_ref(&path));
    refresh_closed(b, importers).await;
}

/// `textDocument/didClose`: the file is read from disk again (its unsaved text is gone).
pub async fn closed(b: &Backend, uri: &Uri) {
    let path = canon(&path_of(uri));
    if b.workspace.contains(&path) || b.workspace.in_roots(&path) {
        analyze_and_store(b, &path, false).await;
    }
}

/// `workspace/didChangeWatchedFiles`: files created, changed or deleted on disk.
pub async fn did_change_watched_files(b: &Backend, p: DidChangeWatchedFilesParams) {
    let mut changed = Vec::new();
    let mut closed = Vec::new();
    let (mut created, mut deleted) = (false, false);
    for ev in p.changes {
        let path = path_of(&ev.uri);
        if !is_mdg(&path) {
            continue;
        }
        let c = canon(&path);
        if ev.typ == FileChangeType::DELETED {
            deleted = true;
            forget(b, &c).await;
        } else {
            created |= ev.typ == FileChangeType::CREATED;
            if b.docs.uri_of_canon(&c).is_none() {
                closed.push(c.clone());
            }
        }
        changed.push(c);
    }
    if changed.is_empty() {
        return;
    }
    // Open documents: those that read a changed file; all of them when files
    // appeared or vanished (an import may now resolve, or no longer).
    for (u, _) in b.docs.open_documents() {
        if created || deleted || changed.iter().any(|c| b.docs.reads(&u, c)) {
            super::analysis::refresh(b, u).await;
        }
    }
    closed.extend(b.workspace.importers(&changed));
    if created || deleted {
        closed.extend(b.workspace.with_errors());
    }
    let rechecked = closed.len();
    refresh_closed(b, closed).await;
    b.client
        .log_message(
            MessageType::INFO,
            format!("mdg-lsp: {} watched file(s) changed; {rechecked} closed file(s) re-checked", changed.len()),
        )
        .await;
}

/// `workspace/didChangeWorkspaceFolders`: indexes added folders, forgets removed ones.
pub async fn did_change_workspace_folders(b: &Backend, p: DidChangeWorkspaceFoldersParams) {
    let paths = |fs: &[WorkspaceFolder]| -> Vec<PathBuf> { fs.iter().map(|f| canon(&path_of(&f.uri))).collect() };
    let added = paths(&p.event.added);
    for (path, entry) in b.workspace.change_roots(added.clone(), &paths(&p.event.removed)) {
        if entry.published && b.docs.uri_of_canon(&path).is_none() {
            if let Some(uri) = Uri::from_file_path(&path) {
                b.client.publish_diagnostics(uri, Vec::new(), None).await;
            }
        }
    }
    index(b, added).await;
}

/// One file's analysis as a cross-file request sees it.
pub struct View {
    pub uri: Uri,
    /// The file's canonical path.
    pub path: PathBuf,
    pub doc: Arc<Document>,
}

impl View {
    /// Whether this view speaks for the file `span_path`: its own file, or a file no
    /// view has as its own (std, a library outside the folders). So each file's
    /// spans come from one analysis of its current text.
    pub fn speaks_for(&self, span_path: &Path, own: &BTreeSet<PathBuf>) -> bool {
        span_path == self.path || !own.contains(span_path)
    }
}

/// The canonical paths of the views' own files.
pub fn own_files(views: &[View]) -> BTreeSet<PathBuf> {
    views.iter().map(|v| v.path.clone()).collect()
}

/// The canonical path of a file of an analysis.
pub fn file_canon(doc: &Document, file: mdg_compiler::span::FileId) -> Option<PathBuf> {
    doc.file_path(file).map(canon)
}

/// Where `sym` is defined in an analysis: (canonical file, start) pairs.
pub(crate) fn definition_keys(doc: &Document, sym: &Symbol) -> BTreeSet<(PathBuf, u32)> {
    guard(|| {
        doc.symbol_definitions(sym).into_iter().filter_map(|s| Some((file_canon(doc, s.file)?, s.start))).collect()
    })
    .unwrap_or_default()
}

/// The analyses a request about `sym`, asked in `doc` (the analysis of `uri`), must
/// consult: that one, and every open or indexed file that sees one of the symbol's
/// definitions (the definition's own file and every file whose import closure holds
/// it), each of its current text. A symbol without a definition is only this file's.
pub async fn views(b: &Backend, uri: &Uri, doc: Arc<Document>, sym: &Symbol) -> Vec<View> {
    let defs = definition_keys(&doc, sym);
    let mut out = vec![View { uri: uri.clone(), path: canon(&path_of(uri)), doc }];
    if defs.is_empty() {
        return out;
    }
    b.workspace.wait_ready().await;
    let def_paths: BTreeSet<PathBuf> = defs.iter().map(|(p, _)| p.clone()).collect();
    let sees = |d: &Document| definition_keys(d, sym).intersection(&defs).next().is_some();
    for (u, path) in b.docs.open_documents() {
        if u == *uri {
            continue;
        }
        let Some(d) = b.document(&u).await else { continue };
        if sees(&d) {
            out.push(View { uri: u, path, doc: d });
        }
    }
    for (path, d) in b.workspace.seeing(&def_paths) {
        if b.docs.uri_of_canon(&path).is_some() || out.iter().any(|v| v.path == path) {
            continue;
        }
        let Some(d) = fresh(b, &path, d).await else { continue };
        let Some(u) = Uri::from_file_path(&path) else { continue };
        if sees(&d) {
            out.push(View { uri: u, path, doc: d });
        }
    }
    out
}

/// A closed file's analysis, redone if the file changed on disk without a watcher
/// telling (`None` if it is gone).
async fn fresh(b: &Backend, path: &Path, doc: Arc<Document>) -> Option<Arc<Document>> {
    let p = path.to_path_buf();
    let disk = tokio::task::spawn_blocking(move || std::fs::read_to_string(p).ok()).await.ok().flatten();
    match disk {
        Some(text) if text == doc.text() => Some(doc),
        Some(_) => analyze_and_store(b, path, false).await,
        None => {
            forget(b, path).await;
            None
        }
    }
}

/// Every open document's and indexed closed file's analysis, as views (for
/// workspace symbols).
pub async fn all_views(b: &Backend) -> Vec<View> {
    b.workspace.wait_ready().await;
    let mut out = Vec::new();
    for (u, path) in b.docs.open_documents() {
        if let Some(doc) = b.document(&u).await {
            out.push(View { uri: u, path, doc });
        }
    }
    for (path, doc) in b.workspace.all() {
        if b.docs.uri_of_canon(&path).is_some() {
            continue;
        }
        if let Some(uri) = Uri::from_file_path(&path) {
            out.push(View { uri, path, doc });
        }
    }
    out
}
