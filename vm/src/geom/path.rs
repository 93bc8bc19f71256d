//! Flat 2D paths (Context Free's `path`): curves flattened to polylines, filled
//! with the non-zero or even-odd rule, and stroked with joins and caps.
//!
//! Everything works on points in a plane (`[f64; 2]`); the evaluator maps a
//! path's points into the plane of the frame that paints it and the triangles back.
//!
//! - **Flattening** ([`quadratic`], [`cubic`], [`arc`]): a curve is cut into
//!   straight segments that stray from it by at most [`TOLERANCE`] of the curve's
//!   own size (the diagonal of its control points' box, or the arc's diameter), so
//!   the error stays under half a pixel when the curve fills a 500-pixel picture and
//!   shrinks with the curve; at most [`MAX_SEGMENTS`] segments per curve.
//! - **Filling** ([`fill`]): a trapezoid decomposition. The plane is cut into
//!   horizontal slabs at every vertex's y; a slab where two edges cross is cut again
//!   at the crossing, so inside a slab no edges cross and, ordered by x, they
//!   alternate between inside and outside by the winding rule. Every inside span is
//!   a trapezoid (two triangles, one where it ends in a point). Correct for holes,
//!   several contours and self-intersections, for both rules; no triangle overlaps
//!   another, so a translucent fill is painted once.
//! - **Stroking** ([`stroke`]): each segment is a rectangle of the width, each
//!   vertex gets its join (miter with Context Free's limit 4, else bevel; round;
//!   bevel) and each open end its cap (butt, round, square); the pieces, all turned
//!   counter-clockwise, are filled as one with the non-zero rule, which is their
//!   union: overlaps are painted once.

/// A point in the plane.
pub type P2 = [f64; 2];

/// How far a flattened curve may stray from the curve, as a fraction of its size.
pub const TOLERANCE: f64 = 1e-3;

/// The most segments one curve is cut into.
pub const MAX_SEGMENTS: usize = 256;

/// The miter limit (the miter's length over half the width), as Context Free's
/// (Anti-Grain Geometry's default): a sharper corner gets a bevel.
pub const MITER_LIMIT: f64 = 4.0;

/// How the inside of a fill is decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FillRule {
    /// Inside where the winding number is not zero (Context Free's default).
    NonZero,
    /// Inside where the winding number is odd (`evenodd`).
    EvenOdd,
}

/// How two stroked segments meet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Join {
    Miter,
    Round,
    Bevel,
}

/// How an open stroke ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cap {
    Butt,
    Round,
    Square,
}

fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}
fn add(a: P2, b: P2) -> P2 {
    [a[0] + b[0], a[1] + b[1]]
}
fn mul(a: P2, k: f64) -> P2 {
    [a[0] * k, a[1] * k]
}
fn cross(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}
fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}
fn len(a: P2) -> f64 {
    a[0].hypot(a[1])
}

fn extent(pts: &[P2]) -> f64 {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0].is_finite() {
        len(sub(hi, lo))
    } else {
        0.0
    }
}

fn segments_for(deviation: f64, size: f64, k: f64) -> usize {
    let tol = TOLERANCE * size;
    if tol.is_nan() || tol <= 0.0 || !deviation.is_finite() {
        return 1;
    }
    ((k * deviation / tol).sqrt().ceil() as usize).clamp(1, MAX_SEGMENTS)
}

/// The quadratic Bézier from `p0` through control `c` to `p1`, flattened: the
/// points after `p0`, ending with `p1`.
pub fn quadratic(p0: P2, c: P2, p1: P2, out: &mut Vec<P2>) {
    // The deviation of n chords is at most |p0 - 2c + p1| / (8 n²).
    let dd = len(add(sub(p0, mul(c, 2.0)), p1));
    let n = segments_for(dd, extent(&[p0, c, p1]), 0.125);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let u = 1.0 - t;
        out.push(if i == n { p1 } else { add(add(mul(p0, u * u), mul(c, 2.0 * u * t)), mul(p1, t * t)) });
    }
}

/// The cubic Bézier from `p0` with controls `c1`, `c2` to `p1`, flattened: the
/// points after `p0`, ending with `p1`.
pub fn cubic(p0: P2, c1: P2, c2: P2, p1: P2, out: &mut Vec<P2>) {
    // The deviation of n chords is at most 3/4 · max second difference / n².
    let d1 = len(add(sub(p0, mul(c1, 2.0)), c2));
    let d2 = len(add(sub(c1, mul(c2, 2.0)), p1));
    let n = segments_for(d1.max(d2), extent(&[p0, c1, c2, p1]), 0.75);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let u = 1.0 - t;
        out.push(if i == n {
            p1
        } else {
            let a = add(mul(p0, u * u * u), mul(c1, 3.0 * u * u * t));
            add(a, add(mul(c2, 3.0 * u * t * t), mul(p1, t * t * t)))
        });
    }
}

/// The elliptical arc from `p0` to `p1` with radii `rx`, `ry`, the ellipse's x
/// axis turned by `angle` degrees, the larger of the two possible arcs when
/// `large`, drawn clockwise when `cw` (counter-clockwise otherwise), as SVG's and
/// Context Free's `ARCTO`: radii too small to reach are scaled up until they do;
/// a zero radius is a straight line. The points after `p0`, ending with `p1`.
#[allow(clippy::too_many_arguments)]
pub fn arc(p0: P2, p1: P2, rx: f64, ry: f64, angle: f64, large: bool, cw: bool, out: &mut Vec<P2>) {
    let (mut rx, mut ry) = (rx.abs(), ry.abs());
    if p0 == p1 {
        return;
    }
    if rx.is_nan() || ry.is_nan() || rx <= 0.0 || ry <= 0.0 || !rx.is_finite() || !ry.is_finite() {
        out.push(p1);
        return;
    }
    let (sin, cos) = angle.to_radians().sin_cos();
    // The midpoint, in the ellipse's axes (SVG implementation notes, F.6.5).
    let h = mul(sub(p0, p1), 0.5);
    let x1 = cos * h[0] + sin * h[1];
    let y1 = -sin * h[0] + cos * h[1];
    let lambda = (x1 / rx).powi(2) + (y1 / ry).powi(2);
    if lambda > 1.0 {
        let k = lambda.sqrt();
        rx *= k;
        ry *= k;
    }
    let num = (rx * rx * ry * ry - rx * rx * y1 * y1 - ry * ry * x1 * x1).max(0.0);
    let den = rx * rx * y1 * y1 + ry * ry * x1 * x1;
    let mut k = if den > 0.0 { (num / den).sqrt() } else { 0.0 };
    // Counter-clockwise (positive sweep) is SVG's sweep flag 1 in a y-up plane.
    let sweep = !cw;
    if large == sweep {
        k = -k;
    }
    let (cx1, cy1) = (k * rx * y1 / ry, -k * ry * x1 / rx);
    let mid = mul(add(p0, p1), 0.5);
    let centre = [cos * cx1 - sin * cy1 + mid[0], sin * cx1 + cos * cy1 + mid[1]];
    let ang = |ux: f64, uy: f64| uy.atan2(ux);
    let t0 = ang((x1 - cx1) / rx, (y1 - cy1) / ry);
    let t1 = ang((-x1 - cx1) / rx, (-y1 - cy1) / ry);
    let mut dt = t1 - t0;
    let tau = std::f64::consts::TAU;
    if sweep && dt < 0.0 {
        dt += tau;
    } else if !sweep && dt > 0.0 {
        dt -= tau;
    }
    // Chords of angle θ stray r (1 - cos θ/2) from a circle of radius r; the size is
    // the diameter.
    let step = 2.0 * (1.0 - 2.0 * TOLERANCE).acos();
    let n = ((dt.abs() / step).ceil() as usize).clamp(1, MAX_SEGMENTS);
    for i in 1..=n {
        if i == n {
            out.push(p1);
            break;
        }
        let t = t0 + dt * i as f64 / n as f64;
        let (s, c) = t.sin_cos();
        let (ex, ey) = (rx * c, ry * s);
        out.push([cos * ex - sin * ey + centre[0], sin * ex + cos * ey + centre[1]]);
    }
}

/// An edge of a fill, its ends ordered by y.
#[derive(Clone, Copy)]
struct Edge {
    lo: P2,
    hi: P2,
    /// +1 for an edge that goes up, -1 for one that goes down.
    wind: i32,
}

impl Edge {
    fn x_at(&self, y: f64) -> f64 {
        let dy = self.hi[1] - self.lo[1];
        if dy <= 0.0 {
            return self.lo[0];
        }
        let t = ((y - self.lo[1]) / dy).clamp(0.0, 1.0);
        self.lo[0] + (self.hi[0] - self.lo[0]) * t
    }
}

/// How deep a slab is cut at crossings before it is painted as it is.
const MAX_SPLITS: u32 = 48;

/// Fills the closed `contours` (each closes back to its first point) by `rule`,
/// appending counter-clockwise triangles to `out`. Non-finite points are left out.
pub fn fill(contours: &[Vec<P2>], rule: FillRule, out: &mut Vec<[P2; 3]>) {
    let mut edges = Vec::new();
    let mut ys = Vec::new();
    for c in contours {
        let pts: Vec<P2> = c.iter().copied().filter(|p| p[0].is_finite() && p[1].is_finite()).collect();
        if pts.len() < 3 {
            continue;
        }
        for i in 0..pts.len() {
            let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
            ys.push(a[1]);
            if a[1] == b[1] {
                continue;
            }
            edges.push(if a[1] < b[1] { Edge { lo: a, hi: b, wind: 1 } } else { Edge { lo: b, hi: a, wind: -1 } });
        }
    }
    if edges.is_empty() {
        return;
    }
    ys.sort_by(f64::total_cmp);
    ys.dedup();
    edges.sort_by(|a, b| a.lo[1].total_cmp(&b.lo[1]));
    let all: Vec<P2> = edges.iter().flat_map(|e| [e.lo, e.hi]).collect();
    let eps = extent(&all) * 1e-12;
    let mut active: Vec<Edge> = Vec::new();
    let mut next = 0;
    for w in ys.windows(2) {
        let (y0, y1) = (w[0], w[1]);
        active.retain(|e| e.hi[1] > y0);
        while next < edges.len() && edges[next].lo[1] <= y0 {
            if edges[next].hi[1] > y0 {
                active.push(edges[next]);
            }
            next += 1;
        }
        slab(&active, y0, y1, rule, eps, 0, out);
    }
}

fn slab(active: &[Edge], y0: f64, y1: f64, rule: FillRule, eps: f64, depth: u32, out: &mut Vec<[P2; 3]>) {
    if active.len() < 2 || y1 <= y0 {
        return;
    }
    let ym = 0.5 * (y0 + y1);
    let mut row: Vec<(f64, f64, f64, i32)> =
        active.iter().map(|e| (e.x_at(y0), e.x_at(ym), e.x_at(y1), e.wind)).collect();
    row.sort_by(|a, b| a.1.total_cmp(&b.1));
    if depth < MAX_SPLITS {
        // Adjacent edges (by x at mid-height) that swap order within the slab cross:
        // cut the slab at the crossings (any crossing shows as an adjacent one).
        let mut cuts = Vec::new();
        for p in row.windows(2) {
            let (a, b) = (p[0], p[1]);
            let d0 = b.0 - a.0;
            let d1 = b.2 - a.2;
            if d0 < -eps || d1 < -eps {
                let t = d0 / (d0 - d1);
                if t.is_finite() {
                    let y = y0 + (y1 - y0) * t.clamp(0.0, 1.0);
                    if y > y0 + eps && y < y1 - eps {
                        cuts.push(y);
                    }
                }
            }
        }
        if !cuts.is_empty() {
            cuts.sort_by(f64::total_cmp);
            cuts.dedup();
            let mut from = y0;
            for y in cuts.into_iter().chain(std::iter::once(y1)) {
                slab(active, from, y, rule, eps, depth + 1, out);
                from = y;
            }
            return;
        }
    }
    let mut wind = 0;
    for p in row.windows(2) {
        wind += p[0].3;
        let inside = match rule {
            FillRule::NonZero => wind != 0,
            FillRule::EvenOdd => wind % 2 != 0,
        };
        if !inside {
            continue;
        }
        let (a, b) = (p[0], p[1]);
        let (l0, r0, l1, r1) = ([a.0, y0], [b.0, y0], [a.2, y1], [b.2, y1]);
        if r0[0] - l0[0] > eps {
            out.push([l0, r0, if r1[0] - l1[0] > eps { r1 } else { l1 }]);
        }
        if r1[0] - l1[0] > eps {
            out.push([if r0[0] - l0[0] > eps { l0 } else { r0 }, r1, l1]);
        }
    }
}

/// The signed area of a closed polygon (positive: counter-clockwise).
fn area(p: &[P2]) -> f64 {
    (0..p.len()).map(|i| cross(p[i], p[(i + 1) % p.len()])).sum::<f64>() * 0.5
}

fn ccw(mut p: Vec<P2>) -> Vec<P2> {
    if area(&p) < 0.0 {
        p.reverse();
    }
    p
}

/// Points on the circle round `c` of radius `r` from direction `from` turning by
/// `sweep` radians (the ends included).
fn fan(c: P2, r: f64, from: f64, sweep: f64, out: &mut Vec<P2>) {
    let step = 2.0 * (1.0 - 2.0 * TOLERANCE).acos();
    let n = ((sweep.abs() / step).ceil() as usize).clamp(1, MAX_SEGMENTS);
    for i in 0..=n {
        let t = from + sweep * i as f64 / n as f64;
        out.push([c[0] + r * t.cos(), c[1] + r * t.sin()]);
    }
}

/// Strokes the polylines `lines` (each with whether it is closed) with `width`,
/// `join` and `cap`, appending counter-clockwise triangles to `out`.
pub fn stroke(lines: &[(Vec<P2>, bool)], width: f64, join: Join, cap: Cap, out: &mut Vec<[P2; 3]>) {
    let hw = 0.5 * width.abs();
    if hw.is_nan() || hw <= 0.0 || !hw.is_finite() {
        return;
    }
    let mut pieces: Vec<Vec<P2>> = Vec::new();
    for (pts, closed) in lines {
        // Repeated points make no segment.
        let mut p: Vec<P2> = Vec::with_capacity(pts.len());
        for q in pts.iter().filter(|q| q[0].is_finite() && q[1].is_finite()) {
            if p.last() != Some(q) {
                p.push(*q);
            }
        }
        let closed = *closed && p.len() > 2;
        if closed && p.first() == p.last() {
            p.pop();
        }
        if p.len() < 2 {
            // A lone point: a round or square cap draws a dot, as Context Free does.
            if let (Some(&c), false) = (p.first(), closed) {
                match cap {
                    Cap::Round => {
                        let mut d = Vec::new();
                        fan(c, hw, 0.0, std::f64::consts::TAU, &mut d);
                        d.pop();
                        pieces.push(d);
                    }
                    Cap::Square => pieces.push(vec![
                        [c[0] - hw, c[1] - hw],
                        [c[0] + hw, c[1] - hw],
                        [c[0] + hw, c[1] + hw],
                        [c[0] - hw, c[1] + hw],
                    ]),
                    Cap::Butt => {}
                }
            }
            continue;
        }
        let n = p.len();
        let segs = if closed { n } else { n - 1 };
        let dir = |i: usize| {
            let d = sub(p[(i + 1) % n], p[i]);
            mul(d, 1.0 / len(d))
        };
        for i in 0..segs {
            let (a, b) = (p[i], p[(i + 1) % n]);
            let d = dir(i);
            let nrm = [-d[1] * hw, d[0] * hw];
            pieces.push(ccw(vec![add(a, nrm), sub(a, nrm), sub(b, nrm), add(b, nrm)]));
        }
        // Joins at the inner vertices (every vertex of a closed line).
        let joins: Vec<usize> = if closed { (0..n).collect() } else { (1..n - 1).collect() };
        for v in joins {
            let (d0, d1) = (dir((v + n - 1) % n), dir(v));
            let c = p[v];
            let turn = cross(d0, d1);
            if turn.abs() < 1e-12 && dot(d0, d1) > 0.0 {
                continue;
            }
            // The outer side: right of the path for a left turn, left for a right turn.
            let side = if turn > 0.0 { -1.0 } else { 1.0 };
            let o0 = mul([-d0[1], d0[0]], hw * side);
            let o1 = mul([-d1[1], d1[0]], hw * side);
            let (a, b) = (add(c, o0), add(c, o1));
            match join {
                Join::Round => {
                    let from = o0[1].atan2(o0[0]);
                    let mut sweep = o1[1].atan2(o1[0]) - from;
                    let tau = std::f64::consts::TAU;
                    while sweep > std::f64::consts::PI {
                        sweep -= tau;
                    }
                    while sweep < -std::f64::consts::PI {
                        sweep += tau;
                    }
                    let mut f = vec![c];
                    fan(c, hw, from, sweep, &mut f);
                    pieces.push(ccw(f));
                }
                Join::Miter | Join::Bevel => {
                    // The miter's tip: where the two outer edges meet.
                    let cos_half = ((1.0 + dot(d0, d1)) * 0.5).max(0.0).sqrt();
                    let miter = if join == Join::Miter && cos_half > 1.0 / MITER_LIMIT {
                        let m = add(o0, o1);
                        let ml = len(m);
                        (ml > 0.0).then(|| add(c, mul(m, hw / cos_half / ml)))
                    } else {
                        None
                    };
                    match miter {
                        Some(m) => pieces.push(ccw(vec![c, a, m, b])),
                        None => pieces.push(ccw(vec![c, a, b])),
                    }
                }
            }
        }
        if !closed {
            for (end, d) in [(p[0], mul(dir(0), -1.0)), (p[n - 1], dir(n - 2))] {
                let nrm = [-d[1] * hw, d[0] * hw];
                match cap {
                    Cap::Butt => {}
                    Cap::Square => {
                        let e = add(end, mul(d, hw));
                        pieces.push(ccw(vec![add(end, nrm), sub(end, nrm), sub(e, nrm), add(e, nrm)]));
                    }
                    Cap::Round => {
                        let from = nrm[1].atan2(nrm[0]);
                        let mut f = Vec::new();
                        fan(end, hw, from, -std::f64::consts::PI, &mut f);
                        pieces.push(ccw(f));
                    }
                }
            }
        }
    }
    fill(&pieces, FillRule::NonZero, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_of(t: &[[P2; 3]]) -> f64 {
        t.iter().map(|t| area(t)).sum()
    }

    fn square(c: P2, s: f64, ccw_: bool) -> Vec<P2> {
        let h = s / 2.0;
        let mut v = vec![[c[0] - h, c[1] - h], [c[0] + h, c[1] - h], [c[0] + h, c[1] + h], [c[0] - h, c[1] + h]];
        if !ccw_ {
            v.reverse();
        }
        v
    }

    #[test]
    fn a_square_fills_its_area_with_counter_clockwise_triangles() {
        let mut t = Vec::new();
        fill(&[square([0.0, 0.0], 2.0, false)], FillRule::NonZero, &mut t);
        assert!((area_of(&t) - 4.0).abs() < 1e-9, "{}", area_of(&t));
        assert!(t.iter().all(|t| area(t) > 0.0));
    }

    #[test]
    fn a_hole_is_left_out_by_both_rules_when_it_winds_the_other_way() {
        let outer = square([0.0, 0.0], 4.0, true);
        let hole = square([0.0, 0.0], 2.0, false);
        for rule in [FillRule::NonZero, FillRule::EvenOdd] {
            let mut t = Vec::new();
            fill(&[outer.clone(), hole.clone()], rule, &mut t);
            assert!((area_of(&t) - 12.0).abs() < 1e-9, "{rule:?}: {}", area_of(&t));
        }
        // Wound the same way, the inner square is a hole only for even-odd.
        let same = square([0.0, 0.0], 2.0, true);
        let (mut nz, mut eo) = (Vec::new(), Vec::new());
        fill(&[outer.clone(), same.clone()], FillRule::NonZero, &mut nz);
        fill(&[outer, same], FillRule::EvenOdd, &mut eo);
        assert!((area_of(&nz) - 16.0).abs() < 1e-9);
        assert!((area_of(&eo) - 12.0).abs() < 1e-9);
    }

    #[test]
    fn a_pentagram_self_intersects_its_centre_in_or_out_by_the_rule() {
        let star: Vec<P2> = (0..5)
            .map(|k| {
                let a = (90.0 + 144.0 * k as f64).to_radians();
                [a.cos(), a.sin()]
            })
            .collect();
        let (mut nz, mut eo) = (Vec::new(), Vec::new());
        fill(std::slice::from_ref(&star), FillRule::NonZero, &mut nz);
        fill(&[star], FillRule::EvenOdd, &mut eo);
        // The centre is the inner pentagon, circumradius 1/φ², wound twice.
        let pent_r = 0.381_966_011_250_105_1; // 1/φ²: the inner pentagon's circumradius
        let pent = 2.5 * pent_r * pent_r * 72f64.to_radians().sin();
        let diff = area_of(&nz) - area_of(&eo);
        assert!((diff - pent).abs() < 1e-6, "non-zero minus even-odd {diff}, pentagon {pent}");
        assert!(nz.iter().chain(&eo).all(|t| area(t) > 0.0));
    }

    #[test]
    fn a_circle_from_two_arcs_is_round_within_the_tolerance() {
        let mut pts = vec![[1.0, 0.0]];
        arc([1.0, 0.0], [-1.0, 0.0], 1.0, 1.0, 0.0, false, false, &mut pts);
        assert!(pts.iter().all(|p| p[1] >= -1e-12), "counter-clockwise from (1, 0) goes up");
        arc([-1.0, 0.0], [1.0, 0.0], 1.0, 1.0, 0.0, false, false, &mut pts);
        let mut t = Vec::new();
        fill(&[pts.clone()], FillRule::NonZero, &mut t);
        let a = area_of(&t);
        assert!((a - std::f64::consts::PI).abs() < 0.01 * std::f64::consts::PI, "{a}");
        assert!(pts.len() > 20 && pts.len() < 200, "{}", pts.len());
        // Clockwise goes down; `large` picks the other centre.
        let mut cw = vec![];
        arc([1.0, 0.0], [-1.0, 0.0], 1.0, 1.0, 0.0, false, true, &mut cw);
        assert!(cw.iter().all(|p| p[1] <= 1e-12));
        let mut big = vec![];
        arc([0.0, 0.0], [1.0, 0.0], 1.0, 1.0, 0.0, true, false, &mut big);
        let lowest = big.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
        assert!(lowest < -1.5, "the large arc swings round the far side: {lowest}");
    }

    #[test]
    fn curves_end_on_their_end_point_and_pass_their_midpoint() {
        let mut q = vec![];
        quadratic([0.0, 0.0], [1.0, 2.0], [2.0, 0.0], &mut q);
        assert_eq!(q.last(), Some(&[2.0, 0.0]));
        let top = q.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!((top - 1.0).abs() < 2e-3, "{top}");
        let mut c = vec![];
        cubic([0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0], &mut c);
        assert_eq!(c.last(), Some(&[1.0, 0.0]));
        let top = c.iter().map(|p| p[1]).fold(0.0, f64::max);
        assert!((top - 0.75).abs() < 2e-3, "{top}");
    }

    #[test]
    fn a_stroke_covers_its_length_times_width_and_overlaps_once() {
        let mut t = Vec::new();
        stroke(&[(vec![[0.0, 0.0], [2.0, 0.0]], false)], 0.5, Join::Miter, Cap::Butt, &mut t);
        assert!((area_of(&t) - 1.0).abs() < 1e-9, "{}", area_of(&t));
        // A right angle with a miter: two rectangles (their inner corner square
        // counted once) plus the outer corner square.
        let mut t = Vec::new();
        stroke(&[(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]], false)], 0.5, Join::Miter, Cap::Butt, &mut t);
        assert!((area_of(&t) - (2.0 - 0.0625 + 0.0625)).abs() < 1e-9, "{}", area_of(&t));
        // A bevel cuts the corner square in half; square caps add half a width each end.
        let mut t = Vec::new();
        stroke(&[(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]], false)], 0.5, Join::Bevel, Cap::Square, &mut t);
        assert!((area_of(&t) - (2.0 - 0.0625 + 0.03125 + 2.0 * 0.125)).abs() < 1e-9, "{}", area_of(&t));
        // A closed square outline: outer minus inner square.
        let mut t = Vec::new();
        stroke(&[(square([0.0, 0.0], 2.0, true), true)], 0.5, Join::Miter, Cap::Butt, &mut t);
        assert!((area_of(&t) - (2.5f64.powi(2) - 1.5f64.powi(2))).abs() < 1e-9, "{}", area_of(&t));
        assert!(t.iter().all(|t| area(t) > 0.0));
    }

    #[test]
    fn a_sharp_turn_is_bevelled_past_the_miter_limit() {
        let (mut m, mut b) = (Vec::new(), Vec::new());
        let line = vec![[0.0, 0.0], [2.0, 0.0], [0.0, 0.1]];
        stroke(&[(line.clone(), false)], 0.2, Join::Miter, Cap::Butt, &mut m);
        stroke(&[(line, false)], 0.2, Join::Bevel, Cap::Butt, &mut b);
        assert!((area_of(&m) - area_of(&b)).abs() < 1e-12);
    }
}
