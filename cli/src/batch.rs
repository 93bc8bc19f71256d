//! Batch runs: many seeds of one grammar, split across machines by the scheduler
//! the user already has (GNU parallel, Slurm job arrays, Kubernetes Indexed Jobs;
//! recipes in docs/batch.md).
//!
//! `--seeds A..B` (or `A..=B`) runs each seed in the range in order; `-o` is a
//! template holding `{seed}`. `--shard K/N` keeps the seeds whose position in the
//! range is K modulo N, so N shards together make exactly the unsharded run. Each
//! output is written atomically, so a file that exists is complete: a run that was
//! killed resumes by skipping the seeds whose output and manifest line are both
//! there. The manifest is one JSON line per output (`mdg_manifest`, `seed`, `file`,
//! `vertices`, `triangles`, `bytes`, `sha256`), `manifest.jsonl` (or
//! `manifest-K-of-N.jsonl` for a shard) in the template's fixed directory.
//!
//! The manifest never destroys data ([`Manifest::open`]): a file at its path that
//! is not a manifest of ours (another tool's `manifest.jsonl`, a damaged line) is
//! refused and left byte for byte; only a last line torn by a kill (no newline) is
//! dropped, with a warning. Devices, pipes and directories are refused without
//! reading them, and reading is bounded. A lock file beside the manifest
//! (`….jsonl.lock`, holding the pid and host of the run) stops a second run of the
//! same shard at once.
//!
//! Seeds run side by side (`-j N`, [`run_in_order`]): workers take the next seed in
//! order, and results are recorded in seed order (by the main thread, which also
//! flushes each seed's files to disk before its line: the workers never wait for
//! the disk), so outputs and manifest are byte
//! for byte those of one worker, and a run killed part-way leaves a manifest that
//! is a prefix of the whole one (plus, at most, outputs of the seeds then running,
//! which a resumed run redoes).

use sha2::{Digest, Sha256};
use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufRead as _, Read as _, Write as _};
use std::path::{Path, PathBuf};

/// A range of seeds, `start..end` (end excluded).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Seeds {
    pub start: u64,
    pub end: u64,
}

/// The most seeds one batch run takes.
pub const MAX_SEEDS: u64 = 100_000_000;

impl std::str::FromStr for Seeds {
    type Err = String;
    /// `A..B` (B excluded) or `A..=B` (B included).
    fn from_str(s: &str) -> Result<Seeds, String> {
        let bad = || format!("--seeds {s}: expected A..B (B excluded) or A..=B, whole numbers with A < B");
        let (a, b, inclusive) = match s.split_once("..=") {
            Some((a, b)) => (a, b, true),
            None => {
                let (a, b) = s.split_once("..").ok_or_else(bad)?;
                (a, b, false)
            }
        };
        let start: u64 = a.trim().parse().map_err(|_| bad())?;
        let last: u64 = b.trim().parse().map_err(|_| bad())?;
        let end = if inclusive { last.checked_add(1).ok_or_else(bad)? } else { last };
        if end <= start {
            return Err(bad());
        }
        if end - start > MAX_SEEDS {
            return Err(format!("--seeds {s}: at most {MAX_SEEDS} seeds in one run (split it with --shard)"));
        }
        Ok(Seeds { start, end })
    }
}

/// Shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u64,
    pub count: u64,
}

impl Default for Shard {
    fn default() -> Shard {
        Shard { index: 0, count: 1 }
    }
}

impl std::str::FromStr for Shard {
    type Err = String;
    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad =
            || format!("--shard {s}: expected K/N with 0 ≤ K < N (K counts from 0, as JOB_COMPLETION_INDEX does)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u64 = k.trim().parse().map_err(|_| bad())?;
        let count: u64 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count || count > 1_000_000 {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// The seeds this shard runs, in order.
pub fn shard_seeds(seeds: Seeds, shard: Shard) -> impl Iterator<Item = u64> {
    (seeds.start..seeds.end).filter(move |s| (s - seeds.start) % shard.count == shard.index)
}

/// `template` with `{seed}` replaced; an error when it holds no `{seed}` (every seed
/// would overwrite the last).
pub fn output_for(template: &Path, seed: u64) -> Result<PathBuf, String> {
    let t = template.to_string_lossy();
    if !t.contains("{seed}") {
        return Err(format!(
            "-o {t}: a batch run (--seeds) needs `{{seed}}` in the output path, e.g. -o 'out/{{seed}}.glb'"
        ));
    }
    Ok(PathBuf::from(t.replace("{seed}", &seed.to_string())))
}

/// Where the manifest goes: the template's directory up to its first component
/// holding `{seed}`.
pub fn manifest_path(template: &Path, shard: Shard) -> PathBuf {
    let mut dir = PathBuf::new();
    let parent = template.parent().unwrap_or(Path::new(""));
    for c in parent.components() {
        if c.as_os_str().to_string_lossy().contains("{seed}") {
            break;
        }
        dir.push(c);
    }
    let name = if shard.count == 1 {
        "manifest.jsonl".to_string()
    } else {
        format!("manifest-{}-of-{}.jsonl", shard.index, shard.count)
    };
    dir.join(name)
}

/// The format marker of the manifest lines this version writes (`"mdg_manifest":2`).
/// Lines without it are format 1, written before the marker existed; both are read.
pub const FORMAT: u64 = 2;

/// The longest manifest line read: 64 KiB (a line of ours is about 200 bytes plus
/// the output's path). A longer line is not ours.
pub const MAX_LINE_BYTES: usize = 64 << 10;

/// The largest manifest read: 32 GiB, about 160 million lines of ours (a run
/// takes at most [`MAX_SEEDS`] seeds). Only the size the file has when it is opened
/// is read; a file that grows meanwhile is not chased.
pub const MAX_MANIFEST_BYTES: u64 = 32 << 30;

/// One manifest line.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    pub seed: u64,
    pub file: PathBuf,
    /// Vertices and triangles of a mesh output; `None` for voxel outputs.
    pub counts: Option<(u64, u64)>,
}

impl Entry {
    /// The JSON line for this entry (without the newline), hashing the file as
    /// written: `{"mdg_manifest":2,"seed":…,"file":…,"vertices":…,"triangles":…,
    /// "bytes":…,"sha256":"…"}`.
    pub fn line(&self) -> Result<String, String> {
        self.line_reading(&self.file)
    }

    /// [`Entry::line`] with the bytes read from `written` (the file still under its
    /// temporary name, before it is flushed and renamed: the same bytes).
    pub fn line_reading(&self, written: &Path) -> Result<String, String> {
        let bytes = std::fs::read(written).map_err(|e| format!("cannot read {}: {e}", self.file.display()))?;
        let hash = Sha256::digest(&bytes);
        let hex: String = hash.iter().map(|b| format!("{b:02x}")).collect();
        let (v, t) = match self.counts {
            Some((v, t)) => (v.to_string(), t.to_string()),
            None => ("null".to_string(), "null".to_string()),
        };
        let file = serde_json::Value::String(self.file.to_string_lossy().into_owned());
        Ok(format!(
            "{{\"mdg_manifest\":{FORMAT},\"seed\":{},\"file\":{file},\"vertices\":{v},\"triangles\":{t},\"bytes\":{},\"sha256\":\"{hex}\"}}",
            self.seed,
            bytes.len()
        ))
    }
}

/// How a line of ours starts, by format: a torn last line must start like one.
const OPENINGS: [&str; 2] = ["{\"mdg_manifest\":", "{\"bytes\":"];

/// The keys of a format-1 line (a format-2 line adds `mdg_manifest`).
const KEYS: [&str; 6] = ["bytes", "file", "seed", "sha256", "triangles", "vertices"];

/// The seed of a manifest line (without its newline), or why the line is not ours.
fn entry_seed(line: &[u8]) -> Result<u64, String> {
    let text = std::str::from_utf8(line).map_err(|_| "it is not UTF-8 text".to_string())?;
    let value: serde_json::Value = serde_json::from_str(text).map_err(|_| "it is not JSON".to_string())?;
    let obj = value.as_object().ok_or("it is not a JSON object")?;
    if let Some(f) = obj.get("mdg_manifest") {
        match f.as_u64() {
            Some(FORMAT) => {}
            Some(n) if n > FORMAT => {
                return Err(format!(
                    "it is format {n}, written by a newer mdg-run (this one reads formats 1 and {FORMAT})"
                ))
            }
            _ => return Err(format!("its `mdg_manifest` is {f}, not a format this mdg-run reads (1 or {FORMAT})")),
        }
    }
    let extra: Vec<&str> =
        obj.keys().map(String::as_str).filter(|k| *k != "mdg_manifest" && !KEYS.contains(k)).collect();
    let missing: Vec<&str> = KEYS.iter().copied().filter(|k| !obj.contains_key(*k)).collect();
    if !extra.is_empty() || !missing.is_empty() {
        let mut why = Vec::new();
        if !missing.is_empty() {
            why.push(format!("no {}", missing.join(", ")));
        }
        if !extra.is_empty() {
            why.push(format!("fields of another tool: {}", extra.join(", ")));
        }
        return Err(format!("its fields are not a manifest entry's ({})", why.join("; ")));
    }
    let counts_ok = match (&obj["vertices"], &obj["triangles"]) {
        (serde_json::Value::Null, serde_json::Value::Null) => true,
        (v, t) => v.is_u64() && t.is_u64(),
    };
    let hash_ok = obj["sha256"]
        .as_str()
        .is_some_and(|h| h.len() == 64 && h.bytes().all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)));
    if !(obj["file"].is_string() && obj["bytes"].is_u64() && counts_ok && hash_ok) {
        return Err("its values are not a manifest entry's (file, counts, bytes, sha256)".into());
    }
    obj["seed"].as_u64().ok_or_else(|| "its seed is not a whole number".to_string())
}

/// A short, printable excerpt of a line for messages.
fn excerpt(line: &[u8]) -> String {
    let text = String::from_utf8_lossy(line);
    let shown: String = text.chars().take(60).map(|c| if c.is_control() { '?' } else { c }).collect();
    if shown.len() < text.len() {
        format!("{shown}…")
    } else {
        shown
    }
}

/// Why a manifest could not be opened.
#[derive(Debug, PartialEq, Eq)]
pub enum OpenError {
    /// Another run holds this shard's lock; the message names it.
    Busy(String),
    /// Anything else: the file is not ours, not a regular file, unreadable.
    Refused(String),
}

impl std::fmt::Display for OpenError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OpenError::Busy(m) | OpenError::Refused(m) => f.write_str(m),
        }
    }
}

/// Opens `path` for reading and appending, creating it, without blocking (a pipe);
/// refuses anything that is not a regular file.
fn open_regular(path: &Path, follow: bool) -> Result<File, String> {
    if let Ok(m) = if follow { std::fs::metadata(path) } else { std::fs::symlink_metadata(path) } {
        if !m.is_file() {
            let what = if m.file_type().is_symlink() { "a symbolic link" } else { mdg_vm::input::kind(&m) };
            return Err(format!(
                "{}: not a regular file ({what}); remove it or choose another -o folder",
                path.display()
            ));
        }
    }
    let mut o = std::fs::OpenOptions::new();
    o.read(true).append(true).create(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK | if follow { 0 } else { libc::O_NOFOLLOW });
    }
    let f = o.open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    let m = f.metadata().map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if !m.is_file() {
        let what = mdg_vm::input::kind(&m);
        return Err(format!("{}: not a regular file ({what}); remove it or choose another -o folder", path.display()));
    }
    Ok(f)
}

/// This machine's name, for the lock file.
fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "(unknown)".into())
}

/// `secs` since the Unix epoch as `YYYY-MM-DD HH:MM:SS UTC`.
fn utc(secs: u64) -> String {
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Days to a civil date (H. Hinnant's algorithm), for dates after 1970.
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + u64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// The lock of one shard's run: an exclusive `flock` on `….jsonl.lock`, which holds
/// who took it. The system releases it when the process ends, however it ends; the
/// file is removed when the run ends normally.
struct Lock {
    path: PathBuf,
    _file: File,
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Removed while still locked (the file closes after this), so a run that
        // opened the old file finds it gone and tries again.
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(unix)]
fn same_file(a: &std::fs::Metadata, b: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(_: &std::fs::Metadata, _: &std::fs::Metadata) -> bool {
    true
}

impl Lock {
    /// Takes the lock at `path` for the run of `manifest`; `Busy` names the holder.
    /// A file system without locks gives a warning and no lock.
    fn acquire(path: &Path, manifest: &Path) -> Result<(Option<Lock>, Option<String>), OpenError> {
        for _ in 0..8 {
            let mut file = open_regular(path, false).map_err(OpenError::Refused)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut held = Vec::new();
                    let _ = (&file).take(512).read_to_end(&mut held);
                    let holder = String::from_utf8_lossy(&held).trim().to_string();
                    let holder = if holder.is_empty() {
                        "another process (it has not written its name yet)".to_string()
                    } else {
                        excerpt(holder.as_bytes())
                    };
                    return Err(OpenError::Busy(format!(
                        "{}: this shard is already being run, by {holder} (lock file {}); a second run would compute \
                         every seed twice. Wait for that run to end or stop it (the lock goes with its process)",
                        manifest.display(),
                        path.display()
                    )));
                }
                Err(std::fs::TryLockError::Error(e)) => {
                    let unsupported =
                        e.kind() == std::io::ErrorKind::Unsupported || e.raw_os_error() == Some(libc::ENOLCK);
                    if unsupported {
                        let w = format!(
                            "{}: cannot lock it ({e}; the file system has no locks), so a second run of this shard at \
                             the same time would not be stopped",
                            path.display()
                        );
                        return Ok((Some(Lock { path: path.to_path_buf(), _file: file }), Some(w)));
                    }
                    return Err(OpenError::Refused(format!("cannot lock {}: {e}", path.display())));
                }
            }
            // The lock is ours if the path still names the file locked: a run that
            // ended may have removed it between our open and our lock.
            let mine =
                file.metadata().map_err(|e| OpenError::Refused(format!("cannot read {}: {e}", path.display())))?;
            match std::fs::symlink_metadata(path) {
                Ok(m) if same_file(&m, &mine) => {}
                _ => continue,
            }
            let since = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs())
                .unwrap_or_default();
            let holder = format!("pid {} on host {}, since {}\n", std::process::id(), host_name(), utc(since));
            file.set_len(0)
                .and_then(|()| file.write_all(holder.as_bytes()))
                .map_err(|e| OpenError::Refused(format!("cannot write {}: {e}", path.display())))?;
            return Ok((Some(Lock { path: path.to_path_buf(), _file: file }), None));
        }
        Err(OpenError::Refused(format!(
            "{}: could not take the lock (other runs kept replacing the lock file); try again",
            path.display()
        )))
    }
}

/// The manifest of a run in progress: the seeds it records, appending, and the lock
/// on its shard.
pub struct Manifest {
    path: PathBuf,
    file: File,
    done: BTreeSet<u64>,
    _lock: Option<Lock>,
}

/// The lock file of the manifest at `path`: `path` with `.lock` added.
pub fn lock_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_os_string();
    p.push(".lock");
    PathBuf::from(p)
}

impl Manifest {
    /// Locks the shard, then opens (or starts) the manifest at `path`, keeping the
    /// recorded seeds for which `wanted` holds. Every complete line must be a
    /// manifest line of ours (format 1 or 2), or the file is refused untouched. A
    /// last line without its newline that starts like one of ours was cut short by
    /// a kill: it is cut off the file (in place) with a warning. Returns the
    /// warnings to print.
    pub fn open(path: &Path, wanted: impl Fn(u64) -> bool) -> Result<(Manifest, Vec<String>), OpenError> {
        let mut warnings = Vec::new();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .map_err(|e| OpenError::Refused(format!("cannot create {}: {e}", dir.display())))?;
        }
        let (lock, warning) = Lock::acquire(&lock_path(path), path)?;
        warnings.extend(warning);
        let file = open_regular(path, true).map_err(OpenError::Refused)?;
        let len =
            file.metadata().map_err(|e| OpenError::Refused(format!("cannot read {}: {e}", path.display())))?.len();
        if len > MAX_MANIFEST_BYTES {
            return Err(OpenError::Refused(format!(
                "{}: {len} bytes, more than a manifest is read ({MAX_MANIFEST_BYTES} bytes); move it away or choose \
                 another -o folder",
                path.display()
            )));
        }
        let not_ours = |n: u64, why: String| {
            OpenError::Refused(format!(
                "{} is not a manifest of mdg-run (line {n}: {why}); it was left as it is: move it away or choose \
                 another -o folder",
                path.display()
            ))
        };
        let mut reader = std::io::BufReader::new((&file).take(len));
        let (mut done, mut duplicates, mut good_len) = (BTreeSet::new(), 0u64, 0u64);
        let mut buf = Vec::new();
        let mut n = 0u64;
        loop {
            buf.clear();
            n += 1;
            let read = (&mut reader)
                .take(MAX_LINE_BYTES as u64 + 1)
                .read_until(b'\n', &mut buf)
                .map_err(|e| OpenError::Refused(format!("cannot read {}: {e}", path.display())))?;
            if read == 0 {
                break;
            }
            let Some(line) = buf.strip_suffix(b"\n") else {
                if buf.len() > MAX_LINE_BYTES {
                    return Err(not_ours(n, format!("longer than {MAX_LINE_BYTES} bytes")));
                }
                // The last line, without its newline: torn by a kill if it starts as
                // ours do.
                let torn = OPENINGS.iter().any(|o| buf.starts_with(o.as_bytes()) || o.as_bytes().starts_with(&buf));
                if !torn {
                    return Err(not_ours(n, format!("`{}` does not end with a newline", excerpt(&buf))));
                }
                break;
            };
            let seed = entry_seed(line).map_err(|why| not_ours(n, format!("`{}`: {why}", excerpt(line))))?;
            if wanted(seed) && !done.insert(seed) {
                duplicates += 1;
            }
            good_len += buf.len() as u64;
        }
        drop(reader);
        if good_len < len {
            file.set_len(good_len)
                .map_err(|e| OpenError::Refused(format!("cannot shorten {}: {e}", path.display())))?;
            warnings.push(format!(
                "{}: its last line was cut short (a run was stopped while writing it): dropped {} bytes; that seed runs again",
                path.display(),
                len - good_len
            ));
        }
        if duplicates > 0 {
            warnings.push(format!(
                "{}: {duplicates} seeds of this run have more than one line (a seed run again after its output \
                 was removed, or two runs of the shard at once before runs were locked); the last line is the \
                 current one",
                path.display()
            ));
        }
        Ok((Manifest { path: path.to_path_buf(), file, done, _lock: lock }, warnings))
    }

    /// Whether `seed` is finished: recorded here and its output on disk.
    pub fn is_done(&self, seed: u64, output: &Path) -> bool {
        self.done.contains(&seed) && output.is_file()
    }

    /// Appends the line of a finished output, made by [`Entry::line`] (in the worker
    /// that ran the seed: hashing the file is the batch's work, not the recorder's,
    /// so it runs on every core).
    pub fn record(&mut self, seed: u64, line: &str) -> Result<(), String> {
        self.file
            .write_all(format!("{line}\n").as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", self.path.display()))?;
        self.done.insert(seed);
        Ok(())
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Runs `run(seed, output)` for each of `todo` (in order) on `jobs` threads and hands
/// each result to `record` in `todo`'s order, as soon as it and every earlier one
/// are done (on this thread: a batch flushes its seeds' files to disk there, while
/// the workers compute); returns how many were recorded. After a failure no new
/// seed starts; the seeds before it are recorded and the first failure (in
/// `todo`'s order) is returned, as one worker would have.
pub fn run_in_order<R, E, F, G>(todo: &[(u64, PathBuf)], jobs: usize, run: F, mut record: G) -> Result<u64, E>
where
    R: Send,
    E: Send,
    F: Fn(u64, &Path) -> Result<R, E> + Sync,
    G: FnMut(u64, &Path, R) -> Result<(), E>,
{
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let jobs = jobs.clamp(1, todo.len().max(1));
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let (tx, rx) = std::sync::mpsc::channel::<(usize, Result<R, E>)>();
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            let tx = tx.clone();
            let (next, failed, run) = (&next, &failed, &run);
            scope.spawn(move || loop {
                if failed.load(Ordering::SeqCst) {
                    break;
                }
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some((seed, output)) = todo.get(i) else { break };
                let result = run(*seed, output);
                if result.is_err() {
                    failed.store(true, Ordering::SeqCst);
                }
                if tx.send((i, result)).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        // Record in order: results that arrive early wait for the earlier ones.
        let mut waiting = std::collections::BTreeMap::new();
        let mut recorded = 0usize;
        let mut outcome = Ok(());
        for (i, result) in rx {
            waiting.insert(i, result);
            while let Some(result) = waiting.remove(&recorded) {
                if outcome.is_err() {
                    break;
                }
                let (seed, output) = &todo[recorded];
                outcome = result.and_then(|r| record(*seed, output, r));
                if outcome.is_err() {
                    failed.store(true, Ordering::SeqCst);
                    break;
                }
                recorded += 1;
            }
        }
        outcome.map(|()| recorded as u64)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_and_shards_parse() {
        assert_eq!("3..7".parse::<Seeds>(), Ok(Seeds { start: 3, end: 7 }));
        assert_eq!("3..=7".parse::<Seeds>(), Ok(Seeds { start: 3, end: 8 }));
        for bad in ["7..3", "3..3", "a..b", "5", "-1..4", "0..200000000"] {
            assert!(bad.parse::<Seeds>().is_err(), "{bad}");
        }
        assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
        for bad in ["5/5", "1/0", "x/2", "3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn shards_partition_the_range() {
        let seeds = Seeds { start: 10, end: 33 };
        let mut all: Vec<u64> = (0..4).flat_map(|k| shard_seeds(seeds, Shard { index: k, count: 4 })).collect();
        all.sort();
        assert_eq!(all, (10..33).collect::<Vec<_>>());
    }

    #[test]
    fn lines_of_both_formats_are_ours_and_others_are_not() {
        let hash = "0123456789abcdef".repeat(4);
        let v1 = format!(r#"{{"bytes":10,"file":"out/3.glb","seed":3,"sha256":"{hash}","triangles":1,"vertices":3}}"#);
        let v2 = format!(
            r#"{{"mdg_manifest":2,"seed":4,"file":"out/4.vox","vertices":null,"triangles":null,"bytes":9,"sha256":"{hash}"}}"#
        );
        assert_eq!(entry_seed(v1.as_bytes()), Ok(3));
        assert_eq!(entry_seed(v2.as_bytes()), Ok(4));
        assert!(v2.starts_with(OPENINGS[0]) && v1.starts_with(OPENINGS[1]));
        let bad = [
            (v1.replace("\"seed\":3", "\"seed\":-3"), "seed"),
            (v1.replace(&hash, "abc"), "values"),
            (v1.replace("\"triangles\":1", "\"triangles\":null"), "values"),
            (v2.replace("\"mdg_manifest\":2", "\"mdg_manifest\":3"), "newer mdg-run"),
            (v2.replace("\"mdg_manifest\":2", "\"mdg_manifest\":\"x\""), "not a format"),
            (v1.replace("\"bytes\"", "\"size\""), "no bytes; fields of another tool: size"),
            ("[1,2]".to_string(), "not a JSON object"),
            ("seed,file".to_string(), "not JSON"),
        ];
        for (line, why) in bad {
            let e = entry_seed(line.as_bytes()).expect_err(&line);
            assert!(e.contains(why), "{line}: {e}");
        }
        assert_eq!(entry_seed(&[0xff, 0xfe]), Err("it is not UTF-8 text".into()));
        let line = Entry { seed: 4, file: PathBuf::from("/nonexistent/4.glb"), counts: None }.line();
        assert!(line.is_err_and(|e| e.contains("/nonexistent/4.glb")));
    }

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("mdg-manifest-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn only_a_torn_last_line_is_cut_and_duplicates_count_once() {
        let d = scratch("torn");
        let path = d.join("manifest.jsonl");
        let hash = "ab".repeat(32);
        let line = |s: u64| {
            format!(r#"{{"bytes":1,"file":"{s}.glb","seed":{s},"sha256":"{hash}","triangles":1,"vertices":3}}"#)
        };
        let opened = |keep: fn(u64) -> bool| Manifest::open(&path, keep).map(|(m, w)| (m.done.clone(), w));
        // A manifest that is only the start of a line: cut to nothing.
        std::fs::create_dir_all(&d).expect("dir");
        std::fs::write(&path, "{\"mdg").expect("write");
        let (done, warnings) = opened(|_| true).expect("opens");
        assert!(done.is_empty() && warnings.len() == 1 && warnings[0].contains("dropped 5 bytes"), "{warnings:?}");
        assert_eq!(std::fs::read(&path).expect("read"), b"");
        // Duplicates (two runs of an older version at once) count once, with a
        // warning; seeds outside the run are not kept; the torn tail is cut.
        let text = format!("{}\n{}\n{}\n{}\n{}", line(1), line(2), line(1), line(9), &line(3)[..20]);
        std::fs::write(&path, &text).expect("write");
        let (done, warnings) = opened(|s| s < 5).expect("opens");
        assert_eq!(done.into_iter().collect::<Vec<_>>(), vec![1, 2]);
        assert!(
            warnings[0].contains("dropped 20 bytes")
                && warnings[1].contains("1 seeds of this run have more than one line")
        );
        assert_eq!(std::fs::read_to_string(&path).expect("read"), text[..text.len() - 20]);
        assert!(!lock_path(&path).exists(), "the lock file outlives the run");
        std::fs::remove_dir_all(&d).expect("cleanup");
    }

    #[test]
    fn a_second_open_of_one_shard_is_busy_and_names_the_first() {
        let d = scratch("busy");
        let path = d.join("manifest-0-of-2.jsonl");
        let (first, _) = Manifest::open(&path, |_| true).expect("the first opens");
        let e = Manifest::open(&path, |_| true).err().expect("the second is refused");
        let OpenError::Busy(m) = e else { panic!("{e}") };
        assert!(m.contains(&format!("pid {} on host {}", std::process::id(), host_name())), "{m}");
        assert!(m.contains("manifest-0-of-2.jsonl.lock"), "{m}");
        drop(first);
        assert!(!lock_path(&path).exists());
        let again = Manifest::open(&path, |_| true);
        assert!(again.is_ok(), "the lock is released with the first");
        drop(again);
        std::fs::remove_dir_all(&d).expect("cleanup");
    }

    #[test]
    fn times_are_written_in_utc() {
        assert_eq!(utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(utc(1_796_406_377), "2026-12-04 17:46:17 UTC");
        assert_eq!(utc(4_102_444_799), "2099-12-31 23:59:59 UTC");
    }

    #[test]
    fn templates_need_a_seed_and_the_manifest_sits_above_it() {
        assert_eq!(output_for(Path::new("out/{seed}.glb"), 7), Ok(PathBuf::from("out/7.glb")));
        assert!(output_for(Path::new("out/a.glb"), 7).is_err());
        assert_eq!(manifest_path(Path::new("out/{seed}.glb"), Shard::default()), PathBuf::from("out/manifest.jsonl"));
        assert_eq!(
            manifest_path(Path::new("runs/x/{seed}/m.glb"), Shard { index: 1, count: 3 }),
            PathBuf::from("runs/x/manifest-1-of-3.jsonl")
        );
        assert_eq!(lock_path(Path::new("out/manifest.jsonl")), PathBuf::from("out/manifest.jsonl.lock"));
    }

    #[test]
    fn seeds_run_side_by_side_are_recorded_in_order_and_stop_at_the_first_failure() {
        let todo: Vec<(u64, PathBuf)> = (0..40).map(|s| (s, PathBuf::from(format!("out/{s}.glb")))).collect();
        // Later seeds finish first: without ordering they would be recorded first.
        let run = |seed: u64, _: &Path| -> Result<u64, String> {
            std::thread::sleep(std::time::Duration::from_millis(40u64.saturating_sub(seed)));
            Ok(seed * seed)
        };
        for jobs in [1, 2, 7] {
            let mut seen = Vec::new();
            let n = run_in_order(&todo, jobs, run, |seed, _, r| {
                seen.push((seed, r));
                Ok(())
            });
            assert_eq!(n, Ok(40));
            assert_eq!(seen, (0..40).map(|s| (s, s * s)).collect::<Vec<_>>(), "jobs {jobs}");
        }
        let failing = |seed: u64, _: &Path| {
            if seed == 9 || seed == 20 {
                Err(format!("seed {seed}"))
            } else {
                Ok(seed)
            }
        };
        for jobs in [1, 4] {
            let mut seen = Vec::new();
            let r = run_in_order(&todo, jobs, failing, |seed, _, _| {
                seen.push(seed);
                Ok(())
            });
            assert_eq!(r, Err("seed 9".to_string()), "jobs {jobs}");
            assert_eq!(seen, (0..9).collect::<Vec<_>>(), "jobs {jobs}");
        }
    }
}
