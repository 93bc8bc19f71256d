//! Shader modules, the descriptor-set and pipeline layouts of reference §13, and
//! graphics pipelines (filled, wireframe, lines, overlay lines). Each frees itself
//! in `Drop`.
//!
//! Set 0: binding 0 `Globals` (uniform buffer), binding 1 `Bones` (storage buffer),
//! binding 2 `User` (uniform buffer), all visible to both stages. Vertex inputs are
//! the five locations of [`crate::scene`]'s layout. Faces are not culled: lighting
//! is two-sided (the shaders flip the normal of back faces), and counter-clockwise
//! faces are front-facing (the scene's winding is corrected for mirrored frames).

use crate::context::{vkerr, Context};
use crate::scene::{INSTANCE_STRIDE, PROTO_STRIDE, SKIN_STRIDE, VERTEX_STRIDE};
use crate::Error;
use ash::vk;
use std::sync::Arc;

/// The descriptor-set layout and pipeline layout shared by every pipeline.
pub struct Layout {
    ctx: Arc<Context>,
    pub set_layout: vk::DescriptorSetLayout,
    pub pipeline_layout: vk::PipelineLayout,
}

impl Layout {
    pub fn new(ctx: &Arc<Context>) -> Result<Layout, Error> {
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let bindings = [
            vk::DescriptorSetLayoutBinding::default()
                .binding(0)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                .descriptor_count(1)
                .stage_flags(stages),
            vk::DescriptorSetLayoutBinding::default()
                .binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(stages),
            vk::DescriptorSetLayoutBinding::default()
                .binding(2)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                .descriptor_count(1)
                .stage_flags(stages),
        ];
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid device and create info.
        let set_layout =
            unsafe { ctx.device.create_descriptor_set_layout(&info, None) }.map_err(vkerr("create set layout"))?;
        let set_layouts = [set_layout];
        let info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid device; the set layout was just created.
        let pipeline_layout = match unsafe { ctx.device.create_pipeline_layout(&info, None) } {
            Ok(l) => l,
            Err(e) => {
                // SAFETY: `set_layout` was created just above from this device and no
                // pipeline layout or descriptor set refers to it (creating one failed).
                unsafe { ctx.device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(Error::Vulkan(format!("create pipeline layout: {e}")));
            }
        };
        Ok(Layout { ctx: ctx.clone(), set_layout, pipeline_layout })
    }
}

impl Drop for Layout {
    fn drop(&mut self) {
        // SAFETY: pipelines and descriptor sets using these are dropped first (field
        // order in the renderer) and the GPU is idle when the renderer drops.
        unsafe {
            self.ctx.device.destroy_pipeline_layout(self.pipeline_layout, None);
            self.ctx.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// A shader module.
struct ShaderModule {
    ctx: Arc<Context>,
    raw: vk::ShaderModule,
}

impl ShaderModule {
    fn new(ctx: &Arc<Context>, spirv: &[u32]) -> Result<ShaderModule, Error> {
        if spirv.first() != Some(&mdg_vm::bundle::SPIRV_MAGIC) {
            return Err(Error::Vulkan("shader code is not SPIR-V".into()));
        }
        let info = vk::ShaderModuleCreateInfo::default().code(spirv);
        // SAFETY: `spirv` is a SPIR-V module from glslang (checked header); the
        // driver copies the code.
        let raw = unsafe { ctx.device.create_shader_module(&info, None) }.map_err(vkerr("create shader module"))?;
        Ok(ShaderModule { ctx: ctx.clone(), raw })
    }
}

impl Drop for ShaderModule {
    fn drop(&mut self) {
        // SAFETY: modules may be destroyed once the pipelines using them are created.
        unsafe { self.ctx.device.destroy_shader_module(self.raw, None) };
    }
}

/// How a pipeline draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Fill,
    Wireframe,
    Lines,
    /// Lines drawn over everything (no depth test): guides, bones, editor handles.
    Overlay,
    /// Point sprites standing in for small instances ([`crate::points`]): one
    /// binding of [`crate::points::POINT_STRIDE`] bytes per point.
    Points,
}

/// What a pipeline is made for.
#[derive(Clone, Copy, Debug)]
pub struct PipelineDesc {
    pub kind: Kind,
    pub render_pass: vk::RenderPass,
    pub samples: vk::SampleCountFlags,
    /// Binding 1 holds one (weight, bone) per vertex; else one shared zero element.
    pub skinned: bool,
    /// The instanced layout ([`crate::scene::PROTO_STRIDE`] per vertex in binding 0,
    /// [`crate::scene::INSTANCE_STRIDE`] per instance in binding 1) for std's
    /// `phong_instanced_vs`.
    pub instanced: bool,
    /// Cull back faces (closed meshes only: see [`crate::scene::InstancedDraw::closed`]).
    pub cull_back: bool,
    /// Depth test and write (off for a `flat` model: painted in triangle order).
    pub depth: bool,
}

/// A graphics pipeline.
pub struct Pipeline {
    ctx: Arc<Context>,
    pub raw: vk::Pipeline,
}

impl Pipeline {
    /// Builds a pipeline from vertex and fragment SPIR-V. Viewport and scissor are
    /// dynamic, so a resize does not rebuild it.
    pub fn new(
        ctx: &Arc<Context>,
        layout: &Layout,
        vertex: &[u32],
        fragment: &[u32],
        desc: PipelineDesc,
    ) -> Result<Pipeline, Error> {
        let vs = ShaderModule::new(ctx, vertex)?;
        let fs = ShaderModule::new(ctx, fragment)?;
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vs.raw)
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fs.raw)
                .name(c"main"),
        ];
        let bindings = [
            vk::VertexInputBindingDescription::default()
                .binding(0)
                .stride(VERTEX_STRIDE)
                .input_rate(vk::VertexInputRate::VERTEX),
            vk::VertexInputBindingDescription::default()
                .binding(1)
                .stride(if desc.skinned { SKIN_STRIDE } else { 0 })
                .input_rate(vk::VertexInputRate::VERTEX),
        ];
        let attrs = [
            vk::VertexInputAttributeDescription::default()
                .location(0)
                .binding(0)
                .format(vk::Format::R32G32B32_SFLOAT)
                .offset(0),
            vk::VertexInputAttributeDescription::default()
                .location(1)
                .binding(0)
                .format(vk::Format::R16G16B16A16_SNORM)
                .offset(12),
            vk::VertexInputAttributeDescription::default()
                .location(2)
                .binding(0)
                .format(vk::Format::R8G8B8A8_UNORM)
                .offset(20),
            vk::VertexInputAttributeDescription::default()
                .location(3)
                .binding(1)
                .format(vk::Format::R32G32B32A32_SFLOAT)
                .offset(0),
            vk::VertexInputAttributeDescription::default()
                .location(4)
                .binding(1)
                .format(vk::Format::R32_UINT)
                .offset(16),
        ];
        let attribute = |location: u32, binding: u32, format: vk::Format, offset: u32| {
            vk::VertexInputAttributeDescription::default()
                .location(location)
                .binding(binding)
                .format(format)
                .offset(offset)
        };
        let vec4 = vk::Format::R32G32B32A32_SFLOAT;
        let instanced_bindings = [
            vk::VertexInputBindingDescription::default()
                .binding(0)
                .stride(PROTO_STRIDE)
                .input_rate(vk::VertexInputRate::VERTEX),
            vk::VertexInputBindingDescription::default()
                .binding(1)
                .stride(INSTANCE_STRIDE)
                .input_rate(vk::VertexInputRate::INSTANCE),
        ];
        let instanced_attrs = [
            attribute(0, 0, vk::Format::R32G32B32_SFLOAT, 0),
            attribute(1, 0, vk::Format::R16G16B16A16_SNORM, 12),
            attribute(2, 0, vec4, 20),
            attribute(4, 1, vk::Format::R32_UINT, 64),
            attribute(5, 1, vec4, 0),
            attribute(6, 1, vec4, 16),
            attribute(7, 1, vec4, 32),
            attribute(8, 1, vec4, 48),
        ];
        let point_bindings = [vk::VertexInputBindingDescription::default()
            .binding(0)
            .stride(crate::points::POINT_STRIDE)
            .input_rate(vk::VertexInputRate::VERTEX)];
        let point_attrs = [
            attribute(0, 0, vk::Format::R32G32B32_SFLOAT, 0),
            attribute(1, 0, vk::Format::R32_SFLOAT, 12),
            attribute(2, 0, vk::Format::R8G8B8A8_UNORM, 16),
        ];
        let vertex_input = if desc.kind == Kind::Points {
            vk::PipelineVertexInputStateCreateInfo::default()
                .vertex_binding_descriptions(&point_bindings)
                .vertex_attribute_descriptions(&point_attrs)
        } else if desc.instanced {
            vk::PipelineVertexInputStateCreateInfo::default()
                .vertex_binding_descriptions(&instanced_bindings)
                .vertex_attribute_descriptions(&instanced_attrs)
        } else {
            vk::PipelineVertexInputStateCreateInfo::default()
                .vertex_binding_descriptions(&bindings)
                .vertex_attribute_descriptions(&attrs)
        };
        let topology = if matches!(desc.kind, Kind::Lines | Kind::Overlay) {
            vk::PrimitiveTopology::LINE_LIST
        } else if desc.kind == Kind::Points {
            vk::PrimitiveTopology::POINT_LIST
        } else {
            vk::PrimitiveTopology::TRIANGLE_LIST
        };
        let input_assembly = vk::PipelineInputAssemblyStateCreateInfo::default().topology(topology);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        let polygon_mode = if desc.kind == Kind::Wireframe { vk::PolygonMode::LINE } else { vk::PolygonMode::FILL };
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(polygon_mode)
            .cull_mode(if desc.cull_back { vk::CullModeFlags::BACK } else { vk::CullModeFlags::NONE })
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(desc.samples);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.kind != Kind::Overlay && desc.depth)
            .depth_write_enable(desc.kind != Kind::Overlay && desc.depth)
            .depth_compare_op(vk::CompareOp::LESS_OR_EQUAL);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(true)
            .src_color_blend_factor(vk::BlendFactor::SRC_ALPHA)
            .dst_color_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
            .color_blend_op(vk::BlendOp::ADD)
            .src_alpha_blend_factor(vk::BlendFactor::ONE)
            .dst_alpha_blend_factor(vk::BlendFactor::ONE_MINUS_SRC_ALPHA)
            .alpha_blend_op(vk::BlendOp::ADD)
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout.pipeline_layout)
            .render_pass(desc.render_pass)
            .subpass(0);
        // SAFETY: every pointer in `info` refers to locals alive until the call
        // returns; the modules, layout and render pass are valid.
        let raw = unsafe { ctx.device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
            .map_err(|(_, e)| Error::Vulkan(format!("create graphics pipeline: {e}")))?;
        let raw = raw.into_iter().next().ok_or_else(|| Error::Vulkan("no pipeline returned".into()))?;
        Ok(Pipeline { ctx: ctx.clone(), raw })
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        // SAFETY: the renderer waits for its last frame before replacing pipelines.
        unsafe { self.ctx.device.destroy_pipeline(self.raw, None) };
    }
}
