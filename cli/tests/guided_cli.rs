//! `mdg-run` with search flags on a grammar without a `search` section: the run goes
//! on as a plain evaluation and a warning says the flag was ignored.

use std::process::Command;

#[test]
fn search_flags_without_a_search_section_are_ignored_with_a_warning() {
    let dir = std::env::temp_dir().join(format!("mdg-guided-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("a.mdg"), "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("write");
    std::fs::write(dir.join("g.json"), r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]]}]}"#)
        .expect("write");
    for (flags, named) in [(&["--guides", "g.json"][..], "--guides"), (&["--particles", "20"][..], "--particles")] {
        let out = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
            .args(["a.mdg", "-o", "a.obj"])
            .args(flags)
            .current_dir(&dir)
            .output()
            .expect("run mdg-run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        let want = format!("warning: {named} is ignored: the grammar has no `search` section (docs/guided.md)");
        assert!(err.lines().any(|l| l == want), "{err}");
        assert!(dir.join("a.obj").is_file());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bad search flag or an unreadable guide file is a usage or IO error (exit 2); a
/// guide file that is read and refused, an error in the input (exit 1).
#[test]
fn search_flag_and_guide_file_failures_exit_with_their_status() {
    let dir = std::env::temp_dir().join(format!("mdg-guided-status-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::write(dir.join("bad.json"), r#"{"guides": [{"points": [[0,0,0],[0,0,1]]}]}"#).expect("write");
    let tree = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../std/examples/guided_tree.mdg");
    for (flags, status, says) in [
        (&["--particles", "0"][..], 2, "--particles 0: expected N or FIRST:LAST"),
        (&["--utilisation", "eq7"][..], 2, "--utilisation eq7: expected `paper` or `local`"),
        (&["--guides", "missing.json"][..], 2, "cannot read missing.json"),
        (&["--guides", "bad.json"][..], 1, "bad.json: invalid guide file"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_mdg-run"))
            .arg(&tree)
            .args(["-o", "t.obj"])
            .args(flags)
            .current_dir(&dir)
            .output()
            .expect("run mdg-run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(status), "{flags:?}: {err}");
        assert!(err.contains(says), "{flags:?}: {err}");
        assert!(!dir.join("t.obj").exists(), "{flags:?}: nothing written");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
