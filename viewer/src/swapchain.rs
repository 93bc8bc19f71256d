//! The window surface and its swapchain: images, views and per-image framebuffers,
//! recreated on resize; everything destroyed in `Drop`.

use crate::context::{vkerr, Context};
use crate::image::create_view;
use crate::renderer::{Framebuffer, Renderer};
use crate::Error;
use ash::vk;
use std::sync::Arc;

/// A window surface (destroyed after its swapchain).
pub struct Surface {
    /// Keeps the instance alive until the surface is destroyed.
    _ctx: Arc<Context>,
    pub loader: ash::khr::surface::Instance,
    pub raw: vk::SurfaceKHR,
}

impl Surface {
    /// Creates a surface for a window.
    pub fn new(
        ctx: &Arc<Context>,
        display: raw_window_handle::RawDisplayHandle,
        window: raw_window_handle::RawWindowHandle,
    ) -> Result<Surface, Error> {
        // SAFETY: the handles come from a live winit window that outlives the
        // surface (the window state drops the surface first); the instance was
        // created with the extensions ash_window asked for.
        let raw = unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display, window, None) }
            .map_err(vkerr("create window surface"))?;
        let loader = ash::khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        // SAFETY: plain query on a valid surface and device.
        let supported =
            unsafe { loader.get_physical_device_surface_support(ctx.physical, ctx.queue_family, raw) }.unwrap_or(false);
        if !supported {
            // SAFETY: `raw` was created just above from this instance and no swapchain
            // was made for it, so nothing uses the surface.
            unsafe { loader.destroy_surface(raw, None) };
            return Err(Error::Vulkan("the device's graphics queue cannot present to this window".into()));
        }
        Ok(Surface { _ctx: ctx.clone(), loader, raw })
    }
}

impl Drop for Surface {
    fn drop(&mut self) {
        // SAFETY: the swapchain made from it was dropped first (field order).
        unsafe { self.loader.destroy_surface(self.raw, None) };
    }
}

/// A swapchain with a view and framebuffer per image.
pub struct Swapchain {
    ctx: Arc<Context>,
    loader: ash::khr::swapchain::Device,
    pub raw: vk::SwapchainKHR,
    pub images: Vec<vk::Image>,
    views: Vec<vk::ImageView>,
    pub framebuffers: Vec<Framebuffer>,
    pub extent: vk::Extent2D,
    pub format: vk::Format,
    /// The images can be copied from (screenshots).
    pub can_read_back: bool,
}

/// The colour format a window uses: 8-bit UNORM BGRA/RGBA (linear, like the
/// offscreen target, so a screenshot matches a PNG), else whatever comes first.
pub fn choose_format(ctx: &Context, surface: &Surface) -> Result<vk::SurfaceFormatKHR, Error> {
    // SAFETY: `surface.raw` is a live surface of this instance (the `Surface` owns it)
    // and `ctx.physical` a device of the same instance; the query only reads.
    let formats = unsafe { surface.loader.get_physical_device_surface_formats(ctx.physical, surface.raw) }
        .map_err(vkerr("surface formats"))?;
    formats
        .iter()
        .find(|f| matches!(f.format, vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM))
        .or(formats.first())
        .copied()
        .ok_or_else(|| Error::Vulkan("the surface offers no formats".into()))
}

impl Swapchain {
    /// Creates a swapchain of about `size` (the surface's current extent wins when
    /// it has one), replacing `old` if given.
    pub fn new(
        ctx: &Arc<Context>,
        surface: &Surface,
        format: vk::SurfaceFormatKHR,
        size: (u32, u32),
        renderer: &mut Renderer,
        old: Option<&Swapchain>,
    ) -> Result<Swapchain, Error> {
        // SAFETY: plain queries on a valid surface.
        let caps = unsafe { surface.loader.get_physical_device_surface_capabilities(ctx.physical, surface.raw) }
            .map_err(vkerr("surface capabilities"))?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size.0.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size.1.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut n_images = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            n_images = n_images.min(caps.max_image_count);
        }
        let can_read_back = caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_SRC);
        let mut usage = vk::ImageUsageFlags::COLOR_ATTACHMENT;
        if can_read_back {
            usage |= vk::ImageUsageFlags::TRANSFER_SRC;
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let loader = ash::khr::swapchain::Device::new(&ctx.instance, &ctx.device);
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(surface.raw)
            .min_image_count(n_images)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(usage)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            // FIFO is always available and paces frames to the display.
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(old.map(|o| o.raw).unwrap_or_default());
        // SAFETY: the surface is valid and supported; the old swapchain (if any) is
        // not used after this (it is dropped by the caller once idle).
        let raw = unsafe { loader.create_swapchain(&info, None) }.map_err(vkerr("create swapchain"))?;
        let mut sc = Swapchain {
            ctx: ctx.clone(),
            loader,
            raw,
            images: Vec::new(),
            views: Vec::new(),
            framebuffers: Vec::new(),
            extent,
            format: format.format,
            can_read_back,
        };
        // SAFETY: the swapchain was just created.
        sc.images = unsafe { sc.loader.get_swapchain_images(raw) }.map_err(vkerr("swapchain images"))?;
        for &img in &sc.images {
            sc.views.push(create_view(ctx, img, format.format, vk::ImageAspectFlags::COLOR)?);
        }
        renderer.resize(extent)?;
        for &v in &sc.views {
            sc.framebuffers.push(renderer.framebuffer(v)?);
        }
        Ok(sc)
    }

    /// Acquires the next image, signalling `semaphore`. `Ok(None)` when the
    /// swapchain is out of date (recreate it).
    pub fn acquire(&self, semaphore: vk::Semaphore) -> Result<Option<(u32, bool)>, Error> {
        // SAFETY: valid swapchain and an unsignalled semaphore with no pending wait.
        match unsafe { self.loader.acquire_next_image(self.raw, u64::MAX, semaphore, vk::Fence::null()) } {
            Ok((i, suboptimal)) => Ok(Some((i, suboptimal))),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(None),
            Err(e) => Err(Error::Vulkan(format!("acquire next image: {e}"))),
        }
    }

    /// Presents image `index` after `wait`. `Ok(false)` when out of date or suboptimal.
    pub fn present(&self, index: u32, wait: vk::Semaphore) -> Result<bool, Error> {
        let waits = [wait];
        let swapchains = [self.raw];
        let indices = [index];
        let info =
            vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&swapchains).image_indices(&indices);
        // SAFETY: the image was acquired and rendered; `wait` is signalled by that submit.
        match unsafe { self.loader.queue_present(self.ctx.queue, &info) } {
            Ok(suboptimal) => Ok(!suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(false),
            Err(e) => Err(Error::Vulkan(format!("present: {e}"))),
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        self.framebuffers.clear();
        // SAFETY: the window waits for the device to be idle before dropping a
        // swapchain; views first, then the swapchain that owns the images.
        unsafe {
            for v in self.views.drain(..) {
                self.ctx.device.destroy_image_view(v, None);
            }
            self.loader.destroy_swapchain(self.raw, None);
        }
    }
}
