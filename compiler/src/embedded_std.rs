//! The std directory embedded in the compiler at build time ([`include_dir`]), and
//! the files under [`EMBEDDED_ROOT`], the std directory used when no cache directory
//! can be written (see [`crate::stdlib`]). Imports nothing from the crate, so the
//! source loader can read from it.

use include_dir::{include_dir, Dir, DirEntry};
use std::path::Path;

/// The std directory as it was when this compiler was built.
pub(crate) static STD: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/../std");

/// Every embedded file: its path relative to the std directory and its bytes, in
/// path order.
pub fn files() -> Vec<(&'static Path, &'static [u8])> {
    fn walk(d: &'static Dir<'static>, out: &mut Vec<(&'static Path, &'static [u8])>) {
        for e in d.entries() {
            match e {
                DirEntry::Dir(sub) => walk(sub, out),
                DirEntry::File(f) => out.push((f.path(), f.contents())),
            }
        }
    }
    let mut out = Vec::new();
    walk(&STD, &mut out);
    out.sort_by(|a, b| a.0.cmp(b.0));
    out
}

/// The std directory when no cache directory can be written: a relative path that
/// names no real directory; `source::FsLoader` reads the files
/// under it from memory, and diagnostics show them as `<built-in std>/NAME.mdg`.
pub const EMBEDDED_ROOT: &str = "<built-in std>";

/// The embedded file at `path` when `path` is under [`EMBEDDED_ROOT`].
pub fn embedded_file(path: &Path) -> Option<&'static [u8]> {
    let rel = path.strip_prefix(EMBEDDED_ROOT).ok()?;
    STD.get_file(rel).map(|f| f.contents())
}

/// Whether `path` is [`EMBEDDED_ROOT`] or a file or folder under it.
pub fn is_embedded(path: &Path) -> bool {
    match path.strip_prefix(EMBEDDED_ROOT) {
        Ok(rel) => rel.as_os_str().is_empty() || STD.get_file(rel).is_some() || STD.get_dir(rel).is_some(),
        Err(_) => false,
    }
}
