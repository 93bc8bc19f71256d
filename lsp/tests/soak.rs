//! Soak test: 10,000 random edits (see `common/soak.rs`) with feature requests in
//! between: the server must not crash or panic, must answer every request, must
//! publish diagnostics for the final version, and its memory must stay flat.
//! Deterministic (fixed seed); takes a few seconds. The benchmark
//! `cargo bench -p mdg-lsp --bench latency` runs the same soak for 100,000 edits.

mod common;

const EDITS: usize = 10_000;

#[test]
fn ten_thousand_random_edits() {
    let soak = common::soak::run(EDITS, 1_000);
    assert_eq!(soak.rss.len(), EDITS / 1_000, "a memory sample every 1,000 edits");
    let (early, peak) = soak.early_and_peak().expect("memory samples");
    // Flat: the server may grow while it warms up (caches, allocator arenas), not per edit.
    soak.levelled_off().unwrap_or_else(|e| panic!("{e}"));
    eprintln!("soak: {EDITS} edits in {:.2?}, RSS {early} → {peak} KiB", soak.elapsed);
}

fn soak_of(rss: &[u64]) -> common::soak::Soak {
    common::soak::Soak {
        edits: EDITS,
        elapsed: std::time::Duration::ZERO,
        rss: rss.iter().enumerate().map(|(i, &k)| ((i + 1) * 1_000, k)).collect(),
    }
}

/// The flatness check on made-up samples: a warm-up then flat (as seen on a loaded
/// machine) passes; a steady leak of 6 KiB per edit fails.
#[test]
fn the_flatness_check_allows_a_warm_up_and_catches_a_leak() {
    let warm_up = [34048, 89324, 98088, 97872, 98544, 99080, 99940, 100292, 100296, 100856];
    assert!(soak_of(&warm_up).levelled_off().is_ok());
    let leak: Vec<u64> = (0..10).map(|i| 34048 + i * 6 * 1_000).collect();
    assert!(soak_of(&leak).levelled_off().is_err());
}
