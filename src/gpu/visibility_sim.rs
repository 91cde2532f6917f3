//! The Vulkan half of the GPU visibility simulator (PRT course, "GPU simulator";
//! `crate::bake::gpu_visibility` prepares the data and states the math). Per direction d
//! of the bake's set, in command buffers of [`DIRECTIONS_PER_SUBMIT`] directions:
//!
//! 1. **depth** — the scene drawn orthographically along d into an RG32F target holding the
//!    sky distance of the nearest surface and its triangle (`glsl/bake/depth.*`), copied to
//!    a buffer;
//! 2. **mark** — one invocation per point sets bit d of its visibility mask when nothing
//!    in the map lies nearer the sky than the point by more than the bias and no triangle
//!    of the 3 × 3 map texels around it lies on its ray (`glsl/bake/mark.comp`).
//!
//! Then **project** (`glsl/bake/project.comp`) sums w·y_i(d) over each point's visible
//! directions into its coefficients and forms its AO. Timestamps bracket the direction
//! passes and the projection where the queue has them.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::compute::{ComputePipeline, ComputePipelineDesc};
use super::descriptors::Resource;
use super::pass::device_local_buffer;
use super::pass_objects::PassObjects;
use super::shader::{ShaderStage, compile_glsl};
use super::target::DEPTH_MAP_FORMAT;
use super::{Buffer, Context, GpuError, RenderTarget};

/// Directions recorded into one command buffer (one progress step).
pub const DIRECTIONS_PER_SUBMIT: usize = 16;
/// Before the direction passes, after them, after the projection.
const TIMESTAMPS: u32 = 3;
/// Cleared sky distance: no surface.
const EMPTY_SKY: f32 = 1e30;

/// The view of one direction, as `glsl/include/sim_view.glsl`'s push constants
/// (`DirectionView`) lay it out.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DirectionView {
    /// xyz: the image's x axis; w: the window's centre along it.
    pub axis_u: [f32; 4],
    /// xyz: the image's y axis; w: the window's centre along it.
    pub axis_v: [f32; 4],
    /// xyz: d; w: the sky plane along d.
    pub axis_d: [f32; 4],
    /// xyz: the scene box's centre; w: constant bias, metres.
    pub centre: [f32; 4],
    /// x, y: the window's half extents; z: the sky range; w: bias per unit tan θ, metres.
    pub window: [f32; 4],
    pub res: u32,
    pub direction: u32,
    pub point_count: u32,
    pub mask_words: u32,
    /// Smallest hit distance the exact silhouette test counts, metres.
    pub t_min: f32,
    /// The ray origins' offset along the normal, metres.
    pub epsilon: f32,
    pub pad: [u32; 2],
}
super::layout::glsl_block!(DirectionView = "DirectionView" {
    axis_u,
    axis_v,
    axis_d,
    centre,
    window,
    res,
    direction,
    point_count,
    mask_words,
    t_min,
    epsilon,
    pad,
});

/// Everything one simulation needs.
pub struct SimulationJob<'a> {
    /// Depth-map texels per side.
    pub res: u32,
    /// Triangle corners, unindexed: triangle t is corners 3t, 3t + 1, 3t + 2 (the depth
    /// pass's triangle ids, `glsl/bake/depth.vert`), xyz f32 each.
    pub positions: &'a [[f32; 3]],
    /// Per point: ray origin then unit normal (w unused).
    pub points: &'a [[f32; 4]],
    /// One view per direction of the set, in order (`direction` = index).
    pub views: &'a [DirectionView],
    /// The directions again, xyz, for the AO.
    pub directions: &'a [[f32; 4]],
    /// w·y_i(d_r), direction-major, `coeff_count` per direction.
    pub weighted_basis: &'a [f32],
    pub coeff_count: u32,
    /// Called after each submission with the directions done so far.
    pub progress: &'a (dyn Fn(usize) + Sync),
}

/// What [`run`] returns.
pub struct SimulationResult {
    /// `coeff_count` per point.
    pub coeffs: Vec<f32>,
    pub ao: Vec<f32>,
    /// Visibility bits per point, `mask_words` u32 each (bit r = direction r escapes).
    pub masks: Vec<u32>,
    /// GPU ms of the direction passes and of the projection (`None` without timestamps).
    pub gpu_ms: Option<(f64, f64)>,
    /// Uploads, shader compiles, pipelines, seconds.
    pub setup_s: f64,
    /// Submissions to readback, seconds.
    pub execute_s: f64,
}

fn storage_buffer(ctx: &Arc<Context>, bytes: u64, name: &str) -> Result<Buffer, GpuError> {
    Buffer::new(
        ctx,
        bytes.max(4),
        vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::GpuOnly,
        name,
    )
}

/// Runs one simulation (module doc).
///
/// # Errors
/// A depth map beyond the device's framebuffer limit, empty input, or a failing Vulkan
/// call.
pub fn run(ctx: &Arc<Context>, job: &SimulationJob<'_>) -> Result<SimulationResult, GpuError> {
    let setup = Instant::now();
    let name = NAME;
    if job.positions.len() < 3 || job.points.is_empty() || job.views.is_empty() {
        return Err(GpuError::Invalid {
            what: name.into(),
            detail: "nothing to simulate (no triangles, points or directions)".into(),
        });
    }
    let res = job.res;
    let sizes = Sizes::of(job);
    let (point_count, mask_words, coeff_count) =
        (sizes.point_count, sizes.mask_words, sizes.coeff_count);
    let target = RenderTarget::with_format(ctx, res, res, DEPTH_MAP_FORMAT)?;
    if !job.positions.len().is_multiple_of(3) || job.positions.len() / 3 >= 1 << 24 {
        return Err(GpuError::Invalid {
            what: name.into(),
            detail: "the simulator takes whole triangles, fewer than 2^24".into(),
        });
    }
    // One buffer for the depth pass's vertices and the mark pass's exact test.
    let corners: Vec<[f32; 4]> = job
        .positions
        .iter()
        .map(|p| [p[0], p[1], p[2], 1.0])
        .collect();
    let triangles = device_local_buffer(
        ctx,
        bytemuck::cast_slice(&corners),
        vk::BufferUsageFlags::VERTEX_BUFFER | vk::BufferUsageFlags::STORAGE_BUFFER,
        "bake.gpu-visibility.triangles",
    )?;
    let points = device_local_buffer(
        ctx,
        bytemuck::cast_slice(job.points),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "bake.gpu-visibility.points",
    )?;
    let basis = device_local_buffer(
        ctx,
        bytemuck::cast_slice(job.weighted_basis),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "bake.gpu-visibility.weighted-basis",
    )?;
    let directions = device_local_buffer(
        ctx,
        bytemuck::cast_slice(job.directions),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "bake.gpu-visibility.directions",
    )?;
    let depth = storage_buffer(
        ctx,
        u64::from(res) * u64::from(res) * 8,
        "bake.gpu-visibility.depth",
    )?;
    let masks = storage_buffer(
        ctx,
        point_count * mask_words * 4,
        "bake.gpu-visibility.masks",
    )?;
    let coeffs = storage_buffer(
        ctx,
        point_count * coeff_count * 4,
        "bake.gpu-visibility.coeffs",
    )?;
    let ao = storage_buffer(ctx, point_count * 4, "bake.gpu-visibility.ao")?;
    let out_bytes = point_count * (mask_words + coeff_count + 1) * 4;
    let readback = Buffer::new(
        ctx,
        out_bytes,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
        "bake.gpu-visibility.readback",
    )?;
    let mark = mark_pipeline(ctx, &depth, &points, &masks, &triangles)?;
    let project = project_pipeline(ctx, &points, &masks, &basis, &directions, &coeffs, &ao)?;
    let mut objects = PassObjects::new(ctx);
    let depth_pass = depth_pipeline(&mut objects, &target)?;
    let timed = objects.timestamps(TIMESTAMPS, "bake.gpu-visibility.timestamps")?;
    let setup_s = setup.elapsed().as_secs_f64();
    let execute = Instant::now();

    SimulationCommands {
        ctx,
        job,
        sizes,
        objects: &objects,
        timed,
        target: &target,
        depth_pass,
        triangles: &triangles,
        depth: &depth,
        masks: &masks,
        coeffs: &coeffs,
        ao: &ao,
        readback: &readback,
        mark: &mark,
        project: &project,
    }
    .submit_all()?;
    let gpu_ms = objects
        .timestamp_ms(TIMESTAMPS as usize - 1, name)?
        .map(|ms| (ms[0], ms[1]));
    let words: &[u32] = bytemuck::cast_slice(readback.read()?);
    let (m, rest) = words.split_at((point_count * mask_words) as usize);
    let (c, a) = rest.split_at((point_count * coeff_count) as usize);
    Ok(SimulationResult {
        masks: m.to_vec(),
        coeffs: bytemuck::cast_slice(c).to_vec(),
        ao: bytemuck::cast_slice(a).to_vec(),
        gpu_ms,
        setup_s,
        execute_s: execute.elapsed().as_secs_f64(),
    })
}

/// The simulator's name: its command buffers' label and the `what` of its errors.
const NAME: &str = "bake.gpu-visibility";

/// A simulation's sizes: points, u32 words of a point's visibility mask, coefficients per
/// point.
#[derive(Clone, Copy)]
struct Sizes {
    point_count: u64,
    mask_words: u64,
    coeff_count: u64,
}

impl Sizes {
    fn of(job: &SimulationJob<'_>) -> Self {
        Sizes {
            point_count: job.points.len() as u64,
            mask_words: job.views.len().div_ceil(32) as u64,
            coeff_count: u64::from(job.coeff_count),
        }
    }
}

/// The mark pass (module doc): per point, bit d of its mask from the depth map and the
/// triangles.
fn mark_pipeline(
    ctx: &Arc<Context>,
    depth: &Buffer,
    points: &Buffer,
    masks: &Buffer,
    triangles: &Buffer,
) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "bake.gpu-visibility.mark",
            spirv: &compile_glsl("bake/mark.comp", ShaderStage::Compute, &[])?,
            resources: &[
                (0, Resource::Storage(depth)),
                (1, Resource::Storage(points)),
                (2, Resource::Storage(masks)),
                (3, Resource::Storage(triangles)),
            ],
            push_constant_bytes: size_of::<DirectionView>() as u32,
        },
    )
}

/// The projection pass (module doc): each point's masks into its coefficients and AO.
fn project_pipeline(
    ctx: &Arc<Context>,
    points: &Buffer,
    masks: &Buffer,
    basis: &Buffer,
    directions: &Buffer,
    coeffs: &Buffer,
    ao: &Buffer,
) -> Result<ComputePipeline, GpuError> {
    ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: "bake.gpu-visibility.project",
            spirv: &compile_glsl("bake/project.comp", ShaderStage::Compute, &[])?,
            resources: &[
                (0, Resource::Storage(points)),
                (1, Resource::Storage(masks)),
                (2, Resource::Storage(basis)),
                (3, Resource::Storage(directions)),
                (4, Resource::Storage(coeffs)),
                (5, Resource::Storage(ao)),
            ],
            push_constant_bytes: 16,
        },
    )
}

/// The depth pass's pipeline and its layout (owned by `objects`).
#[derive(Clone, Copy)]
struct DepthPass {
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
}

/// Builds the depth pass's shader modules, layout and pipeline into `objects`.
fn depth_pipeline(objects: &mut PassObjects, target: &RenderTarget) -> Result<DepthPass, GpuError> {
    let vs = objects.module(
        "bake/depth.vert",
        ShaderStage::Vertex,
        "bake.gpu-visibility.depth.vert",
    )?;
    let fs = objects.module(
        "bake/depth.frag",
        ShaderStage::Fragment,
        "bake.gpu-visibility.depth.frag",
    )?;
    let layout = objects.layout(
        &[],
        vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX,
            offset: 0,
            size: size_of::<DirectionView>() as u32,
        },
        "bake.gpu-visibility.depth",
    )?;
    let pipeline = objects.pipeline(
        target,
        layout,
        vs,
        fs,
        16,
        &[(0, vk::Format::R32G32B32_SFLOAT, 0)],
        "bake.gpu-visibility.depth",
    )?;
    Ok(DepthPass { layout, pipeline })
}

/// Everything the simulation's command buffers record (module doc), all alive until the
/// last of their waited submissions completes.
struct SimulationCommands<'a> {
    ctx: &'a Context,
    job: &'a SimulationJob<'a>,
    sizes: Sizes,
    objects: &'a PassObjects,
    /// Whether `objects` has timestamp queries.
    timed: bool,
    target: &'a RenderTarget,
    depth_pass: DepthPass,
    triangles: &'a Buffer,
    depth: &'a Buffer,
    masks: &'a Buffer,
    coeffs: &'a Buffer,
    ao: &'a Buffer,
    readback: &'a Buffer,
    mark: &'a ComputePipeline,
    project: &'a ComputePipeline,
}

impl SimulationCommands<'_> {
    /// Records and submits the directions, [`DIRECTIONS_PER_SUBMIT`] to a command buffer
    /// (the first also clears the masks, the last also projects and reads back), reporting
    /// progress after each.
    fn submit_all(&self) -> Result<(), GpuError> {
        let (ctx, job) = (self.ctx, self.job);
        // No surface: nothing nearer the sky, no triangle.
        let clears = RenderTarget::clears([EMPTY_SKY, 0.0, 0.0, 0.0]);
        let begin_pass = self.target.begin_info(&clears);
        let chunks: Vec<&[DirectionView]> = job.views.chunks(DIRECTIONS_PER_SUBMIT).collect();
        let last = chunks.len() - 1;
        let mut done = 0;
        for (k, chunk) in chunks.iter().enumerate() {
            ctx.one_shot(NAME, |cmd| {
                if k == 0 {
                    self.record_start(cmd);
                }
                for view in chunk.iter() {
                    self.record_direction(cmd, &begin_pass, self.target.area(), view);
                }
                if k == last {
                    self.record_projection(cmd);
                }
            })?;
            done += chunk.len();
            (job.progress)(done);
        }
        Ok(())
    }

    /// Workgroups of the compute passes: 64 points each.
    fn groups(&self) -> u32 {
        self.sizes.point_count.div_ceil(64) as u32
    }

    /// Before the first direction: resets the timestamps, clears the masks, writes the
    /// first timestamp.
    fn record_start(&self, cmd: vk::CommandBuffer) {
        let device = self.ctx.device();
        // SAFETY (this block): `cmd` is recording; every object recorded lives until
        // one_shot's waited submission completes (locals of `run`).
        unsafe {
            if self.timed {
                device.cmd_reset_query_pool(cmd, self.objects.query_pool, 0, TIMESTAMPS);
            }
            device.cmd_fill_buffer(cmd, self.masks.raw(), 0, vk::WHOLE_SIZE, 0);
        }
        self.barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE,
        );
        self.timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, 0);
    }

    /// One direction: the depth pass along it, copied to `depth`, then the mark pass.
    fn record_direction(
        &self,
        cmd: vk::CommandBuffer,
        begin_pass: &vk::RenderPassBeginInfo<'_>,
        full: vk::Rect2D,
        view: &DirectionView,
    ) {
        let (ctx, DepthPass { layout, pipeline }) = (self.ctx, self.depth_pass);
        let device = ctx.device();
        let push = bytemuck::bytes_of(view);
        ctx.begin_label(cmd, "bake.gpu-visibility.depth");
        // SAFETY (this block): `cmd` is recording; every object recorded lives until
        // one_shot's waited submission completes (locals of `run`).
        unsafe {
            device.cmd_begin_render_pass(cmd, begin_pass, vk::SubpassContents::INLINE);
            device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            device.cmd_set_scissor(cmd, 0, &[full]);
            device.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::VERTEX, 0, push);
            device.cmd_bind_vertex_buffers(cmd, 0, &[self.triangles.raw()], &[0]);
            device.cmd_draw(cmd, self.job.positions.len() as u32, 1, 0, 0);
            device.cmd_end_render_pass(cmd);
        }
        self.target.record_copy_to_buffer(cmd, self.depth, 0);
        ctx.end_label(cmd);
        self.barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::SHADER_READ,
        );
        self.mark.record(cmd, [self.groups(), 1, 1], push);
        // The next copy overwrites the map the mark pass read; the next mark
        // reads the masks this one wrote.
        self.barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::PipelineStageFlags::TRANSFER | vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_WRITE,
            vk::AccessFlags::TRANSFER_WRITE
                | vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE,
        );
    }

    /// After the last direction: the projection pass, then the masks, coefficients and AO
    /// copied into `readback`, one after another.
    fn record_projection(&self, cmd: vk::CommandBuffer) {
        let device = self.ctx.device();
        let job = self.job;
        let Sizes {
            point_count,
            mask_words,
            coeff_count,
        } = self.sizes;
        self.timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, 1);
        let push: Vec<u8> = [
            point_count as u32,
            job.coeff_count,
            mask_words as u32,
            job.views.len() as u32,
        ]
        .iter()
        .flat_map(|v| v.to_ne_bytes())
        .collect();
        self.project.record(cmd, [self.groups(), 1, 1], &push);
        self.barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::SHADER_WRITE,
            vk::AccessFlags::TRANSFER_READ,
        );
        self.timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, 2);
        let mut offset = 0;
        for (src, bytes) in [
            (self.masks, point_count * mask_words * 4),
            (self.coeffs, point_count * coeff_count * 4),
            (self.ao, point_count * 4),
        ] {
            if bytes > 0 {
                let copy = vk::BufferCopy::default().dst_offset(offset).size(bytes);
                // SAFETY: `cmd` is recording; both buffers live until one_shot's waited
                // submission completes (locals of `run`).
                unsafe { device.cmd_copy_buffer(cmd, src.raw(), self.readback.raw(), &[copy]) };
            }
            offset += bytes;
        }
        self.barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::HOST_READ,
        );
    }

    /// Records a global memory barrier into `cmd`.
    fn barrier(
        &self,
        cmd: vk::CommandBuffer,
        src_stage: vk::PipelineStageFlags,
        dst_stage: vk::PipelineStageFlags,
        src_access: vk::AccessFlags,
        dst_access: vk::AccessFlags,
    ) {
        self.objects
            .barrier(cmd, (src_stage, dst_stage), (src_access, dst_access));
    }

    /// Writes timestamp `query` at `stage` (nothing where the queue has no timestamps).
    fn timestamp(&self, cmd: vk::CommandBuffer, stage: vk::PipelineStageFlags, query: u32) {
        self.objects.timestamp(cmd, stage, query);
    }
}
