//! Call hierarchy: `textDocument/prepareCallHierarchy` (the rule definitions at a
//! position), `callHierarchy/incomingCalls` (the rule definitions whose bodies call
//! it, in every open or indexed file that sees it) and `callHierarchy/outgoingCalls`
//! (the rules its body calls). An item's `data` names the rule and the document it
//! was found from.

use super::workspace::{all_views, file_canon, own_files, views};
use super::{at_position, uri};
use crate::backend::Backend;
use crate::documents::path_of;
use crate::position::LineIndex;
use crate::workspace::canon;
use mdg_compiler::analysis::{Document, RuleDef, Symbol};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::*;

/// The items at a position: the definition under the cursor, or every definition of
/// the rule a call names.
pub async fn prepare(b: &Backend, p: CallHierarchyPrepareParams) -> Result<Option<Vec<CallHierarchyItem>>> {
    let pos = &p.text_document_position_params;
    let Some((doc, offset)) = at_position(b, pos).await else { return Ok(None) };
    let main_uri = uri(pos).clone();
    b.run("call hierarchy", || {
        let Some((Symbol::Rule(name), at)) = doc.symbol_at(offset) else { return None };
        let defs: Vec<RuleDef> = doc.rule_definitions().into_iter().filter(|d| d.name == name).collect();
        let here: Vec<&RuleDef> = defs.iter().filter(|d| d.name_span == at).collect();
        let chosen: Vec<&RuleDef> = if here.is_empty() { defs.iter().collect() } else { here };
        let items: Vec<CallHierarchyItem> =
            chosen.into_iter().filter_map(|d| item(b, &doc, &main_uri, d, &main_uri)).collect();
        (!items.is_empty()).then_some(items)
    })
    .await
}

/// The rule definitions that call the item's rule, with the calls' ranges.
pub async fn incoming(
    b: &Backend,
    p: CallHierarchyIncomingCallsParams,
) -> Result<Option<Vec<CallHierarchyIncomingCall>>> {
    let Some((doc, main_uri, def)) = find(b, &p.item).await else { return Ok(None) };
    let sym = Symbol::Rule(def.name.clone());
    let views = views(b, &main_uri, doc, &sym).await;
    b.run("incoming calls", || {
        let own = own_files(&views);
        // Caller (file, name start) -> its item and the calls' ranges.
        let mut callers: BTreeMap<(PathBuf, u32), (CallHierarchyItem, Vec<Range>)> = BTreeMap::new();
        for v in &views {
            for s in v.doc.symbol_references(&sym, false) {
                let Some(path) = file_canon(&v.doc, s.file) else { continue };
                if !v.speaks_for(&path, &own) {
                    continue;
                }
                // Calls outside rules (`startshape`, selectors) have no caller.
                let Some(caller) = v.doc.enclosing_rule(s) else { continue };
                let Some(from) = item(b, &v.doc, &v.uri, &caller, &v.uri) else { continue };
                let range = LineIndex::new(v.doc.file_text(s.file)).range(s.start, s.end);
                let entry = callers.entry((path, caller.name_span.start)).or_insert_with(|| (from, Vec::new()));
                if !entry.1.contains(&range) {
                    entry.1.push(range);
                }
            }
        }
        let out = callers
            .into_values()
            .map(|(from, mut from_ranges)| {
                from_ranges.sort_by_key(|r| (r.start.line, r.start.character));
                CallHierarchyIncomingCall { from, from_ranges }
            })
            .collect();
        Some(out)
    })
    .await
}

/// The rules the item's definition calls, each with the calls' ranges (in the
/// definition's file), in order of first call.
pub async fn outgoing(
    b: &Backend,
    p: CallHierarchyOutgoingCallsParams,
) -> Result<Option<Vec<CallHierarchyOutgoingCall>>> {
    let Some((doc, main_uri, def)) = find(b, &p.item).await else { return Ok(None) };
    b.run("outgoing calls", || {
        let li = LineIndex::new(doc.file_text(def.span.file));
        let defs = doc.rule_definitions();
        let mut out: Vec<CallHierarchyOutgoingCall> = Vec::new();
        for call in doc.outgoing_calls(&def) {
            let range = li.range(call.span.start, call.span.end);
            if let Some(o) = out.iter_mut().find(|o| o.to.name == call.callee) {
                o.from_ranges.push(range);
                continue;
            }
            // The callee's first definition stands for the rule (a call picks one of them).
            let Some(callee) = defs.iter().find(|d| d.name == call.callee) else { continue };
            let Some(to) = item(b, &doc, &main_uri, callee, &main_uri) else { continue };
            out.push(CallHierarchyOutgoingCall { to, from_ranges: vec![range] });
        }
        Some(out)
    })
    .await
}

/// The item of a rule definition found in `doc` (the analysis of `main_uri`);
/// `from` is the document whose analysis answers for it later.
fn item(b: &Backend, doc: &Document, main_uri: &Uri, def: &RuleDef, from: &Uri) -> Option<CallHierarchyItem> {
    let uri = b.uri_of(doc, main_uri, def.span.file)?;
    let li = LineIndex::new(doc.file_text(def.span.file));
    let detail = doc.file_path(def.span.file).and_then(|p| p.file_name()).map(|n| n.to_string_lossy().into_owned());
    Some(CallHierarchyItem {
        name: def.name.clone(),
        kind: SymbolKind::FUNCTION,
        tags: None,
        detail,
        uri,
        range: li.range(def.span.start, def.span.end),
        selection_range: li.range(def.name_span.start, def.name_span.end),
        data: Some(json!({"rule": def.name, "from": from.as_str()})),
    })
}

/// The analysis an item came from (or any open or indexed one holding its file),
/// that analysis's URI, and the item's definition in it.
async fn find(b: &Backend, item: &CallHierarchyItem) -> Option<(Arc<Document>, Uri, RuleDef)> {
    let from: Option<Uri> = item.data.as_ref().and_then(|d| d["from"].as_str()).and_then(|s| s.parse().ok());
    let path = canon(&path_of(&item.uri));
    let matches = |doc: &Document| -> Option<RuleDef> {
        doc.rule_definitions().into_iter().find(|d| {
            d.name == item.name
                && file_canon(doc, d.span.file).is_some_and(|p| p == path)
                && LineIndex::new(doc.file_text(d.span.file)).position(d.name_span.start) == item.selection_range.start
        })
    };
    for u in from.iter().chain(std::iter::once(&item.uri)) {
        if let Some(doc) = b.document(u).await {
            if let Some(def) = crate::guard::guard(|| matches(&doc)).ok().flatten() {
                return Some((doc, u.clone(), def));
            }
        }
    }
    for v in all_views(b).await {
        if let Some(def) = crate::guard::guard(|| matches(&v.doc)).ok().flatten() {
            return Some((v.doc, v.uri, def));
        }
    }
    None
}
