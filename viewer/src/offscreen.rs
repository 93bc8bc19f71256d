//! Offscreen rendering: a model to RGBA pixels and PNG files without a window, one
//! view or a turntable of N views with a contact sheet.

use crate::buffer::Buffer;
use crate::camera::OrbitCamera;
use crate::context::Context;
use crate::image::{Image, ImageDesc};
use crate::model::Model;
use crate::program::Programs;
use crate::renderer::{FrameParams, Framebuffer, ModelInfo, Renderer, RendererOptions};
use crate::Error;
use ash::vk;
use mdg_vm::bundle::Bundle;
use mdg_vm::output::Output;
use std::path::Path;
use std::sync::Arc;

/// The offscreen target format: 8-bit linear RGBA, so the PNG holds exactly what
/// the fragment shader wrote.
pub const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// An offscreen renderer of a fixed size.
pub struct Offscreen {
    // Drop order: framebuffer, then the images and renderer it refers to.
    fb: Framebuffer,
    readback: Buffer,
    target: Image,
    renderer: Renderer,
    ctx: Arc<Context>,
    pub width: u32,
    pub height: u32,
    /// Smooth the edges of each read-back picture ([`crate::smooth`]): on by
    /// default when the samples were left to the device (0) and it draws with one.
    pub smooth: bool,
}

impl Offscreen {
    /// A `width` × `height` target drawn with `samples` samples: 0 chooses by the
    /// device ([`crate::image::default_samples`]: one sample plus edge smoothing on a
    /// CPU driver, 4× on a GPU); any other count is used as the device allows
    /// ([`crate::image::msaa_samples`], with no smoothing: [`Offscreen::smooth`]).
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32, samples: u32) -> Result<Offscreen, Error> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(Error::Other(format!("image size {width}x{height} is out of range (1..16384)")));
        }
        let mut renderer = Renderer::new(
            ctx,
            RendererOptions { color_format: FORMAT, final_layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL, samples },
        )?;
        // Offscreen pictures are rarely wireframe: its pipelines wait for one.
        renderer.wireframe_on_demand = true;
        let extent = vk::Extent2D { width, height };
        renderer.resize(extent)?;
        let target = Image::new(
            ctx,
            ImageDesc {
                width,
                height,
                format: FORMAT,
                samples: vk::SampleCountFlags::TYPE_1,
                usage: vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                aspect: vk::ImageAspectFlags::COLOR,
            },
        )?;
        let fb = renderer.framebuffer(target.view)?;
        let readback = Buffer::host(ctx, width as u64 * height as u64 * 4, vk::BufferUsageFlags::TRANSFER_DST)?;
        let smooth = samples == 0 && renderer.samples == vk::SampleCountFlags::TYPE_1;
        Ok(Offscreen { fb, readback, target, renderer, ctx: ctx.clone(), width, height, smooth })
    }

    /// Loads a model (see [`Renderer::set_model`]).
    pub fn set_model(&mut self, model: &Model, programs: &Programs) -> Result<ModelInfo, Error> {
        self.ctx.wait_idle();
        self.renderer.set_model(model, programs).cloned()
    }

    /// Loads a bundle's output without copying it (see [`Renderer::set_output`]).
    pub fn set_output(&mut self, bundle: &Bundle, output: &Output, programs: &Programs) -> Result<ModelInfo, Error> {
        self.ctx.wait_idle();
        self.renderer.set_output(bundle, output, programs).cloned()
    }

    /// The sample count in use.
    pub fn samples(&self) -> u32 {
        self.renderer.samples.as_raw()
    }

    /// The samples asked for and given (a caller warns when they differ).
    pub fn sample_choice(&self) -> crate::image::SampleChoice {
        self.renderer.sample_choice
    }

    /// The renderer (to load a prepared scene, say).
    pub fn renderer_mut(&mut self) -> &mut Renderer {
        &mut self.renderer
    }

    /// The home camera for the current model: the grammar's field of view, framing
    /// its bounding sphere.
    pub fn home_camera(&self) -> OrbitCamera {
        let aspect = self.width as f32 / self.height as f32;
        match self.renderer.info() {
            Some(i) => OrbitCamera::framing_art(&i.bounds, i.fov_deg, aspect, i.flat),
            None => OrbitCamera::framing(&crate::scene::Bounds::EMPTY, 40.0, aspect),
        }
    }

    /// Renders one frame and returns its pixels: RGBA8, rows top to bottom, edges
    /// smoothed when [`Offscreen::smooth`] is set.
    pub fn render(&mut self, frame: &FrameParams) -> Result<Vec<u8>, Error> {
        self.renderer.prepare(frame)?;
        self.renderer.update(frame)?;
        let (w, h) = (self.width, self.height);
        let region = [vk::BufferImageCopy::default()
            .buffer_offset(0)
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D { width: w, height: h, depth: 1 })];
        let ctx = self.ctx.clone();
        ctx.one_time(|cmd| {
            self.renderer.record(cmd, &self.fb, frame);
            // The render pass left the target in TRANSFER_SRC_OPTIMAL and its
            // outgoing dependency made the resolve visible to transfers.
            // SAFETY: `cmd` is recording; target and buffer are valid and sized.
            unsafe {
                ctx.device.cmd_copy_image_to_buffer(
                    cmd,
                    self.target.raw,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    self.readback.raw,
                    &region,
                );
                let barrier = [vk::BufferMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .buffer(self.readback.raw)
                    .offset(0)
                    .size(vk::WHOLE_SIZE)];
                ctx.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[],
                    &barrier,
                    &[],
                );
            }
        })?;
        let mut px = self.readback.read(w as usize * h as usize * 4)?;
        if self.smooth {
            crate::smooth::smooth_edges(&mut px, w, h);
        }
        Ok(px)
    }
}

/// How much freed memory at the top of a heap the allocator keeps instead of
/// returning it to the kernel: see [`keep_freed_memory`].
pub const TRIM_THRESHOLD: i32 = 1 << 30;

/// Tells glibc's allocator to keep up to [`TRIM_THRESHOLD`] of freed heap memory
/// instead of handing it back to the kernel at every `free`. The software renderer
/// (lavapipe) allocates and frees its vertex and bin memory for every draw on its
/// own threads' heaps; by default glibc returns the freed top of such a heap with
/// `madvise`, and the next draw page-faults it in again. Measured on the 2^20 tree's
/// 600² picture: system time 0.32 s without it, 0.20 s with it, peak RSS unchanged
/// (the memory is kept, not grown: peak RSS is the high-water mark either way).
/// A process-wide setting, so the commands decide: the offscreen picture commands
/// call it (one-shot processes); the window, which lives on, does not. A no-op off
/// glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes the allocator's tuning parameters; called before
    // the renderer starts its threads, and safe to call at any time in glibc.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD);
    }
}

/// `n` cameras around the home camera's target, evenly spaced in azimuth.
pub fn turntable(home: &OrbitCamera, n: u32) -> Vec<OrbitCamera> {
    (0..n.max(1))
        .map(|i| {
            let mut c = *home;
            c.azimuth = home.azimuth + std::f32::consts::TAU * i as f32 / n.max(1) as f32;
            c
        })
        .collect()
}

/// Tiles equally sized RGBA images into a grid (as square as possible), with a
/// 2-pixel gap of `gap` colour. Returns the pixels, width and height.
pub fn contact_sheet(images: &[Vec<u8>], width: u32, height: u32, gap: [u8; 4]) -> (Vec<u8>, u32, u32) {
    let n = images.len().max(1) as u32;
    let cols = (n as f32).sqrt().ceil() as u32;
    let rows = n.div_ceil(cols);
    let g = 2;
    let (sw, sh) = (cols * width + (cols + 1) * g, rows * height + (rows + 1) * g);
    let mut out: Vec<u8> = gap.iter().copied().cycle().take((sw * sh * 4) as usize).collect();
    for (k, img) in images.iter().enumerate() {
        let (c, r) = (k as u32 % cols, k as u32 / cols);
        let (x0, y0) = (g + c * (width + g), g + r * (height + g));
        for y in 0..height {
            let src = (y * width * 4) as usize;
            let dst = (((y0 + y) * sw + x0) * 4) as usize;
            if let (Some(s), Some(d)) =
                (img.get(src..src + (width * 4) as usize), out.get_mut(dst..dst + (width * 4) as usize))
            {
                d.copy_from_slice(s);
            }
        }
    }
    (out, sw, sh)
}

/// The widest contact sheet [`sheet_factor`] allows, in pixels.
pub const MAX_SHEET_WIDTH: u32 = 4096;

/// The integer factor views are shrunk by so a contact sheet of `n` views `width`
/// pixels wide stays within [`MAX_SHEET_WIDTH`] (1: full size).
pub fn sheet_factor(n: u32, width: u32) -> u32 {
    let cols = (n.max(1) as f32).sqrt().ceil() as u32;
    (cols * width).div_ceil(MAX_SHEET_WIDTH).max(1)
}

/// RGBA pixels `width`×`height` shrunk by the integer factor `k` (box filter): the
/// new pixels and size.
pub fn shrink(rgba: &[u8], width: u32, height: u32, k: u32) -> (Vec<u8>, u32, u32) {
    if k <= 1 {
        return (rgba.to_vec(), width, height);
    }
    let (w, h) = ((width / k).max(1), (height / k).max(1));
    let mut out = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0u32; 4];
            let mut n = 0;
            for dy in 0..k {
                for dx in 0..k {
                    let (sx, sy) = (x * k + dx, y * k + dy);
                    if sx < width && sy < height {
                        let i = ((sy * width + sx) * 4) as usize;
                        if let Some(p) = rgba.get(i..i + 4) {
                            for c in 0..4 {
                                sum[c] += p[c] as u32;
                            }
                            n += 1;
                        }
                    }
                }
            }
            out.extend(sum.map(|v| (v + n / 2).checked_div(n).unwrap_or(0) as u8));
        }
    }
    (out, w, h)
}

/// Writes RGBA pixels as a PNG file.
pub fn write_png(path: &Path, rgba: &[u8], width: u32, height: u32) -> Result<(), Error> {
    let bytes = mdg_vm::preview::encode_png(rgba, width, height).map_err(|e| Error::Io(format!("encode PNG: {e}")))?;
    // Atomically (temporary file + rename): a killed run never leaves half a PNG.
    mdg_export::write_atomic(path, &bytes).map_err(|e| Error::Io(format!("cannot write {}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn big_turntables_shrink_their_views_to_a_bounded_sheet() {
        assert_eq!(sheet_factor(8, 1024), 1);
        let k = sheet_factor(360, 1024);
        let cols = 19;
        assert!(cols * 1024 / k <= MAX_SHEET_WIDTH && k > 1, "k = {k}");
        let px = [10u8, 20, 30, 255, 30, 40, 50, 255].repeat(2);
        let (small, w, h) = shrink(&px, 2, 2, 2);
        assert_eq!((w, h), (1, 1));
        assert_eq!(small, [20, 30, 40, 255]);
    }

    #[test]
    fn contact_sheet_places_tiles_in_a_grid() {
        let red = [255u8, 0, 0, 255].repeat(4);
        let blue = [0u8, 0, 255, 255].repeat(4);
        let (px, w, h) = contact_sheet(&[red, blue.clone(), blue], 2, 2, [9, 9, 9, 255]);
        assert_eq!((w, h), (2 * 2 + 3 * 2, 2 * 2 + 3 * 2));
        let at = |x: u32, y: u32| &px[((y * w + x) * 4) as usize..((y * w + x) * 4 + 4) as usize];
        assert_eq!(at(0, 0), [9, 9, 9, 255]);
        assert_eq!(at(2, 2), [255, 0, 0, 255]);
        assert_eq!(at(6, 2), [0, 0, 255, 255]);
        assert_eq!(at(2, 6), [0, 0, 255, 255]);
    }
}
