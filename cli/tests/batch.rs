//! Batch runs (`mdg-run --seeds A..B -o 'out/{seed}.glb' [--shard K/N]`): the union of
//! N shards is the unsharded run byte for byte (outputs and manifest lines), and a
//! run cut short (an output missing, the manifest's last line torn) resumes without
//! redoing the finished seeds.

use std::path::{Path, PathBuf};
use std::process::Command;

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
