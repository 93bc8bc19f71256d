//! Voxel file formats: plain text (`x y z block` a line), MagicaVoxel `.vox`, Minecraft
//! structure-block `.nbt` and Sponge `.schem`. Readers reject corrupt or oversized
//! input with an error message (never a panic); writers are deterministic.

pub mod nbt;
pub mod text;
pub mod vox;

use super::voxel::VoxelModel;
use std::path::{Path, PathBuf};

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

/// Why bytes are not a voxel model in their format ([`read_bytes`]).
#[derive(Debug)]
pub enum DecodeError {
    /// More than [`MAX_FILE_BYTES`].
    TooLarge,
    /// A text file that is not UTF-8.
    NotUtf8(std::str::Utf8Error),
    /// The text reader's refusal.
    Text(text::TextError),
    /// The `.vox` reader's refusal.
    Vox(vox::VoxReadError),
    /// The `.nbt` or `.schem` reader's refusal.
    Nbt(nbt::NbtError),
}

impl std::fmt::Display for DecodeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DecodeError::TooLarge => write!(f, "file is larger than {MAX_FILE_BYTES} bytes"),
            DecodeError::NotUtf8(e) => write!(f, "not UTF-8 text: {e}"),
            DecodeError::Text(e) => write!(f, "{e}"),
            DecodeError::Vox(e) => write!(f, "{e}"),
            DecodeError::Nbt(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for DecodeError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            DecodeError::TooLarge => None,
            DecodeError::NotUtf8(e) => Some(e),
            DecodeError::Text(e) => Some(e),
            DecodeError::Vox(e) => Some(e),
            DecodeError::Nbt(e) => Some(e),
        }
    }
}

/// Why a voxel file could not be read ([`read`], [`read_with_notes`]); each names
/// the file.
#[derive(Debug)]
pub enum ReadError {
    /// An extension that names no voxel format.
    UnknownFormat { path: PathBuf },
    /// A file over [`MAX_FILE_BYTES`].
    TooLarge { path: PathBuf },
    /// The file could not be read (missing, not a regular file, an IO error).
    File { path: PathBuf, source: mdg_vm::input::ReadError },
    /// The file's bytes are not a model in its format.
    Decode { path: PathBuf, error: DecodeError },
}

impl ReadError {
    /// Whether the file could not be read (rather than read and refused): a usage
    /// or IO error for a command, where the others are errors in the input.
    pub fn is_io(&self) -> bool {
        matches!(self, ReadError::File { .. } | ReadError::TooLarge { .. } | ReadError::UnknownFormat { .. })
    }
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::UnknownFormat { path } => {
                write!(f, "{}: unknown voxel format (expected .txt, .vox, .nbt or .schem)", path.display())
            }
            ReadError::TooLarge { path } => write!(f, "{}: larger than {MAX_FILE_BYTES} bytes", path.display()),
            ReadError::File { path, source } => write!(f, "cannot read {}: {source}", path.display()),
            ReadError::Decode { path, error } => write!(f, "{}: {error}", path.display()),
        }
    }
}

impl std::error::Error for ReadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ReadError::Decode { error, .. } => Some(error),
            _ => None,
        }
    }
}

/// Reads a voxel model from bytes in `format`.
pub fn read_bytes(format: VoxelFormat, bytes: &[u8]) -> Result<VoxelModel, DecodeError> {
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(DecodeError::TooLarge);
    }
    match format {
        VoxelFormat::Text => {
            let text = std::str::from_utf8(bytes).map_err(DecodeError::NotUtf8)?;
            text::read(text).map_err(DecodeError::Text)
        }
        VoxelFormat::Vox => vox::read(bytes).map_err(DecodeError::Vox),
        VoxelFormat::Nbt => nbt::read_structure(bytes).map_err(DecodeError::Nbt),
        VoxelFormat::Schem => nbt::read_schem(bytes).map_err(DecodeError::Nbt),
    }
}

/// The bytes of a voxel file: a regular file of at most [`MAX_FILE_BYTES`].
fn read_file(path: &Path) -> Result<Vec<u8>, ReadError> {
    mdg_vm::input::read_bounded(path, MAX_FILE_BYTES).map_err(|e| match e {
        mdg_vm::input::ReadError::TooLarge { .. } => ReadError::TooLarge { path: path.to_path_buf() },
        source => ReadError::File { path: path.to_path_buf(), source },
    })
}

/// The format of `path`, from its extension.
fn format_of(path: &Path) -> Result<VoxelFormat, ReadError> {
    VoxelFormat::from_path(path).ok_or_else(|| ReadError::UnknownFormat { path: path.to_path_buf() })
}

/// Reads the voxel file at `path` (format from the extension).
pub fn read(path: &Path) -> Result<VoxelModel, ReadError> {
    let format = format_of(path)?;
    let bytes = read_file(path)?;
    read_bytes(format, &bytes).map_err(|error| ReadError::Decode { path: path.to_path_buf(), error })
}

/// Reads a voxel file, with notes on what the model does not keep (block entities,
/// explicit air) for the caller to show as warnings.
pub fn read_with_notes(path: &Path) -> Result<(VoxelModel, Vec<String>), ReadError> {
    let format = format_of(path)?;
    match format {
        VoxelFormat::Nbt | VoxelFormat::Schem => {
            let bytes = read_file(path)?;
            let r = if format == VoxelFormat::Nbt {
                nbt::read_structure_notes(&bytes)
            } else {
                nbt::read_schem_notes(&bytes)
            };
            r.map_err(|e| ReadError::Decode { path: path.to_path_buf(), error: DecodeError::Nbt(e) })
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

/// Why a model cannot be written in a format ([`write`]).
#[derive(Debug)]
pub enum WriteError {
    /// The `.vox` writer's refusal.
    Vox(vox::VoxWriteError),
    /// The `.nbt` or `.schem` writer's refusal.
    Nbt(nbt::NbtWriteError),
}

impl std::fmt::Display for WriteError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            WriteError::Vox(e) => write!(f, "{e}"),
            WriteError::Nbt(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for WriteError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            WriteError::Vox(e) => Some(e),
            WriteError::Nbt(e) => Some(e),
        }
    }
}

/// Writes a voxel model in `format`. Doors joined for induction (`LOWER+UPPER`, see
/// [`super::doors::merge_doors`]) are written as their two halves.
pub fn write(format: VoxelFormat, model: &VoxelModel) -> Result<Vec<u8>, WriteError> {
    let split;
    let model = if model.kinds.iter().any(|k| k.id.contains(super::blocks::DOOR_JOIN)) {
        split = super::doors::split_doors(model).0;
        &split
    } else {
        model
    };
    match format {
        VoxelFormat::Text => Ok(text::write(model).into_bytes()),
        VoxelFormat::Vox => vox::write(model).map_err(WriteError::Vox),
        VoxelFormat::Nbt => nbt::write_structure(model).map_err(WriteError::Nbt),
        VoxelFormat::Schem => nbt::write_schem(model).map_err(WriteError::Nbt),
    }
}
