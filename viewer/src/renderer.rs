//! The renderer shared by the offscreen and window paths: a render pass with a
//! multisampled colour and depth attachment resolved into the target image (or, at
//! one sample, drawing into the target with a depth attachment), the
//! model's GPU buffers, the uniform buffers and descriptor set, the pipelines, and
//! command recording for one frame.
//!
//! One frame is in flight at a time: callers wait for the previous frame's fence
//! before [`Renderer::update`] writes the uniform buffers, and wait for the device
//! to be idle before [`Renderer::set_model`] or [`Renderer::resize`] replace
//! resources the GPU may be using.

use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::{vkerr, Context};
use crate::image::{depth_format, msaa_samples, Image, ImageDesc, SampleChoice};
use crate::model::Model;
use crate::pipeline::{Kind, Layout, Pipeline, PipelineDesc};
use crate::points;
use crate::program::{self, ProgramSpirv, Programs};
use crate::scene::{self, Bounds};
use crate::uniforms::{self, UniformSpec};
use crate::Error;
use ash::vk;
use glam::{Mat4, Vec3};
use mdg_vm::bundle::Bundle;
use mdg_vm::output::{Animation, Output};

use std::sync::Arc;

/// What the renderer draws into.
#[derive(Clone, Copy, Debug)]
pub struct RendererOptions {
    /// Format of the target images (the resolve attachment).
    pub color_format: vk::Format,
    /// Layout the target is left in: `TRANSFER_SRC_OPTIMAL` offscreen,
    /// `PRESENT_SRC_KHR` for a swapchain.
    pub final_layout: vk::ImageLayout,
    /// Samples wanted (0: what the device needs, [`crate::image::default_samples`]);
    /// the count used is [`crate::image::msaa_samples`]'s choice. At 1 the render
    /// pass draws straight into the target, with no multisampled colour image and no
    /// resolve.
    pub samples: u32,
}

/// An attachment that starts undefined and has no stencil.
fn attachment(
    format: vk::Format,
    samples: vk::SampleCountFlags,
    load: vk::AttachmentLoadOp,
    store: vk::AttachmentStoreOp,
    final_layout: vk::ImageLayout,
) -> vk::AttachmentDescription {
    vk::AttachmentDescription::default()
        .format(format)
        .samples(samples)
        .load_op(load)
        .store_op(store)
        .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
        .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
        .initial_layout(vk::ImageLayout::UNDEFINED)
        .final_layout(final_layout)
}

/// A render pass, destroyed in `Drop`.
pub struct RenderPass {
    ctx: Arc<Context>,
    pub raw: vk::RenderPass,
}

impl RenderPass {
    fn new(
        ctx: &Arc<Context>,
        color: vk::Format,
        depth: vk::Format,
        samples: vk::SampleCountFlags,
        final_layout: vk::ImageLayout,
    ) -> Result<RenderPass, Error> {
        use vk::{AttachmentLoadOp as Load, AttachmentStoreOp as Store, ImageLayout as Layout};
        let one = vk::SampleCountFlags::TYPE_1;
        let multisampled = samples != one;
        // The target: written by the resolve when multisampled, else drawn into.
        let target = attachment(
            color,
            one,
            if multisampled { Load::DONT_CARE } else { Load::CLEAR },
            Store::STORE,
            final_layout,
        );
        let depth_attachment =
            attachment(depth, samples, Load::CLEAR, Store::DONT_CARE, Layout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL);
        let attachments: Vec<vk::AttachmentDescription> = if multisampled {
            vec![
                // 0: multisampled colour, resolved, never stored.
                attachment(color, samples, Load::CLEAR, Store::DONT_CARE, Layout::COLOR_ATTACHMENT_OPTIMAL),
                // 1: multisampled depth.
                depth_attachment,
                // 2: the target, written by the resolve.
                target,
            ]
        } else {
            // 0: the target, drawn into; 1: depth. No resolve.
            vec![target, depth_attachment]
        };
        let color_ref = [vk::AttachmentReference { attachment: 0, layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL }];
        let depth_ref =
            vk::AttachmentReference { attachment: 1, layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL };
        let resolve_ref =
            [vk::AttachmentReference { attachment: 2, layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL }];
        let mut subpass = vk::SubpassDescription::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&color_ref)
            .depth_stencil_attachment(&depth_ref);
        if multisampled {
            subpass = subpass.resolve_attachments(&resolve_ref);
        }
        let subpass = [subpass];
        // Wait for the previous use of the attachments (and, for a swapchain, the
        // acquire semaphore's stage) before writing; make the resolve (or, at one
        // sample, the drawing) visible to a following copy.
        let deps = [
            vk::SubpassDependency::default()
                .src_subpass(vk::SUBPASS_EXTERNAL)
                .dst_subpass(0)
                .src_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                )
                .dst_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
                )
                .src_access_mask(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE)
                .dst_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
            vk::SubpassDependency::default()
                .src_subpass(0)
                .dst_subpass(vk::SUBPASS_EXTERNAL)
                .src_stage_mask(vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT)
                .dst_stage_mask(vk::PipelineStageFlags::TRANSFER)
                .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
                .dst_access_mask(vk::AccessFlags::TRANSFER_READ),
        ];
        let info =
            vk::RenderPassCreateInfo::default().attachments(&attachments).subpasses(&subpass).dependencies(&deps);
        // SAFETY: valid device; all pointers refer to locals alive for the call.
        let raw = unsafe { ctx.device.create_render_pass(&info, None) }.map_err(vkerr("create render pass"))?;
        Ok(RenderPass { ctx: ctx.clone(), raw })
    }
}

impl Drop for RenderPass {
    fn drop(&mut self) {
        // SAFETY: dropped with the renderer, after the GPU is idle.
        unsafe { self.ctx.device.destroy_render_pass(self.raw, None) };
    }
}

/// A framebuffer for one target image, destroyed in `Drop`.
pub struct Framebuffer {
    ctx: Arc<Context>,
    pub raw: vk::Framebuffer,
    pub extent: vk::Extent2D,
}

impl Drop for Framebuffer {
    fn drop(&mut self) {
        // SAFETY: owners drop framebuffers after the frames using them finished.
        unsafe { self.ctx.device.destroy_framebuffer(self.raw, None) };
    }
}

/// A descriptor pool with the one set the renderer uses.
struct Descriptors {
    ctx: Arc<Context>,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
}

impl Descriptors {
    fn new(ctx: &Arc<Context>, layout: &Layout) -> Result<Descriptors, Error> {
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::UNIFORM_BUFFER, descriptor_count: 2 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: 1 },
        ];
        let info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        // SAFETY: valid device and create info.
        let pool =
            unsafe { ctx.device.create_descriptor_pool(&info, None) }.map_err(vkerr("create descriptor pool"))?;
        let mut d = Descriptors { ctx: ctx.clone(), pool, set: vk::DescriptorSet::null() };
        let layouts = [layout.set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&layouts);
        // SAFETY: the pool has room for this one set of this layout.
        let sets = unsafe { ctx.device.allocate_descriptor_sets(&alloc) }.map_err(vkerr("allocate descriptor set"))?;
        d.set = sets.first().copied().ok_or_else(|| Error::Vulkan("no descriptor set".into()))?;
        Ok(d)
    }

    /// Points the set at the three buffers.
    fn write(&self, globals: &Buffer, bones: &Buffer, user: &Buffer) {
        let infos = [
            [vk::DescriptorBufferInfo { buffer: globals.raw, offset: 0, range: vk::WHOLE_SIZE }],
            [vk::DescriptorBufferInfo { buffer: bones.raw, offset: 0, range: vk::WHOLE_SIZE }],
            [vk::DescriptorBufferInfo { buffer: user.raw, offset: 0, range: vk::WHOLE_SIZE }],
        ];
        let types = [
            vk::DescriptorType::UNIFORM_BUFFER,
            vk::DescriptorType::STORAGE_BUFFER,
            vk::DescriptorType::UNIFORM_BUFFER,
        ];
        let writes: Vec<vk::WriteDescriptorSet> = (0..3)
            .map(|i| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(i as u32)
                    .descriptor_type(types[i])
                    .buffer_info(&infos[i])
            })
            .collect();
        // SAFETY: the set is not in use by a pending frame (callers are idle when
        // models change); the buffers are valid and of the declared types.
        unsafe { self.ctx.device.update_descriptor_sets(&writes, &[]) };
    }
}

impl Drop for Descriptors {
    fn drop(&mut self) {
        // SAFETY: destroying the pool frees its set; the GPU is idle by then.
        unsafe { self.ctx.device.destroy_descriptor_pool(self.pool, None) };
    }
}

/// A model on the GPU: buffers, pipelines and what the camera needs.
struct GpuModel {
    // Pipelines before buffers: field order is drop order, and both go only when
    // the GPU is idle anyway.
    fill: Pipeline,
    wire: Option<Pipeline>,
    lines: Option<Pipeline>,
    overlay: Option<Pipeline>,
    /// What the pipelines were built from: a model with the same key reuses them.
    key: PipelineKey,
    /// Instances drawn with GPU instancing, when the scene has them.
    instanced: Option<GpuInstanced>,
    vertices: Buffer,
    skins: Buffer,
    indices: Buffer,
    n_indices: u32,
    line_vertices: Option<Buffer>,
    n_line_vertices: u32,
    n_overlay_vertices: u32,
    descriptors: Descriptors,
    bones: Buffer,
    n_bones: u32,
    user: Buffer,
    globals: Buffer,
    uniforms: UniformSpec,
    animation: Animation,
}

/// The instanced part of a model on the GPU (see [`scene::Instanced`]).
struct GpuInstanced {
    fill: Pipeline,
    /// `fill` culling back faces, for closed meshes.
    fill_closed: Pipeline,
    wire: Option<Pipeline>,
    vertices: Buffer,
    indices: Buffer,
    instances: Buffer,
    draws: Vec<scene::InstancedDraw>,
    /// Each draw's level of detail ([`scene::Lod`]).
    lods: Vec<Option<scene::Lod>>,
    /// Each draw's point-sprite summary, and their facets ([`crate::points`]).
    stand_ins: Vec<scene::StandIn>,
    facets: Vec<scene::Facet>,
    /// The point program, when the instances' fragment shader is std's `phong_fs`
    /// (whose colour the stand-ins compute) and the caller has one.
    points_program: Option<ProgramSpirv>,
    /// The stand-ins chosen for the last prepared view ([`Renderer::prepare`]).
    selection: Option<GpuSelection>,
}

/// Small instances drawn as points for one view: the instances kept as meshes
/// (their records copied, draw by draw) and the points.
struct GpuSelection {
    view: points::View,
    kept: Buffer,
    /// Per draw, its first instance in `kept` and their count.
    kept_draws: Vec<(u32, u32)>,
    points: Buffer,
    n_points: u32,
    /// Instances drawn as points.
    n_stood_in: u64,
}

/// What a model's pipelines depend on. A new model with the same key (the guide
/// editor uploads one per search and per edit) keeps the pipelines: building them is
/// most of an upload's time on a CPU driver.
#[derive(Clone, Debug, PartialEq)]
struct PipelineKey {
    program: ProgramSpirv,
    lines: ProgramSpirv,
    skinned: bool,
    has_lines: bool,
    /// The instanced program, when the model has instances to draw so.
    instanced: Option<ProgramSpirv>,
    /// Depth-tested (not a `flat` model).
    depth: bool,
}

/// The filled, wireframe, line and overlay pipelines of a model, and the filled and
/// wireframe pipelines of its instances.
struct Pipelines {
    fill: Pipeline,
    wire: Option<Pipeline>,
    lines: Option<Pipeline>,
    overlay: Option<Pipeline>,
    instanced: Option<(Pipeline, Pipeline, Option<Pipeline>)>,
}

/// Facts about the loaded model.
#[derive(Clone, Debug)]
pub struct ModelInfo {
    pub bounds: Bounds,
    /// The grammar's `flat` directive (Context Free's flat art).
    pub flat: bool,
    pub n_triangles: usize,
    pub n_line_segments: usize,
    pub background: [f32; 4],
    pub fov_deg: f32,
    pub near: f32,
    pub far: f32,
    /// Which shaders draw it.
    pub program: String,
    /// Bones move or a camera rule moves the view: time matters.
    pub animated: bool,
    /// The grammar has a `camerarule`.
    pub has_camera_rule: bool,
    /// `duration` in seconds and `fps`.
    pub duration: f32,
    pub fps: f32,
}

impl ModelInfo {
    /// The facts about `output` (of `bundle`) as `scene` packs it, drawn by the
    /// program labelled `program` (either renderer's).
    pub fn of(scene: &scene::Scene, output: &Output, bundle: &Bundle, program: String) -> ModelInfo {
        let s = &bundle.settings;
        ModelInfo {
            bounds: scene.bounds,
            flat: output.flat,
            n_triangles: scene.n_triangles(),
            n_line_segments: scene.n_line_vertices as usize / 2,
            background: output.background,
            fov_deg: s.camerafov,
            near: s.near,
            far: s.far,
            program,
            animated: output.animation.is_animated(),
            has_camera_rule: output.animation.camera.is_some(),
            duration: s.duration,
            fps: s.fps,
        }
    }
}

/// One frame's camera and time.
#[derive(Clone, Copy, Debug)]
pub struct FrameParams {
    pub camera: OrbitCamera,
    /// Seconds: bones, the camera rule and frame-bound uniforms are read here.
    pub time: f32,
    pub wireframe: bool,
    /// Look through the grammar's `camerarule` (when it has one) instead of
    /// `camera`.
    pub camera_rule: bool,
}

/// The renderer.
pub struct Renderer {
    ctx: Arc<Context>,
    model: Option<(GpuModel, ModelInfo)>,
    /// The multisampled colour image (none at one sample) and the depth image.
    attachments: Option<(Option<Image>, Image)>,
    pub render_pass: RenderPass,
    layout: Layout,
    pub samples: vk::SampleCountFlags,
    /// The samples asked for and given.
    pub sample_choice: SampleChoice,
    pub color_format: vk::Format,
    /// Draw the overlay lines (guides, skeleton bones, the guide editor's handles),
    /// over the model; on by default.
    pub show_overlays: bool,
    /// Draw instances that are small on the screen with their shared mesh's level
    /// of detail ([`scene::Lod`]); on by default.
    pub lod: bool,
    /// With `lod`: draw instances that cover at most [`points::POINT_PIXELS`] as
    /// point sprites of their area and shaded colour ([`crate::points`]), chosen
    /// per view by [`Renderer::prepare`]. On by default on a CPU driver (lavapipe),
    /// where every instance costs its own pass through the vertex pipeline; off on
    /// a GPU, which draws small instances fast and would only wait for the CPU's
    /// choice.
    pub stand_ins: bool,
    /// The point-sprite pipeline, built when a view first needs it.
    point_pipeline: Option<Pipeline>,
    /// Build the wireframe pipelines when a frame first asks for wireframe (in
    /// [`Renderer::prepare`]) rather than with every model: the offscreen renderer,
    /// whose pictures are rarely wireframe (on lavapipe each pipeline is shader
    /// compilation work). Off by default: the window toggles wireframe at any frame
    /// and does not call `prepare`.
    pub wireframe_on_demand: bool,
    /// Triangles the last recorded frame drew (instances' at their level of detail).
    drawn: std::cell::Cell<u64>,
    /// Instances the last recorded frame drew as point sprites, and the points.
    drawn_points: std::cell::Cell<(u64, u64)>,
    depth_format: vk::Format,
    extent: vk::Extent2D,
}

impl Renderer {
    pub fn new(ctx: &Arc<Context>, opts: RendererOptions) -> Result<Renderer, Error> {
        let sample_choice = msaa_samples(ctx, opts.samples);
        let samples = sample_choice.flags;
        let depth = depth_format(ctx);
        let render_pass = RenderPass::new(ctx, opts.color_format, depth, samples, opts.final_layout)?;
        let layout = Layout::new(ctx)?;
        Ok(Renderer {
            ctx: ctx.clone(),
            model: None,
            attachments: None,
            render_pass,
            layout,
            samples,
            sample_choice,
            color_format: opts.color_format,
            show_overlays: true,
            lod: true,
            stand_ins: ctx.device_type == vk::PhysicalDeviceType::CPU && ctx.large_points,
            point_pipeline: None,
            wireframe_on_demand: false,
            drawn: std::cell::Cell::new(0),
            drawn_points: std::cell::Cell::new((0, 0)),
            depth_format: depth,
            extent: vk::Extent2D { width: 0, height: 0 },
        })
    }

    /// Facts about the current model.
    pub fn info(&self) -> Option<&ModelInfo> {
        self.model.as_ref().map(|(_, i)| i)
    }

    /// Uploads a model and builds its pipelines (its `program` or std Phong). On
    /// error the previous model stays. The GPU must be idle.
    pub fn set_model(&mut self, model: &Model, programs: &Programs) -> Result<&ModelInfo, Error> {
        self.set_output(&model.bundle, &model.output, programs)
    }

    /// Like [`Renderer::set_model`] with the bundle and its output held apart (no copy
    /// of either is made).
    pub fn set_output(&mut self, bundle: &Bundle, output: &Output, programs: &Programs) -> Result<&ModelInfo, Error> {
        let program = program::for_bundle(bundle, programs)?;
        // A `flat` model is painted in triangle order: one mesh, no GPU instances.
        let instanced = if output.flat { None } else { program::instanced_for_bundle(bundle, programs)? };
        let scene = scene::build_with(output, instanced.is_some());
        // Point stand-ins carry the colour std's fragment shader would give: only
        // for instances drawn by it.
        let points_program = match (&programs.points, &instanced) {
            (Some(p), Some(i)) if i.fragment == programs.phong.fragment => Some(p.clone()),
            _ => None,
        };
        self.set_scene_instanced(&scene, bundle, output, &program, &programs.lines, instanced.as_ref())?;
        if let Some((gpu, _)) = &mut self.model {
            if let Some(inst) = &mut gpu.instanced {
                inst.points_program = points_program;
            }
        }
        self.model.as_ref().map(|(_, i)| i).ok_or_else(|| Error::Other("model vanished".into()))
    }

    /// Like [`Renderer::set_output`] with a prepared scene and program (a scene of
    /// expanded instances, [`scene::build`]).
    pub fn set_scene(
        &mut self,
        scene: &scene::Scene,
        bundle: &Bundle,
        output: &Output,
        program: &ProgramSpirv,
        lines: &ProgramSpirv,
    ) -> Result<&ModelInfo, Error> {
        self.set_scene_instanced(scene, bundle, output, program, lines, None)
    }

    /// [`Renderer::set_scene`] for a scene that may hold instances to draw with GPU
    /// instancing ([`scene::build_with`]) by `instanced`; the scene must have been
    /// built from `output` (the instance records are read from it).
    pub fn set_scene_instanced(
        &mut self,
        scene: &scene::Scene,
        bundle: &Bundle,
        output: &Output,
        program: &ProgramSpirv,
        lines: &ProgramSpirv,
        instanced: Option<&ProgramSpirv>,
    ) -> Result<&ModelInfo, Error> {
        let ctx = &self.ctx;
        let skinned = !scene.skins.is_empty();
        // `flat` (Context Free's flat art): unlit (the pen lines' program, colour as
        // given, no shading or specular) unless the grammar has its own `program`,
        // and no depth test, so later triangles paint over earlier ones.
        let flat_program;
        let program = if output.flat && bundle.program.is_none() {
            flat_program = ProgramSpirv { label: "flat (unlit)".into(), ..lines.clone() };
            &flat_program
        } else {
            program
        };
        let instanced = match (instanced, &scene.instanced) {
            (Some(p), Some(i)) if !i.draws.is_empty() => Some(p.clone()),
            (None, Some(i)) if !i.draws.is_empty() => {
                return Err(Error::Other("a scene of GPU instances needs the instanced program".into()));
            }
            _ => None,
        };
        let key = PipelineKey {
            program: program.clone(),
            lines: lines.clone(),
            skinned,
            has_lines: scene.n_line_vertices > 0,
            instanced,
            depth: !output.flat,
        };
        let reuse = self.model.as_ref().is_some_and(|(old, _)| old.key == key);
        let built = if reuse { None } else { Some(self.pipelines(&key)?) };
        let vertices = Buffer::with_data(ctx, &scene.vertices, vk::BufferUsageFlags::VERTEX_BUFFER)?;
        let skin_bytes: Vec<u8> = if skinned { scene.skins.clone() } else { vec![0u8; scene::SKIN_STRIDE as usize] };
        let skins = Buffer::with_data(ctx, &skin_bytes, vk::BufferUsageFlags::VERTEX_BUFFER)?;
        let index_bytes: Vec<u8> = scene.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let indices = Buffer::with_data(ctx, &index_bytes, vk::BufferUsageFlags::INDEX_BUFFER)?;
        let line_vertices = if scene.n_line_vertices > 0 {
            Some(Buffer::with_data(ctx, &scene.line_vertices, vk::BufferUsageFlags::VERTEX_BUFFER)?)
        } else {
            None
        };
        let spec = UniformSpec::new(bundle, output);
        let animation = output.animation.clone();
        let globals = Buffer::host(ctx, uniforms::GLOBALS_SIZE as u64, vk::BufferUsageFlags::UNIFORM_BUFFER)?;
        let user_bytes = uniforms::user(&spec.values(&animation, 0.0));
        let user = Buffer::host(ctx, user_bytes.len() as u64, vk::BufferUsageFlags::UNIFORM_BUFFER)?;
        user.write(0, &user_bytes)?;
        let n_bones = (scene.max_bone + 1).max(animation.bones.len() as u32);
        let bone_bytes = uniforms::bones(&animation, 0.0, n_bones);
        let bones = Buffer::host(ctx, bone_bytes.len() as u64, vk::BufferUsageFlags::STORAGE_BUFFER)?;
        bones.write(0, &bone_bytes)?;
        let descriptors = Descriptors::new(ctx, &self.layout)?;
        descriptors.write(&globals, &bones, &user);
        let info = ModelInfo::of(scene, output, bundle, program.label.clone());
        let p = match (built, self.model.take()) {
            (Some(p), _) => p,
            (None, Some((old, _))) => Pipelines {
                fill: old.fill,
                wire: old.wire,
                lines: old.lines,
                overlay: old.overlay,
                instanced: old.instanced.map(|i| (i.fill, i.fill_closed, i.wire)),
            },
            (None, None) => self.pipelines(&key)?,
        };
        let instanced = match (p.instanced, &scene.instanced) {
            (Some((fill, fill_closed, wire)), Some(i)) => Some(GpuInstanced {
                fill,
                fill_closed,
                wire,
                vertices: Buffer::with_data(ctx, &i.vertices, vk::BufferUsageFlags::VERTEX_BUFFER)?,
                indices: Buffer::with_data(
                    ctx,
                    &i.indices.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
                    vk::BufferUsageFlags::INDEX_BUFFER,
                )?,
                // The records are written straight into the buffer (no copy).
                instances: Buffer::filled(ctx, i.instance_bytes(), vk::BufferUsageFlags::VERTEX_BUFFER, |dst| {
                    i.write_instances(output, dst)
                })?,
                draws: i.draws.clone(),
                lods: i.lods.clone(),
                stand_ins: i.stand_ins.clone(),
                facets: i.facets.clone(),
                points_program: None,
                selection: None,
            }),
            _ => None,
        };
        let gpu = GpuModel {
            fill: p.fill,
            wire: p.wire,
            lines: p.lines,
            overlay: p.overlay,
            key,
            instanced,
            vertices,
            skins,
            indices,
            n_indices: scene.indices.len() as u32,
            line_vertices,
            n_line_vertices: scene.n_line_vertices,
            n_overlay_vertices: scene.n_overlay_vertices,
            descriptors,
            bones,
            n_bones,
            user,
            globals,
            uniforms: spec,
            animation,
        };
        self.model = Some((gpu, info));
        self.model.as_ref().map(|(_, i)| i).ok_or_else(|| Error::Other("model vanished".into()))
    }

    /// What a pipeline of `key` is made for, of `kind`.
    fn desc(&self, key: &PipelineKey, kind: Kind) -> PipelineDesc {
        PipelineDesc {
            kind,
            render_pass: self.render_pass.raw,
            samples: self.samples,
            skinned: key.skinned,
            instanced: false,
            cull_back: false,
            depth: key.depth,
        }
    }

    /// The wireframe pipelines of `key`: the model's and its instances' (`None`
    /// without instances, or both when the device has no wireframe).
    fn wire_pipelines(&self, key: &PipelineKey) -> Result<(Option<Pipeline>, Option<Pipeline>), Error> {
        if !self.ctx.wireframe {
            return Ok((None, None));
        }
        let p = &key.program;
        let wire = Pipeline::new(&self.ctx, &self.layout, &p.vertex, &p.fragment, self.desc(key, Kind::Wireframe))?;
        let inst = match &key.instanced {
            Some(ip) => {
                let desc = PipelineDesc { instanced: true, ..self.desc(key, Kind::Wireframe) };
                Some(Pipeline::new(&self.ctx, &self.layout, &ip.vertex, &ip.fragment, desc)?)
            }
            None => None,
        };
        Ok((Some(wire), inst))
    }

    /// Builds the pipelines of `key`: filled, wireframe (when the device can, and
    /// unless [`Renderer::wireframe_on_demand`]), and the line and overlay pipelines
    /// when there are lines.
    fn pipelines(&self, key: &PipelineKey) -> Result<Pipelines, Error> {
        let ctx = &self.ctx;
        let desc = |kind| self.desc(key, kind);
        let (p, l) = (&key.program, &key.lines);
        let fill = Pipeline::new(ctx, &self.layout, &p.vertex, &p.fragment, desc(Kind::Fill))?;
        let (wire, inst_wire) = if self.wireframe_on_demand { (None, None) } else { self.wire_pipelines(key)? };
        let line = |kind| {
            Pipeline::new(ctx, &self.layout, &l.vertex, &l.fragment, PipelineDesc { skinned: false, ..desc(kind) })
        };
        let (lines, overlay) =
            if key.has_lines { (Some(line(Kind::Lines)?), Some(line(Kind::Overlay)?)) } else { (None, None) };
        let instanced = match &key.instanced {
            Some(ip) => {
                let inst = |kind| PipelineDesc { instanced: true, ..desc(kind) };
                let fill = Pipeline::new(ctx, &self.layout, &ip.vertex, &ip.fragment, inst(Kind::Fill))?;
                let closed = PipelineDesc { cull_back: true, ..inst(Kind::Fill) };
                let fill_closed = Pipeline::new(ctx, &self.layout, &ip.vertex, &ip.fragment, closed)?;
                Some((fill, fill_closed, inst_wire))
            }
            None => None,
        };
        Ok(Pipelines { fill, wire, lines, overlay, instanced })
    }

    /// (Re)creates the attachments for `extent` (depth, and the multisampled colour
    /// image when there is more than one sample). The GPU must be idle.
    pub fn resize(&mut self, extent: vk::Extent2D) -> Result<(), Error> {
        if self.attachments.is_some() && extent == self.extent {
            return Ok(());
        }
        self.attachments = None;
        let color = if self.samples == vk::SampleCountFlags::TYPE_1 {
            None
        } else {
            Some(Image::new(
                &self.ctx,
                ImageDesc {
                    width: extent.width,
                    height: extent.height,
                    format: self.color_format,
                    samples: self.samples,
                    usage: vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
                    aspect: vk::ImageAspectFlags::COLOR,
                },
            )?)
        };
        let mut aspect = vk::ImageAspectFlags::DEPTH;
        if self.depth_format == vk::Format::D24_UNORM_S8_UINT {
            aspect |= vk::ImageAspectFlags::STENCIL;
        }
        let depth = Image::new(
            &self.ctx,
            ImageDesc {
                width: extent.width,
                height: extent.height,
                format: self.depth_format,
                samples: self.samples,
                usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
                aspect,
            },
        )?;
        self.attachments = Some((color, depth));
        self.extent = extent;
        Ok(())
    }

    /// A framebuffer drawing into `target` (a view of a target image of the
    /// current extent; call [`Renderer::resize`] first).
    pub fn framebuffer(&self, target: vk::ImageView) -> Result<Framebuffer, Error> {
        let Some((color, depth)) = &self.attachments else {
            return Err(Error::Other("framebuffer before resize".into()));
        };
        let views = match color {
            Some(color) => vec![color.view, depth.view, target],
            None => vec![target, depth.view],
        };
        let info = vk::FramebufferCreateInfo::default()
            .render_pass(self.render_pass.raw)
            .attachments(&views)
            .width(self.extent.width)
            .height(self.extent.height)
            .layers(1);
        // SAFETY: the views are valid, of this extent, and match the render pass.
        let raw = unsafe { self.ctx.device.create_framebuffer(&info, None) }.map_err(vkerr("create framebuffer"))?;
        Ok(Framebuffer { ctx: self.ctx.clone(), raw, extent: self.extent })
    }

    /// The view and projection of a frame: the orbit camera, or the grammar's
    /// camera rule at the frame's time (looking along its −z with +y up).
    pub fn view_projection(&self, frame: &FrameParams) -> (Mat4, Mat4, Vec3) {
        let aspect = self.extent.width.max(1) as f32 / self.extent.height.max(1) as f32;
        let planes = self.info().map(|i| (i.near, i.far)).unwrap_or((0.1, 1000.0));
        let animation = self.model.as_ref().map(|(gpu, _)| &gpu.animation);
        let rule_at = frame.camera_rule.then_some(frame.time);
        crate::camera::frame_view_projection(&frame.camera, rule_at, animation, planes, aspect)
    }

    /// Writes the frame's uniforms and bone matrices. The previous frame must have
    /// finished.
    pub fn update(&self, frame: &FrameParams) -> Result<(), Error> {
        let Some((gpu, info)) = &self.model else { return Ok(()) };
        let (view, projection, eye) = self.view_projection(frame);
        let values = gpu.uniforms.values(&gpu.animation, frame.time);
        let (center, radius) = info.bounds.sphere();
        let light = values.light_pos.unwrap_or_else(|| uniforms::default_light(center, radius));
        let spec = values.spec_color_power.unwrap_or(uniforms::DEFAULT_SPEC_COLOR_POWER);
        gpu.globals.write(0, &uniforms::globals(&projection, &view, eye, light, spec))?;
        gpu.user.write(0, &uniforms::user(&values))?;
        if info.animated {
            gpu.bones.write(0, &uniforms::bones(&gpu.animation, frame.time, gpu.n_bones))?;
        }
        Ok(())
    }

    /// What a frame looks like to the point stand-ins: `None` when they are off
    /// (`lod` or `stand_ins` unset, wireframe) or there is nothing to stand in for.
    fn stand_in_view(&self, frame: &FrameParams) -> Option<points::View> {
        if !(self.lod && self.stand_ins) || frame.wireframe {
            return None;
        }
        let (gpu, info) = self.model.as_ref()?;
        let inst = gpu.instanced.as_ref()?;
        inst.points_program.as_ref()?;
        let (view, projection, eye) = self.view_projection(frame);
        let values = gpu.uniforms.values(&gpu.animation, frame.time);
        let (center, radius) = info.bounds.sphere();
        let light = values.light_pos.unwrap_or_else(|| uniforms::default_light(center, radius));
        Some(points::View {
            view_projection: projection * view,
            eye,
            light: Vec3::new(light[0], light[1], light[2]),
            spec: values.spec_color_power.unwrap_or(uniforms::DEFAULT_SPEC_COLOR_POWER),
            width: self.extent.width as f32,
            height: self.extent.height as f32,
            flat: info.bounds.is_flat(),
        })
    }

    /// Builds the wireframe pipelines when `frame` is the first to need them
    /// ([`Renderer::wireframe_on_demand`]); chooses the instances drawn as point
    /// sprites in `frame` ([`crate::points`]) and uploads them with the instances kept as meshes; a frame recorded with
    /// another view draws every instance as a mesh. The GPU must not be using the
    /// model (callers wait for the previous frame first). Does nothing when the
    /// view is the last one prepared.
    pub fn prepare(&mut self, frame: &FrameParams) -> Result<(), Error> {
        if frame.wireframe && self.ctx.wireframe {
            let missing = self.model.as_ref().filter(|(gpu, _)| gpu.wire.is_none()).map(|(gpu, _)| gpu.key.clone());
            if let Some(key) = missing {
                let (wire, inst_wire) = self.wire_pipelines(&key)?;
                if let Some((gpu, _)) = &mut self.model {
                    gpu.wire = wire;
                    if let Some(inst) = &mut gpu.instanced {
                        inst.wire = inst_wire;
                    }
                }
            }
        }
        let view = self.stand_in_view(frame);
        let ctx = self.ctx.clone();
        let Some((gpu, _)) = &mut self.model else { return Ok(()) };
        let Some(inst) = &mut gpu.instanced else { return Ok(()) };
        let Some(view) = view else {
            inst.selection = None;
            return Ok(());
        };
        if inst.selection.as_ref().is_some_and(|s| s.view == view) || !inst.instances.is_mapped() {
            return Ok(());
        }
        inst.selection = None;
        let n_records: usize =
            inst.draws.iter().map(|d| (d.first_instance + d.instance_count) as usize).max().unwrap_or(0);
        let len = n_records * scene::INSTANCE_STRIDE as usize;
        let threads = std::thread::available_parallelism().map_or(1, usize::from);
        let mut chosen = None;
        inst.instances.with_contents(len, |records| {
            let sel = points::select(&view, &inst.draws, &inst.stand_ins, &inst.facets, records, threads);
            if sel.n_points() == 0 {
                return;
            }
            let stride = scene::INSTANCE_STRIDE as usize;
            let mut kept_draws = Vec::with_capacity(sel.kept.len());
            let mut first = 0u32;
            for list in &sel.kept {
                kept_draws.push((first, list.len() as u32));
                first += list.len() as u32;
            }
            let kept = Buffer::filled(&ctx, sel.n_kept() * stride, vk::BufferUsageFlags::VERTEX_BUFFER, |dst| {
                for (&i, d) in sel.kept.iter().flatten().zip(dst.chunks_exact_mut(stride)) {
                    if let Some(r) = records.get(i as usize * stride..(i as usize + 1) * stride) {
                        d.copy_from_slice(r);
                    }
                }
            });
            let points = Buffer::filled(
                &ctx,
                sel.n_points() * points::POINT_STRIDE as usize,
                vk::BufferUsageFlags::VERTEX_BUFFER,
                |dst| sel.write_points(dst),
            );
            let n_stood_in = inst.draws.iter().map(|d| u64::from(d.instance_count)).sum::<u64>() - sel.n_kept() as u64;
            chosen = Some((kept, points, kept_draws, sel.n_points() as u32, n_stood_in));
        })?;
        let Some((kept, points, kept_draws, n_points, n_stood_in)) = chosen else { return Ok(()) };
        let (kept, points) = (kept?, points?);
        if self.point_pipeline.is_none() {
            if let Some(p) = &inst.points_program {
                let desc = PipelineDesc {
                    kind: Kind::Points,
                    render_pass: self.render_pass.raw,
                    samples: self.samples,
                    skinned: false,
                    instanced: false,
                    cull_back: false,
                    depth: true,
                };
                self.point_pipeline = Some(Pipeline::new(&ctx, &self.layout, &p.vertex, &p.fragment, desc)?);
            }
        }
        inst.selection = Some(GpuSelection { view, kept, kept_draws, points, n_points, n_stood_in });
        Ok(())
    }

    /// Instances the last recorded frame drew as point sprites, and the points
    /// (one per facet an instance shows).
    pub fn drawn_points(&self) -> (u64, u64) {
        self.drawn_points.get()
    }

    /// Triangles the last recorded frame drew, instances' at the level of detail
    /// they were drawn with.
    pub fn drawn_triangles(&self) -> u64 {
        self.drawn.get()
    }

    /// How many pixels across a sphere of radius 1 at the model's nearest point
    /// appears at most in this frame (`None` when the eye is inside the model's
    /// bounds, where anything may be near).
    fn pixels_per_unit(&self, frame: &FrameParams) -> Option<f32> {
        let info = self.info()?;
        if info.bounds.is_empty() {
            return None;
        }
        let (_, projection, eye) = self.view_projection(frame);
        let nearest = eye.clamp(info.bounds.lo, info.bounds.hi);
        let d = eye.distance(nearest);
        // The projection's y scale is 1 / tan(fov / 2): NDC units per unit at depth 1.
        let focal = projection.y_axis.y.abs() * self.extent.height as f32 * 0.5;
        (d > 1e-6 && focal.is_finite()).then(|| 2.0 * focal / d)
    }

    /// Records the render pass drawing the model into `fb`.
    pub fn record(&self, cmd: vk::CommandBuffer, fb: &Framebuffer, frame: &FrameParams) {
        let pixels_per_unit = if self.lod { self.pixels_per_unit(frame) } else { None };
        let stand_in_view = self.stand_in_view(frame);
        let mut drawn = 0u64;
        let mut drawn_points = (0u64, 0u64);
        let d = &self.ctx.device;
        let bg = self.info().map(|i| i.background).unwrap_or([0.12, 0.12, 0.14, 1.0]);
        let clears = [
            vk::ClearValue { color: vk::ClearColorValue { float32: bg } },
            vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } },
            vk::ClearValue { color: vk::ClearColorValue { float32: bg } },
        ];
        // One clear value per attachment: colour and depth, and the resolve target
        // when multisampled.
        let clears = if self.samples == vk::SampleCountFlags::TYPE_1 { &clears[..2] } else { &clears[..] };
        let area = vk::Rect2D { offset: vk::Offset2D { x: 0, y: 0 }, extent: fb.extent };
        let begin = vk::RenderPassBeginInfo::default()
            .render_pass(self.render_pass.raw)
            .framebuffer(fb.raw)
            .render_area(area)
            .clear_values(clears);
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: fb.extent.width as f32,
            height: fb.extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: `cmd` is recording; the framebuffer, pipelines, buffers and set
        // are valid and stay alive until the frame's fence is waited on.
        unsafe {
            d.cmd_begin_render_pass(cmd, &begin, vk::SubpassContents::INLINE);
            d.cmd_set_viewport(cmd, 0, &[viewport]);
            d.cmd_set_scissor(cmd, 0, &[area]);
            if let Some((gpu, _)) = &self.model {
                d.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.layout.pipeline_layout,
                    0,
                    &[gpu.descriptors.set],
                    &[],
                );
                if gpu.n_indices > 0 {
                    let pipeline = match (&gpu.wire, frame.wireframe) {
                        (Some(w), true) => w.raw,
                        _ => gpu.fill.raw,
                    };
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
                    d.cmd_bind_vertex_buffers(cmd, 0, &[gpu.vertices.raw, gpu.skins.raw], &[0, 0]);
                    d.cmd_bind_index_buffer(cmd, gpu.indices.raw, 0, vk::IndexType::UINT32);
                    d.cmd_draw_indexed(cmd, gpu.n_indices, 1, 0, 0, 0);
                    drawn += u64::from(gpu.n_indices / 3);
                }
                if let Some(inst) = &gpu.instanced {
                    // The point stand-ins prepared for this view, if any.
                    let selection = match (&inst.selection, &self.point_pipeline) {
                        (Some(s), Some(p)) if Some(s.view) == stand_in_view => Some((s, p)),
                        _ => None,
                    };
                    let records = selection.map_or(inst.instances.raw, |(s, _)| s.kept.raw);
                    d.cmd_bind_vertex_buffers(cmd, 0, &[inst.vertices.raw, records], &[0, 0]);
                    d.cmd_bind_index_buffer(cmd, inst.indices.raw, 0, vk::IndexType::UINT32);
                    let mut bound = vk::Pipeline::null();
                    for (k, dr) in inst.draws.iter().enumerate() {
                        // Every instance of the draw at most LOD_PIXELS across (seen
                        // from the model's nearest point): the coarse mesh, unculled.
                        let lod = match (inst.lods.get(k).copied().flatten(), pixels_per_unit) {
                            (Some(l), Some(ppu)) if l.radius * ppu <= scene::LOD_PIXELS => Some(l),
                            _ => None,
                        };
                        let mut dr = match lod {
                            Some(l) => scene::InstancedDraw {
                                first_index: l.first_index,
                                index_count: l.index_count,
                                vertex_offset: l.vertex_offset,
                                closed: false,
                                ..*dr
                            },
                            None => *dr,
                        };
                        if let Some((s, _)) = selection {
                            let (first, count) = s.kept_draws.get(k).copied().unwrap_or((0, 0));
                            dr.first_instance = first;
                            dr.instance_count = count;
                        }
                        if dr.instance_count == 0 {
                            continue;
                        }
                        drawn += u64::from(dr.index_count / 3) * u64::from(dr.instance_count);
                        let pipeline = match (&inst.wire, frame.wireframe) {
                            (Some(w), true) => w.raw,
                            _ if dr.closed => inst.fill_closed.raw,
                            _ => inst.fill.raw,
                        };
                        if pipeline != bound {
                            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
                            bound = pipeline;
                        }
                        d.cmd_draw_indexed(
                            cmd,
                            dr.index_count,
                            dr.instance_count,
                            dr.first_index,
                            dr.vertex_offset,
                            dr.first_instance,
                        );
                    }
                    if let Some((s, p)) = selection {
                        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, p.raw);
                        d.cmd_bind_vertex_buffers(cmd, 0, &[s.points.raw], &[0]);
                        d.cmd_draw(cmd, s.n_points, 1, 0, 0);
                        drawn_points = (s.n_stood_in, u64::from(s.n_points));
                    }
                }
                if let Some(buf) = &gpu.line_vertices {
                    d.cmd_bind_vertex_buffers(cmd, 0, &[buf.raw, gpu.skins.raw], &[0, 0]);
                    // Pen lines first (depth-tested), then the overlays over everything.
                    let n_pen = gpu.n_line_vertices - gpu.n_overlay_vertices;
                    if let (Some(p), true) = (&gpu.lines, n_pen > 0) {
                        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, p.raw);
                        d.cmd_draw(cmd, n_pen, 1, 0, 0);
                    }
                    if let (Some(p), true) = (&gpu.overlay, self.show_overlays && gpu.n_overlay_vertices > 0) {
                        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, p.raw);
                        d.cmd_draw(cmd, gpu.n_overlay_vertices, 1, n_pen, 0);
                    }
                }
            }
            d.cmd_end_render_pass(cmd);
        }
        self.drawn.set(drawn);
        self.drawn_points.set(drawn_points);
    }
}
