//! The shader deadline counts the compile thread's processor time, not wall-clock
//! time: a good shader compiled while other threads keep every core busy must not
//! fail. Four `mdg-view --png` at once on 2 cores used to fail std's own shaders
//! with E0502 under the 5 s wall-clock deadline.
//!
//! Alone in its test binary, so the load it makes disturbs no other test and no
//! other test's load disturbs its measurement.

#![cfg(target_os = "linux")]

use mdg_compiler::shaders::compile_glsl_within;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// This process's processor time (all threads), from `/proc/self/stat`.
fn process_cpu() -> Duration {
    let stat = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat");
    let fields: Vec<&str> = stat.rsplit_once(')').expect("comm").1.split_whitespace().collect();
    let ticks: u64 = fields[11].parse::<u64>().expect("utime") + fields[12].parse::<u64>().expect("stime");
    Duration::from_millis(ticks * 10)
}

/// A shader that takes glslang a while: `n` statements, made unique by `tag` so no
/// cache answers it.
fn shader(n: usize, tag: usize) -> String {
    let mut s = String::from("#version 450\nlayout(location = 0) in vec3 p;\nvoid main() {\n  float x = p.x;\n");
    for i in 0..n {
        s.push_str(&format!("  x = x * 1.0001 + sin(x + {i}.0) * p.y - cos(x * {i}.5);\n"));
    }
    s.push_str(&format!("  gl_Position = vec4(p * x, 1.0); // {tag}\n}}\n"));
    s
}

#[test]
fn a_loaded_machine_does_not_make_a_good_shader_miss_the_deadline() {
    // glslang's first compile pays for its initialisation.
    compile_glsl_within(&shader(10, 0), true, Duration::from_secs(60)).expect("warm-up compiles");
    // What one compile costs in processor time, alone.
    let n = 1500;
    let before = process_cpu();
    compile_glsl_within(&shader(n, 1), true, Duration::from_secs(60)).expect("compiles");
    let cost = process_cpu() - before;
    // A deadline well above that cost: a compile that used it all would be broken.
    let deadline = (cost * 3).max(Duration::from_millis(300));
    eprintln!("one compile: {cost:?} of processor time; deadline {deadline:?}");

    // Keep every core busy several times over, and compile again: the compile now
    // takes longer than the deadline in wall-clock time, but not in processor time.
    let cores = std::thread::available_parallelism().map_or(2, |n| n.get());
    for (attempt, per_core) in [6usize, 12, 24].into_iter().enumerate() {
        let stop = Arc::new(AtomicBool::new(false));
        let hogs: Vec<_> = (0..cores * per_core)
            .map(|_| {
                let stop = stop.clone();
                std::thread::spawn(move || {
                    let mut x = 0u64;
                    while !stop.load(Ordering::Relaxed) {
                        x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
                    }
                })
            })
            .collect();
        let t = Instant::now();
        let result = compile_glsl_within(&shader(n, 2 + attempt), true, deadline);
        let wall = t.elapsed();
        stop.store(true, Ordering::Relaxed);
        for h in hogs {
            h.join().expect("hog");
        }
        eprintln!("{} hogs: the compile took {wall:?} of wall-clock time", cores * per_core);
        assert!(result.is_ok(), "a good shader failed under load ({wall:?} wall, deadline {deadline:?}): {result:?}");
        if wall > deadline {
            // Shown: past the deadline in wall-clock time, and still compiled.
            return;
        }
    }
    panic!("could not load the machine enough to slow the compile past {deadline:?}: the test shows nothing");
}
