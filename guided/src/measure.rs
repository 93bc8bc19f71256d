//! Measures of how a skeleton follows its guides, and where guides lie beyond a
//! grammar's reach (docs/guided.md, "Coverage" and "Unreachable guides").
//!
//! * **Coverage**: points spaced evenly by arc length along each guide
//!   ([`COVERAGE_POINTS`] per guide), each *covered* when a bone (as a line segment)
//!   passes within [`COVERAGE_RADIUS`]; a guide's coverage is its share of covered
//!   points, a set's the length-weighted mean of its guides'.
//! * **Reach**: the farthest any bone tip of a number of unguided derivations got
//!   from the start shape's origin ([`super::Prepared::reach`]); a guide point
//!   farther than that from the origin is one no sampled skeleton came near, and
//!   [`beyond_reach`] reports each guide's run of such points and how far beyond the
//!   reach it goes.

use super::bezier::Path;
use super::cost::Guides;
use super::search::Bone;
use glam::DVec3;

/// Points along each guide for [`coverage`].
pub const COVERAGE_POINTS: usize = 400;
/// A guide point within this distance of a bone is covered.
pub const COVERAGE_RADIUS: f64 = 0.35;

/// `n` points along `path`, evenly spaced by arc length (at the middles of `n` equal
/// arcs), each with its arc position as a fraction of the length.
pub fn arc_samples(path: &Path, n: usize) -> Vec<(f64, DVec3)> {
    let poly = path.polyline(64);
    let mut cum = vec![0.0];
    for w in poly.windows(2) {
        let last = cum.last().copied().unwrap_or(0.0);
        cum.push(last + (w[1] - w[0]).length());
    }
    let total = cum.last().copied().unwrap_or(0.0);
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for i in 0..n {
        let f = (i as f64 + 0.5) / n as f64;
        let want = f * total;
        while j + 2 < cum.len() && cum[j + 1] < want {
            j += 1;
        }
        let (a, b) = (poly[j], poly[(j + 1).min(poly.len() - 1)]);
        let span = cum.get(j + 1).copied().unwrap_or(total) - cum[j];
        let t = if span > 0.0 { ((want - cum[j]) / span).clamp(0.0, 1.0) } else { 0.0 };
        out.push((f, a + (b - a) * t));
    }
    out
}

/// The distance from `p` to the segment `a`–`b`.
pub fn to_segment(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t - p).length()
}

/// How much of each guide, and of the set, the bones cover.
#[derive(Clone, Debug, PartialEq)]
pub struct Coverage {
    /// Per guide: which of its [`COVERAGE_POINTS`] points are covered, in order.
    pub covered: Vec<Vec<bool>>,
    /// Per guide: the share of covered points.
    pub per_guide: Vec<f64>,
    /// The length-weighted mean of `per_guide`.
    pub total: f64,
}

/// The coverage of `guides` by `bones` ([`COVERAGE_RADIUS`], [`COVERAGE_POINTS`]).
pub fn coverage(guides: &Guides, bones: &[Bone]) -> Coverage {
    let (mut covered, mut per_guide, mut weighted, mut length) = (Vec::new(), Vec::new(), 0.0, 0.0);
    for i in 0..guides.len() {
        let path = guides.path(i);
        let hit: Vec<bool> = arc_samples(path, COVERAGE_POINTS)
            .iter()
            .map(|&(_, p)| bones.iter().any(|b| to_segment(p, b.base, b.tip) < COVERAGE_RADIUS))
            .collect();
        let share = hit.iter().filter(|&&h| h).count() as f64 / hit.len().max(1) as f64;
        weighted += share * path.length();
        length += path.length();
        covered.push(hit);
        per_guide.push(share);
    }
    let total = if length > 0.0 { weighted / length } else { 0.0 };
    Coverage { covered, per_guide, total }
}

/// The covered runs of one guide's points (from [`Coverage::covered`]) as arc
/// fractions `(from, to)`, e.g. `[(0.0, 0.31)]`.
pub fn covered_runs(hit: &[bool]) -> Vec<(f64, f64)> {
    let n = hit.len().max(1) as f64;
    let mut runs = Vec::new();
    let mut start = None;
    for (i, &h) in hit.iter().chain([&false]).enumerate() {
        match (h, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                runs.push((s as f64 / n, i as f64 / n));
                start = None;
            }
            _ => {}
        }
    }
    runs
}

/// How far unguided derivations of a grammar got ([`super::Prepared::reach`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    /// The start shape's origin.
    pub origin: DVec3,
    /// The farthest distance from `origin` of any bone tip of the samples.
    pub radius: f64,
    /// Derivations sampled, and the particle-steps each took at most.
    pub samples: u32,
    pub steps: u32,
}

/// Points along each guide for [`beyond_reach`].
pub const REACH_POINTS: usize = 200;

/// A run of a guide's points beyond the reach.
#[derive(Clone, Debug, PartialEq)]
pub struct Unreached {
    pub guide: usize,
    /// The run's arc fractions along the guide.
    pub from: f64,
    pub to: f64,
    /// How far beyond the reach its farthest point lies.
    pub beyond: f64,
}

/// The runs of each guide's points ([`REACH_POINTS`] per guide) that lie farther
/// than `reach.radius` from `reach.origin`, with how far beyond.
pub fn beyond_reach(guides: &Guides, reach: &Reach) -> Vec<Unreached> {
    let mut out = Vec::new();
    for i in 0..guides.len() {
        let pts = arc_samples(guides.path(i), REACH_POINTS);
        let mut run: Option<Unreached> = None;
        for &(f, p) in &pts {
            let excess = (p - reach.origin).length() - reach.radius;
            let step = 0.5 / REACH_POINTS as f64;
            if excess > 0.0 {
                let r = run.get_or_insert(Unreached { guide: i, from: (f - step).max(0.0), to: f, beyond: 0.0 });
                r.to = (f + step).min(1.0);
                r.beyond = r.beyond.max(excess);
            } else if let Some(r) = run.take() {
                out.push(r);
            }
        }
        out.extend(run);
    }
    out
}

impl Unreached {
    /// One line for warnings: `guide `trunk`: 0.72–1.00 of its length lies beyond
    /// the grammar's reach, up to 1.23 beyond …`.
    pub fn message(&self, guides: &Guides, reach: &Reach) -> String {
        format!(
            "{}: {:.2}–{:.2} of its length lies beyond the grammar's reach, up to {:.2} farther from the start than \
             any bone tip of {} unguided derivations got ({:.2}): no skeleton is likely to follow it there (move it \
             nearer, or let the grammar grow farther)",
            guides.guide(self.guide).label(self.guide),
            self.from,
            self.to,
            self.beyond,
            reach.samples,
            reach.radius
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Guide;

    fn straight(name: &str, z0: f64, z1: f64) -> Guide {
        let z = |k: f64| z0 + (z1 - z0) * k / 3.0;
        Guide::new(name, vec![[0.0, 0.0, z(0.0)], [0.0, 0.0, z(1.0)], [0.0, 0.0, z(2.0)], [0.0, 0.0, z(3.0)]])
    }

    #[test]
    fn arc_samples_are_evenly_spaced_by_length() {
        // A cubic with uneven parameter speed: control points bunched at the start.
        let g = Guide::new("g", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, 4.0]]);
        let gs = Guides::new(&[g]).expect("guides");
        let s = arc_samples(gs.path(0), 8);
        for (k, (f, p)) in s.iter().enumerate() {
            let want = (k as f64 + 0.5) / 8.0;
            assert!((f - want).abs() < 1e-12);
            assert!((p.z - 4.0 * want).abs() < 0.01, "{k}: {p}");
        }
    }

    #[test]
    fn coverage_counts_points_near_bones_weighted_by_length() {
        let gs = Guides::new(&[straight("a", 0.0, 4.0), straight("b", 10.0, 12.0)]).expect("guides");
        // One bone along the lower half of `a`, a little off to the side.
        let bone = Bone { base: DVec3::new(0.2, 0.0, 0.0), tip: DVec3::new(0.2, 0.0, 2.0), rule: 0 };
        let c = coverage(&gs, &[bone]);
        // a: points up to z 2 + √(0.35² − 0.2²) ≈ 2.287 of 4: 0.57; b: none.
        assert!((c.per_guide[0] - 0.5725).abs() < 0.005, "{:?}", c.per_guide);
        assert_eq!(c.per_guide[1], 0.0);
        assert!((c.total - c.per_guide[0] * 4.0 / 6.0).abs() < 1e-9);
        let runs = covered_runs(&c.covered[0]);
        assert_eq!(runs.len(), 1);
        assert_eq!(runs[0].0, 0.0);
        assert!((runs[0].1 - 0.5725).abs() < 0.005, "{runs:?}");
        assert!(covered_runs(&c.covered[1]).is_empty());
        assert_eq!(covered_runs(&[false, true, true, false, true]), vec![(0.2, 0.6), (0.8, 1.0)]);
    }

    #[test]
    fn guide_points_beyond_the_reach_are_reported_with_how_far() {
        let gs = Guides::new(&[straight("up", 0.0, 8.0), straight("low", 0.0, 3.0)]).expect("guides");
        let reach = Reach { origin: DVec3::ZERO, radius: 5.0, samples: 64, steps: 100 };
        let u = beyond_reach(&gs, &reach);
        assert_eq!(u.len(), 1, "{u:?}");
        assert_eq!(u[0].guide, 0);
        assert!((u[0].from - 5.0 / 8.0).abs() < 0.01 && u[0].to == 1.0, "{u:?}");
        assert!((u[0].beyond - 3.0).abs() < 0.03, "{u:?}");
        let m = u[0].message(&gs, &reach);
        assert!(m.starts_with("up: 0.62–1.00 of its length lies beyond the grammar's reach, up to 2.98"), "{m}");
    }
}
