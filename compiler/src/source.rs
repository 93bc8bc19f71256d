//! The source database: every file the compiler has read, with line tables.
//!
//! The compiler reads files only through [`FileLoader`], so the language server
//! can serve unsaved buffers and tests can use in-memory files.

use crate::span::{FileId, Span};
use std::path::{Path, PathBuf};

/// The largest source file the compiler reads, in bytes (E0201 beyond it).
pub const MAX_SOURCE_BYTES: usize = 16 * 1024 * 1024;

/// Reads source files. The only IO the compiler does goes through this trait.
pub trait FileLoader {
    /// The text of `path`, or an error message.
    fn read(&self, path: &Path) -> Result<String, String>;
    /// The canonical form of `path` (symlinks resolved), used for containment checks.
    fn canonicalize(&self, path: &Path) -> Result<PathBuf, String>;
}

/// Reads from the real file system.
pub struct FsLoader;

impl FileLoader for FsLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        // The built-in std, when no directory could hold it (crate::stdlib).
        if let Some(bytes) = crate::embedded_std::embedded_file(path) {
            return decode_source(bytes.to_vec()).map_err(|e| e.to_string());
        }
        // Refuse huge files before reading them (the parser refuses longer texts too, E0201).
        // Only regular files, opened without blocking (a named pipe froze the
        // compiler, `/dev/zero` grew to gigabytes), at most MAX_SOURCE_BYTES.
        let max = MAX_SOURCE_BYTES as u64;
        match mdg_vm::input::read_bounded(path, max) {
            Ok(bytes) => decode_source(bytes).map_err(|e| e.to_string()),
            Err(mdg_vm::input::ReadError::TooLarge { len, max }) => {
                Err(format!("source file too large: {len} bytes (at most {max})"))
            }
            Err(e) => Err(e.to_string()),
        }
    }
    fn canonicalize(&self, path: &Path) -> Result<PathBuf, String> {
        if crate::embedded_std::is_embedded(path) {
            return Ok(normalize(path));
        }
        std::fs::canonicalize(path).map_err(|e| e.to_string())
    }
}

/// Why a source file's bytes are not text the compiler reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// UTF-16, with or without a byte-order mark.
    Utf16,
    /// Not UTF-8 from `line` (from 1), `column` (its byte, from 1) on: `byte` is there.
    NotUtf8 { line: usize, column: usize, byte: u8 },
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DecodeError::Utf16 => write!(
                f,
                "the file is UTF-16, not UTF-8 (MDG reads UTF-8): save it as UTF-8 (in VS Code: \
                 the encoding in the status bar, then `Save with Encoding`)"
            ),
            DecodeError::NotUtf8 { line, column, byte } => write!(
                f,
                "not valid UTF-8 at line {line}, byte {column} of the line (byte 0x{byte:02X}): the file is in \
                 another encoding; save it as UTF-8"
            ),
        }
    }
}

impl std::error::Error for DecodeError {}

/// The text of a source file's bytes: UTF-8, a leading byte-order mark dropped (as
/// editors write it on Windows). UTF-16 (with or without its mark) and other
/// encodings are a [`DecodeError`] saying what the file is and where it stops being
/// UTF-8.
pub fn decode_source(mut bytes: Vec<u8>) -> Result<String, DecodeError> {
    if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
        bytes.drain(..3);
    }
    let utf16 = bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]);
    // ASCII text in UTF-16 without a mark: every other byte is 0.
    let head = &bytes[..bytes.len().min(512)];
    let unmarked_utf16 = head.len() >= 4 && head.iter().filter(|b| **b == 0).count() * 3 >= head.len();
    if utf16 || unmarked_utf16 {
        return Err(DecodeError::Utf16);
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let b = e.as_bytes();
        let line = b[..at].iter().filter(|c| **c == b'\n').count() + 1;
        let column = at - b[..at].iter().rposition(|c| *c == b'\n').map_or(0, |p| p + 1) + 1;
        DecodeError::NotUtf8 { line, column, byte: b[at] }
    })
}

/// Serves files from memory first, then (optionally) from disk.
#[derive(Default)]
pub struct MemLoader {
    pub files: std::collections::BTreeMap<PathBuf, String>,
    /// Fall back to the file system for paths not in `files` (std imports).
    pub disk_fallback: bool,
}

impl FileLoader for MemLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        match self.files.get(path) {
            Some(t) => Ok(t.clone()),
            None if self.disk_fallback => FsLoader.read(path),
            None => Err("no such file".to_string()),
        }
    }
    fn canonicalize(&self, path: &Path) -> Result<PathBuf, String> {
        if self.files.contains_key(path) {
            Ok(normalize(path))
        } else if self.disk_fallback {
            FsLoader.canonicalize(path)
        } else {
            Err("no such file".to_string())
        }
    }
}

/// Lexically normalises `a/./b/../c` to `a/c` (no file system access).
pub fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// Where the lines of `text` start: at 0 and after every line break, which is
/// `\n`, `\r\n` or a lone `\r` (old Mac files; LSP counts it too). The lexer ends
/// `//` comments and one-line tokens at the same breaks, so a file with CR-only
/// line endings checks exactly like its LF twin.
pub fn line_starts(text: &str) -> Vec<u32> {
    let b = text.as_bytes();
    let mut starts = vec![0u32];
    for (i, &c) in b.iter().enumerate() {
        if c == b'\n' || (c == b'\r' && b.get(i + 1) != Some(&b'\n')) {
            starts.push(i as u32 + 1);
        }
    }
    starts
}

/// One source file.
pub struct SourceFile {
    pub path: PathBuf,
    /// The name shown in diagnostics.
    pub name: String,
    pub text: String,
    line_starts: Vec<u32>,
}

impl SourceFile {
    fn new(path: PathBuf, name: String, text: String) -> SourceFile {
        let line_starts = line_starts(&text);
        SourceFile { path, name, text, line_starts }
    }

    /// Zero-based (line, byte column) of a byte offset.
    pub fn line_col(&self, offset: u32) -> (u32, u32) {
        let line = match self.line_starts.binary_search(&offset) {
            Ok(l) => l,
            Err(l) => l - 1,
        };
        (line as u32, offset - self.line_starts[line])
    }

    /// Byte offset where zero-based `line` starts (clamped to the end of the text).
    pub fn line_start(&self, line: u32) -> u32 {
        self.line_starts.get(line as usize).copied().unwrap_or(self.text.len() as u32)
    }

    /// Byte offset where zero-based `line` ends: the start of the next line (after
    /// the line's break), or the end of the text for the last line.
    pub fn line_end(&self, line: u32) -> u32 {
        self.line_start(line + 1)
    }

    /// Number of lines.
    pub fn n_lines(&self) -> usize {
        self.line_starts.len()
    }
}

/// Every file read during one compilation.
#[derive(Default)]
pub struct Sources {
    pub files: Vec<SourceFile>,
}

impl Sources {
    /// Adds a file and returns its id.
    pub fn add(&mut self, path: impl Into<PathBuf>, name: impl Into<String>, text: impl Into<String>) -> FileId {
        self.files.push(SourceFile::new(path.into(), name.into(), text.into()));
        FileId(self.files.len() as u32 - 1)
    }

    /// The file with this id.
    pub fn file(&self, id: FileId) -> &SourceFile {
        &self.files[id.0 as usize]
    }

    /// The id of an already loaded file with this path.
    pub fn find(&self, path: &Path) -> Option<FileId> {
        self.files.iter().position(|f| f.path == path).map(|i| FileId(i as u32))
    }

    /// The text a span covers ("" if the span is out of range).
    pub fn text(&self, span: Span) -> &str {
        self.files.get(span.file.0 as usize).and_then(|f| f.text.get(span.range())).unwrap_or("")
    }
}
