//! `shlmap`: the SH lightmap baseline (Iwanicki–Sloan §5, "SHLmap"; DESIGN §2). Per texel,
//! the order-3 SH of incident radiance with inter-reflection for one static lighting
//! ([`crate::bake::shlmap`]); the shader convolves it with the clamped cosine and evaluates
//! at the normal-mapped normal:
//!
//! ```text
//! radiance = albedo/π · Σ_k A_l(k) c_k(uv) y_k(n)
//! ```
//!
//! No per-lighting data: changing the lighting needs a new bake. Per texel: 27 values (9
//! RGB coefficients, value 3k + c) packed 4 per RGBA16F texel into 7 groups (the last
//! padded), 56 bytes. dx9 binds 7 2D textures (9 with the material's, ≤ 16), dx10 one
//! 7-layer 2D array. Values are scaled into f16's range like the L×H tables
//! ([`super::tables::f16_range_scale`]) and the shader multiplies back.

use ash::vk;
use half::f16;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::{LightingData, Recipe};
use super::spec::{BakeNeeds, ReferenceModel};
use super::{HwPath, ShaderReads, Technique};
use crate::gpu::Context;
use std::sync::Arc;

use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::values::{self, Step, ValueMap};
use super::{Inputs, ShaderVariant, TechniqueError};
use crate::bake::shlmap::{SH_LIGHTMAP_COEFFS, ShLightmap};

/// RGBA groups per texel: ⌈27 / 4⌉.
pub const SHLMAP_GROUPS: usize = (3 * SH_LIGHTMAP_COEFFS).div_ceil(VALUES_PER_TEXEL);

/// Uniforms of glsl/technique/shlmap.frag, block `ShLightmapParams` (std140), and of the
/// blocks of the same layout: engine_sh.frag's and hbasis.frag's (the same name),
/// rnm.frag's `RnmParams` and nmprtsvd.frag's `NmprtParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShLightmapParams {
    /// x: factor undoing the f16 range scaling.
    pub unscale: [f32; 4],
}
crate::gpu::layout::glsl_block!(ShLightmapParams = "ShLightmapParams" { unscale });

/// The fragment shader of `shlmap`.
pub fn fragment_shader() -> ShaderVariant {
    ShaderVariant {
        path: "technique/shlmap.frag",
        defines: vec![("SHLMAP_GROUPS", SHLMAP_GROUPS as u32)],
    }
}

/// The factor the lightmap's values are multiplied by before f16 storage (the shader
/// divides it out), or `None` when a value is not finite.
pub fn stored_scale(map: &ShLightmap) -> Option<f32> {
    super::tables::finite_f16_scale(map.coeffs.iter().flatten().copied())
}

/// The SH lightmap, range-scaled into f16, and a recipe that always gives the block undoing
/// that scale (the lighting is baked in).
pub(crate) fn prepare(
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let map = baked_map(inputs, label)?;
    let texels = (map.res * map.res) as usize;
    let Some(scale) = stored_scale(map) else {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: "the SH lightmap is not finite (non-finite lighting?)".into(),
        });
    };
    // Value 3k + c of a texel is colour c of coefficient k.
    let groups = pack_groups(texels, 3 * SH_LIGHTMAP_COEFFS, |t, value| {
        f16::from_f32(map.texel(t)[value / 3][value % 3] * scale)
    });
    Ok(baked_lightmap(
        &groups,
        map.res,
        format!("{label}.radiance_sh"),
        scale,
    ))
}

/// The SH lightmap bake of `inputs`, or the error of a technique (`label`) that needs it.
pub(crate) fn baked_map<'a>(
    inputs: &Inputs<'a>,
    label: &str,
) -> Result<&'a ShLightmap, TechniqueError> {
    inputs.sh_lightmap.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the SH lightmap bake".into(),
    })
}

/// Per-texel values derived from the SH lightmap (`per_texel` each, texel-major, before the
/// f16 scale) as f16 groups with their scale, and the recipe of the baked-in lighting:
/// what the engine and local bases upload. Returns the scale too (the SG block needs it).
pub(crate) fn baked_values(
    stored: &[f32],
    per_texel: usize,
    res: u32,
    name: String,
    label: &str,
) -> Result<(TexelGroups, Recipe, f32), TechniqueError> {
    let Some(scale) = super::tables::finite_f16_scale(stored.iter().copied()) else {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: "the SH lightmap is not finite (non-finite lighting?)".into(),
        });
    };
    let texels = (res * res) as usize;
    let groups = pack_groups(texels, per_texel, |t, value| {
        f16::from_f32(stored[t * per_texel + value] * scale)
    });
    let (texels, recipe) = baked_lightmap(&groups, res, name, scale);
    Ok((texels, recipe, scale))
}

/// Lightmap groups stored in f16 after multiplying by `scale`, and the recipe of their
/// baked-in lighting: the [`ShLightmapParams`] block undoing the scale (`shlmap`, `rnm`).
pub(crate) fn baked_lightmap(
    groups: &[Vec<f16>],
    res: u32,
    name: String,
    scale: f32,
) -> (TexelGroups, Recipe) {
    let texels = TexelGroups::new(vk::Format::R16G16B16A16_SFLOAT, res, groups, name);
    let params = ShLightmapParams {
        unscale: [1.0 / scale, 0.0, 0.0, 0.0],
    };
    (
        texels,
        Recipe::Baked(LightingData::params(bytemuck::bytes_of(&params).to_vec())),
    )
}

/// The `shlmap` family (one member).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Shlmap;

impl Family for Shlmap {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "shlmap",
        what: "order-3 SH of incident radiance with inter-reflection per texel (static light)",
        paper: "Iwanicki & Sloan §5",
        in_paper_table: true,
    };
    const EXAMPLE: Shlmap = Shlmap;

    fn members() -> Vec<Shlmap> {
        vec![Shlmap]
    }

    fn table_rows() -> Vec<Shlmap> {
        vec![Shlmap]
    }

    fn headline(_: HwPath) -> Vec<Shlmap> {
        vec![Shlmap]
    }

    fn name(self) -> String {
        "shlmap".into()
    }

    fn paper_ms(self) -> Option<f64> {
        Some(0.846)
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds::SH_LIGHTMAP
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::InterReflected
    }

    fn dynamic_lighting(self) -> bool {
        false
    }

    fn ndf_variant(self) -> Option<Technique> {
        None
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        Ok(Form::values(path, BlockCodec::Ratio(NormColours::Triplets)))
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(inputs, label)
    }

    fn extra_slot(
        self,
        _: &Arc<Context>,
        _: HwPath,
        _: &Inputs<'_>,
        _: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        Ok(None)
    }

    fn fragment_shader(self) -> ShaderVariant {
        fragment_shader()
    }

    fn reads(self) -> ShaderReads {
        ShaderReads::PLAIN
    }

    fn options_tag(self, _: &()) -> Option<String> {
        None
    }

    fn sample_fit(self, _: &()) -> Option<crate::sh::samples::SampleFit> {
        None
    }

    fn values(self) -> Option<ValueMap> {
        Some(value_map(
            3,
            "the clamped cosine's convolution: A_l = (pi, 2 pi / 3, pi / 4) for l = 0, 1, 2",
        ))
    }
}

/// The values of an RGB SH lightmap of incident radiance of `order` (`shlmap` and `shlmapw`:
/// 3; `l1`: 2), with the words for its `convolution`: value 3k + c is colour c of
/// coefficient k, shaded as E(n) = Σ_lm A_l L_lm y_lm(n).
pub fn value_map(order: usize, convolution: &'static str) -> ValueMap {
    use std::f64::consts::PI;
    let convolution_constants = &[PI, 2.0 * PI / 3.0, PI / 4.0][..order];
    ValueMap {
        stored: "incident radiance with inter-reflection, projected into SH",
        basis: serde_json::json!({
            "name": "sh",
            "order": order,
            "frame": "world",
            "convention": "conventions.sh_basis",
        }),
        values: values::triplets(&values::sh_coefficient_names(order)),
        steps: [
            Step(serde_json::json!({
                "op": "convolve",
                "with": convolution,
                "constants": {"A_l": convolution_constants},
            })),
            Step(serde_json::json!({
                "op": "evaluate",
                "at": values::WORLD_NORMAL,
                "gives": "E(n) = sum over l, m of A_l L_lm y_lm(n), per colour",
            })),
            values::unscale(),
        ]
        .into_iter()
        .chain(values::diffuse_ending())
        .collect(),
    }
}
