//! End-to-end test with a real client we did not write: neovim's built-in LSP
//! client (Debian package `neovim`, 0.7 API) runs `tests/lsp/e2e.lua` headless
//! against the built `mdg-lsp`, opens `tests/lsp/e2e.mdg` (one error), and writes
//! the diagnostic, hover and definition it received as JSON, checked here.
//!
//! Without `nvim` on PATH the test fails (CI installs it with apt); set
//! `MDG_SKIP_NVIM_TESTS=1` to skip it on a machine without neovim.

mod common;

use common::{pos_of, root, scratch};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::split_paths(&std::env::var_os("PATH")?).map(|d| d.join(name)).find(|p| p.is_file())
}

#[test]
fn neovim_receives_diagnostics_hover_and_definition() {
    if std::env::var("MDG_SKIP_NVIM_TESTS").is_ok_and(|v| v == "1") {
        eprintln!("skipped: MDG_SKIP_NVIM_TESTS=1");
        return;
    }
    let Some(nvim) = find_on_path("nvim") else {
        panic!(
            "neovim (`nvim`) is not installed, so the end-to-end LSP test cannot run.\n\
             Install it with `apt-get install -y neovim` (.ci/run does), or set MDG_SKIP_NVIM_TESTS=1 to skip this test."
        );
    };
    let file = root().join("tests/lsp/e2e.mdg");
    let text = std::fs::read_to_string(&file).expect("tests/lsp/e2e.mdg");
    let out = scratch("nvim").join("result.json");
    let hover = pos_of(&text, "VERTEX", 2);
    let definition = pos_of(&text, "petal {x 2}", 1);
    let mut child = Command::new(nvim)
        .args(["--headless", "--clean", "-c"])
        .arg(format!("luafile {}", root().join("tests/lsp/e2e.lua").display()))
        .env("MDG_LSP", env!("CARGO_BIN_EXE_mdg-lsp"))
        .env("MDG_STD", root().join("std"))
        .env("MDG_FILE", &file)
        .env("MDG_OUT", &out)
        .env("MDG_HOVER", hover.to_string())
        .env("MDG_DEFINITION", definition.to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .expect("start nvim");
    let deadline = Instant::now() + Duration::from_secs(60);
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait for nvim") {
            break s;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("nvim did not finish within 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let written = std::fs::read_to_string(&out).unwrap_or_else(|e| panic!("nvim wrote no result ({status}): {e}"));
    let r: Value = serde_json::from_str(&written).expect("result JSON");
    assert!(status.success(), "nvim failed: {status}; result: {r}");
    assert_eq!(r["errors"], json!([]), "{r}");

    // The diagnostic: `stem` on line 6 (0-based 5), columns 2..6, code E0301.
    let uri = format!("file://{}", file.display());
    assert_eq!(r["diagnostics"]["uri"], uri.as_str());
    let diags = r["diagnostics"]["diagnostics"].as_array().cloned().unwrap_or_default();
    assert_eq!(diags.len(), 1, "{r}");
    assert_eq!(diags[0]["code"], "E0301");
    assert_eq!(diags[0]["severity"], 1);
    assert_eq!(diags[0]["range"], json!({"start": {"line": 5, "character": 2}, "end": {"line": 5, "character": 6}}));

    // Hover on VERTEX: its documentation, as Markdown.
    assert_eq!(r["hover"]["contents"]["kind"], "markdown");
    let hover_text = r["hover"]["contents"]["value"].as_str().unwrap_or("");
    assert!(hover_text.starts_with("```mdg\nVERTEX {ADJ}\n```\nEmit a vertex"), "{hover_text}");

    // Definition of `petal` from its call: the rule's name on line 10.
    assert_eq!(r["definition"]["uri"], uri.as_str());
    assert_eq!(
        r["definition"]["range"],
        json!({"start": {"line": 9, "character": 5}, "end": {"line": 9, "character": 10}})
    );

    // The server went away after shutdown/exit.
    assert_eq!(r["stopped"], true, "{r}");
}
