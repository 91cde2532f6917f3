//! The specular term of a directional light under three normal-map filterings
//! (`glsl/ndf/specular.frag`), and its footprint reference.
//!
//! Radiance L = k_s E · D(h) where both n·l and n·v are positive (n the interpolated
//! normal; no shadowing or masking, as in the paper), D the normal density of [`super`] at
//! the half vector h of the light and the view:
//!
//! - [`NormalFilter::Mip`]: the usual MIP chain of averaged normals, renormalized, with the
//!   base lobe D = κ₀ g(|h − n̄|²/σ²)/σ³ — the filtering the paper shows to be wrong;
//! - [`NormalFilter::Ndf`]: the NDF maps' trilinearly filtered moments, D = κ₀ g(d)/√det S;
//! - [`NormalFilter::NdfNormalized`]: the same with the per-texel 1/N instead of κ₀.
//!
//! The reference ([`render_reference`]) takes the footprint reference's G-buffer passes
//! (full-resolution normal map at stratified sub-pixel positions, `crate::reference`) and
//! evaluates the base lobe of each sample's own normal, so it integrates exactly the BRDF
//! the full-resolution surface has over each pixel.

use std::sync::Arc;

use ash::vk;
use glam::{DVec3, Vec3};

use super::{NdfMaps, pearson};
use crate::gpu::{self, Buffer, Context, GpuError, Image, ImageDesc, Resource, layout};
use crate::reference::ReferenceSettings;
use crate::render::{Frame, SceneGpu};
use crate::technique::HwPath;

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

    /// `SHVIS_SPECULAR` of glsl/include/specular.glsl.
    pub fn shader_value(self) -> u32 {
        match self {
            NormalFilter::Mip => 1,
            NormalFilter::Ndf => 2,
            NormalFilter::NdfNormalized => 3,
        }
    }
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

/// Uniform block `SpecularParams` of `glsl/include/specular.glsl` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SpecularParams {
    light_dir: [f32; 4],
    light_radiance: [f32; 4],
    sigma: f32,
    kappa0: f32,
    _pad: [f32; 2],
}
const _: () = assert!(std::mem::offset_of!(SpecularParams, sigma) == 32);

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
/// of its normal map, their images for both paths (NDF filterings only) and the block.
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
        let maps = super::build(&material.normal, material.normal_scale, term.sigma);
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
            HwPath::Dx10 => &self.images[1],
        }
    }

    /// The bindings of a technique's draw on `path`.
    pub fn resources<'a>(&'a self, scene: &'a SceneGpu, path: HwPath) -> Vec<(u32, Resource<'a>)> {
        specular_resources(scene, &self.params, self.term.filter, self.images(path))
    }
}

/// The NDF images for `path`: three 2D textures (dx9) or one 3-layer array (dx10), each
/// with the full MIP chain.
pub fn upload_maps(
    ctx: &Arc<Context>,
    maps: &NdfMaps,
    path: HwPath,
) -> Result<Vec<Image>, GpuError> {
    let format = super::MOMENT_FORMAT;
    if !ctx.supports_linear_filter(format) {
        return Err(GpuError::Invalid {
            what: "ndf maps".into(),
            detail: format!(
                "{} cannot filter RGBA32F textures linearly",
                ctx.device_name()
            ),
        });
    }
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
        HwPath::Dx10 => {
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
        &[
            path.shader_define(),
            ("SPECULAR", filter.shader_value()),
            ("GBUFFER", 1),
        ],
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

/// The base lobe at full resolution: κ₀ g(|h − n|²/σ²)/σ³.
pub fn base_lobe(h: DVec3, n: DVec3, sigma: f64, kappa0: f64) -> f64 {
    kappa0 * pearson((h - n).length_squared() / (sigma * sigma)) / sigma.powi(3)
}

/// The frame jitter (pixels) that puts pixel centres on stratum `j` of `side`² cells,
/// jittered within the cell by a hash of (`seed`, `j`): the same positions for every pixel.
pub fn stratum_jitter(seed: u64, j: u32, side: u32) -> [f32; 2] {
    let jitter = |axis: u64| {
        let hash = crate::bake::directions::splitmix64(seed ^ (u64::from(j) << 1 | axis));
        crate::bake::directions::unit_f64(hash) as f32
    };
    let sx = ((j % side) as f32 + jitter(0)) / side as f32;
    let sy = ((j / side) as f32 + jitter(1)) / side as f32;
    [0.5 - sx, 0.5 - sy]
}

/// Most sub-pixel strata per side of the specular reference (32² = 1024 G-buffer sets).
pub const MAX_REFERENCE_SIDE: u32 = 32;

/// The footprint reference of the specular image (module doc): ⌈√spp⌉² (≤ 32²) jittered
/// strata of the pixel, one G-buffer set each, the positions shared by all pixels. More
/// strata than the diffuse reference's 8² because nothing else averages here: a pixel near
/// the horizon covers hundreds of bumps, and 64 shared positions alias into moiré.
/// Deterministic for a seed. Without `settings.footprint`, one sample at each pixel centre
/// through the MIP chains (the point reference).
pub fn render_reference(
    ctx: &Arc<Context>,
    scene: &mut SceneGpu,
    camera_position: Vec3,
    maps: &NdfMaps,
    light: &SpecularLight,
    settings: &ReferenceSettings,
) -> Result<Frame, GpuError> {
    // The point reference reads the MIP chains at the pixel centre, as the diffuse one does.
    let pipelines = crate::reference::gbuffer_pipelines(ctx, scene, settings.footprint, 4)?;
    let side = if settings.footprint {
        ((settings.spp.max(1) as f64).sqrt().ceil() as u32).min(MAX_REFERENCE_SIDE)
    } else {
        1
    };
    let (w, h) = (settings.width as usize, settings.height as usize);
    let mut sum = vec![[0.0f64; 4]; w * h];
    let count = side * side;
    let l = light.direction.normalize().as_dvec3();
    let (sigma, kappa0) = (f64::from(maps.sigma), maps.kappa0);
    let eye = camera_position.as_dvec3();
    for j in 0..count {
        scene.set_jitter(if settings.footprint {
            stratum_jitter(settings.seed, j, side)
        } else {
            [0.0, 0.0]
        })?;
        let position = scene.render_pipeline(&pipelines[0], 0, 1)?;
        let normal = scene.render_pipeline(&pipelines[1], 0, 1)?;
        let vertex_normal = scene.render_pipeline(&pipelines[3], 0, 1)?;
        for (i, acc) in sum.iter_mut().enumerate() {
            let p = position.rgba[i];
            if p[3] < 0.5 {
                continue;
            }
            let pos = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let n = Vec3::from_slice(&normal.rgba[i][..3])
                .as_dvec3()
                .normalize_or_zero();
            let ng = Vec3::from_slice(&vertex_normal.rgba[i][..3])
                .as_dvec3()
                .normalize_or_zero();
            let v = (eye - pos).normalize_or_zero();
            let lit = ng.dot(l) > 0.0 && ng.dot(v) > 0.0;
            let d = if lit {
                base_lobe((l + v).normalize_or_zero(), n, sigma, kappa0)
            } else {
                0.0
            };
            for (a, r) in acc.iter_mut().zip(light.radiance.to_array()) {
                *a += d * f64::from(r);
            }
            acc[3] += 1.0;
        }
    }
    scene.set_jitter([0.0, 0.0])?;
    let n = f64::from(count);
    Ok(Frame {
        width: settings.width,
        height: settings.height,
        rgba: sum
            .iter()
            .map(|a| {
                let covered = a[3] / n;
                let scale = if a[3] > 0.0 { 1.0 / a[3] } else { 0.0 };
                // Covered where every stratum hit the surface (coverage edges excluded).
                [
                    (a[0] * scale) as f32,
                    (a[1] * scale) as f32,
                    (a[2] * scale) as f32,
                    if covered >= 1.0 { 1.0 } else { 0.0 },
                ]
            })
            .collect(),
        ms: Vec::new(),
    })
}
