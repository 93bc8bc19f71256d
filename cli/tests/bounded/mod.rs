//! Running a command line as a hostile-input test does: in its own process, under a
//! virtual-memory bound (`ulimit -v`, so a dense allocation past it fails instead of
//! exhausting the machine) and a time limit, with its peak resident memory sampled
//! from `/proc` while it runs.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// What one bounded run did.
pub struct Run {
    pub output: Output,
    pub took: Duration,
    /// The child's peak resident memory (`VmHWM`, KiB), as last sampled before it
    /// exited (every 2 ms; 0 where `/proc` cannot tell).
    pub peak_kib: u64,
    /// Whether it was killed at the time limit.
    pub timed_out: bool,
}

fn peak_of(pid: u32) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// Runs `bin ARGS` in `dir` with `env` added, at most `vmem_kib` KiB of virtual
/// memory and `limit` of wall time (then it is killed).
pub fn run(dir: &Path, bin: &str, args: &[&str], env: &[(&str, &str)], vmem_kib: u64, limit: Duration) -> Run {
    let t0 = Instant::now();
    let mut child = Command::new("sh")
        .envs(env.iter().copied())
        .arg("-c")
        // `exec`: the child's process is the binary itself, so its memory is sampled.
        .arg(format!("ulimit -v {vmem_kib}; exec \"$0\" \"$@\""))
        .arg(bin)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut v);
            }
            v
        })
    };
    let out = drain(child.stdout.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let err = drain(child.stderr.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let (mut peak_kib, mut timed_out) = (0, false);
    let status = loop {
        if let Some(st) = child.try_wait().expect("wait") {
            break st;
        }
        if let Some(k) = peak_of(child.id()) {
            peak_kib = peak_kib.max(k);
        }
        if t0.elapsed() > limit && !timed_out {
            timed_out = true;
            let _ = child.kill();
        }
        std::thread::sleep(Duration::from_millis(2));
    };
    let output = Output { status, stdout: out.join().unwrap_or_default(), stderr: err.join().unwrap_or_default() };
    Run { output, took: t0.elapsed(), peak_kib, timed_out }
}
