//! Lexing only what an edit touched (issue 39): the language server lexes a
//! document again at every keystroke, and most of a large file is unchanged.
//!
//! The previous version's tokens, comments and diagnostics before the edit are
//! kept up to a **safe point**: the start of the line holding the first changed
//! byte, or the start of a token or comment that runs across that line start (a
//! block comment, a shader block). Everything the lexer decides for a token before
//! it reads only that token's own line (logos never matches a line break inside a
//! token other than those two; `[` as an index, `#` as a colour and the
//! preprocessor lines look ahead within the line), so those tokens are the same. From
//! the safe point the new text is lexed, with the last kept token as the one before
//! (the lexer's only memory besides its position), until a step of the lexer ends
//! with a token in the unchanged end of the file that the previous version also had,
//! moved by the edit's change in length: both lexers then stand at the same text with
//! the same last token, so the rest is the previous version's, moved. Where the
//! diagnostics could be capped, or a shader block is unterminated (it has no token to
//! find), or a byte-order mark moves the text, the file is lexed whole. `tests`:
//! random edits, each compared with a whole lexing.

use super::{lex, lex_from, Lexed, Token};
use crate::diag::MAX_ERRORS;
use crate::span::{FileId, Span};

fn shifted(s: Span, delta: i64) -> Span {
    Span::new(s.file, (i64::from(s.start) + delta) as u32, (i64::from(s.end) + delta) as u32)
}

/// Byte length of the common prefix and suffix of `a` and `b` (not overlapping).
fn common(a: &[u8], b: &[u8]) -> (usize, usize) {
    let pre = a.iter().zip(b).take_while(|(x, y)| x == y).count();
    let max_suf = a.len().min(b.len()) - pre;
    let suf = a.iter().rev().zip(b.iter().rev()).take(max_suf).take_while(|(x, y)| x == y).count();
    (pre, suf)
}

/// [`lex`] of `text` (the contents of `file`), reusing `old`, the lexing of `old_text`
/// (the previous version of the same file); the same result.
pub fn relex(old_text: &str, old: &Lexed, text: &str, file: FileId) -> Lexed {
    relex_counted(old_text, old, text, file).0
}

/// [`relex`], with the number of bytes lexed again (the whole text where it lexed
/// everything).
pub fn relex_counted(old_text: &str, old: &Lexed, text: &str, file: FileId) -> (Lexed, usize) {
    match try_relex(old_text, old, text, file) {
        Some(r) => r,
        None => (lex(text, file), text.len()),
    }
}

fn try_relex(old_text: &str, old: &Lexed, text: &str, file: FileId) -> Option<(Lexed, usize)> {
    if old.suppressed.count > 0
        || old_text.starts_with('\u{feff}')
        || text.starts_with('\u{feff}')
        || old.diagnostics.iter().any(|d| d.code == "E0206")
    {
        return None;
    }
    let (pre, suf) = common(old_text.as_bytes(), text.as_bytes());
    if pre == old_text.len() && pre == text.len() {
        return Some((old.clone(), 0));
    }
    let line = text.as_bytes()[..pre].iter().rposition(|&b| b == b'\n' || b == b'\r').map_or(0, |i| i + 1);
    let mut from = line as u32;
    // A token, comment or diagnostic running across the line start: lexed again from
    // its start.
    let l = line as u32;
    let t = old.tokens.partition_point(|t| t.span.end < l);
    let c = old.comments.partition_point(|c| c.span.end < l);
    for start in [
        old.tokens.get(t).map(|t| t.span.start),
        old.comments.get(c).map(|c| c.span.start),
        old.diagnostics.iter().find(|d| d.span.end >= l).map(|d| d.span.start),
    ]
    .into_iter()
    .flatten()
    {
        from = from.min(start);
    }
    let kept_tokens = old.tokens.partition_point(|t| t.span.start < from);
    let kept_comments = old.comments.partition_point(|c| c.span.start < from);
    let kept_diags = old.diagnostics.iter().take_while(|d| d.span.start < from).count();
    let delta = text.len() as i64 - old_text.len() as i64;
    let unchanged = (text.len() - suf) as u32;
    // Where the previous version's lexer stood after the token the new one stopped at.
    let mut old_at = None;
    let (mid, stopped) =
        lex_from(text, file, 0, from as usize, kept_tokens.checked_sub(1).map(|k| old.tokens[k]), &mut |t| {
            if t.span.start < unchanged {
                return false;
            }
            let o = shifted(t.span, -delta);
            let k = old.tokens.partition_point(|x| x.span.start < o.start);
            let same = old.tokens.get(k).is_some_and(|x| x.kind == t.kind && x.span == o);
            if same {
                old_at = Some((k + 1, o.end));
            }
            same
        });
    if mid.suppressed.count > 0 {
        return None;
    }
    let mut out = Lexed {
        tokens: old.tokens[..kept_tokens].to_vec(),
        comments: old.comments[..kept_comments].to_vec(),
        diagnostics: old.diagnostics[..kept_diags].to_vec(),
        suppressed: Default::default(),
    };
    out.tokens.extend_from_slice(&mid.tokens);
    out.comments.extend(mid.comments);
    out.diagnostics.extend(mid.diagnostics);
    let lexed_bytes = stopped.unwrap_or(text.len()) - from as usize;
    if let (Some(_), Some((k, end))) = (stopped, old_at) {
        out.tokens.extend(old.tokens[k..].iter().map(|t| Token { kind: t.kind, span: shifted(t.span, delta) }));
        let c = old.comments.partition_point(|c| c.span.start < end);
        out.comments.extend(old.comments[c..].iter().map(|c| super::Comment { span: shifted(c.span, delta), ..*c }));
        for d in old.diagnostics.iter().filter(|d| d.span.start >= end) {
            let mut d = d.clone();
            d.span = shifted(d.span, delta);
            d.secondary.iter_mut().for_each(|l| l.span = shifted(l.span, delta));
            if let Some(s) = &mut d.suggestion {
                s.span = shifted(s.span, delta);
            }
            out.diagnostics.push(d);
        }
    }
    if out.diagnostics.len() > MAX_ERRORS {
        return None;
    }
    Some((out, lexed_bytes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_vm::rng::Rng;

    const PIECES: &[&str] = &[
        "rule a {x 1}\n",
        "/*",
        "*/",
        "\"",
        "v[i]",
        "[x -1]",
        "#ff8800",
        "# comment\n",
        "@import std\n",
        "@vertexshader\nvoid main(){}\n",
        "@endshader\n",
        "if(",
        "1..3",
        "1e999",
        "\u{202e}",
        "\n",
        "\r\n",
        "$$",
        "// c\n",
        "r5 {y 2 rz 15}",
        "{",
        "}",
        " ",
        "é",
    ];

    fn sample(rng: &mut Rng) -> String {
        (0..rng.below(30)).map(|_| PIECES[rng.below(PIECES.len())]).collect()
    }

    fn boundary(text: &str, mut at: usize) -> usize {
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        at
    }

    /// Random edits (pieces inserted, ranges deleted, typing) of random texts, each
    /// version lexed from the previous one and whole: the same tokens, comments and
    /// diagnostics.
    #[test]
    fn relexing_equals_a_whole_lexing_after_every_random_edit() {
        let file = FileId(0);
        let mut rng = Rng(0x39b_1e8);
        let (mut reused, mut total) = (0usize, 0usize);
        for _ in 0..300 {
            let mut text = sample(&mut rng);
            let mut lexed = lex(&text, file);
            for _ in 0..20 {
                let at = boundary(&text, rng.below(text.len() + 1));
                let mut next = text.clone();
                match rng.below(3) {
                    0 => {
                        let end = boundary(&text, (at + rng.below(12)).min(text.len())).max(at);
                        next.replace_range(at..end, "");
                    }
                    1 => next.insert_str(at, PIECES[rng.below(PIECES.len())]),
                    _ => next.insert(at, ['a', '1', ' ', '[', '/', '*', '"', '#', '\n'][rng.below(9)]),
                }
                let whole = lex(&next, file);
                let (inc, n) = relex_counted(&text, &lexed, &next, file);
                assert_eq!(inc, whole, "the text was {text:?}, is now {next:?}");
                reused += next.len() - n;
                total += next.len();
                text = next;
                lexed = inc;
            }
        }
        // The comparisons mean something only if much of the text was reused (unclosed
        // comments and shader blocks, frequent here, leave nothing to reuse after them).
        assert!(reused > total / 3, "reused {reused} of {total} bytes");
    }

    /// Typing into a long file lexes a line or so per keystroke.
    #[test]
    fn typing_lexes_little_again() {
        let file = FileId(0);
        let body: String = (0..500).map(|i| format!("rule r{i} {{ x 1 r{} {{}} }} // r{i}\n", i + 1)).collect();
        let at = body.len() / 2;
        let at = body[..at].rfind('\n').map_or(0, |i| i + 1);
        let mut text = body.clone();
        let mut lexed = lex(&text, file);
        for (i, c) in "  r5 {y 2 rz 15}\n".char_indices() {
            let mut next = text.clone();
            next.insert(at + i, c);
            let (inc, n) = relex_counted(&text, &lexed, &next, file);
            assert_eq!(inc, lex(&next, file));
            assert!(n < 200, "lexed {n} bytes again after typing {c:?}");
            text = next;
            lexed = inc;
        }
    }
}
