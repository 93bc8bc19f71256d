//! Piecewise cubic Bézier paths: points, tangents, arc length, and the closest point
//! to a query point.
//!
//! # Closest point (subdivision + Newton, with a stated tolerance)
//!
//! At construction every cubic segment is subdivided (de Casteljau at t = ½) into a
//! binary tree until each leaf piece is *uniformly flat*: its inner control points are
//! within ε of the points ⅓ and ⅔ along its chord. The difference between the piece
//! B(u) and the uniformly parameterised chord L(u) is then a cubic with control points
//! (0, d₁, d₂, 0), |dᵢ| ≤ ε, so |B(u) − L(u)| ≤ ε for every u (convex hull property).
//! ε = [`FLATNESS`] × the diagonal of the path's control-point box.
//!
//! A query descends the trees depth first, nearer child first, and finds the leaf
//! whose chord is nearest to the query point p, skipping every node whose
//! control-point box (which contains its piece) is farther than the best upper bound
//! so far (nearest chord distance + ε). On that leaf it starts at u_c, the parameter of
//! p's projection on the chord, and takes up to [`NEWTON_STEPS`] safeguarded Newton
//! steps on |B(u) − p|², keeping the best point seen. Since every piece lies within
//! [dist(p, chord) − ε, dist(p, chord) + ε] of p and |B(u_c) − p| ≤ dist(p, chord) + ε,
//! the returned distance exceeds the true minimum by at most 2ε (tested against dense
//! sampling); the Newton steps make it exact in practice. Ties keep the first piece
//! found, so results are deterministic.

use glam::DVec3;

/// Leaf flatness ε relative to the diagonal of the path's control-point box.
pub const FLATNESS: f64 = 1e-4;
/// Newton steps at a leaf.
pub const NEWTON_STEPS: usize = 2;
/// Deepest subdivision (a cubic's deviation from its chord shrinks 4× per level, so
/// real curves stop long before; this bounds degenerate input).
pub const MAX_LEVELS: u32 = 24;

/// A point of a path closest to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// The point on the path.
    pub point: DVec3,
    /// Its distance to the query point.
    pub dist: f64,
    /// Segment index and the parameter t ∈ [0, 1] within that segment.
    pub segment: u32,
    pub t: f64,
    /// Arc length from the start of the path to the point.
    pub arc: f64,
    /// The unit tangent there (direction of increasing t).
    pub tangent: DVec3,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Children (`a`, `b`) of an inner node, or (`LEAF`, leaf index).
    a: u32,
    b: u32,
}

const LEAF: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
struct Leaf {
    p: [DVec3; 4],
    /// The chord p[3] − p[0] and its squared length.
    ab: DVec3,
    l2: f64,
    segment: u32,
    /// The piece covers t ∈ [t0, t1] of its segment.
    t0: f64,
    t1: f64,
    /// Arc length at the piece's start, and its chord length.
    s0: f64,
    len: f64,
}

/// A piecewise cubic Bézier path, prepared for closest-point queries.
#[derive(Clone, Debug)]
pub struct Path {
    segments: Vec<[DVec3; 4]>,
    nodes: Vec<Node>,
    /// The root node of each segment's tree.
    roots: Vec<u32>,
    leaves: Vec<Leaf>,
    lo: DVec3,
    hi: DVec3,
    length: f64,
    eps: f64,
}

fn bezier(p: &[DVec3; 4], u: f64) -> DVec3 {
    let v = 1.0 - u;
    p[0] * (v * v * v) + p[1] * (3.0 * v * v * u) + p[2] * (3.0 * v * u * u) + p[3] * (u * u * u)
}

fn derivative(p: &[DVec3; 4], u: f64) -> DVec3 {
    let v = 1.0 - u;
    (p[1] - p[0]) * (3.0 * v * v) + (p[2] - p[1]) * (6.0 * v * u) + (p[3] - p[2]) * (3.0 * u * u)
}

fn second_derivative(p: &[DVec3; 4], u: f64) -> DVec3 {
    (p[2] - p[1] * 2.0 + p[0]) * (6.0 * (1.0 - u)) + (p[3] - p[2] * 2.0 + p[1]) * (6.0 * u)
}

/// de Casteljau split at ½.
fn split(p: &[DVec3; 4]) -> ([DVec3; 4], [DVec3; 4]) {
    let ab = (p[0] + p[1]) * 0.5;
    let bc = (p[1] + p[2]) * 0.5;
    let cd = (p[2] + p[3]) * 0.5;
    let abc = (ab + bc) * 0.5;
    let bcd = (bc + cd) * 0.5;
    let m = (abc + bcd) * 0.5;
    ([p[0], ab, abc, m], [m, bcd, cd, p[3]])
}

/// Largest distance of the inner control points from the points ⅓ and ⅔ along the chord.
fn uniform_flatness(p: &[DVec3; 4]) -> f64 {
    let a = p[1] - (p[0] * 2.0 + p[3]) / 3.0;
    let b = p[2] - (p[0] + p[3] * 2.0) / 3.0;
    a.length().max(b.length())
}

fn bounds(p: &[DVec3; 4]) -> (DVec3, DVec3) {
    (p[0].min(p[1]).min(p[2]).min(p[3]), p[0].max(p[1]).max(p[2]).max(p[3]))
}

/// The parameter of `p`'s projection on the segment from `a` along `ab` (clamped;
/// `l2` = |ab|²) and its distance.
fn chord_projection(p: DVec3, a: DVec3, ab: DVec3, l2: f64) -> (f64, f64) {
    let t = if l2 > 0.0 { ((p - a).dot(ab) / l2).clamp(0.0, 1.0) } else { 0.0 };
    (t, (a + ab * t - p).length())
}

/// Squared distance from `p` to the box [lo, hi] (0 inside).
fn box_dist2(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let d = (lo - p).max(DVec3::ZERO).max(p - hi);
    d.length_squared()
}

impl Path {
    /// Prepares the path through `points` (3k + 1 control points, k ≥ 1; validated by
    /// [`super::Guide::validate`]). Returns `None` for fewer than 4 points.
    pub fn new(points: &[[f64; 3]]) -> Option<Path> {
        if points.len() < 4 {
            return None;
        }
        let pts: Vec<DVec3> = points.iter().map(|p| DVec3::from_array(*p)).collect();
        let segments: Vec<[DVec3; 4]> =
            (0..(pts.len() - 1) / 3).map(|i| [pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], pts[3 * i + 3]]).collect();
        let lo = pts.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
        let hi = pts.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
        let eps = ((hi - lo).length() * FLATNESS).max(1e-12);
        let mut path = Path {
            segments: Vec::new(),
            nodes: Vec::new(),
            roots: Vec::new(),
            leaves: Vec::new(),
            lo,
            hi,
            length: 0.0,
            eps,
        };
        for (i, seg) in segments.iter().enumerate() {
            let root = path.build(seg, i as u32, 0.0, 1.0, 0);
            path.roots.push(root);
        }
        path.segments = segments;
        let mut s = 0.0;
        for l in &mut path.leaves {
            l.s0 = s;
            l.len = (l.p[3] - l.p[0]).length();
            s += l.len;
        }
        path.length = s;
        Some(path)
    }

    fn build(&mut self, p: &[DVec3; 4], segment: u32, t0: f64, t1: f64, level: u32) -> u32 {
        let (lo, hi) = bounds(p);
        let id = self.nodes.len() as u32;
        // A flatness that is not a number (coordinates near f64::MAX overflow) counts
        // as flat: subdividing such a curve to MAX_LEVELS made 2^24 leaves a segment.
        let flatness = uniform_flatness(p);
        if level >= MAX_LEVELS || flatness.is_nan() || flatness <= self.eps {
            self.nodes.push(Node { lo, hi, a: LEAF, b: self.leaves.len() as u32 });
            self.leaves.push(Leaf {
                p: *p,
                ab: p[3] - p[0],
                l2: (p[3] - p[0]).length_squared(),
                segment,
                t0,
                t1,
                s0: 0.0,
                len: 0.0,
            });
            return id;
        }
        self.nodes.push(Node { lo, hi, a: 0, b: 0 });
        let (l, r) = split(p);
        let tm = 0.5 * (t0 + t1);
        let a = self.build(&l, segment, t0, tm, level + 1);
        let b = self.build(&r, segment, tm, t1, level + 1);
        self.nodes[id as usize].a = a;
        self.nodes[id as usize].b = b;
        id
    }

    /// The arc length of the whole path (sum of the leaf chords; each is within 2ε of
    /// its piece's length).
    pub fn length(&self) -> f64 {
        self.length
    }

    /// Number of cubic segments.
    pub fn n_segments(&self) -> usize {
        self.segments.len()
    }

    /// Number of leaf pieces (for tests and statistics).
    pub fn n_pieces(&self) -> usize {
        self.leaves.len()
    }

    /// The flatness ε of the leaves: the closest-point tolerance is 2ε.
    pub fn tolerance(&self) -> f64 {
        2.0 * self.eps
    }

    /// The point at parameter `t` of segment `segment` (clamped).
    pub fn point(&self, segment: usize, t: f64) -> DVec3 {
        let s = &self.segments[segment.min(self.segments.len() - 1)];
        bezier(s, t.clamp(0.0, 1.0))
    }

    /// The unit tangent at parameter `t` of segment `segment`, robust where the
    /// derivative vanishes (coincident control points): then the direction the curve
    /// leaves the point in (from the second derivative), else the chord, else +z.
    pub fn tangent(&self, segment: usize, t: f64) -> DVec3 {
        let s = &self.segments[segment.min(self.segments.len() - 1)];
        let t = t.clamp(0.0, 1.0);
        let scale = (self.hi - self.lo).length().max(1e-300);
        let d = derivative(s, t);
        if d.length() > 1e-9 * scale {
            return d.normalize();
        }
        // B'(t) = 0: the curve leaves the point along ±B''(t) (sign: towards larger t).
        let dd = second_derivative(s, t);
        if dd.length() > 1e-9 * scale {
            // Near t = 0, B'(t) ≈ t·B''(0); near t = 1, B'(t) ≈ −(1 − t)·B''(1).
            let sign = if t < 0.5 { 1.0 } else { -1.0 };
            return dd.normalize() * sign;
        }
        let chord = s[3] - s[0];
        if chord.length() > 1e-12 * scale {
            return chord.normalize();
        }
        DVec3::Z
    }

    /// Points along the path, `per_segment` intervals per segment (for drawing it).
    pub fn polyline(&self, per_segment: usize) -> Vec<DVec3> {
        let n = per_segment.max(1);
        let mut out = vec![self.segments[0][0]];
        for s in &self.segments {
            for k in 1..=n {
                out.push(bezier(s, k as f64 / n as f64));
            }
        }
        out
    }

    /// A lower bound of the distance from `p` to any point of the path.
    pub fn lower_bound(&self, p: DVec3) -> f64 {
        box_dist2(p, self.lo, self.hi).sqrt()
    }

    /// The closest point of the path to `p` (within [`Path::tolerance`]).
    pub fn closest(&self, p: DVec3) -> Closest {
        match self.closest_within(p, f64::INFINITY) {
            Some(c) => c,
            // Unreachable for finite input (any leaf beats ∞); keep a valid answer.
            None => self.at_leaf(0, 0.0, p),
        }
    }

    /// The closest point of the path to `p` if it is nearer than `bound`, else `None`.
    pub fn closest_within(&self, p: DVec3, bound: f64) -> Option<Closest> {
        // Each leaf piece is within ε of its chord, so a chord at distance dc bounds the
        // piece's distance to [dc − ε, dc + ε]. Find the leaf with the nearest chord,
        // pruning nodes whose box is no nearer than the best upper bound dc + ε, then
        // refine on that leaf only.
        let eps = self.eps;
        let mut best_ub = if bound.is_finite() { bound + eps } else { f64::INFINITY };
        let mut best: Option<(u32, f64)> = None;
        // Entries carry their box's squared distance, computed once when pushed.
        let mut stack: [(u32, f64); 2 * MAX_LEVELS as usize + 8] = [(0, 0.0); 2 * MAX_LEVELS as usize + 8];
        for &root in &self.roots {
            let r = &self.nodes[root as usize];
            stack[0] = (root, box_dist2(p, r.lo, r.hi));
            let mut sp = 1usize;
            while sp > 0 {
                sp -= 1;
                let (id, d2) = stack[sp];
                if d2 >= best_ub * best_ub {
                    continue;
                }
                let n = &self.nodes[id as usize];
                if n.a == LEAF {
                    let l = &self.leaves[n.b as usize];
                    let (u, dc) = chord_projection(p, l.p[0], l.ab, l.l2);
                    if dc + eps < best_ub {
                        best_ub = dc + eps;
                        best = Some((n.b, u));
                    }
                    continue;
                }
                let (ca, cb) = (&self.nodes[n.a as usize], &self.nodes[n.b as usize]);
                let (da, db) = (box_dist2(p, ca.lo, ca.hi), box_dist2(p, cb.lo, cb.hi));
                // Push the farther child first so the nearer one is searched first.
                let (first, second) = if da <= db { ((n.a, da), (n.b, db)) } else { ((n.b, db), (n.a, da)) };
                if sp + 2 <= stack.len() {
                    stack[sp] = second;
                    stack[sp + 1] = first;
                    sp += 2;
                }
            }
        }
        let (leaf, u0) = best?;
        let (leaf, u, d2) = self.refine(leaf, u0, p);
        if bound.is_finite() && d2 >= bound * bound {
            return None;
        }
        Some(self.at_leaf(leaf, u, p))
    }

    /// Newton refinement from parameter `u0` of leaf `leaf`, following the minimum into
    /// the neighbouring piece when it ends at a piece's end: (leaf, u, squared distance).
    fn refine(&self, mut leaf: u32, u0: f64, p: DVec3) -> (u32, f64, f64) {
        let (mut u, mut d2) = self.leaf_search(leaf, u0, p);
        for _ in 0..4 {
            let next = if u == 0.0 && leaf > 0 {
                Some((leaf - 1, 1.0))
            } else if u == 1.0 && (leaf as usize) + 1 < self.leaves.len() {
                Some((leaf + 1, 0.0))
            } else {
                None
            };
            let Some((nl, nu)) = next else { break };
            let (a, b) = (&self.leaves[leaf as usize], &self.leaves[nl as usize]);
            // Only across a shared end point (pieces of one path are contiguous).
            let joined = if nl < leaf { b.p[3] == a.p[0] } else { a.p[3] == b.p[0] };
            if !joined {
                break;
            }
            let (cu, cd2) = self.leaf_search(nl, nu, p);
            if cd2 < d2 {
                (leaf, u, d2) = (nl, cu, cd2);
            } else {
                break;
            }
        }
        (leaf, u, d2)
    }

    /// Safeguarded Newton steps on leaf `i` from parameter `u0`: the best parameter
    /// for `p` and its squared distance.
    fn leaf_search(&self, i: u32, u0: f64, p: DVec3) -> (f64, f64) {
        let l = &self.leaves[i as usize];
        let mut u = u0;
        let mut best_u = u;
        let mut best_d2 = (bezier(&l.p, u) - p).length_squared();
        for _ in 0..NEWTON_STEPS {
            let b = bezier(&l.p, u) - p;
            let d1 = derivative(&l.p, u);
            let d2 = second_derivative(&l.p, u);
            let g = b.dot(d1);
            let h = d1.length_squared() + b.dot(d2);
            if g == 0.0 || h <= 0.0 {
                break;
            }
            let next = (u - g / h).clamp(0.0, 1.0);
            if next == u {
                break;
            }
            u = next;
            let d = (bezier(&l.p, u) - p).length_squared();
            if d < best_d2 {
                best_d2 = d;
                best_u = u;
            } else {
                break;
            }
        }
        (best_u, best_d2)
    }

    fn at_leaf(&self, leaf: u32, u: f64, p: DVec3) -> Closest {
        let l = &self.leaves[leaf as usize];
        let point = bezier(&l.p, u);
        let t = l.t0 + u * (l.t1 - l.t0);
        Closest {
            point,
            dist: (point - p).length(),
            segment: l.segment,
            t,
            arc: l.s0 + u * l.len,
            tangent: self.tangent(l.segment as usize, t),
        }
    }
}

/// Several paths with one bounding-volume tree over all their pieces, for the
/// closest point on any of them (paper eq. 1) in one descent.
///
/// A uniform grid over the paths' surroundings caches, per cell, the pieces that can
/// be nearest to a point in the cell (built on first use, so only the cells a search
/// visits cost anything); points outside the grid descend the tree. Both give the same
/// answer: the piece whose chord is nearest (+ ε), ties to the first (path, piece).
#[derive(Debug)]
pub struct PathSet {
    paths: Vec<Path>,
    /// Tree over (path, leaf) items: inner nodes as in [`Path`]; a leaf node has
    /// `a == LEAF` and `b` indexing `items`.
    nodes: Vec<Node>,
    items: Vec<(u32, u32)>,
    grid: Grid,
}

/// Cells per axis at most (the grid covers the paths' box padded by half its size).
const GRID_CELLS: f64 = 64.0;

#[derive(Debug)]
struct Grid {
    lo: DVec3,
    cell: f64,
    n: [usize; 3],
    /// Candidate pieces per cell, nearest bound first; built on first use.
    cells: Vec<std::sync::OnceLock<Box<[Cand]>>>,
}

/// A piece (path, piece index) and a parameter on its chord.
type Pick = ((u32, u32), f64);

/// A candidate piece with its chord inline (the same numbers as its [`Leaf`], so the
/// grid and the tree compute identical distances).
#[derive(Clone, Copy, Debug)]
struct Cand {
    a: DVec3,
    ab: DVec3,
    l2: f64,
    eps: f64,
    it: (u32, u32),
    /// A lower bound of dc + ε anywhere in the cell (candidates are sorted by it).
    lb: f64,
}

impl Grid {
    fn empty() -> Grid {
        Grid { lo: DVec3::ZERO, cell: 1.0, n: [0; 3], cells: Vec::new() }
    }

    /// The cell holding `p`, if inside the grid.
    fn cell_of(&self, p: DVec3) -> Option<usize> {
        let q = (p - self.lo) / self.cell;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return None;
        }
        let (i, j, k) = (q.x as usize, q.y as usize, q.z as usize);
        if i >= self.n[0] || j >= self.n[1] || k >= self.n[2] {
            return None;
        }
        Some((k * self.n[1] + j) * self.n[0] + i)
    }

    fn cell_box(&self, c: usize) -> (DVec3, DVec3) {
        let i = c % self.n[0];
        let j = (c / self.n[0]) % self.n[1];
        let k = c / (self.n[0] * self.n[1]);
        let lo = self.lo + DVec3::new(i as f64, j as f64, k as f64) * self.cell;
        (lo, lo + DVec3::splat(self.cell))
    }
}

impl Clone for PathSet {
    fn clone(&self) -> PathSet {
        PathSet::new(self.paths.clone())
    }
}

impl PathSet {
    /// Builds the tree (median splits along the longest axis of the pieces' centres).
    pub fn new(paths: Vec<Path>) -> PathSet {
        let mut items: Vec<(u32, u32)> = Vec::new();
        for (i, path) in paths.iter().enumerate() {
            items.extend((0..path.leaves.len() as u32).map(|l| (i as u32, l)));
        }
        let mut set = PathSet { paths, nodes: Vec::new(), items: Vec::new(), grid: Grid::empty() };
        if !items.is_empty() {
            set.build(&mut items, 0);
            let root = set.nodes[0];
            let size = root.hi - root.lo;
            let pad = size.max_element().max(1e-9) * 0.5;
            let lo = root.lo - DVec3::splat(pad);
            let ext = size + DVec3::splat(2.0 * pad);
            let cell = ext.max_element() / GRID_CELLS;
            let n = [0, 1, 2].map(|a| ((ext[a] / cell).ceil() as usize).clamp(1, GRID_CELLS as usize + 1));
            let cells = (0..n[0] * n[1] * n[2]).map(|_| std::sync::OnceLock::new()).collect();
            set.grid = Grid { lo, cell, n, cells };
        }
        set.items = items;
        set
    }

    /// The pieces that can hold the nearest chord (+ ε) for a point in cell `c`: those
    /// whose box, widened by ε, comes within U of the cell, where U bounds the best
    /// (chord distance + ε) anywhere in the cell (its value at the centre plus half
    /// the cell's diagonal).
    fn candidates(&self, c: usize) -> Box<[Cand]> {
        let (lo, hi) = self.grid.cell_box(c);
        let centre = (lo + hi) * 0.5;
        let Some((_, ub)) = self.nearest_chord(centre) else { return Box::new([]) };
        let u = ub + (hi - lo).length() * 0.5;
        // Slack for rounding in the bounds (far below any ε).
        let u = u + 1e-12 * (1.0 + u);
        let mut out: Vec<(f64, (u32, u32))> = Vec::new();
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let n = &self.nodes[id as usize];
            let d = (n.lo - hi).max(lo - n.hi).max(DVec3::ZERO).length();
            if n.a == LEAF {
                let it = self.items[n.b as usize];
                let lb = d + self.paths[it.0 as usize].eps;
                if lb <= u {
                    out.push((lb, it));
                }
            } else if d <= u {
                stack.push(n.a);
                stack.push(n.b);
            }
        }
        out.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        out.into_iter()
            .map(|(lb, it)| {
                let path = &self.paths[it.0 as usize];
                let l = &path.leaves[it.1 as usize];
                Cand { a: l.p[0], ab: l.ab, l2: l.l2, eps: path.eps, it, lb }
            })
            .collect()
    }

    /// The piece with the nearest chord (+ its path's ε) to `p`, ties to the first
    /// (path, piece): the piece and its chord parameter, and that bound.
    fn nearest_chord(&self, p: DVec3) -> Option<(Pick, f64)> {
        let root = self.nodes.first()?;
        let mut best_ub = f64::INFINITY;
        let mut best: Option<((u32, u32), f64)> = None;
        let mut stack: [(u32, f64); 96] = [(0, 0.0); 96];
        stack[0] = (0, box_dist2(p, root.lo, root.hi));
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let (id, d2) = stack[sp];
            if d2 > best_ub * best_ub {
                continue;
            }
            let n = &self.nodes[id as usize];
            if n.a == LEAF {
                let it = self.items[n.b as usize];
                self.consider(it, p, &mut best, &mut best_ub);
                continue;
            }
            let (ca, cb) = (&self.nodes[n.a as usize], &self.nodes[n.b as usize]);
            let (da, db) = (box_dist2(p, ca.lo, ca.hi), box_dist2(p, cb.lo, cb.hi));
            let (first, second) = if da <= db { ((n.a, da), (n.b, db)) } else { ((n.b, db), (n.a, da)) };
            if sp + 2 <= stack.len() {
                stack[sp] = second;
                stack[sp + 1] = first;
                sp += 2;
            }
        }
        best.map(|b| (b, best_ub))
    }

    /// Keeps piece `it` if its chord (+ ε) is nearer than the best so far, or as near
    /// and earlier in (path, piece) order.
    #[inline]
    fn consider(&self, it: (u32, u32), p: DVec3, best: &mut Option<((u32, u32), f64)>, best_ub: &mut f64) {
        let path = &self.paths[it.0 as usize];
        let l = &path.leaves[it.1 as usize];
        consider(it, chord_projection(p, l.p[0], l.ab, l.l2), path.eps, best, best_ub);
    }
}

/// Keeps piece `it` (chord parameter and distance `(u, dc)`) if dc + `eps` is below
/// the best so far, or equal and earlier in (path, piece) order.
#[inline]
fn consider(it: (u32, u32), (u, dc): (f64, f64), eps: f64, best: &mut Option<((u32, u32), f64)>, best_ub: &mut f64) {
    {
        let ub = dc + eps;
        let better = match best {
            None => true,
            Some((b, _)) => ub < *best_ub || (ub == *best_ub && it < *b),
        };
        if better {
            *best_ub = ub;
            *best = Some((it, u));
        }
    }
}

impl PathSet {
    fn piece(&self, item: (u32, u32)) -> &Leaf {
        &self.paths[item.0 as usize].leaves[item.1 as usize]
    }

    /// Builds the node for `items[..]` (which start at `offset` in the final order) and
    /// returns its index.
    fn build(&mut self, items: &mut [(u32, u32)], offset: usize) -> u32 {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &it in items.iter() {
            let (a, b) = bounds(&self.piece(it).p);
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let id = self.nodes.len() as u32;
        if items.len() == 1 {
            self.nodes.push(Node { lo, hi, a: LEAF, b: offset as u32 });
            return id;
        }
        self.nodes.push(Node { lo, hi, a: 0, b: 0 });
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let centre = |set: &PathSet, it: (u32, u32)| {
            let l = set.piece(it);
            ((l.p[0] + l.p[3]) * 0.5)[axis]
        };
        // Stable order: by centre, then by (path, piece) so equal centres stay deterministic.
        let mut keyed: Vec<(f64, (u32, u32))> = items.iter().map(|&it| (centre(self, it), it)).collect();
        keyed.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        for (slot, (_, it)) in items.iter_mut().zip(keyed) {
            *slot = it;
        }
        let mid = items.len() / 2;
        let (left, right) = items.split_at_mut(mid);
        let a = self.build(left, offset);
        let b = self.build(right, offset + mid);
        self.nodes[id as usize].a = a;
        self.nodes[id as usize].b = b;
        id
    }

    /// The paths.
    pub fn paths(&self) -> &[Path] {
        &self.paths
    }

    /// The path nearest to `p` and its closest point (`None` without paths). The
    /// nearest piece is chosen by its chord (each piece lies within its path's ε of
    /// its chord), so the distance is within the largest path tolerance of the true
    /// minimum over all paths; among equally near chords the path listed first wins.
    pub fn nearest(&self, p: DVec3) -> Option<(usize, Closest)> {
        let found = match self.grid.cell_of(p) {
            Some(c) => {
                let cands = self.grid.cells[c].get_or_init(|| self.candidates(c));
                let mut best = None;
                let mut best_ub = f64::INFINITY;
                for c in cands.iter() {
                    // Sorted by lower bound: the rest cannot be nearer, nor tie.
                    if c.lb > best_ub {
                        break;
                    }
                    consider(c.it, chord_projection(p, c.a, c.ab, c.l2), c.eps, &mut best, &mut best_ub);
                }
                best
            }
            None => self.nearest_chord(p).map(|b| b.0),
        };
        let ((path, leaf), u0) = found?;
        let pth = &self.paths[path as usize];
        let (leaf, u, _) = pth.refine(leaf, u0, p);
        Some((path as usize, pth.at_leaf(leaf, u, p)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_near_f64_max_make_a_small_path() {
        // The flatness of such a curve overflows to NaN; it used to subdivide to
        // MAX_LEVELS (2^24 leaves a segment, 5.6 GB). The validator refuses these
        // points; the path must still not blow up.
        let m = 1e308;
        let p = Path::new(&[[0.0, 0.0, 0.0], [m, 0.0, 0.0], [0.0, m, 0.0], [-m, 0.0, m]]).expect("path");
        assert!(p.leaves.len() <= 64, "{} leaves", p.leaves.len());
    }

    fn s_curve() -> Path {
        Path::new(&[
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.5, 2.0],
            [1.0, 1.0, 3.0],
            [-1.0, 0.0, 3.5],
            [-0.5, -0.5, 4.0],
        ])
        .expect("path")
    }

    /// Brute force: 200,000 samples per segment.
    fn dense(path: &Path, p: DVec3) -> f64 {
        let mut best = f64::INFINITY;
        for s in 0..path.n_segments() {
            for k in 0..=200_000 {
                best = best.min((path.point(s, k as f64 / 200_000.0) - p).length());
            }
        }
        best
    }

    #[test]
    fn straight_line_closest_point_is_the_projection() {
        // Control points evenly spaced on the z axis: B(t) = (0, 0, 3t).
        let path = Path::new(&[[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 2.0], [0.0, 0.0, 3.0]]).expect("path");
        let c = path.closest(DVec3::new(2.0, 0.0, 1.5));
        assert!((c.dist - 2.0).abs() < 1e-12, "{c:?}");
        assert!((c.t - 0.5).abs() < 1e-12);
        assert!((c.arc - 1.5).abs() < 1e-9);
        assert!((c.tangent - DVec3::Z).length() < 1e-12);
        // Beyond the end: the end point.
        let e = path.closest(DVec3::new(0.0, 1.0, 5.0));
        assert!((e.point - DVec3::new(0.0, 0.0, 3.0)).length() < 1e-12);
        assert!((path.length() - 3.0).abs() < 1e-9);
    }

    #[test]
    fn closest_point_matches_dense_sampling_within_the_tolerance() {
        let path = s_curve();
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..60 {
            let p = DVec3::new(next() * 4.0 - 2.0, next() * 4.0 - 2.0, next() * 6.0 - 1.0);
            let c = path.closest(p);
            let want = dense(&path, p);
            // Never (meaningfully) below the true minimum, never above it by more than the tolerance.
            assert!(c.dist >= want - 1e-6, "{p:?}: {} < {want}", c.dist);
            assert!(c.dist <= want + path.tolerance(), "{p:?}: {} vs {want}", c.dist);
            assert!(((c.point - p).length() - c.dist).abs() < 1e-12);
            assert!((c.tangent.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn point_equidistant_from_two_arcs_finds_one_of_them() {
        // A U-shaped curve; the query point is on its axis of symmetry.
        let path = Path::new(&[[-1.0, 0.0, 2.0], [-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 2.0]]).expect("path");
        let p = DVec3::new(0.0, 0.0, 1.5);
        let c = path.closest(p);
        assert!(c.dist <= dense(&path, p) + path.tolerance());
    }

    #[test]
    fn degenerate_tangents_are_unit_vectors() {
        // Coincident first control points: B'(0) = 0.
        let path = Path::new(&[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 1.0], [2.0, 0.0, 2.0]]).expect("path");
        let t = path.tangent(0, 0.0);
        assert!((t.length() - 1.0).abs() < 1e-12);
        assert!(t.dot(DVec3::new(1.0, 0.0, 1.0).normalize()) > 0.9, "{t:?}");
        // All points equal: a single leaf, tangent +z, closest point that point.
        let dot = Path::new(&[[1.0, 1.0, 1.0]; 4]).expect("path");
        assert_eq!(dot.n_pieces(), 1);
        assert_eq!(dot.tangent(0, 0.3), DVec3::Z);
        assert!((dot.closest(DVec3::ZERO).dist - 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn path_set_finds_the_nearest_path() {
        let a = s_curve();
        let b = Path::new(&[[3.0, 0.0, 0.0], [3.0, 1.0, 1.0], [2.5, 0.0, 2.0], [3.0, 0.0, 3.0]]).expect("path");
        let set = PathSet::new(vec![a.clone(), b.clone()]);
        let mut seed = 99u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let p = DVec3::new(next() * 6.0 - 1.5, next() * 3.0 - 1.5, next() * 5.0 - 0.5);
            let (ca, cb) = (a.closest(p), b.closest(p));
            let (i, c) = set.nearest(p).expect("nearest");
            let want = ca.dist.min(cb.dist);
            assert!((c.dist - want).abs() <= a.tolerance().max(b.tolerance()), "{p:?}");
            // When the two paths are clearly apart, the nearer one is chosen.
            if (ca.dist - cb.dist).abs() > 0.01 {
                assert_eq!(i, if ca.dist < cb.dist { 0 } else { 1 }, "{p:?}");
            }
        }
        // The grid's candidate lists give exactly the tree's answer.
        for _ in 0..2000 {
            let p = DVec3::new(next() * 8.0 - 2.5, next() * 4.0 - 2.0, next() * 7.0 - 1.5);
            let via_tree = set.nearest_chord(p).map(|b| b.0);
            let via_grid = set.grid.cell_of(p).map(|c| {
                let mut best = None;
                let mut ub = f64::INFINITY;
                for c in set.candidates(c).iter() {
                    if c.lb > ub {
                        break;
                    }
                    consider(c.it, chord_projection(p, c.a, c.ab, c.l2), c.eps, &mut best, &mut ub);
                }
                best
            });
            if let Some(g) = via_grid {
                assert_eq!(g, via_tree, "{p:?}");
            }
        }
        // Identical paths: the first one.
        let twice = PathSet::new(vec![b.clone(), b]);
        assert_eq!(twice.nearest(DVec3::new(0.0, 0.0, 1.0)).expect("nearest").0, 0);
        assert!(PathSet::new(Vec::new()).nearest(DVec3::ZERO).is_none());
    }

    #[test]
    fn closest_within_a_bound() {
        let path = s_curve();
        let p = DVec3::new(5.0, 5.0, 5.0);
        let c = path.closest(p);
        assert!(path.closest_within(p, c.dist * 0.99).is_none());
        assert_eq!(path.closest_within(p, c.dist * 1.01), Some(c));
        assert!(path.lower_bound(p) <= c.dist);
    }
}
