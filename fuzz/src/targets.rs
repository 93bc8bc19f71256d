//! The fuzz targets. Each turns input bytes into a run of one part of the toolchain
//! and returns a coarse signature of what happened (diagnostic codes, error kinds,
//! warnings), which the driver uses as feedback: inputs with a new signature join the
//! mutation pool. A bug is a panic: crashes, broken invariants (`assert!`), or
//! properties such as "formatting twice changes nothing" and "a lowered bundle loads".

use crate::loader::FuzzFs;
use crate::rng::{hash, Rng};
use mdg_compiler::analysis::{CompletionConfig, Document};
use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver::{analyze_text, Analysis};
use mdg_compiler::expand::Options;
use mdg_compiler::source::{MemLoader, Sources};
use mdg_export::{self as export, Format};
use mdg_grid::format::VoxelFormat;
use mdg_vm::bundle::{self, Section as _};
use mdg_vm::eval::{evaluate, EvalOptions};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Executions that got past the first stage: lowered to a bundle (`parse_check`,
/// `vm_run`, `ext_sources`), formatted (`fmt_idempotent`), expanded without errors
/// (`preprocess`), loaded and run (`bundle_load`). The driver reports it.
pub static DEEP: AtomicU64 = AtomicU64::new(0);

fn deep() {
    DEEP.fetch_add(1, Ordering::Relaxed);
}

/// A fuzz target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// Lexer, preprocessor, parser, checker (and lowering when clean, plus the
    /// editor features) on arbitrary text.
    ParseCheck,
    /// `format(format(x)) == format(x)`, and the tree and comments are unchanged.
    FmtIdempotent,
    /// Macros, `@ifdef` and `@import` over an in-memory project with self-imports,
    /// cycles, symlinks and files outside the root; nothing outside is ever read.
    Preprocess,
    /// Mutated real bundles: decode + verify, then disassemble, run under tight
    /// limits and export.
    BundleLoad,
    /// Random well-formed programs compiled and run under tight limits; the run is
    /// deterministic and its bundle round-trips.
    VmRun,
    /// `guide` / `search` / `creature` / `grid` sections through the checker and lowering.
    ExtSources,
    /// Real bundles with extension tables (guided search, creatures, grid grammars),
    /// one number inside the tables replaced by an extreme value: the verifier refuses
    /// it or the section's mode runs (search, evolution, generation) under tight
    /// limits without panicking.
    ExtTables,
    /// Shader text through the bounds checked before glslang
    /// (`shader_limits::check`), and glslang itself on one input in 64 that passes:
    /// generated shaders (`gen::glsl`: macro chains, long and deep expressions,
    /// arrays) and mutated ones.
    GlslLimits,
    /// The voxel readers (`mdg_grid::format`: text, `.vox`, `.nbt`, `.schem`); a
    /// model read is written back and must read again with as many blocks. The first
    /// input byte picks the format.
    VoxelReaders,
}

impl Target {
    /// Every target, in the order `fuzz/run` runs them.
    pub const ALL: [Target; 9] = [
        Target::ParseCheck,
        Target::FmtIdempotent,
        Target::Preprocess,
        Target::BundleLoad,
        Target::VmRun,
        Target::ExtSources,
        Target::ExtTables,
        Target::GlslLimits,
        Target::VoxelReaders,
    ];

    /// The name on the command line and of the corpus folder.
    pub fn name(self) -> &'static str {
        match self {
            Target::ParseCheck => "parse_check",
            Target::FmtIdempotent => "fmt_idempotent",
            Target::Preprocess => "preprocess",
            Target::BundleLoad => "bundle_load",
            Target::VmRun => "vm_run",
            Target::ExtSources => "ext_sources",
            Target::ExtTables => "ext_tables",
            Target::GlslLimits => "glsl_limits",
            Target::VoxelReaders => "voxel_readers",
        }
    }

    /// The target called `name`.
    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether inputs are binary (mutated byte-wise only).
    pub fn binary(self) -> bool {
        matches!(self, Target::BundleLoad | Target::ExtTables | Target::VoxelReaders)
    }

    /// The extension of saved inputs.
    pub fn extension(self) -> &'static str {
        match self {
            Target::BundleLoad | Target::ExtTables => "mdgb",
            Target::VoxelReaders => "bin",
            _ => "mdg",
        }
    }

    /// The largest input the mutators produce.
    pub fn max_len(self) -> usize {
        match self {
            Target::BundleLoad | Target::ExtTables | Target::VoxelReaders => 256 * 1024,
            // Extension examples are longer (a creature grammar is about 3 KB).
            Target::ExtSources => 4 * 1024,
            // Generated programs with the probe and the parameter rule reach about 2.5 KB.
            Target::VmRun => 4 * 1024,
            // Generated shaders hold up to four 10,000-term statements (about 200 KB);
            // past 256 KiB the size limit is what they meet. Generated projects of 300
            // files are about 20 KB.
            Target::GlslLimits => 320 * 1024,
            Target::Preprocess => 32 * 1024,
            _ => 2 * 1024,
        }
    }

    /// Turns a corpus file into an input: text as is; for `bundle_load`, a `.mdg`
    /// program is compiled into bundle bytes (a `.mdgb` file is taken as is).
    pub fn seed(self, path: &Path, bytes: Vec<u8>) -> Option<Vec<u8>> {
        if matches!(self, Target::BundleLoad | Target::ExtTables) && path.extension().is_some_and(|e| e == "mdg") {
            let text = String::from_utf8_lossy(&bytes);
            let b = compile(&text, path)?;
            if self == Target::ExtTables && b.extensions.is_empty() {
                return None;
            }
            return Some(bundle::encode(&b));
        }
        if self == Target::VoxelReaders {
            // A voxel file: its format's index, then its bytes (saved inputs, `.bin`,
            // already start with the index).
            if let Some(f) = VoxelFormat::from_path(path) {
                let i = VoxelFormat::ALL.iter().position(|x| *x == f).unwrap_or(0) as u8;
                let mut v = vec![i];
                v.extend_from_slice(&bytes);
                return Some(v);
            }
        }
        Some(bytes)
    }

    /// Words the token-level mutators insert.
    pub fn dictionary(self) -> Vec<String> {
        let mut d: Vec<String> = Vec::new();
        fn add_to(d: &mut Vec<String>, words: &[&str]) {
            d.extend(words.iter().map(|s| s.to_string()));
        }
        add_to(&mut d, mdg_compiler::lexer::KEYWORDS);
        add_to(&mut d, mdg_compiler::lexer::PREPROCESSOR_DIRECTIVES);
        add_to(&mut d, mdg_compiler::check::DRAWABLES);
        add_to(&mut d, mdg_compiler::check::SELECTOR_MODES);
        add_to(&mut d, mdg_compiler::check::ANGLE_MODES);
        add_to(&mut d, mdg_vm::expr::VARIABLES);
        add_to(&mut d, mdg_vm::expr::BINOPS);
        add_to(&mut d, &mdg_compiler::check::NUMERIC_DIRECTIVES.iter().map(|d| d.0).collect::<Vec<_>>());
        add_to(&mut d, &mdg_vm::expr::FUNCTIONS.iter().map(|f| f.0).collect::<Vec<_>>());
        let fns: Vec<String> = mdg_vm::expr::FUNCTIONS.iter().map(|f| format!("{}(", f.0)).collect();
        d.extend(fns);
        add_to(&mut d, &mdg_compiler::check::Components::default().all_names());
        add_to(
            &mut d,
            &[
                "{",
                "}",
                "[",
                "]",
                "(",
                ")",
                "*",
                "/",
                "\\",
                ":",
                ",",
                ";",
                "-",
                "A",
                "B",
                "ns.A",
                "A {}",
                "rule A {",
                "B [x 1]",
                "3 * {rz 120}",
                "2/3 *",
                "1000000000000 *",
                "@macro M(a)\n",
                "@macro N\n",
                "@endmacro\n",
                "@expand M(1)",
                "@expand M(M(1))",
                "@expand N",
                "@define D 3\n",
                "@ifdef D\n",
                "@else\n",
                "@endif\n",
                "@param int n 3 0 9\n",
                "@param bool b true\n",
                "@presets p q\n",
                "(n)",
                "(D)",
                "// c\n",
                "/* c */",
                "/*",
                "*/",
                "\n",
                "startshape A\n",
                "rand(0, 1)",
                "randn(0, 1)",
                "90d",
                "2t",
                "0.5r",
                "1o",
                "1e9",
                "%",
                "é",
                "\"path\"",
                "@vertexshader V\nvoid main() {}\n@endshader\n",
                "program { vertexshader V render }",
                "isosurface S { xyz -1 1 4 ; function { x } }\n",
                "S {}",
                "function f { x*x }\n",
                "selector A depth\n",
                "namespace ns {",
                "MOVETO tube {}",
                "rule T { FRAME {} }",
                "rule A : T {",
                "rule A * T : T {",
            ],
        );
        match self {
            Target::Preprocess => add_to(
                &mut d,
                &[
                    "@import self.mdg\n",
                    "@import lib/a.mdg\n",
                    "@import lib/b.mdg\n",
                    "@import lib/macros.mdg\n",
                    "@import prims\n",
                    "@import missing\n",
                    "@import escape/secret.mdg\n",
                    "@import lib/up/main.mdg\n",
                    "@import ../outside/secret.mdg\n",
                    "@import /outside/secret.mdg\n",
                    "@import loop/x.mdg\n",
                    "@import main.mdg\n",
                    "@expand LIBM(1)",
                    "@expand STDM()",
                    "//@file lib/new.mdg\n",
                    "//@file ../outside/new.mdg\n",
                ],
            ),
            Target::ExtSources => {
                add_to(&mut d, mdg_compiler::lexer::SECTION_KINDS);
                for kind in mdg_compiler::lexer::SECTION_KINDS {
                    add_to(&mut d, &mdg_compiler::ext::keys(&[*kind]).iter().map(|k| k.name).collect::<Vec<_>>());
                    d.push(format!("{kind} {{\n"));
                    d.push(format!("{kind} N {{ "));
                }
                add_to(&mut d, &["\"a.vox\"", "\"../x.schem\"", "{ }", "; "]);
            }
            _ => {}
        }
        d
    }

    /// The next input: for `vm_run` mostly a freshly generated program, else a
    /// mutation of one from the pool (half the time of one of its first `seeds`
    /// entries, the corpus, so mutations stay close to valid programs).
    pub fn next_input(self, rng: &mut Rng, pool: &[Vec<u8>], seeds: usize, dict: &[String]) -> Vec<u8> {
        if self == Target::VmRun && (pool.is_empty() || !rng.one_in(4)) {
            return crate::gen::program(rng).into_bytes();
        }
        if self == Target::GlslLimits && (pool.is_empty() || rng.one_in(2)) {
            return crate::gen::glsl(rng).into_bytes();
        }
        if self == Target::Preprocess && (pool.is_empty() || rng.one_in(3)) {
            return crate::gen::imports(rng).into_bytes();
        }
        let from = if seeds > 0 && rng.one_in(2) { &pool[..seeds.min(pool.len())] } else { pool };
        let base = rng.pick(from).cloned().unwrap_or_default();
        if self.binary() {
            let mut v = crate::mutate::bytes(rng, &base, pool, self.max_len());
            // Mostly keep the header consistent, so the decoder and verifier see the change.
            if self == Target::BundleLoad && v.len() >= 24 && !rng.one_in(4) {
                fix_bundle_header(&mut v);
            }
            v
        } else {
            crate::mutate::text(rng, &base, pool, dict, self.max_len())
        }
    }

    /// Runs one input; panics on a bug. Returns the behaviour signature.
    pub fn run(self, input: &[u8]) -> u64 {
        match self {
            Target::ParseCheck => parse_check(input, false),
            Target::ExtSources => parse_check(input, true),
            Target::FmtIdempotent => fmt_idempotent(input),
            Target::Preprocess => preprocess(input),
            Target::BundleLoad => bundle_load(input),
            Target::ExtTables => ext_tables(input),
            Target::GlslLimits => glsl_limits(input),
            Target::VmRun => vm_run(input),
            Target::VoxelReaders => voxel_readers(input),
        }
    }
}

/// Sets a bundle's length and check value to match its payload.
pub fn fix_bundle_header(v: &mut [u8]) {
    if v.len() < 24 {
        return;
    }
    let len = (v.len() - 24) as u64;
    let check = bundle::fnv1a(&v[24..]);
    v[8..16].copy_from_slice(&check.to_le_bytes());
    v[16..24].copy_from_slice(&len.to_le_bytes());
}

fn text(input: &[u8]) -> String {
    String::from_utf8_lossy(input).into_owned()
}

/// The std directory of this checkout.
pub fn std_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../std")
}

/// Compiles a program (std imports from this checkout) to a bundle, if it is clean.
pub fn compile(text: &str, path: &Path) -> Option<bundle::Bundle> {
    let loader = MemLoader { disk_fallback: true, ..MemLoader::default() };
    let opts = Options { std_dir: Some(std_dir()), ..Options::default() };
    let a = analyze_text(&loader, path, text, &opts, CheckOptions { require_start: true });
    lower_clean(&a)
}

fn lower_clean(a: &Analysis) -> Option<bundle::Bundle> {
    if a.has_errors() {
        return None;
    }
    let mut b = mdg_compiler::lower::lower(&a.expanded, &a.checked.symbols, &a.sources).ok()?;
    mdg_compiler::shaders::attach(&mut b, &a.spirv);
    Some(b)
}

/// A bundle the compiler produced must encode, load (decode + verify) and encode
/// to the same bytes again.
fn roundtrip(b: &bundle::Bundle) -> bundle::Bundle {
    let bytes = bundle::encode(b);
    let back = match bundle::load(&bytes) {
        Ok(back) => back,
        Err(e) => panic!("a bundle from the compiler does not load: {e}"),
    };
    assert!(bundle::encode(&back) == bytes, "a bundle changes when decoded and encoded again");
    back
}

/// Diagnostics point into their files, and rendering them works (rendered for one
/// input in sixteen, picked by `salt`: rendering dominates the cost otherwise).
fn check_diagnostics(a: &Analysis, salt: u64) {
    for d in &a.diagnostics {
        let code = d.code;
        assert!(
            code.len() == 5 && (code.starts_with('E') || code.starts_with('W') || code.starts_with('N')),
            "malformed diagnostic code {code:?}"
        );
        let Some(f) = a.sources.files.get(d.span.file.0 as usize) else {
            panic!("{code} points to file {} of {}", d.span.file.0, a.sources.files.len())
        };
        let (s, e) = (d.span.start as usize, d.span.end as usize);
        assert!(s <= e && e <= f.text.len(), "{code} span {s}..{e} outside its file of {} bytes", f.text.len());
        assert!(
            f.text.is_char_boundary(s) && f.text.is_char_boundary(e),
            "{code} span {s}..{e} is not on character boundaries"
        );
    }
    if salt.is_multiple_of(16) {
        let _ = mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources);
    }
}

/// A signature from the sorted set of diagnostic codes and a few counts.
fn diag_signature(a: &Analysis, extra: u64) -> u64 {
    let mut codes: Vec<&str> = a.diagnostics.iter().map(|d| d.code).collect();
    codes.sort_unstable();
    codes.dedup();
    let mut key = codes.join(",");
    key.push_str(&format!("|{}|{}|{extra}", a.expanded.items.len().min(8), a.expanded.expansions.len().min(4)));
    hash(key.as_bytes())
}

/// The std library in memory under `/std` (read once), for `ext_sources`: the
/// creature examples import std's parts.
fn std_fs() -> &'static FuzzFs {
    static FS: std::sync::OnceLock<FuzzFs> = std::sync::OnceLock::new();
    FS.get_or_init(|| {
        let mut fs = FuzzFs::default();
        for e in std::fs::read_dir(std_dir()).into_iter().flatten().flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "mdg") {
                if let (Some(name), Ok(text)) = (p.file_name(), std::fs::read_to_string(&p)) {
                    fs.files.insert(Path::new("/std").join(name), text);
                }
            }
        }
        fs
    })
}

fn parse_check(input: &[u8], ext: bool) -> u64 {
    let text = text(input);
    let (loader, opts): (&dyn mdg_compiler::source::FileLoader, Options) = if ext {
        (std_fs(), Options { std_dir: Some("/std".into()), ..Options::default() })
    } else {
        (&MemLoader::default(), Options::default())
    };
    let a = analyze_text(loader, Path::new("/fuzz/main.mdg"), &text, &opts, CheckOptions { require_start: true });
    let h = hash(input);
    check_diagnostics(&a, h >> 8);
    let mut extra = 0;
    if let Some(b) = lower_clean(&a) {
        deep();
        let back = roundtrip(&b);
        let _ = bundle::disassemble(&back);
        extra = 1
            + (back.code.len() as u64).min(64) / 8
            + if ext { 100 * u64::from(!back.extensions.is_empty()) } else { 0 };
    }
    let sig = diag_signature(&a, extra);
    // The editor features on the same analysis, at offsets picked from the input, on
    // one input in eight (they are what the language server runs under its guard).
    if h.is_multiple_of(8) {
        let doc = Document::from_analysis(a);
        let len = doc.text().len() as u32;
        let _ = doc.diagnostics();
        let _ = doc.semantic_tokens();
        let _ = doc.folding_ranges();
        let _ = doc.document_symbols();
        let _ = doc.inlay_hints(0, len);
        let _ = doc.code_actions(0, len);
        let config = CompletionConfig { std_libraries: vec!["primitives".into()] };
        let mut r = Rng::new(h);
        for _ in 0..2 {
            let at = r.below(len as usize + 1) as u32;
            let _ = doc.hover(at);
            let _ = doc.definition(at);
            let _ = doc.references(at, true);
            let _ = doc.completion(at, &config);
            let _ = doc.rename(at, "renamed");
        }
    }
    sig
}

/// The tree of a text with spans removed (for comparing differently laid-out text).
pub fn tree(text: &str) -> String {
    let mut s = Sources::default();
    let id = s.add("x.mdg", "x.mdg", text);
    let dump = mdg_compiler::dump::dump_file(&mdg_compiler::parse::parse_file(&s, id).file);
    dump.lines()
        .map(|l| {
            l.split(' ')
                .filter(|w| !(w.starts_with('@') && w[1..].chars().next().is_some_and(|c| c.is_ascii_digit())))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn comments(text: &str) -> Vec<String> {
    let lexed = mdg_compiler::lexer::lex(text, mdg_compiler::span::FileId(0));
    lexed.comments.iter().map(|c| text.get(c.span.range()).unwrap_or("").trim_end().to_string()).collect()
}

fn fmt_idempotent(input: &[u8]) -> u64 {
    let text = text(input);
    match mdg_compiler::fmt::format_source(&text) {
        Err(e) => hash(e.to_string().lines().next().unwrap_or("").split(']').next().unwrap_or("").as_bytes()),
        Ok(once) => {
            deep();
            let twice = match mdg_compiler::fmt::format_source(&once) {
                Ok(t) => t,
                Err(e) => panic!("formatted output does not parse:\n{e}\n--- formatted\n{once}"),
            };
            assert!(once == twice, "formatting is not idempotent:\n--- once\n{once}\n--- twice\n{twice}");
            let (a, b) = (tree(&text), tree(&once));
            assert!(a == b, "formatting changed the tree:\n--- before\n{a}\n--- after\n{b}");
            assert!(comments(&text) == comments(&once), "formatting lost or reordered comments");
            hash(format!("ok{}", once.lines().count().min(64)).as_bytes())
        }
    }
}

/// The in-memory project the preprocessor target imports from.
fn project(main: &str) -> FuzzFs {
    let mut fs = FuzzFs::default();
    let mut add = |p: &str, t: &str| {
        fs.files.insert(PathBuf::from(p), t.to_string());
    };
    add("/proj/self.mdg", "@import self.mdg\nrule SELF { VERTEX {} }\n");
    add("/proj/lib/a.mdg", "@import b.mdg\n@import ../main.mdg\nrule LA { LB {} }\n");
    add("/proj/lib/b.mdg", "@import a.mdg\nrule LB { VERTEX {} }\n");
    add(
        "/proj/lib/macros.mdg",
        "@macro LIBM(a)\nrule LM { VERTEX {x a} }\n@endmacro\n@macro REC(n)\n@expand REC(n n)\n@endmacro\n@define LIBD 2\n",
    );
    add("/outside/secret.mdg", "rule SECRET_OUTSIDE { VERTEX {} }\n");
    add("/std/prims.mdg", "@macro STDM()\nVERTEX {}\n@endmacro\nrule PRIM { VERTEX {} }\n@import prims\n");
    fs.links.insert("/proj/escape".into(), "/outside".into());
    fs.links.insert("/proj/lib/up".into(), "..".into());
    fs.links.insert("/proj/loop".into(), "loop".into());
    fs.links.insert("/std/evil.mdg".into(), "/outside/secret.mdg".into());
    // The input: the main file, then more files after `//@file NAME` lines.
    let mut name = "main.mdg".to_string();
    let mut body = String::new();
    let mut files = Vec::new();
    for line in main.split_inclusive('\n') {
        if let Some(n) = line.strip_prefix("//@file ") {
            files.push((std::mem::take(&mut name), std::mem::take(&mut body)));
            name = n.trim().to_string();
        } else {
            body.push_str(line);
        }
    }
    files.push((name, body));
    for (n, t) in files {
        let p = mdg_compiler::source::normalize(&Path::new("/proj").join(n));
        if p.starts_with("/proj") && !p.starts_with("/proj/escape") {
            fs.files.insert(p, t);
        }
    }
    fs
}

fn preprocess(input: &[u8]) -> u64 {
    let fs = project(&text(input));
    let main_text = fs.files.get(Path::new("/proj/main.mdg")).cloned().unwrap_or_default();
    let opts =
        Options { std_dir: Some("/std".into()), defines: vec!["P".into()], params: vec![("n".into(), "4".into())] };
    let a = analyze_text(&fs, Path::new("/proj/main.mdg"), &main_text, &opts, CheckOptions { require_start: false });
    check_diagnostics(&a, hash(input));
    for f in a.sources.files.iter().skip(1) {
        assert!(
            (f.path.starts_with("/proj") || f.path.starts_with("/std")) && !f.text.contains("SECRET_OUTSIDE"),
            "an import read {} outside the project and std",
            f.path.display()
        );
    }
    if !a.has_errors() {
        deep();
    }
    let mut paths: Vec<_> = a.sources.files.iter().map(|f| f.path.clone()).collect();
    let n = paths.len();
    paths.sort();
    paths.dedup();
    assert!(paths.len() == n, "a file was imported twice: {paths:?}");
    diag_signature(&a, n as u64)
}

/// Tight limits: every run ends quickly.
fn tight() -> EvalOptions {
    EvalOptions {
        maxiter: Some(3_000),
        max_vertices: 30_000,
        max_iso_cells: 4_096,
        time_budget: Some(Duration::from_secs(2)),
        ..EvalOptions::default()
    }
}

fn warnings_signature(out: &mdg_vm::output::Output) -> u64 {
    let mut w: Vec<String> =
        out.stats.warnings.iter().map(|w| w.chars().filter(|c| !c.is_ascii_digit()).collect()).collect();
    w.sort();
    w.dedup();
    hash(w.join("|").as_bytes())
}

fn bundle_load(input: &[u8]) -> u64 {
    match bundle::load(input) {
        Err(e) => {
            let msg = e.to_string();
            hash(msg.chars().filter(|c| !c.is_ascii_digit()).take(40).collect::<String>().as_bytes())
        }
        Ok(b) => {
            deep();
            let _ = bundle::disassemble(&b);
            // A verified bundle re-encodes to one that loads.
            if let Err(e) = bundle::load(&bundle::encode(&b)) {
                panic!("a verified bundle does not load after re-encoding: {e}");
            }
            let out = evaluate(&b, &tight());
            let format = Format::ALL[(hash(input) % Format::ALL.len() as u64) as usize];
            let mut bytes = Vec::new();
            let _ = export::write(format, &out, &mut bytes);
            warnings_signature(&out) ^ 0x5555
        }
    }
}

/// Values that break code trusting a table: zeros, negatives, huge and tiny
/// magnitudes, the integer edges, one past common limits.
const EXTREME_NUMBERS: &[f64] = &[
    0.0,
    -1.0,
    1.0,
    0.5,
    -0.5,
    2.0,
    3.0,
    1e-300,
    -1e-300,
    1e9,
    1e10,
    1e23,
    1e308,
    -1e308,
    4294967295.0,
    4294967296.0,
    2147483647.0,
    -2147483648.0,
    9007199254740993.0,
    18446744073709551615.0,
    65536.0,
    16000001.0,
    100001.0,
    1001.0,
    1000001.0,
];

/// The paths (object keys and array indices) of every number in `v`, in order.
fn number_paths(v: &serde_json::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        serde_json::Value::Number(_) => out.push(at.clone()),
        serde_json::Value::Array(xs) => {
            for (i, x) in xs.iter().enumerate() {
                at.push(i.to_string());
                number_paths(x, at, out);
                at.pop();
            }
        }
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                at.push(k.clone());
                number_paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

/// The number at `path` in `v`, for replacing.
fn number_at<'v>(v: &'v mut serde_json::Value, path: &[String]) -> Option<&'v mut serde_json::Value> {
    let mut cur = v;
    for p in path {
        cur = match cur {
            serde_json::Value::Array(xs) => xs.get_mut(p.parse::<usize>().ok()?)?,
            serde_json::Value::Object(m) => m.get_mut(p)?,
            _ => return None,
        };
    }
    Some(cur)
}

/// The `ext_tables` corpus compiled once: what an input that no longer loads is
/// replaced by (byte mutations break most bundles; the numbers are what matters).
fn ext_seeds() -> &'static [bundle::Bundle] {
    static SEEDS: std::sync::OnceLock<Vec<bundle::Bundle>> = std::sync::OnceLock::new();
    SEEDS.get_or_init(|| {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("corpus/ext_tables");
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map(|rd| rd.flatten().map(|e| e.path()).filter(|p| p.extension().is_some_and(|e| e == "mdg")).collect())
            .unwrap_or_default();
        files.sort();
        files
            .iter()
            .filter_map(|p| compile(&std::fs::read_to_string(p).ok()?, p))
            .filter(|b| !b.extensions.is_empty())
            .collect()
    })
}

fn ext_tables(input: &[u8]) -> u64 {
    let h = hash(input);
    let mut b = match bundle::load(input) {
        Ok(b) if !b.extensions.is_empty() => b,
        _ => match ext_seeds() {
            [] => return 1,
            seeds => seeds[(h % seeds.len() as u64) as usize].clone(),
        },
    };
    // The sections as one JSON object keyed by kind (as stored).
    let mut sections = serde_json::Map::new();
    for kind in bundle::SectionKind::ALL {
        if let Some(text) = b.extensions.get(kind) {
            let Ok(table) = serde_json::from_str(text) else { return 2 };
            sections.insert(kind.key().to_string(), table);
        }
    }
    let mut tables = serde_json::Value::Object(sections);
    let mut paths = Vec::new();
    number_paths(&tables, &mut Vec::new(), &mut paths);
    if paths.is_empty() {
        return 3;
    }
    // The input's own bytes choose the number and its new value (inputs mutate).
    let path = &paths[(h % paths.len() as u64) as usize];
    let value = EXTREME_NUMBERS[((h >> 20) % EXTREME_NUMBERS.len() as u64) as usize];
    let Some(slot) = number_at(&mut tables, path) else { return 4 };
    // Integers stay integers (a float where a u32 is expected does not deserialize).
    *slot = if slot.is_f64() {
        serde_json::json!(value)
    } else if value >= 0.0 && value.fract() == 0.0 && value < 1.9e19 {
        serde_json::json!(value as u64)
    } else if value.fract() == 0.0 && value > -9.3e18 {
        serde_json::json!(value as i64)
    } else {
        serde_json::json!(value)
    };
    if std::env::var_os("MDG_FUZZ_DEBUG").is_some() {
        println!("ext_tables: {} = {value}", path.join("/"));
    }
    let key = hash(path.join("/").as_bytes()) & 0xFFFF;
    for kind in bundle::SectionKind::ALL {
        if let Some(table) = tables.get(kind.key()) {
            b.extensions.set(kind, table.to_string());
        }
    }
    // The sections' verifiers apply the checker's limits to the tables: a table they
    // accept must run in its section's mode without a panic.
    let b = match bundle::load(&bundle::encode(&b)) {
        Err(e) => {
            let msg = e.to_string();
            return hash(msg.chars().filter(|c| !c.is_ascii_digit()).take(40).collect::<String>().as_bytes()) ^ key;
        }
        Ok(b) => b,
    };
    deep();
    let mut sig = 0x7777 ^ key;
    let section = mdg_guided::GuidedTable::from_bundle(&b);
    sig ^= section_signature(&section);
    if let Ok(Some(t)) = &section {
        if let Ok(p) = mdg_guided::Prepared::new(&b, t, &t.guides) {
            let full = mdg_guided::SearchOptions::from_settings(&t.settings, b.settings.randseed);
            // The table's own sizes are checked (that is where huge values are refused);
            // the run itself is kept short.
            sig ^= u64::from(p.check_size(&full).is_ok()) << 1;
            let opts = mdg_guided::SearchOptions {
                particles: (full.particles.0.min(8), full.particles.1.min(8)),
                generations: full.generations.min(3),
                budget: Some(Duration::from_millis(50)),
                threads: Some(1),
                ..full
            };
            if p.check_size(&opts).is_ok() {
                let r = p.search(&opts, None);
                let out = p.geometry(&r.model, &tight(), true);
                sig ^= warnings_signature(&out);
            }
        }
    }
    let section = mdg_creature::CreatureTable::from_bundle(&b);
    sig ^= section_signature(&section);
    if let Ok(Some(t)) = &section {
        if let Ok(lib) = mdg_creature::geometry::Library::build(&b, t) {
            let mut o = mdg_creature::evolve::EvolveOptions::from_table(t);
            o.population = o.population.min(3);
            o.background = o.background.min(3);
            o.offspring = o.offspring.min(6);
            o.generations = 1;
            let evo = mdg_creature::evolve::Evolution::new(t, &lib, o);
            let (mut pop, _) = evo.start();
            let g = evo.step(&mut pop, None);
            sig ^= (g.presented.len() as u64) << 3;
        }
    }
    let section = mdg_grid::GridGrammar::from_bundle(&b);
    sig ^= section_signature(&section);
    if let Ok(Some(g)) = &section {
        let d = mdg_grid::generate::GenerateOptions::default();
        // Two attempts: the retry path (assessment against the example) is fuzzed too.
        let o = mdg_grid::generate::GenerateOptions {
            steps: g.generate.steps.min(20),
            seal: g.generate.seal,
            attempts: 2,
            ..d
        };
        sig ^= match mdg_grid::build::generate(g, &o) {
            Ok(m) => (m.model.blocks.len() as u64).min(8) << 5,
            Err(e) => {
                hash(e.to_string().chars().filter(|c| !c.is_ascii_digit()).take(30).collect::<String>().as_bytes())
            }
        };
    }
    sig
}

/// The signature of an extension section that does not decode or verify (0 when it
/// does, or is absent).
fn section_signature<T>(section: &Result<Option<T>, bundle::SectionError>) -> u64 {
    match section {
        Err(e) => hash(e.to_string().chars().filter(|c| !c.is_ascii_digit()).take(40).collect::<String>().as_bytes()),
        Ok(_) => 0,
    }
}

fn glsl_limits(input: &[u8]) -> u64 {
    let text = text(input);
    match mdg_compiler::shader_limits::check(&text) {
        Err(r) => {
            // The refusal points inside the text, on character boundaries.
            assert!(r.start <= r.end && r.end <= text.len(), "refusal span {}..{} of {}", r.start, r.end, text.len());
            assert!(text.is_char_boundary(r.start) && text.is_char_boundary(r.end), "refusal span off a boundary");
            hash(r.message.chars().filter(|c| !c.is_ascii_digit()).take(30).collect::<String>().as_bytes())
        }
        Ok(()) => {
            deep();
            // What passes the bounds is what glslang must survive (on its own thread,
            // with the deadline): once in 64 inputs, it is slow.
            if hash(input).is_multiple_of(64) {
                match mdg_compiler::shaders::compile_glsl(&text, hash(input) & 64 == 0) {
                    Ok(_) => 0x11,
                    Err(e) => 0x22 ^ (e.len().min(4) as u64),
                }
            } else {
                0x33
            }
        }
    }
}

fn vm_run(input: &[u8]) -> u64 {
    let text = text(input);
    let a = analyze_text(
        &MemLoader::default(),
        Path::new("/fuzz/vm.mdg"),
        &text,
        &Options::default(),
        CheckOptions { require_start: true },
    );
    let Some(b) = lower_clean(&a) else { return diag_signature(&a, 0) };
    deep();
    let b = roundtrip(&b);
    let opts = EvalOptions { time_budget: None, ..tight() };
    let out = evaluate(&b, &opts);
    // Same bundle, seed and options: the same output, bit for bit (checked on one
    // input in four: it doubles the cost).
    let h = hash(input);
    if h % 4 == 1 {
        let again = evaluate(&b, &opts);
        assert!(digest(&out) == digest(&again), "two runs of the same bundle differ");
    }
    // The exporters on one input in eight each (formatting floats is the slow part).
    if h.is_multiple_of(8) {
        let format = Format::ALL[((h >> 8) % Format::ALL.len() as u64) as usize];
        let mut bytes = Vec::new();
        let _ = export::write(format, &out, &mut bytes);
    }
    warnings_signature(&out) ^ (out.stats.vertices.min(8) << 1)
}

/// A hash of everything an evaluation produced except its timing (FxHash-style over
/// the float bits: this runs on every `vm_run` input).
fn digest(out: &mdg_vm::output::Output) -> u64 {
    let mut h: u64 = 0;
    let mut add = |x: u32| h = (h.rotate_left(5) ^ u64::from(x)).wrapping_mul(0x517c_c1b7_2722_0a95);
    let meshes =
        std::iter::once(&out.mesh).chain(std::iter::once(&out.sweeps)).chain(out.shared_meshes.iter().map(|s| &s.mesh));
    for m in meshes {
        m.positions.iter().flatten().chain(m.normals.iter().flatten()).for_each(|x| add(x.to_bits()));
        m.colors.iter().flatten().chain(m.weights.iter().flatten()).for_each(|x| add(x.to_bits()));
        m.triangles.iter().flatten().chain(m.bones.iter()).for_each(|i| add(*i));
    }
    out.lines.iter().flat_map(|l| l.points.iter().flatten()).for_each(|x| add(x.to_bits()));
    for i in &out.instances {
        out.instance_transform(&i).to_cols_array().iter().chain(i.color.iter()).for_each(|x| add(x.to_bits()));
        add(i.mesh);
    }
    add(out.animation.bones.len() as u32);
    h ^ hash(out.stats.warnings.join("\n").as_bytes())
}

fn voxel_readers(input: &[u8]) -> u64 {
    let Some((&sel, bytes)) = input.split_first() else { return 0 };
    let format = VoxelFormat::ALL[usize::from(sel) % VoxelFormat::ALL.len()];
    match mdg_grid::format::read_bytes(format, bytes) {
        Err(e) => hash(
            format!("{format:?}{}", e.to_string().chars().filter(|c| !c.is_ascii_digit()).take(40).collect::<String>())
                .as_bytes(),
        ),
        Ok(model) => {
            deep();
            // What was read can be written back, and that reads again to as many blocks.
            if let Ok(out) = mdg_grid::format::write(format, &model) {
                match mdg_grid::format::read_bytes(format, &out) {
                    Ok(again) => assert!(
                        again.blocks.len() == model.blocks.len(),
                        "{format:?}: {} blocks read, {} after writing and reading back",
                        model.blocks.len(),
                        again.blocks.len()
                    ),
                    Err(e) => panic!("{format:?}: a written model does not read back: {e}"),
                }
            }
            hash(format!("{format:?}ok{}", model.blocks.len().min(16)).as_bytes())
        }
    }
}
