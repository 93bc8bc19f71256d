//! A minimal LSP client for the protocol tests, the soak test and the latency
//! benchmark: spawns the built `mdg-lsp`, frames JSON-RPC over its stdio, and
//! collects what the server sends on a reader thread.
#![allow(dead_code)]

pub mod soak;

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

/// How long any single wait may take before a test fails.
pub const TIMEOUT: Duration = Duration::from_secs(20);

/// The workspace root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().expect("workspace root")
}

/// A `file://` URI for a path.
pub fn uri(path: &Path) -> String {
    format!("file://{}", path.display())
}

/// A fresh scratch directory for one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mdg-lsp-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// A running server and what it has sent.
pub struct Client {
    child: Child,
    stdin: Option<ChildStdin>,
    rx: Receiver<Value>,
    next_id: i64,
    /// Messages received while waiting for something else (notifications).
    pub pending: Vec<Value>,
    /// Every `window/logMessage` text received.
    pub logs: Vec<String>,
}

fn read_message(r: &mut impl BufRead) -> Option<Value> {
    let mut len = None;
    loop {
        let mut line = String::new();
        if r.read_line(&mut line).ok()? == 0 {
            return None;
        }
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some(v) = line.strip_prefix("Content-Length:") {
            len = v.trim().parse::<usize>().ok();
        }
    }
    let mut buf = vec![0u8; len?];
    r.read_exact(&mut buf).ok()?;
    serde_json::from_slice(&buf).ok()
}

impl Client {
    /// Starts the server binary with the repository's std library.
    pub fn spawn() -> Client {
        Client::spawn_with(&[])
    }

    /// Starts the server with extra environment variables.
    pub fn spawn_with(env: &[(&str, &str)]) -> Client {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_mdg-lsp"));
        cmd.env("MDG_STD", root().join("std")).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::inherit());
        for (k, v) in env {
            cmd.env(k, v);
        }
        let mut child = cmd.spawn().expect("spawn mdg-lsp");
        let stdout = child.stdout.take().expect("stdout");
        let stdin = child.stdin.take();
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut r = BufReader::new(stdout);
            while let Some(v) = read_message(&mut r) {
                if tx.send(v).is_err() {
                    break;
                }
            }
        });
        Client { child, stdin, rx, next_id: 1, pending: Vec::new(), logs: Vec::new() }
    }

    /// The server's process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Sends one message.
    pub fn send(&mut self, msg: &Value) {
        let body = serde_json::to_string(msg).expect("json");
        let stdin = self.stdin.as_mut().expect("stdin open");
        write!(stdin, "Content-Length: {}\r\n\r\n{}", body.len(), body).expect("write to server");
        stdin.flush().expect("flush");
    }

    /// Sends a notification.
    pub fn notify(&mut self, method: &str, params: Value) {
        self.send(&json!({"jsonrpc": "2.0", "method": method, "params": params}));
    }

    /// Sends a request without waiting; returns its id.
    pub fn request_async(&mut self, method: &str, params: Value) -> i64 {
        let id = self.next_id;
        self.next_id += 1;
        self.send(&json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}));
        id
    }

    /// Sends a request and returns the whole response (`result` or `error`).
    pub fn request(&mut self, method: &str, params: Value) -> Value {
        let id = self.request_async(method, params);
        self.response(id)
    }

    /// Sends a request and returns its `result`, failing on an error response.
    pub fn call(&mut self, method: &str, params: Value) -> Value {
        let r = self.request(method, params);
        assert!(r.get("error").is_none(), "{method} failed: {r}");
        r["result"].clone()
    }

    fn next_message(&mut self, deadline: Instant) -> Value {
        let left = deadline.saturating_duration_since(Instant::now());
        match self.rx.recv_timeout(left) {
            Ok(v) => {
                if v["method"] == "window/logMessage" {
                    self.logs.push(v["params"]["message"].as_str().unwrap_or("").to_string());
                }
                v
            }
            Err(RecvTimeoutError::Timeout) => panic!("timed out waiting for the server; logs: {:?}", self.logs),
            Err(RecvTimeoutError::Disconnected) => panic!("the server closed its output; logs: {:?}", self.logs),
        }
    }

    /// Waits for the response to request `id`.
    pub fn response(&mut self, id: i64) -> Value {
        let is_it = |v: &Value| v.get("id").and_then(Value::as_i64) == Some(id) && v.get("method").is_none();
        if let Some(i) = self.pending.iter().position(is_it) {
            return self.pending.remove(i);
        }
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let v = self.next_message(deadline);
            if is_it(&v) {
                return v;
            }
            self.pending.push(v);
        }
    }

    /// Waits for a notification matching `pred` (looking at ones already received first).
    pub fn notification(&mut self, method: &str, pred: impl Fn(&Value) -> bool) -> Value {
        if let Some(i) = self.pending.iter().position(|v| v["method"] == method && pred(&v["params"])) {
            return self.pending.remove(i)["params"].clone();
        }
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let v = self.next_message(deadline);
            if v["method"] == method && pred(&v["params"]) {
                return v["params"].clone();
            }
            self.pending.push(v);
        }
    }

    /// Waits for diagnostics of `uri` at `version`, up to `timeout` (for a result
    /// that waits on a deadline of processor time, which a loaded machine stretches).
    pub fn diagnostics_within(&mut self, uri: &str, version: i64, timeout: Duration) -> Vec<Value> {
        let is_it = |v: &Value| {
            v["method"] == "textDocument/publishDiagnostics"
                && v["params"]["uri"] == uri
                && v["params"]["version"] == version
        };
        let p = match self.pending.iter().position(is_it) {
            Some(i) => self.pending.remove(i),
            None => {
                let deadline = Instant::now() + timeout;
                loop {
                    let v = self.next_message(deadline);
                    if is_it(&v) {
                        break v;
                    }
                    self.pending.push(v);
                }
            }
        };
        p["params"]["diagnostics"].as_array().cloned().unwrap_or_default()
    }

    /// Waits for diagnostics of `uri` at `version`.
    pub fn diagnostics(&mut self, uri: &str, version: i64) -> Vec<Value> {
        let p = self.notification("textDocument/publishDiagnostics", |p| p["uri"] == uri && p["version"] == version);
        p["diagnostics"].as_array().cloned().unwrap_or_default()
    }

    /// Drops messages received so far.
    pub fn clear(&mut self) {
        while let Ok(v) = self.rx.try_recv() {
            if v["method"] == "window/logMessage" {
                self.logs.push(v["params"]["message"].as_str().unwrap_or("").to_string());
            }
        }
        self.pending.clear();
    }

    /// `initialize` + `initialized`; returns the capabilities.
    pub fn initialize(&mut self, root_dir: &Path) -> Value {
        let r = self.call(
            "initialize",
            json!({"processId": null, "rootUri": uri(root_dir), "capabilities": {}, "clientInfo": {"name": "mdg-lsp tests"}}),
        );
        self.notify("initialized", json!({}));
        r["capabilities"].clone()
    }

    /// Opens a document.
    pub fn open(&mut self, uri: &str, version: i64, text: &str) {
        self.notify(
            "textDocument/didOpen",
            json!({"textDocument": {"uri": uri, "languageId": "mdg", "version": version, "text": text}}),
        );
    }

    /// Replaces a document's text (full sync).
    pub fn change(&mut self, uri: &str, version: i64, text: &str) {
        self.notify(
            "textDocument/didChange",
            json!({"textDocument": {"uri": uri, "version": version}, "contentChanges": [{"text": text}]}),
        );
    }

    /// `shutdown` then `exit`; returns how the process ended (failing if it does not within the timeout).
    pub fn shutdown_and_exit(mut self) -> ExitStatus {
        self.call("shutdown", Value::Null);
        self.notify("exit", Value::Null);
        self.wait_exit()
    }

    /// Waits for the process to end after `exit`, with stdin still open (a client
    /// that does not close the pipe must not keep the server alive).
    pub fn wait_exit(mut self) -> ExitStatus {
        // Generous: the server first waits for its glslang warm-up (a second or two
        // in a debug build on a loaded machine).
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Some(status) = self.child.try_wait().expect("wait") {
                return status;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                panic!("mdg-lsp did not exit within 30 s of `exit`");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// The server's resident memory in KiB (Linux), if it can be read.
    pub fn rss_kib(&self) -> Option<u64> {
        self.status_kib("VmRSS:")
    }

    /// The most memory the server has held resident so far, in KiB (Linux).
    pub fn peak_kib(&self) -> Option<u64> {
        self.status_kib("VmHWM:")
    }

    fn status_kib(&self, field: &str) -> Option<u64> {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id())).ok()?;
        let line = status.lines().find(|l| l.starts_with(field))?;
        line.split_whitespace().nth(1)?.parse().ok()
    }

    /// Fails unless the server's peak resident memory so far is under `mib` MiB
    /// (where `/proc` can tell).
    pub fn assert_peak_below(&self, mib: u64) {
        if let Some(kib) = self.peak_kib() {
            eprintln!("mdg-lsp peak RSS: {:.1} MiB", kib as f64 / 1024.0);
            assert!(kib < mib * 1024, "the server's peak RSS was {kib} KiB, more than {mib} MiB");
        }
    }
}

impl Drop for Client {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// The zero-based (line, UTF-16 column) of the first occurrence of `needle` in `text`, plus `delta` bytes.
pub fn pos_of(text: &str, needle: &str, delta: usize) -> Value {
    let at = text.find(needle).unwrap_or_else(|| panic!("`{needle}` not in text")) + delta;
    let before = &text[..at];
    let line = before.matches('\n').count();
    let col = before.rsplit('\n').next().unwrap_or("").encode_utf16().count();
    json!({"line": line, "character": col})
}

/// A fresh scratch directory with its canonical path (URIs the server reports are canonical).
pub fn canonical_scratch(name: &str) -> PathBuf {
    scratch(name).canonicalize().expect("canonical scratch dir")
}

/// A program of about `lines` lines for the benchmarks (latency, typing): the
/// compiler's benchmark grammar, so the `phases` example measures the same program.
pub fn benchmark_grammar(lines: usize) -> String {
    mdg_compiler::benchmark::grammar(lines)
}

/// The value at fraction `p` (0..1) of `sorted`, nearest rank.
pub fn percentile<T: Copy>(sorted: &[T], p: f64) -> T {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// A file importing `shaders`, opened right after `initialize` by a server whose
/// SPIR-V disk cache is empty (a first-ever start), then by one whose cache the
/// first filled: the time from `didOpen` to its first diagnostics (target ≤ 100 ms).
pub fn first_shader_diagnostics(dir: &std::path::Path) {
    let cache = dir.join("spirv-cache");
    let _ = std::fs::remove_dir_all(&cache);
    for cold in [true, false] {
        let mut c = Client::spawn_with(&[("XDG_CACHE_HOME", cache.to_str().unwrap_or(""))]);
        c.initialize(dir);
        let u = uri(&dir.join("shaded.mdg"));
        let t0 = Instant::now();
        c.open(&u, 1, "@import shaders\nstartshape a\nrule a { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n");
        let d = c.diagnostics(&u, 1);
        let first = t0.elapsed().as_secs_f64() * 1000.0;
        let what = if cold { "empty SPIR-V cache (first-ever start)" } else { "SPIR-V disk cache filled" };
        println!(
            "first diagnostics of a file importing shaders, {what}: {first:.0} ms ({} diagnostics; target ≤ 100 ms)",
            d.len()
        );
        assert!(c.shutdown_and_exit().success());
    }
}
