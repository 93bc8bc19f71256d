//! Hostile documents through the real server: nesting deep enough to overflow a
//! 2 MiB analysis thread without the nesting limit, a document over the source size
//! limit, and a recursive macro. Each gets its diagnostic (E0105, E0201, E0208) and
//! the server keeps serving the next edit.

mod common;

use common::{scratch, uri, Client};
use serde_json::json;

fn codes(diags: &[serde_json::Value]) -> Vec<String> {
    diags.iter().filter_map(|d| d["code"].as_str().map(str::to_string)).collect()
}

#[test]
fn hostile_documents_get_diagnostics_and_the_server_keeps_serving() {
    let dir = scratch("hostile");
    let u = uri(&dir.join("hostile.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);

    // 100,000 nested blocks: without the nesting limit the analysis thread's stack
    // overflows and the whole server aborts (a panic guard cannot catch that).
    let deep = format!("startshape A\nrule A {}VERTEX {{}}{} }}\n", "{ ".repeat(100_000), " }".repeat(100_000));
    c.open(&u, 1, &deep);
    let d = c.diagnostics(&u, 1);
    assert_eq!(codes(&d), ["E0105"], "{d:?}");
    let msg = d[0]["message"].as_str().unwrap_or("");
    assert!(msg.starts_with("nesting too deep: more than 256 levels\n"), "{msg}");
    // Features on the deep document answer too.
    let toks = c.call("textDocument/semanticTokens/full", json!({"textDocument": {"uri": u}}));
    assert!(toks["data"].is_array(), "{toks}");

    // A document over the 16 MiB source limit.
    let big = format!("startshape A\n{}", "rule A { VERTEX {} }\n".repeat(17 * 1024 * 1024 / 21 + 1));
    c.change(&u, 2, &big);
    let d = c.diagnostics(&u, 2);
    assert_eq!(codes(&d), ["E0201"], "{d:?}");
    assert!(d[0]["message"].as_str().unwrap_or("").contains("source file too large"), "{d:?}");

    // A macro that recurses and branches.
    let rec = "startshape A\n@macro R(a)\n@expand R(a)\n@expand R(a)\n@endmacro\nrule A { VERTEX {} @expand R(1) }\n";
    c.change(&u, 3, rec);
    let d = c.diagnostics(&u, 3);
    assert!(codes(&d).contains(&"E0208".to_string()), "{d:?}");

    // Still serving: a clean edit is analysed and hover answers.
    c.change(&u, 4, "startshape A\nrule A { VERTEX {} }\n");
    assert!(c.diagnostics(&u, 4).is_empty());
    let h = c.call("textDocument/hover", json!({"textDocument": {"uri": u}, "position": {"line": 1, "character": 10}}));
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("VERTEX"), "{h}");
    c.clear();
    assert!(!c.logs.iter().any(|l| l.contains("panic")), "{:?}", c.logs);
    assert!(c.shutdown_and_exit().success());
}
