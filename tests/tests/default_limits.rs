//! Default limits that protect the user (issue 17, docs/limits.md): a runaway
//! grammar — exponential recursion without `maxdepth`, `1000000000000 * {rz 1} B {}`,
//! recursion that draws nothing — ends with the defaults within 5 s of CPU time and
//! 1 GB of peak memory, with a warning naming the limit, how to raise it and the rule
//! that ran away (its line), and its output so far written to a `.glb`. Each run is
//! measured in a process of its own (this test binary re-entered), one at a time; the
//! tests are a binary of their own so that no other heavy test runs beside them.

use mdg_tests::{build_source, run_source};
use mdg_vm::eval::{evaluate, EvalOptions};
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn warning<'a>(out: &'a mdg_vm::output::Output, needle: &str) -> &'a str {
    out.stats
        .warnings
        .iter()
        .find(|w| w.contains(needle))
        .unwrap_or_else(|| panic!("no warning containing {needle:?} in {:?}", out.stats.warnings))
}

/// A scratch directory under the target directory, fresh for each test.
fn scratch(name: &str) -> PathBuf {
    let d = mdg_tests::root().join("target/tmp/default_limits").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// One measured run at a time (the in-process test below takes it too).
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// What [`run_isolated`] measured: wall time, peak RSS of the child, its warnings.
struct Isolated {
    took: Duration,
    /// CPU time of the child (user + system): what the run costs, whatever else the
    /// machine is doing.
    cpu: Duration,
    peak_kib: u64,
    warnings: Vec<String>,
    vertices: u64,
    glb_bytes: u64,
}

/// The child half of [`run_isolated`]: compiles `MDG_HOSTILE_SRC` with the default
/// options, evaluates it with `EvalOptions::default()` (the defaults every binary
/// gets), writes the `.glb` as `mdg-run` does, and prints what it saw and its own
/// peak RSS (`VmHWM`). Does nothing when run as an ordinary test.
#[test]
#[ignore = "the child process of the default-limit tests"]
fn isolated_child() {
    let Ok(src) = std::env::var("MDG_HOSTILE_SRC") else { return };
    let out_path = PathBuf::from(std::env::var("MDG_HOSTILE_OUT").expect("MDG_HOSTILE_OUT"));
    let out = run_source(&src);
    mdg_export::write_file(mdg_export::Format::Glb, &out, &out_path).expect("write glb");
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let hwm = status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        .unwrap_or(0);
    // CPU time (user + system) from /proc/self/stat, in clock ticks of 1/100 s.
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit_once(')').map(|(_, r)| r.split_whitespace().collect()).unwrap_or_default();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
    println!("ISOLATED cpu_ms {}", (ticks(11) + ticks(12)) * 10);
    println!("ISOLATED vertices {}", out.stats.vertices);
    println!("ISOLATED peak_kib {hwm}");
    for w in &out.stats.warnings {
        println!("ISOLATED warning {w}");
    }
}

/// Runs `src` in a fresh process (this test binary, [`isolated_child`]) so that its
/// peak memory is its own, and times it from spawn to exit.
fn run_isolated(name: &str, src: &str) -> Isolated {
    // One child at a time: each measures a run on its own, as a user would see it.
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch(name);
    let glb = dir.join("out.glb");
    let t0 = Instant::now();
    let child = std::process::Command::new(std::env::current_exe().expect("test binary"))
        .args(["--exact", "isolated_child", "--ignored", "--nocapture", "--test-threads", "1"])
        .env("MDG_HOSTILE_SRC", src)
        .env("MDG_HOSTILE_OUT", &glb)
        .output()
        .expect("spawn the child");
    let took = t0.elapsed();
    let stdout = String::from_utf8_lossy(&child.stdout).into_owned();
    assert!(child.status.success(), "child failed:\n{stdout}\n{}", String::from_utf8_lossy(&child.stderr));
    // (The test harness may print "test isolated_child ... " before the first line.)
    let after = |l: &str, tag: &str| l.find(tag).map(|i| l[i + tag.len()..].to_string());
    let field = |k: &str| stdout.lines().find_map(|l| after(l, &format!("ISOLATED {k} ")));
    let num = |k: &str| field(k).and_then(|v| v.parse::<u64>().ok()).unwrap_or_else(|| panic!("no {k} in {stdout}"));
    let warnings = stdout.lines().filter_map(|l| after(l, "ISOLATED warning ")).collect();
    let glb_bytes = std::fs::metadata(&glb).map(|m| m.len()).unwrap_or(0);
    let r = Isolated {
        took,
        cpu: Duration::from_millis(num("cpu_ms")),
        peak_kib: num("peak_kib"),
        warnings,
        vertices: num("vertices"),
        glb_bytes,
    };
    eprintln!(
        "{name}: {:.2?} wall, {:.2?} CPU, peak RSS {} MiB, {} vertices, .glb {} MiB, warnings {:?}",
        r.took,
        r.cpu,
        r.peak_kib / 1024,
        r.vertices,
        r.glb_bytes >> 20,
        r.warnings
    );
    r
}

/// The limits a runaway run must stay within with the defaults (issue 17).
fn assert_protected(r: &Isolated) {
    // 5 s of CPU time (the whole process: compile, evaluate, write the .glb); the
    // wall-clock bound is looser because test machines run many tests at once.
    assert!(r.cpu < Duration::from_secs(5), "took {:?} of CPU time", r.cpu);
    assert!(r.took < Duration::from_secs(30), "took {:?}", r.took);
    assert!(r.peak_kib <= 1024 * 1024, "peak RSS {} MiB", r.peak_kib / 1024);
    assert!(r.vertices > 0 && r.glb_bytes > 0, "the output so far is kept");
}

#[test]
fn exponential_recursion_without_maxdepth_ends_quickly_with_the_defaults() {
    let r = run_isolated(
        "default_exponential",
        "startshape A\nrule A {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n  A {z 1}\n  A {x 1}\n}\n",
    );
    assert_protected(&r);
    let w = r.warnings.iter().find(|w| w.contains("budget") || w.contains("maxiter")).expect("a limit warning");
    // The limit, the flag that raises it, and the rule that ran away with its line.
    assert_eq!(
        w,
        &format!(
            "vertex budget {} reached in rule `A` (inline.mdg:5): the run stopped; the output so far is kept (raise the limit with `--max-vertices N`)",
            mdg_vm::eval::DEFAULT_MAX_VERTICES
        )
    );
}

#[test]
fn a_trillion_runs_of_an_iterator_end_quickly_with_the_defaults() {
    let r = run_isolated(
        "default_trillion",
        "startshape A\nrule A {\n  1000000000000 * {rz 1} B {}\n}\nrule B { VERTEX {x 1} VERTEX {x 2} VERTEX {y 1} }\n",
    );
    assert_protected(&r);
    assert_eq!(
        r.warnings,
        [format!(
            "vertex budget {} reached in rule `A` (inline.mdg:3): the run stopped; the output so far is kept (raise the limit with `--max-vertices N`)",
            mdg_vm::eval::DEFAULT_MAX_VERTICES
        )]
    );
}

#[test]
fn recursion_that_draws_nothing_ends_at_the_default_maxiter() {
    let r = run_isolated("default_silent", "startshape A\nrule A {\n  A {x 1}\n  A {y 1}\n}\n");
    assert!(r.cpu < Duration::from_secs(5), "took {:?} of CPU time", r.cpu);
    assert!(r.took < Duration::from_secs(30), "took {:?}", r.took);
    assert!(r.peak_kib <= 1024 * 1024, "peak RSS {} MiB", r.peak_kib / 1024);
    let w = r.warnings.iter().find(|w| w.starts_with("maxiter")).expect("the maxiter warning");
    let head = format!("maxiter {} reached in rule `A` (inline.mdg:", mdg_vm::eval::DEFAULT_MAXITER);
    assert!(w.starts_with(&head), "{w}");
    assert!(
        w.ends_with("): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"),
        "{w}"
    );
}

#[test]
fn a_user_who_asks_for_more_gets_it() {
    // `maxiter` in the grammar and `max_vertices` (`--max-vertices`) raise the defaults.
    let _guard = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let src = "startshape A\nmaxiter 30000000\nrule A { 1000000000000 * {rz 1} VERTEX {x 1} }\n";
    let b = build_source(src);
    let n = mdg_vm::eval::DEFAULT_MAX_VERTICES + 100_000;
    let out = evaluate(&b, &EvalOptions { max_vertices: n, ..EvalOptions::default() });
    assert!(out.stats.vertices > mdg_vm::eval::DEFAULT_MAX_VERTICES, "{}", out.stats.vertices);
    assert!(warning(&out, "vertex budget").starts_with(&format!("vertex budget {n} reached")));
}
