//! Every fuzz target runs its corpus and the crash reproducers it found (fixed since,
//! kept in `fuzz/regressions/TARGET/`) without panicking, on a 2 MiB stack (the
//! language server's worker threads). Then a short bounded fuzz run per target, so
//! the harness itself stays working; long runs are `fuzz/run`.

use mdg_fuzz::{Rng, Target};
use std::path::{Path, PathBuf};

fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_file()).collect())
        .unwrap_or_default();
    v.sort();
    v
}

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `f` on a thread with a 2 MiB stack and returns whether it panicked.
fn on_small_stack(f: impl FnOnce() + Send + 'static) -> Result<(), String> {
    std::thread::Builder::new().stack_size(2 * 1024 * 1024).spawn(f).map_err(|e| e.to_string())?.join().map_err(|p| {
        p.downcast_ref::<String>()
            .cloned()
            .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default()
    })
}

#[test]
fn corpus_and_fixed_crashes_run_clean() {
    let mut failures = Vec::new();
    let mut n = 0;
    for t in Target::ALL {
        let corpus = files(&fuzz_dir().join("corpus").join(t.name()));
        assert!(!corpus.is_empty(), "{}: empty corpus", t.name());
        let fixed = files(&fuzz_dir().join("regressions").join(t.name()));
        for path in corpus.into_iter().chain(fixed) {
            let bytes = std::fs::read(&path).expect("read");
            let Some(input) = t.seed(&path, bytes) else {
                // A corpus program for bundle_load must compile.
                failures.push(format!("{}: {} is not an input", t.name(), path.display()));
                continue;
            };
            n += 1;
            if let Err(e) = on_small_stack(move || {
                t.run(&input);
            }) {
                failures.push(format!("{}: {} panicked: {e}", t.name(), path.display()));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(n > 40, "only {n} inputs");
}

#[test]
fn every_target_survives_a_short_bounded_run() {
    for t in Target::ALL {
        let res = on_small_stack(move || {
            let pool: Vec<Vec<u8>> = files(&fuzz_dir().join("corpus").join(t.name()))
                .into_iter()
                .filter_map(|p| std::fs::read(&p).ok().and_then(|b| t.seed(&p, b)))
                .collect();
            let dict = t.dictionary();
            let mut rng = Rng::new(0x5EED);
            for _ in 0..30 {
                let input = t.next_input(&mut rng, &pool, pool.len(), &dict);
                assert!(input.len() <= t.max_len());
                t.run(&input);
            }
        });
        assert!(res.is_ok(), "{}: {res:?}", t.name());
    }
}
