//! Doors as one block: a door's two halves joined into one kind for inference and
//! matching ([`merge_doors`]), and written back as two blocks ([`split_doors`]). Over
//! the voxel model (`voxel`) and the block names (`blocks`), below neither.

use super::blocks::{door_half, same_door, DOOR_JOIN};
use super::voxel::{Block, BlockKind, VoxelModel};

/// A model with each door's upper half joined to its lower half: the lower cell gets
/// the kind `LOWER+UPPER` and the upper cell is left empty, so inference and matching
/// treat a door as one block (a shape holds the whole door or none of it). Returns the
/// model and the number of doors joined. [`split_doors`] undoes it.
pub fn merge_doors(m: &VoxelModel) -> (VoxelModel, usize) {
    let at: std::collections::HashMap<[i32; 3], usize> = m.blocks.iter().enumerate().map(|(i, b)| (b.pos, i)).collect();
    let mut kinds: Vec<BlockKind> = m.kinds.clone();
    let mut joined: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    let mut drop = vec![false; m.blocks.len()];
    let mut new_kind = vec![None; m.blocks.len()];
    for (i, b) in m.blocks.iter().enumerate() {
        let lower = &m.kinds[b.kind as usize].id;
        if door_half(lower) != Some(true) {
            continue;
        }
        let Some(&j) = at.get(&[b.pos[0], b.pos[1] + 1, b.pos[2]]) else { continue };
        let upper_kind = m.blocks[j].kind;
        let upper = &m.kinds[upper_kind as usize].id;
        if door_half(upper) != Some(false) || !same_door(lower, upper) || drop[j] {
            continue;
        }
        let k = *joined.entry((b.kind, upper_kind)).or_insert_with(|| {
            kinds.push(BlockKind { id: format!("{lower}{DOOR_JOIN}{upper}"), color: m.kinds[b.kind as usize].color });
            kinds.len() as u32 - 1
        });
        new_kind[i] = Some(k);
        drop[j] = true;
    }
    let mut blocks: Vec<Block> = m
        .blocks
        .iter()
        .enumerate()
        .filter(|(i, _)| !drop[*i])
        .map(|(i, b)| Block { pos: b.pos, kind: new_kind[i].unwrap_or(b.kind) })
        .collect();
    let n = drop.iter().filter(|d| **d).count();
    if n == 0 {
        return (m.clone(), 0);
    }
    // Only the kinds still used, in their order.
    let mut used = vec![false; kinds.len()];
    blocks.iter().for_each(|b| used[b.kind as usize] = true);
    let mut remap = vec![0u32; kinds.len()];
    let mut kept = Vec::new();
    for (k, kind) in kinds.into_iter().enumerate() {
        if used[k] {
            remap[k] = kept.len() as u32;
            kept.push(kind);
        }
    }
    blocks.iter_mut().for_each(|b| b.kind = remap[b.kind as usize]);
    (VoxelModel { kinds: kept, blocks }, n)
}

/// Writes joined doors back as two blocks: a kind `LOWER+UPPER` at p becomes LOWER at
/// p and UPPER at p + (0, 1, 0) (when that cell is empty; else the lower half stays
/// alone). Returns the model and the number of upper halves that did not fit.
pub fn split_doors(m: &VoxelModel) -> (VoxelModel, usize) {
    if !m.kinds.iter().any(|k| k.id.contains(DOOR_JOIN)) {
        return (m.clone(), 0);
    }
    let mut kinds: Vec<BlockKind> = Vec::new();
    let mut index: std::collections::HashMap<String, u32> = std::collections::HashMap::new();
    let mut intern = |id: &str, color: [u8; 3], kinds: &mut Vec<BlockKind>| -> u32 {
        *index.entry(id.to_string()).or_insert_with(|| {
            kinds.push(BlockKind { id: id.to_string(), color });
            kinds.len() as u32 - 1
        })
    };
    // Per old kind: the lower (or only) part and the upper part.
    let parts: Vec<(u32, Option<u32>)> = m
        .kinds
        .iter()
        .map(|k| match k.id.split_once(DOOR_JOIN) {
            Some((lo, up)) => (intern(lo, k.color, &mut kinds), Some(intern(up, k.color, &mut kinds))),
            None => (intern(&k.id, k.color, &mut kinds), None),
        })
        .collect();
    let taken: std::collections::HashSet<[i32; 3]> = m.blocks.iter().map(|b| b.pos).collect();
    let mut blocks = Vec::with_capacity(m.blocks.len());
    let mut lost = 0;
    for b in &m.blocks {
        let (lo, up) = parts[b.kind as usize];
        blocks.push(Block { pos: b.pos, kind: lo });
        if let Some(up) = up {
            let above = [b.pos[0], b.pos[1] + 1, b.pos[2]];
            if taken.contains(&above) {
                lost += 1;
            } else {
                blocks.push(Block { pos: above, kind: up });
            }
        }
    }
    blocks.sort_by_key(|b| (b.pos[1], b.pos[2], b.pos[0]));
    (VoxelModel { kinds, blocks }, lost)
}
