//! Creature grammar: sets of monsters evolved from regular creatures (SPEC §11,
//! `papers/creature-grammar.txt`).
//!
//! - [`table`]: what the compiler produces (parts with slots, families, regular
//!   creatures, structure rules, selection and evolution settings) and its verifier;
//! - [`shape`]: abstract shapes — meta-parts, super-parts, arrangement modes, torso
//!   attachment, symmetry groups — their structure graph and complexity C_s;
//! - [`cond`]: condition and probability expressions (over `g` and shape counts);
//! - [`rules`]: structure rules (increase, insert, replace, combine), the rule metric
//!   C_r and the selection strategies;
//! - [`geometry`]: the part library, geometry rules (slots), the stability test and
//!   the assembled mesh;
//! - [`evolve`]: generations, structure-based diversity control and the diversity
//!   measure;
//! - [`silhouette`]: low-resolution silhouettes, to tell monsters apart by what is
//!   visible, made from each part's [`outline`];
//! - [`sheet`]: contact sheets composed from per-monster pictures;
//! - [`error`]: why a table, a shape, the part library or a sheet is refused.

pub mod cond;
pub mod error;
pub mod evolve;
pub mod geometry;
pub mod outline;
pub mod rules;
pub mod shape;
pub mod sheet;
pub mod silhouette;
pub mod table;

pub use table::CreatureTable;

#[cfg(test)]
mod tests;
