//! The plain text voxel format: one block a line, `x y z block`, integers and a block
//! id without spaces (`5:0`, `minecraft:oak_planks`, `#ff8800`). A line whose first
//! field starts with `#` is a comment; after the four fields, `#` starts a comment.
//! y is up.

use crate::voxel::{ModelBuilder, ModelError, VoxelModel};
use std::fmt::Write as _;

/// Why a text voxel file was refused: each error but the last names its line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TextError {
    /// A line with fewer than four fields: `what` is missing.
    Missing { line: usize, what: &'static str },
    /// A coordinate that is not an `i32`.
    NotInteger { line: usize, text: String, what: &'static str },
    /// A fifth field that is not a comment.
    Extra { line: usize, text: String },
    /// The block of a line refused by the model (its id, or two blocks in a cell).
    Block { line: usize, error: ModelError },
    /// The model as a whole refused (its bounding box).
    Model(ModelError),
}

impl std::fmt::Display for TextError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextError::Missing { line, what } => {
                write!(f, "line {line}: expected `x y z block`, the {what} is missing")
            }
            TextError::NotInteger { line, text, what } => write!(f, "line {line}: `{text}` is not an integer {what}"),
            TextError::Extra { line, text } => {
                write!(f, "line {line}: unexpected `{text}` after the block (comments start with `#`)")
            }
            TextError::Block { line, error } => write!(f, "line {line}: {error}"),
            TextError::Model(error) => write!(f, "{error}"),
        }
    }
}

impl std::error::Error for TextError {}

/// Parses the text format.
pub fn read(text: &str) -> Result<VoxelModel, TextError> {
    let mut b = ModelBuilder::new();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let mut fields = line.split_whitespace();
        let Some(first) = fields.next() else { continue };
        if first.starts_with('#') {
            continue;
        }
        let coord = |s: Option<&str>, what: &'static str| -> Result<i32, TextError> {
            let s = s.ok_or(TextError::Missing { line: n, what })?;
            s.parse::<i32>().map_err(|_| TextError::NotInteger { line: n, text: s.to_string(), what })
        };
        let x = coord(Some(first), "x coordinate")?;
        let y = coord(fields.next(), "y coordinate")?;
        let z = coord(fields.next(), "z coordinate")?;
        let id = fields.next().ok_or(TextError::Missing { line: n, what: "block" })?;
        if let Some(extra) = fields.next() {
            if !extra.starts_with('#') {
                return Err(TextError::Extra { line: n, text: extra.to_string() });
            }
        }
        if crate::blocks::is_air(id) {
            continue;
        }
        let kind = b.kind(id, None).map_err(|error| TextError::Block { line: n, error })?;
        b.add([x, y, z], kind).map_err(|error| TextError::Block { line: n, error })?;
    }
    b.finish().map_err(TextError::Model)
}

/// Writes the text format: a comment header, then the blocks in (y, z, x) order.
pub fn write(model: &VoxelModel) -> String {
    let mut s = String::new();
    let (lo, hi) = model.bounds().unwrap_or(([0; 3], [-1; 3]));
    let _ = writeln!(
        s,
        "# {} blocks, {} block kinds, size {}x{}x{} (x y z, y up)",
        model.blocks.len(),
        model.kinds_used(),
        hi[0] - lo[0] + 1,
        hi[1] - lo[1] + 1,
        hi[2] - lo[2] + 1
    );
    for b in &model.blocks {
        let id = model.kinds.get(b.kind as usize).map(|k| k.id.as_str()).unwrap_or("?");
        let _ = writeln!(s, "{} {} {} {id}", b.pos[0], b.pos[1], b.pos[2]);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_comments_and_rejects_bad_lines() {
        let m = read("# a wall\n0 0 0 1:0\n1 0 0 1:0 # trailing\n\n2 0 0 #ff0000\n").expect("reads");
        assert_eq!(m.blocks.len(), 3);
        assert_eq!(m.kinds.len(), 2);
        assert_eq!(m.kinds[1].color, [255, 0, 0]);
        let e = read("0 0 x 1:0").expect_err("an error");
        assert_eq!(e, TextError::NotInteger { line: 1, text: "x".into(), what: "z coordinate" });
        assert_eq!(e.to_string(), "line 1: `x` is not an integer z coordinate");
        let e = read("0 0 0").expect_err("an error");
        assert_eq!(e, TextError::Missing { line: 1, what: "block" });
        assert_eq!(e.to_string(), "line 1: expected `x y z block`, the block is missing");
        let e = read("0 0 0 a\n0 0 0 b").expect_err("an error");
        assert_eq!(e, TextError::Block { line: 2, error: ModelError::TwoBlocks { pos: [0, 0, 0] } }, "{e:?}");
        assert!(e.to_string().contains("two blocks"), "{e}");
        let e = read("0 0 0 a b").expect_err("an error");
        assert_eq!(e.to_string(), "line 1: unexpected `b` after the block (comments start with `#`)");
        assert!(matches!(read("0 0 99999999999 a"), Err(TextError::NotInteger { .. })));
        let e = read("0 0 0 a\n5000 5000 5000 a").expect_err("an error");
        assert!(matches!(&e, TextError::Model(ModelError::TooLarge { .. })), "{e:?}");
        assert!(e.to_string().contains("bounding box"), "{e}");
    }

    #[test]
    fn writes_what_it_reads() {
        let m = read("2 1 0 5:0\n0 0 0 1:0\n").expect("reads");
        let again = read(&write(&m)).expect("reads back");
        assert_eq!(m, again);
    }
}
