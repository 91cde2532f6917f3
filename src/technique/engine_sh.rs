//! `l1`, `l1geo`, `l1zh3`, `zh3`, `l1lum`, `shlmapw`: the SH-family lightmaps engines ship
//! (`crate::sh::bases`, whose module doc has the equations), from `shlmap`'s bake.
//!
//! Per texel the basis' stored values ([`ShBasis::encode`] of the texel's order-3 radiance
//! SH), range-scaled into f16 as `shlmap`'s are and packed 4 per RGBA16F texel; the shader
//! (`glsl/technique/engine_sh.frag`, reconstructions in `glsl/include/sh_bases.glsl`)
//! reconstructs irradiance at the normal-mapped normal:
//!
//! ```text
//! technique  stored values            groups  bytes/texel  reconstruction
//! l1         c_00, c_1m  (RGB)        3       24           linear, (1)
//! l1geo      the same                 3       24           Geomerics, (2)
//! l1zh3      the same                 3       24           ZH3 hallucinated, (5)
//! zh3        + z about the lum. axis  4       32           ZH3, (4)
//! l1lum      c_00 (RGB), e (lum.)     2       16           luminance-directional, (6)
//! shlmapw    9 c_lm (RGB), windowed   7       56           L2 deringed, (8); shlmap's shader
//! ```
//!
//! dx9 binds one 2D texture per group, dx10 one array. Every reconstruction is homogeneous
//! of degree one in the stored values, so the shader multiplies the f16 range scale back
//! after reconstructing. No per-lighting data: the lighting is baked in, as for `shlmap`.

use rayon::prelude::*;

use super::lighting::Recipe;
use super::spec::EngineShBasis;
use super::texels::{TexelGroups, VALUES_PER_TEXEL};
use super::{Inputs, ShaderVariant, TechniqueError};
use crate::bake::shlmap::ShLightmap;
use crate::gpu::layout::ShaderIds;
use crate::sh::bases::ShBasis;

/// RGBA groups per texel of `basis`.
pub fn groups(basis: EngineShBasis) -> usize {
    basis.sh_basis().stored_values().div_ceil(VALUES_PER_TEXEL)
}

/// The value of the shader macro `SHVIS_ENGINE_SH_BASIS` (glsl/include/sh_bases.glsl) that
/// reconstructs `basis`, named there by [`basis_ids`]; L2's (`sh_irradiance_order3`) for
/// both L2s.
pub fn shader_value(basis: ShBasis) -> u32 {
    match basis {
        ShBasis::L1 => 0,
        ShBasis::L1Geomerics => 1,
        ShBasis::L1Zh3Hallucinated => 2,
        ShBasis::Zh3 => 3,
        ShBasis::L1Luminance => 4,
        ShBasis::L2 | ShBasis::L2Deringed => 5,
    }
}

/// `SHVIS_ENGINE_SH_BASIS`'s ids: one per reconstruction of sh_bases.glsl.
pub fn basis_ids() -> ShaderIds {
    ShaderIds {
        selector: "ENGINE_SH_BASIS",
        ids: vec![
            ("SH_BASIS_L1", shader_value(ShBasis::L1)),
            ("SH_BASIS_L1_GEOMERICS", shader_value(ShBasis::L1Geomerics)),
            (
                "SH_BASIS_L1_ZH3_HALLUCINATED",
                shader_value(ShBasis::L1Zh3Hallucinated),
            ),
            ("SH_BASIS_ZH3", shader_value(ShBasis::Zh3)),
            ("SH_BASIS_L1_LUMINANCE", shader_value(ShBasis::L1Luminance)),
            ("SH_BASIS_L2", shader_value(ShBasis::L2)),
        ],
    }
}

/// The fragment shader of `basis`: `shlmap`'s for the deringed L2 (the same layout),
/// `engine_sh.frag` otherwise.
pub fn fragment_shader(basis: EngineShBasis) -> ShaderVariant {
    match basis {
        EngineShBasis::L2Deringed => super::shlmap::fragment_shader(),
        EngineShBasis::L1
        | EngineShBasis::L1Geomerics
        | EngineShBasis::L1Zh3
        | EngineShBasis::Zh3
        | EngineShBasis::L1Luminance => ShaderVariant {
            path: "technique/engine_sh.frag",
            defines: vec![
                ("ENGINE_SH_BASIS", shader_value(basis.sh_basis())),
                ("ENGINE_SH_GROUPS", groups(basis) as u32),
            ],
        },
    }
}

/// Every texel's stored values (texel-major, [`ShBasis::stored_values`] each), in f32 as
/// the bake's coefficients are, before the f16 range scale.
pub fn stored_texels(map: &ShLightmap, basis: ShBasis) -> Vec<f32> {
    let texels = (map.res * map.res) as usize;
    (0..texels)
        .into_par_iter()
        .flat_map_iter(|t| {
            let radiance: Vec<[f64; 3]> = map.texel(t).iter().map(|c| c.map(f64::from)).collect();
            let shaded = map.normal[t].as_dvec3();
            basis
                .encode(&radiance, Some(shaded))
                .into_iter()
                .map(|v| v as f32)
        })
        .collect()
}

/// The stored values, range-scaled into f16, and the recipe of their baked-in lighting.
pub(crate) fn prepare(
    basis: EngineShBasis,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let map = super::shlmap::baked_map(inputs, label)?;
    let sh_basis = basis.sh_basis();
    let per_texel = sh_basis.stored_values();
    let stored = stored_texels(map, sh_basis);
    let name = format!("{label}.{}", sh_basis_stem(basis));
    let (texels, recipe, _) =
        super::shlmap::baked_values(&stored, per_texel, map.res, name, label)?;
    Ok((texels, recipe))
}

/// The debug-name stem of the per-texel images.
fn sh_basis_stem(basis: EngineShBasis) -> &'static str {
    match basis {
        EngineShBasis::L1 | EngineShBasis::L1Geomerics | EngineShBasis::L1Zh3 => "l1_sh",
        EngineShBasis::Zh3 => "zh3_sh",
        EngineShBasis::L1Luminance => "ambient_luminance_l1",
        EngineShBasis::L2Deringed => "deringed_sh",
    }
}
