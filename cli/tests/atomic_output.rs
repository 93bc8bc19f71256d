//! Atomic output under SIGKILL (`mdg-run`): killed at many points — during evaluation,
//! export, and while its temporary file is being written — the output path must then
//! hold nothing or a complete, valid `.glb`: the previous one or the new one, never a
//! truncated mix. A killed writer may leave its temporary file, named
//! `.NAME.PID.N.tmp` beside the target (hidden, never the final name); the test checks
//! the names of any leftovers. The same holds for `mdgc build` and its bundle: killed
//! while compiling and while writing, the path holds nothing or a bundle that loads.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mdg-atomic-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

/// A grammar with about 400,000 vertices (a 16 MB `.glb`).
const BIG: &str =
    "startshape A\nmaxdepth 16\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} A {z 1 s 0.9 rx rand(0, 9)} A {x 1 s 0.9 ry 7} }\n";

/// Checks that `bytes` are one whole glTF binary: header, JSON chunk, BIN chunk, and
/// every accessor inside the buffer.
fn check_glb(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |i: usize| -> Result<usize, String> {
        bytes.get(i..i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize).ok_or("short".into())
    };
    if bytes.get(..4) != Some(b"glTF") || u32_at(4)? != 2 {
        return Err("bad glTF header".into());
    }
    if u32_at(8)? != bytes.len() {
        return Err(format!("header says {} bytes, file has {}", u32_at(8)?, bytes.len()));
    }
    let json_len = u32_at(12)?;
    if bytes.get(16..20) != Some(b"JSON") {
        return Err("no JSON chunk".into());
    }
    let json = bytes.get(20..20 + json_len).ok_or("JSON chunk cut")?;
    let json = std::str::from_utf8(json).map_err(|e| format!("JSON chunk: {e}"))?.trim_end();
    if !(json.starts_with('{') && json.ends_with('}') && json.contains("\"meshes\"")) {
        return Err("the JSON chunk is not a whole glTF document".into());
    }
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at)?;
    if bytes.get(bin_at + 4..bin_at + 8) != Some(b"BIN\0") || bin_at + 8 + bin_len != bytes.len() {
        return Err("the BIN chunk does not end the file".into());
    }
    // The buffer the JSON declares fits in the BIN chunk.
    let declared: usize = json
        .split("\"byteLength\":")
        .nth(1)
        .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).find(|s| !s.is_empty()))
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    if declared == 0 || declared > bin_len {
        return Err(format!("buffer of {declared} bytes in a BIN chunk of {bin_len}"));
    }
    Ok(())
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
fn a_killed_mdg_run_never_leaves_a_partial_mesh() {
    let dir = scratch("run");
    let src = dir.join("big.mdg");
    std::fs::write(&src, BIG).expect("write");
    let out = dir.join("big.glb");
    let bin = env!("CARGO_BIN_EXE_mdg-run");
    let mut killed = Vec::new();
    let (mut mid_write, mut before, mut replaced) = (0, 0, 0);
    // A clean run first (seed 2): its time scales the last fixed kills, late enough
    // for a run to finish even on a loaded machine, where a run can take longer
    // than every fixed delay (then nothing would ever be replaced).
    let t = Instant::now();
    let status = Command::new(bin)
        .args([src.as_path(), Path::new("-o"), out.as_path()])
        .args(["--seed", "2"])
        .stderr(Stdio::null())
        .status()
        .expect("run");
    assert!(status.success());
    let clean = t.elapsed().as_millis() as u64;
    // Kills at fixed times after the start (evaluation, export, writing), then kills
    // timed from the moment the temporary file appears.
    let delays_ms = [5u64, 30, 80, 150, 250, 400, 600, 3 * clean, 6 * clean];
    for round in 0..delays_ms.len() + 6 {
        let had = out.exists();
        let old = std::fs::read(&out).ok();
        // Even rounds write a different seed, so a replaced file is detectable.
        let seed = if round % 2 == 0 { "1" } else { "2" };
        let child = spawn(bin, &[&src, Path::new("-o"), &out], &["--seed", seed]);
        let t0 = Instant::now();
        let (was_killed, pid) = if let Some(d) = delays_ms.get(round) {
            kill_when(child, || t0.elapsed() >= Duration::from_millis(*d))
        } else {
            let extra = Duration::from_micros([0u64, 300, 1_000, 3_000, 10_000, 30_000][round - delays_ms.len()]);
            let mut seen: Option<Instant> = None;
            kill_when(child, || {
                if seen.is_none() && !temps(&dir, "big.glb").is_empty() {
                    seen = Some(Instant::now());
                }
                seen.is_some_and(|s| s.elapsed() >= extra)
            })
        };
        if was_killed {
            killed.push(pid);
        }
        match std::fs::read(&out) {
            Err(_) => {
                assert!(!had, "round {round}: the previous output vanished");
                before += 1;
            }
            Ok(bytes) => {
                if let Err(e) = check_glb(&bytes) {
                    panic!("round {round}: {} holds a broken file ({} bytes): {e}", out.display(), bytes.len());
                }
                if old.as_deref() == Some(&bytes[..]) {
                    if was_killed {
                        mid_write += usize::from(round >= delays_ms.len());
                    }
                } else {
                    replaced += 1;
                }
            }
        }
        check_leftovers(&dir, "big.glb", &killed);
    }
    assert!(!killed.is_empty(), "no run was killed: the test did not test anything");
    assert!(
        mid_write + before > 0 && replaced > 0,
        "kills should hit both before and after the rename (before {before}, mid-write {mid_write}, replaced {replaced})"
    );
    // A clean run afterwards writes a valid file despite any leftovers.
    let status = Command::new(bin).args([&src, Path::new("-o"), &out]).stderr(Stdio::null()).status().expect("run");
    assert!(status.success());
    check_glb(&std::fs::read(&out).expect("output")).expect("valid after a clean run");
    let _ = std::fs::remove_dir_all(&dir);
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

/// An output that cannot be written is an IO error (exit 2), whatever the format,
/// and says which path; a model the format cannot hold is an error in the input
/// (exit 1, docs/limits.md), covered by the exporter's own tests.
#[test]
fn an_unwritable_output_path_is_an_io_error() {
    let dir = scratch("unwritable");
    let src = dir.join("one.mdg");
    std::fs::write(&src, "startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n").expect("grammar");
    // A plain file where a folder is needed.
    let blocker = dir.join("file");
    std::fs::write(&blocker, "x").expect("file");
    for ext in ["glb", "obj", "stl", "ply", "json"] {
        let out = blocker.join(format!("m.{ext}"));
        let run =
            Command::new(env!("CARGO_BIN_EXE_mdg-run")).args([&src, Path::new("-o"), &out]).output().expect("run");
        let err = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{ext}: {err}");
        assert!(err.contains(&format!("cannot write {}:", out.display())), "{ext}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
