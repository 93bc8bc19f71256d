//! The outside of a production, for the enclosure constraint (see
//! [`super::generate`]): the empty cells that a flood fill from outside reaches when it
//! runs around the blocks grown by `seal` cells, grown back by `seal` cells; the fill does
//! not pass below the production's lowest blocks (the building stands on the ground).
//!
//! Kept as counts so that removing blocks updates it in place ([`Outside::remove`]):
//! per cell, how many solid cells lie within `seal` cells (Chebyshev distance: the
//! blocks grown) and how many filled cells (the fill grown back). Removing a block
//! lowers the first count around it; a cell whose count falls to 0 beside the fill
//! joins it, and the fill goes on from there. The fill only grows when blocks go (a
//! path of free cells stays free), so the result is exactly the fill computed again from
//! scratch, at the cost of the cells that change rather than of the whole box: the
//! enclosure's rounds (remove what is exposed, look again) cost one box and then the
//! removed blocks. Only while the lowest blocks stay: when the ground rises, compute it
//! again ([`Outside::ground`]).
//!
//! The box is the blocks' bounding box padded by `seal + 1`; a larger box (the blocks'
//! box before some were removed) gives the same outside: its padding is empty, above
//! the grown ground and connected to the fill's start, so every path through it enters
//! the smaller box through that box's own free shell.

use super::voxel::{cell_index, MAX_CELLS, NEIGHBOURS};

/// A production too large for the enclosure constraint: `cells` cells in its
/// padded bounding box, over 4 × [`MAX_CELLS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooLarge {
    pub cells: u64,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the production is too large for the enclosure constraint ({} cells in its bounding box, at most {})",
            self.cells,
            MAX_CELLS * 4
        )
    }
}

impl std::error::Error for TooLarge {}

/// The outside of a set of blocks (see the module documentation).
pub(super) struct Outside {
    lo: [i32; 3],
    dims: [i32; 3],
    /// Seal radius.
    r: i32,
    /// The lowest blocks' level: cells below it are solid, and never outside.
    ground: i32,
    /// A block stands here, or the cell is below the ground.
    solid: Vec<bool>,
    /// Solid cells within `r` (0: the fill may pass).
    grown: Vec<u16>,
    /// Reached by the fill.
    fill: Vec<bool>,
    /// Filled cells within `r` (above 0 and not solid: outside).
    near: Vec<u16>,
}

/// Adds up `v` over the box of half-width `r` around each cell (Chebyshev distance),
/// one axis at a time with a running window; `buf` is scratch space.
fn box_sums(v: &mut [u16], dims: [i32; 3], r: i32, buf: &mut Vec<u16>) {
    if r <= 0 {
        return;
    }
    let (dx, dy, dz) = (dims[0] as usize, dims[1] as usize, dims[2] as usize);
    let r = r as usize;
    // (line length, stride along it, the starts of the lines)
    let axes: [(usize, usize, Vec<usize>); 3] = [
        (dx, 1, (0..dy * dz).map(|l| l * dx).collect()),
        (dz, dx, (0..dy).flat_map(|y| (0..dx).map(move |x| y * dx * dz + x)).collect()),
        (dy, dx * dz, (0..dx * dz).collect()),
    ];
    for (len, stride, starts) in axes {
        for s in starts {
            buf.clear();
            buf.extend((0..len).map(|i| v[s + i * stride]));
            // The window [i − r, i + r] ∩ [0, len).
            let mut sum: u32 = buf.iter().take(r).map(|&x| u32::from(x)).sum();
            for i in 0..len {
                if i + r < len {
                    sum += u32::from(buf[i + r]);
                }
                if i > r {
                    sum -= u32::from(buf[i - r - 1]);
                }
                v[s + i * stride] = sum.min(u32::from(u16::MAX)) as u16;
            }
        }
    }
}

impl Outside {
    /// The outside of `blocks` (positions; repeats allowed) with openings up to
    /// `2·seal` wide sealed (`seal` at most the enclosure's largest, 8); none for no
    /// blocks, an error when the padded box has more than `4 × MAX_CELLS` cells.
    pub(super) fn of(blocks: impl Iterator<Item = [i32; 3]> + Clone, seal: u32) -> Result<Option<Outside>, TooLarge> {
        let r = seal.min(64) as i32;
        let mut it = blocks.clone();
        let Some(first) = it.next() else { return Ok(None) };
        let (mut lo, mut hi) = (first, first);
        for p in it {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        // Checked before anything is allocated: a rule placing a shape 16,000,000
        // blocks away made a 29 GB grid.
        let pad = i64::from(r) + 1;
        let cells =
            (0..3).map(|k| (i64::from(hi[k]) - i64::from(lo[k]) + 1 + 2 * pad) as u64).fold(1u64, u64::saturating_mul);
        if cells > MAX_CELLS * 4 {
            return Err(TooLarge { cells });
        }
        let ground = lo[1];
        let lo = lo.map(|v| v - (r + 1));
        let dims = [0, 1, 2].map(|k| hi[k] + r + 1 - lo[k] + 1);
        let n = cells as usize;
        let mut out = Outside {
            lo,
            dims,
            r,
            ground,
            solid: vec![false; n],
            grown: vec![0; n],
            fill: vec![false; n],
            near: vec![0; n],
        };
        // The production stands on the ground: the layers below its lowest blocks are solid.
        let layer = (dims[0] * dims[2]) as usize;
        let below = (ground - lo[1]) as usize * layer;
        out.solid[..below].iter_mut().for_each(|s| *s = true);
        for p in blocks {
            if let Some(c) = out.index(p) {
                out.solid[c] = true;
            }
        }
        let mut buf = Vec::new();
        out.grown = out.solid.iter().map(|&s| u16::from(s)).collect();
        box_sums(&mut out.grown, dims, r, &mut buf);
        // Flood fill from a top corner of the padded box (never grown over).
        let corner = [lo[0], lo[1] + dims[1] - 1, lo[2]];
        let mut stack = Vec::new();
        if let Some(c) = out.index(corner) {
            if out.grown[c] == 0 {
                out.fill[c] = true;
                stack.push(corner);
            }
        }
        out.spread(&mut stack, false);
        out.near = out.fill.iter().map(|&f| u16::from(f)).collect();
        box_sums(&mut out.near, dims, r, &mut buf);
        Ok(Some(out))
    }

    #[inline]
    fn index(&self, p: [i32; 3]) -> Option<usize> {
        cell_index(self.lo, self.dims, p)
    }

    /// Calls `f` on each cell within `r` of `p` inside the box.
    #[inline]
    fn around(&self, p: [i32; 3], mut f: impl FnMut(usize)) {
        let r = self.r;
        let lo = [0, 1, 2].map(|k| (p[k] - r).max(self.lo[k]));
        let hi = [0, 1, 2].map(|k| (p[k] + r).min(self.lo[k] + self.dims[k] - 1));
        for y in lo[1]..=hi[1] {
            for z in lo[2]..=hi[2] {
                let row = ((y - self.lo[1]) as usize * self.dims[2] as usize + (z - self.lo[2]) as usize)
                    * self.dims[0] as usize;
                for x in lo[0]..=hi[0] {
                    f(row + (x - self.lo[0]) as usize);
                }
            }
        }
    }

    /// Floods from the filled cells on `stack` through cells nothing grown covers;
    /// with `counted`, each newly filled cell is added to the `near` counts around it.
    fn spread(&mut self, stack: &mut Vec<[i32; 3]>, counted: bool) {
        let (dx, dy, dz) = (self.dims[0], self.dims[1], self.dims[2]);
        let (sz, sy) = (dx as isize, (dx * dz) as isize);
        while let Some(p) = stack.pop() {
            let Some(c) = self.index(p) else { continue };
            let l = [p[0] - self.lo[0], p[1] - self.lo[1], p[2] - self.lo[2]];
            // The six neighbours inside the box: (offset, step in the cell index).
            let steps = [
                (l[0] > 0, [-1, 0, 0], -1),
                (l[0] + 1 < dx, [1, 0, 0], 1),
                (l[1] > 0, [0, -1, 0], -sy),
                (l[1] + 1 < dy, [0, 1, 0], sy),
                (l[2] > 0, [0, 0, -1], -sz),
                (l[2] + 1 < dz, [0, 0, 1], sz),
            ];
            for (inside, d, step) in steps {
                if !inside {
                    continue;
                }
                let n = (c as isize + step) as usize;
                if !self.fill[n] && self.grown[n] == 0 {
                    self.fill[n] = true;
                    let q = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
                    if counted {
                        self.mark_near(q);
                    }
                    stack.push(q);
                }
            }
        }
    }

    fn mark_near(&mut self, p: [i32; 3]) {
        let mut near = std::mem::take(&mut self.near);
        self.around(p, |c| near[c] = near[c].saturating_add(1));
        self.near = near;
    }

    /// The level of the lowest blocks it was computed for (cells below are never
    /// outside). When removing blocks raises the lowest level, compute it again.
    pub(super) fn ground(&self) -> i32 {
        self.ground
    }

    /// Takes the block at `p` away (nothing when there is none, or below the ground):
    /// the fill reaches what the block held back.
    pub(super) fn remove(&mut self, p: [i32; 3]) {
        let Some(c) = self.index(p) else { return };
        if !self.solid[c] || p[1] < self.ground {
            return;
        }
        self.solid[c] = false;
        let (mut grown, mut freed) = (std::mem::take(&mut self.grown), Vec::new());
        self.around(p, |n| {
            grown[n] = grown[n].saturating_sub(1);
            if grown[n] == 0 && !self.fill[n] {
                freed.push(n);
            }
        });
        self.grown = grown;
        let mut stack = Vec::new();
        for n in freed {
            let q = self.position(n);
            let beside = NEIGHBOURS
                .iter()
                .any(|d| self.index([q[0] + d[0], q[1] + d[1], q[2] + d[2]]).is_some_and(|m| self.fill[m]));
            if beside && !self.fill[n] {
                self.fill[n] = true;
                self.mark_near(q);
                stack.push(q);
                self.spread(&mut stack, true);
            }
        }
    }

    fn position(&self, i: usize) -> [i32; 3] {
        let dx = self.dims[0] as usize;
        let dz = self.dims[2] as usize;
        [(i % dx) as i32 + self.lo[0], (i / (dx * dz)) as i32 + self.lo[1], ((i / dx) % dz) as i32 + self.lo[2]]
    }

    /// Whether the cell at `p` is outside (cells beyond the padded box are).
    pub(super) fn is_out(&self, p: [i32; 3]) -> bool {
        p[1] >= self.ground && self.index(p).is_none_or(|c| self.near[c] > 0 && !self.solid[c])
    }

    /// Empty cells above the ground that the outside does not reach.
    pub(super) fn interior(&self) -> usize {
        (0..self.solid.len()).filter(|&c| !self.solid[c] && self.near[c] == 0).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mdg_vm::rng::Rng;
    use std::collections::BTreeSet;

    /// Every cell of the houses' box and four beyond, outside or not.
    fn outside_cells(o: &Outside) -> Vec<bool> {
        let (lo, hi) = (-4, 14);
        (lo..hi).flat_map(|y| (lo..hi).flat_map(move |z| (lo..hi).map(move |x| o.is_out([x, y, z])))).collect()
    }

    #[test]
    fn removing_blocks_gives_the_outside_computed_again() {
        // Houses with rooms, walls with holes, scattered blocks: blocks go one at a
        // time (the floor stays, so the ground does not move) and the updated outside
        // is the one computed from scratch, cell for cell, with its interior.
        let mut rng = Rng::new(42);
        let mut checked = 0;
        for case in 0..12u64 {
            let seal = (case % 3) as u32;
            let mut blocks: BTreeSet<[i32; 3]> = BTreeSet::new();
            for x in 0..9 {
                for z in 0..9 {
                    blocks.insert([x, 0, z]);
                    for y in 1..7 {
                        let wall = x == 0 || x == 8 || z == 0 || z == 8 || y == 6 || (case % 2 == 0 && x == 4);
                        if (wall && !rng.one_in(8)) || rng.one_in(12) {
                            blocks.insert([x, y, z]);
                        }
                    }
                }
            }
            let mut o = Outside::of(blocks.iter().copied(), seal).expect("fits").expect("blocks");
            let mut order: Vec<[i32; 3]> = blocks.iter().copied().filter(|p| p[1] > 0).collect();
            for i in (1..order.len()).rev() {
                order.swap(i, rng.below(i + 1));
            }
            for (n, p) in order.into_iter().enumerate() {
                blocks.remove(&p);
                o.remove(p);
                if n % 7 != 0 {
                    continue;
                }
                let fresh = Outside::of(blocks.iter().copied(), seal).expect("fits").expect("blocks");
                assert_eq!(o.ground(), fresh.ground());
                assert!(outside_cells(&o) == outside_cells(&fresh), "case {case}, step {n}");
                assert_eq!(o.interior(), fresh.interior(), "case {case}, step {n}");
                checked += 1;
            }
        }
        assert!(checked > 300, "{checked}");
    }

    #[test]
    fn a_box_too_large_is_refused_before_anything_is_allocated() {
        let far = [[0, 0, 0], [16_000_000, 0, 16_000_000]];
        let e = Outside::of(far.iter().copied(), 1).err().expect("refused");
        assert!(e.cells > MAX_CELLS * 4, "{e:?}");
        assert!(e.to_string().contains("too large for the enclosure constraint"), "{e}");
        assert!(Outside::of(std::iter::empty(), 1).expect("nothing").is_none());
    }
}
