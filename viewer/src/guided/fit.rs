//! Fitting a drawn stroke with a chain of cubic Bézier segments (Schneider's
//! algorithm, "An Algorithm for Automatically Fitting Digitized Curves", Graphics
//! Gems 1990, written here from its description).
//!
//! The points are given chord-length parameters; one cubic is fitted by least
//! squares with its end tangents fixed (only the lengths of the two inner handles
//! are free); when the largest distance from a point to the cubic exceeds the
//! tolerance, the parameters are improved by Newton–Raphson steps a few times, and
//! if that does not help the points are split at the worst one and both halves are
//! fitted the same way, sharing the tangent there. The joins are C1: the second half
//! is fitted with its first handle as long as the first half's last one (only its
//! other handle is free), so the two handles at a join lie on one line through it
//! with the same length and the chain's derivative is continuous with each segment
//! parameterised on [0, 1], as a guide's segments are (a stroke that turns back on
//! itself keeps that corner).

use glam::DVec3;

/// Newton–Raphson passes tried before a segment is split.
const MAX_REPARAMETERISE: usize = 20;
/// A cubic whose error is within this many tolerances is worth reparameterising.
const REPARAMETERISE_FACTOR: f64 = 16.0;

/// The control points (3k + 1) of a chain of k cubic Bézier segments through the
/// first and last of `points`, within `tolerance` of every point. Points closer
/// than a millionth of the stroke's extent to the previous one are dropped. `None`
/// when fewer than two distinct points remain or the input is not finite.
pub fn fit_stroke(points: &[DVec3], tolerance: f64) -> Option<Vec<DVec3>> {
    if points.iter().any(|p| !p.is_finite()) || !tolerance.is_finite() {
        return None;
    }
    let extent = points.iter().fold(0.0f64, |m, p| m.max((*p - points[0]).length()));
    let eps = (extent * 1e-6).max(f64::MIN_POSITIVE);
    let mut pts: Vec<DVec3> = Vec::with_capacity(points.len());
    for &p in points {
        if pts.last().is_none_or(|q: &DVec3| (p - *q).length() > eps) {
            pts.push(p);
        }
    }
    if pts.len() < 2 {
        return None;
    }
    let tolerance = tolerance.max(eps);
    let n = pts.len();
    let t_start = (pts[1] - pts[0]).normalize_or_zero();
    let t_end = (pts[n - 2] - pts[n - 1]).normalize_or_zero();
    let mut out = vec![pts[0]];
    fit_cubic(&pts, t_start, t_end, tolerance, None, &mut out);
    Some(out)
}

/// The point at `t` of the cubic `c`.
pub fn point_at(c: &[DVec3; 4], t: f64) -> DVec3 {
    let s = 1.0 - t;
    c[0] * (s * s * s) + c[1] * (3.0 * s * s * t) + c[2] * (3.0 * s * t * t) + c[3] * (t * t * t)
}

fn derivative(c: &[DVec3; 4], t: f64) -> DVec3 {
    let s = 1.0 - t;
    (c[1] - c[0]) * (3.0 * s * s) + (c[2] - c[1]) * (6.0 * s * t) + (c[3] - c[2]) * (3.0 * t * t)
}

fn second_derivative(c: &[DVec3; 4], t: f64) -> DVec3 {
    (c[2] - c[1] * 2.0 + c[0]) * (6.0 * (1.0 - t)) + (c[3] - c[2] * 2.0 + c[1]) * (6.0 * t)
}

/// Fits `pts` (at least two) with tangents `t1` at the start and `t2` at the end
/// (pointing into the curve from each end), the first handle `start_handle` long
/// when given, appending the control points after the first point to `out`.
/// Returns the length of the last handle.
fn fit_cubic(
    pts: &[DVec3],
    t1: DVec3,
    t2: DVec3,
    tolerance: f64,
    start_handle: Option<f64>,
    out: &mut Vec<DVec3>,
) -> f64 {
    let n = pts.len();
    let (first, last) = (pts[0], pts[n - 1]);
    let mut accept = |c: [DVec3; 4]| {
        out.extend(&c[1..]);
        (c[3] - c[2]).length()
    };
    if n == 2 {
        let third = (last - first).length() / 3.0;
        return accept([first, first + t1 * start_handle.unwrap_or(third), last + t2 * third, last]);
    }
    let mut u = chord_length_parameters(pts);
    let mut cubic = least_squares(pts, &u, t1, t2, start_handle);
    let (mut err, mut split) = max_error(pts, &cubic, &u);
    if err <= tolerance {
        return accept(cubic);
    }
    if err <= tolerance * REPARAMETERISE_FACTOR {
        for _ in 0..MAX_REPARAMETERISE {
            u = reparameterise(pts, &u, &cubic);
            cubic = least_squares(pts, &u, t1, t2, start_handle);
            (err, split) = max_error(pts, &cubic, &u);
            if err <= tolerance {
                return accept(cubic);
            }
        }
    }
    // Split at the worst point; both halves share the tangent there.
    let split = split.clamp(1, n - 2);
    let center = (pts[split - 1] - pts[split + 1]).normalize_or_zero();
    let (left, right) = if center == DVec3::ZERO {
        // A cusp (the stroke turns back on itself): each half keeps its own tangent.
        ((pts[split - 1] - pts[split]).normalize_or_zero(), (pts[split + 1] - pts[split]).normalize_or_zero())
    } else {
        (center, -center)
    };
    let handle = fit_cubic(&pts[..=split], t1, left, tolerance, start_handle, out);
    let cusp = center == DVec3::ZERO;
    fit_cubic(&pts[split..], right, t2, tolerance, (!cusp).then_some(handle), out)
}

/// Parameters in [0, 1] proportional to the distance along the polyline.
fn chord_length_parameters(pts: &[DVec3]) -> Vec<f64> {
    let mut u = Vec::with_capacity(pts.len());
    let mut s = 0.0;
    u.push(0.0);
    for w in pts.windows(2) {
        s += (w[1] - w[0]).length();
        u.push(s);
    }
    let total = s.max(f64::MIN_POSITIVE);
    u.iter_mut().for_each(|x| *x /= total);
    u
}

/// The cubic from `pts[0]` to the last point with handles along `t1` and `t2` whose
/// lengths minimise the squared distances to the points at parameters `u` (only the
/// second's when the first is given). When the system is singular or a handle would
/// point backwards, the free handles are a third of the chord (Schneider's
/// fallback).
fn least_squares(pts: &[DVec3], u: &[f64], t1: DVec3, t2: DVec3, start_handle: Option<f64>) -> [DVec3; 4] {
    let (first, last) = (pts[0], pts[pts.len() - 1]);
    let (mut c00, mut c01, mut c11, mut x0, mut x1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (p, &t) in pts.iter().zip(u) {
        let s = 1.0 - t;
        let (b0, b1, b2, b3) = (s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t);
        let a1 = t1 * b1;
        let a2 = t2 * b2;
        c00 += a1.dot(a1);
        c01 += a1.dot(a2);
        c11 += a2.dot(a2);
        let rest = *p - (first * (b0 + b1) + last * (b2 + b3));
        x0 += a1.dot(rest);
        x1 += a2.dot(rest);
    }
    let chord = (last - first).length();
    let eps = 1e-6 * chord;
    let usable = |a: f64| a.is_finite() && a >= eps;
    let (alpha1, alpha2) = match start_handle {
        Some(a1) => {
            // Only the second handle is free: minimise over it alone.
            let a2 = if c11 > 0.0 { (x1 - c01 * a1) / c11 } else { 0.0 };
            (a1, if usable(a2) { a2 } else { chord / 3.0 })
        }
        None => {
            let det = c00 * c11 - c01 * c01;
            let (a1, a2) = if det.abs() > 1e-12 * (c00 * c11).abs().max(f64::MIN_POSITIVE) {
                ((x0 * c11 - x1 * c01) / det, (c00 * x1 - c01 * x0) / det)
            } else {
                (0.0, 0.0)
            };
            if usable(a1) && usable(a2) {
                (a1, a2)
            } else {
                (chord / 3.0, chord / 3.0)
            }
        }
    };
    [first, first + t1 * alpha1, last + t2 * alpha2, last]
}

/// The largest distance from a point to the cubic at its parameter, and where.
fn max_error(pts: &[DVec3], c: &[DVec3; 4], u: &[f64]) -> (f64, usize) {
    let mut worst = (0.0, pts.len() / 2);
    for (i, (p, &t)) in pts.iter().zip(u).enumerate().skip(1).take(pts.len().saturating_sub(2)) {
        let d = (point_at(c, t) - *p).length();
        if d > worst.0 {
            worst = (d, i);
        }
    }
    worst
}

/// One Newton–Raphson step per point towards the parameter of the closest point of
/// the cubic: the root of (Q(t) − P) · Q′(t). Keeps the ends at 0 and 1 and the
/// parameters in order.
fn reparameterise(pts: &[DVec3], u: &[f64], c: &[DVec3; 4]) -> Vec<f64> {
    let mut v: Vec<f64> = pts
        .iter()
        .zip(u)
        .map(|(p, &t)| {
            let d = point_at(c, t) - *p;
            let q1 = derivative(c, t);
            let q2 = second_derivative(c, t);
            let num = d.dot(q1);
            let den = q1.dot(q1) + d.dot(q2);
            if den.abs() < 1e-12 {
                t
            } else {
                (t - num / den).clamp(0.0, 1.0)
            }
        })
        .collect();
    if let Some(f) = v.first_mut() {
        *f = 0.0;
    }
    if let Some(l) = v.last_mut() {
        *l = 1.0;
    }
    for i in 1..v.len() {
        if v[i] < v[i - 1] {
            v[i] = v[i - 1];
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    fn segments(cps: &[DVec3]) -> Vec<[DVec3; 4]> {
        cps.windows(4).step_by(3).map(|w| [w[0], w[1], w[2], w[3]]).collect()
    }

    /// The largest distance from each point to the chain (dense sampling).
    fn distance_to_chain(cps: &[DVec3], p: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        for c in segments(cps) {
            for k in 0..=2000 {
                best = best.min((point_at(&c, k as f64 / 2000.0) - p).length());
            }
        }
        best
    }

    #[test]
    fn a_sampled_cubic_comes_back_as_one_segment_through_the_same_points() {
        let c = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 2.0),
            DVec3::new(3.0, 0.0, 2.5),
            DVec3::new(4.0, 0.0, 0.5),
        ];
        let pts: Vec<DVec3> = (0..=60).map(|k| point_at(&c, k as f64 / 60.0)).collect();
        // The end tangents are estimated from the first and last chords, which
        // differ from the curve's by a little: within 0.03 of a curve 4.5 long.
        let tol = 0.03;
        let fit = fit_stroke(&pts, tol).expect("fits");
        assert_eq!(fit.len(), 4, "one segment: {fit:?}");
        assert!((fit[0] - c[0]).length() < 1e-12 && (fit[3] - c[3]).length() < 1e-12);
        // The curve, not only its samples, is recovered: each lies near the other.
        for k in 0..=20 {
            let t = k as f64 / 20.0;
            let d = distance_to_chain(&fit, point_at(&c, t));
            assert!(d < tol, "t {t}: {d}");
            let back = distance_to_chain(&c, point_at(&[fit[0], fit[1], fit[2], fit[3]], t));
            assert!(back < tol, "t {t}: {back}");
        }
    }

    #[test]
    fn a_straight_stroke_gives_a_straight_segment() {
        let pts: Vec<DVec3> = (0..=10).map(|k| DVec3::new(0.5 * k as f64, 0.0, 0.25 * k as f64)).collect();
        let fit = fit_stroke(&pts, 0.001).expect("fits");
        assert_eq!(fit.len(), 4);
        let dir = (fit[3] - fit[0]).normalize();
        for p in &fit {
            let off = (*p - fit[0]) - dir * (*p - fit[0]).dot(dir);
            assert!(off.length() < 1e-9, "{p:?} is off the line");
        }
        // The handles point inwards, in order along the line.
        let along: Vec<f64> = fit.iter().map(|p| (*p - fit[0]).dot(dir)).collect();
        assert!(along.windows(2).all(|w| w[0] < w[1]), "{along:?}");
    }

    #[test]
    fn a_wiggly_stroke_is_split_within_the_tolerance_with_c1_joins() {
        // An S over two periods: one cubic cannot follow it.
        let pts: Vec<DVec3> = (0..=200)
            .map(|k| {
                let t = k as f64 / 200.0;
                DVec3::new(4.0 * t, 0.0, (t * std::f64::consts::TAU * 2.0).sin())
            })
            .collect();
        let tol = 0.02;
        let fit = fit_stroke(&pts, tol).expect("fits");
        assert!(fit.len() > 4 && (fit.len() - 1).is_multiple_of(3), "{} points", fit.len());
        for p in &pts {
            assert!(distance_to_chain(&fit, *p) <= tol, "{p:?}");
        }
        for j in (3..fit.len() - 1).step_by(3) {
            let (a, b) = (fit[j] - fit[j - 1], fit[j + 1] - fit[j]);
            assert!((a - b).length() < 1e-9, "join {j}: handles {a:?} and {b:?} differ");
        }
    }

    #[test]
    fn degenerate_strokes_are_refused_or_straight() {
        assert!(fit_stroke(&[], 0.1).is_none());
        assert!(fit_stroke(&[DVec3::ONE; 5], 0.1).is_none());
        assert!(fit_stroke(&[DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0)], 0.1).is_none());
        let two = fit_stroke(&[DVec3::ZERO, DVec3::new(3.0, 0.0, 0.0)], 0.1).expect("two points");
        assert_eq!(
            two,
            vec![DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0), DVec3::new(3.0, 0.0, 0.0)]
        );
        // Back and forth over the same line (a cusp) still fits, within tolerance.
        let pts: Vec<DVec3> =
            (0..=20).map(|k| DVec3::new(if k <= 10 { k as f64 } else { 20.0 - k as f64 }, 0.0, 0.0)).collect();
        let fit = fit_stroke(&pts, 0.05).expect("fits");
        assert!(fit.iter().all(|p| p.is_finite()));
        for p in &pts {
            assert!(distance_to_chain(&fit, *p) < 0.2, "{p:?}");
        }
    }
}
