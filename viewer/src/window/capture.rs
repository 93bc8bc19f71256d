//! Screenshots: one more frame drawn and read back from the swapchain, written as
//! a PNG (`--screenshot`, a script's `screenshot`, the last frame of `--frames`).

use super::App;
use crate::context::Context;
use crate::Error;
use ash::vk;
use std::path::Path;

/// Copies the presented image to `buffer`, leaving it ready to present.
pub(super) fn record_readback(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    extent: vk::Extent2D,
    buffer: vk::Buffer,
) {
    let range = vk::ImageSubresourceRange {
        aspect_mask: vk::ImageAspectFlags::COLOR,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    };
    let to_src = vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ)
        .old_layout(vk::ImageLayout::PRESENT_SRC_KHR)
        .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range);
    let back = vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_READ)
        .dst_access_mask(vk::AccessFlags::empty())
        .old_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
        .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range);
    let region = [vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D { width: extent.width, height: extent.height, depth: 1 })];
    let host = vk::BufferMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .buffer(buffer)
        .offset(0)
        .size(vk::WHOLE_SIZE);
    // SAFETY: `cmd` is recording after the render pass that left `image` in
    // PRESENT_SRC_KHR; the buffer holds width × height × 4 bytes.
    unsafe {
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[to_src],
        );
        ctx.device.cmd_copy_image_to_buffer(cmd, image, vk::ImageLayout::TRANSFER_SRC_OPTIMAL, buffer, &region);
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::BOTTOM_OF_PIPE | vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &[],
            &[host],
            &[back],
        );
    }
}

impl App {
    /// Draws one more frame, reads it back and writes the screenshot (if asked for).
    pub(super) fn write_screenshot(&mut self) -> Result<(), Error> {
        let Some(path) = self.opts.screenshot.clone() else { return Ok(()) };
        self.write_screenshot_to(&path)
    }

    /// Draws one more frame, reads it back and writes it to `path`.
    pub(super) fn write_screenshot_to(&mut self, path: &Path) -> Result<(), Error> {
        if !self.gpu.as_ref().is_some_and(|g| g.swapchain.can_read_back) {
            (self.opts.log)("mdg-view: this swapchain cannot be read back; no screenshot");
            return Ok(());
        }
        // An out-of-date swapchain draws nothing; a second try uses the new one.
        for _ in 0..2 {
            if let Some(px) = self.draw(true)? {
                let Some(g) = &self.gpu else { return Ok(()) };
                let e = g.swapchain.extent;
                return crate::offscreen::write_png(path, &px, e.width, e.height);
            }
        }
        (self.opts.log)("mdg-view: no frame to write as the screenshot");
        Ok(())
    }
}
