//! Buildings as a user asks for them: several derivations of a grid grammar
//! ([`super::generate::derive`]) measured against the example
//! ([`super::assess`]), the first complete one kept; and the variety that seeds give.
//! Above both, so that one derivation and its measure do not depend on each other.

use super::assess::{assess_with, Assessment, Reference};
use super::generate::{derive, GenerateError, GenerateOptions, Generated, MAX_ATTEMPTS};
use super::kinds::add_missing_kinds;
use super::voxel::VoxelModel;
use super::GridGrammar;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashSet;

/// Generates a building: `steps` random rule applications from the start shape, then
/// (optionally) the enclosure constraint; with several [`GenerateOptions::attempts`],
/// the first complete building of that many derivations (measured against the start
/// shape's example), else the best one with a note saying so.
pub fn generate(grammar: &GridGrammar, opts: &GenerateOptions) -> Result<Generated, GenerateError> {
    grammar.validate()?;
    let attempts = opts.attempts.clamp(1, MAX_ATTEMPTS);
    match reference(grammar, opts)? {
        Some(r) if attempts > 1 => Ok(whole(grammar, &r, opts)?.0),
        _ => derive(grammar, opts),
    }
}

/// The start shape's example measured, when the grammar has shapes placed in it.
fn reference(grammar: &GridGrammar, opts: &GenerateOptions) -> Result<Option<Reference>, GenerateError> {
    let example = grammar.shapes.get(grammar.start as usize).map(|s| s.example).unwrap_or(0);
    if !grammar.shapes.iter().any(|s| s.at.is_some() && s.example == example) {
        return Ok(None);
    }
    Reference::of(grammar, example, opts.seal).map(Some)
}

/// The first complete building with every block kind of `reference` in
/// `opts.attempts` derivations, else the most complete with a note; and its
/// assessment. A complete derivation that lacks kinds gets them where rules allow
/// ([`add_missing_kinds`]).
fn whole(
    grammar: &GridGrammar,
    reference: &Reference,
    opts: &GenerateOptions,
) -> Result<(Generated, Assessment), GenerateError> {
    let attempts = opts.attempts.clamp(1, MAX_ATTEMPTS);
    let mut seeds = Pcg64::seed_from_u64(opts.seed ^ 0x9e37_79b9_7f4a_7c15);
    // (complete, kinds kept, blocks): the best so far.
    let mut best: Option<((bool, usize, usize), Generated, Assessment)> = None;
    for a in 0..attempts {
        let seed = if a == 0 { opts.seed } else { seeds.next_u64() };
        let attempt = GenerateOptions { seed, ..*opts };
        let mut made = derive(grammar, &attempt)?;
        let mut m = assess_with(grammar, reference, &made, opts.seal)?;
        if m.complete()
            && !m.missing_kinds.is_empty()
            && add_missing_kinds(grammar, &mut made, &reference.kinds, &attempt).map_err(|e| e.0)? > 0
        {
            m = assess_with(grammar, reference, &made, opts.seal)?;
        }
        if m.complete() && m.missing_kinds.is_empty() {
            return Ok((made, m));
        }
        let score = (m.complete(), m.example_kinds - m.missing_kinds.len(), m.blocks);
        if best.as_ref().is_none_or(|(s, _, _)| score > *s) {
            best = Some((score, made, m));
        }
    }
    let Some((_, mut made, m)) = best else {
        let made = derive(grammar, opts)?;
        let m = assess_with(grammar, reference, &made, opts.seal)?;
        return Ok((made, m));
    };
    let why = format!(
        "no complete building with all the example's block kinds in {attempts} derivations; the most complete is kept"
    );
    made.note = Some(match made.note.take() {
        Some(n) => format!("{n}; {why}"),
        None => why,
    });
    Ok((made, m))
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
/// them against the start shape's example. The seeds are generated in parallel
/// (each is one deterministic building, so the result does not depend on the
/// threads).
pub fn variety(grammar: &GridGrammar, opts: &GenerateOptions, seeds: u64) -> Result<Variety, GenerateError> {
    use rayon::prelude::*;
    grammar.validate()?;
    let example = grammar.shapes.get(grammar.start as usize).map(|s| s.example).unwrap_or(0);
    // Without shapes placed in the example, `generate` derives once (nothing to be
    // complete against); the measure is the same.
    let (reference, placed) = match reference(grammar, opts)? {
        Some(r) => (r, true),
        None => (Reference::of(grammar, example, opts.seal)?, false),
    };
    let attempts = if placed { opts.attempts.clamp(1, MAX_ATTEMPTS) } else { 1 };
    let made: Vec<(Generated, Assessment)> = (1..=seeds)
        .into_par_iter()
        .map(|i| {
            let o = GenerateOptions { seed: opts.seed.wrapping_add(i), ..*opts };
            if attempts > 1 {
                whole(grammar, &reference, &o)
            } else {
                let made = derive(grammar, &o)?;
                let a = assess_with(grammar, &reference, &made, opts.seal)?;
                Ok((made, a))
            }
        })
        .collect::<Result<_, GenerateError>>()?;
    let mut seen = HashSet::new();
    let mut v = Variety { seeds, ..Variety::default() };
    for (made, a) in made {
        seen.insert(normalized(&made.model));
        v.complete += a.complete() as usize;
        v.all_kinds += a.missing_kinds.is_empty() as usize;
        v.assessments.push(a);
    }
    v.distinct = seen.len();
    Ok(v)
}
