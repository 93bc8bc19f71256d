//! The plain text voxel format: one block a line, `x y z block`, integers and a block
//! id without spaces (`5:0`, `minecraft:oak_planks`, `#ff8800`). A line whose first
//! field starts with `#` is a comment; after the four fields, `#` starts a comment.
//! y is up.

use crate::voxel::{ModelBuilder, VoxelModel};
use std::fmt::Write as _;

/// Parses the text format.
pub fn read(text: &str) -> Result<VoxelModel, String> {
    let mut b = ModelBuilder::new();
    for (i, line) in text.lines().enumerate() {
        let n = i + 1;
        let mut fields = line.split_whitespace();
        let Some(first) = fields.next() else { continue };
        if first.starts_with('#') {
            continue;
        }
        let coord = |s: Option<&str>, what: &str| -> Result<i32, String> {
            let s = s.ok_or_else(|| format!("line {n}: expected `x y z block`, the {what} is missing"))?;
            s.parse::<i32>().map_err(|_| format!("line {n}: `{s}` is not an integer {what}"))
        };
        let x = coord(Some(first), "x coordinate")?;
        let y = coord(fields.next(), "y coordinate")?;
        let z = coord(fields.next(), "z coordinate")?;
        let id = fields.next().ok_or_else(|| format!("line {n}: expected `x y z block`, the block is missing"))?;
        if let Some(extra) = fields.next() {
            if !extra.starts_with('#') {
                return Err(format!("line {n}: unexpected `{extra}` after the block (comments start with `#`)"));
            }
        }
        if crate::blocks::is_air(id) {
            continue;
        }
        let kind = b.kind(id, None).map_err(|e| format!("line {n}: {e}"))?;
        b.add([x, y, z], kind).map_err(|e| format!("line {n}: {e}"))?;
    }
    b.finish()
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
        assert!(read("0 0 x 1:0").expect_err("an error").contains("line 1"));
        assert!(read("0 0 0").expect_err("an error").contains("block is missing"));
        assert!(read("0 0 0 a\n0 0 0 b").expect_err("an error").contains("two blocks"));
        assert!(read("0 0 0 a b").is_err());
        assert!(read("0 0 99999999999 a").is_err());
        assert!(read("0 0 0 a\n5000 5000 5000 a").expect_err("an error").contains("bounding box"));
    }

    #[test]
    fn writes_what_it_reads() {
        let m = read("2 1 0 5:0\n0 0 0 1:0\n").expect("reads");
        let again = read(&write(&m)).expect("reads back");
        assert_eq!(m, again);
    }
}
