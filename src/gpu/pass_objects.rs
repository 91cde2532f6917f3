//! Raw Vulkan objects of the one-command-buffer GPU bakes (normal maps, the visibility
//! simulator): shader modules, pipeline layouts and depth-tested triangle pipelines into
//! a [`RenderTarget`], a timestamp pool and the command buffer, all destroyed in Drop.

use std::sync::Arc;

use ash::vk;

use super::frame_timing::{tick_mask, ticks_to_ms};
use super::shader::{ShaderStage, compile_glsl};
use super::{Context, GpuError, RenderTarget};

impl PassObjects {
    /// Creates the pool of `count` timestamp queries when the queue has timestamps;
    /// returns whether it did.
    pub fn timestamps(&mut self, count: u32, name: &str) -> Result<bool, GpuError> {
        if !self.ctx.supports_timestamps() {
            return Ok(false);
        }
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(count);
        // SAFETY: plain create-info; stored for Drop at once.
        self.query_pool = unsafe { self.ctx.device().create_query_pool(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateQueryPool", name, e))?;
        self.ctx.set_name(self.query_pool, name);
        Ok(true)
    }

    /// Records timestamp `query` after `stage` into `cmd`, when there is a pool.
    pub fn timestamp(&self, cmd: vk::CommandBuffer, stage: vk::PipelineStageFlags, query: u32) {
        if self.query_pool != vk::QueryPool::null() {
            // SAFETY: recording; the caller resets the pool before writing a query and
            // keeps `query` below the pool's count.
            unsafe {
                self.ctx
                    .device()
                    .cmd_write_timestamp(cmd, stage, self.query_pool, query)
            };
        }
    }

    /// The ms between consecutive timestamps 0..=`intervals` once the submissions that
    /// wrote them completed; `None` without a pool.
    pub fn timestamp_ms(&self, intervals: usize, what: &str) -> Result<Option<Vec<f64>>, GpuError> {
        if self.query_pool == vk::QueryPool::null() {
            return Ok(None);
        }
        let mut ticks = vec![0u64; intervals + 1];
        // SAFETY: all queries were written by completed submissions.
        unsafe {
            self.ctx.device().get_query_pool_results(
                self.query_pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(|e| GpuError::vulkan("vkGetQueryPoolResults", what, e))?;
        let mask = tick_mask(self.ctx.timestamp_valid_bits());
        let period = f64::from(self.ctx.limits().timestamp_period);
        Ok(Some(
            ticks
                .windows(2)
                .map(|t| ticks_to_ms(t[0], t[1], mask, period))
                .collect(),
        ))
    }

    /// Records a global memory barrier into `cmd`.
    pub fn barrier(
        &self,
        cmd: vk::CommandBuffer,
        stages: (vk::PipelineStageFlags, vk::PipelineStageFlags),
        access: (vk::AccessFlags, vk::AccessFlags),
    ) {
        let memory = vk::MemoryBarrier::default()
            .src_access_mask(access.0)
            .dst_access_mask(access.1);
        // SAFETY: recording a global memory barrier.
        unsafe {
            self.ctx.device().cmd_pipeline_barrier(
                cmd,
                stages.0,
                stages.1,
                vk::DependencyFlags::empty(),
                &[memory],
                &[],
                &[],
            );
        }
    }

    /// No objects yet.
    pub fn new(ctx: &Arc<Context>) -> Self {
        PassObjects {
            ctx: ctx.clone(),
            modules: Vec::new(),
            layouts: Vec::new(),
            pipelines: Vec::new(),
            query_pool: vk::QueryPool::null(),
            cmd: vk::CommandBuffer::null(),
        }
    }
}

/// Vulkan objects made for one GPU bake, destroyed in Drop (null handles allowed).
pub(crate) struct PassObjects {
    pub ctx: Arc<Context>,
    pub modules: Vec<vk::ShaderModule>,
    pub layouts: Vec<vk::PipelineLayout>,
    pub pipelines: Vec<vk::Pipeline>,
    pub query_pool: vk::QueryPool,
    pub cmd: vk::CommandBuffer,
}

impl Drop for PassObjects {
    fn drop(&mut self) {
        let device = self.ctx.device();
        // SAFETY: the one submission was waited for (or never made); null handles are
        // valid to destroy.
        unsafe {
            for &p in &self.pipelines {
                device.destroy_pipeline(p, None);
            }
            for &l in &self.layouts {
                device.destroy_pipeline_layout(l, None);
            }
            for &m in &self.modules {
                device.destroy_shader_module(m, None);
            }
            device.destroy_query_pool(self.query_pool, None);
        }
        if self.cmd != vk::CommandBuffer::null() {
            self.ctx.free_command_buffer(self.cmd);
        }
    }
}

impl PassObjects {
    pub fn module(
        &mut self,
        path: &str,
        stage: ShaderStage,
        name: &str,
    ) -> Result<vk::ShaderModule, GpuError> {
        let code = compile_glsl(path, stage, &[])?;
        let info = vk::ShaderModuleCreateInfo::default().code(&code);
        // SAFETY: SPIR-V words from shaderc; the handle is stored for Drop at once.
        let module = unsafe { self.ctx.device().create_shader_module(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateShaderModule", name, e))?;
        self.modules.push(module);
        self.ctx.set_name(module, name);
        Ok(module)
    }

    pub fn layout(
        &mut self,
        set_layouts: &[vk::DescriptorSetLayout],
        push: vk::PushConstantRange,
        name: &str,
    ) -> Result<vk::PipelineLayout, GpuError> {
        let ranges = [push];
        let info = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(set_layouts)
            .push_constant_ranges(&ranges);
        // SAFETY: the create-info borrows locals alive for the call.
        let layout = unsafe { self.ctx.device().create_pipeline_layout(&info, None) }
            .map_err(|e| GpuError::vulkan("vkCreatePipelineLayout", name, e))?;
        self.layouts.push(layout);
        self.ctx.set_name(layout, name);
        Ok(layout)
    }

    /// A triangle-list pipeline into `target` with depth test LESS + write, no culling,
    /// no blending, dynamic scissor.
    #[allow(clippy::too_many_arguments)]
    pub fn pipeline(
        &mut self,
        target: &RenderTarget,
        layout: vk::PipelineLayout,
        vertex: vk::ShaderModule,
        fragment: vk::ShaderModule,
        stride: u32,
        attributes: &[(u32, vk::Format, u32)],
        name: &str,
    ) -> Result<vk::Pipeline, GpuError> {
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vertex)
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fragment)
                .name(c"main"),
        ];
        let bindings = [vk::VertexInputBindingDescription {
            binding: 0,
            stride,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let attrs: Vec<_> = attributes
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
            .vertex_binding_descriptions(&bindings)
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
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewports(&viewports)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .render_pass(target.render_pass())
            .subpass(0);
        // SAFETY: every state struct borrows locals alive for the call; the handle is
        // stored for Drop at once.
        let pipeline = unsafe {
            self.ctx
                .device()
                .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None)
        }
        .map_err(|(_, e)| GpuError::vulkan("vkCreateGraphicsPipelines", name, e))?[0];
        self.pipelines.push(pipeline);
        self.ctx.set_name(pipeline, name);
        Ok(pipeline)
    }
}
