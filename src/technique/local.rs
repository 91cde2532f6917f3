//! `hb4`, `hb6`: the H-basis lightmaps (Habel & Wimmer 2010; `crate::sh::hbasis`, whose
//! module doc has the functions and the projection), from `shlmap`'s bake.
//!
//! Per texel the H coefficients of the irradiance over the hemisphere of its normal-map frame
//! (RGB, value 3i + c), range-scaled into f16 as `shlmap`'s values are and packed 4 per
//! RGBA16F texel: `hb4` 12 values in 3 groups (24 bytes), `hb6` 18 in 5 (40 bytes). The
//! shader (`glsl/technique/hbasis.frag`, functions in `glsl/include/hbasis.glsl`) evaluates
//! Σ h_i H_i(m) at the normal map's tangent-space normal m — no frame, no SH. The lighting is
//! baked in.

use half::f16;
use rayon::prelude::*;

use super::lighting::Recipe;
use super::spec::LocalBasis;
use super::tables::{f16_range_scale, max_abs};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{Inputs, ShaderVariant, TechniqueError};
use crate::bake::shlmap::ShLightmap;
use crate::sh::hbasis::{self, HBasisSize};

/// Values per texel of `basis` (RGB counted three times).
pub fn stored_values(basis: LocalBasis) -> usize {
    match basis {
        LocalBasis::HBasis(size) => 3 * size.count(),
    }
}

/// The fragment shader of `basis`.
pub fn fragment_shader(basis: LocalBasis) -> ShaderVariant {
    match basis {
        LocalBasis::HBasis(size) => ShaderVariant {
            path: "technique/hbasis.frag",
            defines: vec![
                ("HBASIS_COUNT", size.count() as u32),
                (
                    "HBASIS_GROUPS",
                    stored_values(basis).div_ceil(VALUES_PER_TEXEL) as u32,
                ),
            ],
        },
    }
}

/// Every texel's stored values (texel-major, [`stored_values`] each) before the f16 range
/// scale; zeros where the lightmap has no frame.
pub fn stored_texels(map: &ShLightmap, size: HBasisSize) -> Vec<f32> {
    let texels = (map.res * map.res) as usize;
    (0..texels)
        .into_par_iter()
        .flat_map_iter(|t| {
            let frame = map.frame[t];
            let radiance: Vec<[f64; 3]> = map.texel(t).iter().map(|c| c.map(f64::from)).collect();
            let columns = [frame.x_axis, frame.y_axis, frame.z_axis].map(|c| c.as_dvec3());
            hbasis::project_irradiance(&radiance, columns, size)
                .into_iter()
                .flatten()
                .map(|v| v as f32)
        })
        .collect()
}

/// The factor the stored values are multiplied by before f16 storage, or `None` when a
/// value is not finite.
pub fn stored_scale(stored: &[f32]) -> Option<f32> {
    let max = max_abs(stored.iter().copied());
    max.is_finite().then(|| f16_range_scale(max))
}

/// The stored values, range-scaled into f16, and the recipe of their baked-in lighting.
pub(crate) fn prepare(
    basis: LocalBasis,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let map = super::shlmap::baked_map(inputs, label)?;
    let LocalBasis::HBasis(size) = basis;
    let stored = stored_texels(map, size);
    let Some(scale) = stored_scale(&stored) else {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: "the SH lightmap is not finite (non-finite lighting?)".into(),
        });
    };
    let per_texel = stored_values(basis);
    let texels = (map.res * map.res) as usize;
    let groups = pack_groups(texels, per_texel, |t, value| {
        f16::from_f32(stored[t * per_texel + value] * scale)
    });
    Ok(super::shlmap::baked_lightmap(
        &groups,
        map.res,
        format!("{label}.hbasis"),
        scale,
    ))
}
