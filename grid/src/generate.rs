//! Generation (paper §"Production of Similar Structures"): random rule application from
//! the start shape, then the enclosure constraint.
//!
//! A production is a list of *instances*: a shape and its [`Placement`] (local frame →
//! world). A rule `f → f t` applies to an instance of any shape s matching f: with
//! M the placement taking f's frame onto s's (through the declared matches), t is added
//! at `P_s ∘ M ∘ place`. An application is possible when the new instance puts no block
//! where a different block stands and adds at least one block. Each step picks an
//! instance uniformly among those with a possible application, then one of its
//! possible applications uniformly (PCG-64 seeded by the seed, so a seed gives one
//! building).
//!
//! **Enclosure.** Empty cells reachable from outside the production's box (6-connected
//! flood fill) are *outside*. The production stands on the ground: the fill does not
//! pass below its lowest blocks. Openings up to `2·seal` blocks wide (doors, windows;
//! `seal` 1 by default) do not let the outside in: the fill runs around the blocks
//! grown by `seal` cells, and an empty cell is outside when it is within `seal` cells
//! of the fill (`seal 0` is the paper's plain flood fill). An instance of a flat shape
//! is exposed when some block of it has outside cells on both sides along the shape's
//! axis (a wall with air on both faces); exposed instances are removed (their blocks
//! too, unless another instance holds them) and the fill repeats until nothing is
//! removed. 3D shapes are never removed.

use super::outside::{Outside, TooLarge};
use super::voxel::{Block, BlockKind, VoxelModel, MAX_BLOCKS, NEIGHBOURS};
use super::{turn_box, GrammarError, GridGrammar, Placement};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::collections::HashMap;

/// Generation options.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GenerateOptions {
    /// Rule applications.
    pub steps: u32,
    pub enclosure: bool,
    /// Openings up to `2·seal` blocks wide do not let the outside in (0: the paper's
    /// plain flood fill).
    pub seal: u32,
    pub seed: u64,
    /// The largest box (x, y, z) the production may fill: an application that would
    /// make it larger is not possible. See [`Bounds`].
    pub bounds: Bounds,
    /// After the enclosure constraint, keep only the largest connected piece that
    /// stands on the ground (no floating pieces).
    pub keep_largest: bool,
    /// Start from a shape drawn at random (among those with rules) instead of the
    /// grammar's start shape, as the paper's reference implementation does.
    pub random_start: bool,
    /// The adjacency constraint (the paper's alternative to enclosure, from model
    /// synthesis): a rule application is possible only when every pair of face
    /// neighbours it makes (a new block beside another block) stands beside each other,
    /// the same way round, somewhere in an example (turned, oriented blocks turned
    /// with it) or inside a shape.
    pub adjacency: bool,
    /// Derivations tried per seed: the first *complete* one (enclosed where the
    /// example is, one piece, at least 80 % of the example's blocks, every block kind
    /// of the example; see `grid::assess`) is kept, else the best of them, with a
    /// note. 1: the first derivation, as it comes. Attempt 0 is the plain seed, later
    /// ones seeds drawn from it, so a seed still gives one building.
    pub attempts: u32,
}

impl Default for GenerateOptions {
    fn default() -> Self {
        GenerateOptions {
            steps: 50,
            enclosure: true,
            seal: 1,
            seed: 0,
            bounds: Bounds::Examples(BOUNDS_FACTOR),
            keep_largest: true,
            random_start: false,
            adjacency: false,
            attempts: DEFAULT_ATTEMPTS,
        }
    }
}

impl GenerateOptions {
    /// The defaults with the grammar's `generate { }` settings (steps, enclosure,
    /// seal, and its seed when it has one).
    pub fn for_grammar(g: &GridGrammar) -> GenerateOptions {
        let s = &g.generate;
        GenerateOptions {
            steps: s.steps,
            enclosure: s.enclosure,
            seal: s.seal,
            seed: s.seed.unwrap_or(0),
            ..GenerateOptions::default()
        }
    }
}

/// A limit on the production's box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bounds {
    /// No limit.
    None,
    /// At most this many blocks along x, y and z (the reference implementation's
    /// limit is 25 × 25 × 25).
    Box([u32; 3]),
    /// `k` times the largest example's extents (x and z both take the larger of the
    /// two, since rules turn shapes; rebuilt from the shapes' `at`), or no limit for a
    /// grammar without example positions.
    Examples(u32),
}

/// The default factor of [`Bounds::Examples`].
pub const BOUNDS_FACTOR: u32 = 2;

impl Bounds {
    /// The box for `grammar`, if any.
    pub fn resolve(self, grammar: &GridGrammar) -> Option<[u32; 3]> {
        match self {
            Bounds::None => None,
            Bounds::Box(b) => Some(b),
            Bounds::Examples(k) => {
                let mut ext = [0u32; 3];
                for m in examples(grammar) {
                    if let Some((lo, hi)) = m.bounds() {
                        for a in 0..3 {
                            ext[a] = ext[a].max((hi[a] - lo[a] + 1) as u32);
                        }
                    }
                }
                if ext == [0; 3] {
                    return None;
                }
                let h = ext[0].max(ext[2]).saturating_mul(k);
                Some([h, ext[1].saturating_mul(k), h])
            }
        }
    }
}

/// The default [`GenerateOptions::attempts`].
pub const DEFAULT_ATTEMPTS: u32 = 16;
/// The largest [`GenerateOptions::attempts`].
pub const MAX_ATTEMPTS: u32 = 1000;

/// The largest `seal`.
pub const MAX_SEAL: u32 = 8;

/// A placed shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Instance {
    pub shape: u32,
    pub place: Placement,
}

/// A generated building.
#[derive(Clone, Debug)]
pub struct Generated {
    pub model: VoxelModel,
    /// The instances left after the enclosure constraint.
    pub instances: Vec<Instance>,
    /// Rules applied.
    pub applied: u32,
    /// Instances the enclosure constraint removed.
    pub removed: usize,
    /// Flood fills run by the enclosure constraint.
    pub enclosure_rounds: usize,
    /// Why generation stopped early, if it did.
    pub note: Option<String>,
}

/// A grammar prepared for derivation: matching classes and rules per class.
pub struct Derivation<'g> {
    pub grammar: &'g GridGrammar,
    /// Per shape: class index.
    class: Vec<u32>,
    /// Per shape: placement from the shape's frame to its class representative's.
    to_rep: Vec<Placement>,
    /// Per class: rule indices whose `from` is in the class.
    rules: Vec<Vec<u32>>,
    /// The block kinds of a production: the palette, then the turned blocks it lacks.
    pub kinds: Vec<BlockKind>,
    /// Per palette kind and quarter turn: the production kind (index into `kinds`).
    turns: Vec<[u32; 4]>,
}

impl<'g> Derivation<'g> {
    /// Prepares `grammar` (validated: every index in range, every match true).
    pub fn new(grammar: &'g GridGrammar) -> Derivation<'g> {
        let n = grammar.shapes.len();
        // Breadth-first over the match graph from each unvisited shape.
        let mut edges: Vec<Vec<(u32, Placement)>> = vec![Vec::new(); n];
        for m in &grammar.matches {
            let (Some(a), Some(_)) = (grammar.shapes.get(m.a as usize), grammar.shapes.get(m.b as usize)) else {
                continue;
            };
            // a-local → b-local.
            let ab = turn_box(a.size, m.turn).0;
            edges[m.a as usize].push((m.b, ab));
            edges[m.b as usize].push((m.a, ab.inverse()));
        }
        let mut class = vec![u32::MAX; n];
        let mut to_rep = vec![Placement::IDENTITY; n];
        let mut n_classes = 0;
        for root in 0..n {
            if class[root] != u32::MAX {
                continue;
            }
            class[root] = n_classes;
            let mut queue = std::collections::VecDeque::from([root as u32]);
            while let Some(x) = queue.pop_front() {
                for &(y, xy) in &edges[x as usize] {
                    if class[y as usize] == u32::MAX {
                        class[y as usize] = n_classes;
                        // y-local → x-local → rep-local.
                        to_rep[y as usize] = to_rep[x as usize].compose(&xy.inverse());
                        queue.push_back(y);
                    }
                }
            }
            n_classes += 1;
        }
        let mut rules = vec![Vec::new(); n_classes as usize];
        for (i, r) in grammar.rules.iter().enumerate() {
            if let Some(&c) = class.get(r.from as usize) {
                rules[c as usize].push(i as u32);
            }
        }
        // Turned blocks the palette lacks become kinds of their own.
        let mut kinds: Vec<BlockKind> =
            grammar.palette.iter().map(|p| BlockKind { id: p.block.clone(), color: p.color }).collect();
        let n_pal = kinds.len() as u32;
        let mut turns = grammar.kind_turns();
        for (k, row) in turns.iter_mut().enumerate() {
            for (t, v) in row.iter_mut().enumerate() {
                if *v >= n_pal {
                    let p = &grammar.palette[k];
                    let id = super::blocks::turn_block(&p.block, t as u8).unwrap_or_else(|| p.block.clone());
                    *v = kinds.len() as u32;
                    kinds.push(BlockKind { id, color: p.color });
                }
            }
        }
        Derivation { grammar, class, to_rep, rules, kinds, turns }
    }

    /// The start instance: the start shape at its example position (or the origin).
    pub fn start(&self) -> Instance {
        let s = &self.grammar.shapes[self.grammar.start as usize];
        Instance { shape: self.grammar.start, place: Placement::translation(s.at.unwrap_or([0, 0, 0])) }
    }

    /// Rules that apply to an instance of `shape` (those of every matching shape).
    pub fn rules_for(&self, shape: u32) -> &[u32] {
        self.class.get(shape as usize).and_then(|c| self.rules.get(*c as usize)).map(|v| v.as_slice()).unwrap_or(&[])
    }

    /// The instance rule `rule` adds to `inst`, or none when the rule's left side does
    /// not match the instance's shape.
    pub fn apply(&self, inst: &Instance, rule: u32) -> Option<Instance> {
        let r = self.grammar.rules.get(rule as usize)?;
        let (s, f) = (inst.shape as usize, r.from as usize);
        if self.class.get(s)? != self.class.get(f)? {
            return None;
        }
        // f-local → s-local = (s-local → rep)⁻¹ ∘ (f-local → rep).
        let f_to_s = self.to_rep[s].inverse().compose(&self.to_rep[f]);
        Some(Instance { shape: r.to, place: inst.place.compose(&f_to_s).compose(&r.place) })
    }

    /// The world box of an instance (inclusive corners).
    pub fn bounds(&self, inst: &Instance) -> ([i32; 3], [i32; 3]) {
        let size = self.grammar.shapes.get(inst.shape as usize).map(|s| s.size).unwrap_or([1; 3]);
        let hi = [size[0] as i32 - 1, size[1] as i32 - 1, size[2] as i32 - 1];
        let (a, b) = (inst.place.apply([0, 0, 0]), inst.place.apply(hi));
        let mut lo = a;
        let mut up = a;
        for k in 0..3 {
            lo[k] = a[k].min(b[k]);
            up[k] = a[k].max(b[k]);
        }
        (lo, up)
    }

    /// The world blocks of an instance.
    pub fn blocks(&self, inst: &Instance) -> impl Iterator<Item = ([i32; 3], u32)> + '_ {
        let shape = self.grammar.shapes.get(inst.shape as usize);
        let place = inst.place;
        let turns = &self.turns;
        shape.into_iter().flat_map(move |s| {
            s.blocks.iter().map(move |b| (place.apply(b.pos), super::turn_kind(turns, b.kind, place.turn)))
        })
    }
}

/// A uniform index in `0..n` (n > 0) from the stream (Lemire's multiply-shift with
/// rejection, so it does not depend on a library's sampling algorithm).
pub(super) fn below(rng: &mut Pcg64, n: usize) -> usize {
    let n = n as u64;
    loop {
        let x = rng.next_u64();
        let m = (x as u128) * (n as u128);
        let low = m as u64;
        if low >= n || low >= n.wrapping_neg() % n {
            return (m >> 64) as usize;
        }
    }
}

/// The world during a derivation: the kind and number of instances at each cell.
#[derive(Default)]
pub(super) struct World {
    pub(super) cells: HashMap<[i32; 3], (u32, u32)>,
}

impl World {
    /// Whether `blocks` fit (no different kind at a cell) and add at least one block.
    pub(super) fn fits(&self, blocks: impl Iterator<Item = ([i32; 3], u32)>) -> bool {
        let mut adds = false;
        for (p, k) in blocks {
            match self.cells.get(&p) {
                Some(&(kind, _)) if kind != k => return false,
                Some(_) => {}
                None => adds = true,
            }
        }
        adds
    }

    pub(super) fn add(&mut self, blocks: impl Iterator<Item = ([i32; 3], u32)>) {
        for (p, k) in blocks {
            self.cells.entry(p).or_insert((k, 0)).1 += 1;
        }
    }

    /// The blocks as a model with the production's kinds.
    pub(super) fn model(&self, kinds: &[BlockKind]) -> VoxelModel {
        let kinds = kinds.to_vec();
        let mut blocks: Vec<Block> = self.cells.iter().map(|(p, (k, _))| Block { pos: *p, kind: *k }).collect();
        blocks.sort_by_key(|b| (b.pos[1], b.pos[2], b.pos[0]));
        VoxelModel { kinds, blocks }
    }

    pub(super) fn remove(&mut self, blocks: impl Iterator<Item = ([i32; 3], u32)>) {
        self.remove_into(blocks, &mut Vec::new());
    }

    /// [`World::remove`], pushing the cells left empty onto `emptied`.
    fn remove_into(&mut self, blocks: impl Iterator<Item = ([i32; 3], u32)>, emptied: &mut Vec<[i32; 3]>) {
        for (p, _) in blocks {
            if let Some(c) = self.cells.get_mut(&p) {
                c.1 -= 1;
                if c.1 == 0 {
                    self.cells.remove(&p);
                    emptied.push(p);
                }
            }
        }
    }
}

/// Why a building cannot be generated, measured or enclosed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GenerateError {
    /// The grammar does not verify.
    Grammar(GrammarError),
    /// The production is too large for the enclosure constraint (`cells` cells in
    /// its padded bounding box).
    TooLarge { cells: u64 },
    /// An instance names a shape past the grammar's shapes.
    ShapeOutOfRange,
    /// An example index past the grammar's examples.
    NoExample(u32),
}

impl std::fmt::Display for GenerateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GenerateError::Grammar(e) => write!(f, "{e}"),
            GenerateError::TooLarge { cells } => write!(f, "{}", TooLarge { cells: *cells }),
            GenerateError::ShapeOutOfRange => write!(f, "an instance names a shape out of range"),
            GenerateError::NoExample(e) => write!(f, "no example {e}"),
        }
    }
}

impl std::error::Error for GenerateError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            GenerateError::Grammar(e) => Some(e),
            _ => None,
        }
    }
}

impl From<GrammarError> for GenerateError {
    fn from(e: GrammarError) -> GenerateError {
        GenerateError::Grammar(e)
    }
}

impl From<TooLarge> for GenerateError {
    fn from(e: TooLarge) -> GenerateError {
        GenerateError::TooLarge { cells: e.cells }
    }
}

/// One derivation: `steps` random rule applications from the start shape, then
/// (optionally) the enclosure constraint. `grid::build::generate` makes several
/// and keeps the first complete one ([`GenerateOptions::attempts`]).
pub fn derive(grammar: &GridGrammar, opts: &GenerateOptions) -> Result<Generated, GenerateError> {
    let d = Derivation::new(grammar);
    let mut rng = Pcg64::seed_from_u64(opts.seed);
    let mut world = World::default();
    let limit = opts.bounds.resolve(grammar);
    let start = if opts.random_start {
        let with_rules: Vec<u32> = (0..grammar.shapes.len() as u32).filter(|&s| !d.rules_for(s).is_empty()).collect();
        match with_rules.len() {
            0 => d.start(),
            n => {
                let s = with_rules[below(&mut rng, n)];
                let at = grammar.shapes[s as usize].at.unwrap_or([0, 0, 0]);
                Instance { shape: s, place: Placement::translation(at) }
            }
        }
    } else {
        d.start()
    };
    world.add(d.blocks(&start));
    let mut bbox = d.bounds(&start);
    let mut instances = vec![start];
    // Per instance: the rules not yet found impossible (a rule that cannot apply now
    // never can: the world only grows while rules are applied), copied from the class's
    // list when the instance is first picked.
    let mut open: Vec<Option<Vec<u32>>> = vec![None];
    let mut open_instances: Vec<usize> = if d.rules_for(start.shape).is_empty() { vec![] } else { vec![0] };
    let mut applied = 0;
    let mut note = None;
    let adjacent = opts.adjacency.then(|| Adjacency::of(&d));
    while applied < opts.steps && !open_instances.is_empty() {
        let oi = below(&mut rng, open_instances.len());
        let i = open_instances[oi];
        let rules = open[i].get_or_insert_with(|| d.rules_for(instances[i].shape).to_vec());
        let ri = below(&mut rng, rules.len());
        let rule = rules[ri];
        let within = |new: &Instance| {
            let Some(limit) = limit else { return true };
            let (lo, hi) = union_box(bbox, d.bounds(new));
            (0..3).all(|a| (hi[a] - lo[a] + 1) as u32 <= limit[a])
        };
        match d.apply(&instances[i], rule) {
            Some(new)
                if within(&new)
                    && world.fits(d.blocks(&new))
                    && adjacent.as_ref().is_none_or(|a| a.allows(&world, d.blocks(&new))) =>
            {
                bbox = union_box(bbox, d.bounds(&new));
                if world.cells.len() + grammar.shapes[new.shape as usize].blocks.len() > MAX_BLOCKS {
                    note = Some(format!("stopped at {MAX_BLOCKS} blocks"));
                    break;
                }
                world.add(d.blocks(&new));
                instances.push(new);
                open.push(None);
                if !d.rules_for(new.shape).is_empty() {
                    open_instances.push(instances.len() - 1);
                }
                applied += 1;
            }
            _ => {
                rules.swap_remove(ri);
                if rules.is_empty() {
                    open_instances.swap_remove(oi);
                    open[i] = Some(Vec::new());
                }
            }
        }
    }
    let (removed, rounds) = settle(&d, &mut instances, &mut world, opts)?;
    // Doors joined for induction are two blocks again.
    let (model, _) = super::doors::split_doors(&world.model(&d.kinds));
    Ok(Generated { model, instances, applied, removed, enclosure_rounds: rounds, note })
}

/// The enclosure constraint (when on), then the largest piece on the ground (when
/// kept); dropping the other pieces can open what they closed, so the two repeat until
/// neither removes anything. Returns (instances removed, rounds of the enclosure: looks
/// for exposed instances). The outside is computed once and then updated as blocks go
/// (`grid::outside`), again from scratch only when the lowest blocks go.
pub(super) fn settle(
    d: &Derivation,
    instances: &mut Vec<Instance>,
    world: &mut World,
    opts: &GenerateOptions,
) -> Result<(usize, usize), GenerateError> {
    let (mut removed, mut rounds) = (0, 0);
    let mut out = if opts.enclosure { outside_of(world, opts.seal)? } else { None };
    let mut emptied = Vec::new();
    loop {
        if opts.enclosure {
            loop {
                rounds += 1;
                let Some(o) = &out else { break };
                let exposed: Vec<usize> =
                    instances.iter().enumerate().filter(|(_, inst)| o.exposes(d, inst)).map(|(i, _)| i).collect();
                if exposed.is_empty() {
                    break;
                }
                removed += exposed.len();
                let mut gone = vec![false; instances.len()];
                for i in exposed {
                    gone[i] = true;
                    world.remove_into(d.blocks(&instances[i]), &mut emptied);
                }
                let mut g = gone.iter();
                instances.retain(|_| !g.next().copied().unwrap_or(false));
                update_outside(&mut out, world, &mut emptied, opts.seal)?;
            }
        }
        let dropped = if opts.keep_largest { keep_largest_into(d, instances, world, &mut emptied) } else { 0 };
        removed += dropped;
        if dropped == 0 || !opts.enclosure {
            return Ok((removed, rounds));
        }
        update_outside(&mut out, world, &mut emptied, opts.seal)?;
    }
}

/// The outside of `world`'s blocks with openings up to `2·seal` sealed.
pub(super) fn outside_of(world: &World, seal: u32) -> Result<Option<Outside>, GenerateError> {
    Ok(Outside::of(world.cells.keys().copied(), seal.min(MAX_SEAL))?)
}

/// Takes the `emptied` cells out of the outside (and clears the list); computes it
/// again when the lowest blocks went (the ground rose) or the world is empty.
fn update_outside(
    out: &mut Option<Outside>,
    world: &World,
    emptied: &mut Vec<[i32; 3]>,
    seal: u32,
) -> Result<(), GenerateError> {
    let ground = world.cells.keys().map(|p| p[1]).min();
    match (out.as_mut(), ground) {
        (Some(o), Some(g)) if g == o.ground() => emptied.iter().for_each(|&p| o.remove(p)),
        _ => *out = outside_of(world, seal)?,
    }
    emptied.clear();
    Ok(())
}

/// The pairs of face neighbours the adjacency constraint allows: (kind, neighbour's
/// kind, direction index into [`NEIGHBOURS`]), in production kinds.
pub(super) struct Adjacency {
    allowed: std::collections::HashSet<(u32, u32, u8)>,
}

impl Adjacency {
    /// Every pair of face neighbours of the examples (rebuilt from the shapes' places)
    /// and inside each shape, under the four quarter turns.
    pub(super) fn of(d: &Derivation) -> Adjacency {
        let mut allowed = std::collections::HashSet::new();
        let mut add_all = |cells: &HashMap<[i32; 3], u32>| {
            for (&p, &k) in cells {
                for (di, dir) in NEIGHBOURS.iter().enumerate() {
                    let Some(&n) = cells.get(&super::add(p, *dir)) else { continue };
                    for t in 0..4u8 {
                        let td = super::rotate(t, *dir);
                        let tdi = NEIGHBOURS.iter().position(|x| *x == td).unwrap_or(di) as u8;
                        allowed.insert((super::turn_kind(&d.turns, k, t), super::turn_kind(&d.turns, n, t), tdi));
                    }
                }
            }
        };
        for m in examples(d.grammar) {
            add_all(&m.blocks.iter().map(|b| (b.pos, b.kind)).collect());
        }
        for s in &d.grammar.shapes {
            add_all(&s.blocks.iter().map(|b| (b.pos, b.kind)).collect());
        }
        Adjacency { allowed }
    }

    /// Whether adding `blocks` (production kinds) to the world makes only allowed pairs.
    pub(super) fn allows(&self, world: &World, blocks: impl Iterator<Item = ([i32; 3], u32)>) -> bool {
        let new: HashMap<[i32; 3], u32> = blocks.collect();
        new.iter().all(|(&p, &k)| {
            NEIGHBOURS.iter().enumerate().all(|(di, dir)| {
                let q = super::add(p, *dir);
                match world.cells.get(&q).map(|c| c.0).or_else(|| new.get(&q).copied()) {
                    Some(n) => self.allowed.contains(&(k, n, di as u8)),
                    None => true,
                }
            })
        })
    }
}

/// The smallest box holding both boxes (inclusive corners).
pub(super) fn union_box(a: ([i32; 3], [i32; 3]), b: ([i32; 3], [i32; 3])) -> ([i32; 3], [i32; 3]) {
    let mut out = a;
    for k in 0..3 {
        out.0[k] = a.0[k].min(b.0[k]);
        out.1[k] = a.1[k].max(b.1[k]);
    }
    out
}

/// Keeps the largest 6-connected piece of the production that reaches its lowest
/// level (ties: the piece with the smallest lowest block), and the instances in it;
/// returns how many instances were removed. Each instance is connected, so it lies
/// in one piece.
pub(super) fn keep_largest_supported(d: &Derivation, instances: &mut Vec<Instance>, world: &mut World) -> usize {
    keep_largest_into(d, instances, world, &mut Vec::new())
}

/// [`keep_largest_supported`], pushing the cells it empties onto `emptied`.
fn keep_largest_into(
    d: &Derivation,
    instances: &mut Vec<Instance>,
    world: &mut World,
    emptied: &mut Vec<[i32; 3]>,
) -> usize {
    let Some(ground) = world.cells.keys().map(|p| p[1]).min() else { return 0 };
    let mut cells: Vec<[i32; 3]> = world.cells.keys().copied().collect();
    cells.sort_by_key(|p| (p[1], p[2], p[0]));
    let mut piece: HashMap<[i32; 3], u32> = HashMap::with_capacity(cells.len());
    let mut best: Option<(usize, u32)> = None;
    let mut n_pieces = 0u32;
    for &c in &cells {
        if piece.contains_key(&c) {
            continue;
        }
        let id = n_pieces;
        n_pieces += 1;
        let (mut size, mut grounded) = (0usize, false);
        let mut stack = vec![c];
        piece.insert(c, id);
        while let Some(p) = stack.pop() {
            size += 1;
            grounded |= p[1] == ground;
            for dl in NEIGHBOURS {
                let q = super::add(p, dl);
                if world.cells.contains_key(&q) && !piece.contains_key(&q) {
                    piece.insert(q, id);
                    stack.push(q);
                }
            }
        }
        if grounded && best.is_none_or(|(s, _)| size > s) {
            best = Some((size, id));
        }
    }
    let Some((_, keep)) = best else { return 0 };
    if n_pieces == 1 {
        return 0;
    }
    let before = instances.len();
    let mut gone = Vec::new();
    instances.retain(|inst| {
        let first = d.blocks(inst).next().map(|(p, _)| p);
        let stays = first.and_then(|p| piece.get(&p)).is_some_and(|&id| id == keep);
        if !stays {
            gone.push(*inst);
        }
        stays
    });
    for inst in &gone {
        world.remove_into(d.blocks(inst), emptied);
    }
    // Blocks of removed pieces that no instance held (none: every block is an
    // instance's) would stay; drop any cell outside the kept piece all the same.
    world.cells.retain(|p, _| {
        let stays = piece.get(p) == Some(&keep);
        if !stays {
            emptied.push(*p);
        }
        stays
    });
    before - instances.len()
}

/// Applies the enclosure constraint to given instances of `grammar`'s shapes (a
/// production made by hand, say); returns the instances kept, the building they
/// make, and how many were removed.
pub fn enclosure(
    grammar: &GridGrammar,
    instances: &[Instance],
    seal: u32,
) -> Result<(Vec<Instance>, VoxelModel, usize), GenerateError> {
    grammar.validate()?;
    let (d, mut world) = placed(grammar, instances)?;
    let mut kept = instances.to_vec();
    let only = GenerateOptions { enclosure: true, seal, keep_largest: false, ..GenerateOptions::default() };
    let (removed, _) = settle(&d, &mut kept, &mut world, &only)?;
    Ok((kept, world.model(&d.kinds), removed))
}

/// The instances exposed on both sides (see the module documentation). Openings up
/// to `2·seal` blocks wide are sealed: the flood fill runs around the blocks grown by
/// `seal` cells, and an empty cell is outside when it lies within `seal` cells of the
/// fill (`seal` 0 is the paper's plain flood fill).
fn exposed_instances(
    d: &Derivation,
    instances: &[Instance],
    world: &World,
    seal: u32,
) -> Result<Vec<usize>, GenerateError> {
    Ok(exposed_and_interior(d, instances, world, seal)?.0)
}

impl Outside {
    /// Whether `inst` (of a flat shape that is not open) has a block with outside cells
    /// on both sides along the shape's axis.
    pub(super) fn exposes(&self, d: &Derivation, inst: &Instance) -> bool {
        let Some(shape) = d.grammar.shapes.get(inst.shape as usize) else { return false };
        let Some(plane) = shape.plane.filter(|_| !shape.open) else { return false };
        let axis = inst.place.axis(plane) as usize;
        d.blocks(inst).any(|(p, _)| {
            let (mut a, mut b) = (p, p);
            a[axis] += 1;
            b[axis] -= 1;
            self.is_out(a) && self.is_out(b)
        })
    }
}

/// [`exposed_instances`] and the number of *interior* cells: empty cells above the
/// ground that the outside does not reach (the rooms a roof and walls enclose).
fn exposed_and_interior(
    d: &Derivation,
    instances: &[Instance],
    world: &World,
    seal: u32,
) -> Result<(Vec<usize>, usize), GenerateError> {
    let Some(out) = outside_of(world, seal)? else { return Ok((Vec::new(), 0)) };
    let exposed = instances.iter().enumerate().filter(|(_, inst)| out.exposes(d, inst)).map(|(i, _)| i).collect();
    Ok((exposed, out.interior()))
}

/// The derivation of `grammar` and the world holding `instances`' blocks, for the
/// enclosure and its report; an instance of a shape the grammar lacks is an error.
pub(super) fn placed<'g>(
    grammar: &'g GridGrammar,
    instances: &[Instance],
) -> Result<(Derivation<'g>, World), GenerateError> {
    if instances.iter().any(|i| i.shape as usize >= grammar.shapes.len()) {
        return Err(GenerateError::ShapeOutOfRange);
    }
    let d = Derivation::new(grammar);
    let mut world = World::default();
    for i in instances {
        world.add(d.blocks(i));
    }
    Ok((d, world))
}

/// How enclosed a production is: (instances of shapes that are not open exposed on
/// both sides, interior cells), with openings up to `2·seal` wide sealed.
pub fn enclosure_report(
    grammar: &GridGrammar,
    instances: &[Instance],
    seal: u32,
) -> Result<(usize, usize), GenerateError> {
    let (d, world) = placed(grammar, instances)?;
    let (exposed, interior) = exposed_and_interior(&d, instances, &world, seal)?;
    Ok((exposed.len(), interior))
}

/// The shapes of example `e` placed where they stand in it (shapes without a
/// position left out): the production that rebuilds the example.
pub fn example_instances(grammar: &GridGrammar, e: u32) -> Vec<Instance> {
    (0..grammar.shapes.len() as u32)
        .filter_map(|i| {
            let s = &grammar.shapes[i as usize];
            s.at.filter(|_| s.example == e).map(|at| Instance { shape: i, place: Placement::translation(at) })
        })
        .collect()
}

/// Per shape: whether it is *open* in its example, i.e. the enclosure constraint
/// (with `seal`) finds it exposed where the example has it (a roof's overhang, a
/// chimney, a porch's floor). Such shapes are legitimately unenclosed (the paper's
/// remedy for enclosure removing an example's own parts); generation never removes
/// them. Shapes without a position are not open.
pub fn open_in_examples(grammar: &GridGrammar, seal: u32) -> Result<Vec<bool>, GenerateError> {
    let mut open = vec![false; grammar.shapes.len()];
    let mut plain = grammar.clone();
    plain.shapes.iter_mut().for_each(|s| s.open = false);
    let d = Derivation::new(&plain);
    for e in 0..grammar.examples.len().max(1) as u32 {
        let instances = example_instances(grammar, e);
        let mut world = World::default();
        for i in &instances {
            world.add(d.blocks(i));
        }
        for i in exposed_instances(&d, &instances, &world, seal)? {
            open[instances[i].shape as usize] = true;
        }
    }
    Ok(open)
}

/// The example buildings rebuilt from the shapes' `at` positions (one model per
/// example; shapes without a position are left out).
pub fn examples(grammar: &GridGrammar) -> Vec<VoxelModel> {
    let kinds: Vec<BlockKind> =
        grammar.palette.iter().map(|p| BlockKind { id: p.block.clone(), color: p.color }).collect();
    let n = grammar.examples.len().max(1);
    let mut cells: Vec<HashMap<[i32; 3], u32>> = vec![HashMap::new(); n];
    for s in &grammar.shapes {
        let (Some(at), Some(c)) = (s.at, cells.get_mut(s.example as usize)) else { continue };
        for b in &s.blocks {
            c.insert(super::add(b.pos, at), b.kind);
        }
    }
    cells
        .into_iter()
        .map(|c| {
            let mut blocks: Vec<Block> = c.into_iter().map(|(pos, kind)| Block { pos, kind }).collect();
            blocks.sort_by_key(|b| (b.pos[1], b.pos[2], b.pos[0]));
            super::doors::split_doors(&VoxelModel { kinds: kinds.clone(), blocks }).0
        })
        .collect()
}
