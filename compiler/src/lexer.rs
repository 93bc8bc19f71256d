//! The lexer: source text to tokens, with comments kept aside for the formatter.
//!
//! Built on logos. Lexing never fails: an invalid character becomes a diagnostic
//! (E0103) and is skipped, so the parser still sees the rest of the file.
//! Preprocessor lines (`@import`, `@define`, `@param`, `@presets`) and shader blocks
//! are single tokens whose payload is read later from their text.

use crate::diag::Diagnostic;
use crate::span::{FileId, Span};
use logos::Logos;

mod relex;

pub use relex::{relex, relex_counted};

/// Lexing errors, turned into diagnostics by [`lex`].
#[derive(Clone, Debug, Default, PartialEq)]
pub enum LexError {
    #[default]
    InvalidChar,
    UnterminatedComment,
    UnterminatedShader,
}

fn block_comment(lex: &mut logos::Lexer<Tok>) -> Result<(), LexError> {
    match lex.remainder().find("*/") {
        Some(i) => {
            lex.bump(i + 2);
            Ok(())
        }
        None => {
            lex.bump(lex.remainder().len());
            Err(LexError::UnterminatedComment)
        }
    }
}

fn shader_block(lex: &mut logos::Lexer<Tok>) -> Result<(), LexError> {
    match lex.remainder().find("@endshader") {
        Some(i) => {
            lex.bump(i + "@endshader".len());
            Ok(())
        }
        None => {
            lex.bump(lex.remainder().len());
            Err(LexError::UnterminatedShader)
        }
    }
}

/// Consumes the rest of the line (up to a `//` comment or the line break: `\n`,
/// `\r\n` or a lone `\r`, as [`crate::source::line_starts`] counts lines).
fn rest_of_line(lex: &mut logos::Lexer<Tok>) {
    let rem = lex.remainder();
    let nl = rem.find(['\n', '\r']).unwrap_or(rem.len());
    let cut = rem[..nl].find("//").unwrap_or(nl);
    lex.bump(rem[..cut].trim_end().len());
}

/// Words the lexer makes keyword tokens (structured top-level items). They may
/// still be used as rule names where that is unambiguous, but not renamed to.
pub const KEYWORDS: &[&str] = &[
    "rule",
    "startshape",
    "selector",
    "linerule",
    "camerarule",
    "namespace",
    "function",
    "isosurface",
    "program",
    "uniform",
    "angle",
    "color",
    "weight",
    "guide",
    "search",
    "creature",
    "grid",
];

/// Words reserved for control flow inside rule bodies (`if (…) { } else { }`,
/// `let x = …;`, `loop i = a, b {ADJ} ITEM`): never rule names.
pub const CONTROL_KEYWORDS: &[&str] = &["if", "else", "let", "loop"];

/// The words that open a SPEC §11 extension section (`KIND [NAME] { KEY VALUE… ; … }`).
pub const SECTION_KINDS: &[&str] = &["guide", "search", "creature", "grid"];

/// Every preprocessor directive the lexer knows.
pub const PREPROCESSOR_DIRECTIVES: &[&str] = &[
    "@import",
    "@define",
    "@ifdef",
    "@else",
    "@endif",
    "@macro",
    "@endmacro",
    "@expand",
    "@presets",
    "@param",
    "@vertexshader",
    "@fragmentshader",
    "@endshader",
];

/// Token kinds. Text (names, numbers) is read back from the token's span.
#[derive(Logos, Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[logos(error = LexError)]
#[logos(skip r"[ \t\r\n\f]+")]
pub enum Tok {
    // Keywords: top-level words that start structured items.
    #[token("rule")]
    KwRule,
    #[token("startshape")]
    KwStartshape,
    #[token("selector")]
    KwSelector,
    #[token("linerule")]
    KwLinerule,
    #[token("camerarule")]
    KwCamerarule,
    #[token("namespace")]
    KwNamespace,
    #[token("function")]
    KwFunction,
    #[token("isosurface")]
    KwIsosurface,
    #[token("program")]
    KwProgram,
    #[token("uniform")]
    KwUniform,
    #[token("angle")]
    KwAngle,
    #[token("color")]
    KwColor,
    #[token("weight")]
    KwWeight,
    /// `guide`, `search`, `creature`, `grid`: a §11 extension section.
    #[token("guide")]
    #[token("search")]
    #[token("creature")]
    #[token("grid")]
    KwSection,
    #[token("if")]
    KwIf,
    #[token("else")]
    KwElse,
    #[token("let")]
    KwLet,
    #[token("loop")]
    KwLoop,
    /// A string literal `"…"` on one line (paths in extension sections).
    #[regex(r#""[^"\n\r]*""#)]
    Str,

    #[regex(r"[A-Za-z_][A-Za-z0-9_]*")]
    Ident,
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)+")]
    Dotted,
    /// A word directly followed by `(`: the token includes the parenthesis.
    #[regex(r"[A-Za-z_][A-Za-z0-9_]*\(")]
    CallOpen,
    #[regex(r"([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+)?[drot]?")]
    Number,

    #[token("{")]
    LBrace,
    #[token("}")]
    RBrace,
    #[token("[")]
    LBracket,
    #[token("]")]
    RBracket,
    #[token("(")]
    LParen,
    #[token(")")]
    RParen,
    #[token(",")]
    Comma,
    #[token(";")]
    Semi,
    #[token("*")]
    Star,
    #[token("/")]
    Slash,
    #[token("+")]
    Plus,
    #[token("-")]
    Minus,
    #[token("^")]
    Caret,
    #[token("\\")]
    Backslash,
    #[token(":")]
    Colon,
    #[token("<")]
    Lt,
    #[token("<=")]
    Le,
    #[token(">")]
    Gt,
    #[token(">=")]
    Ge,
    #[token("==")]
    EqEq,
    #[token("!=")]
    Ne,
    #[token("=")]
    Assign,
    #[token("&&")]
    AndAnd,
    #[token("||")]
    OrOr,
    #[token("!")]
    Bang,
    /// `..` (or Context Free's `…`): the range of a `switch` arm, `case 5..9:`.
    #[token("..")]
    #[token("…")]
    DotDot,
    /// `5..`: a whole number and `..` (which the number would otherwise take a `.`
    /// of: `5..9` would read `5.` `.9`). Split into `Number` and `DotDot` by [`lex`].
    #[regex(r"[0-9]+\.\.")]
    NumberDotDot,

    #[regex(r"//[^\n\r]*", allow_greedy = true)]
    LineComment,
    #[token("/*", block_comment)]
    BlockComment,

    // Preprocessor.
    #[token("@import", |lex| rest_of_line(lex))]
    AtImport,
    #[token("@define", |lex| rest_of_line(lex))]
    AtDefine,
    #[token("@param", |lex| rest_of_line(lex))]
    AtParam,
    #[token("@presets", |lex| rest_of_line(lex))]
    AtPresets,
    #[token("@ifdef")]
    AtIfdef,
    #[token("@else")]
    AtElse,
    #[token("@endif")]
    AtEndif,
    #[token("@macro")]
    AtMacro,
    #[token("@endmacro")]
    AtEndmacro,
    #[token("@expand")]
    AtExpand,
    #[regex(r"@(vertexshader|fragmentshader)", shader_block)]
    Shader,
    #[token("@endshader")]
    AtEndshader,
    /// An unknown `@word`: the rest of its line is taken with it, so one typo is one error.
    #[regex(r"@[A-Za-z_][A-Za-z0-9_]*", |lex| rest_of_line(lex), priority = 1)]
    AtUnknown,

    /// A whole `@macro … @endmacro` definition (made by the pre-pass).
    MacroDef,
    /// A whole `@expand NAME(…)` use (made by the pre-pass).
    Expand,
    /// A colour value `#rrggbb`, `#rgb`, `#rrggbbaa` or `#name` (made by the lexer
    /// from a `#` and the word after it: [`crate::colour::looks_like_colour`]).
    Colour,
    /// `switch`, `case` and a `switch`'s `else:` arm: plain words the Context Free
    /// pass (`crate::cfdg`) retags where they open a `switch` and its arms, so a rule
    /// named `switch` or `case` stays a name.
    KwSwitch,
    KwCase,
    KwDefault,
    /// A `[` that indexes a vector, `v[0]` (made by the lexer from `[`:
    /// [`index_bracket`]), told apart from an adjustment list `CIRCLE[s 2]`.
    IndexOpen,
}

impl Tok {
    /// How the token is shown in "expected …" messages.
    pub fn describe(self) -> &'static str {
        use Tok::*;
        match self {
            KwRule => "`rule`",
            KwStartshape => "`startshape`",
            KwSelector => "`selector`",
            KwLinerule => "`linerule`",
            KwCamerarule => "`camerarule`",
            KwNamespace => "`namespace`",
            KwFunction => "`function`",
            KwIsosurface => "`isosurface`",
            KwProgram => "`program`",
            KwUniform => "`uniform`",
            KwAngle => "`angle`",
            KwColor => "`color`",
            KwWeight => "`weight`",
            KwSection => "a section keyword",
            KwIf => "`if`",
            KwElse => "`else`",
            KwLet => "`let`",
            KwLoop => "`loop`",
            Str => "a string",
            Ident | Dotted => "a name",
            CallOpen => "a call",
            Number => "a number",
            Colour => "a colour value",
            LBrace => "`{`",
            RBrace => "`}`",
            LBracket => "`[`",
            IndexOpen => "an index `[`",
            RBracket => "`]`",
            LParen => "`(`",
            RParen => "`)`",
            Comma => "`,`",
            Semi => "`;`",
            Star => "`*`",
            Slash => "`/`",
            Plus => "`+`",
            Minus => "`-`",
            Caret => "`^`",
            Backslash => "`\\`",
            Colon => "`:`",
            Lt => "`<`",
            Le => "`<=`",
            Gt => "`>`",
            Ge => "`>=`",
            EqEq => "`==`",
            Ne => "`!=`",
            Assign => "`=`",
            AndAnd => "`&&`",
            OrOr => "`||`",
            Bang => "`!`",
            DotDot | NumberDotDot => "`..`",
            KwSwitch => "`switch`",
            KwCase => "`case`",
            KwDefault => "`else:`",
            LineComment | BlockComment => "a comment",
            AtImport => "`@import`",
            AtDefine => "`@define`",
            AtParam => "`@param`",
            AtPresets => "`@presets`",
            AtIfdef => "`@ifdef`",
            AtElse => "`@else`",
            AtEndif => "`@endif`",
            AtMacro => "`@macro`",
            AtEndmacro => "`@endmacro`",
            AtExpand => "`@expand`",
            Shader => "a shader block",
            AtEndshader => "`@endshader`",
            AtUnknown => "a preprocessor directive",
            MacroDef => "a macro definition",
            Expand => "`@expand`",
        }
    }
}

/// One token with its span.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token {
    pub kind: Tok,
    pub span: Span,
}

/// A comment, kept for the formatter and the language server.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Comment {
    pub span: Span,
    /// Whether it is a `/* … */` comment.
    pub block: bool,
}

/// The result of lexing one file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lexed {
    pub tokens: Vec<Token>,
    pub comments: Vec<Comment>,
    /// At most [`MAX_ERRORS`](crate::diag::MAX_ERRORS); the rest are counted in `suppressed`.
    pub diagnostics: Vec<Diagnostic>,
    pub suppressed: crate::diag::Suppressed,
}

/// Lexes `text` (the contents of `file`), starting at byte `base` (for lexing macro
/// arguments in place).
pub fn lex_at(text: &str, file: FileId, base: u32) -> Lexed {
    lex_from(text, file, base, 0, None, &mut |_| false).0
}

/// Lexes `text[from..]` (`text` the contents of `file` from byte `base`), as if the
/// tokens before `from` had ended with `prev`, until `stop` says so of the last token
/// a step of the lexer gave: then also the byte (in `text`) where it stopped.
fn lex_from(
    text: &str,
    file: FileId,
    base: u32,
    from: usize,
    prev: Option<Token>,
    stop: &mut dyn FnMut(&Token) -> bool,
) -> (Lexed, Option<usize>) {
    let mut out = Lexed::default();
    let mut diags = crate::diag::Capped::default();
    // The end of the last run of invalid characters (one diagnostic per run).
    let mut invalid_end: Option<u32> = None;
    let mut lexer = Tok::lexer(&text[from..]);
    let mut stopped = None;
    while let Some(res) = lexer.next() {
        let before = out.tokens.len();
        let r = lexer.span();
        let r = r.start + from..r.end + from;
        let span = Span::new(file, base + r.start as u32, base + r.end as u32);
        let last = out.tokens.last().or(prev.as_ref()).copied();
        match res {
            Ok(Tok::LineComment | Tok::BlockComment) if !text[r.clone()].is_ascii() => {
                let block = text[r.clone()].starts_with("/*");
                if let Some(d) =
                    text_flow_warning(&text[r.clone()], span, if block { "comment" } else { "line comment" })
                {
                    diags.push(d);
                }
                out.comments.push(Comment { span, block });
            }
            Ok(Tok::LineComment) => out.comments.push(Comment { span, block: false }),
            Ok(Tok::BlockComment) => out.comments.push(Comment { span, block: true }),
            Ok(
                kind @ (Tok::Str
                | Tok::Shader
                | Tok::AtImport
                | Tok::AtDefine
                | Tok::AtParam
                | Tok::AtPresets
                | Tok::AtUnknown),
            ) if !text[r.clone()].is_ascii() => {
                let what = match kind {
                    Tok::Str => "string",
                    Tok::Shader => "shader block",
                    _ => "preprocessor line",
                };
                if let Some(d) = text_flow_warning(&text[r.clone()], span, what) {
                    diags.push(d);
                }
                out.tokens.push(Token { kind, span });
            }
            Ok(Tok::CallOpen) => {
                // `if(`, `loop(`: a control keyword then `(`, not a call.
                let word = &text[r.start..r.end - 1];
                let kw = match word {
                    "if" => Some(Tok::KwIf),
                    "loop" => Some(Tok::KwLoop),
                    "let" => Some(Tok::KwLet),
                    "else" => Some(Tok::KwElse),
                    _ => None,
                };
                match kw {
                    Some(kind) => {
                        out.tokens.push(Token { kind, span: Span::new(file, span.start, span.end - 1) });
                        out.tokens.push(Token { kind: Tok::LParen, span: Span::new(file, span.end - 1, span.end) });
                    }
                    None => out.tokens.push(Token { kind: Tok::CallOpen, span }),
                }
            }
            Ok(Tok::NumberDotDot) => {
                let mid = span.end - 2;
                out.tokens.push(Token { kind: Tok::Number, span: Span::new(file, span.start, mid) });
                out.tokens.push(Token { kind: Tok::DotDot, span: Span::new(file, mid, span.end) });
            }
            Ok(Tok::Number) => {
                if !parse_number(&text[r.clone()]).0.is_finite() {
                    diags.push(
                        Diagnostic::error("E0109", span, format!("number `{}` is too large", &text[r.clone()]))
                            .with_label("beyond the largest number, about 1.8e308")
                            .with_note("numbers are 64-bit floats; write a smaller value"),
                    );
                }
                out.tokens.push(Token { kind: Tok::Number, span });
            }
            Ok(Tok::LBracket) if index_bracket(text, r.start, span.start, last.as_ref()) => {
                out.tokens.push(Token { kind: Tok::IndexOpen, span })
            }
            Ok(kind) => out.tokens.push(Token { kind, span }),
            Err(LexError::InvalidChar)
                if text[r.clone()].starts_with('#') && colour_word(&text[r.end..], last.map(|t| t.kind)).is_some() =>
            {
                // A colour value (`#ff8800`, `#tomato`); the checker reports malformed ones.
                let n = colour_word(&text[r.end..], last.map(|t| t.kind)).map_or(0, str::len);
                lexer.bump(n);
                invalid_end = None;
                out.tokens.push(Token { kind: Tok::Colour, span: Span::new(file, span.start, span.end + n as u32) });
            }
            Err(LexError::InvalidChar) if text[r.clone()].starts_with('#') => {
                // A `#` comment (shell, Python, Context Free) or a C-style `#define`:
                // one error with the fix, and the rest of the line is skipped as the
                // comment it was meant to be (not an error per word after it).
                let rest = &text[r.end..];
                let line_len = rest.find(['\n', '\r']).unwrap_or(rest.len());
                lexer.bump(line_len);
                invalid_end = None;
                diags.push(hash_line(&text[r.start..r.end + line_len], span));
            }
            Err(LexError::InvalidChar) => {
                let ch = text[r.clone()].chars().next().unwrap_or('?');
                // Merge runs of invalid characters into one diagnostic.
                if invalid_end == Some(span.start) {
                    invalid_end = Some(span.end);
                    if let Some(last) = diags.list.last_mut().filter(|_| diags.suppressed.count == 0) {
                        last.span.end = span.end;
                    }
                    continue;
                }
                invalid_end = Some(span.end);
                diags.push(
                    Diagnostic::error("E0103", span, format!("invalid character `{}`", ch.escape_debug()))
                        .with_label("not part of the language"),
                );
            }
            Err(LexError::UnterminatedComment) => {
                let s = Span::new(file, span.start, span.start + 2);
                diags.push(
                    Diagnostic::error("E0102", s, "unterminated block comment")
                        .with_label("this comment is never closed")
                        .with_note("add `*/` where the comment should end"),
                );
                out.comments.push(Comment { span, block: true });
            }
            Err(LexError::UnterminatedShader) => {
                let head_len = text[r.clone()].find(char::is_whitespace).unwrap_or(r.len());
                let s = Span::new(file, span.start, span.start + head_len as u32);
                diags.push(
                    Diagnostic::error("E0206", s, "unterminated shader block")
                        .with_label("this shader block has no `@endshader`"),
                );
            }
        }
        if out.tokens.len() > before {
            if let Some(t) = out.tokens.last().filter(|t| stop(t)) {
                stopped = Some((t.span.end - base) as usize);
                break;
            }
        }
    }
    out.diagnostics = diags.list;
    out.suppressed = diags.suppressed;
    (out, stopped)
}

/// At most this many occurrences of text-flow controls in one comment or string
/// get a label of their own (the message names every distinct one).
const MAX_FLOW_LABELS: usize = 8;

/// W0014 for a comment, string or other free text (`what`) at `span` holding
/// text-flow controls ([`text_flow_control`]): at the first one, naming each
/// distinct code point, with labels at the next few.
fn text_flow_warning(text: &str, span: Span, what: &str) -> Option<Diagnostic> {
    let mut found = text.char_indices().filter(|(_, c)| crate::text::text_flow_control(*c).is_some());
    let (first, c0) = found.next()?;
    let at = |i: usize, c: char| Span::new(span.file, span.start + i as u32, span.start + (i + c.len_utf8()) as u32);
    let mut distinct = vec![c0];
    let mut d = Diagnostic::warning("W0014", at(first, c0), "");
    let mut more = 0usize;
    for (i, c) in found {
        if !distinct.contains(&c) {
            distinct.push(c);
        }
        if d.secondary.len() < MAX_FLOW_LABELS {
            d = d.with_secondary(at(i, c), format!("U+{:04X}", c as u32));
        } else {
            more += 1;
        }
    }
    let names: Vec<String> = distinct
        .iter()
        .map(|&c| format!("U+{:04X} {}", c as u32, crate::text::text_flow_control(c).unwrap_or_default()))
        .collect();
    d.message = format!(
        "{what} holds invisible text-direction or line-break character{}: {}",
        if names.len() == 1 { "" } else { "s" },
        names.join(", ")
    );
    d = d.with_label(format!("U+{:04X}: the text may be shown in another order than it is read", c0 as u32)).with_note(
        "these characters make code look different from what the compiler reads (\"Trojan Source\"); \
             remove them unless they are meant",
    );
    if more > 0 {
        d = d.with_note(format!("{more} more not labelled"));
    }
    Some(d)
}

/// The error for a `#` at the start of `line` (the rest of the line is skipped): a
/// known directive written the C way (`#define`) points at `@`, anything else is a
/// comment written the shell way.
fn hash_line(line: &str, span: Span) -> Diagnostic {
    let word: String = line[1..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
    let directive = format!("@{word}");
    if !word.is_empty() && PREPROCESSOR_DIRECTIVES.contains(&directive.as_str()) {
        return Diagnostic::error("E0103", span, format!("`#{word}` is not a directive in MDG"))
            .with_label("`#` is not part of the language; the rest of the line is skipped")
            .with_note(format!("MDG's preprocessor directives start with `@`: `{directive}`"))
            .with_suggestion(format!("write `{directive}`"), span, "@");
    }
    let d = Diagnostic::error("E0103", span, "`#` does not start a comment in MDG")
        .with_label("not part of the language; the rest of the line is skipped")
        .with_note("MDG comments are `//` or `/* */`");
    // A misspelt colour name (`#tomatoe`) reads as a comment too: say what was near.
    let d = match crate::colour::nearest_name(&word).filter(|_| word.len() >= 3) {
        Some(name) => d.with_note(format!(
            "a colour value is `#` and 3, 4, 6 or 8 hex digits, or a colour name: did you mean `#{name}`?"
        )),
        None => d,
    };
    d.with_suggestion("write `//`", span, "//")
}

/// The word after a `#` when it makes a colour value (ASCII letters and digits,
/// [`crate::colour::looks_like_colour`], or any word where an adjustment may stand:
/// after `{`, `[`, a number, `)` or another colour), or `None` for a
/// `#` comment or directive. `prev` is the token before the `#`.
fn colour_word(rest: &str, prev: Option<Tok>) -> Option<&str> {
    let n = rest.find(|c: char| !c.is_ascii_alphanumeric()).unwrap_or(rest.len());
    let word = &rest[..n];
    // A word followed by `_` is an identifier-like comment word (`#my_note`), not a value.
    let directive = format!("@{word}");
    if rest[n..].starts_with('_') || PREPROCESSOR_DIRECTIVES.contains(&directive.as_str()) {
        return None;
    }
    let in_list = matches!(prev, Some(Tok::LBrace | Tok::LBracket | Tok::Number | Tok::Colour | Tok::RParen));
    (crate::colour::looks_like_colour(word) || (in_list && !word.is_empty())).then_some(word)
}

/// Whether the `[` at byte `at` indexes a vector (`v[0]`, `f(a)[1]`, `v[i + 1]`)
/// rather than opening an adjustment list (`CIRCLE[s 2]`, `loop i = 0, n [x 1]`):
/// it follows a name, `)` or `]` with no space between, and what it holds starts
/// with a digit, `(` or `-`, or is one name that is not an adjustment without
/// arguments (`CIRCLE[fx]`), alone or followed by an operator.
/// `at` is the `[`'s offset in `text`, `start` in the file (spans are the file's).
fn index_bracket(text: &str, at: usize, start: u32, prev: Option<&Token>) -> bool {
    let Some(prev) = prev else { return false };
    if !matches!(prev.kind, Tok::Ident | Tok::RParen | Tok::RBracket) || prev.span.end != start {
        return false;
    }
    let inside = text[at + 1..].trim_start_matches([' ', '\t']);
    let Some(first) = inside.chars().next() else { return false };
    if first.is_ascii_digit() || first == '(' || first == '.' {
        return true;
    }
    if first == '-' {
        return inside[1..].starts_with(|c: char| c.is_ascii_digit() || c == '.');
    }
    if !(first.is_ascii_alphabetic() || first == '_') {
        return false;
    }
    let n = inside.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(inside.len());
    const BARE: &[&str] = &["fx", "fy", "fz", "up", "down", "left", "right", "rollleft", "rollright"];
    if BARE.contains(&&inside[..n]) {
        return false;
    }
    let rest = &inside[n..];
    let after = rest.trim_start_matches([' ', '\t']);
    // `v[i]`, `v[i+1]`, `v[i + 1]`; not `[x -1]` (a word, a space, a signed number).
    after.starts_with(']')
        || rest.starts_with(['+', '-', '*', '/', '^'])
        || (after.starts_with(['+', '-', '*', '/', '^']) && after[1..].starts_with([' ', '\t']))
}

/// Lexes a whole file.
pub fn lex(text: &str, file: FileId) -> Lexed {
    // A byte-order mark (an editor's, in text given directly) is not part of the text.
    match text.strip_prefix('\u{feff}') {
        Some(rest) => lex_at(rest, file, '\u{feff}'.len_utf8() as u32),
        None => lex_at(text, file, 0),
    }
}

/// The numeric value and unit suffix of a number token's text.
pub fn parse_number(text: &str) -> (f64, Option<char>) {
    let last = text.chars().last().unwrap_or('0');
    let (digits, unit) =
        if matches!(last, 'd' | 'r' | 'o' | 't') { (&text[..text.len() - 1], Some(last)) } else { (text, None) };
    (digits.parse::<f64>().unwrap_or(0.0), unit)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(text: &str) -> Vec<Tok> {
        lex(text, FileId(0)).tokens.iter().map(|t| t.kind).collect()
    }

    /// `v[0]` indexes; an adjustment list after a name stays a list, however it is
    /// spaced (`CIRCLE[s 2]`, `CIRCLE[fx]`, `CIRCLE[]`, `loop … n[x -1]`).
    #[test]
    fn an_index_bracket_is_told_from_an_adjustment_list() {
        for text in
            ["v[0]", "v[ 1 ]", "f(a)[1]", "(a, b)[0]", "v[i]", "v[i+1]", "v[i + 1]", "m[0][1]", "v[-0]", "v[.5]"]
        {
            assert!(kinds(text).contains(&Tok::IndexOpen), "{text}: {:?}", kinds(text));
        }
        for text in
            ["CIRCLE[s 2]", "CIRCLE[fx]", "CIRCLE[]", "n[x -1]", "v [0]", "f(1)[b 1]", "CIRCLE [x 1]", "x[x 1 y 2]"]
        {
            assert!(!kinds(text).contains(&Tok::IndexOpen), "{text}: {:?}", kinds(text));
        }
        // After a byte-order mark (spans count from the file's start).
        assert!(kinds("\u{feff}v[0]").contains(&Tok::IndexOpen));
    }
}
