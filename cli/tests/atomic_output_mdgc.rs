//! Atomic output under SIGKILL (`mdgc build`): killed while compiling and while its
//! temporary file is being written, the output path must then hold nothing or a
//! complete bundle that loads — never a truncated one. A killed writer may leave its
//! temporary file, named `.NAME.PID.N.tmp` beside the target (hidden, never the final
//! name); the test checks the names of any leftovers. (`mdg-run`'s twin of this test
//! is `cli/tests/atomic_output.rs`.)

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mdg-atomic-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

fn spawn(bin: &str, args: &[&Path], extra: &[&str]) -> Child {
    Command::new(bin).args(args).args(extra).stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("spawn")
}

/// Kills `child` with SIGKILL once `when` says so (or it exits by itself).
fn kill_when(mut child: Child, mut when: impl FnMut() -> bool) -> (bool, u32) {
    let pid = child.id();
    let t0 = Instant::now();
    loop {
        if let Ok(Some(_)) = child.try_wait() {
            return (false, pid);
        }
        if when() || t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill(); // SIGKILL on Unix
            let _ = child.wait();
            return (true, pid);
        }
        std::thread::sleep(Duration::from_micros(200));
    }
}

/// The temporary files in `dir` for the target `name`.
fn temps(dir: &Path, name: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(&format!(".{name}.")) && n.ends_with(".tmp"))
                .collect()
        })
        .unwrap_or_default()
}

/// Leftover temporaries must be named `.NAME.PID.N.tmp` with the PID of a killed run.
fn check_leftovers(dir: &Path, name: &str, killed: &[u32]) {
    for t in temps(dir, name) {
        let mid = &t[name.len() + 2..t.len() - 4];
        let pid: u32 = mid.split('.').next().and_then(|p| p.parse().ok()).unwrap_or(0);
        assert!(killed.contains(&pid), "{t}: not a temporary of a killed run");
    }
}

#[test]
fn a_killed_mdgc_build_never_leaves_a_partial_bundle() {
    let dir = scratch("build");
    let src = dir.join("big.mdg");
    let mut text = String::from("startshape r0\n");
    for i in 0..5_000 {
        text.push_str(&format!(
            "rule r{i} {{ VERTEX {{x {i}}} VERTEX {{y 1}} VERTEX {{z 1}} r{} {{s 0.5}} }}\n",
            i + 1
        ));
    }
    text.push_str("rule r5000 { VERTEX {} }\n");
    std::fs::write(&src, text).expect("write");
    let out = dir.join("big.mdgb");
    let bin = env!("CARGO_BIN_EXE_mdgc");
    let mut killed = Vec::new();
    let (mut absent, mut complete) = (0, 0);
    for round in 0..6 {
        let child = spawn(bin, &[Path::new("build"), &src, Path::new("-o"), &out], &[]);
        let extra = Duration::from_micros([0u64, 200, 1_000, 5_000, 20_000, 0][round]);
        let mut seen: Option<Instant> = None;
        let t0 = Instant::now();
        let (was_killed, pid) = kill_when(child, || {
            if round == 5 {
                return t0.elapsed() > Duration::from_millis(100); // while compiling
            }
            if seen.is_none() && !temps(&dir, "big.mdgb").is_empty() {
                seen = Some(Instant::now());
            }
            seen.is_some_and(|s| s.elapsed() >= extra)
        });
        if was_killed {
            killed.push(pid);
        }
        match std::fs::read(&out) {
            Err(_) => absent += 1,
            Ok(bytes) => {
                if let Err(e) = mdg_vm::bundle::load(&bytes) {
                    panic!("round {round}: {} holds a broken bundle ({} bytes): {e}", out.display(), bytes.len());
                }
                complete += 1;
            }
        }
        check_leftovers(&dir, "big.mdgb", &killed);
    }
    assert!(!killed.is_empty(), "no build was killed");
    assert_eq!(absent + complete, 6);
    let _ = std::fs::remove_dir_all(&dir);
}
