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

mod columns;
use columns::{MeshColumn, Runs, DENSE_AFTER, DENSE_FROM};

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

/// The frames' room at the first instance (4,096 frames, 176 KiB): an allocation
/// that large is mapped on its own, so the frames grow without copies (a smaller
/// one grows in the heap, copied each time the heap's top is too small); doubled
/// from a power of two, their room stays one. Its pages are only touched as
/// instances come.
const FRAMES_ROOM: usize = 1 << 12;

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

    /// Whether the last instance's fields but frame and mesh are `fixed` (then
    /// [`Instances::push_fixed_after`] may be told so).
    #[inline]
    pub fn tail_is(&self, fixed: &Fixed) -> bool {
        fixed.0 == self.tail
    }

    /// [`Instances::push_fixed`] where the caller knows whether the last instance's
    /// fields but frame and mesh are `fixed` (`tail_is_fixed`: from
    /// [`Instances::tail_is`], or because its last push was of `fixed`): they are not
    /// compared again. (After the push they are `fixed`.)
    #[inline(always)]
    pub fn push_fixed_after(&mut self, frame: &Frame, fixed: &Fixed, mesh: u32, tail_is_fixed: bool) {
        if !self.same_mesh(mesh) || !tail_is_fixed {
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
        if i == 0 {
            // (The first instance notes its fields.)
            self.frames.reserve(FRAMES_ROOM);
        }
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

    /// Whether every frame from instance `from` on passes the frame part of
    /// [`crate::output::frame_surely_maps_finite`]: each component of q and q̂ below
    /// 1e7 in size, of u below 1e15 (NaN fails). The same comparisons, made over the
    /// packed frames four at a time (the evaluator's lean runs test their instances
    /// this way once the run is over, instead of at every push).
    pub fn frames_surely_small(&self, from: usize) -> bool {
        use glam::{BVec4A, Vec4};
        let frames = self.frames.get(from..).unwrap_or_default();
        // Four frames are 44 words, eleven vectors; word j's limit is u's when
        // j mod 11 is 8 or more.
        let limit = |j: usize| if j % FRAME_WORDS < TRANSLATION_AT { 1e7 } else { 1e15 };
        let limits: [Vec4; FRAME_WORDS] =
            std::array::from_fn(|k| Vec4::new(limit(4 * k), limit(4 * k + 1), limit(4 * k + 2), limit(4 * k + 3)));
        let mut small = BVec4A::splat(true);
        let (fours, rest) = frames.as_chunks::<4>();
        for c in fours {
            let w: &[f32; 4 * FRAME_WORDS] = c.as_flattened().try_into().unwrap_or(&[f32::NAN; 4 * FRAME_WORDS]);
            for (k, l) in limits.iter().enumerate() {
                small &= Vec4::new(w[4 * k], w[4 * k + 1], w[4 * k + 2], w[4 * k + 3]).abs().cmplt(*l);
            }
        }
        small.all() && rest.iter().all(|p| crate::output::frame_surely_maps_finite(&unpack(p), 0.0))
    }

    /// The run-table fields of instance `i`, reading on from the tables' cursors `at`
    /// (see [`Runs::read`]), and the first instance after `i` where one of them may
    /// change. With `mesh_runs` a dense mesh column ends a run where its mesh
    /// changes; without, it ends none (a reader that reads it at every instance).
    #[inline]
    fn fields_at(&self, at: &mut [usize; 5], i: usize, mesh_runs: bool) -> (Option<Fields>, usize) {
        let [c, m, b, l, t] = at;
        let fields = match (
            self.colors.read(c, i),
            self.meshes.read(m, i),
            self.bones.read(b, i),
            self.lins.read(l, i),
            self.ats.read(t, i),
        ) {
            (Some(color), Some(mesh), Some(bone), Some(lin), Some(at)) => Some(Fields { color, mesh, bone, lin, at }),
            _ => None,
        };
        let mesh_end = if mesh_runs { self.meshes.run_end(*m, i) } else { self.meshes.next_start(*m) };
        let until = [
            self.colors.next_start(*c),
            mesh_end,
            self.bones.next_start(*b),
            self.lins.next_start(*l),
            self.ats.next_start(*t),
        ]
        .into_iter()
        .min()
        .unwrap_or(usize::MAX);
        (fields, until)
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
            let (f, end) = self.fields_at(&mut at, start, true);
            let f = f?;
            let end = end.min(self.len()).max(start + 1);
            next = end;
            Some(Span { range: start..end, color: f.color, mesh: f.mesh, bone: f.bone, lin: f.lin, at: f.at })
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

    /// The bones' runs: `(first instance, bone)` where the bone changes from the
    /// previous instance, in order (one entry when every instance has the same).
    pub fn bone_runs(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        self.bones.0.iter().copied()
    }

    /// How many instances place each shared mesh (indexed by mesh, as long as the
    /// largest mesh index used, plus one), from the mesh table alone.
    pub fn mesh_counts(&self) -> Vec<usize> {
        fn count(counts: &mut Vec<usize>, mesh: u32, n: usize) {
            let m = mesh as usize;
            if counts.len() <= m {
                counts.resize(m + 1, 0);
            }
            if let Some(c) = counts.get_mut(m) {
                *c += n;
            }
        }
        let mut counts = Vec::new();
        match &self.meshes {
            MeshColumn::Runs(runs) => {
                for (k, &(first, mesh)) in runs.0.iter().enumerate() {
                    let end = runs.0.get(k + 1).map_or(self.len(), |r| r.0);
                    count(&mut counts, mesh, end.saturating_sub(first));
                }
            }
            MeshColumn::Narrow(v) => v.iter().for_each(|&m| count(&mut counts, u32::from(m), 1)),
            MeshColumn::Wide(v) => v.iter().for_each(|&m| count(&mut counts, m, 1)),
        }
        counts
    }

    /// The instances in runs of equal fields (colour, mesh, bone, lin, at): each
    /// range of instances with the fields they share, in order, covering them all
    /// (a tree of one prototype in one colour is one run). A walk that reads the
    /// frames from [`Instances::packed_frames`] keeps the fields out of its inner loop.
    pub fn field_runs(&self) -> impl Iterator<Item = (Range<usize>, Fields)> + '_ {
        self.spans().map(|s| (s.range.clone(), s.fields()))
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

    /// The fields the span's instances share.
    #[inline]
    pub fn fields(&self) -> Fields {
        Fields { color: self.color, mesh: self.mesh, bone: self.bone, lin: self.lin, at: self.at }
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
        (self.fields, self.until) = a.fields_at(&mut self.at, i, true);
        self.from = i;
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
        let (fields, until) = a.fields_at(&mut self.at, i, false);
        self.fields = fields.map(|f| (f.color, [f.mesh, f.bone, f.lin, f.at]));
        self.until = until;
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

    /// The packed scan of the frames' bound says what
    /// [`crate::output::frame_surely_maps_finite`] says of each frame, from every
    /// starting point (four frames at a time and the rest one by one), with every
    /// word's limit, sign, infinity and NaN in every lane.
    #[test]
    fn the_frames_bound_is_the_bound_of_each_frame() {
        let specials =
            [0.0, -0.0, 1.0, -2.5, 9.99e6, -9.99e6, 1e7, -1e7, 9.9e14, -9.9e14, 1e15, f32::INFINITY, f32::NAN];
        let mut seed = 12345u64;
        let mut next = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as usize
        };
        for len in [0, 1, 3, 4, 5, 8, 11, 13] {
            for _ in 0..200 {
                let mut all = Instances::new();
                for _ in 0..len {
                    let mut w = [0.5f32; FRAME_WORDS];
                    // Mostly small frames, so that one word decides.
                    if next() % 3 == 0 {
                        let at = next() % FRAME_WORDS;
                        w[at] = specials[next() % specials.len()];
                    }
                    all.push(Instance { frame: unpack(&w), ..inst(0, [1.0; 4]) });
                }
                for from in 0..=len {
                    let each =
                        all.frames[from..].iter().all(|p| crate::output::frame_surely_maps_finite(&unpack(p), 0.0));
                    assert_eq!(all.frames_surely_small(from), each, "{len} frames from {from}: {:?}", all.frames);
                }
            }
        }
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
            // The field reader and the mesh counts read a dense column too.
            let mut r = all.fields();
            for (i, p) in pushed.iter().enumerate() {
                assert_eq!(r.get(i).map(|f| f.mesh), Some(p.mesh), "{i}");
            }
            let mut counts = vec![0; pushed.iter().map(|p| p.mesh as usize + 1).max().unwrap_or(0)];
            for p in pushed {
                counts[p.mesh as usize] += 1;
            }
            assert_eq!(all.mesh_counts(), counts);
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
        assert_eq!(all.spans().map(|s| (s.range.start, s.range.end)).collect::<Vec<_>>(), [(0, 1000)]);
        kept.retain(|i| i.frame.u.x < 10.0);
        assert_eq!(kept.len(), 10);
        assert_eq!(
            kept.iter().map(|i| bits(&i)).collect::<Vec<_>>(),
            all.range(0..10).map(|i| bits(&i)).collect::<Vec<_>>()
        );
    }
}
