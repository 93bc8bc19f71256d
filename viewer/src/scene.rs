//! An evaluation's output packed for the GPU: interleaved vertices, indices with the
//! winding corrected for mirrored frames, pen-line segments, and the bounding sphere
//! the camera frames.
//!
//! Vertex layout (binding 0, 24 bytes; the shader sees the types of reference §13):
//! position `R32G32B32_SFLOAT` (location 0, `vec3`), normal `R16G16B16A16_SNORM`
//! (location 1, `vec3`), colour `R8G8B8A8_UNORM` (location 2, `vec4`). Binding 1
//! (20 bytes): weight `R32G32B32A32_SFLOAT` (location 3, `vec4`) and bone `R32_UINT`
//! (location 4, `uint`); most models have neither, and then binding 1 is one zero
//! element read with stride 0, which saves 45% of the memory of a big model.

use glam::Vec3;
use mdg_vm::output::{Groups, Output, Piece};

/// Bytes per vertex in binding 0.
pub const VERTEX_STRIDE: u32 = 24;
/// Bytes per vertex in binding 1 (weight, bone).
pub const SKIN_STRIDE: u32 = 20;

/// The model's extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Bounds {
    /// Nothing yet.
    pub const EMPTY: Bounds = Bounds { lo: Vec3::splat(f32::MAX), hi: Vec3::splat(f32::MIN) };
}

impl Default for Bounds {
    fn default() -> Bounds {
        Bounds::EMPTY
    }
}

impl Bounds {
    /// Grows to include `p` (non-finite points are ignored).
    pub fn add(&mut self, p: Vec3) {
        if p.is_finite() {
            self.lo = self.lo.min(p);
            self.hi = self.hi.max(p);
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }

    /// Centre and radius of the sphere around the box (unit sphere when empty).
    pub fn sphere(&self) -> (Vec3, f32) {
        if self.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            ((self.lo + self.hi) * 0.5, ((self.hi - self.lo).length() * 0.5).max(1e-4))
        }
    }

    /// Whether the model is flat in z (curves, tilings): shown from above.
    pub fn is_flat(&self) -> bool {
        let (_, r) = self.sphere();
        !self.is_empty() && (self.hi.z - self.lo.z) < r * 0.01
    }
}

/// Packed geometry, ready to upload.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Binding 0 data, [`VERTEX_STRIDE`] bytes per vertex.
    pub vertices: Vec<u8>,
    /// Binding 1 data, [`SKIN_STRIDE`] bytes per vertex, or empty when every weight
    /// and bone is zero.
    pub skins: Vec<u8>,
    pub indices: Vec<u32>,
    /// Pen-line segments as pairs of vertices (binding 0 layout); drawn when nothing
    /// was swept along the lines.
    pub line_vertices: Vec<u8>,
    pub n_vertices: u32,
    /// All line vertices: pen lines first, then the overlay lines.
    pub n_line_vertices: u32,
    /// How many of the line vertices (the last ones) are overlays ([`OVERLAYS`]):
    /// guided search's guide curves (namespace `guides`), skeleton bones (namespace
    /// `bones`) and the guide editor's lines, drawn whether or not anything was
    /// swept, in their own colours, over the model.
    pub n_overlay_vertices: u32,
    /// Largest bone index used (the bones buffer holds this many + 1 matrices).
    pub max_bone: u32,
    pub bounds: Bounds,
}

impl Scene {
    /// Number of triangles.
    pub fn n_triangles(&self) -> usize {
        self.indices.len() / 3
    }
}

fn snorm16(v: f32) -> i16 {
    (v.clamp(-1.0, 1.0) * 32767.0).round() as i16
}

fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Appends one binding-0 vertex.
fn push_vertex(out: &mut Vec<u8>, p: Vec3, n: Vec3, c: [f32; 4]) {
    let n = n.normalize_or_zero();
    for x in p.to_array() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    for x in [n.x, n.y, n.z, 0.0] {
        out.extend_from_slice(&snorm16(x).to_le_bytes());
    }
    out.extend_from_slice(&c.map(unorm8));
}

fn push_skin(out: &mut Vec<u8>, w: [f32; 4], bone: u32) {
    for x in w {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out.extend_from_slice(&bone.to_le_bytes());
}

struct Builder {
    s: Scene,
    skinned: bool,
}

impl Builder {
    /// Appends a flat piece of the output (world space), with oriented triangles.
    fn piece(&mut self, p: &Piece) {
        let m = p.mesh;
        let base = self.s.n_vertices;
        for i in p.vertices.clone() {
            let pos = Vec3::from_array(m.positions[i]);
            let nn = Vec3::from_array(m.normals.get(i).copied().unwrap_or([0.0, 0.0, 1.0]));
            let c = m.colors.get(i).copied().unwrap_or([1.0; 4]);
            let bone = m.bone(i);
            self.s.bounds.add(pos);
            push_vertex(&mut self.s.vertices, pos, nn, c);
            if self.skinned {
                push_skin(&mut self.s.skins, m.weight(i), bone);
            }
            self.s.max_bone = self.s.max_bone.max(bone);
        }
        for k in p.triangles.clone() {
            if let Some(t) = p.oriented(k) {
                self.s.indices.extend(t.map(|v| v - p.base + base));
            }
        }
        self.s.n_vertices += p.vertices.len() as u32;
    }
}

/// Packs an output: the VERTEX mesh, sweeps and every instance (expanded in place),
/// plus pen lines when there are no sweeps.
pub fn build(out: &Output) -> Scene {
    let skinned = !out.mesh.weights.is_empty()
        || !out.mesh.bones.is_empty()
        || !out.sweeps.weights.is_empty()
        || !out.sweeps.bones.is_empty()
        || !out.instance_weights.is_empty()
        || out.instances.iter().any(|i| i.bone != 0);
    let (n_vertices, _) = out.flat_counts(Groups::ALL);
    let mut b = Builder { s: Scene { bounds: Bounds::EMPTY, ..Scene::default() }, skinned };
    b.s.vertices.reserve(n_vertices * VERTEX_STRIDE as usize);
    if skinned {
        b.s.skins.reserve(n_vertices * SKIN_STRIDE as usize);
    }
    let _ = out.for_each_piece::<()>(Groups::ALL, |p| {
        b.piece(p);
        Ok(())
    });
    let is_overlay = |l: &mdg_vm::output::Polyline| OVERLAYS.iter().any(|(ns, _)| *ns == l.namespace);
    if out.sweeps.triangles.is_empty() {
        let ink = ink(out.background);
        for line in out.lines.iter().filter(|l| !is_overlay(l)) {
            for seg in line.points.windows(2) {
                for p in seg {
                    let p = Vec3::from_array(*p);
                    b.s.bounds.add(p);
                    push_vertex(&mut b.s.line_vertices, p, Vec3::ZERO, ink);
                    b.s.n_line_vertices += 1;
                }
            }
        }
    }
    for (ns, color) in OVERLAYS {
        let color = color.unwrap_or_else(|| ink(out.background));
        for line in out.lines.iter().filter(|l| l.namespace == ns) {
            for seg in line.points.windows(2) {
                for p in seg {
                    let p = Vec3::from_array(*p);
                    b.s.bounds.add(p);
                    push_vertex(&mut b.s.line_vertices, p, Vec3::ZERO, color);
                    b.s.n_line_vertices += 1;
                    b.s.n_overlay_vertices += 1;
                }
            }
        }
    }
    b.s
}

/// Line namespaces drawn as overlays (over the model, in this order), and their
/// colours: guide curves amber, skeleton bones cyan (as the live preview draws
/// them), and the guide editor's selected guide magenta and control-point markers in
/// the ink colour (`None`: [`ink`]).
pub const OVERLAYS: [(&str, Option<[f32; 4]>); 4] = [
    ("guides", Some([1.0, 0.66, 0.0, 1.0])),
    ("bones", Some([0.0, 0.78, 0.92, 1.0])),
    ("guide_selected", Some([0.9, 0.1, 0.75, 1.0])),
    ("guide_points", None),
];

/// The colour pen lines are drawn in: dark on a light background, light on a dark one.
pub fn ink(background: [f32; 4]) -> [f32; 4] {
    if background[0] + background[1] + background[2] > 1.5 {
        [0.1, 0.1, 0.1, 1.0]
    } else {
        [0.9, 0.9, 0.9, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirrored_triangles_are_reoriented_and_bounds_cover_everything() {
        let mut out = Output::default();
        let m = &mut out.mesh;
        for p in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            m.push_vertex(Vec3::from_array(p), Vec3::Z, [1.0, 0.0, 0.0, 1.0], [0.0; 4], 0);
        }
        m.push_triangle([0, 1, 2], true);
        let s = build(&out);
        assert_eq!(s.indices, vec![0, 2, 1]);
        assert_eq!(s.vertices.len(), 3 * VERTEX_STRIDE as usize);
        assert!(s.skins.is_empty());
        assert_eq!(s.bounds.lo, Vec3::ZERO);
        assert_eq!(s.bounds.hi, Vec3::new(1.0, 1.0, 0.0));
        assert!(s.bounds.is_flat());
        // Colour bytes of the first vertex: red, opaque.
        assert_eq!(&s.vertices[20..24], &[255, 0, 0, 255]);
    }
}
