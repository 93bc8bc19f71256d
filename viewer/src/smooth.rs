//! Edge smoothing of a picture drawn with one sample, on the CPU after read-back:
//! an FXAA-style filter (after Lottes' "Fast Approximate Anti-Aliasing", written
//! here from its description).
//!
//! Multisampling on a CPU driver (lavapipe) rasterises and shades every sample in
//! software, so 4× costs several times the fragment work of 1×; a GPU does it
//! nearly for free. Offscreen pictures on a CPU driver are therefore drawn with one
//! sample and smoothed here: for each pixel on a contrast edge (its luma differs
//! from its neighbours' by more than a threshold), the edge's direction is found
//! from the 3 × 3 neighbourhood, the edge is followed both ways to its ends, and the
//! pixel is blended with its neighbour across the edge by how far it lies from the
//! nearer end (staircases become ramps); lone bright or dark pixels (sub-pixel
//! detail) are blended toward their neighbourhood's average. Pixels off edges are
//! left exactly as drawn. Everything is a fixed function of the input bytes, so
//! the output is deterministic.

/// A pixel must differ from its neighbourhood by this much luma (of 1) to be
/// smoothed…
const EDGE_THRESHOLD: f32 = 0.125;
/// …and by at least this much in dark regions.
const EDGE_THRESHOLD_MIN: f32 = 0.0312;
/// How much of the sub-pixel blend is applied (0: none, 1: full).
const SUBPIXEL: f32 = 0.75;
/// The farthest an edge is followed each way, in pixels.
const MAX_SEARCH: i32 = 16;

/// Smooths the edges of an RGBA8 picture (rows top to bottom) in place.
pub fn smooth_edges(rgba: &mut [u8], width: u32, height: u32) {
    let (w, h) = (width as usize, height as usize);
    if w < 3 || h < 3 || rgba.len() < w * h * 4 {
        return;
    }
    let luma: Vec<f32> = rgba
        .chunks_exact(4)
        .take(w * h)
        .map(|p| (0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2])) / 255.0)
        .collect();
    let src = rgba[..w * h * 4].to_vec();
    let at = |x: i32, y: i32| -> f32 {
        let (x, y) = (x.clamp(0, w as i32 - 1) as usize, y.clamp(0, h as i32 - 1) as usize);
        luma[y * w + x]
    };
    for y in 0..h as i32 {
        for x in 0..w as i32 {
            let Some((dx, dy, amount)) = blend_at(&at, x, y) else { continue };
            let (nx, ny) = ((x + dx).clamp(0, w as i32 - 1) as usize, (y + dy).clamp(0, h as i32 - 1) as usize);
            let (i, j) = ((y as usize * w + x as usize) * 4, (ny * w + nx) * 4);
            for c in 0..4 {
                let (a, b) = (f32::from(src[i + c]), f32::from(src[j + c]));
                rgba[i + c] = (a + (b - a) * amount).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

/// For the pixel at (x, y): the neighbour to blend with (a unit step across the
/// edge) and how much of it (0..1), or `None` when the pixel is not on an edge.
fn blend_at(at: &impl Fn(i32, i32) -> f32, x: i32, y: i32) -> Option<(i32, i32, f32)> {
    let m = at(x, y);
    let (n, s, e, wst) = (at(x, y - 1), at(x, y + 1), at(x + 1, y), at(x - 1, y));
    let hi = m.max(n).max(s).max(e).max(wst);
    let lo = m.min(n).min(s).min(e).min(wst);
    let range = hi - lo;
    if range < EDGE_THRESHOLD_MIN.max(hi * EDGE_THRESHOLD) {
        return None;
    }
    let (nw, ne, sw, se) = (at(x - 1, y - 1), at(x + 1, y - 1), at(x - 1, y + 1), at(x + 1, y + 1));
    // How much luma changes vertically (a horizontal edge) and horizontally.
    let change_vertical = (nw + sw - 2.0 * wst).abs() + 2.0 * (n + s - 2.0 * m).abs() + (ne + se - 2.0 * e).abs();
    let change_horizontal = (nw + ne - 2.0 * n).abs() + 2.0 * (wst + e - 2.0 * m).abs() + (sw + se - 2.0 * s).abs();
    let horizontal_edge = change_vertical >= change_horizontal;
    // The two neighbours across the edge; the steeper side is the one to blend with.
    let (l1, l2) = if horizontal_edge { (n, s) } else { (wst, e) };
    let (g1, g2) = (l1 - m, l2 - m);
    let first_steeper = g1.abs() >= g2.abs();
    let gradient = 0.25 * g1.abs().max(g2.abs());
    let (across, local_average) = if first_steeper { (-1, 0.5 * (l1 + m)) } else { (1, 0.5 * (l2 + m)) };
    let (cx, cy) = if horizontal_edge { (0, across) } else { (across, 0) };
    // Along the edge: the mean luma of the pixel pair straddling it, relative to the
    // local average, until it changes by more than the gradient (the edge's end).
    let (ax, ay) = if horizontal_edge { (1, 0) } else { (0, 1) };
    let pair = |k: i32| 0.5 * (at(x + ax * k, y + ay * k) + at(x + ax * k + cx, y + ay * k + cy)) - local_average;
    // Beyond the picture's border the edge continues (pixels are clamped), so only
    // a change of luma ends it; an end not found within the search is no end.
    let walk = |dir: i32| -> (i32, f32, bool) {
        let mut k = dir;
        loop {
            let delta = pair(k);
            if delta.abs() >= gradient {
                return (k.abs(), delta, true);
            }
            if k.abs() >= MAX_SEARCH {
                return (k.abs(), delta, false);
            }
            k += dir;
        }
    };
    let (d1, end1, found1) = walk(-1);
    let (d2, end2, found2) = walk(1);
    let (nearer, end, found) = if d1 < d2 { (d1, end1, found1) } else { (d2, end2, found2) };
    let length = (d1 + d2) as f32;
    // Blend only where the end's luma moves away from this pixel's side: that is
    // the staircase whose step this pixel is on.
    let centre_smaller = m - local_average < 0.0;
    let edge_blend = if found && (end < 0.0) != centre_smaller { 0.5 - nearer as f32 / length } else { 0.0 };
    // Sub-pixel detail: how far the pixel is from its neighbourhood's average.
    let average = (2.0 * (n + s + e + wst) + nw + ne + sw + se) / 12.0;
    let sub = ((average - m).abs() / range).clamp(0.0, 1.0);
    let sub = (-2.0 * sub + 3.0) * sub * sub;
    let amount = edge_blend.max(sub * sub * SUBPIXEL);
    (amount > 0.0).then_some((cx, cy, amount.min(1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picture(w: u32, h: u32, inside: impl Fn(u32, u32) -> bool) -> Vec<u8> {
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .flat_map(|(x, y)| if inside(x, y) { [255u8, 255, 255, 255] } else { [0, 0, 0, 255] })
            .collect()
    }

    #[test]
    fn flat_regions_are_untouched_and_straight_edges_barely() {
        let mut flat = picture(16, 16, |_, _| false);
        let before = flat.clone();
        smooth_edges(&mut flat, 16, 16);
        assert_eq!(flat, before);
        // A vertical edge along pixel boundaries has no staircase: only the sub-pixel
        // term touches it, a little, and only the two columns beside it.
        let mut half = picture(16, 16, |x, _| x >= 8);
        let before = half.clone();
        smooth_edges(&mut half, 16, 16);
        for (i, (a, b)) in half.iter().zip(&before).enumerate() {
            let x = (i / 4) % 16;
            if a != b {
                assert!((x == 7 || x == 8) && a.abs_diff(*b) <= 16, "pixel {x} changed from {b} to {a}");
            }
        }
    }

    #[test]
    fn a_staircase_edge_becomes_a_ramp_and_stays_within_its_pixels() {
        // A shallow slope (1 in 8): steps of 8 pixels.
        let (w, h) = (64, 32);
        let mut px = picture(w, h, |x, y| (y * 8) as f32 > x as f32 + 40.0);
        let before = px.clone();
        smooth_edges(&mut px, w, h);
        assert_ne!(px, before, "the staircase was smoothed");
        let grey = px.chunks_exact(4).filter(|p| p[0] != 0 && p[0] != 255).count();
        assert!(grey >= 16, "intermediate shades along the edge: {grey}");
        // Only pixels next to the edge change.
        for y in 0..h {
            for x in 0..w {
                let i = ((y * w + x) * 4) as usize;
                if px[i] != before[i] {
                    let near = [(0i32, -1i32), (0, 1), (-1, 0), (1, 0)].iter().any(|(dx, dy)| {
                        let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                        nx >= 0
                            && ny >= 0
                            && nx < w as i32
                            && ny < h as i32
                            && before[((ny as u32 * w + nx as u32) * 4) as usize] != before[i]
                    });
                    assert!(near, "pixel ({x}, {y}) changed away from the edge");
                }
            }
        }
        // Deterministic.
        let mut again = before.clone();
        smooth_edges(&mut again, w, h);
        assert_eq!(again, px);
    }

    #[test]
    fn a_lone_pixel_is_softened() {
        let mut px = picture(9, 9, |x, y| x == 4 && y == 4);
        smooth_edges(&mut px, 9, 9);
        let centre = px[(4 * 9 + 4) * 4];
        assert!(centre < 255 && centre > 0, "{centre}");
    }
}
