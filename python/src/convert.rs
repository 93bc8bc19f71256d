//! An [`Output`] turned into flat buffers (Rust vectors that become numpy arrays
//! without a copy): the flat walks of [`Output::for_each_piece_where`], and the
//! prototype instances as meshes plus placements.

use glam::Vec3;
use mdg_export::glb::prototype_placement;
use mdg_vm::geom::mesh::Mesh;
use mdg_vm::output::{expand_isosurface, expand_prototype, Groups, Instance, InstanceIter, Output, Piece, VertexPart};

/// A flat mesh: what [`crate::Mesh`] holds.
#[derive(Debug, Default)]
pub struct Flat {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub colors: Vec<[f32; 4]>,
    pub triangles: Vec<[u32; 3]>,
    pub bones: Vec<u32>,
    /// Whether the model has bones (else `bones` is left empty).
    pub animated: bool,
}

/// A coordinate as the exporters write it: 0 where not finite.
pub fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

pub fn finite3(p: [f32; 3]) -> [f32; 3] {
    p.map(finite)
}

/// A unit normal (+z for a zero-length or non-finite one), as the exporters write it.
fn unit(n: [f32; 3]) -> [f32; 3] {
    let v = Vec3::from(n);
    if v.is_finite() {
        v.normalize_or(Vec3::Z).to_array()
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// A colour clamped to 0..1 (NaN as 0).
fn clamped(c: [f32; 4]) -> [f32; 4] {
    c.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) })
}

/// Which instances a flat walk expands ([`flatten`]).
pub enum Expand<F> {
    /// Those `f(index)` keeps.
    Where(F),
    /// No prototype instance; the isosurfaces `f(index)` keeps.
    NoPrototypes(F),
}

/// One vertex as the exporters write it: a finite position, a unit normal, a
/// colour clamped to 0..1.
fn vertex(m: &Mesh, i: usize) -> ([f32; 3], [f32; 3], [f32; 4]) {
    (
        finite3(m.positions[i]),
        unit(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0])),
        clamped(m.colors.get(i).copied().unwrap_or([1.0; 4])),
    )
}

/// One part of a flat walk, in walk order: a run of a mesh that the model holds (a
/// run of [`Output::mesh`], the sweeps), or an instance expanded on the way.
#[derive(Clone, Copy, Debug)]
enum What {
    /// Index into the walk's runs.
    Run(u32),
    /// Index into [`Output::instances`] (a prototype or an isosurface).
    Instance(u32),
}

/// A [`What`] with the flat index of its first vertex and the most triangles
/// before it (triangles that refer outside their piece are left out, so the
/// triangle offsets are upper bounds until the end).
#[derive(Clone, Copy, Debug)]
struct Part {
    what: What,
    vertex: usize,
    triangle: usize,
}

/// The buffers of one thread's parts: its share of each of [`Flat`]'s vectors.
struct Slices<'a> {
    positions: &'a mut [[f32; 3]],
    normals: &'a mut [[f32; 3]],
    colors: &'a mut [[f32; 4]],
    triangles: &'a mut [[u32; 3]],
    bones: &'a mut [u32],
}

impl<'a> Slices<'a> {
    /// Splits off the first `v` vertices and `t` triangles.
    fn split(self, v: usize, t: usize, animated: bool) -> (Slices<'a>, Slices<'a>) {
        let (p1, p2) = self.positions.split_at_mut(v);
        let (n1, n2) = self.normals.split_at_mut(v);
        let (c1, c2) = self.colors.split_at_mut(v);
        let (t1, t2) = self.triangles.split_at_mut(t);
        let (b1, b2) = self.bones.split_at_mut(if animated { v } else { 0 });
        (
            Slices { positions: p1, normals: n1, colors: c1, triangles: t1, bones: b1 },
            Slices { positions: p2, normals: n2, colors: c2, triangles: t2, bones: b2 },
        )
    }
}

/// The geometry of `groups` as one world-space mesh, leaving out the instances
/// `expand` refuses (triangles wound as the exporters write them): the vertices and
/// triangles of [`Output::for_each_piece_where`], in its order.
///
/// A first walk lists the parts (runs of the model's meshes, instances to expand)
/// with where each one's vertices and triangles go; then up to `threads` threads
/// convert nearly equal shares of the vertices, each straight into its part of the
/// final buffers (which become the numpy arrays without a copy). The walk over the
/// instances is skipped where it would find nothing: the prototype instances when
/// `Expand::NoPrototypes` (the base mesh of a model whose instances are all
/// placed), the isosurfaces when the model has none.
pub fn flatten(out: &Output, groups: Groups, expand: Expand<impl Fn(usize) -> bool>, threads: usize) -> Flat {
    let (expand, prototypes) = match expand {
        Expand::Where(f) => (f, true),
        Expand::NoPrototypes(f) => (f, false),
    };
    let animated = out.animation.bones.len() > 1;
    // The walk: the VERTEX group's runs and prototype instances, the sweeps, the
    // isosurface instances.
    let mut runs: Vec<Piece<'_>> = Vec::new();
    let mut parts: Vec<Part> = Vec::new();
    let (mut v, mut t) = (0usize, 0usize);
    let mut push = |what: What, nv: usize, nt: usize| {
        parts.push(Part { what, vertex: v, triangle: t });
        v += nv;
        t += nt;
    };
    if groups.vertex && !prototypes {
        // The walk would make one run of the whole mesh.
        let m = &out.mesh;
        runs.push(Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: 0 });
        push(What::Run(runs.len() as u32 - 1), m.n_vertices(), m.triangles.len());
    } else if groups.vertex {
        let _ = out.for_each_vertex_part::<()>(&expand, |part| {
            match part {
                VertexPart::Piece(p) => {
                    let (nv, nt) = (p.vertices.len(), p.triangles.len());
                    runs.push(p);
                    push(What::Run(runs.len() as u32 - 1), nv, nt);
                }
                VertexPart::Prototype { instance, inst, .. } => {
                    if let Some(s) = out.shared(&inst) {
                        push(What::Instance(instance as u32), s.mesh.n_vertices(), s.mesh.triangles.len());
                    }
                }
            }
            Ok(())
        });
    }
    if groups.sweeps {
        let m = &out.sweeps;
        runs.push(Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: 0 });
        push(What::Run(runs.len() as u32 - 1), m.n_vertices(), m.triangles.len());
    }
    if groups.isosurfaces && out.shared_meshes.iter().any(|s| !s.is_prototype()) {
        for (i, inst) in out.instances.iter().enumerate() {
            let Some(s) = out.shared(&inst).filter(|s| !s.is_prototype() && expand(i)) else { continue };
            push(What::Instance(i as u32), s.mesh.n_vertices(), s.mesh.triangles.len());
        }
    }
    let mut f = Flat {
        positions: vec![[0.0; 3]; v],
        normals: vec![[0.0; 3]; v],
        colors: vec![[0.0; 4]; v],
        triangles: vec![[0; 3]; t],
        bones: vec![0; if animated { v } else { 0 }],
        animated,
    };
    // Each thread's parts: nearly equal numbers of vertices (parts are not split),
    // at least 64k vertices each (a thread costs more than it saves on less).
    let threads = threads.min(v / 65_536).clamp(1, parts.len().max(1));
    let mut bounds = vec![0usize];
    for k in 1..threads {
        let at = parts.partition_point(|p| p.vertex < v * k / threads);
        if at > *bounds.last().unwrap_or(&0) && at < parts.len() {
            bounds.push(at);
        }
    }
    bounds.push(parts.len());
    let starts = |b: usize| parts.get(b).map_or((v, t), |p| (p.vertex, p.triangle));
    let mut rest = Slices {
        positions: &mut f.positions,
        normals: &mut f.normals,
        colors: &mut f.colors,
        triangles: &mut f.triangles,
        bones: &mut f.bones,
    };
    let mut work = Vec::new();
    for w in bounds.windows(2) {
        let ((v0, t0), (v1, t1)) = (starts(w[0]), starts(w[1]));
        let (mine, others) = rest.split(v1 - v0, t1 - t0, animated);
        rest = others;
        work.push((&parts[w[0]..w[1]], v0, mine));
    }
    let convert = |(parts, v0, s): (&[Part], usize, Slices<'_>)| -> usize {
        let mut scratch = Mesh::default();
        let mut written = 0;
        for part in parts {
            let piece = match part.what {
                What::Run(r) => match runs.get(r as usize) {
                    Some(p) => Piece { base: part.vertex as u32, ..p.clone() },
                    None => continue,
                },
                What::Instance(i) => {
                    let Some(inst) = out.instances.get(i as usize) else { continue };
                    let Some(shared) = out.shared(&inst) else { continue };
                    scratch.clear();
                    if shared.is_prototype() {
                        expand_prototype(&mut scratch, shared, &inst, out.instance_weight(i as usize));
                    } else {
                        expand_isosurface(&mut scratch, &shared.mesh, out, &inst);
                    }
                    Piece {
                        mesh: &scratch,
                        vertices: 0..scratch.n_vertices(),
                        triangles: 0..scratch.triangles.len(),
                        base: part.vertex as u32,
                    }
                }
            };
            let m = piece.mesh;
            let at = part.vertex - v0;
            for (k, i) in piece.vertices.clone().enumerate() {
                let (p, n, c) = vertex(m, i);
                s.positions[at + k] = p;
                s.normals[at + k] = n;
                s.colors[at + k] = c;
                if animated {
                    s.bones[at + k] = m.bone(i);
                }
            }
            for tri in piece.triangles.clone().filter_map(|k| piece.oriented(k)) {
                if let Some(slot) = s.triangles.get_mut(written) {
                    *slot = tri;
                    written += 1;
                }
            }
        }
        written
    };
    let written = chunks_on_threads(work, convert);
    // Triangles that referred outside their piece were left out: close the gaps.
    let mut end = 0;
    for (w, n) in bounds.windows(2).zip(written) {
        let t0 = starts(w[0]).1;
        if end != t0 {
            f.triangles.copy_within(t0..t0 + n, end);
        }
        end += n;
    }
    f.triangles.truncate(end);
    f
}

/// `f` of each work item, the first on the calling thread and each other one on a
/// thread of its own; results in order.
fn chunks_on_threads<W: Send, R: Send>(work: Vec<W>, f: impl Fn(W) -> R + Sync) -> Vec<R> {
    let mut work = work.into_iter();
    let Some(first) = work.next() else { return Vec::new() };
    std::thread::scope(|scope| {
        let f = &f;
        let handles: Vec<_> = work.map(|w| scope.spawn(move || f(w))).collect();
        let mut out = vec![f(first)];
        for h in handles {
            match h.join() {
                Ok(r) => out.push(r),
                // A panicking worker is a bug: let it surface as the panic it was.
                Err(e) => std::panic::resume_unwind(e),
            }
        }
        out
    })
}

/// Whether instance `inst` of `out` is a prototype instance placed by a transform
/// (listed in [`Placed`]) rather than expanded into the base mesh; its placement.
fn placement(out: &Output, inst: &Instance) -> Option<([f32; 3], [f32; 4], [f32; 3])> {
    if !out.shared(inst).is_some_and(|s| s.is_prototype() && !s.mesh.triangles.is_empty()) {
        return None;
    }
    prototype_placement(&inst.frame)
}

/// The threads the conversions of big models use: the machine's, at most 16.
pub fn cpus() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()).min(16)
}

/// Prototype instances as meshes and placements.
#[derive(Debug, Default)]
pub struct Placed {
    pub prototypes: Vec<Flat>,
    pub names: Vec<String>,
    /// The `prototype`, `translation` and `bone` rows: `None` where the records of
    /// [`Output::instances`] hold them as they are ([`Instance::mesh`],
    /// `Instance::frame.u`, [`Instance::bone`]), which is when every instance is a
    /// placed prototype instance and every shared mesh a prototype ([`in_place`]).
    pub prototype: Option<Vec<u32>>,
    pub translation: Option<Vec<[f32; 3]>>,
    /// (w, x, y, z).
    pub rotation: Vec<[f32; 4]>,
    pub scale: Vec<[f32; 3]>,
    /// The colour rows (clamped to 0..1): `None` where the records hold them as they
    /// are (as above, and every colour already in 0..1).
    pub color: Option<Vec<[f32; 4]>>,
    pub bone: Option<Vec<u32>>,
    /// The prototype instances that could not be placed (indices into
    /// [`Output::instances`], ascending): the base mesh expands them.
    pub unplaced: Vec<u32>,
}

/// The rows of one chunk of instances: its share of each of [`Placed`]'s vectors.
type Rows<'a> =
    (&'a mut [u32], &'a mut [[f32; 3]], &'a mut [[f32; 4]], &'a mut [[f32; 3]], &'a mut [[f32; 4]], &'a mut [u32]);

/// The placed prototype instances of `out`, with every prototype (of the shared
/// meshes, in order) in its own space: normals as a renderer placing it needs them,
/// colours the deltas its vertices add to the instance's colour.
///
/// Where every instance is placed, only the rotations and scales are written (and the
/// colours if some are outside 0..1): the records hold the other rows ([`in_place`]).
/// Otherwise, one pass over the instances, on up to `threads` threads (chunks of at
/// least 64k instances): each chunk writes its rows straight into its part of the
/// final buffers (which become the numpy arrays without a copy), from the chunk's
/// first instance on; the rows of instances that are not placed (rare) leave gaps
/// that are closed afterwards.
pub fn instances(out: &Output, threads: usize) -> Placed {
    let mut p = Placed::default();
    let mut index = vec![u32::MAX; out.shared_meshes.len()];
    for (k, s) in out.shared_meshes.iter().enumerate().filter(|(_, s)| s.is_prototype()) {
        index[k] = p.prototypes.len() as u32;
        let m = &s.mesh;
        let mut f = Flat::default();
        for i in 0..m.n_vertices() {
            f.positions.push(m.positions[i]);
            f.normals.push(s.local_normal(i).to_array());
            f.colors.push(m.colors.get(i).copied().unwrap_or([0.0; 4]));
        }
        let piece = Piece { mesh: m, vertices: 0..m.n_vertices(), triangles: 0..m.triangles.len(), base: 0 };
        f.triangles.extend((0..m.triangles.len()).filter_map(|t| piece.oriented(t)));
        p.prototypes.push(f);
        p.names.push(s.name.clone());
    }
    if let Some((rotation, scale, in_range)) = in_place(out, threads) {
        p.rotation = rotation;
        p.scale = scale;
        if !in_range {
            p.color = Some(out.instances.iter().map(|i| clamped(i.color)).collect());
        }
        return p;
    }
    let all = &out.instances;
    let n = all.len();
    let threads = threads.min(n / 65_536).max(1);
    let size = n.div_ceil(threads).max(1);
    let mut prototype = vec![0; n];
    let mut translation = vec![[0.0; 3]; n];
    p.rotation = vec![[0.0; 4]; n];
    p.scale = vec![[0.0; 3]; n];
    let mut color = vec![[0.0; 4]; n];
    let mut bone = vec![0; n];
    let work: Vec<(InstanceIter<'_>, usize, Rows<'_>)> = all
        .chunks(size)
        .zip(prototype.chunks_mut(size))
        .zip(translation.chunks_mut(size))
        .zip(p.rotation.chunks_mut(size))
        .zip(p.scale.chunks_mut(size))
        .zip(color.chunks_mut(size))
        .zip(bone.chunks_mut(size))
        .enumerate()
        .map(|(c, ((((((insts, a), b), c2), d), e), f))| (insts, c * size, (a, b, c2, d, e, f)))
        .collect();
    let fill = |(insts, first, rows): (InstanceIter<'_>, usize, Rows<'_>)| -> (usize, Vec<u32>) {
        let (proto, trans, rot, scale, color, bone) = rows;
        let mut unplaced = Vec::new();
        let mut k = 0;
        for (j, inst) in insts.enumerate() {
            let Some((t, r, s)) = placement(out, &inst) else {
                if out.is_prototype_instance(&inst) {
                    unplaced.push((first + j) as u32);
                }
                continue;
            };
            proto[k] = index.get(inst.mesh as usize).copied().unwrap_or(0);
            trans[k] = t;
            rot[k] = [r[3], r[0], r[1], r[2]];
            scale[k] = s;
            color[k] = clamped(inst.color);
            bone[k] = inst.bone;
            k += 1;
        }
        (k, unplaced)
    };
    let done = chunks_on_threads(work, fill);
    // Close the gaps the instances that are not placed left.
    let mut end = 0;
    for (c, (k, unplaced)) in done.into_iter().enumerate() {
        let from = c * size;
        if end != from {
            prototype.copy_within(from..from + k, end);
            translation.copy_within(from..from + k, end);
            p.rotation.copy_within(from..from + k, end);
            p.scale.copy_within(from..from + k, end);
            color.copy_within(from..from + k, end);
            bone.copy_within(from..from + k, end);
        }
        end += k;
        p.unplaced.extend(unplaced);
    }
    prototype.truncate(end);
    translation.truncate(end);
    p.rotation.truncate(end);
    p.scale.truncate(end);
    color.truncate(end);
    bone.truncate(end);
    (p.prototype, p.translation, p.color, p.bone) = (Some(prototype), Some(translation), Some(color), Some(bone));
    p
}

/// What [`in_place`] makes: rotation rows, scale rows, whether every colour is in 0..1.
type InPlace = (Vec<[f32; 4]>, Vec<[f32; 3]>, bool);

/// The rotation and scale rows of every instance of `out`, and whether every
/// instance's colour is in 0..1; `None` unless there are instances, every one of
/// them a placed prototype instance, and every shared mesh a prototype (so that
/// an instance's prototype index is its [`Instance::mesh`]): then the records of
/// [`Output::instances`] hold the other rows as they are ([`Placed`]). Chunks of at
/// least 64k instances on up to `threads` threads, as [`instances`].
fn in_place(out: &Output, threads: usize) -> Option<InPlace> {
    let all = &out.instances;
    if all.is_empty() || !out.shared_meshes.iter().all(|s| s.is_prototype() && !s.mesh.triangles.is_empty()) {
        return None;
    }
    let n = all.len();
    let threads = threads.min(n / 65_536).max(1);
    let size = n.div_ceil(threads).max(1);
    let mut rotation = vec![[0.0; 4]; n];
    let mut scale = vec![[0.0; 3]; n];
    let work: Vec<_> = all.chunks(size).zip(rotation.chunks_mut(size)).zip(scale.chunks_mut(size)).collect();
    let done = chunks_on_threads(work, |((insts, rot), sc)| -> Option<bool> {
        let mut in_range = true;
        for ((inst, r), s) in insts.zip(rot).zip(sc) {
            let (_, q, k) = placement(out, &inst)?;
            *r = [q[3], q[0], q[1], q[2]];
            *s = k;
            in_range &= inst.color.iter().all(|c| (0.0..=1.0).contains(c));
        }
        Some(in_range)
    });
    let mut in_range = true;
    for d in done {
        in_range &= d?;
    }
    Some((rotation, scale, in_range))
}

/// The prototype instances of `out` that [`instances`] cannot place (ascending).
pub fn unplaced(out: &Output, threads: usize) -> Vec<u32> {
    let all = &out.instances;
    let threads = threads.min(all.len() / 65_536).max(1);
    let size = all.len().div_ceil(threads).max(1);
    let work: Vec<_> = all.chunks(size).enumerate().collect();
    chunks_on_threads(work, |(c, insts)| {
        let first = c * size;
        insts
            .enumerate()
            .filter(|(_, i)| out.is_prototype_instance(i) && placement(out, i).is_none())
            .map(|(j, _)| (first + j) as u32)
            .collect::<Vec<u32>>()
    })
    .concat()
}
