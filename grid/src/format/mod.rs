//! Voxel file formats: plain text (`x y z block` a line), MagicaVoxel `.vox`, Minecraft
//! structure-block `.nbt` and Sponge `.schem`. Readers reject corrupt or oversized
//! input with an error message (never a panic); writers are deterministic.

pub mod nbt;
pub mod text;
pub mod vox;

use super::voxel::VoxelModel;
use std::path::Path;

/// The most bytes a voxel file may have (compressed or not).
pub const MAX_FILE_BYTES: u64 = 64 * 1024 * 1024;

/// A voxel file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoxelFormat {
    /// `x y z block` lines, `#` comments (`.txt`).
    Text,
    /// MagicaVoxel (`.vox`).
    Vox,
    /// Minecraft structure block, gzip NBT (`.nbt`).
    Nbt,
    /// Sponge schematic v2/v3, gzip NBT (`.schem`).
    Schem,
}

impl VoxelFormat {
    /// Every format.
    pub const ALL: [VoxelFormat; 4] = [VoxelFormat::Text, VoxelFormat::Vox, VoxelFormat::Nbt, VoxelFormat::Schem];

    /// The format for a file extension (case-insensitive, without the dot).
    pub fn from_extension(ext: &str) -> Option<VoxelFormat> {
        let ext = ext.to_ascii_lowercase();
        VoxelFormat::ALL.into_iter().find(|f| f.extension() == ext)
    }

    /// The format of a path, from its extension.
    pub fn from_path(path: &Path) -> Option<VoxelFormat> {
        path.extension().and_then(|e| e.to_str()).and_then(VoxelFormat::from_extension)
    }

    /// The canonical extension.
    pub fn extension(self) -> &'static str {
        match self {
            VoxelFormat::Text => "txt",
            VoxelFormat::Vox => "vox",
            VoxelFormat::Nbt => "nbt",
            VoxelFormat::Schem => "schem",
        }
    }
}

/// Reads a voxel model from bytes in `format`.
pub fn read_bytes(format: VoxelFormat, bytes: &[u8]) -> Result<VoxelModel, String> {
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(format!("file is larger than {MAX_FILE_BYTES} bytes"));
    }
    match format {
        VoxelFormat::Text => {
            let text = std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?;
            text::read(text).map_err(|e| e.to_string())
        }
        VoxelFormat::Vox => vox::read(bytes).map_err(|e| e.to_string()),
        VoxelFormat::Nbt => nbt::read_structure(bytes),
        VoxelFormat::Schem => nbt::read_schem(bytes),
    }
}

/// The bytes of a voxel file: a regular file of at most [`MAX_FILE_BYTES`].
fn read_file(path: &Path) -> Result<Vec<u8>, String> {
    mdg_vm::input::read_bounded(path, MAX_FILE_BYTES).map_err(|e| match e {
        mdg_vm::input::ReadError::TooLarge { .. } => format!("{}: larger than {MAX_FILE_BYTES} bytes", path.display()),
        e => format!("cannot read {}: {e}", path.display()),
    })
}

/// Reads the voxel file at `path` (format from the extension).
pub fn read(path: &Path) -> Result<VoxelModel, String> {
    let format = VoxelFormat::from_path(path)
        .ok_or_else(|| format!("{}: unknown voxel format (expected .txt, .vox, .nbt or .schem)", path.display()))?;
    let bytes = read_file(path)?;
    read_bytes(format, &bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads a voxel file, with notes on what the model does not keep (block entities,
/// explicit air) for the caller to show as warnings.
pub fn read_with_notes(path: &Path) -> Result<(VoxelModel, Vec<String>), String> {
    let format = VoxelFormat::from_path(path)
        .ok_or_else(|| format!("{}: unknown voxel format (expected .txt, .vox, .nbt or .schem)", path.display()))?;
    let at = |e: String| format!("{}: {e}", path.display());
    match format {
        VoxelFormat::Nbt | VoxelFormat::Schem => {
            let bytes = read_file(path)?;
            let r = if format == VoxelFormat::Nbt {
                nbt::read_structure_notes(&bytes)
            } else {
                nbt::read_schem_notes(&bytes)
            };
            r.map_err(at)
        }
        _ => read(path).map(|m| (m, Vec::new())),
    }
}

/// Minecraft's build height (y from −64 to 319): a taller `.nbt` or `.schem` cannot be
/// placed whole.
pub const BUILD_HEIGHT: i32 = 384;
/// The largest structure a structure block saves or loads, along each axis.
pub const STRUCTURE_BLOCK_MAX: i32 = 48;

/// Warnings for writing `model` as `format`: Minecraft formats taller than the build
/// height, structure files over the structure block's 48 blocks along an axis (they
/// still load with commands such as `/place template`).
pub fn write_notes(format: VoxelFormat, model: &VoxelModel) -> Vec<String> {
    let Some((lo, hi)) = model.bounds() else { return Vec::new() };
    let size = [hi[0] - lo[0] + 1, hi[1] - lo[1] + 1, hi[2] - lo[2] + 1];
    let mut notes = Vec::new();
    if matches!(format, VoxelFormat::Nbt | VoxelFormat::Schem) && size[1] > BUILD_HEIGHT {
        notes.push(format!("the building is {} blocks tall, over Minecraft's build height of {BUILD_HEIGHT}", size[1]));
    }
    if format == VoxelFormat::Nbt && size.iter().any(|&e| e > STRUCTURE_BLOCK_MAX) {
        notes.push(format!(
            "the structure is {}×{}×{}: a structure block loads at most {STRUCTURE_BLOCK_MAX} along each axis \
             (use /place template, or write .schem)",
            size[0], size[1], size[2]
        ));
    }
    notes
}

/// Writes a voxel model in `format`. Doors joined for induction (`LOWER+UPPER`, see
/// [`super::doors::merge_doors`]) are written as their two halves.
pub fn write(format: VoxelFormat, model: &VoxelModel) -> Result<Vec<u8>, String> {
    let split;
    let model = if model.kinds.iter().any(|k| k.id.contains(super::blocks::DOOR_JOIN)) {
        split = super::doors::split_doors(model).0;
        &split
    } else {
        model
    };
    match format {
        VoxelFormat::Text => Ok(text::write(model).into_bytes()),
        VoxelFormat::Vox => vox::write(model).map_err(|e| e.to_string()),
        VoxelFormat::Nbt => nbt::write_structure(model),
        VoxelFormat::Schem => nbt::write_schem(model),
    }
}
