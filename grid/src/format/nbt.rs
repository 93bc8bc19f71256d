//! Minecraft NBT formats: the vanilla structure-block file (`.nbt`: `size`,
//! `palette` or `palettes`, `blocks` with `pos` and `state`) and the Sponge schematic
//! (`.schem`, versions 2 and 3: `Width`/`Height`/`Length`, a `Palette` of block states
//! and varint `BlockData`). Both are gzip-compressed NBT; uncompressed NBT is read too.
//!
//! Untrusted input is checked before `fastnbt` sees it: the decompressed size is
//! capped and a small iterative scanner rejects truncated data and nesting deeper than
//! Minecraft's own limit (512), so deserialisation cannot recurse without bound.
//! Block kinds are block states written `name[key=value,…]` with the keys sorted;
//! air, cave air, void air and structure voids are empty space.

use crate::blocks;
use crate::voxel::{ModelBuilder, ModelError, VoxelModel};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::io::Read as _;

/// The most bytes decompressed NBT may have.
pub const MAX_NBT_BYTES: u64 = 256 * 1024 * 1024;
/// Deepest nesting of lists and compounds accepted (Minecraft's limit).
pub const MAX_DEPTH: usize = 512;
/// The data version written (Minecraft 1.19.2, as the GDMC structures).
pub const DATA_VERSION: i32 = 3120;

/// Why an `.nbt` or `.schem` file was refused.
#[derive(Debug)]
pub enum NbtError {
    /// The gzip stream is corrupt.
    Gzip(std::io::Error),
    /// More than [`MAX_NBT_BYTES`] once decompressed.
    TooLarge,
    /// The data ends inside a tag.
    Truncated,
    /// A negative length.
    NegativeLength,
    /// The root tag is not a compound.
    RootNotCompound,
    /// A list of an unknown element type (or of `End` with elements).
    ListType(u8),
    /// A list longer than the data could hold.
    ListTooLong,
    /// An array whose length in bytes overflows.
    ArrayTooLong,
    /// An unknown tag type.
    TagType(u8),
    /// Nesting deeper than [`MAX_DEPTH`].
    TooDeep,
    /// Well-formed NBT that is not a structure or schematic.
    Content(fastnbt::error::Error),
    /// A structure without `palette` or `palettes`.
    NoPalette,
    /// A structure block whose `pos` does not have 3 values (it has `n`).
    PosLength(usize),
    /// A structure block at `pos` whose state is past the palette's `palette` states.
    StateOutOfRange { pos: [i32; 3], state: i32, palette: usize },
    /// A schematic version other than 1 to 3.
    Version(i32),
    /// A schematic without `Width`, `Height` and `Length`.
    NoSize,
    /// A schematic of `size` blocks, `cells` in all, over the model's limit.
    SchemTooLarge { size: [usize; 3], cells: u64 },
    /// A schematic without palette and block data.
    NoBlockData,
    /// A palette index given to two states.
    IndexTwice(i32),
    /// The block data ends inside a varint.
    TruncatedBlockData,
    /// A varint longer than 5 bytes.
    Varint,
    /// More block data than the schematic's cells.
    MoreBlockData,
    /// Block data using an index the palette does not have.
    IndexNotInPalette(i32),
    /// Block data of `entries` entries for `cells` cells.
    BlockDataCount { entries: usize, cells: usize },
    /// The voxel model refused a block or as a whole.
    Model(ModelError),
}

impl std::fmt::Display for NbtError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NbtError::Gzip(e) => write!(f, "corrupt gzip data: {e}"),
            NbtError::TooLarge => write!(f, "decompressed NBT is larger than {MAX_NBT_BYTES} bytes"),
            NbtError::Truncated => write!(f, "truncated NBT data"),
            NbtError::NegativeLength => write!(f, "negative NBT length"),
            NbtError::RootNotCompound => write!(f, "the NBT root is not a compound"),
            NbtError::ListType(t) => write!(f, "invalid NBT list element type {t}"),
            NbtError::ListTooLong => write!(f, "NBT list longer than the data"),
            NbtError::ArrayTooLong => write!(f, "NBT array too long"),
            NbtError::TagType(t) => write!(f, "invalid NBT tag type {t}"),
            NbtError::TooDeep => write!(f, "NBT nested deeper than {MAX_DEPTH}"),
            NbtError::Content(e) => write!(f, "unexpected NBT content: {e}"),
            NbtError::NoPalette => write!(f, "the structure has no `palette`"),
            NbtError::PosLength(n) => write!(f, "a block's `pos` has {n} values, expected 3"),
            NbtError::StateOutOfRange { pos: [x, y, z], state, palette } => {
                write!(f, "block at {x} {y} {z} has state {state} but the palette has {palette}")
            }
            NbtError::Version(v) => write!(f, "unsupported schematic version {v}"),
            NbtError::NoSize => write!(f, "the schematic has no Width, Height and Length"),
            NbtError::SchemTooLarge { size: [w, h, l], cells } => {
                write!(f, "the schematic is {w}×{h}×{l} = {cells} cells (at most {})", crate::voxel::MAX_CELLS)
            }
            NbtError::NoBlockData => write!(f, "the schematic has no palette and block data"),
            NbtError::IndexTwice(i) => write!(f, "palette index {i} is used twice"),
            NbtError::TruncatedBlockData => write!(f, "truncated block data"),
            NbtError::Varint => write!(f, "invalid varint in block data"),
            NbtError::MoreBlockData => write!(f, "more block data than Width × Height × Length"),
            NbtError::IndexNotInPalette(i) => write!(f, "block data uses palette index {i}, not in the palette"),
            NbtError::BlockDataCount { entries, cells } => {
                write!(f, "block data has {entries} entries, expected {cells}")
            }
            NbtError::Model(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for NbtError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            NbtError::Gzip(e) => Some(e),
            NbtError::Content(e) => Some(e),
            NbtError::Model(e) => Some(e),
            _ => None,
        }
    }
}

impl From<ModelError> for NbtError {
    fn from(e: ModelError) -> NbtError {
        NbtError::Model(e)
    }
}

/// Why a model cannot be written as `.nbt` or `.schem`.
#[derive(Debug)]
pub enum NbtWriteError {
    /// A block kind with no Minecraft name (its id).
    NoMinecraftName(String),
    /// A block whose kind is past the model's kinds.
    KindOutOfRange,
    /// A schematic over 65,535 blocks along an axis.
    SchemTooLarge,
    /// The NBT encoder refused the data.
    Encode(fastnbt::error::Error),
    /// The gzip encoder failed.
    Gzip(std::io::Error),
}

impl std::fmt::Display for NbtWriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            NbtWriteError::NoMinecraftName(id) => {
                write!(f, "block `{id}` has no Minecraft name (write .txt or .vox to keep any block id)")
            }
            NbtWriteError::KindOutOfRange => write!(f, "block kind out of range"),
            NbtWriteError::SchemTooLarge => write!(f, "a schematic is at most 65535 blocks along each axis"),
            NbtWriteError::Encode(e) => write!(f, "cannot encode NBT: {e}"),
            NbtWriteError::Gzip(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for NbtWriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            NbtWriteError::Encode(e) => Some(e),
            NbtWriteError::Gzip(e) => Some(e),
            _ => None,
        }
    }
}

/// Decompresses gzip (or passes raw NBT through), within [`MAX_NBT_BYTES`].
fn decompress(bytes: &[u8]) -> Result<Vec<u8>, NbtError> {
    if !bytes.starts_with(&[0x1f, 0x8b]) {
        return Ok(bytes.to_vec());
    }
    let mut out = Vec::new();
    flate2::read::GzDecoder::new(bytes).take(MAX_NBT_BYTES + 1).read_to_end(&mut out).map_err(NbtError::Gzip)?;
    if out.len() as u64 > MAX_NBT_BYTES {
        return Err(NbtError::TooLarge);
    }
    Ok(out)
}

/// The NBT inside a gzip file (or the bytes themselves, when not compressed), within
/// [`MAX_NBT_BYTES`]: what the readers parse.
pub fn nbt_bytes(bytes: &[u8]) -> Result<Vec<u8>, NbtError> {
    decompress(bytes)
}

/// Walks NBT without building it: every length within the data, nesting ≤ [`MAX_DEPTH`],
/// the root a compound.
pub fn scan(data: &[u8]) -> Result<(), NbtError> {
    struct R<'a> {
        d: &'a [u8],
        i: usize,
    }
    impl R<'_> {
        fn take(&mut self, n: usize) -> Result<&[u8], NbtError> {
            let end = self.i.checked_add(n).filter(|&e| e <= self.d.len()).ok_or(NbtError::Truncated)?;
            let s = &self.d[self.i..end];
            self.i = end;
            Ok(s)
        }
        fn u8(&mut self) -> Result<u8, NbtError> {
            Ok(self.take(1)?[0])
        }
        fn u16(&mut self) -> Result<usize, NbtError> {
            let b = self.take(2)?;
            Ok(u16::from_be_bytes([b[0], b[1]]) as usize)
        }
        fn len(&mut self) -> Result<usize, NbtError> {
            let b = self.take(4)?;
            let n = i32::from_be_bytes([b[0], b[1], b[2], b[3]]);
            usize::try_from(n).map_err(|_| NbtError::NegativeLength)
        }
    }
    // A frame: a compound (reads named tags until End) or a list (n more payloads of a type).
    enum Frame {
        Compound,
        List(u8, usize),
    }
    let mut r = R { d: data, i: 0 };
    if r.u8()? != 10 {
        return Err(NbtError::RootNotCompound);
    }
    let n = r.u16()?;
    r.take(n)?;
    let mut stack = vec![Frame::Compound];
    while let Some(top) = stack.last_mut() {
        let tag = match top {
            Frame::Compound => {
                let t = r.u8()?;
                if t == 0 {
                    stack.pop();
                    continue;
                }
                let n = r.u16()?;
                r.take(n)?;
                t
            }
            Frame::List(t, left) => {
                if *left == 0 {
                    stack.pop();
                    continue;
                }
                *left -= 1;
                *t
            }
        };
        match tag {
            1 => drop(r.take(1)?),
            2 => drop(r.take(2)?),
            3 | 5 => drop(r.take(4)?),
            4 | 6 => drop(r.take(8)?),
            7 => {
                let n = r.len()?;
                r.take(n)?;
            }
            8 => {
                let n = r.u16()?;
                r.take(n)?;
            }
            9 => {
                let t = r.u8()?;
                let n = r.len()?;
                if t > 12 || (t == 0 && n > 0) {
                    return Err(NbtError::ListType(t));
                }
                if n > data.len() {
                    return Err(NbtError::ListTooLong);
                }
                stack.push(Frame::List(t, n));
            }
            10 => stack.push(Frame::Compound),
            11 => {
                let n = r.len()?;
                r.take(n.checked_mul(4).ok_or(NbtError::ArrayTooLong)?)?;
            }
            12 => {
                let n = r.len()?;
                r.take(n.checked_mul(8).ok_or(NbtError::ArrayTooLong)?)?;
            }
            t => return Err(NbtError::TagType(t)),
        }
        if stack.len() > MAX_DEPTH {
            return Err(NbtError::TooDeep);
        }
    }
    Ok(())
}

/// Decompresses, scans and deserialises.
fn parse<'a, T: Deserialize<'a>>(data: &'a [u8]) -> Result<T, NbtError> {
    scan(data)?;
    let opts = fastnbt::DeOpts::new().max_seq_len(data.len());
    fastnbt::from_bytes_with_opts(data, opts).map_err(NbtError::Content)
}

/// A block state `name[k=v,…]` (keys sorted) from a name and properties.
fn state_string(name: &str, props: &BTreeMap<String, String>) -> String {
    if props.is_empty() {
        return name.to_string();
    }
    let p: Vec<String> = props.iter().map(|(k, v)| format!("{k}={v}")).collect();
    format!("{name}[{}]", p.join(","))
}

/// Splits `name[k=v,…]` into the name and its properties.
fn split_state(state: &str) -> (String, BTreeMap<String, String>) {
    let mut props = BTreeMap::new();
    let Some((name, rest)) = state.split_once('[') else { return (state.to_string(), props) };
    for kv in rest.trim_end_matches(']').split(',') {
        if let Some((k, v)) = kv.split_once('=') {
            props.insert(k.trim().to_string(), v.trim().to_string());
        }
    }
    (name.to_string(), props)
}

/// The block states of a model's kinds for Minecraft output; an error names the
/// first kind with no Minecraft name.
fn modern_kinds(model: &VoxelModel) -> Result<Vec<String>, NbtWriteError> {
    model
        .kinds
        .iter()
        .map(|k| blocks::to_modern(&k.id).ok_or_else(|| NbtWriteError::NoMinecraftName(k.id.clone())))
        .collect()
}

#[derive(Deserialize)]
struct PaletteState {
    #[serde(rename = "Name")]
    name: String,
    #[serde(rename = "Properties", default)]
    properties: BTreeMap<String, String>,
}

#[derive(Deserialize)]
struct StructureBlock {
    pos: Vec<i32>,
    state: i32,
    /// A block entity's data (a chest's items, a sign's text): not kept.
    #[serde(default)]
    nbt: Option<fastnbt::Value>,
}

#[derive(Deserialize)]
struct Structure {
    #[serde(default)]
    palette: Option<Vec<PaletteState>>,
    #[serde(default)]
    palettes: Option<Vec<Vec<PaletteState>>>,
    blocks: Vec<StructureBlock>,
}

/// Reads a structure-block `.nbt` file (with several palettes, the first is used).
pub fn read_structure(bytes: &[u8]) -> Result<VoxelModel, NbtError> {
    read_structure_notes(bytes).map(|(m, _)| m)
}

/// [`read_structure`], with notes on what the model does not keep: block entities
/// (their data) and explicit air blocks (which clear cells when the structure is
/// placed; the model's empty space does not).
pub fn read_structure_notes(bytes: &[u8]) -> Result<(VoxelModel, Vec<String>), NbtError> {
    let data = decompress(bytes)?;
    let s: Structure = parse(&data)?;
    let palette = match (s.palette, s.palettes) {
        (Some(p), _) => p,
        (None, Some(mut ps)) if !ps.is_empty() => ps.swap_remove(0),
        _ => return Err(NbtError::NoPalette),
    };
    let states: Vec<String> = palette.iter().map(|p| state_string(&p.name, &p.properties)).collect();
    let mut b = ModelBuilder::new();
    let mut kinds: HashMap<usize, u32> = HashMap::new();
    let (mut air, mut entities) = (0usize, 0usize);
    for blk in &s.blocks {
        entities += blk.nbt.is_some() as usize;
        let [x, y, z] = blk.pos[..] else {
            return Err(NbtError::PosLength(blk.pos.len()));
        };
        let idx = usize::try_from(blk.state).ok().filter(|&i| i < states.len()).ok_or(NbtError::StateOutOfRange {
            pos: [x, y, z],
            state: blk.state,
            palette: states.len(),
        })?;
        if blocks::is_air(&states[idx]) {
            air += 1;
            continue;
        }
        let kind = match kinds.get(&idx) {
            Some(k) => *k,
            None => {
                let k = b.kind(&states[idx], None)?;
                kinds.insert(idx, k);
                k
            }
        };
        b.add([x, y, z], kind)?;
    }
    let mut notes = Vec::new();
    if entities > 0 {
        notes.push(format!(
            "{entities} block entities (chest contents, sign text…) are not kept: only block states are"
        ));
    }
    if air > 0 {
        notes.push(format!(
            "{air} explicit air blocks are read as empty space (placing a written file will not clear those cells)"
        ));
    }
    Ok((b.finish()?, notes))
}

#[derive(Serialize)]
struct PaletteOut {
    #[serde(rename = "Name")]
    name: String,
    #[serde(rename = "Properties", skip_serializing_if = "BTreeMap::is_empty")]
    properties: BTreeMap<String, String>,
}

#[derive(Serialize)]
struct BlockOut {
    pos: Vec<i32>,
    state: i32,
}

#[derive(Serialize)]
struct StructureOut {
    #[serde(rename = "DataVersion")]
    data_version: i32,
    size: Vec<i32>,
    palette: Vec<PaletteOut>,
    blocks: Vec<BlockOut>,
    entities: Vec<fastnbt::Value>,
}

fn gzip(data: &[u8]) -> Result<Vec<u8>, NbtWriteError> {
    use std::io::Write as _;
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(data).map_err(NbtWriteError::Gzip)?;
    enc.finish().map_err(NbtWriteError::Gzip)
}

/// Writes a structure-block `.nbt` file (the model moved to the origin).
pub fn write_structure(model: &VoxelModel) -> Result<Vec<u8>, NbtWriteError> {
    let states = modern_kinds(model)?;
    let m = model.normalized();
    let (_, hi) = m.bounds().unwrap_or(([0; 3], [-1; 3]));
    // One palette entry per distinct state, in order of first use.
    let mut index: BTreeMap<&str, i32> = BTreeMap::new();
    let mut palette = Vec::new();
    let mut blocks_out = Vec::with_capacity(m.blocks.len());
    for b in &m.blocks {
        let s = states.get(b.kind as usize).ok_or(NbtWriteError::KindOutOfRange)?;
        let i = match index.get(s.as_str()) {
            Some(i) => *i,
            None => {
                let i = palette.len() as i32;
                let (name, properties) = split_state(s);
                palette.push(PaletteOut { name, properties });
                index.insert(s, i);
                i
            }
        };
        blocks_out.push(BlockOut { pos: b.pos.to_vec(), state: i });
    }
    let out = StructureOut {
        data_version: DATA_VERSION,
        size: vec![hi[0] + 1, hi[1] + 1, hi[2] + 1],
        palette,
        blocks: blocks_out,
        entities: Vec::new(),
    };
    let raw = fastnbt::to_bytes(&out).map_err(NbtWriteError::Encode)?;
    gzip(&raw)
}

#[derive(Deserialize)]
struct SchemBlocks {
    #[serde(rename = "Palette")]
    palette: HashMap<String, i32>,
    #[serde(rename = "Data")]
    data: fastnbt::ByteArray,
    #[serde(rename = "BlockEntities", default)]
    block_entities: Option<Vec<fastnbt::Value>>,
}

#[derive(Deserialize)]
struct Schem {
    #[serde(rename = "Version", default)]
    version: Option<i32>,
    #[serde(rename = "Width", default)]
    width: Option<i16>,
    #[serde(rename = "Height", default)]
    height: Option<i16>,
    #[serde(rename = "Length", default)]
    length: Option<i16>,
    #[serde(rename = "Palette", default)]
    palette: Option<HashMap<String, i32>>,
    #[serde(rename = "BlockData", default)]
    block_data: Option<fastnbt::ByteArray>,
    #[serde(rename = "Blocks", default)]
    blocks: Option<SchemBlocks>,
    #[serde(rename = "BlockEntities", default)]
    block_entities: Option<Vec<fastnbt::Value>>,
    /// Version 3 wraps everything in a `Schematic` compound.
    #[serde(rename = "Schematic", default)]
    schematic: Option<Box<Schem>>,
}

/// Reads a Sponge `.schem` file (version 2 or 3).
pub fn read_schem(bytes: &[u8]) -> Result<VoxelModel, NbtError> {
    read_schem_notes(bytes).map(|(m, _)| m)
}

/// [`read_schem`], with a note on block entities (their data is not kept).
pub fn read_schem_notes(bytes: &[u8]) -> Result<(VoxelModel, Vec<String>), NbtError> {
    let data = decompress(bytes)?;
    let mut s: Schem = parse(&data)?;
    if let Some(inner) = s.schematic.take() {
        s = *inner;
    }
    if let Some(v) = s.version {
        if !(1..=3).contains(&v) {
            return Err(NbtError::Version(v));
        }
    }
    let (Some(w), Some(h), Some(l)) = (s.width, s.height, s.length) else {
        return Err(NbtError::NoSize);
    };
    let (w, h, l) = (w as u16 as usize, h as u16 as usize, l as u16 as usize);
    let cells = (w as u64) * (h as u64) * (l as u64);
    if cells > crate::voxel::MAX_CELLS {
        return Err(NbtError::SchemTooLarge { size: [w, h, l], cells });
    }
    let mut entities = s.block_entities.as_ref().map_or(0, |v| v.len());
    let (palette, block_data) = match (s.palette, s.block_data, s.blocks) {
        (Some(p), Some(d), _) => (p, d),
        (_, _, Some(b)) => {
            entities += b.block_entities.as_ref().map_or(0, |v| v.len());
            (b.palette, b.data)
        }
        _ => return Err(NbtError::NoBlockData),
    };
    let mut states: BTreeMap<i32, String> = BTreeMap::new();
    for (state, i) in palette {
        if states.insert(i, state).is_some() {
            return Err(NbtError::IndexTwice(i));
        }
    }
    let mut b = ModelBuilder::new();
    let mut kinds: HashMap<i32, Option<u32>> = HashMap::new();
    let bytes: Vec<u8> = block_data.iter().map(|v| *v as u8).collect();
    let (mut at, mut cell) = (0usize, 0usize);
    while at < bytes.len() {
        // Varint (LEB128, at most 5 bytes).
        let mut value: u32 = 0;
        let mut shift = 0;
        loop {
            let byte = *bytes.get(at).ok_or(NbtError::TruncatedBlockData)?;
            at += 1;
            value |= ((byte & 0x7f) as u32) << shift;
            if byte & 0x80 == 0 {
                break;
            }
            shift += 7;
            if shift > 28 {
                return Err(NbtError::Varint);
            }
        }
        if cell >= w * h * l {
            return Err(NbtError::MoreBlockData);
        }
        let idx = value as i32;
        let kind = match kinds.get(&idx) {
            Some(k) => *k,
            None => {
                let state = states.get(&idx).ok_or(NbtError::IndexNotInPalette(idx))?;
                let k = if blocks::is_air(state) { None } else { Some(b.kind(state, None)?) };
                kinds.insert(idx, k);
                k
            }
        };
        if let Some(k) = kind {
            let x = cell % w;
            let z = (cell / w) % l;
            let y = cell / (w * l);
            b.add([x as i32, y as i32, z as i32], k)?;
        }
        cell += 1;
    }
    if cell != w * h * l {
        return Err(NbtError::BlockDataCount { entries: cell, cells: w * h * l });
    }
    let notes = if entities > 0 {
        vec![format!("{entities} block entities (chest contents, sign text…) are not kept: only block states are")]
    } else {
        Vec::new()
    };
    Ok((b.finish()?, notes))
}

#[derive(Serialize)]
struct SchemOut {
    #[serde(rename = "Version")]
    version: i32,
    #[serde(rename = "DataVersion")]
    data_version: i32,
    #[serde(rename = "Width")]
    width: i16,
    #[serde(rename = "Height")]
    height: i16,
    #[serde(rename = "Length")]
    length: i16,
    #[serde(rename = "Offset")]
    offset: fastnbt::IntArray,
    #[serde(rename = "PaletteMax")]
    palette_max: i32,
    #[serde(rename = "Palette")]
    palette: BTreeMap<String, i32>,
    #[serde(rename = "BlockData")]
    block_data: fastnbt::ByteArray,
    #[serde(rename = "BlockEntities")]
    block_entities: Vec<fastnbt::Value>,
    /// WorldEdit's paste offset; older WorldEdit versions refuse a schematic without it.
    #[serde(rename = "Metadata")]
    metadata: SchemMetadata,
}

#[derive(Serialize)]
struct SchemMetadata {
    #[serde(rename = "WEOffsetX")]
    x: i32,
    #[serde(rename = "WEOffsetY")]
    y: i32,
    #[serde(rename = "WEOffsetZ")]
    z: i32,
}

/// Writes a Sponge schematic, version 2 (the model moved to the origin).
pub fn write_schem(model: &VoxelModel) -> Result<Vec<u8>, NbtWriteError> {
    let states = modern_kinds(model)?;
    let m = model.normalized();
    let (_, hi) = m.bounds().unwrap_or(([0; 3], [0; 3]));
    let (w, h, l) = ((hi[0] + 1) as usize, (hi[1] + 1) as usize, (hi[2] + 1) as usize);
    if w > 65535 || h > 65535 || l > 65535 {
        return Err(NbtWriteError::SchemTooLarge);
    }
    let mut palette: BTreeMap<String, i32> = BTreeMap::new();
    palette.insert("minecraft:air".into(), 0);
    let mut kind_index = vec![0i32; states.len()];
    for (k, s) in states.iter().enumerate() {
        let next = palette.len() as i32;
        kind_index[k] = *palette.entry(s.clone()).or_insert(next);
    }
    let mut cells = vec![0i32; w * h * l];
    for b in &m.blocks {
        let i = (b.pos[1] as usize * l + b.pos[2] as usize) * w + b.pos[0] as usize;
        cells[i] = kind_index.get(b.kind as usize).copied().ok_or(NbtWriteError::KindOutOfRange)?;
    }
    let mut data: Vec<i8> = Vec::with_capacity(cells.len());
    for mut v in cells.into_iter().map(|c| c as u32) {
        loop {
            let byte = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                data.push(byte as i8);
                break;
            }
            data.push((byte | 0x80) as i8);
        }
    }
    let out = SchemOut {
        version: 2,
        data_version: DATA_VERSION,
        width: w as u16 as i16,
        height: h as u16 as i16,
        length: l as u16 as i16,
        offset: fastnbt::IntArray::new(vec![0, 0, 0]),
        palette_max: palette.len() as i32,
        palette,
        block_data: fastnbt::ByteArray::new(data),
        block_entities: Vec::new(),
        metadata: SchemMetadata { x: 0, y: 0, z: 0 },
    };
    let raw = fastnbt::to_bytes_with_opts(&out, fastnbt::SerOpts::new().root_name("Schematic"))
        .map_err(NbtWriteError::Encode)?;
    gzip(&raw)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> VoxelModel {
        crate::format::text::read("0 0 0 1:0\n1 0 0 5:5\n1 1 0 53:1\n0 0 2 minecraft:glass\n").expect("text")
    }

    fn ids(m: &VoxelModel) -> Vec<([i32; 3], String)> {
        let mut v: Vec<_> =
            m.normalized().blocks.iter().map(|b| (b.pos, m.kinds[b.kind as usize].id.clone())).collect();
        v.sort();
        v
    }

    #[test]
    fn structure_and_schem_round_trip() {
        let m = sample();
        let want: Vec<([i32; 3], String)> =
            ids(&m).into_iter().map(|(p, id)| (p, blocks::to_modern(&id).expect("modern").to_string())).collect();
        let s = write_structure(&m).expect("nbt");
        assert_eq!(ids(&read_structure(&s).expect("reads nbt")), want);
        let c = write_schem(&m).expect("schem");
        assert_eq!(ids(&read_schem(&c).expect("reads schem")), want);
        assert_eq!(write_schem(&m).expect("again"), c, "deterministic");
    }

    #[test]
    fn schematics_carry_worldedit_metadata_and_readers_note_what_they_drop() {
        let c = write_schem(&sample()).expect("schem");
        let raw = decompress(&c).expect("gunzip");
        let v: fastnbt::Value = fastnbt::from_bytes(&raw).expect("nbt");
        let fastnbt::Value::Compound(root) = v else { panic!("a compound") };
        let Some(fastnbt::Value::Compound(meta)) = root.get("Metadata") else { panic!("Metadata: {root:?}") };
        assert_eq!(meta.get("WEOffsetX"), Some(&fastnbt::Value::Int(0)));
        assert!(meta.contains_key("WEOffsetY") && meta.contains_key("WEOffsetZ"));
        // A structure with an explicit air block and a chest holding items.
        #[derive(Serialize)]
        struct B {
            pos: Vec<i32>,
            state: i32,
            #[serde(skip_serializing_if = "Option::is_none")]
            nbt: Option<fastnbt::Value>,
        }
        #[derive(Serialize)]
        struct S {
            size: Vec<i32>,
            palette: Vec<PaletteOut>,
            blocks: Vec<B>,
        }
        let items = fastnbt::Value::Compound(Default::default());
        let s = S {
            size: vec![2, 1, 1],
            palette: vec![
                PaletteOut { name: "minecraft:air".into(), properties: BTreeMap::new() },
                PaletteOut { name: "minecraft:chest".into(), properties: BTreeMap::new() },
            ],
            blocks: vec![
                B { pos: vec![0, 0, 0], state: 0, nbt: None },
                B { pos: vec![1, 0, 0], state: 1, nbt: Some(items) },
            ],
        };
        let bytes = gzip(&fastnbt::to_bytes(&s).expect("encode")).expect("gzip");
        let (m, notes) = read_structure_notes(&bytes).expect("reads");
        assert_eq!(m.blocks.len(), 1);
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].contains("1 block entities") && notes[1].contains("1 explicit air"), "{notes:?}");
        // Nothing to say about a plain structure.
        assert!(read_structure_notes(&write_structure(&sample()).expect("nbt")).expect("reads").1.is_empty());
    }

    #[test]
    fn corrupt_and_hostile_nbt_is_rejected() {
        let s = write_structure(&sample()).expect("nbt");
        let raw = decompress(&s).expect("gunzip");
        for cut in [0, 1, 5, raw.len() / 2, raw.len() - 1] {
            assert!(read_structure(&raw[..cut]).is_err(), "truncated at {cut}");
        }
        assert!(read_structure(&s[..s.len() / 2]).is_err());
        // Lists nested 10,000 deep: rejected by the scanner, not by a stack overflow.
        let mut deep = vec![10u8, 0, 0, 9, 0, 1, b'a'];
        for _ in 0..10_000 {
            deep.extend_from_slice(&[9, 0, 0, 0, 1]);
        }
        let e = scan(&deep).expect_err("an error");
        assert!(matches!(e, NbtError::TooDeep), "{e:?}");
        assert_eq!(e.to_string(), "NBT nested deeper than 512");
        let mut deep2 = vec![10u8, 0, 0];
        for _ in 0..10_000 {
            deep2.extend_from_slice(&[10, 0, 1, b'a']);
        }
        assert!(matches!(scan(&deep2), Err(NbtError::TooDeep)));
        assert!(matches!(read_schem(b"\x1f\x8b garbage"), Err(NbtError::Gzip(_))));
        assert!(matches!(scan(&[10, 0, 0, 13, 0, 0]), Err(NbtError::TagType(13))));
        assert!(matches!(read_structure(&[1, 0, 0, 0]), Err(NbtError::RootNotCompound)));
    }
}
