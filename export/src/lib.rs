//! Exporters: an evaluation's [`Output`] written as glTF binary, OBJ, STL, PLY or the
//! JSON inspection dump, plus an atomic file writer.
//!
//! Every format writes triangles through [`Mesh::oriented_triangles`], so triangles
//! emitted in mirrored frames get their winding reversed and face outward (SPEC
//! resolved semantics 8). Formats without instancing walk [`Output::for_each_piece`],
//! which expands instances one at a time as the file is written.
//! All writers are deterministic: the same output gives the same bytes.

pub mod durable;
mod error;
pub mod glb;
pub mod json;
pub mod obj;
pub mod ply;
mod sites;
pub mod stl;
mod text;

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

use glam::Vec3;

use mdg_vm::output::{Mesh, Output};

pub use error::ExportError;

/// An output file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// glTF 2.0 binary (`.glb`), with shared meshes instanced by nodes.
    Glb,
    /// Wavefront OBJ with vertex colours (`.obj`).
    Obj,
    /// Binary STL (`.stl`).
    Stl,
    /// Binary little-endian PLY with colours (`.ply`).
    Ply,
    /// The JSON inspection dump (`.json`).
    Json,
}

impl Format {
    /// Every format, in a fixed order.
    pub const ALL: [Format; 5] = [Format::Glb, Format::Obj, Format::Stl, Format::Ply, Format::Json];

    /// The format for a file extension (case-insensitive, with or without the dot).
    pub fn from_extension(ext: &str) -> Option<Format> {
        let ext = ext.strip_prefix('.').unwrap_or(ext).to_ascii_lowercase();
        Format::ALL.into_iter().find(|f| f.extension() == ext)
    }

    /// The format for a path, from its extension.
    pub fn from_path(path: &Path) -> Option<Format> {
        path.extension().and_then(|e| e.to_str()).and_then(Format::from_extension)
    }

    /// The canonical file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Glb => "glb",
            Format::Obj => "obj",
            Format::Stl => "stl",
            Format::Ply => "ply",
            Format::Json => "json",
        }
    }
}

/// Appends `out` in `format` to `buf`.
pub fn write(format: Format, out: &Output, buf: &mut Vec<u8>) -> Result<(), ExportError> {
    write_to(format, out, buf)
}

/// Writes `out` in `format` to `w`. Every format streams: instances are expanded
/// as the file is written, and no copy of the model is held in memory (the `.glb`
/// assembles its binary chunk first).
pub fn write_to(format: Format, out: &Output, w: &mut dyn std::io::Write) -> Result<(), ExportError> {
    write_with(format, out, &glb::GlbOptions::default(), w)
}

/// [`write_to`] with the glTF writer's options.
pub fn write_with(
    format: Format,
    out: &Output,
    glb_opts: &glb::GlbOptions,
    w: &mut dyn std::io::Write,
) -> Result<(), ExportError> {
    match format {
        Format::Glb => glb::write_glb_with(out, glb_opts, w),
        Format::Obj => obj::write_obj_to(out, w),
        Format::Stl => stl::write_stl_to(out, w),
        Format::Ply => ply::write_ply_to(out, w),
        Format::Json => json::write_json_to(out, w),
    }
}

/// Writes `out` in `format` to the file `path`, atomically (see [`write_atomic_with`]);
/// the error says `cannot write PATH: …`. Every format is streamed into the file
/// (see [`write_to`]).
pub fn write_file(format: Format, out: &Output, path: &Path) -> Result<(), ExportError> {
    write_file_with(format, out, &glb::GlbOptions::default(), path)
}

/// [`write_file`] with the glTF writer's options.
pub fn write_file_with(
    format: Format,
    out: &Output,
    glb_opts: &glb::GlbOptions,
    path: &Path,
) -> Result<(), ExportError> {
    let mut failed = None;
    let r = write_atomic_with(path, &mut |file| {
        let mut w = FileWriter(std::io::BufWriter::with_capacity(1 << 20, file));
        let res = write_with(format, out, glb_opts, &mut w);
        if let Err(e) = res {
            let io = std::io::Error::other(e.to_string());
            failed = Some(e);
            return Err(io);
        }
        w.flush()
    });
    let source = match (r, failed) {
        (Ok(()), _) => return Ok(()),
        (Err(_), Some(e)) => e,
        (Err(e), None) => ExportError::Io(e),
    };
    Err(ExportError::File { path: path.to_path_buf(), source: Box::new(source) })
}

/// Writes of at least this many bytes bypass [`FileWriter`]'s buffer.
const DIRECT_BYTES: usize = 1 << 16;

/// The file writer of [`write_file_with`]: a `BufWriter` that hands a big write
/// (at least [`DIRECT_BYTES`], such as the `.glb` writer's records gathered a MiB
/// at a time, or its spooled flat geometry) to the file straight after the bytes it
/// holds, instead of copying it into its buffer first: `BufWriter` copies every
/// write that fits in its spare capacity, which for a `.glb` of instances was as
/// many byte copies as the file has bytes. Small writes are buffered as before.
struct FileWriter<W: Write>(std::io::BufWriter<W>);

impl<W: Write> Write for FileWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.len() < DIRECT_BYTES {
            return self.0.write(buf);
        }
        self.0.flush()?;
        self.0.get_mut().write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        if buf.len() < DIRECT_BYTES {
            return self.0.write_all(buf);
        }
        self.0.flush()?;
        self.0.get_mut().write_all(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// Distinguishes temporary files of concurrent writers in one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically: into a temporary file in the same directory
/// (named after the target, the process id and a counter), flushed to disk, then
/// renamed over `path`. Readers see the old file or the whole new one, never a part.
/// See [`write_atomic_with`] for symlinks, modes and devices.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, &mut |file| file.write_all(bytes))
}

/// Follows `path` through symlinks (up to 40, as the kernel does) to the file they
/// name, which need not exist yet: writing over a symlink writes its target and
/// keeps the link.
pub fn resolve_symlinks(path: &Path) -> std::io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let target = std::fs::read_link(&p)?;
                p = match p.parent() {
                    Some(d) if target.is_relative() => d.join(target),
                    _ => target,
                };
            }
            _ => return Ok(p),
        }
    }
    Err(std::io::Error::other(format!("{}: too many levels of symbolic links", path.display())))
}

/// Whether `a` and `b` are the same existing file (same device and inode on Unix,
/// the same canonical path elsewhere). Used to refuse an output that is an input.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        matches!((std::fs::canonicalize(a), std::fs::canonicalize(b)), (Ok(x), Ok(y)) if x == y)
    }
}

/// Like [`write_atomic`], with the content written by `fill` into the temporary file.
///
/// * A symlink is followed: its target is replaced, the link stays.
/// * An existing file keeps its permissions (a 0600 file stays 0600) and, where the
///   process may, its owner and group.
/// * A character device (`/dev/null`, `/dev/full`) or a named pipe is written
///   through, not replaced by a regular file (a pipe without a reader is refused
///   instead of blocking); a directory or any other kind of file is refused.
pub fn write_atomic_with(
    path: &Path,
    fill: &mut dyn FnMut(&mut std::fs::File) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let path = &resolve_symlinks(path)?;
    let existing = std::fs::metadata(path).ok();
    if let Some(m) = &existing {
        if !m.is_file() {
            return write_through(path, m, fill);
        }
    }
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{} has no file name", path.display()))
    })?;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!(".{}.{}.{n}.tmp", name.to_string_lossy(), std::process::id()));
    let result = (|| {
        let mut file = std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        if let Some(m) = &existing {
            file.set_permissions(m.permissions())?;
            #[cfg(unix)]
            {
                use std::os::unix::fs::MetadataExt;
                // Only root may give a file away; others keep their own (best effort).
                let _ = std::os::unix::fs::fchown(&file, Some(m.uid()), Some(m.gid()));
            }
        }
        fill(&mut file)?;
        // (A thread that defers its writes finishes them later: `durable`.)
        let Some(file) = durable::defer(file, &tmp, path, dir) else { return Ok(false) };
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path).map(|()| true)
    })();
    match result {
        Err(e) => {
            // Best effort: the temporary file is garbage either way.
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
        Ok(false) => Ok(()),
        Ok(true) => {
            settle(dir, path);
            Ok(())
        }
    }
}

/// After `path` was renamed into place in `dir`: makes the rename itself durable
/// where the platform allows syncing a directory, and removes the temporary files
/// earlier writers of it left.
fn settle(dir: &Path, path: &Path) {
    #[cfg(unix)]
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    if let Some(name) = path.file_name() {
        remove_stale_temporaries(dir, &name.to_string_lossy());
    }
}

/// Removes the temporary files an earlier writer of `name` left in `dir` when it was
/// killed (`.NAME.PID.N.tmp` whose process no longer runs): the next successful write
/// of a file cleans up after the runs of it that died. Only on Linux, where a
/// process's liveness is `/proc/PID`; a temporary file of a live writer is never
/// touched. A directory is listed once per process (a batch writes thousands of files
/// into one), when it is first written to.
fn remove_stale_temporaries(dir: &Path, name: &str) {
    if !cfg!(target_os = "linux") || !Path::new("/proc/self").exists() {
        return;
    }
    static STALE: Mutex<BTreeMap<PathBuf, HashMap<String, Vec<PathBuf>>>> = Mutex::new(BTreeMap::new());
    let mut stale = STALE.lock().unwrap_or_else(|e| e.into_inner());
    let found = stale.entry(dir.to_path_buf()).or_insert_with(|| stale_temporaries(dir));
    for p in found.remove(name).unwrap_or_default() {
        let _ = std::fs::remove_file(p);
    }
}

/// The temporary files in `dir` whose writer no longer runs, by the name of the file
/// they were written for.
fn stale_temporaries(dir: &Path) -> HashMap<String, Vec<PathBuf>> {
    let mut out: HashMap<String, Vec<PathBuf>> = HashMap::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries.flatten() {
        let file = e.file_name();
        // `.NAME.PID.N.tmp`, read from the right (NAME may hold dots).
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix('.')).and_then(|f| f.strip_suffix(".tmp")) else {
            continue;
        };
        let Some((rest, n)) = rest.rsplit_once('.') else { continue };
        let Some((name, pid)) = rest.rsplit_once('.') else { continue };
        let (Ok(pid), true) = (pid.parse::<u32>(), !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit())) else {
            continue;
        };
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            out.entry(name.to_string()).or_default().push(e.path());
        }
    }
    out
}

/// Writes into an existing file that is not a regular file: character devices and
/// named pipes (opened without blocking, so a pipe nobody reads is an error); the
/// rest is refused.
fn write_through(
    path: &Path,
    m: &std::fs::Metadata,
    fill: &mut dyn FnMut(&mut std::fs::File) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let refuse = |what: &str| -> std::io::Result<()> {
        Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{what}, not a file to write")))
    };
    if m.is_dir() {
        return refuse("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
        let t = m.file_type();
        if t.is_char_device() || t.is_fifo() {
            if t.is_fifo() {
                // Probe without blocking: a pipe nobody reads is an error, not a hang.
                let probe = std::fs::OpenOptions::new().write(true).custom_flags(libc::O_NONBLOCK).open(path);
                if let Err(e) = probe {
                    return Err(if e.raw_os_error() == Some(libc::ENXIO) {
                        std::io::Error::other("a named pipe that nobody reads")
                    } else {
                        e
                    });
                }
            }
            // A reader is there (or it is a device): blocking writes from here on.
            let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
            fill(&mut file)?;
            return file.flush();
        }
        if t.is_block_device() {
            return refuse("a block device");
        }
        if t.is_socket() {
            return refuse("a socket");
        }
    }
    refuse("not a regular file")
}

/// A finite float (non-finite values become 0, which every format can store).
pub(crate) fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

/// A position with non-finite components replaced by 0.
pub(crate) fn finite3(p: [f32; 3]) -> [f32; 3] {
    p.map(finite)
}

/// A unit normal; zero-length or non-finite normals become +z.
pub(crate) fn unit_normal(n: [f32; 3]) -> [f32; 3] {
    let v = Vec3::from(n);
    if v.is_finite() {
        v.normalize_or(Vec3::Z).to_array()
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// A colour clamped to 0..1 (NaN becomes 0).
pub(crate) fn clamp_color(c: [f32; 4]) -> [f32; 4] {
    c.map(|x| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) })
}

/// An sRGB-encoded (display) channel value in 0..1 as linear light (IEC 61966-2-1).
/// MDG colours are display values, as the picture shows them; glTF's vertex colours
/// and `baseColorFactor` are linear, so the glTF writer converts with this.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The inverse of [`srgb_to_linear`]: a linear channel value in 0..1 as sRGB.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// A clamped display colour with its RGB channels made linear (alpha is linear already).
pub(crate) fn linear_color(c: [f32; 4]) -> [f32; 4] {
    let c = clamp_color(c);
    [srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2]), c[3]]
}

/// MDG space (z up) turned to the y-up convention of glTF and OBJ: a −90° rotation
/// about x, (x, y, z) → (x, z, −y). STL and PLY stay z up.
pub fn z_up_to_y_up(p: [f32; 3]) -> [f32; 3] {
    [p[0], p[2], -p[1]]
}

/// Whether the oriented triangles `tris` of `m` form closed surfaces: after welding
/// vertices at bit-identical positions, every directed edge a→b is matched by as many
/// b→a (each edge is shared by faces on both sides). Open surfaces (a leaf, a
/// sheet) are seen from behind, so their materials are written double-sided.
pub fn is_closed(m: &Mesh, tris: &[[u32; 3]]) -> bool {
    if tris.is_empty() {
        return true;
    }
    // Weld by position bits (−0 and +0 alike): sort (position, index) pairs once,
    // give equal positions one id.
    let bits = |p: &[f32; 3]| p.map(|x| if x == 0.0 { 0 } else { x.to_bits() });
    let mut order: Vec<([u32; 3], u32)> = m.positions.iter().enumerate().map(|(i, p)| (bits(p), i as u32)).collect();
    order.sort_unstable();
    let mut id = vec![0u32; m.positions.len()];
    let mut next = 0u32;
    for (k, &(key, i)) in order.iter().enumerate() {
        if k > 0 && key != order[k - 1].0 {
            next += 1;
        }
        id[i as usize] = next;
    }
    drop(order);
    // Closed: every directed edge a→b is matched by as many b→a. Each edge is keyed
    // by its unordered pair, with its direction in the lowest bit; one sort, then
    // each pair's run must hold as many of one direction as of the other. (In 64
    // bits while the ids fit in 31: half the memory to sort. A vertex index out of
    // range gets an id no vertex has.)
    let compact = next < (1 << 31) - 1;
    let none = if compact { (1 << 31) - 1 } else { u32::MAX };
    let keys = tris.iter().flat_map(|t| {
        let w = t.map(|i| id.get(i as usize).copied().unwrap_or(none));
        [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])].into_iter().filter(|(a, b)| a != b).map(|(a, b)| {
            let (lo, hi, dir) = if a < b { (a, b, 0u8) } else { (b, a, 1) };
            (lo, hi, dir)
        })
    });
    if compact {
        let mut edges: Vec<u64> = Vec::with_capacity(tris.len() * 3);
        edges.extend(keys.map(|(lo, hi, dir)| (u64::from(lo) << 32) | (u64::from(hi) << 1) | u64::from(dir)));
        balanced(&mut edges)
    } else {
        let mut edges: Vec<u128> = Vec::with_capacity(tris.len() * 3);
        edges.extend(keys.map(|(lo, hi, dir)| (u128::from(lo) << 65) | (u128::from(hi) << 1) | u128::from(dir)));
        balanced(&mut edges)
    }
}

/// Whether the sorted edge keys `edges` (an unordered pair above the lowest bit,
/// the direction in it) hold as many of each pair in one direction as in the other.
fn balanced<K: Ord + Copy + std::ops::Shr<u32, Output = K> + std::ops::BitAnd<Output = K> + From<u8>>(
    edges: &mut [K],
) -> bool {
    edges.sort_unstable();
    let one = K::from(1);
    let mut k = 0;
    while k < edges.len() {
        let pair = edges[k] >> 1;
        let (mut fwd, mut back) = (0usize, 0usize);
        while k < edges.len() && edges[k] >> 1 == pair {
            if edges[k] & one == K::from(0) {
                fwd += 1;
            } else {
                back += 1;
            }
            k += 1;
        }
        if fwd != back {
            return false;
        }
    }
    true
}

/// The colour of vertex `i`, white where the mesh has none.
pub(crate) fn color_at(m: &Mesh, i: usize) -> [f32; 4] {
    clamp_color(m.colors.get(i).copied().unwrap_or([1.0; 4]))
}

/// The normal of vertex `i`, +z where the mesh has none.
pub(crate) fn normal_at(m: &Mesh, i: usize) -> [f32; 3] {
    unit_normal(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]))
}

/// Triangle `k` of a flat piece, oriented, as indices into the piece's mesh, or an
/// error if it refers outside the piece's vertices.
pub(crate) fn local_oriented(piece: &mdg_vm::output::Piece, k: usize) -> Result<[usize; 3], ExportError> {
    match piece.oriented(k) {
        Some(t) => Ok(t.map(|i| (i - piece.base) as usize + piece.vertices.start)),
        None => Err(ExportError::TriangleOutOfRange {
            what: "flattened mesh".into(),
            triangle: piece.mesh.triangles.get(k).copied().unwrap_or_default(),
            vertices: piece.vertices.len(),
        }),
    }
}

/// Checks that every triangle of the flat walk ([`Output::for_each_piece`]) refers
/// to vertices of its own piece, without expanding the instances: the runs of the
/// `VERTEX` mesh, the sweeps and every shared mesh (an instance's triangles are its
/// shared mesh's).
pub(crate) fn check_flat_triangles(out: &Output) -> Result<(), ExportError> {
    out.for_each_vertex_part::<ExportError>(&|_| true, |part| match part {
        mdg_vm::output::VertexPart::Piece(p) => p.triangles.clone().try_for_each(|k| local_oriented(&p, k).map(|_| ())),
        mdg_vm::output::VertexPart::Prototype { .. } => Ok(()),
    })?;
    checked_triangles(&out.sweeps, "sweeps")?;
    for s in &out.shared_meshes {
        checked_triangles(&s.mesh, &format!("shared mesh {}", s.name))?;
    }
    Ok(())
}

/// The oriented triangles of `m`, checked against its vertex count.
pub(crate) fn checked_triangles(m: &Mesh, what: &str) -> Result<Vec<[u32; 3]>, ExportError> {
    let n = m.positions.len();
    let tris: Vec<[u32; 3]> = m.oriented_triangles().collect();
    if let Some(t) = tris.iter().find(|t| t.iter().any(|&i| i as usize >= n)) {
        return Err(ExportError::TriangleOutOfRange { what: what.to_string(), triangle: *t, vertices: n });
    }
    Ok(tris)
}

#[cfg(test)]
pub(crate) mod tests {
    use glam::{Quat, Vec3};

    use super::*;
    use mdg_vm::geom::Frame;
    use mdg_vm::output::{Instance, Polyline, SharedMesh, Stats};

    /// A tetrahedron is closed, also with its corners split per face (welded by
    /// position, `-0` as `0`); without a face, with a face turned, as a sheet or
    /// with an index out of range it is not.
    #[test]
    fn closed_surfaces_are_told_from_open_ones() {
        let corners = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let faces = [[0u32, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let mut shared = Mesh::default();
        for p in corners {
            shared.push_vertex(Vec3::from_array(p), Vec3::Z, [1.0; 4], [0.0; 4], 0);
        }
        let mut split = Mesh::default();
        let mut split_tris = Vec::new();
        for f in faces {
            let k = split.n_vertices() as u32;
            for i in f {
                let p = corners[i as usize].map(|x: f32| if x == 0.0 { -0.0 } else { x });
                split.push_vertex(Vec3::from_array(p), Vec3::Z, [1.0; 4], [0.0; 4], 0);
            }
            split_tris.push([k, k + 1, k + 2]);
        }
        assert!(is_closed(&shared, &faces));
        assert!(is_closed(&split, &split_tris));
        assert!(!is_closed(&shared, &faces[..3]));
        assert!(!is_closed(&shared, &[faces[0], faces[1], faces[2], [1, 3, 2]]));
        assert!(!is_closed(&shared, &[[0, 1, 2], [1, 3, 2]]));
        assert!(!is_closed(&shared, &[faces[0], faces[1], faces[2], [1, 2, 9]]));
        assert!(is_closed(&shared, &[]));
    }

    /// Small writes buffered and big ones passed straight through come out in the
    /// order they were made, whole.
    #[test]
    fn the_file_writer_keeps_the_order_of_big_and_small_writes() {
        let mut w = FileWriter(std::io::BufWriter::with_capacity(1 << 20, Vec::new()));
        let mut expected = Vec::new();
        for (k, len) in [10, DIRECT_BYTES, 3, DIRECT_BYTES - 1, 3 * DIRECT_BYTES, 1, 0, 2 << 20].into_iter().enumerate()
        {
            let part: Vec<u8> = (0..len).map(|i| (i * 7 + k) as u8).collect();
            w.write_all(&part).expect("writes");
            expected.extend_from_slice(&part);
        }
        w.flush().expect("flushes");
        assert!(w.0.get_ref() == &expected, "the bytes in another order");
    }

    /// A unit cube as 12 VERTEX-style triangles (outward, counter-clockwise).
    pub(crate) fn cube(mirror_first: bool) -> Mesh {
        let mut m = Mesh::default();
        let faces: [(Vec3, Vec3, Vec3); 6] = [
            (Vec3::X, Vec3::Y, Vec3::Z),
            (-Vec3::X, Vec3::Z, Vec3::Y),
            (Vec3::Y, Vec3::Z, Vec3::X),
            (-Vec3::Y, Vec3::X, Vec3::Z),
            (Vec3::Z, Vec3::X, Vec3::Y),
            (-Vec3::Z, Vec3::Y, Vec3::X),
        ];
        for (n, a, b) in faces {
            let c = n * 0.5;
            let corners = [c - a * 0.5 - b * 0.5, c + a * 0.5 - b * 0.5, c + a * 0.5 + b * 0.5, c - a * 0.5 + b * 0.5];
            let idx: Vec<u32> =
                corners.iter().map(|&p| m.push_vertex(p, n, [0.2, 0.4, 0.6, 1.0], [0.0; 4], 0)).collect();
            m.push_triangle([idx[0], idx[1], idx[2]], false);
            m.push_triangle([idx[0], idx[2], idx[3]], false);
        }
        if mirror_first {
            // Store the first triangle reversed and flag it: oriented output is unchanged.
            m.triangles[0] = [m.triangles[0][0], m.triangles[0][2], m.triangles[0][1]];
            m.mirrored[0] = true;
        }
        m
    }

    /// An output exercising every group: VERTEX mesh, sweeps, lines, instances
    /// (plain, scaled, mirrored) of a shared mesh, stats.
    pub(crate) fn sample_output() -> Output {
        let mut sweeps = Mesh::default();
        let profile: Vec<Vec3> = (0..6)
            .map(|k| {
                let a = k as f32 / 6.0 * std::f32::consts::TAU;
                Vec3::new(a.cos(), a.sin(), 0.0) * 0.2
            })
            .collect();
        let a = mdg_vm::geom::Frame::identity();
        let b = a.translate(Vec3::new(0.0, 1.0, 2.0)).rotate(Quat::from_rotation_x(0.5));
        mdg_vm::geom::sweep_path(
            &mut sweeps,
            &profile,
            &mdg_vm::geom::blend_frames(&a, &b, 4),
            [1.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, 1.0, 1.0],
            0,
        );
        let shared = cube(false);
        let inst = |frame: Frame, color: [f32; 4]| Instance { frame, color, mesh: 0, bone: 0, lin: 0, at: 0 };
        let id = Frame::identity();
        Output {
            mesh: cube(true),
            sweeps,
            lines: vec![Polyline {
                namespace: "".into(),
                points: vec![[0.0; 3], [0.0, 1.0, 2.0], [1.0, 1.0, 2.0]],
                bones: Vec::new(),
            }],
            shared_meshes: vec![SharedMesh::isosurface("CUBE", shared)],
            instances: [
                inst(id.translate(Vec3::new(3.0, 0.0, 0.0)), [1.0, 0.0, 0.0, 1.0]),
                inst(
                    id.translate(Vec3::new(0.0, 3.0, 0.0)).rotate(Quat::from_rotation_y(0.3)).scale(2.0),
                    [0.0, 1.0, 0.0, 1.0],
                ),
                inst(id.translate(Vec3::new(-3.0, 0.0, 0.0)).reflect(Vec3::X), [2.0, -1.0, 0.5, 1.0]),
            ]
            .into_iter()
            .collect(),
            instance_weights: Vec::new(),
            lins: Vec::new(),
            stats: Stats {
                rule_calls: 5,
                vertices: 36,
                triangles: 12,
                max_depth: 2,
                paths: 0,
                path_triangles: 0,
                elapsed_ms: 0.5,
                warnings: vec!["maxdepth reached".into()],
            },
            background: [0.0, 0.0, 0.0, 1.0],
            flat: false,
            animation: Default::default(),
            debug: Vec::new(),
            sites: Default::default(),
            derivation: None,
        }
    }

    #[test]
    fn formats_from_extensions() {
        assert_eq!(Format::from_extension("GLB"), Some(Format::Glb));
        assert_eq!(Format::from_extension(".ply"), Some(Format::Ply));
        assert_eq!(Format::from_path(Path::new("a/b.stl")), Some(Format::Stl));
        assert_eq!(Format::from_extension("vox"), None);
        for f in Format::ALL {
            assert_eq!(Format::from_extension(f.extension()), Some(f));
        }
    }

    #[test]
    fn every_format_is_deterministic() {
        let out = sample_output();
        for f in Format::ALL {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            write(f, &out, &mut a).expect("writes");
            write(f, &out, &mut b).expect("writes");
            assert!(!a.is_empty());
            assert_eq!(a, b, "{f:?}");
        }
    }

    #[test]
    fn bad_indices_are_errors_not_panics() {
        let mut out = Output::default();
        out.mesh.push_vertex(Vec3::ZERO, Vec3::Z, [1.0; 4], [0.0; 4], 0);
        out.mesh.push_triangle([0, 1, 2], false);
        for f in Format::ALL {
            assert!(write(f, &out, &mut Vec::new()).is_err(), "{f:?}");
        }
    }

    #[cfg(unix)]
    #[test]
    fn writing_keeps_symlinks_modes_and_devices() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("mdg-write-through-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        // A 0600 file stays 0600 (it became 0644).
        let f = dir.join("secret.obj");
        std::fs::write(&f, "old").expect("write");
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o600)).expect("chmod");
        write_atomic(&f, b"new").expect("write_atomic");
        assert_eq!(std::fs::metadata(&f).expect("meta").permissions().mode() & 0o777, 0o600);
        assert_eq!(std::fs::read(&f).expect("read"), b"new");
        // Writing over a symlink writes its target and keeps the link (it became a file).
        let link = dir.join("link.obj");
        std::os::unix::fs::symlink("secret.obj", &link).expect("symlink");
        write_atomic(&link, b"through the link").expect("write_atomic");
        assert!(std::fs::symlink_metadata(&link).expect("meta").file_type().is_symlink());
        assert_eq!(std::fs::read(&f).expect("read"), b"through the link");
        // A dangling symlink: the file it names is created.
        let dangling = dir.join("dangling.obj");
        std::os::unix::fs::symlink("made.obj", &dangling).expect("symlink");
        write_atomic(&dangling, b"made").expect("write_atomic");
        assert!(std::fs::symlink_metadata(&dangling).expect("meta").file_type().is_symlink());
        assert_eq!(std::fs::read(dir.join("made.obj")).expect("read"), b"made");
        // /dev/null is written through, never replaced (as root it became a file).
        // As root a regression would replace the machine's /dev/null, so only an
        // unprivileged run tries it (there the old rename failed with EACCES).
        let root = std::fs::read_to_string("/proc/self/status")
            .is_ok_and(|s| s.lines().any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(2) == Some("0")));
        if !root {
            write_atomic(Path::new("/dev/null"), b"discarded").expect("write /dev/null");
            assert!(!std::fs::metadata("/dev/null").expect("meta").is_file());
        }
        // /dev/full reports its error.
        if Path::new("/dev/full").exists() {
            let e = write_atomic(Path::new("/dev/full"), b"x").expect_err("/dev/full");
            assert!(e.to_string().contains("No space left on device"), "{e}");
        }
        // A named pipe nobody reads is refused at once; a directory is refused.
        let fifo = dir.join("pipe.obj");
        if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            let e = write_atomic(&fifo, b"x").expect_err("no reader");
            assert!(e.to_string().contains("nobody reads"), "{e}");
        }
        let e = write_atomic(&dir, b"x").expect_err("a directory");
        assert!(e.to_string().contains("a directory"), "{e}");
        // Nothing left behind but what was written.
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[cfg(unix)]
    #[test]
    fn a_named_pipe_with_a_reader_is_written_through_and_a_socket_is_refused() {
        use std::io::Read;
        use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
        let dir = std::env::temp_dir().join(format!("mdg-write-special-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        let fifo = dir.join("pipe.obj");
        if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
            // The reader is there before the write (opened without blocking, so no
            // writer is needed to open it); the bytes fit in the pipe's buffer.
            let mut reader = std::fs::OpenOptions::new()
                .read(true)
                .custom_flags(libc::O_NONBLOCK)
                .open(&fifo)
                .expect("open the reading end");
            let bytes: Vec<u8> = (0..4000u32).map(|i| (i % 251) as u8).collect();
            write_atomic(&fifo, &bytes).expect("written through the pipe");
            // The writer has closed: the reader gets the bytes, then the end.
            let mut got = Vec::new();
            reader.read_to_end(&mut got).expect("read");
            assert_eq!(got, bytes);
            assert!(std::fs::symlink_metadata(&fifo).expect("meta").file_type().is_fifo(), "still a pipe");
        }
        let sock = dir.join("sock.obj");
        let _listener = std::os::unix::net::UnixListener::bind(&sock).expect("bind");
        let e = write_atomic(&sock, b"x").expect_err("a socket");
        assert_eq!(e.to_string(), "a socket, not a file to write");
        assert!(std::fs::symlink_metadata(&sock).expect("meta").file_type().is_socket(), "still a socket");
        let names: Vec<String> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.ends_with(".tmp")), "{names:?}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn a_write_removes_the_temporaries_of_killed_writers_only() {
        let dir = std::env::temp_dir().join(format!("mdg-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("dir");
        // A pid above the kernel's maximum (2^22) never runs; ours always does.
        let dead = dir.join(".out.obj.4194399.0.tmp");
        let live = dir.join(format!(".out.obj.{}.77.tmp", std::process::id()));
        let other = dir.join(".other.obj.4194399.0.tmp");
        let unrelated = dir.join(".out.obj.notapid.tmp");
        for f in [&dead, &live, &other, &unrelated] {
            std::fs::write(f, b"partial").expect("write");
        }
        write_atomic(&dir.join("out.obj"), b"whole").expect("write");
        assert!(!dead.exists(), "the killed writer's temporary file is removed");
        assert!(live.exists() && other.exists() && unrelated.exists(), "nothing else is touched");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn atomic_write_replaces_the_file() {
        let dir = std::env::temp_dir().join(format!("mdg-export-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let p = dir.join("out.bin");
        write_atomic(&p, b"first").expect("write");
        write_atomic(&p, b"second").expect("write");
        assert_eq!(std::fs::read(&p).expect("read"), b"second");
        let leftovers = std::fs::read_dir(&dir).expect("list").count();
        assert_eq!(leftovers, 1, "no temporary files left behind");
        std::fs::remove_dir_all(&dir).expect("cleanup");
    }
}
