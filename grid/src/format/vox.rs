//! MagicaVoxel `.vox`: read with the `dot_vox` crate, written here (so the bytes are
//! deterministic). MagicaVoxel is z-up; a voxel (x, y, z) is the block (x, z, −y).
//! Each palette slot used is one block kind: its id is the `_mdg_block` property of
//! the slot's material when present (this writer stores it, so ids survive a round
//! trip), else the slot's colour as `#rrggbb`.
//!
//! Files with several models are assembled through the scene graph's translations;
//! rotated models are rejected.

use crate::voxel::{ModelBuilder, ModelError, VoxelModel};

/// The material property holding a block id.
const BLOCK_KEY: &str = "_mdg_block";
/// The `_r` byte of the identity rotation.
const IDENTITY_ROTATION: u8 = 0b0000100;

/// Walks the chunks of a `.vox` file (`VOX `, version, then `MAIN` with its
/// children, each chunk an id, a content size, a children size): every size must
/// fit in the file, and an `XYZI` chunk must hold the voxels it counts. Returns the
/// number of `XYZI` chunks; the error names the broken chunk and its byte offset.
fn check_chunks(bytes: &[u8]) -> Result<usize, VoxReadError> {
    let word =
        |at: usize| -> Option<u32> { bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])) };
    let id = |at: usize| -> String {
        bytes
            .get(at..at + 4)
            .map(|b| b.iter().map(|&c| if c.is_ascii_graphic() { c as char } else { '?' }).collect())
            .unwrap_or_default()
    };
    if bytes.len() < 20 || bytes.get(8..12) != Some(b"MAIN") {
        return Err(VoxReadError::NoMain);
    }
    let (Some(content), Some(children)) = (word(12), word(16)) else {
        return Err(VoxReadError::MainCutShort);
    };
    let start = 20usize.saturating_add(content as usize);
    let end = start.saturating_add(children as usize);
    if end > bytes.len() {
        return Err(VoxReadError::Truncated { declared: children, left: bytes.len().saturating_sub(start) });
    }
    let mut at = start;
    let mut models = 0;
    while at < end {
        let name = id(at);
        let (Some(c), Some(ch)) = (word(at + 4), word(at + 8)) else {
            return Err(VoxReadError::ChunkHeaderCut { chunk: name, at });
        };
        let next = at.saturating_add(12).saturating_add(c as usize).saturating_add(ch as usize);
        if next > end {
            return Err(VoxReadError::ChunkTooLong {
                chunk: name,
                at,
                declared: c as u64 + ch as u64,
                left: end - at - 12.min(end - at),
            });
        }
        if name == "XYZI" {
            let n = word(at + 12).unwrap_or(0) as u64;
            if c < 4 || n.saturating_mul(4) > c as u64 - 4 {
                return Err(VoxReadError::VoxelCount { at, voxels: n, room: (c as u64).saturating_sub(4) / 4 });
            }
            models += 1;
        }
        at = next;
    }
    Ok(models)
}

/// Reads a `.vox` file.
pub fn read(bytes: &[u8]) -> Result<VoxelModel, VoxReadError> {
    if !bytes.starts_with(b"VOX ") {
        return Err(VoxReadError::NotVox);
    }
    // `dot_vox` skips what it cannot parse, so a broken chunk used to surface as
    // "no model": the chunk structure is checked first, to name what is broken.
    let models = check_chunks(bytes)?;
    let data = dot_vox::load_bytes(bytes).map_err(VoxReadError::Corrupt)?;
    if data.models.is_empty() {
        return Err(if models == 0 { VoxReadError::NoModel } else { VoxReadError::UnreadableModels { models } });
    }
    let mut ids: Vec<Option<String>> = vec![None; 256];
    for m in &data.materials {
        if let (Some(slot), Some(id)) = (ids.get_mut(m.id as usize), m.properties.get(BLOCK_KEY)) {
            if !id.is_empty() && id.len() <= 256 && !id.chars().any(|c| c.is_whitespace()) {
                *slot = Some(id.clone());
            }
        }
    }
    let placements = model_placements(&data)?;
    let mut b = ModelBuilder::new();
    let mut kinds: Vec<Option<u32>> = vec![None; 256];
    for (model_idx, offset) in placements {
        let Some(model) = data.models.get(model_idx) else {
            return Err(VoxReadError::NoSuchModel { model: model_idx });
        };
        for v in &model.voxels {
            let slot = v.i as usize;
            let kind = match kinds[slot] {
                Some(k) => k,
                None => {
                    let c = data.palette.get(slot).map(|c| [c.r, c.g, c.b]).unwrap_or([128, 128, 128]);
                    let id = ids[slot + 1].clone().unwrap_or_else(|| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]));
                    let k = b.kind(&id, Some(c)).map_err(VoxReadError::Model)?;
                    kinds[slot] = Some(k);
                    k
                }
            };
            let p = [v.x as i64 + offset[0], v.y as i64 + offset[1], v.z as i64 + offset[2]];
            let c = |v: i64| v.clamp(i32::MIN as i64 + 1, i32::MAX as i64) as i32;
            b.add([c(p[0]), c(p[2]), c(-p[1])], kind).map_err(VoxReadError::Model)?;
        }
    }
    b.finish().map_err(VoxReadError::Model)
}

/// (model index, voxel offset in z-up file coordinates) for each model instance.
fn model_placements(data: &dot_vox::DotVoxData) -> Result<Vec<(usize, [i64; 3])>, VoxReadError> {
    use dot_vox::SceneNode;
    if data.scenes.is_empty() {
        return Ok((0..data.models.len()).map(|i| (i, [0, 0, 0])).collect());
    }
    let mut out = Vec::new();
    // Depth-first over the scene graph with an explicit stack (node, translation, depth).
    let mut stack = vec![(0u32, [0i64; 3], 0u32)];
    let mut visited = 0usize;
    while let Some((node, t, depth)) = stack.pop() {
        visited += 1;
        if depth > 64 || visited > 1_000_000 {
            return Err(VoxReadError::SceneTooDeep);
        }
        match data.scenes.get(node as usize) {
            Some(SceneNode::Transform { frames, child, .. }) => {
                let mut t2 = t;
                if let Some(f) = frames.first() {
                    if let Some(p) = f.position() {
                        t2 = [t[0] + p.x as i64, t[1] + p.y as i64, t[2] + p.z as i64];
                    }
                    // Read `_r` here: `Frame::orientation` asserts on invalid bytes.
                    if let Some(r) = f.attributes.get("_r") {
                        if r.trim().parse::<u8>().ok() != Some(IDENTITY_ROTATION) {
                            return Err(VoxReadError::Rotated);
                        }
                    }
                }
                stack.push((*child, t2, depth + 1));
            }
            Some(SceneNode::Group { children, .. }) => {
                for c in children.iter().rev() {
                    stack.push((*c, t, depth + 1));
                }
            }
            Some(SceneNode::Shape { models, .. }) => {
                for m in models {
                    let i = m.model_id as usize;
                    let size = data.models.get(i).map(|m| m.size).ok_or(VoxReadError::MissingModel)?;
                    // A translation places the model's centre (MagicaVoxel rounds down).
                    let half = [(size.x / 2) as i64, (size.y / 2) as i64, (size.z / 2) as i64];
                    out.push((i, [t[0] - half[0], t[1] - half[1], t[2] - half[2]]));
                }
            }
            None => return Err(VoxReadError::NoSuchNode { node }),
        }
    }
    Ok(out)
}

fn chunk(out: &mut Vec<u8>, id: &[u8; 4], content: &[u8]) {
    out.extend_from_slice(id);
    out.extend_from_slice(&(content.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(content);
}

fn string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

/// Why a `.vox` file was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum VoxReadError {
    /// No `VOX ` header.
    NotVox,
    /// No `MAIN` chunk after the header.
    NoMain,
    /// The `MAIN` chunk's header is cut short.
    MainCutShort,
    /// `MAIN` declares more bytes of chunks than the file has `left` after it.
    Truncated { declared: u32, left: usize },
    /// A chunk's 12-byte header is cut short.
    ChunkHeaderCut { chunk: String, at: usize },
    /// A chunk declares more bytes than are left in `MAIN`.
    ChunkTooLong { chunk: String, at: usize, declared: u64, left: usize },
    /// An `XYZI` chunk counts more voxels than it holds.
    VoxelCount { at: usize, voxels: u64, room: u64 },
    /// The `.vox` reader's own complaint.
    Corrupt(&'static str),
    /// No `SIZE` and `XYZI` chunks.
    NoModel,
    /// Model chunks there, none readable.
    UnreadableModels { models: usize },
    /// The scene places a model that is not in the file.
    NoSuchModel { model: usize },
    /// A shape node of the scene refers to a missing model.
    MissingModel,
    /// The scene graph refers to a node that is not there.
    NoSuchNode { node: u32 },
    /// The scene graph is deeper than 64 or visits more than a million nodes.
    SceneTooDeep,
    /// A model placed with a rotation.
    Rotated,
    /// The voxel model refused a block or as a whole.
    Model(ModelError),
}

impl std::fmt::Display for VoxReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            VoxReadError::NotVox => f.write_str("not a MagicaVoxel file (no `VOX ` header)"),
            VoxReadError::NoMain => f.write_str("corrupt .vox file: no MAIN chunk after the header"),
            VoxReadError::MainCutShort => f.write_str("corrupt .vox file: the MAIN chunk is cut short"),
            VoxReadError::Truncated { declared, left } => write!(
                f,
                "corrupt .vox file: the MAIN chunk declares {declared} bytes of chunks, but the file ends {left} bytes after it starts (truncated?)"
            ),
            VoxReadError::ChunkHeaderCut { chunk, at } => {
                write!(f, "corrupt .vox file: chunk `{chunk}` at byte {at} is cut short (its header needs 12 bytes)")
            }
            VoxReadError::ChunkTooLong { chunk, at, declared, left } => write!(
                f,
                "corrupt .vox file: chunk `{chunk}` at byte {at} declares {declared} bytes, more than the {left} left in the file"
            ),
            VoxReadError::VoxelCount { at, voxels, room } => {
                write!(f, "corrupt .vox file: chunk `XYZI` at byte {at} counts {voxels} voxels but holds room for {room}")
            }
            VoxReadError::Corrupt(e) => write!(f, "corrupt .vox file: {e}"),
            VoxReadError::NoModel => f.write_str("the .vox file has no model (no SIZE and XYZI chunks)"),
            VoxReadError::UnreadableModels { models } => write!(
                f,
                "corrupt .vox file: its {models} model chunk(s) could not be read (a SIZE or XYZI chunk is malformed)"
            ),
            VoxReadError::NoSuchModel { model } => write!(f, "the scene refers to model {model}, which does not exist"),
            VoxReadError::MissingModel => f.write_str("the scene refers to a missing model"),
            VoxReadError::NoSuchNode { node } => {
                write!(f, "the .vox scene graph refers to node {node}, which does not exist")
            }
            VoxReadError::SceneTooDeep => f.write_str("the .vox scene graph is too deep or cyclic"),
            VoxReadError::Rotated => f.write_str("rotated models in the .vox scene graph are not supported"),
            VoxReadError::Model(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for VoxReadError {}

/// Why a model cannot be written as `.vox`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum VoxWriteError {
    /// Larger than 256 voxels along an axis (the size in `.vox` axes).
    TooLarge { size: [i32; 3] },
    /// More than 255 block kinds in use (the palette's slots).
    TooManyKinds,
    /// A block whose kind is not in the model's kinds.
    KindOutOfRange,
}

impl std::fmt::Display for VoxWriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            VoxWriteError::TooLarge { size } => {
                write!(f, "a .vox model holds at most 256 voxels along each axis; this one is {size:?}")
            }
            VoxWriteError::TooManyKinds => f.write_str("a .vox file holds at most 255 block kinds"),
            VoxWriteError::KindOutOfRange => f.write_str("block kind out of range"),
        }
    }
}

impl std::error::Error for VoxWriteError {}

/// Writes a `.vox` file (one model; at most 255 kinds and 256 voxels along each axis).
pub fn write(model: &VoxelModel) -> Result<Vec<u8>, VoxWriteError> {
    let (lo, hi) = model.bounds().unwrap_or(([0; 3], [0; 3]));
    // Block (x, y, z) is voxel (x, −z, y); shift to non-negative voxel coordinates.
    let vlo = [lo[0], -hi[2], lo[1]];
    let size = [hi[0] - lo[0] + 1, hi[2] - lo[2] + 1, hi[1] - lo[1] + 1];
    if size.iter().any(|&s| s > 256) {
        return Err(VoxWriteError::TooLarge { size });
    }
    // Palette slots in order of first use.
    let mut slot_of: Vec<Option<u8>> = vec![None; model.kinds.len()];
    let mut used: Vec<u32> = Vec::new();
    for b in &model.blocks {
        let k = b.kind as usize;
        if k < slot_of.len() && slot_of[k].is_none() {
            if used.len() == 255 {
                return Err(VoxWriteError::TooManyKinds);
            }
            used.push(b.kind);
            slot_of[k] = Some(used.len() as u8);
        }
    }
    let mut body = Vec::new();
    let mut s = Vec::new();
    for v in size {
        s.extend_from_slice(&(v.max(1) as u32).to_le_bytes());
    }
    chunk(&mut body, b"SIZE", &s);
    let mut xyzi = Vec::with_capacity(4 + 4 * model.blocks.len());
    xyzi.extend_from_slice(&(model.blocks.len() as u32).to_le_bytes());
    for b in &model.blocks {
        let v = [b.pos[0] - vlo[0], -b.pos[2] - vlo[1], b.pos[1] - vlo[2]];
        let slot = slot_of.get(b.kind as usize).copied().flatten().ok_or(VoxWriteError::KindOutOfRange)?;
        xyzi.extend_from_slice(&[v[0] as u8, v[1] as u8, v[2] as u8, slot]);
    }
    chunk(&mut body, b"XYZI", &xyzi);
    let mut rgba = vec![0u8; 256 * 4];
    for (i, k) in used.iter().enumerate() {
        let c = model.kinds[*k as usize].color;
        rgba[i * 4..i * 4 + 4].copy_from_slice(&[c[0], c[1], c[2], 255]);
    }
    chunk(&mut body, b"RGBA", &rgba);
    for (i, k) in used.iter().enumerate() {
        let mut m = Vec::new();
        m.extend_from_slice(&(i as u32 + 1).to_le_bytes());
        m.extend_from_slice(&2u32.to_le_bytes());
        string(&mut m, "_type");
        string(&mut m, "_diffuse");
        string(&mut m, BLOCK_KEY);
        string(&mut m, &model.kinds[*k as usize].id);
        chunk(&mut body, b"MATL", &m);
    }
    let mut out = Vec::with_capacity(body.len() + 20);
    out.extend_from_slice(b"VOX ");
    out.extend_from_slice(&150u32.to_le_bytes());
    out.extend_from_slice(b"MAIN");
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_blocks_and_ids() {
        let m = crate::format::text::read("0 0 0 1:0\n1 0 0 5:5\n1 2 3 #ff0000\n").expect("text");
        let bytes = write(&m).expect("writes");
        let back = read(&bytes).expect("reads");
        assert_eq!(back.normalized().blocks.len(), 3);
        let ids = |m: &VoxelModel| {
            let mut v: Vec<([i32; 3], String)> =
                m.normalized().blocks.iter().map(|b| (b.pos, m.kinds[b.kind as usize].id.clone())).collect();
            v.sort();
            v
        };
        assert_eq!(ids(&m), ids(&back));
        assert_eq!(write(&back).expect("again"), bytes, "writing is deterministic");
    }

    #[test]
    fn corrupt_files_are_errors() {
        assert!(read(b"").is_err());
        assert!(read(b"VOX \x96\x00\x00\x00MAIN").is_err());
        let m = crate::format::text::read("0 0 0 1:0\n").expect("text");
        let bytes = write(&m).expect("writes");
        for cut in [9, 20, 30, bytes.len() - 3] {
            assert!(read(&bytes[..cut]).is_err(), "truncated at {cut}");
        }
    }

    /// The offset of the first chunk named `id` inside MAIN.
    fn chunk_at(bytes: &[u8], id: &[u8; 4]) -> usize {
        (20..bytes.len() - 4).find(|&i| &bytes[i..i + 4] == id).expect("chunk")
    }

    #[test]
    fn a_broken_chunk_is_named_not_reported_as_no_model() {
        let m = crate::format::text::read("0 0 0 1:0\n1 0 0 1:0\n").expect("text");
        let good = write(&m).expect("writes");
        // An XYZI chunk whose voxel count is larger than the chunk.
        let mut bad = good.clone();
        let at = chunk_at(&bad, b"XYZI");
        bad[at + 12..at + 16].copy_from_slice(&1000u32.to_le_bytes());
        let e = read(&bad).expect_err("broken");
        assert!(matches!(e, VoxReadError::VoxelCount { voxels: 1000, .. }), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("chunk `XYZI` at byte") && e.contains("counts 1000 voxels"), "{e}");
        // A chunk whose size runs past the end of the file.
        let mut bad = good.clone();
        let at = chunk_at(&bad, b"SIZE");
        bad[at + 4..at + 8].copy_from_slice(&100_000u32.to_le_bytes());
        let e = read(&bad).expect_err("broken");
        assert!(matches!(&e, VoxReadError::ChunkTooLong { chunk, .. } if chunk == "SIZE"), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("chunk `SIZE` at byte") && e.contains("declares"), "{e}");
        // MAIN that claims more children than the file holds: truncated.
        let e = read(&good[..good.len() - 10]).expect_err("truncated");
        assert!(matches!(e, VoxReadError::Truncated { .. }), "{e:?}");
        let e = e.to_string();
        assert!(e.contains("MAIN chunk declares") && e.contains("truncated"), "{e}");
        // No model at all is still "no model".
        let mut empty = b"VOX \x96\x00\x00\x00MAIN".to_vec();
        empty.extend([0u8; 8]);
        let e = read(&empty).expect_err("no model");
        assert_eq!(e, VoxReadError::NoModel);
        assert_eq!(e.to_string(), "the .vox file has no model (no SIZE and XYZI chunks)");
    }

    #[test]
    fn a_model_too_large_for_vox_is_refused_with_its_size() {
        let m = crate::format::text::read("0 0 0 1:0\n300 0 0 1:0\n").expect("text");
        let e = write(&m).expect_err("301 voxels along x");
        assert_eq!(e, VoxWriteError::TooLarge { size: [301, 1, 1] });
        assert_eq!(e.to_string(), "a .vox model holds at most 256 voxels along each axis; this one is [301, 1, 1]");
    }
}
