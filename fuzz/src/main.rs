//! `mdg-fuzz`: runs one fuzz target for a time or a number of executions.
//!
//! ```text
//! mdg-fuzz TARGET [--time SECS] [--runs N] [--seed S] [--jobs J] [--corpus DIR] [--crashes DIR]
//!                 [--timeout SECS] [--slow-ms MS] [--rss-limit-mb MB] [--stack-kb KB]
//! mdg-fuzz replay TARGET FILE…     # run saved inputs once each (exit 1 if one fails)
//! mdg-fuzz minimize TARGET FILE     # shrink a crashing input (same panic site) to FILE.min
//! mdg-fuzz gen [SEED [N]]           # print N programs of the `vm_run` generator
//! mdg-fuzz list                     # the targets
//! ```
//!
//! The command is a supervisor: it starts itself as a worker (under `ulimit -v`)
//! that runs the loop, and restarts it after a crash the worker cannot catch (stack
//! overflow, abort, out of memory, a hang past `--timeout`). The worker writes every
//! input to a small file before running it, so the supervisor can save the input
//! that killed it. Panics are caught per input in the worker. Crashing inputs go to
//! `fuzz/crashes/TARGET/` (one per distinct panic location), with a `.txt` beside
//! each saying what happened.
//!
//! `--jobs J` runs J such supervisors side by side, each with its own seed (job k,
//! from 0, has seed `S + k·1,000,000,007`) and a share of `--runs`, and sums their
//! totals (each job's lines are prefixed with `[k]`).

use mdg_fuzz::rng::hash;
use mdg_fuzz::{Rng, Target};
use std::collections::HashSet;
use std::io::{BufRead, BufReader, Write};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Exit status of a worker whose watchdog saw an input run past the timeout.
const EXIT_TIMEOUT: i32 = 70;

struct Args {
    target: Target,
    time: Option<f64>,
    runs: Option<u64>,
    seed: u64,
    corpus: PathBuf,
    crashes: PathBuf,
    timeout: u64,
    slow_ms: u64,
    rss_limit_mb: u64,
    stack_kb: usize,
    jobs: u64,
    worker: bool,
}

fn usage() -> ExitCode {
    eprintln!(
        "usage: mdg-fuzz TARGET [--time SECS] [--runs N] [--seed S] [--jobs J] [--corpus DIR] [--crashes DIR] [--timeout SECS] \
         [--slow-ms MS] [--rss-limit-mb MB] [--stack-kb KB]\n       mdg-fuzz replay TARGET FILE...\n       \
         mdg-fuzz minimize TARGET FILE\n       mdg-fuzz list\ntargets: {}",
        Target::ALL.map(|t| t.name()).join(", ")
    );
    ExitCode::from(2)
}

fn fuzz_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn parse_args(argv: &[String]) -> Result<Args, String> {
    let mut it = argv.iter();
    let name = it.next().ok_or("no target")?;
    let target = Target::from_name(name).ok_or_else(|| format!("unknown target `{name}`"))?;
    let mut a = Args {
        target,
        time: None,
        runs: None,
        seed: 1,
        corpus: fuzz_dir().join("corpus").join(target.name()),
        crashes: fuzz_dir().join("crashes").join(target.name()),
        timeout: 20,
        slow_ms: 2_000,
        rss_limit_mb: 4_096,
        stack_kb: 2_048,
        jobs: 1,
        worker: false,
    };
    while let Some(flag) = it.next() {
        if flag == "--worker" {
            a.worker = true;
            continue;
        }
        let v = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = |v: &str| v.parse::<u64>().map_err(|_| format!("{flag}: `{v}` is not a whole number"));
        match flag.as_str() {
            "--time" => a.time = Some(v.parse::<f64>().map_err(|_| format!("--time: `{v}` is not a number"))?),
            "--runs" => a.runs = Some(num(v)?),
            "--seed" => a.seed = num(v)?,
            "--corpus" => a.corpus = PathBuf::from(v),
            "--crashes" => a.crashes = PathBuf::from(v),
            "--timeout" => a.timeout = num(v)?.max(1),
            "--slow-ms" => a.slow_ms = num(v)?,
            "--rss-limit-mb" => a.rss_limit_mb = num(v)?,
            "--stack-kb" => a.stack_kb = num(v)?.max(64) as usize,
            "--jobs" => {
                a.jobs = num(v)?;
                if !(1..=1024).contains(&a.jobs) {
                    return Err(format!("--jobs: `{v}` is not between 1 and 1024"));
                }
            }
            _ => return Err(format!("unknown option `{flag}`")),
        }
    }
    if a.time.is_none() && a.runs.is_none() {
        a.time = Some(60.0);
    }
    Ok(a)
}

fn main() -> ExitCode {
    let argv: Vec<String> = std::env::args().skip(1).collect();
    match argv.first().map(String::as_str) {
        None | Some("-h") | Some("--help") => usage(),
        Some("list") => {
            for t in Target::ALL {
                println!("{}", t.name());
            }
            ExitCode::SUCCESS
        }
        Some("replay") => replay(&argv[1..]),
        Some("minimize") => minimize(&argv[1..]),
        Some("voxel-seeds") => voxel_seeds(argv.get(1).map(PathBuf::from)),
        Some("gen") => {
            // Prints generated programs (the `vm_run` generator), for inspection.
            let seed = argv.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
            let mut rng = Rng::new(seed);
            for _ in 0..argv.get(2).and_then(|s| s.parse().ok()).unwrap_or(1) {
                println!("{}", mdg_fuzz::gen::program(&mut rng));
            }
            ExitCode::SUCCESS
        }
        _ => match parse_args(&argv) {
            Ok(a) if a.worker => worker(&a),
            Ok(a) if a.jobs > 1 => jobs(&a, &argv),
            Ok(a) => supervise(&a, &argv),
            Err(e) => {
                eprintln!("mdg-fuzz: {e}");
                usage()
            }
        },
    }
}

/// The panic message of the last panic on this thread (set by the quiet hook).
static LAST_PANIC: Mutex<String> = Mutex::new(String::new());

fn install_quiet_hook() {
    std::panic::set_hook(Box::new(|info| {
        let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
        let msg = if let Some(s) = info.payload().downcast_ref::<&str>() {
            (*s).to_string()
        } else if let Some(s) = info.payload().downcast_ref::<String>() {
            s.clone()
        } else {
            "a panic with no message".to_string()
        };
        // `MDG_FUZZ_BACKTRACE=1` (for `replay`): where a panic inside `core` came from.
        let bt = if std::env::var_os("MDG_FUZZ_BACKTRACE").is_some() {
            format!("\n{}", std::backtrace::Backtrace::force_capture())
        } else {
            String::new()
        };
        if let Ok(mut last) = LAST_PANIC.lock() {
            *last = format!("{at}\n{msg}{bt}");
        }
    }));
}

/// Runs one input, catching a panic: `Err(location and message)`.
fn run_one(target: Target, input: &[u8]) -> Result<u64, String> {
    std::panic::catch_unwind(|| target.run(input))
        .map_err(|_| LAST_PANIC.lock().map(|s| s.clone()).unwrap_or_else(|_| "panic".to_string()))
}

fn replay(argv: &[String]) -> ExitCode {
    let Some(target) = argv.first().and_then(|n| Target::from_name(n)) else { return usage() };
    install_quiet_hook();
    let mut failed = 0;
    for f in &argv[1..] {
        let path = Path::new(f);
        let bytes = match std::fs::read(path) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("{f}: {e}");
                failed += 1;
                continue;
            }
        };
        let Some(input) = target.seed(path, bytes) else {
            println!("{f}: not an input for {} (skipped)", target.name());
            continue;
        };
        let t0 = Instant::now();
        match run_one(target, &input) {
            Ok(_) => println!("{f}: ok in {:.1} ms", t0.elapsed().as_secs_f64() * 1e3),
            Err(e) => {
                println!("{f}: PANIC at {e}");
                failed += 1;
            }
        }
    }
    if failed > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// Writes every `.txt` voxel model in DIR (default: the voxel_readers corpus) in the
/// other formats too (`.vox`, `.nbt`, `.schem`, and the NBT ones uncompressed as
/// `.raw.nbt`, `.raw.schem`), as seeds for `voxel_readers`.
fn voxel_seeds(dir: Option<PathBuf>) -> ExitCode {
    use mdg_grid::format::{self, VoxelFormat};
    let dir = dir.unwrap_or_else(|| fuzz_dir().join("corpus/voxel_readers"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == "txt")).collect()
        })
        .unwrap_or_default();
    files.sort();
    for f in files {
        let model = match format::read(&f) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("mdg-fuzz: {e}");
                return ExitCode::FAILURE;
            }
        };
        for fmt in [VoxelFormat::Vox, VoxelFormat::Nbt, VoxelFormat::Schem] {
            let Ok(bytes) = format::write(fmt, &model) else { continue };
            let _ = std::fs::write(f.with_extension(fmt.extension()), &bytes);
            if fmt != VoxelFormat::Vox {
                let mut raw = Vec::new();
                if std::io::Read::read_to_end(&mut flate2::read::GzDecoder::new(&bytes[..]), &mut raw).is_ok() {
                    let _ = std::fs::write(f.with_extension(format!("raw.{}", fmt.extension())), raw);
                }
            }
        }
    }
    ExitCode::SUCCESS
}

/// The panic site (`file:line`) of an input, if it panics.
fn site(target: Target, input: &[u8]) -> Option<String> {
    run_one(target, input).err().map(|m| m.lines().next().unwrap_or("").to_string())
}

/// Removes chunks of `units` (lines, words or bytes of `input`) while the panic site
/// stays the same; returns the smallest input found.
fn shrink(target: Target, input: Vec<u8>, want: &str, split: fn(&[u8]) -> Vec<Vec<u8>>) -> Vec<u8> {
    let mut units = split(&input);
    let mut chunk = (units.len() / 2).max(1);
    loop {
        let mut i = 0;
        while i < units.len() {
            let mut trial = units.clone();
            trial.drain(i..(i + chunk).min(units.len()));
            let bytes: Vec<u8> = trial.concat();
            if site(target, &bytes).as_deref() == Some(want) {
                units = trial;
            } else {
                i += chunk;
            }
        }
        if chunk == 1 {
            break;
        }
        chunk /= 2;
    }
    units.concat()
}

fn split_lines(b: &[u8]) -> Vec<Vec<u8>> {
    b.split_inclusive(|c| *c == b'\n').map(<[u8]>::to_vec).collect()
}

fn split_words(b: &[u8]) -> Vec<Vec<u8>> {
    let mut out: Vec<Vec<u8>> = Vec::new();
    for &c in b {
        match out.last_mut() {
            Some(w) if !c.is_ascii_whitespace() && w.last().is_some_and(|l| !l.is_ascii_whitespace()) => w.push(c),
            _ => out.push(vec![c]),
        }
    }
    out
}

fn split_bytes(b: &[u8]) -> Vec<Vec<u8>> {
    b.iter().map(|c| vec![*c]).collect()
}

fn minimize(argv: &[String]) -> ExitCode {
    let (Some(target), Some(file)) = (argv.first().and_then(|n| Target::from_name(n)), argv.get(1)) else {
        return usage();
    };
    install_quiet_hook();
    let path = Path::new(file);
    let Some(input) = std::fs::read(path).ok().and_then(|b| target.seed(path, b)) else {
        eprintln!("mdg-fuzz: cannot read {file} as an input for {}", target.name());
        return ExitCode::FAILURE;
    };
    let Some(want) = site(target, &input) else {
        eprintln!("mdg-fuzz: {file} does not panic");
        return ExitCode::FAILURE;
    };
    let mut best = input;
    best = shrink(target, best, &want, split_lines);
    best = shrink(target, best, &want, split_words);
    if best.len() <= 4096 {
        best = shrink(target, best, &want, split_bytes);
    }
    let out = path.with_extension(format!("min.{}", target.extension()));
    if let Err(e) = std::fs::write(&out, &best) {
        eprintln!("mdg-fuzz: cannot write {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    println!("{} bytes, panics at {want}; written to {}", best.len(), out.display());
    ExitCode::SUCCESS
}

/// Totals across worker restarts.
#[derive(Clone, Copy, Default)]
struct Totals {
    execs: u64,
    deep: u64,
    crashes: u64,
    slow: u64,
}

impl Totals {
    /// The closing `TOTAL` line of a run of `secs` seconds.
    fn line(&self, a: &Args, secs: f64, restarts: u64) -> String {
        format!(
            "TOTAL {}: {} executions in {:.0} s ({:.0}/s), {} past the first stage, {} crashes, {} slow inputs (> {} ms), {} worker restarts",
            a.target.name(),
            self.execs,
            secs,
            self.execs as f64 / secs.max(1e-9),
            self.deep,
            self.crashes,
            self.slow,
            a.slow_ms,
            restarts
        )
    }
}

fn supervise(a: &Args, argv: &[String]) -> ExitCode {
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("mdg-fuzz: cannot find my own executable: {e}");
            return ExitCode::FAILURE;
        }
    };
    if let Err(e) = std::fs::create_dir_all(&a.crashes) {
        eprintln!("mdg-fuzz: cannot create {}: {e}", a.crashes.display());
        return ExitCode::FAILURE;
    }
    let current = std::env::temp_dir().join(format!("mdg-fuzz-{}-{}.current", a.target.name(), std::process::id()));
    let started = Instant::now();
    let mut totals = Totals::default();
    let mut restarts = 0u64;
    println!(
        "mdg-fuzz {}: seed {}, corpus {}, crashes to {}",
        a.target.name(),
        a.seed,
        a.corpus.display(),
        a.crashes.display()
    );
    loop {
        let left_time = a.time.map(|t| t - started.elapsed().as_secs_f64());
        let left_runs = a.runs.map(|r| r.saturating_sub(totals.execs));
        if left_time.is_some_and(|t| t <= 0.5) || left_runs == Some(0) {
            break;
        }
        // The worker: same options, a fresh seed after each restart, under a memory limit.
        let mut args: Vec<String> = vec![a.target.name().to_string(), "--worker".into()];
        let mut skip = false;
        for (i, v) in argv.iter().enumerate().skip(1) {
            if skip {
                skip = false;
                continue;
            }
            if ["--time", "--runs", "--seed"].contains(&v.as_str()) {
                skip = true;
                continue;
            }
            if i > 0 {
                args.push(v.clone());
            }
        }
        if let Some(t) = left_time {
            args.extend(["--time".into(), format!("{t:.1}")]);
        }
        if let Some(r) = left_runs {
            args.extend(["--runs".into(), r.to_string()]);
        }
        args.extend(["--seed".into(), (a.seed.wrapping_add(restarts.wrapping_mul(1_000_003))).to_string()]);
        let script = format!("ulimit -v {} 2>/dev/null; exec \"$0\" \"$@\"", a.rss_limit_mb * 1024);
        let child = Command::new("sh")
            .arg("-c")
            .arg(script)
            .arg(&exe)
            .args(&args)
            .env("MDG_FUZZ_CURRENT", &current)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn();
        let mut child = match child {
            Ok(c) => c,
            Err(e) => {
                eprintln!("mdg-fuzz: cannot start the worker: {e}");
                return ExitCode::FAILURE;
            }
        };
        // The worker's stderr (what the VM's `DEBUG` prints, a fatal runtime error's
        // message): only the last few KB are kept, for the crash report.
        let tail = Arc::new(Mutex::new(Vec::<u8>::new()));
        let reader = child.stderr.take().map(|mut err| {
            let tail = tail.clone();
            std::thread::spawn(move || {
                let mut buf = [0u8; 8192];
                while let Ok(n) = std::io::Read::read(&mut err, &mut buf) {
                    if n == 0 {
                        break;
                    }
                    if let Ok(mut t) = tail.lock() {
                        t.extend_from_slice(&buf[..n]);
                        let excess = t.len().saturating_sub(4096);
                        t.drain(..excess);
                    }
                }
            })
        });
        let mut last = Totals::default();
        if let Some(out) = child.stdout.take() {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                println!("{line}");
                if let Some(rest) = line.split("stats:").nth(1) {
                    for kv in rest.split_whitespace() {
                        if let Some((k, v)) = kv.split_once('=') {
                            let v: u64 = v.parse().unwrap_or(0);
                            match k {
                                "execs" => last.execs = v,
                                "deep" => last.deep = v,
                                "crashes" => last.crashes = v,
                                "slow" => last.slow = v,
                                _ => {}
                            }
                        }
                    }
                }
            }
        }
        let status = child.wait();
        if let Some(r) = reader {
            let _ = r.join();
        }
        totals.execs += last.execs;
        totals.deep += last.deep;
        totals.crashes += last.crashes;
        totals.slow += last.slow;
        match status {
            Ok(s) if s.success() => break,
            Ok(s) => {
                // The worker died: the input it was running is the culprit.
                let kind = if s.code() == Some(EXIT_TIMEOUT) { "timeout" } else { "crash" };
                let input = read_current(&current).unwrap_or_default();
                let name = format!("{kind}-{:016x}.{}", hash(&input), a.target.extension());
                let path = a.crashes.join(&name);
                let _ = std::fs::write(&path, &input);
                let tail = tail.lock().map(|t| String::from_utf8_lossy(&t).into_owned()).unwrap_or_default();
                let _ = std::fs::write(
                    path.with_extension("txt"),
                    format!(
                        "{kind}: the worker ended with {s} (stack overflow, abort, out of memory or a hang)\n{tail}"
                    ),
                );
                println!("mdg-fuzz: worker ended with {s}; saved its input as {}", path.display());
                totals.crashes += 1;
                totals.execs += 1;
                restarts += 1;
            }
            Err(e) => {
                eprintln!("mdg-fuzz: lost the worker: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let _ = std::fs::remove_file(&current);
    let secs = started.elapsed().as_secs_f64();
    println!("{}", totals.line(a, secs, restarts));
    // For `--jobs`: the same numbers, to add up.
    println!(
        "totals: execs={} deep={} crashes={} slow={} restarts={restarts}",
        totals.execs, totals.deep, totals.crashes, totals.slow
    );
    if totals.crashes > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// The seed of job `k` of a `--jobs` run started with `--seed seed` (a prime stride:
/// the supervisors' restart seeds step by 1,000,003, so the streams stay distinct).
fn job_seed(seed: u64, k: u64) -> u64 {
    seed.wrapping_add(k.wrapping_mul(1_000_000_007))
}

/// `--jobs J`: runs J supervisors (this command without `--jobs`, each with its
/// seed and share of `--runs`) at once, prints their lines prefixed with `[k]`, and
/// the sum of their totals. Fails if one failed or crashed.
fn jobs(a: &Args, argv: &[String]) -> ExitCode {
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("mdg-fuzz: cannot find my own executable: {e}");
            return ExitCode::FAILURE;
        }
    };
    // The options less those each job gets its own value of.
    let mut common: Vec<String> = Vec::new();
    let mut it = argv.iter().skip(1);
    while let Some(v) = it.next() {
        if ["--runs", "--seed", "--jobs"].contains(&v.as_str()) {
            it.next();
        } else {
            common.push(v.clone());
        }
    }
    let started = Instant::now();
    println!("mdg-fuzz {}: {} jobs, seeds {} + k·1000000007", a.target.name(), a.jobs, a.seed);
    let mut children = Vec::new();
    for k in 0..a.jobs {
        let mut args = vec![a.target.name().to_string()];
        args.extend(common.iter().cloned());
        args.extend(["--seed".into(), job_seed(a.seed, k).to_string()]);
        if let Some(r) = a.runs {
            let share = r / a.jobs + u64::from(k < r % a.jobs);
            if share == 0 {
                continue;
            }
            args.extend(["--runs".into(), share.to_string()]);
        }
        match Command::new(&exe).args(&args).stdout(Stdio::piped()).stderr(Stdio::inherit()).spawn() {
            Ok(c) => children.push((k, c)),
            Err(e) => {
                eprintln!("mdg-fuzz: cannot start job {k}: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let totals = Arc::new(Mutex::new((Totals::default(), 0u64)));
    let mut readers = Vec::new();
    for (k, child) in &mut children {
        let Some(out) = child.stdout.take() else { continue };
        let (k, totals) = (*k, totals.clone());
        readers.push(std::thread::spawn(move || {
            for line in BufReader::new(out).lines().map_while(Result::ok) {
                println!("[{k}] {line}");
                if let Some(rest) = line.strip_prefix("totals:") {
                    let Ok(mut t) = totals.lock() else { continue };
                    for kv in rest.split_whitespace() {
                        let Some((key, v)) = kv.split_once('=') else { continue };
                        let v: u64 = v.parse().unwrap_or(0);
                        match key {
                            "execs" => t.0.execs += v,
                            "deep" => t.0.deep += v,
                            "crashes" => t.0.crashes += v,
                            "slow" => t.0.slow += v,
                            "restarts" => t.1 += v,
                            _ => {}
                        }
                    }
                }
            }
        }));
    }
    let mut failed = false;
    for (k, mut child) in children {
        match child.wait() {
            Ok(s) if s.success() => {}
            Ok(s) => {
                println!("mdg-fuzz: job {k} ended with {s}");
                failed = true;
            }
            Err(e) => {
                eprintln!("mdg-fuzz: lost job {k}: {e}");
                failed = true;
            }
        }
    }
    for r in readers {
        let _ = r.join();
    }
    let secs = started.elapsed().as_secs_f64();
    let (t, restarts) = totals.lock().map(|t| *t).unwrap_or_default();
    println!("{}, {} jobs", t.line(a, secs, restarts), a.jobs);
    if failed || t.crashes > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// The input a worker was running: `[len: u64 LE][bytes]`.
fn read_current(path: &Path) -> Option<Vec<u8>> {
    let b = std::fs::read(path).ok()?;
    let len = u64::from_le_bytes(b.get(..8)?.try_into().ok()?) as usize;
    b.get(8..8 + len).map(<[u8]>::to_vec)
}

/// Corpus inputs (files directly in `dir`, sorted), turned into inputs by the target.
fn load_corpus(target: Target, dir: &Path) -> Vec<Vec<u8>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| rd.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.is_file()).collect())
        .unwrap_or_default();
    files.sort();
    files.into_iter().filter_map(|p| std::fs::read(&p).ok().and_then(|b| target.seed(&p, b))).collect()
}

fn worker(a: &Args) -> ExitCode {
    install_quiet_hook();
    let current_path = std::env::var_os("MDG_FUZZ_CURRENT").map(PathBuf::from);
    let current = current_path.as_ref().and_then(|p| std::fs::File::create(p).ok());
    let started = Instant::now();
    let input_started = Arc::new(AtomicU64::new(u64::MAX));
    {
        // Watchdog: an input running past the timeout ends the worker (the supervisor
        // saves it as a timeout).
        let input_started = input_started.clone();
        let timeout = a.timeout;
        std::thread::spawn(move || loop {
            std::thread::sleep(Duration::from_millis(250));
            let s = input_started.load(Ordering::Relaxed);
            if s != u64::MAX && started.elapsed().as_millis() as u64 > s + timeout * 1000 {
                println!("mdg-fuzz: an input ran longer than {timeout} s");
                let _ = std::io::stdout().flush();
                std::process::exit(EXIT_TIMEOUT);
            }
        });
    }
    let a2 = Args { corpus: a.corpus.clone(), crashes: a.crashes.clone(), ..*a };
    // The loop runs on a thread with the stack size of the language server's worker
    // threads (2 MiB by default), the smallest the compiler runs on.
    let handle = std::thread::Builder::new()
        .stack_size(a.stack_kb * 1024)
        .spawn(move || fuzz_loop(&a2, current, started, &input_started));
    match handle.map(|h| h.join()) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        _ => ExitCode::FAILURE,
    }
}

fn fuzz_loop(a: &Args, current: Option<std::fs::File>, started: Instant, input_started: &AtomicU64) {
    let target = a.target;
    let seeds = load_corpus(target, &a.corpus);
    let mut pool: Vec<Vec<u8>> = seeds.clone();
    if pool.is_empty() {
        pool.push(b"startshape A\nrule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n".to_vec());
    }
    let n_seeds = pool.len();
    let dict = target.dictionary();
    let mut rng = Rng::new(a.seed);
    let mut seen: HashSet<u64> = HashSet::new();
    let mut crash_sites: HashSet<String> = HashSet::new();
    let (mut execs, mut crashes, mut slow) = (0u64, 0u64, 0u64);
    let mut last_report = Instant::now();
    let mut last_execs = 0u64;
    let deadline = a.time.map(|t| started + Duration::from_secs_f64(t.max(0.0)));
    let _ = std::fs::create_dir_all(&a.crashes);
    loop {
        if a.runs.is_some_and(|r| execs >= r) || deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        // The seeds first, once each, then mutations.
        let input = if (execs as usize) < seeds.len() {
            seeds[execs as usize].clone()
        } else {
            target.next_input(&mut rng, &pool, n_seeds, &dict)
        };
        if let Some(f) = &current {
            let mut rec = (input.len() as u64).to_le_bytes().to_vec();
            rec.extend_from_slice(&input);
            let _ = f.write_at(&rec, 0);
        }
        let t0 = Instant::now();
        input_started.store(started.elapsed().as_millis() as u64, Ordering::Relaxed);
        let result = run_one(target, &input);
        input_started.store(u64::MAX, Ordering::Relaxed);
        let took = t0.elapsed();
        execs += 1;
        match result {
            Ok(sig) => {
                if seen.insert(sig) {
                    if pool.len() < 4_000 {
                        pool.push(input.clone());
                    } else {
                        let i = n_seeds + rng.below(pool.len() - n_seeds);
                        pool[i] = input.clone();
                    }
                }
            }
            Err(msg) => {
                crashes += 1;
                let site = msg.lines().next().unwrap_or("").to_string();
                if crash_sites.insert(site.clone()) {
                    let name = format!("crash-{:016x}.{}", hash(&input), target.extension());
                    let path = a.crashes.join(name);
                    let _ = std::fs::write(&path, &input);
                    let _ = std::fs::write(path.with_extension("txt"), format!("panic at {msg}\n"));
                    println!("mdg-fuzz: CRASH at {site}; input saved as {}", path.display());
                }
            }
        }
        if took.as_millis() as u64 > a.slow_ms {
            slow += 1;
            if slow <= 10 {
                let name = format!("slow-{:016x}.{}", hash(&input), target.extension());
                let path = a.crashes.join(name);
                let _ = std::fs::write(&path, &input);
                let _ = std::fs::write(path.with_extension("txt"), format!("slow: {} ms\n", took.as_millis()));
                println!("mdg-fuzz: slow input ({} ms) saved as {}", took.as_millis(), path.display());
            }
        }
        if last_report.elapsed() >= Duration::from_secs(10) {
            let rate = (execs - last_execs) as f64 / last_report.elapsed().as_secs_f64();
            println!(
                "#{execs} {rate:.0}/s pool {} signatures {} stats: execs={execs} deep={} crashes={crashes} slow={slow}",
                pool.len(),
                seen.len(),
                mdg_fuzz::targets::DEEP.load(Ordering::Relaxed)
            );
            let _ = std::io::stdout().flush();
            last_report = Instant::now();
            last_execs = execs;
        }
    }
    let secs = started.elapsed().as_secs_f64();
    println!(
        "done {}: {execs} execs in {secs:.1} s ({:.0}/s), pool {}, signatures {} stats: execs={execs} deep={} crashes={crashes} slow={slow}",
        target.name(),
        execs as f64 / secs.max(1e-9),
        pool.len(),
        seen.len(),
        mdg_fuzz::targets::DEEP.load(Ordering::Relaxed)
    );
}
