//! What can go wrong when a model is written: [`ExportError`], one variant per
//! failure, each keeping the message the writers have always given.

use std::fmt;
use std::path::PathBuf;

/// Why an export failed.
#[derive(Debug)]
#[non_exhaustive]
pub enum ExportError {
    /// The destination refused bytes (OBJ, STL, PLY and the JSON dump say only the
    /// IO error).
    Io(std::io::Error),
    /// The glTF writer's destination refused bytes (`cannot write: …`).
    GlbIo(std::io::Error),
    /// The JSON dump could not be serialised.
    Json(serde_json::Error),
    /// The glTF JSON chunk could not be serialised.
    GltfJson(serde_json::Error),
    /// More skeleton bones than a glTF file holds.
    TooManyBones { bones: usize, max: usize },
    /// The binary chunk is larger than a GLB can address (4 GiB).
    GlbTooLarge { bytes: u64 },
    /// More triangles than a binary STL counts (`u32`).
    StlTooLarge { triangles: usize },
    /// A triangle of `what` refers to a vertex past its `vertices`.
    TriangleOutOfRange { what: String, triangle: [u32; 3], vertices: usize },
    /// A glTF primitive's source is not one mesh.
    NotOneMesh { what: String },
    /// A prototype of `what` whose mesh has a triangle past its vertices.
    PrototypeTriangles { what: String, prototype: String },
    /// The writer's two walks over the model disagree (a bug, not the model's
    /// fault): what it found.
    Inconsistent(&'static str),
    /// The flat pieces of `what` do not come in vertex order.
    PiecesOutOfOrder { what: String },
    /// A glTF binary record that does not fit its buffer.
    Record { bytes: usize },
    /// A streamed part of the glTF binary wrote other than its laid-out length.
    StreamLength { written: usize, laid_out: usize },
    /// A scene node ([`crate::glb::write_glb_nodes`]) names a mesh that is not there.
    NoMesh { node: String, mesh: u32 },
    /// A scene node's parent does not come before it.
    ParentOrder { node: String, parent: u32 },
    /// Writing the file `path` failed (`cannot write PATH: …`).
    File { path: PathBuf, source: Box<ExportError> },
}

impl fmt::Display for ExportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExportError::Io(e) => write!(f, "{e}"),
            ExportError::GlbIo(e) => write!(f, "cannot write: {e}"),
            ExportError::Json(e) => write!(f, "JSON dump: {e}"),
            ExportError::GltfJson(e) => write!(f, "glTF JSON: {e}"),
            ExportError::TooManyBones { bones, max } => {
                write!(f, "{bones} bones: glTF export holds at most {max} (write one pose with --time instead)")
            }
            ExportError::GlbTooLarge { bytes } => write!(f, "glTF binary of {bytes} bytes exceeds the 4 GiB GLB limit"),
            ExportError::StlTooLarge { triangles } => write!(f, "{triangles} triangles exceed the STL limit"),
            ExportError::TriangleOutOfRange { what, triangle, vertices } => {
                write!(f, "{what}: triangle {triangle:?} refers past the {vertices} vertices")
            }
            ExportError::PrototypeTriangles { what, prototype } => {
                write!(f, "{what}: prototype {prototype} has a triangle past its vertices")
            }
            ExportError::Inconsistent(what) => f.write_str(what),
            ExportError::NotOneMesh { what } => write!(f, "{what}: not one mesh"),
            ExportError::PiecesOutOfOrder { what } => write!(f, "{what}: the pieces are out of order"),
            ExportError::Record { bytes } => write!(f, "glTF binary: a record of {bytes} bytes"),
            ExportError::StreamLength { written, laid_out } => {
                write!(f, "glTF binary: a streamed part wrote {written} bytes where {laid_out} were laid out")
            }
            ExportError::NoMesh { node, mesh } => write!(f, "node `{node}`: no mesh {mesh}"),
            ExportError::ParentOrder { node, parent } => {
                write!(f, "node `{node}`: its parent {parent} does not come before it")
            }
            ExportError::File { path, source } => write!(f, "cannot write {}: {source}", path.display()),
        }
    }
}

impl std::error::Error for ExportError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ExportError::Io(e) | ExportError::GlbIo(e) => Some(e),
            ExportError::Json(e) | ExportError::GltfJson(e) => Some(e),
            ExportError::File { source, .. } => Some(source.as_ref()),
            _ => None,
        }
    }
}

impl ExportError {
    /// Whether the failure is the destination's (an IO error, exit status 2 in
    /// the commands) rather than the model's.
    pub fn is_io(&self) -> bool {
        match self {
            ExportError::Io(_) | ExportError::GlbIo(_) => true,
            ExportError::File { source, .. } => source.is_io(),
            _ => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A destination that refuses every byte.
    struct Full;

    impl std::io::Write for Full {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::new(std::io::ErrorKind::StorageFull, "no space left"))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_refused_write_is_an_io_error_with_the_writers_message() {
        let out = mdg_vm::output::Output::default();
        for format in crate::Format::ALL {
            let e = crate::write_to(format, &out, &mut Full).expect_err("the destination refuses");
            assert!(e.is_io(), "{format:?}: {e:?}");
            let io = std::error::Error::source(&e).expect("the IO error underneath");
            assert_eq!(io.to_string(), "no space left");
            let want = if format == crate::Format::Glb { "cannot write: no space left" } else { "no space left" };
            assert_eq!(e.to_string(), want, "{format:?}");
        }
    }

    #[test]
    fn a_file_error_names_the_path_and_keeps_its_cause() {
        let e = ExportError::File {
            path: "out/a.stl".into(),
            source: Box::new(ExportError::StlTooLarge { triangles: 5_000_000_000 }),
        };
        assert_eq!(e.to_string(), "cannot write out/a.stl: 5000000000 triangles exceed the STL limit");
        assert!(!e.is_io());
        let missing = ExportError::File {
            path: "no/such/dir/a.obj".into(),
            source: Box::new(ExportError::Io(std::io::Error::from(std::io::ErrorKind::NotFound))),
        };
        assert!(missing.is_io());
    }
}
