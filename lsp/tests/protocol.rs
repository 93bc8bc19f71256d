//! Protocol tests: the built `mdg-lsp` binary spoken to over stdio, JSON-RPC
//! framed by hand — initialize, diagnostics at the right UTF-16 range with their
//! codes, every request the server offers, panic isolation, and a clean exit.

mod common;

use common::{pos_of, scratch, uri, Client};
use serde_json::{json, Value};

/// A program with an unknown rule after a comment with non-ASCII characters, so
/// the diagnostic's column is in UTF-16 units (é is 1 unit and 2 bytes, 😀 is 2 units and 4 bytes).
const MAIN: &str = "startshape A\nrule A {\n  /* é😀 */ branch {x 1}\n  30/30 * [ry 360] leaf {}\n}\nrule leaf { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";

fn text_doc(u: &str) -> Value {
    json!({"uri": u})
}

fn at(u: &str, text: &str, needle: &str, delta: usize) -> Value {
    json!({"textDocument": {"uri": u}, "position": pos_of(text, needle, delta)})
}

#[test]
fn initialize_announces_the_features() {
    let dir = scratch("init");
    let mut c = Client::spawn();
    let caps = c.initialize(&dir);
    assert_eq!(caps["textDocumentSync"]["change"], 1, "full sync");
    assert_eq!(caps["semanticTokensProvider"]["range"], true);
    assert_eq!(caps["workspace"]["workspaceFolders"]["supported"], true);
    for cap in [
        "hoverProvider",
        "definitionProvider",
        "referencesProvider",
        "renameProvider",
        "completionProvider",
        "documentSymbolProvider",
        "workspaceSymbolProvider",
        "semanticTokensProvider",
        "foldingRangeProvider",
        "documentFormattingProvider",
        "codeActionProvider",
        "inlayHintProvider",
        "documentLinkProvider",
        "documentRangeFormattingProvider",
        "codeLensProvider",
        "callHierarchyProvider",
        "selectionRangeProvider",
        "colorProvider",
    ] {
        assert!(!caps[cap].is_null(), "missing {cap} in {caps}");
    }
    assert!(c.shutdown_and_exit().success());
}

#[test]
fn diagnostics_hover_definition_completion_formatting() {
    let dir = scratch("features");
    let path = dir.join("main.mdg");
    let u = uri(&path);
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, MAIN);

    // The unknown rule, at its UTF-16 range, with its code and the suggestion in the message.
    let diags = c.diagnostics(&u, 1);
    assert_eq!(diags.len(), 1, "{diags:?}");
    let d = &diags[0];
    assert_eq!(d["code"], "E0301");
    assert_eq!(d["severity"], 1);
    assert_eq!(d["source"], "mdg");
    assert_eq!(d["range"], json!({"start": {"line": 2, "character": 12}, "end": {"line": 2, "character": 18}}));
    assert!(d["message"].as_str().unwrap_or("").starts_with("unknown rule `branch`"), "{d}");
    // The code links to its entry in the docs installed beside std.
    let href = d["codeDescription"]["href"].as_str().unwrap_or("");
    assert!(href.starts_with("file:///") && href.ends_with("/docs/diagnostics.md#e0301"), "{d}");

    // Hover: a drawable's docs and an iterator's step.
    let h = c.call("textDocument/hover", at(&u, MAIN, "VERTEX", 1));
    assert_eq!(h["contents"]["kind"], "markdown");
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("Emit a vertex"), "{h}");
    let h = c.call("textDocument/hover", at(&u, MAIN, "30/30", 1));
    assert_eq!(h["contents"]["value"], "`30/30 * [ry 360]` → 30 step(s) of `ry 12°`");

    // Definition of `leaf` from its call.
    let def = c.call("textDocument/definition", at(&u, MAIN, "leaf {}", 1));
    assert_eq!(def["uri"], u.as_str());
    assert_eq!(def["range"], json!({"start": {"line": 5, "character": 5}, "end": {"line": 5, "character": 9}}));

    // References, highlight and rename of `leaf`.
    let refs = c.call("textDocument/references", json!({"textDocument": {"uri": u}, "position": pos_of(MAIN, "leaf {}", 0), "context": {"includeDeclaration": true}}));
    assert_eq!(refs.as_array().map(Vec::len), Some(2), "{refs}");
    let hl = c.call("textDocument/documentHighlight", at(&u, MAIN, "leaf {}", 0));
    assert_eq!(hl.as_array().map(Vec::len), Some(2), "{hl}");
    let prep = c.call("textDocument/prepareRename", at(&u, MAIN, "leaf {}", 0));
    assert_eq!(prep["placeholder"], "leaf");
    let edit = c.call(
        "textDocument/rename",
        json!({"textDocument": {"uri": u}, "position": pos_of(MAIN, "leaf {}", 0), "newName": "petal"}),
    );
    assert_eq!(edit["changes"][u.as_str()].as_array().map(Vec::len), Some(2), "{edit}");
    let bad = c.request(
        "textDocument/rename",
        json!({"textDocument": {"uri": u}, "position": pos_of(MAIN, "leaf {}", 0), "newName": "9"}),
    );
    assert!(bad["error"]["message"].as_str().unwrap_or("").contains("not a valid name"), "{bad}");

    // Completion inside an adjustment list offers adjustments as snippets.
    let comp = c.call("textDocument/completion", at(&u, MAIN, "x 1}", 0));
    let items = comp["items"].as_array().cloned().unwrap_or_default();
    let rx = items.iter().find(|i| i["label"] == "rx").unwrap_or_else(|| panic!("no rx in {comp}"));
    assert_eq!(rx["insertTextFormat"], 2);
    assert_eq!(rx["textEdit"]["newText"], "rx ${1:90}");

    // The quick fix creates the missing rule.
    let range = json!({"start": pos_of(MAIN, "branch", 1), "end": pos_of(MAIN, "branch", 1)});
    let actions = c.call(
        "textDocument/codeAction",
        json!({"textDocument": {"uri": u}, "range": range, "context": {"diagnostics": []}}),
    );
    let titles: Vec<&str> = actions.as_array().into_iter().flatten().filter_map(|a| a["title"].as_str()).collect();
    assert_eq!(titles, ["Create rule `branch`"]);
    assert_eq!(actions[0]["diagnostics"][0]["code"], "E0301");

    // Outline, tokens, folding and hints answer.
    let syms = c.call("textDocument/documentSymbol", json!({"textDocument": text_doc(&u)}));
    let names: Vec<&str> = syms.as_array().into_iter().flatten().filter_map(|s| s["name"].as_str()).collect();
    assert_eq!(names, ["A", "leaf"]);
    let toks = c.call("textDocument/semanticTokens/full", json!({"textDocument": text_doc(&u)}));
    assert_eq!(toks["data"].as_array().map(|d| d.len() % 5), Some(0));
    assert!(toks["data"].as_array().map(Vec::len).unwrap_or(0) > 50, "{toks}");
    let folds = c.call("textDocument/foldingRange", json!({"textDocument": text_doc(&u)}));
    assert_eq!(folds, json!([{"startLine": 1, "endLine": 3, "kind": "region"}]));
    let hints = c.call("textDocument/inlayHint", json!({"textDocument": text_doc(&u), "range": {"start": {"line": 0, "character": 0}, "end": {"line": 9, "character": 0}}}));
    assert_eq!(hints[0]["label"], "30 × ry 12°");
    let ws = c.call("workspace/symbol", json!({"query": "lef"}));
    assert_eq!(ws[0]["name"], "leaf");

    // Formatting: the edit gives `mdgc fmt`'s layout.
    let messy = "startshape A\nrule A {\nVERTEX {x 1}   VERTEX {y 1} VERTEX {}\n}\n";
    c.change(&u, 2, messy);
    let diags = c.diagnostics(&u, 2);
    assert!(diags.is_empty(), "{diags:?}");
    let edits = c.call(
        "textDocument/formatting",
        json!({"textDocument": text_doc(&u), "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    let edits = edits.as_array().cloned().unwrap_or_default();
    assert_eq!(edits.len(), 1, "{edits:?}");
    let formatted = mdg_format(messy, &edits[0]);
    assert_eq!(formatted, "startshape A\nrule A {\n  VERTEX {x 1}\n  VERTEX {y 1}\n  VERTEX {}\n}\n");

    assert!(c.shutdown_and_exit().success());
}

/// A program with the §11 extension sections (guided search and a creature grammar).
const SECTIONS: &str = "search {\n  skeleton limb;\n}\nguide left {\n  points 0 0 0  0 0 1  0.5 0 2  1.5 0 2.5;\n  delta_a 0.6;\n}\ncreature monsters {\n  part torso_h { rule limb; mesh \"parts/torso.obj\"; slot neck { at 0 0 1.4; } }\n}\nrule limb { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";

/// The semantic tokens as (line, column, length, type, modifiers).
fn decode_tokens(data: &Value) -> Vec<[u64; 5]> {
    let nums: Vec<u64> = data.as_array().into_iter().flatten().filter_map(Value::as_u64).collect();
    let (mut line, mut col) = (0, 0);
    nums.chunks(5)
        .map(|c| {
            if c[0] > 0 {
                (line, col) = (line + c[0], c[1]);
            } else {
                col += c[1];
            }
            [line, col, c[2], c[3], c[4]]
        })
        .collect()
}

#[test]
fn sections_hover_outline_completion_tokens_and_folding() {
    use mdg_compiler::ext::keys;
    let dir = scratch("sections");
    let u = uri(&dir.join("main.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, SECTIONS);
    c.diagnostics(&u, 1);

    // Hover on a section word: what the section is for, and where its keys are documented.
    let h = c.call("textDocument/hover", at(&u, SECTIONS, "guide", 2));
    assert_eq!(h["contents"]["kind"], "markdown");
    let text = h["contents"]["value"].as_str().unwrap_or("");
    assert!(text.starts_with("```mdg\nguide [NAME] {"), "{h}");
    assert!(text.contains("docs/guided.md"), "{h}");
    assert!(c.call("textDocument/hover", at(&u, SECTIONS, "creature", 1))["contents"]["value"]
        .as_str()
        .unwrap_or("")
        .contains("docs/creatures.md"));

    // Hover on a key: its values and doc from the key table (nothing for a key it lacks),
    // at the key's range.
    for (needle, path) in
        [("delta_a", &["guide"][..]), ("slot", &["creature", "part"][..]), ("at 0", &["creature", "part", "slot"][..])]
    {
        let name = needle.split(' ').next().unwrap_or(needle);
        let h = c.call("textDocument/hover", at(&u, SECTIONS, needle, 1));
        match keys(path).iter().find(|k| k.name == name) {
            Some(k) => {
                let value = h["contents"]["value"].as_str().unwrap_or("");
                assert!(value.starts_with(format!("```mdg\n{} {}", k.name, k.values).trim_end()), "{h}");
                assert!(value.contains(k.doc), "{h}");
                let start = pos_of(SECTIONS, needle, 0);
                assert_eq!(h["range"]["start"], start, "{h}");
            }
            None => assert!(h.is_null(), "{h}"),
        }
    }

    // The outline: each section, its named blocks nested.
    let syms = c.call("textDocument/documentSymbol", json!({"textDocument": text_doc(&u)}));
    let names: Vec<&str> = syms.as_array().into_iter().flatten().filter_map(|s| s["name"].as_str()).collect();
    assert_eq!(names, ["search", "guide left", "creature monsters", "limb"]);
    let creature = &syms[2];
    assert_eq!(creature["kind"], 23, "a section is a struct: {creature}");
    assert_eq!(creature["selectionRange"]["start"], pos_of(SECTIONS, "monsters", 0));
    assert_eq!(creature["children"][0]["name"], "part torso_h");
    assert_eq!(creature["children"][0]["kind"], 19, "a named block is an object");
    assert_eq!(creature["children"][0]["children"][0]["name"], "slot neck");

    // Completion at the start of an entry offers the keys of the section, as properties.
    let comp = c.call("textDocument/completion", at(&u, SECTIONS, "delta_a", 0));
    let items = comp["items"].as_array().cloned().unwrap_or_default();
    let labels: Vec<&str> = items.iter().filter_map(|i| i["label"].as_str()).collect();
    let want: Vec<&str> = keys(&["guide"]).iter().map(|k| k.name).collect();
    assert_eq!(labels, want, "{comp}");
    assert!(items.iter().all(|i| i["kind"] == 10 && i["insertTextFormat"] == 2), "{comp}");

    // Tokens: the section word is a keyword, keys are properties, the path a string.
    let toks =
        decode_tokens(&c.call("textDocument/semanticTokens/full", json!({"textDocument": text_doc(&u)}))["data"]);
    let token_at = |needle: &str| {
        let p = pos_of(SECTIONS, needle, 0);
        let (line, col) = (p["line"].as_u64().unwrap_or(0), p["character"].as_u64().unwrap_or(0));
        toks.iter().find(|t| t[0] == line && t[1] == col).map(|t| (t[2], t[3], t[4]))
    };
    assert_eq!(token_at("guide"), Some((5, 4, 0)), "keyword");
    assert_eq!(token_at("delta_a"), Some((7, 3, 0)), "property");
    assert_eq!(token_at("rule limb;"), Some((4, 3, 0)), "`rule` as a key is a property");
    assert_eq!(token_at("\"parts"), Some((17, 11, 0)), "string");
    assert_eq!(token_at("limb;"), Some((4, 0, 0)), "a rule name the section refers to is a rule");

    // Folding: the multi-line sections.
    let folds = c.call("textDocument/foldingRange", json!({"textDocument": text_doc(&u)}));
    assert_eq!(
        folds,
        json!([{"startLine": 0, "endLine": 1, "kind": "region"}, {"startLine": 3, "endLine": 5, "kind": "region"}, {"startLine": 7, "endLine": 8, "kind": "region"}])
    );
    assert!(c.shutdown_and_exit().success());
}

/// Applies one LSP edit (ASCII text only) to `text`.
fn mdg_format(text: &str, edit: &Value) -> String {
    let offset = |p: &Value| {
        let line = p["line"].as_u64().unwrap_or(0) as usize;
        let col = p["character"].as_u64().unwrap_or(0) as usize;
        text.split_inclusive('\n').take(line).map(str::len).sum::<usize>() + col
    };
    let (s, e) = (offset(&edit["range"]["start"]), offset(&edit["range"]["end"]));
    format!("{}{}{}", &text[..s], edit["newText"].as_str().unwrap_or(""), &text[e..])
}

#[test]
fn unsaved_imports_and_their_dependents() {
    let dir = scratch("imports");
    let (main, lib) = (dir.join("main.mdg"), dir.join("lib.mdg"));
    let (um, ul) = (uri(&main), uri(&lib));
    // The library exists only in the editor, not on disk.
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&ul, 1, "rule shape { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    c.diagnostics(&ul, 1);
    let main_text = "@import lib.mdg\nstartshape A\nrule A { shape {} }\n";
    c.open(&um, 1, main_text);
    assert_eq!(c.diagnostics(&um, 1), Vec::<Value>::new());
    let def = c.call("textDocument/definition", at(&um, main_text, "shape {}", 1));
    assert_eq!(def["uri"], ul.as_str());
    // Removing the rule from the library re-checks the program that imports it.
    c.change(&ul, 2, "rule form { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    let diags = c.diagnostics(&um, 1);
    assert_eq!(diags.iter().map(|d| d["code"].clone()).collect::<Vec<_>>(), [json!("E0301")]);
    assert!(c.shutdown_and_exit().success());
}

#[test]
fn stale_changes_are_ignored() {
    let dir = scratch("stale");
    let u = uri(&dir.join("a.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 5, "startshape A\nrule A { VERTEX {} }\n");
    assert!(c.diagnostics(&u, 5).is_empty());
    c.change(&u, 4, "startshape A\nrule A { nope {} }\n");
    c.change(&u, 6, "startshape A\nrule A { VERTEX {} nope2 {} }\n");
    let diags = c.diagnostics(&u, 6);
    assert_eq!(diags.len(), 1);
    assert!(diags[0]["message"].as_str().unwrap_or("").contains("nope2"));
    assert!(c.logs.iter().any(|l| l.contains("stale change")), "{:?}", c.logs);
    assert!(c.shutdown_and_exit().success());
}

#[test]
fn a_panicking_request_does_not_take_the_server_down() {
    let dir = scratch("panic");
    let u = uri(&dir.join("a.mdg"));
    let mut c = Client::spawn_with(&[("MDG_LSP_PANIC_COMMAND", "1")]);
    c.initialize(&dir);
    let text = "startshape A\nrule A { VERTEX {} }\n";
    c.open(&u, 1, text);
    c.diagnostics(&u, 1);
    let r = c.request("workspace/executeCommand", json!({"command": "mdg.debug.panic", "arguments": []}));
    assert_eq!(r["error"]["code"], -32603, "{r}");
    assert!(r["error"]["message"].as_str().unwrap_or("").contains("panic requested"), "{r}");
    // Still serving.
    let h = c.call("textDocument/hover", at(&u, text, "VERTEX", 0));
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("VERTEX"));
    c.clear();
    assert!(c.logs.iter().any(|l| l.contains("panic in mdg.debug.panic")), "{:?}", c.logs);
    assert!(c.shutdown_and_exit().success());
}

#[test]
fn exit_without_shutdown_exits_with_1() {
    let dir = scratch("exit");
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.notify("exit", Value::Null);
    assert_eq!(c.wait_exit().code(), Some(1));
}

#[test]
fn version_flag() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_mdg-lsp")).arg("--version").output().expect("run");
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).starts_with("mdg-lsp "));
}

/// The files of a workspace test: a library, two importers and an unrelated file
/// with its own rule of the same name.
const WS_LIB: &str = "rule shape { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
const WS_A: &str = "@import lib.mdg\nstartshape A\nrule A { shape {} }\n";
const WS_B: &str =
    "@import lib.mdg\nstartshape B\nrule B { shape {x 2} shape {y 2} twig {} }\nrule twig { VERTEX {} }\n";
const WS_OTHER: &str = "startshape C\nrule C { shape {} }\nrule shape { VERTEX {} }\n";

/// (file name, start line, start character) of each location, sorted.
fn places(locations: &Value) -> Vec<(String, u64, u64)> {
    let mut v: Vec<(String, u64, u64)> = locations
        .as_array()
        .into_iter()
        .flatten()
        .map(|l| {
            let u = l["uri"].as_str().unwrap_or("");
            let name = u.rsplit('/').next().unwrap_or("").to_string();
            let s = &l["range"]["start"];
            (name, s["line"].as_u64().unwrap_or(0), s["character"].as_u64().unwrap_or(0))
        })
        .collect();
    v.sort();
    v
}

/// The (file name, number of edits) of a workspace edit, sorted.
fn edit_counts(edit: &Value) -> Vec<(String, usize)> {
    let mut v: Vec<(String, usize)> = edit["changes"]
        .as_object()
        .into_iter()
        .flatten()
        .map(|(u, e)| (u.rsplit('/').next().unwrap_or("").to_string(), e.as_array().map(Vec::len).unwrap_or(0)))
        .collect();
    v.sort();
    v
}

#[test]
fn the_workspace_not_only_the_open_files() {
    let dir = common::canonical_scratch("workspace");
    for (name, text) in [("lib.mdg", WS_LIB), ("a.mdg", WS_A), ("b.mdg", WS_B), ("other.mdg", WS_OTHER)] {
        std::fs::write(dir.join(name), text).expect("write");
    }
    let (ul, ua, ub) = (uri(&dir.join("lib.mdg")), uri(&dir.join("a.mdg")), uri(&dir.join("b.mdg")));
    let mut c = Client::spawn();
    c.initialize(&dir);
    // The library and one importer are open; `b.mdg` stays closed.
    c.open(&ul, 1, WS_LIB);
    c.open(&ua, 1, WS_A);
    assert!(c.diagnostics(&ul, 1).is_empty());
    assert!(c.diagnostics(&ua, 1).is_empty());

    // Workspace symbols cover the closed files (and wait for the index).
    let ws = c.call("workspace/symbol", json!({"query": "twig"}));
    assert_eq!(
        places(&ws.as_array().map(|a| a.iter().map(|s| s["location"].clone()).collect()).unwrap_or(json!([]))),
        [("b.mdg".to_string(), 3, 5)]
    );
    c.notification("window/logMessage", |p| {
        p["message"].as_str().unwrap_or("").contains("indexed 4 files of the workspace")
    });

    // References from the definition in the library reach both importers, open or
    // not, and not the unrelated rule of the same name.
    let want = [
        ("a.mdg".to_string(), 2, 9),
        ("b.mdg".to_string(), 2, 9),
        ("b.mdg".to_string(), 2, 21),
        ("lib.mdg".to_string(), 0, 5),
    ];
    let refs = c.call("textDocument/references", json!({"textDocument": {"uri": ul}, "position": pos_of(WS_LIB, "shape", 0), "context": {"includeDeclaration": true}}));
    assert_eq!(places(&refs), want, "{refs}");
    // The same from a use in an importer.
    let refs = c.call("textDocument/references", json!({"textDocument": {"uri": ua}, "position": pos_of(WS_A, "shape {}", 1), "context": {"includeDeclaration": true}}));
    assert_eq!(places(&refs), want, "{refs}");
    let refs = c.call("textDocument/references", json!({"textDocument": {"uri": ua}, "position": pos_of(WS_A, "shape {}", 1), "context": {"includeDeclaration": false}}));
    assert_eq!(places(&refs).len(), 3, "{refs}");

    // Rename edits the library and both importers.
    let edit = c.call(
        "textDocument/rename",
        json!({"textDocument": {"uri": ua}, "position": pos_of(WS_A, "shape {}", 1), "newName": "form"}),
    );
    assert_eq!(edit_counts(&edit), [("a.mdg".to_string(), 1), ("b.mdg".to_string(), 2), ("lib.mdg".to_string(), 1)]);
    assert!(edit["changes"][ub.as_str()].as_array().into_iter().flatten().all(|e| e["newText"] == "form"), "{edit}");
    // A name that clashes in the closed importer is refused, naming it.
    let clash = c.request(
        "textDocument/rename",
        json!({"textDocument": {"uri": ul}, "position": pos_of(WS_LIB, "shape", 0), "newName": "twig"}),
    );
    let message = clash["error"]["message"].as_str().unwrap_or("");
    assert!(message.contains("a rule named `twig` already exists (in b.mdg)"), "{clash}");

    // An edit of the library that breaks the closed importer publishes its diagnostics...
    c.change(&ul, 2, "rule form { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    let closed = c.notification("textDocument/publishDiagnostics", |p| p["uri"] == ub.as_str());
    assert!(closed["version"].is_null(), "{closed}");
    let codes: Vec<&str> =
        closed["diagnostics"].as_array().into_iter().flatten().filter_map(|d| d["code"].as_str()).collect();
    assert_eq!(codes, ["E0301", "E0301"], "{closed}");
    assert_eq!(closed["diagnostics"][0]["range"]["start"], json!({"line": 2, "character": 9}));
    // ... and mending it clears them.
    c.change(&ul, 3, WS_LIB);
    let closed = c.notification("textDocument/publishDiagnostics", |p| p["uri"] == ub.as_str());
    assert_eq!(closed["diagnostics"], json!([]), "{closed}");

    // Files created and deleted on disk, announced by the client's watcher.
    let uc = uri(&dir.join("c.mdg"));
    std::fs::write(dir.join("c.mdg"), "@import lib.mdg\nstartshape D\nrule D { shape {} }\n").expect("write");
    std::fs::remove_file(dir.join("b.mdg")).expect("remove");
    c.notify("workspace/didChangeWatchedFiles", json!({"changes": [{"uri": uc, "type": 1}, {"uri": ub, "type": 3}]}));
    c.notification("window/logMessage", |p| p["message"].as_str().unwrap_or("").contains("2 watched file(s) changed"));
    let refs = c.call("textDocument/references", json!({"textDocument": {"uri": ul}, "position": pos_of(WS_LIB, "shape", 0), "context": {"includeDeclaration": false}}));
    assert_eq!(places(&refs), [("a.mdg".to_string(), 2, 9), ("c.mdg".to_string(), 2, 9)], "{refs}");
    assert!(c.shutdown_and_exit().success());
}

#[test]
fn links_token_ranges_and_format_errors() {
    let dir = common::canonical_scratch("links");
    std::fs::write(dir.join("lib.mdg"), "rule shape { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("write");
    let u = uri(&dir.join("main.mdg"));
    let text = "@import lib.mdg primitives\nstartshape A\nrule A {\n  shape {}\n  cube {x 2}\n}\nrule B { shape {} }\n";
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, text);
    c.diagnostics(&u, 1);

    // Each @import word links to its file.
    let links = c.call("textDocument/documentLink", json!({"textDocument": text_doc(&u)}));
    let targets: Vec<&str> = links.as_array().into_iter().flatten().filter_map(|l| l["target"].as_str()).collect();
    assert_eq!(targets.len(), 2, "{links}");
    assert_eq!(targets[0], uri(&dir.join("lib.mdg")));
    assert!(targets[1].ends_with("/std/primitives.mdg"), "{links}");
    assert_eq!(links[0]["range"], json!({"start": {"line": 0, "character": 8}, "end": {"line": 0, "character": 15}}));

    // Tokens of a range are the full tokens on those lines, encoded the same way.
    let full =
        decode_tokens(&c.call("textDocument/semanticTokens/full", json!({"textDocument": text_doc(&u)}))["data"]);
    let range = c.call(
        "textDocument/semanticTokens/range",
        json!({"textDocument": text_doc(&u), "range": {"start": {"line": 3, "character": 0}, "end": {"line": 5, "character": 0}}}),
    );
    let part = decode_tokens(&range["data"]);
    let want: Vec<[u64; 5]> = full.iter().filter(|t| (3..5).contains(&t[0])).copied().collect();
    assert!(!want.is_empty());
    assert_eq!(part, want);

    // Formatting a file with a syntax error says why, where the user looks.
    c.change(&u, 2, "startshape A\nrule A { VERTEX {x 1 }\n");
    c.diagnostics(&u, 2);
    let r = c.call(
        "textDocument/formatting",
        json!({"textDocument": text_doc(&u), "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert!(r.is_null(), "{r}");
    let shown = c.notification("window/showMessage", |_| true);
    assert_eq!(shown["type"], 2, "a warning: {shown}");
    assert!(shown["message"].as_str().unwrap_or("").contains("not formatting, the file has syntax errors"), "{shown}");

    assert!(c.shutdown_and_exit().success());
}

/// The text of an LSP range (ASCII text only).
fn text_of(text: &str, range: &Value) -> String {
    let offset = |p: &Value| {
        let line = p["line"].as_u64().unwrap_or(0) as usize;
        let col = p["character"].as_u64().unwrap_or(0) as usize;
        text.split_inclusive('\n').take(line).map(str::len).sum::<usize>() + col
    };
    text[offset(&range["start"])..offset(&range["end"])].to_string()
}

/// (title, command, line) of each lens, in order.
fn lens_rows(lenses: &Value) -> Vec<(String, String, u64)> {
    lenses
        .as_array()
        .into_iter()
        .flatten()
        .map(|l| {
            (
                l["command"]["title"].as_str().unwrap_or("").to_string(),
                l["command"]["command"].as_str().unwrap_or("").to_string(),
                l["range"]["start"]["line"].as_u64().unwrap_or(99),
            )
        })
        .collect()
}

/// The lenses with every unresolved one resolved (`codeLens/resolve`), as a client
/// resolves those it shows.
fn resolve_lenses(c: &mut Client, lenses: &Value) -> Value {
    let all = lenses.as_array().into_iter().flatten();
    Value::Array(
        all.map(|l| if l["command"].is_null() { c.call("codeLens/resolve", l.clone()) } else { l.clone() }).collect(),
    )
}

#[test]
fn code_lenses_and_call_hierarchy_across_the_workspace() {
    let dir = common::canonical_scratch("lenses");
    for (name, text) in [("lib.mdg", WS_LIB), ("a.mdg", WS_A), ("b.mdg", WS_B), ("sections.mdg", SECTIONS)] {
        std::fs::write(dir.join(name), text).expect("write");
    }
    let (ul, ua, us) = (uri(&dir.join("lib.mdg")), uri(&dir.join("a.mdg")), uri(&dir.join("sections.mdg")));
    let ub = uri(&dir.join("b.mdg"));
    let s = |v: &str| v.to_string();
    let mut c = Client::spawn();
    c.initialize(&dir);
    // `b.mdg` stays closed: its calls count from the workspace index.
    c.open(&ul, 1, WS_LIB);
    c.open(&ua, 1, WS_A);
    c.open(&us, 1, SECTIONS);
    c.diagnostics(&ua, 1);

    // The importer: run lenses over `startshape`, the count over its rule. The
    // counts come unresolved (no command: the client resolves the visible ones).
    let lenses = c.call("textDocument/codeLens", json!({"textDocument": text_doc(&ua)}));
    let unresolved: Vec<&Value> = lenses.as_array().into_iter().flatten().filter(|l| l["command"].is_null()).collect();
    assert_eq!(unresolved.len(), 1, "{lenses}");
    assert!(unresolved[0]["data"].is_object(), "{lenses}");
    let lenses = resolve_lenses(&mut c, &lenses);
    assert_eq!(
        lens_rows(&lenses),
        [
            (s("▶ Preview"), s("mdg.preview"), 1),
            (s("Render .glb"), s("mdg.renderGlb"), 1),
            (s("Stats"), s("mdg.stats"), 1),
            (s("1 reference"), s("mdg.showReferences"), 2),
        ],
        "{lenses}"
    );
    assert_eq!(lenses[0]["command"]["arguments"], json!([ua]));
    // The library's rule: called once in a.mdg and twice in the closed b.mdg.
    let lenses = c.call("textDocument/codeLens", json!({"textDocument": text_doc(&ul)}));
    let lenses = resolve_lenses(&mut c, &lenses);
    assert_eq!(lens_rows(&lenses), [(s("3 references"), s("mdg.showReferences"), 0)], "{lenses}");
    let args = &lenses[0]["command"]["arguments"];
    assert_eq!(args[0], ul.as_str());
    assert_eq!(args[1], json!({"line": 0, "character": 5}));
    assert_eq!(places(&args[2]), [(s("a.mdg"), 2, 9), (s("b.mdg"), 2, 9), (s("b.mdg"), 2, 21)], "{lenses}");
    // A lens resolved after an edit counts the rule defined at its place now (the
    // client resolves lenses it already had): made over `shapf` (no calls), resolved
    // once the library says `shape` again.
    c.change(&ul, 2, &WS_LIB.replace("shape", "shapf"));
    c.diagnostics(&ul, 2);
    let stale = c.call("textDocument/codeLens", json!({"textDocument": text_doc(&ul)}))[0].clone();
    c.change(&ul, 3, WS_LIB);
    c.diagnostics(&ul, 3);
    // The importers are re-analysed in the background after the library's edit: on a
    // loaded machine the first resolve may still see them as they were under `shapf`
    // (asked again, as a client does on its next lens refresh; 60 s hang guard).
    let asked = std::time::Instant::now();
    let resolved = loop {
        let resolved = c.call("codeLens/resolve", stale.clone());
        if resolved["command"]["title"] == "3 references" || asked.elapsed() > std::time::Duration::from_secs(60) {
            break resolved;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    assert_eq!(resolved["command"]["title"], "3 references", "{resolved}");
    // Extension sections: the guided search and the creature evolution.
    let lenses = c.call("textDocument/codeLens", json!({"textDocument": text_doc(&us)}));
    let lenses = resolve_lenses(&mut c, &lenses);
    let rows = lens_rows(&lenses);
    assert_eq!(rows[0], (s("Run search"), s("mdg.runSearch"), 0), "{lenses}");
    assert!(rows.contains(&(s("Evolve"), s("mdg.evolve"), 7)), "{lenses}");

    // Call hierarchy of the library's rule: called by A (open) and B (closed).
    let items = c.call("textDocument/prepareCallHierarchy", at(&ul, WS_LIB, "shape", 1));
    assert_eq!(items.as_array().map(Vec::len), Some(1), "{items}");
    assert_eq!(items[0]["name"], "shape");
    assert_eq!(items[0]["uri"], ul.as_str());
    assert_eq!(items[0]["selectionRange"]["start"], json!({"line": 0, "character": 5}));
    let incoming = c.call("callHierarchy/incomingCalls", json!({"item": items[0]}));
    let callers: Vec<(String, String, usize)> = incoming
        .as_array()
        .into_iter()
        .flatten()
        .map(|i| {
            let u = i["from"]["uri"].as_str().unwrap_or("");
            (
                i["from"]["name"].as_str().unwrap_or("").to_string(),
                u.rsplit('/').next().unwrap_or("").to_string(),
                i["fromRanges"].as_array().map(Vec::len).unwrap_or(0),
            )
        })
        .collect();
    assert_eq!(callers, [(s("A"), s("a.mdg"), 1), (s("B"), s("b.mdg"), 2)], "{incoming}");
    // Outgoing calls of the closed file's rule B: `shape` twice (into the library), `twig` once.
    let b_item = &incoming[1]["from"];
    assert_eq!(b_item["uri"], ub.as_str());
    let outgoing = c.call("callHierarchy/outgoingCalls", json!({"item": b_item}));
    let callees: Vec<(String, String, usize)> = outgoing
        .as_array()
        .into_iter()
        .flatten()
        .map(|o| {
            let u = o["to"]["uri"].as_str().unwrap_or("");
            (
                o["to"]["name"].as_str().unwrap_or("").to_string(),
                u.rsplit('/').next().unwrap_or("").to_string(),
                o["fromRanges"].as_array().map(Vec::len).unwrap_or(0),
            )
        })
        .collect();
    assert_eq!(callees, [(s("shape"), s("lib.mdg"), 2), (s("twig"), s("b.mdg"), 1)], "{outgoing}");
    assert_eq!(outgoing[0]["fromRanges"][1]["start"], json!({"line": 2, "character": 21}));
    // From a call: the callee's definitions.
    let items = c.call("textDocument/prepareCallHierarchy", at(&ua, WS_A, "shape {}", 1));
    assert_eq!(items[0]["uri"], ul.as_str(), "{items}");
    // Nothing for a word that is no rule.
    let none = c.call("textDocument/prepareCallHierarchy", at(&ua, WS_A, "startshape", 1));
    assert!(none.is_null(), "{none}");
    assert!(c.shutdown_and_exit().success());
}

/// A file with colours, a messy rule and nested syntax.
const COLOUR_VALUES: &str = "startshape A\nrule A {\n  tri {#ff8000 x 1}\n  4 * {#tomato} tri {}\n  tri {#}\n}\nrule tri { VERTEX {} VERTEX {x 0.8} VERTEX {y 0.8} }\n";

#[test]
fn colour_values_are_swatches_hovers_and_completions() {
    let dir = scratch("colour_values");
    let u = uri(&dir.join("main.mdg"));
    let mut c = Client::spawn();
    let caps = c.initialize(&dir);
    assert!(
        caps["completionProvider"]["triggerCharacters"].as_array().is_some_and(|t| t.contains(&json!("#"))),
        "{caps}"
    );
    c.open(&u, 1, COLOUR_VALUES);
    let colours = c.call("textDocument/documentColor", json!({"textDocument": text_doc(&u)}));
    let got: Vec<(String, Vec<f64>)> = colours
        .as_array()
        .into_iter()
        .flatten()
        .map(|ci| {
            let col = &ci["color"];
            let v = ["red", "green", "blue", "alpha"].map(|k| (col[k].as_f64().unwrap_or(-1.0) * 255.0).round());
            (text_of(COLOUR_VALUES, &ci["range"]), v.to_vec())
        })
        .collect();
    assert_eq!(
        got,
        [
            (String::from("#ff8000"), vec![255.0, 128.0, 0.0, 255.0]),
            (String::from("#tomato"), vec![255.0, 99.0, 71.0, 255.0])
        ],
        "{colours}"
    );
    let color = json!({"red": 0.0, "green": 0.5, "blue": 1.0, "alpha": 1.0});
    let p = c.call(
        "textDocument/colorPresentation",
        json!({"textDocument": text_doc(&u), "color": color, "range": colours[1]["range"]}),
    );
    assert_eq!(p[0]["textEdit"]["newText"], "#0080ff", "{p}");
    let h = c.call("textDocument/hover", at(&u, COLOUR_VALUES, "#tomato", 2));
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("palette name `tomato`"), "{h}");
    let comp = c.call("textDocument/completion", at(&u, COLOUR_VALUES, "#}", 1));
    let items = comp["items"].as_array().cloned().unwrap_or_default();
    let tomato = items.iter().find(|i| i["label"] == "tomato").unwrap_or_else(|| panic!("no tomato in {comp}"));
    assert_eq!(tomato["kind"], 16, "CompletionItemKind::COLOR");
    assert_eq!(tomato["detail"], "#ff6347");
}

const COLOURS: &str = "background 0.2 0.4 0.6 1\nstartshape A\nrule A {\n  tri {G -1 x 1 B -1}\n  tri {hue 30 R -1}\n}\nrule tri { VERTEX {}   VERTEX {x 0.8} VERTEX {y 0.8} }\n";

#[test]
fn selection_ranges_colours_range_formatting_and_code_links() {
    let dir = scratch("colours");
    let u = uri(&dir.join("main.mdg"));
    let mut c = Client::spawn_with(&[("MDG_DOCS_URL", "https://mdg.example/docs/")]);
    c.initialize(&dir);
    c.open(&u, 1, COLOURS);
    assert!(c.diagnostics(&u, 1).is_empty());

    // Expand selection from inside a number: each enclosing node, then the file.
    let sel = c.call(
        "textDocument/selectionRange",
        json!({"textDocument": text_doc(&u), "positions": [pos_of(COLOURS, "0.8}", 1)]}),
    );
    let mut texts = Vec::new();
    let mut r = &sel[0];
    while !r.is_null() {
        texts.push(text_of(COLOURS, &r["range"]));
        r = &r["parent"];
    }
    assert_eq!(
        texts,
        [
            "0.8",
            "x 0.8",
            "{x 0.8}",
            "VERTEX {x 0.8}",
            " VERTEX {}   VERTEX {x 0.8} VERTEX {y 0.8} ",
            "{ VERTEX {}   VERTEX {x 0.8} VERTEX {y 0.8} }",
            "rule tri { VERTEX {}   VERTEX {x 0.8} VERTEX {y 0.8} }",
            COLOURS,
        ],
        "{sel}"
    );

    // Colours: the background as written, the deltas as the colour they give from
    // white (a list that turns the hue has none).
    let colours = c.call("textDocument/documentColor", json!({"textDocument": text_doc(&u)}));
    let got: Vec<(String, Vec<f64>)> = colours
        .as_array()
        .into_iter()
        .flatten()
        .map(|ci| {
            let col = &ci["color"];
            let v =
                ["red", "green", "blue", "alpha"].map(|k| (col[k].as_f64().unwrap_or(-1.0) * 1000.0).round() / 1000.0);
            (text_of(COLOURS, &ci["range"]), v.to_vec())
        })
        .collect();
    assert_eq!(
        got,
        [
            (String::from("0.2 0.4 0.6 1"), vec![0.2, 0.4, 0.6, 1.0]),
            (String::from("G -1 x 1 B -1"), vec![1.0, 0.0, 0.0, 1.0])
        ],
        "{colours}"
    );
    let present = |c: &mut Client, range: &Value, rgba: [f64; 4]| {
        let color = json!({"red": rgba[0], "green": rgba[1], "blue": rgba[2], "alpha": rgba[3]});
        let p = c.call(
            "textDocument/colorPresentation",
            json!({"textDocument": text_doc(&u), "color": color, "range": range}),
        );
        assert_eq!(p[0]["textEdit"]["range"], *range, "{p}");
        p[0]["textEdit"]["newText"].as_str().unwrap_or("").to_string()
    };
    assert_eq!(present(&mut c, &colours[0]["range"], [1.0, 0.5, 0.0, 1.0]), "1 0.5 0 1");
    // Deltas from white, the other adjustments kept after them.
    assert_eq!(present(&mut c, &colours[1]["range"], [0.0, 0.5, 1.0, 0.75]), "R -1 G -0.5 A -0.25 x 1");

    // Range formatting: only the rule the range touches changes.
    let range = json!({"start": pos_of(COLOURS, "VERTEX {x", 0), "end": pos_of(COLOURS, "VERTEX {x", 3)});
    let edits = c.call(
        "textDocument/rangeFormatting",
        json!({"textDocument": text_doc(&u), "range": range, "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert_eq!(edits.as_array().map(Vec::len), Some(1), "{edits}");
    let formatted = mdg_format(COLOURS, &edits[0]);
    let (head, _) = COLOURS.split_at(COLOURS.find("rule tri").unwrap_or(0));
    assert_eq!(formatted, format!("{head}rule tri {{\n  VERTEX {{}}\n  VERTEX {{x 0.8}}\n  VERTEX {{y 0.8}}\n}}\n"));
    // A range over formatted items only: no edit.
    let top = json!({"start": {"line": 0, "character": 0}, "end": {"line": 1, "character": 3}});
    let edits = c.call(
        "textDocument/rangeFormatting",
        json!({"textDocument": text_doc(&u), "range": top, "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert_eq!(edits, json!([]));

    // A syntax error: range formatting says why too.
    c.change(&u, 2, "startshape A\nrule A { VERTEX {x 1 }\n");
    let diags = c.diagnostics(&u, 2);
    let r = c.call(
        "textDocument/rangeFormatting",
        json!({"textDocument": text_doc(&u), "range": top, "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert!(r.is_null(), "{r}");
    let shown = c.notification("window/showMessage", |_| true);
    assert!(shown["message"].as_str().unwrap_or("").contains("not formatting, the file has syntax errors"), "{shown}");
    // The code links to its entry under $MDG_DOCS_URL.
    let code = diags[0]["code"].as_str().unwrap_or("").to_ascii_lowercase();
    assert_eq!(
        diags[0]["codeDescription"]["href"],
        format!("https://mdg.example/docs/diagnostics.md#{code}"),
        "{diags:?}"
    );
    assert!(c.shutdown_and_exit().success());
}

/// A grammar that never ends: each call draws a triangle and calls itself twice. Its
/// `maxiter` is the cap's (100M calls, seconds even in a release build; the default
/// 10M ends in about 0.2 s, before the test's edit could cancel it).
const RUNAWAY: &str = "startshape a\nmaxiter 100000000\nrule a { tri {} a {x 1} a {y 1} }\nrule tri { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";

#[test]
fn the_preview_cuts_a_runaway_grammar_warns_and_previews_the_next_edit() {
    let dir = scratch("preview");
    let u = uri(&dir.join("a.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, RUNAWAY);
    // The default budgets cut it (time or vertices, whichever comes first); the
    // warning names the setting that raises it.
    let started = std::time::Instant::now();
    let r = c.call("mdg/preview", json!({"uri": u}));
    let took = started.elapsed();
    assert_eq!(r["status"], "model", "{}", r["message"]);
    assert_eq!(r["version"], 1);
    let warnings = r["warnings"].to_string();
    assert!(
        (warnings.contains("time budget reached") && warnings.contains("mdg.preview.timeBudget"))
            || (warnings.contains("vertex budget 1000000 reached") && warnings.contains("mdg.preview.maxVertices")),
        "{warnings}"
    );
    assert!(r["glb"].as_str().is_some_and(|g| g.starts_with("Z2xURg")), "not a .glb"); // "glTF"
    assert!(r["stats"]["triangles"].as_u64().is_some_and(|t| t > 0));
    eprintln!("runaway cut and answered in {took:?} (debug build): {}", r["stats"]);

    // An edit while a run is going stops it (newest wins): a run with a long budget,
    // then the grammar mended; the run answers `cancelled`, and the next preview
    // shows the mended grammar.
    let id =
        c.request_async("mdg/preview", json!({"uri": u, "timeBudgetMs": 600_000, "maxVertices": 1_000_000_000_000u64}));
    std::thread::sleep(std::time::Duration::from_millis(500));
    let mended = RUNAWAY.replace("a {x 1} a {y 1}", "");
    c.change(&u, 2, &mended);
    let r = c.response(id);
    assert_eq!(r["result"]["status"], "cancelled", "{}", r["result"]["message"]);
    let r = c.call("mdg/preview", json!({"uri": u, "seed": "12"}));
    assert_eq!(r["status"], "model", "{}", r["message"]);
    assert_eq!(r["version"], 2);
    assert_eq!(r["seed"], "12");
    assert_eq!(r["stats"]["triangles"], 1);
    assert_eq!(r["warnings"], json!([]));
    // A newer request stops the one going, too.
    c.change(&u, 3, RUNAWAY);
    let id =
        c.request_async("mdg/preview", json!({"uri": u, "timeBudgetMs": 600_000, "maxVertices": 1_000_000_000_000u64}));
    std::thread::sleep(std::time::Duration::from_millis(500));
    let next = c.request_async("mdg/preview", json!({"uri": u, "timeBudgetMs": 100}));
    assert_eq!(c.response(id)["result"]["status"], "cancelled");
    assert_eq!(c.response(next)["result"]["status"], "model");
    // A document that is not open is an error response, not a panic.
    let r = c.request("mdg/preview", json!({"uri": uri(&dir.join("closed.mdg"))}));
    assert!(r["error"]["message"].as_str().is_some_and(|m| m.contains("is not open")), "{r}");
    assert!(c.shutdown_and_exit().success());
}
