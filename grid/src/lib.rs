//! Grid shape grammars of voxel buildings (SPEC §11, `papers/sigi-grammar-induction.txt`):
//! the grammar table, voxel formats, shape inference, grammar induction and generation.
//!
//! A grid grammar is a palette of block kinds, a set of *shapes* (connected sets of
//! blocks in their own local frame), *matches* (shape b is shape a turned by quarter
//! turns about the vertical axis), *rules* `a → a b` (b placed relative to a), and a
//! start shape. The vertical axis is y (Minecraft's convention; `.vox` files are
//! converted on reading).
//!
//! Module map: [`voxel`] (the voxel model), [`blocks`] (block names and colours),
//! [`format`] (text, `.vox`, `.nbt`, `.schem`), [`mesh`] (greedy meshing to an
//! [`mdg_vm::output::Output`]), [`infer`] (shape inference by hill climbing),
//! [`matching`] (matching shapes), [`induce`] (rules and the grammar), [`generate`]
//! (random derivation and the enclosure constraint; `outside` keeps the outside it
//! tests, updated as blocks go), [`kinds`] (missing block kinds
//! added back), [`build`] and [`assess`] (whole buildings measured against the example).

pub mod assess;
pub mod blocks;
pub mod build;
pub mod doors;
pub mod format;
pub mod generate;
pub mod induce;
pub mod infer;
pub mod kinds;
pub mod matching;
pub mod mesh;
mod outside;
pub mod share;
pub mod voxel;

use serde::{Deserialize, Serialize};

/// The most blocks one grammar (all shapes together) may hold.
pub const MAX_GRAMMAR_BLOCKS: usize = 4_000_000;
/// The largest extent of a shape along one axis, in blocks.
pub const MAX_SHAPE_EXTENT: u32 = 4096;
/// The largest number of generation steps.
pub const MAX_STEPS: u32 = 100_000;
/// The largest rule offset (`rule A B at X Y Z`) in any direction, in blocks.
pub const MAX_RULE_OFFSET: i32 = 4 * MAX_SHAPE_EXTENT as i32 * 1024;

/// An axis: 0 = x, 1 = y (vertical), 2 = z.
pub type Axis = u8;

/// Axis names, by index.
pub const AXIS_NAMES: [&str; 3] = ["x", "y", "z"];

/// A rigid placement on the grid: a quarter-turn rotation about the vertical (y)
/// axis followed by an integer translation. A point p maps to `R^turn · p + offset`,
/// where one turn maps (x, y, z) to (z, y, −x) (a right-handed quarter turn about +y:
/// counter-clockwise seen from above).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Placement {
    /// Quarter turns, 0..4.
    pub turn: u8,
    pub offset: [i32; 3],
}

/// `p` turned `turn` quarter turns about the vertical axis.
pub fn rotate(turn: u8, p: [i32; 3]) -> [i32; 3] {
    let [x, y, z] = p;
    match turn % 4 {
        0 => [x, y, z],
        1 => [z, y, -x],
        2 => [-x, y, -z],
        _ => [-z, y, x],
    }
}

/// Component-wise sum.
pub fn add(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0].wrapping_add(b[0]), a[1].wrapping_add(b[1]), a[2].wrapping_add(b[2])]
}

/// Component-wise difference.
pub fn sub(a: [i32; 3], b: [i32; 3]) -> [i32; 3] {
    [a[0].wrapping_sub(b[0]), a[1].wrapping_sub(b[1]), a[2].wrapping_sub(b[2])]
}

impl Placement {
    /// The identity placement.
    pub const IDENTITY: Placement = Placement { turn: 0, offset: [0, 0, 0] };

    /// A pure translation.
    pub fn translation(offset: [i32; 3]) -> Placement {
        Placement { turn: 0, offset }
    }

    /// Where this placement sends the local point `p`.
    pub fn apply(&self, p: [i32; 3]) -> [i32; 3] {
        add(rotate(self.turn, p), self.offset)
    }

    /// `self ∘ inner`: first `inner`, then `self`.
    pub fn compose(&self, inner: &Placement) -> Placement {
        Placement { turn: (self.turn + inner.turn) % 4, offset: self.apply(inner.offset) }
    }

    /// The inverse placement.
    pub fn inverse(&self) -> Placement {
        let back = (4 - self.turn % 4) % 4;
        let o = rotate(back, self.offset);
        Placement { turn: back, offset: [-o[0], -o[1], -o[2]] }
    }

    /// Which axis a local axis becomes (quarter turns swap x and z).
    pub fn axis(&self, axis: Axis) -> Axis {
        if self.turn % 2 == 1 && axis != 1 {
            2 - axis
        } else {
            axis
        }
    }
}

/// The placement that turns the box `[0, size)` by `turn` quarter turns and moves the
/// result back to `[0, size')`, with `size'` (x and z swapped for odd turns).
pub fn turn_box(size: [u32; 3], turn: u8) -> (Placement, [u32; 3]) {
    let hi = [size[0] as i32 - 1, size[1] as i32 - 1, size[2] as i32 - 1];
    let mut lo = [i32::MAX; 3];
    for cx in [0, hi[0]] {
        for cz in [0, hi[2]] {
            let r = rotate(turn, [cx, 0, cz]);
            for k in 0..3 {
                lo[k] = lo[k].min(r[k]);
            }
        }
    }
    let turned = if turn % 2 == 1 { [size[2], size[1], size[0]] } else { size };
    (Placement { turn: turn % 4, offset: [-lo[0], 0, -lo[2]] }, turned)
}

/// One block kind of a grammar's palette.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PaletteEntry {
    /// The name used in the grammar source (an identifier).
    pub name: String,
    /// The block as the voxel formats know it: `minecraft:oak_planks`, `5:0`, `#a0b0c0`…
    pub block: String,
    /// Display colour (sRGB).
    pub color: [u8; 3],
}

/// One block of a shape, in the shape's local frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct ShapeBlock {
    pub pos: [i32; 3],
    /// Palette index.
    pub kind: u32,
}

/// A shape: a connected set of blocks in its local box `[0, size)`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GridShape {
    pub name: String,
    /// Box size (x, y, z).
    pub size: [u32; 3],
    /// Blocks sorted by (y, z, x), positions inside the box, no two at one place.
    pub blocks: Vec<ShapeBlock>,
    /// The axis the shape is flat along (its two sides for the enclosure constraint),
    /// or none (3D shapes; the enclosure constraint never removes them).
    pub plane: Option<Axis>,
    /// Where the shape's box corner sits in its example, if it came from one.
    pub at: Option<[i32; 3]>,
    /// Which example (index into [`GridGrammar::examples`]) the shape came from.
    pub example: u32,
    /// Open in its example (a roof, a chimney, a porch: air on both of its sides where
    /// the example stands): the enclosure constraint never removes it. `mdgc induce`
    /// marks these (see [`generate::open_in_examples`]); the source says `open;`.
    #[serde(default)]
    pub open: bool,
}

/// `b` is `a` turned `turn` quarter turns (box to box, see [`turn_box`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShapeMatch {
    pub a: u32,
    pub b: u32,
    pub turn: u8,
}

/// A rule `from → from to`: when `from` is placed at P, `to` may be added at
/// `P ∘ place`. Shared with every shape matching `from` (paper eq. 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GridRule {
    pub from: u32,
    pub to: u32,
    pub place: Placement,
}

/// Generation defaults from the `generate { }` block (the command line overrides them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct GenerateSettings {
    /// Rule applications.
    pub steps: u32,
    /// Apply the enclosure constraint after the steps.
    pub enclosure: bool,
    /// Openings up to `2·seal` blocks wide (doors, windows) do not let the outside in
    /// (see [`generate`]); 0 is the paper's plain flood fill.
    pub seal: u32,
    /// Seed when the command line gives none.
    pub seed: Option<u64>,
}

impl Default for GenerateSettings {
    fn default() -> Self {
        GenerateSettings { steps: 50, enclosure: true, seal: 1, seed: None }
    }
}

/// What a program's `grid` section compiles to.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GridGrammar {
    /// The section's name (`grid NAME { }`), or empty.
    pub name: String,
    /// The example files the grammar was induced from (for `example N`).
    pub examples: Vec<String>,
    pub palette: Vec<PaletteEntry>,
    pub shapes: Vec<GridShape>,
    pub matches: Vec<ShapeMatch>,
    pub rules: Vec<GridRule>,
    /// Index of the start shape.
    pub start: u32,
    pub generate: GenerateSettings,
}

/// The blocks of `shape` turned `turn` quarter turns inside its box (sorted like
/// [`GridShape::blocks`]), and the turned box size. Block kinds turn by `turns` (see
/// [`kind_turns`]; an empty table leaves them).
pub fn turned_blocks(shape: &GridShape, turn: u8, turns: &[[u32; 4]]) -> (Vec<ShapeBlock>, [u32; 3]) {
    let (p, size) = turn_box(shape.size, turn);
    let mut v: Vec<ShapeBlock> =
        shape.blocks.iter().map(|b| ShapeBlock { pos: p.apply(b.pos), kind: turn_kind(turns, b.kind, turn) }).collect();
    sort_blocks(&mut v);
    (v, size)
}

/// Kind `k` turned `turn` quarter turns by the table (itself when the table does not
/// know it).
pub fn turn_kind(turns: &[[u32; 4]], k: u32, turn: u8) -> u32 {
    turns.get(k as usize).map(|t| t[(turn % 4) as usize]).unwrap_or(k)
}

/// The state-rotation table of a palette (block ids by index): entry `[k][t]` is the
/// kind `k` becomes turned `t` quarter turns about the vertical axis (stairs, logs,
/// doors… turn; see [`blocks::turn_block`]): its index when the palette holds the
/// turned block, else `n + 4k + t` (n = the palette's length), a kind no block of the
/// palette has.
pub fn kind_turns(ids: &[&str]) -> Vec<[u32; 4]> {
    let n = ids.len() as u32;
    let index: std::collections::HashMap<&str, u32> =
        ids.iter().enumerate().rev().map(|(i, id)| (*id, i as u32)).collect();
    (0..n)
        .map(|k| {
            let mut row = [k; 4];
            for t in 1..4u8 {
                if let Some(turned) = blocks::turn_block(ids[k as usize], t) {
                    row[t as usize] = index.get(turned.as_str()).copied().unwrap_or(n + 4 * k + t as u32);
                }
            }
            row
        })
        .collect()
}

/// Sorts blocks by (y, z, x).
pub fn sort_blocks(v: &mut [ShapeBlock]) {
    v.sort_by_key(|b| (b.pos[1], b.pos[2], b.pos[0], b.kind));
}

/// Whether the blocks are 6-connected (an empty set is not).
pub fn connected(blocks: &[ShapeBlock]) -> bool {
    let Some(first) = blocks.first() else { return false };
    let set: std::collections::HashSet<[i32; 3]> = blocks.iter().map(|b| b.pos).collect();
    let mut seen = std::collections::HashSet::new();
    let mut stack = vec![first.pos];
    seen.insert(first.pos);
    while let Some(p) = stack.pop() {
        for d in voxel::NEIGHBOURS {
            let q = add(p, d);
            if set.contains(&q) && seen.insert(q) {
                stack.push(q);
            }
        }
    }
    seen.len() == set.len()
}

impl mdg_vm::bundle::Section for GridGrammar {
    const KIND: mdg_vm::bundle::SectionKind = mdg_vm::bundle::SectionKind::Grid;
    fn check(&self, bundle: &mdg_vm::bundle::Bundle) -> Result<(), String> {
        self.verify(bundle).map_err(|e| e.to_string())
    }
}

impl GridGrammar {
    /// The palette's state-rotation table (see [`kind_turns`]).
    pub fn kind_turns(&self) -> Vec<[u32; 4]> {
        kind_turns(&self.palette.iter().map(|p| p.block.as_str()).collect::<Vec<_>>())
    }

    /// Checks every index, size and match (called by `Section::from_bundle`, so a
    /// corrupt bundle is rejected before generation reads it).
    pub fn verify(&self, _bundle: &mdg_vm::bundle::Bundle) -> Result<(), GrammarError> {
        self.validate()
    }

    /// The checks of [`GridGrammar::verify`], without a bundle.
    pub fn validate(&self) -> Result<(), GrammarError> {
        let n_kinds = self.palette.len() as u32;
        let n_shapes = self.shapes.len() as u32;
        if self.shapes.is_empty() {
            return Err(GrammarError::NoShapes);
        }
        if self.start >= n_shapes {
            return Err(GrammarError::StartOutOfRange(self.start));
        }
        let mut total = 0usize;
        for (i, s) in self.shapes.iter().enumerate() {
            let bad = |problem| Err(GrammarError::Shape { index: i, name: s.name.clone(), problem });
            if s.blocks.is_empty() {
                return bad(ShapeProblem::NoBlocks);
            }
            total += s.blocks.len();
            if total > MAX_GRAMMAR_BLOCKS {
                return Err(GrammarError::TooManyBlocks);
            }
            if s.size.iter().any(|&e| e == 0 || e > MAX_SHAPE_EXTENT) {
                return bad(ShapeProblem::Size(s.size));
            }
            if let Some(at) = s.at.filter(|a| a.iter().any(|c| c.unsigned_abs() > voxel::MAX_COORD as u32)) {
                return bad(ShapeProblem::TooFar(at));
            }
            if s.plane.is_some_and(|a| a > 2) {
                return bad(ShapeProblem::Plane);
            }
            if (s.example as usize) >= self.examples.len().max(1) {
                return bad(ShapeProblem::Example(s.example));
            }
            for w in s.blocks.windows(2) {
                let key = |b: &ShapeBlock| (b.pos[1], b.pos[2], b.pos[0]);
                if key(&w[0]) >= key(&w[1]) {
                    return bad(ShapeProblem::Order);
                }
            }
            for b in &s.blocks {
                if b.kind >= n_kinds {
                    return bad(ShapeProblem::Kind(b.kind));
                }
                if (0..3).any(|k| b.pos[k] < 0 || b.pos[k] as u32 >= s.size[k]) {
                    return bad(ShapeProblem::OutsideBox(b.pos));
                }
            }
        }
        let turns = self.kind_turns();
        for m in &self.matches {
            if m.a >= n_shapes || m.b >= n_shapes || m.turn > 3 {
                return Err(GrammarError::MatchOutOfRange(*m));
            }
            let (a, b) = (&self.shapes[m.a as usize], &self.shapes[m.b as usize]);
            let (blocks, size) = turned_blocks(a, m.turn, &turns);
            if size != b.size || blocks != b.blocks {
                return Err(GrammarError::NotTurned { a: a.name.clone(), b: b.name.clone(), turn: m.turn });
            }
        }
        for r in &self.rules {
            if r.from >= n_shapes || r.to >= n_shapes || r.place.turn > 3 {
                return Err(GrammarError::RuleOutOfRange(*r));
            }
            if r.place.offset.iter().any(|c| c.unsigned_abs() > MAX_RULE_OFFSET as u32) {
                return Err(GrammarError::RuleTooFar(*r));
            }
        }
        if self.generate.seal > generate::MAX_SEAL {
            return Err(GrammarError::Seal(self.generate.seal));
        }
        if self.generate.steps > MAX_STEPS {
            return Err(GrammarError::TooManySteps);
        }
        Ok(())
    }
}

/// What is wrong with one shape of a grid grammar ([`GrammarError::Shape`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShapeProblem {
    /// No blocks.
    NoBlocks,
    /// A size of 0 or over [`MAX_SHAPE_EXTENT`] along an axis.
    Size([u32; 3]),
    /// Placed (`at`) beyond the voxel model's coordinates.
    TooFar([i32; 3]),
    /// A plane axis other than 0, 1, 2.
    Plane,
    /// An example index past the grammar's examples.
    Example(u32),
    /// Blocks out of order, or two at one place.
    Order,
    /// A block of a palette entry past the palette.
    Kind(u32),
    /// A block outside the shape's box.
    OutsideBox([i32; 3]),
}

/// Why a grid grammar does not verify ([`GridGrammar::validate`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GrammarError {
    /// No shapes.
    NoShapes,
    /// A start shape past the shapes.
    StartOutOfRange(u32),
    /// Shape `index` (named `name`) is wrong.
    Shape { index: usize, name: String, problem: ShapeProblem },
    /// More than [`MAX_GRAMMAR_BLOCKS`] blocks in all shapes.
    TooManyBlocks,
    /// A match naming a shape or a turn out of range.
    MatchOutOfRange(ShapeMatch),
    /// A match whose second shape is not the first one turned.
    NotTurned { a: String, b: String, turn: u8 },
    /// A rule naming a shape or a turn out of range.
    RuleOutOfRange(GridRule),
    /// A rule placing a shape beyond ±[`MAX_RULE_OFFSET`] blocks.
    RuleTooFar(GridRule),
    /// A seal over [`generate::MAX_SEAL`].
    Seal(u32),
    /// More than [`MAX_STEPS`] generation steps.
    TooManySteps,
}

impl std::fmt::Display for GrammarError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GrammarError::NoShapes => write!(f, "no shapes"),
            GrammarError::StartOutOfRange(s) => write!(f, "start shape {s} out of range"),
            GrammarError::Shape { index, name, problem } => {
                write!(f, "shape {index} (`{name}`) ")?;
                match problem {
                    ShapeProblem::NoBlocks => write!(f, "has no blocks"),
                    ShapeProblem::Size(size) => write!(f, "has size {size:?} (each 1..{MAX_SHAPE_EXTENT})"),
                    ShapeProblem::TooFar(at) => write!(f, "stands at {at:?}, beyond ±{}", voxel::MAX_COORD),
                    ShapeProblem::Plane => write!(f, "has an invalid plane axis"),
                    ShapeProblem::Example(e) => write!(f, "names example {e} out of range"),
                    ShapeProblem::Order => write!(f, "has blocks out of order or two at one place"),
                    ShapeProblem::Kind(k) => write!(f, "uses palette entry {k} out of range"),
                    ShapeProblem::OutsideBox(pos) => write!(f, "has a block at {pos:?} outside its box"),
                }
            }
            GrammarError::TooManyBlocks => write!(f, "more than {MAX_GRAMMAR_BLOCKS} blocks in all shapes"),
            GrammarError::MatchOutOfRange(m) => write!(f, "match {m:?} out of range"),
            GrammarError::NotTurned { a, b, turn } => {
                write!(f, "shape `{b}` is not shape `{a}` turned {turn} quarter turns")
            }
            GrammarError::RuleOutOfRange(r) => write!(f, "rule {r:?} out of range"),
            GrammarError::RuleTooFar(r) => write!(f, "rule {r:?} places a shape beyond ±{MAX_RULE_OFFSET} blocks"),
            GrammarError::Seal(s) => write!(f, "seal {s} is more than {}", generate::MAX_SEAL),
            GrammarError::TooManySteps => write!(f, "more than {MAX_STEPS} generation steps"),
        }
    }
}

impl std::error::Error for GrammarError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_compose_and_invert() {
        let a = Placement { turn: 1, offset: [3, -2, 5] };
        let b = Placement { turn: 3, offset: [-1, 4, 7] };
        let p = [2, 9, -4];
        assert_eq!(a.compose(&b).apply(p), a.apply(b.apply(p)));
        assert_eq!(a.inverse().apply(a.apply(p)), p);
        assert_eq!(a.compose(&a.inverse()), Placement::IDENTITY);
        assert_eq!(rotate(1, [1, 0, 0]), [0, 0, -1]);
        assert_eq!(rotate(4 - 1, rotate(1, p)), p);
    }

    #[test]
    fn turning_a_box_keeps_it_in_place() {
        let (p, size) = turn_box([3, 2, 1], 1);
        assert_eq!(size, [1, 2, 3]);
        for x in 0..3 {
            let q = p.apply([x, 0, 0]);
            assert!(q[0] == 0 && (0..3).contains(&q[2]), "{q:?}");
        }
        for t in 0..4 {
            let (p, size) = turn_box([4, 1, 2], t);
            let q = p.apply([3, 0, 1]);
            assert!((0..3).all(|k| q[k] >= 0 && (q[k] as u32) < size[k]), "turn {t}: {q:?} in {size:?}");
        }
    }
}
