//! Tokens of Context Free (`.cfdg`, CFDG 2 and 3) and Structure Synth (`.es`)
//! programs: numbers, names (with `::`), strings, punctuation, each with its line.
//! Comments (`//`, `/* */`, `#` to the end of the line in CFDG) are skipped.

/// A token's kind.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum T {
    Num(f64),
    Id(String),
    /// A quoted string, or the rest of the line after `include`/`import`.
    Str(String),
    P(&'static str),
}

/// A token, its 1-based line, and whether white space came before it (so a list
/// `[s 1 -1]` reads two arguments, not `1 - 1`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Tok {
    pub t: T,
    pub line: u32,
    pub space: bool,
}

const PUNCT2: &[&str] = &["[[", "]]", "--", "..", "<=", ">=", "==", "!=", "<>", "&&", "||", "^^", "+-"];
const PUNCT1: &[&str] =
    &["{", "}", "[", "]", "(", ")", ",", "=", "+", "-", "*", "/", "^", "<", ">", "!", "%", ":", "|", ";", "@", "."];

/// Options of the scan: whether `#` starts a comment (CFDG) or a word (`#define`,
/// `#ff0` in Structure Synth).
pub(crate) struct Lexed {
    pub toks: Vec<Tok>,
    /// Characters that are no token, with their lines.
    pub stray: Vec<(u32, char)>,
}

/// Scans `text`. `hash_comments`: `#` starts a comment (CFDG); otherwise `#word`
/// is one name (Structure Synth's `#define` and `#rrggbb`).
pub(crate) fn lex(text: &str, hash_comments: bool) -> Lexed {
    let chars: Vec<char> = text.chars().collect();
    let mut toks = Vec::new();
    let mut stray = Vec::new();
    let mut i = 0;
    let mut line = 1u32;
    let mut space = true;
    // Open `[` (false) and `[[` (true), innermost last.
    let mut brackets: Vec<bool> = Vec::new();
    while i < chars.len() {
        let c = chars[i];
        if c == '\n' {
            line += 1;
            i += 1;
            space = true;
            continue;
        }
        if c.is_whitespace() {
            i += 1;
            space = true;
            continue;
        }
        if c == '/' && chars.get(i + 1) == Some(&'/') || (c == '#' && hash_comments) {
            while i < chars.len() && chars[i] != '\n' {
                i += 1;
            }
            continue;
        }
        if c == '/' && chars.get(i + 1) == Some(&'*') {
            i += 2;
            while i < chars.len() && !(chars[i] == '*' && chars.get(i + 1) == Some(&'/')) {
                if chars[i] == '\n' {
                    line += 1;
                }
                i += 1;
            }
            i += 2;
            space = true;
            continue;
        }
        let start_line = line;
        if c.is_ascii_digit() || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            let s = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                // `1..5` is a range: stop before the second dot.
                if chars[i] == '.' && chars.get(i + 1) == Some(&'.') {
                    break;
                }
                i += 1;
            }
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let word: String = chars[s..i].iter().collect();
            let v = word.trim_end_matches('.').parse::<f64>().unwrap_or(0.0);
            toks.push(Tok { t: T::Num(v), line: start_line, space });
            space = false;
            continue;
        }
        if c.is_alphabetic() || c == '_' || (c == '#' && !hash_comments) {
            let s = i;
            i += 1;
            loop {
                if i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                    i += 1;
                } else if chars.get(i) == Some(&':')
                    && chars.get(i + 1) == Some(&':')
                    && chars.get(i + 2).is_some_and(|c| c.is_alphabetic() || *c == '_')
                {
                    i += 2;
                } else {
                    break;
                }
            }
            let word: String = chars[s..i].iter().collect();
            let rest_of_line = word == "include" || word == "import";
            toks.push(Tok { t: T::Id(word), line: start_line, space });
            if rest_of_line {
                let s = i;
                while i < chars.len() && chars[i] != '\n' {
                    i += 1;
                }
                let rest: String = chars[s..i].iter().collect();
                let rest = rest.split("//").next().unwrap_or("").trim().trim_matches('"').to_string();
                toks.push(Tok { t: T::Str(rest), line: start_line, space: true });
            }
            space = false;
            continue;
        }
        if c == '"' {
            let s = i + 1;
            i += 1;
            while i < chars.len() && chars[i] != '"' && chars[i] != '\n' {
                i += 1;
            }
            let word: String = chars[s..i.min(chars.len())].iter().collect();
            i += 1;
            toks.push(Tok { t: T::Str(word), line: start_line, space });
            space = false;
            continue;
        }
        let two: String = chars[i..(i + 2).min(chars.len())].iter().collect();
        // `v3[2]]`: the first `]` closes an index, not a `[[ ]]` list.
        let closes_one = two == "]]" && brackets.last() == Some(&false);
        match (two.as_str(), c) {
            ("[[", _) => brackets.push(true),
            ("]]", _) if !closes_one => {
                brackets.pop();
            }
            (_, '[') => brackets.push(false),
            (_, ']') => {
                brackets.pop();
            }
            _ => {}
        }
        if let Some(p) = PUNCT2.iter().find(|p| **p == two).filter(|_| !closes_one) {
            toks.push(Tok { t: T::P(p), line, space });
            i += 2;
            space = false;
            continue;
        }
        let one = c.to_string();
        let mapped = match c {
            '…' => Some(".."),
            '≤' => Some("<="),
            '≥' => Some(">="),
            '≠' => Some("!="),
            '±' => Some("+-"),
            _ => PUNCT1.iter().find(|p| **p == one).copied(),
        };
        match mapped {
            Some(p) => toks.push(Tok { t: T::P(p), line, space }),
            None => stray.push((line, c)),
        }
        i += 1;
        space = false;
    }
    Lexed { toks, stray }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scans_cfdg_tokens_with_lines_and_spacing() {
        let l = lex("CF::MinimumSize = .5 // c\nshape A { B [[s 1 -1]] } # c\n18* {r 20}", true);
        let kinds: Vec<&T> = l.toks.iter().map(|t| &t.t).collect();
        assert_eq!(kinds[0], &T::Id("CF::MinimumSize".into()));
        assert_eq!(kinds[2], &T::Num(0.5));
        assert_eq!(l.toks[3].line, 2);
        assert!(kinds.contains(&&T::P("[[")));
        let minus = l.toks.iter().position(|t| t.t == T::P("-")).unwrap_or(0);
        assert!(l.toks[minus].space && !l.toks[minus + 1].space);
        assert_eq!(l.toks.last().map(|t| t.line), Some(3));
        assert!(l.stray.is_empty());
    }

    #[test]
    fn es_keeps_hash_words_and_import_takes_the_line() {
        let l = lex("#define a 2\n{ color #ff0 } box", false);
        assert_eq!(l.toks[0].t, T::Id("#define".into()));
        assert!(l.toks.iter().any(|t| t.t == T::Id("#ff0".into())));
        let c = lex("import \"i_pix.cfdg\"\nshape A {}", true);
        assert_eq!(c.toks[1].t, T::Str("i_pix.cfdg".into()));
    }
}
