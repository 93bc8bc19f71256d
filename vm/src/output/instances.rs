//! The instance records of an output, packed: [`Instances`].
//!
//! A big tree is millions of instances, so the record is what bounds the largest model
//! that fits in memory. Each instance stores only its frame, as eleven unaligned `f32`s
//! (44 bytes: q, q̂, u, bit for bit what the evaluator composed); its colour, shared
//! mesh, bone, non-uniform factor and `at` are kept in *run tables*, one entry where the
//! value changes from the previous instance (a tree of one prototype in one colour has
//! one entry in each). Readers go through the accessors ([`Instances::iter`],
//! [`Instances::get`], [`Instances::frame`], [`Instances::color`] …), which hand out
//! the unpacked [`Instance`], so none depends on the layout.
//!
//! Values are compared bit for bit when runs are made (a colour of `-0.0` after `0.0`
//! starts a run), so every instance reads back exactly what was pushed.

use crate::geom::quat::Frame;
use glam::{Quat, Vec3};
use std::ops::Range;

/// One placement of a shared mesh: an isosurface's, or a prototype's (a rule's run
/// of `VERTEX`/`FACENORMALS` items compiled once, bytecode `INST`), as a value.
/// [`Instances`] stores it packed (44 bytes and the run tables); this is what it
/// hands out and takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// The frame the mesh is placed in (for an isosurface, with the non-uniform
    /// factor [`Instance::lin`]).
    pub frame: Frame,
    /// The frame's colour, as the evaluator holds it (not clamped): an isosurface is
    /// painted in it (clamped); a prototype's vertices add their colour deltas to it.
    pub color: [f32; 4],
    /// Index into [`crate::output::Output::shared_meshes`].
    pub mesh: u32,
    pub bone: u32,
    /// The frame's non-uniform factor: an index into [`crate::output::Output::lins`],
    /// 0 for none (always 0 for prototypes).
    pub lin: u32,
    /// Prototypes: how many vertices [`crate::output::Output::mesh`] held when the
    /// instance was made, so that flattening puts its vertices back where the
    /// evaluator would have emitted them (0 for isosurfaces).
    pub at: u32,
}

/// How many `f32`s a packed frame is: q (x, y, z, w), q̂ (x, y, z, w), u (x, y, z).
pub const FRAME_WORDS: usize = 11;

/// Where u's x is in a packed frame ([`Instances::packed_frames`]); y and z follow.
pub const TRANSLATION_AT: usize = 8;

/// A packed frame.
pub type PackedFrame = [f32; FRAME_WORDS];

/// `f` packed (its bits unchanged).
#[inline]
fn pack(f: &Frame) -> PackedFrame {
    let (q, qh, u) = (f.q.to_array(), f.qh.to_array(), f.u.to_array());
    [q[0], q[1], q[2], q[3], qh[0], qh[1], qh[2], qh[3], u[0], u[1], u[2]]
}

/// The frame `p` packs.
#[inline]
fn unpack(p: &PackedFrame) -> Frame {
    Frame {
        q: Quat::from_xyzw(p[0], p[1], p[2], p[3]),
        qh: Quat::from_xyzw(p[4], p[5], p[6], p[7]),
        u: Vec3::new(p[8], p[9], p[10]),
    }
}

/// A value a run table holds, compared bit for bit.
trait Bits: Copy {
    fn same(&self, other: &Self) -> bool;
}

impl Bits for u32 {
    #[inline]
    fn same(&self, other: &u32) -> bool {
        self == other
    }
}

impl Bits for [f32; 4] {
    #[inline]
    fn same(&self, other: &[f32; 4]) -> bool {
        self.map(f32::to_bits) == other.map(f32::to_bits)
    }
}

/// A run table: `(first instance, value)` in increasing order of first instance; the
/// value holds from its first instance to the next entry's. Empty while there is no
/// instance; the first entry's first instance is 0.
#[derive(Clone, Debug, Default, PartialEq)]
struct Runs<T>(Vec<(usize, T)>);

impl<T: Bits> Runs<T> {
    /// Instance `i` (the next one) has `v`.
    #[inline]
    fn note(&mut self, i: usize, v: T) {
        match self.0.last() {
            Some((_, last)) if last.same(&v) => {}
            _ => self.0.push((i, v)),
        }
    }

    /// The entry holding instance `i` (which must exist).
    #[inline]
    fn entry(&self, i: usize) -> usize {
        self.0.partition_point(|r| r.0 <= i).saturating_sub(1)
    }

    /// The value of instance `i`, if there is one.
    #[inline]
    fn at(&self, i: usize) -> Option<T> {
        match self.0.as_slice() {
            [(_, v)] => Some(*v),
            _ => self.0.get(self.entry(i)).map(|r| r.1),
        }
    }

    /// Where the entry after `c` begins (`usize::MAX` if it is the last).
    #[inline]
    fn next_start(&self, c: usize) -> usize {
        self.0.get(c + 1).map_or(usize::MAX, |r| r.0)
    }

    /// The value of instance `i`, reading on from entry `*c` (instances read in
    /// increasing order move `c` forwards only).
    #[inline]
    fn read(&self, c: &mut usize, i: usize) -> Option<T> {
        while self.0.get(*c + 1).is_some_and(|r| r.0 <= i) {
            *c += 1;
        }
        self.0.get(*c).map(|r| r.1)
    }

    /// The value every instance has, if there are instances and they all have one.
    fn uniform(&self) -> Option<&T> {
        match self.0.as_slice() {
            [(_, v)] => Some(v),
            _ => None,
        }
    }
}

/// The instances of an output, in the order they were made (see the module docs).
#[derive(Clone, Default, PartialEq)]
pub struct Instances {
    frames: Vec<PackedFrame>,
    colors: Runs<[f32; 4]>,
    meshes: Runs<u32>,
    bones: Runs<u32>,
    lins: Runs<u32>,
    ats: Runs<u32>,
    /// The last instance's colour (bits), mesh, bone, lin and at: a push that
    /// repeats them (nearly every one) is one comparison and the frame's write.
    tail: [u32; 8],
}

/// `inst`'s fields that go in run tables, as bits.
#[inline(always)]
fn tail_of(inst: &Instance) -> [u32; 8] {
    let c = inst.color.map(f32::to_bits);
    [c[0], c[1], c[2], c[3], inst.mesh, inst.bone, inst.lin, inst.at]
}

impl std::fmt::Debug for Instances {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl Instances {
    /// No instance.
    pub fn new() -> Instances {
        Instances::default()
    }

    /// How many instances there are.
    #[inline]
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether there is none.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Adds `inst` after the others.
    #[inline(always)]
    pub fn push(&mut self, inst: Instance) {
        let tail = tail_of(&inst);
        if tail != self.tail || self.frames.is_empty() {
            self.note(&inst, tail);
        }
        self.frames.push(pack(&inst.frame));
    }

    /// The run tables' entries for `inst` (the next instance), whose fields differ
    /// from the last instance's (`tail`: see [`Instances::push`]).
    #[inline(never)]
    fn note(&mut self, inst: &Instance, tail: [u32; 8]) {
        let i = self.frames.len();
        self.colors.note(i, inst.color);
        self.meshes.note(i, inst.mesh);
        self.bones.note(i, inst.bone);
        self.lins.note(i, inst.lin);
        self.ats.note(i, inst.at);
        self.tail = tail;
    }

    /// Instance `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Option<Instance> {
        let frame = self.frame(i)?;
        Some(Instance {
            frame,
            color: self.colors.at(i)?,
            mesh: self.meshes.at(i)?,
            bone: self.bones.at(i)?,
            lin: self.lins.at(i)?,
            at: self.ats.at(i)?,
        })
    }

    /// The frame of instance `i`.
    #[inline]
    pub fn frame(&self, i: usize) -> Option<Frame> {
        self.frames.get(i).map(unpack)
    }

    /// The colour of instance `i`.
    #[inline]
    pub fn color(&self, i: usize) -> Option<[f32; 4]> {
        self.frames.get(i).and_then(|_| self.colors.at(i))
    }

    /// The shared mesh of instance `i`.
    #[inline]
    pub fn mesh(&self, i: usize) -> Option<u32> {
        self.frames.get(i).and_then(|_| self.meshes.at(i))
    }

    /// The bone of instance `i`.
    #[inline]
    pub fn bone(&self, i: usize) -> Option<u32> {
        self.frames.get(i).and_then(|_| self.bones.at(i))
    }

    /// The shared mesh of every instance in order (without unpacking the rest).
    pub fn meshes(&self) -> impl Iterator<Item = u32> + '_ {
        let runs = &self.meshes.0;
        runs.iter().enumerate().flat_map(move |(k, &(first, mesh))| {
            let end = runs.get(k + 1).map_or(self.len(), |r| r.0);
            std::iter::repeat_n(mesh, end.saturating_sub(first))
        })
    }

    /// Every instance in order.
    pub fn iter(&self) -> InstanceIter<'_> {
        self.range(0..self.len())
    }

    /// Instances `r` (clamped to those there are) in order.
    pub fn range(&self, r: Range<usize>) -> InstanceIter<'_> {
        let end = r.end.min(self.len());
        let start = r.start.min(end);
        InstanceIter {
            all: self,
            next: start,
            end,
            at: [
                self.colors.entry(start),
                self.meshes.entry(start),
                self.bones.entry(start),
                self.lins.entry(start),
                self.ats.entry(start),
            ],
            until: start,
            fields: None,
        }
    }

    /// The instances in consecutive chunks of `size` (the last may be shorter; at
    /// least 1), in order: for work split over threads.
    pub fn chunks(&self, size: usize) -> impl Iterator<Item = InstanceIter<'_>> {
        let size = size.max(1);
        (0..self.len()).step_by(size).map(move |a| self.range(a..a + size))
    }

    /// Keeps the instances `keep` accepts, in order.
    pub fn retain(&mut self, mut keep: impl FnMut(&Instance) -> bool) {
        *self = self.iter().filter(|i| keep(i)).collect();
    }

    /// The frames, packed: instance i's is `packed_frames()[i]`, q's x, y, z, w, q̂'s
    /// x, y, z, w, u's x, y, z (u from [`TRANSLATION_AT`]).
    pub fn packed_frames(&self) -> &[PackedFrame] {
        &self.frames
    }

    /// The colour every instance has, if there are instances and all have the same
    /// (bit for bit).
    pub fn uniform_color(&self) -> Option<&[f32; 4]> {
        self.colors.uniform()
    }

    /// The shared mesh every instance places, if there are instances and all place one.
    pub fn uniform_mesh(&self) -> Option<&u32> {
        self.meshes.uniform()
    }

    /// The bone of every instance, if there are instances and all have one.
    pub fn uniform_bone(&self) -> Option<&u32> {
        self.bones.uniform()
    }

    /// The bones' runs: `(first instance, bone)` where the bone changes from the
    /// previous instance, in order (one entry when every instance has the same).
    pub fn bone_runs(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        self.bones.0.iter().copied()
    }

    /// How many instances place each shared mesh (indexed by mesh, as long as the
    /// largest mesh index used, plus one), from the mesh table alone.
    pub fn mesh_counts(&self) -> Vec<usize> {
        let runs = &self.meshes.0;
        let mut counts = vec![0; runs.iter().map(|r| r.1 as usize + 1).max().unwrap_or(0)];
        for (k, &(first, mesh)) in runs.iter().enumerate() {
            let end = runs.get(k + 1).map_or(self.len(), |r| r.0);
            if let Some(c) = counts.get_mut(mesh as usize) {
                *c += end.saturating_sub(first);
            }
        }
        counts
    }

    /// The instances in runs of equal fields (colour, mesh, bone, lin, at): each
    /// range of instances with the fields they share, in order, covering them all
    /// (a tree of one prototype in one colour is one run). A walk that reads the
    /// frames from [`Instances::packed_frames`] keeps the fields out of its inner loop.
    pub fn field_runs(&self) -> impl Iterator<Item = (Range<usize>, Fields)> + '_ {
        let mut r = self.fields();
        let mut from = 0;
        std::iter::from_fn(move || {
            let f = r.get(from)?;
            let to = r.until.min(self.len()).max(from + 1);
            let run = (from..to, f);
            from = to;
            Some(run)
        })
    }

    /// A reader of the run-table fields (colour, mesh, bone, lin, at) of instances
    /// by index, for a walk that visits them in increasing order without unpacking
    /// their frames (read those from [`Instances::packed_frames`]): each look-up
    /// moves the tables' cursors forwards, and costs nothing while no run changes.
    pub fn fields(&self) -> FieldReader<'_> {
        FieldReader { all: self, at: [0; 5], from: 0, until: 0, fields: None }
    }

    /// Bytes the instances hold (frames and run tables, not the spare capacity).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.frames.len() * size_of::<PackedFrame>()
            + self.colors.0.len() * size_of::<(usize, [f32; 4])>()
            + (self.meshes.0.len() + self.bones.0.len() + self.lins.0.len() + self.ats.0.len())
                * size_of::<(usize, u32)>()
    }
}

impl FromIterator<Instance> for Instances {
    fn from_iter<I: IntoIterator<Item = Instance>>(iter: I) -> Instances {
        let mut all = Instances::new();
        all.extend(iter);
        all
    }
}

impl Extend<Instance> for Instances {
    fn extend<I: IntoIterator<Item = Instance>>(&mut self, iter: I) {
        for i in iter {
            self.push(i);
        }
    }
}

impl<'a> IntoIterator for &'a Instances {
    type Item = Instance;
    type IntoIter = InstanceIter<'a>;
    fn into_iter(self) -> InstanceIter<'a> {
        self.iter()
    }
}

/// An instance's fields kept in run tables (everything but its frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fields {
    pub color: [f32; 4],
    pub mesh: u32,
    pub bone: u32,
    pub lin: u32,
    pub at: u32,
}

/// Reads [`Fields`] by instance index ([`Instances::fields`]).
#[derive(Clone)]
pub struct FieldReader<'a> {
    all: &'a Instances,
    /// The run-table entries of instance `from`.
    at: [usize; 5],
    /// The instances in `from..until` have `fields`.
    from: usize,
    until: usize,
    fields: Option<Fields>,
}

impl FieldReader<'_> {
    /// The fields of instance `i` (`None` past the last). Increasing indices read
    /// on from the last one; a smaller index starts again with a search.
    #[inline]
    pub fn get(&mut self, i: usize) -> Option<Fields> {
        if i < self.from || i >= self.until || self.fields.is_none() {
            self.refill(i);
        }
        self.fields.filter(|_| i < self.all.len())
    }

    #[inline(never)]
    fn refill(&mut self, i: usize) {
        let a = self.all;
        if i < self.from {
            self.at = [a.colors.entry(i), a.meshes.entry(i), a.bones.entry(i), a.lins.entry(i), a.ats.entry(i)];
        }
        let [c, m, b, l, t] = &mut self.at;
        self.fields =
            match (a.colors.read(c, i), a.meshes.read(m, i), a.bones.read(b, i), a.lins.read(l, i), a.ats.read(t, i)) {
                (Some(color), Some(mesh), Some(bone), Some(lin), Some(at)) => {
                    Some(Fields { color, mesh, bone, lin, at })
                }
                _ => None,
            };
        self.from = i;
        self.until = [
            a.colors.next_start(*c),
            a.meshes.next_start(*m),
            a.bones.next_start(*b),
            a.lins.next_start(*l),
            a.ats.next_start(*t),
        ]
        .into_iter()
        .min()
        .unwrap_or(usize::MAX);
    }
}

/// The instances of a range of [`Instances`], in order, unpacked.
#[derive(Clone)]
pub struct InstanceIter<'a> {
    all: &'a Instances,
    next: usize,
    end: usize,
    /// The run-table entries of `next`'s colour, mesh, bone, lin and at.
    at: [usize; 5],
    /// The instances before `until` have `fields` (colour, mesh, bone, lin, at):
    /// no run table changes before it.
    until: usize,
    fields: Option<([f32; 4], [u32; 4])>,
}

impl InstanceIter<'_> {
    /// Reads the run tables at instance `i` and how far their values hold.
    #[inline(never)]
    fn refill(&mut self, i: usize) {
        let a = self.all;
        let [c, m, b, l, t] = &mut self.at;
        self.fields =
            match (a.colors.read(c, i), a.meshes.read(m, i), a.bones.read(b, i), a.lins.read(l, i), a.ats.read(t, i)) {
                (Some(color), Some(mesh), Some(bone), Some(lin), Some(at)) => Some((color, [mesh, bone, lin, at])),
                _ => None,
            };
        self.until = [
            a.colors.next_start(*c),
            a.meshes.next_start(*m),
            a.bones.next_start(*b),
            a.lins.next_start(*l),
            a.ats.next_start(*t),
        ]
        .into_iter()
        .min()
        .unwrap_or(usize::MAX);
    }
}

impl Iterator for InstanceIter<'_> {
    type Item = Instance;

    #[inline]
    fn next(&mut self) -> Option<Instance> {
        let i = self.next;
        if i >= self.end {
            return None;
        }
        self.next += 1;
        if i >= self.until || self.fields.is_none() {
            self.refill(i);
        }
        let (color, [mesh, bone, lin, at]) = self.fields?;
        Some(Instance { frame: unpack(self.all.frames.get(i)?), color, mesh, bone, lin, at })
    }

    #[inline]
    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.end - self.next;
        (n, Some(n))
    }
}

impl ExactSizeIterator for InstanceIter<'_> {}

#[cfg(test)]
mod tests {
    use super::*;

    fn inst(k: u32, color: [f32; 4]) -> Instance {
        let x = k as f32;
        Instance {
            frame: Frame {
                q: Quat::from_xyzw(x, -x, 0.5, f32::from_bits(0x7fc0_0001)),
                qh: Quat::from_xyzw(1.0, 2.0, -0.0, x * 3.0),
                u: Vec3::new(x, 1e-40, -x),
            },
            color,
            mesh: k % 3,
            bone: k / 4,
            lin: u32::from(k == 5),
            at: k / 2,
        }
    }

    fn bits(i: &Instance) -> Vec<u32> {
        let f = &i.frame;
        let mut v: Vec<u32> = [f.q.to_array(), f.qh.to_array(), i.color].concat().iter().map(|c| c.to_bits()).collect();
        v.extend(f.u.to_array().map(f32::to_bits));
        v.extend([i.mesh, i.bone, i.lin, i.at]);
        v
    }

    /// Every field of every instance reads back bit for bit, by every accessor, from
    /// any starting point; runs are kept only where a value changes.
    #[test]
    fn records_read_back_bit_for_bit() {
        let colors = [[1.0, 0.5, 0.0, 1.0], [1.0, 0.5, 0.0, 1.0], [-0.0, 0.5, 0.0, 1.0], [0.0, 0.5, 0.0, 1.0]];
        let pushed: Vec<Instance> = (0..40).map(|k| inst(k, colors[(k as usize / 3) % 4])).collect();
        let all: Instances = pushed.iter().copied().collect();
        assert_eq!(all.len(), 40);
        let read: Vec<Instance> = all.iter().collect();
        assert_eq!(read.iter().map(bits).collect::<Vec<_>>(), pushed.iter().map(bits).collect::<Vec<_>>());
        for (i, p) in pushed.iter().enumerate() {
            let g = all.get(i).expect("there");
            assert_eq!(bits(&g), bits(p));
            assert_eq!(all.frame(i).map(|f| pack(&f).map(f32::to_bits)), Some(pack(&p.frame).map(f32::to_bits)));
            assert_eq!(all.color(i).map(|c| c.map(f32::to_bits)), Some(p.color.map(f32::to_bits)));
            assert_eq!((all.mesh(i), all.bone(i)), (Some(p.mesh), Some(p.bone)));
            let from: Vec<Vec<u32>> = all.range(i..40).map(|x| bits(&x)).collect();
            assert_eq!(from, pushed[i..].iter().map(bits).collect::<Vec<_>>());
        }
        assert_eq!(all.get(40), None);
        assert_eq!(all.meshes().collect::<Vec<_>>(), pushed.iter().map(|p| p.mesh).collect::<Vec<_>>());
        assert_eq!(all.range(38..100).count(), 2);
        assert_eq!(all.range(50..60).count(), 0);
        let chunks: Vec<Vec<u32>> = all.chunks(16).map(|c| c.map(|i| i.mesh).collect()).collect();
        assert_eq!(chunks.iter().map(Vec::len).collect::<Vec<_>>(), [16, 16, 8]);
        assert_eq!(chunks.concat(), pushed.iter().map(|p| p.mesh).collect::<Vec<_>>());
        // One entry per change: -0.0 after 0.0 is a change; equal neighbours are not.
        let changes = |v: Vec<u32>| 1 + v.windows(2).filter(|w| w[0] != w[1]).count();
        assert_eq!(all.colors.0.len(), changes(pushed.iter().map(|p| p.color[0].to_bits()).collect()));
        assert_eq!(all.meshes.0.len(), 40);
        assert_eq!(all.bones.0.len(), 10);
        assert_eq!(all.lins.0.len(), 3);
        assert_eq!(all.ats.0.len(), 20);
    }

    /// The field reader gives what `get` gives, in increasing order (the renderer's
    /// walk), backwards and out of order; past the end, nothing; the bones' runs are
    /// the table's entries.
    #[test]
    fn fields_read_by_index_match_get() {
        let colors = [[1.0, 0.5, 0.0, 1.0], [-0.0, 0.5, 0.0, 1.0]];
        let all: Instances = (0..40).map(|k| inst(k, colors[(k as usize / 5) % 2])).collect();
        let want =
            |i: usize| all.get(i).map(|g| Fields { color: g.color, mesh: g.mesh, bone: g.bone, lin: g.lin, at: g.at });
        let mut r = all.fields();
        let orders: [Vec<usize>; 3] =
            [(0..40).step_by(3).collect(), (0..40).rev().collect(), vec![7, 7, 39, 0, 20, 21, 5, 38, 40, 3]];
        for order in orders {
            for i in order {
                let got = r.get(i);
                assert_eq!(got.map(|f| f.color.map(f32::to_bits)), want(i).map(|f| f.color.map(f32::to_bits)), "{i}");
                assert_eq!(got.map(|f| [f.mesh, f.bone, f.lin, f.at]), want(i).map(|f| [f.mesh, f.bone, f.lin, f.at]));
            }
        }
        assert_eq!(r.get(40), None);
        let mut counts = vec![0; 3];
        for m in all.meshes() {
            counts[m as usize] += 1;
        }
        assert_eq!(all.mesh_counts(), counts);
        assert_eq!(Instances::new().mesh_counts(), Vec::<usize>::new());
        // The field runs cover every instance once, each with its fields.
        let mut next = 0;
        for (range, f) in all.field_runs() {
            assert_eq!(range.start, next);
            assert!(range.end > range.start);
            for i in range.clone() {
                assert_eq!(Some(f.color.map(f32::to_bits)), want(i).map(|w| w.color.map(f32::to_bits)));
                assert_eq!(Some([f.mesh, f.bone, f.lin, f.at]), want(i).map(|w| [w.mesh, w.bone, w.lin, w.at]));
            }
            next = range.end;
        }
        assert_eq!(next, 40);
        assert_eq!(Instances::new().field_runs().count(), 0);
        let runs: Vec<(usize, u32)> = all.bone_runs().collect();
        assert_eq!(runs, (0..10).map(|b| (4 * b as usize, b)).collect::<Vec<_>>());
    }

    /// One prototype in one colour: 44 bytes an instance and one entry per table.
    #[test]
    fn a_uniform_tree_costs_its_frames() {
        let all: Instances =
            (0..1000).map(|k| Instance { mesh: 2, bone: 0, lin: 0, at: 0, ..inst(k, [1.0; 4]) }).collect();
        assert_eq!(all.bytes(), 1000 * 44 + 24 + 4 * 16);
        assert_eq!(
            (all.uniform_mesh(), all.uniform_bone(), all.uniform_color()),
            (Some(&2), Some(&0), Some(&[1.0; 4]))
        );
        let mut kept = all.clone();
        kept.retain(|i| i.frame.u.x < 10.0);
        assert_eq!(kept.len(), 10);
        assert_eq!(
            kept.iter().map(|i| bits(&i)).collect::<Vec<_>>(),
            all.range(0..10).map(|i| bits(&i)).collect::<Vec<_>>()
        );
    }
}
