//! `pca4` … `pca24` and the weights-only `pca4w` … `pca24w` (Iwanicki–Sloan §4, eqs.
//! (5)–(6); DESIGN §2).
//!
//! The order-6 visibility is compressed to a mean V_e plus M principal vectors V_k
//! (`bake::pca`), weights quantized to 8-bit UNORM with each basis vector's range pushed
//! into the basis and the mean (so the shader reads weights in [0, 1] straight from RGBA8
//! textures, M/4 of them). Eq. (6) then needs, per lighting:
//!
//! - `pcaN`: a colour table per basis vector and one for the mean,
//!   T_k(n) = ∫ L V_k H_n = Σ_j V_kj (L×H_n)_j, built from the order-6 L×H table (`bake::lxh`)
//!   and laid out like `unc*` (`technique::grouped`: 4 basis vectors per RGBA texel, per
//!   colour) — M + 1 dependent lookups per pixel;
//! - `pcaNw`: per basis vector the order-3 SH of V_k·L (Gaunt product, `sh::product`),
//!   already multiplied by the clamped-cosine factors A_l, in a uniform block; the shader
//!   sums the weighted vectors and evaluates at the normal — no dependent lookups.
//!
//! Both compute ∫ L V H₃ (H truncated to order 3: the order-3 projection of V·L is all an
//! order-3 H sees), so they differ only by the table's parameterization and f16 storage.
//! The quantized model is refitted per M (the mean absorbs Σ_{k<M} lo_k V_k).

use std::sync::Arc;

use ash::vk;

use super::grouped::{self, upload_normal_tables, upload_texel_groups};
use super::unc::table_map;
use super::{HwPath, Inputs, TechniqueError, TechniqueGpu, TechniqueId, TechniqueStats};
use crate::bake::lxh::{LxhMatrices, build_table};
use crate::bake::pca::{PcaModel, QuantizedPca};
use crate::gpu::{Buffer, Context, Resource, ShaderStage, compile_glsl, layout};
use crate::render::SceneGpu;
use crate::sh::Order;
use crate::sh::product::product;
use crate::sh::zonal::clamped_cosine_convolution;

/// Bits per stored weight.
pub const WEIGHT_BITS: u32 = 8;

/// (M, weights-only) of a `pca*` technique.
pub fn basis_size(id: TechniqueId) -> (usize, bool) {
    use TechniqueId::*;
    match id {
        Pca4 => (4, false),
        Pca8 => (8, false),
        Pca12 => (12, false),
        Pca16 => (16, false),
        Pca24 => (24, false),
        Pca4w => (4, true),
        Pca8w => (8, true),
        Pca12w => (12, true),
        Pca16w => (16, true),
        _ => (24, true),
    }
}

/// The first `m` principal vectors of `model` (PCA bases are nested), quantized.
pub fn quantized_prefix(model: &PcaModel, m: usize) -> QuantizedPca {
    let full = model.basis.len();
    let m = m.min(full);
    let texels = model.weights.len() / full.max(1);
    let truncated = PcaModel {
        basis: model.basis[..m].to_vec(),
        weights: (0..texels)
            .flat_map(|t| model.weights[t * full..t * full + m].iter().copied())
            .collect(),
        ..model.clone()
    };
    truncated.quantize(WEIGHT_BITS)
}

pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: TechniqueId,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{id}.{path}");
    let (m, weights_only) = basis_size(id);
    let model = inputs.pca.ok_or_else(|| TechniqueError::Input {
        label: label.clone(),
        detail: "needs the PCA of the visibility bake".into(),
    })?;
    if model.basis.len() < m {
        return Err(TechniqueError::Input {
            label,
            detail: format!(
                "needs {m} principal vectors, the fit has {}",
                model.basis.len()
            ),
        });
    }
    let q = quantized_prefix(model, m);
    let groups = m / 4;
    let n = model.order.coeff_count();
    let texels = (q.res * q.res) as usize;
    let mut weight_groups: Vec<Vec<u8>> = vec![vec![0u8; texels * 4]; groups];
    for t in 0..texels {
        for k in 0..m {
            weight_groups[k / 4][t * 4 + k % 4] = q.weights_unorm[t * m + k] as u8;
        }
    }
    let weight_bytes: Vec<&[u8]> = weight_groups.iter().map(|g| g.as_slice()).collect();
    let texel_images = upload_texel_groups(
        ctx,
        path,
        q.res,
        vk::Format::R8G8B8A8_UNORM,
        &weight_bytes,
        &format!("{label}.weights"),
    )?;
    let texel_bytes = (groups * texels * 4) as u64;

    if weights_only {
        // Per basis vector and the mean: A_l · SH₃(V_k · L), RGB in .xyz.
        let l_order = Order::new(8).expect("valid order");
        let coeffs_of = |v: &[f64]| -> [[f32; 4]; 9] {
            let mut out = [[0.0f32; 4]; 9];
            for c in 0..3 {
                let l: Vec<f64> = inputs.radiance_sh[..l_order.coeff_count()]
                    .iter()
                    .map(|rgb| rgb[c])
                    .collect();
                let vl = product(&l, l_order, v, model.order, Order::THREE);
                for (i, o) in out.iter_mut().enumerate() {
                    let band = (i as f64).sqrt().floor() as u32;
                    o[c] = (clamped_cosine_convolution(band) * vl[i]) as f32;
                }
            }
            out
        };
        let mut block: Vec<[f32; 4]> = Vec::with_capacity((m + 1) * 9);
        for k in 0..m {
            block.extend(coeffs_of(&q.basis[k]));
        }
        block.extend(coeffs_of(&q.mean));
        let params = Buffer::with_data(
            ctx,
            bytemuck::cast_slice(&block),
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            &format!("{label}.params"),
        )?;
        let all: Vec<_> = texel_images.iter().collect();
        super::check_path_rules(&label, path, &all)?;
        let fragment = compile_glsl(
            "technique/pcaw.frag",
            ShaderStage::Fragment,
            &[path.shader_define(), ("PCA_GROUPS", groups as u32)],
        )?;
        let sampler = scene.lightmap_sampler();
        let mut resources = scene.common_resources();
        resources.push((layout::BINDING_TECHNIQUE_PARAMS, Resource::Uniform(&params)));
        resources.push((
            layout::BINDING_TECHNIQUE_TEXTURE0,
            match path {
                HwPath::Dx9 => {
                    Resource::TextureArray(texel_images.iter().map(|i| (i, sampler)).collect())
                }
                HwPath::Dx10 => Resource::Texture(&texel_images[0], sampler),
            },
        ));
        let pipeline = scene.mesh_pipeline(ctx, &label, &fragment, &resources)?;
        drop(resources);
        let textures_bound = layout::MATERIAL_TEXTURES + texel_images.len() as u32;
        return Ok(TechniqueGpu {
            id,
            path,
            pipeline,
            stats: TechniqueStats {
                texel_bytes,
                table_bytes: params.size(),
                textures_bound,
                lookups_per_pixel: layout::MATERIAL_TEXTURES + groups as u32,
            },
            _images: texel_images,
            _buffers: vec![params],
        });
    }

    // Tables T_k(n) = Σ_j V_kj (L×H_n)_j and the mean's, from the order-6 L×H table.
    let matrices = LxhMatrices::new(inputs.radiance_sh, model.order, inputs.h_order);
    let map = table_map(path, inputs.table_res, &label)?;
    let lxh = build_table(&matrices, map);
    let project = |t: usize, v: &[f64]| -> [f32; 3] {
        let mut s = [0.0f64; 3];
        for (j, vj) in v.iter().enumerate().take(n) {
            let e = lxh.values[t * n + j];
            for c in 0..3 {
                s[c] += vj * e[c] as f64;
            }
        }
        s.map(|x| x as f32)
    };
    let samples = map.sample_count();
    let basis_tables: Vec<[f32; 3]> = (0..samples)
        .flat_map(|t| q.basis.iter().map(move |b| (t, b)))
        .map(|(t, b)| project(t, b))
        .collect();
    let mean_table: Vec<[f32; 3]> = (0..samples).map(|t| project(t, &q.mean)).collect();
    let mean_fn = |t: usize| mean_table[t];
    let (table_images, unscale) = upload_normal_tables(
        ctx,
        path,
        map,
        groups,
        |t, g, c| std::array::from_fn(|k| basis_tables[t * m + 4 * g + k][c]),
        Some(&mean_fn),
        &format!("{label}.tables"),
    )?;
    grouped::finish(
        ctx,
        scene,
        id,
        path,
        "technique/pca.frag",
        &[("PCA_GROUPS", groups as u32)],
        texel_images,
        table_images,
        true,
        unscale,
        inputs.table_res,
        TechniqueStats {
            texel_bytes,
            table_bytes: (samples * (3 * groups + 1) * 8) as u64,
            textures_bound: 0, // filled in by `finish`
            lookups_per_pixel: layout::MATERIAL_TEXTURES + (4 * groups + 1) as u32,
        },
    )
}
