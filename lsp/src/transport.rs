//! The server's input: LSP frames from stdin, passed on to tower-lsp, except a
//! document too large to be worth parsing.
//!
//! tower-lsp parses every message on the one thread that serves all requests, and
//! a document's text arrives whole (full sync) in `didOpen` and every `didChange`:
//! a 50 MB document over the live-analysis limit held requests on other documents
//! for seconds while its JSON was parsed (and copied, three times), although it is
//! never analysed. So a reader thread frames the input itself, and a frame so large
//! that its text must be over the limit (more than [`Oversize::threshold`] bytes)
//! is not parsed: a scanner that jumps over long strings finds the method, the
//! document's URI and version, the frame is dropped, and tower-lsp gets the same
//! notification with an empty text, the size noted in [`Oversize`] (the document
//! then gets its one W0012). Any other frame is passed on whole, as before.

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read};
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{Context, Poll};
use tokio::io::{AsyncRead, ReadBuf};
use tokio::sync::mpsc;

/// The longest string of a message the scanner for an oversized one decodes.
const MAX_DECODED: usize = 64 * 1024;

/// Sizes of documents whose text was not passed on, by URI, until the server takes
/// them ([`Oversize::take`]).
#[derive(Default)]
pub struct Oversize {
    sizes: Mutex<HashMap<String, usize>>,
    /// Frames larger than this are not parsed.
    threshold: usize,
}

impl Oversize {
    /// For a live-analysis limit of `max_live_bytes`: a frame longer than six times
    /// the limit (a JSON string escape is at most 6 bytes per character) plus room
    /// for the rest of the message cannot hold a text within it.
    pub fn new(max_live_bytes: usize) -> Oversize {
        Oversize { sizes: Mutex::default(), threshold: max_live_bytes.saturating_mul(6).saturating_add(64 * 1024) }
    }

    /// Frames longer than this are not parsed.
    pub fn threshold(&self) -> usize {
        self.threshold
    }

    /// The size noted for `uri`'s latest open or change, if its text was not passed on.
    pub fn take(&self, uri: &str) -> Option<usize> {
        self.sizes.lock().unwrap_or_else(|e| e.into_inner()).remove(uri)
    }

    fn note(&self, uri: &str, size: usize) {
        self.sizes.lock().unwrap_or_else(|e| e.into_inner()).insert(uri.to_string(), size);
    }
}

/// Reads frames from `input` on a thread of its own; what it passes on is read from
/// the returned reader.
pub fn filter(input: impl Read + Send + 'static, oversize: Arc<Oversize>) -> Filtered {
    let (tx, rx) = mpsc::unbounded_channel();
    let _ = std::thread::Builder::new().name("mdg-lsp input".into()).spawn(move || {
        let mut r = BufReader::with_capacity(64 * 1024, input);
        while let Some(frame) = next_frame(&mut r, &oversize) {
            if tx.send(frame).is_err() {
                break;
            }
        }
    });
    Filtered { rx, chunk: Vec::new(), at: 0 }
}

/// One frame to pass on (header and body), or `None` at the end of the input. Bytes
/// that are not a frame are passed on as they are (tower-lsp reports them).
fn next_frame(r: &mut impl BufRead, oversize: &Oversize) -> Option<Vec<u8>> {
    let mut header = Vec::new();
    let mut len = None;
    loop {
        let mut line = Vec::new();
        if r.read_until(b'\n', &mut line).ok()? == 0 {
            return (!header.is_empty()).then_some(header);
        }
        header.extend_from_slice(&line);
        let text = String::from_utf8_lossy(&line);
        let text = text.trim();
        if text.is_empty() {
            break;
        }
        if let Some((name, value)) = text.split_once(':') {
            if name.trim().eq_ignore_ascii_case("content-length") {
                len = value.trim().parse::<usize>().ok();
            }
        }
    }
    let Some(len) = len else { return Some(header) };
    // Grown as the bytes arrive: a wrong or hostile length allocates nothing up front.
    let mut body = Vec::new();
    if r.by_ref().take(len as u64).read_to_end(&mut body).ok()? < len {
        return None;
    }
    let fields = if len > oversize.threshold() { message_fields(&body) } else { None };
    let replacement = match fields {
        Some((method, uri, version)) if method == "textDocument/didOpen" => Some((
            uri.clone(),
            serde_json::json!({
            "jsonrpc": "2.0", "method": method, "params": {
            "textDocument": {"uri": uri, "languageId": "mdg", "version": version, "text": ""}}}),
        )),
        Some((method, uri, version)) if method == "textDocument/didChange" => Some((
            uri.clone(),
            serde_json::json!({
            "jsonrpc": "2.0", "method": method, "params": {
            "textDocument": {"uri": uri, "version": version}, "contentChanges": [{"text": ""}]}}),
        )),
        _ => None,
    };
    let Some((uri, replacement)) = replacement else {
        header.extend_from_slice(&body);
        return Some(header);
    };
    drop(body);
    oversize.note(&uri, len);
    let body = replacement.to_string();
    let mut frame = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
    frame.extend_from_slice(body.as_bytes());
    Some(frame)
}

/// The method, `params.textDocument.uri` and `params.textDocument.version` of a
/// message: a small JSON scanner that decodes only short strings and jumps over
/// long ones (the text) to their closing quote. `None` unless all three are there.
fn message_fields(head: &[u8]) -> Option<(String, String, i64)> {
    let mut path: Vec<Option<String>> = Vec::new();
    let (mut method, mut uri, mut version) = (None, None, None);
    let mut key: Option<String> = None;
    let mut i = 0;
    let skip_ws = |i: &mut usize| {
        while *i < head.len() && head[*i].is_ascii_whitespace() {
            *i += 1;
        }
    };
    loop {
        if let (Some(m), Some(u), Some(v)) = (&method, &uri, version) {
            return Some((String::clone(m), String::clone(u), v));
        }
        skip_ws(&mut i);
        let c = *head.get(i)?;
        match c {
            b'{' | b'[' => {
                path.push(if c == b'{' { key.take() } else { None });
                i += 1;
            }
            b'}' | b']' => {
                path.pop()?;
                key = None;
                i += 1;
            }
            b',' | b':' => i += 1,
            b'"' => {
                // The string's end (past escapes).
                let mut j = i + 1;
                loop {
                    j += memchr::memchr2(b'"', b'\\', head.get(j..)?)?;
                    if head[j] == b'"' {
                        break;
                    }
                    j += 2;
                }
                // Only short strings are decoded (keys, the method, the URI).
                let s: String =
                    if j - i <= MAX_DECODED { serde_json::from_slice(&head[i..=j]).ok()? } else { String::new() };
                i = j + 1;
                skip_ws(&mut i);
                if head.get(i) == Some(&b':') {
                    key = Some(s);
                    continue;
                }
                let at = |names: &[&str]| {
                    path.len() == names.len()
                        && path.iter().skip(1).zip(names).all(|(p, n)| p.as_deref() == Some(*n))
                        && key.as_deref() == names.last().copied()
                };
                if at(&["method"]) {
                    method = Some(s);
                } else if at(&["params", "textDocument", "uri"]) {
                    uri = Some(s);
                }
                key = None;
            }
            _ => {
                let start = i;
                while i < head.len() && !matches!(head[i], b',' | b'}' | b']') && !head[i].is_ascii_whitespace() {
                    i += 1;
                }
                if i >= head.len() {
                    return None;
                }
                let word = std::str::from_utf8(&head[start..i]).ok()?;
                let in_document = path.len() == 3
                    && path[1].as_deref() == Some("params")
                    && path[2].as_deref() == Some("textDocument");
                if in_document && key.as_deref() == Some("version") {
                    version = word.parse().ok();
                }
                key = None;
            }
        }
    }
}

/// The filtered input, as tower-lsp reads it.
pub struct Filtered {
    rx: mpsc::UnboundedReceiver<Vec<u8>>,
    chunk: Vec<u8>,
    at: usize,
}

impl AsyncRead for Filtered {
    fn poll_read(mut self: Pin<&mut Self>, cx: &mut Context<'_>, buf: &mut ReadBuf<'_>) -> Poll<std::io::Result<()>> {
        while self.at >= self.chunk.len() {
            match self.rx.poll_recv(cx) {
                Poll::Ready(Some(c)) => {
                    self.chunk = c;
                    self.at = 0;
                }
                // The end of the input.
                Poll::Ready(None) => return Poll::Ready(Ok(())),
                Poll::Pending => return Poll::Pending,
            }
        }
        let n = buf.remaining().min(self.chunk.len() - self.at);
        let at = self.at;
        buf.put_slice(&self.chunk[at..at + n]);
        self.at += n;
        Poll::Ready(Ok(()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_head_gives_method_uri_and_version_before_the_text() {
        let m = br#"{"jsonrpc":"2.0","method":"textDocument/didOpen","params":{"textDocument":{"uri":"file:///a%20b.mdg","languageId":"mdg","version":7,"text":"rule A { // \"uri\": no"#;
        assert_eq!(message_fields(m), Some(("textDocument/didOpen".into(), "file:///a%20b.mdg".into(), 7)));
        // The text first: not found in the head.
        let m = br#"{"jsonrpc":"2.0","method":"textDocument/didOpen","params":{"textDocument":{"text":"rule A {"#;
        assert_eq!(message_fields(m), None);
        // A `uri` elsewhere does not count.
        let m = br#"{"method":"x","params":{"other":{"uri":"u","version":1},"textDocument":{"version":2,"uri":"v"}}}"#;
        assert_eq!(message_fields(m), Some(("x".into(), "v".into(), 2)));
    }

    #[test]
    fn a_frame_claiming_more_than_it_has_ends_the_input_without_allocating_it() {
        let mut r = std::io::Cursor::new(b"Content-Length: 999999999999999\r\n\r\n{}".to_vec());
        assert!(next_frame(&mut r, &Oversize::new(10)).is_none());
    }

    #[test]
    fn an_oversized_frame_is_passed_on_without_its_text() {
        let oversize = Oversize::new(10);
        assert_eq!(oversize.threshold(), 60 + 64 * 1024);
        let text = "x".repeat(200_000);
        let body = serde_json::json!({"jsonrpc": "2.0", "method": "textDocument/didChange",
            "params": {"textDocument": {"uri": "file:///big.mdg", "version": 3}, "contentChanges": [{"text": text}]}})
        .to_string();
        let small = r#"{"jsonrpc":"2.0","id":1,"method":"shutdown"}"#;
        let input =
            format!("Content-Length: {}\r\n\r\n{body}Content-Length: {}\r\n\r\n{small}", body.len(), small.len());
        let mut r = std::io::Cursor::new(input.into_bytes());
        let first = String::from_utf8(next_frame(&mut r, &oversize).expect("frame")).expect("utf-8");
        assert!(first.len() < 300 && first.contains(r#""contentChanges":[{"text":""}]"#), "{first}");
        assert!(first.contains(r#""version":3"#), "{first}");
        assert_eq!(oversize.take("file:///big.mdg"), Some(body.len()));
        assert_eq!(oversize.take("file:///big.mdg"), None);
        let second = String::from_utf8(next_frame(&mut r, &oversize).expect("frame")).expect("utf-8");
        assert!(second.ends_with(small), "the next frame follows intact: {second}");
        assert!(next_frame(&mut r, &oversize).is_none());
    }
}
