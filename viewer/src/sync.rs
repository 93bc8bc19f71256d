//! Fences and semaphores, destroyed in `Drop`.

use crate::context::{vkerr, Context};
use crate::Error;
use ash::vk;
use std::sync::Arc;

/// A fence the host waits on.
pub struct Fence {
    ctx: Arc<Context>,
    pub raw: vk::Fence,
}

impl Fence {
    /// A fence, created signalled when `signalled` (so the first wait returns).
    pub fn new(ctx: &Arc<Context>, signalled: bool) -> Result<Fence, Error> {
        let flags = if signalled { vk::FenceCreateFlags::SIGNALED } else { vk::FenceCreateFlags::empty() };
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_fence(&vk::FenceCreateInfo::default().flags(flags), None) }
            .map_err(vkerr("create fence"))?;
        Ok(Fence { ctx: ctx.clone(), raw })
    }

    /// Waits for the fence without a time limit.
    pub fn wait(&self) -> Result<(), Error> {
        // SAFETY: `self.raw` was created from `self.ctx.device`, which the `Arc` keeps
        // alive, and is destroyed only in `drop`, so the handle is valid for the wait.
        unsafe { self.ctx.device.wait_for_fences(&[self.raw], true, u64::MAX) }.map_err(vkerr("wait for fence"))
    }

    /// Resets it to unsignalled (after a wait, before the next submit).
    pub fn reset(&self) -> Result<(), Error> {
        // SAFETY: the fence is not in use by a pending submission (callers wait first).
        unsafe { self.ctx.device.reset_fences(&[self.raw]) }.map_err(vkerr("reset fence"))
    }
}

impl Drop for Fence {
    fn drop(&mut self) {
        // SAFETY: owners wait on the fence (or for device idle) before dropping it,
        // so no pending submission signals it.
        unsafe { self.ctx.device.destroy_fence(self.raw, None) };
    }
}

/// A binary semaphore ordering GPU work.
pub struct Semaphore {
    ctx: Arc<Context>,
    pub raw: vk::Semaphore,
}

impl Semaphore {
    pub fn new(ctx: &Arc<Context>) -> Result<Semaphore, Error> {
        // SAFETY: valid device and create info.
        let raw = unsafe { ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .map_err(vkerr("create semaphore"))?;
        Ok(Semaphore { ctx: ctx.clone(), raw })
    }
}

impl Drop for Semaphore {
    fn drop(&mut self) {
        // SAFETY: owners drop semaphores after the device is idle (window teardown).
        unsafe { self.ctx.device.destroy_semaphore(self.raw, None) };
    }
}
