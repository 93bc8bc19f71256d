//! The CPU renderer for pictures: a model drawn on the machine's cores without
//! Vulkan, for the programs it implements exactly — std's Phong program
//! (`phong_vs` + `phong_fs` of `std/shaders.mdg`, recognised by the content hash of
//! their GLSL: [`PHONG_VS_HASH`], [`PHONG_FS_HASH`]), the unlit program of flat art
//! (`flat` without a `program`), and the viewer's pen lines and overlays. A grammar
//! with shaders of its own is drawn by Vulkan (the caller decides: [`program_of`]
//! says which and why).
//!
//! What it draws is what the Vulkan renderer draws ([`crate::renderer`]): the same
//! scene ([`crate::scene::build_with`]), camera ([`crate::camera::frame_view_projection`]),
//! light and uniforms ([`crate::uniforms`]), level of detail and point stand-ins
//! ([`crate::points`]), edge smoothing ([`crate::smooth`]). Instances are rasterised
//! from their shared meshes and transforms, computed as they are drawn (never
//! expanded nor stored: a million instances cost no memory beyond the evaluation's
//! records). The picture is split into strips of [`raster::STRIP`] rows dealt
//! round-robin to the threads; every thread walks all primitives, skips those whose
//! screen extent misses its strips, and draws the rest in the order the Vulkan
//! renderer submits them, so a pixel sees the same primitives in the same order for
//! any number of threads: the output does not depend on it. Memory is the picture's
//! (colour and depth per sample) plus the scene's packed meshes.

pub mod raster;

use crate::camera::OrbitCamera;
use crate::points;
use crate::renderer::{FrameParams, ModelInfo};
use crate::scene::{self, Scene, PROTO_STRIDE, SKIN_STRIDE, VERTEX_STRIDE};
use crate::uniforms::{self, UniformSpec};
use glam::{Mat3, Mat4, Quat, Vec3, Vec4};
use mdg_vm::bundle::{Bundle, NONE};
use mdg_vm::geom::quat::Frame;
use mdg_vm::output::{Fields, Instance, Output, PackedFrame};
use raster::{Lighting, Shade, Target, V};

/// The content hash ([`shader_hash`]) of std's `phong_vs`, the vertex shader this
/// renderer implements (and its instanced twin, `phong_instanced_vs`, which computes
/// the same).
pub const PHONG_VS_HASH: u64 = 0x228a38a9823db189;
/// The content hash of std's `phong_fs`, the fragment shader this renderer implements.
pub const PHONG_FS_HASH: u64 = 0x79a28f3b06efb45b;

/// A shader's content hash: FNV-1a (64 bits) of its GLSL with every line trimmed and
/// empty lines dropped (so re-indenting it keeps the hash; any other change does
/// not).
pub fn shader_hash(code: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for line in code.lines().map(str::trim).filter(|l| !l.is_empty()) {
        for b in line.bytes().chain(std::iter::once(b'\n')) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// The program a model is drawn with, as this renderer sees it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Program {
    /// std's Phong program (`label` says which shaders: `std phong_vs + phong_fs`, or
    /// the names the grammar imported them under).
    Phong { label: String },
    /// Flat art without a `program`: the colour as given.
    Unlit,
}

impl Program {
    pub fn label(&self) -> String {
        match self {
            Program::Phong { label } => label.clone(),
            Program::Unlit => "flat (unlit)".into(),
        }
    }
}

/// Why the CPU renderer does not draw a model: a message naming the shader.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotImplemented(pub String);

impl std::fmt::Display for NotImplemented {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for NotImplemented {}

/// Which of its programs draws `bundle`'s output, or why none does. `std_vs` and `std_fs` are the GLSL of the std shaders a stage
/// the bundle's `program` leaves out falls back on (std's `phong_vs` and `phong_fs`
/// from the std directory in use).
pub fn program_of(bundle: &Bundle, output: &Output, std_vs: &str, std_fs: &str) -> Result<Program, NotImplemented> {
    let (v, f) = match &bundle.program {
        None if output.flat => return Ok(Program::Unlit),
        None => (NONE, NONE),
        Some(p) => (p.vertex, p.fragment),
    };
    let stage = |i: u32, std: &str, std_name: &str, want: u64, what: &str| -> Result<String, NotImplemented> {
        let (name, code) = if i == NONE {
            (format!("std {std_name}"), std.to_string())
        } else {
            let sh = bundle
                .shaders
                .get(i as usize)
                .ok_or_else(|| NotImplemented(format!("program names shader {i}, which is missing")))?;
            (bundle.string(sh.name).to_string(), bundle.string(sh.source).to_string())
        };
        let h = shader_hash(&code);
        if h == want {
            Ok(name)
        } else if i == NONE {
            Err(NotImplemented(format!("the std directory's {std_name} (content hash {h:016x}) is not std's own")))
        } else {
            Err(NotImplemented(format!("the grammar's {what} shader `{name}` is its own (content hash {h:016x})")))
        }
    };
    let vs = stage(v, std_vs, "phong_vs", PHONG_VS_HASH, "vertex")?;
    let fs = stage(f, std_fs, "phong_fs", PHONG_FS_HASH, "fragment")?;
    Ok(Program::Phong { label: format!("{vs} + {fs}") })
}

/// How a picture is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    pub width: u32,
    pub height: u32,
    /// 1 or 4 samples a pixel.
    pub samples: u32,
    /// Smooth the edges afterwards ([`crate::smooth`]; at one sample).
    pub smooth: bool,
    /// Threads to draw with (the picture is the same for any count).
    pub threads: usize,
    /// Small instances at their level of detail ([`scene::Lod`]).
    pub lod: bool,
    /// Instances a few pixels across as point stand-ins ([`crate::points`]).
    pub stand_ins: bool,
}

/// What a picture drew.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Drawn {
    /// Triangles submitted (instances' at the level of detail they were drawn with).
    pub triangles: u64,
    /// Instances drawn as point stand-ins.
    pub stood_in: u64,
}

/// A model ready to draw: the packed scene and what the camera needs.
pub struct CpuScene<'a> {
    output: &'a Output,
    scene: Scene,
    info: ModelInfo,
    shade: Shade,
    spec: UniformSpec,
    /// Per instanced draw: the first vertex and count of its mesh, and of its level
    /// of detail.
    ranges: Vec<(VertexRange, Option<VertexRange>)>,
    /// Flat art painted in program order with its prototype instances kept
    /// ([`scene::build_painted`]): then `scene` holds only the mesh's runs between
    /// them, the sweeps and the lines.
    painted: Option<scene::Painted>,
}

/// The first vertex an index run uses and how many.
type VertexRange = (i64, usize);

/// The vertex range an index run of a shared mesh uses.
fn vertex_range(indices: &[u32], vertex_offset: i32) -> VertexRange {
    let lo = indices.iter().copied().min().unwrap_or(0);
    let hi = indices.iter().copied().max().unwrap_or(0);
    (i64::from(vertex_offset) + i64::from(lo), if indices.is_empty() { 0 } else { (hi - lo + 1) as usize })
}

impl<'a> CpuScene<'a> {
    /// Packs `output` (of `bundle`) for `program`.
    pub fn new(bundle: &Bundle, output: &'a Output, program: &Program) -> CpuScene<'a> {
        // As the Vulkan renderer: instances stay instanced (std's vertex shader) except
        // in flat art, painted in triangle order as one mesh: here with its
        // prototype instances expanded as they are painted (the same picture), where
        // `build_painted` applies (unlit, no isosurface, no bones).
        let painted = if *program == Program::Unlit { scene::build_painted(output) } else { None };
        let (scene, painted) = match painted {
            Some((scene, p)) => (scene, Some(p)),
            None => (scene::build_with(output, !output.flat), None),
        };
        let mut info = ModelInfo::of(&scene, output, bundle, program.label());
        info.n_triangles += painted.as_ref().map_or(0, |p| p.instance_triangles as usize);
        let ranges = match &scene.instanced {
            Some(inst) => inst
                .draws
                .iter()
                .zip(&inst.lods)
                .map(|(d, l)| {
                    let run = |first: u32, count: u32| {
                        inst.indices.get(first as usize..(first + count) as usize).unwrap_or(&[])
                    };
                    let full = vertex_range(run(d.first_index, d.index_count), d.vertex_offset);
                    let lod = l.map(|l| vertex_range(run(l.first_index, l.index_count), l.vertex_offset));
                    (full, lod)
                })
                .collect(),
            None => Vec::new(),
        };
        let shade = if *program == Program::Unlit { Shade::Unlit } else { Shade::Phong };
        CpuScene { output, scene, info, shade, spec: UniformSpec::new(bundle, output), ranges, painted }
    }

    pub fn info(&self) -> &ModelInfo {
        &self.info
    }

    /// The home camera for a picture of aspect `aspect` (as
    /// [`crate::offscreen::Offscreen::home_camera`]).
    pub fn home_camera(&self, aspect: f32) -> OrbitCamera {
        OrbitCamera::framing_art(&self.info.bounds, self.info.fov_deg, aspect, self.info.flat)
    }

    /// Draws one frame: RGBA8, rows top to bottom.
    pub fn render(&self, frame: &FrameParams, opts: &Options) -> (Vec<u8>, Drawn) {
        let (w, h) = (opts.width.max(1), opts.height.max(1));
        let aspect = w as f32 / h as f32;
        let anim = &self.output.animation;
        let rule_at = frame.camera_rule.then_some(frame.time);
        let (view, projection, eye) = crate::camera::frame_view_projection(
            &frame.camera,
            rule_at,
            Some(anim),
            (self.info.near, self.info.far),
            aspect,
        );
        let vp = projection * view;
        let values = self.spec.values(anim, frame.time);
        let (center, radius) = self.info.bounds.sphere();
        let light = values.light_pos.unwrap_or_else(|| uniforms::default_light(center, radius));
        let spec = values.spec_color_power.unwrap_or(uniforms::DEFAULT_SPEC_COLOR_POWER);
        let lighting = Lighting { eye, light: Vec3::new(light[0], light[1], light[2]), spec };
        // The bones at this time (at 0 for a still model, as the renderer uploads them).
        let n_bones = (self.scene.max_bone + 1).max(anim.bones.len() as u32) as usize;
        let pose = anim.pose(if self.info.animated { f64::from(frame.time) } else { 0.0 });
        let bones: Vec<Mat4> =
            (0..n_bones).map(|i| pose.get(i).map(|f| f.to_mat4()).unwrap_or(Mat4::IDENTITY)).collect();
        let samples = if opts.samples >= 4 { 4 } else { 1 };
        let stand_in_view = (opts.lod && opts.stand_ins && self.shade == Shade::Phong).then(|| points::View {
            view_projection: vp,
            eye,
            light: lighting.light,
            spec,
            width: w as f32,
            height: h as f32,
            flat: self.info.bounds.is_flat(),
        });
        // Pixels across a unit sphere at the model's nearest point (the renderer's
        // `pixels_per_unit`), for the level of detail.
        let ppu = if opts.lod && !self.info.bounds.is_empty() {
            let nearest = eye.clamp(self.info.bounds.lo, self.info.bounds.hi);
            let d = eye.distance(nearest);
            let focal = projection.y_axis.y.abs() * h as f32 * 0.5;
            (d > 1e-6 && focal.is_finite()).then(|| 2.0 * focal / d)
        } else {
            None
        };
        let bg = self.info.background.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8);
        let threads = (opts.threads.max(1) as u32).min(h.div_ceil(raster::STRIP)).max(1);
        let row = |k: usize| Vec3::new(vp.x_axis[k], vp.y_axis[k], vp.z_axis[k]).length();
        let row_lengths = [row(0), row(1), row(3)];
        let job = Job {
            cpu: self,
            vp,
            row_lengths,
            bones: &bones,
            stand_in_view,
            ppu,
            depth_test: !self.info.flat,
            height: h,
        };
        let target = |t: u32| {
            let mut target = Target::new(t, threads, w, h, samples, bg);
            target.lighting = lighting;
            target.shade = self.shade;
            target.depth_test = job.depth_test;
            target
        };
        let mut targets: Vec<Target> = (0..threads).map(target).collect();
        let stood_in = match job.draw(&mut targets) {
            Some(n) => n,
            None => {
                // A thread panicked: the picture is drawn again on this one.
                targets = vec![Target::new(0, 1, w, h, samples, bg)];
                if let Some(t) = targets.first_mut() {
                    t.lighting = lighting;
                    t.shade = self.shade;
                    t.depth_test = job.depth_test;
                }
                job.draw(&mut targets).unwrap_or(0)
            }
        };
        let mut px = vec![0u8; w as usize * h as usize * 4];
        for (y, row) in px.chunks_exact_mut(w as usize * 4).enumerate() {
            let y = y as u32;
            if let Some(t) = targets.iter().find(|t| t.owns(y)) {
                t.resolve_row(y, row);
            }
        }
        if opts.smooth && samples == 1 {
            crate::smooth::smooth_edges(&mut px, w, h);
        }
        (px, Drawn { triangles: self.submitted(ppu), stood_in })
    }

    /// Triangles a frame submits (every instance's at the level of detail of its
    /// draw; stand-ins not subtracted).
    fn submitted(&self, ppu: Option<f32>) -> u64 {
        let mut n = self.scene.indices.len() as u64 / 3 + self.painted.as_ref().map_or(0, |p| p.instance_triangles);
        if let Some(inst) = &self.scene.instanced {
            for (d, l) in inst.draws.iter().zip(&inst.lods) {
                let count = match (l, ppu) {
                    (Some(l), Some(p)) if l.radius * p <= scene::LOD_PIXELS => l.index_count,
                    _ => d.index_count,
                };
                n += u64::from(count / 3) * u64::from(d.instance_count);
            }
        }
        n
    }
}

/// One frame's shared state, read by every thread.
struct Job<'s, 'a> {
    cpu: &'s CpuScene<'a>,
    vp: Mat4,
    /// The lengths of `vp`'s rows 0, 1 and 3 (x, y, w) without their last column,
    /// for [`Job::sphere_rows`].
    row_lengths: [f32; 3],
    bones: &'s [Mat4],
    stand_in_view: Option<points::View>,
    ppu: Option<f32>,
    depth_test: bool,
    height: u32,
}

/// Instances prepared, then drawn, at a time ([`Job::instances`]): a batch's
/// points stay in the cache and their buffers are reused.
const BATCH: usize = 1 << 15;

/// One instanced draw as this frame draws it ([`Job::draw_plans`]).
struct DrawPlan<'s> {
    /// Its index run, at the level of detail chosen.
    indices: &'s [u32],
    /// What turns an index into a place in the vertex range `v_first..v_first + v_n`.
    base: i64,
    v_first: i64,
    v_n: usize,
    cull: bool,
    stand: Option<scene::StandIn>,
    facets: &'s [scene::Facet],
    /// The first look's reach around an instance's origin, per unit of scale.
    reach: Option<f32>,
    /// Where its instances end in the draw order.
    end: usize,
}

/// A part of a batch of instances, prepared ([`Job::prepare`]). Each thread
/// prepares its own, and they lie side by side in one `Vec`: aligned to 128 bytes
/// (two cache lines, as the adjacent-line prefetcher fetches them) so that no two
/// threads write the same cache line (the vectors' lengths and `stood_in` change
/// per instance; shared lines made the preparation twice as dear on two threads).
#[derive(Default)]
#[repr(align(128))]
struct Prepared {
    items: Vec<Item>,
    /// Per target: the stand-ins' points that cover one of its rows, set up on the
    /// screen, with their colours (a point on no target's rows is dropped, as each
    /// target would drop it).
    points: Vec<Vec<(raster::PointSetup, [u8; 4])>>,
    /// Per [`Item::Points`] in order, per target: where its points end in that
    /// target's list.
    ends: Vec<u32>,
    /// Points set up but not yet shaded ([`Prepared::flush`]).
    staged: Vec<(raster::PointSetup, points::Point)>,
    /// Instances drawn as stand-ins.
    stood_in: u64,
}

/// Points staged before they are shaded in a loop of their own ([`Prepared::flush`]):
/// one point's shading (a chain of square roots and divisions) then overlaps the
/// next's, and the staged points stay in the cache.
const STAGE: usize = 64;

impl Prepared {
    /// Shades the staged points, in order, and puts each in the lists of the
    /// targets that own its rows (`owner`, per row); the last [`Item::Points`]
    /// (theirs) then ends at the lists' ends.
    fn flush(&mut self, view: &points::View, owner: &[u32]) {
        let Prepared { staged, points, ends, .. } = self;
        if staged.is_empty() {
            return;
        }
        let mut fours = staged.chunks_exact(4);
        for four in &mut fours {
            let colors = points::rgba4(view, &[four[0].1, four[1].1, four[2].1, four[3].1]);
            for ((setup, _), rgba) in four.iter().zip(colors) {
                bin_point(owner, points, *setup, rgba);
            }
        }
        for (setup, p) in fours.remainder() {
            bin_point(owner, points, *setup, p.rgba(view));
        }
        staged.clear();
        let at = ends.len().saturating_sub(points.len());
        for (e, list) in ends.iter_mut().skip(at).zip(points.iter()) {
            *e = list.len() as u32;
        }
    }
}

/// What a prepared instance draws, in order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Item {
    /// The next points of each target's list in [`Prepared::points`] (those of
    /// consecutive stand-ins; where they end: [`Prepared::ends`]).
    Points,
    /// The instance at `pos` of the draw order, of draw `draw`, as its mesh.
    Mesh { pos: u32, draw: u32 },
}

/// What a thread reuses from instance to instance (aligned as [`Prepared`] is, for
/// the same reason: one per thread, side by side).
#[repr(align(128))]
struct Scratch<'a> {
    fields: mdg_vm::output::FieldReader<'a>,
    local: Vec<V>,
}

/// Runs `f` on every element of `items`, each on a thread of its own (the first on
/// this one); `false` if one panicked.
fn on_each<T: Send>(items: &mut [T], f: impl Fn(usize, &mut T) + Sync) -> bool {
    match items {
        [] => true,
        [one] => {
            f(0, one);
            true
        }
        [first, rest @ ..] => std::thread::scope(|scope| {
            let f = &f;
            let handles: Vec<_> = rest.iter_mut().enumerate().map(|(k, x)| scope.spawn(move || f(k + 1, x))).collect();
            f(0, first);
            handles.into_iter().all(|h| h.join().is_ok())
        }),
    }
}

fn f32_at(b: &[u8], at: usize) -> f32 {
    b.get(at..at + 4).map_or(0.0, |s| f32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn snorm16_at(b: &[u8], at: usize) -> f32 {
    b.get(at..at + 2).map_or(0.0, |s| (f32::from(i16::from_le_bytes([s[0], s[1]])) / 32767.0).max(-1.0))
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    b.get(at..at + 4).map_or(0, |s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

/// The cofactor matrix of `m` (its inverse transpose times its determinant).
fn cofactor(m: Mat3) -> Mat3 {
    Mat3::from_cols(m.y_axis.cross(m.z_axis), m.z_axis.cross(m.x_axis), m.x_axis.cross(m.y_axis))
}

impl<'s, 'a> Job<'s, 'a> {
    /// The pixel rows a sphere (world centre `c`, radius `r`) may cover, or `None`
    /// when it may reach behind the eye (then any row).
    #[inline]
    fn sphere_rows(&self, c: Vec3, r: f32) -> Option<(i64, i64, bool)> {
        self.sphere_rows_at(self.vp * c.extend(1.0), r)
    }

    /// The sphere of stand-in `s` placed by `l` and `t` (what [`points`] reads).
    #[inline]
    fn placed(&self, s: &scene::StandIn, l: Mat3, t: Vec3) -> points::Placed {
        self.placed_at(l * s.centre + t, s.radius * max_axis(l))
    }

    /// A sphere of centre `centre` and radius `radius`, placed (as [`points`] reads it).
    #[inline]
    fn placed_at(&self, centre: Vec3, radius: f32) -> points::Placed {
        points::Placed { centre, radius, clip: self.vp * centre.extend(1.0), w_len: self.row_lengths[2] }
    }

    /// [`Job::sphere_rows`] for the centre's clip position `clip`.
    #[inline(always)]
    fn sphere_rows_at(&self, clip: Vec4, r: f32) -> Option<(i64, i64, bool)> {
        let [x_len, y_len, w_len] = self.row_lengths;
        let ahead = clip.w - r * w_len;
        if ahead.is_nan() || ahead <= 0.0 || !clip.is_finite() {
            return None;
        }
        let (nx, ny) = (clip.x / clip.w, clip.y / clip.w);
        // |Δndc| ≤ r (|row| + |ndc| |w row|) / (w − r |w row|).
        let ex = r * (x_len + nx.abs() * w_len) / ahead;
        let ey = r * (y_len + ny.abs() * w_len) / ahead;
        let visible = nx - ex <= 1.0 && nx + ex >= -1.0 && ny - ey <= 1.0 && ny + ey >= -1.0;
        let h = self.height as f32 * 0.5;
        Some((raster::floor_i64((ny - ey + 1.0) * h) - 1, raster::floor_i64((ny + ey + 1.0) * h) + 1, visible))
    }

    /// Draws everything, in the Vulkan renderer's order: the mesh, the instances
    /// (stand-ins where chosen), pen lines, overlays; each target its strips, on a
    /// thread of its own. Returns the instances drawn as stand-ins, or `None` when
    /// a thread panicked.
    fn draw(&self, targets: &mut [Target]) -> Option<u64> {
        let drawn = match &self.cpu.painted {
            Some(p) => on_each(targets, |_, t| self.paint(t, p)),
            None => on_each(targets, |_, t| self.mesh(t, 0..self.cpu.scene.indices.len() / 3)),
        };
        if !drawn {
            return None;
        }
        let stood_in = self.instances(targets)?;
        on_each(targets, |_, t| self.lines(t)).then_some(stood_in)
    }

    /// Flat art in program order ([`scene::Painted`]): the mesh's runs and the
    /// prototype instances between them, each instance expanded as
    /// `mdg_vm::output::expand_prototype` expands it (the same vertices and colours
    /// as the packed scene of every instance expanded holds) and painted unless its
    /// sphere misses this target's rows.
    fn paint(&self, t: &mut Target, painted: &scene::Painted) {
        let frames = self.cpu.output.instances.packed_frames();
        let mut points: Vec<(Vec3, Vec4, Option<raster::Snapped>)> = Vec::new();
        let mut colors: Vec<Vec4> = Vec::new();
        for step in &painted.steps {
            match step {
                scene::PaintStep::Mesh(r) => self.mesh(t, r.clone()),
                scene::PaintStep::Prototypes { instances, span } => {
                    let Some(proto) = painted.protos.get(span.mesh as usize) else { continue };
                    // Each vertex's colour, as the packed scene stores it (8 bits a
                    // channel): the span's colour plus the vertex's delta, clamped.
                    colors.clear();
                    colors.extend(proto.deltas.iter().map(|d| {
                        Vec4::from_array(
                            [0, 1, 2, 3]
                                .map(|k| f32::from(scene::unorm8((span.color[k] + d[k]).clamp(0.0, 1.0))) / 255.0),
                        )
                    }));
                    for f in frames.get(instances.clone()).unwrap_or(&[]) {
                        self.paint_instance(t, proto, &span.instance(f).frame, &colors, &mut points);
                    }
                }
            }
        }
    }

    /// One instance of `proto` placed by `frame`, its vertices' colours by delta in
    /// `colors` ([`Job::paint`]); `points` is scratch.
    fn paint_instance(
        &self,
        t: &mut Target,
        proto: &scene::PaintProto,
        frame: &Frame,
        colors: &[Vec4],
        points: &mut Vec<(Vec3, Vec4, Option<raster::Snapped>)>,
    ) {
        let (lin, mirrored) = frame.linear();
        // (Rounding: the sphere grows by a part in a thousand.)
        let c = frame.u + lin * proto.centre;
        let r = proto.radius * max_axis(lin) * 1.001 + 1e-6 * c.abs().max_element();
        if let Some((y0, y1, visible)) = self.sphere_rows(c, r) {
            if !visible || !t.any_row(y0, y1) {
                return;
            }
        }
        // Each point placed, projected and (inside the guard band) snapped once: a
        // circle's 96 vertices are 33 points.
        points.clear();
        points.extend(proto.points.iter().map(|&p| {
            let w = frame.u + lin * p;
            let clip = self.vp * w.extend(1.0);
            (w, clip, raster::inside(clip).then(|| t.snap(clip)))
        }));
        let point = |i: u32| proto.point_of.get(i as usize).and_then(|&k| points.get(k as usize));
        let vertex = |i: u32| -> V {
            let (world, clip, _) = point(i).copied().unwrap_or_default();
            let color = proto.delta_of.get(i as usize).and_then(|&d| colors.get(d as usize));
            V { clip, world, normal: Vec3::Z, color: color.copied().unwrap_or(Vec4::ONE), matte: 0.0 }
        };
        for (k, tri) in proto.triangles.iter().enumerate() {
            let flip = mirrored != proto.mirrored.get(k).copied().unwrap_or(false);
            let tri = if flip { [tri[0], tri[2], tri[1]] } else { *tri };
            if let [Some((_, _, Some(a))), Some((_, _, Some(b))), Some((_, _, Some(c)))] = tri.map(point) {
                // Snapped already: what `Target::triangle` would do.
                let s = [*a, *b, *c];
                if !t.misses_every_sample(&s) {
                    t.triangle_snapped(tri.map(vertex), s);
                }
                continue;
            }
            let v = tri.map(vertex);
            if let Some((y0, y1)) = screen_rows(&v, self.height) {
                if !t.any_row(y0, y1) {
                    continue;
                }
            }
            t.triangle(v, false);
        }
    }

    /// Triangles `tris` of the scene's index list.
    fn mesh(&self, t: &mut Target, tris: std::ops::Range<usize>) {
        let s = &self.cpu.scene;
        let vs = VERTEX_STRIDE as usize;
        let skinned = !s.skins.is_empty();
        let vertex = |i: u32| -> V {
            let i = i as usize;
            let b = s.vertices.get(i * vs..(i + 1) * vs).unwrap_or(&[]);
            let p = Vec3::new(f32_at(b, 0), f32_at(b, 4), f32_at(b, 8));
            let n = Vec3::new(snorm16_at(b, 12), snorm16_at(b, 14), snorm16_at(b, 16));
            let matte = snorm16_at(b, 18);
            let c = b.get(20..24).map_or([255; 4], |c| [c[0], c[1], c[2], c[3]]);
            let color = Vec4::new(
                f32::from(c[0]) / 255.0,
                f32::from(c[1]) / 255.0,
                f32::from(c[2]) / 255.0,
                f32::from(c[3]) / 255.0,
            );
            let bone = if skinned { u32_at(&s.skins, i * SKIN_STRIDE as usize + 16) } else { 0 };
            let m = self.bones.get(bone as usize).copied().unwrap_or(Mat4::IDENTITY);
            let world = m.transform_point3(p);
            // transpose(inverse(mat3(model))) · n, as phong_vs.
            let l = Mat3::from_mat4(m);
            let normal = if m == Mat4::IDENTITY { n } else { l.inverse().transpose() * n };
            V { clip: self.vp * world.extend(1.0), world, normal, color, matte }
        };
        for tri in s.indices.get(3 * tris.start..3 * tris.end).unwrap_or(&[]).chunks_exact(3) {
            let v = [vertex(tri[0]), vertex(tri[1]), vertex(tri[2])];
            if let Some((y0, y1)) = screen_rows(&v, self.height) {
                if !t.any_row(y0, y1) {
                    continue;
                }
            }
            t.triangle(v, false);
        }
    }

    /// What each instanced draw needs of the frame: its index run, vertex range and
    /// culling at the level of detail chosen, and its stand-in.
    fn draw_plans(&self) -> Vec<DrawPlan<'s>> {
        let Some(inst) = &self.cpu.scene.instanced else { return Vec::new() };
        let cpu: &'s CpuScene<'a> = self.cpu;
        inst.draws
            .iter()
            .enumerate()
            .map(|(k, d)| {
                let lod = match (inst.lods.get(k).copied().flatten(), self.ppu) {
                    (Some(l), Some(p)) if l.radius * p <= scene::LOD_PIXELS => Some(l),
                    _ => None,
                };
                let ((full_first, full_n), lod_range) = cpu.ranges.get(k).copied().unwrap_or(((0, 0), None));
                let (first_index, index_count, vertex_offset, (v_first, v_n), cull) = match (lod, lod_range) {
                    (Some(l), Some(r)) => (l.first_index, l.index_count, l.vertex_offset, r, false),
                    _ => (d.first_index, d.index_count, d.vertex_offset, (full_first, full_n), d.closed),
                };
                let stand = inst.stand_ins.get(k).copied();
                let facets =
                    stand.and_then(|s| inst.facets.get(s.first_facet as usize..(s.first_facet + s.n_facets) as usize));
                DrawPlan {
                    indices: inst
                        .indices
                        .get(first_index as usize..(first_index + index_count) as usize)
                        .unwrap_or(&[]),
                    base: i64::from(vertex_offset) - v_first,
                    v_first,
                    v_n,
                    cull,
                    stand,
                    facets: facets.unwrap_or(&[]),
                    reach: stand.map(|s| s.centre.length() + s.radius),
                    end: (d.first_instance + d.instance_count) as usize,
                }
            })
            .collect()
    }

    /// The instances, in batches of [`BATCH`] (in draw order): each batch is first
    /// prepared, its parts on the threads (every instance culled, its transform
    /// made and its stand-in's points set up once), then drawn, each target its
    /// strips. Returns the instances drawn as stand-ins, `None` if a thread panicked.
    fn instances(&self, targets: &mut [Target]) -> Option<u64> {
        let Some(inst) = &self.cpu.scene.instanced else { return Some(0) };
        let plans = self.draw_plans();
        let n = inst.order.len();
        let parts = targets.len().max(1);
        // The target that owns each row of the picture (as `Target::owns` says).
        let owner: Vec<u32> = (0..self.height).map(|y| (y / raster::STRIP) % parts as u32).collect();
        let mut prepared: Vec<Prepared> = (0..parts).map(|_| Prepared::default()).collect();
        let mut scratch: Vec<Scratch<'_>> = (0..targets.len())
            .map(|_| Scratch { fields: self.cpu.output.instances.fields(), local: Vec::new() })
            .collect();
        let mut stood_in = 0;
        let mut from = 0;
        while from < n {
            let to = (from + BATCH).min(n);
            let per = (to - from).div_ceil(parts);
            let ok = on_each(&mut prepared, |k, p| {
                let a = (from + k * per).min(to);
                self.prepare(&plans, &owner, a..(a + per).min(to), p);
            });
            if !ok {
                return None;
            }
            stood_in += prepared.iter().map(|p| p.stood_in).sum::<u64>();
            let mut work: Vec<(&mut Target, &mut Scratch<'_>)> = targets.iter_mut().zip(scratch.iter_mut()).collect();
            if !on_each(&mut work, |k, (t, sc)| self.draw_prepared(t, k, &plans, &prepared, sc)) {
                return None;
            }
            from = to;
        }
        Some(stood_in)
    }

    /// Prepares the instances at `range` of the draw order into `out`: those off
    /// the picture dropped, stand-ins as points set up on the screen (each in the
    /// list of every target that owns one of its rows: `owner`, per row), the rest
    /// as meshes to draw.
    fn prepare(&self, plans: &[DrawPlan<'_>], owner: &[u32], range: std::ops::Range<usize>, out: &mut Prepared) {
        out.items.clear();
        let targets = owner.iter().copied().max().map_or(1, |m| m as usize + 1);
        out.points.resize_with(targets, Vec::new);
        out.points.iter_mut().for_each(Vec::clear);
        out.ends.clear();
        out.staged.clear();
        out.stood_in = 0;
        let (Some(inst), Some(view)) = (&self.cpu.scene.instanced, &self.stand_in_view) else {
            // No stand-ins: every instance a mesh.
            let mut k = plans.partition_point(|p| p.end <= range.start);
            for pos in range {
                while plans.get(k).is_some_and(|p| p.end <= pos) {
                    k += 1;
                }
                out.items.push(Item::Mesh { pos: pos as u32, draw: k as u32 });
            }
            return;
        };
        let out_ = self.cpu.output;
        let frames = out_.instances.packed_frames();
        let mut fields = out_.instances.fields();
        let (w, h) = (view.width as u32, self.height);
        let on_picture = |y0: i64, y1: i64| y1 >= 0 && y0 < i64::from(h);
        let mut k = plans.partition_point(|p| p.end <= range.start);
        let mut points: Vec<points::Point> = Vec::new();
        // A run of instances of one draw whose linear parts are bit-equal (q and q̂,
        // no non-uniform factor: every square of a grid) shares its matrix, its
        // sphere's offset and radius and its oriented facets, made once for the
        // run: `run` says for which draw and linear part they were made.
        let mut run: Option<(usize, [u32; 8])> = None;
        let mut shared = (Vec3::ZERO, 0.0f32);
        let mut oriented = points::Oriented::default();
        let linear_bits = |pf: &PackedFrame| -> [u32; 8] { std::array::from_fn(|i| pf[i].to_bits()) };
        let end = range.end;
        for pos in range {
            while plans.get(k).is_some_and(|p| p.end <= pos) {
                k += 1;
            }
            let Some(plan) = plans.get(k) else { break };
            let mesh = Item::Mesh { pos: pos as u32, draw: k as u32 };
            let Some(&oi) = inst.order.get(pos) else { continue };
            let oi = oi as usize;
            let (Some(pf), Some(f)) = (frames.get(oi), fields.get(oi)) else { continue };
            let (Some(s), 0) = (plan.stand, f.bone) else {
                out.flush(view, owner);
                out.items.push(mesh);
                continue;
            };
            // (No first look from the frame alone here: each instance is prepared
            // once, and most are on the picture.)
            let color = Vec4::from_array(f.color);
            let in_run = f.lin == 0 && {
                let bits = linear_bits(pf);
                run == Some((k, bits))
                    || (pos + 1 < end.min(plan.end)
                        && inst
                            .order
                            .get(pos + 1)
                            .and_then(|&o| frames.get(o as usize))
                            .is_some_and(|next| linear_bits(next) == bits)
                        && {
                            // The first of a run (the next instance shares its linear part).
                            let (l, _) = transform(out_, pf, &f);
                            shared = (l * s.centre, max_axis(l));
                            oriented.set(l, plan.facets);
                            run = Some((k, bits));
                            true
                        })
            };
            let stood = if in_run {
                let (centre, scale) = shared;
                let tr = Vec3::new(pf[8], pf[9], pf[10]);
                let at = self.placed_at(centre + tr, s.radius * scale);
                if let Some((y0, y1, visible)) = self.sphere_rows_at(at.clip, at.radius) {
                    if !visible || !on_picture(y0, y1) {
                        continue;
                    }
                }
                points::stand_in_points_oriented(view, &s, plan.facets, &oriented, tr, color, &at, &mut points)
            } else {
                let (l, tr) = transform(out_, pf, &f);
                let at = self.placed(&s, l, tr);
                if let Some((y0, y1, visible)) = self.sphere_rows_at(at.clip, at.radius) {
                    if !visible || !on_picture(y0, y1) {
                        continue;
                    }
                }
                points::stand_in_points(view, &s, plan.facets, l, tr, color, &at, &mut points)
            };
            if !stood {
                out.flush(view, owner);
                out.items.push(mesh);
                continue;
            }
            out.stood_in += 1;
            if out.items.last() != Some(&Item::Points) {
                out.items.push(Item::Points);
                out.ends.extend(std::iter::repeat_n(0, targets));
            }
            for p in &points {
                if let Some(setup) = raster::point_setup(self.vp * p.pos.extend(1.0), p.size, w, h) {
                    out.staged.push((setup, *p));
                }
            }
            if out.staged.len() >= STAGE {
                out.flush(view, owner);
            }
        }
        out.flush(view, owner);
    }

    /// Draws the prepared instances (`prepared`, in order) into the strips of
    /// target `t`, the `k`-th.
    fn draw_prepared(
        &self,
        t: &mut Target,
        k: usize,
        plans: &[DrawPlan<'_>],
        prepared: &[Prepared],
        sc: &mut Scratch<'_>,
    ) {
        for p in prepared {
            let targets = p.points.len().max(1);
            let points = p.points.get(k).map_or(&[][..], Vec::as_slice);
            let mut ends = p.ends.iter().skip(k).step_by(targets);
            let mut next = 0usize;
            for item in &p.items {
                match *item {
                    Item::Points => {
                        let end = ends.next().map_or(next, |&e| e as usize);
                        for (setup, rgba) in points.get(next..end).unwrap_or(&[]) {
                            t.point_at(setup, *rgba);
                        }
                        next = end;
                    }
                    Item::Mesh { pos, draw } => {
                        if let Some(plan) = plans.get(draw as usize) {
                            self.mesh_instance(t, plan, pos as usize, sc);
                        }
                    }
                }
            }
        }
    }

    /// Draws the instance at `pos` of the draw order as its mesh (phong_instanced_vs
    /// for each vertex), where it covers this target's strips.
    fn mesh_instance(&self, t: &mut Target, plan: &DrawPlan<'_>, pos: usize, sc: &mut Scratch<'_>) {
        let Some(inst) = &self.cpu.scene.instanced else { return };
        let out = self.cpu.output;
        let Some(&oi) = inst.order.get(pos) else { return };
        let oi = oi as usize;
        let (Some(pf), Some(f)) = (out.instances.packed_frames().get(oi), sc.fields.get(oi)) else { return };
        let u = Vec3::new(pf[8], pf[9], pf[10]);
        if let (0, 0, Some(reach)) = (f.bone, f.lin, plan.reach) {
            let q = Vec4::new(pf[0], pf[1], pf[2], pf[3]).length();
            let qh = Vec4::new(pf[4], pf[5], pf[6], pf[7]).length();
            if let Some((y0, y1, visible)) = self.sphere_rows(u, q * qh * reach) {
                if !visible || !t.any_row(y0, y1) {
                    return;
                }
            }
        }
        let (l, tr) = transform(out, pf, &f);
        // Where it may be on the screen (instances posed by a bone: anywhere).
        if let (0, Some(s)) = (f.bone, plan.stand) {
            let at = self.placed(&s, l, tr);
            if let Some((y0, y1, visible)) = self.sphere_rows_at(at.clip, at.radius) {
                if !visible || !t.any_row(y0, y1) {
                    return;
                }
            }
        }
        let ps = PROTO_STRIDE as usize;
        let color = Vec4::from_array(f.color);
        let bone = self.bones.get(f.bone as usize).copied().unwrap_or(Mat4::IDENTITY);
        let b3 = Mat3::from_mat4(bone);
        let (cl, cb) = (cofactor(l), cofactor(b3));
        let sign = l.x_axis.dot(cl.x_axis).signum() * b3.x_axis.dot(cb.x_axis).signum();
        let nm = cb * cl * sign;
        let local = &mut sc.local;
        local.clear();
        for v in 0..plan.v_n {
            let at = (plan.v_first as usize + v) * ps;
            let b = inst.vertices.get(at..at + ps).unwrap_or(&[]);
            let p = Vec3::new(f32_at(b, 0), f32_at(b, 4), f32_at(b, 8));
            let n = Vec3::new(snorm16_at(b, 12), snorm16_at(b, 14), snorm16_at(b, 16));
            let matte = snorm16_at(b, 18);
            let delta = Vec4::new(f32_at(b, 20), f32_at(b, 24), f32_at(b, 28), f32_at(b, 32));
            let world = bone.transform_point3(l * p + tr);
            local.push(V {
                clip: self.vp * world.extend(1.0),
                world,
                normal: nm * n,
                color: (color + delta).clamp(Vec4::ZERO, Vec4::ONE),
                matte,
            });
        }
        for tri in plan.indices.chunks_exact(3) {
            let at = |k: usize| local.get((plan.base + i64::from(tri[k])) as usize).copied().unwrap_or_default();
            let v = [at(0), at(1), at(2)];
            if let Some((y0, y1)) = screen_rows(&v, self.height) {
                if !t.any_row(y0, y1) {
                    continue;
                }
            }
            t.triangle(v, plan.cull);
        }
    }

    /// Pen lines (depth-tested), then overlays (over everything), in the line
    /// program's colours.
    fn lines(&self, t: &mut Target) {
        let s = &self.cpu.scene;
        let vs = VERTEX_STRIDE as usize;
        let n_pen = s.n_line_vertices.saturating_sub(s.n_overlay_vertices);
        let at = |i: u32| -> (Vec4, Vec4) {
            let b = s.line_vertices.get(i as usize * vs..(i as usize + 1) * vs).unwrap_or(&[]);
            let p = Vec3::new(f32_at(b, 0), f32_at(b, 4), f32_at(b, 8));
            let c = b.get(20..24).map_or([255; 4], |c| [c[0], c[1], c[2], c[3]]);
            (self.vp * p.extend(1.0), Vec4::from_array(c.map(|x| f32::from(x) / 255.0)))
        };
        let saved = t.shade;
        t.shade = Shade::Unlit;
        for i in (0..s.n_line_vertices / 2).map(|k| 2 * k) {
            let ((a, c), (b, _)) = (at(i), at(i + 1));
            t.line(a, b, c, i < n_pen && self.depth_test);
        }
        t.shade = saved;
    }
}

/// Appends point `setup` (in `color`) to the list of every target that owns one of
/// the rows it covers (`owner`, per row of the picture; `lists`, per target), as
/// [`Target::point_at`] reads its rows; a point on no row of the picture is dropped.
#[inline]
fn bin_point(
    owner: &[u32],
    lists: &mut [Vec<(raster::PointSetup, [u8; 4])>],
    setup: raster::PointSetup,
    color: [u8; 4],
) {
    let last = owner.len() as i64 - 1;
    let (r0, r1) = (raster::floor_i64(setup.y0).max(0), raster::floor_i64(setup.y1).min(last));
    if r0 > r1 {
        return;
    }
    // The strips it covers: each of a different target when fewer than the
    // targets, else every target owns one of them.
    let strip = i64::from(raster::STRIP);
    let (s0, s1) = (r0 / strip, r1 / strip);
    if s1 - s0 + 1 >= lists.len() as i64 {
        lists.iter_mut().for_each(|l| l.push((setup, color)));
        return;
    }
    for s in s0..=s1 {
        let t = owner.get((s * strip) as usize).copied().unwrap_or(0) as usize;
        if let Some(l) = lists.get_mut(t) {
            l.push((setup, color));
        }
    }
}

/// The pixel rows a triangle's vertices span, or `None` when one is behind the eye
/// (then it is clipped and may cover any row).
fn screen_rows(v: &[V; 3], height: u32) -> Option<(i64, i64)> {
    if v.iter().any(|x| x.clip.w.is_nan() || x.clip.w <= 0.0) {
        return None;
    }
    let ys = v.map(|x| (x.clip.y / x.clip.w + 1.0) * 0.5 * height as f32);
    let lo = ys.iter().copied().fold(f32::MAX, f32::min);
    let hi = ys.iter().copied().fold(f32::MIN, f32::max);
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    Some((raster::floor_i64(lo) - 1, raster::floor_i64(hi) + 1))
}

/// An instance's transform (its packed frame `pf`, its fields `f`), as a linear
/// part and a translation: the frame's axes, or through the output for a
/// non-uniform factor (`Output::instance_transform`, whose columns are the same
/// axes without one).
#[inline]
fn transform(out: &Output, pf: &PackedFrame, f: &Fields) -> (Mat3, Vec3) {
    let frame = frame_of(pf);
    if f.lin == 0 {
        let [a, b, c] = frame.axes();
        (Mat3::from_cols(a, b, c), frame.u)
    } else {
        let instance = Instance { frame, color: f.color, mesh: f.mesh, bone: f.bone, lin: f.lin, at: f.at };
        let m = out.instance_transform(&instance);
        (Mat3::from_mat4(m), m.w_axis.truncate())
    }
}

/// The longest column of `l`: `max(|x|, |y|, |z|)` with one square root (the same
/// bits: a square root is correctly rounded and increasing).
#[inline]
fn max_axis(l: Mat3) -> f32 {
    l.x_axis.length_squared().max(l.y_axis.length_squared()).max(l.z_axis.length_squared()).sqrt()
}

/// The frame a packed frame holds.
#[inline]
fn frame_of(pf: &PackedFrame) -> Frame {
    Frame {
        q: Quat::from_xyzw(pf[0], pf[1], pf[2], pf[3]),
        qh: Quat::from_xyzw(pf[4], pf[5], pf[6], pf[7]),
        u: Vec3::new(pf[8], pf[9], pf[10]),
    }
}
