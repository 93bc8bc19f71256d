//! Buildings as a user asks for them: several derivations of a grid grammar
//! ([`super::generate::derive`]) measured against the example
//! ([`super::assess`]), the first complete one kept; and the variety that seeds give.
//! Above both, so that one derivation and its measure do not depend on each other.

use super::assess::{assess_with, Assessment, Reference};
use super::generate::{derive, GenerateOptions, Generated, MAX_ATTEMPTS};
use super::voxel::VoxelModel;
use super::GridGrammar;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashSet;

/// Generates a building: `steps` random rule applications from the start shape, then
/// (optionally) the enclosure constraint; with several [`GenerateOptions::attempts`],
/// the first complete building of that many derivations (measured against the start
/// shape's example), else the best one with a note saying so.
pub fn generate(grammar: &GridGrammar, opts: &GenerateOptions) -> Result<Generated, String> {
    grammar.validate()?;
    let example = grammar.shapes.get(grammar.start as usize).map(|s| s.example).unwrap_or(0);
    let has_example = grammar.shapes.iter().any(|s| s.at.is_some() && s.example == example);
    let attempts = opts.attempts.clamp(1, MAX_ATTEMPTS);
    if attempts == 1 || !has_example {
        return derive(grammar, opts);
    }
    let reference = Reference::of(grammar, example, opts.seal)?;
    let mut seeds = Pcg64::seed_from_u64(opts.seed ^ 0x9e37_79b9_7f4a_7c15);
    // (complete, kinds kept, blocks): the best so far.
    let mut best: Option<((bool, usize, usize), Generated)> = None;
    for a in 0..attempts {
        let seed = if a == 0 { opts.seed } else { seeds.next_u64() };
        let made = derive(grammar, &GenerateOptions { seed, ..*opts })?;
        let m = assess_with(grammar, &reference, &made, opts.seal)?;
        let whole = m.complete() && m.missing_kinds.is_empty();
        if whole {
            return Ok(made);
        }
        let score = (m.complete(), m.example_kinds - m.missing_kinds.len(), m.blocks);
        if best.as_ref().is_none_or(|(s, _)| score > *s) {
            best = Some((score, made));
        }
    }
    let Some((_, mut made)) = best else { return derive(grammar, opts) };
    let why = format!(
        "no complete building with all the example's block kinds in {attempts} derivations; the most complete is kept"
    );
    made.note = Some(match made.note.take() {
        Some(n) => format!("{n}; {why}"),
        None => why,
    });
    Ok(made)
}

/// What `seeds` seeds give (`opts.seed + 1` to `opts.seed + seeds`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Variety {
    pub seeds: u64,
    /// Distinct buildings (block sets compared up to a translation).
    pub distinct: usize,
    /// Complete buildings (measured against the start shape's example).
    pub complete: usize,
    /// Buildings that keep every block kind of the example.
    pub all_kinds: usize,
    /// Per seed, its assessment.
    pub assessments: Vec<Assessment>,
}

/// The buildings as blocks moved to the origin, for comparison.
fn normalized(m: &VoxelModel) -> Vec<([i32; 3], String)> {
    let n = m.normalized();
    let mut v: Vec<([i32; 3], String)> = n
        .blocks
        .iter()
        .map(|b| (b.pos, n.kinds.get(b.kind as usize).map(|k| k.id.clone()).unwrap_or_default()))
        .collect();
    v.sort();
    v
}

/// Generates `seeds` buildings with `opts` (seeds after `opts.seed`) and measures
/// them against the start shape's example.
pub fn variety(grammar: &GridGrammar, opts: &GenerateOptions, seeds: u64) -> Result<Variety, String> {
    let example = grammar.shapes.get(grammar.start as usize).map(|s| s.example).unwrap_or(0);
    let reference = Reference::of(grammar, example, opts.seal)?;
    let mut seen = HashSet::new();
    let mut v = Variety { seeds, ..Variety::default() };
    for i in 1..=seeds {
        let made = generate(grammar, &GenerateOptions { seed: opts.seed.wrapping_add(i), ..*opts })?;
        seen.insert(normalized(&made.model));
        let a = assess_with(grammar, &reference, &made, opts.seal)?;
        v.complete += a.complete() as usize;
        v.all_kinds += a.missing_kinds.is_empty() as usize;
        v.assessments.push(a);
    }
    v.distinct = seen.len();
    Ok(v)
}
