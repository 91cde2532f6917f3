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
use std::sync::Arc;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::texels::{TexelGroups, VALUES_PER_TEXEL};
use super::{Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::shlmap::ShLightmap;
use crate::gpu::Context;
use crate::gpu::layout::ShaderIds;
use crate::sh::bases::ShBasis;

/// RGBA groups per texel of `basis`.
pub fn groups(basis: ShVariantBasis) -> usize {
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
pub fn fragment_shader(basis: ShVariantBasis) -> ShaderVariant {
    match basis {
        ShVariantBasis::L2Deringed => super::shlmap::fragment_shader(),
        ShVariantBasis::L1
        | ShVariantBasis::L1Geomerics
        | ShVariantBasis::L1Zh3
        | ShVariantBasis::Zh3
        | ShVariantBasis::L1Luminance => ShaderVariant {
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
    basis: ShVariantBasis,
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
fn sh_basis_stem(basis: ShVariantBasis) -> &'static str {
    match basis {
        ShVariantBasis::L1 | ShVariantBasis::L1Geomerics | ShVariantBasis::L1Zh3 => "l1_sh",
        ShVariantBasis::Zh3 => "zh3_sh",
        ShVariantBasis::L1Luminance => "ambient_luminance_l1",
        ShVariantBasis::L2Deringed => "deringed_sh",
    }
}

/// What a [`ShVariant`] technique stores and how it reconstructs (`crate::sh::bases`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShVariantBasis {
    /// `l1`: L1 SH, 4 coefficients per colour, linear (Frostbite, Godot 4, Bakery).
    L1,
    /// `l1geo`: the same data, Geomerics' non-linear reconstruction (Enlighten, Bakery).
    L1Geomerics,
    /// `l1zh3`: the same data, the zonal quadratic term hallucinated from it (ZH3 paper).
    L1Zh3,
    /// `zh3`: L1 plus one stored zonal quadratic coefficient per colour about the
    /// luminance axis (ZH3 paper).
    Zh3,
    /// `l1lum`: RGB ambient plus L1 of luminance (Unreal's HQ lightmaps).
    L1Luminance,
    /// `shlmapw`: `shlmap`'s order-3 SH, deringed by a per-texel Hanning window.
    L2Deringed,
}

impl ShVariantBasis {
    pub const ALL: [ShVariantBasis; 6] = [
        ShVariantBasis::L1,
        ShVariantBasis::L1Geomerics,
        ShVariantBasis::L1Zh3,
        ShVariantBasis::Zh3,
        ShVariantBasis::L1Luminance,
        ShVariantBasis::L2Deringed,
    ];

    /// The encoding and reconstruction it runs.
    pub fn sh_basis(self) -> ShBasis {
        match self {
            ShVariantBasis::L1 => ShBasis::L1,
            ShVariantBasis::L1Geomerics => ShBasis::L1Geomerics,
            ShVariantBasis::L1Zh3 => ShBasis::L1Zh3Hallucinated,
            ShVariantBasis::Zh3 => ShBasis::Zh3,
            ShVariantBasis::L1Luminance => ShBasis::L1Luminance,
            ShVariantBasis::L2Deringed => ShBasis::L2Deringed,
        }
    }
}

/// The SH-lightmap variants engines ship (module doc): from the same bake as `shlmap`
/// (order-3 incident radiance with inter-reflection), each texel stores what its basis
/// keeps and the shader reconstructs irradiance at the normal-mapped normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShVariant {
    pub basis: ShVariantBasis,
}

impl Family for ShVariant {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "l1, l1geo, l1zh3, zh3, l1lum, shlmapw",
        what: "the SH lightmaps engines ship, from shlmap's bake: L1 (linear, Geomerics, hallucinated ZH3), stored ZH3, luminance L1, deringed L2",
        paper: "Frostbite, Enlighten, Roughton et al. ZH3 (i3D 2024), Unreal, Sloan (deringing)",
        in_paper_table: false,
    };
    const EXAMPLE: ShVariant = ShVariant {
        basis: ShVariantBasis::L1,
    };

    fn members() -> Vec<ShVariant> {
        ShVariantBasis::ALL
            .map(|basis| ShVariant { basis })
            .to_vec()
    }

    fn table_rows() -> Vec<ShVariant> {
        ShVariant::members()
    }

    fn headline(path: HwPath) -> Vec<ShVariant> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => [ShVariantBasis::L1, ShVariantBasis::Zh3]
                .map(|basis| ShVariant { basis })
                .to_vec(),
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.basis {
            ShVariantBasis::L1 => "l1",
            ShVariantBasis::L1Geomerics => "l1geo",
            ShVariantBasis::L1Zh3 => "l1zh3",
            ShVariantBasis::Zh3 => "zh3",
            ShVariantBasis::L1Luminance => "l1lum",
            ShVariantBasis::L2Deringed => "shlmapw",
        }
        .into()
    }

    fn paper_ms(self) -> Option<f64> {
        None
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
        let colours = match self.basis {
            ShVariantBasis::L1
            | ShVariantBasis::L1Geomerics
            | ShVariantBasis::L1Zh3
            | ShVariantBasis::L2Deringed => NormColours::Triplets,
            ShVariantBasis::Zh3 | ShVariantBasis::L1Luminance => NormColours::One,
        };
        Ok(Form::values(path, BlockCodec::Ratio(colours)))
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.basis, inputs, label)
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
        fragment_shader(self.basis)
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

    fn values(self) -> Option<super::values::ValueMap> {
        use super::values::{self, Colour, Value, ValueMap};
        let linear = "E_lin(n) = pi K_00 c_00 + (2 pi / 3) K_1 d . n per colour, d = (-c_11, -c_1-1, c_10), K_00 = 1 / (2 sqrt(pi)), K_1 = sqrt(3 / (4 pi))";
        let (names, evaluate): (Vec<String>, String) = match self.basis {
            ShVariantBasis::L2Deringed => {
                return Some(super::shlmap::value_map(
                    3,
                    "the clamped cosine's convolution windowed to be non-negative over the texel's hemisphere: A_l per texel folded into the stored values, so evaluate with A_l = (pi, 2 pi / 3, pi / 4)",
                ));
            }
            ShVariantBasis::L1 => {
                return Some(super::shlmap::value_map(
                    2,
                    "the clamped cosine's convolution: A_l = (pi, 2 pi / 3) for l = 0, 1",
                ));
            }
            ShVariantBasis::L1Geomerics => (
                values::sh_coefficient_names(2),
                "Geomerics' non-linear L1, per colour: r0 = pi K_00 c_00, r1 = (pi / 3) K_1 d; if r0 <= 0: 0; if |r1| = 0: r0; else r = min(|r1| / r0, 1), q = clamp((1 + n . r1 / |r1|) / 2, 0, 1), p = 1 + 2 r, a = (1 - r) / (1 + r), E = r0 (a + (1 - a) (p + 1) q^p)".into(),
            ),
            ShVariantBasis::L1Zh3 => (
                values::sh_coefficient_names(2),
                format!("{linear}; plus (pi / 4) z Y_20(axis . n) per colour, axis = the luminance-weighted d (0.2126, 0.7152, 0.0722) normalised (none: E_lin), Y_20(t) = sqrt(5 / (16 pi)) (3 t^2 - 1), z = c_00 (0.08 r + 0.6 r^2) with r = min(|d . axis| / c_00, sqrt(3)) (0 where c_00 <= 0)"),
            ),
            ShVariantBasis::Zh3 => {
                let mut names = values::sh_coefficient_names(2);
                names.push("zh_2 (about the luminance axis)".into());
                (
                    names,
                    format!("{linear}; plus (pi / 4) z Y_20(axis . n) per colour, z = coefficient 4 (stored), axis = the luminance-weighted d (0.2126, 0.7152, 0.0722) normalised (none: E_lin), Y_20(t) = sqrt(5 / (16 pi)) (3 t^2 - 1)"),
                )
            }
            ShVariantBasis::L1Luminance => {
                let names = values::sh_coefficient_names(2);
                let mut v = values::triplets(&names[..1]);
                v.extend((1..4).map(|k| {
                    Some(Value {
                        coefficient: names[k].clone(),
                        index: k,
                        colour: Colour::Shared,
                    })
                }));
                return Some(ValueMap {
                    stored: "incident radiance with inter-reflection: RGB order-1 SH and the luminance's order-2 band (luminance 0.2126 R + 0.7152 G + 0.0722 B)",
                    basis: serde_json::json!({"name": "sh", "order": 2, "frame": "world", "convention": "conventions.sh_basis"}),
                    values: v,
                    steps: values::evaluated_and_unscaled(values::WORLD_NORMAL, "E(n) = pi K_00 c_00 + c_00 (2 pi / 3) K_1 (e . n) / lum(c_00) per colour, e = (-e_11, -e_1-1, e_10) clamped to |e| <= sqrt(3) lum(c_00); 0 for the directional part where lum(c_00) <= 0"),
                });
            }
        };
        Some(ValueMap {
            stored: "incident radiance with inter-reflection, projected into SH (order 2, and for zh3 a zonal band-2 coefficient)",
            basis: serde_json::json!({"name": "sh", "order": 2, "frame": "world", "convention": "conventions.sh_basis"}),
            values: values::triplets(&names),
            steps: values::evaluated_and_unscaled(values::WORLD_NORMAL, &evaluate),
        })
    }
}
