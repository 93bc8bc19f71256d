//! Which SPIR-V draws a model: the bundle's `program` (reference §13), with std's
//! Phong program (`std/shaders.mdg`) for any stage it leaves out or when there is
//! none; plus the viewer's own unlit shaders for pen lines.
//!
//! The std program is compiled once per process from the std directory's
//! `shaders.mdg` (so an installation's edited copy is honoured), or from the copy
//! built into this binary when there is no std directory.

use crate::Error;
use mdg_compiler::check::CheckOptions;
use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use mdg_compiler::source::FsLoader;
use mdg_vm::bundle::{Bundle, NONE};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The std library's shader file, built in as a fallback.
const STD_SHADERS: &str = include_str!("../../std/shaders.mdg");

/// Vertex and fragment SPIR-V, and where they came from (for messages).
#[derive(Clone, Debug, PartialEq)]
pub struct ProgramSpirv {
    pub vertex: Vec<u32>,
    pub fragment: Vec<u32>,
    /// e.g. `flat_vs + flat_fs` or `std phong_vs + phong_fs`.
    pub label: String,
}

/// Compiles std's `shaders.mdg` (from `std_dir` if given and present) and returns
/// its `program`'s shaders.
fn compile_std(std_dir: Option<&Path>) -> Result<ProgramSpirv, String> {
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
        return Err(mdg_compiler::diag::render_plain(&a.diagnostics, &a.sources));
    }
    let pick = |vertex: bool, name: &str| -> Option<Vec<u32>> {
        let i = a.expanded.shaders.iter().position(|s| s.vertex == vertex && s.name.text == name)?;
        a.spirv.get(i).cloned().flatten()
    };
    match (pick(true, "phong_vs"), pick(false, "phong_fs")) {
        (Some(vertex), Some(fragment)) => {
            Ok(ProgramSpirv { vertex, fragment, label: "std phong_vs + phong_fs".into() })
        }
        _ => Err("std/shaders.mdg has no phong_vs / phong_fs".into()),
    }
}

/// Compiled std programs by std directory.
type StdCache = std::sync::Mutex<Vec<(Option<PathBuf>, ProgramSpirv)>>;

/// The std Phong program (compiled once per process and std directory).
pub fn std_program(std_dir: Option<&Path>) -> Result<ProgramSpirv, Error> {
    static CACHE: OnceLock<StdCache> = OnceLock::new();
    let cache = CACHE.get_or_init(|| std::sync::Mutex::new(Vec::new()));
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

/// The program for `bundle`: its `program` directive's shaders, std Phong for the
/// rest.
pub fn for_bundle(bundle: &Bundle, std_dir: Option<&Path>) -> Result<ProgramSpirv, Error> {
    let (v, f) = match &bundle.program {
        Some(p) => (p.vertex, p.fragment),
        None => (NONE, NONE),
    };
    let shader = |i: u32| -> Result<Option<(String, Vec<u32>)>, Error> {
        if i == NONE {
            return Ok(None);
        }
        let sh = bundle
            .shaders
            .get(i as usize)
            .ok_or_else(|| Error::Other(format!("program names shader {i}, which is missing")))?;
        let name = bundle.string(sh.name).to_string();
        if sh.spirv.is_empty() {
            return Err(Error::Compile(format!(
                "shader `{name}` has no SPIR-V (the bundle was built without the shader stage)"
            )));
        }
        Ok(Some((name, sh.spirv.clone())))
    };
    let (vs, fs) = (shader(v)?, shader(f)?);
    if let (Some((vn, vertex)), Some((fname, fragment))) = (&vs, &fs) {
        return Ok(ProgramSpirv {
            vertex: vertex.clone(),
            fragment: fragment.clone(),
            label: format!("{vn} + {fname}"),
        });
    }
    let std = std_program(std_dir)?;
    let label = format!(
        "{} + {}",
        vs.as_ref().map(|(n, _)| n.clone()).unwrap_or_else(|| "std phong_vs".into()),
        fs.as_ref().map(|(n, _)| n.clone()).unwrap_or_else(|| "std phong_fs".into())
    );
    Ok(ProgramSpirv {
        vertex: vs.map(|(_, s)| s).unwrap_or(std.vertex),
        fragment: fs.map(|(_, s)| s).unwrap_or(std.fragment),
        label,
    })
}

/// Unlit shaders for pen lines: position and colour, nothing else.
const LINE_VS: &str = "#version 450
layout(location = 0) in vec3 in_position;
layout(location = 2) in vec4 in_color;
layout(set = 0, binding = 0) uniform Globals {
    mat4 projection;
    mat4 view;
    vec4 camera_pos;
    vec4 light_pos;
    vec4 spec_color_power;
} globals;
layout(location = 0) out vec4 v_color;
void main() {
    v_color = in_color;
    gl_Position = globals.projection * globals.view * vec4(in_position, 1.0);
}
";

const LINE_FS: &str = "#version 450
layout(location = 0) in vec4 v_color;
layout(location = 0) out vec4 out_color;
void main() {
    out_color = v_color;
}
";

/// The line program (compiled once per process).
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
