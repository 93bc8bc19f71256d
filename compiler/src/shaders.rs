//! The shader stage: every `@vertexshader` / `@fragmentshader` block compiled to
//! SPIR-V with glslang, GLSL errors turned into diagnostics (E0501) at the line and
//! column of the `.mdg` file.
//!
//! Shaders are Vulkan GLSL (`#version 450`) compiled for Vulkan 1.0 / SPIR-V 1.0, the
//! interface of docs/reference.md §13. A block's code starts right after its name on
//! the `@vertexshader NAME` line, so GLSL line 1 is the rest of that line and GLSL
//! line *n* is file line `block + n - 1`: the mapping is exact, not estimated.
//!
//! The driver runs this stage for every analysis (so `mdgc check` and the editor
//! show GLSL errors too) and attaches the SPIR-V to the bundle in `build`. Results
//! are cached by (stage, source) in memory, so re-analysing an edited file
//! recompiles only the blocks that changed; a binary may also install a
//! [`SpirvStore`] ([`install_store`], e.g. the [`DiskCache`] the commands and the
//! language server use), which keeps compiled SPIR-V across processes, keyed by a
//! hash of everything it depends on ([`cache_key`]): std's shaders are compiled
//! once per machine, not on every `mdg-run --png`.
//!
//! # Bounds (issue 25)
//!
//! glslang recurses on the native stack, expands `#define`s without a bound and
//! cannot be interrupted. So a block is first checked against the limits of
//! [`crate::shader_limits`] (size, preprocessed size, operators per statement):
//! past them it is refused with E0502 and glslang never sees it. What passes is
//! compiled on a thread of its own with a [`COMPILE_STACK_BYTES`] stack, and the
//! caller waits until that thread has used [`COMPILE_DEADLINE`] of processor time
//! (its own CPU time, so a busy machine does not make a good shader fail: four
//! `mdg-view --png` at once on 2 cores failed std's shaders under a wall-clock
//! deadline), or [`COMPILE_WALL_LIMIT`] of wall-clock time as a safety net; past
//! either the caller gets an E0502 ("took longer than 5 s of processor time") and
//! returns, and the thread is **abandoned**: it runs
//! to its end in the background (glslang has no way to stop it), then stores its
//! result in the cache and exits. At most [`MAX_COMPILE_THREADS`] compile threads
//! live at once, abandoned ones included; when that many are busy a new compile
//! waits for one to end, up to its own deadline, and is then refused (E0502, not
//! cached, so a later analysis tries again).
//!
//! The cache's lock is held only to look up and store results, never while glslang
//! runs, so an abandoned compile holds no lock. Compilations of different sources
//! run side by side (glslang is thread-safe once initialised; the test
//! `concurrent_compiles_agree_with_serial_ones` checks it); a caller asking for a
//! source that is being compiled waits for that compile instead of starting
//! another. A timed-out source is cached as timed out, so re-analysing the same
//! text does not start it again, until its thread ends and replaces that entry
//! with the real result.

use crate::diag::Diagnostic;
use crate::expand::{Expanded, Shader};
use crate::source::Sources;
use crate::span::Span;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{mpsc, Condvar, Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// One GLSL error as glslang reports it, positions relative to the shader source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GlslError {
    /// 1-based line in the shader source, when glslang gives one.
    pub line: Option<u32>,
    /// 1-based column, when glslang gives one.
    pub column: Option<u32>,
    pub message: String,
    /// Whether this is a limit of the shader stage (E0502: too large, too complex,
    /// too slow) rather than an error in the GLSL (E0501).
    pub limit: bool,
}

impl GlslError {
    fn glsl(line: Option<u32>, column: Option<u32>, message: impl Into<String>) -> GlslError {
        GlslError { line, column, message: message.into(), limit: false }
    }
    fn limit(message: impl Into<String>) -> GlslError {
        GlslError { line: None, column: None, message: message.into(), limit: true }
    }
}

/// The result of compiling one shader source.
pub type CompileResult = Result<Vec<u32>, Vec<GlslError>>;

/// Most cached results kept; the cache is emptied when it grows past this (an
/// editor session produces one entry per edited version of a block).
const CACHE_LIMIT: usize = 256;

/// How much processor time one glslang compilation may use (the compile thread's
/// own CPU time, measured while the caller waits: a loaded machine slows a compile
/// down but does not make it use more of it). std's shaders take about 20 ms.
pub const COMPILE_DEADLINE: Duration = Duration::from_secs(5);
/// The wall-clock safety net of a compilation (and of a wait for a free compile
/// thread or for a compile of the same source): [`WALL_FACTOR`] times its deadline,
/// 60 s for [`COMPILE_DEADLINE`].
pub const COMPILE_WALL_LIMIT: Duration = Duration::from_secs(60);
/// The wall-clock limit of a compile is this many times its processor-time deadline.
pub const WALL_FACTOR: u32 = 12;
/// The stack of a compile thread (reserved, not committed: only what glslang
/// touches is memory). 256 MiB takes an expression nested 200,000 deep, far
/// past what [`crate::shader_limits`] lets through.
pub const COMPILE_STACK_BYTES: usize = 256 << 20;
/// Most compile threads alive at once, abandoned ones included.
pub const MAX_COMPILE_THREADS: usize = 4;

type Key = (bool, String);

#[derive(Default)]
struct State {
    cache: HashMap<Key, CompileResult>,
    /// Sources a thread is compiling now (its caller may have given up on it).
    running: HashSet<Key>,
    /// Compile threads alive.
    threads: usize,
}

fn state() -> &'static (Mutex<State>, Condvar) {
    static STATE: OnceLock<(Mutex<State>, Condvar)> = OnceLock::new();
    STATE.get_or_init(|| (Mutex::new(State::default()), Condvar::new()))
}

/// The state, whatever a panicking holder left: it is only finished results and
/// counts updated in single steps.
fn lock(m: &Mutex<State>) -> MutexGuard<'_, State> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Compiles one GLSL source for the vertex (`vertex = true`) or fragment stage,
/// within the limits of [`crate::shader_limits`] and [`COMPILE_DEADLINE`].
pub fn compile_glsl(source: &str, vertex: bool) -> CompileResult {
    compile_glsl_within(source, vertex, COMPILE_DEADLINE)
}

/// [`compile_glsl`] with another deadline.
pub fn compile_glsl_within(source: &str, vertex: bool, deadline: Duration) -> CompileResult {
    if let Err(r) = crate::shader_limits::check(source) {
        let (line, column) = line_col(source, r.start);
        return Err(vec![GlslError { line: Some(line), column: Some(column), message: r.message, limit: true }]);
    }
    // Without a cancel check the compile always answers.
    compile_checked(source, vertex, deadline, None).unwrap_or_else(|| Err(timed_out(deadline)))
}

/// How often a caller with a cancel check looks at it while it waits for glslang.
const CANCEL_POLL: Duration = Duration::from_millis(10);

/// The SPIR-V of each shader block (`None` where it failed) and the diagnostics.
pub type Compiled = (Vec<Option<Vec<u32>>>, Vec<Diagnostic>);

/// A cancel check (see [`crate::driver::Effort`]).
pub type Cancel<'a> = Option<&'a (dyn Fn() -> bool + Sync)>;

/// How long to wait next: what is left of `left`, at most [`CANCEL_POLL`] when
/// there is a cancel check to look at.
fn slice(left: Duration, cancel: Cancel) -> Duration {
    if cancel.is_some() {
        left.min(CANCEL_POLL)
    } else {
        left
    }
}

/// Waits until no compile thread is running, at most `timeout`; whether none is.
/// Called before a process exits: glslang's static destructors must not run under
/// a compilation (an abandoned one that outlives `timeout` is left to the exit).
pub fn wait_for_compiles(timeout: Duration) -> bool {
    let (m, cv) = state();
    let start = Instant::now();
    let mut st = lock(m);
    while st.threads > 0 {
        let left = timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return false;
        }
        st = cv.wait_timeout(st, left).map(|(g, _)| g).unwrap_or_else(|p| p.into_inner().0);
    }
    true
}

fn seconds(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s >= 1.0 && s.fract() == 0.0 {
        format!("{s:.0} s")
    } else {
        format!("{} ms", d.as_millis())
    }
}

fn timed_out(deadline: Duration) -> Vec<GlslError> {
    vec![GlslError::limit(format!(
        "shader compilation took longer than {} of processor time (the limit for one shader); glslang was left \
         to finish in the background",
        seconds(deadline)
    ))]
}

fn timed_out_wall(limit: Duration) -> Vec<GlslError> {
    vec![GlslError::limit(format!(
        "shader compilation took longer than {} of wall-clock time (the safety net for one shader, however busy \
         the machine); glslang was left to finish in the background",
        seconds(limit)
    ))]
}

/// How often a waiting caller reads the compile thread's processor time.
const CPU_POLL: Duration = Duration::from_millis(10);

/// Stores a result in the in-memory cache (emptied when it grows past [`CACHE_LIMIT`]).
fn remember(st: &mut State, key: Key, result: CompileResult) {
    if st.cache.len() >= CACHE_LIMIT && !st.cache.contains_key(&key) {
        st.cache.clear();
    }
    st.cache.insert(key, result);
}

/// Processor time of one thread, read from another: on Linux the thread's
/// `/proc/<pid>/task/<tid>/stat` (user + system time, in the kernel's 10 ms ticks),
/// found by the thread itself through `/proc/thread-self`. Elsewhere there is none
/// and the deadline falls back to wall-clock time.
pub mod cpu_clock {
    use std::path::PathBuf;
    use std::time::Duration;

    /// A thread's processor-time counter.
    #[derive(Clone, Debug)]
    pub struct Clock(PathBuf);

    /// The calling thread's clock (`None` where the platform has none).
    pub fn current_thread() -> Option<Clock> {
        let task = std::fs::read_link("/proc/thread-self").ok()?;
        let clock = Clock(PathBuf::from("/proc").join(task).join("stat"));
        clock.used().map(|_| clock)
    }

    impl Clock {
        /// The processor time the thread has used; `None` once it has ended.
        pub fn used(&self) -> Option<Duration> {
            let stat = std::fs::read_to_string(&self.0).ok()?;
            // Fields after the command name (which may hold spaces): state is the
            // first, utime the 12th, stime the 13th; in USER_HZ (100) ticks.
            let mut fields = stat.rsplit_once(')')?.1.split_whitespace().skip(11);
            let utime: u64 = fields.next()?.parse().ok()?;
            let stime: u64 = fields.next()?.parse().ok()?;
            Some(Duration::from_millis((utime + stime).saturating_mul(10)))
        }
    }
}

/// glslang runs (compilations not answered by a cache) in this process so far.
static GLSLANG_RUNS: AtomicU64 = AtomicU64::new(0);
/// Compilations answered by the installed [`SpirvStore`] in this process so far.
static STORE_HITS: AtomicU64 = AtomicU64::new(0);

/// How many shaders this process compiled with glslang, and how many it took from
/// the installed [`SpirvStore`] instead (`mdg-run --stats` prints them).
pub fn compile_counts() -> (u64, u64) {
    (GLSLANG_RUNS.load(Ordering::Relaxed), STORE_HITS.load(Ordering::Relaxed))
}

/// Where compiled SPIR-V is kept between processes, keyed by [`cache_key`].
/// Implementations must never fail a compile: a read that goes wrong is a miss, a
/// write that goes wrong is dropped.
pub trait SpirvStore: Send + Sync {
    /// The SPIR-V stored under `key`, if any.
    fn load(&self, key: &str) -> Option<Vec<u32>>;
    /// Keeps `words` under `key`.
    fn save(&self, key: &str, words: &[u32]);
}

static STORE: OnceLock<Box<dyn SpirvStore>> = OnceLock::new();

/// Installs the store compiled SPIR-V is kept in across processes (once per
/// process; false if one was installed already). The library installs none: the
/// binaries opt in at start-up.
pub fn install_store(store: Box<dyn SpirvStore>) -> bool {
    STORE.set(store).is_ok()
}

/// Empties the in-memory cache, as a new process starts: for tests and measurements
/// of a [`SpirvStore`].
pub fn clear_memory_cache() {
    lock(&state().0).cache.clear();
}

/// What the glslang settings are, for [`cache_key`] (change it when
/// [`compile_uncached`] changes how it calls glslang).
const GLSLANG_SETTINGS: &str = "glslang 0.9 vulkan1.0 spirv1.0 display-error-column";

/// Everything compiled SPIR-V depends on: this compiler's version, the glslang
/// settings, the stage and the source.
pub fn cache_key(source: &str, vertex: bool) -> String {
    let stage = if vertex { "vertex" } else { "fragment" };
    format!("mdg-compiler {} / {GLSLANG_SETTINGS} / {stage}\n{source}", env!("CARGO_PKG_VERSION"))
}

fn store_load(source: &str, vertex: bool) -> Option<Vec<u32>> {
    let words = STORE.get()?.load(&cache_key(source, vertex))?;
    // Only what looks like SPIR-V: anything else is a miss.
    (words.first() == Some(&mdg_vm::bundle::SPIRV_MAGIC)).then(|| {
        STORE_HITS.fetch_add(1, Ordering::Relaxed);
        words
    })
}

fn store_save(source: &str, vertex: bool, words: &[u32]) {
    if let Some(store) = STORE.get() {
        store.save(&cache_key(source, vertex), words);
    }
}

/// A [`SpirvStore`] in a directory: one file per compiled shader, named by a
/// 128-bit hash of its key and holding the whole key (a hash collision is a miss,
/// never wrong SPIR-V), written atomically (a temporary file renamed into place,
/// so concurrent processes never read half a file). Past [`DiskCache::MAX_FILES`]
/// files the older half is deleted. Errors are misses.
pub struct DiskCache {
    dir: PathBuf,
}

/// The first bytes of a [`DiskCache`] file.
const DISK_MAGIC: &[u8; 10] = b"MDGSPIRV1\n";

impl DiskCache {
    /// Most files kept (an editor session writes one per edited version of a block).
    pub const MAX_FILES: usize = 1024;
    /// The largest file read back (larger ones are misses).
    const MAX_FILE_BYTES: u64 = 64 << 20;

    /// A cache in `dir` (created when first written).
    pub fn new(dir: PathBuf) -> DiskCache {
        DiskCache { dir }
    }

    /// The user's cache directory for SPIR-V: `$XDG_CACHE_HOME/mdg/spirv`, else
    /// `$HOME/.cache/mdg/spirv`; `None` when `MDG_SPIRV_CACHE` is `0` or `off`
    /// (or neither variable is set).
    pub fn default_dir() -> Option<PathBuf> {
        if std::env::var("MDG_SPIRV_CACHE").is_ok_and(|v| matches!(v.trim(), "0" | "off")) {
            return None;
        }
        crate::stdlib::user_cache_roots().into_iter().next().map(|root| root.join("spirv"))
    }

    /// Installs a disk cache in [`DiskCache::default_dir`], if there is one.
    pub fn install_default() {
        if let Some(dir) = DiskCache::default_dir() {
            install_store(Box::new(DiskCache::new(dir)));
        }
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!(
            "{:016x}{:016x}.spv",
            fnv1a(key, 0xcbf2_9ce4_8422_2325),
            fnv1a(key, 0x6c62_272e_07bb_0142)
        ))
    }

    fn trim(&self) {
        let Ok(rd) = std::fs::read_dir(&self.dir) else { return };
        let mut files: Vec<(std::time::SystemTime, PathBuf)> = rd
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".spv"))
            .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
            .collect();
        if files.len() < DiskCache::MAX_FILES {
            return;
        }
        files.sort();
        for (_, p) in files.iter().take(files.len() / 2) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// 64-bit FNV-1a of `text` from `basis` (the file name only: the file holds the key).
fn fnv1a(text: &str, basis: u64) -> u64 {
    text.bytes().fold(basis, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}

impl SpirvStore for DiskCache {
    fn load(&self, key: &str) -> Option<Vec<u32>> {
        let path = self.path(key);
        let bytes = mdg_vm::input::read_bounded(&path, DiskCache::MAX_FILE_BYTES).ok()?;
        let rest = bytes.strip_prefix(DISK_MAGIC.as_slice())?;
        let (len, rest) = rest.split_first_chunk::<8>()?;
        let len = usize::try_from(u64::from_le_bytes(*len)).ok()?;
        if rest.len() < len || rest[..len] != *key.as_bytes() {
            return None;
        }
        let body = &rest[len..];
        if body.is_empty() || body.len() % 4 != 0 {
            return None;
        }
        Some(body.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect())
    }

    fn save(&self, key: &str, words: &[u32]) {
        if std::fs::create_dir_all(&self.dir).is_err() {
            return;
        }
        self.trim();
        let mut bytes = Vec::with_capacity(DISK_MAGIC.len() + 8 + key.len() + words.len() * 4);
        bytes.extend_from_slice(DISK_MAGIC);
        bytes.extend_from_slice(&(key.len() as u64).to_le_bytes());
        bytes.extend_from_slice(key.as_bytes());
        for w in words {
            bytes.extend_from_slice(&w.to_le_bytes());
        }
        // Temporary file + rename (never half a file for a concurrent reader); errors are dropped.
        let _ = mdg_export::write_atomic(&self.path(key), &bytes);
    }
}

/// A source that passed the limits: from the cache, from a compile of the same
/// source already running, or compiled on a new thread. `None` once `cancel` says
/// so (a compile it started goes on and stores its result in the cache).
fn compile_checked(source: &str, vertex: bool, deadline: Duration, cancel: Cancel) -> Option<CompileResult> {
    if let Err(e) = precheck(source) {
        return Some(Err(e));
    }
    let cancelled = || cancel.is_some_and(|c| c());
    let key: Key = (vertex, source.to_string());
    let (m, cv) = state();
    let wall_limit = deadline.saturating_mul(WALL_FACTOR);
    if let Some(r) = lock(m).cache.get(&key) {
        return Some(r.clone());
    }
    // Compiled by an earlier process? (Read without the lock: it is IO.)
    if let Some(words) = store_load(source, vertex) {
        let mut st = lock(m);
        remember(&mut st, key, Ok(words.clone()));
        return Some(Ok(words));
    }
    let start = Instant::now();
    let mut st = lock(m);
    loop {
        if let Some(r) = st.cache.get(&key) {
            return Some(r.clone());
        }
        if cancelled() {
            return None;
        }
        let same_running = st.running.contains(&key);
        if !same_running && st.threads < MAX_COMPILE_THREADS {
            break;
        }
        // A compile of the same source ends by its own deadline (then it caches a
        // time-out, read above) and busy threads by theirs: wait by the wall-clock
        // safety net, so a loaded machine does not fail a good shader here either.
        let left = wall_limit.saturating_sub(start.elapsed());
        if left.is_zero() {
            if same_running {
                return Some(Err(timed_out_wall(wall_limit)));
            }
            return Some(Err(vec![GlslError::limit(format!(
                "shader not compiled: all {MAX_COMPILE_THREADS} glslang threads stayed busy for {} (a compilation \
                 past its deadline keeps its thread until it ends)",
                seconds(wall_limit)
            ))]));
        }
        st = cv.wait_timeout(st, slice(left, cancel)).map(|(g, _)| g).unwrap_or_else(|p| p.into_inner().0);
    }
    st.running.insert(key.clone());
    st.threads += 1;
    drop(st);

    let (tx, rx) = mpsc::channel();
    let (clock_tx, clock_rx) = mpsc::channel();
    let src = key.1.clone();
    let spawned =
        std::thread::Builder::new().name("mdg glslang".into()).stack_size(COMPILE_STACK_BYTES).spawn(move || {
            let _ = clock_tx.send(cpu_clock::current_thread());
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| compile_uncached(&src, vertex)))
                .unwrap_or_else(|_| Err(vec![GlslError::glsl(None, None, "glslang failed on this shader")]));
            // Kept (on disk, in memory) before the caller hears of it: a process
            // that exits right after its compile still leaves the file, and what the
            // caller does next finds it cached.
            if let Ok(words) = &result {
                store_save(&src, vertex, words);
            }
            let (m, cv) = state();
            let mut st = lock(m);
            let key = (vertex, src);
            st.running.remove(&key);
            st.threads -= 1;
            // Replaces a "took too long" entry its caller may have left.
            remember(&mut st, key, result.clone());
            cv.notify_all();
            drop(st);
            let _ = tx.send(result);
        });
    if let Err(e) = spawned {
        let mut st = lock(m);
        st.running.remove(&key);
        st.threads -= 1;
        cv.notify_all();
        return Some(Err(vec![GlslError::limit(format!("shader not compiled: cannot start a compile thread: {e}"))]));
    }
    // Waits until the thread answers, has used `deadline` of processor time, or
    // `wall_limit` has passed.
    let compiling = Instant::now();
    let mut clock: Option<Option<cpu_clock::Clock>> = None;
    let mut over_wall = false;
    loop {
        let wall_left = wall_limit.saturating_sub(compiling.elapsed());
        match rx.recv_timeout(wall_left.min(CPU_POLL)) {
            Ok(r) => return Some(r),
            // Given up: the thread finishes on its own and stores its result.
            Err(mpsc::RecvTimeoutError::Timeout) if cancelled() => return None,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if clock.is_none() {
                    clock = clock_rx.try_recv().ok();
                }
                let used = match clock {
                    // Not started yet: it has used nothing.
                    None => Duration::ZERO,
                    Some(Some(ref c)) => c.used().unwrap_or_else(|| compiling.elapsed()),
                    // No thread clock on this platform: wall-clock time.
                    Some(None) => compiling.elapsed(),
                };
                over_wall = compiling.elapsed() >= wall_limit;
                if used >= deadline || over_wall {
                    break;
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
    }
    // Finished just now after all?
    if let Ok(r) = rx.try_recv() {
        return Some(r);
    }
    // Abandoned: the thread finishes on its own and stores its result.
    let r = Err(if over_wall { timed_out_wall(wall_limit) } else { timed_out(deadline) });
    let mut st = lock(m);
    if st.running.contains(&key) {
        st.cache.entry(key).or_insert_with(|| r.clone());
    }
    cv.notify_all();
    Some(r)
}

/// What is refused before glslang: NUL characters and a missing or non-ASCII
/// `#version` line.
fn precheck(source: &str) -> Result<(), Vec<GlslError>> {
    // glslang takes a C string: a NUL inside the block cannot be passed on (and would
    // make the crate's conversion panic), so report it here.
    if let Some(at) = source.find('\0') {
        let (line, column) = line_col(source, at);
        return Err(vec![GlslError::glsl(Some(line), Some(column), "NUL character in shader source")]);
    }
    // Without a `#version` line glslang assumes ES 1.00 and says so obscurely.
    if !source.lines().any(|l| l.trim_start().starts_with("#version")) {
        return Err(vec![GlslError::glsl(
            None,
            None,
            "no `#version` line: Vulkan GLSL shaders start with `#version 450`",
        )]);
    }
    // The glslang crate slices the `#version` line by bytes and panics inside a
    // multi-byte character: refuse a non-ASCII one here.
    if let Some(i) = source.lines().position(|l| l.trim_start().starts_with("#version") && !l.is_ascii()) {
        return Err(vec![GlslError::glsl(
            Some(i as u32 + 1),
            None,
            "the `#version` line must be plain ASCII, like `#version 450`",
        )]);
    }
    Ok(())
}

/// The result for a source that passed the limits from the caches alone (the
/// in-memory one, then the installed [`SpirvStore`]), or `None` where only glslang
/// could answer: never starts a compile nor waits for one.
fn cached(source: &str, vertex: bool) -> Option<CompileResult> {
    if let Err(e) = precheck(source) {
        return Some(Err(e));
    }
    let key: Key = (vertex, source.to_string());
    let m = &state().0;
    if let Some(r) = lock(m).cache.get(&key) {
        return Some(r.clone());
    }
    let words = store_load(source, vertex)?;
    remember(&mut lock(m), key, Ok(words.clone()));
    Some(Ok(words))
}

/// A test hook: `MDG_TEST_SHADER_GATE=PATH` makes every glslang compile wait until a
/// file exists at `PATH` (a shader checker that answers only when the test lets it,
/// for the language server's test that diagnostics do not wait for it).
fn test_gate() {
    static GATE: OnceLock<Option<PathBuf>> = OnceLock::new();
    let Some(gate) = GATE.get_or_init(|| std::env::var_os("MDG_TEST_SHADER_GATE").map(PathBuf::from)) else {
        return;
    };
    while !gate.exists() {
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn compile_uncached(source: &str, vertex: bool) -> CompileResult {
    use glslang::{Compiler, CompilerOptions, ShaderInput, ShaderMessage, ShaderSource, ShaderStage};
    test_gate();
    GLSLANG_RUNS.fetch_add(1, Ordering::Relaxed);
    let Some(compiler) = Compiler::acquire() else {
        return Err(vec![GlslError::glsl(None, None, "glslang could not be initialised")]);
    };
    let stage = if vertex { ShaderStage::Vertex } else { ShaderStage::Fragment };
    let src = ShaderSource::from(source);
    let options = CompilerOptions { messages: ShaderMessage::DISPLAY_ERROR_COLUMN, ..CompilerOptions::default() };
    let input = match ShaderInput::new(&src, stage, &options, None::<&[(&str, Option<&str>)]>, None) {
        Ok(i) => i,
        Err(e) => {
            // Rejected before parsing: an unsupported `#version` line.
            let line = source.lines().position(|l| l.trim_start().starts_with("#version")).map(|i| i as u32 + 1);
            return Err(vec![GlslError::glsl(line, None, format!("{e} (Vulkan GLSL needs `#version 450`)"))]);
        }
    };
    let shader = match compiler.create_shader(input) {
        Ok(s) => s,
        Err(e) => return Err(errors_of(&e)),
    };
    match shader.compile() {
        Ok(words) => Ok(words),
        Err(e) => Err(errors_of(&e)),
    }
}

/// The errors in a glslang failure: one per `ERROR:` line of its log.
fn errors_of(e: &glslang::error::GlslangError) -> Vec<GlslError> {
    use glslang::error::GlslangError as G;
    let log = match e {
        G::PreprocessError(l) | G::ParseError(l) | G::MapIoError(l) | G::LinkError(l) => l.log.clone(),
        other => return vec![GlslError::glsl(None, None, other.to_string())],
    };
    let errors = parse_log(&log);
    if errors.is_empty() {
        vec![GlslError::glsl(None, None, log.trim())]
    } else {
        errors
    }
}

/// Parses glslang's log: `ERROR: 0:LINE:COL: 'token' : message` (with
/// `DISPLAY_ERROR_COLUMN`), `ERROR: 0:LINE: …`, or `ERROR: message` (link errors).
/// The summary line `ERROR: N compilation errors.  No code generated.` is dropped.
pub fn parse_log(log: &str) -> Vec<GlslError> {
    let mut out = Vec::new();
    for raw in log.lines() {
        let Some(rest) = raw.trim().strip_prefix("ERROR:") else { continue };
        let rest = rest.trim_start();
        if rest.contains("compilation errors.") && rest.contains("No code generated") {
            continue;
        }
        // glslang stops at the first error it cannot recover from and says so in
        // an extra error; the real one was already reported.
        if rest.ends_with("compilation terminated") {
            continue;
        }
        if rest.starts_with("Linking ") && rest.ends_with("stage:") {
            // A heading; the next line carries the message.
            continue;
        }
        // `0:LINE[:COL]: message`: string index, line, optional column.
        let mut fields = rest.splitn(4, ':');
        let parsed = (|| {
            let _string = fields.next()?.trim().parse::<u32>().ok()?;
            let line = fields.next()?.trim().parse::<u32>().ok()?;
            let third = fields.next()?;
            match third.trim().parse::<u32>() {
                Ok(col) => Some((line, Some(col), fields.next()?.trim().to_string())),
                Err(_) => {
                    let tail = fields.next().map(|t| format!("{third}:{t}")).unwrap_or_else(|| third.to_string());
                    Some((line, None, tail.trim().to_string()))
                }
            }
        })();
        match parsed {
            Some((line, column, message)) => out.push(GlslError::glsl(Some(line), column, tidy(&message))),
            None => out.push(GlslError::glsl(None, None, tidy(rest))),
        }
    }
    out
}

/// glslang writes `'token' : message`; keep it, minus the odd spacing and an
/// empty token.
fn tidy(message: &str) -> String {
    let m = message.trim();
    let m = m.strip_prefix("'' :").unwrap_or(m);
    m.replace(" : ", ": ").split_whitespace().collect::<Vec<_>>().join(" ")
}

/// 1-based (line, column) of byte offset `at` in `text`.
fn line_col(text: &str, at: usize) -> (u32, u32) {
    let before = &text[..at];
    let line = before.matches('\n').count() as u32 + 1;
    let col = before.rfind('\n').map(|nl| at - nl).unwrap_or(at + 1) as u32;
    (line, col)
}

/// The span in the `.mdg` file of a GLSL error in block `sh`: the quoted token at
/// the reported column when glslang names one, else the rest of the line from the
/// column, else the whole line; errors with no line point at the block's name.
fn span_of(sh: &Shader, sources: &Sources, e: &GlslError) -> Span {
    let Some(line) = e.line else { return sh.name.span };
    let code = lone_cr_to_lf(sources.text(sh.code_span));
    // Byte offset of the start of GLSL line `line` within the block's code.
    let mut start = 0usize;
    for _ in 1..line {
        match code[start..].find('\n') {
            Some(nl) => start += nl + 1,
            None => return sh.name.span,
        }
    }
    let end = code[start..].find('\n').map(|nl| start + nl).unwrap_or(code.len());
    let text = &code[start..end];
    let text = text.strip_suffix('\r').unwrap_or(text);
    let end = start + text.len();
    let indent = text.len() - text.trim_start().len();
    let (lo, hi) = match e.column {
        // glslang's columns count bytes from 1.
        Some(c) if c >= 1 && (c as usize - 1) < text.len() => {
            // A byte column can fall inside a multi-byte character: back up to its start.
            let mut lo = start + c as usize - 1;
            while !code.is_char_boundary(lo) {
                lo -= 1;
            }
            let token = quoted_token(&e.message);
            let hi = match token {
                Some(t) if !t.is_empty() && code[lo..end].starts_with(t) => lo + t.len(),
                _ => {
                    // The identifier or symbol at the column.
                    let rest = &code[lo..end];
                    let n = rest.find(|ch: char| !(ch.is_alphanumeric() || ch == '_')).unwrap_or(rest.len());
                    // At least the character at the column.
                    let first = rest.chars().next().map_or(0, char::len_utf8);
                    lo + n.max(first).min(rest.len())
                }
            };
            (lo, hi)
        }
        _ => match quoted_token(&e.message)
            .and_then(|t| (!t.is_empty()).then(|| text.find(t).map(|i| (i, t.len()))).flatten())
        {
            Some((i, n)) => (start + i, start + i + n),
            None => (start + indent, end),
        },
    };
    let base = sh.code_span.start;
    Span::new(sh.code_span.file, base + lo as u32, base + hi.max(lo) as u32)
}

/// `code` with every lone CR made a LF: the compiler ends lines at a lone CR
/// ([`crate::source::line_starts`]) but glslang does not. Byte for byte, so offsets
/// and line numbers stay those of the `.mdg` file.
fn lone_cr_to_lf(code: &str) -> std::borrow::Cow<'_, str> {
    let b = code.as_bytes();
    if !b.iter().enumerate().any(|(i, &c)| c == b'\r' && b.get(i + 1) != Some(&b'\n')) {
        return std::borrow::Cow::Borrowed(code);
    }
    let mut out = String::with_capacity(code.len());
    let mut chars = code.chars().peekable();
    while let Some(c) = chars.next() {
        out.push(if c == '\r' && chars.peek() != Some(&'\n') { '\n' } else { c });
    }
    std::borrow::Cow::Owned(out)
}

/// The first `'…'` in a glslang message, the token it complains about.
fn quoted_token(message: &str) -> Option<&str> {
    let a = message.find('\'')?;
    let b = message[a + 1..].find('\'')?;
    Some(&message[a + 1..a + 1 + b])
}

/// Compiles every shader block of an expanded program. Returns the SPIR-V of each
/// block, index-aligned with `ex.shaders` (`None` where it failed), and the
/// diagnostics.
/// `None` once `cancel` says so.
pub fn compile_all(ex: &Expanded, sources: &Sources, cancel: Cancel) -> Option<Compiled> {
    compile_all_by(ex, sources, &mut |code, vertex| compile_checked(code, vertex, COMPILE_DEADLINE, cancel))
}

/// [`compile_all`] answered by the caches alone (in memory, then the installed
/// [`SpirvStore`]): `None` if a block would need glslang (not yet compiled, or
/// being compiled). Never waits: what the language server publishes first while
/// glslang starts or compiles.
pub fn compile_all_cached(ex: &Expanded, sources: &Sources) -> Option<Compiled> {
    compile_all_by(ex, sources, &mut cached)
}

/// [`compile_all`] with `compile` for the blocks that pass the limits (`None`: stop,
/// and answer `None`).
fn compile_all_by(
    ex: &Expanded,
    sources: &Sources,
    compile: &mut dyn FnMut(&str, bool) -> Option<CompileResult>,
) -> Option<Compiled> {
    let mut spirv = Vec::with_capacity(ex.shaders.len());
    let mut diags = Vec::new();
    for sh in &ex.shaders {
        let stage = if sh.vertex { "vertex" } else { "fragment" };
        let code = lone_cr_to_lf(&sh.code);
        if let Err(r) = crate::shader_limits::check(&code) {
            let base = sh.code_span.start;
            let span = Span::new(sh.code_span.file, base + r.start as u32, base + r.end as u32);
            let mut d = Diagnostic::error("E0502", span, r.message).with_label(r.label);
            if let Some((a, b, what)) = r.context {
                d = d.with_secondary(Span::new(sh.code_span.file, base + a as u32, base + b as u32), what);
            }
            diags.push(
                d.with_secondary(sh.name.span, format!("in {stage} shader `{}`", sh.name.text))
                    .with_note(r.note)
                    .with_note(
                        "shader blocks are checked against these limits before glslang compiles them (docs/limits.md)",
                    ),
            );
            spirv.push(None);
            continue;
        }
        match compile(&code, sh.vertex)? {
            Ok(words) if mdg_vm::bundle::spirv::largest_array(&words) > mdg_vm::bundle::spirv::MAX_ARRAY_ELEMENTS => {
                let n = mdg_vm::bundle::spirv::largest_array(&words);
                let max = mdg_vm::bundle::spirv::MAX_ARRAY_ELEMENTS;
                diags.push(
                    Diagnostic::error("E0502", sh.name.span, format!("shader array too large: {n} elements (at most {max})"))
                        .with_label(format!("{stage} shader `{}` declares it", sh.name.text))
                        .with_note("the Vulkan driver allocates every array a shader declares (a `float[100000000]` took 7.8 GB); keep large tables in buffers or textures"),
                );
                spirv.push(None);
            }
            Ok(words) => spirv.push(Some(words)),
            Err(errors) => {
                for e in &errors {
                    let d = if e.limit {
                        Diagnostic::error("E0502", sh.name.span, e.message.clone())
                            .with_label(format!("{stage} shader `{}`", sh.name.text))
                            .with_note("shader blocks are compiled within the limits in docs/limits.md")
                    } else {
                        Diagnostic::error("E0501", span_of(sh, sources, e), format!("GLSL: {}", e.message))
                            .with_label(format!("in {stage} shader `{}`", sh.name.text))
                            .with_note("shaders are Vulkan GLSL 450; the inputs and uniforms provided are in docs/reference.md §13")
                    };
                    diags.push(d);
                }
                spirv.push(None);
            }
        }
    }
    Some((spirv, diags))
}

/// Stores compiled SPIR-V in a lowered bundle (whose shader list was lowered from
/// the same blocks, in the same order).
pub fn attach(bundle: &mut mdg_vm::bundle::Bundle, spirv: &[Option<Vec<u32>>]) {
    for (sh, words) in bundle.shaders.iter_mut().zip(spirv) {
        sh.spirv = words.clone().unwrap_or_default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_logs_with_and_without_columns() {
        let log = "ERROR: 0:5:12: 'foo' : undeclared identifier\nERROR: 0:7: '' : syntax error\nERROR: 0:7:3: '' : compilation terminated\nERROR: Linking vertex stage: \nERROR: Missing entry point: Each stage requires one entry point\nERROR: 2 compilation errors.  No code generated.\n";
        let e = parse_log(log);
        assert_eq!(e.len(), 3, "{e:?}");
        assert_eq!(e[0], GlslError::glsl(Some(5), Some(12), "'foo': undeclared identifier"));
        assert_eq!(e[1].line, Some(7));
        assert_eq!(e[1].column, None);
        assert_eq!(e[2].line, None);
        assert!(e[2].message.contains("Missing entry point"));
    }

    #[test]
    fn compiles_a_vertex_shader_and_reports_errors_with_positions() {
        let ok = "\n#version 450\nlayout(location = 0) in vec3 p;\nvoid main() { gl_Position = vec4(p, 1.0); }\n";
        let words = compile_glsl(ok, true).expect("compiles");
        assert_eq!(words.first(), Some(&mdg_vm::bundle::SPIRV_MAGIC));
        let bad = "\n#version 450\nvoid main() {\n    gl_Position = vec4(nope, 1.0);\n}\n";
        let errs = compile_glsl(bad, true).expect_err("fails");
        assert_eq!(errs[0].line, Some(4), "{errs:?}");
        assert!(errs[0].message.contains("nope"), "{errs:?}");
        assert!(!errs[0].limit);
    }

    #[test]
    fn limits_are_checked_before_glslang() {
        let terms = vec!["x"; 10_000].join("+");
        let src = format!("#version 450\nvoid main() {{ float x = 1.0;\n gl_Position = vec4({terms}); }}\n");
        let errs = compile_glsl(&src, true).expect_err("refused");
        assert!(errs[0].limit && errs[0].message.starts_with("expression too complex"), "{errs:?}");
        assert_eq!(errs[0].line, Some(3), "{errs:?}");
    }

    /// A compile past its deadline returns at once; its thread ends on its own and
    /// leaves the real result in the cache, and no lock stays held meanwhile.
    #[test]
    fn a_compile_past_its_deadline_is_abandoned_not_waited_for() {
        let src = "#version 450\nvoid main() { gl_Position = vec4(0.125, 0.25, 0.5, 1.0); }\n// deadline test\n";
        let errs = loop {
            let t = Instant::now();
            let errs = compile_glsl_within(src, true, Duration::ZERO).expect_err("no time at all");
            // Hang guard only (no wall-clock bound under 30 s: loaded machines).
            assert!(t.elapsed() < Duration::from_secs(30), "{:?}", t.elapsed());
            // Other tests may hold every compile thread for a moment.
            if !errs[0].message.starts_with("shader not compiled: all") {
                break errs;
            }
            wait_for_compiles(Duration::from_secs(60));
        };
        assert!(errs[0].limit && errs[0].message.starts_with("shader compilation took longer than 0 ms"), "{errs:?}");
        // Other sources compile meanwhile: nothing is locked by the abandoned one.
        compile_glsl("#version 450\nvoid main() { gl_Position = vec4(1.0); }\n// other\n", true).expect("compiles");
        assert!(wait_for_compiles(Duration::from_secs(60)), "the abandoned compile never ended");
        let words = compile_glsl(src, true).expect("the abandoned compile's result replaced the timeout");
        assert_eq!(words.first(), Some(&mdg_vm::bundle::SPIRV_MAGIC));
    }

    #[test]
    fn concurrent_compiles_agree_with_serial_ones() {
        let source = |i: usize| {
            let bad = if i.is_multiple_of(3) { " + nope" } else { "" };
            format!("#version 450\nlayout(location = 0) in vec3 p;\nvoid main() {{ float a{i} = {i}.0; gl_Position = vec4(p * a{i}, 1.0){bad}; }}\n")
        };
        let serial: Vec<CompileResult> = (0..12).map(|i| compile_uncached(&source(i), true)).collect();
        let threads: Vec<_> = (0..4)
            .map(|k| {
                std::thread::spawn(move || {
                    (0..12).map(|i| (i, compile_glsl(&source((i + k) % 12), true))).collect::<Vec<_>>()
                })
            })
            .collect();
        for (k, h) in threads.into_iter().enumerate() {
            for (i, r) in h.join().expect("no panic") {
                assert_eq!(r, serial[(i + k) % 12], "source {}", (i + k) % 12);
            }
        }
    }

    /// An analysis that takes the shaders from the caches only leaves them pending
    /// (no SPIR-V, no GLSL diagnostics) until glslang has compiled them, then gives
    /// what the full analysis gives; a block the limits refuse needs no glslang.
    #[test]
    fn the_cached_only_stage_never_compiles_and_then_matches_the_full_one() {
        use crate::check::CheckOptions;
        use crate::driver::{analyze_text, analyze_text_with, Effort};
        let loader = crate::source::MemLoader::default();
        let path = std::path::Path::new("/t/cached_only.mdg");
        // A source no other test compiles (the in-memory cache is the process's).
        let src = "startshape A\n@vertexshader cached_only_vs\n#version 450\n\
                   void main() { gl_Position = vec4(0.125, 0.25, undeclared_cached_only, 1.0); }\n@endshader\n\
                   rule A { VERTEX {} VERTEX {x 1} VERTEX {y 1} }\n";
        let opts = crate::expand::Options::default();
        let cached_only = Effort { cached_shaders_only: true, ..Effort::default() };
        let early = analyze_text_with(&loader, path, src, &opts, CheckOptions::default(), cached_only).expect("done");
        assert!(early.shaders_pending);
        assert_eq!(early.spirv, vec![None]);
        assert!(!early.diagnostics.iter().any(|d| d.code == "E0501"), "{:?}", early.diagnostics);
        let full = analyze_text(&loader, path, src, &opts, CheckOptions::default());
        assert!(!full.shaders_pending);
        assert!(full.diagnostics.iter().any(|d| d.code == "E0501"), "{:?}", full.diagnostics);
        let later = analyze_text_with(&loader, path, src, &opts, CheckOptions::default(), cached_only).expect("done");
        assert!(!later.shaders_pending);
        assert_eq!(later.diagnostics, full.diagnostics);
        assert_eq!(later.spirv, full.spirv);
        // Refused by the limits: answered without glslang, nothing pending.
        let terms = vec!["x"; 10_000].join("+");
        let huge = src.replace("undeclared_cached_only", &terms);
        let refused =
            analyze_text_with(&loader, path, &huge, &opts, CheckOptions::default(), cached_only).expect("done");
        assert!(!refused.shaders_pending);
        assert!(refused.diagnostics.iter().any(|d| d.code == "E0502"), "{:?}", refused.diagnostics);
    }
}
