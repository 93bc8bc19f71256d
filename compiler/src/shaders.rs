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
//! are cached by (stage, source), so re-analysing an edited file recompiles only the
//! blocks that changed.

use crate::diag::Diagnostic;
use crate::expand::{Expanded, Shader};
use crate::source::Sources;
use crate::span::Span;
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

/// One GLSL error as glslang reports it, positions relative to the shader source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GlslError {
    /// 1-based line in the shader source, when glslang gives one.
    pub line: Option<u32>,
    /// 1-based column, when glslang gives one.
    pub column: Option<u32>,
    pub message: String,
}

/// The result of compiling one shader source.
pub type CompileResult = Result<Vec<u32>, Vec<GlslError>>;

/// Most cached results kept; the cache is emptied when it grows past this (an
/// editor session produces one entry per edited version of a block).
const CACHE_LIMIT: usize = 256;

fn cache() -> &'static Mutex<HashMap<(bool, String), CompileResult>> {
    static CACHE: OnceLock<Mutex<HashMap<(bool, String), CompileResult>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Compiles one GLSL source for the vertex (`vertex = true`) or fragment stage.
///
/// Compilations are serialised through the cache's lock: glslang's process-wide
/// state is initialised once, and one compile takes a few milliseconds.
pub fn compile_glsl(source: &str, vertex: bool) -> CompileResult {
    let key = (vertex, source.to_string());
    let mut cache = match cache().lock() {
        Ok(c) => c,
        // A panic while holding the lock leaves only a possibly partial map of
        // finished results behind; start afresh.
        Err(poisoned) => {
            let mut c = poisoned.into_inner();
            c.clear();
            c
        }
    };
    if let Some(r) = cache.get(&key) {
        return r.clone();
    }
    let result = compile_uncached(source, vertex);
    if cache.len() >= CACHE_LIMIT {
        cache.clear();
    }
    cache.insert(key, result.clone());
    result
}

fn compile_uncached(source: &str, vertex: bool) -> CompileResult {
    use glslang::{Compiler, CompilerOptions, ShaderInput, ShaderMessage, ShaderSource, ShaderStage};
    // glslang takes a C string: a NUL inside the block cannot be passed on (and would
    // make the crate's conversion panic), so report it here.
    if let Some(at) = source.find('\0') {
        let (line, column) = line_col(source, at);
        return Err(vec![GlslError {
            line: Some(line),
            column: Some(column),
            message: "NUL character in shader source".into(),
        }]);
    }
    // Without a `#version` line glslang assumes ES 1.00 and says so obscurely.
    if !source.lines().any(|l| l.trim_start().starts_with("#version")) {
        return Err(vec![GlslError {
            line: None,
            column: None,
            message: "no `#version` line: Vulkan GLSL shaders start with `#version 450`".into(),
        }]);
    }
    // The glslang crate slices the `#version` line by bytes and panics inside a
    // multi-byte character: refuse a non-ASCII one here.
    if let Some(i) = source.lines().position(|l| l.trim_start().starts_with("#version") && !l.is_ascii()) {
        return Err(vec![GlslError {
            line: Some(i as u32 + 1),
            column: None,
            message: "the `#version` line must be plain ASCII, like `#version 450`".into(),
        }]);
    }
    let Some(compiler) = Compiler::acquire() else {
        return Err(vec![GlslError { line: None, column: None, message: "glslang could not be initialised".into() }]);
    };
    let stage = if vertex { ShaderStage::Vertex } else { ShaderStage::Fragment };
    let src = ShaderSource::from(source);
    let options = CompilerOptions { messages: ShaderMessage::DISPLAY_ERROR_COLUMN, ..CompilerOptions::default() };
    let input = match ShaderInput::new(&src, stage, &options, None::<&[(&str, Option<&str>)]>, None) {
        Ok(i) => i,
        Err(e) => {
            // Rejected before parsing: an unsupported `#version` line.
            let line = source.lines().position(|l| l.trim_start().starts_with("#version")).map(|i| i as u32 + 1);
            return Err(vec![GlslError {
                line,
                column: None,
                message: format!("{e} (Vulkan GLSL needs `#version 450`)"),
            }]);
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
        other => return vec![GlslError { line: None, column: None, message: other.to_string() }],
    };
    let errors = parse_log(&log);
    if errors.is_empty() {
        vec![GlslError { line: None, column: None, message: log.trim().to_string() }]
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
            Some((line, column, message)) => out.push(GlslError { line: Some(line), column, message: tidy(&message) }),
            None => out.push(GlslError { line: None, column: None, message: tidy(rest) }),
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
    let code = sources.text(sh.code_span);
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

/// The first `'…'` in a glslang message, the token it complains about.
fn quoted_token(message: &str) -> Option<&str> {
    let a = message.find('\'')?;
    let b = message[a + 1..].find('\'')?;
    Some(&message[a + 1..a + 1 + b])
}

/// Compiles every shader block of an expanded program. Returns the SPIR-V of each
/// block, index-aligned with `ex.shaders` (`None` where it failed), and the
/// diagnostics.
pub fn compile_all(ex: &Expanded, sources: &Sources) -> (Vec<Option<Vec<u32>>>, Vec<Diagnostic>) {
    let mut spirv = Vec::with_capacity(ex.shaders.len());
    let mut diags = Vec::new();
    for sh in &ex.shaders {
        match compile_glsl(&sh.code, sh.vertex) {
            Ok(words) => spirv.push(Some(words)),
            Err(errors) => {
                let stage = if sh.vertex { "vertex" } else { "fragment" };
                for e in &errors {
                    let span = span_of(sh, sources, e);
                    let d = Diagnostic::error("E0501", span, format!("GLSL: {}", e.message))
                        .with_label(format!("in {stage} shader `{}`", sh.name.text))
                        .with_note("shaders are Vulkan GLSL 450; the inputs and uniforms provided are in docs/reference.md §13");
                    diags.push(d);
                }
                spirv.push(None);
            }
        }
    }
    (spirv, diags)
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
        assert_eq!(e[0], GlslError { line: Some(5), column: Some(12), message: "'foo': undeclared identifier".into() });
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
    }
}
