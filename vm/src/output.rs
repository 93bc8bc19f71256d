//! What an evaluation produces: flat buffers, ready for the exporters.
//!
//! Geometry is kept in three groups so tools can tell them apart: triangles emitted by
//! `VERTEX` ([`Output::mesh`]), swept profiles from `LINETO`/`BLENDTO`/… ([`Output::sweeps`]),
//! and instances of shared meshes such as isosurfaces ([`Output::instances`]).
//! Animation ([`Output::animation`]) is kept beside the geometry: the bones with
//! the frame tracks of their transform rules, and the camera's track; vertices refer
//! to their bone by index ([`Mesh::bones`]). Sampling at a time is in [`crate::anim`].

use crate::geom::quat::Frame;
use glam::{Mat4, Vec3};
use serde::Serialize;

pub use crate::geom::Mesh;

/// A pen line: the positions reached by MOVETO/LINETO/BLENDTO/SLINETO/ALINETO in order.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Polyline {
    pub namespace: String,
    pub points: Vec<[f32; 3]>,
    /// Bone per point (as [`Mesh::bones`]), or empty while all are 0.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub bones: Vec<u32>,
}

impl Polyline {
    /// Appends a point drawn in `bone`.
    pub fn push(&mut self, p: Vec3, bone: u32) {
        let i = self.points.len();
        self.points.push(p.to_array());
        if bone != 0 || !self.bones.is_empty() {
            self.bones.resize(i, 0);
            self.bones.push(bone);
        }
    }

    /// The bone of point `i` (0 when bones are not stored).
    pub fn bone(&self, i: usize) -> u32 {
        self.bones.get(i).copied().unwrap_or(0)
    }
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

/// Counters reported by `--stats` and stored in the JSON dump (all but the elapsed
/// time: a dump is byte-identical from run to run; timings go to `--stats`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    pub rule_calls: u64,
    pub vertices: u64,
    pub triangles: u64,
    pub max_depth: u32,
    /// Wall-clock time of the evaluation (`--stats` only; never in the dump).
    #[serde(skip)]
    pub elapsed_ms: f64,
    /// Limits that ended branches or the run, with a message each.
    pub warnings: Vec<String>,
}

/// The frames one transform rule emitted (thesis §4.4.1), in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// The transform rule's name.
    pub rule: String,
    /// Frame k is the frame of the k-th `FRAME {adj}` reached when the rule is
    /// evaluated from the identity: the current frame composed with `adj`.
    pub frames: Vec<Frame>,
    /// True when the rule ended by itself (a finite track: animation wraps around
    /// it); false when it was cut at the number of frames the run needed (an
    /// infinite rule, sampled lazily).
    pub complete: bool,
}

/// A bone: one call of a model rule with transform rules (`rule A : X1 : X2 {…}`).
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    /// The model rule's name (`""` for the root, bone 0).
    pub rule: String,
    /// The enclosing bone (0 = the root; the root is its own parent).
    pub parent: u32,
    /// A's frame at the call, in world space (the rest pose): A's own space.
    pub rest: Frame,
    /// Frames per second of the bone's transform rules (the `fps` directive plus the
    /// `fps` adjustments on the way to the call).
    pub fps: f32,
    /// The transform rules X1…Xn, as indices into [`Animation::tracks`].
    pub tracks: Vec<u32>,
}

/// The camera of a `camerarule`.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The camera rule's frames, as an index into [`Animation::tracks`].
    pub track: u32,
    /// Frames per second (the `fps` directive).
    pub fps: f32,
    /// `camerafov`: vertical field of view in degrees.
    pub fov: f32,
    /// `cameranearplane`.
    pub near: f32,
    /// `camerafarplane`.
    pub far: f32,
}

/// Bones, their tracks and the camera. Empty (the default) for a static model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// `duration` in seconds.
    pub duration: f32,
    /// Bone b is `bones[b]`; `bones[0]` is the root (unanimated). Empty when no
    /// bone was made: every vertex then belongs to the root.
    pub bones: Vec<Bone>,
    /// One track per transform rule used (bones and the camera share them).
    pub tracks: Vec<Track>,
    pub camera: Option<Camera>,
}

/// Which op of the grammar drew each triangle of [`Output::mesh`], recorded when
/// [`crate::eval::EvalOptions::record_sites`] is set: what an editor needs to go
/// from a click on the model to the source (`mdg-run --sites`). Sweeps, instances
/// and isosurfaces are not recorded.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sites {
    /// `[first triangle, site]`, in triangle order: triangles from `first` up to the
    /// next run's first were drawn at `sites[site]`.
    pub runs: Vec<[u32; 2]>,
    pub sites: Vec<Site>,
}

/// One drawing op of the grammar: its rule and source line.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Site {
    /// The rule whose definition holds the op (`ns.NAME`), "" if the bundle has no
    /// such information.
    pub rule: String,
    /// The source file and 1-based line of the op, as the bundle records them
    /// ("" and 0 without a source map).
    pub file: String,
    pub line: u32,
}

impl Sites {
    /// The site of triangle `t`.
    pub fn of(&self, t: u32) -> Option<&Site> {
        let i = self.runs.partition_point(|r| r[0] <= t).checked_sub(1)?;
        self.sites.get(self.runs[i][1] as usize)
    }
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
    /// Bones with their frame tracks, and the camera track.
    pub animation: Animation,
    /// What `DEBUG {}` items reported, in order (at most [`MAX_DEBUG_LINES`]; the
    /// caller prints them: the VM prints nothing).
    pub debug: Vec<String>,
    /// Which op drew each mesh triangle (empty unless asked for).
    pub sites: Sites,
}

/// How many `DEBUG {}` reports one run keeps (a loop over a DEBUG item would fill
/// memory otherwise); the last line says how many more there were.
pub const MAX_DEBUG_LINES: usize = 10_000;

impl Output {
    /// How many positions of the geometry are not finite (vertices, line points,
    /// instance transforms): exporters write them as 0, so the run warns.
    pub fn non_finite_positions(&self) -> usize {
        let bad = |p: &[f32; 3]| !p.iter().all(|c| c.is_finite());
        // Nearly always all finite: a branch-free pass (it vectorises) decides that.
        let all_finite = |ps: &[[f32; 3]]| ps.as_flattened().iter().fold(true, |ok, c| ok & c.is_finite());
        let mesh = |m: &Mesh| if all_finite(&m.positions) { 0 } else { m.positions.iter().filter(|p| bad(p)).count() };
        mesh(&self.mesh)
            + mesh(&self.sweeps)
            + self.shared_meshes.iter().map(|(_, m)| mesh(m)).sum::<usize>()
            + self.lines.iter().map(|l| l.points.iter().filter(|p| bad(p)).count()).sum::<usize>()
            + self.instances.iter().filter(|i| !i.transform.is_finite()).count()
    }

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
