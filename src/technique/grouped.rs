//! What `unc*` and `pca*` share (Iwanicki–Sloan eqs. (4) and (6)): per-texel values in
//! groups of four (RGBA texels) dotted with normal-indexed tables in the same groups, per
//! colour, plus optionally a per-colour "mean" table (PCA's V_e term):
//!
//! ```text
//! I_c(n) = mean_c(n) + Σ_g dot(texel_g(uv), table_{c,g}(n))
//! ```
//!
//! Layouts (DESIGN §2):
//!
//! ```text
//! dx9  texel groups: G 2D textures     tables: 3 2D textures (one per colour), the G
//!                                       dual-paraboloid spheres side by side, each two
//!                                       hemisphere squares wide: | g0 +Y | g0 −Y | g1 +Y | …
//!                                       mean: one more 2D texture, one sphere, RGB
//! dx10 texel groups: one 2D array      tables: one cube-map array, cube c·G + g; mean: cube 3G
//! ```
//!
//! Tables are RGBA16F; one whose largest magnitude exceeds `F16_TABLE_MAX` is scaled down
//! and the shader multiplies the sum back (glsl/include/grouped.glsl), keeping f16's
//! relative precision under an HDR sun.

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::{HwPath, TechniqueError};
use crate::gpu::{Buffer, Context, Image, ImageDesc, MeshPipeline, Resource, layout};
use crate::render::SceneGpu;
use crate::sphere::SphereMap;

/// Largest table magnitude stored in f16: far below 65504, so filtering and the products
/// stay finite, far above f16's subnormals.
pub const F16_TABLE_MAX: f32 = 16384.0;

/// Factor that brings values whose largest magnitude is `max_abs` into f16's safe range
/// (`F16_TABLE_MAX`); 1 when they already fit. Shaders multiply by its inverse.
pub fn f16_range_scale(max_abs: f32) -> f32 {
    if max_abs > F16_TABLE_MAX {
        F16_TABLE_MAX / max_abs
    } else {
        1.0
    }
}

/// Uniforms of glsl/include/grouped.glsl, block `GroupedParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GroupedParams {
    /// x: 1/scale of the tables' f16 range scaling; y: table texels per side.
    pub unscale_res: [f32; 4],
}

/// Uploads per-texel groups (`groups[g]` = res² RGBA texels of `format`).
pub fn upload_texel_groups(
    ctx: &Arc<Context>,
    path: HwPath,
    res: u32,
    format: vk::Format,
    groups: &[&[u8]],
    name: &str,
) -> Result<Vec<Image>, TechniqueError> {
    Ok(match path {
        HwPath::Dx9 => groups
            .iter()
            .enumerate()
            .map(|(g, bytes)| {
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(format, res, res),
                    &[vec![*bytes]],
                    &format!("{name}.{g}"),
                )
            })
            .collect::<Result<_, _>>()?,
        HwPath::Dx10 => vec![Image::with_data(
            ctx,
            &ImageDesc::texture_2d_array(format, res, res, groups.len() as u32),
            &[groups.to_vec()],
            name,
        )?],
    })
}

/// Normal-indexed tables at the texel centres of `map` (dual paraboloid for dx9, cube
/// for dx10): `value(t, g, c)` is the RGBA of texel t (`SphereMap::texel_index`), group g,
/// colour c; `mean(t)` the RGB of the optional mean table. Returns the images and the
/// factor the shader multiplies sums by.
pub fn upload_normal_tables(
    ctx: &Arc<Context>,
    path: HwPath,
    map: SphereMap,
    groups: usize,
    value: impl Fn(usize, usize, usize) -> [f32; 4],
    mean: Option<&dyn Fn(usize) -> [f32; 3]>,
    name: &str,
) -> Result<(Vec<Image>, f32), TechniqueError> {
    let samples = map.sample_count();
    let mut max_abs = 0.0f32;
    for t in 0..samples {
        for g in 0..groups {
            for c in 0..3 {
                max_abs = value(t, g, c).iter().fold(max_abs, |m, v| m.max(v.abs()));
            }
        }
        if let Some(mean) = mean {
            max_abs = mean(t).iter().fold(max_abs, |m, v| m.max(v.abs()));
        }
    }
    if !max_abs.is_finite() {
        return Err(TechniqueError::Input {
            label: name.into(),
            detail: "a normal-indexed table is not finite (non-finite lighting?)".into(),
        });
    }
    let scale = f16_range_scale(max_abs);
    let h = |v: f32| f16::from_f32(v * scale);
    let fmt = vk::Format::R16G16B16A16_SFLOAT;
    let tr = map.res() as usize;
    let mean_rgba = |t: usize| -> [f32; 4] {
        mean.map(|m| {
            let [r, g, b] = m(t);
            [r, g, b, 0.0]
        })
        .unwrap_or([0.0; 4])
    };
    let images = match path {
        HwPath::Dx9 => {
            // One sphere strip per colour (G spheres), plus the mean strip (1 sphere).
            let strip = |spheres: usize, texel: &dyn Fn(usize, usize) -> [f32; 4]| {
                let width = spheres * 2 * tr;
                let mut texels = vec![f16::ZERO; width * tr * 4];
                for y in 0..tr {
                    for x in 0..width {
                        let (g, within) = (x / (2 * tr), x % (2 * tr));
                        let (hemi, i) = (within / tr, within % tr);
                        let t = map.texel_index(hemi as u32, i as u32, y as u32);
                        let v = texel(t, g);
                        for k in 0..4 {
                            texels[(y * width + x) * 4 + k] = h(v[k]);
                        }
                    }
                }
                (width as u32, texels)
            };
            let mut images = Vec::new();
            for c in 0..3 {
                let (width, texels) = strip(groups, &|t, g| value(t, g, c));
                images.push(Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(fmt, width, tr as u32),
                    &[vec![bytemuck::cast_slice(&texels)]],
                    &format!("{name}.{}", ["red", "green", "blue"][c]),
                )?);
            }
            if mean.is_some() {
                let (width, texels) = strip(1, &|t, _| mean_rgba(t));
                images.push(Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(fmt, width, tr as u32),
                    &[vec![bytemuck::cast_slice(&texels)]],
                    &format!("{name}.mean"),
                )?);
            }
            images
        }
        HwPath::Dx10 => {
            let cubes = 3 * groups + mean.is_some() as usize;
            let mut layers: Vec<Vec<f16>> = Vec::with_capacity(cubes * 6);
            for cube in 0..cubes {
                for face in 0..6u32 {
                    let mut texels = vec![f16::ZERO; tr * tr * 4];
                    for j in 0..tr {
                        for i in 0..tr {
                            let t = map.texel_index(face, i as u32, j as u32);
                            let v = if cube < 3 * groups {
                                value(t, cube % groups, cube / groups)
                            } else {
                                mean_rgba(t)
                            };
                            for k in 0..4 {
                                texels[(j * tr + i) * 4 + k] = h(v[k]);
                            }
                        }
                    }
                    layers.push(texels);
                }
            }
            let bytes: Vec<&[u8]> = layers.iter().map(|l| bytemuck::cast_slice(l)).collect();
            vec![Image::with_data(
                ctx,
                &ImageDesc::texture_cube_array(fmt, tr as u32, cubes as u32),
                &[bytes],
                name,
            )?]
        }
    };
    Ok((images, 1.0 / scale))
}

/// The end every grouped technique shares: checks the path rules, creates the uniform
/// block, compiles `shader` with `defines` (plus the path's) and builds the pipeline.
/// Returns the finished technique with `stats.textures_bound` filled in.
#[allow(clippy::too_many_arguments)]
pub fn finish(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: super::TechniqueId,
    path: HwPath,
    shader: &str,
    defines: &[(&str, u32)],
    texel_images: Vec<Image>,
    table_images: Vec<Image>,
    has_mean: bool,
    unscale: f32,
    table_res: u32,
    mut stats: super::TechniqueStats,
) -> Result<super::TechniqueGpu, TechniqueError> {
    let label = format!("{id}.{path}");
    let all: Vec<_> = texel_images.iter().chain(&table_images).collect();
    super::check_path_rules(&label, path, &all)?;
    stats.textures_bound = layout::MATERIAL_TEXTURES + all.len() as u32;
    let params = params_buffer(ctx, unscale, table_res, &label)?;
    let mut all_defines = vec![path.shader_define()];
    all_defines.extend_from_slice(defines);
    let fragment =
        crate::gpu::compile_glsl(shader, crate::gpu::ShaderStage::Fragment, &all_defines)?;
    let pipeline = grouped_pipeline(
        ctx,
        scene,
        path,
        &label,
        &fragment,
        &texel_images,
        &table_images,
        has_mean,
        &params,
    )?;
    Ok(super::TechniqueGpu {
        id,
        path,
        pipeline,
        stats,
        _images: texel_images.into_iter().chain(table_images).collect(),
        _buffers: vec![params],
    })
}

/// The pipeline of a grouped technique: `texel_images` at TEXTURE0 and `table_images` at
/// TEXTURE0 + 1 (dx9: as arrays, the mean table at TEXTURE0 + 2; dx10: one image each).
#[allow(clippy::too_many_arguments)]
fn grouped_pipeline(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    path: HwPath,
    label: &str,
    fragment: &[u32],
    texel_images: &[Image],
    table_images: &[Image],
    has_mean: bool,
    params: &Buffer,
) -> Result<MeshPipeline, TechniqueError> {
    let sampler = scene.lightmap_sampler();
    let mut resources = scene.common_resources();
    resources.push((layout::BINDING_TECHNIQUE_PARAMS, Resource::Uniform(params)));
    match path {
        HwPath::Dx9 => {
            let colour_tables = &table_images[..3];
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0,
                Resource::TextureArray(texel_images.iter().map(|i| (i, sampler)).collect()),
            ));
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0 + 1,
                Resource::TextureArray(colour_tables.iter().map(|i| (i, sampler)).collect()),
            ));
            if has_mean {
                resources.push((
                    layout::BINDING_TECHNIQUE_TEXTURE0 + 2,
                    Resource::Texture(&table_images[3], sampler),
                ));
            }
        }
        HwPath::Dx10 => {
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0,
                Resource::Texture(&texel_images[0], sampler),
            ));
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0 + 1,
                Resource::Texture(&table_images[0], sampler),
            ));
        }
    }
    Ok(scene.mesh_pipeline(ctx, label, fragment, &resources)?)
}

/// A host-visible uniform buffer holding `GroupedParams`.
pub fn params_buffer(
    ctx: &Arc<Context>,
    unscale: f32,
    table_res: u32,
    label: &str,
) -> Result<Buffer, TechniqueError> {
    let params = GroupedParams {
        unscale_res: [unscale, table_res as f32, 0.0, 0.0],
    };
    Ok(Buffer::with_data(
        ctx,
        bytemuck::bytes_of(&params),
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &format!("{label}.params"),
    )?)
}
