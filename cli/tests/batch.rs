//! Batch runs (`mdg-run --seeds A..B -o 'out/{seed}.glb' [--shard K/N]`): the union of
//! N shards is the unsharded run byte for byte (outputs and manifest lines), and a
//! run cut short (an output missing, the manifest's last line torn) resumes without
//! redoing the finished seeds. The manifest is never destroyed: a file that is not
//! ours is refused and left byte for byte, a device or pipe is refused without
//! reading it, and a second run of the same shard stops at once, naming the first.

mod bounded;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("batch-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// A grammar whose output depends on the seed.
const GRAMMAR: &str = "startshape arm\nmaxdepth 12\nrule arm {\n  VERTEX {} VERTEX {x 1} VERTEX {y 1}\n  arm {z 0.3 rz rand(-40, 40) s 0.9}\n}\n";

fn mdg_run(dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_mdg-run")).current_dir(dir).args(args).output().expect("run mdg-run");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "mdg-run {args:?} failed:\n{err}");
    err
}

fn manifest_lines(dir: &Path) -> Vec<String> {
    let mut lines = Vec::new();
    for e in std::fs::read_dir(dir.join("out")).expect("out").flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("manifest") {
            let text = std::fs::read_to_string(e.path()).expect("manifest");
            lines.extend(text.lines().map(str::to_string));
        }
    }
    lines.sort();
    lines
}

#[test]
fn shards_together_are_the_whole_run_and_a_cut_run_resumes() {
    let whole = scratch("whole");
    let sharded = scratch("sharded");
    for d in [&whole, &sharded] {
        std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    }
    mdg_run(&whole, &["g.mdg", "--seeds", "0..7", "-o", "out/{seed}.glb"]);
    for k in 0..3 {
        let shard = format!("{k}/3");
        mdg_run(&sharded, &["g.mdg", "--seeds", "0..7", "-o", "out/{seed}.glb", "--shard", &shard]);
    }
    let seeds: Vec<u64> = (0..7).collect();
    let mut distinct = std::collections::BTreeSet::new();
    for s in &seeds {
        let a = std::fs::read(whole.join(format!("out/{s}.glb"))).expect("whole output");
        let b = std::fs::read(sharded.join(format!("out/{s}.glb"))).expect("sharded output");
        assert_eq!(a, b, "seed {s}: the shard's output differs from the unsharded run's");
        distinct.insert(a);
    }
    assert!(distinct.len() > 3, "the seeds should give different models");
    let lines = manifest_lines(&whole);
    assert_eq!(lines.len(), 7);
    assert_eq!(lines, manifest_lines(&sharded), "the shards' manifests together are the whole run's");
    let first: serde_json::Value = serde_json::from_str(&lines[0]).expect("json line");
    assert_eq!(first["seed"], 0);
    assert_eq!(first["file"], "out/0.glb");
    assert!(
        first["vertices"].as_u64().is_some_and(|v| v > 0) && first["sha256"].as_str().is_some_and(|h| h.len() == 64)
    );

    // Cut short: seed 5's output is gone and the manifest's last line is torn.
    let manifest = whole.join("out/manifest.jsonl");
    let full = std::fs::read_to_string(&manifest).expect("manifest");
    let kept: Vec<&str> = full.lines().collect();
    let torn = format!("{}\n{}", kept[..5].join("\n"), &kept[5][..10]);
    std::fs::write(&manifest, torn).expect("tear");
    std::fs::remove_file(whole.join("out/5.glb")).expect("remove");
    let before = std::fs::metadata(whole.join("out/2.glb")).and_then(|m| m.modified()).expect("mtime");
    let err = mdg_run(&whole, &["g.mdg", "--seeds", "0..7", "-o", "out/{seed}.glb"]);
    assert!(err.contains("2 seeds run, 5 already done"), "{err}");
    assert!(
        err.contains("warning: out/manifest.jsonl: its last line was cut short") && err.contains("dropped 10 bytes"),
        "the torn line is dropped with a warning: {err}"
    );
    let after = std::fs::metadata(whole.join("out/2.glb")).and_then(|m| m.modified()).expect("mtime");
    assert_eq!(before, after, "a finished seed was redone");
    assert_eq!(std::fs::read_to_string(&manifest).expect("manifest"), full, "the resumed manifest is the whole run's");
}

#[test]
fn batch_mistakes_are_usage_errors() {
    let d = scratch("mistakes");
    std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_mdg-run")).current_dir(&d).args(args).output().expect("run");
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = run(&["g.mdg", "--seeds", "0..3", "-o", "out/a.glb"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("{seed}"), "{err}");
    let (code, err) = run(&["g.mdg", "--seeds", "3..1", "-o", "out/{seed}.glb"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--seeds 3..1"), "{err}");
    let (code, err) = run(&["g.mdg", "--seeds", "0..3", "-o", "out/{seed}.glb", "--shard", "3/3"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("--shard 3/3"), "{err}");
    assert!(!d.join("out").exists(), "a refused run writes nothing");
}

#[test]
fn the_default_output_is_in_the_current_directory() {
    let d = scratch("cwd");
    let std_tree = Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples/koch_snowflake.mdg");
    mdg_run(&d, &[std_tree.to_str().expect("utf-8 path")]);
    assert!(d.join("koch_snowflake.glb").is_file(), "the output goes into the current directory");
    assert!(!std_tree.with_extension("glb").exists(), "nothing is written into std/");
}

/// Runs mdg-run in `dir` under a 3 GiB virtual-memory bound and a 60 s limit (a
/// child that blocks on a pipe or reads a device forever fails the test instead of
/// hanging it or exhausting the machine); its peak resident memory must stay under
/// 256 MiB.
fn mdg_run_bounded(dir: &Path, args: &[&str]) -> Output {
    let r = bounded::run(dir, env!("CARGO_BIN_EXE_mdg-run"), args, &[], 3 * 1024 * 1024, Duration::from_secs(60));
    assert!(!r.timed_out, "mdg-run {args:?} ran past 60 s (blocked?)");
    eprintln!("mdg-run {}: peak RSS {} KiB, {:?}", args.join(" "), r.peak_kib, r.took);
    assert!(r.peak_kib < 256 * 1024, "mdg-run {args:?}: peak RSS {} KiB, more than 256 MiB", r.peak_kib);
    r.output
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A line as the previous version (format 1, no marker) wrote it: keys sorted.
fn v1_line(dir: &Path, seed: u64) -> String {
    let file = format!("out/{seed}.glb");
    let bytes = std::fs::read(dir.join(&file)).expect("output");
    format!(
        "{{\"bytes\":{},\"file\":\"{file}\",\"seed\":{seed},\"sha256\":\"{}\",\"triangles\":13,\"vertices\":39}}",
        bytes.len(),
        "ab".repeat(32)
    )
}

#[test]
fn a_manifest_that_is_not_ours_is_refused_and_left_as_it_was() {
    let d = scratch("foreign");
    std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    std::fs::create_dir_all(d.join("out")).expect("out");
    let manifest = d.join("out/manifest.jsonl");
    // A dataset tool's own manifest (valid JSON, even a `seed` field), lines that
    // are not JSON, and ours with a line damaged in the middle.
    let dataset: String = (0..2000)
        .map(|i| format!("{{\"seed\":{i},\"image\":\"img/{i}.png\",\"label\":\"cat\",\"split\":\"train\"}}\n"))
        .collect();
    let cases: [(&str, Vec<u8>); 5] = [
        ("a dataset's JSON lines", dataset.into_bytes()),
        ("CSV", b"seed,file\n0,a.png\n1,b.png\n".to_vec()),
        ("not UTF-8", vec![0, 1, 0xc3, 0x28, b'\n']),
        ("JSON without a trailing newline", b"{\"seed\":1,\"file\":\"x\"}".to_vec()),
        ("a line much longer than ours", format!("{{\"seed\":1,\"file\":\"{}\"}}\n", "x".repeat(200_000)).into_bytes()),
    ];
    for (what, text) in &cases {
        std::fs::write(&manifest, text).expect("write");
        let o = mdg_run_bounded(&d, &["g.mdg", "--seeds", "0..3", "-o", "out/{seed}.glb"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{what}: {e}");
        assert!(e.contains("out/manifest.jsonl is not a manifest of mdg-run"), "{what}: {e}");
        assert!(e.contains("line 1"), "{what}: the message says where: {e}");
        assert!(&std::fs::read(&manifest).expect("read") == text, "{what}: the file was changed");
        assert!(!d.join("out/0.glb").exists(), "{what}: a seed ran");
    }

    // Our own manifest with a damaged line in the middle: refused too (only a torn
    // last line is ours to drop).
    std::fs::remove_file(&manifest).expect("rm");
    mdg_run(&d, &["g.mdg", "--seeds", "0..3", "-o", "out/{seed}.glb"]);
    let full = std::fs::read_to_string(&manifest).expect("manifest");
    let lines: Vec<&str> = full.lines().collect();
    let damaged = format!("{}\n{}\n{}\n", lines[0], &lines[1][..30], lines[2]);
    std::fs::write(&manifest, &damaged).expect("damage");
    let o = mdg_run_bounded(&d, &["g.mdg", "--seeds", "0..3", "-o", "out/{seed}.glb"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("line 2"), "{e}");
    assert_eq!(std::fs::read_to_string(&manifest).expect("read"), damaged, "the damaged manifest was changed");
}

#[test]
fn a_manifest_of_the_previous_version_resumes() {
    let d = scratch("v1");
    std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    mdg_run(&d, &["g.mdg", "--seeds", "0..4", "-o", "out/{seed}.glb"]);
    // The manifest as the previous version left it: three lines and a torn fourth.
    let v1: String = (0..3).map(|s| v1_line(&d, s) + "\n").collect();
    let manifest = d.join("out/manifest.jsonl");
    std::fs::write(&manifest, format!("{v1}{}", &v1_line(&d, 3)[..40])).expect("write");
    let err = mdg_run(&d, &["g.mdg", "--seeds", "0..4", "-o", "out/{seed}.glb"]);
    assert!(err.contains("1 seeds run, 3 already done"), "{err}");
    let text = std::fs::read_to_string(&manifest).expect("manifest");
    assert!(text.starts_with(&v1), "the old lines are kept as they were");
    let last: serde_json::Value = serde_json::from_str(text.lines().last().expect("a line")).expect("json");
    assert_eq!((last["seed"].as_u64(), last["mdg_manifest"].as_u64()), (Some(3), Some(2)));
    assert_eq!(text.lines().count(), 4);
}

#[test]
fn a_manifest_that_is_not_a_regular_file_is_refused_without_reading_it() {
    let d = scratch("special");
    std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    std::fs::create_dir_all(d.join("out")).expect("out");
    let manifest = d.join("out/manifest.jsonl");
    let run = || mdg_run_bounded(&d, &["g.mdg", "--seeds", "0..3", "-o", "out/{seed}.glb"]);

    std::os::unix::fs::symlink("/dev/zero", &manifest).expect("symlink");
    let o = run();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("out/manifest.jsonl") && e.contains("not a regular file (a device)"), "{e}");
    std::fs::remove_file(&manifest).expect("rm");

    let made = Command::new("mkfifo").arg(&manifest).status().expect("mkfifo");
    assert!(made.success());
    let o = run();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("not a regular file (a named pipe)"), "{e}");
    std::fs::remove_file(&manifest).expect("rm");

    std::fs::create_dir(&manifest).expect("dir");
    let o = run();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("not a regular file (a directory)"), "{e}");
    assert!(!d.join("out/0.glb").exists(), "a seed ran");
}

/// A grammar that takes a while per seed (a million rule calls), so a run is still
/// going when the test looks at it.
const SLOW: &str = "startshape a\nrule a {\n  VERTEX {} VERTEX {x 1} VERTEX {y rand(0, 1)}\n  1000 * {x 1} row {}\n}\n\
                    rule row { 1000 * {y 1} dot {} }\nrule dot { }\n";

/// The seeds of a manifest's lines, in file order.
fn seeds_of(manifest: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(manifest).unwrap_or_default();
    text.lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| v["seed"].as_u64())
        .collect()
}

#[test]
fn a_second_run_of_the_same_shard_stops_at_once_and_names_the_first() {
    let d = scratch("lock");
    std::fs::write(d.join("g.mdg"), SLOW).expect("grammar");
    let args = ["g.mdg", "--seeds", "0..400", "-o", "out/{seed}.glb", "--shard", "1/2"];
    let manifest = d.join("out/manifest-1-of-2.jsonl");
    let mut first = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
        .current_dir(&d)
        .args(args)
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("first run");
    // Wait (at most 120 s) until the first run has finished a seed.
    let t0 = std::time::Instant::now();
    while seeds_of(&manifest).is_empty() {
        assert!(t0.elapsed() < Duration::from_secs(120), "the first run wrote no manifest line in 120 s");
        assert!(first.try_wait().expect("wait").is_none(), "the first run ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let second = mdg_run_bounded(&d, &args);
    let still_running = first.try_wait().expect("wait").is_none();
    let _ = first.kill();
    let _ = first.wait();
    assert!(still_running, "the first run ended before the second started: make SLOW slower");
    let e = stderr(&second);
    assert_eq!(second.status.code(), Some(75), "{e}");
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").expect("hostname");
    assert!(e.contains(&format!("pid {} on host {}", first.id(), host.trim())), "the holder is named: {e}");
    assert!(e.contains("out/manifest-1-of-2.jsonl.lock"), "{e}");

    // The first run was killed: a third finishes the shard, every seed once, and
    // takes over the stale lock file (and removes it at the end).
    let r = bounded::run(
        &d,
        env!("CARGO_BIN_EXE_mdg-run"),
        &["g.mdg", "--seeds", "0..40", "-o", "out/{seed}.glb", "--shard", "1/2"],
        &[],
        3 * 1024 * 1024,
        Duration::from_secs(300),
    );
    assert!(r.output.status.success(), "{}", stderr(&r.output));
    let mut seeds = seeds_of(&manifest);
    let n = seeds.len();
    seeds.sort();
    seeds.dedup();
    assert_eq!(seeds.len(), n, "a seed is recorded twice: {seeds:?}");
    let want: Vec<u64> = (0..40).filter(|s| s % 2 == 1).collect();
    assert!(want.iter().all(|s| seeds.contains(s)), "{seeds:?}");
    assert!(!d.join("out/manifest-1-of-2.jsonl.lock").exists(), "the lock file is left behind");
}

/// `-j N` runs seeds side by side: every output and the manifest are byte for byte
/// those of `-j 1` (the manifest's lines in seed order).
#[test]
fn seeds_run_side_by_side_give_the_same_bytes() {
    let serial = scratch("jobs-1");
    let parallel = scratch("jobs-3");
    for d in [&serial, &parallel] {
        std::fs::write(d.join("g.mdg"), GRAMMAR).expect("grammar");
    }
    mdg_run(&serial, &["g.mdg", "--seeds", "0..12", "-o", "out/{seed}.glb", "-j", "1"]);
    mdg_run(&parallel, &["g.mdg", "--seeds", "0..12", "-o", "out/{seed}.glb", "-j", "3"]);
    for s in 0..12 {
        let a = std::fs::read(serial.join(format!("out/{s}.glb"))).expect("-j 1 output");
        let b = std::fs::read(parallel.join(format!("out/{s}.glb"))).expect("-j 3 output");
        assert_eq!(a, b, "seed {s}: -j 3 wrote other bytes than -j 1");
    }
    // The manifests byte for byte: the same lines in the same (seed) order.
    let manifest = |d: &Path| std::fs::read_to_string(d.join("out/manifest.jsonl")).expect("manifest");
    let text = manifest(&serial);
    assert_eq!(text, manifest(&parallel));
    let seeds: Vec<u64> =
        text.lines().filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok()?["seed"].as_u64()).collect();
    assert_eq!(seeds, (0..12).collect::<Vec<u64>>());
    let e = mdg_run_bounded(&serial, &["g.mdg", "-o", "x.glb", "-j", "2"]);
    assert_eq!(e.status.code(), Some(2), "-j without --seeds is a usage error: {}", stderr(&e));
}
