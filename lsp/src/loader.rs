//! The file loader the server gives the compiler: open documents (unsaved text)
//! first, then the file system.

use mdg_compiler::source::{normalize, FileLoader};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Open documents over the file system.
#[derive(Default)]
pub struct OverlayLoader {
    /// Open documents by path (both as given and canonical, when it exists on disk).
    pub open: HashMap<PathBuf, Arc<str>>,
}

impl OverlayLoader {
    /// Adds an open document.
    pub fn insert(&mut self, path: &Path, text: Arc<str>) {
        if let Ok(c) = std::fs::canonicalize(path) {
            self.open.insert(c, text.clone());
        }
        self.open.insert(path.to_path_buf(), text);
    }
}

impl FileLoader for OverlayLoader {
    fn read(&self, path: &Path) -> Result<String, String> {
        if let Some(t) = self.open.get(path) {
            return Ok(t.to_string());
        }
        mdg_compiler::source::FsLoader.read(path)
    }

    fn canonicalize(&self, path: &Path) -> Result<PathBuf, String> {
        match std::fs::canonicalize(path) {
            Ok(c) => Ok(c),
            // An unsaved document that exists only in the editor.
            Err(_) if self.open.contains_key(path) => Ok(normalize(path)),
            Err(e) => Err(e.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_documents_shadow_the_disk() {
        let dir = std::env::temp_dir().join(format!("mdg-lsp-loader-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let on_disk = dir.join("a.mdg");
        std::fs::write(&on_disk, "disk").expect("write");
        let mut l = OverlayLoader::default();
        assert_eq!(l.read(&on_disk).as_deref(), Ok("disk"));
        l.insert(&on_disk, Arc::from("editor"));
        assert_eq!(l.read(&l.canonicalize(&on_disk).expect("canon")).as_deref(), Ok("editor"));
        let unsaved = dir.join("new.mdg");
        assert!(l.canonicalize(&unsaved).is_err());
        l.insert(&unsaved, Arc::from("new"));
        assert_eq!(l.canonicalize(&unsaved), Ok(unsaved.clone()));
        assert_eq!(l.read(&unsaved).as_deref(), Ok("new"));
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }
}
