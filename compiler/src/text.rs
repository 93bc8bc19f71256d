//! Text from the input as the terminal shows it: which characters are escaped when
//! printed ([`needs_escape`], [`escape_text`]) and which change how text is
//! displayed without changing what it is ([`text_flow_control`], W0014).
//! Depends on nothing else in the crate.

/// The name of a character that changes how the text around it is shown but not how
/// it is read ("Trojan Source", CVE-2021-42574): the bidirectional embeddings,
/// overrides and isolates (U+202A–U+202E, U+2066–U+2069), and the Unicode line
/// breaks the lexer does not count as ones (U+2028, U+2029, U+0085 NEXT LINE), which
/// editors show as a new line inside a comment or string.
pub fn text_flow_control(c: char) -> Option<&'static str> {
    Some(match c {
        '\u{202a}' => "LEFT-TO-RIGHT EMBEDDING",
        '\u{202b}' => "RIGHT-TO-LEFT EMBEDDING",
        '\u{202c}' => "POP DIRECTIONAL FORMATTING",
        '\u{202d}' => "LEFT-TO-RIGHT OVERRIDE",
        '\u{202e}' => "RIGHT-TO-LEFT OVERRIDE",
        '\u{2066}' => "LEFT-TO-RIGHT ISOLATE",
        '\u{2067}' => "RIGHT-TO-LEFT ISOLATE",
        '\u{2068}' => "FIRST STRONG ISOLATE",
        '\u{2069}' => "POP DIRECTIONAL ISOLATE",
        '\u{2028}' => "LINE SEPARATOR",
        '\u{2029}' => "PARAGRAPH SEPARATOR",
        '\u{85}' => "NEXT LINE",
        _ => return None,
    })
}

/// Whether a character is shown escaped in rendered diagnostics: a C0 control other
/// than tab and newline (ESC starts the sequences that retitle, clear or recolour a
/// terminal), DEL, a C1 control (U+0080–U+009F: U+009B is CSI, U+009D OSC), or a
/// character that reorders or breaks the displayed text
/// ([`text_flow_control`]).
pub fn needs_escape(c: char) -> bool {
    (c.is_control() && c != '\t' && c != '\n') || text_flow_control(c).is_some()
}

/// `text` with every character [`needs_escape`] picks written as `\u{1b}` (Rust's
/// escape form), so text from a source file or a file name can be printed to a
/// terminal safely. Newlines and tabs are kept.
pub fn escape_text(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        push_escaped(&mut out, c);
    }
    std::borrow::Cow::Owned(out)
}

/// Appends `c`, escaped if [`needs_escape`]; returns how many bytes were added.
pub(crate) fn push_escaped(out: &mut String, c: char) -> usize {
    let before = out.len();
    if needs_escape(c) {
        out.push_str(&format!("\\u{{{:x}}}", c as u32));
    } else {
        out.push(c);
    }
    out.len() - before
}
