//! Shared style from several examples: **sub-shape matching**.
//!
//! Shapes are inferred per example, so two examples rarely give two equal shapes: a
//! wall with a window in one building is a longer wall with the same window in the
//! other. Matching only whole shapes (paper eqs. 1–2) then links nothing, and the
//! grammar is the examples' grammars side by side. This pass finds, for shapes of
//! different examples, the largest piece they have in common (the same blocks in the
//! same configuration up to a translation and quarter turns, oriented blocks turned
//! with it) and cuts that piece out of both, so the two pieces match and their rules
//! are shared (eq. 6): the bridge between the production spaces the paper describes.
//!
//! * A common piece is a valid shape of the specification: for `rect` the largest
//!   filled rectangle of the common cells, for `2d` and `3d` their largest 6-connected
//!   part (the common cells of two planar shapes lie in one plane).
//! * Only pieces of at least `min_blocks` blocks count. Shapes that already match a
//!   shape of another example are left alone.
//! * Greedy and single-round: candidate pairs are taken largest piece first, and a
//!   shape takes part in at most one cut, so a shape becomes at most its piece plus
//!   the pieces of its remainder (rectangles for `rect`, connected parts otherwise).
//!   The order is fixed (piece size, then example and shape indices, turn, offset), so
//!   the result is deterministic.

use super::infer::{Inference, InferredShape, Spec};
use super::voxel::VoxelModel;
use super::{rotate, sub, Axis};
use std::collections::{HashMap, HashSet};

/// What [`share`] did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ShareStats {
    /// Shape pairs of different examples with a common piece of `min_blocks` or more.
    pub candidates: usize,
    /// Pieces cut out (each makes one shape of each of two examples match).
    pub cuts: usize,
    /// Shapes added by the cuts (pieces and remainders, less the shapes they replace).
    pub added: usize,
    /// Per example: its shapes that were cut.
    pub cut_per_example: Vec<usize>,
}

/// A shape's blocks in one frame: (position, global kind, model block index).
type Cells = Vec<([i32; 3], u32, u32)>;

struct Candidate {
    size: usize,
    a: (usize, usize),
    b: (usize, usize),
    turn: u8,
    offset: [i32; 3],
    /// Model block indices of the piece in a and in b.
    in_a: Vec<u32>,
    in_b: Vec<u32>,
}

/// Cuts the largest common pieces of shapes of different examples out of both (see
/// the module documentation). `models[i]` is the example of `inferences[i]`.
pub fn share(models: &[&VoxelModel], spec: Spec, inferences: &mut [Inference], min_blocks: usize) -> ShareStats {
    let mut stats = ShareStats { cut_per_example: vec![0; inferences.len()], ..ShareStats::default() };
    if models.len() < 2 || models.len() != inferences.len() {
        return stats;
    }
    let min_blocks = min_blocks.max(1);
    // One kind numbering for all examples, so kinds compare across them.
    let mut ids: Vec<&str> = Vec::new();
    let mut global: HashMap<&str, u32> = HashMap::new();
    let kind_maps: Vec<Vec<u32>> = models
        .iter()
        .map(|m| {
            m.kinds
                .iter()
                .map(|k| {
                    *global.entry(k.id.as_str()).or_insert_with(|| {
                        ids.push(k.id.as_str());
                        ids.len() as u32 - 1
                    })
                })
                .collect()
        })
        .collect();
    let turns = super::kind_turns(&ids);
    let cells = |e: usize, s: &InferredShape| -> Cells {
        s.blocks
            .iter()
            .map(|&b| {
                let blk = models[e].blocks[b as usize];
                (blk.pos, kind_maps[e][blk.kind as usize], b)
            })
            .collect()
    };
    // Shapes that already match a shape of another example.
    let mut classes: HashMap<Vec<super::ShapeBlock>, HashSet<usize>> = HashMap::new();
    let mut keys: Vec<Vec<Vec<super::ShapeBlock>>> = Vec::new();
    for (e, inf) in inferences.iter().enumerate() {
        let mut per = Vec::new();
        for s in &inf.shapes {
            let blocks: Vec<super::ShapeBlock> =
                cells(e, s).iter().map(|&(pos, kind, _)| super::ShapeBlock { pos, kind }).collect();
            let key = super::matching::canonical(&blocks, &turns).0;
            classes.entry(key.clone()).or_default().insert(e);
            per.push(key);
        }
        keys.push(per);
    }
    let shared = |e: usize, i: usize| classes.get(&keys[e][i]).is_some_and(|x| x.len() > 1);
    // The best common piece of every pair of shapes of different examples.
    let mut cands: Vec<Candidate> = Vec::new();
    for ea in 0..inferences.len() {
        for eb in ea + 1..inferences.len() {
            for (ia, sa) in inferences[ea].shapes.iter().enumerate() {
                if sa.blocks.len() < min_blocks || shared(ea, ia) {
                    continue;
                }
                let ca = cells(ea, sa);
                let at_a: HashMap<[i32; 3], (u32, u32)> = ca.iter().map(|&(p, k, b)| (p, (k, b))).collect();
                let kinds_a: HashSet<u32> = ca.iter().map(|c| c.1).collect();
                for (ib, sb) in inferences[eb].shapes.iter().enumerate() {
                    if sb.blocks.len() < min_blocks || shared(eb, ib) {
                        continue;
                    }
                    let cb = cells(eb, sb);
                    let mut best: Option<Candidate> = None;
                    for turn in 0..4u8 {
                        let bt: Cells = cb
                            .iter()
                            .map(|&(p, k, b)| (rotate(turn, p), super::turn_kind(&turns, k, turn), b))
                            .collect();
                        if bt.iter().filter(|c| kinds_a.contains(&c.1)).count() < min_blocks {
                            continue;
                        }
                        // Offsets (a − b) that put at least min_blocks equal blocks together.
                        let mut by_kind: HashMap<u32, Vec<[i32; 3]>> = HashMap::new();
                        for &(p, k, _) in &ca {
                            by_kind.entry(k).or_default().push(p);
                        }
                        let mut votes: HashMap<[i32; 3], usize> = HashMap::new();
                        for &(p, k, _) in &bt {
                            for &q in by_kind.get(&k).map(|v| v.as_slice()).unwrap_or(&[]) {
                                *votes.entry(sub(q, p)).or_insert(0) += 1;
                            }
                        }
                        let mut offsets: Vec<([i32; 3], usize)> =
                            votes.into_iter().filter(|&(_, n)| n >= min_blocks).collect();
                        offsets.sort_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(&y.0)));
                        for (offset, n) in offsets {
                            if best.as_ref().is_some_and(|c| c.size >= n) {
                                break;
                            }
                            // The common cells, keyed by position in a's frame.
                            let common: HashMap<[i32; 3], (u32, u32)> = bt
                                .iter()
                                .filter_map(|&(p, k, b)| {
                                    let q = super::add(p, offset);
                                    at_a.get(&q).filter(|(ka, _)| *ka == k).map(|&(_, ba)| (q, (ba, b)))
                                })
                                .collect();
                            let piece = match spec {
                                Spec::Rect => largest_rect(&common, sa.plane),
                                Spec::Planar | Spec::Solid => largest_component(&common),
                            };
                            if piece.len() < min_blocks || best.as_ref().is_some_and(|c| c.size >= piece.len()) {
                                continue;
                            }
                            if piece.len() == ca.len() && piece.len() == cb.len() {
                                continue; // the shapes match already
                            }
                            let mut in_a: Vec<u32> = piece.iter().map(|q| common[q].0).collect();
                            let mut in_b: Vec<u32> = piece.iter().map(|q| common[q].1).collect();
                            in_a.sort_unstable();
                            in_b.sort_unstable();
                            best = Some(Candidate {
                                size: piece.len(),
                                a: (ea, ia),
                                b: (eb, ib),
                                turn,
                                offset,
                                in_a,
                                in_b,
                            });
                        }
                    }
                    if let Some(c) = best {
                        cands.push(c);
                    }
                }
            }
        }
    }
    stats.candidates = cands.len();
    cands.sort_by(|x, y| {
        y.size
            .cmp(&x.size)
            .then(x.a.cmp(&y.a))
            .then(x.b.cmp(&y.b))
            .then(x.turn.cmp(&y.turn))
            .then(x.offset.cmp(&y.offset))
    });
    let mut used: HashSet<(usize, usize)> = HashSet::new();
    // Per example: shape index → its piece (block indices).
    let mut cut: Vec<HashMap<usize, Vec<u32>>> = vec![HashMap::new(); inferences.len()];
    for c in cands {
        if used.contains(&c.a) || used.contains(&c.b) {
            continue;
        }
        used.insert(c.a);
        used.insert(c.b);
        cut[c.a.0].insert(c.a.1, c.in_a);
        cut[c.b.0].insert(c.b.1, c.in_b);
        stats.cut_per_example[c.a.0] += 1;
        stats.cut_per_example[c.b.0] += 1;
        stats.cuts += 1;
    }
    for (e, inf) in inferences.iter_mut().enumerate() {
        if cut[e].is_empty() {
            continue;
        }
        let before = inf.shapes.len();
        let mut out: Vec<InferredShape> = Vec::with_capacity(before + 2 * cut[e].len());
        for (i, s) in inf.shapes.iter().enumerate() {
            let Some(piece) = cut[e].get(&i) else {
                out.push(s.clone());
                continue;
            };
            out.push(InferredShape { blocks: piece.clone(), plane: s.plane });
            let inside: HashSet<u32> = piece.iter().copied().collect();
            let rest: Vec<u32> = s.blocks.iter().copied().filter(|b| !inside.contains(b)).collect();
            let pos = |b: u32| models[e].blocks[b as usize].pos;
            for part in pieces(&rest, &pos, spec, s.plane) {
                out.push(InferredShape { blocks: part, plane: s.plane });
            }
        }
        out.sort_by(|a, b| b.blocks.len().cmp(&a.blocks.len()).then_with(|| a.blocks.cmp(&b.blocks)));
        stats.added += out.len() - before;
        inf.shapes = out;
    }
    stats
}

/// The two in-plane axes of a plane (or of the thinnest axis of a cell set).
fn plane_axes(cells: &HashMap<[i32; 3], (u32, u32)>, plane: Option<Axis>) -> (usize, usize, usize) {
    let flat = plane.map(|a| a as usize).unwrap_or_else(|| {
        (0..3)
            .find(|&k| {
                let mut it = cells.keys().map(|p| p[k]);
                let first = it.next();
                it.all(|c| Some(c) == first)
            })
            .unwrap_or(1)
    });
    let others: Vec<usize> = (0..3).filter(|&k| k != flat).collect();
    (flat, others[0], others[1])
}

/// The largest filled rectangle of `cells` within one plane (ties: the first by its
/// lowest corner), as positions.
fn largest_rect(cells: &HashMap<[i32; 3], (u32, u32)>, plane: Option<Axis>) -> Vec<[i32; 3]> {
    if cells.is_empty() {
        return Vec::new();
    }
    let (flat, u, v) = plane_axes(cells, plane);
    // Group by the flat coordinate (a rectangle lies in one layer).
    let mut layers: Vec<i32> = cells.keys().map(|p| p[flat]).collect();
    layers.sort_unstable();
    layers.dedup();
    let mut best: (usize, Vec<[i32; 3]>) = (0, Vec::new());
    for layer in layers {
        let set: HashSet<(i32, i32)> = cells.keys().filter(|p| p[flat] == layer).map(|p| (p[u], p[v])).collect();
        let mut list: Vec<(i32, i32)> = set.iter().copied().collect();
        list.sort_unstable();
        for &(u0, v0) in &list {
            // Rectangles with lowest corner (u0, v0): widen along u, then extend along v.
            let mut width = 0;
            while set.contains(&(u0 + width, v0)) {
                width += 1;
            }
            let mut w = width;
            let mut h = 0;
            while w > 0 {
                // Row v0 + h: how far it runs (capped by the rows below).
                let mut run = 0;
                while run < w && set.contains(&(u0 + run, v0 + h)) {
                    run += 1;
                }
                if run == 0 {
                    break;
                }
                w = run;
                h += 1;
                let area = (w * h) as usize;
                if area > best.0 {
                    let mut rect = Vec::with_capacity(area);
                    for dv in 0..h {
                        for du in 0..w {
                            let mut p = [layer; 3];
                            p[u] = u0 + du;
                            p[v] = v0 + dv;
                            rect.push(p);
                        }
                    }
                    best = (area, rect);
                }
            }
        }
    }
    best.1
}

/// The largest 6-connected part of `cells` (ties: the one with the smallest position).
fn largest_component(cells: &HashMap<[i32; 3], (u32, u32)>) -> Vec<[i32; 3]> {
    let mut keys: Vec<[i32; 3]> = cells.keys().copied().collect();
    keys.sort_unstable();
    let mut seen: HashSet<[i32; 3]> = HashSet::new();
    let mut best: Vec<[i32; 3]> = Vec::new();
    for &k in &keys {
        if !seen.insert(k) {
            continue;
        }
        let mut part = vec![k];
        let mut stack = vec![k];
        while let Some(p) = stack.pop() {
            for d in super::voxel::NEIGHBOURS {
                let q = super::add(p, d);
                if cells.contains_key(&q) && seen.insert(q) {
                    part.push(q);
                    stack.push(q);
                }
            }
        }
        if part.len() > best.len() {
            best = part;
        }
    }
    best
}

/// Splits a block set into valid shapes of the specification: greedy rectangles in
/// the plane (`rect`) or 6-connected parts.
fn pieces(blocks: &[u32], pos: &dyn Fn(u32) -> [i32; 3], spec: Spec, plane: Option<Axis>) -> Vec<Vec<u32>> {
    let at: HashMap<[i32; 3], u32> = blocks.iter().map(|&b| (pos(b), b)).collect();
    let mut order: Vec<[i32; 3]> = at.keys().copied().collect();
    order.sort_by_key(|p| (p[1], p[2], p[0]));
    let mut taken: HashSet<[i32; 3]> = HashSet::new();
    let mut out = Vec::new();
    let flat = plane.unwrap_or(1) as usize;
    let axes: Vec<usize> = (0..3).filter(|&k| k != flat).collect();
    for p in order {
        if taken.contains(&p) {
            continue;
        }
        let free = |q: &[i32; 3], taken: &HashSet<[i32; 3]>| at.contains_key(q) && !taken.contains(q);
        let mut part: Vec<[i32; 3]> = Vec::new();
        if spec == Spec::Rect {
            let (u, v) = (axes[0], axes[1]);
            let step = |q: [i32; 3], k: usize, n: i32| {
                let mut r = q;
                r[k] += n;
                r
            };
            let mut w = 0;
            while free(&step(p, u, w), &taken) {
                w += 1;
            }
            let mut h = 0;
            while (0..w).all(|du| free(&step(step(p, u, du), v, h), &taken)) {
                h += 1;
            }
            for dv in 0..h {
                for du in 0..w {
                    part.push(step(step(p, u, du), v, dv));
                }
            }
        } else {
            let mut stack = vec![p];
            taken.insert(p);
            part.push(p);
            while let Some(q) = stack.pop() {
                for d in super::voxel::NEIGHBOURS {
                    let r = super::add(q, d);
                    if free(&r, &taken) {
                        taken.insert(r);
                        part.push(r);
                        stack.push(r);
                    }
                }
            }
        }
        part.iter().for_each(|q| {
            taken.insert(*q);
        });
        let mut ids: Vec<u32> = part.iter().map(|q| at[q]).collect();
        ids.sort_unstable();
        out.push(ids);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::infer::{infer, InferOptions, Ops};
    use crate::voxel::ModelBuilder;

    fn cells(v: &[[i32; 3]]) -> HashMap<[i32; 3], (u32, u32)> {
        v.iter().enumerate().map(|(i, &p)| (p, (i as u32, i as u32))).collect()
    }

    #[test]
    fn the_largest_rectangle_of_an_l_and_the_largest_component() {
        // An L in the plane z = 0: a 3×2 block and a tail of 3 along x at y = 2.
        let mut v = Vec::new();
        for x in 0..3 {
            for y in 0..2 {
                v.push([x, y, 0]);
            }
        }
        v.extend([[0, 2, 0], [0, 3, 0], [0, 4, 0], [5, 0, 0]]);
        let r = largest_rect(&cells(&v), Some(2));
        assert_eq!(r.len(), 6);
        assert!(r.iter().all(|p| p[1] < 2 && p[0] < 3));
        let c = largest_component(&cells(&v));
        assert_eq!(c.len(), 9, "the lone block at x = 5 is another part");
    }

    fn model(blocks: &[([i32; 3], &str)]) -> VoxelModel {
        let mut b = ModelBuilder::new();
        for (p, id) in blocks {
            let k = b.kind(id, None).expect("kind");
            b.add(*p, k).expect("block");
        }
        b.finish().expect("model")
    }

    #[test]
    fn a_turned_common_piece_is_cut_out_of_both_solid_shapes() {
        // A 3D step of stone and a log (facing along x) in one building; the same step
        // turned a quarter (the log along z) inside a larger lump in the other.
        let a = model(&[([0, 0, 0], "stone"), ([1, 0, 0], "stone"), ([1, 1, 0], "log[axis=x]"), ([0, 0, 1], "stone")]);
        let turned: Vec<([i32; 3], &str)> =
            [([0, 0, 0], "stone"), ([1, 0, 0], "stone"), ([1, 1, 0], "log[axis=z]"), ([0, 0, 1], "stone")]
                .iter()
                .map(|&(p, id)| {
                    let q = rotate(1, p);
                    ([q[0] + 10, q[1], q[2] + 10], id)
                })
                .chain([([12, 0, 10], "dirt"), ([12, 0, 11], "dirt"), ([12, 1, 11], "dirt")])
                .collect();
        let b = model(&turned);
        let opts = InferOptions { spec: Spec::Solid, alpha: 100.0, ops: Ops::Merge, ..InferOptions::default() };
        let mut infs = vec![infer(&a, &opts, &mut |_| {}), infer(&b, &opts, &mut |_| {})];
        assert_eq!((infs[0].shapes.len(), infs[1].shapes.len()), (1, 1), "one lump each");
        let stats = share(&[&a, &b], Spec::Solid, &mut infs, 4);
        assert_eq!((stats.cuts, stats.cut_per_example.clone()), (1, vec![1, 1]));
        // The first building's lump is the piece itself; the second is the piece and
        // its dirt.
        assert_eq!(infs[0].shapes.len(), 1);
        let sizes: Vec<usize> = infs[1].shapes.iter().map(|s| s.blocks.len()).collect();
        assert_eq!(sizes, [4, 3]);
        // Too large a minimum: nothing is cut.
        let mut again = vec![infer(&a, &opts, &mut |_| {}), infer(&b, &opts, &mut |_| {})];
        assert_eq!(share(&[&a, &b], Spec::Solid, &mut again, 5).cuts, 0);
    }
}
