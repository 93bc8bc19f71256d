//! Heap bounds for tests of hostile input: a test binary installs `peakmem-alloc`'s
//! instrumented system allocator and wraps each case in [`bounded`], which fails
//! when the case's peak of live heap bytes or its wall time passes a bound.
//! Measured cases run one at a time (the peak is the whole process's), so a binary
//! that uses it measures every test.
//!
//! ```ignore
//! #[global_allocator]
//! static HEAP: &PeakMemAlloc<System> = &INSTRUMENTED_SYSTEM;
//! ```

pub use peakmem_alloc::{PeakMemAlloc, PeakMemAllocTrait, INSTRUMENTED_SYSTEM};
use std::alloc::System;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// What [`measure`] saw.
#[derive(Clone, Copy, Debug)]
pub struct Measured {
    /// The most heap bytes live at once during the case, above those live before.
    pub peak_bytes: usize,
    pub took: Duration,
}

static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Runs `f` alone (no other measured case runs meanwhile) and returns its result
/// with its peak heap use (as `heap` counts it: the binary's global allocator) and
/// wall time.
pub fn measure<T>(heap: &PeakMemAlloc<System>, f: impl FnOnce() -> T) -> (T, Measured) {
    let _alone = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    heap.reset_peak_memory();
    let t0 = Instant::now();
    let v = f();
    let took = t0.elapsed();
    (v, Measured { peak_bytes: heap.get_peak_memory(), took })
}

/// [`measure`], asserting that the case stayed under `max_mib` MiB of heap and
/// `max_secs` seconds: bounds generous against what it needs (a shared machine is
/// slow) but far below what a missing limit costs (gigabytes, minutes).
pub fn bounded<T>(heap: &PeakMemAlloc<System>, what: &str, max_mib: usize, max_secs: u64, f: impl FnOnce() -> T) -> T {
    let (v, m) = measure(heap, f);
    let mib = m.peak_bytes as f64 / (1 << 20) as f64;
    assert!(m.peak_bytes <= max_mib << 20, "{what}: peak heap {mib:.1} MiB, more than the bound of {max_mib} MiB");
    assert!(m.took <= Duration::from_secs(max_secs), "{what}: took {:?}, more than {max_secs} s", m.took);
    eprintln!("{what}: peak heap {mib:.1} MiB in {:?}", m.took);
    v
}
