//! The voxel model: blocks at integer positions, each of one block kind, with the
//! size limits every reader enforces and a dense lookup grid for the searches.

use std::collections::HashMap;

/// The most blocks a voxel model may hold.
pub const MAX_BLOCKS: usize = 4_000_000;
/// The largest bounding box (cells) of a model: dense per-cell tables stay under 64 MiB.
pub const MAX_CELLS: u64 = 16 * 1024 * 1024;
/// The largest coordinate magnitude.
pub const MAX_COORD: i32 = 1 << 24;
/// The most block kinds a model may hold.
pub const MAX_KINDS: usize = 65_536;

/// The index of cell `p` in a box of `dims` cells from corner `lo`, laid out x
/// fastest, then z, then y (the grids' layout), or none outside the box.
#[inline]
pub(crate) fn cell_index(lo: [i32; 3], dims: [i32; 3], p: [i32; 3]) -> Option<usize> {
    let x = p[0].wrapping_sub(lo[0]);
    let y = p[1].wrapping_sub(lo[1]);
    let z = p[2].wrapping_sub(lo[2]);
    if x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2] {
        return None;
    }
    Some(((y as usize * dims[2] as usize) + z as usize) * dims[0] as usize + x as usize)
}

/// The six face neighbours: ±x, ±y, ±z.
pub const NEIGHBOURS: [[i32; 3]; 6] = [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]];

/// One block kind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BlockKind {
    /// The block as its format names it: `minecraft:stone`, `1:0`, `#ff8800`…
    pub id: String,
    /// Display colour (sRGB).
    pub color: [u8; 3],
}

/// One block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Block {
    pub pos: [i32; 3],
    /// Index into [`VoxelModel::kinds`].
    pub kind: u32,
}

/// A voxel building: blocks sorted by (y, z, x), no two at one position, y up.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VoxelModel {
    pub kinds: Vec<BlockKind>,
    pub blocks: Vec<Block>,
}

/// Why a [`ModelBuilder`] refused a block, a kind or the finished model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelError {
    /// More than [`MAX_KINDS`] block kinds.
    TooManyKinds,
    /// A block beyond ±[`MAX_COORD`].
    TooFar { pos: [i32; 3] },
    /// More than [`MAX_BLOCKS`] blocks.
    TooManyBlocks,
    /// A second block at one position.
    TwoBlocks { pos: [i32; 3] },
    /// A bounding box of `size` blocks, `cells` in all, over [`MAX_CELLS`].
    TooLarge { size: [i64; 3], cells: u64 },
}

impl std::fmt::Display for ModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            ModelError::TooManyKinds => write!(f, "more than {MAX_KINDS} block kinds"),
            ModelError::TooFar { pos } => {
                write!(f, "position {pos:?} is too far out (coordinates are limited to ±{MAX_COORD})")
            }
            ModelError::TooManyBlocks => write!(f, "more than {MAX_BLOCKS} blocks"),
            ModelError::TwoBlocks { pos: [x, y, z] } => write!(f, "two blocks at {x} {y} {z}"),
            ModelError::TooLarge { size: [x, y, z], cells } => {
                write!(f, "the building's bounding box is {x}×{y}×{z} = {cells} cells (at most {MAX_CELLS})")
            }
        }
    }
}

impl std::error::Error for ModelError {}

/// Builds a [`VoxelModel`] block by block, checking duplicates and limits.
#[derive(Default)]
pub struct ModelBuilder {
    kinds: Vec<BlockKind>,
    kind_ids: HashMap<String, u32>,
    at: HashMap<[i32; 3], u32>,
    blocks: Vec<Block>,
}

impl ModelBuilder {
    /// An empty builder.
    pub fn new() -> ModelBuilder {
        ModelBuilder::default()
    }

    /// The kind index for `id`, added with `color` (or the default colour for the
    /// block name) when new.
    pub fn kind(&mut self, id: &str, color: Option<[u8; 3]>) -> Result<u32, ModelError> {
        if let Some(&k) = self.kind_ids.get(id) {
            return Ok(k);
        }
        if self.kinds.len() >= MAX_KINDS {
            return Err(ModelError::TooManyKinds);
        }
        let k = self.kinds.len() as u32;
        let color = color.unwrap_or_else(|| super::blocks::color_of(id));
        self.kinds.push(BlockKind { id: id.to_string(), color });
        self.kind_ids.insert(id.to_string(), k);
        Ok(k)
    }

    /// Adds a block; a second block at one position is an error.
    pub fn add(&mut self, pos: [i32; 3], kind: u32) -> Result<(), ModelError> {
        if pos.iter().any(|c| c.unsigned_abs() > MAX_COORD as u32) {
            return Err(ModelError::TooFar { pos });
        }
        if self.blocks.len() >= MAX_BLOCKS {
            return Err(ModelError::TooManyBlocks);
        }
        if self.at.insert(pos, kind).is_some() {
            return Err(ModelError::TwoBlocks { pos });
        }
        self.blocks.push(Block { pos, kind });
        Ok(())
    }

    /// The model, blocks sorted; fails when the bounding box is too large.
    pub fn finish(self) -> Result<VoxelModel, ModelError> {
        let mut m = VoxelModel { kinds: self.kinds, blocks: self.blocks };
        m.sort();
        // Kinds renumbered by first use in block order, unused ones dropped: the same
        // blocks give the same model whatever order a file listed them in.
        let mut new_index = vec![u32::MAX; m.kinds.len()];
        let mut kinds = Vec::new();
        for b in &mut m.blocks {
            let k = b.kind as usize;
            if new_index[k] == u32::MAX {
                new_index[k] = kinds.len() as u32;
                kinds.push(m.kinds[k].clone());
            }
            b.kind = new_index[k];
        }
        m.kinds = kinds;
        if let Some((lo, hi)) = m.bounds() {
            let size = [0, 1, 2].map(|k| hi[k] as i64 - lo[k] as i64 + 1);
            let cells = size.iter().map(|&e| e as u64).product::<u64>();
            if cells > MAX_CELLS {
                return Err(ModelError::TooLarge { size, cells });
            }
        }
        Ok(m)
    }
}

impl VoxelModel {
    /// Sorts the blocks by (y, z, x) (the canonical order).
    pub fn sort(&mut self) {
        self.blocks.sort_by_key(|b| (b.pos[1], b.pos[2], b.pos[0]));
    }

    /// Inclusive bounds (min corner, max corner), or none when empty.
    pub fn bounds(&self) -> Option<([i32; 3], [i32; 3])> {
        let first = self.blocks.first()?;
        let (mut lo, mut hi) = (first.pos, first.pos);
        for b in &self.blocks {
            for k in 0..3 {
                lo[k] = lo[k].min(b.pos[k]);
                hi[k] = hi[k].max(b.pos[k]);
            }
        }
        Some((lo, hi))
    }

    /// The same model moved so its min corner is at the origin.
    pub fn normalized(&self) -> VoxelModel {
        let Some((lo, _)) = self.bounds() else { return self.clone() };
        let mut m = self.clone();
        for b in &mut m.blocks {
            b.pos = super::sub(b.pos, lo);
        }
        m
    }

    /// Number of distinct kinds actually used.
    pub fn kinds_used(&self) -> usize {
        let mut used = vec![false; self.kinds.len()];
        for b in &self.blocks {
            if let Some(u) = used.get_mut(b.kind as usize) {
                *u = true;
            }
        }
        used.iter().filter(|u| **u).count()
    }
}

/// A dense table over a model's bounding box (padded by `pad` cells on every side):
/// the block index at each cell, or [`Grid::EMPTY`].
pub struct Grid {
    pub lo: [i32; 3],
    pub dims: [i32; 3],
    cells: Vec<u32>,
}

impl Grid {
    /// The value of a cell without a block.
    pub const EMPTY: u32 = u32::MAX;

    /// The cells [`Grid::new`] would allocate for `blocks` grown by `pad`, computed
    /// without allocating (check it against a limit first: blocks far apart make a
    /// bounding box of many gigabytes).
    pub fn cells_needed(blocks: &[Block], pad: i32) -> u64 {
        let Some(f) = blocks.first() else { return 0 };
        let (mut lo, mut hi) = (f.pos.map(i64::from), f.pos.map(i64::from));
        for b in blocks {
            for k in 0..3 {
                lo[k] = lo[k].min(i64::from(b.pos[k]));
                hi[k] = hi[k].max(i64::from(b.pos[k]));
            }
        }
        (0..3).map(|k| (hi[k] - lo[k] + 1 + 2 * i64::from(pad.max(0))) as u64).fold(1u64, u64::saturating_mul)
    }

    /// The grid of `blocks` (positions within the limits of [`ModelBuilder::finish`];
    /// others: check [`Grid::cells_needed`] first).
    pub fn new(blocks: &[Block], pad: i32) -> Grid {
        let (mut lo, mut hi) = ([0; 3], [-1; 3]);
        if let Some(f) = blocks.first() {
            lo = f.pos;
            hi = f.pos;
        }
        for b in blocks {
            for k in 0..3 {
                lo[k] = lo[k].min(b.pos[k]);
                hi[k] = hi[k].max(b.pos[k]);
            }
        }
        let lo = [lo[0] - pad, lo[1] - pad, lo[2] - pad];
        let dims = [hi[0] + pad - lo[0] + 1, hi[1] + pad - lo[1] + 1, hi[2] + pad - lo[2] + 1].map(|d| d.max(0));
        let n = dims.iter().map(|&d| d as usize).product::<usize>();
        let mut g = Grid { lo, dims, cells: vec![Grid::EMPTY; n] };
        for (i, b) in blocks.iter().enumerate() {
            if let Some(c) = g.index(b.pos) {
                g.cells[c] = i as u32;
            }
        }
        g
    }

    /// The cell index of `p`, or none outside the grid.
    #[inline]
    pub fn index(&self, p: [i32; 3]) -> Option<usize> {
        cell_index(self.lo, self.dims, p)
    }

    /// The block at `p`, or [`Grid::EMPTY`].
    #[inline]
    pub fn get(&self, p: [i32; 3]) -> u32 {
        match self.index(p) {
            Some(i) => self.cells[i],
            None => Grid::EMPTY,
        }
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether the grid has no cells.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The position of cell `i`.
    pub fn position(&self, i: usize) -> [i32; 3] {
        let dx = self.dims[0] as usize;
        let dz = self.dims[2] as usize;
        let x = i % dx;
        let z = (i / dx) % dz;
        let y = i / (dx * dz);
        [x as i32 + self.lo[0], y as i32 + self.lo[1], z as i32 + self.lo[2]]
    }
}
