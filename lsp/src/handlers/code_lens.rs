//! `textDocument/codeLens`: `▶ Preview | Render .glb | Stats` over `startshape`,
//! `Run search` over a `search` section, `Evolve` over a `creature` section, and the
//! number of references over each rule definition, counted over the whole workspace
//! (every open or indexed file that sees the definition). The commands are the VS
//! Code extension's (`editors/vscode`); their arguments are JSON (the document's
//! URI, and for `mdg.showReferences` a position and the locations).
//!
//! The reference counts are lazy: `textDocument/codeLens` answers them without a
//! command (only the rule's name in `data`, which costs nothing), and
//! `codeLens/resolve` counts one when the client shows it — VS Code resolves the
//! lenses of the visible lines only, so a 3,000-line file costs what its screen
//! does, not what every rule's references over the workspace do.

use super::workspace::{all_views, definition_keys, file_canon, View};
use crate::backend::Backend;
use crate::position::LineIndex;
use mdg_compiler::analysis::{LensKind, Symbol};
use serde_json::json;
use std::collections::{BTreeSet, HashSet};
use std::path::PathBuf;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The extension's commands a lens runs.
pub const PREVIEW: &str = "mdg.preview";
pub const RENDER: &str = "mdg.renderGlb";
pub const STATS: &str = "mdg.stats";
pub const SEARCH: &str = "mdg.runSearch";
pub const EVOLVE: &str = "mdg.evolve";
pub const SHOW_REFERENCES: &str = "mdg.showReferences";

/// The lenses of a document.
pub async fn code_lens(b: &Backend, p: CodeLensParams) -> Result<Option<Vec<CodeLens>>> {
    let uri = &p.text_document.uri;
    let Some(doc) = b.document(uri).await else { return Ok(None) };
    let targets = b.run("code lens", || doc.lens_targets()).await?;
    b.run("code lens", || {
        let li = LineIndex::new(doc.text());
        let arg = json!(uri.as_str());
        let lens = |range: Range, title: &str, command: &str, arguments: Vec<serde_json::Value>| CodeLens {
            range,
            command: Some(Command {
                title: title.to_string(),
                command: command.to_string(),
                arguments: Some(arguments),
            }),
            data: None,
        };
        let mut out = Vec::new();
        for t in targets {
            let range = li.range(t.span.start, t.span.start);
            match t.kind {
                LensKind::Startshape => {
                    out.push(lens(range, "▶ Preview", PREVIEW, vec![arg.clone()]));
                    out.push(lens(range, "Render .glb", RENDER, vec![arg.clone()]));
                    out.push(lens(range, "Stats", STATS, vec![arg.clone()]));
                }
                LensKind::Search => out.push(lens(range, "Run search", SEARCH, vec![arg.clone()])),
                LensKind::Creature => out.push(lens(range, "Evolve", EVOLVE, vec![arg.clone()])),
                LensKind::Rule(name) => {
                    out.push(CodeLens { range, command: None, data: Some(json!({"uri": uri.as_str(), "rule": name})) })
                }
            }
        }
        Some(out)
    })
    .await
}

/// `codeLens/resolve`: a rule's reference count (the lens's `data` names the document
/// and the rule), counted over the workspace now. A lens of a document no longer
/// open, or of a rule no longer defined, says `0 references`.
pub async fn resolve(b: &Backend, mut lens: CodeLens) -> Result<CodeLens> {
    let data = lens.data.take().unwrap_or_default();
    let (Some(uri), Some(rule)) = (
        data.get("uri").and_then(|u| u.as_str()).and_then(|u| u.parse::<Uri>().ok()),
        data.get("rule").and_then(|r| r.as_str()).map(str::to_string),
    ) else {
        return Ok(lens);
    };
    let Some(doc) = b.document(&uri).await else {
        lens.command = Some(references_command(&uri, lens.range.start, Vec::new()));
        return Ok(lens);
    };
    // The rule defined at the lens's place now: the text may have changed since the
    // lens was made (a rename), and the client resolves lenses it already had.
    let targets = b.run("code lens", || doc.lens_targets()).await?;
    let li = LineIndex::new(doc.text());
    let here = targets.into_iter().find_map(|t| match t.kind {
        LensKind::Rule(name) if li.position(t.span.start) == lens.range.start => Some(name),
        _ => None,
    });
    let rule = here.unwrap_or(rule);
    let views = all_views(b).await;
    let locations = b.run("code lens", || references(b, &views, &doc, &Symbol::Rule(rule))).await?;
    lens.command = Some(references_command(&uri, lens.range.start, locations));
    Ok(lens)
}

/// `N references`, listing them when clicked.
fn references_command(uri: &Uri, position: Position, locations: Vec<Location>) -> Command {
    let n = locations.len();
    Command {
        title: if n == 1 { "1 reference".to_string() } else { format!("{n} references") },
        command: SHOW_REFERENCES.to_string(),
        arguments: Some(vec![json!(uri.as_str()), json!(position), json!(locations)]),
    }
}

/// The uses of `sym` (defined in `doc`) in every view that sees one of its
/// definitions, each file's from its own analysis, sorted.
fn references(b: &Backend, views: &[View], doc: &mdg_compiler::analysis::Document, sym: &Symbol) -> Vec<Location> {
    let defs = definition_keys(doc, sym);
    if defs.is_empty() {
        return Vec::new();
    }
    let seeing: Vec<&View> =
        views.iter().filter(|v| definition_keys(&v.doc, sym).intersection(&defs).next().is_some()).collect();
    let own: BTreeSet<PathBuf> = seeing.iter().map(|v| v.path.clone()).collect();
    let mut seen = HashSet::new();
    let mut out: Vec<Location> = Vec::new();
    for v in seeing {
        for s in v.doc.symbol_references(sym, false) {
            let Some(path) = file_canon(&v.doc, s.file) else { continue };
            if !v.speaks_for(&path, &own) || !seen.insert((path, s.start)) {
                continue;
            }
            if let Some(loc) = b.location(&v.doc, &v.uri, s) {
                out.push(loc);
            }
        }
    }
    out.sort_by(|a, b| (a.uri.as_str(), a.range.start).cmp(&(b.uri.as_str(), b.range.start)));
    out
}
