//! Matching shapes (paper eqs. 1–2): two shapes match when the same blocks stand in the
//! same configuration up to an integer translation and quarter turns about the
//! vertical axis. Each shape gets a canonical form (the smallest of its four turns,
//! moved to the origin); shapes match exactly when their canonical forms are equal.

use super::{rotate, sort_blocks, Placement, ShapeBlock};
use std::collections::HashMap;

/// The canonical form of a block set and the placement taking the blocks to it (a
/// turn, then the translation to the origin). Among equal turned forms the smallest
/// turn is chosen, so the result is deterministic for symmetric shapes.
pub fn canonical(blocks: &[ShapeBlock], turns: &[[u32; 4]]) -> (Vec<ShapeBlock>, Placement) {
    let mut best: Option<(Vec<ShapeBlock>, Placement)> = None;
    for turn in 0..4u8 {
        let mut lo = [i32::MAX; 3];
        for b in blocks {
            let p = rotate(turn, b.pos);
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
            }
        }
        let place = Placement { turn, offset: [-lo[0], -lo[1], -lo[2]] };
        let mut v: Vec<ShapeBlock> = blocks
            .iter()
            .map(|b| ShapeBlock { pos: place.apply(b.pos), kind: super::turn_kind(turns, b.kind, turn) })
            .collect();
        sort_blocks(&mut v);
        if best.as_ref().is_none_or(|(bv, _)| v < *bv) {
            best = Some((v, place));
        }
    }
    best.unwrap_or_default()
}

/// Matching classes of a list of block sets.
#[derive(Clone, Debug, Default)]
pub struct Classes {
    /// Class index per shape (classes numbered by first member).
    pub class: Vec<u32>,
    /// Per shape: the placement taking its blocks onto its class representative's
    /// blocks (the first member; the identity for it).
    pub to_rep: Vec<Placement>,
    /// The representative (first member) of each class.
    pub rep: Vec<u32>,
    /// Members per class.
    pub size: Vec<u32>,
}

impl Classes {
    /// Groups `shapes` (block sets in any frame) into matching classes; kinds turn with
    /// the shape by `turns` (see [`super::kind_turns`]; empty: kinds do not turn).
    pub fn of(shapes: &[Vec<ShapeBlock>], turns: &[[u32; 4]]) -> Classes {
        let mut by_key: HashMap<Vec<ShapeBlock>, u32> = HashMap::new();
        let mut c = Classes::default();
        let mut to_canon: Vec<Placement> = Vec::with_capacity(shapes.len());
        for (i, s) in shapes.iter().enumerate() {
            let (key, place) = canonical(s, turns);
            to_canon.push(place);
            let next = c.rep.len() as u32;
            let class = *by_key.entry(key).or_insert(next);
            if class == next {
                c.rep.push(i as u32);
                c.size.push(0);
            }
            c.size[class as usize] += 1;
            c.class.push(class);
        }
        for (i, &class) in c.class.iter().enumerate() {
            let rep = c.rep[class as usize] as usize;
            c.to_rep.push(to_canon[rep].inverse().compose(&to_canon[i]));
        }
        c
    }

    /// Whether shape `i` matches another shape.
    pub fn has_match(&self, i: usize) -> bool {
        self.size[self.class[i] as usize] > 1
    }

    /// The percentage of shapes that match at least one other shape.
    pub fn matching_percent(&self) -> f64 {
        if self.class.is_empty() {
            return 0.0;
        }
        100.0 * (0..self.class.len()).filter(|&i| self.has_match(i)).count() as f64 / self.class.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blocks(v: &[([i32; 3], u32)]) -> Vec<ShapeBlock> {
        v.iter().map(|&(pos, kind)| ShapeBlock { pos, kind }).collect()
    }

    #[test]
    fn a_floor_l_matches_its_quarter_turn_but_not_its_mirror() {
        // Lying flat (in the xz plane), so its mirror image is no turn of it.
        let l = blocks(&[([0, 0, 0], 1), ([1, 0, 0], 1), ([2, 0, 0], 2), ([0, 0, 1], 1)]);
        let turned: Vec<ShapeBlock> =
            l.iter().map(|b| ShapeBlock { pos: crate::add(rotate(1, b.pos), [10, 3, -4]), kind: b.kind }).collect();
        let mirrored: Vec<ShapeBlock> =
            l.iter().map(|b| ShapeBlock { pos: [-b.pos[0], b.pos[1], b.pos[2]], kind: b.kind }).collect();
        let c = Classes::of(&[l.clone(), turned.clone(), mirrored], &[]);
        assert_eq!(c.class, vec![0, 0, 1]);
        // to_rep maps the turned copy's blocks onto the original's.
        let mut back: Vec<ShapeBlock> =
            turned.iter().map(|b| ShapeBlock { pos: c.to_rep[1].apply(b.pos), kind: b.kind }).collect();
        sort_blocks(&mut back);
        let mut want = l;
        sort_blocks(&mut want);
        assert_eq!(back, want);
        assert!((c.matching_percent() - 200.0 / 3.0).abs() < 1e-9);
    }
}
