//! `mdg._native`: the native half of the Python package `mdg` (python/mdg/ is the
//! other half). It compiles grammars with the compiler crate, evaluates them with
//! the VM and hands the results to Python as numpy arrays that own the buffers Rust
//! filled (`PyArray::from_vec` then a reshape: no copy of the data).
//!
//! What Python sees (see python/mdg/_native.pyi and docs/python.md):
//! * [`compile`] → [`Program`], or `CompileError` carrying [`Diagnostic`]s;
//! * [`Program::run`] → [`Model`] (the evaluation; arrays are made on first access);
//! * [`generate`] → [`Generation`], an iterator over `(seed, Model)` that evaluates
//!   seeds on a pool of worker threads with the GIL released.
//!
//! Evaluation, compilation and writing release the GIL; the library prints nothing:
//! warnings go to Python's `warnings` module (category `mdg.MdgWarning`).

mod convert;

use convert::{cpus, flatten, instances, Expand, Flat};
use mdg_compiler::codes::Severity;
use mdg_compiler::diag::{render_plain, Diagnostic as Diag};
use mdg_compiler::driver;
use mdg_compiler::expand::Options;
use mdg_compiler::source::{FsLoader, MemLoader, Sources};
use mdg_export::{self as export, Format};
use mdg_vm::bundle::{Bundle, SectionKind};
use mdg_vm::eval::{evaluate, EvalOptions};
use mdg_vm::output::{Groups, Output, PackedFrame, FRAME_WORDS, TRANSLATION_AT};

use numpy::ndarray::{ArrayView1, ArrayView2, ShapeBuilder};
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::{PyException, PyOSError, PyTypeError, PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Duration;

pyo3::create_exception!(
    _native,
    CompileError,
    PyException,
    "A grammar did not compile; `.diagnostics` lists each error and warning (code, message, file, line, column)."
);
pyo3::create_exception!(_native, MdgWarning, PyUserWarning, "A warning from compiling or evaluating a grammar.");

/// One compiler diagnostic: an error, warning or note with its code and place.
#[pyclass(frozen, get_all, module = "mdg")]
#[derive(Clone, Debug)]
pub struct Diagnostic {
    /// `E0301`, `W0001`, … (docs/diagnostics.md).
    code: String,
    /// `"error"`, `"warning"` or `"note"`.
    severity: String,
    message: String,
    /// The file as diagnostics name it (the path, or the `name` given to `compile`).
    file: String,
    /// 1-based line and column (in characters) of the start of the span.
    line: u32,
    column: u32,
    /// 1-based line and column of the end of the span.
    end_line: u32,
    end_column: u32,
}

#[pymethods]
impl Diagnostic {
    fn __repr__(&self) -> String {
        format!(
            "Diagnostic(code={:?}, severity={:?}, message={:?}, file={:?}, line={}, column={})",
            self.code, self.severity, self.message, self.file, self.line, self.column
        )
    }

    fn __str__(&self) -> String {
        format!("{}:{}:{}: {}[{}]: {}", self.file, self.line, self.column, self.severity, self.code, self.message)
    }
}

/// 1-based line and character column of byte `offset` in file `f`.
fn line_col(sources: &Sources, file: u32, offset: u32) -> (String, u32, u32) {
    let Some(f) = sources.files.get(file as usize) else { return (String::new(), 0, 0) };
    let offset = offset.min(f.text.len() as u32);
    let (line, col) = f.line_col(offset);
    let start = f.line_start(line) as usize;
    let chars = f.text.get(start..start + col as usize).map_or(col as usize, |s| s.chars().count());
    (f.name.clone(), line + 1, chars as u32 + 1)
}

fn diagnostic(d: &Diag, sources: &Sources) -> Diagnostic {
    let (file, line, column) = line_col(sources, d.span.file.0, d.span.start);
    let (_, end_line, end_column) = line_col(sources, d.span.file.0, d.span.end);
    let severity = match d.severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Note => "note",
    };
    Diagnostic {
        code: d.code.to_string(),
        severity: severity.into(),
        message: d.message.clone(),
        file,
        line,
        column,
        end_line,
        end_column,
    }
}

/// Where a program came from, so that it can be compiled again with other params.
#[derive(Clone, Debug)]
enum Origin {
    /// Source text, named `path` in diagnostics (imports resolve beside it).
    Text {
        path: PathBuf,
        text: String,
    },
    File(PathBuf),
    /// A compiled bundle (`.mdgb`): params and presets are fixed.
    Bundle(PathBuf),
}

/// A compiled program and what the compilation said.
struct Compiled {
    bundle: Arc<Bundle>,
    warnings: Vec<Diagnostic>,
    presets: Vec<String>,
}

/// Why a compilation failed: the grammar's diagnostics, or a usage error.
enum Failed {
    Grammar { message: String, diagnostics: Vec<Diagnostic> },
    Usage(String),
    Io(String),
}

impl Failed {
    fn into_py(self, py: Python<'_>) -> PyErr {
        match self {
            Failed::Grammar { message, diagnostics } => {
                let err = CompileError::new_err(message);
                let list = diagnostics.into_iter().map(|d| Py::new(py, d)).collect::<PyResult<Vec<_>>>();
                match list {
                    Ok(list) => match err.value(py).setattr("diagnostics", list) {
                        Ok(()) => err,
                        Err(e) => e,
                    },
                    Err(e) => e,
                }
            }
            Failed::Usage(m) => PyValueError::new_err(m),
            Failed::Io(m) => PyOSError::new_err(m),
        }
    }
}

fn compile_origin(origin: &Origin, opts: &Options) -> Result<Compiled, Failed> {
    let built = match origin {
        Origin::Bundle(path) => {
            if let Some((n, _)) = opts.params.first() {
                return Err(Failed::Usage(format!(
                    "params: {} is a compiled bundle; `{n}` can only be set when compiling the source",
                    path.display()
                )));
            }
            if let Some(p) = opts.defines.first() {
                return Err(Failed::Usage(format!(
                    "presets: {} is a compiled bundle; preset `{p}` can only be chosen when compiling the source",
                    path.display()
                )));
            }
            let bytes = mdg_vm::input::read_bounded(path, mdg_vm::input::MAX_DATA_BYTES)
                .map_err(|e| Failed::Io(format!("cannot read {}: {e}", path.display())))?;
            let b = mdg_vm::bundle::load(&bytes).map_err(|e| Failed::Usage(format!("{}: {e}", path.display())))?;
            return Ok(Compiled { bundle: Arc::new(b), warnings: Vec::new(), presets: Vec::new() });
        }
        Origin::Text { path, text } => {
            let loader = MemLoader { files: [(path.clone(), text.clone())].into(), disk_fallback: true };
            driver::build(&loader, path, opts)
        }
        Origin::File(path) => {
            if !path.is_file() {
                return Err(Failed::Io(format!("cannot read {}: no such file", path.display())));
            }
            driver::build(&FsLoader, path, opts)
        }
    };
    match built {
        Ok((b, a)) => {
            if let Some((_, e)) =
                mdg_compiler::expand::unused_command_line(&a.expanded, &a.sources, opts).into_iter().next()
            {
                // The CLI's words name `--param`/`--preset`; here they are arguments.
                let e = e.replace("--param ", "params: ").replace("--preset ", "presets: ");
                return Err(Failed::Usage(e));
            }
            let warnings = a.diagnostics.iter().map(|d| diagnostic(d, &a.sources)).collect();
            let presets = a.expanded.presets.iter().map(|p| p.text.clone()).collect();
            Ok(Compiled { bundle: Arc::new(b), warnings, presets })
        }
        Err(a) => {
            let errors: Vec<Diag> = a.diagnostics.iter().filter(|d| d.is_error()).cloned().collect();
            let message = render_plain(&errors, &a.sources).trim_end().to_string();
            let diagnostics = a.diagnostics.iter().map(|d| diagnostic(d, &a.sources)).collect();
            Err(Failed::Grammar { message, diagnostics })
        }
    }
}

/// `params` as `(name, value)` strings, as `--param NAME=VALUE` takes them.
fn params_of(params: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut out = Vec::new();
    let Some(d) = params else { return Ok(out) };
    for (k, v) in d.iter() {
        let name: String = k.extract().map_err(|_| PyTypeError::new_err("params: names must be strings"))?;
        let value = if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
            if b.is_true() { "true" } else { "false" }.to_string()
        } else if let Ok(i) = v.extract::<i64>() {
            i.to_string()
        } else if let Ok(f) = v.extract::<f64>() {
            if !f.is_finite() {
                return Err(PyValueError::new_err(format!("params: {name}={f}: expected a finite number")));
            }
            format!("{f:?}")
        } else {
            return Err(PyTypeError::new_err(format!(
                "params: {name}: expected an int, float or bool, got {}",
                v.get_type().name()?
            )));
        };
        out.push((name, value));
    }
    out.sort();
    Ok(out)
}

fn presets_of(presets: Option<Vec<String>>) -> Vec<String> {
    let mut p = presets.unwrap_or_default();
    p.sort();
    p.dedup();
    p
}

/// Sends each warning to Python's `warnings` module as an `MdgWarning`.
fn warn_all<'a>(py: Python<'_>, warnings: impl IntoIterator<Item = &'a str>) -> PyResult<()> {
    let category = py.get_type::<MdgWarning>();
    for w in warnings {
        PyErr::warn(py, &category, &std::ffi::CString::new(w.replace('\0', " ")).unwrap_or_default(), 2)?;
    }
    Ok(())
}

/// Compiles a grammar into a [`Program`].
#[pyfunction]
#[pyo3(signature = (source, *, std = None, params = None, presets = None, name = None))]
fn compile(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    std: Option<PathBuf>,
    params: Option<&Bound<'_, PyDict>>,
    presets: Option<Vec<String>>,
    name: Option<String>,
) -> PyResult<Program> {
    let origin = if source.hasattr("__fspath__")? {
        let p: PathBuf = source.extract()?;
        origin_of_path(p)
    } else if let Ok(text) = source.extract::<String>() {
        let one_line = !text.contains('\n');
        if one_line && (text.ends_with(".mdg") || text.ends_with(".mdgb")) {
            origin_of_path(PathBuf::from(text))
        } else {
            Origin::Text { path: PathBuf::from(name.unwrap_or_else(|| "<source>.mdg".into())), text }
        }
    } else {
        return Err(PyTypeError::new_err(
            "compile: expected source text (str) or a path (str ending in .mdg/.mdgb, or os.PathLike)",
        ));
    };
    let std_dir = match std {
        Some(d) if !d.is_dir() => {
            return Err(PyValueError::new_err(format!("std={}: not a directory", d.display())));
        }
        Some(d) => Some(d),
        None => driver::default_std_dir(),
    };
    let opts = Options { defines: presets_of(presets), params: params_of(params)?, std_dir };
    let compiled = py.detach(|| compile_origin(&origin, &opts)).map_err(|f| f.into_py(py))?;
    let warnings: Vec<String> = compiled.warnings.iter().map(|d| d.__str__()).collect();
    warn_all(py, warnings.iter().map(String::as_str))?;
    Ok(Program { origin, opts, base: compiled, variant: Mutex::new(None) })
}

fn origin_of_path(p: PathBuf) -> Origin {
    if p.extension().is_some_and(|e| e == "mdgb") {
        Origin::Bundle(p)
    } else {
        Origin::File(p)
    }
}

/// Evaluation limits from a dict: `max_vertices`, `max_frames`, `max_iso_cells`,
/// `max_iter`, `max_stack` (integers), `time_budget` (seconds).
fn limits_of(limits: Option<&Bound<'_, PyDict>>, opts: &mut EvalOptions) -> PyResult<()> {
    let Some(d) = limits else { return Ok(()) };
    const KEYS: &str = "max_vertices, max_frames, max_iso_cells, max_iter, max_stack, time_budget";
    for (k, v) in d.iter() {
        let key: String = k.extract()?;
        let int = |v: &Bound<'_, PyAny>| -> PyResult<u64> {
            v.extract::<u64>().map_err(|_| PyValueError::new_err(format!("limits: {key}: expected an integer ≥ 0")))
        };
        match key.as_str() {
            "max_vertices" => opts.max_vertices = int(&v)?,
            "max_frames" => opts.max_frames = int(&v)?,
            "max_iso_cells" => opts.max_iso_cells = int(&v)?,
            "max_iter" => opts.max_iter = int(&v)?.max(1),
            "max_stack" => opts.max_stack = u32::try_from(int(&v)?).unwrap_or(u32::MAX).max(1),
            "time_budget" => {
                opts.time_budget = if v.is_none() {
                    None
                } else {
                    let s: f64 = v.extract()?;
                    if !(s.is_finite() && s > 0.0 && s <= 1e7) {
                        return Err(PyValueError::new_err(format!(
                            "limits: time_budget={s}: expected seconds, > 0 and at most 1e7 (or None)"
                        )));
                    }
                    Some(Duration::from_secs_f64(s))
                }
            }
            _ => return Err(PyValueError::new_err(format!("limits: unknown limit `{key}` (known: {KEYS})"))),
        }
    }
    Ok(())
}

/// The run mode a grammar's extension section asks for, which `Program.run` does not
/// evaluate (mdg-run does).
fn mode_error(b: &Bundle) -> Option<PyErr> {
    let (section, what, doc) = if b.extensions.has(SectionKind::Guided) {
        ("search", "guided search", "docs/guided.md")
    } else if b.extensions.has(SectionKind::Creatures) {
        ("creatures", "creature evolution", "docs/creatures.md")
    } else if b.extensions.has(SectionKind::Grid) {
        ("grid", "grid generation (voxels)", "docs/grid.md")
    } else {
        return None;
    };
    Some(PyValueError::new_err(format!(
        "the grammar has a `{section}` section ({what}): Program.run evaluates plain grammars into meshes; \
         run this one with mdg-run ({doc})"
    )))
}

/// A compiled grammar. Run it with [`Program::run`]; it can be run many times, from
/// several threads at once.
#[pyclass(frozen, module = "mdg")]
pub struct Program {
    origin: Origin,
    opts: Options,
    base: Compiled,
    /// The last program compiled for other params/presets, with them.
    variant: Mutex<Option<Variant>>,
}

/// A program compiled for other params and presets: the params, the presets, the bundle.
type Variant = (Vec<(String, String)>, Vec<String>, Arc<Bundle>);

/// One seed's evaluation in [`generate`]: the seed, the output, `mesh`'s buffers if
/// the workers made them.
type Evaluated = (u64, Output, Option<Flat>);

/// One seed's evaluation (written to its file if asked), or why not.
type SeedResult = Result<Evaluated, String>;

/// One evaluation's settings, resolved from Python arguments.
#[derive(Clone)]
struct RunSettings {
    eval: EvalOptions,
    time: Option<f64>,
}

fn settings(seed: Option<u64>, time: Option<f64>, limits: Option<&Bound<'_, PyDict>>) -> PyResult<RunSettings> {
    if let Some(t) = time {
        if !(t.is_finite() && t >= 0.0) {
            return Err(PyValueError::new_err(format!("time={t}: expected a number of seconds ≥ 0")));
        }
    }
    let mut eval = EvalOptions { seed, time, ..EvalOptions::default() };
    limits_of(limits, &mut eval)?;
    Ok(RunSettings { eval, time })
}

/// Evaluates `bundle` once (no GIL needed).
fn run_once(bundle: &Bundle, s: &RunSettings, seed: Option<u64>) -> Output {
    let opts = EvalOptions { seed, ..s.eval.clone() };
    let out = evaluate(bundle, &opts);
    match s.time {
        Some(t) => out.posed(t),
        None => out,
    }
}

impl Program {
    /// The bundle for `params`/`presets` (compiled again when they differ from the
    /// program's own; the last such variant is kept).
    fn bundle_for(
        &self,
        py: Python<'_>,
        params: Option<&Bound<'_, PyDict>>,
        presets: Option<Vec<String>>,
    ) -> PyResult<Arc<Bundle>> {
        if params.is_none() && presets.is_none() {
            return Ok(self.base.bundle.clone());
        }
        let mut p = self.opts.params.clone();
        for (k, v) in params_of(params)? {
            p.retain(|(n, _)| *n != k);
            p.push((k, v));
        }
        p.sort();
        let d = presets.map(|v| presets_of(Some(v))).unwrap_or_else(|| self.opts.defines.clone());
        if p == self.opts.params && d == self.opts.defines {
            return Ok(self.base.bundle.clone());
        }
        if let Ok(g) = self.variant.lock() {
            if let Some((vp, vd, b)) = g.as_ref() {
                if *vp == p && *vd == d {
                    return Ok(b.clone());
                }
            }
        }
        let opts = Options { params: p.clone(), defines: d.clone(), std_dir: self.opts.std_dir.clone() };
        let c = py.detach(|| compile_origin(&self.origin, &opts)).map_err(|f| f.into_py(py))?;
        if let Ok(mut g) = self.variant.lock() {
            *g = Some((p, d, c.bundle.clone()));
        }
        Ok(c.bundle)
    }
}

#[pymethods]
impl Program {
    /// Evaluates the program into a [`Model`].
    #[pyo3(signature = (*, seed = None, params = None, presets = None, time = None, limits = None))]
    fn run(
        &self,
        py: Python<'_>,
        seed: Option<u64>,
        params: Option<&Bound<'_, PyDict>>,
        presets: Option<Vec<String>>,
        time: Option<f64>,
        limits: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Model> {
        let bundle = self.bundle_for(py, params, presets)?;
        if let Some(e) = mode_error(&bundle) {
            return Err(e);
        }
        let s = settings(seed, time, limits)?;
        let out = py.detach(|| run_once(&bundle, &s, seed));
        warn_all(py, out.stats.warnings.iter().map(String::as_str))?;
        Ok(Model::new(out, seed))
    }

    /// The grammar's `@param` declarations: a list of dicts with `name`, `type`
    /// (`"int"`, `"float"`, `"bool"`), `value` (in force), `min` and `max` (None
    /// when unbounded).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let json = py.import("json")?;
        json.call_method1("loads", (self.base.bundle.params_json(),))
    }

    /// The presets the grammar declares with `@presets`.
    #[getter]
    fn presets(&self) -> Vec<String> {
        self.base.presets.clone()
    }

    /// The compiler's warnings (as [`Diagnostic`]s).
    #[getter]
    fn warnings(&self, py: Python<'_>) -> PyResult<Vec<Py<Diagnostic>>> {
        self.base.warnings.iter().map(|d| Py::new(py, d.clone())).collect()
    }

    /// The file the program was compiled from (None for source text).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        match &self.origin {
            Origin::Text { .. } => None,
            Origin::File(p) | Origin::Bundle(p) => Some(p.clone()),
        }
    }

    /// What running the grammar does: `"model"` (a mesh, what [`Program::run`]
    /// makes), or the mdg-run mode of its extension section: `"search"`,
    /// `"creatures"` or `"grid"`.
    #[getter]
    fn mode(&self) -> &'static str {
        let e = &self.base.bundle.extensions;
        if e.has(SectionKind::Guided) {
            "search"
        } else if e.has(SectionKind::Creatures) {
            "creatures"
        } else if e.has(SectionKind::Grid) {
            "grid"
        } else {
            "model"
        }
    }

    fn __repr__(&self) -> String {
        match &self.origin {
            Origin::Text { path, .. } => format!("<mdg.Program {}>", path.display()),
            Origin::File(p) | Origin::Bundle(p) => format!("<mdg.Program {}>", p.display()),
        }
    }
}

/// A flat triangle mesh as numpy arrays.
#[pyclass(frozen, get_all, module = "mdg")]
pub struct Mesh {
    /// (n, 3) float32.
    positions: Py<PyAny>,
    /// (n, 3) float32, unit length.
    normals: Py<PyAny>,
    /// (n, 4) float32 RGBA in 0..1 (for a prototype: the deltas its vertices add to
    /// the instance's colour, which may be negative).
    colors: Py<PyAny>,
    /// (m, 3) uint32, wound counter-clockwise seen from outside.
    triangles: Py<PyAny>,
    /// (n,) uint32 bone per vertex, or None for a model without bones.
    bones: Py<PyAny>,
}

#[pymethods]
impl Mesh {
    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let n = self.positions.bind(py).len()?;
        let m = self.triangles.bind(py).len()?;
        Ok(format!("<mdg.Mesh {n} vertices, {m} triangles>"))
    }
}

/// `v` (rows of `K` values) as an (n, K) array that owns `v`'s buffer.
fn rows<'py, T: numpy::Element, const K: usize>(py: Python<'py>, v: Vec<[T; K]>) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len();
    let flat = PyArray1::from_vec(py, v.into_flattened());
    Ok(flat.reshape([n, K])?.into_any())
}

fn mesh_py(py: Python<'_>, f: Flat) -> PyResult<Py<Mesh>> {
    let bones = if f.animated { PyArray1::from_vec(py, f.bones).into_any().unbind() } else { py.None() };
    Py::new(
        py,
        Mesh {
            positions: rows(py, f.positions)?.unbind(),
            normals: rows(py, f.normals)?.unbind(),
            colors: rows(py, f.colors)?.unbind(),
            triangles: rows(py, f.triangles)?.unbind(),
            bones,
        },
    )
}

/// Prototype instances: the prototypes' meshes and, per instance, which prototype
/// and how it is placed.
#[pyclass(frozen, get_all, module = "mdg")]
pub struct Instances {
    /// The prototype meshes, in their own space (colours are deltas).
    prototypes: Vec<Py<Mesh>>,
    /// The prototypes' rule names, aligned with `prototypes`.
    names: Vec<String>,
    /// (k,) uint32: index into `prototypes`.
    prototype: Py<PyAny>,
    /// (k, 3) float32.
    translation: Py<PyAny>,
    /// (k, 4) float32 unit quaternion (w, x, y, z).
    rotation: Py<PyAny>,
    /// (k, 3) float32 per-axis scale (x negative for a mirrored instance).
    scale: Py<PyAny>,
    /// (k, 4) float32 RGBA in 0..1.
    color: Py<PyAny>,
    /// (k,) uint32 bone of each instance.
    bone: Py<PyAny>,
}

#[pymethods]
impl Instances {
    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        self.prototype.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("<mdg.Instances {} of {} prototypes>", self.__len__(py)?, self.prototypes.len()))
    }
}

/// The owner of an evaluation's output that read-only numpy views of its instance
/// records ([`record_view`]) hold as their base. Not the [`Model`]: the Model holds
/// the [`Instances`] that hold the views, a cycle Python's collector would not see.
#[pyclass(frozen, module = "mdg")]
struct Records {
    out: Arc<Output>,
}

/// A field of [`Instance`] that `Instances` shows from the records themselves.
#[derive(Clone, Copy, Debug)]
enum Field {
    /// `mesh` (u32): the prototype index, where every shared mesh is a prototype.
    Prototype,
    /// `frame.u` (3 × f32).
    Translation,
    /// `color` (4 × f32).
    Color,
    /// `bone` (u32).
    Bone,
}

// The views' strides are whole elements of 4 bytes: a packed frame is `f32`s.
const _: () = {
    assert!(size_of::<PackedFrame>() == 4 * FRAME_WORDS && align_of::<PackedFrame>() == 4);
    assert!(size_of::<f32>() == 4 && size_of::<u32>() == 4 && TRANSLATION_AT + 3 <= FRAME_WORDS);
};

/// Column `field` of every instance of `owner`'s [`Output::instances`] as a read-only
/// numpy array, (n,) uint32 or (n, K) float32, over the records themselves, with
/// `owner` as its base: the translations over the packed frames (a row stride of
/// [`FRAME_WORDS`] `f32`s, 44 bytes); a colour, prototype or bone that every
/// instance shares as that one value repeated (a row stride of 0). `None` where the
/// instances do not share it (the caller copies the column). At least one record.
#[allow(unsafe_code)]
fn record_view<'py>(owner: &Bound<'py, Records>, field: Field) -> PyResult<Option<Bound<'py, PyAny>>> {
    let records = &owner.get().out.instances;
    let n = records.len();
    if n == 0 {
        return Err(PyValueError::new_err("internal: a view of no instance records"));
    }
    let (start, stride, k): (*const u8, usize, usize) = match field {
        Field::Translation => {
            let frames = records.packed_frames();
            (frames.as_ptr().cast::<f32>().wrapping_add(TRANSLATION_AT).cast(), FRAME_WORDS, 3)
        }
        Field::Prototype => match records.uniform_mesh() {
            Some(v) => (std::ptr::from_ref(v).cast(), 0, 0),
            None => return Ok(None),
        },
        Field::Color => match records.uniform_color() {
            Some(v) => (v.as_ptr().cast(), 0, 4),
            None => return Ok(None),
        },
        Field::Bone => match records.uniform_bone() {
            Some(v) => (std::ptr::from_ref(v).cast(), 0, 0),
            None => return Ok(None),
        },
    };
    let base = owner.clone().into_any();
    // SAFETY: for the translations, the view reads, for each of the n packed frames
    // (`[f32; FRAME_WORDS]`, 4-aligned, contiguous in one `Vec`), the three `f32`s
    // from `TRANSLATION_AT` on (asserted inside the frame): aligned, within the one
    // allocation. For a shared value, every row reads the same `max(k, 1)` 4-byte
    // values of one run-table entry (a `u32` or `[f32; 4]`, aligned) with a row
    // stride of 0. Both live in a `Vec` inside an `Arc<Output>` that `owner` holds:
    // the array keeps `owner` alive as its base, so the buffer outlives the array;
    // nothing mutates or reallocates it (an `Output` behind an `Arc` is never
    // changed: no `get_mut`/`make_mut` in this crate, and `Records` is frozen),
    // and the array is made read-only before Python sees it, so numpy never
    // writes it either.
    let array = unsafe {
        if k == 0 {
            let view = ArrayView1::from_shape_ptr([n].strides([stride]), start.cast::<u32>());
            PyArray1::borrow_from_array(&view, base).into_any()
        } else {
            let view = ArrayView2::from_shape_ptr([n, k].strides([stride, 1]), start.cast::<f32>());
            PyArray2::borrow_from_array(&view, base).into_any()
        }
    };
    array.getattr("flags")?.setattr("writeable", false)?;
    Ok(Some(array))
}

/// One evaluation's result. Its arrays are made on first access and kept.
#[pyclass(frozen, module = "mdg")]
pub struct Model {
    out: Arc<Output>,
    seed: Option<u64>,
    mesh: OnceLock<Py<Mesh>>,
    vertex_mesh: OnceLock<Py<Mesh>>,
    base_mesh: OnceLock<Py<Mesh>>,
    instances: OnceLock<Py<Instances>>,
    /// The prototype instances `instances` cannot place (the base mesh expands them).
    unplaced: OnceLock<Vec<u32>>,
    /// `mesh`'s buffers made ahead (by [`generate`]'s workers), taken on first access.
    flat: Mutex<Option<Flat>>,
}

impl Model {
    fn new(out: Output, seed: Option<u64>) -> Model {
        Model::with_flat(out, seed, None)
    }

    fn with_flat(out: Output, seed: Option<u64>, flat: Option<Flat>) -> Model {
        Model {
            out: Arc::new(out),
            seed,
            mesh: OnceLock::new(),
            vertex_mesh: OnceLock::new(),
            base_mesh: OnceLock::new(),
            instances: OnceLock::new(),
            unplaced: OnceLock::new(),
            flat: Mutex::new(flat),
        }
    }

    fn cached<T: pyo3::PyClass>(
        py: Python<'_>,
        cell: &OnceLock<Py<T>>,
        make: impl FnOnce() -> PyResult<Py<T>>,
    ) -> PyResult<Py<T>> {
        if let Some(v) = cell.get() {
            return Ok(v.clone_ref(py));
        }
        let v = make()?;
        Ok(cell.get_or_init(|| v).clone_ref(py))
    }
}

/// A 4×4 row-major matrix of a frame (translation in the last column).
fn matrix(f: &mdg_vm::geom::quat::Frame) -> [[f32; 4]; 4] {
    let m = f.to_mat4().transpose().to_cols_array();
    [[m[0], m[1], m[2], m[3]], [m[4], m[5], m[6], m[7]], [m[8], m[9], m[10], m[11]], [m[12], m[13], m[14], m[15]]]
}

#[pymethods]
impl Model {
    /// All geometry as one mesh in world space, every instance expanded: what
    /// `.obj`, `.ply` and `.stl` hold (`VERTEX` triangles with prototype instances
    /// where they were made, then sweeps, then isosurfaces).
    #[getter]
    fn mesh(&self, py: Python<'_>) -> PyResult<Py<Mesh>> {
        Model::cached(py, &self.mesh, || {
            let ready = self.flat.lock().ok().and_then(|mut f| f.take());
            let out = self.out.clone();
            mesh_py(
                py,
                ready.unwrap_or_else(|| py.detach(|| flatten(&out, Groups::ALL, Expand::Where(|_| true), cpus()))),
            )
        })
    }

    /// The `VERTEX` triangles only (prototype instances expanded): what the JSON
    /// dump's `vertices` and `triangles` hold.
    #[getter]
    fn vertex_mesh(&self, py: Python<'_>) -> PyResult<Py<Mesh>> {
        Model::cached(py, &self.vertex_mesh, || {
            let out = self.out.clone();
            mesh_py(py, py.detach(|| flatten(&out, Groups::VERTEX, Expand::Where(|_| true), cpus())))
        })
    }

    /// All geometry except the prototype instances listed in `instances`: with
    /// them, the whole model without expanding a copy per instance.
    #[getter]
    fn base_mesh(&self, py: Python<'_>) -> PyResult<Py<Mesh>> {
        Model::cached(py, &self.base_mesh, || {
            let out = self.out.clone();
            let flat = py.detach(|| {
                let unplaced = self.unplaced.get_or_init(|| convert::unplaced(&out, cpus()));
                // Every isosurface, and the prototype instances that are not placed.
                let expand = |i: usize| {
                    out.instances.get(i).is_none_or(|inst| !out.is_prototype_instance(&inst))
                        || unplaced.binary_search(&(i as u32)).is_ok()
                };
                let expand = if unplaced.is_empty() { Expand::NoPrototypes(expand) } else { Expand::Where(expand) };
                flatten(&out, Groups::ALL, expand, cpus())
            });
            mesh_py(py, flat)
        })
    }

    /// Prototype instances (see `Instances`); the rest of the model is `base_mesh`.
    #[getter]
    fn instances(&self, py: Python<'_>) -> PyResult<Py<Instances>> {
        Model::cached(py, &self.instances, || {
            let out = self.out.clone();
            let mut i = py.detach(|| instances(&out, cpus()));
            let _ = self.unplaced.set(std::mem::take(&mut i.unplaced));
            let prototypes = i.prototypes.into_iter().map(|f| mesh_py(py, f)).collect::<PyResult<Vec<_>>>()?;
            // The rows the records hold as they are: read-only views of them, kept
            // alive by an owner of the output (not the Model: it holds the arrays).
            let records = Bound::new(py, Records { out: out.clone() })?;
            let read_only = |a: Bound<'_, PyAny>| -> PyResult<Py<PyAny>> {
                a.getattr("flags")?.setattr("writeable", false)?;
                Ok(a.unbind())
            };
            // A view of the records, or (a value the instances do not share) a copy.
            let column = |field: Field| -> PyResult<Py<PyAny>> {
                if let Some(a) = record_view(&records, field)? {
                    return Ok(a.unbind());
                }
                let all = &out.instances;
                match field {
                    Field::Prototype => {
                        read_only(PyArray1::from_vec(py, all.iter().map(|i| i.mesh).collect()).into_any())
                    }
                    Field::Bone => read_only(PyArray1::from_vec(py, all.iter().map(|i| i.bone).collect()).into_any()),
                    Field::Color => read_only(rows(py, all.iter().map(|i| i.color).collect())?),
                    Field::Translation => read_only(rows(py, all.iter().map(|i| i.frame.u.to_array()).collect())?),
                }
            };
            Py::new(
                py,
                Instances {
                    prototypes,
                    names: i.names,
                    prototype: match i.prototype {
                        Some(v) => read_only(PyArray1::from_vec(py, v).into_any())?,
                        None => column(Field::Prototype)?,
                    },
                    translation: match i.translation {
                        Some(v) => read_only(rows(py, v)?)?,
                        None => column(Field::Translation)?,
                    },
                    rotation: rows(py, i.rotation)?.unbind(),
                    scale: rows(py, i.scale)?.unbind(),
                    color: match i.color {
                        Some(v) => read_only(rows(py, v)?)?,
                        None => column(Field::Color)?,
                    },
                    bone: match i.bone {
                        Some(v) => read_only(PyArray1::from_vec(py, v).into_any())?,
                        None => column(Field::Bone)?,
                    },
                },
            )
        })
    }

    /// Shortcuts for `mesh.positions`, `mesh.normals`, `mesh.colors`, `mesh.triangles`.
    #[getter]
    fn positions(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(self.mesh(py)?.get().positions.clone_ref(py))
    }
    #[getter]
    fn normals(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(self.mesh(py)?.get().normals.clone_ref(py))
    }
    #[getter]
    fn colors(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(self.mesh(py)?.get().colors.clone_ref(py))
    }
    #[getter]
    fn triangles(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        Ok(self.mesh(py)?.get().triangles.clone_ref(py))
    }

    /// Pen lines: one (n, 3) float32 array of points per line.
    #[getter]
    fn lines<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyAny>>> {
        self.out.lines.iter().map(|l| rows(py, l.points.iter().map(|p| convert::finite3(*p)).collect())).collect()
    }

    /// The namespace of each pen line.
    #[getter]
    fn line_namespaces(&self) -> Vec<String> {
        self.out.lines.iter().map(|l| l.namespace.clone()).collect()
    }

    /// Isosurface placements as the JSON dump lists them: dicts with `name`,
    /// `position` and `scale` (their geometry is in `mesh` and `base_mesh`).
    #[getter]
    fn isosurfaces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for i in &self.out.instances {
            let Some(s) = self.out.shared(&i).filter(|s| !s.is_prototype()) else { continue };
            let d = PyDict::new(py);
            d.set_item("name", &s.name)?;
            d.set_item("position", convert::finite3(self.out.instance_transform(&i).w_axis.truncate().to_array()))?;
            d.set_item("scale", convert::finite(self.out.instance_scale(&i)))?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// The run's counters: `rule_calls`, `vertices`, `triangles`, `max_depth`,
    /// `elapsed_ms` and `warnings`.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.out.stats;
        let d = PyDict::new(py);
        d.set_item("rule_calls", s.rule_calls)?;
        d.set_item("vertices", s.vertices)?;
        d.set_item("triangles", s.triangles)?;
        d.set_item("max_depth", s.max_depth)?;
        d.set_item("elapsed_ms", s.elapsed_ms)?;
        d.set_item("warnings", s.warnings.clone())?;
        Ok(d)
    }

    /// The limits that ended branches or the run, and other warnings of the run.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.out.stats.warnings.clone()
    }

    /// What `DEBUG {}` items reported.
    #[getter]
    fn debug(&self) -> Vec<String> {
        self.out.debug.clone()
    }

    /// The grammar's `background` colour (RGBA).
    #[getter]
    fn background(&self) -> [f32; 4] {
        self.out.background
    }

    /// The seed the model was run with (None: the grammar's `randseed`).
    #[getter]
    fn seed(&self) -> Option<u64> {
        self.seed
    }

    /// `duration` in seconds of an animated grammar (0 for a static one).
    #[getter]
    fn duration(&self) -> f32 {
        self.out.animation.duration
    }

    /// Bones of an animated grammar (empty for a static one): dicts with `rule`,
    /// `parent` (index), `rest` (4×4 world matrix), `fps` and `tracks` (indices into
    /// `tracks`). Bone 0 is the root. Vertices name their bone in `Mesh.bones`.
    #[getter]
    fn bones<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for b in &self.out.animation.bones {
            let d = PyDict::new(py);
            d.set_item("rule", &b.rule)?;
            d.set_item("parent", b.parent)?;
            d.set_item("rest", rows(py, matrix(&b.rest).to_vec())?)?;
            d.set_item("fps", b.fps)?;
            d.set_item("tracks", b.tracks.clone())?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// Animation tracks: dicts with `rule`, `complete` (the rule ended by itself)
    /// and `frames`, an (n, 4, 4) float32 array of row-major matrices.
    #[getter]
    fn tracks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for t in &self.out.animation.tracks {
            let d = PyDict::new(py);
            d.set_item("rule", &t.rule)?;
            d.set_item("complete", t.complete)?;
            let n = t.frames.len();
            let flat: Vec<f32> = t.frames.iter().flat_map(|f| matrix(f).into_iter().flatten()).collect();
            d.set_item("frames", PyArray1::from_vec(py, flat).reshape([n, 4, 4])?)?;
            list.append(d)?;
        }
        Ok(list)
    }

    /// The world transform of every bone at `time` seconds: an (n, 4, 4) float32
    /// array of row-major matrices, aligned with `bones` (bone 0, the root, is the
    /// identity). A vertex of bone b at rest position v is at `pose[b] @ (v, 1)`:
    /// what `pose(time)` does to every vertex.
    fn bone_pose<'py>(&self, py: Python<'py>, time: f64) -> PyResult<Bound<'py, PyAny>> {
        if !(time.is_finite() && time >= 0.0) {
            return Err(PyValueError::new_err(format!("bone_pose: time={time}: expected a number of seconds ≥ 0")));
        }
        let pose = self.out.animation.pose(time);
        let n = pose.len();
        let flat: Vec<f32> = pose.iter().flat_map(|f| matrix(f).into_iter().flatten()).collect();
        Ok(PyArray1::from_vec(py, flat).reshape([n, 4, 4])?.into_any())
    }

    /// The `camerarule` camera, or None: a dict with `fov` (the vertical field of
    /// view in degrees), `near` and `far` (the clipping planes) and `fps` (its
    /// frames per second), as mdg-run's pictures use them (`fov` within 1..170,
    /// `near` ≥ 0.0001, `far` ≥ 2·`near`). Where it is: [`Model::camera_pose`].
    #[getter]
    fn camera<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(cam) = &self.out.animation.camera else { return Ok(None) };
        let (fov, near, far) = picture_lens(cam);
        let d = PyDict::new(py);
        d.set_item("fov", fov)?;
        d.set_item("near", near)?;
        d.set_item("far", far)?;
        d.set_item("fps", cam.fps)?;
        Ok(Some(d))
    }

    /// Where the `camerarule` camera is at `time` seconds, as mdg-run's picture
    /// places it: `(translation, rotation)`, a (3,) float32 position and a (4,)
    /// float32 unit quaternion (w, x, y, z). The camera looks along its own −z axis
    /// with +y up (Blender's and OpenGL's convention). None without a camera.
    fn camera_pose<'py>(&self, py: Python<'py>, time: f64) -> PyResult<Option<(Bound<'py, PyAny>, Bound<'py, PyAny>)>> {
        if !(time.is_finite() && time >= 0.0) {
            return Err(PyValueError::new_err(format!("camera_pose: time={time}: expected a number of seconds ≥ 0")));
        }
        let Some(f) = self.out.animation.camera_at(time) else { return Ok(None) };
        let (t, r, _) = mdg_vm::anim::trs(&f);
        let r = if r.is_finite() { [r.w, r.x, r.y, r.z] } else { [1.0, 0.0, 0.0, 0.0] };
        let t = convert::finite3(t.to_array());
        Ok(Some((PyArray1::from_vec(py, t.to_vec()).into_any(), PyArray1::from_vec(py, r.to_vec()).into_any())))
    }

    /// The model posed at `time` seconds (every bone moved by its tracks), as
    /// `mdg-run --time` writes it.
    fn pose(&self, py: Python<'_>, time: f64) -> PyResult<Model> {
        if !(time.is_finite() && time >= 0.0) {
            return Err(PyValueError::new_err(format!("pose: time={time}: expected a number of seconds ≥ 0")));
        }
        let out = self.out.clone();
        Ok(Model::new(py.detach(|| out.posed(time)), self.seed))
    }

    /// Writes the model in the format of `path`'s extension (or `format`): glb,
    /// obj, stl, ply or json, byte for byte as `mdg-run` writes them. `instances`:
    /// glb with `EXT_mesh_gpu_instancing` (as `mdg-run --instances`).
    #[pyo3(signature = (path, *, format = None, instances = false))]
    fn write(&self, py: Python<'_>, path: PathBuf, format: Option<String>, instances: bool) -> PyResult<()> {
        let f = match &format {
            Some(f) => Format::from_extension(f)
                .ok_or_else(|| PyValueError::new_err(format!("format={f:?}: expected glb, obj, stl, ply or json")))?,
            None => Format::from_path(&path).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{}: cannot tell the format from the extension; name the file .glb, .obj, .stl, .ply or .json, or pass format=",
                    path.display()
                ))
            })?,
        };
        if instances && f != Format::Glb {
            warn_all(py, [format!("instances=True is for .glb; {} expands every instance", f.extension()).as_str()])?;
        }
        let out = self.out.clone();
        let glb = export::glb::GlbOptions { instances };
        py.detach(|| write_model(&out, f, &glb, &path)).map_err(PyOSError::new_err)
    }

    /// The model as a `trimesh.Trimesh` (vertex colours and normals kept, no
    /// processing); needs `trimesh` installed. Pen lines are not part of it (a
    /// warning says so; `lines` has them).
    fn to_trimesh(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let trimesh = py.import("trimesh").map_err(|e| {
            pyo3::exceptions::PyImportError::new_err(format!(
                "Model.to_trimesh needs the trimesh package (pip install trimesh): {e}"
            ))
        })?;
        if !self.out.lines.is_empty() {
            let n = self.out.lines.len();
            warn_all(
                py,
                [format!("to_trimesh: the model's {n} pen lines are not in the Trimesh (Model.lines has them)")
                    .as_str()],
            )?;
        }
        let mesh = self.mesh(py)?;
        let m = mesh.get();
        let kwargs = PyDict::new(py);
        kwargs.set_item("vertices", m.positions.bind(py))?;
        kwargs.set_item("faces", m.triangles.bind(py))?;
        kwargs.set_item("vertex_normals", m.normals.bind(py))?;
        kwargs.set_item("vertex_colors", m.colors.bind(py))?;
        kwargs.set_item("process", false)?;
        Ok(trimesh.getattr("Trimesh")?.call((), Some(&kwargs))?.unbind())
    }

    fn __repr__(&self) -> String {
        let (v, t) = self.out.flat_counts(Groups::ALL);
        format!(
            "<mdg.Model {v} vertices, {t} triangles, {} instances, {} lines>",
            self.out.instances.len(),
            self.out.lines.len()
        )
    }
}

/// The vertical field of view (degrees) and the clipping planes of a `camerarule`
/// camera as mdg-run's pictures use them (the viewer's `view_projection`).
fn picture_lens(cam: &mdg_vm::output::Camera) -> (f32, f32, f32) {
    let near = cam.near.max(1e-4);
    // (A field of view that is not a number: the .glb's 40°.)
    let fov = if cam.fov.is_finite() { cam.fov.clamp(1.0, 170.0) } else { 40.0 };
    (fov, near, cam.far.max(near * 2.0))
}

/// Writes `out` to `path` (creating its folder).
fn write_model(out: &Output, f: Format, glb: &export::glb::GlbOptions, path: &Path) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty() && !d.exists()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    export::write_file_with(f, out, glb, path).map_err(|e| e.to_string())
}

/// Iterator over `(seed, Model)` for [`generate`]: a pool of worker threads
/// evaluates the seeds (no GIL) up to a window of `4 × workers` seeds ahead of the
/// one Python is reading, and the models are yielded in the order of `seeds`. The
/// workers keep going while Python reads (no worker waits for the slowest seed of a
/// batch); dropping the iterator stops them after their current seed.
#[pyclass(module = "mdg")]
pub struct Generation {
    pool: Arc<Pool>,
    seeds: usize,
}

/// What the workers of a [`Generation`] share.
struct Pool {
    bundle: Arc<Bundle>,
    settings: RunSettings,
    seeds: Vec<u64>,
    write: Option<(String, Option<Format>)>,
    /// Make each model's `mesh` on the workers too.
    mesh: bool,
    /// How many seeds past the next one to hand over a worker may start.
    window: usize,
    state: Mutex<PoolState>,
    changed: std::sync::Condvar,
}

#[derive(Default)]
struct PoolState {
    /// The index (into `seeds`) of the next seed to start.
    started: usize,
    /// How many results were handed over (the next to hand over is this index).
    taken: usize,
    done: std::collections::BTreeMap<usize, SeedResult>,
    stop: bool,
}

impl Pool {
    /// A worker: evaluates the next seed until there is none, or it is stopped.
    fn work(&self) {
        loop {
            let i = {
                let Ok(mut st) = self.state.lock() else { return };
                while !st.stop && st.started < self.seeds.len() && st.started >= st.taken + self.window {
                    st = match self.changed.wait(st) {
                        Ok(g) => g,
                        Err(_) => return,
                    };
                }
                if st.stop || st.started >= self.seeds.len() {
                    return;
                }
                st.started += 1;
                st.started - 1
            };
            let seed = self.seeds[i];
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.evaluate(seed)))
                .unwrap_or_else(|_| Err(format!("seed {seed}: the evaluation failed (a bug: please report it)")));
            let Ok(mut st) = self.state.lock() else { return };
            st.done.insert(i, r);
            self.changed.notify_all();
        }
    }

    /// One seed: evaluated, flattened if asked, written if asked.
    fn evaluate(&self, seed: u64) -> SeedResult {
        let out = run_once(&self.bundle, &self.settings, Some(seed));
        // One thread per seed: the pool's workers already keep the CPUs busy.
        let flat = self.mesh.then(|| flatten(&out, Groups::ALL, Expand::Where(|_| true), 1));
        match &self.write {
            Some((template, format)) => {
                let path = seed_path(template, seed);
                let f = format.or_else(|| Format::from_path(&path)).unwrap_or(Format::Glb);
                write_model(&out, f, &export::glb::GlbOptions::default(), &path).map(|()| (seed, out, flat))
            }
            None => Ok((seed, out, flat)),
        }
    }

    /// Waits for the next result in order (None when all were handed over).
    fn next(&self) -> Option<SeedResult> {
        let mut st = self.state.lock().ok()?;
        if st.taken >= self.seeds.len() {
            return None;
        }
        loop {
            let k = st.taken;
            if let Some(r) = st.done.remove(&k) {
                st.taken += 1;
                self.changed.notify_all();
                return Some(r);
            }
            st = self.changed.wait(st).ok()?;
        }
    }
}

impl Drop for Generation {
    fn drop(&mut self) {
        if let Ok(mut st) = self.pool.state.lock() {
            st.stop = true;
        }
        self.pool.changed.notify_all();
    }
}

#[pymethods]
impl Generation {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __len__(&self) -> usize {
        self.seeds
    }

    fn __next__(&mut self, py: Python<'_>) -> PyResult<Option<(u64, Model)>> {
        let pool = self.pool.clone();
        match py.detach(|| pool.next()) {
            None => Ok(None),
            Some(Err(e)) => Err(PyOSError::new_err(e)),
            Some(Ok((seed, out, flat))) => {
                warn_all(py, out.stats.warnings.iter().map(|w| w.as_str()))?;
                Ok(Some((seed, Model::with_flat(out, Some(seed), flat))))
            }
        }
    }
}

/// The file for `seed` of a `{seed}` template.
fn seed_path(template: &str, seed: u64) -> PathBuf {
    PathBuf::from(template.replace("{seed}", &seed.to_string()))
}

/// Runs `program` for every seed of `seeds` on `workers` threads.
#[pyfunction]
#[pyo3(signature = (program, seeds, *, workers = None, params = None, presets = None, time = None, limits = None, write = None, format = None, mesh = true))]
#[allow(clippy::too_many_arguments)]
fn generate(
    py: Python<'_>,
    program: &Program,
    seeds: &Bound<'_, PyAny>,
    workers: Option<usize>,
    params: Option<&Bound<'_, PyDict>>,
    presets: Option<Vec<String>>,
    time: Option<f64>,
    limits: Option<&Bound<'_, PyDict>>,
    write: Option<String>,
    format: Option<String>,
    mesh: bool,
) -> PyResult<Generation> {
    let seeds: Vec<u64> = seeds
        .try_iter()?
        .map(|s| s.and_then(|s| s.extract::<u64>()))
        .collect::<PyResult<_>>()
        .map_err(|_| PyTypeError::new_err("generate: seeds must be integers ≥ 0 (e.g. range(1000))"))?;
    let workers = match workers {
        Some(0) => return Err(PyValueError::new_err("generate: workers=0: expected at least 1")),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let bundle = program.bundle_for(py, params, presets)?;
    if let Some(e) = mode_error(&bundle) {
        return Err(e);
    }
    let settings = settings(None, time, limits)?;
    let write = match write {
        Some(t) => {
            if !t.contains("{seed}") && seeds.len() > 1 {
                return Err(PyValueError::new_err(format!(
                    "generate: write={t:?} must hold `{{seed}}` (e.g. \"out/{{seed}}.glb\"): every seed writes a file"
                )));
            }
            let f = match &format {
                Some(f) => Some(Format::from_extension(f).ok_or_else(|| {
                    PyValueError::new_err(format!("format={f:?}: expected glb, obj, stl, ply or json"))
                })?),
                None => {
                    if Format::from_path(Path::new(&t)).is_none() {
                        return Err(PyValueError::new_err(format!(
                            "generate: write={t:?}: cannot tell the format from the extension; name the files .glb, .obj, .stl, .ply or .json, or pass format="
                        )));
                    }
                    None
                }
            };
            Some((t, f))
        }
        None => None,
    };
    let n = seeds.len();
    let pool = Arc::new(Pool {
        bundle,
        settings,
        seeds,
        write,
        mesh,
        window: 4 * workers,
        state: Mutex::new(PoolState::default()),
        changed: std::sync::Condvar::new(),
    });
    // The Generation stops the workers when it is dropped, also on an error here.
    let generation = Generation { pool: pool.clone(), seeds: n };
    for _ in 0..workers.min(n) {
        let p = pool.clone();
        std::thread::Builder::new()
            .name("mdg-generate".into())
            .spawn(move || p.work())
            .map_err(|e| PyOSError::new_err(format!("generate: cannot start a worker thread: {e}")))?;
    }
    Ok(generation)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add_function(wrap_pyfunction!(compile, m)?)?;
    m.add_function(wrap_pyfunction!(generate, m)?)?;
    m.add_class::<Program>()?;
    m.add_class::<Model>()?;
    m.add_class::<Mesh>()?;
    m.add_class::<Instances>()?;
    m.add_class::<Diagnostic>()?;
    m.add_class::<Generation>()?;
    m.add("CompileError", py.get_type::<CompileError>())?;
    m.add("MdgWarning", py.get_type::<MdgWarning>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
