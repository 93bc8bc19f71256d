//! An [`Output`] turned into flat buffers (Rust vectors that become numpy arrays
//! without a copy): the flat walks of [`Output::for_each_piece_where`], and the
//! prototype instances as meshes plus placements.

use glam::Vec3;
use mdg_vm::export::glb::prototype_placement;
use mdg_vm::output::{Groups, Instance, Output, Piece};

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

impl Flat {
    fn push_piece(&mut self, p: &Piece) {
        let m = p.mesh;
        for i in p.vertices.clone() {
            self.positions.push(finite3(m.positions[i]));
            self.normals.push(unit(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0])));
            self.colors.push(clamped(m.colors.get(i).copied().unwrap_or([1.0; 4])));
            if self.animated {
                self.bones.push(m.bone(i));
            }
        }
        self.triangles.extend(p.triangles.clone().filter_map(|k| p.oriented(k)));
    }
}

/// The geometry of `groups` as one world-space mesh, leaving out the instances
/// `expand` refuses (triangles wound as the exporters write them).
pub fn flatten(out: &Output, groups: Groups, expand: impl Fn(usize) -> bool) -> Flat {
    let (v, t) = out.flat_counts_where(groups, &expand);
    let animated = out.animation.bones.len() > 1;
    let mut f = Flat {
        positions: Vec::with_capacity(v),
        normals: Vec::with_capacity(v),
        colors: Vec::with_capacity(v),
        triangles: Vec::with_capacity(t),
        bones: Vec::with_capacity(if animated { v } else { 0 }),
        animated,
    };
    let _ = out.for_each_piece_where::<()>(groups, &expand, |p| {
        f.push_piece(p);
        Ok(())
    });
    f
}

/// Whether instance `inst` of `out` is a prototype instance placed by a transform
/// (listed in [`Placed`]) rather than expanded into the base mesh; its placement.
fn placement(out: &Output, inst: &Instance) -> Option<([f32; 3], [f32; 4], [f32; 3])> {
    if !out.shared(inst).is_some_and(|s| s.is_prototype() && !s.mesh.triangles.is_empty()) {
        return None;
    }
    prototype_placement(&inst.frame)
}

/// The threads the conversions of big models use: the machine's, at most 16, and
/// one per 64k items at least (threads cost more than they save on small models).
fn threads_for(items: usize) -> usize {
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get()).min(16);
    cpus.min(items / 65_536).max(1)
}

/// `f(chunk index, chunk)` for `threads` nearly equal chunks of `0..n`, on as many
/// threads (the calling thread takes the first); results in chunk order.
fn chunked<R: Send>(n: usize, threads: usize, f: impl Fn(std::ops::Range<usize>) -> R + Sync) -> Vec<R> {
    let size = n.div_ceil(threads.max(1)).max(1);
    let ranges: Vec<_> = (0..n).step_by(size).map(|a| a..(a + size).min(n)).collect();
    if ranges.len() <= 1 {
        return vec![f(0..n)];
    }
    std::thread::scope(|scope| {
        let f = &f;
        let handles: Vec<_> = ranges[1..].iter().map(|r| scope.spawn(move || f(r.clone()))).collect();
        let mut out = vec![f(ranges[0].clone())];
        // A panicking worker is a bug; its chunk is then computed again here.
        out.extend(handles.into_iter().zip(&ranges[1..]).map(|(h, r)| h.join().unwrap_or_else(|_| f(r.clone()))));
        out
    })
}

/// Per instance of `out`: whether it is a prototype instance placed by a transform
/// (listed in [`Placed`]) rather than expanded into the base mesh.
pub fn placed(out: &Output) -> Vec<bool> {
    let n = out.instances.len();
    chunked(n, threads_for(n), |r| out.instances[r].iter().map(|i| placement(out, i).is_some()).collect::<Vec<_>>())
        .concat()
}

/// Prototype instances as meshes and placements.
#[derive(Debug, Default)]
pub struct Placed {
    pub prototypes: Vec<Flat>,
    pub names: Vec<String>,
    pub prototype: Vec<u32>,
    pub translation: Vec<[f32; 3]>,
    /// (w, x, y, z).
    pub rotation: Vec<[f32; 4]>,
    pub scale: Vec<[f32; 3]>,
    pub color: Vec<[f32; 4]>,
    pub bone: Vec<u32>,
}

/// The placed prototype instances of `out` (see [`placed`]), with every prototype
/// (of the shared meshes, in order) in its own space: normals as a renderer placing
/// it needs them, colours the deltas its vertices add to the instance's colour.
///
/// Big models are converted on several threads: a first pass counts each chunk's
/// placed instances, then every thread writes its rows straight into its own part
/// of the final buffers (which become the numpy arrays without a copy).
pub fn instances(out: &Output) -> Placed {
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
    let all = &out.instances;
    let threads = threads_for(all.len());
    let counts = chunked(all.len(), threads, |r| all[r].iter().filter(|i| placement(out, i).is_some()).count());
    let n: usize = counts.iter().sum();
    p.prototype = vec![0; n];
    p.translation = vec![[0.0; 3]; n];
    p.rotation = vec![[0.0; 4]; n];
    p.scale = vec![[0.0; 3]; n];
    p.color = vec![[0.0; 4]; n];
    p.bone = vec![0; n];
    // Each chunk's rows: the same chunks as the count, so chunk c's rows start at the
    // sum of the counts before it.
    type Rows<'a> =
        (&'a mut [u32], &'a mut [[f32; 3]], &'a mut [[f32; 4]], &'a mut [[f32; 3]], &'a mut [[f32; 4]], &'a mut [u32]);
    let mut parts: Vec<Rows<'_>> = Vec::with_capacity(counts.len());
    {
        let (mut a, mut b, mut c, mut d, mut e, mut f) = (
            &mut p.prototype[..],
            &mut p.translation[..],
            &mut p.rotation[..],
            &mut p.scale[..],
            &mut p.color[..],
            &mut p.bone[..],
        );
        for &k in &counts {
            let (a1, a2) = std::mem::take(&mut a).split_at_mut(k);
            let (b1, b2) = std::mem::take(&mut b).split_at_mut(k);
            let (c1, c2) = std::mem::take(&mut c).split_at_mut(k);
            let (d1, d2) = std::mem::take(&mut d).split_at_mut(k);
            let (e1, e2) = std::mem::take(&mut e).split_at_mut(k);
            let (f1, f2) = std::mem::take(&mut f).split_at_mut(k);
            parts.push((a1, b1, c1, d1, e1, f1));
            (a, b, c, d, e, f) = (a2, b2, c2, d2, e2, f2);
        }
    }
    let size = all.len().div_ceil(threads.max(1)).max(1);
    let fill = |(chunk, rows): (usize, Rows<'_>)| {
        let (proto, trans, rot, scale, color, bone) = rows;
        let start = chunk * size;
        let mut k = 0;
        for inst in &all[start..(start + size).min(all.len())] {
            let Some((t, r, s)) = placement(out, inst) else { continue };
            proto[k] = index.get(inst.mesh as usize).copied().unwrap_or(0);
            trans[k] = t;
            rot[k] = [r[3], r[0], r[1], r[2]];
            scale[k] = s;
            color[k] = clamped(inst.color);
            bone[k] = inst.bone;
            k += 1;
        }
    };
    std::thread::scope(|scope| {
        let mut work = parts.into_iter().enumerate();
        let first = work.next();
        for w in work {
            scope.spawn(move || fill(w));
        }
        if let Some(w) = first {
            fill(w);
        }
    });
    p
}
