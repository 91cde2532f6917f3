//! The offscreen render target: RGBA16F colour + D32 depth, its render pass and
//! framebuffer, and readback of the colour image to linear f32 RGBA.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{Buffer, Context, GpuError, Image, ImageDesc};

/// The colour format of technique frames.
pub const COLOR_FORMAT: vk::Format = vk::Format::R16G16B16A16_SFLOAT;
/// The colour format of G-buffer passes (positions need f32).
pub const COLOR_FORMAT_F32: vk::Format = vk::Format::R32G32B32A32_SFLOAT;
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// The one-channel f32 colour format of the visibility simulator's sky-distance maps.
pub const DEPTH_MAP_FORMAT: vk::Format = vk::Format::R32G32_SFLOAT;

/// Colour and depth images at one size, with the render pass that clears them.
pub struct RenderTarget {
    ctx: Arc<Context>,
    color: Image,
    _depth: Image,
    render_pass: vk::RenderPass,
    framebuffer: vk::Framebuffer,
    width: u32,
    height: u32,
    format: vk::Format,
}

impl RenderTarget {
    /// # Errors
    /// A size of zero or beyond the device's limits, or a failing Vulkan call.
    pub fn new(ctx: &Arc<Context>, width: u32, height: u32) -> Result<Self, GpuError> {
        Self::with_format(ctx, width, height, COLOR_FORMAT)
    }

    /// A target with colour format [`COLOR_FORMAT`], [`COLOR_FORMAT_F32`] or
    /// [`DEPTH_MAP_FORMAT`] ([`Self::read_rgba`] needs one of the first two).
    pub fn with_format(
        ctx: &Arc<Context>,
        width: u32,
        height: u32,
        format: vk::Format,
    ) -> Result<Self, GpuError> {
        if ![COLOR_FORMAT, COLOR_FORMAT_F32, DEPTH_MAP_FORMAT].contains(&format) {
            return Err(GpuError::Invalid {
                what: "render target".into(),
                detail: format!("colour format {format:?} is not supported"),
            });
        }
        let max = ctx
            .limits()
            .max_framebuffer_width
            .min(ctx.limits().max_framebuffer_height);
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::Invalid {
                what: "render target".into(),
                detail: format!("size {width}×{height} is outside 1..={max} on this device"),
            });
        }
        let color = Image::new(
            ctx,
            &ImageDesc::texture_2d(format, width, height)
                .usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC),
            "target.color",
        )?;
        let depth = Image::new(
            ctx,
            &ImageDesc::texture_2d(DEPTH_FORMAT, width, height)
                .usage(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
                .aspect(vk::ImageAspectFlags::DEPTH),
            "target.depth",
        )?;
        let attachments = [
            vk::AttachmentDescription::default()
                .format(format)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL),
            vk::AttachmentDescription::default()
                .format(DEPTH_FORMAT)
                .samples(vk::SampleCountFlags::TYPE_1)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::DONT_CARE)
                .stencil_load_op(vk::AttachmentLoadOp::DONT_CARE)
                .stencil_store_op(vk::AttachmentStoreOp::DONT_CARE)
                .initial_layout(vk::ImageLayout::UNDEFINED)
                .final_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL),
        ];
        let color_ref = [vk::AttachmentReference {
            attachment: 0,
            layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        }];
        let depth_ref = vk::AttachmentReference {
            attachment: 1,
            layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        };
        let subpass = [vk::SubpassDescription::default()
            .pipeline_bind_point(vk::PipelineBindPoint::GRAPHICS)
            .color_attachments(&color_ref)
            .depth_stencil_attachment(&depth_ref)];
        let dependencies = [
            // The previous frame's readback/copy and depth use finish before we clear.
            vk::SubpassDependency::default()
                .src_subpass(vk::SUBPASS_EXTERNAL)
                .dst_subpass(0)
                .src_stage_mask(
                    vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
                )
                .dst_stage_mask(
                    vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
                )
                .src_access_mask(
                    vk::AccessFlags::TRANSFER_READ
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                )
                .dst_access_mask(
                    vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE
                        | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ,
                ),
            // Colour writes are visible to the readback copy.
            vk::SubpassDependency::default()
                .src_subpass(0)
                .dst_subpass(vk::SUBPASS_EXTERNAL)
                .src_stage_mask(vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT)
                .dst_stage_mask(vk::PipelineStageFlags::TRANSFER)
                .src_access_mask(vk::AccessFlags::COLOR_ATTACHMENT_WRITE)
                .dst_access_mask(vk::AccessFlags::TRANSFER_READ),
        ];
        let rp_info = vk::RenderPassCreateInfo::default()
            .attachments(&attachments)
            .subpasses(&subpass)
            .dependencies(&dependencies);
        // SAFETY: create-info borrows locals alive for the call.
        let render_pass = unsafe { ctx.device().create_render_pass(&rp_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateRenderPass", "target.pass", e))?;
        ctx.set_name(render_pass, "target.pass");
        let views = [color.view(), depth.view()];
        let fb_info = vk::FramebufferCreateInfo::default()
            .render_pass(render_pass)
            .attachments(&views)
            .width(width)
            .height(height)
            .layers(1);
        // SAFETY: views are compatible with the render pass; both outlive the framebuffer.
        let framebuffer = match unsafe { ctx.device().create_framebuffer(&fb_info, None) } {
            Ok(f) => f,
            Err(e) => {
                // SAFETY: unused render pass.
                unsafe { ctx.device().destroy_render_pass(render_pass, None) };
                return Err(GpuError::vulkan(
                    "vkCreateFramebuffer",
                    "target.framebuffer",
                    e,
                ));
            }
        };
        ctx.set_name(framebuffer, "target.framebuffer");
        Ok(RenderTarget {
            ctx: ctx.clone(),
            color,
            _depth: depth,
            render_pass,
            framebuffer,
            width,
            height,
            format,
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }
    pub(crate) fn render_pass(&self) -> vk::RenderPass {
        self.render_pass
    }
    /// The whole target, as a render area or scissor.
    pub fn area(&self) -> vk::Rect2D {
        vk::Rect2D {
            offset: vk::Offset2D { x: 0, y: 0 },
            extent: vk::Extent2D {
                width: self.width,
                height: self.height,
            },
        }
    }

    /// The clear values of a pass over a target: colour `color`, depth 1 (the far plane).
    pub fn clears(color: [f32; 4]) -> [vk::ClearValue; 2] {
        [
            vk::ClearValue {
                color: vk::ClearColorValue { float32: color },
            },
            vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            },
        ]
    }

    /// The begin info of a render pass over the whole target, cleared to `clears`
    /// ([`Self::clears`]).
    pub(crate) fn begin_info<'a>(
        &self,
        clears: &'a [vk::ClearValue; 2],
    ) -> vk::RenderPassBeginInfo<'a> {
        vk::RenderPassBeginInfo::default()
            .render_pass(self.render_pass)
            .framebuffer(self.framebuffer)
            .render_area(self.area())
            .clear_values(clears)
    }

    /// Records a copy of the whole colour image (TRANSFER_SRC_OPTIMAL after a render pass)
    /// into `dst` from byte `offset`, row-major, row 0 at the top. The caller makes sure
    /// the render pass came first and `dst` holds width × height texels from `offset`.
    pub(crate) fn record_copy_to_buffer(&self, cmd: vk::CommandBuffer, dst: &Buffer, offset: u64) {
        let region = vk::BufferImageCopy::default()
            .buffer_offset(offset)
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            .image_extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: 1,
            });
        // SAFETY: `cmd` is recording; the image is owned by `self` and, per the contract
        // above, in TRANSFER_SRC_OPTIMAL with `dst` large enough.
        unsafe {
            self.ctx.device().cmd_copy_image_to_buffer(
                cmd,
                self.color.raw(),
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.raw(),
                &[region],
            );
        }
    }

    /// Copies the colour image (left in TRANSFER_SRC_OPTIMAL by the render pass) to the
    /// host: linear RGBA f32, row-major, row 0 at the top. Call after at least one frame.
    pub fn read_rgba(&self) -> Result<Vec<[f32; 4]>, GpuError> {
        let texels = self.width as u64 * self.height as u64;
        let texel_bytes = if self.format == COLOR_FORMAT_F32 {
            16
        } else {
            8
        };
        let buffer = Buffer::new(
            &self.ctx,
            texels * texel_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            "target.readback",
        )?;
        let device = self.ctx.device();
        self.ctx.one_shot("readback target.color", |cmd| {
            self.record_copy_to_buffer(cmd, &buffer, 0);
            super::buffer::record_transfer_to_host(device, cmd, buffer.raw());
        })?;
        let bytes = buffer.read()?;
        if self.format == COLOR_FORMAT_F32 {
            return Ok(bytes
                .chunks_exact(16)
                .map(|t| {
                    std::array::from_fn(|i| {
                        f32::from_le_bytes([t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]])
                    })
                })
                .collect());
        }
        Ok(bytes
            .chunks_exact(8)
            .map(|t| {
                let h = |i: usize| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32();
                [h(0), h(1), h(2), h(3)]
            })
            .collect())
    }
}

impl Drop for RenderTarget {
    fn drop(&mut self) {
        // SAFETY: submissions are waited for; images are dropped after (field order).
        unsafe {
            self.ctx
                .device()
                .destroy_framebuffer(self.framebuffer, None);
            self.ctx
                .device()
                .destroy_render_pass(self.render_pass, None);
        }
    }
}
