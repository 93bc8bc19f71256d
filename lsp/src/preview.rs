//! The live preview's evaluator: the `mdg/preview` request.
//!
//! The editor's preview panel asks the (long-lived) server for the model of an
//! open document instead of starting `mdg-run` per edit: the server compiles the
//! text it already holds (unsaved imports included, through the open documents),
//! evaluates it with `mdg-run`'s budgets plus a time budget, and answers with the
//! model as a binary glTF (`.glb`, base64 in the JSON: the positions, normals,
//! colours and per-triangle rule sites as typed arrays the webview hands to
//! three.js without parsing text), the limit warnings reworded to name the
//! editor's settings, the `@param` declarations and the phases' times.
//!
//! Newest wins: every request for a document bumps that document's preview
//! generation, and an edit bumps the document's own; the run in progress checks
//! both in the evaluator's budget check ([`mdg_vm::eval::EvalOptions::cancel`]) and
//! stops, answering `cancelled`. Grammars with a `search`, `creature` or `grid`
//! section run in modes of `mdg-run` of their own: for them the answer says so
//! (`status: "mode"`) and the extension runs `mdg-run`.

use mdg_compiler::expand::Options;
use mdg_compiler::source::FileLoader;
use mdg_vm::bundle::SectionKind;
use mdg_vm::eval::{Cancel, EvalOptions};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tower_lsp_server::ls_types::Uri;

/// The preview's time budget when the request names none (the setting
/// `mdg.preview.timeBudget`, in seconds, sends one): a runaway grammar is cut
/// here, so the panel shows its warning within about a second and a half.
pub const DEFAULT_TIME_BUDGET_MS: u64 = 1000;

/// The preview's vertex budget when the request names none (the setting
/// `mdg.preview.maxVertices` sends one): a quarter of `mdg-run`'s 4,000,000, over
/// twice the largest std example. The model travels to the panel (about 44 bytes a
/// vertex in the `.glb`, a third more in base64): at 4,000,000 a runaway grammar
/// sent 180 MB and took seconds to export, send and parse (docs/decisions.md).
pub const DEFAULT_MAX_VERTICES: u64 = 1_000_000;

/// The largest time budget a request may ask for (10 minutes).
const MAX_TIME_BUDGET_MS: u64 = 600_000;

/// `mdg/preview`'s parameters.
#[derive(Debug, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct PreviewParams {
    /// An open document.
    pub uri: Uri,
    /// The seed (a decimal string: JSON numbers lose digits past 2^53); absent: the
    /// grammar's `randseed`.
    #[serde(default)]
    pub seed: Option<String>,
    /// `@param` values by name (as `mdg-run --param NAME=V`).
    #[serde(default)]
    pub params: BTreeMap<String, f64>,
    /// The time budget in milliseconds (default [`DEFAULT_TIME_BUDGET_MS`]).
    #[serde(default)]
    pub time_budget_ms: Option<u64>,
    /// The vertex budget (default [`DEFAULT_MAX_VERTICES`]).
    #[serde(default)]
    pub max_vertices: Option<u64>,
}

/// What a preview run ended with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub enum Status {
    /// A model (`glb`), perhaps cut by a limit (`warnings`).
    #[default]
    Model,
    /// The grammar does not compile, or the request was malformed (`message`).
    Error,
    /// A newer edit or request arrived: this run was stopped and has no model.
    Cancelled,
    /// The grammar runs in a mode of `mdg-run`'s own (`message` names it).
    Mode,
}

/// The phases' times and the model's size.
#[derive(Debug, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PreviewStats {
    pub compile_ms: f64,
    pub eval_ms: f64,
    pub export_ms: f64,
    /// The `.glb`'s size in bytes (before base64).
    pub bytes: usize,
    pub rule_calls: u64,
    pub vertices: u64,
    pub triangles: u64,
}

/// `mdg/preview`'s answer.
#[derive(Debug, Default, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct PreviewResult {
    pub status: Status,
    /// The document version evaluated.
    pub version: i32,
    /// The seed used (decimal), for the panel's seed field.
    pub seed: String,
    /// The model: a binary glTF, base64.
    pub glb: String,
    /// Limits reached and inputs ignored, each naming the setting or fix.
    pub warnings: Vec<String>,
    /// The error (compiler diagnostics as text), or the mode.
    pub message: String,
    /// The `@param` declarations (as `mdg-run --params-json` writes them); `null`
    /// when the text did not compile.
    pub params: serde_json::Value,
    pub stats: PreviewStats,
    /// The derivation inspector's tree of rule calls ([`mdg_vm::output::Derivation`]:
    /// one node per path of rules, with calls and triangles); `null` without a model.
    /// The `.glb`'s sites (`mdg_sites` in the extras) name each triangle's and
    /// instance's node and depth.
    pub tree: Option<mdg_vm::output::Derivation>,
}

/// Each document's preview generation (bumped by every `mdg/preview` request).
#[derive(Default)]
pub struct Previews {
    map: Mutex<HashMap<Uri, Arc<AtomicU64>>>,
}

impl Previews {
    /// Starts a run for `uri`: the counter and this run's generation.
    pub(crate) fn begin(&self, uri: &Uri) -> (Arc<AtomicU64>, u64) {
        let counter = match self.map.lock() {
            Ok(mut m) => m.entry(uri.clone()).or_default().clone(),
            Err(_) => Arc::new(AtomicU64::new(0)),
        };
        let generation = counter.fetch_add(1, Ordering::SeqCst) + 1;
        (counter, generation)
    }

    /// Forgets a closed document.
    pub fn forget(&self, uri: &Uri) {
        if let Ok(mut m) = self.map.lock() {
            if let Some(c) = m.remove(uri) {
                // A run still going stops.
                c.fetch_add(1, Ordering::SeqCst);
            }
        }
    }
}

/// Compiles `path` (read through `loader`), evaluates it and exports the `.glb`.
pub fn run(
    loader: &dyn FileLoader,
    path: &Path,
    options: &Options,
    p: &PreviewParams,
    cancel: Cancel,
) -> PreviewResult {
    let mut r = PreviewResult { params: serde_json::Value::Null, ..PreviewResult::default() };
    let seed = match p.seed.as_deref().map(str::trim).filter(|s| !s.is_empty()) {
        None => None,
        Some(s) => match s.parse::<u64>() {
            Ok(n) => Some(n),
            Err(_) => {
                r.status = Status::Error;
                r.message = format!("seed `{s}`: expected a whole number from 0 to {}", u64::MAX);
                return r;
            }
        },
    };
    let mut opts = options.clone();
    opts.params = p.params.iter().map(|(n, v)| (n.clone(), format!("{v}"))).collect();
    let started = Instant::now();
    let built = mdg_compiler::driver::build(loader, path, &opts);
    r.stats.compile_ms = ms(started);
    let (bundle, analysis) = match built {
        Ok(x) => x,
        Err(a) => {
            r.status = Status::Error;
            r.message = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
            if r.message.trim().is_empty() {
                r.message = format!("{} has errors", path.display());
            }
            return r;
        }
    };
    r.params = serde_json::from_str(&bundle.params_json()).unwrap_or(serde_json::Value::Null);
    for (_, e) in mdg_compiler::expand::unused_command_line(&analysis.expanded, &analysis.sources, &opts) {
        r.warnings.push(format!("{e}; the panel's value is ignored"));
    }
    let ext = &bundle.extensions;
    let mode = if ext.has(SectionKind::Guided) {
        Some("search")
    } else if ext.has(SectionKind::Creatures) {
        Some("creature")
    } else if ext.has(SectionKind::Grid) {
        Some("grid")
    } else {
        None
    };
    if let Some(m) = mode {
        r.status = Status::Mode;
        r.message = m.to_string();
        return r;
    }
    r.seed = seed.unwrap_or(bundle.settings.randseed).to_string();
    let d = EvalOptions::default();
    let budget = p.time_budget_ms.unwrap_or(DEFAULT_TIME_BUDGET_MS).clamp(1, MAX_TIME_BUDGET_MS);
    let eval_opts = EvalOptions {
        seed,
        time_budget: Some(std::time::Duration::from_millis(budget)),
        max_vertices: p.max_vertices.filter(|&n| n > 0).unwrap_or(DEFAULT_MAX_VERTICES),
        record_sites: true,
        record_derivation: true,
        cancel: Some(cancel.clone()),
        ..d
    };
    let started = Instant::now();
    let out = mdg_vm::eval::evaluate(&bundle, &eval_opts);
    r.stats.eval_ms = ms(started);
    if (cancel.0)() {
        r.status = Status::Cancelled;
        return r;
    }
    r.warnings.extend(out.stats.warnings.iter().map(String::as_str).map(preview_warning));
    r.stats.rule_calls = out.stats.rule_calls;
    r.stats.vertices = out.stats.vertices;
    r.stats.triangles = out.stats.triangles;
    r.tree = out.derivation.clone();
    let started = Instant::now();
    let mut glb = Vec::new();
    let written = mdg_export::glb::write_glb_with(&out, &mdg_export::glb::GlbOptions { instances: true }, &mut glb);
    if let Err(e) = written {
        r.status = Status::Error;
        r.message = format!("cannot write the model: {e}");
        return r;
    }
    r.stats.bytes = glb.len();
    r.glb = base64(&glb);
    r.stats.export_ms = ms(started);
    r
}

fn ms(since: Instant) -> f64 {
    since.elapsed().as_secs_f64() * 1000.0
}

/// The evaluator's limit warnings name `mdg-run`'s flags; in the preview the
/// editor's settings raise those limits.
pub fn preview_warning(w: &str) -> String {
    w.replace(
        "`--time-budget TIME`, e.g. `--time-budget 30s`",
        "the setting `mdg.preview.timeBudget` (seconds; `mdg-run` has no time budget unless given `--time-budget`)",
    )
    .replace("`--max-vertices N`", "the setting `mdg.preview.maxVertices`")
}

/// Standard base64 (RFC 4648, with padding).
pub fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], chunk.get(1).copied().unwrap_or(0), chunk.get(2).copied().unwrap_or(0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        s.push(ABC[(n >> 18) as usize & 63] as char);
        s.push(ABC[(n >> 12) as usize & 63] as char);
        s.push(if chunk.len() > 1 { ABC[(n >> 6) as usize & 63] as char } else { '=' });
        s.push(if chunk.len() > 2 { ABC[n as usize & 63] as char } else { '=' });
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_compiler::source::MemLoader;
    use std::path::PathBuf;

    const TRI: &str = "rule tri { VERTEX{x 0 0 0} VERTEX{x 1 0 0} VERTEX{x 0 1 0} FACENORMALS{} }\n";
    const RUNAWAY: &str = "startshape a\nrule a { tri {} a {x 1} a {y 1} }\n";

    fn params() -> PreviewParams {
        PreviewParams {
            uri: "file:///preview-test/a.mdg".parse().expect("a URI"),
            seed: None,
            params: BTreeMap::new(),
            time_budget_ms: None,
            max_vertices: None,
        }
    }

    fn never() -> Cancel {
        Cancel(Arc::new(|| false))
    }

    fn run_text(text: &str, p: &PreviewParams, cancel: Cancel) -> PreviewResult {
        let path = PathBuf::from("/preview-test/a.mdg");
        let loader = MemLoader { files: [(path.clone(), text.to_string())].into(), disk_fallback: false };
        run(&loader, &path, &Options::default(), p, cancel)
    }

    #[test]
    fn base64_matches_rfc_4648() {
        assert_eq!(base64(b""), "");
        assert_eq!(base64(b"f"), "Zg==");
        assert_eq!(base64(b"fo"), "Zm8=");
        assert_eq!(base64(b"foo"), "Zm9v");
        assert_eq!(base64(b"foobar"), "Zm9vYmFy");
        assert_eq!(base64(&[0xff, 0xfe, 0x00]), "//4A");
    }

    #[test]
    fn a_model_comes_back_as_a_glb_with_its_seed_and_params() {
        let text = format!("@param int n 3 1 5\nstartshape a\nrule a {{ loop i = 0, n {{x 2}} tri {{}} }}\n{TRI}");
        let text = text.as_str();
        let p = PreviewParams { seed: Some("7".into()), ..params() };
        let r = run_text(text, &p, never());
        assert_eq!(r.status, Status::Model, "{}", r.message);
        assert_eq!(r.seed, "7");
        assert_eq!(r.stats.triangles, 3);
        assert!(r.glb.starts_with(&base64(b"glTF")[..4]), "{}", &r.glb[..8]);
        assert_eq!(r.params[0]["name"], "n");
        // A param value is passed as `--param` would pass it.
        let p = PreviewParams { params: [("n".to_string(), 5.0)].into(), ..params() };
        assert_eq!(run_text(text, &p, never()).stats.triangles, 5);
        // An undeclared one is ignored with a warning.
        let p = PreviewParams { params: [("m".to_string(), 5.0)].into(), ..params() };
        let r = run_text(text, &p, never());
        assert!(r.warnings.iter().any(|w| w.contains('m') && w.contains("ignored")), "{:?}", r.warnings);
    }

    /// The `.glb`'s JSON chunk.
    fn glb_json(b64: &str) -> serde_json::Value {
        const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut bytes = Vec::new();
        for chunk in b64.as_bytes().chunks(4) {
            let v: Vec<u32> = chunk
                .iter()
                .filter(|&&c| c != b'=')
                .map(|c| ABC.iter().position(|a| a == c).expect("base64") as u32)
                .collect();
            let n = v.iter().enumerate().fold(0u32, |n, (i, d)| n | d << (18 - 6 * i));
            bytes.extend_from_slice(&n.to_be_bytes()[1..v.len()]);
        }
        let len = u32::from_le_bytes(bytes[12..16].try_into().expect("a length")) as usize;
        serde_json::from_slice(&bytes[20..20 + len]).expect("the JSON chunk")
    }

    #[test]
    fn the_answer_carries_the_derivation_tree_and_the_glb_its_sites() {
        let text = format!("startshape a\nrule a {{ tri {{}} 2 * {{x 2}} b {{}} }}\nrule b {{ tri {{z 1}} }}\n{TRI}");
        let r = run_text(&text, &params(), never());
        assert_eq!(r.status, Status::Model, "{}", r.message);
        let tree = r.tree.as_ref().expect("a tree");
        let names: Vec<(&str, u32, u64, u64)> =
            tree.nodes.iter().map(|n| (tree.rules[n.rule as usize].rule.as_str(), n.depth, n.calls, n.total)).collect();
        assert_eq!(names, [("a", 0, 1, 3), ("tri", 1, 1, 1), ("b", 1, 2, 2), ("tri", 2, 2, 2)]);
        assert_eq!(tree.triangles, r.stats.triangles);
        let json = serde_json::to_value(&r).expect("JSON");
        assert_eq!(json["tree"]["nodes"][2]["parent"], 0);
        // The glb's geometry names each triangle's site, depth and node.
        let glb = glb_json(&r.glb);
        let sites = &glb["meshes"][0]["primitives"][0]["extras"]["mdg_sites"];
        assert_eq!(sites["runs"], serde_json::json!([[0, 0, 1, 1], [1, 0, 2, 3]]), "{sites}");
        assert_eq!(sites["sites"][0]["rule"], "tri");
    }

    #[test]
    fn errors_and_bad_seeds_are_reported() {
        let r = run_text("startshape a\nrule a { nosuch {} }\n", &params(), never());
        assert_eq!(r.status, Status::Error);
        assert!(r.message.contains("nosuch"), "{}", r.message);
        let p = PreviewParams { seed: Some("twelve".into()), ..params() };
        let r = run_text(&format!("startshape a\nrule a {{ tri {{}} }}\n{TRI}"), &p, never());
        assert_eq!(r.status, Status::Error);
        assert!(r.message.contains("seed `twelve`"), "{}", r.message);
    }

    #[test]
    fn a_runaway_grammar_is_cut_by_the_time_budget_and_the_warning_names_the_setting() {
        let runaway = &format!("{RUNAWAY}{TRI}");
        let p = PreviewParams { time_budget_ms: Some(200), max_vertices: Some(u64::MAX), ..params() };
        let started = Instant::now();
        let r = run_text(runaway, &p, never());
        assert_eq!(r.status, Status::Model);
        assert!(started.elapsed().as_secs_f64() < 30.0);
        assert!(
            r.warnings.iter().any(|w| w.contains("time budget") && w.contains("mdg.preview.timeBudget")),
            "{:?}",
            r.warnings
        );
        let p = PreviewParams { max_vertices: Some(1000), ..params() };
        let r = run_text(runaway, &p, never());
        assert!(
            r.warnings.iter().any(|w| w.contains("vertex budget") && w.contains("mdg.preview.maxVertices")),
            "{:?}",
            r.warnings
        );
        // (The budget is checked every 4,096 calls.)
        assert!(r.stats.vertices < 100_000, "{}", r.stats.vertices);
    }

    #[test]
    fn a_cancelled_run_stops_and_has_no_model() {
        let runaway = &format!("{RUNAWAY}{TRI}");
        let p = PreviewParams { time_budget_ms: Some(60_000), max_vertices: Some(u64::MAX), ..params() };
        let calls = Arc::new(AtomicU64::new(0));
        let c = calls.clone();
        // Cancelled at the evaluator's third budget check.
        let cancel = Cancel(Arc::new(move || c.fetch_add(1, Ordering::SeqCst) >= 2));
        let r = run_text(runaway, &p, cancel);
        assert_eq!(r.status, Status::Cancelled);
        assert!(r.glb.is_empty());
        assert!(r.stats.eval_ms < 30_000.0);
    }
}
