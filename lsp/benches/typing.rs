//! Typing benchmark (not a test): the server's CPU time per edit while a user types
//! into a 10,600-line grammar (issue 39: diagnostics per edit ≤ 10 ms of CPU), through
//! the real `mdg-lsp` over stdio.
//!
//! The file is the latency benchmark's kind of grammar (chained rules with
//! iterators, an isosurface, a selector, `@import primitives`), 10,600 lines. A call
//! `r5 {y 2 rz 15}` is typed one character at a time into a rule in the middle
//! of the file and deleted again one character at a time (backspace), so the
//! versions in between have syntax errors, unknown rules and unknown adjustments,
//! as real typing does. Each edit is sent as the client's document sync asks
//! (the changed range under incremental sync, else the whole text) and waits for
//! the diagnostics of its version. The server's CPU time (user + system, from
//! `/proc/PID/stat`) over all the edits, divided by their number, is the figure;
//! the wall time from sending an edit to its diagnostics is printed beside it
//! (p50/p95), with the load average.
//!
//! It runs twice, one server after the other: with `MDG_LSP_WHOLE_PARSE=1` (every
//! version parsed whole, as before the reuse) and with the reuse.
//!
//! Run: `cargo bench --profile release -p mdg-lsp --bench typing` (release), or
//! `--profile dev` for the debug build. `MDG_TYPING_ROUNDS=N` sets how often the
//! call is typed and deleted (default 6: 204 edits).
//!
//! The same edits in one process, without the server (`PHASES_TYPING=1 cargo run
//! --release -p mdg-compiler --example phases`; `PHASES_TYPING=reusing` under a
//! profiler), measured 2026-12-05 at load average 18–19: CPU per version, medians
//! of three, 40.3 ms before rules were shared between versions and 20.6 ms after
//! (every version parsed whole: 53.5 → 35.0 ms); instructions per version with the
//! drop of the previous analysis 172 → 113 million (docs/editors.md). This bench
//! after that change (release, three runs, load average 11–13): server CPU per
//! edit 16.0, 13.3, 17.1 ms reusing, 34.0, 24.5, 24.1 ms parsed whole.
//! With the checker's per-rule cache (the rules an edit left alone replayed, not
//! checked; release, three runs, load average 4–6): 10.98, 12.55, 11.81 ms reusing
//! (median 11.8), 37.7, 22.0, 23.0 ms parsed and checked whole; in one process
//! 17.4 → 13.2 ms per version, 115.3 → 101.8 million instructions.

#[path = "../tests/common/mod.rs"]
mod common;

use common::{benchmark_grammar as grammar, first_shader_diagnostics, percentile, scratch, uri, Client};
use serde_json::json;
use std::time::{Duration, Instant};

/// The server's CPU time so far (user + system), in clock ticks of 10 ms.
fn cpu_ticks(pid: u32) -> u64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the whole line: 12 and 13 here.
    let n = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    n(11) + n(12)
}

/// Clock ticks per second (`getconf CLK_TCK`; 100 on Linux).
fn ticks_per_second() -> f64 {
    std::process::Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.trim().parse::<f64>().ok())
        .unwrap_or(100.0)
}

/// Waits until the server has used no CPU for half a second (its start-up work —
/// the glslang warm-up, the workspace index — done), at most 60 s.
fn settle(pid: u32) {
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut last = cpu_ticks(pid);
    while Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(500));
        let now = cpu_ticks(pid);
        if now == last {
            return;
        }
        last = now;
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".to_string())
}

/// The line and UTF-16 column of byte `offset` (the text is ASCII).
fn position(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset];
    let line = before.matches('\n').count();
    let col = offset - before.rfind('\n').map_or(0, |i| i + 1);
    (line, col)
}

fn main() {
    let rounds: usize = std::env::var("MDG_TYPING_ROUNDS").ok().and_then(|v| v.parse().ok()).unwrap_or(6);
    let dir = scratch("bench-typing");
    // Each version parsed whole (as before issue 39's reuse), then reusing the
    // previous version's items, one after the other under the same load.
    for whole in ["1", "0"] {
        typing(&dir, rounds, whole);
    }
    first_shader_diagnostics(&dir);
}

/// Types into the grammar with `MDG_LSP_WHOLE_PARSE` set to `whole`.
fn typing(dir: &std::path::Path, rounds: usize, whole: &str) {
    let u = uri(&dir.join("big.mdg"));
    let base = grammar(10_600);
    let n_lines = base.lines().count();
    let mut c = Client::spawn_with(&[("MDG_LSP_WHOLE_PARSE", whole)]);
    let caps = c.initialize(dir);
    let sync = &caps["textDocumentSync"];
    let incremental = sync["change"] == 2 || *sync == json!(2);
    c.open(&u, 1, &base);
    let first = c.diagnostics(&u, 1);
    assert!(first.is_empty(), "the generated grammar should be clean: {first:?}");
    settle(c.pid());

    // Where the call is typed: a new line after the call in the middle rule.
    let anchor = format!("  r{} {{x 1 rz 10 s 0.9}}\n", n_lines / 12 + 1);
    let at = base.find(&anchor).expect("the middle rule") + anchor.len();
    let typed = "  r5 {y 2 rz 15}\n";
    let mut text = base.clone();
    let mut version = 1;
    let mut wall = Vec::new();
    let mut with_errors = 0;
    let cpu0 = cpu_ticks(c.pid());
    let started = Instant::now();
    for _ in 0..rounds {
        // Type, then delete, one character at a time.
        let mut steps: Vec<(usize, Option<char>)> = Vec::new();
        for (i, ch) in typed.char_indices() {
            steps.push((at + i, Some(ch)));
        }
        for i in (0..typed.len()).rev() {
            steps.push((at + i, None));
        }
        for (offset, ch) in steps {
            version += 1;
            let (line, col) = position(&text, offset);
            let (end_line, end_col, new) = match ch {
                Some(ch) => {
                    text.insert(offset, ch);
                    (line, col, ch.to_string())
                }
                None => {
                    let removed = text.remove(offset);
                    let (l, c) = if removed == '\n' { (line + 1, 0) } else { (line, col + 1) };
                    (l, c, String::new())
                }
            };
            let t0 = Instant::now();
            if incremental {
                c.notify(
                    "textDocument/didChange",
                    json!({"textDocument": {"uri": u, "version": version}, "contentChanges": [{
                        "range": {"start": {"line": line, "character": col}, "end": {"line": end_line, "character": end_col}},
                        "text": new,
                    }]}),
                );
            } else {
                c.change(&u, version, &text);
            }
            let d = c.diagnostics(&u, version);
            wall.push(t0.elapsed().as_secs_f64() * 1000.0);
            with_errors += usize::from(!d.is_empty());
        }
    }
    let elapsed = started.elapsed().as_secs_f64();
    let cpu_ms = (cpu_ticks(c.pid()) - cpu0) as f64 * 1000.0 / ticks_per_second();
    assert_eq!(text, base, "typing and deleting gives the text back");
    let edits = wall.len();
    wall.sort_by(f64::total_cmp);
    println!(
        "typing into a {n_lines}-line grammar ({} sync, {}): {edits} edits ({with_errors} with diagnostics) in {elapsed:.1} s; \
         server CPU {:.2} ms per edit (target ≤ 10 ms); edit → diagnostics p50 {:.2} ms, p95 {:.2} ms; load average {}",
        if incremental { "incremental" } else { "full" },
        if whole == "1" { "every version parsed whole" } else { "unchanged items reused" },
        cpu_ms / edits as f64,
        percentile(&wall, 0.5),
        percentile(&wall, 0.95),
        load_average()
    );
    assert!(c.shutdown_and_exit().success());
}
