//! Buffers with gpu-allocator memory: vertex/index/uniform buffers and staging/readback.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::Allocation;

use super::{Context, GpuError};

/// A `vk::Buffer` with its memory, destroyed in `Drop`.
pub struct Buffer {
    ctx: Arc<Context>,
    raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
    name: String,
}

impl Buffer {
    /// A buffer of `size` bytes; `location` decides host visibility.
    pub fn new(
        ctx: &Arc<Context>,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
        name: &str,
    ) -> Result<Self, GpuError> {
        if size == 0 {
            return Err(GpuError::Invalid {
                what: name.into(),
                detail: "buffer of zero bytes".into(),
            });
        }
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: the create-info is fully initialised and lives for the call.
        let raw = unsafe { ctx.device().create_buffer(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateBuffer", name, e))?;
        let mut buffer = Buffer {
            ctx: ctx.clone(),
            raw,
            allocation: None,
            size,
            name: name.to_string(),
        };
        // SAFETY: `raw` is a live buffer of this device.
        let req = unsafe { ctx.device().get_buffer_memory_requirements(raw) };
        let allocation = ctx.allocate(name, req, location, true)?;
        // SAFETY: the allocation satisfies `req` and is not bound elsewhere.
        unsafe {
            ctx.device()
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        }
        .map_err(|e| GpuError::vulkan("vkBindBufferMemory", name, e))?;
        buffer.allocation = Some(allocation);
        ctx.set_name(raw, name);
        Ok(buffer)
    }

    /// A host-visible buffer filled with `bytes`.
    pub fn with_data(
        ctx: &Arc<Context>,
        bytes: &[u8],
        usage: vk::BufferUsageFlags,
        name: &str,
    ) -> Result<Self, GpuError> {
        let mut b = Self::new(
            ctx,
            bytes.len() as u64,
            usage,
            MemoryLocation::CpuToGpu,
            name,
        )?;
        b.write(bytes)?;
        Ok(b)
    }

    /// Copies `bytes` to the start of a host-visible buffer.
    pub fn write(&mut self, bytes: &[u8]) -> Result<(), GpuError> {
        let name = self.name.clone();
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| GpuError::Invalid {
                what: name.clone(),
                detail: "buffer is not host-visible".into(),
            })?;
        if bytes.len() > slice.len() {
            return Err(GpuError::Invalid {
                what: name,
                detail: format!("{} bytes do not fit in {}", bytes.len(), slice.len()),
            });
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }

    /// The contents of a host-visible buffer.
    pub fn read(&self) -> Result<&[u8], GpuError> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| &s[..self.size as usize])
            .ok_or_else(|| GpuError::Invalid {
                what: self.name.clone(),
                detail: "buffer is not host-visible".into(),
            })
    }

    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }
    pub fn size(&self) -> u64 {
        self.size
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: every submission using this buffer was waited for (all GPU work in shvis
        // is submit-and-wait); nothing else owns `raw`.
        unsafe { self.ctx.device().destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            self.ctx.free(a);
        }
    }
}

/// Records the barrier that makes transfer writes into `buffer` visible to host reads (after
/// a copy into a readback buffer, before `Buffer::read`).
pub(crate) fn record_transfer_to_host(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    buffer: vk::Buffer,
) {
    let to_host = vk::BufferMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .buffer(buffer)
        .size(vk::WHOLE_SIZE);
    // SAFETY: recording a barrier into a command buffer in the recording state.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &[],
            &[to_host],
            &[],
        );
    }
}
