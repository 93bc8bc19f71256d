//! How good a generated building is, measured against the grammar's examples (issue
//! 42's table): complete (enclosed where the example is, one connected piece on the
//! ground, at least [`COMPLETE_FRACTION`] of the example's blocks), which of the
//! example's block kinds it keeps, and how many distinct buildings seeds give.
//!
//! The warnings `mdgc induce` gives about what a grammar can generate have their codes
//! here (registered in the compiler's code table, explained by `mdgc explain`).

use super::generate::{enclosure_report, example_instances, examples, GenerateError, Generated};
use super::voxel::{VoxelModel, NEIGHBOURS};
use super::GridGrammar;
use std::collections::{BTreeSet, HashSet};

/// No shape matches another: the grammar only rebuilds (parts of) its examples.
pub const W_NO_MATCH: &str = "W0901";
/// The hill climbing made no move.
pub const W_NO_MOVE: &str = "W0902";
/// Every seed gave the same building.
pub const W_SAME_OUTPUT: &str = "W0903";

/// A complete building has at least this fraction of its example's blocks.
pub const COMPLETE_FRACTION: f64 = 0.8;

/// The seeds [`variety`] tries by default (1 to 10).
pub const SEEDS: u64 = 10;

/// One generated building measured against an example.
#[derive(Clone, Debug, PartialEq)]
pub struct Assessment {
    pub blocks: usize,
    pub example_blocks: usize,
    /// Instances of shapes that are not open, exposed on both sides (0: enclosed
    /// where the example is).
    pub exposed: usize,
    /// Empty cells the building encloses (rooms), and the example's.
    pub interior: usize,
    pub example_interior: usize,
    /// One 6-connected piece (it then stands on the ground: its lowest blocks are the
    /// ground the enclosure fill does not pass).
    pub connected: bool,
    /// The example's block kinds (ids without block states: `minecraft:oak_stairs`)
    /// the building lacks.
    pub missing_kinds: Vec<String>,
    /// The example's block kinds.
    pub example_kinds: usize,
}

impl Assessment {
    /// Enclosed where the example is: nothing exposed that the example has closed,
    /// and rooms where the example has rooms.
    pub fn enclosed(&self) -> bool {
        self.exposed == 0 && (self.example_interior == 0 || self.interior > 0)
    }

    /// Whether the building is complete (see the module documentation).
    pub fn complete(&self) -> bool {
        self.enclosed()
            && self.connected
            && self.blocks as f64 >= COMPLETE_FRACTION * self.example_blocks as f64
            && self.example_blocks > 0
    }
}

pub use super::blocks::base_kind;

fn kinds_of(m: &VoxelModel) -> BTreeSet<String> {
    m.blocks.iter().filter_map(|b| m.kinds.get(b.kind as usize)).map(|k| base_kind(&k.id).to_string()).collect()
}

/// Whether the blocks are one 6-connected piece (an empty model is not).
pub fn one_piece(m: &VoxelModel) -> bool {
    let cells: HashSet<[i32; 3]> = m.blocks.iter().map(|b| b.pos).collect();
    let Some(&first) = cells.iter().min() else { return false };
    let mut seen = HashSet::from([first]);
    let mut stack = vec![first];
    while let Some(p) = stack.pop() {
        for d in NEIGHBOURS {
            let q = super::add(p, d);
            if cells.contains(&q) && seen.insert(q) {
                stack.push(q);
            }
        }
    }
    seen.len() == cells.len()
}

/// What a building is measured against: an example's blocks, rooms and block kinds
/// (computed once for many buildings).
#[derive(Clone, Debug)]
pub struct Reference {
    pub blocks: usize,
    pub interior: usize,
    pub kinds: BTreeSet<String>,
}

impl Reference {
    /// Example `example` of `grammar` (rooms measured with `seal`).
    pub fn of(grammar: &GridGrammar, example: u32, seal: u32) -> Result<Reference, GenerateError> {
        let models = examples(grammar);
        let ex = models.get(example as usize).ok_or(GenerateError::NoExample(example))?;
        let (_, interior) = enclosure_report(grammar, &example_instances(grammar, example), seal)?;
        Ok(Reference { blocks: ex.blocks.len(), interior, kinds: kinds_of(ex) })
    }
}

/// Measures a generated building against example `example` of `grammar` (the
/// enclosure measured with `seal`).
pub fn assess(grammar: &GridGrammar, made: &Generated, example: u32, seal: u32) -> Result<Assessment, GenerateError> {
    assess_with(grammar, &Reference::of(grammar, example, seal)?, made, seal)
}

/// [`assess`] against a reference computed before.
pub fn assess_with(
    grammar: &GridGrammar,
    r: &Reference,
    made: &Generated,
    seal: u32,
) -> Result<Assessment, GenerateError> {
    let (exposed, interior) = enclosure_report(grammar, &made.instances, seal)?;
    let have = kinds_of(&made.model);
    Ok(Assessment {
        blocks: made.model.blocks.len(),
        example_blocks: r.blocks,
        exposed,
        interior,
        example_interior: r.interior,
        connected: one_piece(&made.model),
        missing_kinds: r.kinds.difference(&have).cloned().collect(),
        example_kinds: r.kinds.len(),
    })
}
