//! Shape inference (SIGI, paper §"Inferring Shape Sets"): hill climbing over shape
//! sets with the cost `(1 + #S)^α · Σ_s entropy(s)`, merge and split moves, and the
//! paper's initialisations.
//!
//! **Cost.** [`Cost::Product`] is the paper's equation 4 (the default); from one shape
//! per block it cannot accept a merge that mixes block kinds (every pure set costs 0).
//! [`Cost::Sum`], `α·(1 + #S) + Σ entropy`, is what the paper's reference
//! implementation computes; docs/grid.md compares the two.
//!
//! **Shapes.** A shape is a connected set of blocks under a specification: *3D* (any
//! 6-connected set), *2D* (4-connected within one plane x = c, y = c or z = c), or
//! *rectangular* (a filled rectangle within one plane).
//!
//! **Search state.** For 2D and rectangular shapes every block starts as three shapes,
//! one in each plane (paper: "we initialize each block as three shapes, with one in
//! each plane, and only allow merges between shapes in the same plane"). The shapes of
//! one *layer* (axis a, coordinate c) then always partition that layer's blocks, so a
//! block has one owner per axis and the neighbours of a shape are found through the
//! owner tables in O(boundary). 3D shapes partition the whole building. Merging starts
//! from one shape per block (per plane); splitting from maximal shapes (connected
//! components of each layer, or greedy maximal rectangles); both operations start from
//! the minimal set, as in the paper's implementation.
//!
//! **Moves.** Each shape keeps its kind histogram, `Σ c·log2 c` and entropy, so a move
//! is evaluated in O(kinds) (a merge) or O(blocks) for all cuts of a shape (a split,
//! with running prefix histograms), never by re-evaluating the whole set. The global
//! cost only depends on #S and Σ entropy, kept incrementally (and recomputed exactly
//! after each pass). Hill climbing is first-improvement: passes visit the shapes in
//! order and apply, for each shape, its best improving merge (each shape takes part in
//! at most one merge per pass, so shapes grow evenly, like the paper's
//! merge-then-requeue loop); with both operations, split passes run when a merge pass
//! finds nothing, and merging resumes after any split. A move improves when it lowers
//! the cost, or keeps it equal and lowers #S (so a building of one block kind, where
//! every entropy is 0, still merges). Splits cut a shape by an axis-aligned plane into
//! two parts that must each be connected.
//!
//! **Result.** After the search every block is covered: shapes are taken largest first;
//! without overlap a shape is taken only if it is disjoint from those taken, and the
//! blocks left over are covered by the pieces of the remaining shapes (split into valid
//! shapes); with overlap any shape covering an uncovered block is taken, then shapes
//! covered entirely by the others are removed.

use super::voxel::{Grid, VoxelModel};
use super::Axis;

/// A shape specification.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Spec {
    /// Filled rectangles in one plane.
    Rect,
    /// Connected sets in one plane.
    Planar,
    /// Connected sets.
    Solid,
}

impl Spec {
    /// `rect`, `2d` or `3d`.
    pub fn parse(s: &str) -> Option<Spec> {
        match s {
            "rect" | "rectangular" => Some(Spec::Rect),
            "2d" | "2D" | "planar" => Some(Spec::Planar),
            "3d" | "3D" | "solid" => Some(Spec::Solid),
            _ => None,
        }
    }

    /// The name `parse` reads.
    pub fn name(self) -> &'static str {
        match self {
            Spec::Rect => "rect",
            Spec::Planar => "2d",
            Spec::Solid => "3d",
        }
    }
}

/// The search operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Ops {
    Merge,
    Split,
    Both,
}

impl Ops {
    /// `merge`, `split` or `both`.
    pub fn parse(s: &str) -> Option<Ops> {
        match s {
            "merge" => Some(Ops::Merge),
            "split" => Some(Ops::Split),
            "both" => Some(Ops::Both),
            _ => None,
        }
    }

    /// The name `parse` reads.
    pub fn name(self) -> &'static str {
        match self {
            Ops::Merge => "merge",
            Ops::Split => "split",
            Ops::Both => "both",
        }
    }
}

/// The cost function of the search.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Cost {
    /// `(1 + #S)^α · Σ entropy`: the paper's equation 4 as printed. From one shape per
    /// block (Σ entropy = 0, cost 0) it accepts no merge that mixes block kinds, so α
    /// has no effect and shapes stay pure.
    Product,
    /// `α · (1 + #S) + Σ entropy`: what the paper's reference implementation computes
    /// (its tables and pictures come from this one): the default. It trades entropy
    /// for fewer shapes.
    #[default]
    Sum,
    /// `α · (1 + #S) + Σ entropy · kinds`: the reference implementation's second cost
    /// function ("cost grows more for every block type"): each shape's entropy weighed
    /// by its number of block kinds, so mixed shapes cost more.
    Kinds,
}

impl Cost {
    /// `product`, `sum` or `kinds`.
    pub fn parse(s: &str) -> Option<Cost> {
        match s {
            "product" => Some(Cost::Product),
            "sum" => Some(Cost::Sum),
            "kinds" => Some(Cost::Kinds),
            _ => None,
        }
    }

    /// The name `parse` reads.
    pub fn name(self) -> &'static str {
        match self {
            Cost::Product => "product",
            Cost::Sum => "sum",
            Cost::Kinds => "kinds",
        }
    }

    /// A number ordered like [`Cost::eval`] that stays finite where the cost overflows
    /// (the product's logarithm; −∞ for a zero product): what the search compares.
    pub fn key(self, n_shapes: usize, entropy_sum: f64, alpha: f64) -> f64 {
        match self {
            Cost::Product if entropy_sum <= 0.0 => f64::NEG_INFINITY,
            Cost::Product => alpha * (1.0 + n_shapes as f64).ln() + entropy_sum.ln(),
            Cost::Sum | Cost::Kinds => self.eval(n_shapes, entropy_sum, alpha),
        }
    }

    /// The cost of `n_shapes` shapes whose terms sum to `entropy_sum` (see
    /// [`Cost::term`]).
    pub fn eval(self, n_shapes: usize, entropy_sum: f64, alpha: f64) -> f64 {
        match self {
            Cost::Product => cost(n_shapes, entropy_sum, alpha),
            Cost::Sum | Cost::Kinds => alpha * (1.0 + n_shapes as f64) + entropy_sum,
        }
    }

    /// A shape's term in the sum: its entropy, times its number of kinds for
    /// [`Cost::Kinds`].
    pub fn term(self, entropy: f64, kinds: usize) -> f64 {
        match self {
            Cost::Kinds => entropy * kinds as f64,
            Cost::Product | Cost::Sum => entropy,
        }
    }
}

/// The default α: with the default cost (`sum`) and operations (`both`, from the
/// maximal shapes) the search splits and merges on real examples at α < 1 (at α ≥ 1
/// no single cut pays: no move), and #S falls and matching falls as α grows from 0 to
/// 1 (the paper's Table 2 trend); docs/grid.md "Whole buildings" has the measurements.
pub const DEFAULT_ALPHA: f64 = 0.5;

/// Inference options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InferOptions {
    pub spec: Spec,
    /// Weight of #S in the cost (≥ 0).
    pub alpha: f64,
    pub ops: Ops,
    /// Keep overlapping shapes in the result.
    pub overlap: bool,
    pub cost: Cost,
    /// After the search, cut shapes along the floors and walls they touch (the
    /// reference implementation's post-split; see [`Search::post_split`]).
    pub post_split: bool,
}

impl Default for InferOptions {
    fn default() -> Self {
        InferOptions {
            spec: Spec::Rect,
            alpha: DEFAULT_ALPHA,
            ops: Ops::Both,
            overlap: false,
            cost: Cost::default(),
            post_split: false,
        }
    }
}

/// The entropy (bits) of a shape with these kind counts: −Σ p log2 p.
pub fn entropy(counts: &[u32]) -> f64 {
    let n: u32 = counts.iter().sum();
    if n == 0 {
        return 0.0;
    }
    let n = n as f64;
    let e: f64 = counts.iter().filter(|&&c| c > 0).map(|&c| -(c as f64 / n) * (c as f64 / n).log2()).sum();
    e.max(0.0)
}

/// The cost of a shape set: `(1 + n_shapes)^α · entropy_sum`.
pub fn cost(n_shapes: usize, entropy_sum: f64, alpha: f64) -> f64 {
    (1.0 + n_shapes as f64).powf(alpha) * entropy_sum
}

/// One shape of the result: block indices into the model (sorted) and the axis the
/// shape is flat along (none for 3D shapes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InferredShape {
    pub blocks: Vec<u32>,
    pub plane: Option<Axis>,
}

/// A move the search applied (recorded when asked for, see [`Search::record_moves`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Move {
    /// Shapes `kept` and `removed` became one (with `kept`'s id).
    Merge { kept: u32, removed: u32, cost: f64 },
    /// Blocks of `shape` with coordinate `< at` along `axis` became shape `new`.
    Split { shape: u32, new: u32, axis: Axis, at: i32, cost: f64 },
}

/// What a search did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SearchStats {
    /// Shapes in the initial set.
    pub initial_shapes: usize,
    /// Shapes in the set when the search stopped (before coverage and overlap).
    pub search_shapes: usize,
    pub merges: usize,
    pub splits: usize,
    pub passes: usize,
    /// The cost when the search stopped.
    pub cost: f64,
    /// True when the move cap stopped the search before a local optimum.
    pub capped: bool,
}

/// Progress of a running search (for progress bars).
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub pass: usize,
    pub shapes: usize,
    pub cost: f64,
}

/// A search's result.
#[derive(Clone, Debug)]
pub struct Inference {
    pub shapes: Vec<InferredShape>,
    pub stats: SearchStats,
}

/// Infers shapes for one building.
pub fn infer(model: &VoxelModel, opts: &InferOptions, progress: &mut dyn FnMut(Progress)) -> Inference {
    let mut s = Search::new(model, opts.spec, opts.alpha);
    s.set_cost(opts.cost);
    // Both operations start from the maximal set: from the minimal one the merges
    // reach sets where no cut pays (a cut lowers Σ entropy by more than α only where
    // a merge raised it by more than α), so `both` would never split.
    match opts.ops {
        Ops::Split | Ops::Both => s.init_maximal(),
        Ops::Merge => s.init_minimal(),
    }
    s.run(opts.ops, progress);
    let mut shapes = s.result(opts.overlap);
    if opts.post_split {
        shapes = s.post_split(shapes);
    }
    Inference { shapes, stats: s.stats.clone() }
}

#[derive(Clone, Debug, Default)]
struct SShape {
    alive: bool,
    /// The layer axis (0..3) for planar and rectangular shapes; 0 for 3D shapes.
    layer: u8,
    blocks: Vec<u32>,
    lo: [i32; 3],
    hi: [i32; 3],
    /// (kind, count), sorted by kind.
    hist: Vec<(u32, u32)>,
    /// Σ c·log2 c over the histogram.
    sclog: f64,
    entropy: f64,
}

/// The hill-climbing search (public so tests can drive it move by move).
pub struct Search<'m> {
    model: &'m VoxelModel,
    grid: Grid,
    spec: Spec,
    alpha: f64,
    cost_model: Cost,
    shapes: Vec<SShape>,
    /// owner[a][block]: the shape holding `block` in layer axis a (3D: owner[0]).
    owner: [Vec<u32>; 3],
    n_alive: usize,
    entropy_sum: f64,
    /// c·log2 c for c in 0..=#blocks.
    clog: Vec<f64>,
    /// Scratch stamps per shape (deduplicating neighbour lists).
    stamp: Vec<u32>,
    stamp_gen: u32,
    log: Option<Vec<Move>>,
    max_moves: usize,
    /// Per layer axis: the neighbour offsets within the plane (all six for 3D).
    steps: [Vec<[i32; 3]>; 3],
    /// Per layer axis: the in-plane axes (all three for 3D).
    axes: [Vec<usize>; 3],
    pub stats: SearchStats,
}

const NONE: u32 = u32::MAX;

impl<'m> Search<'m> {
    /// A search over `model`'s blocks, with no shapes yet (call an `init_…`).
    pub fn new(model: &'m VoxelModel, spec: Spec, alpha: f64) -> Search<'m> {
        let n = model.blocks.len();
        let clog = (0..=n).map(|c| if c == 0 { 0.0 } else { c as f64 * (c as f64).log2() }).collect();
        Search {
            model,
            grid: Grid::new(&model.blocks, 1),
            spec,
            alpha: if alpha.is_finite() { alpha.max(0.0) } else { 1.0 },
            cost_model: Cost::Product,
            shapes: Vec::new(),
            owner: [vec![NONE; n], vec![NONE; n], vec![NONE; n]],
            n_alive: 0,
            entropy_sum: 0.0,
            clog,
            stamp: Vec::new(),
            stamp_gen: 0,
            log: None,
            max_moves: 50 * n.max(1) + 1000,
            steps: [0u8, 1, 2].map(|a| {
                super::voxel::NEIGHBOURS.iter().copied().filter(|d| spec == Spec::Solid || d[a as usize] == 0).collect()
            }),
            axes: [0usize, 1, 2].map(|a| (0..3).filter(|&k| spec == Spec::Solid || k != a).collect()),
            stats: SearchStats::default(),
        }
    }

    /// Uses another cost function (before `init_…`).
    pub fn set_cost(&mut self, c: Cost) {
        self.cost_model = c;
    }

    fn cost_of(&self, n: usize, h: f64) -> f64 {
        self.cost_model.eval(n, h, self.alpha)
    }

    fn key_of(&self, n: usize, h: f64) -> f64 {
        self.cost_model.key(n, h, self.alpha)
    }

    /// Records every applied move (see [`Search::moves`]).
    pub fn record_moves(&mut self) {
        self.log = Some(Vec::new());
    }

    /// The applied moves, if recorded.
    pub fn moves(&self) -> &[Move] {
        self.log.as_deref().unwrap_or(&[])
    }

    fn layers(&self) -> std::ops::Range<u8> {
        match self.spec {
            Spec::Solid => 0..1,
            _ => 0..3,
        }
    }

    /// The current cost.
    pub fn cost(&self) -> f64 {
        self.cost_of(self.n_alive, self.entropy_sum)
    }

    /// The number of shapes in the current set.
    pub fn n_shapes(&self) -> usize {
        self.n_alive
    }

    /// Σ entropy over the current set.
    pub fn entropy_sum(&self) -> f64 {
        self.entropy_sum
    }

    /// The current shapes of layer axis `axis` (3D: pass 0), each as sorted block indices.
    pub fn layer_shapes(&self, axis: Axis) -> Vec<Vec<u32>> {
        let mut v: Vec<Vec<u32>> = self
            .shapes
            .iter()
            .filter(|s| s.alive && s.layer == axis)
            .map(|s| {
                let mut b = s.blocks.clone();
                b.sort_unstable();
                b
            })
            .collect();
        v.sort();
        v
    }

    fn pos(&self, b: u32) -> [i32; 3] {
        self.model.blocks[b as usize].pos
    }

    fn kind(&self, b: u32) -> u32 {
        self.model.blocks[b as usize].kind
    }

    /// Builds a shape from blocks and registers it as a new id.
    fn add_shape(&mut self, layer: u8, blocks: Vec<u32>) -> u32 {
        let id = self.shapes.len() as u32;
        let mut s = SShape { alive: true, layer, blocks, ..SShape::default() };
        self.refresh(&mut s);
        for &b in &s.blocks {
            self.owner[layer as usize][b as usize] = id;
        }
        self.entropy_sum += s.entropy;
        self.n_alive += 1;
        self.shapes.push(s);
        id
    }

    /// Recomputes bounds, histogram and entropy from the blocks.
    fn refresh(&self, s: &mut SShape) {
        let first = s.blocks.first().map(|&b| self.pos(b)).unwrap_or([0; 3]);
        let (mut lo, mut hi) = (first, first);
        let mut kinds: Vec<u32> = Vec::with_capacity(s.blocks.len());
        for &b in &s.blocks {
            let p = self.pos(b);
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            kinds.push(self.kind(b));
        }
        kinds.sort_unstable();
        let mut hist: Vec<(u32, u32)> = Vec::new();
        for k in kinds {
            match hist.last_mut() {
                Some((kk, c)) if *kk == k => *c += 1,
                _ => hist.push((k, 1)),
            }
        }
        s.lo = lo;
        s.hi = hi;
        s.sclog = hist.iter().map(|&(_, c)| self.clog[c as usize]).sum();
        s.entropy = self.term_of(s.blocks.len(), s.sclog, hist.len());
        s.hist = hist;
    }

    fn entropy_of(&self, n: usize, sclog: f64) -> f64 {
        if n <= 1 {
            return 0.0;
        }
        ((n as f64).log2() - sclog / n as f64).max(0.0)
    }

    /// A shape's term in the cost: its entropy (times its kinds for [`Cost::Kinds`]).
    fn term_of(&self, n: usize, sclog: f64, kinds: usize) -> f64 {
        self.cost_model.term(self.entropy_of(n, sclog), kinds)
    }

    fn reset(&mut self) {
        self.shapes.clear();
        self.n_alive = 0;
        self.entropy_sum = 0.0;
        for o in &mut self.owner {
            o.iter_mut().for_each(|x| *x = NONE);
        }
    }

    /// One shape per block (per plane for 2D and rectangular shapes).
    pub fn init_minimal(&mut self) {
        self.reset();
        for a in self.layers() {
            for b in 0..self.model.blocks.len() as u32 {
                self.add_shape(a, vec![b]);
            }
        }
        self.start_stats();
    }

    /// Maximal shapes: connected components (of each layer for 2D), or greedy maximal
    /// rectangles of each layer.
    pub fn init_maximal(&mut self) {
        self.reset();
        let n = self.model.blocks.len();
        for a in self.layers() {
            let mut taken = vec![false; n];
            for b in 0..n as u32 {
                if taken[b as usize] {
                    continue;
                }
                let blocks = match self.spec {
                    Spec::Rect => self.grow_rect(b, a, &mut |x| !taken[x as usize]),
                    Spec::Planar | Spec::Solid => self.component(b, a, &|_| true, &taken),
                };
                for &x in &blocks {
                    taken[x as usize] = true;
                }
                self.add_shape(a, blocks);
            }
        }
        self.start_stats();
    }

    /// Starts a search from given shapes (each a block list in a layer), for tests.
    pub fn init_from(&mut self, shapes: &[(Axis, Vec<u32>)]) {
        self.reset();
        for (a, blocks) in shapes {
            self.add_shape(*a, blocks.clone());
        }
        self.start_stats();
    }

    fn start_stats(&mut self) {
        self.stats = SearchStats { initial_shapes: self.n_alive, cost: self.cost(), ..SearchStats::default() };
    }

    /// The in-plane axes of layer axis a (the cut axes; all three for 3D).
    fn plane_axes(&self, a: u8) -> &[usize] {
        &self.axes[a as usize]
    }

    /// The neighbour offsets within a shape's plane (6 for 3D).
    fn steps(&self, a: u8) -> &[[i32; 3]] {
        &self.steps[a as usize]
    }

    /// The maximal rectangle grown from block `b` in layer a: along the first in-plane
    /// axis, then the second, over blocks `free` accepts.
    fn grow_rect(&self, b: u32, a: u8, free: &mut dyn FnMut(u32) -> bool) -> Vec<u32> {
        let axes = self.plane_axes(a);
        let (u, v) = (axes[0], axes[1]);
        let start = self.pos(b);
        let at = |du: i32, dv: i32| {
            let mut p = start;
            p[u] += du;
            p[v] += dv;
            p
        };
        let mut w = 1;
        loop {
            let c = self.grid.get(at(w, 0));
            if c == Grid::EMPTY || !free(c) {
                break;
            }
            w += 1;
        }
        let mut h = 1;
        'rows: loop {
            for x in 0..w {
                let c = self.grid.get(at(x, h));
                if c == Grid::EMPTY || !free(c) {
                    break 'rows;
                }
            }
            h += 1;
        }
        let mut out = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                out.push(self.grid.get(at(x, y)));
            }
        }
        out
    }

    /// The connected component of `b` (in-plane for layer a unless 3D) among blocks
    /// `member` accepts and `taken` does not hold.
    fn component(&self, b: u32, a: u8, member: &dyn Fn(u32) -> bool, taken: &[bool]) -> Vec<u32> {
        let steps = self.steps(a);
        let mut seen = std::collections::HashSet::new();
        seen.insert(b);
        let mut stack = vec![b];
        let mut out = Vec::new();
        while let Some(x) = stack.pop() {
            out.push(x);
            let p = self.pos(x);
            for d in steps {
                let c = self.grid.get(super::add(p, *d));
                if c != Grid::EMPTY && !taken[c as usize] && member(c) && seen.insert(c) {
                    stack.push(c);
                }
            }
        }
        out.sort_unstable();
        out
    }

    /// Whether moving to `n` shapes with entropy sum `h` improves on the current set
    /// (compared by [`Cost::key`], so a product too large for a float still compares).
    fn improves(&self, n: usize, h: f64) -> bool {
        let (k_old, k_new) = (self.key_of(self.n_alive, self.entropy_sum), self.key_of(n, h));
        let tol = match self.cost_model {
            // The logarithm of the product: a relative tolerance.
            Cost::Product => 1e-12,
            Cost::Sum | Cost::Kinds => 1e-10 * (1.0 + k_old.abs()),
        };
        k_new < k_old - tol || (k_new <= k_old + tol && n < self.n_alive)
    }

    /// Runs hill climbing until no move improves (or the move cap).
    pub fn run(&mut self, ops: Ops, progress: &mut dyn FnMut(Progress)) {
        loop {
            if self.stats.merges + self.stats.splits >= self.max_moves {
                self.stats.capped = true;
                break;
            }
            if ops != Ops::Split {
                let merged = self.merge_pass();
                self.after_pass(progress);
                if merged > 0 {
                    continue;
                }
            }
            if ops == Ops::Merge {
                break;
            }
            let split = self.split_pass();
            self.after_pass(progress);
            if split == 0 {
                break;
            }
        }
        self.stats.search_shapes = self.n_alive;
        self.stats.cost = self.cost();
    }

    fn after_pass(&mut self, progress: &mut dyn FnMut(Progress)) {
        // Recompute Σ entropy exactly (the incremental sum drifts by rounding).
        self.entropy_sum = self.shapes.iter().filter(|s| s.alive).map(|s| s.entropy).sum();
        self.stats.passes += 1;
        progress(Progress { pass: self.stats.passes, shapes: self.n_alive, cost: self.cost() });
    }

    /// The ids of shapes a merge with `id` would be legal with, in a fixed order.
    fn merge_candidates(&mut self, id: u32) -> Vec<u32> {
        let s = &self.shapes[id as usize];
        let a = s.layer as usize;
        let mut out = Vec::new();
        if self.spec == Spec::Rect {
            let axes = self.plane_axes(s.layer);
            for (u, v) in [(axes[0], axes[1]), (axes[1], axes[0])] {
                for forward in [true, false] {
                    let mut p = s.lo;
                    p[u] = if forward { s.hi[u] + 1 } else { s.lo[u] - 1 };
                    let b = self.grid.get(p);
                    if b == Grid::EMPTY {
                        continue;
                    }
                    let o = self.owner[a][b as usize];
                    let t = &self.shapes[o as usize];
                    let edge_ok = if forward { t.lo[u] == s.hi[u] + 1 } else { t.hi[u] == s.lo[u] - 1 };
                    if edge_ok && t.lo[v] == s.lo[v] && t.hi[v] == s.hi[v] {
                        out.push(o);
                    }
                }
            }
            return out;
        }
        if self.stamp.len() < self.shapes.len() {
            self.stamp.resize(self.shapes.len(), 0);
        }
        self.stamp_gen = self.stamp_gen.wrapping_add(1);
        if self.stamp_gen == 0 {
            self.stamp.iter_mut().for_each(|x| *x = 0);
            self.stamp_gen = 1;
        }
        let s = &self.shapes[id as usize];
        let steps = &self.steps[s.layer as usize];
        self.stamp[id as usize] = self.stamp_gen;
        for &b in &s.blocks {
            let p = self.model.blocks[b as usize].pos;
            for d in steps {
                let c = self.grid.get(super::add(p, *d));
                if c == Grid::EMPTY {
                    continue;
                }
                let o = self.owner[a][c as usize];
                if self.stamp[o as usize] != self.stamp_gen {
                    self.stamp[o as usize] = self.stamp_gen;
                    out.push(o);
                }
            }
        }
        out
    }

    /// The change of Σ entropy if `x` and `y` merged.
    fn merge_delta(&self, x: u32, y: u32) -> f64 {
        let (s, t) = (&self.shapes[x as usize], &self.shapes[y as usize]);
        let (mut i, mut j, mut sclog, mut kinds) = (0, 0, 0.0, 0);
        while i < s.hist.len() || j < t.hist.len() {
            kinds += 1;
            let (ks, kt) = (s.hist.get(i).map(|h| h.0), t.hist.get(j).map(|h| h.0));
            let c = match (ks, kt) {
                (Some(a), Some(b)) if a == b => {
                    let c = s.hist[i].1 + t.hist[j].1;
                    i += 1;
                    j += 1;
                    c
                }
                (Some(a), Some(b)) if a < b => {
                    i += 1;
                    s.hist[i - 1].1
                }
                (Some(_), None) => {
                    i += 1;
                    s.hist[i - 1].1
                }
                _ => {
                    j += 1;
                    t.hist[j - 1].1
                }
            };
            sclog += self.clog[c as usize];
        }
        self.term_of(s.blocks.len() + t.blocks.len(), sclog, kinds) - s.entropy - t.entropy
    }

    /// One pass of merges; returns how many were applied.
    fn merge_pass(&mut self) -> usize {
        let mut touched = vec![false; self.shapes.len()];
        let mut applied = 0;
        for id in 0..self.shapes.len() as u32 {
            if !self.shapes[id as usize].alive || touched[id as usize] {
                continue;
            }
            let mut best: Option<(f64, u32, f64)> = None;
            for o in self.merge_candidates(id) {
                if touched[o as usize] || o == id {
                    continue;
                }
                let dh = self.merge_delta(id, o);
                let h = self.entropy_sum + dh;
                if self.improves(self.n_alive - 1, h) {
                    let c = self.key_of(self.n_alive - 1, h);
                    if best.is_none_or(|(bc, _, _)| c < bc) {
                        best = Some((c, o, dh));
                    }
                }
            }
            if let Some((_, o, dh)) = best {
                let kept = self.merge(id, o, dh);
                touched[id as usize] = true;
                touched[o as usize] = true;
                applied += 1;
                let c = self.cost();
                if let Some(log) = &mut self.log {
                    let removed = if kept == id { o } else { id };
                    log.push(Move::Merge { kept, removed, cost: c });
                }
                if self.stats.merges + self.stats.splits >= self.max_moves {
                    break;
                }
            }
        }
        applied
    }

    /// Merges two shapes (the larger keeps its id); returns the kept id.
    fn merge(&mut self, x: u32, y: u32, dh: f64) -> u32 {
        let (kept, gone) =
            if self.shapes[y as usize].blocks.len() > self.shapes[x as usize].blocks.len() { (y, x) } else { (x, y) };
        let g = std::mem::take(&mut self.shapes[gone as usize]);
        let layer = g.layer as usize;
        for &b in &g.blocks {
            self.owner[layer][b as usize] = kept;
        }
        let mut k = std::mem::take(&mut self.shapes[kept as usize]);
        k.blocks.extend_from_slice(&g.blocks);
        for c in 0..3 {
            k.lo[c] = k.lo[c].min(g.lo[c]);
            k.hi[c] = k.hi[c].max(g.hi[c]);
        }
        let mut hist = Vec::with_capacity(k.hist.len() + g.hist.len());
        let (mut i, mut j) = (0, 0);
        while i < k.hist.len() || j < g.hist.len() {
            match (k.hist.get(i), g.hist.get(j)) {
                (Some(a), Some(b)) if a.0 == b.0 => {
                    hist.push((a.0, a.1 + b.1));
                    i += 1;
                    j += 1;
                }
                (Some(a), Some(b)) if a.0 < b.0 => {
                    hist.push(*a);
                    i += 1;
                }
                (Some(a), None) => {
                    hist.push(*a);
                    i += 1;
                }
                (_, Some(b)) => {
                    hist.push(*b);
                    j += 1;
                }
                (None, None) => break,
            }
        }
        k.sclog = hist.iter().map(|&(_, c)| self.clog[c as usize]).sum();
        k.hist = hist;
        k.entropy = self.term_of(k.blocks.len(), k.sclog, k.hist.len());
        self.shapes[kept as usize] = k;
        self.shapes[gone as usize] = SShape { alive: false, layer: g.layer, ..SShape::default() };
        self.n_alive -= 1;
        self.entropy_sum += dh;
        self.stats.merges += 1;
        kept
    }

    /// One pass of splits; returns how many were applied.
    fn split_pass(&mut self) -> usize {
        let n = self.shapes.len() as u32;
        let mut applied = 0;
        for id in 0..n {
            let s = &self.shapes[id as usize];
            if !s.alive || s.blocks.len() < 2 {
                continue;
            }
            if let Some((axis, at, dh)) = self.best_split(id) {
                let new = self.split(id, axis, at, dh);
                applied += 1;
                let c = self.cost();
                if let Some(log) = &mut self.log {
                    log.push(Move::Split { shape: id, new, axis: axis as Axis, at, cost: c });
                }
                if self.stats.merges + self.stats.splits >= self.max_moves {
                    break;
                }
            }
        }
        applied
    }

    /// The best improving cut of shape `id`: (axis, coordinate, Δ entropy); the part
    /// below the coordinate and the rest must both be valid shapes.
    fn best_split(&self, id: u32) -> Option<(usize, i32, f64)> {
        let s = &self.shapes[id as usize];
        let n = s.blocks.len();
        let mut found: Vec<(f64, usize, i32, f64)> = Vec::new();
        for &d in self.plane_axes(s.layer) {
            let extent = (s.hi[d] - s.lo[d] + 1) as usize;
            if extent < 2 {
                continue;
            }
            // Counting sort of the blocks by slice along d; kinds as histogram slots.
            let mut per_slice = vec![0usize; extent + 1];
            for &b in &s.blocks {
                per_slice[(self.pos(b)[d] - s.lo[d]) as usize + 1] += 1;
            }
            for i in 1..=extent {
                per_slice[i] += per_slice[i - 1];
            }
            let mut order = vec![0u32; n];
            let mut fill = per_slice.clone();
            for &b in &s.blocks {
                let sl = (self.pos(b)[d] - s.lo[d]) as usize;
                order[fill[sl]] = b;
                fill[sl] += 1;
            }
            let total: Vec<u32> = s.hist.iter().map(|h| h.1).collect();
            let mut prefix = vec![0u32; total.len()];
            let (mut sp, mut ss) = (0.0, s.sclog);
            // Kinds below and above the cut.
            let (mut kp, mut ks) = (0usize, total.len());
            for cut in 1..extent {
                for &b in &order[per_slice[cut - 1]..per_slice[cut]] {
                    let k = self.kind(b);
                    let j = s.hist.partition_point(|h| h.0 < k);
                    let (p, t) = (prefix[j] as usize, total[j] as usize);
                    sp += self.clog[p + 1] - self.clog[p];
                    ss += self.clog[t - p - 1] - self.clog[t - p];
                    kp += (p == 0) as usize;
                    ks -= (t - p == 1) as usize;
                    prefix[j] += 1;
                }
                let np = per_slice[cut];
                if np == 0 || np == n {
                    continue;
                }
                let dh = self.term_of(np, sp, kp) + self.term_of(n - np, ss, ks) - s.entropy;
                let h = self.entropy_sum + dh;
                if self.improves(self.n_alive + 1, h) {
                    found.push((self.key_of(self.n_alive + 1, h), d, s.lo[d] + cut as i32, dh));
                }
            }
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
        found
            .into_iter()
            .find(|&(_, d, at, _)| self.spec == Spec::Rect || self.split_is_valid(id, d, at))
            .map(|(_, d, at, dh)| (d, at, dh))
    }

    /// Whether both parts of a cut are connected.
    fn split_is_valid(&self, id: u32, d: usize, at: i32) -> bool {
        let s = &self.shapes[id as usize];
        let layer = s.layer as usize;
        for below in [true, false] {
            let Some(&first) = s.blocks.iter().find(|&&b| (self.pos(b)[d] < at) == below) else { return false };
            let member = |c: u32| self.owner[layer][c as usize] == id && (self.pos(c)[d] < at) == below;
            let count = s.blocks.iter().filter(|&&b| (self.pos(b)[d] < at) == below).count();
            if self.component_count(first, s.layer, &member) != count {
                return false;
            }
        }
        true
    }

    /// The size of the connected component of `b` among blocks `member` accepts.
    fn component_count(&self, b: u32, a: u8, member: &dyn Fn(u32) -> bool) -> usize {
        let steps = self.steps(a);
        let mut seen = std::collections::HashSet::new();
        seen.insert(b);
        let mut stack = vec![b];
        while let Some(x) = stack.pop() {
            let p = self.pos(x);
            for dd in steps {
                let c = self.grid.get(super::add(p, *dd));
                if c != Grid::EMPTY && member(c) && seen.insert(c) {
                    stack.push(c);
                }
            }
        }
        seen.len()
    }

    /// Applies a cut: blocks below `at` along `d` become a new shape; returns its id.
    fn split(&mut self, id: u32, d: usize, at: i32, dh: f64) -> u32 {
        let mut s = std::mem::take(&mut self.shapes[id as usize]);
        let model = self.model;
        let (below, rest): (Vec<u32>, Vec<u32>) = s.blocks.iter().partition(|&&b| model.blocks[b as usize].pos[d] < at);
        s.blocks = rest;
        self.refresh(&mut s);
        let layer = s.layer;
        self.shapes[id as usize] = s;
        let before = self.entropy_sum;
        let new = self.add_shape(layer, below);
        // add_shape added the new part's entropy; account for the whole move instead.
        self.entropy_sum = before + dh;
        self.stats.splits += 1;
        new
    }

    /// The result: every block covered, with or without overlapping shapes (see the
    /// module documentation).
    pub fn result(&self, overlap: bool) -> Vec<InferredShape> {
        let n = self.model.blocks.len();
        // Candidates: distinct block sets, with their plane.
        let mut seen: std::collections::HashMap<Vec<u32>, usize> = std::collections::HashMap::new();
        let mut cands: Vec<InferredShape> = Vec::new();
        for s in self.shapes.iter().filter(|s| s.alive) {
            let mut blocks = s.blocks.clone();
            blocks.sort_unstable();
            if seen.contains_key(&blocks) {
                continue;
            }
            let plane = self.plane_of(&blocks, s.layer);
            seen.insert(blocks.clone(), cands.len());
            cands.push(InferredShape { blocks, plane });
        }
        cands.sort_by(|a, b| b.blocks.len().cmp(&a.blocks.len()).then_with(|| a.blocks.cmp(&b.blocks)));
        let mut count = vec![0u32; n];
        let mut chosen: Vec<InferredShape> = Vec::new();
        if overlap {
            for c in &cands {
                if c.blocks.iter().any(|&b| count[b as usize] == 0) {
                    c.blocks.iter().for_each(|&b| count[b as usize] += 1);
                    chosen.push(c.clone());
                }
            }
            // Remove shapes the others cover entirely, smallest first.
            let mut keep = vec![true; chosen.len()];
            for i in (0..chosen.len()).rev() {
                if chosen[i].blocks.iter().all(|&b| count[b as usize] >= 2) {
                    keep[i] = false;
                    chosen[i].blocks.iter().for_each(|&b| count[b as usize] -= 1);
                }
            }
            let mut k = keep.iter();
            chosen.retain(|_| k.next().copied().unwrap_or(true));
        } else {
            for c in &cands {
                if c.blocks.iter().all(|&b| count[b as usize] == 0) {
                    c.blocks.iter().for_each(|&b| count[b as usize] = 1);
                    chosen.push(c.clone());
                }
            }
            for c in &cands {
                let left: Vec<u32> = c.blocks.iter().copied().filter(|&b| count[b as usize] == 0).collect();
                if left.is_empty() {
                    continue;
                }
                for piece in self.pieces(&left, c.plane) {
                    piece.iter().for_each(|&b| count[b as usize] = 1);
                    chosen.push(InferredShape { blocks: piece, plane: c.plane });
                }
            }
        }
        chosen.sort_by(|a, b| b.blocks.len().cmp(&a.blocks.len()).then_with(|| a.blocks.cmp(&b.blocks)));
        chosen
    }

    /// The reference implementation's post-split: for the planes y (floors), then z and
    /// x (walls), every flat shape of that plane cuts each shape touching it face to face
    /// that has blocks on both sides of its coordinate: the blocks above it and the rest
    /// (the blocks at the coordinate go with the lower part, so no block is doubled)
    /// become shapes, each cut into valid pieces. Splitters are the plane's shapes
    /// before its round; a splitter cut by an earlier one still cuts.
    pub fn post_split(&self, shapes: Vec<InferredShape>) -> Vec<InferredShape> {
        let n = self.model.blocks.len();
        let mut all: Vec<Option<InferredShape>> = shapes.into_iter().map(Some).collect();
        let mut of_block: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, s) in all.iter().enumerate() {
            for &b in s.iter().flat_map(|s| &s.blocks) {
                of_block[b as usize].push(i as u32);
            }
        }
        for axis in [1u8, 2, 0] {
            let a = axis as usize;
            let splitters: Vec<(Vec<u32>, i32)> = all
                .iter()
                .flatten()
                .filter(|s| s.plane == Some(axis))
                .map(|s| (s.blocks.clone(), self.pos(s.blocks[0])[a]))
                .collect();
            for (sb, at) in splitters {
                let mut near: Vec<u32> = Vec::new();
                for &b in &sb {
                    for d in super::voxel::NEIGHBOURS {
                        let c = self.grid.get(super::add(self.pos(b), d));
                        if c != Grid::EMPTY {
                            near.extend_from_slice(&of_block[c as usize]);
                        }
                    }
                }
                near.sort_unstable();
                near.dedup();
                for i in near {
                    let Some(s) = &all[i as usize] else { continue };
                    if s.blocks == sb {
                        continue;
                    }
                    let (top, bottom): (Vec<u32>, Vec<u32>) = s.blocks.iter().partition(|&&b| self.pos(b)[a] > at);
                    if top.is_empty() || !bottom.iter().any(|&b| self.pos(b)[a] < at) {
                        continue;
                    }
                    let plane = s.plane;
                    let old = all[i as usize].take().map(|s| s.blocks).unwrap_or_default();
                    for &b in &old {
                        of_block[b as usize].retain(|&x| x != i);
                    }
                    for part in [top, bottom] {
                        for piece in self.pieces(&part, plane) {
                            let id = all.len() as u32;
                            piece.iter().for_each(|&b| of_block[b as usize].push(id));
                            let plane =
                                if self.spec == Spec::Solid { None } else { self.plane_of(&piece, plane.unwrap_or(0)) };
                            all.push(Some(InferredShape { blocks: piece, plane }));
                        }
                    }
                }
            }
        }
        let mut out: Vec<InferredShape> = all.into_iter().flatten().collect();
        out.sort_by(|a, b| b.blocks.len().cmp(&a.blocks.len()).then_with(|| a.blocks.cmp(&b.blocks)));
        out
    }

    /// The plane of a final shape: its flat axis; for lines and single blocks, the flat
    /// axis with the most empty cells beside the blocks (a wall's row faces the air on
    /// both sides, not its neighbours), preferring the layer it was found in.
    fn plane_of(&self, blocks: &[u32], layer: u8) -> Option<Axis> {
        if self.spec == Spec::Solid {
            return None;
        }
        let first = self.pos(blocks[0]);
        let flat: Vec<u8> =
            (0..3u8).filter(|&k| blocks.iter().all(|&b| self.pos(b)[k as usize] == first[k as usize])).collect();
        if flat.len() == 1 {
            return Some(flat[0]);
        }
        let empty_beside = |k: u8| {
            blocks
                .iter()
                .map(|&b| {
                    let p = self.pos(b);
                    let mut q = p;
                    q[k as usize] += 1;
                    let mut r = p;
                    r[k as usize] -= 1;
                    (self.grid.get(q) == Grid::EMPTY) as usize + (self.grid.get(r) == Grid::EMPTY) as usize
                })
                .sum::<usize>()
        };
        flat.iter().copied().max_by_key(|&k| (empty_beside(k), k == layer, std::cmp::Reverse(k))).or(Some(layer))
    }

    /// Splits a block set (inside one plane unless 3D) into valid shapes: greedy maximal
    /// rectangles, or connected components.
    fn pieces(&self, blocks: &[u32], plane: Option<Axis>) -> Vec<Vec<u32>> {
        let n = self.model.blocks.len();
        let mut inside = vec![false; n];
        blocks.iter().for_each(|&b| inside[b as usize] = true);
        let a = plane.unwrap_or(0);
        let mut taken = vec![false; n];
        let mut out = Vec::new();
        for &b in blocks {
            if taken[b as usize] {
                continue;
            }
            let mut piece = match self.spec {
                Spec::Rect => self.grow_rect(b, a, &mut |x| inside[x as usize] && !taken[x as usize]),
                Spec::Planar | Spec::Solid => self.component(b, a, &|x| inside[x as usize], &taken),
            };
            piece.sort_unstable();
            piece.iter().for_each(|&x| taken[x as usize] = true);
            out.push(piece);
        }
        out
    }
}
