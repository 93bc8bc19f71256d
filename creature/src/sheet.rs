//! Contact sheets: pictures of a generation's monsters (PNG tiles, each rendered
//! by whichever renderer the caller uses) composed into one PNG in a grid, each
//! tile labelled with its monster's id.

use super::error::SheetError;
use std::io::Cursor;

/// Decodes a PNG to RGBA8 pixels: (width, height, pixels).
pub fn decode_png(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), SheetError> {
    let mut dec = png::Decoder::new(Cursor::new(bytes));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(SheetError::Decode)?;
    let size = reader.output_buffer_size().ok_or(SheetError::TooLarge)?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(SheetError::Decode)?;
    let (w, h) = (info.width, info.height);
    let n = (w * h) as usize;
    let src = &buf[..info.buffer_size()];
    let rgba = match info.color_type {
        png::ColorType::Rgba => src.to_vec(),
        png::ColorType::Rgb => src.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect(),
        png::ColorType::Grayscale => src.iter().flat_map(|&g| [g, g, g, 255]).collect(),
        png::ColorType::GrayscaleAlpha => src.chunks_exact(2).flat_map(|p| [p[0], p[0], p[0], p[1]]).collect(),
        png::ColorType::Indexed => return Err(SheetError::Indexed),
    };
    if rgba.len() != n * 4 {
        return Err(SheetError::SizeMismatch);
    }
    Ok((w, h, rgba))
}

/// 5×9 glyphs for labels: each row is 5 bits, most significant on the left;
/// digits use the top seven rows, `g` has a descender.
fn glyph(c: char) -> Option<[u8; 9]> {
    let d = |r: [u8; 7]| [r[0], r[1], r[2], r[3], r[4], r[5], r[6], 0, 0];
    Some(match c {
        '0' => d([0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e]),
        '1' => d([0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e]),
        '2' => d([0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f]),
        '3' => d([0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e]),
        '4' => d([0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02]),
        '5' => d([0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e]),
        '6' => d([0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e]),
        '7' => d([0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08]),
        '8' => d([0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e]),
        '9' => d([0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c]),
        'g' => [0x00, 0x00, 0x0f, 0x11, 0x11, 0x11, 0x0f, 0x01, 0x0e],
        'b' => d([0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1e]),
        '-' => d([0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00]),
        ' ' => [0; 9],
        _ => return None,
    })
}

/// RGBA8 pixels with their size.
struct Canvas<'a> {
    px: &'a mut [u8],
    w: u32,
    h: u32,
}

/// Draws `text` at (x, y), each glyph pixel `scale`² pixels.
fn draw_text(canvas: &mut Canvas, x: u32, y: u32, text: &str, scale: u32, color: [u8; 3]) {
    let (w, h) = (canvas.w, canvas.h);
    let mut cx = x;
    for c in text.chars() {
        let Some(g) = glyph(c) else {
            cx += 6 * scale;
            continue;
        };
        for (row, bits) in g.iter().enumerate() {
            for col in 0..5u32 {
                if bits & (0x10 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (cx + col * scale + dx, y + row as u32 * scale + dy);
                        if px < w && py < h {
                            let i = ((py * w + px) * 4) as usize;
                            canvas.px[i..i + 3].copy_from_slice(&color);
                            canvas.px[i + 3] = 255;
                        }
                    }
                }
            }
        }
        cx += 6 * scale;
    }
}

/// Composes PNG tiles (all the same size) into a grid of `cols` columns with a
/// thin gutter, each labelled at its top left; returns the sheet as PNG bytes.
pub fn compose(tiles: &[(Vec<u8>, String)], cols: usize, background: [u8; 3]) -> Result<Vec<u8>, SheetError> {
    let decoded: Vec<(u32, u32, Vec<u8>)> = tiles.iter().map(|(png, _)| decode_png(png)).collect::<Result<_, _>>()?;
    let (tw, th) = decoded.first().map(|d| (d.0, d.1)).ok_or(SheetError::NoTiles)?;
    if decoded.iter().any(|d| (d.0, d.1) != (tw, th)) {
        return Err(SheetError::TilesDiffer);
    }
    let cols = cols.clamp(1, decoded.len());
    let rows = decoded.len().div_ceil(cols);
    let gap = 4u32;
    let (w, h) = (cols as u32 * (tw + gap) + gap, rows as u32 * (th + gap) + gap);
    let mut out: Vec<u8> = (0..w * h).flat_map(|_| [background[0], background[1], background[2], 255]).collect();
    for (k, (tw_, th_, px)) in decoded.iter().enumerate() {
        let (x0, y0) = (gap + (k % cols) as u32 * (tw + gap), gap + (k / cols) as u32 * (th + gap));
        for y in 0..*th_ {
            let src = &px[(y * tw_ * 4) as usize..((y + 1) * tw_ * 4) as usize];
            let at = (((y0 + y) * w + x0) * 4) as usize;
            out[at..at + src.len()].copy_from_slice(src);
        }
        let label = &tiles[k].1;
        draw_text(&mut Canvas { px: &mut out, w, h }, x0 + 8, y0 + 8, label, 3, [40, 40, 48]);
    }
    mdg_vm::preview::encode_png(&out, w, h).map_err(SheetError::Encode)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn composes_tiles_in_a_grid_with_labels() {
        let tile = |v: u8| mdg_vm::preview::encode_png(&[v; 64 * 64 * 4], 64, 64).expect("png");
        let tiles: Vec<(Vec<u8>, String)> = (0..5).map(|i| (tile(40 * i as u8 + 20), format!("g1-0{i}"))).collect();
        let sheet = compose(&tiles, 3, [200, 200, 200]).expect("sheet");
        let (w, h, px) = decode_png(&sheet).expect("decode");
        assert_eq!((w, h), (3 * 68 + 4, 2 * 68 + 4));
        let at = |x: u32, y: u32| px[((y * w + x) * 4) as usize];
        // The fifth tile (row 1, column 1) starts at (72, 72): its far corner has
        // its colour, its label is dark, the gutter and the empty sixth cell are
        // the background.
        assert_eq!(at(72 + 62, 72 + 62), 40 * 4 + 20);
        let label_dark = (72 + 8..72 + 40).any(|x| (72 + 8..72 + 35).any(|y| at(x, y) == 40));
        assert!(label_dark, "the label is drawn");
        assert_eq!(at(2, 2), 200);
        assert_eq!(at(140 + 30, 72 + 30), 200);
    }

    #[test]
    fn sheets_that_cannot_be_made_say_why() {
        assert!(matches!(compose(&[], 3, [0; 3]), Err(SheetError::NoTiles)));
        let e = decode_png(b"not a png").expect_err("not a PNG");
        assert!(matches!(e, SheetError::Decode(_)), "{e:?}");
        assert!(e.to_string().starts_with("cannot decode PNG: "), "{e}");
        let tile =
            |n: u32| (mdg_vm::preview::encode_png(&vec![9; (n * n * 4) as usize], n, n).expect("png"), "t".into());
        assert!(matches!(compose(&[tile(4), tile(5)], 2, [0; 3]), Err(SheetError::TilesDiffer)));
    }
}
