//! The std library built into the compiler, so that an installed `mdgc`, `mdg-run`,
//! `mdg-view` or `mdg-lsp` works from any directory without the source checkout.
//!
//! The files are embedded at build time ([`include_dir`]) and written once, on first
//! use, to a cache directory named after their content hash
//! (`$XDG_CACHE_HOME/mdg/std-HASH`, else `~/.cache/mdg/std-HASH`, else the
//! temporary directory): the compiler, the viewer's shader program and the
//! language server's go-to-definition then read real files. `$MDG_STD` (or
//! `--std`) still chooses another std directory.

use include_dir::{include_dir, Dir, DirEntry};
use std::path::{Path, PathBuf};

/// The std directory as it was when this compiler was built.
static STD: Dir<'static> = include_dir!("$CARGO_MANIFEST_DIR/../std");

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

/// FNV-1a over the paths and contents: names the cache directory, so a binary
/// built from another std never reads this one's files.
pub fn content_hash() -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for (path, bytes) in files() {
        for b in path.to_string_lossy().as_bytes().iter().chain([0u8].iter()).chain(bytes.iter()) {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

fn cache_root() -> PathBuf {
    if let Some(x) = std::env::var_os("XDG_CACHE_HOME").filter(|x| !x.is_empty()) {
        return PathBuf::from(x).join("mdg");
    }
    if let Some(h) = std::env::var_os("HOME").filter(|h| !h.is_empty()) {
        return PathBuf::from(h).join(".cache/mdg");
    }
    std::env::temp_dir().join("mdg")
}

/// The embedded std written out under `root` (once: a directory that holds the
/// completion marker is reused as it is). Returns the directory.
pub fn materialize_in(root: &Path) -> std::io::Result<PathBuf> {
    let dir = root.join(format!("std-{:016x}", content_hash()));
    let marker = dir.join(".complete");
    if marker.is_file() {
        return Ok(dir);
    }
    for (rel, bytes) in files() {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        mdg_vm::export::write_atomic(&path, bytes)?;
    }
    mdg_vm::export::write_atomic(&marker, b"")?;
    Ok(dir)
}

/// The embedded std, written to the cache directory if it is not there yet; `None`
/// when no cache directory can be written.
pub fn materialize() -> Option<PathBuf> {
    materialize_in(&cache_root()).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_std_is_the_std_directory() {
        let on_disk = Path::new(env!("CARGO_MANIFEST_DIR")).join("../std");
        let files = files();
        assert!(files.iter().any(|(p, _)| *p == Path::new("primitives.mdg")));
        for (rel, bytes) in &files {
            assert_eq!(std::fs::read(on_disk.join(rel)).expect("std file"), *bytes, "{}", rel.display());
        }
    }

    #[test]
    fn materialising_writes_every_file_once() {
        let root = std::env::temp_dir().join(format!("mdg-stdlib-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = materialize_in(&root).expect("written");
        for (rel, bytes) in files() {
            assert_eq!(std::fs::read(dir.join(rel)).expect("file"), bytes);
        }
        assert_eq!(materialize_in(&root).expect("again"), dir);
        let _ = std::fs::remove_dir_all(&root);
    }
}
