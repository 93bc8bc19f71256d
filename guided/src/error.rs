//! Why a guided table, its settings or a search cannot be used: the errors of
//! [`SearchSettings::validate`](crate::SearchSettings::validate),
//! [`GuidedTable::verify`](crate::GuidedTable::verify),
//! [`Prepared::new`](crate::Prepared::new) / [`Prepared::check_size`](crate::Prepared::check_size).
//! ([`Guides::new`](crate::cost::Guides::new) has its own, `cost::GuidesError`.)
//! Each message is the one users read (written by hand, like the other crates'
//! errors: `Display` and `Error`, no derive macro).

use crate::cost::GuidesError;
use crate::{GuideError, MAX_BUDGET_MS, MAX_EXPECTED, MAX_GENERATIONS, MAX_PARTICLES, MAX_UTILISATION_COUNTS};
use std::fmt;

/// Why a `search` section's settings are out of range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SettingsError {
    /// A generation of 0 particles.
    NoParticles,
    /// More than [`MAX_PARTICLES`] particles in a generation (the larger end of the ramp).
    TooManyParticles(u32),
    /// Generations outside 1 to [`MAX_GENERATIONS`].
    Generations(u32),
    /// A heuristic scale that is negative or not a number.
    HeuristicScale(f64),
    /// A heuristic fraction outside [0, 1].
    HeuristicFraction(f64),
    /// A time budget that is not a positive number of at most [`MAX_BUDGET_MS`].
    Budget(f64),
    /// No EXPECTED samples, or samples of no expansions.
    NoExpected,
    /// More than [`MAX_EXPECTED`] EXPECTED samples or expansions (the larger).
    TooManyExpected(u32),
}

impl fmt::Display for SettingsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            SettingsError::NoParticles => write!(f, "a generation needs at least 1 particle"),
            SettingsError::TooManyParticles(_) => write!(f, "more than {MAX_PARTICLES} particles in a generation"),
            SettingsError::Generations(n) => write!(f, "{n} generations: expected 1 to {MAX_GENERATIONS}"),
            SettingsError::HeuristicScale(v) => write!(f, "heuristic scale {v} is not a number ≥ 0"),
            SettingsError::HeuristicFraction(v) => write!(f, "heuristic fraction {v} is outside [0, 1]"),
            SettingsError::Budget(v) => {
                write!(f, "budget {v} ms is not a positive number of at most {MAX_BUDGET_MS} ms")
            }
            SettingsError::NoExpected => {
                write!(f, "the EXPECTED estimate needs at least 1 sample of at least 1 expansion")
            }
            SettingsError::TooManyExpected(_) => write!(f, "more than {MAX_EXPECTED} EXPECTED samples or expansions"),
        }
    }
}

impl std::error::Error for SettingsError {}

/// Why a decoded guided table does not fit its bundle.
#[derive(Clone, Debug, PartialEq)]
pub enum TableError {
    /// A rule index past the bundle's rules; `what` names the list (`skeleton`, `wrap-up`).
    RuleOutOfRange { what: &'static str, rule: u32 },
    /// A skeleton rule that is a convolution or has transform rules.
    SkeletonTransforms { rule: String },
    /// A skeleton rule whose body draws.
    SkeletonDraws { rule: String },
    /// A wrap-up from a rule that is not a skeleton rule.
    WrapupFrom(u32),
    /// A wrap-up to a skeleton rule.
    WrapupTo(u32),
    /// A rule with two wrap-ups.
    TwoWrapups(u32),
    /// A guide that is not valid: its label and why.
    Guide { label: String, error: GuideError },
    /// The search settings are out of range.
    Settings(SettingsError),
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TableError::RuleOutOfRange { what, rule } => write!(f, "{what}: rule {rule} out of range"),
            TableError::SkeletonTransforms { rule } => {
                write!(f, "skeleton rule `{rule}` is a convolution or has transform rules")
            }
            TableError::SkeletonDraws { rule } => write!(f, "skeleton rule `{rule}` draws"),
            TableError::WrapupFrom(r) => write!(f, "wrap-up of rule {r}, which is not a skeleton rule"),
            TableError::WrapupTo(r) => write!(f, "wrap-up to rule {r}, which is a skeleton rule"),
            TableError::TwoWrapups(r) => write!(f, "rule {r} has two wrap-ups"),
            TableError::Guide { label, error } => write!(f, "{label}: {error}"),
            TableError::Settings(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for TableError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            TableError::Guide { error, .. } => Some(error),
            TableError::Settings(e) => Some(e),
            _ => None,
        }
    }
}

impl From<SettingsError> for TableError {
    fn from(e: SettingsError) -> TableError {
        TableError::Settings(e)
    }
}

/// Why a guided search cannot be prepared ([`Prepared::new`](crate::Prepared::new))
/// or would not fit in memory ([`Prepared::check_size`](crate::Prepared::check_size)).
#[derive(Clone, Debug, PartialEq)]
pub enum PrepareError {
    /// No guiding curves at all.
    NoGuides,
    /// The guided table does not fit the bundle.
    Table(TableError),
    /// The guides cannot be prepared.
    Guides(GuidesError),
    /// The search would keep `counts` utilisation counts (2 generations ×
    /// `particles` × `segments`), more than [`MAX_UTILISATION_COUNTS`].
    TooLarge { counts: u64, particles: u64, segments: u64 },
}

impl fmt::Display for PrepareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PrepareError::NoGuides => write!(f, "no guiding curves: add a `guide` section or give a guide file"),
            PrepareError::Table(e) => write!(f, "{e}"),
            PrepareError::Guides(e) => write!(f, "{e}"),
            PrepareError::TooLarge { counts, particles, segments } => write!(
                f,
                "the search would keep {counts} utilisation counts (2 generations × {particles} particles × \
                 {segments} segments of the guides), more than {MAX_UTILISATION_COUNTS}: use fewer particles or a \
                 longer `segment`"
            ),
        }
    }
}

impl std::error::Error for PrepareError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            PrepareError::Table(e) => Some(e),
            PrepareError::Guides(e) => Some(e),
            _ => None,
        }
    }
}

impl From<TableError> for PrepareError {
    fn from(e: TableError) -> PrepareError {
        PrepareError::Table(e)
    }
}

impl From<GuidesError> for PrepareError {
    fn from(e: GuidesError) -> PrepareError {
        PrepareError::Guides(e)
    }
}
