//! Images with their memory and a view: the (multisampled) colour and depth
//! attachments and the offscreen target, and the choice of sample count. Each [`Image`] frees in `Drop`.

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

/// The sample count a picture is drawn with, and whether it is the one asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleChoice {
    pub flags: vk::SampleCountFlags,
    /// The count asked for (after [`default_samples`] for 0).
    pub wanted: u32,
    /// The counts the device offers for colour and depth together (1 always).
    pub supported: vk::SampleCountFlags,
}

impl SampleChoice {
    /// The count in use.
    pub fn count(&self) -> u32 {
        self.flags.as_raw()
    }

    /// The device could not give the count asked for (the caller says so: e.g.
    /// lavapipe offers 1 or 4, so 2 gives 4).
    pub fn differs(&self) -> bool {
        self.count() != self.wanted
    }

    /// The offered counts as text, e.g. `1 or 4`.
    pub fn offered(&self) -> String {
        let n: Vec<String> = [1u32, 2, 4, 8, 16, 32, 64]
            .iter()
            .filter(|&&n| n == 1 || self.supported.contains(vk::SampleCountFlags::from_raw(n)))
            .map(|n| n.to_string())
            .collect();
        match n.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
            _ => n.join(""),
        }
    }
}

/// The samples a picture needs when none is asked for: 1 on a CPU driver
/// (lavapipe rasterises every sample in software, so 4× costs about 4× the
/// fragment work; the offscreen path smooths edges afterwards instead), 4 on a GPU
/// (multisampling is nearly free there). docs/decisions.md, "Picture samples".
pub fn default_samples(ctx: &Context) -> u32 {
    if ctx.device_type == vk::PhysicalDeviceType::CPU {
        1
    } else {
        4
    }
}

/// The sample count for `want` (0: [`default_samples`]): `want` itself when colour
/// and depth attachments both support it, else the smallest supported count above
/// it (more smoothing rather than less), else the largest below it (1 is always
/// supported; lavapipe supports 1 and 4, so 2 gives 4 and 8 gives 4).
pub fn msaa_samples(ctx: &Context, want: u32) -> SampleChoice {
    let supported = ctx.limits.framebuffer_color_sample_counts & ctx.limits.framebuffer_depth_sample_counts;
    let want = if want == 0 { default_samples(ctx) } else { want };
    SampleChoice {
        flags: choose_samples(supported, want),
        wanted: want,
        supported: supported | vk::SampleCountFlags::TYPE_1,
    }
}

/// [`msaa_samples`]'s choice among the `supported` counts.
fn choose_samples(supported: vk::SampleCountFlags, want: u32) -> vk::SampleCountFlags {
    let counts = [
        (1, vk::SampleCountFlags::TYPE_1),
        (2, vk::SampleCountFlags::TYPE_2),
        (4, vk::SampleCountFlags::TYPE_4),
        (8, vk::SampleCountFlags::TYPE_8),
    ];
    // 1 is always supported (the Vulkan specification requires it).
    let usable = counts.iter().filter(|(n, f)| *n == 1 || supported.contains(*f));
    usable
        .clone()
        .find(|(n, _)| *n >= want)
        .or_else(|| usable.clone().next_back())
        .map(|(_, f)| *f)
        .unwrap_or(vk::SampleCountFlags::TYPE_1)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_counts_are_the_ones_asked_for_where_supported() {
        let lavapipe = vk::SampleCountFlags::TYPE_1 | vk::SampleCountFlags::TYPE_4;
        assert_eq!(choose_samples(lavapipe, 1), vk::SampleCountFlags::TYPE_1);
        assert_eq!(choose_samples(lavapipe, 4), vk::SampleCountFlags::TYPE_4);
        // 2 is not offered: the next above it.
        assert_eq!(choose_samples(lavapipe, 2), vk::SampleCountFlags::TYPE_4);
        assert_eq!(choose_samples(lavapipe, 3), vk::SampleCountFlags::TYPE_4);
        assert_eq!(choose_samples(lavapipe, 8), vk::SampleCountFlags::TYPE_4);
        let gpu = lavapipe | vk::SampleCountFlags::TYPE_2 | vk::SampleCountFlags::TYPE_8;
        assert_eq!(choose_samples(gpu, 2), vk::SampleCountFlags::TYPE_2);
        assert_eq!(choose_samples(gpu, 16), vk::SampleCountFlags::TYPE_8);
        assert_eq!(choose_samples(vk::SampleCountFlags::empty(), 4), vk::SampleCountFlags::TYPE_1);
        let choice = SampleChoice { flags: vk::SampleCountFlags::TYPE_4, wanted: 2, supported: lavapipe };
        assert!(choice.differs());
        assert_eq!(choice.offered(), "1 or 4");
        assert_eq!(SampleChoice { supported: gpu, ..choice }.offered(), "1, 2, 4 or 8");
    }
}
