//! Test fixtures: in-memory documents with a `$0` cursor marker.
//!
//! The main file is `/test/main.mdg`; extra files sit beside it; `@import NAME`
//! reads the real std library.

use super::Document;
use crate::expand::Options;
use crate::source::MemLoader;
use crate::span::Span;
use std::path::{Path, PathBuf};

/// The main file's path in fixtures.
pub const MAIN: &str = "/test/main.mdg";

/// Splits `$0` out of `text`: the text without it and the marker's offset.
pub fn cursor(text: &str) -> (String, Option<u32>) {
    match text.find("$0") {
        Some(i) => (format!("{}{}", &text[..i], &text[i + 2..]), Some(i as u32)),
        None => (text.to_string(), None),
    }
}

/// The std directory of this repository.
pub fn std_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../std")
}

/// A document for `main` (with an optional `$0`) and extra files `(name, text)` in `/test`.
pub fn doc_with(main: &str, files: &[(&str, &str)]) -> (Document, u32) {
    let (text, offset) = cursor(main);
    let mut loader = MemLoader { disk_fallback: true, ..MemLoader::default() };
    // The project root must canonicalize for relative imports to be contained.
    loader.files.insert(PathBuf::from("/test"), String::new());
    for (name, t) in files {
        loader.files.insert(Path::new("/test").join(name), t.to_string());
    }
    let opts = Options { std_dir: Some(std_dir()), ..Options::default() };
    let doc = Document::new(&loader, Path::new(MAIN), &text, &opts);
    (doc, offset.unwrap_or(0))
}

/// A document for `main` alone.
pub fn doc(main: &str) -> (Document, u32) {
    doc_with(main, &[])
}

/// `file:start..end "text"` for a span, to compare results readably.
pub fn show(doc: &Document, span: Span) -> String {
    let name = doc
        .file_path(span.file)
        .map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default())
        .unwrap_or_default();
    let f = &doc.analysis.sources.file(span.file);
    let (line, col) = f.line_col(span.start);
    format!("{name}:{}:{} {:?}", line + 1, col + 1, doc.span_text(span))
}

/// A section of `kind` that uses every key of [`crate::ext::keys`] once, at every
/// path (`KEY 1;`, or `KEY nN { … }` for a key that opens a block), one entry a line.
pub fn section_sample(kind: &str) -> String {
    fn entries(path: &mut Vec<&'static str>, depth: usize, n: &mut usize, out: &mut String) {
        for k in crate::ext::keys(path) {
            let pad = "  ".repeat(depth);
            path.push(k.name);
            if crate::ext::keys(path).is_empty() || depth > 6 {
                out.push_str(&format!("{pad}{} 1;\n", k.name));
            } else {
                *n += 1;
                out.push_str(&format!("{pad}{} n{n} {{\n", k.name));
                entries(path, depth + 1, n, out);
                out.push_str(&format!("{pad}}}\n"));
            }
            path.pop();
        }
    }
    let kind: &'static str = crate::lexer::SECTION_KINDS.iter().copied().find(|k| *k == kind).unwrap_or("guide");
    let mut out = format!("{kind} sample {{\n");
    entries(&mut vec![kind], 1, &mut 0, &mut out);
    out.push_str("}\n");
    out
}
