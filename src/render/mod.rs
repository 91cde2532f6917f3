//! The GPU side of a scene shared by all techniques — mesh buffers, material textures
//! (with CPU-built mip chains), samplers, the per-frame uniform block, the offscreen
//! target — and the frame loop that renders a mesh pipeline and reads the image back.
//! Techniques build on it (`technique::TechniqueGpu::render`); it knows none of them.

pub mod specular;

use std::sync::Arc;

use ash::vk;

use crate::gpu::{
    Buffer, Context, GpuError, Image, ImageDesc, MeshBuffers, MeshPipeline, RenderTarget, Resource,
    Sampler, SamplerKind, ShaderStage, VertexLayout, compile_glsl, layout,
};
use crate::scene::{Mesh, Scene, Texture8, Vertex};

/// How a frame is rendered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameSettings {
    pub width: u32,
    pub height: u32,
    /// Replace the material's normal map with the interpolated normal (comparisons).
    pub flat_normals: bool,
    /// Render into RGBA32F instead of RGBA16F (G-buffer passes of the reference).
    pub float32_target: bool,
    /// Techniques built for this scene read the material textures at full resolution
    /// (`SHVIS_MATERIAL_LEVEL0`), for integrating their own shading over a pixel's
    /// footprint by jittered renders (`study ndf`).
    pub material_level0: bool,
}

impl Default for FrameSettings {
    fn default() -> Self {
        FrameSettings {
            width: 1280,
            height: 800,
            flat_normals: false,
            float32_target: false,
            material_level0: false,
        }
    }
}

/// GPU resources of one scene at one frame size.
pub struct SceneGpu {
    target: RenderTarget,
    mesh: MeshBuffers,
    /// The mesh on the CPU, for the cost model's screen edges ([`Self::shading_load`]).
    cpu_mesh: Mesh,
    albedo: Image,
    normal: Image,
    material_sampler: Sampler,
    lightmap_sampler: Sampler,
    frame: Buffer,
    /// The frame block as uploaded with no jitter ([`Self::set_jitter`]).
    frame_params: layout::FrameParams,
    vertex_spirv: Vec<u32>,
    vertex_layout: VertexLayout,
    material_level0: bool,
    specular: Option<crate::render::specular::SceneSpecular>,
    /// Frames shorter than this are timed several to a query (`gpu::frame_timing`).
    min_query_span_ms: f64,
}

impl SceneGpu {
    /// Uploads `scene` and creates the target for `settings`.
    pub fn new(
        ctx: &Arc<Context>,
        scene: &Scene,
        settings: &FrameSettings,
    ) -> Result<Self, GpuError> {
        let format = if settings.float32_target {
            crate::gpu::target::COLOR_FORMAT_F32
        } else {
            crate::gpu::target::COLOR_FORMAT
        };
        let target = RenderTarget::with_format(ctx, settings.width, settings.height, format)?;
        let mesh = MeshBuffers::new(
            ctx,
            bytemuck::cast_slice(&scene.mesh.vertices),
            &scene.mesh.indices,
            "scene.mesh",
        )?;
        let albedo = upload_texture8(
            ctx,
            &scene.material.albedo,
            vk::Format::R8G8B8A8_SRGB,
            true,
            "scene.albedo",
        )?;
        let normal = upload_texture8(
            ctx,
            &scene.material.normal,
            vk::Format::R8G8B8A8_UNORM,
            false,
            "scene.normal_map",
        )?;
        let aspect = settings.width as f32 / settings.height as f32;
        let params = layout::FrameParams {
            clip_from_world: scene.camera.clip_from_world(aspect).to_cols_array_2d(),
            camera_position: scene.camera.position.extend(1.0).to_array(),
            normal_scale: if settings.flat_normals {
                0.0
            } else {
                scene.material.normal_scale
            },
            _pad: [0.0; 3],
        };
        let frame = Buffer::with_data(
            ctx,
            bytemuck::bytes_of(&params),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            "scene.frame_params",
        )?;
        let f = |offset: usize| offset as u32;
        let vertex_layout = VertexLayout {
            stride: std::mem::size_of::<Vertex>() as u32,
            attributes: vec![
                (
                    0,
                    vk::Format::R32G32B32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, position)),
                ),
                (
                    1,
                    vk::Format::R32G32B32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, normal)),
                ),
                (
                    2,
                    vk::Format::R32G32B32A32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, tangent)),
                ),
                (
                    3,
                    vk::Format::R32G32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, uv_material)),
                ),
                (
                    4,
                    vk::Format::R32G32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, uv_lightmap)),
                ),
                (
                    5,
                    vk::Format::R32G32B32_SFLOAT,
                    f(std::mem::offset_of!(Vertex, albedo_tint)),
                ),
            ],
        };
        Ok(SceneGpu {
            target,
            mesh,
            cpu_mesh: scene.mesh.clone(),
            albedo,
            normal,
            material_sampler: Sampler::new(
                ctx,
                SamplerKind::MaterialRepeat,
                "scene.material_sampler",
            )?,
            lightmap_sampler: Sampler::new(
                ctx,
                SamplerKind::LinearClamp,
                "scene.lightmap_sampler",
            )?,
            frame,
            frame_params: params,
            vertex_spirv: compile_glsl(
                "scene/mesh.vert",
                ShaderStage::Vertex,
                &[("GBUFFER", settings.float32_target as u32)],
            )?,
            vertex_layout,
            material_level0: settings.material_level0,
            specular: None,
            min_query_span_ms: crate::gpu::frame_timing::MIN_QUERY_SPAN_MS,
        })
    }

    /// Adds the specular material term `term` to every technique built for this scene
    /// afterwards (`--specular`; `crate::render::specular`): its NDF maps from `scene`'s normal
    /// map, and a vertex stage that passes the world position on.
    pub fn add_specular(
        &mut self,
        ctx: &Arc<Context>,
        scene: &Scene,
        term: crate::render::specular::SpecularTerm,
    ) -> Result<(), GpuError> {
        self.specular = Some(crate::render::specular::SceneSpecular::new(
            ctx,
            &scene.material,
            term,
        )?);
        self.vertex_spirv =
            compile_glsl("scene/mesh.vert", ShaderStage::Vertex, &[("GBUFFER", 1)])?;
        Ok(())
    }

    /// The specular material term techniques add, if any ([`Self::add_specular`]).
    pub fn specular(&self) -> Option<&crate::render::specular::SceneSpecular> {
        self.specular.as_ref()
    }

    /// Times frames shorter than `ms` several to a query (`gpu::frame_timing`; default
    /// `MIN_QUERY_SPAN_MS`): a test forces several draws per query on a slow device.
    pub fn set_min_query_span(&mut self, ms: f64) {
        self.min_query_span_ms = ms;
    }

    /// The bindings every technique shares: frame block, albedo, normal map.
    pub fn common_resources(&self) -> Vec<(u32, Resource<'_>)> {
        vec![
            (layout::BINDING_FRAME, Resource::Uniform(&self.frame)),
            (
                layout::BINDING_ALBEDO,
                Resource::Texture(&self.albedo, &self.material_sampler),
            ),
            (
                layout::BINDING_NORMAL_MAP,
                Resource::Texture(&self.normal, &self.material_sampler),
            ),
        ]
    }
    /// Shifts every later frame by `offset_px` pixels (x right, y down; (0, 0) renders
    /// pixel centres, ±0.5 the pixel's edges): the sub-pixel positions of the reference's
    /// footprint integration. Applied in clip space, x_clip += 2·dx/width · w_clip, so the
    /// rasterizer samples the scene at (x + ½ − dx, y + ½ − dy) of the unshifted image.
    pub fn set_jitter(&mut self, offset_px: [f32; 2]) -> Result<(), GpuError> {
        let (w, h) = (self.target.width() as f32, self.target.height() as f32);
        let shift = glam::Mat4::from_cols(
            glam::Vec4::X,
            glam::Vec4::Y,
            glam::Vec4::Z,
            glam::Vec4::new(2.0 * offset_px[0] / w, 2.0 * offset_px[1] / h, 0.0, 1.0),
        );
        let base = glam::Mat4::from_cols_array_2d(&self.frame_params.clip_from_world);
        let params = layout::FrameParams {
            clip_from_world: (shift * base).to_cols_array_2d(),
            ..self.frame_params
        };
        self.frame.write(bytemuck::bytes_of(&params))
    }

    /// Renders from `camera` from now on (`shvis view`'s orbit).
    pub fn set_camera(&mut self, camera: &crate::scene::Camera) -> Result<(), GpuError> {
        let aspect = self.target.width() as f32 / self.target.height() as f32;
        self.frame_params.clip_from_world = camera.clip_from_world(aspect).to_cols_array_2d();
        self.frame_params.camera_position = camera.position.extend(1.0).to_array();
        self.frame.write(bytemuck::bytes_of(&self.frame_params))
    }

    /// The scene mesh's vertex shader.
    pub fn vertex_spirv(&self) -> &[u32] {
        &self.vertex_spirv
    }

    pub fn target(&self) -> &RenderTarget {
        &self.target
    }
    /// The material textures' sampler (repeat, trilinear): for material-space technique
    /// textures such as the SSBump.
    pub fn material_sampler(&self) -> &Sampler {
        &self.material_sampler
    }

    pub fn lightmap_sampler(&self) -> &Sampler {
        &self.lightmap_sampler
    }

    /// A mesh pipeline over this scene's target with the shared vertex shader: `resources`
    /// are the common ones ([`Self::common_resources`]) plus the pass's own.
    pub fn mesh_pipeline(
        &self,
        ctx: &Arc<Context>,
        name: &str,
        fragment_spirv: &[u32],
        resources: &[(u32, Resource<'_>)],
    ) -> Result<MeshPipeline, GpuError> {
        self.mesh_pipeline_with_depth(ctx, name, fragment_spirv, resources, true)
    }

    /// [`Self::mesh_pipeline`] with the depth test on or off (the device probe).
    pub fn mesh_pipeline_with_depth(
        &self,
        ctx: &Arc<Context>,
        name: &str,
        fragment_spirv: &[u32],
        resources: &[(u32, Resource<'_>)],
        depth_test: bool,
    ) -> Result<MeshPipeline, GpuError> {
        MeshPipeline::new(
            ctx,
            &self.target,
            &crate::gpu::MeshPipelineDesc {
                name,
                vertex_spirv: &self.vertex_spirv,
                fragment_spirv,
                vertex_layout: &self.vertex_layout,
                resources,
                depth_test,
                additive: false,
            },
        )
    }

    /// Fragments shaded in one frame of the scene mesh with the depth test, counted exactly
    /// (each fragment adds 1 to its pixel; hidden fragments drawn before their occluder
    /// count, as they are shaded): the overdraw every technique of the scene pays, since
    /// they all draw the same surfaces in the same order (`crate::probe`'s coverage).
    pub fn shaded_fragments(&self, ctx: &Arc<Context>) -> Result<u64, GpuError> {
        Ok(self.shading_load(ctx, None)?.fragments)
    }

    /// Fragments shaded and lanes kept busy in one frame of `mesh` (its buffers and the same
    /// mesh on the CPU; the scene's when `None`) with the depth test (glsl/probe/count.frag):
    /// where triangles are small, the device's SIMD batches (subgroups) run partly empty, and
    /// the lanes, not the fragments, are what a fragment shader's frame time follows. And the
    /// length of the triangles' edges on the screen (`scene::screen_triangles`), which the
    /// rasterizer walks.
    pub fn shading_load(
        &self,
        ctx: &Arc<Context>,
        mesh: Option<(&MeshBuffers, &Mesh)>,
    ) -> Result<ShadingLoad, GpuError> {
        let (buffers, cpu_mesh) = mesh.unwrap_or((&self.mesh, &self.cpu_mesh));
        let clip_from_world = glam::Mat4::from_cols_array_2d(&self.frame_params.clip_from_world);
        let edge_pixels = crate::scene::screen_triangles(
            cpu_mesh,
            clip_from_world,
            self.target.width(),
            self.target.height(),
        )
        .map(|t| t.perimeter)
        .sum();
        let ballot = ctx.supports_fragment_subgroup_ballot();
        let fragment = compile_glsl(
            "probe/count.frag",
            ShaderStage::Fragment,
            &[("SUBGROUP_BALLOT", u32::from(ballot))],
        )?;
        let resources = self.common_resources();
        let pipeline = MeshPipeline::new(
            ctx,
            &self.target,
            &crate::gpu::MeshPipelineDesc {
                name: "scene.count_fragments",
                vertex_spirv: &self.vertex_spirv,
                fragment_spirv: &fragment,
                vertex_layout: &self.vertex_layout,
                resources: &resources,
                depth_test: true,
                additive: true,
            },
        )?;
        drop(resources);
        let frame = self.render_pipeline_on(&pipeline, buffers, 0, 1)?;
        Ok(ShadingLoad {
            edge_pixels,
            fragments: frame.rgba.iter().map(|p| p[0].round() as u64).sum(),
            lanes: frame.rgba.iter().map(|p| f64::from(p[1])).sum(),
            measured_lanes: ballot,
        })
    }

    /// Triangles of the scene mesh.
    pub fn triangle_count(&self) -> u32 {
        self.mesh.triangle_count()
    }

    /// Whether techniques read the material textures at full resolution
    /// ([`FrameSettings::material_level0`]).
    pub fn material_level0(&self) -> bool {
        self.material_level0
    }

    /// The layout of the scene's vertex buffer (`scene::Vertex`).
    pub fn vertex_layout(&self) -> &VertexLayout {
        &self.vertex_layout
    }

    /// Renders `mesh` (a technique's own, over the same surface) with `pipeline`.
    pub fn render_pipeline_on(
        &self,
        pipeline: &MeshPipeline,
        mesh: &MeshBuffers,
        warmup: u32,
        frames: u32,
    ) -> Result<Frame, GpuError> {
        let ms =
            pipeline.render_frames(&self.target, mesh, warmup, frames, self.min_query_span_ms)?;
        Ok(Frame {
            width: self.target.width(),
            height: self.target.height(),
            rgba: self.target.read_rgba()?,
            ms,
        })
    }

    /// The GPU times of `frames` frames of `mesh` with `pipeline`, ms; nothing read back (the
    /// device probe's interleaved rounds).
    pub fn time_pipeline_on(
        &self,
        pipeline: &MeshPipeline,
        mesh: &MeshBuffers,
        warmup: u32,
        frames: u32,
    ) -> Result<Vec<f64>, GpuError> {
        pipeline.render_frames(&self.target, mesh, warmup, frames, self.min_query_span_ms)
    }

    /// Times `pipeline` over the scene's mesh, as [`Self::render_pipeline`] without reading
    /// the image back.
    pub fn time_pipeline(
        &self,
        pipeline: &MeshPipeline,
        warmup: u32,
        frames: u32,
    ) -> Result<Vec<f64>, GpuError> {
        pipeline.render_frames(
            &self.target,
            &self.mesh,
            warmup,
            frames,
            self.min_query_span_ms,
        )
    }

    /// Renders with any mesh pipeline built for this scene's target (e.g. G-buffer passes).
    pub fn render_pipeline(
        &self,
        pipeline: &MeshPipeline,
        warmup: u32,
        frames: u32,
    ) -> Result<Frame, GpuError> {
        let ms = pipeline.render_frames(
            &self.target,
            &self.mesh,
            warmup,
            frames,
            self.min_query_span_ms,
        )?;
        Ok(Frame {
            width: self.target.width(),
            height: self.target.height(),
            rgba: self.target.read_rgba()?,
            ms,
        })
    }
}

/// A rendered image (linear radiance, RGBA f32, row 0 at the top) and its frame times.
/// What one frame of a mesh shades ([`SceneGpu::shading_load`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingLoad {
    pub fragments: u64,
    /// Subgroup lanes kept busy (the fragments where the device has no subgroup ballot).
    pub lanes: f64,
    pub measured_lanes: bool,
    /// Σ over the triangles of their clipped screen perimeters, pixels (occlusion ignored:
    /// hidden triangles are rasterized too).
    pub edge_pixels: f64,
}

#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<[f32; 4]>,
    /// GPU time of each timed frame, ms (empty without timestamp support).
    pub ms: Vec<f64>,
}

impl Frame {
    /// Covered pixels (alpha > ½) with a channel that is not finite or at least the f16
    /// target's largest value 65504 (an f16 target saturates to Inf there). The
    /// same check for every technique: `render` warns, `bench` marks the row.
    pub fn clipped_pixels(&self) -> u64 {
        self.rgba
            .iter()
            .filter(|p| p[3] > 0.5 && p[..3].iter().any(|c| !c.is_finite() || *c >= 65504.0))
            .count() as u64
    }

    /// Linear RGB at pixel (x, y).
    pub fn rgb(&self, x: u32, y: u32) -> [f32; 3] {
        let t = self.rgba[(y * self.width + x) as usize];
        [t[0], t[1], t[2]]
    }
    /// Rec. 709 luminance at pixel (x, y).
    pub fn luminance(&self, x: u32, y: u32) -> f32 {
        let [r, g, b] = self.rgb(x, y);
        0.2126 * r + 0.7152 * g + 0.0722 * b
    }
    /// Pixels rendered (alpha 1) as opposed to background (alpha 0).
    pub fn covered(&self, x: u32, y: u32) -> bool {
        self.rgba[(y * self.width + x) as usize][3] > 0.5
    }
}

/// Uploads an RGBA8 texture with a full box-filtered mip chain (averaged in linear light
/// when `srgb`, so dark mortar lines do not grow in the distance).
fn upload_texture8(
    ctx: &Arc<Context>,
    tex: &Texture8,
    format: vk::Format,
    srgb: bool,
    name: &str,
) -> Result<Image, GpuError> {
    let levels = crate::scene::mip::mip_chain(tex, srgb);
    let desc = ImageDesc::texture_2d(format, tex.width, tex.height).mip_levels(levels.len() as u32);
    let level_bytes: Vec<Vec<&[u8]>> = levels
        .iter()
        .map(|l| vec![bytemuck::cast_slice::<[u8; 4], u8>(&l.texels)])
        .collect();
    Image::with_data(ctx, &desc, &level_bytes, name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mesh_vertex_shader_compiles_for_techniques_and_g_buffers() {
        for gbuffer in [0, 1] {
            compile_glsl(
                "scene/mesh.vert",
                ShaderStage::Vertex,
                &[("GBUFFER", gbuffer)],
            )
            .unwrap();
        }
    }
}
