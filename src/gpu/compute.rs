//! Compute pipelines: one shader, one descriptor set, optional push constants, and a
//! dispatch that waits and makes storage-buffer writes visible to the host.

use std::sync::Arc;

use ash::vk;

use super::descriptors::{DescriptorSet, Resource};
use super::{Context, GpuError};

/// Everything needed to build a [`ComputePipeline`].
pub struct ComputePipelineDesc<'a> {
    /// Debug name: "study.params.cube-dx10".
    pub name: &'a str,
    pub spirv: &'a [u32],
    pub resources: &'a [(u32, Resource<'a>)],
    /// Size of the push-constant block (0 for none).
    pub push_constant_bytes: u32,
}

/// A compute pipeline with its descriptor set.
pub struct ComputePipeline {
    ctx: Arc<Context>,
    name: String,
    descriptors: DescriptorSet,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    module: vk::ShaderModule,
    push_constant_bytes: u32,
}

impl ComputePipeline {
    pub fn new(ctx: &Arc<Context>, desc: &ComputePipelineDesc<'_>) -> Result<Self, GpuError> {
        let name = desc.name;
        let mut p = ComputePipeline {
            ctx: ctx.clone(),
            name: name.to_string(),
            descriptors: DescriptorSet::new(
                ctx,
                desc.resources,
                vk::ShaderStageFlags::COMPUTE,
                name,
            )?,
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            module: vk::ShaderModule::null(),
            push_constant_bytes: desc.push_constant_bytes,
        };
        let device = ctx.device();
        let set_layouts = [p.descriptors.layout];
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::COMPUTE,
            offset: 0,
            size: desc.push_constant_bytes,
        }];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if desc.push_constant_bytes > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        // SAFETY (this and below): create-infos borrow locals alive for each call; handles
        // are stored in `p` at once so Drop destroys them on any error.
        p.layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreatePipelineLayout", name, e))?;
        ctx.set_name(p.layout, name);
        let module_info = vk::ShaderModuleCreateInfo::default().code(desc.spirv);
        // SAFETY: see above; SPIR-V words from shaderc.
        p.module = unsafe { device.create_shader_module(&module_info, None) }
            .map_err(|e| GpuError::vulkan("vkCreateShaderModule", name, e))?;
        ctx.set_name(p.module, name);
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(p.module)
            .name(c"main");
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(p.layout);
        // SAFETY: see above.
        p.pipeline =
            unsafe { device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) }
                .map_err(|(_, e)| GpuError::vulkan("vkCreateComputePipelines", name, e))?[0];
        ctx.set_name(p.pipeline, name);
        Ok(p)
    }

    /// Dispatches `groups` work groups with `push_constants`, waits, and makes shader
    /// writes to storage buffers visible to host reads.
    pub fn dispatch(&self, groups: [u32; 3], push_constants: &[u8]) -> Result<(), GpuError> {
        if push_constants.len() as u32 != self.push_constant_bytes {
            return Err(GpuError::Invalid {
                what: self.name.clone(),
                detail: format!(
                    "{} push-constant bytes given, {} declared",
                    push_constants.len(),
                    self.push_constant_bytes
                ),
            });
        }
        let device = self.ctx.device();
        self.ctx.one_shot(&self.name, |cmd| {
            self.record(cmd, groups, push_constants);
            let to_host = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            // SAFETY: recording into the command buffer one_shot waits for.
            unsafe {
                device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::COMPUTE_SHADER,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[to_host],
                    &[],
                    &[],
                );
            }
        })
    }

    /// Records one dispatch into `cmd` (no barrier): for callers that chain several
    /// passes in one command buffer. `push_constants` must match the declared size.
    pub(crate) fn record(&self, cmd: vk::CommandBuffer, groups: [u32; 3], push_constants: &[u8]) {
        let device = self.ctx.device();
        // SAFETY: `cmd` is recording; the pipeline, layout and set are owned by `self`,
        // which the caller keeps alive until the submission completes.
        unsafe {
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.descriptors.set],
                &[],
            );
            if !push_constants.is_empty() {
                device.cmd_push_constants(
                    cmd,
                    self.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    push_constants,
                );
            }
            device.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
        }
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        // SAFETY: dispatches are waited for; null handles are valid to destroy; the
        // descriptor set drops after this (field order).
        unsafe {
            let device = self.ctx.device();
            device.destroy_pipeline(self.pipeline, None);
            device.destroy_shader_module(self.module, None);
            device.destroy_pipeline_layout(self.layout, None);
        }
    }
}
