//! The Vulkan half of GPU normal-map generation (`crate::normalmap::gpu` prepares the
//! data; Gumbau et al. §3). One command buffer, three timed phases:
//!
//! 1. **mask** — the low mesh drawn in texture space into the RGBA32F target, each texel
//!    recording its owning triangle (`glsl/normalmap/mask.*`); copied to a storage buffer.
//!    This is the paper's stencil generalised to all low triangles at once.
//! 2. **project** — the high mesh drawn once per low triangle T (`project.vert`,
//!    `normal.frag`): either one `vkCmdDrawIndexedIndirect` holding a command per T, or one
//!    `vkCmdDrawIndexed` per T under a scissor around T's texels. The depth buffer is
//!    cleared once: the mask gives every texel to one T, so depths of different Ts never
//!    meet. Copied to the first half of the expansion buffer.
//! 3. **expand** — `passes` border-expansion dispatches (`expand.comp`), ping-pong between
//!    the buffer's halves; the last half is read back.
//!
//! Timestamps bracket the phases where the queue has them.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::compute::{ComputePipeline, ComputePipelineDesc};
use super::descriptors::{DescriptorSet, Resource};
use super::pass::device_local_buffer;
use super::pass_objects::PassObjects;
use super::shader::{ShaderStage, compile_glsl};
use super::target::COLOR_FORMAT_F32;
use super::{Buffer, Context, GpuError, RenderTarget};

/// One low triangle's render of the high mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProjectionDraw {
    /// The low triangle (the draw's `firstInstance`, the view index).
    pub triangle: u32,
    pub first_index: u32,
    pub index_count: u32,
    /// Texels the triangle may write: [x0, y0, x1, y1), for the scissor of direct draws.
    pub scissor: [u32; 4],
}

/// Everything one bake needs, as bytes in the shaders' layouts.
pub struct ProjectionJob<'a> {
    pub res: u32,
    /// Low mesh, de-indexed: per corner `vec2 uv` + `uint triangle` (12 bytes).
    pub mask_vertices: &'a [u8],
    pub low_triangles: u32,
    /// High mesh: per vertex `vec3 position` + `vec3 normal` (24 bytes).
    pub high_vertices: &'a [u8],
    pub high_indices: &'a [u32],
    /// Per low triangle two column-major mat4 (view_from_world, clip_from_view).
    pub views: &'a [u8],
    pub draws: &'a [ProjectionDraw],
    /// One multi-draw indirect call (needs `multiDrawIndirect`); else direct draws.
    pub indirect: bool,
    pub max_distance: f32,
    pub mirror: bool,
    pub expand_passes: u32,
}

/// GPU time of each phase, ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PhaseMs {
    pub mask: f64,
    pub project: f64,
    pub expand: f64,
}

/// What [`run`] returns.
pub struct ProjectionResult {
    /// res² RGBA texels, row-major (object normal, coverage in w).
    pub texels: Vec<[f32; 4]>,
    /// `None` where the queue has no timestamps.
    pub gpu_ms: Option<PhaseMs>,
    /// Uploads, shader compiles and pipeline creation, seconds.
    pub setup_s: f64,
    /// Submission to completion of the one command buffer plus readback, seconds.
    pub execute_s: f64,
}

const MASK_VERTEX_BYTES: u32 = 12;
const HIGH_VERTEX_BYTES: u32 = 24;
const INDIRECT_COMMAND_BYTES: u32 = 20;
const TIMESTAMPS: u32 = 4;
/// Bytes of an RGBA32F texel, in the target and the buffers.
const TEXEL_BYTES: u64 = 16;

/// Runs one bake (module doc).
///
/// # Errors
/// A size beyond the device's limits, indirect draws without `multiDrawIndirect`, or a
/// failing Vulkan call.
pub fn run(ctx: &Arc<Context>, job: &ProjectionJob<'_>) -> Result<ProjectionResult, GpuError> {
    let setup = Instant::now();
    let name = NAME;
    check_job(ctx, job)?;
    let res = job.res;
    let texels = res as u64 * res as u64;
    let target = RenderTarget::with_format(ctx, res, res, COLOR_FORMAT_F32)?;
    let mask_vb = device_local_buffer(
        ctx,
        job.mask_vertices,
        vk::BufferUsageFlags::VERTEX_BUFFER,
        "normalmap.mask.vertices",
    )?;
    let high_vb = device_local_buffer(
        ctx,
        job.high_vertices,
        vk::BufferUsageFlags::VERTEX_BUFFER,
        "normalmap.high.vertices",
    )?;
    let high_ib = device_local_buffer(
        ctx,
        bytemuck::cast_slice(job.high_indices),
        vk::BufferUsageFlags::INDEX_BUFFER,
        "normalmap.high.indices",
    )?;
    let views = device_local_buffer(
        ctx,
        job.views,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "normalmap.views",
    )?;
    let indirect = indirect_commands(ctx, job)?;
    let mask = Buffer::new(
        ctx,
        texels * TEXEL_BYTES,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuOnly,
        "normalmap.mask",
    )?;
    let expand = Buffer::new(
        ctx,
        2 * texels * TEXEL_BYTES,
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
        "normalmap.expand",
    )?;
    let readback = Buffer::new(
        ctx,
        texels * TEXEL_BYTES,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
        "normalmap.readback",
    )?;
    let projection_set = DescriptorSet::new(
        ctx,
        &[
            (0, Resource::Storage(&views)),
            (1, Resource::Storage(&mask)),
        ],
        vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
        "normalmap.project",
    )?;
    let expand_pipeline = ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "normalmap.expand",
            spirv: &compile_glsl("normalmap/expand.comp", ShaderStage::Compute, &[])?,
            resources: &[(0, Resource::Storage(&expand))],
            push_constant_bytes: 12,
        },
    )?;

    let mut objects = PassObjects::new(ctx);
    let draw = draw_pipelines(&mut objects, &target, &projection_set)?;
    let timed = objects.timestamps(TIMESTAMPS, "normalmap.timestamps")?;
    objects.cmd = ctx.allocate_command_buffer(name)?;
    let cmd = objects.cmd;
    let setup_s = setup.elapsed().as_secs_f64();

    BakeCommands {
        ctx,
        job,
        texels,
        cmd,
        objects: &objects,
        timed,
        target: &target,
        draw,
        mask_vb: &mask_vb,
        high_vb: &high_vb,
        high_ib: &high_ib,
        indirect: indirect.as_ref(),
        projection_set: &projection_set,
        expand_pipeline: &expand_pipeline,
        mask: &mask,
        expand: &expand,
        readback: &readback,
    }
    .record()?;
    let execute = Instant::now();
    ctx.submit_and_wait(cmd, name)?;
    let gpu_ms = objects
        .timestamp_ms(TIMESTAMPS as usize - 1, name)?
        .map(|ms| PhaseMs {
            mask: ms[0],
            project: ms[1],
            expand: ms[2],
        });
    let texels: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(readback.read()?);
    Ok(ProjectionResult {
        texels,
        gpu_ms,
        setup_s,
        execute_s: execute.elapsed().as_secs_f64(),
    })
}

/// The bake's name: its command buffer's label and the `what` of its errors.
const NAME: &str = "normalmap";

/// Refuses a job this device cannot run (indirect draws without `multiDrawIndirect`) or
/// that draws nothing.
fn check_job(ctx: &Context, job: &ProjectionJob<'_>) -> Result<(), GpuError> {
    let invalid = |detail: String| GpuError::Invalid {
        what: NAME.into(),
        detail,
    };
    if job.indirect && !ctx.supports_multi_draw_indirect() {
        return Err(invalid(
            "this device lacks multiDrawIndirect / drawIndirectFirstInstance: use direct draws"
                .into(),
        ));
    }
    if job.draws.is_empty() || job.high_indices.is_empty() || job.mask_vertices.is_empty() {
        return Err(invalid("nothing to draw".into()));
    }
    Ok(())
}

/// The indirect buffer of one draw command per low triangle, where the job draws
/// indirectly.
fn indirect_commands(
    ctx: &Arc<Context>,
    job: &ProjectionJob<'_>,
) -> Result<Option<Buffer>, GpuError> {
    if !job.indirect {
        return Ok(None);
    }
    let commands: Vec<u32> = job
        .draws
        .iter()
        .flat_map(|d| [d.index_count, 1, d.first_index, 0, d.triangle])
        .collect();
    Ok(Some(device_local_buffer(
        ctx,
        bytemuck::cast_slice(&commands),
        vk::BufferUsageFlags::INDIRECT_BUFFER,
        "normalmap.draws",
    )?))
}

/// The graphics pipelines of the mask and project phases and their layouts (owned by the
/// `PassObjects` that made them).
#[derive(Clone, Copy)]
struct DrawPipelines {
    mask_layout: vk::PipelineLayout,
    mask: vk::Pipeline,
    project_layout: vk::PipelineLayout,
    project: vk::Pipeline,
}

/// Builds the mask and project phases' shader modules, layouts and pipelines into
/// `objects`.
fn draw_pipelines(
    objects: &mut PassObjects,
    target: &RenderTarget,
    projection_set: &DescriptorSet,
) -> Result<DrawPipelines, GpuError> {
    let mask_vs = objects.module(
        "normalmap/mask.vert",
        ShaderStage::Vertex,
        "normalmap.mask.vert",
    )?;
    let mask_fs = objects.module(
        "normalmap/mask.frag",
        ShaderStage::Fragment,
        "normalmap.mask.frag",
    )?;
    let project_vs = objects.module(
        "normalmap/project.vert",
        ShaderStage::Vertex,
        "normalmap.project.vert",
    )?;
    let project_fs = objects.module(
        "normalmap/normal.frag",
        ShaderStage::Fragment,
        "normalmap.normal.frag",
    )?;
    let mask_layout = objects.layout(
        &[],
        vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX,
            offset: 0,
            size: 4,
        },
        "normalmap.mask",
    )?;
    let project_layout = objects.layout(
        &[projection_set.layout],
        vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            offset: 0,
            size: 12,
        },
        "normalmap.project",
    )?;
    let mask_pipeline = objects.pipeline(
        target,
        mask_layout,
        mask_vs,
        mask_fs,
        MASK_VERTEX_BYTES,
        &[
            (0, vk::Format::R32G32_SFLOAT, 0),
            (1, vk::Format::R32_UINT, 8),
        ],
        "normalmap.mask",
    )?;
    let project_pipeline = objects.pipeline(
        target,
        project_layout,
        project_vs,
        project_fs,
        HIGH_VERTEX_BYTES,
        &[
            (0, vk::Format::R32G32B32_SFLOAT, 0),
            (1, vk::Format::R32G32B32_SFLOAT, 12),
        ],
        "normalmap.project",
    )?;
    Ok(DrawPipelines {
        mask_layout,
        mask: mask_pipeline,
        project_layout,
        project: project_pipeline,
    })
}

/// Everything the bake's one command buffer records (module doc), all alive until its
/// waited submission in [`run`] completes.
struct BakeCommands<'a> {
    ctx: &'a Context,
    job: &'a ProjectionJob<'a>,
    /// res².
    texels: u64,
    /// Freshly allocated, owned by `objects`.
    cmd: vk::CommandBuffer,
    objects: &'a PassObjects,
    /// Whether `objects` has timestamp queries.
    timed: bool,
    target: &'a RenderTarget,
    draw: DrawPipelines,
    mask_vb: &'a Buffer,
    high_vb: &'a Buffer,
    high_ib: &'a Buffer,
    indirect: Option<&'a Buffer>,
    projection_set: &'a DescriptorSet,
    expand_pipeline: &'a ComputePipeline,
    mask: &'a Buffer,
    expand: &'a Buffer,
    readback: &'a Buffer,
}

impl BakeCommands<'_> {
    /// Records the three phases and the readback copy into `cmd`.
    fn record(&self) -> Result<(), GpuError> {
        let (ctx, cmd) = (self.ctx, self.cmd);
        let device = ctx.device();
        let full = self.target.area();
        let clears = RenderTarget::clears([0.0; 4]);
        let begin_pass = self.target.begin_info(&clears);
        // SAFETY (this block): `cmd` is freshly allocated; every object recorded lives until
        // the waited submission in `run` completes (its locals and `objects`).
        unsafe {
            device
                .begin_command_buffer(
                    cmd,
                    &vk::CommandBufferBeginInfo::default()
                        .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .map_err(|e| GpuError::vulkan("vkBeginCommandBuffer", NAME, e))?;
            ctx.begin_label(cmd, "normalmap");
            if self.timed {
                device.cmd_reset_query_pool(cmd, self.objects.query_pool, 0, TIMESTAMPS);
            }
        }
        self.timestamp(vk::PipelineStageFlags::TOP_OF_PIPE, 0);
        self.record_mask(&begin_pass, full);
        self.record_project(&begin_pass, full);
        let src = self.record_expand();
        let region = vk::BufferCopy::default()
            .src_offset(u64::from(src) * TEXEL_BYTES)
            .size(self.texels * TEXEL_BYTES);
        // SAFETY (this block): as above.
        unsafe {
            device.cmd_copy_buffer(cmd, self.expand.raw(), self.readback.raw(), &[region]);
            self.barrier(
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::HOST,
                vk::AccessFlags::TRANSFER_WRITE,
                vk::AccessFlags::HOST_READ,
            );
            ctx.end_label(cmd);
            device
                .end_command_buffer(cmd)
                .map_err(|e| GpuError::vulkan("vkEndCommandBuffer", NAME, e))?;
        }
        Ok(())
    }

    /// Phase 1: the low mesh drawn in texture space, each texel recording its triangle,
    /// copied to `mask`.
    fn record_mask(&self, begin_pass: &vk::RenderPassBeginInfo<'_>, full: vk::Rect2D) {
        let (ctx, cmd, job) = (self.ctx, self.cmd, self.job);
        let device = ctx.device();
        // SAFETY (this block): `cmd` is recording (`record`); every object recorded lives
        // until the waited submission in `run` completes.
        unsafe {
            ctx.begin_label(cmd, "normalmap.mask");
            device.cmd_begin_render_pass(cmd, begin_pass, vk::SubpassContents::INLINE);
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.draw.mask);
            device.cmd_set_scissor(cmd, 0, &[full]);
            device.cmd_push_constants(
                cmd,
                self.draw.mask_layout,
                vk::ShaderStageFlags::VERTEX,
                0,
                &job.low_triangles.to_ne_bytes(),
            );
            device.cmd_bind_vertex_buffers(cmd, 0, &[self.mask_vb.raw()], &[0]);
            device.cmd_draw(cmd, 3 * job.low_triangles, 1, 0, 0);
            device.cmd_end_render_pass(cmd);
        }
        self.image_to_buffer(self.mask, 0);
        self.barrier(
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::FRAGMENT_SHADER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::SHADER_READ,
        );
        ctx.end_label(cmd);
        self.timestamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 1);
    }

    /// Phase 2: one render of the high mesh per low triangle (indirect, or direct under
    /// each triangle's scissor), copied to the first half of `expand`.
    fn record_project(&self, begin_pass: &vk::RenderPassBeginInfo<'_>, full: vk::Rect2D) {
        let (ctx, cmd, job, res) = (self.ctx, self.cmd, self.job, self.job.res);
        let device = ctx.device();
        let project_push: Vec<u8> = [job.max_distance.to_bits(), u32::from(job.mirror), res]
            .iter()
            .flat_map(|v| v.to_ne_bytes())
            .collect();
        // SAFETY (this block): `cmd` is recording (`record`); every object recorded lives
        // until the waited submission in `run` completes.
        unsafe {
            ctx.begin_label(cmd, "normalmap.project");
            device.cmd_begin_render_pass(cmd, begin_pass, vk::SubpassContents::INLINE);
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, self.draw.project);
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.draw.project_layout,
                0,
                &[self.projection_set.set],
                &[],
            );
            device.cmd_push_constants(
                cmd,
                self.draw.project_layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                &project_push,
            );
            device.cmd_bind_vertex_buffers(cmd, 0, &[self.high_vb.raw()], &[0]);
            device.cmd_bind_index_buffer(cmd, self.high_ib.raw(), 0, vk::IndexType::UINT32);
            if let Some(commands) = self.indirect {
                device.cmd_set_scissor(cmd, 0, &[full]);
                let per_call = ctx.limits().max_draw_indirect_count.max(1) as usize;
                for (k, chunk) in job.draws.chunks(per_call).enumerate() {
                    device.cmd_draw_indexed_indirect(
                        cmd,
                        commands.raw(),
                        (k * per_call) as u64 * u64::from(INDIRECT_COMMAND_BYTES),
                        chunk.len() as u32,
                        INDIRECT_COMMAND_BYTES,
                    );
                }
            } else {
                for d in job.draws {
                    let [x0, y0, x1, y1] = d.scissor.map(|c| c.min(res));
                    let scissor = vk::Rect2D {
                        offset: vk::Offset2D {
                            x: x0 as i32,
                            y: y0 as i32,
                        },
                        extent: vk::Extent2D {
                            width: x1.saturating_sub(x0),
                            height: y1.saturating_sub(y0),
                        },
                    };
                    device.cmd_set_scissor(cmd, 0, &[scissor]);
                    device.cmd_draw_indexed(cmd, d.index_count, 1, d.first_index, 0, d.triangle);
                }
            }
            device.cmd_end_render_pass(cmd);
        }
        self.image_to_buffer(self.expand, 0);
        self.barrier(
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
        );
        ctx.end_label(cmd);
        self.timestamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 2);
    }

    /// Phase 3: the border-expansion passes, ping-pong between the halves of `expand`;
    /// returns the offset, in texels, of the half the last one wrote.
    fn record_expand(&self) -> u32 {
        let (ctx, cmd, res) = (self.ctx, self.cmd, self.job.res);
        ctx.begin_label(cmd, "normalmap.expand");
        let half = (self.texels as u32, 0u32);
        let groups = res.div_ceil(8);
        let mut src = 0u32;
        for _ in 0..self.job.expand_passes {
            let dst = if src == 0 { half.0 } else { 0 };
            let push: Vec<u8> = [res, src, dst]
                .iter()
                .flat_map(|v| v.to_ne_bytes())
                .collect();
            self.expand_pipeline.record(cmd, [groups, groups, 1], &push);
            self.barrier(
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::SHADER_WRITE,
                vk::AccessFlags::SHADER_READ
                    | vk::AccessFlags::SHADER_WRITE
                    | vk::AccessFlags::TRANSFER_READ,
            );
            src = dst;
        }
        ctx.end_label(cmd);
        self.timestamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 3);
        src
    }

    /// Copies the target (left in TRANSFER_SRC_OPTIMAL by the render passes) into `dst`,
    /// res² texels from `offset`.
    fn image_to_buffer(&self, dst: &Buffer, offset: u64) {
        self.target.record_copy_to_buffer(self.cmd, dst, offset);
    }

    /// Records a global memory barrier into `cmd`.
    fn barrier(
        &self,
        src_stage: vk::PipelineStageFlags,
        dst_stage: vk::PipelineStageFlags,
        src_access: vk::AccessFlags,
        dst_access: vk::AccessFlags,
    ) {
        self.objects
            .barrier(self.cmd, (src_stage, dst_stage), (src_access, dst_access));
    }

    /// Writes timestamp `query` at `stage` (nothing where the queue has no timestamps).
    fn timestamp(&self, stage: vk::PipelineStageFlags, query: u32) {
        self.objects.timestamp(self.cmd, stage, query);
    }
}
