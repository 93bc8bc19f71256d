//! The compiler, as the viewer needs it: [`Toolchain`] implements the viewer's
//! [`Loader`] (compile or load a grammar and evaluate it; compile the fallback
//! shader programs). The viewer depends on the VM only; this is where it meets the
//! compiler.

use mdg_compiler::check::CheckOptions;
use mdg_compiler::diag::render_plain;
use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use mdg_viewer::model::{LoadFailure, LoadOptions, Loader, Model};
use mdg_viewer::program::{ProgramSpirv, Programs, LINE_FS, LINE_VS, POINT_VS};
use mdg_viewer::Error;
use mdg_vm::eval::evaluate;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The std library's shader file, built in as a fallback.
const STD_SHADERS: &str = include_str!("../../std/shaders.mdg");

/// The MDG compiler and VM behind the viewer.
#[derive(Clone, Copy, Debug, Default)]
pub struct Toolchain;

impl Loader for Toolchain {
    fn load(&self, path: &Path, opts: &LoadOptions) -> Result<(Model, Vec<PathBuf>), Box<LoadFailure>> {
        let fail = |error: Error, files: Vec<PathBuf>| Box::new(LoadFailure { error, files });
        let is_bundle = path.extension().is_some_and(|e| e == "mdgb");
        let (bundle, files, warnings) = if is_bundle {
            let flag = opts.params.first().map(|(n, v)| format!("--param {n}={v}"));
            if let Some(flag) = flag.or_else(|| opts.presets.first().map(|p| format!("--preset {p}"))) {
                let msg = format!(
                    "{flag}: {} is a compiled bundle; {flag} applies when compiling the source (mdgc build {flag} …)",
                    path.display()
                );
                return Err(fail(Error::Other(msg), vec![path.into()]));
            }
            let bytes = mdg_vm::input::read_bounded(path, mdg_vm::input::MAX_DATA_BYTES)
                .map_err(|e| fail(Error::Io(format!("cannot read {}: {e}", path.display())), vec![path.into()]))?;
            let b = mdg_vm::bundle::load(&bytes)
                .map_err(|e| fail(Error::Compile(format!("{}: {e}", path.display())), vec![path.into()]))?;
            (b, vec![path.to_path_buf()], String::new())
        } else {
            let copts = Options {
                defines: opts.presets.clone(),
                params: opts.params.clone(),
                std_dir: opts.std_dir.clone().or_else(driver::default_std_dir),
            };
            match driver::build(&FsLoader, path, &copts) {
                Ok((b, a)) => {
                    let files: Vec<PathBuf> = a.sources.files.iter().map(|f| f.path.clone()).collect();
                    // (A usage error: `mdg-view` exits 2 on `Error::Other` from here.)
                    if let Err(e) = crate::args::check_declared(&a, &copts) {
                        return Err(fail(Error::Other(e), files));
                    }
                    (b, files, render_plain(&a.diagnostics, &a.sources))
                }
                Err(a) => {
                    let mut files: Vec<PathBuf> = a.sources.files.iter().map(|f| f.path.clone()).collect();
                    if files.is_empty() {
                        files.push(path.to_path_buf());
                    }
                    return Err(fail(Error::Compile(render_plain(&a.diagnostics, &a.sources)), files));
                }
            }
        };
        // A guided grammar's model comes from its search, which the viewer runs.
        let output = if opts.guided_search && bundle.extensions.has(mdg_vm::bundle::SectionKind::Guided) {
            mdg_vm::output::Output::default()
        } else {
            evaluate(&bundle, &opts.eval)
        };
        Ok((Model { bundle, output, warnings }, files))
    }

    fn programs(&self, std_dir: Option<&Path>) -> Result<Programs, Error> {
        let std = std_programs(std_dir)?;
        Ok(Programs {
            phong: std.phong,
            instanced: std.instanced,
            lines: line_program()?,
            points: Some(point_program()?),
        })
    }
}

/// std's Phong program and its instanced vertex shader with the same fragment
/// shader (`None` for a std without `phong_instanced_vs`).
#[derive(Clone, Debug)]
pub struct StdPrograms {
    pub phong: ProgramSpirv,
    pub instanced: Option<ProgramSpirv>,
}

/// Compiles std's `shaders.mdg` (from `std_dir` if given and present) and returns
/// its `program`'s shaders and the instanced variant.
fn compile_std(std_dir: Option<&Path>) -> Result<StdPrograms, String> {
    let opts = Options { std_dir: std_dir.map(Path::to_path_buf), ..Options::default() };
    let file = std_dir.map(|d| d.join("shaders.mdg")).filter(|p| p.is_file());
    let a = match &file {
        Some(p) => driver::analyze(&FsLoader, p, &opts, CheckOptions { require_start: false }),
        None => driver::analyze_text(
            &FsLoader,
            Path::new("std/shaders.mdg"),
            STD_SHADERS,
            &opts,
            CheckOptions { require_start: false },
        ),
    };
    if a.has_errors() {
        return Err(render_plain(&a.diagnostics, &a.sources));
    }
    let pick = |vertex: bool, name: &str| -> Option<Vec<u32>> {
        let i = a.expanded.shaders.iter().position(|s| s.vertex == vertex && s.name.text == name)?;
        a.spirv.get(i).cloned().flatten()
    };
    match (pick(true, "phong_vs"), pick(false, "phong_fs")) {
        (Some(vertex), Some(fragment)) => {
            // (An older std without the instanced shader: instances are drawn expanded.)
            let instanced = pick(true, "phong_instanced_vs").map(|v| ProgramSpirv {
                vertex: v,
                fragment: fragment.clone(),
                label: "std phong_instanced_vs + phong_fs".into(),
            });
            Ok(StdPrograms {
                phong: ProgramSpirv { vertex, fragment, label: "std phong_vs + phong_fs".into() },
                instanced,
            })
        }
        _ => Err("std/shaders.mdg has no phong_vs / phong_fs".into()),
    }
}

/// The GLSL of std's `phong_vs` and `phong_fs` as [`std_programs`] compiles them
/// (from `std_dir`'s `shaders.mdg` when it has one, else the built-in copy), read
/// without compiling anything: the CPU renderer checks their content hash
/// (`mdg_viewer::cpu::program_of`). A shader that is not there is empty (and so not
/// std's).
pub fn std_phong_code(std_dir: Option<&Path>) -> (String, String) {
    let text = std_dir
        .map(|d| d.join("shaders.mdg"))
        .filter(|p| p.is_file())
        .and_then(|p| std::fs::read_to_string(p).ok())
        .unwrap_or_else(|| STD_SHADERS.to_string());
    (shader_code(&text, "@vertexshader", "phong_vs"), shader_code(&text, "@fragmentshader", "phong_fs"))
}

/// The lines between `DIRECTIVE NAME` and `@endshader` in an `.mdg` text.
fn shader_code(text: &str, directive: &str, name: &str) -> String {
    let mut lines = text.lines();
    let found = lines.by_ref().any(|l| {
        let mut w = l.split_whitespace();
        w.next() == Some(directive) && w.next() == Some(name)
    });
    if !found {
        return String::new();
    }
    lines.take_while(|l| l.trim() != "@endshader").collect::<Vec<_>>().join("\n")
}

/// Compiled std programs by std directory.
type StdCache = Mutex<Vec<(Option<PathBuf>, StdPrograms)>>;

/// The std Phong program.
pub fn std_program(std_dir: Option<&Path>) -> Result<ProgramSpirv, Error> {
    std_programs(std_dir).map(|p| p.phong)
}

/// The std programs (compiled once per process and std directory; an
/// installation's edited `shaders.mdg` is honoured).
pub fn std_programs(std_dir: Option<&Path>) -> Result<StdPrograms, Error> {
    static CACHE: OnceLock<StdCache> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
    let key = std_dir.map(Path::to_path_buf);
    if let Ok(c) = cache.lock() {
        if let Some((_, p)) = c.iter().find(|(k, _)| *k == key) {
            return Ok(p.clone());
        }
    }
    let p =
        compile_std(std_dir).map_err(|m| Error::Compile(format!("the std Phong program does not compile:\n{m}")))?;
    if let Ok(mut c) = cache.lock() {
        c.push((key, p.clone()));
    }
    Ok(p)
}

/// The viewer's point-sprite program for small instances (compiled once per process).
pub fn point_program() -> Result<ProgramSpirv, Error> {
    static POINTS: OnceLock<Result<ProgramSpirv, String>> = OnceLock::new();
    POINTS
        .get_or_init(|| {
            let c = |src: &str, vertex: bool| {
                mdg_compiler::shaders::compile_glsl(src, vertex).map_err(|e| format!("built-in point shader: {e:?}"))
            };
            Ok(ProgramSpirv { vertex: c(POINT_VS, true)?, fragment: c(LINE_FS, false)?, label: "points".into() })
        })
        .clone()
        .map_err(Error::Compile)
}

/// The viewer's line program (compiled once per process).
pub fn line_program() -> Result<ProgramSpirv, Error> {
    static LINES: OnceLock<Result<ProgramSpirv, String>> = OnceLock::new();
    LINES
        .get_or_init(|| {
            let c = |src: &str, vertex: bool| {
                mdg_compiler::shaders::compile_glsl(src, vertex).map_err(|e| format!("built-in line shader: {e:?}"))
            };
            Ok(ProgramSpirv { vertex: c(LINE_VS, true)?, fragment: c(LINE_FS, false)?, label: "lines".into() })
        })
        .clone()
        .map_err(Error::Compile)
}
