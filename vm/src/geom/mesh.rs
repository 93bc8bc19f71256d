//! The triangle mesh the geometry kernels append to (and evaluation's output
//! holds, see [`crate::output`]).

use glam::Vec3;

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
    /// Per vertex: made by a flat primitive (std `flat`'s `CIRCLE`, `SQUARE`,
    /// `TRIANGLE`), which the default picture program draws without a specular
    /// highlight; empty while no vertex is. Read with [`Mesh::matte`].
    pub matte: Vec<bool>,
}

impl Mesh {
    /// Appends one vertex and returns its index.
    #[inline]
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

    /// Whether vertex `i` is a flat primitive's (see [`Mesh::matte`](Mesh#structfield.matte)).
    pub fn matte(&self, i: usize) -> bool {
        self.matte.get(i).copied().unwrap_or(false)
    }

    /// Marks vertices `range` (clamped to the mesh) as a flat primitive's.
    pub fn mark_matte(&mut self, range: std::ops::Range<usize>) {
        let n = self.n_vertices();
        let (start, end) = (range.start.min(n), range.end.min(n));
        if start < end {
            self.matte.resize(n, false);
            self.matte[start..end].fill(true);
        }
    }

    /// Appends a triangle.
    #[inline]
    pub fn push_triangle(&mut self, t: [u32; 3], mirrored: bool) {
        self.triangles.push(t);
        self.mirrored.push(mirrored);
    }

    /// Triangles with the winding corrected for mirrored frames: what exporters write.
    pub fn oriented_triangles(&self) -> impl Iterator<Item = [u32; 3]> + '_ {
        self.triangles.iter().zip(self.mirrored.iter().chain(std::iter::repeat(&false))).map(|(t, m)| {
            if *m {
                [t[0], t[2], t[1]]
            } else {
                *t
            }
        })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Removes everything, keeping the buffers' capacity.
    pub fn clear(&mut self) {
        self.positions.clear();
        self.normals.clear();
        self.colors.clear();
        self.weights.clear();
        self.bones.clear();
        self.triangles.clear();
        self.mirrored.clear();
        self.matte.clear();
    }

    /// Makes room for `vertices` more vertices and `triangles` more triangles.
    pub fn reserve(&mut self, vertices: usize, triangles: usize) {
        self.positions.reserve(vertices);
        self.normals.reserve(vertices);
        self.colors.reserve(vertices);
        self.triangles.reserve(triangles);
        self.mirrored.reserve(triangles);
    }

    /// Appends vertices `vertices` of `other` (vertex by vertex, as [`Mesh::push_vertex`]
    /// would) and its triangles `triangles`, which refer to those vertices (indices
    /// are moved to where the vertices land).
    pub fn append_range(&mut self, other: &Mesh, vertices: std::ops::Range<usize>, triangles: std::ops::Range<usize>) {
        let base = self.positions.len() as i64 - vertices.start as i64;
        for i in vertices {
            let n = other.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]);
            let c = other.colors.get(i).copied().unwrap_or([1.0; 4]);
            let k = self.push_vertex(Vec3::from(other.positions[i]), Vec3::from(n), c, other.weight(i), other.bone(i));
            if other.matte(i) {
                self.mark_matte(k as usize..k as usize + 1);
            }
        }
        for t in triangles {
            let tri = other.triangles[t].map(|v| (v as i64 + base) as u32);
            self.push_triangle(tri, other.mirrored.get(t).copied().unwrap_or(false));
        }
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
        if !self.matte.is_empty() || !other.matte.is_empty() {
            self.matte.resize(base as usize, false);
            self.matte.extend((0..other.n_vertices()).map(|i| other.matte(i)));
        }
        self.triangles.extend(other.triangles.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
        self.mirrored.extend_from_slice(&other.mirrored);
    }
}
