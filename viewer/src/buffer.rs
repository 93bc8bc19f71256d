//! GPU buffers with their memory: vertex, index, uniform, storage and readback
//! buffers. Each [`Buffer`] frees its memory in `Drop`.
//!
//! Data is uploaded through a mapping when the device has a memory type that is both
//! device-local and host-visible (lavapipe, integrated GPUs, resizable BAR), else
//! through a staging buffer and a copy (discrete GPUs).

use crate::context::{vkerr, Context};
use crate::Error;
use ash::vk;
use std::sync::Arc;

/// A buffer and its memory.
pub struct Buffer {
    ctx: Arc<Context>,
    pub raw: vk::Buffer,
    memory: vk::DeviceMemory,
    pub size: u64,
    /// Host-visible and coherent: [`Buffer::write`] and [`Buffer::read`] work.
    mapped: bool,
}

impl Buffer {
    /// A buffer of `size` bytes (at least 1) in memory with `props`.
    pub fn new(
        ctx: &Arc<Context>,
        size: u64,
        usage: vk::BufferUsageFlags,
        props: vk::MemoryPropertyFlags,
    ) -> Result<Buffer, Error> {
        let size = size.max(4);
        let info = vk::BufferCreateInfo::default().size(size).usage(usage).sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_buffer(&info, None) }.map_err(vkerr("create buffer"))?;
        // SAFETY: `raw` was just created from this device.
        let req = unsafe { ctx.device.get_buffer_memory_requirements(raw) };
        let Some(type_index) = ctx.memory_type(req.memory_type_bits, props) else {
            // SAFETY: `raw` was created just above from this device, has no memory bound
            // and was never given to the GPU, so nothing uses it.
            unsafe { ctx.device.destroy_buffer(raw, None) };
            return Err(Error::Vulkan(format!("no memory type with {props:?} for a buffer")));
        };
        let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(type_index);
        // SAFETY: valid allocate info for this device.
        let memory = match unsafe { ctx.device.allocate_memory(&alloc, None) } {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: `raw` was created just above from this device, has no memory
                // bound and was never given to the GPU, so nothing uses it.
                unsafe { ctx.device.destroy_buffer(raw, None) };
                return Err(Error::Vulkan(format!("allocate {} bytes of buffer memory: {e}", req.size)));
            }
        };
        let buffer = Buffer {
            ctx: ctx.clone(),
            raw,
            memory,
            size,
            mapped: props.contains(vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT),
        };
        // SAFETY: fresh memory of a compatible type, bound once at offset 0.
        unsafe { ctx.device.bind_buffer_memory(raw, memory, 0) }.map_err(vkerr("bind buffer memory"))?;
        Ok(buffer)
    }

    /// A host-visible, coherent buffer (uniforms, readback).
    pub fn host(ctx: &Arc<Context>, size: u64, usage: vk::BufferUsageFlags) -> Result<Buffer, Error> {
        Buffer::new(ctx, size, usage, vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT)
    }

    /// A buffer for the GPU to read, filled with `data`.
    pub fn with_data(ctx: &Arc<Context>, data: &[u8], usage: vk::BufferUsageFlags) -> Result<Buffer, Error> {
        let direct = vk::MemoryPropertyFlags::DEVICE_LOCAL
            | vk::MemoryPropertyFlags::HOST_VISIBLE
            | vk::MemoryPropertyFlags::HOST_COHERENT;
        if let Ok(b) = Buffer::new(ctx, data.len() as u64, usage, direct) {
            b.write(0, data)?;
            return Ok(b);
        }
        let staging = Buffer::host(ctx, data.len() as u64, vk::BufferUsageFlags::TRANSFER_SRC)?;
        staging.write(0, data)?;
        let b = Buffer::new(
            ctx,
            data.len() as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let region = [vk::BufferCopy::default().size(data.len().max(1) as u64)];
        ctx.one_time(|cmd| {
            // SAFETY: both buffers are valid and large enough; `cmd` is recording.
            unsafe { ctx.device.cmd_copy_buffer(cmd, staging.raw, b.raw, &region) };
        })?;
        Ok(b)
    }

    /// A buffer for the GPU to read, `len` bytes filled by `fill` in place: in the
    /// buffer's own memory when the device has memory that is device-local and
    /// host-visible (lavapipe, integrated GPUs), else in a staging buffer copied
    /// over. Nothing is built on the heap first (the instance records of a big
    /// model are tens of MB). `fill` must write every byte.
    pub fn filled(
        ctx: &Arc<Context>,
        len: usize,
        usage: vk::BufferUsageFlags,
        fill: impl FnOnce(&mut [u8]),
    ) -> Result<Buffer, Error> {
        let direct = vk::MemoryPropertyFlags::DEVICE_LOCAL
            | vk::MemoryPropertyFlags::HOST_VISIBLE
            | vk::MemoryPropertyFlags::HOST_COHERENT;
        if let Ok(b) = Buffer::new(ctx, len as u64, usage, direct) {
            b.fill(len, fill)?;
            return Ok(b);
        }
        let staging = Buffer::host(ctx, len as u64, vk::BufferUsageFlags::TRANSFER_SRC)?;
        staging.fill(len, fill)?;
        let b = Buffer::new(
            ctx,
            len as u64,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let region = [vk::BufferCopy::default().size(len.max(1) as u64)];
        ctx.one_time(|cmd| {
            // SAFETY: both buffers are valid and large enough; `cmd` is recording.
            unsafe { ctx.device.cmd_copy_buffer(cmd, staging.raw, b.raw, &region) };
        })?;
        Ok(b)
    }

    /// Maps `len` bytes from byte `offset` (host-visible buffers only), lets `f`
    /// read or write them, and unmaps them. `what` names the use in the error.
    /// Callers only map buffers the GPU is not using: new ones, or ones whose
    /// frame's fence they have waited on.
    fn mapped(&self, offset: u64, len: usize, what: &str, f: impl FnOnce(&mut [u8])) -> Result<(), Error> {
        if !self.mapped || offset + len as u64 > self.size {
            return Err(Error::Vulkan(format!("{what} a buffer that is not host-visible or too small")));
        }
        if len == 0 {
            return Ok(());
        }
        // SAFETY: host-visible, coherent memory of at least offset + len bytes,
        // mapped for the duration of `f` only and not in use by the GPU (the
        // callers' contract above); the slice does not outlive the mapping.
        unsafe {
            let p = self
                .ctx
                .device
                .map_memory(self.memory, offset, len as u64, vk::MemoryMapFlags::empty())
                .map_err(vkerr("map memory"))?;
            f(std::slice::from_raw_parts_mut(p as *mut u8, len));
            self.ctx.device.unmap_memory(self.memory);
        }
        Ok(())
    }

    /// Maps the first `len` bytes (host-visible buffers only) and lets `fill` write
    /// them.
    fn fill(&self, len: usize, fill: impl FnOnce(&mut [u8])) -> Result<(), Error> {
        self.mapped(0, len, "fill of", fill)
    }

    /// Copies `data` into the buffer at byte `offset` (host-visible buffers only;
    /// callers wait on the frame's fence first).
    pub fn write(&self, offset: u64, data: &[u8]) -> Result<(), Error> {
        self.mapped(offset, data.len(), "write to", |m| m.copy_from_slice(data))
    }

    /// Whether [`Buffer::read`] and [`Buffer::with_contents`] work (the memory is
    /// host-visible).
    pub fn is_mapped(&self) -> bool {
        self.mapped
    }

    /// Lets `f` read the first `len` bytes in place (host-visible buffers only;
    /// callers wait on the fence of any GPU work that writes it).
    pub fn with_contents(&self, len: usize, f: impl FnOnce(&[u8])) -> Result<(), Error> {
        self.mapped(0, len, "read from", |m| f(m))
    }

    /// Reads `len` bytes from the start of the buffer (host-visible buffers only;
    /// callers wait on the fence of the GPU work that wrote it).
    pub fn read(&self, len: usize) -> Result<Vec<u8>, Error> {
        let mut out = vec![0u8; len];
        self.mapped(0, len, "read from", |m| out.copy_from_slice(m))?;
        Ok(out)
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: owners drop buffers only after the GPU work using them finished
        // (the renderer waits on its fence or for idle before replacing them).
        unsafe {
            self.ctx.device.destroy_buffer(self.raw, None);
            self.ctx.device.free_memory(self.memory, None);
        }
    }
}
