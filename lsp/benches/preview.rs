//! The live preview's and the editor's hot paths, through the real `mdg-lsp` over
//! stdio (not a test; prints numbers):
//!
//! - `mdg/preview` on every std example the server evaluates (the compile, the
//!   evaluation, the `.glb` export, its size, and the request's round trip as the
//!   client sees it: the part of keystroke → frame the server owns), and what the
//!   inspector adds to the answer: the `.glb`'s sites (`mdg_sites` extras: now, and
//!   as they were before issue 39, `VERTEX` runs of `[first, site]` only) and the
//!   derivation tree's JSON;
//! - a runaway grammar: request → the answer with the limit warning;
//! - code lenses on a 3,000-line grammar: `textDocument/codeLens`, then resolving
//!   the 40 lenses a screen shows (target ≤ 10 ms a request);
//! - the first diagnostics of a file importing `shaders`, opened as soon as the
//!   server has initialised (target ≤ 100 ms).
//!
//! Run: `cargo bench -p mdg-lsp --bench preview` (release), or add `--profile dev`
//! for the debug build's numbers.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{first_shader_diagnostics, root, scratch, uri, Client};
use serde_json::{json, Value};
use std::time::{Duration, Instant};

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let dir = scratch("bench-preview");
    previews(&dir);
    runaway(&dir);
    lenses(&dir);
    first_shader_diagnostics(&dir);
}

/// `mdg/preview` five times on each std example (the first run warms the caches).
fn previews(dir: &std::path::Path) {
    let examples = root().join("std/examples");
    let mut files: Vec<_> = std::fs::read_dir(&examples)
        .expect("std/examples")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mdg"))
        .collect();
    files.sort();
    let mut c = Client::spawn();
    c.initialize(dir);
    let mut trips = Vec::new();
    // (.glb bytes, .glb bytes with the sites as before, tree bytes) over the examples.
    let mut payload = (0u64, 0u64, 0u64);
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read");
        let u = uri(&f);
        c.open(&u, 1, &text);
        let mut round = Vec::new();
        let mut last = Value::Null;
        for _ in 0..5 {
            let t0 = Instant::now();
            last = c.call("mdg/preview", json!({"uri": u}));
            round.push(ms(t0.elapsed()));
        }
        let name = f.file_name().map(|n| n.to_string_lossy().to_string()).unwrap_or_default();
        if last["status"] != "model" {
            println!("{name:<26} {} (mdg-run's mode)", last["status"]);
            continue;
        }
        let s = &last["stats"];
        let trip = median(&mut round);
        trips.push(trip);
        let (sites_now, sites_before) = sites_bytes(last["glb"].as_str().unwrap_or(""));
        let tree = serde_json::to_string(&last["tree"]).map_or(0, |t| t.len());
        let glb = s["bytes"].as_u64().unwrap_or(0);
        println!(
            "{name:<26} round trip {trip:7.1} ms (compile {:6.1}, eval {:6.1}, export {:6.1}); {:>8} triangles, .glb {:>9} bytes \
             (sites {sites_now} bytes, before {sites_before}); tree {tree} bytes, {} nodes",
            s["compileMs"].as_f64().unwrap_or(0.0),
            s["evalMs"].as_f64().unwrap_or(0.0),
            s["exportMs"].as_f64().unwrap_or(0.0),
            s["triangles"],
            glb,
            last["tree"]["nodes"].as_array().map_or(0, Vec::len),
        );
        payload.0 += glb;
        payload.1 += glb - sites_now + sites_before;
        payload.2 += tree as u64;
    }
    println!(
        "payload over the std examples: .glb {} bytes + tree {} bytes; before issue 39 (the sites as they were, no tree) {} bytes: {:+.1}%",
        payload.0,
        payload.2,
        payload.1,
        100.0 * ((payload.0 + payload.2) as f64 / payload.1.max(1) as f64 - 1.0)
    );
    let all = trips.len();
    println!(
        "mdg/preview round trip over {all} std examples: median {:.1} ms, max {:.1} ms",
        median(&mut trips),
        trips.last().copied().unwrap_or(0.0)
    );
    assert!(c.shutdown_and_exit().success());
}

/// The bytes of a base64 `.glb`'s `mdg_sites` extras (as JSON), and what the
/// `VERTEX` primitive's were before issue 39 (runs of `[first, site]`, merged by
/// site, and the table).
fn sites_bytes(b64: &str) -> (u64, u64) {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut bytes = Vec::new();
    for chunk in b64.as_bytes().chunks(4) {
        let v: Vec<u32> = chunk
            .iter()
            .filter(|&&c| c != b'=')
            .filter_map(|c| ABC.iter().position(|a| a == c))
            .map(|d| d as u32)
            .collect();
        let n = v.iter().enumerate().fold(0u32, |n, (i, d)| n | d << (18 - 6 * i));
        bytes.extend_from_slice(&n.to_be_bytes()[1..v.len().max(1)]);
    }
    let Some(len) = bytes.get(12..16).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize) else {
        return (0, 0);
    };
    let Ok(json) = serde_json::from_slice::<Value>(bytes.get(20..20 + len).unwrap_or(&[])) else { return (0, 0) };
    let mut now = 0;
    let mut before = 0;
    let mut visit = |extras: &Value, vertex: bool| {
        let Some(sites) = extras.get("mdg_sites") else { return };
        now += serde_json::to_string(extras).map_or(0, |t| t.len()) as u64;
        if vertex {
            let mut runs: Vec<[u64; 2]> = Vec::new();
            for r in sites["runs"].as_array().into_iter().flatten() {
                let (first, site) = (r[0].as_u64().unwrap_or(0), r[1].as_u64().unwrap_or(0));
                if runs.last().is_none_or(|l| l[1] != site) {
                    runs.push([first, site]);
                }
            }
            let old = json!({"mdg_sites": {"runs": runs, "sites": sites["sites"]}});
            before += serde_json::to_string(&old).map_or(0, |t| t.len()) as u64;
        }
    };
    for m in json["meshes"].as_array().into_iter().flatten() {
        for (k, p) in m["primitives"].as_array().into_iter().flatten().enumerate() {
            if let Some(e) = p.get("extras") {
                // The geometry's first primitive: the VERTEX one, unless the model has
                // none (then the sweeps' runs are counted as before, which understates
                // the change).
                visit(e, k == 0 && m["name"] == "mdg");
            }
        }
    }
    for n in json["nodes"].as_array().into_iter().flatten() {
        if let Some(e) = n.get("extras") {
            visit(e, false);
        }
    }
    (now, before)
}

/// A grammar that never ends, with the preview's default budgets.
fn runaway(dir: &std::path::Path) {
    let u = uri(&dir.join("runaway.mdg"));
    let mut c = Client::spawn();
    c.initialize(dir);
    c.open(
        &u,
        1,
        "startshape a\nrule a { tri {} a {x 1} a {y 1} }\nrule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n",
    );
    let t0 = Instant::now();
    let r = c.call("mdg/preview", json!({"uri": u}));
    println!(
        "runaway grammar: answered with {} in {:.0} ms ({}; {} bytes of .glb)",
        r["warnings"][0].as_str().unwrap_or("no warning").split(':').next().unwrap_or(""),
        ms(t0.elapsed()),
        r["stats"]["vertices"],
        r["stats"]["bytes"]
    );
    assert!(c.shutdown_and_exit().success());
}

/// Code lenses on a 3,000-line grammar of 500 rules.
fn lenses(dir: &std::path::Path) {
    let mut text = String::from("startshape r0\n");
    for i in 0..500 {
        text.push_str(&format!("rule r{i} {{\n  VERTEX {{x 1}} VERTEX {{y 1}} VERTEX {{z 1}}\n  r{} {{x 1 s 0.9}}\n  r{} {{y 1 s 0.5}}\n}}\n\n", (i + 1) % 500, (i + 7) % 500));
    }
    let lines = text.lines().count();
    let u = uri(&dir.join("lenses.mdg"));
    let mut c = Client::spawn();
    c.initialize(dir);
    c.open(&u, 1, &text);
    c.diagnostics(&u, 1);
    let mut requests = Vec::new();
    let mut resolves = Vec::new();
    let mut bytes = 0;
    for _ in 0..10 {
        let t0 = Instant::now();
        let lenses = c.call("textDocument/codeLens", json!({"textDocument": {"uri": u}}));
        requests.push(ms(t0.elapsed()));
        bytes = lenses.to_string().len();
        let screen: Vec<Value> =
            lenses.as_array().into_iter().flatten().filter(|l| l["command"].is_null()).take(40).cloned().collect();
        let t0 = Instant::now();
        for l in screen {
            c.call("codeLens/resolve", l);
        }
        resolves.push(ms(t0.elapsed()) / 40.0);
    }
    println!(
        "code lenses, {lines} lines: request median {:.2} ms ({bytes} bytes); resolve median {:.2} ms a lens (target ≤ 10 ms a request)",
        median(&mut requests),
        median(&mut resolves)
    );
    assert!(c.shutdown_and_exit().success());
}
