//! The specular term of a directional light under three normal-map filterings
//! (`glsl/ndf/specular.frag`), and its footprint reference.
//!
//! Radiance L = k_s E · D(h) where both n·l and n·v are positive (n the interpolated
//! normal; no shadowing or masking, as in the paper), D the normal density of `crate::ndf` at
//! the half vector h of the light and the view:
//!
//! - [`NormalFilter::Mip`]: the usual MIP chain of averaged normals, renormalized, with the
//!   base lobe D = κ₀ g(|h − n̄|²/σ²)/σ³ — the filtering the paper shows to be wrong;
//! - [`NormalFilter::Ndf`]: the NDF maps' trilinearly filtered moments, D = κ₀ g(d)/√det S;
//! - [`NormalFilter::NdfNormalized`]: the same with the per-texel 1/N instead of κ₀.
//!
//! Its footprint reference is `crate::reference::specular`.

use std::sync::Arc;

use ash::vk;
use glam::Vec3;

use super::{Frame, SceneGpu};
use crate::gpu::layout::ShaderIds;
use crate::gpu::{self, Buffer, Context, GpuError, HwPath, Image, ImageDesc, Resource, layout};
use crate::ndf::NdfMaps;

/// How the specular pass filters the normal map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum NormalFilter {
    Mip,
    Ndf,
    NdfNormalized,
}

impl NormalFilter {
    pub const ALL: [NormalFilter; 3] = [
        NormalFilter::Mip,
        NormalFilter::Ndf,
        NormalFilter::NdfNormalized,
    ];

    pub fn name(self) -> &'static str {
        match self {
            NormalFilter::Mip => "mip",
            NormalFilter::Ndf => "ndf",
            NormalFilter::NdfNormalized => "ndfn",
        }
    }

    /// Textures fetched per pixel besides albedo (not read) and normal map.
    pub fn extra_lookups(self) -> u32 {
        match self {
            NormalFilter::Mip => 0,
            NormalFilter::Ndf | NormalFilter::NdfNormalized => 3,
        }
    }

    /// `SHVIS_SPECULAR` of glsl/include/specular.glsl, named there by [`filter_ids`]
    /// (undefined where the scene has no specular term).
    pub fn shader_value(self) -> u32 {
        match self {
            NormalFilter::Mip => 1,
            NormalFilter::Ndf => 2,
            NormalFilter::NdfNormalized => 3,
        }
    }

    /// The name of its id (`SHVIS_SPECULAR_MIP`, without `SHVIS_`).
    fn id_name(self) -> &'static str {
        match self {
            NormalFilter::Mip => "SPECULAR_MIP",
            NormalFilter::Ndf => "SPECULAR_NDF",
            NormalFilter::NdfNormalized => "SPECULAR_NDFN",
        }
    }
}

/// `SHVIS_SPECULAR`'s ids (glsl/include/specular.glsl): one per filtering.
pub fn filter_ids() -> ShaderIds {
    ShaderIds {
        selector: "SPECULAR",
        ids: NormalFilter::ALL
            .iter()
            .map(|&filter| (filter.id_name(), filter.shader_value()))
            .collect(),
    }
}

/// The macros of the specular term's own frame (glsl/ndf/specular.frag) on `path`.
pub fn frame_defines(filter: NormalFilter, path: HwPath) -> Vec<(&'static str, u32)> {
    let mut defines = path.shader_defines().to_vec();
    defines.push(("SPECULAR", filter.shader_value()));
    defines.push(("GBUFFER", 1));
    defines.extend(filter_ids().ids);
    defines
}

impl std::str::FromStr for NormalFilter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        NormalFilter::ALL
            .into_iter()
            .find(|f| f.name() == s)
            .ok_or_else(|| format!("unknown specular filtering '{s}': use mip, ndf or ndfn"))
    }
}

/// The directional light and the material's specular factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularLight {
    /// Unit direction toward the light.
    pub direction: Vec3,
    /// k_s · E, linear RGB.
    pub radiance: Vec3,
}

/// The specular material term a scene adds to every technique's radiance (`--specular`):
/// the light, the filtering of the normal map and the surface's base spread σ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularTerm {
    pub filter: NormalFilter,
    pub light: SpecularLight,
    pub sigma: f32,
}

/// Uniform block `SpecularParams` of `glsl/include/specular.glsl` (std140); public for
/// its layout (`GlslBlock`) alone.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SpecularParams {
    light_dir: [f32; 4],
    light_radiance: [f32; 4],
    sigma: f32,
    kappa0: f32,
    _pad: [f32; 2],
}
const _: () = assert!(std::mem::offset_of!(SpecularParams, sigma) == 32);
crate::gpu::layout::glsl_block!(SpecularParams = "SpecularParams" {
    light_dir,
    light_radiance,
    sigma,
    kappa0,
});

impl SpecularParams {
    fn new(light: &SpecularLight, maps: &NdfMaps) -> Self {
        SpecularParams {
            light_dir: light.direction.normalize().extend(0.0).to_array(),
            light_radiance: light.radiance.extend(0.0).to_array(),
            sigma: maps.sigma,
            kappa0: maps.kappa0 as f32,
            _pad: [0.0; 2],
        }
    }

    fn upload(&self, ctx: &Arc<Context>, name: &str) -> Result<Buffer, GpuError> {
        Buffer::with_data(
            ctx,
            bytemuck::bytes_of(self),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            name,
        )
    }
}

/// The bindings of the specular term: its block and, for the NDF filterings, `images`
/// (from [`upload_maps`] for the draw's path) with the material sampler.
fn specular_resources<'a>(
    scene: &'a SceneGpu,
    params: &'a Buffer,
    filter: NormalFilter,
    images: &'a [Image],
) -> Vec<(u32, Resource<'a>)> {
    let mut resources = vec![(layout::BINDING_SPECULAR_PARAMS, Resource::Uniform(params))];
    if filter != NormalFilter::Mip {
        let sampler = scene.material_sampler();
        resources.push((
            layout::BINDING_SPECULAR_MOMENTS,
            match images {
                [one] => Resource::Texture(one, sampler),
                many => Resource::TextureArray(many.iter().map(|i| (i, sampler)).collect()),
            },
        ));
    }
    resources
}

/// A scene's specular material term on the GPU (`SceneGpu::add_specular`): the NDF maps
/// of its normal map, their images for dx9 and for dx10/dx11 (NDF filterings only) and the block.
pub struct SceneSpecular {
    pub term: SpecularTerm,
    pub maps: NdfMaps,
    params: Buffer,
    /// (dx9, dx10) images of the maps; empty for [`NormalFilter::Mip`].
    images: [Vec<Image>; 2],
}

impl SceneSpecular {
    pub fn new(
        ctx: &Arc<Context>,
        material: &crate::scene::Material,
        term: SpecularTerm,
    ) -> Result<Self, GpuError> {
        let maps = crate::ndf::build(&material.normal, material.normal_scale, term.sigma);
        let params = SpecularParams::new(&term.light, &maps).upload(ctx, "scene.specular")?;
        let images = match term.filter {
            NormalFilter::Mip => [Vec::new(), Vec::new()],
            _ => [
                upload_maps(ctx, &maps, HwPath::Dx9)?,
                upload_maps(ctx, &maps, HwPath::Dx10)?,
            ],
        };
        Ok(SceneSpecular {
            term,
            maps,
            params,
            images,
        })
    }

    /// The shader macros of the term: `SHVIS_SPECULAR`, and the world position passed on.
    pub fn defines(&self) -> [(&'static str, u32); 2] {
        [
            ("SPECULAR", self.term.filter.shader_value()),
            ("GBUFFER", 1),
        ]
    }

    /// The images bound on `path`.
    pub fn images(&self, path: HwPath) -> &[Image] {
        match path {
            HwPath::Dx9 => &self.images[0],
            HwPath::Dx10 | HwPath::Dx11 => &self.images[1],
        }
    }

    /// The bindings of a technique's draw on `path`.
    pub fn resources<'a>(&'a self, scene: &'a SceneGpu, path: HwPath) -> Vec<(u32, Resource<'a>)> {
        specular_resources(scene, &self.params, self.term.filter, self.images(path))
    }
}

/// The NDF moment maps' format ([`crate::ndf::MOMENT_FORMAT`]), or an error where the
/// device cannot filter it linearly (optional for RGBA32F in Vulkan): the maps are read
/// trilinearly, so no fallback would be the same filter.
pub fn check_moment_filtering(ctx: &Context) -> Result<ash::vk::Format, GpuError> {
    let format = crate::ndf::MOMENT_FORMAT;
    if !ctx.supports_linear_filter(format) {
        return Err(GpuError::Invalid {
            what: "ndf maps".into(),
            detail: format!(
                "{} cannot filter RGBA32F textures linearly",
                ctx.device_name()
            ),
        });
    }
    Ok(format)
}

/// The NDF images for `path`: three 2D textures (dx9) or one 3-layer array (dx10, dx11), each
/// with the full MIP chain.
pub fn upload_maps(
    ctx: &Arc<Context>,
    maps: &NdfMaps,
    path: HwPath,
) -> Result<Vec<Image>, GpuError> {
    let format = check_moment_filtering(ctx)?;
    let (w, h) = (maps.levels[0].width, maps.levels[0].height);
    let levels = maps.levels.len() as u32;
    let bytes = |k: usize, l: usize| -> &[u8] { bytemuck::cast_slice(&maps.levels[l].textures[k]) };
    match path {
        HwPath::Dx9 => (0..3)
            .map(|k| {
                let data: Vec<Vec<&[u8]>> =
                    (0..maps.levels.len()).map(|l| vec![bytes(k, l)]).collect();
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(format, w, h).mip_levels(levels),
                    &data,
                    &format!("ndf.moments{k}"),
                )
            })
            .collect(),
        HwPath::Dx10 | HwPath::Dx11 => {
            let data: Vec<Vec<&[u8]>> = (0..maps.levels.len())
                .map(|l| (0..3).map(|k| bytes(k, l)).collect())
                .collect();
            Ok(vec![Image::with_data(
                ctx,
                &ImageDesc::texture_2d_array(format, w, h, 3).mip_levels(levels),
                &data,
                "ndf.moments",
            )?])
        }
    }
}

/// Renders the specular image of `scene` (a [`SceneGpu`] with `float32_target`, whose
/// vertex stage passes the world position) under `filter` on `path`; `images` from
/// [`upload_maps`] for the same path (unused by [`NormalFilter::Mip`]).
#[allow(clippy::too_many_arguments)]
pub fn render_specular(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    maps: &NdfMaps,
    images: &[Image],
    light: &SpecularLight,
    filter: NormalFilter,
    path: HwPath,
    frames: u32,
) -> Result<Frame, GpuError> {
    let name = format!("spec{}.{path}", filter.name());
    let params = SpecularParams::new(light, maps).upload(ctx, &format!("{name}.params"))?;
    let fragment = gpu::compile_glsl(
        "ndf/specular.frag",
        gpu::ShaderStage::Fragment,
        &frame_defines(filter, path),
    )?;
    let mut resources = scene.common_resources();
    resources.extend(specular_resources(scene, &params, filter, images));
    let pipeline = scene.mesh_pipeline(ctx, &name, &fragment, &resources)?;
    drop(resources);
    scene.render_pipeline(&pipeline, 1, frames.max(1))
}

/// The normal map's level of detail λ per pixel of `scene` (row-major; `None` where the
/// surface does not cover the pixel): ≤ 0 where the map is magnified, k where 2^k texels
/// fall across a pixel (`glsl/ndf/lod.frag`).
pub fn normal_map_lod(ctx: &Arc<Context>, scene: &SceneGpu) -> Result<Vec<Option<f32>>, GpuError> {
    let fragment = gpu::compile_glsl("ndf/lod.frag", gpu::ShaderStage::Fragment, &[])?;
    let resources = scene.common_resources();
    let pipeline = scene.mesh_pipeline(ctx, "ndf.lod", &fragment, &resources)?;
    drop(resources);
    let frame = scene.render_pipeline(&pipeline, 0, 1)?;
    Ok(frame
        .rgba
        .iter()
        .map(|p| (p[3] > 0.5).then_some(p[0]))
        .collect())
}
