//! `unc3`, `unc4`, `unc6`: uncompressed SH visibility per texel and an L×H table indexed
//! by the normal (Iwanicki–Sloan §3, eq. (4); DESIGN §2).
//!
//! Per texel: the first O² coefficients of the baked visibility, 4 per RGBA16F texel
//! (G = ⌈O²/4⌉ groups; unc3's last group is padded with zeros). Per lighting: the L×H table
//! of `bake::lxh` for order O, 4 coefficients per RGBA16F texel per colour.
//!
//! ```text
//! dx9  V: G 2D textures (res²)      L×H: 3 2D textures (one per colour), G dual-paraboloid
//!                                        spheres side by side, each two hemispheres wide:
//!                                        | g0 +Y | g0 −Y | g1 +Y | g1 −Y | … |  (table_res high)
//! dx10 V: one 2D array, G layers     L×H: one cube-map array, cube c·G + g
//! ```
//!
//! dx9 binds G + 3 + 2 textures (unc6: 14 ≤ 16) and `check_path_rules` refuses more.
//! Range: table values can exceed f16's 65504 under an HDR sun; the table is scaled so its
//! largest magnitude is `F16_TABLE_MAX` and the shader multiplies the sum back
//! (`UncParams.lxh_unscale_res.x`), keeping f16's relative precision.

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::{HwPath, Inputs, TechniqueError, TechniqueGpu, TechniqueId, TechniqueStats};
use crate::bake::lxh::{LxhMatrices, build_table};
use crate::gpu::{Buffer, Context, Image, ImageDesc, Resource, ShaderStage, compile_glsl, layout};
use crate::render::SceneGpu;
use crate::sh::Order;
use crate::sphere::{Parameterization, SphereMap};

/// Largest table magnitude stored in f16: far below 65504, so filtering and the
/// per-coefficient products stay finite, far above f16's subnormals.
pub const F16_TABLE_MAX: f32 = 16384.0;

/// Uniforms of glsl/technique/unc.frag, block `UncParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct UncParams {
    /// x: 1/scale of the table's f16 range scaling; y: table texels per side.
    pub lxh_unscale_res: [f32; 4],
}

/// The visibility order of an `unc*` technique.
pub fn order_of(id: TechniqueId) -> Order {
    match id {
        TechniqueId::Unc3 => Order::THREE,
        TechniqueId::Unc4 => Order::FOUR,
        _ => Order::SIX,
    }
}

pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: TechniqueId,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{id}.{path}");
    let order = order_of(id);
    let n = order.coeff_count();
    let groups = n.div_ceil(4);
    let vis = inputs.visibility.ok_or_else(|| TechniqueError::Input {
        label: label.clone(),
        detail: "needs the SH visibility bake".into(),
    })?;
    if vis.order < order {
        return Err(TechniqueError::Input {
            label,
            detail: format!(
                "needs visibility of order {order}, the bake has {}",
                vis.order
            ),
        });
    }
    let res = vis.res;
    let texels = (res * res) as usize;
    let stride = vis.order.coeff_count();

    // Per-texel visibility, 4 coefficients per RGBA16F texel, group-major.
    let mut vis_groups: Vec<Vec<f16>> = vec![vec![f16::ZERO; texels * 4]; groups];
    for t in 0..texels {
        for j in 0..n {
            vis_groups[j / 4][t * 4 + j % 4] = f16::from_f32(vis.coeffs[t * stride + j]);
        }
    }
    let vis_bytes: Vec<&[u8]> = vis_groups.iter().map(|g| bytemuck::cast_slice(g)).collect();
    let fmt = vk::Format::R16G16B16A16_SFLOAT;
    let vis_images: Vec<Image> = match path {
        HwPath::Dx9 => vis_bytes
            .iter()
            .enumerate()
            .map(|(g, bytes)| {
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(fmt, res, res),
                    &[vec![*bytes]],
                    &format!("{label}.visibility.{g}"),
                )
            })
            .collect::<Result<_, _>>()?,
        HwPath::Dx10 => vec![Image::with_data(
            ctx,
            &ImageDesc::texture_2d_array(fmt, res, res, groups as u32),
            &[vis_bytes.clone()],
            &format!("{label}.visibility"),
        )?],
    };

    // The L×H table for this lighting.
    let matrices = LxhMatrices::new(inputs.radiance_sh, order, inputs.h_order);
    let kind = match path {
        HwPath::Dx9 => Parameterization::DualParaboloid,
        HwPath::Dx10 => Parameterization::CubeDx10,
    };
    let map = SphereMap::new(kind, inputs.table_res).map_err(|e| TechniqueError::Input {
        label: label.clone(),
        detail: e.to_string(),
    })?;
    let table = build_table(&matrices, map);
    let max_abs = table
        .values
        .iter()
        .flatten()
        .fold(0.0f32, |m, v| m.max(v.abs()));
    if !max_abs.is_finite() {
        return Err(TechniqueError::Input {
            label,
            detail: "the L×H table is not finite (non-finite lighting?)".into(),
        });
    }
    let scale = if max_abs > F16_TABLE_MAX {
        F16_TABLE_MAX / max_abs
    } else {
        1.0
    };
    let tr = inputs.table_res as usize;
    let coeff = |t: usize, j: usize, c: usize| -> f16 {
        if j < n {
            f16::from_f32(table.values[t * n + j][c] * scale)
        } else {
            f16::ZERO
        }
    };
    let table_images: Vec<Image> = match path {
        HwPath::Dx9 => (0..3)
            .map(|c| {
                let width = groups * 2 * tr;
                let mut texels = vec![f16::ZERO; width * tr * 4];
                for y in 0..tr {
                    for x in 0..width {
                        let (g, within) = (x / (2 * tr), x % (2 * tr));
                        let (hemi, i) = (within / tr, within % tr);
                        let t = map.texel_index(hemi as u32, i as u32, y as u32);
                        for k in 0..4 {
                            texels[(y * width + x) * 4 + k] = coeff(t, 4 * g + k, c);
                        }
                    }
                }
                Image::with_data(
                    ctx,
                    &ImageDesc::texture_2d(fmt, width as u32, tr as u32),
                    &[vec![bytemuck::cast_slice(&texels)]],
                    &format!("{label}.lxh.{}", ["red", "green", "blue"][c]),
                )
            })
            .collect::<Result<_, _>>()?,
        HwPath::Dx10 => {
            let mut layers: Vec<Vec<f16>> = Vec::with_capacity(3 * groups * 6);
            for c in 0..3 {
                for g in 0..groups {
                    for face in 0..6u32 {
                        let mut texels = vec![f16::ZERO; tr * tr * 4];
                        for j in 0..tr {
                            for i in 0..tr {
                                let t = map.texel_index(face, i as u32, j as u32);
                                for k in 0..4 {
                                    texels[(j * tr + i) * 4 + k] = coeff(t, 4 * g + k, c);
                                }
                            }
                        }
                        layers.push(texels);
                    }
                }
            }
            let layer_bytes: Vec<&[u8]> = layers.iter().map(|l| bytemuck::cast_slice(l)).collect();
            vec![Image::with_data(
                ctx,
                &ImageDesc::texture_cube_array(fmt, tr as u32, (3 * groups) as u32),
                &[layer_bytes],
                &format!("{label}.lxh"),
            )?]
        }
    };
    let all_textures: Vec<&Image> = vis_images.iter().chain(&table_images).collect();
    super::check_path_rules(&label, path, &all_textures)?;

    let params = UncParams {
        lxh_unscale_res: [1.0 / scale, inputs.table_res as f32, 0.0, 0.0],
    };
    let params_buffer = Buffer::with_data(
        ctx,
        bytemuck::bytes_of(&params),
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &format!("{label}.params"),
    )?;
    let fragment = compile_glsl(
        "technique/unc.frag",
        ShaderStage::Fragment,
        &[path.shader_define(), ("UNC_GROUPS", groups as u32)],
    )?;
    let sampler = scene.lightmap_sampler();
    let mut resources = scene.common_resources();
    resources.push((
        layout::BINDING_TECHNIQUE_PARAMS,
        Resource::Uniform(&params_buffer),
    ));
    match path {
        HwPath::Dx9 => {
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0,
                Resource::TextureArray(vis_images.iter().map(|i| (i, sampler)).collect()),
            ));
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0 + 1,
                Resource::TextureArray(table_images.iter().map(|i| (i, sampler)).collect()),
            ));
        }
        HwPath::Dx10 => {
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0,
                Resource::Texture(&vis_images[0], sampler),
            ));
            resources.push((
                layout::BINDING_TECHNIQUE_TEXTURE0 + 1,
                Resource::Texture(&table_images[0], sampler),
            ));
        }
    }
    let pipeline = scene.mesh_pipeline(ctx, &label, &fragment, &resources)?;
    drop(resources);
    let texel_bytes = (groups * texels * 8) as u64;
    let table_texels = (map.sample_count() * groups * 3) as u64;
    let stats = TechniqueStats {
        texel_bytes,
        table_bytes: table_texels * 8 + std::mem::size_of::<UncParams>() as u64,
        textures_bound: layout::MATERIAL_TEXTURES + all_textures.len() as u32,
        lookups_per_pixel: layout::MATERIAL_TEXTURES + (4 * groups) as u32,
    };
    Ok(TechniqueGpu {
        id,
        path,
        pipeline,
        stats,
        _images: vis_images.into_iter().chain(table_images).collect(),
        _buffers: vec![params_buffer],
    })
}
