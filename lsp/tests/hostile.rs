//! Hostile documents through the real server: nesting deep enough to overflow a
//! 2 MiB analysis thread without the nesting limit, a document over the source size
//! limit, and a recursive macro. Each gets its diagnostic (E0105, E0201, E0208) and
//! the server keeps serving the next edit.

mod common;

use common::{scratch, uri, Client};
use serde_json::json;

/// The most resident memory the server may reach in any of these tests (MiB).
/// Each test prints its peak (16–205 MiB measured); the failures they guard against
/// reached 1.9–5.8 GB.
const PEAK_MIB: u64 = 512;

fn codes(diags: &[serde_json::Value]) -> Vec<String> {
    diags.iter().filter_map(|d| d["code"].as_str().map(str::to_string)).collect()
}

#[test]
fn hostile_documents_get_diagnostics_and_the_server_keeps_serving() {
    let dir = scratch("hostile");
    let u = uri(&dir.join("hostile.mdg"));
    // The live-analysis limit (2 MiB) raised past the source limit, so the 17 MB
    // document below meets the compiler's own limit (E0201).
    let mut c = Client::spawn_with(&[("MDG_LSP_MAX_LIVE_BYTES", "100000000")]);
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
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
}

/// A program whose vertex shader is `glsl` (after `#version 450`).
/// Whether an E0502 (a shader refused or past its deadline) for `uri` has been
/// published among the messages received so far while waiting for others. The tests
/// below use the order of the server's messages, not the clock, to show that requests
/// and edits do not wait for glslang: the deadline's E0502 comes 5 s after the open,
/// and an answer that waited for glslang could not come before it. (Their latencies
/// are measured by `cargo bench -p mdg-lsp --bench latency`.)
fn e0502_published(c: &Client, uri: &str) -> bool {
    c.pending.iter().any(|v| {
        v["method"] == "textDocument/publishDiagnostics"
            && v["params"]["uri"] == uri
            && v["params"]["diagnostics"].as_array().is_some_and(|d| d.iter().any(|d| d["code"] == "E0502"))
    })
}

fn with_shader(glsl: &str) -> String {
    format!(
        "startshape A\n@vertexshader vs\n#version 450\n{glsl}\n@endshader\n\
         rule A {{ VERTEX {{}} VERTEX {{x 1}} VERTEX {{y 1}} }}\n"
    )
}

/// Shader blocks that killed the server (a 12-level `#define` doubling chain and a
/// 10,000-term sum overflowed the analysis thread's stack inside glslang) or hung it
/// for good (statements doubled 24 times by macros: glslang never finished, held
/// the compile lock, and `exit` waited for it). Each now gets its E0502 quickly,
/// another document is served meanwhile, and the server exits.
#[test]
fn hostile_shaders_get_e0502_and_the_server_exits() {
    let dir = scratch("hostile-glsl");
    let u = uri(&dir.join("shader.mdg"));
    let other = uri(&dir.join("other.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&other, 1, "startshape B\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&other, 1).is_empty());

    let mut chain = String::from("#define M0 x+x\n");
    for i in 1..12 {
        chain.push_str(&format!("#define M{i} M{}+M{}\n", i - 1, i - 1));
    }
    chain.push_str("void main() { float x = 1.0; gl_Position = vec4(M11); }");
    let terms = vec!["x"; 10_000].join("+");
    let mut statements = String::from("#define S0 x = x * 0.5 + sin(x) * cos(x) - 1.0;\n");
    for i in 1..24 {
        statements.push_str(&format!("#define S{i} S{} S{}\n", i - 1, i - 1));
    }
    statements.push_str("void main() { float x = 1.0; S23 gl_Position = vec4(x); }");
    let cases = [
        (chain, "expression too complex: more than 2048 operators in one statement after macro expansion"),
        (format!("void main() {{ float x = 1.0; gl_Position = vec4({terms}); }}"), "expression too complex"),
        (statements, "shader too large after preprocessing: more than 262144 tokens"),
    ];
    for (version, (glsl, message)) in (1..).zip(cases) {
        let t = std::time::Instant::now();
        c.open(&u, version, &with_shader(&glsl));
        let d = c.diagnostics(&u, version);
        assert_eq!(codes(&d), ["E0502"], "{d:?}");
        assert!(d[0]["message"].as_str().unwrap_or("").starts_with(message), "{d:?}");
        // The message shows the text limits refused it (not the deadline); this is the
        // hang guard, long for a loaded machine.
        assert!(t.elapsed() < std::time::Duration::from_secs(60), "took {:?}", t.elapsed());
        // The other document answers meanwhile.
        let h = c.call(
            "textDocument/hover",
            json!({"textDocument": {"uri": other}, "position": {"line": 1, "character": 10}}),
        );
        assert!(h["contents"]["value"].as_str().unwrap_or("").contains("VERTEX"), "{h}");
        c.notify("textDocument/didClose", json!({"textDocument": {"uri": u}}));
    }
    // A shader within the limits compiles.
    c.open(&u, 10, &with_shader("void main() { gl_Position = vec4(1.0); }"));
    assert!(c.diagnostics(&u, 10).is_empty());
    c.clear();
    assert!(!c.logs.iter().any(|l| l.contains("panic")), "{:?}", c.logs);
    let t = std::time::Instant::now();
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
    // Hang guard: a server that kept reading after `exit` would never end.
    assert!(t.elapsed() < std::time::Duration::from_secs(60), "exit took {:?}", t.elapsed());
}

/// 2^23 statements made by 24 doubling `#define`s: past the shader limits (which a
/// test hook turns off) glslang takes longer than its 5 s deadline on them.
fn slow_statements() -> String {
    let mut statements = String::from("#define S0 x = x * 0.5 + sin(x) * cos(x) - 1.0;\n");
    for i in 1..24 {
        statements.push_str(&format!("#define S{i} S{} S{}\n", i - 1, i - 1));
    }
    statements.push_str("void main() { float x = 1.0; S23 gl_Position = vec4(x); }");
    statements
}

/// While a document's shader compiles (for seconds), requests on that document are
/// answered at once from an analysis without the shaders, and an edit makes the
/// running analysis give up: the new version's diagnostics come without waiting
/// for glslang's deadline.
#[test]
fn requests_do_not_wait_for_a_slow_shader_and_an_edit_cancels_it() {
    let dir = scratch("hostile-cancel");
    let u = uri(&dir.join("slow.mdg"));
    let mut c = Client::spawn_with(&[("MDG_TEST_NO_SHADER_LIMITS", "1")]);
    c.initialize(&dir);
    let slow = format!("{}\nrule Leaf {{ VERTEX {{}} }}\n", with_shader(&slow_statements()));
    c.open(&u, 1, &slow);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let asked = std::time::Instant::now();
    let symbols = c.call("textDocument/documentSymbol", json!({"textDocument": {"uri": u}}));
    let names: Vec<&str> = symbols.as_array().into_iter().flatten().filter_map(|s| s["name"].as_str()).collect();
    assert!(names.contains(&"Leaf"), "{symbols}");
    let folds = c.call("textDocument/foldingRange", json!({"textDocument": {"uri": u}}));
    assert!(folds.as_array().is_some_and(|f| !f.is_empty()), "{folds}");
    let toks = c.call("textDocument/semanticTokens/full", json!({"textDocument": {"uri": u}}));
    assert!(toks["data"].as_array().is_some_and(|d| !d.is_empty()), "{toks}");
    let line = slow[..slow.find("rule Leaf").unwrap_or(0)].matches('\n').count();
    let h =
        c.call("textDocument/hover", json!({"textDocument": {"uri": u}, "position": {"line": line, "character": 13}}));
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("VERTEX"), "{h}");
    let answered = asked.elapsed();
    assert!(!e0502_published(&c, &u), "the requests were answered only after glslang's deadline ({answered:?})");
    eprintln!("requests answered in {answered:?}");

    // An edit while the shader still compiles: version 1's analysis gives up and
    // version 2 is published well before version 1's 5 s deadline.
    let edited = std::time::Instant::now();
    c.change(&u, 2, "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&u, 2).is_empty());
    let took = edited.elapsed();
    assert!(!e0502_published(&c, &u), "version 1 ran into the deadline before version 2 was published ({took:?})");
    eprintln!("the edit's diagnostics came in {took:?}");
    c.clear();
    assert!(!c.logs.iter().any(|l| l.contains("panic")), "{:?}", c.logs);
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
}

/// The first diagnostics of a document with a shader block do not wait for the
/// shader checker: every glslang compile is held by a test hook
/// (`MDG_TEST_SHADER_GATE`) until the test releases it, yet the document's other
/// diagnostics arrive; once released, the same version's diagnostics come again
/// with the GLSL error. (By the order of events, not the clock: before, the first
/// publish waited for the compile, so it never came while the gate was shut.)
#[test]
fn first_diagnostics_do_not_wait_for_the_shader_checker() {
    let dir = scratch("hostile-gate");
    let gate = dir.join("gate");
    let cache = dir.join("cache");
    let u = uri(&dir.join("shaded.mdg"));
    let mut c = Client::spawn_with(&[
        ("MDG_TEST_SHADER_GATE", gate.to_str().unwrap_or("")),
        ("XDG_CACHE_HOME", cache.to_str().unwrap_or("")),
    ]);
    c.initialize(&dir);
    let text = with_shader("void main() { gl_Position = vec4(undefined_name); }")
        .replace("VERTEX {y 1}", "VERTEX {y 1 rzz 3}");
    assert!(text.contains("rzz"));
    c.open(&u, 1, &text);
    // The gate is shut: whatever arrives did not wait for glslang.
    let first = c.diagnostics(&u, 1);
    assert_eq!(codes(&first), ["E0303"], "{first:?}");
    std::fs::write(&gate, "open").expect("gate");
    let full = c.diagnostics(&u, 1);
    assert_eq!(codes(&full), ["E0501", "E0303"], "{full:?}");
    // An edit outside the shader: its compiled result is cached now, so the
    // version's diagnostics come once, complete.
    let edited = text.replace("rzz 3", "rzz 4");
    c.change(&u, 2, &edited);
    let d = c.diagnostics(&u, 2);
    assert_eq!(codes(&d), ["E0501", "E0303"], "{d:?}");
    c.clear();
    assert!(!c.logs.iter().any(|l| l.contains("panic")), "{:?}", c.logs);
    assert!(c.shutdown_and_exit().success());
}

/// Behind the text limits, the deadline (the limits turned off by a test hook): the
/// 16-million-statement shader runs glslang past 5 s. Meanwhile another document
/// is served; then the document gets its E0502, a new shader compiles although the
/// abandoned compile still runs, and the server exits.
#[test]
fn a_compile_past_the_deadline_does_not_block_the_server() {
    let dir = scratch("hostile-deadline");
    let u = uri(&dir.join("slow.mdg"));
    let other = uri(&dir.join("other.mdg"));
    let mut c = Client::spawn_with(&[("MDG_TEST_NO_SHADER_LIMITS", "1")]);
    c.initialize(&dir);
    c.open(&other, 1, "startshape B\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&other, 1).is_empty());
    let t = std::time::Instant::now();
    c.open(&u, 1, &with_shader(&slow_statements()));
    // While the shader compiles, the other document answers at once.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let asked = std::time::Instant::now();
    let h =
        c.call("textDocument/hover", json!({"textDocument": {"uri": other}, "position": {"line": 1, "character": 10}}));
    assert!(h["contents"]["value"].as_str().unwrap_or("").contains("VERTEX"), "{h}");
    assert!(!e0502_published(&c, &u), "the hover was answered only after the deadline ({:?})", asked.elapsed());
    // The deadline is 5 s of the compile's processor time (a loaded machine
    // stretches it in wall-clock time, up to the 60 s safety net).
    // Version 1's diagnostics come twice: at once without the shader's (glslang has
    // not answered), then with its E0502.
    let early = c.diagnostics_within(&u, 1, std::time::Duration::from_secs(90));
    assert!(early.is_empty(), "{early:?}");
    let d = c.diagnostics_within(&u, 1, std::time::Duration::from_secs(90));
    assert_eq!(codes(&d), ["E0502"], "{d:?}");
    assert!(d[0]["message"].as_str().unwrap_or("").starts_with("shader compilation took longer than "), "{d:?}");
    // Hang guard.
    assert!(t.elapsed() < std::time::Duration::from_secs(90), "took {:?}", t.elapsed());
    // The abandoned compile holds nothing: another shader compiles now.
    c.change(&u, 2, &with_shader("void main() { gl_Position = vec4(2.0); }"));
    assert!(c.diagnostics(&u, 2).is_empty());
    let t = std::time::Instant::now();
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
    // Hang guard: an exit waiting for the abandoned compile would take minutes.
    assert!(t.elapsed() < std::time::Duration::from_secs(60), "exit took {:?}", t.elapsed());
}

/// A junk document: at most 100 errors, then one note with how many more.
#[test]
fn a_junk_document_gets_a_bounded_number_of_diagnostics() {
    let dir = scratch("hostile-junk");
    let u = uri(&dir.join("junk.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    let junk = "% ] ( rule\n".repeat(100_000);
    c.open(&u, 1, &junk);
    let d = c.diagnostics(&u, 1);
    assert!(d.len() <= 101, "{} diagnostics", d.len());
    let last = d.last().expect("diagnostics");
    assert_eq!(last["code"], "N0001", "{last}");
    assert_eq!(last["severity"], 3, "information: {last}");
    assert!(last["message"].as_str().unwrap_or("").contains(" more errors"), "{last}");
    let rss = c.rss_kib().unwrap_or(0);
    assert!(rss < 1024 * 1024, "RSS {rss} KiB");
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
}

/// A document past the live-analysis limit (2 MiB) is not analysed: one W0012 at its
/// start, features answer nothing for it, memory stays that of its text, and other
/// documents are served. A 15 MB grammar used to take 5.8 GB and 29 s per edit.
#[test]
fn a_document_past_the_live_limit_gets_w0012_and_costs_only_its_text() {
    let dir = scratch("hostile-live");
    let u = uri(&dir.join("big.mdg"));
    let small = uri(&dir.join("small.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    let big =
        format!("startshape A\n{}", "rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n".repeat((15 << 20) / 48 + 1));
    assert!(big.len() > 14 << 20);
    let started = std::time::Instant::now();
    c.open(&u, 1, &big);
    let d = c.diagnostics(&u, 1);
    assert_eq!(codes(&d), ["W0012"], "{d:?}");
    let msg = d[0]["message"].as_str().unwrap_or("");
    assert!(msg.contains("MiB: the editor analyses documents of up to 2.0 MiB"), "{msg}");
    assert_eq!(d[0]["range"]["start"], json!({"line": 0, "character": 0}));
    let h = c.call("textDocument/hover", json!({"textDocument": {"uri": u}, "position": {"line": 1, "character": 10}}));
    assert!(h.is_null(), "{h}");
    assert!(started.elapsed() < std::time::Duration::from_secs(30), "took {:?}", started.elapsed());
    if let Some(kib) = c.rss_kib() {
        assert!(kib < 1 << 20, "{kib} KiB resident for a 15 MB document");
    }
    // Another document is analysed as usual.
    c.open(&small, 1, "startshape B\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&small, 1).is_empty());
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());

    // The limit is the server's to raise (or lower).
    let mut c = Client::spawn_with(&[("MDG_LSP_MAX_LIVE_BYTES", "100")]);
    c.initialize(&dir);
    c.open(&small, 1, &format!("startshape B\nrule B {{ VERTEX {{}} }}\n{}", "// padding\n".repeat(20)));
    assert_eq!(codes(&c.diagnostics(&small, 1)), ["W0012"]);
    c.assert_peak_below(PEAK_MIB);
    assert!(c.shutdown_and_exit().success());
}

/// A 50 MB document (full sync: every open and change carries all of it) is past
/// the live limit, so its text is not even parsed: the input filter reads the
/// message's head and skips the rest. A request on another document is answered
/// without waiting for 50 MB of JSON to be parsed and copied on the message loop
/// (4.7 s measured), and the server never holds the text: its peak memory stays
/// that of an idle server, where holding the text took three copies of it.
#[test]
fn a_fifty_megabyte_document_is_not_parsed_and_does_not_hold_up_other_documents() {
    let dir = scratch("hostile-fifty");
    let big = uri(&dir.join("big.mdg"));
    let small = uri(&dir.join("small.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&small, 1, "startshape B\nrule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&small, 1).is_empty());
    let text =
        format!("startshape A\n{}", "rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n".repeat((50 << 20) / 48 + 1));
    assert!(text.len() > 50_000_000);
    c.open(&big, 1, &text);
    let id = c.request_async("textDocument/documentSymbol", json!({"textDocument": {"uri": small}}));
    let symbols = c.response(id);
    assert!(symbols["result"].as_array().is_some_and(|s| !s.is_empty()), "{symbols}");
    let d = c.diagnostics(&big, 1);
    assert_eq!(codes(&d), ["W0012"], "{d:?}");
    assert!(d[0]["message"].as_str().unwrap_or("").contains("MiB: the editor analyses documents of up to 2.0 MiB"));
    // The text was never held (the server held three copies of it: 150 MB and more).
    c.assert_peak_below(100);
    // A full-sync change of the same size: the same, and a small text is analysed again.
    c.change(&big, 2, &text);
    assert_eq!(codes(&c.diagnostics(&big, 2)), ["W0012"]);
    let f = c.request(
        "textDocument/formatting",
        json!({"textDocument": {"uri": big}, "options": {"tabSize": 2, "insertSpaces": true}}),
    );
    assert!(f["result"].is_null(), "no edits computed from a text the server does not have: {f}");
    c.change(&big, 3, "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
    assert!(c.diagnostics(&big, 3).is_empty());
    c.assert_peak_below(100);
    assert!(c.shutdown_and_exit().success());
}

/// Trojan Source in the editor: the W0014 warning of the checker is published as a
/// diagnostic at the invisible character (its UTF-16 range), and a lone CR ends a
/// line for the server as it does for LSP clients.
#[test]
fn bidirectional_controls_are_warned_about_in_the_editor() {
    let dir = scratch("hostile-bidi");
    let u = uri(&dir.join("bidi.mdg"));
    let mut c = Client::spawn();
    c.initialize(&dir);
    c.open(&u, 1, "startshape A\rrule A { VERTEX {} } // é \u{202e} }nimda{\r");
    let d = c.diagnostics(&u, 1);
    assert_eq!(codes(&d), ["W0014"], "{d:?}");
    assert_eq!(d[0]["severity"], 2, "a warning: {d:?}");
    assert!(d[0]["message"].as_str().unwrap_or("").contains("U+202E RIGHT-TO-LEFT OVERRIDE"), "{d:?}");
    assert_eq!(d[0]["range"], json!({"start": {"line": 1, "character": 26}, "end": {"line": 1, "character": 27}}));
    assert!(c.shutdown_and_exit().success());
}
