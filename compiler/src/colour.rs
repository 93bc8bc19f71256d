//! Colour values: `#rgb`, `#rgba`, `#rrggbb`, `#rrggbbaa` and the named palette
//! (CSS's named colours, `#tomato`). An adjustment list that holds one sets the
//! colour absolutely (reference §5, "Colour by value"); the lexer reads `#word` as a
//! colour token ([`looks_like_colour`]), the checker reports malformed ones
//! ([`parse`]'s errors) and lowering turns them into RGBA ([`parse`]).

/// Why a `#…` colour value is not one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ColourError {
    /// Hex digits, but not 3, 4, 6 or 8 of them.
    Length(usize),
    /// A character that is no hex digit, at this char index of the word (after `#`).
    NotHex(usize, char),
    /// Not hex and not a palette name; the nearest name, if one is close.
    UnknownName(Option<&'static str>),
}

/// The RGBA (each 0..1) of a colour value's text, `#` included.
pub fn parse(text: &str) -> Result<[f32; 4], ColourError> {
    let word = text.strip_prefix('#').unwrap_or(text);
    if let Some(rgb) = named(word) {
        let [r, g, b] = rgb.map(|c| f32::from(c) / 255.0);
        return Ok([r, g, b, 1.0]);
    }
    if !is_hex_like(word) {
        return Err(ColourError::UnknownName(nearest_name(word)));
    }
    if let Some((i, c)) = word.chars().enumerate().find(|(_, c)| !c.is_ascii_hexdigit()) {
        return Err(ColourError::NotHex(i, c));
    }
    let digits: Vec<u8> = word.bytes().map(hex_value).collect();
    let (per, n) = match digits.len() {
        3 | 4 => (1, digits.len()),
        6 | 8 => (2, digits.len() / 2),
        k => return Err(ColourError::Length(k)),
    };
    let mut out = [1.0f32; 4];
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let v = if per == 1 { digits[i] * 17 } else { digits[2 * i] * 16 + digits[2 * i + 1] };
        *o = f32::from(v) / 255.0;
    }
    Ok(out)
}

/// Whether the word after a `#` is meant as a colour value (so the lexer makes it a
/// colour token rather than reporting a `#` comment): hex digits, anything starting
/// with a digit, or a palette name.
pub fn looks_like_colour(word: &str) -> bool {
    !word.is_empty() && (is_hex_like(word) || named(word).is_some())
}

/// Hex digits only, or a word starting with a digit (a hex value with a typo).
fn is_hex_like(word: &str) -> bool {
    word.chars().all(|c| c.is_ascii_hexdigit()) || word.starts_with(|c: char| c.is_ascii_digit())
}

fn hex_value(b: u8) -> u8 {
    match b {
        b'0'..=b'9' => b - b'0',
        b'a'..=b'f' => b - b'a' + 10,
        b'A'..=b'F' => b - b'A' + 10,
        _ => 0,
    }
}

/// The palette colour of a name (case-insensitive), as 8-bit RGB.
pub fn named(word: &str) -> Option<[u8; 3]> {
    let lower = word.to_ascii_lowercase();
    PALETTE.binary_search_by(|(n, _)| n.cmp(&lower.as_str())).ok().map(|i| PALETTE[i].1)
}

/// The palette name nearest to `word`, if one is close.
pub fn nearest_name(word: &str) -> Option<&'static str> {
    crate::diag::did_you_mean(&word.to_ascii_lowercase(), PALETTE.iter().map(|(n, _)| *n))
}

/// The palette name whose colour is nearest to `rgb` (squared RGB distance; the
/// first in name order among equals, so `aqua` before `cyan`) and whether it is exact.
pub fn nearest_palette_colour(rgb: [u8; 3]) -> (&'static str, [u8; 3], bool) {
    let d = |c: [u8; 3]| (0..3).map(|k| (i32::from(c[k]) - i32::from(rgb[k])).pow(2)).sum::<i32>();
    let (name, c) = PALETTE.iter().min_by_key(|(_, c)| d(*c)).copied().unwrap_or(("black", [0, 0, 0]));
    (name, c, d(c) == 0)
}

/// Every palette name, sorted.
pub fn names() -> impl Iterator<Item = &'static str> {
    PALETTE.iter().map(|(n, _)| *n)
}

const fn h(v: u32) -> [u8; 3] {
    [(v >> 16) as u8, (v >> 8) as u8, v as u8]
}

/// CSS's named colours (CSS Color Module Level 4), sorted by name for the search.
const PALETTE: &[(&str, [u8; 3])] = &[
    ("aliceblue", h(0xf0f8ff)),
    ("antiquewhite", h(0xfaebd7)),
    ("aqua", h(0x00ffff)),
    ("aquamarine", h(0x7fffd4)),
    ("azure", h(0xf0ffff)),
    ("beige", h(0xf5f5dc)),
    ("bisque", h(0xffe4c4)),
    ("black", h(0x000000)),
    ("blanchedalmond", h(0xffebcd)),
    ("blue", h(0x0000ff)),
    ("blueviolet", h(0x8a2be2)),
    ("brown", h(0xa52a2a)),
    ("burlywood", h(0xdeb887)),
    ("cadetblue", h(0x5f9ea0)),
    ("chartreuse", h(0x7fff00)),
    ("chocolate", h(0xd2691e)),
    ("coral", h(0xff7f50)),
    ("cornflowerblue", h(0x6495ed)),
    ("cornsilk", h(0xfff8dc)),
    ("crimson", h(0xdc143c)),
    ("cyan", h(0x00ffff)),
    ("darkblue", h(0x00008b)),
    ("darkcyan", h(0x008b8b)),
    ("darkgoldenrod", h(0xb8860b)),
    ("darkgray", h(0xa9a9a9)),
    ("darkgreen", h(0x006400)),
    ("darkgrey", h(0xa9a9a9)),
    ("darkkhaki", h(0xbdb76b)),
    ("darkmagenta", h(0x8b008b)),
    ("darkolivegreen", h(0x556b2f)),
    ("darkorange", h(0xff8c00)),
    ("darkorchid", h(0x9932cc)),
    ("darkred", h(0x8b0000)),
    ("darksalmon", h(0xe9967a)),
    ("darkseagreen", h(0x8fbc8f)),
    ("darkslateblue", h(0x483d8b)),
    ("darkslategray", h(0x2f4f4f)),
    ("darkslategrey", h(0x2f4f4f)),
    ("darkturquoise", h(0x00ced1)),
    ("darkviolet", h(0x9400d3)),
    ("deeppink", h(0xff1493)),
    ("deepskyblue", h(0x00bfff)),
    ("dimgray", h(0x696969)),
    ("dimgrey", h(0x696969)),
    ("dodgerblue", h(0x1e90ff)),
    ("firebrick", h(0xb22222)),
    ("floralwhite", h(0xfffaf0)),
    ("forestgreen", h(0x228b22)),
    ("fuchsia", h(0xff00ff)),
    ("gainsboro", h(0xdcdcdc)),
    ("ghostwhite", h(0xf8f8ff)),
    ("gold", h(0xffd700)),
    ("goldenrod", h(0xdaa520)),
    ("gray", h(0x808080)),
    ("green", h(0x008000)),
    ("greenyellow", h(0xadff2f)),
    ("grey", h(0x808080)),
    ("honeydew", h(0xf0fff0)),
    ("hotpink", h(0xff69b4)),
    ("indianred", h(0xcd5c5c)),
    ("indigo", h(0x4b0082)),
    ("ivory", h(0xfffff0)),
    ("khaki", h(0xf0e68c)),
    ("lavender", h(0xe6e6fa)),
    ("lavenderblush", h(0xfff0f5)),
    ("lawngreen", h(0x7cfc00)),
    ("lemonchiffon", h(0xfffacd)),
    ("lightblue", h(0xadd8e6)),
    ("lightcoral", h(0xf08080)),
    ("lightcyan", h(0xe0ffff)),
    ("lightgoldenrodyellow", h(0xfafad2)),
    ("lightgray", h(0xd3d3d3)),
    ("lightgreen", h(0x90ee90)),
    ("lightgrey", h(0xd3d3d3)),
    ("lightpink", h(0xffb6c1)),
    ("lightsalmon", h(0xffa07a)),
    ("lightseagreen", h(0x20b2aa)),
    ("lightskyblue", h(0x87cefa)),
    ("lightslategray", h(0x778899)),
    ("lightslategrey", h(0x778899)),
    ("lightsteelblue", h(0xb0c4de)),
    ("lightyellow", h(0xffffe0)),
    ("lime", h(0x00ff00)),
    ("limegreen", h(0x32cd32)),
    ("linen", h(0xfaf0e6)),
    ("magenta", h(0xff00ff)),
    ("maroon", h(0x800000)),
    ("mediumaquamarine", h(0x66cdaa)),
    ("mediumblue", h(0x0000cd)),
    ("mediumorchid", h(0xba55d3)),
    ("mediumpurple", h(0x9370db)),
    ("mediumseagreen", h(0x3cb371)),
    ("mediumslateblue", h(0x7b68ee)),
    ("mediumspringgreen", h(0x00fa9a)),
    ("mediumturquoise", h(0x48d1cc)),
    ("mediumvioletred", h(0xc71585)),
    ("midnightblue", h(0x191970)),
    ("mintcream", h(0xf5fffa)),
    ("mistyrose", h(0xffe4e1)),
    ("moccasin", h(0xffe4b5)),
    ("navajowhite", h(0xffdead)),
    ("navy", h(0x000080)),
    ("oldlace", h(0xfdf5e6)),
    ("olive", h(0x808000)),
    ("olivedrab", h(0x6b8e23)),
    ("orange", h(0xffa500)),
    ("orangered", h(0xff4500)),
    ("orchid", h(0xda70d6)),
    ("palegoldenrod", h(0xeee8aa)),
    ("palegreen", h(0x98fb98)),
    ("paleturquoise", h(0xafeeee)),
    ("palevioletred", h(0xdb7093)),
    ("papayawhip", h(0xffefd5)),
    ("peachpuff", h(0xffdab9)),
    ("peru", h(0xcd853f)),
    ("pink", h(0xffc0cb)),
    ("plum", h(0xdda0dd)),
    ("powderblue", h(0xb0e0e6)),
    ("purple", h(0x800080)),
    ("rebeccapurple", h(0x663399)),
    ("red", h(0xff0000)),
    ("rosybrown", h(0xbc8f8f)),
    ("royalblue", h(0x4169e1)),
    ("saddlebrown", h(0x8b4513)),
    ("salmon", h(0xfa8072)),
    ("sandybrown", h(0xf4a460)),
    ("seagreen", h(0x2e8b57)),
    ("seashell", h(0xfff5ee)),
    ("sienna", h(0xa0522d)),
    ("silver", h(0xc0c0c0)),
    ("skyblue", h(0x87ceeb)),
    ("slateblue", h(0x6a5acd)),
    ("slategray", h(0x708090)),
    ("slategrey", h(0x708090)),
    ("snow", h(0xfffafa)),
    ("springgreen", h(0x00ff7f)),
    ("steelblue", h(0x4682b4)),
    ("tan", h(0xd2b48c)),
    ("teal", h(0x008080)),
    ("thistle", h(0xd8bfd8)),
    ("tomato", h(0xff6347)),
    ("turquoise", h(0x40e0d0)),
    ("violet", h(0xee82ee)),
    ("wheat", h(0xf5deb3)),
    ("white", h(0xffffff)),
    ("whitesmoke", h(0xf5f5f5)),
    ("yellow", h(0xffff00)),
    ("yellowgreen", h(0x9acd32)),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_palette_is_sorted_so_the_search_finds_every_name() {
        assert!(PALETTE.windows(2).all(|w| w[0].0 < w[1].0));
        for (n, rgb) in PALETTE {
            assert_eq!(named(n), Some(*rgb), "{n}");
        }
        assert_eq!(PALETTE.len(), 148);
    }

    #[test]
    fn hex_forms_and_names_parse_and_bad_ones_say_why() {
        assert_eq!(parse("#f00"), Ok([1.0, 0.0, 0.0, 1.0]));
        assert_eq!(parse("#ff000080"), Ok([1.0, 0.0, 0.0, 128.0 / 255.0]));
        assert_eq!(parse("#0000FF"), Ok([0.0, 0.0, 1.0, 1.0]));
        assert_eq!(parse("#f008"), Ok([1.0, 0.0, 0.0, 136.0 / 255.0]));
        assert_eq!(parse("#Tomato"), Ok([1.0, 99.0 / 255.0, 71.0 / 255.0, 1.0]));
        assert_eq!(parse("#12345"), Err(ColourError::Length(5)));
        assert_eq!(parse("#12g456"), Err(ColourError::NotHex(2, 'g')));
        assert_eq!(parse("#tomatoe"), Err(ColourError::UnknownName(Some("tomato"))));
        assert!(looks_like_colour("fff") && looks_like_colour("navy") && looks_like_colour("1x"));
        assert!(!looks_like_colour("this") && !looks_like_colour(""));
    }
}
