//! Guided search: sequential Monte Carlo over skeleton derivations, steered by
//! guiding curves (SPEC §11, `papers/guiding-curves-sosmc.txt`).
//!
//! A program marks some rules as *skeleton* rules. A call made by a skeleton rule
//! forms a bone from the caller's origin (BASE) to the callee's origin (TIP); a
//! skeleton rule may not draw, and the calls it makes to other rules are deferred to
//! the geometry phase. The search ([`search`]) keeps particles, partial skeleton
//! derivations that share structure; each step expands one pending skeleton call
//! chosen uniformly at random, weights by the likelihood ratio of
//! exp(−(COST + HEURISTICSCALE·HEURISTICCOST)) ([`cost`]), and resamples
//! ([`resample`]). When the search stops, leftover skeleton calls become their
//! wrap-up productions and everything deferred is evaluated without optimisation.
//!
//! [`GuidedTable`] is what the compiler makes of `search` and `guide` sections; it
//! is stored in the bundle and checked by [`GuidedTable::verify`]. Guides can also be
//! read from a JSON file ([`guides_from_json`]).

pub mod bezier;
pub mod cost;
pub mod error;
pub mod measure;
pub mod resample;
pub mod search;
pub mod team;

pub use cost::{GuidesError, Utilisation};
pub use error::{PrepareError, SettingsError, TableError};
pub use search::{
    Cancel, Model, ModelChoice, Prepared, Progress, SearchOptions, SearchResult, Stop, DEFAULT_REACH_SHARE,
    PARALLEL_MIN_PARTICLES, REACH_SAMPLES,
};

use mdg_vm::bundle::{Bundle, Op, NONE};
use serde::{Deserialize, Serialize};

/// Default number of particles in the first and the last generation.
pub const DEFAULT_PARTICLES: (u32, u32) = (100, 15);
/// Default number of generations (with the default particles, ≈ 5,750 particle-steps).
pub const DEFAULT_GENERATIONS: u32 = 100;
/// Default starting heuristic scale.
pub const DEFAULT_HEURISTIC_SCALE: f64 = 1.0;
/// Default fraction of the generations over which the heuristic scale ramps to 0.
pub const DEFAULT_HEURISTIC_FRACTION: f64 = 0.4;
/// Default time budget in milliseconds.
pub const DEFAULT_BUDGET_MS: f64 = 200.0;
/// The longest time budget: 10,000,000 s in milliseconds (the command line's
/// duration limit); beyond about 1.8e22 ms a `Duration` cannot hold it.
pub const MAX_BUDGET_MS: f64 = 1e10;
/// The largest guide control point coordinate (in either direction): distances
/// and lengths between such points stay far from overflow.
pub const MAX_GUIDE_COORD: f64 = 1e9;
/// The most particles in a generation.
pub const MAX_PARTICLES: u32 = 1_000_000;
/// The most generations.
pub const MAX_GENERATIONS: u32 = 10_000_000;
/// The most EXPECTED samples per skeleton rule, and expansions in each.
pub const MAX_EXPECTED: u32 = 1_000_000;
/// The most utilisation counts a search keeps (4 bytes each: 256 MiB); see
/// [`Prepared::check_size`].
pub const MAX_UTILISATION_COUNTS: u64 = 1 << 26;
/// Default forward samples per skeleton rule for the EXPECTED vectors, and the
/// expansions in each.
pub const DEFAULT_EXPECTED: (u32, u32) = (64, 32);

/// How a generation is drawn from the previous one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Resampling {
    /// One uniform offset, evenly spaced positions (low variance).
    #[default]
    Systematic,
    /// Independent draws.
    Multinomial,
}

impl Resampling {
    /// The name used in sources and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Resampling::Systematic => "systematic",
            Resampling::Multinomial => "multinomial",
        }
    }

    /// Parses a name written by [`Resampling::name`].
    pub fn from_name(s: &str) -> Option<Resampling> {
        match s {
            "systematic" => Some(Resampling::Systematic),
            "multinomial" => Some(Resampling::Multinomial),
            _ => None,
        }
    }
}

/// One guiding curve: a piecewise cubic Bézier path and its cost parameters (paper
/// §3.3, eqs. 1–8).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Guide {
    /// A label for messages and the exported line geometry.
    #[serde(default)]
    pub name: String,
    /// Control points, 3k + 1 of them (k ≥ 1): segment i is points 3i … 3i+3.
    pub points: Vec<[f64; 3]>,
    /// COST_d = Σ scale_d[i]·DIST^i (eq. 3).
    #[serde(default = "default_scale_d")]
    pub scale_d: [f64; 3],
    /// COST_a multiplier (eq. 6).
    #[serde(default = "default_scale_a")]
    pub scale_a: f64,
    /// Alignment offset in [−1, 1] (eq. 6): how aligned a bone must be to lower the cost.
    #[serde(default = "default_delta_a")]
    pub delta_a: f64,
    /// COST_u multiplier, ≥ 0 (eq. 7).
    #[serde(default = "default_scale_u")]
    pub scale_u: f64,
    /// Length of the utilisation segments along the curve, > 0.
    #[serde(default = "default_segment")]
    pub segment: f64,
}

/// Default `scale_d`: no constant term, linear and quadratic distance penalties.
pub const DEFAULT_SCALE_D: [f64; 3] = [0.0, 0.5, 1.0];
/// Default `scale_a`.
pub const DEFAULT_SCALE_A: f64 = 1.0;
/// Default `delta_a`.
pub const DEFAULT_DELTA_A: f64 = 0.6;
/// Default `scale_u`.
pub const DEFAULT_SCALE_U: f64 = 1.0;
/// Default `segment` length.
pub const DEFAULT_SEGMENT: f64 = 0.25;

fn default_scale_d() -> [f64; 3] {
    DEFAULT_SCALE_D
}
fn default_scale_a() -> f64 {
    DEFAULT_SCALE_A
}
fn default_delta_a() -> f64 {
    DEFAULT_DELTA_A
}
fn default_scale_u() -> f64 {
    DEFAULT_SCALE_U
}
fn default_segment() -> f64 {
    DEFAULT_SEGMENT
}

impl Guide {
    /// A guide through `points` with the default parameters.
    pub fn new(name: &str, points: Vec<[f64; 3]>) -> Guide {
        Guide {
            name: name.to_string(),
            points,
            scale_d: DEFAULT_SCALE_D,
            scale_a: DEFAULT_SCALE_A,
            delta_a: DEFAULT_DELTA_A,
            scale_u: DEFAULT_SCALE_U,
            segment: DEFAULT_SEGMENT,
        }
    }

    /// Checks the control points and parameters; the error names the problem.
    pub fn validate(&self) -> Result<(), GuideError> {
        let n = self.points.len();
        if n < 4 {
            return Err(GuideError::TooFewPoints(n));
        }
        if !(n - 1).is_multiple_of(3) {
            return Err(GuideError::NotPiecewise(n));
        }
        if self.points.iter().flatten().any(|c| !c.is_finite()) {
            return Err(GuideError::NonFinitePoint);
        }
        if self.points.iter().flatten().any(|c| c.abs() > MAX_GUIDE_COORD) {
            return Err(GuideError::PointBeyond);
        }
        let finite = self.scale_d.iter().chain([&self.scale_a, &self.delta_a, &self.scale_u, &self.segment]);
        if finite.into_iter().any(|v| !v.is_finite()) {
            return Err(GuideError::NonFiniteParam);
        }
        if !(-1.0..=1.0).contains(&self.delta_a) {
            return Err(GuideError::DeltaA(self.delta_a));
        }
        if self.scale_u < 0.0 {
            return Err(GuideError::ScaleU(self.scale_u));
        }
        if self.segment <= 0.0 {
            return Err(GuideError::Segment(self.segment));
        }
        Ok(())
    }

    /// A label: the name, or `guide N` (1-based) when it has none.
    pub fn label(&self, index: usize) -> String {
        if self.name.is_empty() {
            format!("guide {}", index + 1)
        } else {
            self.name.clone()
        }
    }
}

/// The options of a `search` section.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchSettings {
    /// Particles in the first and the last generation (linear ramp between).
    pub particles: (u32, u32),
    pub generations: u32,
    /// Starting HEURISTICSCALE.
    pub heuristic_scale: f64,
    /// Fraction of the generations over which HEURISTICSCALE ramps down to 0.
    pub heuristic_fraction: f64,
    /// Time budget in milliseconds (`None`: only the generations limit).
    pub budget_ms: Option<f64>,
    pub resampling: Resampling,
    /// Forward samples per skeleton rule for the EXPECTED vectors, and the most
    /// expansions in each.
    pub expected: (u32, u32),
    /// The utilisation term (`utilisation` key); `None`: the default
    /// ([`Utilisation::default`]). Left out of the bundle when not given, so bundles
    /// of programs without the key are unchanged.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub utilisation: Option<Utilisation>,
}

impl Default for SearchSettings {
    fn default() -> Self {
        SearchSettings {
            particles: DEFAULT_PARTICLES,
            generations: DEFAULT_GENERATIONS,
            heuristic_scale: DEFAULT_HEURISTIC_SCALE,
            heuristic_fraction: DEFAULT_HEURISTIC_FRACTION,
            budget_ms: Some(DEFAULT_BUDGET_MS),
            resampling: Resampling::Systematic,
            expected: DEFAULT_EXPECTED,
            utilisation: None,
        }
    }
}

impl SearchSettings {
    /// Checks ranges; the message names the problem.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let largest = self.particles.0.max(self.particles.1);
        if self.particles.0 == 0 || self.particles.1 == 0 {
            return Err(SettingsError::NoParticles);
        }
        if largest > MAX_PARTICLES {
            return Err(SettingsError::TooManyParticles(largest));
        }
        if self.generations == 0 || self.generations > MAX_GENERATIONS {
            return Err(SettingsError::Generations(self.generations));
        }
        if !(self.heuristic_scale.is_finite() && self.heuristic_scale >= 0.0) {
            return Err(SettingsError::HeuristicScale(self.heuristic_scale));
        }
        if !(self.heuristic_fraction.is_finite() && (0.0..=1.0).contains(&self.heuristic_fraction)) {
            return Err(SettingsError::HeuristicFraction(self.heuristic_fraction));
        }
        if let Some(b) = self.budget_ms {
            if !(b.is_finite() && b > 0.0 && b <= MAX_BUDGET_MS) {
                return Err(SettingsError::Budget(b));
            }
        }
        if self.expected.0 == 0 || self.expected.1 == 0 {
            return Err(SettingsError::NoExpected);
        }
        if self.expected.0.max(self.expected.1) > MAX_EXPECTED {
            return Err(SettingsError::TooManyExpected(self.expected.0.max(self.expected.1)));
        }
        Ok(())
    }
}

/// What a program's `guide` and `search` sections compile to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuidedTable {
    /// Skeleton rules (rule indices), in the order declared.
    pub skeleton: Vec<u32>,
    /// Wrap-up productions: (skeleton rule, the rule a leftover call of it becomes).
    pub wrapups: Vec<(u32, u32)>,
    /// Guiding curves from `guide` sections, in source order.
    pub guides: Vec<Guide>,
    pub settings: SearchSettings,
}

impl mdg_vm::bundle::Section for GuidedTable {
    const KIND: mdg_vm::bundle::SectionKind = mdg_vm::bundle::SectionKind::Guided;
    fn check(&self, bundle: &Bundle) -> Result<(), String> {
        self.verify(bundle).map_err(|e| e.to_string())
    }
}

impl GuidedTable {
    /// Checks every index against the bundle (called by `Section::from_bundle`): rules
    /// in range, skeleton rules that do not draw and are not animated or
    /// convolutions, wrap-ups from skeleton rules to other rules, valid guides and
    /// settings.
    pub fn verify(&self, bundle: &Bundle) -> Result<(), TableError> {
        let n = bundle.rules.len() as u32;
        let in_range = |rule: u32, what: &'static str| {
            if rule < n {
                Ok(())
            } else {
                Err(TableError::RuleOutOfRange { what, rule })
            }
        };
        for &r in &self.skeleton {
            in_range(r, "skeleton")?;
            let rule = &bundle.rules[r as usize];
            let name = || bundle.string(rule.name).to_string();
            if rule.iter != NONE || !rule.transforms.is_empty() {
                return Err(TableError::SkeletonTransforms { rule: name() });
            }
            if rule.defs.iter().any(|d| body_draws(bundle, d.start)) {
                return Err(TableError::SkeletonDraws { rule: name() });
            }
        }
        for (i, &(from, to)) in self.wrapups.iter().enumerate() {
            in_range(from, "wrap-up")?;
            in_range(to, "wrap-up")?;
            if !self.skeleton.contains(&from) {
                return Err(TableError::WrapupFrom(from));
            }
            if self.skeleton.contains(&to) {
                return Err(TableError::WrapupTo(to));
            }
            if self.wrapups[..i].iter().any(|w| w.0 == from) {
                return Err(TableError::TwoWrapups(from));
            }
        }
        for (i, g) in self.guides.iter().enumerate() {
            g.validate().map_err(|error| TableError::Guide { label: g.label(i), error })?;
        }
        Ok(self.settings.validate()?)
    }
}

/// Whether the body starting at op `start` draws (a `DRAW` or `ISO` before its `RET`).
fn body_draws(b: &Bundle, start: u32) -> bool {
    let mut depth = 0usize;
    for op in b.code.iter().skip(start as usize) {
        match op {
            Op::Draw { .. } | Op::Iso { .. } => return true,
            Op::Loop { .. } | Op::LoopN { .. } => depth += 1,
            Op::EndLoop { .. } => depth = depth.saturating_sub(1),
            Op::Ret {} if depth == 0 => return false,
            _ => {}
        }
    }
    false
}

/// The JSON guide file: `{"guides": [{"name": …, "points": [[x, y, z], …], "scale_d":
/// [d0, d1, d2], "scale_a": …, "delta_a": …, "scale_u": …, "segment": …}, …]}`; every key
/// but `points` is optional (defaults as in `guide` sections). See docs/guided.md.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideFile {
    pub guides: Vec<Guide>,
}

/// Why a guide is not valid ([`Guide::validate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum GuideError {
    /// Fewer than 4 control points (how many).
    TooFewPoints(usize),
    /// Not 3k + 1 control points (how many).
    NotPiecewise(usize),
    /// A control point coordinate is NaN or infinite.
    NonFinitePoint,
    /// A control point coordinate is beyond [`MAX_GUIDE_COORD`].
    PointBeyond,
    /// A cost parameter is NaN or infinite.
    NonFiniteParam,
    /// `delta_a` outside [-1, 1].
    DeltaA(f64),
    /// A negative `scale_u`.
    ScaleU(f64),
    /// A `segment` length that is not positive.
    Segment(f64),
}

impl std::fmt::Display for GuideError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            GuideError::TooFewPoints(n) => write!(f, "{n} control points; a cubic Bézier path needs at least 4"),
            GuideError::NotPiecewise(n) => {
                write!(f, "{n} control points; a piecewise cubic Bézier path has 3k + 1 (4, 7, 10, …)")
            }
            GuideError::NonFinitePoint => write!(f, "a control point is not a finite number"),
            GuideError::PointBeyond => write!(f, "a control point coordinate is beyond ±{MAX_GUIDE_COORD}"),
            GuideError::NonFiniteParam => write!(f, "a parameter is not a finite number"),
            GuideError::DeltaA(v) => write!(f, "delta_a {v} is outside [-1, 1]"),
            GuideError::ScaleU(v) => write!(f, "scale_u {v} is negative"),
            GuideError::Segment(v) => write!(f, "segment length {v} is not positive"),
        }
    }
}

impl std::error::Error for GuideError {}

/// Why a guide file's text is not a guide file.
#[derive(Debug)]
pub enum GuideJsonError {
    /// Not JSON of the guide file's shape.
    Json(serde_json::Error),
    /// `guides` is empty.
    Empty,
    /// A guide is not valid: its label and why.
    Invalid { label: String, error: GuideError },
}

impl std::fmt::Display for GuideJsonError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GuideJsonError::Json(e) => write!(f, "invalid guide file: {e}"),
            GuideJsonError::Empty => write!(f, "invalid guide file: `guides` is empty"),
            GuideJsonError::Invalid { label, error } => write!(f, "invalid guide file: {label}: {error}"),
        }
    }
}

impl std::error::Error for GuideJsonError {}

/// Reads and validates a JSON guide file's text.
pub fn guides_from_json(text: &str) -> Result<Vec<Guide>, GuideJsonError> {
    let f: GuideFile = serde_json::from_str(text).map_err(GuideJsonError::Json)?;
    if f.guides.is_empty() {
        return Err(GuideJsonError::Empty);
    }
    for (i, g) in f.guides.iter().enumerate() {
        g.validate().map_err(|error| GuideJsonError::Invalid { label: g.label(i), error })?;
    }
    Ok(f.guides)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_guides_default_and_validate() {
        let g = guides_from_json(r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]], "delta_a": 0.6}]}"#)
            .expect("valid");
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].delta_a, 0.6);
        assert_eq!(g[0].scale_d, DEFAULT_SCALE_D);
        assert_eq!(g[0].segment, DEFAULT_SEGMENT);
        let few = guides_from_json(r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2]]}]}"#);
        let few = few.expect_err("3 points");
        assert!(matches!(&few, GuideJsonError::Invalid { error: GuideError::TooFewPoints(3), .. }), "{few:?}");
        assert!(few.to_string().contains("at least 4"));
        let five = guides_from_json(r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3],[0,0,4]]}]}"#);
        assert!(five.expect_err("5 points").to_string().contains("3k + 1"));
        let delta = guides_from_json(r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]], "delta_a": 1.5}]}"#);
        assert!(delta.expect_err("delta").to_string().contains("outside [-1, 1]"));
        let unknown = guides_from_json(r#"{"guides": [{"points": [[0,0,0],[0,0,1],[0,0,2],[0,0,3]], "scale": 1}]}"#);
        assert!(matches!(unknown, Err(GuideJsonError::Json(_))));
        assert!(guides_from_json("[1, 2").is_err());
        assert!(matches!(guides_from_json(r#"{"guides": []}"#), Err(GuideJsonError::Empty)));
    }

    #[test]
    fn settings_and_tables_say_what_is_wrong_as_data() {
        let s = SearchSettings { generations: 0, ..SearchSettings::default() };
        assert_eq!(s.validate(), Err(SettingsError::Generations(0)));
        assert_eq!(s.validate().map_err(|e| e.to_string()), Err("0 generations: expected 1 to 10000000".into()));
        let s = SearchSettings { particles: (3, MAX_PARTICLES + 1), ..SearchSettings::default() };
        assert_eq!(s.validate(), Err(SettingsError::TooManyParticles(MAX_PARTICLES + 1)));
        let b = Bundle::empty();
        let t = GuidedTable { skeleton: vec![4], ..GuidedTable::default() };
        let e = t.verify(&b).expect_err("no rule 4");
        assert_eq!(e, TableError::RuleOutOfRange { what: "skeleton", rule: 4 });
        assert_eq!(e.to_string(), "skeleton: rule 4 out of range");
        let mut g = Guide::new("arm", vec![[0.0; 3]; 4]);
        g.delta_a = 2.0;
        let t = GuidedTable { guides: vec![g], ..GuidedTable::default() };
        let e = t.verify(&b).expect_err("delta_a");
        assert_eq!(e, TableError::Guide { label: "arm".into(), error: GuideError::DeltaA(2.0) });
        assert_eq!(e.to_string(), "arm: delta_a 2 is outside [-1, 1]");
        let t = GuidedTable { settings: SearchSettings { budget_ms: Some(-1.0), ..SearchSettings::default() }, ..t };
        let t = GuidedTable { guides: vec![], ..t };
        assert_eq!(t.verify(&b), Err(TableError::Settings(SettingsError::Budget(-1.0))));
    }
}
