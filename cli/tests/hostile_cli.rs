//! Hostile and careless command lines (issue 25): numbers that used to panic,
//! values the checker accepted that allocated gigabytes, files that are not regular
//! files, outputs that overwrite their inputs. Each binary runs in its own process
//! under `ulimit -v` (virtual memory), so a dense allocation past the bound fails the
//! test instead of exhausting the machine, and its peak resident memory and time
//! are bounded too.

mod bounded;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

/// Virtual memory each child may map (KiB): 3 GiB. Every case below needs well
/// under 100 MB; the failures they guard against mapped 5–29 GB.
const VMEM_KIB: u64 = 3 * 1024 * 1024;
/// Peak resident memory each child may reach (KiB): 256 MiB.
const PEAK_KIB: u64 = 256 * 1024;

/// A fresh scratch directory for one test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mdg-hostile-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// Runs `bin` with `args` in `dir` under the memory bound and a 120 s limit (a
/// child that blocks, on a named pipe say, is killed and fails); asserts its peak
/// resident memory stayed under [`PEAK_KIB`]; returns the output and the wall time.
fn run_in(dir: &Path, bin: &str, args: &[&str]) -> (Output, Duration) {
    let r = bounded::run(dir, bin, args, &[], VMEM_KIB, Duration::from_secs(120));
    eprintln!(
        "{} {}: peak RSS {:.1} MiB, {:?}",
        bin.rsplit('/').next().unwrap_or(bin),
        args.join(" "),
        r.peak_kib as f64 / 1024.0,
        r.took
    );
    assert!(!r.timed_out, "{args:?} ran past 120 s");
    assert!(r.peak_kib < PEAK_KIB, "{args:?}: peak RSS {} KiB, more than {PEAK_KIB} KiB", r.peak_kib);
    (r.output, r.took)
}

fn mdg_run(dir: &Path, args: &[&str]) -> (Output, Duration) {
    run_in(dir, env!("CARGO_BIN_EXE_mdg-run"), args)
}

fn mdgc(dir: &Path, args: &[&str]) -> (Output, Duration) {
    run_in(dir, env!("CARGO_BIN_EXE_mdgc"), args)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The run ended by itself (no signal, so no panic abort or memory kill) with `code`,
/// printed no panic, and took less than `secs` (generous: the machine is shared).
fn assert_ended(o: &Output, took: Duration, code: i32, secs: u64) {
    let e = stderr(o);
    assert!(!e.contains("panicked"), "panicked: {e}");
    assert_eq!(o.status.code(), Some(code), "status {:?}, stderr: {e}", o.status);
    assert!(took < Duration::from_secs(secs), "took {took:?}");
}

const TRIANGLE: &str = "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";

// ----------------------------------------------------------------- numbers

#[test]
fn time_budgets_that_are_not_positive_finite_times_are_refused() {
    let dir = scratch("time-budget");
    std::fs::write(dir.join("a.mdg"), TRIANGLE).expect("ok");
    for bad in ["-1s", "nan", "infs", "-inf", "0s", "1e23s", "1e400ms", "10000001s", "soon", "2"] {
        let flag = format!("--time-budget={bad}");
        let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "a.obj", &flag]);
        // clap's usage error: exit 2, naming the flag and what it takes.
        assert_ended(&o, took, 2, 60);
        let e = stderr(&o);
        assert!(e.contains("--time-budget") && e.contains("expected a positive time"), "{bad}: {e}");
    }
    for good in ["2s", "1.5s", "500ms", "none", "10000000s"] {
        let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--time-budget", good]);
        assert_ended(&o, took, 0, 60);
    }
}

/// Issue 35: `clamp` with NaN bounds (one `log(-1)` or `0/0` away) made `mdg-run`
/// exit 101 and `mdgc build` panic while folding constants. Now every command ends
/// normally, the run warns that NaN arguments were used as 0 and `mdgc check` shows
/// the folded one (W0013); the source and its bundle give the same model.
#[test]
fn clamp_with_nan_bounds_runs_and_builds_without_a_panic() {
    let dir = scratch("clamp-nan");
    let src = "startshape A
isosurface S { xyz -1 1 8 ; function { clamp(x*x + y*y + z*z - 0.5, log(-1), 0/0) } }
rule A { B(0) {} S {} VERTEX {} VERTEX {x 1} VERTEX {y clamp(1, log(-1), 0/0) x 3} }
rule B(float t) {
  VERTEX {} VERTEX {x 1} VERTEX {y clamp(1, sqrt(t - 1), log(t - 1)) x 2}
  if (clamp(1, sqrt(t - 1), log(t - 1)) > 0) { VERTEX {} }
}
";
    std::fs::write(dir.join("a.mdg"), src).expect("ok");
    let (o, took) = mdgc(&dir, &["check", "a.mdg"]);
    assert_ended(&o, took, 0, 60);
    assert!(stderr(&o).contains("W0013"), "{}", stderr(&o));
    let (o, took) = mdgc(&dir, &["build", "a.mdg", "-o", "a.mdgb"]);
    assert_ended(&o, took, 0, 60);
    for input in ["a.mdg", "a.mdgb"] {
        let out = format!("{input}.json");
        let (o, took) = mdg_run(&dir, &[input, "-o", &out, "--format", "json"]);
        assert_ended(&o, took, 0, 60);
        assert!(stderr(&o).contains("computed as NaN") && stderr(&o).contains("used as 0"), "{}", stderr(&o));
    }
    let json = |f: &str| std::fs::read_to_string(dir.join(f)).expect("dump");
    assert_eq!(json("a.mdg.json"), json("a.mdgb.json"));
    assert!(json("a.mdg.json").starts_with("{\"vertices\":[[0.0,0.0,0.0],[1.0,0.0,0.0],[2.0,0.0,0.0]"));
}

#[test]
fn a_guide_file_with_points_near_f64_max_is_refused() {
    let dir = scratch("guide-max");
    let src = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples/guided_tree.mdg"))
        .expect("guided_tree.mdg");
    std::fs::write(dir.join("tree.mdg"), src).expect("ok");
    std::fs::write(
        dir.join("g.json"),
        r#"{"guides": [{"name": "far", "points": [[0,0,0],[1e308,0,0],[0,1e308,0],[-1e308,0,1e308]]}]}"#,
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["tree.mdg", "--guides", "g.json", "-o", "t.obj", "--budget", "50ms"]);
    assert_ended(&o, took, 1, 60);
    assert!(stderr(&o).contains("beyond ±1000000000"), "{}", stderr(&o));
    // Within the coordinate bound but 2.4e6 long with 0.25 segments: ten million
    // utilisation segments, a count each per particle (it took gigabytes); refused
    // while preparing the guides, before the search.
    std::fs::write(
        dir.join("long.json"),
        r#"{"guides": [{"name": "long", "points": [[0,0,0],[1e6,0,0],[0,1e6,0],[-1e6,0,1e6]]}]}"#,
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["tree.mdg", "--guides", "long.json", "-o", "t.obj", "--budget", "50ms"]);
    assert_ended(&o, took, 1, 60);
    assert!(stderr(&o).contains("into 9689759 utilisation segments, more than 1048576"), "{}", stderr(&o));
    // A tenth of that passes the per-guide limit, but 100 particles would keep 2 × 100
    // counts of each of its segments: refused before the search.
    std::fs::write(
        dir.join("longish.json"),
        r#"{"guides": [{"name": "longish", "points": [[0,0,0],[1e5,0,0],[0,1e5,0],[-1e5,0,1e5]]}]}"#,
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["tree.mdg", "--guides", "longish.json", "-o", "t.obj"]);
    assert_ended(&o, took, 1, 60);
    assert!(stderr(&o).contains("utilisation counts") && stderr(&o).contains("more than 67108864"), "{}", stderr(&o));
}

#[test]
fn a_grid_rule_placing_a_shape_16_million_blocks_away_ends_with_an_error() {
    let dir = scratch("grid-far");
    let src = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples/grid_cottage.mdg"))
        .expect("grid_cottage.mdg");
    let far = src.replace("rule floor floor at 6 0 0;", "rule floor floor at 16000000 0 0;");
    assert_ne!(far, src, "the example changed: update this test");
    std::fs::write(dir.join("far.mdg"), far).expect("ok");
    // The checker accepts the offset (within ±16777216); the enclosure constraint's
    // grid is refused before it is allocated (it was 29 GB).
    let (o, took) = mdg_run(&dir, &["far.mdg", "--bounds", "none", "-o", "far.obj"]);
    assert_ended(&o, took, 1, 60);
    assert!(stderr(&o).contains("too large for the enclosure constraint"), "{}", stderr(&o));
}

// ------------------------------------------------------------- reading

#[cfg(unix)]
#[test]
fn devices_and_named_pipes_are_refused_without_blocking() {
    let dir = scratch("not-regular");
    // mdgc check /dev/zero grew to 8 GB in 12 s.
    let (o, took) = mdgc(&dir, &["check", "/dev/zero"]);
    assert_ended(&o, took, 1, 60);
    let e = stderr(&o);
    assert!(e.contains("error[E0201]: cannot read `/dev/zero`: not a regular file (a device)"), "{e}");
    // --guides /dev/zero reached 22.8 GB.
    let tree = Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples/guided_tree.mdg");
    std::fs::copy(tree, dir.join("tree.mdg")).expect("ok");
    let (o, took) = mdg_run(&dir, &["tree.mdg", "--guides", "/dev/zero", "-o", "t.obj"]);
    // A guide file that cannot be read is an IO error, like a bundle (it was 1).
    assert_ended(&o, took, 2, 60);
    assert!(stderr(&o).contains("cannot read /dev/zero: not a regular file (a device)"), "{}", stderr(&o));
    // A named pipe imported in a project froze mdgc (open blocks until a writer comes).
    let fifo = dir.join("pipe.mdg");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
    assert!(made.success());
    std::fs::write(dir.join("main.mdg"), format!("@import pipe.mdg\n{TRIANGLE}")).expect("ok");
    let (o, took) = mdgc(&dir, &["check", "main.mdg"]);
    assert_ended(&o, took, 1, 60);
    let e = stderr(&o);
    assert!(e.contains("error[E0201]: cannot read `pipe.mdg`: not a regular file (a named pipe)"), "{e}");
    // So did a pipe given as the bundle to run.
    let fifo = dir.join("pipe.mdgb");
    assert!(Command::new("mkfifo").arg(&fifo).status().expect("mkfifo").success());
    let (o, took) = mdg_run(&dir, &["pipe.mdgb", "-o", "p.obj"]);
    assert_ended(&o, took, 2, 60);
    assert!(stderr(&o).contains("not a regular file (a named pipe)"), "{}", stderr(&o));
}

// ------------------------------------------------------------- writing

#[test]
fn an_output_that_is_an_input_is_refused_and_the_source_kept() {
    let dir = scratch("output-is-input");
    std::fs::write(dir.join("lib.mdg"), "rule B { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("ok");
    let main = format!("@import lib.mdg\n{TRIANGLE}");
    std::fs::write(dir.join("x.mdg"), &main).expect("ok");
    for (bin, args) in [
        ("mdg-run", vec!["x.mdg", "-o", "x.mdg"]),
        ("mdg-run", vec!["x.mdg", "-o", "lib.mdg", "--format", "obj"]),
        ("mdg-run", vec!["x.mdg", "-o", "x.obj", "--png", "./x.mdg"]),
        ("mdgc", vec!["build", "x.mdg", "-o", "lib.mdg"]),
    ] {
        let (o, took) = if bin == "mdgc" { mdgc(&dir, &args) } else { mdg_run(&dir, &args) };
        assert_ended(&o, took, 2, 60);
        assert!(stderr(&o).contains("that is an input"), "{args:?}: {}", stderr(&o));
    }
    assert_eq!(std::fs::read_to_string(dir.join("x.mdg")).expect("ok"), main);
    assert!(std::fs::read_to_string(dir.join("lib.mdg")).expect("ok").starts_with("rule B"));
}

#[cfg(unix)]
#[test]
fn an_output_that_is_an_input_through_a_hard_link_or_a_symlink_is_refused() {
    let dir = scratch("output-is-linked-input");
    std::fs::write(dir.join("x.mdg"), TRIANGLE).expect("ok");
    std::fs::hard_link(dir.join("x.mdg"), dir.join("hard.obj")).expect("hard link");
    std::os::unix::fs::symlink("x.mdg", dir.join("soft.obj")).expect("symlink");
    for out in ["hard.obj", "soft.obj"] {
        let (o, took) = mdg_run(&dir, &["x.mdg", "-o", out]);
        assert_ended(&o, took, 2, 60);
        assert!(stderr(&o).contains("that is an input"), "{out}: {}", stderr(&o));
    }
    assert_eq!(std::fs::read_to_string(dir.join("x.mdg")).expect("ok"), TRIANGLE, "the source is kept");
    assert!(std::fs::symlink_metadata(dir.join("soft.obj")).expect("ok").file_type().is_symlink());
}

#[test]
fn writing_to_dev_full_says_no_space_left_on_device() {
    if !Path::new("/dev/full").exists() {
        eprintln!("no /dev/full here: skipped");
        return;
    }
    let dir = scratch("dev-full");
    std::fs::write(dir.join("a.mdg"), TRIANGLE).expect("ok");
    let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "/dev/full", "--format", "obj"]);
    // An IO error: exit 2, as the statuses are documented (cli/src/failure.rs).
    assert_ended(&o, took, 2, 60);
    assert!(stderr(&o).contains("No space left on device"), "{}", stderr(&o));
}

#[cfg(unix)]
#[test]
fn directories_and_sockets_are_refused_as_sources() {
    let dir = scratch("dir-socket");
    std::fs::create_dir_all(dir.join("sub")).expect("ok");
    let (o, took) = mdgc(&dir, &["check", "sub"]);
    assert_ended(&o, took, 1, 60);
    let e = stderr(&o);
    assert!(
        e.contains("error[E0201]: cannot read `sub`: not a regular file (a directory); only regular files are read"),
        "{e}"
    );
    // A socket is refused at once too, but by `open` itself (ENXIO on Linux), before
    // `read_bounded` can name it: docs/limits.md's "(a socket)" is not what is printed.
    let _listener = std::os::unix::net::UnixListener::bind(dir.join("sock.mdg")).expect("bind");
    let (o, took) = mdgc(&dir, &["check", "sock.mdg"]);
    assert_ended(&o, took, 1, 60);
    let e = stderr(&o);
    assert!(e.contains("error[E0201]: cannot read `sock.mdg`: "), "{e}");
}

#[test]
fn a_corrupted_bundle_is_an_invalid_bundle_not_a_panic() {
    let dir = scratch("corrupt-bundle");
    std::fs::write(dir.join("a.mdg"), TRIANGLE).expect("ok");
    let (o, took) = mdgc(&dir, &["build", "a.mdg", "-o", "a.mdgb"]);
    assert_ended(&o, took, 0, 60);
    let (o, took) = mdg_run(&dir, &["a.mdgb", "-o", "a.obj"]);
    assert_ended(&o, took, 0, 60);
    let mut bytes = std::fs::read(dir.join("a.mdgb")).expect("bundle");
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x5a;
    std::fs::write(dir.join("bad.mdgb"), &bytes).expect("ok");
    let (o, took) = mdg_run(&dir, &["bad.mdgb", "-o", "bad.obj"]);
    assert_ended(&o, took, 1, 60);
    assert!(stderr(&o).starts_with("mdg-run: bad.mdgb: invalid bundle: "), "{}", stderr(&o));
    assert!(!dir.join("bad.obj").exists());
}

#[test]
fn a_picture_larger_than_8192_or_4096x4096_pixels_is_a_usage_error() {
    let dir = scratch("size");
    std::fs::write(dir.join("a.mdg"), TRIANGLE).expect("ok");
    for bad in ["8193x10", "10x8193", "0x10"] {
        let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--size", bad]);
        assert_ended(&o, took, 2, 60);
        assert_eq!(stderr(&o), format!("mdg-run: --size {bad}: expected WIDTHxHEIGHT, each 1..8192, e.g. 1024x768\n"));
    }
    // A side may be 8192, but a picture at most 4096x4096 pixels: 8192x8192 took
    // 3.8 GB (issue 35).
    let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--size", "8192x8192"]);
    assert_ended(&o, took, 2, 60);
    assert!(stderr(&o).contains("67108864 pixels, more than the 16777216 (4096x4096)"), "{}", stderr(&o));
    let (o, took) = mdg_run(&dir, &["a.mdg", "-o", "a.obj", "--size", "8192x2048"]);
    assert_ended(&o, took, 0, 60);
    // mdg-view has the same limit (checked before any Vulkan work).
    let (o, took) = run_in(&dir, env!("CARGO_BIN_EXE_mdg-view"), &["a.mdg", "--png", "a.png", "--size", "16384x10"]);
    assert_ended(&o, took, 2, 60);
    assert_eq!(stderr(&o), "mdg-view: --size 16384x10: expected WIDTHxHEIGHT, each 1..8192, e.g. 1024x768\n");
}

/// The `warning:` lines of a run's stderr.
fn warnings(o: &Output) -> Vec<String> {
    stderr(o).lines().filter(|l| l.starts_with("warning:")).map(str::to_string).collect()
}

#[test]
fn a_limit_reached_is_one_warning_line_and_the_run_succeeds() {
    let dir = scratch("one-warning");
    std::fs::write(
        dir.join("r.mdg"),
        "startshape A\nmaxiter 10\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} }\n",
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["r.mdg", "-o", "r.obj"]);
    assert_ended(&o, took, 0, 60);
    assert_eq!(
        warnings(&o),
        ["warning: maxiter 10 reached in rule `A` (r.mdg:3): the run stopped; the output so far is kept (raise the limit with `maxiter N` in the grammar, up to the cap set by `--max-iter N`)"],
        "{}",
        stderr(&o)
    );
    let obj = std::fs::read_to_string(dir.join("r.obj")).expect("the output is written");
    assert_eq!(obj.lines().filter(|l| l.starts_with("v ")).count(), 3 * 11, "the output so far is kept");
}

#[test]
fn the_evaluation_limit_flags_change_the_limits() {
    let dir = scratch("limit-flags");
    std::fs::write(
        dir.join("grow.mdg"),
        "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1} A {x 1} }\n",
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["grow.mdg", "-o", "g.obj", "--max-vertices", "1234"]);
    assert_ended(&o, took, 0, 60);
    assert_eq!(
        warnings(&o),
        ["warning: vertex budget 1234 reached in rule `A` (grow.mdg:2): the run stopped; the output so far is kept (raise the limit with `--max-vertices N`)"]
    );
    std::fs::write(
        dir.join("conv.mdg"),
        "startshape S\nmaxiter 100000000\nrule S * spin { VERTEX {x 1} VERTEX {x 2} VERTEX {y 1} }\n\
         rule spin { 1000000000000 * {rz 1} FRAME {} }\n",
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["conv.mdg", "-o", "c.obj", "--max-frames", "321"]);
    assert_ended(&o, took, 0, 60);
    assert_eq!(
        warnings(&o),
        ["warning: conv.mdg:4: convolution `S`: iterator rule `spin` did not end within the frame budget of 321 frames; only those are used (an iterator rule must terminate; raise the budget with `--max-frames N`)"]
    );
    std::fs::write(
        dir.join("iso.mdg"),
        "startshape A\nisosurface BALL { xyz -1 1 10 ; function { x*x + y*y + z*z - 1 } }\nrule A { VERTEX {} BALL {} }\n",
    )
    .expect("ok");
    let (o, took) = mdg_run(&dir, &["iso.mdg", "-o", "i.obj", "--max-iso-cells", "999"]);
    assert_ended(&o, took, 0, 60);
    assert_eq!(
        warnings(&o),
        ["warning: iso.mdg:3: isosurface `BALL` not built: isosurface grid has 1000 cells, more than the limit of 999 (raise it with `--max-iso-cells N`)"]
    );
    let (o, took) = mdg_run(&dir, &["iso.mdg", "-o", "i.obj", "--max-iso-cells", "1000"]);
    assert_ended(&o, took, 0, 60);
    assert_eq!(warnings(&o), Vec::<String>::new(), "1000 cells are within a limit of 1000");
}

#[test]
fn a_turntable_past_360_views_is_a_usage_error() {
    let dir = scratch("turntable");
    std::fs::write(dir.join("a.mdg"), TRIANGLE).expect("ok");
    // clap refuses it before any Vulkan is touched.
    let (o, took) = run_in(&dir, env!("CARGO_BIN_EXE_mdg-view"), &["a.mdg", "--png", "t.png", "--turntable", "10000"]);
    assert_ended(&o, took, 2, 60);
    assert!(
        stderr(&o).starts_with("error: invalid value '10000' for '--turntable <N>': 10000 is not in 1..=360"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("t.png").exists());
}

/// A file whose name holds terminal control sequences (`ESC [2J` clears the screen,
/// `ESC ] 0 ; … BEL` retitles the window): `mdgc check` and `mdg-run` name it in
/// their messages with the controls escaped, never raw.
#[test]
fn file_names_with_terminal_controls_are_printed_escaped() {
    let dir = scratch("controls");
    let name = "ev\u{1b}[2Jil\u{1b}]0;pwned\u{7}.mdg";
    std::fs::write(dir.join(name), "startshape A\nrule A { VERTEX {} } %\n").expect("write");
    let (o, _) = mdgc(&dir, &["check", name]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(!e.contains('\u{1b}') && !e.contains('\u{7}'), "{e:?}");
    assert!(e.contains(r"ev\u{1b}[2Jil\u{1b}]0;pwned\u{7}.mdg:2:22"), "{e}");
    // A path that cannot be read: the command's own message.
    let (o, _) = mdg_run(&dir, &["missing\u{1b}[2J.mdgb"]);
    let e = stderr(&o);
    assert!(!e.contains('\u{1b}') && e.contains(r"missing\u{1b}[2J.mdgb"), "{e:?}");
}
