//! The run tables behind [`super::Instances`]: a value per run of equal values
//! ([`Runs`]) and the shared meshes' column, a run table or one entry per instance
//! ([`MeshColumn`]).

/// A value a run table holds, compared bit for bit.
pub(super) trait Bits: Copy {
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
pub(super) struct Runs<T>(pub(super) Vec<(usize, T)>);

impl<T: Bits> Runs<T> {
    /// Instance `i` (the next one) has `v`.
    #[inline]
    pub(super) fn note(&mut self, i: usize, v: T) {
        match self.0.last() {
            Some((_, last)) if last.same(&v) => {}
            _ => self.0.push((i, v)),
        }
    }

    /// The entry holding instance `i` (which must exist).
    #[inline]
    pub(super) fn entry(&self, i: usize) -> usize {
        self.0.partition_point(|r| r.0 <= i).saturating_sub(1)
    }

    /// The value of instance `i`, if there is one.
    #[inline]
    pub(super) fn at(&self, i: usize) -> Option<T> {
        match self.0.as_slice() {
            [(_, v)] => Some(*v),
            _ => self.0.get(self.entry(i)).map(|r| r.1),
        }
    }

    /// Where the entry after `c` begins (`usize::MAX` if it is the last).
    #[inline]
    pub(super) fn next_start(&self, c: usize) -> usize {
        self.0.get(c + 1).map_or(usize::MAX, |r| r.0)
    }

    /// The value of instance `i`, reading on from entry `*c` (instances read in
    /// increasing order move `c` forwards only).
    #[inline]
    pub(super) fn read(&self, c: &mut usize, i: usize) -> Option<T> {
        while self.0.get(*c + 1).is_some_and(|r| r.0 <= i) {
            *c += 1;
        }
        self.0.get(*c).map(|r| r.1)
    }

    /// The value every instance has, if there are instances and they all have one.
    pub(super) fn uniform(&self) -> Option<&T> {
        match self.0.as_slice() {
            [(_, v)] => Some(v),
            _ => None,
        }
    }
}

/// A dense mesh column is made once the mesh's run table has more entries than
/// this and than one in [`DENSE_FROM`] instances.
pub(super) const DENSE_AFTER: usize = 64;

/// See [`DENSE_AFTER`]: a run-table entry is 16 bytes, a dense entry 2 (or 4), so
/// past one change in 8 instances the column is smaller.
pub(super) const DENSE_FROM: usize = 8;

/// The room a dense mesh column is made with (128 KiB of `u16`s): an allocation that
/// large is mapped on its own, outside the heap, where the frames' vector grows (a
/// small column allocated after the frames would make each of their growths a copy),
/// and it grows without a copy too. Its pages are only touched as instances come.
pub(super) const DENSE_ROOM: usize = 1 << 16;

/// The shared meshes' column: a run table while meshes change seldom; one entry per
/// instance once changes are frequent (a tree with one prototype per depth changes
/// mesh at nearly every instance in depth-first order), `u16`s while every mesh
/// index fits one.
/// (Its kind is a byte of its own, `repr(u8)`, not a niche of a vector's capacity:
/// a dense push tests it in one comparison.)
#[derive(Clone, Debug, PartialEq)]
#[repr(u8)]
pub(super) enum MeshColumn {
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
    pub(super) fn at(&self, i: usize) -> Option<u32> {
        match self {
            MeshColumn::Runs(r) => r.at(i),
            MeshColumn::Narrow(v) => v.get(i).map(|&m| u32::from(m)),
            MeshColumn::Wide(v) => v.get(i).copied(),
        }
    }

    /// Appends the mesh of the next instance to a dense column.
    #[inline(always)]
    pub(super) fn push_dense(&mut self, mesh: u32) {
        match self {
            MeshColumn::Narrow(v) if mesh <= u32::from(u16::MAX) => v.push(mesh as u16),
            _ => self.push_dense_slowly(mesh),
        }
    }

    /// [`MeshColumn::push_dense`] past a `u16` (the column is widened first).
    #[cold]
    #[inline(never)]
    pub(super) fn push_dense_slowly(&mut self, mesh: u32) {
        if let MeshColumn::Narrow(v) = self {
            *self = MeshColumn::Wide(v.iter().map(|&m| u32::from(m)).collect());
        }
        if let MeshColumn::Wide(v) = self {
            v.push(mesh);
        }
    }

    /// The run table made dense, for `len` instances: room for at least
    /// [`DENSE_ROOM`] of them.
    pub(super) fn densify(runs: &Runs<u32>, len: usize) -> MeshColumn {
        let mut column = MeshColumn::Narrow(Vec::with_capacity(len.max(DENSE_ROOM)));
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
    pub(super) fn entry(&self, i: usize) -> usize {
        match self {
            MeshColumn::Runs(r) => r.entry(i),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => 0,
        }
    }

    /// The mesh of instance `i`, reading on from the cursor `*c` (see [`Runs::read`]).
    #[inline]
    pub(super) fn read(&self, c: &mut usize, i: usize) -> Option<u32> {
        match self {
            MeshColumn::Runs(r) => r.read(c, i),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => self.at(i),
        }
    }

    /// Where the run after cursor `c` begins (`usize::MAX` when dense: the
    /// iterator reads a dense column at every instance).
    #[inline]
    pub(super) fn next_start(&self, c: usize) -> usize {
        match self {
            MeshColumn::Runs(r) => r.next_start(c),
            MeshColumn::Narrow(_) | MeshColumn::Wide(_) => usize::MAX,
        }
    }

    /// Where the run of equal meshes that holds instance `i` (read at cursor `c`)
    /// ends: the run table's next start, or, in a dense column, the first later
    /// instance with another mesh.
    #[inline]
    pub(super) fn run_end(&self, c: usize, i: usize) -> usize {
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
    pub(super) fn bytes(&self) -> usize {
        use std::mem::size_of;
        match self {
            MeshColumn::Runs(r) => r.0.len() * size_of::<(usize, u32)>(),
            MeshColumn::Narrow(v) => v.len() * size_of::<u16>(),
            MeshColumn::Wide(v) => v.len() * size_of::<u32>(),
        }
    }
}
