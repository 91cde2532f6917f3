//! Staging uploads: texel data → image, leaving it ready for sampling.

use std::sync::Arc;

use ash::vk;

use super::image::format_texel_bytes;
use super::{Buffer, Context, GpuError, Image};

/// Uploads `levels[mip][layer]` into `image` and transitions it to SHADER_READ_ONLY_OPTIMAL.
pub(crate) fn upload_image(
    ctx: &Arc<Context>,
    image: &Image,
    levels: &[Vec<&[u8]>],
    name: &str,
) -> Result<(), GpuError> {
    let desc = *image.desc();
    let texel = format_texel_bytes(desc.format).ok_or_else(|| GpuError::Invalid {
        what: name.into(),
        detail: format!("upload of format {:?} is not supported", desc.format),
    })? as usize;
    if levels.len() != desc.mip_levels as usize {
        return Err(GpuError::Invalid {
            what: name.into(),
            detail: format!(
                "{} mip levels given, {} expected",
                levels.len(),
                desc.mip_levels
            ),
        });
    }
    let mut staging_bytes = Vec::new();
    let mut regions = Vec::new();
    for (mip, layers) in levels.iter().enumerate() {
        let w = (desc.width >> mip).max(1);
        let h = (desc.height >> mip).max(1);
        if layers.len() != desc.layers as usize {
            return Err(GpuError::Invalid {
                what: name.into(),
                detail: format!(
                    "mip {mip}: {} layers given, {} expected",
                    layers.len(),
                    desc.layers
                ),
            });
        }
        for (layer, data) in layers.iter().enumerate() {
            let expected = w as usize * h as usize * texel;
            if data.len() != expected {
                return Err(GpuError::Invalid {
                    what: name.into(),
                    detail: format!(
                        "mip {mip} layer {layer}: {} bytes given, {expected} expected",
                        data.len()
                    ),
                });
            }
            // Offsets stay multiples of 16 (≥ every texel size and 4, as copies require).
            while staging_bytes.len() % 16 != 0 {
                staging_bytes.push(0);
            }
            regions.push(
                vk::BufferImageCopy::default()
                    .buffer_offset(staging_bytes.len() as u64)
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
            staging_bytes.extend_from_slice(data);
        }
    }
    let staging = Buffer::with_data(
        ctx,
        &staging_bytes,
        vk::BufferUsageFlags::TRANSFER_SRC,
        &format!("{name}.staging"),
    )?;
    let range = image.full_range();
    let device = ctx.device();
    ctx.one_shot(&format!("upload {name}"), |cmd| {
        let to_dst = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::empty())
            .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.raw())
            .subresource_range(range);
        let to_read = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::SHADER_READ)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.raw())
            .subresource_range(range);
        // SAFETY: `cmd` is recording; the staging buffer and image outlive the submission,
        // which `one_shot` waits for.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_dst],
            );
            device.cmd_copy_buffer_to_image(
                cmd,
                staging.raw(),
                image.raw(),
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &regions,
            );
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::FRAGMENT_SHADER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_read],
            );
        }
    })
}
