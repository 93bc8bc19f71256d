//! Grammar induction (paper §"Shape Grammar Induction"): inferred shapes of one or more
//! example buildings become a [`GridGrammar`].
//!
//! * **Shapes** keep their blocks in a local frame (the box corner at the origin) and
//!   their place in the example (`at`), so the example can be rebuilt from them.
//! * **Matches**: shapes with equal canonical forms (see [`super::matching`]) match; each
//!   class is written as `match REP MEMBER turn K` from its first shape.
//! * **Rules**: when a block of s_i touches a block of s_j (face neighbours, or the same
//!   block for overlapping shapes), `s_i → s_i s_j` and `s_j → s_j s_i` with s_j at its
//!   example position relative to s_i (paper eq. 5). Rules are shared across matching
//!   shapes at generation time (eq. 6), so a rule equal to an earlier one once both are
//!   expressed in their classes' representative frames adds nothing and is left out.
//!   Matching shapes of different examples link their rules: one grammar, one shared
//!   style.
//! * The **start** shape is the largest shape.
//! * **Names** say a shape's role and material: `wall_stone_1`, `floor_planks_2`,
//!   `roof_slab_1`, `solid_stone_1` (from its plane and height in the example and its
//!   most common block kind).

use super::generate::GenerateError;
use super::infer::Inference;
use super::matching::Classes;
use super::voxel::VoxelModel;
use super::{
    blocks, sort_blocks, sub, GenerateSettings, GrammarError, GridGrammar, GridRule, GridShape, PaletteEntry,
    Placement, ShapeBlock, ShapeMatch,
};
use std::collections::{HashMap, HashSet};

/// Generation steps an induced grammar gets per shape of its largest example (at
/// least 50): a derivation adds one shape a step, and some steps add shapes the
/// enclosure constraint removes, so a whole building takes more steps than it has shapes.
pub const STEPS_PER_SHAPE: u32 = 2;

/// One example building.
pub struct Example<'a> {
    /// The file it came from (written into the grammar's `examples`).
    pub name: String,
    pub model: &'a VoxelModel,
}

/// Summary measures of a shape set (the paper's Tables 1–4).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measures {
    /// Number of shapes.
    pub shapes: usize,
    /// Percentage of shapes that match another shape (oriented blocks turned with the
    /// shape: a stair facing east matches one facing north in a turned shape).
    pub matching: f64,
    /// The same with blocks compared by id only, as the paper's reference does (a turned
    /// stair is another block).
    pub matching_exact: f64,
    /// Mean blocks per shape.
    pub size: f64,
    /// Mean of (block kinds in the shape / blocks in the shape).
    pub complexity: f64,
}

/// The local blocks of an inferred shape (box corner at the origin) and that corner.
pub fn local_blocks(model: &VoxelModel, blocks: &[u32]) -> (Vec<ShapeBlock>, [i32; 3]) {
    let mut lo = [i32::MAX; 3];
    for &b in blocks {
        let p = model.blocks[b as usize].pos;
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
        }
    }
    let mut v: Vec<ShapeBlock> = blocks
        .iter()
        .map(|&b| {
            let blk = model.blocks[b as usize];
            ShapeBlock { pos: sub(blk.pos, lo), kind: blk.kind }
        })
        .collect();
    sort_blocks(&mut v);
    (v, lo)
}

/// The measures of one example's inferred shapes.
pub fn measures(model: &VoxelModel, inference: &Inference) -> Measures {
    let shapes: Vec<Vec<ShapeBlock>> = inference.shapes.iter().map(|s| local_blocks(model, &s.blocks).0).collect();
    let n = shapes.len();
    if n == 0 {
        return Measures::default();
    }
    let ids: Vec<&str> = model.kinds.iter().map(|k| k.id.as_str()).collect();
    let classes = Classes::of(&shapes, &super::kind_turns(&ids));
    let exact = Classes::of(&shapes, &[]);
    let size = shapes.iter().map(|s| s.len() as f64).sum::<f64>() / n as f64;
    let complexity = shapes
        .iter()
        .map(|s| {
            let kinds: HashSet<u32> = s.iter().map(|b| b.kind).collect();
            kinds.len() as f64 / s.len().max(1) as f64
        })
        .sum::<f64>()
        / n as f64;
    Measures {
        shapes: n,
        matching: classes.matching_percent(),
        matching_exact: exact.matching_percent(),
        size,
        complexity,
    }
}

/// Why no grammar was built from examples ([`induce`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InductionError {
    /// No examples, or not one inference per example.
    InferencesPerExample,
    /// The examples are empty: no shapes.
    NoShapes,
    /// The built grammar does not verify (a limit of grid grammars).
    Grammar(GrammarError),
    /// The built grammar's examples could not be enclosed.
    Generate(GenerateError),
}

impl std::fmt::Display for InductionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InductionError::InferencesPerExample => write!(f, "induction needs one inference per example"),
            InductionError::NoShapes => write!(f, "no shapes (the examples are empty)"),
            InductionError::Grammar(e) => write!(f, "{e}"),
            InductionError::Generate(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for InductionError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            InductionError::Grammar(e) => Some(e),
            InductionError::Generate(e) => Some(e),
            _ => None,
        }
    }
}

/// Builds the grammar from examples and their inferred shapes (same order).
pub fn induce(examples: &[Example], inferences: &[Inference], name: &str) -> Result<GridGrammar, InductionError> {
    if examples.is_empty() || examples.len() != inferences.len() {
        return Err(InductionError::InferencesPerExample);
    }
    // The palette: one entry per block id, named readably and uniquely.
    let mut palette: Vec<PaletteEntry> = Vec::new();
    let mut palette_of: HashMap<String, u32> = HashMap::new();
    let mut names: HashSet<String> = HashSet::new();
    let mut kind_maps: Vec<Vec<u32>> = Vec::new();
    for e in examples {
        let mut map = Vec::with_capacity(e.model.kinds.len());
        for k in &e.model.kinds {
            let i = match palette_of.get(&k.id) {
                Some(i) => *i,
                None => {
                    let i = palette.len() as u32;
                    let name = unique(&blocks::identifier(&k.id), &mut names);
                    palette.push(PaletteEntry { name, block: k.id.clone(), color: k.color });
                    palette_of.insert(k.id.clone(), i);
                    i
                }
            };
            map.push(i);
        }
        kind_maps.push(map);
    }
    // Shapes, in example order, largest first within an example.
    let mut shapes: Vec<GridShape> = Vec::new();
    let mut shape_names: HashSet<String> = names.clone();
    let mut per_name: HashMap<String, u32> = HashMap::new();
    let mut first_of_example = Vec::new();
    for (ei, (e, inf)) in examples.iter().zip(inferences).enumerate() {
        first_of_example.push(shapes.len());
        let (lo_y, hi_y) = e.model.bounds().map(|(lo, hi)| (lo[1], hi[1])).unwrap_or((0, 0));
        for s in &inf.shapes {
            let (mut local, at) = local_blocks(e.model, &s.blocks);
            for b in &mut local {
                b.kind = kind_maps[ei][b.kind as usize];
            }
            let mut size = [1u32; 3];
            for b in &local {
                for (extent, c) in size.iter_mut().zip(b.pos) {
                    *extent = (*extent).max(c as u32 + 1);
                }
            }
            // Named after the most common block kind (ties: the first in palette order).
            let mut counts: HashMap<u32, u32> = HashMap::new();
            local.iter().for_each(|b| *counts.entry(b.kind).or_insert(0) += 1);
            let dominant =
                counts.iter().max_by_key(|(k, c)| (**c, std::cmp::Reverse(**k))).map(|(k, _)| *k).unwrap_or(0);
            // Named by role and material: `floor_…` (flat along y at the example's lowest
            // level, or inside it), `roof_…` (flat along y at its top), `wall_…` (flat
            // along x or z), `solid_…` (3D), then the most common block kind.
            let role = match s.plane {
                Some(1) if at[1] == hi_y && at[1] > lo_y => "roof",
                Some(1) => "floor",
                Some(_) => "wall",
                None => "solid",
            };
            let base = format!("{role}_{}", palette[dominant as usize].name);
            let n = per_name.entry(base.clone()).or_insert(0);
            *n += 1;
            let name = unique(&format!("{base}_{n}"), &mut shape_names);
            shapes.push(GridShape {
                name,
                size,
                blocks: local,
                plane: s.plane,
                at: Some(at),
                example: ei as u32,
                open: false,
            });
        }
    }
    if shapes.is_empty() {
        return Err(InductionError::NoShapes);
    }
    let ids: Vec<&str> = palette.iter().map(|p| p.block.as_str()).collect();
    let classes = Classes::of(&shapes.iter().map(|s| s.blocks.clone()).collect::<Vec<_>>(), &super::kind_turns(&ids));
    let mut matches = Vec::new();
    for (i, &c) in classes.class.iter().enumerate() {
        let rep = classes.rep[c as usize];
        if rep as usize != i {
            // shape i = rep turned: rep-local → i-local is to_rep[i]⁻¹.
            let turn = classes.to_rep[i].inverse().turn;
            matches.push(ShapeMatch { a: rep, b: i as u32, turn });
        }
    }
    // Rules from touching shapes, deduplicated in representative frames.
    let mut rules = Vec::new();
    let mut seen: HashSet<(u32, u32, Placement)> = HashSet::new();
    for (ei, e) in examples.iter().enumerate() {
        let base = first_of_example[ei];
        let count = inferences[ei].shapes.len();
        let mut at_cell: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        for (j, s) in inferences[ei].shapes.iter().enumerate() {
            for &b in &s.blocks {
                at_cell.entry(e.model.blocks[b as usize].pos).or_default().push((base + j) as u32);
            }
        }
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut pair_seen: HashSet<(u32, u32)> = HashSet::new();
        for (j, s) in inferences[ei].shapes.iter().enumerate().take(count) {
            let i = (base + j) as u32;
            for &b in &s.blocks {
                let p = e.model.blocks[b as usize].pos;
                for d in std::iter::once([0, 0, 0]).chain(super::voxel::NEIGHBOURS) {
                    for &o in at_cell.get(&super::add(p, d)).map(|v| v.as_slice()).unwrap_or(&[]) {
                        if o != i && pair_seen.insert((i, o)) {
                            pairs.push((i, o));
                        }
                    }
                }
            }
        }
        pairs.sort_unstable();
        for (i, o) in pairs {
            let (si, so) = (&shapes[i as usize], &shapes[o as usize]);
            let (Some(ai), Some(ao)) = (si.at, so.at) else { continue };
            let place = Placement::translation(sub(ao, ai));
            let (ci, co) = (classes.class[i as usize], classes.class[o as usize]);
            let in_reps = classes.to_rep[i as usize].compose(&place).compose(&classes.to_rep[o as usize].inverse());
            if seen.insert((ci, co, in_reps)) {
                rules.push(GridRule { from: i, to: o, place });
            }
        }
    }
    // Grouped by their source shape (stable: the example order within a group), so the
    // written grammar lists each shape's matches and rules under it.
    matches.sort_by_key(|m| m.a);
    rules.sort_by_key(|r| r.from);
    let start = (0..shapes.len()).max_by_key(|&i| (shapes[i].blocks.len(), std::cmp::Reverse(i))).unwrap_or(0) as u32;
    // Enough rule applications to rebuild the largest example about twice over (each
    // application adds one shape), at least the usual 50.
    let most_shapes = inferences.iter().map(|i| i.shapes.len()).max().unwrap_or(0) as u32;
    let generate = GenerateSettings {
        steps: most_shapes.saturating_mul(STEPS_PER_SHAPE).clamp(GenerateSettings::default().steps, super::MAX_STEPS),
        ..GenerateSettings::default()
    };
    let mut g = GridGrammar {
        name: blocks::sanitize(name),
        examples: examples.iter().map(|e| e.name.clone()).collect(),
        palette,
        shapes,
        matches,
        rules,
        start,
        generate,
    };
    g.validate().map_err(InductionError::Grammar)?;
    // Shapes the enclosure constraint would remove from their own example (roofs,
    // chimneys, porches) are open: generation keeps them.
    let open = super::generate::open_in_examples(&g, g.generate.seal).map_err(InductionError::Generate)?;
    for (s, o) in g.shapes.iter_mut().zip(open) {
        s.open = o;
    }
    Ok(g)
}

/// How many shapes match a shape of another example (through the grammar's matches):
/// what links the examples into one style. Zero for one example.
pub fn shared_shapes(g: &GridGrammar) -> usize {
    let n = g.shapes.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for m in &g.matches {
        let (a, b) = (m.a as usize, m.b as usize);
        if a < n && b < n {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            parent[ra.max(rb)] = ra.min(rb);
        }
    }
    let mut examples: HashMap<usize, HashSet<u32>> = HashMap::new();
    for (i, s) in g.shapes.iter().enumerate() {
        let r = find(&mut parent, i);
        examples.entry(r).or_default().insert(s.example);
    }
    (0..n).filter(|&i| examples.get(&find(&mut parent, i)).is_some_and(|e| e.len() > 1)).count()
}

/// `base`, or `base_2`, `base_3`… whichever is not taken yet (and takes it).
fn unique(base: &str, taken: &mut HashSet<String>) -> String {
    let mut name = base.to_string();
    let mut n = 2;
    while taken.contains(&name) || name == "_" {
        name = format!("{base}_{n}");
        n += 1;
    }
    taken.insert(name.clone());
    name
}
