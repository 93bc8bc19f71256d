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

/// A dense mesh column is made once the mesh's run table has more entries than
/// this and than one in [`DENSE_FROM`] instances.
const DENSE_AFTER: usize = 64;

/// See [`DENSE_AFTER`]: a run-table entry is 16 bytes, a dense entry 2 (or 4), so
/// past one change in 8 instances the column is smaller.
const DENSE_FROM: usize = 8;

/// The shared meshes' column: a run table while meshes change seldom; one entry per
/// instance once changes are frequent (a tree with one prototype per depth changes
/// mesh at nearly every instance in depth-first order), `u16`s while every mesh
/// index fits one.
#[derive(Clone, Debug, PartialEq)]
enum MeshColumn {
    Runs(Runs<u32>),
    Narrow(Vec<u16>),
    Wide(Vec<u32>),
}

impl Default for MeshColumn {
    fn default() -> Self {
        MeshColumn::Runs(Runs::default())
    }
}

impl MeshColumn {
    /// The mesh of instance `i`, if there is one.
    #[inline]
    fn at(&self, i: usize) -> Option<u32> {
        match self {
            MeshColumn::Runs(r) => r.at(i),
            MeshColumn::Narrow(v) => v.get(i).map(|&m| u32::from(m)),
            MeshColumn::Wide(v) => v.get(i).copied(),
        }
    }

    /// Appends the mesh of the next instance to a dense column.
    #[inline(always)]
    fn push_dense(&mut self, mesh: u32) {
        match self {
            MeshColumn::Narrow(v) if mesh <= u32::from(u16::MAX) => v.push(mesh as u16),
            _ => self.push_dense_slowly(mesh),
        }
    }

    /// [`MeshColumn::push_dense`] past a `u16` (the column is widened first).
    #[cold]
    #[inline(never)]
    fn push_dense_slowly(&mut self, mesh: u32) {
        if let MeshColumn::Narrow(v) = self {
            *self = MeshColumn::Wide(v.iter().map(|&m| u32::from(m)).collect());
        }
        if let MeshColumn::Wide(v) = self {
            v.push(mesh);
        }
    }

    /// The run table made dense, for `len` instances.
    fn densify(runs: &Runs<u32>, len: usize) -> MeshColumn {
        let mut column = MeshColumn::Narrow(Vec::with_capacity(len));
        for (k, &(first, mesh)) in runs.0.iter().enumerate() {
            let end = runs.0.get(k + 1).map_or(len, |r| r.0);
            for _ in first..end {
                column.push_dense(mesh);
            }
        }
        column
    }

    /// An iterator's cursor for instance `i` (see [`Runs::entry`]; unused when dense).
    #[inline]
    fn entry(&self, i: usize) -> usize {
        match self {
            MeshColumn::Runs(r) => r.entry(i),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => 0,
        }
    }

    /// The mesh of instance `i`, reading on from the cursor `*c` (see [`Runs::read`]).
    #[inline]
    fn read(&self, c: &mut usize, i: usize) -> Option<u32> {
        match self {
            MeshColumn::Runs(r) => r.read(c, i),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => self.at(i),
        }
    }

    /// Where the run after cursor `c` begins (`usize::MAX` when dense: the
    /// iterator reads a dense column at every instance).
    #[inline]
    fn next_start(&self, c: usize) -> usize {
        match self {
            MeshColumn::Runs(r) => r.next_start(c),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => usize::MAX,
        }
    }

    /// Where the run of equal meshes that holds instance `i` (read at cursor `c`)
    /// ends: the run table's next start, or, in a dense column, the first later
    /// instance with another mesh.
    #[inline]
    fn run_end(&self, c: usize, i: usize) -> usize {
        fn end<T: PartialEq>(v: &[T], i: usize) -> usize {
            match v.get(i) {
                Some(m) => v[i..].iter().position(|x| x != m).map_or(v.len(), |k| i + k),
                None => i,
            }
        }
        match self {
            MeshColumn::Runs(r) => r.next_start(c),
            MeshColumn::Narrow(v) => end(v, i),
            MeshColumn::Wide(v) => end(v, i),
        }
    }

    /// Bytes the column holds.
    fn bytes(&self) -> usize {
        use std::mem::size_of;
        match self {
            MeshColumn::Runs(r) => r.0.len() * size_of::<(usize, u32)>(),
            MeshColumn::Narrow(v) => v.len() * size_of::<u16>(),
            MeshColumn::Wide(v) => v.len() * size_of::<u32>(),
        }
    }
}

/// The fields but the frame and the mesh of instances pushed one after the other
/// with [`Instances::push_fixed`]: their colour, bone, non-uniform factor and `at`,
/// as the run tables compare them (bits), made once.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Fixed([u32; 8]);

impl Fixed {
    pub fn new(color: [f32; 4], bone: u32, lin: u32, at: u32) -> Fixed {
        let c = color.map(f32::to_bits);
        Fixed([c[0], c[1], c[2], c[3], 0, bone, lin, at])
    }
}

/// The instances of an output, in the order they were made (see the module docs).
#[derive(Clone, PartialEq)]
pub struct Instances {
    frames: Vec<PackedFrame>,
    colors: Runs<[f32; 4]>,
    meshes: MeshColumn,
    bones: Runs<u32>,
    lins: Runs<u32>,
    ats: Runs<u32>,
    /// The last instance's colour (bits), 0, bone, lin and at (a [`Fixed`]'s
    /// layout): a push that repeats them (nearly every one) is one comparison and
    /// the frame's write.
    tail: [u32; 8],
    /// The last instance's mesh (compared only while the mesh column is runs);
    /// before the first instance, a value no mesh has (so the first push always
    /// notes its fields, with no test of its own).
    tail_mesh: u64,
    /// `tail` with the last mesh in its place while the mesh column is runs (what
    /// [`Instances::push_parts`] compares its fields with, gathered as they come).
    tail_parts: [u32; 8],
    /// Whether [`Instances::meshes`] is dense.
    dense: bool,
}

impl Default for Instances {
    fn default() -> Instances {
        Instances {
            frames: Vec::new(),
            colors: Runs::default(),
            meshes: MeshColumn::default(),
            bones: Runs::default(),
            lins: Runs::default(),
            ats: Runs::default(),
            tail: [0; 8],
            tail_mesh: u64::MAX,
            tail_parts: [0; 8],
            dense: false,
        }
    }
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
        self.push_parts(&inst.frame, inst.color, [inst.mesh, inst.bone, inst.lin, inst.at]);
    }

    /// Adds the instance of `frame`, mesh `mesh` and the fields `fixed` after the
    /// others: [`Instances::push_parts`] where only the frame and the mesh change
    /// from one push to the next (the fields are not gathered again).
    #[inline(always)]
    pub fn push_fixed(&mut self, frame: &Frame, fixed: &Fixed, mesh: u32) {
        // (`fixed` is compared where it lies: its mesh's place holds 0, as the
        // tail's does.)
        if !self.same_mesh(mesh) || fixed.0 != self.tail {
            let [c0, c1, c2, c3, _, bone, lin, at] = fixed.0;
            let color = [c0, c1, c2, c3].map(f32::from_bits);
            self.note(&Instance { frame: *frame, color, mesh, bone, lin, at }, fixed.0);
        }
        self.frames.push(pack(frame));
    }

    /// Adds the instance of `frame`, `color` and `[mesh, bone, lin, at]` after the
    /// others ([`Instances::push`] without an [`Instance`] to build: the evaluator's
    /// frame is packed from where it lies).
    #[inline(always)]
    pub fn push_parts(&mut self, frame: &Frame, color: [f32; 4], [mesh, bone, lin, at]: [u32; 4]) {
        let c = color.map(f32::to_bits);
        let mut parts = [c[0], c[1], c[2], c[3], mesh, bone, lin, at];
        if self.dense {
            self.meshes.push_dense(mesh);
            parts[4] = 0;
        }
        if parts != self.tail_parts || self.frames.is_empty() {
            self.note(
                &Instance { frame: *frame, color, mesh, bone, lin, at },
                [c[0], c[1], c[2], c[3], 0, bone, lin, at],
            );
        }
        self.frames.push(pack(frame));
    }

    /// Whether the next instance's `mesh` needs no run-table entry: under a dense
    /// column it is written there (and `true`), else it is the last instance's.
    #[inline(always)]
    fn same_mesh(&mut self, mesh: u32) -> bool {
        if self.dense {
            self.meshes.push_dense(mesh);
            true
        } else {
            u64::from(mesh) == self.tail_mesh
        }
    }

    /// The run tables' entries for `inst` (the next instance), whose fields differ
    /// from the last instance's (`tail`, the mesh's place 0: see
    /// [`Instances::push`]).
    #[inline(never)]
    fn note(&mut self, inst: &Instance, tail: [u32; 8]) {
        let i = self.frames.len();
        self.colors.note(i, inst.color);
        if let MeshColumn::Runs(r) = &mut self.meshes {
            r.note(i, inst.mesh);
            if r.0.len() > DENSE_AFTER && r.0.len() * DENSE_FROM > i {
                self.meshes = MeshColumn::densify(r, i + 1);
                self.dense = true;
            }
        }
        self.bones.note(i, inst.bone);
        self.lins.note(i, inst.lin);
        self.ats.note(i, inst.at);
        self.tail = tail;
        self.tail_mesh = u64::from(inst.mesh);
        self.tail_parts = tail;
        if !self.dense {
            self.tail_parts[4] = inst.mesh;
        }
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
        let (runs, narrow, wide): (&[(usize, u32)], &[u16], &[u32]) = match &self.meshes {
            MeshColumn::Runs(r) => (&r.0, &[], &[]),
            MeshColumn::Narrow(v) => (&[], v, &[]),
            MeshColumn::Wide(v) => (&[], &[], v),
        };
        let runs = runs.iter().enumerate().flat_map(move |(k, &(first, mesh))| {
            let end = runs.get(k + 1).map_or(self.len(), |r| r.0);
            std::iter::repeat_n(mesh, end.saturating_sub(first))
        });
        runs.chain(narrow.iter().map(|&m| u32::from(m))).chain(wide.iter().copied())
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

    /// The instances as spans over which no run table changes, in order: each span's
    /// instances share their colour, mesh, bone, `lin` and `at` (the span's
    /// [`Span::fields`]) and differ only in their frames ([`Instances::packed_frames`]
    /// over [`Span::range`]). A tree of one prototype in one colour is one span: a
    /// reader that needs the shared fields once per span, not per instance, walks
    /// these.
    pub fn spans(&self) -> impl Iterator<Item = Span> + '_ {
        let mut at = [0usize; 5];
        let mut next = 0usize;
        std::iter::from_fn(move || {
            let start = next;
            if start >= self.len() {
                return None;
            }
            let [c, m, b, l, t] = &mut at;
            let (Some(color), Some(mesh), Some(bone), Some(lin), Some(at_)) = (
                self.colors.read(c, start),
                self.meshes.read(m, start),
                self.bones.read(b, start),
                self.lins.read(l, start),
                self.ats.read(t, start),
            ) else {
                return None;
            };
            let end = [
                self.colors.next_start(*c),
                self.meshes.run_end(*m, start),
                self.bones.next_start(*b),
                self.lins.next_start(*l),
                self.ats.next_start(*t),
                self.len(),
            ]
            .into_iter()
            .min()
            .unwrap_or(self.len())
            .max(start + 1);
            next = end;
            Some(Span { range: start..end, color, mesh, bone, lin, at: at_ })
        })
    }

    /// The colour every instance has, if there are instances and all have the same
    /// (bit for bit).
    pub fn uniform_color(&self) -> Option<&[f32; 4]> {
        self.colors.uniform()
    }

    /// The shared mesh every instance places, if there are instances and all place one.
    pub fn uniform_mesh(&self) -> Option<&u32> {
        match &self.meshes {
            MeshColumn::Runs(r) => r.uniform(),
            // (A column is dense only after many changes.)
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => None,
        }
    }

    /// The bone of every instance, if there are instances and all have one.
    pub fn uniform_bone(&self) -> Option<&u32> {
        self.bones.uniform()
    }

    /// Bytes the instances hold (frames and run tables, not the spare capacity).
    pub fn bytes(&self) -> usize {
        use std::mem::size_of;
        self.frames.len() * size_of::<PackedFrame>()
            + self.colors.0.len() * size_of::<(usize, [f32; 4])>()
            + self.meshes.bytes()
            + (self.bones.0.len() + self.lins.0.len() + self.ats.0.len()) * size_of::<(usize, u32)>()
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

/// Consecutive instances that share every field but their frames (see
/// [`Instances::spans`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Span {
    /// The instances (indices into the [`Instances`]).
    pub range: Range<usize>,
    pub color: [f32; 4],
    pub mesh: u32,
    pub bone: u32,
    pub lin: u32,
    pub at: u32,
}

impl Span {
    /// Instance `i`'s record (`frame` its frame): the span's fields with it.
    #[inline]
    pub fn instance(&self, frame: &PackedFrame) -> Instance {
        Instance {
            frame: unpack(frame),
            color: self.color,
            mesh: self.mesh,
            bone: self.bone,
            lin: self.lin,
            at: self.at,
        }
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
        let mesh = if self.all.dense { self.all.meshes.at(i)? } else { mesh };
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
        // The spans: every instance once, in order, with its fields; a span ends
        // where some field changes and nowhere else.
        let mut rebuilt = Vec::new();
        let spans: Vec<Span> = all.spans().collect();
        for s in &spans {
            assert!(!s.range.is_empty());
            for (k, f) in all.packed_frames()[s.range.clone()].iter().enumerate() {
                assert_eq!(bits(&s.instance(f)), bits(&pushed[s.range.start + k]));
                rebuilt.push(s.instance(f));
            }
        }
        assert_eq!(rebuilt.iter().map(bits).collect::<Vec<_>>(), pushed.iter().map(bits).collect::<Vec<_>>());
        for w in spans.windows(2) {
            assert_eq!(w[0].range.end, w[1].range.start);
            let (a, b) = (&pushed[w[0].range.end - 1], &pushed[w[1].range.start]);
            assert_ne!(
                bits(a)[8..12].iter().chain(&bits(a)[15..]).collect::<Vec<_>>(),
                bits(b)[8..12].iter().chain(&bits(b)[15..]).collect::<Vec<_>>()
            );
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
        assert!(matches!(&all.meshes, MeshColumn::Runs(r) if r.0.len() == 40));
        assert_eq!(all.bones.0.len(), 10);
        assert_eq!(all.lins.0.len(), 3);
        assert_eq!(all.ats.0.len(), 20);
    }

    /// A mesh that changes at nearly every instance (a tree with one prototype per
    /// depth) costs a `u16` an instance, not a run-table entry (16 bytes), and
    /// reads back exactly by every accessor; a mesh past 65,535 widens the column.
    #[test]
    fn frequently_changing_meshes_cost_two_bytes_an_instance() {
        let mut pushed: Vec<Instance> =
            (0..300).map(|k| Instance { mesh: k % 15, bone: 0, lin: 0, at: 0, ..inst(k, [1.0; 4]) }).collect();
        let mut all: Instances = pushed.iter().copied().collect();
        assert_eq!(all.bytes(), 300 * 44 + 300 * 2 + 24 + 3 * 16);
        let check = |all: &Instances, pushed: &[Instance]| {
            let read: Vec<Vec<u32>> = all.iter().map(|i| bits(&i)).collect();
            assert_eq!(read, pushed.iter().map(bits).collect::<Vec<_>>());
            for (i, p) in pushed.iter().enumerate() {
                assert_eq!(all.get(i).map(|g| bits(&g)), Some(bits(p)));
                assert_eq!(all.mesh(i), Some(p.mesh));
                let from: Vec<Vec<u32>> = all.range(i..i + 3).map(|x| bits(&x)).collect();
                let end = (i + 3).min(pushed.len());
                assert_eq!(from, pushed[i..end].iter().map(bits).collect::<Vec<_>>());
            }
            assert_eq!(all.meshes().collect::<Vec<_>>(), pushed.iter().map(|p| p.mesh).collect::<Vec<_>>());
            assert_eq!(all.uniform_mesh(), None);
            // The spans of a dense column end where the mesh changes, and only there.
            let spans: Vec<Span> = all.spans().collect();
            let rebuilt: Vec<Vec<u32>> = spans
                .iter()
                .flat_map(|s| all.packed_frames()[s.range.clone()].iter().map(|f| bits(&s.instance(f))))
                .collect();
            assert_eq!(rebuilt, pushed.iter().map(bits).collect::<Vec<_>>());
            for w in spans.windows(2) {
                assert_ne!(w[0].mesh, w[1].mesh);
            }
        };
        check(&all, &pushed);
        // Meshes in pairs: dense, and each span two instances long.
        let pairs: Vec<Instance> =
            (0..300).map(|k| Instance { mesh: (k / 2) % 15, bone: 0, lin: 0, at: 0, ..inst(k, [1.0; 4]) }).collect();
        let paired: Instances = pairs.iter().copied().collect();
        assert_eq!(paired.bytes(), 300 * 44 + 300 * 2 + 24 + 3 * 16);
        check(&paired, &pairs);
        assert!(paired.spans().all(|s| s.range.len() == 2));
        let wide = Instance { mesh: 70_000, ..pushed[7] };
        pushed.push(wide);
        all.push(wide);
        check(&all, &pushed);
        assert_eq!(all.bytes(), 301 * 44 + 301 * 4 + 24 + 3 * 16);
        // Fewer changes keep the run table: 300 instances in runs of 20.
        let runs: Instances =
            (0..300).map(|k| Instance { mesh: k / 20, bone: 0, lin: 0, at: 0, ..inst(k, [1.0; 4]) }).collect();
        assert_eq!(runs.bytes(), 300 * 44 + 15 * 16 + 24 + 3 * 16);
    }

    /// Pushing with fixed fields gives what pushing whole instances gives: meshes
    /// that change seldom, then at every instance (the column made dense), then
    /// other fixed fields.
    #[test]
    fn pushing_with_fixed_fields_is_pushing_the_instances() {
        let pushed: Vec<Instance> = (0..400)
            .map(|k| {
                let (mesh, bone) = if k < 100 { (k / 30, 1) } else { (k % 7, 2 + u32::from(k > 300)) };
                Instance { mesh, bone, lin: 0, at: 5, ..inst(k, [0.5, -0.0, 1.0, 1.0]) }
            })
            .collect();
        let whole: Instances = pushed.iter().copied().collect();
        let mut fixed = Instances::new();
        for p in &pushed {
            fixed.push_fixed(&p.frame, &Fixed::new(p.color, p.bone, p.lin, p.at), p.mesh);
        }
        assert_eq!(fixed.iter().map(|i| bits(&i)).collect::<Vec<_>>(), pushed.iter().map(bits).collect::<Vec<_>>());
        // (The frames hold a NaN, so the two are compared through what they hold.)
        assert_eq!(fixed.bytes(), whole.bytes());
        assert_eq!(
            (fixed.dense, fixed.tail, fixed.tail_mesh, fixed.tail_parts),
            (whole.dense, whole.tail, whole.tail_mesh, whole.tail_parts)
        );
        assert_eq!(fixed.meshes().collect::<Vec<_>>(), whole.meshes().collect::<Vec<_>>());
        // The two pushes taking turns (a lean run after a general one, and back)
        // give the same instances too.
        let mut mixed = Instances::new();
        for (k, p) in pushed.iter().enumerate() {
            if (k / 3) % 2 == 0 {
                mixed.push(*p);
            } else {
                mixed.push_fixed(&p.frame, &Fixed::new(p.color, p.bone, p.lin, p.at), p.mesh);
            }
        }
        assert_eq!(mixed.iter().map(|i| bits(&i)).collect::<Vec<_>>(), pushed.iter().map(bits).collect::<Vec<_>>());
        assert_eq!(mixed.bytes(), whole.bytes());
    }

    /// The first instance's fields are noted whatever they are (all zero, the
    /// largest mesh index), by either push: there is no last instance to repeat.
    #[test]
    fn the_first_instance_is_noted_whatever_its_fields() {
        for mesh in [0, u32::MAX] {
            let first = Instance { mesh, bone: 0, lin: 0, at: 0, ..inst(0, [0.0; 4]) };
            let mut whole = Instances::new();
            whole.push(first);
            let mut fixed = Instances::new();
            fixed.push_fixed(&first.frame, &Fixed::new(first.color, 0, 0, 0), mesh);
            for got in [&whole, &fixed] {
                assert_eq!(got.get(0).map(|i| bits(&i)), Some(bits(&first)), "mesh {mesh}");
            }
        }
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
        assert_eq!(all.spans().map(|s| (s.range.start, s.range.end)).collect::<Vec<_>>(), [(0, 1000)]);
        kept.retain(|i| i.frame.u.x < 10.0);
        assert_eq!(kept.len(), 10);
        assert_eq!(
            kept.iter().map(|i| bits(&i)).collect::<Vec<_>>(),
            all.range(0..10).map(|i| bits(&i)).collect::<Vec<_>>()
        );
    }
}
