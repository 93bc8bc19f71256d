//! Images with their memory and a view: the multisampled colour and depth
//! attachments and the offscreen resolve target. Each [`Image`] frees in `Drop`.

use crate::context::{vkerr, Context};
use crate::Error;
use ash::vk;
use std::sync::Arc;

/// What an image is for.
#[derive(Clone, Copy, Debug)]
pub struct ImageDesc {
    pub width: u32,
    pub height: u32,
    pub format: vk::Format,
    pub samples: vk::SampleCountFlags,
    pub usage: vk::ImageUsageFlags,
    pub aspect: vk::ImageAspectFlags,
}

/// A 2D image, its device memory and a view of it.
pub struct Image {
    ctx: Arc<Context>,
    pub raw: vk::Image,
    memory: vk::DeviceMemory,
    pub view: vk::ImageView,
    pub desc: ImageDesc,
}

impl Image {
    /// Creates the image in device-local memory (lazily allocated when the device
    /// offers it and the image is a transient attachment).
    pub fn new(ctx: &Arc<Context>, desc: ImageDesc) -> Result<Image, Error> {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D { width: desc.width.max(1), height: desc.height.max(1), depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(desc.samples)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_image(&info, None) }.map_err(vkerr("create image"))?;
        // SAFETY: `raw` was just created from this device.
        let req = unsafe { ctx.device.get_image_memory_requirements(raw) };
        let Some(type_index) = ctx.memory_type(req.memory_type_bits, vk::MemoryPropertyFlags::DEVICE_LOCAL) else {
            // SAFETY: `raw` was created just above from this device, has no memory bound
            // and was never given to the GPU, so nothing uses it.
            unsafe { ctx.device.destroy_image(raw, None) };
            return Err(Error::Vulkan("no device-local memory type for an image".into()));
        };
        let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(type_index);
        // SAFETY: `alloc` names a memory type index this device reported (from
        // `ctx.memory_type`) and the size the image requires.
        let memory = match unsafe { ctx.device.allocate_memory(&alloc, None) } {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: `raw` was created just above from this device, has no memory
                // bound and was never given to the GPU, so nothing uses it.
                unsafe { ctx.device.destroy_image(raw, None) };
                return Err(Error::Vulkan(format!("allocate image memory: {e}")));
            }
        };
        // SAFETY: fresh memory of a compatible type bound once at offset 0.
        if let Err(e) = unsafe { ctx.device.bind_image_memory(raw, memory, 0) } {
            // SAFETY: the image and the memory were created just above from this device;
            // binding failed, so no view or command refers to either.
            unsafe {
                ctx.device.destroy_image(raw, None);
                ctx.device.free_memory(memory, None);
            }
            return Err(Error::Vulkan(format!("bind image memory: {e}")));
        }
        let view = match create_view(ctx, raw, desc.format, desc.aspect) {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: the image and its memory were created just above from this
                // device; creating the view failed, so no command refers to either.
                unsafe {
                    ctx.device.destroy_image(raw, None);
                    ctx.device.free_memory(memory, None);
                }
                return Err(e);
            }
        };
        Ok(Image { ctx: ctx.clone(), raw, memory, view, desc })
    }
}

/// A 2D view of a whole single-level image.
pub fn create_view(
    ctx: &Context,
    image: vk::Image,
    format: vk::Format,
    aspect: vk::ImageAspectFlags,
) -> Result<vk::ImageView, Error> {
    let info = vk::ImageViewCreateInfo::default()
        .image(image)
        .view_type(vk::ImageViewType::TYPE_2D)
        .format(format)
        .subresource_range(vk::ImageSubresourceRange {
            aspect_mask: aspect,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        });
    // SAFETY: `image` is a valid image of this device with a compatible format.
    unsafe { ctx.device.create_image_view(&info, None) }.map_err(vkerr("create image view"))
}

impl Drop for Image {
    fn drop(&mut self) {
        // SAFETY: owners drop images after the GPU work using them finished.
        unsafe {
            self.ctx.device.destroy_image_view(self.view, None);
            self.ctx.device.destroy_image(self.raw, None);
            self.ctx.device.free_memory(self.memory, None);
        }
    }
}

/// The largest sample count ≤ `want` (at least 2) that colour and depth
/// attachments both support, else the smallest supported count above 1 (every
/// device supports 4; lavapipe supports only 1 and 4).
pub fn msaa_samples(ctx: &Context, want: u32) -> vk::SampleCountFlags {
    let supported = ctx.limits.framebuffer_color_sample_counts & ctx.limits.framebuffer_depth_sample_counts;
    let counts =
        [(2, vk::SampleCountFlags::TYPE_2), (4, vk::SampleCountFlags::TYPE_4), (8, vk::SampleCountFlags::TYPE_8)];
    let usable = counts.iter().filter(|(_, f)| supported.contains(*f));
    let want = want.max(2);
    usable
        .clone()
        .rfind(|(n, _)| *n <= want)
        .or_else(|| usable.clone().next())
        .map(|(_, f)| *f)
        .unwrap_or(vk::SampleCountFlags::TYPE_4)
}

/// The depth format: D32 float when supported as an attachment, else D24S8 / D16.
pub fn depth_format(ctx: &Context) -> vk::Format {
    for f in [vk::Format::D32_SFLOAT, vk::Format::D24_UNORM_S8_UINT, vk::Format::D16_UNORM] {
        // SAFETY: `ctx.physical` was enumerated from `ctx.instance`, which is alive; the
        // query only reads the device's properties.
        let props = unsafe { ctx.instance.get_physical_device_format_properties(ctx.physical, f) };
        if props.optimal_tiling_features.contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT) {
            return f;
        }
    }
    vk::Format::D16_UNORM
}
