//! Mutators: byte-level (flips, random bytes, deletions, duplications, splices) and
//! token-level (insert / delete / duplicate / replace words from the language's word
//! lists, repeat a token many times, swap in interesting numbers, move lines between
//! inputs). Each call applies one to eight of them.

use crate::rng::Rng;

/// Numbers that often reach edge cases.
pub const INTERESTING_NUMBERS: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "0.5",
    ".0",
    "255",
    "256",
    "65535",
    "65536",
    "2147483647",
    "2147483648",
    "4294967295",
    "4294967296",
    "9007199254740993",
    "18446744073709551615",
    "18446744073709551616",
    "1e12",
    "1e308",
    "1e309",
    "1e-308",
    "1e-320",
    "1000000000000",
    "360t",
    "1e9d",
    "0.000001",
    "99999999999999999999999999999999",
];

/// Non-ASCII and control text (char boundaries, UTF-16 widths, zero-width).
const ODD_TEXT: &[&str] = &["é", "😀", "\u{200b}", "\u{feff}", "\t", "\r\n", "\0", "\u{7f}", "\\", "\"", "\n"];

/// Mutates `input` with one or two text-aware operations (up to eight now and then:
/// most inputs should stay close to valid programs); `dict` holds words of
/// the language, `pool` other inputs to splice from. The result is at most `max_len`
/// bytes.
pub fn text(rng: &mut Rng, input: &[u8], pool: &[Vec<u8>], dict: &[String], max_len: usize) -> Vec<u8> {
    let mut v = input.to_vec();
    let n = 1 + if rng.one_in(4) { rng.below(8) } else { rng.below(2) };
    for _ in 0..n {
        match rng.below(16) {
            0..=3 => insert_word(rng, &mut v, dict),
            4 => delete_word(rng, &mut v),
            5 => duplicate_word(rng, &mut v),
            6 => replace_word(rng, &mut v, dict),
            7 => replace_number(rng, &mut v),
            8 => repeat_word(rng, &mut v, dict),
            9 => splice_lines(rng, &mut v, pool),
            10 => line_op(rng, &mut v),
            11 => {
                let at = rng.below(v.len() + 1);
                let t = rng.pick(ODD_TEXT).copied().unwrap_or(" ");
                v.splice(at..at, t.bytes());
            }
            _ => byte_op(rng, &mut v, pool),
        }
    }
    v.truncate(max_len);
    v
}

/// Mutates binary `input` (bundles, voxel files) with one to eight byte-level
/// operations; at most `max_len` bytes.
pub fn bytes(rng: &mut Rng, input: &[u8], pool: &[Vec<u8>], max_len: usize) -> Vec<u8> {
    let mut v = input.to_vec();
    let n = 1 + rng.below(8);
    for _ in 0..n {
        byte_op(rng, &mut v, pool);
    }
    v.truncate(max_len);
    v
}

fn byte_op(rng: &mut Rng, v: &mut Vec<u8>, pool: &[Vec<u8>]) {
    let len = v.len();
    match rng.below(12) {
        0 | 1 if len > 0 => {
            let i = rng.below(len);
            v[i] ^= 1 << rng.below(8);
        }
        2 if len > 0 => {
            let i = rng.below(len);
            v[i] = rng.bits() as u8;
        }
        3 if len > 0 => {
            // An interesting byte.
            let i = rng.below(len);
            v[i] = *rng.pick(&[0u8, 1, 0x7f, 0x80, 0xff, b'{', b'}', b'(', b'*', b'@']).unwrap_or(&0);
        }
        4 if len >= 4 => {
            // An interesting 32-bit little-endian value (counts, indices, lengths).
            let i = rng.below(len - 3);
            let val: u32 = *rng
                .pick(&[0, 1, 0x7fff_ffff, 0x8000_0000, u32::MAX, u32::MAX - 1, 0xffff, 0x1_0000, 255])
                .unwrap_or(&0);
            v[i..i + 4].copy_from_slice(&val.to_le_bytes());
        }
        5 if len >= 8 => {
            // A small value in a 32-bit field (a plausible index just out of range).
            let i = rng.below(len - 3);
            let val = rng.below(64) as u32;
            v[i..i + 4].copy_from_slice(&val.to_le_bytes());
        }
        6 if len > 0 => {
            let a = rng.below(len);
            let b = (a + 1 + rng.below(32)).min(len);
            v.drain(a..b);
        }
        7 if len > 0 => {
            let a = rng.below(len);
            let b = (a + 1 + rng.below(64)).min(len);
            let chunk = v[a..b].to_vec();
            let at = rng.below(len + 1);
            v.splice(at..at, chunk);
        }
        8 => {
            let at = rng.below(len + 1);
            v.insert(at, rng.bits() as u8);
        }
        9 if len > 0 => v.truncate(rng.below(len)),
        10 => {
            // Splice: our prefix, another input's suffix.
            if let Some(other) = rng.pick(pool) {
                let a = rng.below(len + 1);
                let b = rng.below(other.len() + 1);
                v.truncate(a);
                v.extend_from_slice(&other[b..]);
            }
        }
        _ => {
            // Copy a chunk of another input over ours.
            if let Some(other) = rng.pick(pool) {
                if !other.is_empty() && len > 0 {
                    let a = rng.below(other.len());
                    let n = (1 + rng.below(64)).min(other.len() - a);
                    let at = rng.below(len);
                    let end = (at + n).min(len);
                    v[at..end].copy_from_slice(&other[a..a + (end - at)]);
                }
            }
        }
    }
}

/// Byte ranges of whitespace-separated words.
fn words(v: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, b) in v.iter().enumerate() {
        let ws = b.is_ascii_whitespace();
        match (start, ws) {
            (None, false) => start = Some(i),
            (Some(s), true) => {
                out.push((s, i));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, v.len()));
    }
    out
}

/// A position at a word boundary (or anywhere, now and then).
fn boundary(rng: &mut Rng, v: &[u8]) -> usize {
    let w = words(v);
    if w.is_empty() || rng.one_in(8) {
        return rng.below(v.len() + 1);
    }
    let (a, b) = w[rng.below(w.len())];
    if rng.one_in(2) {
        a
    } else {
        b
    }
}

fn dict_word<'a>(rng: &mut Rng, dict: &'a [String]) -> &'a str {
    rng.pick(dict).map(|s| s.as_str()).unwrap_or("x")
}

fn insert_word(rng: &mut Rng, v: &mut Vec<u8>, dict: &[String]) {
    let at = boundary(rng, v);
    let w = dict_word(rng, dict);
    let sep: &[u8] = if rng.one_in(4) { b"" } else { b" " };
    let mut ins = sep.to_vec();
    ins.extend_from_slice(w.as_bytes());
    ins.extend_from_slice(sep);
    v.splice(at..at, ins);
}

fn delete_word(rng: &mut Rng, v: &mut Vec<u8>) {
    let w = words(v);
    if let Some(&(a, b)) = rng.pick(&w) {
        v.drain(a..b);
    }
}

fn duplicate_word(rng: &mut Rng, v: &mut Vec<u8>) {
    let w = words(v);
    if let Some(&(a, b)) = rng.pick(&w) {
        let mut chunk = vec![b' '];
        chunk.extend_from_slice(&v[a..b]);
        v.splice(b..b, chunk);
    }
}

fn replace_word(rng: &mut Rng, v: &mut Vec<u8>, dict: &[String]) {
    let w = words(v);
    if let Some(&(a, b)) = rng.pick(&w) {
        let new = dict_word(rng, dict).as_bytes().to_vec();
        v.splice(a..b, new);
    }
}

fn replace_number(rng: &mut Rng, v: &mut Vec<u8>) {
    let w: Vec<(usize, usize)> = words(v).into_iter().filter(|&(a, _)| v[a].is_ascii_digit() || v[a] == b'.').collect();
    let new = rng.pick(INTERESTING_NUMBERS).copied().unwrap_or("0").as_bytes().to_vec();
    match rng.pick(&w) {
        Some(&(a, b)) => {
            v.splice(a..b, new);
        }
        None => {
            let at = boundary(rng, v);
            v.splice(at..at, new);
        }
    }
}

/// Inserts one word (often a bracket or operator) many times: nesting and length limits.
fn repeat_word(rng: &mut Rng, v: &mut Vec<u8>, dict: &[String]) {
    let at = boundary(rng, v);
    let w = match rng.below(4) {
        0 => rng.pick(&["{", "(", "[", "-", "2 * {x 1} ", "@ifdef A\n", "x + "]).copied().unwrap_or("{"),
        _ => dict_word(rng, dict),
    };
    let times = 2 + rng.small(0, 400) as usize;
    let mut ins = Vec::with_capacity(times * (w.len() + 1));
    for _ in 0..times {
        ins.extend_from_slice(w.as_bytes());
        if !w.ends_with(' ') && !w.ends_with('\n') && rng.one_in(2) {
            ins.push(b' ');
        }
    }
    v.splice(at..at, ins);
}

fn line_ranges(v: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut s = 0;
    for (i, b) in v.iter().enumerate() {
        if *b == b'\n' {
            out.push((s, i + 1));
            s = i + 1;
        }
    }
    if s < v.len() {
        out.push((s, v.len()));
    }
    out
}

fn splice_lines(rng: &mut Rng, v: &mut Vec<u8>, pool: &[Vec<u8>]) {
    let Some(other) = rng.pick(pool) else { return };
    let lines = line_ranges(other);
    if lines.is_empty() {
        return;
    }
    let i = rng.below(lines.len());
    let j = (i + 1 + rng.below(8)).min(lines.len());
    let chunk = other[lines[i].0..lines[j - 1].1].to_vec();
    let mine = line_ranges(v);
    let at = rng.pick(&mine).map(|l| l.0).unwrap_or(v.len());
    v.splice(at..at, chunk);
}

fn line_op(rng: &mut Rng, v: &mut Vec<u8>) {
    let lines = line_ranges(v);
    if lines.is_empty() {
        return;
    }
    let (a, b) = lines[rng.below(lines.len())];
    match rng.below(3) {
        0 => {
            v.drain(a..b);
        }
        1 => {
            let chunk = v[a..b].to_vec();
            v.splice(b..b, chunk);
        }
        _ => {
            let (c, d) = lines[rng.below(lines.len())];
            if (c, d) != (a, b) {
                let (first, second) = if a < c { ((a, b), (c, d)) } else { ((c, d), (a, b)) };
                let x = v[first.0..first.1].to_vec();
                let y = v[second.0..second.1].to_vec();
                // Replace the later range first so the earlier offsets stay valid.
                v.splice(second.0..second.1, x);
                v.splice(first.0..first.1, y);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_stay_within_the_size_limit_and_change_the_input() {
        let mut rng = Rng::new(1);
        let input = b"startshape A\nrule A { VERTEX {x 1} }\n".to_vec();
        let dict: Vec<String> = ["rule", "{", "}"].iter().map(|s| s.to_string()).collect();
        let pool = vec![input.clone()];
        let mut changed = 0;
        for _ in 0..500 {
            let m = text(&mut rng, &input, &pool, &dict, 256);
            assert!(m.len() <= 256);
            changed += usize::from(m != input);
            let b = bytes(&mut rng, &input, &pool, 64);
            assert!(b.len() <= 64);
        }
        assert!(changed > 400, "only {changed} of 500 mutations changed the input");
    }
}
