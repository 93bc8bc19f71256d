//! The guiding-curve cost of a skeleton (paper §3.3–3.4).
//!
//! Per bone b (BASE → TIP), with γ the guide closest to BASE (eq. 1):
//!
//! * COST_d = Σᵢ γ.scale_d[i]·DISTⁱ, DIST = |BASE − CLOSEST(γ, BASE)| (eqs. 2–3);
//! * COST_a = (d̂_bone · d̂_guide + γ.delta_a)·γ.scale_a with d̂_bone = −(TIP − BASE)/|TIP − BASE|
//!   and d̂_guide the unit tangent of γ at CLOSEST(γ, BASE) (eqs. 4–6);
//! * COST_u = −γ.scale_u · Σ_{s∈S} e^(−count(s)), S the utilisation segments of γ from
//!   the one holding CLOSEST(γ, BASE) to the one holding CLOSEST(γ, TIP), inclusive,
//!   count(s) the bones that used s before (then each count goes up by one) (eq. 7).
//!
//! The heuristic term of a pending skeleton call of rule n in frame M (eq. 10) is
//! (−M·EXPECTED(n)/|M·EXPECTED(n)| · DIR + γ.delta_a)·γ.scale_a, with γ and DIR taken at
//! the call's origin. Segments are measured by arc length; a guide of length L has
//! ⌈L / segment⌉ of them (at least one). Distances and directions are computed in
//! f64 from the VM's f32 frames.
//!
//! Sums over bones commute, and a segment used n times contributes
//! −scale_u·Σ_{k<n} e^(−k) whatever the order, so the total cost does not depend on
//! the order in which bones are added (the SOSMC requirement).

use super::bezier::{Closest, Path, PathSet};
use super::{Guide, GuideError};
use glam::DVec3;

/// A bone shorter than this (in world units) is no bone: a call that does not move
/// the origin adds nothing to the cost.
pub const MIN_BONE_LENGTH: f64 = 1e-9;

/// The three cost terms, summed over bones.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cost {
    /// Distance (COST_d).
    pub d: f64,
    /// Alignment (COST_a).
    pub a: f64,
    /// Utilisation (COST_u).
    pub u: f64,
}

impl Cost {
    /// COST = COST_d + COST_a + COST_u (eq. 8).
    pub fn total(&self) -> f64 {
        self.d + self.a + self.u
    }
}

impl std::ops::AddAssign for Cost {
    fn add_assign(&mut self, o: Cost) {
        self.d += o.d;
        self.a += o.a;
        self.u += o.u;
    }
}

/// The guide closest to a point, and what the cost needs of it there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Near {
    /// Index of the guide γ.
    pub curve: u32,
    /// DIST: the distance to γ.
    pub dist: f64,
    /// DIR: γ's unit tangent at the closest point.
    pub dir: DVec3,
    /// The utilisation segment holding the closest point (index into the counts of
    /// all guides, see [`Guides::n_segments`]).
    pub segment: u32,
    /// The closest point's arc length along γ.
    pub arc: f64,
}

/// Which segments of a guide a bone's utilisation term (eq. 7) credits (the
/// `search` section's `utilisation` key, `mdg-run --utilisation`, `L` in `mdg-view`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Utilisation {
    /// Eq. 7 as written: every segment from the one holding CLOSEST(γ, BASE) to the
    /// one holding CLOSEST(γ, TIP). A short bone across the turns of a helix, whose
    /// tip is closest to another turn, credits all the turns between.
    Paper,
    /// Only the segments within the bone's own length of CLOSEST(γ, BASE) along γ:
    /// the tip's arc position is clamped to arc(BASE) ± |TIP − BASE|, so a bone
    /// credits no more of the curve than it could lie along. The default: on curved
    /// guides it covers 1.2–2.6× as much as eq. 7 (docs/guided.md, "Coverage").
    #[default]
    Local,
}

impl Utilisation {
    /// Every term, in the order `mdg-view`'s `L` cycles them.
    pub const ALL: [Utilisation; 2] = [Utilisation::Paper, Utilisation::Local];

    /// Its name in sources and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Utilisation::Paper => "paper",
            Utilisation::Local => "local",
        }
    }

    /// The next term in [`Utilisation::ALL`] (after the last, the first).
    pub fn cycled(self) -> Utilisation {
        let i = Utilisation::ALL.iter().position(|&u| u == self).unwrap_or(0);
        Utilisation::ALL[(i + 1) % Utilisation::ALL.len()]
    }

    /// From its name (`paper`, `local`).
    pub fn from_name(s: &str) -> Option<Utilisation> {
        match s {
            "paper" => Some(Utilisation::Paper),
            "local" => Some(Utilisation::Local),
            _ => None,
        }
    }
}

/// The guides of a search, prepared for cost evaluation.
#[derive(Clone, Debug)]
pub struct Guides {
    paths: PathSet,
    params: Vec<Guide>,
    /// First utilisation segment of each guide, and how many it has.
    first: Vec<u32>,
    count: Vec<u32>,
    /// Which segments a bone credits.
    pub utilisation: Utilisation,
}

/// e^(−k) for small k.
const EXP_TABLE: usize = 64;

fn exp_neg(k: u32) -> f64 {
    static TABLE: std::sync::OnceLock<[f64; EXP_TABLE]> = std::sync::OnceLock::new();
    let t = TABLE.get_or_init(|| std::array::from_fn(|i| (-(i as f64)).exp()));
    match t.get(k as usize) {
        Some(v) => *v,
        None => (-(k as f64)).exp(),
    }
}

/// Utilisation segments one guide may have (`length / segment`).
pub const MAX_GUIDE_SEGMENTS: u32 = 1 << 20;
/// Utilisation segments of all guides together.
pub const MAX_TOTAL_SEGMENTS: u32 = 1 << 22;

/// Why guides cannot be prepared for a search ([`Guides::new`](crate::cost::Guides::new)).
#[derive(Clone, Debug, PartialEq)]
pub enum GuidesError {
    /// The time budget ran out after `prepared` of `total` guides.
    OutOfTime { prepared: usize, total: usize },
    /// A guide that is not valid: its label and why.
    Guide { label: String, error: GuideError },
    /// A guide whose control points make no path.
    TooFewPoints { label: String },
    /// A guide cut into more than [`MAX_GUIDE_SEGMENTS`] utilisation segments.
    TooManySegments { label: String, segment: f64, length: f64, wanted: f64 },
    /// The guides up to `label` have more than [`MAX_TOTAL_SEGMENTS`] segments in all.
    TooManyInAll { label: String },
}

impl std::fmt::Display for GuidesError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GuidesError::OutOfTime { prepared, total } => write!(
                f,
                "the time budget ran out while preparing the guides ({prepared} of {total} prepared): raise --budget \
                 or use fewer guides"
            ),
            GuidesError::Guide { label, error } => write!(f, "{label}: {error}"),
            GuidesError::TooFewPoints { label } => write!(f, "{label}: too few control points"),
            GuidesError::TooManySegments { label, segment, length, wanted } => write!(
                f,
                "{label}: `segment` {segment} cuts the guide (length {length:.4}) into {wanted:.0} utilisation \
                 segments, more than {MAX_GUIDE_SEGMENTS}: use a longer `segment`"
            ),
            GuidesError::TooManyInAll { label } => write!(
                f,
                "{label}: the guides have more than {MAX_TOTAL_SEGMENTS} utilisation segments in all: use a longer \
                 `segment` or fewer guides"
            ),
        }
    }
}

impl std::error::Error for GuidesError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GuidesError::Guide { error, .. } => Some(error),
            _ => None,
        }
    }
}

impl Guides {
    /// Prepares `guides` (each validated by [`Guide::validate`]).
    pub fn new(guides: &[Guide]) -> Result<Guides, GuidesError> {
        Guides::new_within(guides, None)
    }

    /// [`Guides::new`] that gives up once `deadline` has passed (checked before each guide).
    pub fn new_within(guides: &[Guide], deadline: Option<std::time::Instant>) -> Result<Guides, GuidesError> {
        let (mut paths, mut params, mut first, mut count) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut next = 0u32;
        for (i, guide) in guides.iter().enumerate() {
            if deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                return Err(GuidesError::OutOfTime { prepared: i, total: guides.len() });
            }
            guide.validate().map_err(|error| GuidesError::Guide { label: guide.label(i), error })?;
            let path = Path::new(&guide.points).ok_or_else(|| GuidesError::TooFewPoints { label: guide.label(i) })?;
            let wanted = (path.length() / guide.segment).ceil();
            if wanted > MAX_GUIDE_SEGMENTS as f64 {
                return Err(GuidesError::TooManySegments {
                    label: guide.label(i),
                    segment: guide.segment,
                    length: path.length(),
                    wanted,
                });
            }
            let n = (wanted as u32).max(1);
            first.push(next);
            count.push(n);
            next = next
                .checked_add(n)
                .filter(|&t| t <= MAX_TOTAL_SEGMENTS)
                .ok_or_else(|| GuidesError::TooManyInAll { label: guide.label(i) })?;
            paths.push(path);
            params.push(guide.clone());
        }
        Ok(Guides { paths: PathSet::new(paths), params, first, count, utilisation: Utilisation::default() })
    }

    /// Number of guides.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Whether there are no guides.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// The prepared path of guide `i`.
    pub fn path(&self, i: usize) -> &Path {
        &self.paths.paths()[i]
    }

    /// The parameters of guide `i`.
    pub fn guide(&self, i: usize) -> &Guide {
        &self.params[i]
    }

    /// Utilisation segments of all guides together (the length of a counts array).
    pub fn n_segments(&self) -> usize {
        self.first.last().zip(self.count.last()).map(|(f, c)| (f + c) as usize).unwrap_or(0)
    }

    /// The utilisation segment (global index) holding the point at arc length `arc` of guide `curve`.
    fn segment_at(&self, curve: usize, arc: f64) -> u32 {
        let g = &self.params[curve];
        let n = self.count[curve];
        let k = if arc.is_finite() && arc > 0.0 { (arc / g.segment).floor() as u64 } else { 0 };
        self.first[curve] + (k.min(n as u64 - 1) as u32)
    }

    fn near_of(&self, curve: usize, c: &Closest) -> Near {
        Near { curve: curve as u32, dist: c.dist, dir: c.tangent, segment: self.segment_at(curve, c.arc), arc: c.arc }
    }

    /// The closest guide γ to `p` and the closest point on it (eq. 1), within the
    /// curves' tolerance (see [`PathSet::nearest`]); on a tie the guide listed first.
    /// `None` when there are no guides.
    pub fn nearest(&self, p: DVec3) -> Option<Near> {
        self.paths.nearest(p).map(|(i, c)| self.near_of(i, &c))
    }

    /// COST_d at distance `dist` from guide `curve` (eqs. 2–3).
    pub fn distance_cost(&self, curve: u32, dist: f64) -> f64 {
        let s = &self.params[curve as usize].scale_d;
        s[0] + s[1] * dist + s[2] * dist * dist
    }

    /// COST_a of a bone along `v` (TIP − BASE, non-zero) whose base is at `near` (eqs. 4–6).
    pub fn alignment_cost(&self, near: &Near, v: DVec3) -> f64 {
        let g = &self.params[near.curve as usize];
        let d_bone = -v.normalize();
        (d_bone.dot(near.dir) + g.delta_a) * g.scale_a
    }

    /// COST_u of a bone of length `len` from BASE (at `near`) to `tip` (eq. 7, or its
    /// [`Utilisation::Local`] variant); increments the counts of the segments it uses.
    /// `tip_near` is the guide nearest to `tip` if known (when it is γ, its segment is
    /// the tip's; otherwise the tip is projected onto γ).
    pub fn utilisation_cost(
        &self,
        near: &Near,
        tip: DVec3,
        len: f64,
        tip_near: Option<&Near>,
        counts: &mut [u32],
    ) -> f64 {
        let curve = near.curve as usize;
        let g = &self.params[curve];
        if g.scale_u == 0.0 {
            return 0.0;
        }
        let arc_tip = || match tip_near {
            Some(t) if t.curve == near.curve => t.arc,
            _ => self.path(curve).closest(tip).arc,
        };
        let s_tip = match (self.utilisation, tip_near) {
            (Utilisation::Paper, Some(t)) if t.curve == near.curve => t.segment,
            (Utilisation::Paper, _) => self.segment_at(curve, arc_tip()),
            // (NaN-safe, unlike `f64::clamp`, which panics on a NaN bound.)
            (Utilisation::Local, _) => {
                self.segment_at(curve, mdg_vm::expr::clamp(arc_tip(), near.arc - len, near.arc + len))
            }
        };
        let (lo, hi) = if near.segment <= s_tip { (near.segment, s_tip) } else { (s_tip, near.segment) };
        let mut sum = 0.0;
        for s in lo..=hi {
            if let Some(c) = counts.get_mut(s as usize) {
                sum += exp_neg(*c);
                *c = c.saturating_add(1);
            }
        }
        -g.scale_u * sum
    }

    /// The cost of the bone `base` → `tip`, with `near` the guide closest to `base` and
    /// `tip_near` the one closest to `tip` if known; updates the utilisation counts.
    /// `None` (no bone, no cost) when the two points are closer than [`MIN_BONE_LENGTH`].
    pub fn bone_cost(
        &self,
        near: &Near,
        base: DVec3,
        tip: DVec3,
        tip_near: Option<&Near>,
        counts: &mut [u32],
    ) -> Option<Cost> {
        let v = tip - base;
        let len = v.length();
        if len.is_nan() || len <= MIN_BONE_LENGTH {
            return None;
        }
        Some(Cost {
            d: self.distance_cost(near.curve, near.dist),
            a: self.alignment_cost(near, v),
            u: self.utilisation_cost(near, tip, len, tip_near, counts),
        })
    }

    /// The heuristic term of a pending call at `near` whose EXPECTED vector, taken into
    /// world space by the call's frame, is `expected` (eq. 10); 0 for a zero vector.
    pub fn heuristic(&self, near: &Near, expected: DVec3) -> f64 {
        let len = expected.length();
        if len.is_nan() || len <= MIN_BONE_LENGTH {
            return 0.0;
        }
        let g = &self.params[near.curve as usize];
        (-(expected / len).dot(near.dir) + g.delta_a) * g.scale_a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One straight guide along +z from (0,0,0) to (0,0,3), evenly parameterised,
    /// scale_d (0.5, 2, 3), scale_a 1.5, delta_a 0.2, scale_u 0.7, segment 1 (3 segments).
    fn line() -> Guides {
        let mut g = Guide::new("z", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]);
        g.scale_d = [0.5, 2.0, 3.0];
        g.scale_a = 1.5;
        g.delta_a = 0.2;
        g.scale_u = 0.7;
        g.segment = 1.0;
        Guides::new(&[g]).expect("guides")
    }

    #[test]
    fn guides_that_cannot_be_prepared_say_which_and_why() {
        let mut g = Guide::new("long", vec![[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]);
        g.segment = 1e-9;
        let e = Guides::new(std::slice::from_ref(&g)).expect_err("too many segments");
        assert!(matches!(&e, GuidesError::TooManySegments { label, wanted, .. } if label == "long" && *wanted == 3e9));
        assert_eq!(
            e.to_string(),
            "long: `segment` 0.000000001 cuts the guide (length 3.0000) into 3000000000 utilisation segments, more \
             than 1048576: use a longer `segment`"
        );
        g.segment = -1.0;
        let e = Guides::new(&[g]).expect_err("negative segment");
        assert_eq!(e, GuidesError::Guide { label: "long".into(), error: GuideError::Segment(-1.0) });
        let past = Some(std::time::Instant::now());
        assert_eq!(Guides::new_within(&[], past).map(|g| g.len()), Ok(0));
        let one = [Guide::new("a", vec![[0.0; 3]; 4])];
        assert_eq!(Guides::new_within(&one, past).err(), Some(GuidesError::OutOfTime { prepared: 0, total: 1 }));
    }

    #[test]
    fn distance_cost_by_hand() {
        let g = line();
        // BASE (2, 0, 1.5): DIST = 2; COST_d = 0.5 + 2·2 + 3·4 = 16.5.
        let near = g.nearest(DVec3::new(2.0, 0.0, 1.5)).expect("near");
        assert!((near.dist - 2.0).abs() < 1e-12);
        assert!((g.distance_cost(near.curve, near.dist) - 16.5).abs() < 1e-9);
        // On the curve: only the constant term.
        let on = g.nearest(DVec3::new(0.0, 0.0, 1.0)).expect("near");
        assert!((g.distance_cost(on.curve, on.dist) - 0.5).abs() < 1e-12);
    }

    #[test]
    fn alignment_cost_by_hand() {
        let g = line();
        let near = g.nearest(DVec3::new(1.0, 0.0, 1.0)).expect("near");
        assert!((near.dir - DVec3::Z).length() < 1e-12);
        // Along the tangent: (−1 + 0.2)·1.5 = −1.2.
        assert!((g.alignment_cost(&near, DVec3::new(0.0, 0.0, 0.3)) - -1.2).abs() < 1e-12);
        // Perpendicular: (0 + 0.2)·1.5 = 0.3.
        assert!((g.alignment_cost(&near, DVec3::new(2.0, 0.0, 0.0)) - 0.3).abs() < 1e-12);
        // Against it: (1 + 0.2)·1.5 = 1.8.
        assert!((g.alignment_cost(&near, DVec3::new(0.0, 0.0, -5.0)) - 1.8).abs() < 1e-12);
        // 45°: (−√½ + 0.2)·1.5.
        let want = (-(0.5f64).sqrt() + 0.2) * 1.5;
        assert!((g.alignment_cost(&near, DVec3::new(1.0, 0.0, 1.0)) - want).abs() < 1e-12);
    }

    #[test]
    fn utilisation_cost_by_hand() {
        let g = line();
        assert_eq!(g.n_segments(), 3);
        let mut counts = vec![0u32; g.n_segments()];
        // Bone from z 0.5 (segment 0) to z 2.5 (segment 2): S = {0, 1, 2}, all unused:
        // −0.7·3.
        let base = DVec3::new(0.1, 0.0, 0.5);
        let near = g.nearest(base).expect("near");
        assert_eq!(near.segment, 0);
        let u = g.utilisation_cost(&near, DVec3::new(0.1, 0.0, 2.5), 2.0, None, &mut counts);
        assert!((u - -2.1).abs() < 1e-12, "{u}");
        assert_eq!(counts, vec![1, 1, 1]);
        // Bone within segment 1 (z 1.2 → 1.8): S = {1}, used once before: −0.7·e^(−1).
        let near = g.nearest(DVec3::new(0.0, 0.3, 1.2)).expect("near");
        let u = g.utilisation_cost(&near, DVec3::new(0.0, 0.3, 1.8), 0.67, None, &mut counts);
        assert!((u - -0.7 * (-1.0f64).exp()).abs() < 1e-12);
        // Downwards (z 2.9 → 0.1) spans all three again: −0.7·(e^(−1) + e^(−2) + e^(−1)).
        let near = g.nearest(DVec3::new(0.0, 0.0, 2.9)).expect("near");
        let tip = DVec3::new(0.0, 0.0, 0.1);
        let u = g.utilisation_cost(&near, tip, 2.0, g.nearest(tip).as_ref(), &mut counts);
        let want = -0.7 * (2.0 * (-1.0f64).exp() + (-2.0f64).exp());
        assert!((u - want).abs() < 1e-12);
        assert_eq!(counts, vec![2, 3, 2]);
    }

    /// The local variant credits only the arc within the bone's length of its base: a
    /// 0.5-long bone from z 0.2 whose tip is closest to z 2.6 (a jump, as across the
    /// turns of a helix) credits segments 0..2 as written, segment 0 only when local.
    #[test]
    fn the_local_utilisation_credits_only_the_bones_own_arc() {
        let mut g = line();
        g.utilisation = Utilisation::Paper;
        let base = DVec3::new(0.0, 0.0, 0.2);
        let near = g.nearest(base).expect("near");
        let tip = DVec3::new(0.0, 0.0, 2.6);
        let mut counts = vec![0u32; 3];
        let paper = g.utilisation_cost(&near, tip, 0.5, None, &mut counts);
        assert!((paper - -2.1).abs() < 1e-12, "{paper}");
        g.utilisation = Utilisation::Local;
        let mut counts = vec![0u32; 3];
        let local = g.utilisation_cost(&near, tip, 0.5, None, &mut counts);
        assert!((local - -0.7).abs() < 1e-12, "{local}");
        assert_eq!(counts, vec![1, 0, 0]);
        // A bone that lies along the guide credits the same either way.
        let mut counts = vec![0u32; 3];
        let along = g.utilisation_cost(&near, DVec3::new(0.0, 0.0, 2.2), 2.0, None, &mut counts);
        assert!((along - -2.1).abs() < 1e-12, "{along}");
        assert_eq!(Utilisation::from_name("local"), Some(Utilisation::Local));
        assert_eq!(Utilisation::from_name("paper"), Some(Utilisation::Paper));
        assert_eq!(Utilisation::from_name("eq7"), None);
    }

    #[test]
    fn the_default_utilisation_is_local() {
        assert_eq!(line().utilisation, Utilisation::Local);
        assert_eq!(Utilisation::Local.cycled(), Utilisation::Paper);
        assert_eq!(Utilisation::Paper.cycled(), Utilisation::Local);
        assert_eq!(Utilisation::ALL.map(Utilisation::name), ["paper", "local"]);
    }

    #[test]
    fn bone_cost_sums_the_terms_and_skips_zero_length() {
        let g = line();
        let mut counts = vec![0u32; 3];
        let base = DVec3::new(1.0, 0.0, 0.2);
        let near = g.nearest(base).expect("near");
        let c = g.bone_cost(&near, base, base + DVec3::new(0.0, 0.0, 0.5), None, &mut counts).expect("bone");
        // DIST 1: 0.5 + 2 + 3 = 5.5; aligned: −1.2; segment 0 only: −0.7.
        assert!((c.d - 5.5).abs() < 1e-12 && (c.a - -1.2).abs() < 1e-12 && (c.u - -0.7).abs() < 1e-12, "{c:?}");
        assert!((c.total() - 3.6).abs() < 1e-12);
        assert!(g.bone_cost(&near, base, base, None, &mut counts).is_none());
        assert_eq!(counts, vec![1, 0, 0]);
    }

    #[test]
    fn heuristic_term_by_hand() {
        let g = line();
        let near = g.nearest(DVec3::new(0.0, 1.0, 1.0)).expect("near");
        // EXPECTED along +z at any length: like an aligned bone, (−1 + 0.2)·1.5.
        assert!((g.heuristic(&near, DVec3::new(0.0, 0.0, 0.01)) - -1.2).abs() < 1e-12);
        assert_eq!(g.heuristic(&near, DVec3::ZERO), 0.0);
    }

    #[test]
    fn nearest_picks_the_closest_guide_and_the_first_on_ties() {
        let a = Guide::new("a", vec![[-1.0, 0.0, 0.0], [-1.0, 0.0, 1.0], [-1.0, 0.0, 2.0], [-1.0, 0.0, 3.0]]);
        let b = Guide::new("b", vec![[1.0, 0.0, 3.0], [1.0, 0.0, 2.0], [1.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);
        let g = Guides::new(&[a, b]).expect("guides");
        let n = g.nearest(DVec3::new(0.6, 0.0, 1.0)).expect("near");
        assert_eq!(n.curve, 1);
        assert!((n.dir - -DVec3::Z).length() < 1e-12, "b runs downwards");
        assert!((n.dist - 0.4).abs() < 1e-12);
        // The same curve twice: exactly equal distances, the first guide wins.
        let a = Guide::new("a", vec![[-1.0, 0.0, 0.0], [-1.0, 0.0, 1.0], [-1.0, 0.0, 2.0], [-1.0, 0.0, 3.0]]);
        let mut a2 = a.clone();
        a2.delta_a = -0.3;
        let twice = Guides::new(&[a, a2]).expect("guides");
        assert_eq!(twice.nearest(DVec3::new(0.0, 0.0, 1.0)).expect("near").curve, 0);
        assert!(Guides::new(&[]).expect("none").nearest(DVec3::ZERO).is_none());
    }
}
