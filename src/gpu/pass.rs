//! The mesh pass every technique uses: a graphics pipeline over the scene mesh into the
//! [`RenderTarget`], one descriptor set (set 0) with the technique's resources, and the
//! timed frame loop.
//!
//! Timing (DESIGN §4, `shvis bench`): one command buffer is recorded per run; per query it
//! resets a 2-query pool, writes a TOP_OF_PIPE timestamp, runs the render pass (clear of
//! colour and depth, one indexed draw of the whole mesh) once or, for frames shorter than
//! half a millisecond, several times (`frame_timing`), writes a BOTTOM_OF_PIPE timestamp.
//! Each submission is waited for, so queries never overlap. `warmup` frames are run before
//! the timed ones; ticks become ms with `timestampPeriod`.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::descriptors::{DescriptorSet, Resource};
use super::{Buffer, Context, GpuError, RenderTarget, frame_timing};

/// Vertex buffer layout: stride and (location, format, offset) per attribute.
#[derive(Clone, Debug)]
pub struct VertexLayout {
    pub stride: u32,
    pub attributes: Vec<(u32, vk::Format, u32)>,
}

/// Everything needed to build a [`MeshPipeline`].
pub struct MeshPipelineDesc<'a> {
    /// Debug name and timestamp row: "preconv.dx10".
    pub name: &'a str,
    pub vertex_spirv: &'a [u32],
    pub fragment_spirv: &'a [u32],
    pub vertex_layout: &'a VertexLayout,
    pub resources: &'a [(u32, Resource<'a>)],
    /// Depth test and write (every technique); off only for the device probe's
    /// measurement of what the depth test costs (`crate::probe`).
    pub depth_test: bool,
    /// Additive blending of the colour output (one + one): with a shader writing 1, each
    /// pixel counts the fragments shaded there (`SceneGpu::shaded_fragments`).
    pub additive: bool,
}

/// Vertex and index buffers in device-local memory.
pub struct MeshBuffers {
    vertex: Buffer,
    index: Buffer,
    index_count: u32,
}

impl MeshBuffers {
    /// Triangles drawn (indices ÷ 3).
    pub fn triangle_count(&self) -> u32 {
        self.index_count / 3
    }

    pub fn new(
        ctx: &Arc<Context>,
        vertex_bytes: &[u8],
        indices: &[u32],
        name: &str,
    ) -> Result<Self, GpuError> {
        if indices.is_empty() || vertex_bytes.is_empty() {
            return Err(GpuError::Invalid {
                what: name.into(),
                detail: "mesh has no triangles".into(),
            });
        }
        Ok(MeshBuffers {
            vertex: device_local_buffer(
                ctx,
                vertex_bytes,
                vk::BufferUsageFlags::VERTEX_BUFFER,
                &format!("{name}.vertices"),
            )?,
            index: device_local_buffer(
                ctx,
                bytemuck::cast_slice(indices),
                vk::BufferUsageFlags::INDEX_BUFFER,
                &format!("{name}.indices"),
            )?,
            index_count: indices.len() as u32,
        })
    }
}

/// A device-local buffer filled through a staging copy.
pub fn device_local_buffer(
    ctx: &Arc<Context>,
    bytes: &[u8],
    usage: vk::BufferUsageFlags,
    name: &str,
) -> Result<Buffer, GpuError> {
    let staging = Buffer::with_data(
        ctx,
        bytes,
        vk::BufferUsageFlags::TRANSFER_SRC,
        &format!("{name}.staging"),
    )?;
    let buffer = Buffer::new(
        ctx,
        bytes.len() as u64,
        usage | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
        name,
    )?;
    let device = ctx.device();
    ctx.one_shot(&format!("upload {name}"), |cmd| {
        let region = vk::BufferCopy::default().size(bytes.len() as u64);
        let barrier = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(
                vk::AccessFlags::VERTEX_ATTRIBUTE_READ
                    | vk::AccessFlags::INDEX_READ
                    | vk::AccessFlags::UNIFORM_READ,
            );
        // SAFETY: recording; both buffers outlive the waited submission.
        unsafe {
            device.cmd_copy_buffer(cmd, staging.raw(), buffer.raw(), &[region]);
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::VERTEX_INPUT
                    | vk::PipelineStageFlags::VERTEX_SHADER
                    | vk::PipelineStageFlags::FRAGMENT_SHADER,
                vk::DependencyFlags::empty(),
                &[barrier],
                &[],
                &[],
            );
        }
    })?;
    Ok(buffer)
}

/// A graphics pipeline for the mesh pass with its descriptor set.
pub struct MeshPipeline {
    ctx: Arc<Context>,
    name: String,
    descriptors: DescriptorSet,
    pipeline_layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    modules: [vk::ShaderModule; 2],
}

impl MeshPipeline {
    pub fn new(
        ctx: &Arc<Context>,
        target: &RenderTarget,
        desc: &MeshPipelineDesc<'_>,
    ) -> Result<Self, GpuError> {
        let mut p = MeshPipeline {
            ctx: ctx.clone(),
            name: desc.name.to_string(),
            descriptors: DescriptorSet::new(
                ctx,
                desc.resources,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                desc.name,
            )?,
            pipeline_layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            modules: [vk::ShaderModule::null(); 2],
        };
        // Half-built pipelines are torn down by Drop, which tolerates null handles.
        p.build(target, desc)?;
        Ok(p)
    }

    fn build(
        &mut self,
        target: &RenderTarget,
        desc: &MeshPipelineDesc<'_>,
    ) -> Result<(), GpuError> {
        let ctx = self.ctx.clone();
        let device = ctx.device();
        let name = desc.name;
        let set_layouts = [self.descriptors.layout];
        let pl_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY (this block and those below): create-infos borrow locals alive for each
        // call; created handles are stored in `self` at once so Drop destroys them.
        self.pipeline_layout = unsafe { device.create_pipeline_layout(&pl_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreatePipelineLayout", name, e))?;
        ctx.set_name(self.pipeline_layout, name);

        // Shaders and pipeline.
        for (i, code) in [desc.vertex_spirv, desc.fragment_spirv].iter().enumerate() {
            let info = vk::ShaderModuleCreateInfo::default().code(code);
            // SAFETY: SPIR-V words from shaderc.
            self.modules[i] = unsafe { device.create_shader_module(&info, None) }
                .map_err(|e| GpuError::vulkan("vkCreateShaderModule", name, e))?;
            ctx.set_name(self.modules[i], &format!("{name}.{}", ["vert", "frag"][i]));
        }
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(self.modules[0])
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(self.modules[1])
                .name(c"main"),
        ];
        let vb = [vk::VertexInputBindingDescription {
            binding: 0,
            stride: desc.vertex_layout.stride,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let attrs: Vec<_> = desc
            .vertex_layout
            .attributes
            .iter()
            .map(
                |&(location, format, offset)| vk::VertexInputAttributeDescription {
                    location,
                    binding: 0,
                    format,
                    offset,
                },
            )
            .collect();
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&vb)
            .vertex_attribute_descriptions(&attrs);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewports = [vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: target.width() as f32,
            height: target.height() as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        }];
        let scissors = [vk::Rect2D {
            offset: vk::Offset2D { x: 0, y: 0 },
            extent: vk::Extent2D {
                width: target.width(),
                height: target.height(),
            },
        }];
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewports(&viewports)
            .scissors(&scissors);
        // No culling: the one-sided ground and thin boxes are never seen from behind by
        // the built-in camera, and the same pipeline state must serve any glTF scene.
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth_test)
            .depth_write_enable(desc.depth_test)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)
            .blend_enable(desc.additive)
            .src_color_blend_factor(vk::BlendFactor::ONE)
            .dst_color_blend_factor(vk::BlendFactor::ONE)
            .color_blend_op(vk::BlendOp::ADD)
            .src_alpha_blend_factor(vk::BlendFactor::ONE)
            .dst_alpha_blend_factor(vk::BlendFactor::ONE)
            .alpha_blend_op(vk::BlendOp::ADD)];
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .layout(self.pipeline_layout)
            .render_pass(target.render_pass())
            .subpass(0);
        // SAFETY: every state struct borrows locals alive for the call.
        self.pipeline =
            unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None) }
                .map_err(|(_, e)| GpuError::vulkan("vkCreateGraphicsPipelines", name, e))?[0];
        ctx.set_name(self.pipeline, name);
        Ok(())
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Runs `warmup` untimed and `frames` timed frames; returns the timed frames' GPU
    /// times in ms (empty when the queue has no timestamps). Frames shorter than
    /// `min_span_ms` are timed several to a query (`frame_timing`). See the module doc.
    pub fn render_frames(
        &self,
        target: &RenderTarget,
        mesh: &MeshBuffers,
        warmup: u32,
        frames: u32,
        min_span_ms: f64,
    ) -> Result<Vec<f64>, GpuError> {
        let ctx = &self.ctx;
        let device = ctx.device();
        let name = self.name.as_str();
        let timed = ctx.supports_timestamps();
        let pool = if timed {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(2);
            // SAFETY: plain create-info; destroyed at the end of this function.
            let pool = unsafe { device.create_query_pool(&info, None) }
                .map_err(|e| GpuError::vulkan("vkCreateQueryPool", name, e))?;
            ctx.set_name(pool, &format!("{name}.timestamps"));
            pool
        } else {
            vk::QueryPool::null()
        };
        let cmd = match ctx.allocate_command_buffer(name) {
            Ok(c) => c,
            Err(e) => {
                // SAFETY: unused pool (null is allowed).
                unsafe { device.destroy_query_pool(pool, None) };
                return Err(e);
            }
        };
        let result = self.time_queries(target, mesh, cmd, pool, (warmup, frames), min_span_ms);
        ctx.free_command_buffer(cmd);
        // SAFETY: every submission was waited for.
        unsafe { device.destroy_query_pool(pool, None) };
        result
    }

    /// The frames of [`Self::render_frames`] on `cmd` and `pool`: `warmup` frames one per
    /// query, then — where the last of them was shorter than half a millisecond — queries of
    /// several frames until the clocks settle, then `frames` timed queries (module doc).
    fn time_queries(
        &self,
        target: &RenderTarget,
        mesh: &MeshBuffers,
        cmd: vk::CommandBuffer,
        pool: vk::QueryPool,
        (warmup, frames): (u32, u32),
        min_span_ms: f64,
    ) -> Result<Vec<f64>, GpuError> {
        let timed = pool != vk::QueryPool::null();
        self.record(target, mesh, cmd, pool, 1)?;
        let warm = self.run_queries(cmd, pool, warmup)?;
        let ns_per_tick = f64::from(self.ctx.limits().timestamp_period);
        let draws = match warm.last() {
            Some(&ms) if timed => frame_timing::draws_per_query(ms, ns_per_tick, min_span_ms),
            _ => 1,
        };
        if draws == 1 {
            let ms = self.run_queries(cmd, pool, frames.max(1))?;
            return Ok(if timed { ms } else { Vec::new() });
        }
        // SAFETY: every submission of `cmd` was waited for; it is re-recorded from the start.
        unsafe {
            self.ctx
                .device()
                .reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
        }
        .map_err(|e| GpuError::vulkan("vkResetCommandBuffer", &self.name, e))?;
        self.record(target, mesh, cmd, pool, draws)?;
        let mut settling = Vec::new();
        while settling.len() < frame_timing::MAX_SETTLE_QUERIES && !frame_timing::settled(&settling)
        {
            settling.extend(self.run_queries(cmd, pool, 1)?);
        }
        log::debug!(
            "{}: {draws} frames a query, clocks settled after {} queries",
            self.name,
            settling.len()
        );
        let ms = self.run_queries(cmd, pool, frames.max(1))?;
        Ok(ms.into_iter().map(|q| q / f64::from(draws)).collect())
    }

    /// Records into `cmd`: the pool's reset and a timestamp (when there is a pool), `draws`
    /// render passes of the mesh, a timestamp.
    fn record(
        &self,
        target: &RenderTarget,
        mesh: &MeshBuffers,
        cmd: vk::CommandBuffer,
        pool: vk::QueryPool,
        draws: u32,
    ) -> Result<(), GpuError> {
        let ctx = &self.ctx;
        let device = ctx.device();
        let name = self.name.as_str();
        let timed = pool != vk::QueryPool::null();
        let clears = RenderTarget::clears([0.0; 4]);
        let begin_pass = target.begin_info(&clears);
        // SAFETY: `cmd` is freshly allocated or reset; every object recorded is owned by
        // `self`, `target` or `mesh`, all alive until the waited submissions complete.
        unsafe {
            device
                .begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
                .map_err(|e| GpuError::vulkan("vkBeginCommandBuffer", name, e))?;
            ctx.begin_label(cmd, name);
            if timed {
                device.cmd_reset_query_pool(cmd, pool, 0, 2);
                device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, pool, 0);
            }
            for _ in 0..draws {
                device.cmd_begin_render_pass(cmd, &begin_pass, vk::SubpassContents::INLINE);
                device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.pipeline);
                device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.pipeline_layout,
                    0,
                    &[self.descriptors.set],
                    &[],
                );
                device.cmd_bind_vertex_buffers(cmd, 0, &[mesh.vertex.raw()], &[0]);
                device.cmd_bind_index_buffer(cmd, mesh.index.raw(), 0, vk::IndexType::UINT32);
                device.cmd_draw_indexed(cmd, mesh.index_count, 1, 0, 0, 0);
                device.cmd_end_render_pass(cmd);
            }
            if timed {
                device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, pool, 1);
            }
            ctx.end_label(cmd);
            device
                .end_command_buffer(cmd)
                .map_err(|e| GpuError::vulkan("vkEndCommandBuffer", name, e))?;
        }
        Ok(())
    }

    /// Submits `cmd` `queries` times, each waited for; returns each query's span in ms
    /// (nothing without a pool).
    fn run_queries(
        &self,
        cmd: vk::CommandBuffer,
        pool: vk::QueryPool,
        queries: u32,
    ) -> Result<Vec<f64>, GpuError> {
        let ctx = &self.ctx;
        let name = self.name.as_str();
        let mask = frame_timing::tick_mask(ctx.timestamp_valid_bits());
        let ns_per_tick = f64::from(ctx.limits().timestamp_period);
        let mut ms = Vec::with_capacity(queries as usize);
        for _ in 0..queries {
            ctx.submit_and_wait(cmd, name)?;
            if pool != vk::QueryPool::null() {
                let mut ticks = [0u64; 2];
                // SAFETY: both queries were written by the completed submission.
                unsafe {
                    ctx.device().get_query_pool_results(
                        pool,
                        0,
                        &mut ticks,
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                }
                .map_err(|e| GpuError::vulkan("vkGetQueryPoolResults", name, e))?;
                ms.push(frame_timing::ticks_to_ms(
                    ticks[0],
                    ticks[1],
                    mask,
                    ns_per_tick,
                ));
            }
        }
        Ok(ms)
    }
}

impl Drop for MeshPipeline {
    fn drop(&mut self) {
        let device = self.ctx.device();
        // SAFETY: submissions are waited for; destroying null handles is valid. The
        // descriptor set is dropped after this (field order), once nothing uses it.
        unsafe {
            device.destroy_pipeline(self.pipeline, None);
            for m in self.modules {
                device.destroy_shader_module(m, None);
            }
            device.destroy_pipeline_layout(self.pipeline_layout, None);
        }
    }
}
