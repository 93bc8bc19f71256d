//! Compiled SPIR-V kept across processes ([`DiskCache`]): a second compile of the
//! same shader does not run glslang, a corrupt or foreign cache file is a miss, and
//! an unwritable cache directory never fails a compile. Alone in its test binary:
//! the glslang run counter is per process.

use mdg_compiler::shaders::{cache_key, clear_memory_cache, compile_counts, compile_glsl, install_store, DiskCache};

#[test]
fn compiled_spirv_is_kept_on_disk_and_glslang_is_not_run_again() {
    let dir = std::env::temp_dir().join(format!("mdg-spirv-cache-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    assert!(install_store(Box::new(DiskCache::new(dir.clone()))));
    let src = "#version 450\nlayout(location = 0) in vec3 p;\nvoid main() { gl_Position = vec4(p, 1.0); }\n";
    let (runs0, hits0) = compile_counts();
    let words = compile_glsl(src, true).expect("compiles");
    assert_eq!(compile_counts(), (runs0 + 1, hits0), "compiled once");
    let files: Vec<_> = std::fs::read_dir(&dir).expect("the cache directory").filter_map(|e| e.ok()).collect();
    assert_eq!(files.len(), 1, "one file, written atomically (no temporary left)");
    assert!(files[0].file_name().to_string_lossy().ends_with(".spv"));

    // A new process (its memory cache empty) takes it from the disk.
    clear_memory_cache();
    assert_eq!(compile_glsl(src, true), Ok(words.clone()));
    assert_eq!(compile_counts(), (runs0 + 1, hits0 + 1), "not compiled again");
    // The same source for the other stage is another key.
    assert_ne!(cache_key(src, true), cache_key(src, false));

    // A corrupt file is a miss (compiled again, then rewritten).
    std::fs::write(files[0].path(), b"MDGSPIRV1\ngarbage").expect("corrupt it");
    clear_memory_cache();
    assert_eq!(compile_glsl(src, true), Ok(words.clone()));
    assert_eq!(compile_counts(), (runs0 + 2, hits0 + 1));
    clear_memory_cache();
    assert_eq!(compile_glsl(src, true), Ok(words));
    assert_eq!(compile_counts(), (runs0 + 2, hits0 + 2), "the rewritten file is read");

    // Errors are not kept on disk.
    let bad = "#version 450\nvoid main() { gl_Position = vec4(nope); }\n";
    assert!(compile_glsl(bad, true).is_err());
    assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unusable_cache_directory_never_fails_a_compile() {
    use mdg_compiler::shaders::SpirvStore;
    // A file where the directory should be: nothing can be written or read there.
    let blocker = std::env::temp_dir().join(format!("mdg-spirv-blocker-{}", std::process::id()));
    std::fs::write(&blocker, b"not a directory").expect("write");
    let cache = DiskCache::new(blocker.join("spirv"));
    let key = cache_key("#version 450\nvoid main() {}\n", false);
    cache.save(&key, &[0x0723_0203, 1, 2]);
    assert_eq!(cache.load(&key), None);
    let _ = std::fs::remove_file(&blocker);
}
