//! Block kinds added back (issue 42): a complete derivation that lacks block kinds of
//! its example gets them through chains of rule applications, searched in the rule
//! graph ([`add_missing_kinds`]). Kept apart from [`super::generate`], whose
//! derivation, enclosure and largest piece it uses.

use super::generate::{
    below, keep_largest_supported, outside_of, placed, settle, union_box, Adjacency, Derivation, GenerateError,
    GenerateOptions, Generated, Instance, World,
};
use super::GridGrammar;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Why [`add_missing_kinds`] could not measure a building: an instance of a shape the
/// grammar lacks, or a production too large for the enclosure constraint.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CompletionError(pub GenerateError);

impl std::fmt::Display for CompletionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.0)
    }
}

impl std::error::Error for CompletionError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.0)
    }
}

/// The most chains [`add_missing_kinds`] tests (enclosure and largest piece) for one
/// missing kind.
pub const KIND_TRIES: usize = 24;
/// The most rule applications [`add_missing_kinds`]'s search places (and undoes) for
/// one missing kind, all chains together.
pub const KIND_SEARCH: usize = 4096;

/// Per shape: the fewest rule applications from an instance of it to a shape that
/// `carries` (0: it carries), or `usize::MAX` when no chain of rules reaches one
/// (breadth-first search over the rule graph, backwards from the carriers).
fn chain_distances(d: &Derivation, carries: &[bool]) -> Vec<usize> {
    let n = carries.len();
    // Per shape: the shapes with a rule adding it.
    let mut into: Vec<Vec<u32>> = vec![Vec::new(); n];
    for sh in 0..n {
        for &r in d.rules_for(sh as u32) {
            if let Some(r) = d.grammar.rules.get(r as usize) {
                if let Some(v) = into.get_mut(r.to as usize) {
                    v.push(sh as u32);
                }
            }
        }
    }
    let mut dist: Vec<usize> = carries.iter().map(|&c| if c { 0 } else { usize::MAX }).collect();
    let mut queue: std::collections::VecDeque<usize> = (0..n).filter(|&s| carries[s]).collect();
    while let Some(s) = queue.pop_front() {
        for &f in &into[s] {
            if dist[f as usize] == usize::MAX {
                dist[f as usize] = dist[s] + 1;
                queue.push_back(f as usize);
            }
        }
    }
    dist
}

/// Completes a generated building with the block kinds it lacks: for each kind of
/// `wanted` (ids without block states, see [`super::blocks::base_kind`]) that is
/// missing, one kind at a time in `wanted`'s order, each with its own budget (a kind
/// that cannot be added does not use up the search of the others), a *chain* of rule
/// applications from an instance of the building to a shape carrying it is searched:
/// first among chains whose shapes are all *sheltered* (not exposed to the building's
/// outside, not below its ground: sure to stay enclosed, so only the largest piece is
/// tested), then among all chains, each pass with the budget; the shortest chains first (breadth-first distances over the rule
/// graph, [`chain_distances`]; the instances at the same distance in an order drawn by
/// `opts.seed`), each step an application, where it fits (no block over a different
/// one, inside the bounds, adjacency when asked), of a rule one step nearer, the
/// alternatives tried depth first in an order drawn by the seed. A complete chain is
/// kept when the enclosure and the largest piece remove nothing (what it adds is
/// enclosed, or open in its example, and opens nothing), else undone and the search
/// goes on: at most [`KIND_TRIES`] chains tested and [`KIND_SEARCH`] steps placed per
/// kind. Returns the shapes added (also counted in `made.applied`). A rare kind (a
/// chimney's top, a balcony's fence, a tower's top platform) stands in few shapes,
/// often far from where derivations end, so random derivations lose it; this puts it
/// back where the grammar's rules allow it.
///
/// The test of a chain is the full one only when needed: the outside of the building
/// before the chain is computed once per kind; adding blocks (none below the ground)
/// only shrinks the outside, so when no shape of the chain is exposed to the old
/// outside, the enclosure would remove nothing and only the largest piece is checked.
pub fn add_missing_kinds(
    grammar: &GridGrammar,
    made: &mut Generated,
    wanted: &std::collections::BTreeSet<String>,
    opts: &GenerateOptions,
) -> Result<usize, CompletionError> {
    if made.instances.is_empty() || wanted.is_empty() {
        return Ok(0);
    }
    let (d, mut world) = placed(grammar, &made.instances).map_err(CompletionError)?;
    let base: Vec<&str> = d.kinds.iter().map(|k| super::blocks::base_kind(&k.id)).collect();
    let palette_base: Vec<&str> = grammar.palette.iter().map(|p| super::blocks::base_kind(&p.block)).collect();
    let limit = opts.bounds.resolve(grammar);
    let adjacent = opts.adjacency.then(|| Adjacency::of(&d));
    let mut rng = Pcg64::seed_from_u64(opts.seed ^ 0x6b69_6e64_735f_6669);
    let mut instances = made.instances.clone();
    let mut added = 0;
    let mut failed: std::collections::HashSet<&str> = std::collections::HashSet::new();
    loop {
        let present: std::collections::HashSet<&str> =
            world.cells.values().filter_map(|(k, _)| base.get(*k as usize).copied()).collect();
        // One kind at a time, in the order of `wanted`, each with its own budget: a kind
        // whose chains all fail (its carriers stand in the open) does not use up the
        // search of the others.
        let Some(target) = wanted.iter().map(|k| k.as_str()).find(|k| !present.contains(k) && !failed.contains(k))
        else {
            break;
        };
        let carries: Vec<bool> = grammar
            .shapes
            .iter()
            .map(|s| s.blocks.iter().any(|b| palette_base.get(b.kind as usize) == Some(&target)))
            .collect();
        let dist = chain_distances(&d, &carries);
        let dist_of = |inst: &Instance| dist.get(inst.shape as usize).copied().unwrap_or(usize::MAX);
        // The starts: instances of the building from which a chain reaches a missing
        // kind, nearest first, ties in an order drawn by the seed.
        let mut starts: Vec<(usize, u64, usize)> = instances
            .iter()
            .enumerate()
            .filter(|(_, inst)| dist_of(inst) != usize::MAX && dist_of(inst) > 0)
            .map(|(i, inst)| (dist_of(inst), rng.next_u64(), i))
            .collect();
        starts.sort_unstable();
        let outside = if opts.enclosure { outside_of(&world, opts.seal).map_err(CompletionError)? } else { None };
        let ground = world.cells.keys().map(|p| p[1]).min();
        let fits = |new: &Instance, w: &World, bb: Option<([i32; 3], [i32; 3])>| {
            let inside = match (limit, bb) {
                (Some(limit), Some(bb)) => {
                    let (lo, hi) = union_box(bb, d.bounds(new));
                    (0..3).all(|a| (hi[a] - lo[a] + 1) as u32 <= limit[a])
                }
                _ => true,
            };
            inside && w.fits(d.blocks(new)) && adjacent.as_ref().is_none_or(|a| a.allows(w, d.blocks(new)))
        };
        // The applications from `cur` one step nearer (to shapes at distance `want`)
        // that fit, in an order drawn by the seed (popped from the end).
        // Whether a shape added to the building is sure to stay enclosed: not exposed to
        // the building's outside (which added blocks only shrink) and not below its ground.
        let sheltered = |new: &Instance| {
            outside.as_ref().is_none_or(|o| !o.exposes(&d, new)) && ground.is_none_or(|g| d.bounds(new).0[1] >= g)
        };
        let steps = |cur: &Instance,
                     want: usize,
                     w: &World,
                     bb: Option<([i32; 3], [i32; 3])>,
                     only_sheltered: bool,
                     rng: &mut Pcg64|
         -> Vec<Instance> {
            let mut v: Vec<Instance> = d
                .rules_for(cur.shape)
                .iter()
                .filter(|&&r| grammar.rules.get(r as usize).is_some_and(|r| dist.get(r.to as usize) == Some(&want)))
                .filter_map(|&r| d.apply(cur, r))
                .filter(|new| fits(new, w, bb) && (!only_sheltered || sheltered(new)))
                .collect();
            v.dedup();
            for i in (1..v.len()).rev() {
                v.swap(i, below(rng, i + 1));
            }
            v
        };
        // A chain is kept when the enclosure and the largest piece remove nothing.
        let accept = |chain: &[Instance], trial: &[Instance], w: &World| -> Result<bool, CompletionError> {
            let low = chain.iter().map(|i| d.bounds(i).0[1]).min();
            let plain = match (&outside, ground, low) {
                (Some(out), Some(g), Some(l)) => l >= g && !chain.iter().any(|i| out.exposes(&d, i)),
                _ => !opts.enclosure,
            };
            let (mut ti, mut tw) = (trial.to_vec(), World { cells: w.cells.clone() });
            if plain {
                // The enclosure removes nothing (see above): only the largest piece.
                return Ok(!opts.keep_largest || keep_largest_supported(&d, &mut ti, &mut tw) == 0);
            }
            Ok(settle(&d, &mut ti, &mut tw, opts).map_err(CompletionError)?.0 == 0)
        };
        let bbox = instances.iter().map(|i| d.bounds(i)).reduce(union_box);
        // Two passes, each with the budget: first only chains of shapes sure to stay
        // enclosed (cheap to test: only the largest piece), then any chain. The test
        // that keeps a chain is the same; only the order of the search changes, so the
        // carriers that stand in the open near the building (most of the first tries)
        // do not use up the budget before a sheltered chain is seen.
        let mut kept: Option<Vec<Instance>> = None;
        let passes: &[bool] = if outside.is_some() { &[true, false] } else { &[false] };
        'passes: for &only_sheltered in passes {
            let (mut tries, mut placed_steps) = (0, 0);
            for &(n, _, i) in &starts {
                let Some(&start) = instances.get(i) else { continue };
                // Depth first: frames[k] holds the untried next steps after chain[..k].
                let mut chain: Vec<Instance> = Vec::new();
                let mut boxes = vec![bbox];
                let mut trial = instances.clone();
                let mut frames = vec![steps(&start, n - 1, &world, bbox, only_sheltered, &mut rng)];
                let mut spent = false;
                while let Some(frame) = frames.last_mut() {
                    if tries >= KIND_TRIES || placed_steps >= KIND_SEARCH {
                        spent = true;
                        break;
                    }
                    let Some(next) = frame.pop() else {
                        frames.pop();
                        if !chain.is_empty() && chain.len() == frames.len() {
                            if let Some(last) = chain.pop() {
                                world.remove(d.blocks(&last));
                                trial.pop();
                                boxes.pop();
                            }
                        }
                        continue;
                    };
                    let bb = boxes.last().copied().flatten();
                    if !fits(&next, &world, bb) {
                        continue;
                    }
                    placed_steps += 1;
                    world.add(d.blocks(&next));
                    trial.push(next);
                    chain.push(next);
                    boxes.push(bb.map(|b| union_box(b, d.bounds(&next))));
                    let left = dist_of(&next);
                    if left == 0 {
                        tries += 1;
                        if accept(&chain, &trial, &world)? {
                            kept = Some(trial);
                            break 'passes;
                        }
                        world.remove(d.blocks(&next));
                        trial.pop();
                        chain.pop();
                        boxes.pop();
                    } else {
                        let nb = boxes.last().copied().flatten();
                        let f = steps(&next, left - 1, &world, nb, only_sheltered, &mut rng);
                        frames.push(f);
                    }
                }
                // Nothing kept from this start: the world is the building's again.
                for last in chain.drain(..).rev() {
                    world.remove(d.blocks(&last));
                }
                if spent {
                    break;
                }
            }
        }
        let Some(trial) = kept else {
            failed.insert(target);
            continue;
        };
        added += trial.len() - instances.len();
        instances = trial;
    }
    if added > 0 {
        made.instances = instances;
        made.applied += added as u32;
        made.model = super::doors::split_doors(&world.model(&d.kinds)).0;
    }
    Ok(added)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::generate::enclosure;
    use crate::{GridRule, GridShape, PaletteEntry, Placement, ShapeBlock};
    use std::collections::BTreeSet;

    /// A one-block shape of `kind`, flat along z when `plane` says so.
    fn block(name: &str, kind: u32, plane: Option<u8>) -> GridShape {
        GridShape {
            name: name.into(),
            size: [1, 1, 1],
            blocks: vec![ShapeBlock { pos: [0, 0, 0], kind }],
            plane,
            at: None,
            example: 0,
            open: false,
        }
    }

    #[test]
    fn kinds_whose_near_carriers_stand_in_the_open_do_not_use_up_the_search() {
        // tower_observation (issue 42): its iron bars and torches were missing in 3 of 10
        // seeds. The search went to the nearest shape carrying any missing kind; those
        // near the building (a bookshelf, a trapdoor, a pane standing in the open) were
        // all exposed, the enclosure took them away, and the budget of 24 chains was
        // spent before a chain to a sheltered carrier was tried.
        //
        // Here: a row of 60 floor tiles and a corner tile. Every tile has rules to glass
        // and to iron bars placed in the open (one-block walls, flat along z, above it:
        // exposed, or floating), so glass can never be added; the corner alone has a
        // rule to iron bars standing beside it (not flat: never exposed).
        let palette = ["stone", "glass", "iron_bars"]
            .iter()
            .map(|b| PaletteEntry { name: b.to_string(), block: format!("minecraft:{b}"), color: [90, 90, 90] })
            .collect();
        let at = Placement::translation;
        let rule = |from: u32, to: u32, place: Placement| GridRule { from, to, place };
        let mut rules = vec![rule(1, 4, at([0, 0, 1]))];
        for y in 1..5 {
            rules.push(rule(0, 2, at([0, y, 0])));
            rules.push(rule(0, 3, at([0, y, 0])));
        }
        let g = GridGrammar {
            palette,
            shapes: vec![
                block("tile", 0, None),
                block("corner", 0, None),
                block("pane", 1, Some(2)),
                block("bars_in_the_open", 2, Some(2)),
                block("bars", 2, None),
            ],
            rules,
            start: 0,
            ..GridGrammar::default()
        };
        let mut row: Vec<Instance> = (0..60).map(|x| Instance { shape: 0, place: at([x, 0, 0]) }).collect();
        row.push(Instance { shape: 1, place: at([60, 0, 0]) });
        let (instances, model, removed) = enclosure(&g, &row, 1).expect("encloses");
        assert_eq!(removed, 0);
        let wanted: BTreeSet<String> =
            ["stone", "glass", "iron_bars"].iter().map(|s| format!("minecraft:{s}")).collect();
        for seed in 0..6 {
            let mut made = Generated {
                model: model.clone(),
                instances: instances.clone(),
                applied: 0,
                removed: 0,
                enclosure_rounds: 1,
                note: None,
            };
            let opts =
                GenerateOptions { seed, bounds: super::super::generate::Bounds::None, ..GenerateOptions::default() };
            let added = add_missing_kinds(&g, &mut made, &wanted, &opts).expect("adds");
            assert_eq!(added, 1, "seed {seed}: the bars beside the corner: {:?}", &made.instances[61..]);
            assert_eq!(made.instances[61], Instance { shape: 4, place: at([60, 0, 1]) }, "seed {seed}");
            let ids: BTreeSet<&str> =
                made.model.blocks.iter().map(|b| made.model.kinds[b.kind as usize].id.as_str()).collect();
            assert!(ids.contains("minecraft:iron_bars") && !ids.contains("minecraft:glass"), "seed {seed}: {ids:?}");
        }
    }
}
