//! Bounds on shader text, checked before glslang sees it (issue 25).
//!
//! glslang recurses on the native stack over its syntax tree and expands `#define`s
//! without a bound, so a few hundred bytes of GLSL could overflow a thread's stack
//! (`x+x+…` with 10,000 terms, or a 12-level `#define B A+A` doubling chain: 4,096
//! copies) or run for ever (the same chain 24 levels deep makes 16 million tokens).
//! [`check`] refuses such text cheaply, in time and memory linear in its limits:
//!
//! - the block's size in bytes ([`MAX_SHADER_BYTES`]);
//! - the preprocessor's output: the `#define`s are expanded here, token by token,
//!   with a budget ([`MAX_PREPROCESSED_TOKENS`] tokens out, [`MAX_EXPANSION_STEPS`]
//!   steps of work, [`MAX_MACRO_ARG_NESTING`] levels of macro calls inside macro
//!   arguments), so an explosion stops at the budget instead of being built;
//! - expression complexity: the operators in one statement after expansion
//!   ([`MAX_STATEMENT_OPERATORS`]), which bounds the depth of glslang's tree for it.
//!
//! The expansion follows the C preprocessor closely enough to bound it (object- and
//! function-like macros, arguments expanded before substitution, rescanning with
//! the rest of the text, a macro not expanding inside itself, `#undef`); it does
//! not evaluate `#if` (every branch is counted, an over-estimate) and leaves `##`
//! pasting out (an over-estimate by one token per paste). It is a bound, not a
//! second GLSL compiler: whatever passes still goes to glslang, which reports the
//! GLSL errors.
//!
//! Nothing here recurses except arguments within arguments (at most
//! [`MAX_MACRO_ARG_NESTING`] deep), so the check is safe on a small stack.

use std::collections::{HashMap, VecDeque};
use std::rc::Rc;

/// Most bytes in one shader block (256 KiB; real shaders are a few KiB).
pub const MAX_SHADER_BYTES: usize = 256 * 1024;
/// Most tokens a shader may have after its `#define`s are expanded.
pub const MAX_PREPROCESSED_TOKENS: u64 = 262_144;
/// Most operators in one statement (`;`, `{`, `}` end a statement), after expansion.
/// Each operator or `(` `[` `.` can add a level to glslang's tree for the statement.
pub const MAX_STATEMENT_OPERATORS: u64 = 2_048;
/// Most levels of macro calls inside the arguments of macro calls (`F(G(H(x)))`).
pub const MAX_MACRO_ARG_NESTING: usize = 64;
/// Most steps (tokens read, substituted or produced) the expansion may take; with
/// arguments used many times the work can pass the output.
pub const MAX_EXPANSION_STEPS: u64 = 4 * 1_048_576;

/// Why a shader is not given to glslang: the byte range of the offending text in the
/// shader source and what to say about it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Refusal {
    pub start: usize,
    pub end: usize,
    pub message: String,
    /// What the span shows.
    pub label: String,
    /// Where the offending text starts, when that is elsewhere (the statement).
    pub context: Option<(usize, usize, String)>,
    pub note: String,
}

/// Checks `code` (the text of one shader block) against the limits above.
pub fn check(code: &str) -> Result<(), Box<Refusal>> {
    if limits_off() {
        return Ok(());
    }
    if code.len() > MAX_SHADER_BYTES {
        let mut at = MAX_SHADER_BYTES;
        while !code.is_char_boundary(at) {
            at -= 1;
        }
        let start = code[..at].rfind('\n').map_or(0, |i| i + 1);
        let end = code[at..].find('\n').map_or(code.len(), |i| at + i);
        return Err(Box::new(Refusal {
            start,
            end,
            message: format!("shader block too large: {} bytes (at most {MAX_SHADER_BYTES})", code.len()),
            label: format!("the block passes {MAX_SHADER_BYTES} bytes on this line"),
            context: None,
            note: "split the shader into smaller blocks, or move large tables into buffers or textures".into(),
        }));
    }
    let events = tokenize(code);
    let mut pre = Pre::new(code, events);
    pre.run()
}

/// `MDG_TEST_NO_SHADER_LIMITS=1` turns the check off, for the tests of what stays
/// behind it (the compile deadline); not for use.
fn limits_off() -> bool {
    static OFF: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *OFF.get_or_init(|| std::env::var_os("MDG_TEST_NO_SHADER_LIMITS").is_some_and(|v| v == "1"))
}

/// What a token is, for the bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Ident,
    Number,
    /// An operator, `(`, `[`, `.` or `?`/`:`: each may add a level to the tree.
    Op,
    /// `;`, `{`, `}`: ends a statement.
    Sep,
    /// `,`, `)`, `]` and anything else.
    Other,
}

/// A token of the shader source: its kind and byte range.
#[derive(Clone, Copy, Debug)]
struct Raw {
    kind: Kind,
    start: u32,
    end: u32,
}

/// The source as the preprocessor sees it: ordinary tokens and directive lines.
enum Event {
    Tok(Raw),
    /// `#` at the start of a line, then the line's tokens; `at` is the `#`.
    Directive {
        at: u32,
        end: u32,
        toks: Vec<Raw>,
    },
}

const PUNCT3: &[&str] = &["<<=", ">>="];
const PUNCT2: &[&str] = &[
    "++", "--", "<<", ">>", "<=", ">=", "==", "!=", "&&", "||", "^^", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=",
    "##",
];

/// Splits the source into tokens and directive lines: comments dropped, `\` at the
/// end of a line joining it to the next.
fn tokenize(code: &str) -> Vec<Event> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0usize;
    let mut line_start = true;
    let mut dir: Option<(u32, Vec<Raw>)> = None;
    let close = |dir: &mut Option<(u32, Vec<Raw>)>, out: &mut Vec<Event>, end: usize| {
        if let Some((at, toks)) = dir.take() {
            out.push(Event::Directive { at, end: end as u32, toks });
        }
    };
    while i < b.len() {
        let c = b[i];
        match c {
            b'\\' if b.get(i + 1) == Some(&b'\n') => i += 2,
            b'\\' if b.get(i + 1) == Some(&b'\r') && b.get(i + 2) == Some(&b'\n') => i += 3,
            b'\n' => {
                close(&mut dir, &mut out, i);
                line_start = true;
                i += 1;
            }
            b' ' | b'\t' | b'\r' | 0x0b | 0x0c => i += 1,
            b'/' if b.get(i + 1) == Some(&b'/') => {
                i = code[i..].find('\n').map_or(b.len(), |n| i + n);
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                i = code[i + 2..].find("*/").map_or(b.len(), |n| i + 2 + n + 2);
            }
            b'#' if line_start && dir.is_none() => {
                dir = Some((i as u32, Vec::new()));
                line_start = false;
                i += 1;
            }
            _ => {
                let (kind, len) = token_at(code, i);
                let t = Raw { kind, start: i as u32, end: (i + len) as u32 };
                line_start = false;
                match dir.as_mut() {
                    Some((_, toks)) => toks.push(t),
                    None => out.push(Event::Tok(t)),
                }
                i += len;
            }
        }
    }
    close(&mut dir, &mut out, b.len());
    out
}

/// The kind and length of the token starting at byte `i` (not whitespace).
fn token_at(code: &str, i: usize) -> (Kind, usize) {
    let b = code.as_bytes();
    let c = b[i];
    let word = |j: usize| j < b.len() && (b[j].is_ascii_alphanumeric() || b[j] == b'_');
    if c.is_ascii_alphabetic() || c == b'_' {
        let mut j = i + 1;
        while word(j) {
            j += 1;
        }
        return (Kind::Ident, j - i);
    }
    if c.is_ascii_digit() || (c == b'.' && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
        // A preprocessing number: digits, letters, `_`, `.`, and a sign after an exponent.
        let mut j = i + 1;
        while j < b.len() {
            if word(j) || b[j] == b'.' || (matches!(b[j], b'+' | b'-') && matches!(b[j - 1], b'e' | b'E')) {
                j += 1;
            } else {
                break;
            }
        }
        return (Kind::Number, j - i);
    }
    if !c.is_ascii() {
        let len = code[i..].chars().next().map_or(1, char::len_utf8);
        return (Kind::Other, len);
    }
    let rest = &code[i..];
    for p in PUNCT3.iter().chain(PUNCT2) {
        if rest.starts_with(p) {
            return (Kind::Op, p.len());
        }
    }
    let kind = match c {
        b';' | b'{' | b'}' => Kind::Sep,
        b',' | b')' | b']' => Kind::Other,
        b'+' | b'-' | b'*' | b'/' | b'%' | b'<' | b'>' | b'=' | b'!' | b'~' | b'&' | b'|' | b'^' | b'?' | b':'
        | b'(' | b'[' | b'.' => Kind::Op,
        _ => Kind::Other,
    };
    (kind, 1)
}

/// The macros a token came out of (it is not expanded again inside them).
type Hide = Option<Rc<HideNode>>;

struct HideNode {
    id: usize,
    next: Hide,
}

fn hidden(mut h: &Hide, id: usize) -> bool {
    while let Some(n) = h {
        if n.id == id {
            return true;
        }
        h = &n.next;
    }
    false
}

fn hide_with(h: &Hide, id: usize) -> Hide {
    Some(Rc::new(HideNode { id, next: h.clone() }))
}

/// A token on its way through the expansion: the source token it is a copy of, the
/// macros it came from, and the text in the shader it is blamed on (the macro use
/// at the top level that produced it, or itself).
#[derive(Clone)]
struct Ptok {
    raw: Raw,
    hide: Hide,
    origin: (u32, u32),
}

struct Macro {
    id: usize,
    /// `None` for an object-like macro.
    params: Option<Vec<Raw>>,
    body: Vec<Raw>,
}

/// Tokens still to be scanned: expansions pushed back in front, then (for the top
/// level) the rest of the source.
struct Stream {
    pending: VecDeque<Ptok>,
    source: bool,
}

struct Pre<'a> {
    code: &'a str,
    events: Vec<Event>,
    pos: usize,
    macros: HashMap<&'a str, Rc<Macro>>,
    next_id: usize,
    steps: u64,
    /// Tokens out of the preprocessor so far.
    total: u64,
    /// Operators in the current statement, where it starts, and whether macros
    /// took part in it.
    stmt_ops: u64,
    stmt_start: Option<u32>,
    /// The text the statement's first token is blamed on.
    stmt_first: (u32, u32),
    stmt_macro: bool,
}

impl<'a> Pre<'a> {
    fn new(code: &'a str, events: Vec<Event>) -> Pre<'a> {
        Pre {
            code,
            events,
            pos: 0,
            macros: HashMap::new(),
            next_id: 0,
            steps: 0,
            total: 0,
            stmt_ops: 0,
            stmt_start: None,
            stmt_first: (0, 0),
            stmt_macro: false,
        }
    }

    fn text(&self, r: Raw) -> &'a str {
        &self.code[r.start as usize..r.end as usize]
    }

    fn run(&mut self) -> Result<(), Box<Refusal>> {
        let mut top = Stream { pending: VecDeque::new(), source: true };
        while let Some(t) = self.next_expanded(&mut top, 0)? {
            self.emit(&t)?;
        }
        Ok(())
    }

    fn step(&mut self, n: u64, origin: (u32, u32)) -> Result<(), Box<Refusal>> {
        self.steps += n;
        if self.steps > MAX_EXPANSION_STEPS {
            return Err(Box::new(Refusal {
                start: origin.0 as usize,
                end: origin.1 as usize,
                message: format!(
                    "shader too large after preprocessing: expanding its macros takes more than \
                     {MAX_EXPANSION_STEPS} steps"
                ),
                label: "the expansion passes the limit here".into(),
                context: None,
                note: expansion_note(),
            }));
        }
        Ok(())
    }

    /// One token out of the preprocessor: counted against the output and statement limits.
    fn emit(&mut self, t: &Ptok) -> Result<(), Box<Refusal>> {
        self.total += 1;
        if self.total > MAX_PREPROCESSED_TOKENS {
            let what = if t.hide.is_some() {
                format!("`{}` expands past the limit here", &self.code[t.origin.0 as usize..t.origin.1 as usize])
            } else {
                "the text passes the limit here".to_string()
            };
            return Err(Box::new(Refusal {
                start: t.origin.0 as usize,
                end: t.origin.1 as usize,
                message: format!("shader too large after preprocessing: more than {MAX_PREPROCESSED_TOKENS} tokens"),
                label: what,
                context: None,
                note: expansion_note(),
            }));
        }
        match t.raw.kind {
            Kind::Sep => {
                self.stmt_ops = 0;
                self.stmt_start = None;
                self.stmt_macro = false;
            }
            kind => {
                if self.stmt_start.is_none() {
                    self.stmt_start = Some(t.origin.0);
                    self.stmt_first = t.origin;
                }
                self.stmt_macro |= t.hide.is_some();
                if kind == Kind::Op {
                    self.stmt_ops += 1;
                    if self.stmt_ops > MAX_STATEMENT_OPERATORS {
                        let after = if self.stmt_macro { " after macro expansion" } else { "" };
                        let (lo, hi) = (t.origin.0 as usize, t.origin.1 as usize);
                        let label = if t.hide.is_some() {
                            format!("`{}` expands past {MAX_STATEMENT_OPERATORS} operators here", &self.code[lo..hi])
                        } else {
                            format!("operator {} of the statement", MAX_STATEMENT_OPERATORS + 1)
                        };
                        let first = self.stmt_first;
                        let context = (first.0 != t.origin.0)
                            .then(|| (first.0 as usize, first.1 as usize, "the statement starts here".to_string()));
                        return Err(Box::new(Refusal {
                            start: lo,
                            end: hi,
                            message: format!(
                                "expression too complex: more than {MAX_STATEMENT_OPERATORS} operators in one \
                                 statement{after}"
                            ),
                            label,
                            context,
                            note: "split the expression into several statements with intermediate variables".into(),
                        }));
                    }
                }
            }
        }
        Ok(())
    }

    /// The next token of `s` before expansion; directive lines met on the way are
    /// carried out.
    fn next_raw(&mut self, s: &mut Stream, depth: usize) -> Result<Option<Ptok>, Box<Refusal>> {
        if let Some(t) = s.pending.pop_front() {
            self.step(1, t.origin)?;
            return Ok(Some(t));
        }
        if !s.source {
            return Ok(None);
        }
        while self.pos < self.events.len() {
            let i = self.pos;
            self.pos += 1;
            match &self.events[i] {
                Event::Tok(r) => {
                    let r = *r;
                    self.step(1, (r.start, r.end))?;
                    return Ok(Some(Ptok { raw: r, hide: None, origin: (r.start, r.end) }));
                }
                Event::Directive { at, end, toks } => {
                    let (at, end, toks) = (*at, *end, toks.clone());
                    self.directive(at, end, &toks, depth)?;
                }
            }
        }
        Ok(None)
    }

    fn directive(&mut self, at: u32, end: u32, toks: &[Raw], depth: usize) -> Result<(), Box<Refusal>> {
        let Some(&name) = toks.first() else { return Ok(()) };
        self.step(toks.len() as u64, (at, end))?;
        match self.text(name) {
            "define" => {
                let Some(&m) = toks.get(1).filter(|t| t.kind == Kind::Ident) else { return Ok(()) };
                let function_like = toks.get(2).is_some_and(|p| self.text(*p) == "(" && p.start == m.end);
                let (params, body_at) = if function_like {
                    let close = toks[3..].iter().position(|t| self.text(*t) == ")").map(|p| p + 3);
                    match close {
                        Some(c) => {
                            (Some(toks[3..c].iter().copied().filter(|t| t.kind == Kind::Ident).collect()), c + 1)
                        }
                        None => (Some(Vec::new()), toks.len()),
                    }
                } else {
                    (None, 2)
                };
                let body: Vec<Raw> =
                    toks[body_at.min(toks.len())..].iter().copied().filter(|t| self.text(*t) != "##").collect();
                self.next_id += 1;
                self.macros.insert(self.text(m), Rc::new(Macro { id: self.next_id, params, body }));
            }
            "undef" => {
                if let Some(&m) = toks.get(1) {
                    self.macros.remove(self.text(m));
                }
            }
            "if" | "elif" => {
                // glslang expands and evaluates the condition: count it as a statement of its own.
                let mut sub = Stream { pending: VecDeque::new(), source: false };
                let mut skip_next = false;
                for t in &toks[1..] {
                    // `defined X` / `defined(X)`: X is not expanded.
                    let is_defined = self.text(*t) == "defined";
                    if skip_next && t.kind == Kind::Ident {
                        skip_next = false;
                        continue;
                    }
                    skip_next = is_defined || (skip_next && self.text(*t) == "(");
                    if !is_defined {
                        sub.pending.push_back(Ptok { raw: *t, hide: None, origin: (t.start, t.end) });
                    }
                }
                let saved = (self.stmt_ops, self.stmt_start, self.stmt_macro);
                self.stmt_ops = 0;
                self.stmt_start = None;
                self.stmt_macro = false;
                while let Some(t) = self.next_expanded(&mut sub, depth + 1)? {
                    self.emit(&t)?;
                }
                (self.stmt_ops, self.stmt_start, self.stmt_macro) = saved;
            }
            _ => {}
        }
        Ok(())
    }

    /// The next token of `s` after expansion: macros met are replaced by their bodies
    /// (pushed back in front of `s`, so they are rescanned with what follows).
    fn next_expanded(&mut self, s: &mut Stream, depth: usize) -> Result<Option<Ptok>, Box<Refusal>> {
        loop {
            let Some(t) = self.next_raw(s, depth)? else { return Ok(None) };
            if t.raw.kind != Kind::Ident {
                return Ok(Some(t));
            }
            let Some(m) = self.macros.get(self.text(t.raw)).cloned() else { return Ok(Some(t)) };
            if hidden(&t.hide, m.id) {
                return Ok(Some(t));
            }
            let hide = hide_with(&t.hide, m.id);
            match &m.params {
                None => {
                    self.step(m.body.len() as u64, t.origin)?;
                    for b in m.body.iter().rev() {
                        s.pending.push_front(Ptok { raw: *b, hide: hide.clone(), origin: t.origin });
                    }
                }
                Some(params) => {
                    // A function-like macro is called only when `(` follows.
                    let Some(open) = self.next_raw(s, depth)? else { return Ok(Some(t)) };
                    if self.text(open.raw) != "(" {
                        s.pending.push_front(open);
                        return Ok(Some(t));
                    }
                    let args = self.arguments(s, depth)?;
                    let mut expanded: Vec<Option<Vec<Ptok>>> = vec![None; args.len()];
                    let mut out = Vec::with_capacity(m.body.len());
                    for b in &m.body {
                        let k = (b.kind == Kind::Ident)
                            .then(|| params.iter().position(|p| self.text(*p) == self.text(*b)))
                            .flatten();
                        match k {
                            Some(k) if k < args.len() => {
                                if expanded[k].is_none() {
                                    expanded[k] = Some(self.expand_argument(&args[k], depth + 1, t.origin)?);
                                }
                                let arg = expanded[k].as_deref().unwrap_or_default();
                                self.step(arg.len() as u64, t.origin)?;
                                out.extend(arg.iter().map(|a| Ptok {
                                    raw: a.raw,
                                    hide: hide_with(&a.hide, m.id),
                                    origin: a.origin,
                                }));
                            }
                            // A parameter without an argument expands to nothing.
                            Some(_) => {}
                            None => {
                                self.step(1, t.origin)?;
                                out.push(Ptok { raw: *b, hide: hide.clone(), origin: t.origin });
                            }
                        }
                    }
                    for p in out.into_iter().rev() {
                        s.pending.push_front(p);
                    }
                }
            }
        }
    }

    /// The arguments of a call whose `(` was just read: up to the matching `)` (or
    /// the end of the stream), split at the commas outside inner parentheses.
    fn arguments(&mut self, s: &mut Stream, depth: usize) -> Result<Vec<Vec<Ptok>>, Box<Refusal>> {
        let mut args = vec![Vec::new()];
        let mut level = 0usize;
        while let Some(t) = self.next_raw(s, depth)? {
            match self.text(t.raw) {
                "(" => level += 1,
                ")" if level == 0 => break,
                ")" => level -= 1,
                "," if level == 0 => {
                    args.push(Vec::new());
                    continue;
                }
                _ => {}
            }
            if let Some(last) = args.last_mut() {
                last.push(t);
            }
        }
        Ok(args)
    }

    /// An argument expanded on its own, as the preprocessor does before substituting it.
    fn expand_argument(&mut self, arg: &[Ptok], depth: usize, origin: (u32, u32)) -> Result<Vec<Ptok>, Box<Refusal>> {
        if depth > MAX_MACRO_ARG_NESTING {
            return Err(Box::new(Refusal {
                start: origin.0 as usize,
                end: origin.1 as usize,
                message: format!(
                    "macro calls nest too deeply: more than {MAX_MACRO_ARG_NESTING} levels of macro calls in \
                     macro arguments"
                ),
                label: "this call passes the limit".into(),
                context: None,
                note: "use intermediate variables or functions instead of nested macro calls".into(),
            }));
        }
        let mut sub = Stream { pending: arg.iter().cloned().collect(), source: false };
        let mut out = Vec::new();
        while let Some(t) = self.next_expanded(&mut sub, depth)? {
            out.push(t);
        }
        Ok(out)
    }
}

fn expansion_note() -> String {
    format!(
        "each `#define` that uses the one before twice doubles the text (12 levels of `#define B A+A` make 4096 \
         copies); the preprocessed shader may have at most {MAX_PREPROCESSED_TOKENS} tokens"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(levels: usize) -> String {
        let mut s = String::from("#version 450\n#define M0 x+x\n");
        for i in 1..levels {
            s.push_str(&format!("#define M{i} M{}+M{}\n", i - 1, i - 1));
        }
        s.push_str(&format!("void main() {{ float x = 1.0; gl_Position = vec4(M{}); }}\n", levels - 1));
        s
    }

    #[test]
    fn ordinary_shaders_pass() {
        let ok = "#version 450\n#define SCALE(v) ((v) * 2.0)\n#define N 4\nlayout(location = 0) in vec3 p;\n\
                  void main() {\n  float a[N];\n  for (int i = 0; i < N; i++) { a[i] = SCALE(p.x); }\n\
                  gl_Position = vec4(SCALE(p), 1.0); // x+x+x\n}\n/* #define BAD */\n";
        assert_eq!(check(ok), Ok(()));
        // A long table is not a long chain of operators: commas do not count.
        let table: Vec<String> = (0..5000).map(|i| format!("{i}.5")).collect();
        let t = format!("#version 450\nconst float T[5000] = float[]({});\nvoid main() {{}}\n", table.join(", "));
        assert_eq!(check(&t), Ok(()));
        // Ten levels of doubling (1023 `+`) stay within the operator limit.
        assert_eq!(check(&chain(10)), Ok(()));
    }

    #[test]
    fn a_doubling_chain_is_refused_at_its_use() {
        let src = chain(12);
        let r = check(&src).expect_err("12 levels: 4095 operators");
        assert!(r.message.starts_with("expression too complex: more than 2048 operators"), "{r:?}");
        assert!(r.message.ends_with("after macro expansion"), "{r:?}");
        assert_eq!(&src[r.start..r.end], "M11");
        assert_eq!(r.label, "`M11` expands past 2048 operators here");
        let (a, b, _) = r.context.clone().expect("the statement");
        assert_eq!(&src[a..b], "gl_Position");
        // Deep enough, the output limit is met first (2^24 copies would hang glslang).
        let src = chain(24);
        let r = check(&src).expect_err("24 levels");
        assert!(r.message.contains("more than 262144 tokens") || r.message.contains("operators"), "{r:?}");
    }

    #[test]
    fn output_limit_across_statements() {
        // Many short statements from one macro: no statement is long, the output is.
        let mut s = String::from("#version 450\n#define S0 x = x + 1.0;\n");
        for i in 1..20 {
            s.push_str(&format!("#define S{i} S{} S{}\n", i - 1, i - 1));
        }
        s.push_str("void main() { float x = 0.0; S19 }\n");
        let r = check(&s).expect_err("2^19 statements");
        assert!(r.message.contains("more than 262144 tokens"), "{r:?}");
        assert_eq!(&s[r.start..r.end], "S19");
        assert_eq!(r.label, "`S19` expands past the limit here");
    }

    #[test]
    fn long_expressions_and_nesting() {
        let terms = vec!["x"; 10_000].join("+");
        let src = format!("#version 450\nvoid main() {{ float x = 1.0; gl_Position = vec4({terms}); }}\n");
        let r = check(&src).expect_err("10,000 terms");
        assert!(r.message.ends_with("operators in one statement"), "{r:?}");
        assert_eq!(&src[r.start..r.end], "+");
        assert_eq!(src[..r.start].matches('+').count(), 2048 - 2, "`=` and `(` count too: {r:?}");
        assert_eq!(r.label, "operator 2049 of the statement");
        let deep = format!("#version 450\nvoid main() {{ float x = {}1.0{}; }}\n", "(".repeat(3000), ")".repeat(3000));
        assert!(check(&deep).is_err());
        // Function-like macros doubling through their arguments.
        let mut f = String::from("#version 450\n#define D0(a) a a\n");
        for i in 1..30 {
            f.push_str(&format!("#define D{i}(a) D{}(D{}(a))\n", i - 1, i - 1));
        }
        f.push_str("void main() { D29(;) }\n");
        let r = check(&f).expect_err("2^(2^29) tokens");
        assert!(r.message.contains("preprocessing") || r.message.contains("nest"), "{r:?}");
        // Nested calls in arguments.
        let n = format!("#version 450\n#define F(a) a\nvoid main() {{ {}x{}; }}\n", "F(".repeat(100), ")".repeat(100));
        let r = check(&n).expect_err("100 nested calls");
        assert!(r.message.starts_with("macro calls nest too deeply"), "{r:?}");
    }

    #[test]
    fn recursion_and_conditions() {
        // A macro does not expand inside itself (the preprocessor leaves `A` there).
        assert_eq!(check("#version 450\n#define A A+1\n#define B A*B\nvoid main() { float A = B; }\n"), Ok(()));
        // `#if` conditions are expanded too.
        let mut s = String::from("#version 450\n#define M0 1+1\n");
        for i in 1..24 {
            s.push_str(&format!("#define M{i} M{}+M{}\n", i - 1, i - 1));
        }
        s.push_str("#if M23 > 0\n#endif\nvoid main() {}\n");
        assert!(check(&s).is_err());
        // `defined X` does not expand X.
        assert_eq!(check("#version 450\n#define A 1\n#if defined(A) && defined A\n#endif\nvoid main() {}\n"), Ok(()));
    }

    /// Random text built from the preprocessor's pieces: never a panic, and a
    /// refusal's range always lies inside the text on character boundaries.
    #[test]
    fn random_text_never_panics() {
        const PIECES: &[&str] = &[
            "#define ", "#undef ", "#if ", "#elif ", "defined", "\n", "\\\n", "\\", "/*", "*/", "//", "(", ")", ",",
            "A", "B", "F", "G", "x", "+", "##", "#", ";", "{", "}", " ", "1.5e+3", ".", "é", "\r\n", "F(", "A A",
        ];
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..3000 {
            let mut text = String::new();
            for _ in 0..(state % 60) {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                text.push_str(PIECES[(state % PIECES.len() as u64) as usize]);
            }
            if let Err(r) = check(&text) {
                assert!(r.start <= r.end && r.end <= text.len(), "{text:?}: {r:?}");
                assert!(text.is_char_boundary(r.start) && text.is_char_boundary(r.end), "{text:?}: {r:?}");
            }
        }
    }

    #[test]
    fn size_limit_points_at_the_line_that_passes_it() {
        let line = "float v = 1.0;\n";
        let src = format!("#version 450\n{}", line.repeat(MAX_SHADER_BYTES / line.len() + 2));
        let r = check(&src).expect_err("too large");
        assert_eq!(r.message, format!("shader block too large: {} bytes (at most 262144)", src.len()));
        assert_eq!(r.label, "the block passes 262144 bytes on this line");
        assert_eq!(r.note, "split the shader into smaller blocks, or move large tables into buffers or textures");
        assert!(r.start <= MAX_SHADER_BYTES && MAX_SHADER_BYTES <= r.end, "{r:?}");
        assert_eq!(&src[r.start..r.end], line.trim_end());
        // A block of exactly the limit is not refused for its size.
        let mut exact = String::from("#version 450\n");
        while exact.len() + line.len() <= MAX_SHADER_BYTES {
            exact.push_str(line);
        }
        exact.push_str(&" ".repeat(MAX_SHADER_BYTES - exact.len()));
        assert_eq!(exact.len(), MAX_SHADER_BYTES);
        assert_eq!(check(&exact), Ok(()));
    }

    /// A doubling chain of object-like macros `M0 … M{levels-1}` whose use is the
    /// argument of `A`, which hands it to `B`, which drops it: the expansion works
    /// (2^levels tokens) but emits nothing.
    fn silent_chain(levels: usize) -> String {
        let mut s = String::from("#version 450\n#define B(y)\n#define A(x) B(x)\n#define M0 1\n");
        for i in 1..levels {
            s.push_str(&format!("#define M{i} M{} M{}\n", i - 1, i - 1));
        }
        s.push_str(&format!("void main() {{ A(M{}) }}\n", levels - 1));
        s
    }

    #[test]
    fn expansion_work_without_output_is_refused_at_the_steps_limit() {
        assert_eq!(check(&silent_chain(12)), Ok(()), "2^11 tokens of work");
        let src = silent_chain(22);
        let r = check(&src).expect_err("2^21 tokens of work, none emitted");
        assert_eq!(
            r.message,
            "shader too large after preprocessing: expanding its macros takes more than 4194304 steps"
        );
        assert_eq!(r.label, "the expansion passes the limit here");
        assert!(r.note.starts_with("each `#define` that uses the one before twice doubles the text"), "{r:?}");
        assert_eq!(&src[r.start..r.end], "M21");
    }

    #[test]
    fn macro_calls_nest_in_arguments_64_deep_not_65() {
        let nest = |n: usize| {
            format!("#version 450\n#define F(a) a\nvoid main() {{ {}x{}; }}\n", "F(".repeat(n), ")".repeat(n))
        };
        assert_eq!(check(&nest(MAX_MACRO_ARG_NESTING)), Ok(()));
        let r = check(&nest(MAX_MACRO_ARG_NESTING + 1)).expect_err("65 levels");
        assert_eq!(r.message, "macro calls nest too deeply: more than 64 levels of macro calls in macro arguments");
        assert_eq!(r.label, "this call passes the limit");
        assert_eq!(r.note, "use intermediate variables or functions instead of nested macro calls");
    }

    #[test]
    fn brackets_members_and_conditionals_count_as_operators() {
        // A statement of `v` and n member selections: n operators.
        let dots = |n: usize| format!("#version 450\nvoid main() {{ v{}; }}\n", ".x".repeat(n));
        assert_eq!(check(&dots(2048)), Ok(()));
        let src = dots(2049);
        let r = check(&src).expect_err("2049 `.`");
        assert_eq!(r.message, "expression too complex: more than 2048 operators in one statement");
        assert_eq!(r.label, "operator 2049 of the statement");
        assert_eq!(&src[r.start..r.end], ".");
        assert_eq!(src[..r.start].matches('.').count(), 2048);
        // `[` counts, `]` does not.
        let index = |n: usize| format!("#version 450\nvoid main() {{ a{}; }}\n", "[0]".repeat(n));
        assert_eq!(check(&index(2048)), Ok(()));
        assert_eq!(check(&index(2049)).expect_err("2049 `[`").label, "operator 2049 of the statement");
        // `?` and `:` count one each.
        let cond = |n: usize| format!("#version 450\nvoid main() {{ {}c; }}\n", "c ? 1 : ".repeat(n));
        assert_eq!(check(&cond(1024)), Ok(()));
        let src = cond(1025);
        let r = check(&src).expect_err("2050 `?`/`:`");
        assert_eq!(r.label, "operator 2049 of the statement");
        assert_eq!(&src[r.start..r.end], "?");
    }
}
