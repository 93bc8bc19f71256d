//! The std library built into the compiler.
//!
//! Two uses. (1) What the std library defines, for the hint on an unknown name: a
//! call of a rule or isosurface that a std library file defines (`SPHERE {}` without
//! `@import primitives`, as thesis Listing 4.1 is printed) gets E0301 with a
//! suggestion that adds the right `@import` (a quick fix in the editor). See
//! docs/decisions.md (issue 17) for why this is a fix and not an implicit prelude.
//! The libraries are the embedded std directory's top-level files ([`libraries`]).
//!
//! (2) The whole std directory, so that an installed `mdgc`, `mdg-run`, `mdg-view` or
//! `mdg-lsp` works from any directory without the source checkout: embedded at build
//! time ([`include_dir`]) and written once, on first use, to a cache directory named
//! after the content hash (`$XDG_CACHE_HOME/mdg/std-HASH`, else `~/.cache/mdg/std-HASH`,
//! else the temporary directory) by [`materialize`]: the compiler, the viewer's shader
//! program and the language server's go-to-definition then read real files.
//! `$MDG_STD` (or `--std`) still chooses another std directory.
//!
//! Where none of those directories can be written (a service user whose `HOME` does
//! not exist, a read-only container), std is read from memory: [`materialize`]
//! returns [`EMBEDDED_ROOT`], a path no file system holds, and
//! [`FsLoader`](crate::source::FsLoader) serves the files under it from the
//! embedded copy ([`embedded_file`]). A writable `HOME` is never needed.

use crate::embedded_std::STD;
pub use crate::embedded_std::{embedded_file, files, is_embedded, EMBEDDED_ROOT};
use crate::lexer::{self, Tok};
use crate::span::FileId;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Every std library: its `@import` name and its text — the `.mdg` files at the top
/// of the embedded std directory, in name order (so the list is complete by
/// construction).
pub fn libraries() -> Vec<(&'static str, &'static str)> {
    STD.files()
        .filter(|f| f.path().extension().is_some_and(|e| e == "mdg"))
        .filter_map(|f| Some((f.path().file_stem()?.to_str()?, f.contents_utf8()?)))
        .collect::<std::collections::BTreeMap<_, _>>()
        .into_iter()
        .collect()
}

/// The names each library declares at its top level (`rule NAME`, `isosurface NAME`),
/// mapped to the first library (in [`libraries`] order) that declares them.
fn index() -> &'static HashMap<String, &'static str> {
    static INDEX: OnceLock<HashMap<String, &'static str>> = OnceLock::new();
    INDEX.get_or_init(|| {
        let mut map = HashMap::new();
        for (lib, text) in libraries() {
            let lexed = lexer::lex(text, FileId(0));
            let mut depth = 0usize;
            let toks = &lexed.tokens;
            for (i, t) in toks.iter().enumerate() {
                match t.kind {
                    Tok::LBrace | Tok::LBracket | Tok::IndexOpen | Tok::LParen | Tok::CallOpen => depth += 1,
                    Tok::RBrace | Tok::RBracket | Tok::RParen => depth = depth.saturating_sub(1),
                    Tok::KwRule | Tok::KwIsosurface if depth == 0 => {
                        if let Some(n) = toks.get(i + 1).filter(|n| n.kind == Tok::Ident) {
                            let name = &text[n.span.start as usize..n.span.end as usize];
                            map.entry(name.to_string()).or_insert(lib);
                        }
                    }
                    _ => {}
                }
            }
        }
        map
    })
}

/// The std library that defines rule or isosurface `name`, if any.
pub fn library_defining(name: &str) -> Option<&'static str> {
    index().get(name).copied()
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

/// The user's cache directories for MDG, best first: `$XDG_CACHE_HOME/mdg` (an
/// absolute path, as the XDG spec requires), then `$HOME/.cache/mdg`. The embedded
/// std and the SPIR-V cache ([`crate::shaders::DiskCache`]) live under them.
pub fn user_cache_roots() -> Vec<PathBuf> {
    let mut roots = Vec::new();
    if let Some(x) = std::env::var_os("XDG_CACHE_HOME").map(PathBuf::from).filter(|x| x.is_absolute()) {
        roots.push(x.join("mdg"));
    }
    if let Some(h) = std::env::var_os("HOME").filter(|h| !h.is_empty()) {
        roots.push(PathBuf::from(h).join(".cache/mdg"));
    }
    roots
}

/// Where the embedded std may be written, best first: [`user_cache_roots`], then
/// the temporary directory.
fn cache_roots() -> Vec<PathBuf> {
    let mut roots = user_cache_roots();
    roots.push(std::env::temp_dir().join("mdg"));
    roots
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
        mdg_export::write_atomic(&path, bytes)?;
    }
    mdg_export::write_atomic(&marker, b"")?;
    Ok(dir)
}

/// The embedded std, written to the first cache directory that can be written if it
/// is not there yet; [`EMBEDDED_ROOT`] (read from memory) when none can. Done once
/// per process (every analysis asks for the std directory).
pub fn materialize() -> Option<PathBuf> {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    Some(DIR.get_or_init(|| materialize_first(&cache_roots())).clone())
}

/// The std written under the first of `roots` that takes it, else [`EMBEDDED_ROOT`].
fn materialize_first(roots: &[PathBuf]) -> PathBuf {
    roots.iter().find_map(|r| materialize_in(r).ok()).unwrap_or_else(|| PathBuf::from(EMBEDDED_ROOT))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn std_names_map_to_their_library() {
        assert_eq!(library_defining("SPHERE"), Some("primitives"));
        assert_eq!(library_defining("cube"), Some("primitives"));
        assert_eq!(library_defining("sic_lattice"), Some("molecules"));
        assert_eq!(library_defining("no_such_rule_anywhere"), None);
    }
}

#[cfg(test)]
mod embedded_tests {
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
    fn the_libraries_are_the_top_level_std_files() {
        let on_disk = Path::new(env!("CARGO_MANIFEST_DIR")).join("../std");
        let mut names: Vec<String> = std::fs::read_dir(&on_disk)
            .expect("std dir")
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "mdg"))
            .filter_map(|p| Some(p.file_stem()?.to_str()?.to_string()))
            .collect();
        names.sort();
        let libs: Vec<&str> = libraries().iter().map(|(n, _)| *n).collect();
        assert_eq!(libs, names);
        assert!(libs.contains(&"primitives") && libs.contains(&"molecules"));
    }

    #[test]
    fn without_a_writable_directory_std_is_read_from_memory() {
        // A path below a regular file can never be created, even as root.
        let file = std::env::temp_dir().join(format!("mdg-stdlib-file-{}", std::process::id()));
        std::fs::write(&file, "x").expect("write");
        let dir = materialize_first(&[file.join("cache"), file.join("tmp")]);
        assert_eq!(dir, PathBuf::from(EMBEDDED_ROOT));
        let loader = crate::source::FsLoader;
        let text = crate::source::FileLoader::read(&loader, &dir.join("primitives.mdg")).expect("read from memory");
        assert!(text.contains("SPHERE"));
        assert!(crate::source::FileLoader::canonicalize(&loader, &dir).is_ok());
        assert!(crate::source::FileLoader::canonicalize(&loader, &dir.join("nope.mdg")).is_err());
        // An ordinary program imports from it.
        let opts = crate::expand::Options { std_dir: Some(dir), ..Default::default() };
        let a = crate::driver::analyze_text(
            &loader,
            &file.with_extension("mdg"),
            "@import primitives\nstartshape a\nrule a { cube {} }\n",
            &opts,
            crate::check::CheckOptions { require_start: true },
        );
        let _ = std::fs::remove_file(&file);
        assert!(!a.has_errors(), "{}", crate::diag::render_plain(&a.diagnostics, &a.sources));
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
