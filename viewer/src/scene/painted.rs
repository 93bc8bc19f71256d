//! Flat art packed for painting in program order with its prototype instances kept
//! as instances: the mesh's runs between them and the sweeps are packed as any
//! scene's, and the paint order says which run or which instances come next. The
//! CPU renderer expands each instance as it paints it (`crate::cpu`), so a picture
//! of Context Free's art holds its circles as records, not as vertices.
//!
//! What it paints is what the scene of [`super::build`] (every instance expanded in
//! place, one mesh) paints, bit for bit: the same vertices (`u + lin · p`, as
//! `mdg_vm::output::expand_prototype` computes them), colours, windings and order,
//! and the same bounds.

use super::{Bounds, Builder, Scene, VERTEX_STRIDE};
use glam::{Mat3, Vec3};
use mdg_vm::output::{Output, Span, VertexRun};
use std::ops::Range;

/// One step of the paint order.
#[derive(Clone, Debug)]
pub enum PaintStep {
    /// Triangles of the scene's index list (`indices[3 * start..3 * end]`).
    Mesh(Range<usize>),
    /// Prototype instances `instances` (indices into the output's instances, frames
    /// in its packed frames), all with `span`'s fields.
    Prototypes { instances: Range<usize>, span: Span },
}

/// A prototype as the painter reads it: its distinct positions, each vertex's
/// position and colour delta, its triangles, and a sphere around it.
#[derive(Clone, Debug, Default)]
pub struct PaintProto {
    /// The distinct positions (a circle's 96 vertices are 33 points).
    pub points: Vec<Vec3>,
    /// Per vertex: its point.
    pub point_of: Vec<u32>,
    /// The distinct colour deltas (added to the instance's colour, clamped), and
    /// per vertex its delta.
    pub deltas: Vec<[f32; 4]>,
    pub delta_of: Vec<u32>,
    /// The triangles (vertex indices) and whether each was made in a mirrored frame.
    pub triangles: Vec<[u32; 3]>,
    pub mirrored: Vec<bool>,
    /// Centre and radius of a sphere around the points.
    pub centre: Vec3,
    pub radius: f32,
}

impl PaintProto {
    fn of(m: &mdg_vm::output::Mesh) -> PaintProto {
        let (points, point_of) = distinct(m.positions.iter().map(|p| (p.map(f32::to_bits), Vec3::from_array(*p))));
        let (deltas, delta_of) = distinct((0..m.n_vertices()).map(|i| {
            let d = m.colors.get(i).copied().unwrap_or([0.0; 4]);
            (d.map(f32::to_bits), d)
        }));
        let mut b = Bounds::EMPTY;
        points.iter().for_each(|&p| b.add(p));
        let centre = if b.is_empty() { Vec3::ZERO } else { (b.lo + b.hi) * 0.5 };
        let radius = points.iter().map(|p| p.distance(centre)).fold(0.0f32, f32::max);
        PaintProto {
            points,
            point_of,
            deltas,
            delta_of,
            triangles: m.triangles.clone(),
            mirrored: (0..m.triangles.len()).map(|t| m.mirrored.get(t).copied().unwrap_or(false)).collect(),
            centre,
            radius,
        }
    }
}

/// The distinct values of `items` (by their keys, in order of first sight), and per
/// item the index of its value.
fn distinct<K: std::hash::Hash + Eq, T>(items: impl Iterator<Item = (K, T)>) -> (Vec<T>, Vec<u32>) {
    let mut values = Vec::new();
    let mut seen = std::collections::HashMap::new();
    let index = items
        .map(|(k, v)| {
            *seen.entry(k).or_insert_with(|| {
                values.push(v);
                values.len() as u32 - 1
            })
        })
        .collect();
    (values, index)
}

/// Flat art's paint order ([`build_painted`]).
#[derive(Clone, Debug, Default)]
pub struct Painted {
    pub steps: Vec<PaintStep>,
    /// Per shared mesh: the prototype as the painter reads it.
    pub protos: Vec<PaintProto>,
    /// Triangles the instances paint.
    pub instance_triangles: u64,
}

/// `out` (flat art) packed for painting in order, its prototype instances kept
/// ([`Painted`]), or `None` where that does not apply: no prototype instance, an
/// isosurface instance (painted after everything else, expanded), or bones and
/// weights (the painter does not skin).
pub fn build_painted(out: &Output) -> Option<(Scene, Painted)> {
    if !out.flat
        || super::skinned(out)
        || out.instances.is_empty()
        || !out.shared_meshes.iter().all(|s| s.is_prototype())
    {
        return None;
    }
    let protos: Vec<PaintProto> = out.shared_meshes.iter().map(|s| PaintProto::of(&s.mesh)).collect();
    let mut b = Builder { s: Scene { bounds: Bounds::EMPTY, ..Scene::default() }, skinned: false };
    b.s.vertices.reserve((out.mesh.n_vertices() + out.sweeps.n_vertices()) * VERTEX_STRIDE as usize);
    let mut steps = Vec::new();
    let mut instance_triangles = 0u64;
    let frames = out.instances.packed_frames();
    let mesh_step = |b: &mut Builder, steps: &mut Vec<PaintStep>, p: &mdg_vm::output::Piece| {
        let from = b.s.indices.len() / 3;
        b.piece(p);
        let to = b.s.indices.len() / 3;
        if to > from {
            steps.push(PaintStep::Mesh(from..to));
        }
    };
    let _ = out.for_each_vertex_run::<()>(&|_| true, |run| {
        match run {
            VertexRun::Piece(p) => mesh_step(&mut b, &mut steps, &p),
            VertexRun::Prototypes { instances, span, .. } => {
                let Some(proto) = protos.get(span.mesh as usize) else { return Ok(()) };
                for f in frames.get(instances.clone()).unwrap_or(&[]) {
                    let frame = span.instance(f).frame;
                    let (lin, _) = frame.linear();
                    add_points(&mut b.s.bounds, proto, lin, frame.u);
                }
                instance_triangles += (proto.triangles.len() * instances.len()) as u64;
                steps.push(PaintStep::Prototypes { instances, span });
            }
        }
        Ok(())
    });
    let sweeps = mdg_vm::output::Piece {
        mesh: &out.sweeps,
        vertices: 0..out.sweeps.n_vertices(),
        triangles: 0..out.sweeps.triangles.len(),
        base: 0,
    };
    mesh_step(&mut b, &mut steps, &sweeps);
    b.lines(out);
    Some((b.s, Painted { steps, protos, instance_triangles }))
}

/// Adds the points of `proto` placed by `lin` and `u` to `bounds` (as the expanded
/// vertices would add them).
fn add_points(bounds: &mut Bounds, proto: &PaintProto, lin: Mat3, u: Vec3) {
    for &p in &proto.points {
        bounds.add(u + lin * p);
    }
}
