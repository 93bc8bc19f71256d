//! An in-memory file system for the preprocessor target: files, directories implied
//! by them, and symbolic links (resolved by `canonicalize`, like the real one), so
//! import containment and cycles are exercised without touching the disk.

use mdg_compiler::source::{normalize, FileLoader};
use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

/// Files and links in memory. Paths are absolute.
#[derive(Clone, Default)]
pub struct FuzzFs {
    pub files: BTreeMap<PathBuf, String>,
    /// Link path → target (absolute or relative to the link's directory).
    pub links: BTreeMap<PathBuf, PathBuf>,
}

impl FuzzFs {
    /// Resolves links component by component (at most 40 hops, like Linux).
    fn resolve(&self, path: &Path) -> Result<PathBuf, String> {
        let mut hops = 0;
        let mut todo: Vec<PathBuf> = normalize(path).components().map(|c| PathBuf::from(c.as_os_str())).collect();
        todo.reverse();
        let mut out = PathBuf::new();
        while let Some(c) = todo.pop() {
            if c.as_os_str() == ".." {
                out.pop();
                continue;
            }
            out.push(&c);
            if let Some(target) = self.links.get(&out) {
                hops += 1;
                if hops > 40 {
                    return Err("too many levels of symbolic links".into());
                }
                let base = out.parent().map(Path::to_path_buf).unwrap_or_default();
                let full = if target.is_absolute() { target.clone() } else { base.join(target) };
                let mut parts: Vec<PathBuf> = full
                    .components()
                    .filter(|c| !matches!(c, Component::CurDir))
                    .map(|c| PathBuf::from(c.as_os_str()))
                    .collect();
                parts.reverse();
                // The rest of the path goes after the link's target.
                let rest: Vec<PathBuf> = std::mem::take(&mut todo);
                todo = rest;
                todo.extend(parts);
                out = PathBuf::new();
            }
        }
        Ok(out)
    }

    fn exists(&self, p: &Path) -> bool {
        self.files.contains_key(p) || self.files.keys().any(|f| f.starts_with(p))
    }
}

impl FileLoader for FuzzFs {
    fn read(&self, path: &Path) -> Result<String, String> {
        let p = self.resolve(path)?;
        self.files.get(&p).cloned().ok_or_else(|| "no such file".to_string())
    }

    fn canonicalize(&self, path: &Path) -> Result<PathBuf, String> {
        let p = self.resolve(path)?;
        if self.exists(&p) {
            Ok(p)
        } else {
            Err("no such file".into())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_resolve_like_the_real_file_system() {
        let mut fs = FuzzFs::default();
        fs.files.insert("/proj/a.mdg".into(), "a".into());
        fs.files.insert("/secret/s.mdg".into(), "s".into());
        fs.links.insert("/proj/out".into(), "../secret".into());
        fs.links.insert("/proj/loop".into(), "loop".into());
        assert_eq!(fs.canonicalize(Path::new("/proj/out/s.mdg")), Ok(PathBuf::from("/secret/s.mdg")));
        assert_eq!(fs.canonicalize(Path::new("/proj/./a.mdg")), Ok(PathBuf::from("/proj/a.mdg")));
        assert_eq!(fs.canonicalize(Path::new("/proj")), Ok(PathBuf::from("/proj")));
        assert!(fs.canonicalize(Path::new("/proj/loop")).is_err());
        assert_eq!(fs.read(Path::new("/proj/out/s.mdg")), Ok("s".into()));
    }
}
