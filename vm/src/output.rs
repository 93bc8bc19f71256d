//! What an evaluation produces: flat buffers, ready for the exporters.
//!
//! Geometry is kept in three groups so tools can tell them apart: triangles emitted by
//! `VERTEX` ([`Output::mesh`]), swept profiles from `LINETO`/`BLENDTO`/… ([`Output::sweeps`]),
//! and instances of shared meshes such as isosurfaces ([`Output::instances`]).

use glam::{Mat4, Vec3};
use serde::Serialize;

/// A triangle mesh as flat per-vertex buffers plus an index list.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// RGBA, each in 0..1 after clamping by the exporters.
    pub colors: Vec<[f32; 4]>,
    /// Weight per vertex, or empty while every weight is zero (most models), which
    /// saves a third of the memory of big outputs. Read with [`Mesh::weight`].
    pub weights: Vec<[f32; 4]>,
    /// Bone index per vertex (0 = the root, unanimated), or empty while all are 0.
    /// Read with [`Mesh::bone`].
    pub bones: Vec<u32>,
    /// Triangles as vertex indices, in emission order.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: emitted in a mirrored frame (odd number of flips). Exporters
    /// reverse the winding of these so every face faces outward (SPEC resolved semantics 8).
    pub mirrored: Vec<bool>,
}

impl Mesh {
    /// Appends one vertex and returns its index.
    pub fn push_vertex(&mut self, p: Vec3, n: Vec3, color: [f32; 4], weight: [f32; 4], bone: u32) -> u32 {
        let i = self.positions.len();
        self.positions.push(p.to_array());
        self.normals.push(n.to_array());
        self.colors.push(color);
        if weight != [0.0; 4] || !self.weights.is_empty() {
            self.weights.resize(i, [0.0; 4]);
            self.weights.push(weight);
        }
        if bone != 0 || !self.bones.is_empty() {
            self.bones.resize(i, 0);
            self.bones.push(bone);
        }
        i as u32
    }

    /// The weight of vertex `i` (zero when weights are not stored).
    pub fn weight(&self, i: usize) -> [f32; 4] {
        self.weights.get(i).copied().unwrap_or([0.0; 4])
    }

    /// The bone of vertex `i` (0 when bones are not stored).
    pub fn bone(&self, i: usize) -> u32 {
        self.bones.get(i).copied().unwrap_or(0)
    }

    /// Appends a triangle.
    pub fn push_triangle(&mut self, t: [u32; 3], mirrored: bool) {
        self.triangles.push(t);
        self.mirrored.push(mirrored);
    }

    /// Triangles with the winding corrected for mirrored frames: what exporters write.
    pub fn oriented_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.triangles
            .iter()
            .zip(self.mirrored.iter().chain(std::iter::repeat(&false)))
            .map(|(t, m)| if *m { [t[0], t[2], t[1]] } else { *t })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Appends all of `other`, offsetting its indices.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.colors.extend_from_slice(&other.colors);
        if !self.weights.is_empty() || !other.weights.is_empty() {
            self.weights.resize(base as usize, [0.0; 4]);
            self.weights.extend((0..other.n_vertices()).map(|i| other.weight(i)));
        }
        if !self.bones.is_empty() || !other.bones.is_empty() {
            self.bones.resize(base as usize, 0);
            self.bones.extend((0..other.n_vertices()).map(|i| other.bone(i)));
        }
        self.triangles.extend(other.triangles.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        self.mirrored.extend_from_slice(&other.mirrored);
    }
}

/// A pen line: the positions reached by MOVETO/LINETO/BLENDTO/SLINETO/ALINETO in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Polyline {
    pub namespace: String,
    pub points: Vec<[f32; 3]>,
}

/// One placement of a shared mesh (an isosurface, say).
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// The drawable's name, e.g. `SPHERE`.
    pub name: String,
    /// Index into [`Output::shared_meshes`].
    pub mesh: u32,
    /// Object-to-world transform (rotation, uniform scale, translation; may be mirrored).
    pub transform: Mat4,
    /// Linear scale of the frame (the quaternion norm, SPEC resolved semantics 7).
    pub scale: f32,
    pub color: [f32; 4],
    pub mirrored: bool,
    pub bone: u32,
}

/// Counters reported by `--stats` and stored in the JSON dump.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub rule_calls: u64,
    pub vertices: u64,
    pub triangles: u64,
    pub max_depth: u32,
    pub elapsed_ms: f64,
    /// Limits that ended branches or the run, with a message each.
    pub warnings: Vec<String>,
}

/// Everything an evaluation produced.
#[derive(Clone, Debug, Default)]
pub struct Output {
    pub mesh: Mesh,
    pub sweeps: Mesh,
    pub lines: Vec<Polyline>,
    pub shared_meshes: Vec<(String, Mesh)>,
    pub instances: Vec<Instance>,
    pub stats: Stats,
    /// `background r g b a`.
    pub background: [f32; 4],
}

impl Output {
    /// All geometry as one mesh in world space: VERTEX triangles, sweeps and every
    /// instance expanded (formats without instancing use this).
    pub fn flattened(&self) -> Mesh {
        let mut m = self.mesh.clone();
        m.append(&self.sweeps);
        for inst in &self.instances {
            let Some((_, shared)) = self.shared_meshes.get(inst.mesh as usize) else { continue };
            let base = m.positions.len() as u32;
            let normal_mat = inst.transform.inverse().transpose();
            for (i, p) in shared.positions.iter().enumerate() {
                let wp = inst.transform.transform_point3(Vec3::from(*p));
                let n = shared.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]);
                let wn = normal_mat.transform_vector3(Vec3::from(n)).normalize_or_zero();
                m.push_vertex(wp, wn, inst.color, [0.0; 4], inst.bone);
            }
            for (t, mir) in shared.triangles.iter().zip(shared.mirrored.iter().chain(std::iter::repeat(&false))) {
                m.push_triangle([t[0] + base, t[1] + base, t[2] + base], *mir != inst.mirrored);
            }
        }
        m
    }
}
