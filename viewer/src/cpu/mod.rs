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
use mdg_vm::output::{Instance, Output, PackedFrame};
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
        // in flat art, painted in triangle order as one mesh.
        let scene = scene::build_with(output, !output.flat);
        let info = ModelInfo::of(&scene, output, bundle, program.label());
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
        CpuScene { output, scene, info, shade, spec: UniformSpec::new(bundle, output), ranges }
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
        let draw = |t: u32| {
            let mut target = Target::new(t, threads, w, h, samples, bg);
            target.lighting = lighting;
            target.shade = self.shade;
            target.depth_test = job.depth_test;
            let stood_in = job.draw(&mut target);
            (target, stood_in)
        };
        let results: Vec<(Target, u64)> = if threads == 1 {
            vec![draw(0)]
        } else {
            std::thread::scope(|scope| {
                let handles: Vec<_> = (1..threads).map(|t| scope.spawn(move || draw(t))).collect();
                let mut all = vec![draw(0)];
                // (A thread that panicked has its share drawn again here.)
                for (k, hd) in handles.into_iter().enumerate() {
                    all.push(hd.join().unwrap_or_else(|_| draw(k as u32 + 1)));
                }
                all
            })
        };
        let mut px = vec![0u8; w as usize * h as usize * 4];
        for (y, row) in px.chunks_exact_mut(w as usize * 4).enumerate() {
            let y = y as u32;
            if let Some((t, _)) = results.iter().find(|(t, _)| t.owns(y)) {
                t.resolve_row(y, row);
            }
        }
        if opts.smooth && samples == 1 {
            crate::smooth::smooth_edges(&mut px, w, h);
        }
        let stood_in = results.iter().map(|(_, s)| s).sum::<u64>();
        (px, Drawn { triangles: self.submitted(ppu), stood_in })
    }

    /// Triangles a frame submits (every instance's at the level of detail of its
    /// draw; stand-ins not subtracted).
    fn submitted(&self, ppu: Option<f32>) -> u64 {
        let mut n = self.scene.indices.len() as u64 / 3;
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

impl Job<'_, '_> {
    /// The pixel rows a sphere (world centre `c`, radius `r`) may cover, or `None`
    /// when it may reach behind the eye (then any row).
    #[inline]
    fn sphere_rows(&self, c: Vec3, r: f32) -> Option<(i64, i64, bool)> {
        self.sphere_rows_at(self.vp * c.extend(1.0), r)
    }

    /// The sphere of stand-in `s` placed by `l` and `t` (what [`points`] reads).
    #[inline]
    fn placed(&self, s: &scene::StandIn, l: Mat3, t: Vec3) -> points::Placed {
        let centre = l * s.centre + t;
        let scale = l.x_axis.length().max(l.y_axis.length()).max(l.z_axis.length());
        points::Placed {
            centre,
            radius: s.radius * scale,
            clip: self.vp * centre.extend(1.0),
            w_len: self.row_lengths[2],
        }
    }

    /// [`Job::sphere_rows`] for the centre's clip position `clip`.
    #[inline]
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

    /// Draws everything this thread's strips show, in the Vulkan renderer's order:
    /// the mesh, the instances (stand-ins where chosen), pen lines, overlays.
    /// Returns the instances it drew as stand-ins (those whose centre row it owns).
    fn draw(&self, t: &mut Target) -> u64 {
        self.mesh(t);
        let stood_in = self.instances(t);
        self.lines(t);
        stood_in
    }

    fn mesh(&self, t: &mut Target) {
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
        for tri in s.indices.chunks_exact(3) {
            let v = [vertex(tri[0]), vertex(tri[1]), vertex(tri[2])];
            if let Some((y0, y1)) = screen_rows(&v, self.height) {
                if !t.any_row(y0, y1) {
                    continue;
                }
            }
            t.triangle(v, false);
        }
    }

    fn instances(&self, t: &mut Target) -> u64 {
        let Some(inst) = &self.cpu.scene.instanced else { return 0 };
        let out = self.cpu.output;
        let frames = out.instances.packed_frames();
        let mut fields = out.instances.fields();
        let ps = PROTO_STRIDE as usize;
        let mut local: Vec<V> = Vec::new();
        let mut points_buf: Vec<points::Point> = Vec::new();
        let mut stood_in = 0u64;
        for (k, d) in inst.draws.iter().enumerate() {
            let lod = match (inst.lods.get(k).copied().flatten(), self.ppu) {
                (Some(l), Some(p)) if l.radius * p <= scene::LOD_PIXELS => Some(l),
                _ => None,
            };
            let ((full_first, full_n), lod_range) = self.cpu.ranges.get(k).copied().unwrap_or(((0, 0), None));
            let (first_index, index_count, vertex_offset, (v_first, v_n), cull) = match (lod, lod_range) {
                (Some(l), Some(r)) => (l.first_index, l.index_count, l.vertex_offset, r, false),
                _ => (d.first_index, d.index_count, d.vertex_offset, (full_first, full_n), d.closed),
            };
            let indices = inst.indices.get(first_index as usize..(first_index + index_count) as usize).unwrap_or(&[]);
            let stand = inst.stand_ins.get(k).copied();
            let facets =
                stand.and_then(|s| inst.facets.get(s.first_facet as usize..(s.first_facet + s.n_facets) as usize));
            // The first look's reach around u, per unit of |q| |q̂| (see below).
            let reach = stand.map(|s| s.centre.length() + s.radius);
            let order = inst.order.get(d.first_instance as usize..(d.first_instance + d.instance_count) as usize);
            for &oi in order.unwrap_or(&[]) {
                let oi = oi as usize;
                let (Some(pf), Some(f)) = (frames.get(oi), fields.get(oi)) else { continue };
                let u = Vec3::new(pf[8], pf[9], pf[10]);
                // A first look from the frame alone (no matrix yet): q x q̂ scales by
                // |q| |q̂|, so the mesh's sphere lies within this one around u.
                if let (0, 0, Some(reach)) = (f.bone, f.lin, reach) {
                    let q = Vec4::new(pf[0], pf[1], pf[2], pf[3]).length();
                    let qh = Vec4::new(pf[4], pf[5], pf[6], pf[7]).length();
                    if let Some((y0, y1, visible)) = self.sphere_rows(u, q * qh * reach) {
                        if !visible || !t.any_row(y0, y1) {
                            continue;
                        }
                    }
                }
                // The transform, made once: the frame's axes, or through the output
                // for a non-uniform factor.
                let frame = frame_of(pf);
                let (l, tr) = if f.lin == 0 {
                    let [a, b, c] = frame.axes();
                    (Mat3::from_cols(a, b, c), u)
                } else {
                    let instance = Instance { frame, color: f.color, mesh: f.mesh, bone: f.bone, lin: f.lin, at: f.at };
                    let m = out.instance_transform(&instance);
                    (Mat3::from_mat4(m), m.w_axis.truncate())
                };
                // Where it may be on the screen (instances posed by a bone: anywhere).
                let mut centre_row = None;
                let mut placed = None;
                if let (0, Some(s)) = (f.bone, stand) {
                    let at = self.placed(&s, l, tr);
                    if let Some((y0, y1, visible)) = self.sphere_rows_at(at.clip, at.radius) {
                        if !visible || !t.any_row(y0, y1) {
                            continue;
                        }
                        centre_row = Some((y0 + y1) / 2);
                    }
                    placed = Some(at);
                }
                let color = Vec4::from_array(f.color);
                if let (Some(view), Some(s), Some(fs), Some(at)) = (&self.stand_in_view, stand, facets, placed) {
                    if points::stand_in_points(view, &s, fs, l, tr, color, &at, &mut points_buf) {
                        let row = centre_row.unwrap_or(0).clamp(0, i64::from(self.height) - 1) as u32;
                        if t.owns(row) {
                            stood_in += 1;
                        }
                        for p in &points_buf {
                            t.point(self.vp * p.pos.extend(1.0), p.size, p.rgba);
                        }
                        continue;
                    }
                }
                // phong_instanced_vs for each vertex of the mesh.
                let bone = self.bones.get(f.bone as usize).copied().unwrap_or(Mat4::IDENTITY);
                let b3 = Mat3::from_mat4(bone);
                let (cl, cb) = (cofactor(l), cofactor(b3));
                let sign = l.x_axis.dot(cl.x_axis).signum() * b3.x_axis.dot(cb.x_axis).signum();
                let nm = cb * cl * sign;
                local.clear();
                for v in 0..v_n {
                    let at = (v_first as usize + v) * ps;
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
                let base = i64::from(vertex_offset) - v_first;
                for tri in indices.chunks_exact(3) {
                    let at = |k: usize| local.get((base + i64::from(tri[k])) as usize).copied().unwrap_or_default();
                    let v = [at(0), at(1), at(2)];
                    if let Some((y0, y1)) = screen_rows(&v, self.height) {
                        if !t.any_row(y0, y1) {
                            continue;
                        }
                    }
                    t.triangle(v, cull);
                }
            }
        }
        stood_in
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

/// The frame a packed frame holds.
#[inline]
fn frame_of(pf: &PackedFrame) -> Frame {
    Frame {
        q: Quat::from_xyzw(pf[0], pf[1], pf[2], pf[3]),
        qh: Quat::from_xyzw(pf[4], pf[5], pf[6], pf[7]),
        u: Vec3::new(pf[8], pf[9], pf[10]),
    }
}
