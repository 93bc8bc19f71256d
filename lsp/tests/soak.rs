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
    // Flat: after the first 1,000 edits the server may grow by caches, not per edit.
    assert!(peak < early + early / 2 + 32 * 1024, "memory grew from {early} KiB to {peak} KiB: {:?}", soak.rss);
    eprintln!("soak: {EDITS} edits in {:.2?}, RSS {early} → {peak} KiB", soak.elapsed);
}
