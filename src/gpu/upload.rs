//! Staging uploads: texel data → images, leaving them ready for sampling — either waited
//! for (`upload_image`, at creation) or submitted without waiting ([`PendingUpload`]: the
//! table swaps of `shvis relight`, which must not stall the frame loop).

use std::sync::Arc;

use ash::vk;

use super::image::format_level_bytes;
use super::{Buffer, Context, GpuError, Image};

/// Copies of texel data into images, staged in one host-visible buffer.
pub(crate) struct StagedCopies {
    staging: Buffer,
    copies: Vec<ImageCopy>,
}

struct ImageCopy {
    image: vk::Image,
    range: vk::ImageSubresourceRange,
    regions: Vec<vk::BufferImageCopy>,
}

impl StagedCopies {
    /// Stages `levels[mip][layer]` (tightly packed texels) for each image of `uploads`;
    /// every texel of each image is written, so its previous contents are discarded.
    pub(crate) fn new(
        ctx: &Arc<Context>,
        uploads: &[(&Image, &[Vec<&[u8]>])],
        name: &str,
    ) -> Result<Self, GpuError> {
        let mut staging_bytes = Vec::new();
        let mut copies = Vec::with_capacity(uploads.len());
        for &(image, levels) in uploads {
            copies.push(ImageCopy {
                image: image.raw(),
                range: image.full_range(),
                regions: stage_levels(image, levels, &mut staging_bytes, name)?,
            });
        }
        let staging = Buffer::with_data(
            ctx,
            &staging_bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            &format!("{name}.staging"),
        )?;
        Ok(StagedCopies { staging, copies })
    }

    /// Records the copies with their layout transitions: any layout → TRANSFER_DST →
    /// SHADER_READ_ONLY_OPTIMAL, the fragment shaders of later submissions waiting for the
    /// writes.
    fn record(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let device = ctx.device();
        let barrier = |copy: &ImageCopy, old, new, src, dst| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(src)
                .dst_access_mask(dst)
                .old_layout(old)
                .new_layout(new)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(copy.image)
                .subresource_range(copy.range)
        };
        let to_dst: Vec<_> = self
            .copies
            .iter()
            .map(|c| {
                // UNDEFINED: every texel is overwritten, and earlier reads finished before
                // this submission was recorded (callers' contract).
                barrier(
                    c,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::TRANSFER_WRITE,
                )
            })
            .collect();
        let to_read: Vec<_> = self
            .copies
            .iter()
            .map(|c| {
                barrier(
                    c,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::SHADER_READ,
                )
            })
            .collect();
        // SAFETY: `cmd` is recording; the staging buffer and the images outlive the
        // submission (one_shot waits for it; PendingUpload owns the staging and its callers
        // keep the images alive until it completes).
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_dst,
            );
            for copy in &self.copies {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    self.staging.raw(),
                    copy.image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &copy.regions,
                );
            }
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::FRAGMENT_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &to_read,
            );
        }
    }
}

/// Appends `levels` of `image` to `staging` (offsets kept multiples of 16) and returns the
/// copy regions, after checking every level and layer has the size `image` needs.
fn stage_levels(
    image: &Image,
    levels: &[Vec<&[u8]>],
    staging: &mut Vec<u8>,
    name: &str,
) -> Result<Vec<vk::BufferImageCopy>, GpuError> {
    let desc = *image.desc();
    let invalid = |detail: String| GpuError::Invalid {
        what: name.into(),
        detail,
    };
    if format_level_bytes(desc.format, 1, 1).is_none() {
        return Err(invalid(format!(
            "upload of format {:?} is not supported",
            desc.format
        )));
    }
    if levels.len() != desc.mip_levels as usize {
        return Err(invalid(format!(
            "{} mip levels given, {} expected",
            levels.len(),
            desc.mip_levels
        )));
    }
    let mut regions = Vec::new();
    for (mip, layers) in levels.iter().enumerate() {
        let w = (desc.width >> mip).max(1);
        let h = (desc.height >> mip).max(1);
        if layers.len() != desc.layers as usize {
            return Err(invalid(format!(
                "mip {mip}: {} layers given, {} expected",
                layers.len(),
                desc.layers
            )));
        }
        for (layer, data) in layers.iter().enumerate() {
            let expected = format_level_bytes(desc.format, w, h).unwrap_or(0) as usize;
            if data.len() != expected {
                return Err(invalid(format!(
                    "mip {mip} layer {layer}: {} bytes given, {expected} expected",
                    data.len()
                )));
            }
            // Offsets stay multiples of 16 (≥ every texel size and 4, as copies require).
            staging.resize(staging.len().next_multiple_of(16), 0);
            regions.push(
                vk::BufferImageCopy::default()
                    .buffer_offset(staging.len() as u64)
                    .image_subresource(vk::ImageSubresourceLayers {
                        aspect_mask: desc.aspect,
                        mip_level: mip as u32,
                        base_array_layer: layer as u32,
                        layer_count: 1,
                    })
                    .image_extent(vk::Extent3D {
                        width: w,
                        height: h,
                        depth: 1,
                    }),
            );
            staging.extend_from_slice(data);
        }
    }
    Ok(regions)
}

/// Uploads `levels[mip][layer]` into `image`, waits, and leaves it in
/// SHADER_READ_ONLY_OPTIMAL.
pub(crate) fn upload_image(
    ctx: &Arc<Context>,
    image: &Image,
    levels: &[Vec<&[u8]>],
    name: &str,
) -> Result<(), GpuError> {
    let staged = StagedCopies::new(ctx, &[(image, levels)], name)?;
    ctx.one_shot(&format!("upload {name}"), |cmd| staged.record(ctx, cmd))
}

/// Copies into images submitted to the queue without waiting: frames submitted after it
/// see the new texels (the copy's closing barrier), and the CPU goes on. Poll it with
/// [`PendingUpload::is_done`]; dropping it waits for the GPU first, so the staging buffer
/// and command buffer are never freed while in use.
///
/// The images must not be read by work in flight when it is submitted, and must outlive it.
pub struct PendingUpload {
    ctx: Arc<Context>,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    _staging: Buffer,
    name: String,
}

impl PendingUpload {
    /// Stages `uploads` and submits their copies (see the type's doc for the contract).
    pub fn submit(
        ctx: &Arc<Context>,
        uploads: &[(&Image, &[Vec<&[u8]>])],
        name: &str,
    ) -> Result<Self, GpuError> {
        let staged = StagedCopies::new(ctx, uploads, name)?;
        let cmd = ctx.allocate_command_buffer(name)?;
        let recorded = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            let device = ctx.device();
            // SAFETY: `cmd` was just allocated and is in the initial state.
            unsafe { device.begin_command_buffer(cmd, &begin) }
                .map_err(|e| GpuError::vulkan("vkBeginCommandBuffer", name, e))?;
            ctx.begin_label(cmd, name);
            staged.record(ctx, cmd);
            ctx.end_label(cmd);
            // SAFETY: recording began above.
            unsafe { device.end_command_buffer(cmd) }
                .map_err(|e| GpuError::vulkan("vkEndCommandBuffer", name, e))?;
            ctx.submit(cmd, name)
        })();
        match recorded {
            Ok(fence) => Ok(PendingUpload {
                ctx: ctx.clone(),
                cmd,
                fence,
                _staging: staged.staging,
                name: name.to_string(),
            }),
            Err(e) => {
                ctx.free_command_buffer(cmd);
                Err(e)
            }
        }
    }

    /// Whether the GPU has finished the copies (never blocks).
    pub fn is_done(&self) -> Result<bool, GpuError> {
        // SAFETY: the fence belongs to this device and lives until Drop.
        unsafe { self.ctx.device().get_fence_status(self.fence) }
            .map_err(|e| GpuError::vulkan("vkGetFenceStatus", &self.name, e))
    }

    /// Blocks until the GPU has finished the copies.
    pub fn wait(&self) -> Result<(), GpuError> {
        // SAFETY: as `is_done`.
        unsafe {
            self.ctx
                .device()
                .wait_for_fences(&[self.fence], true, u64::MAX)
        }
        .map_err(|e| GpuError::vulkan("vkWaitForFences", &self.name, e))
    }
}

impl Drop for PendingUpload {
    fn drop(&mut self) {
        if let Err(e) = self.wait() {
            log::error!("{e}");
        }
        // SAFETY: the submission completed (waited above), so neither is in use.
        unsafe { self.ctx.device().destroy_fence(self.fence, None) };
        self.ctx.free_command_buffer(self.cmd);
    }
}
