//! Radiosity normal mapping and self-shadowed bump maps (Green, "Efficient self-shadowed
//! radiosity normal mapping", Valve): `rnm`, `rnmao`, `ssbump`.
//!
//! Per lightmap texel three RGB irradiances E_i around the HL2 basis directions B_i in the
//! texel's tangent frame ([`crate::bake::shlmap`], eq. (3) there: the clamped-cosine lobe
//! about B_i, with the SH lightmap's visibility and inter-reflection). Per pixel
//! (`glsl/technique/rnm.frag`), with weights w:
//!
//! ```text
//! rnm:     w_i = saturate(N·B_i)² / Σ_j saturate(N·B_j)²         (Listing 1, eq. (3))
//! rnmao:   w_i = Listing 1's · AO                                  (scalar AO of the height field)
//! ssbump:  w_i = SSBump_i = D_i · occlusion_i                      (Listing 2)
//! radiance = albedo/π · Σ_i w_i E_i
//! ```
//!
//! N is the normal map's tangent-space normal. `ssbump` does not read the normal map at
//! all: its texel replaces it. The SSBump / AO texture (RGB SSBump, A AO, with a box MIP
//! chain; RGBA8 UNORM as Valve ships it and as the normal map is stored, 4 bytes per height
//! texel — RGBA16F only to test the shader at f16 precision) lives in material space,
//! sampled like the normal map; like albedo and normal map it counts in textures and lookups, not in the lightmap
//! bytes. Per lightmap texel: the three lightmaps as three RGBA16F groups (the alpha
//! unused: dx9's three lightmap textures, dx10's 3-layer array), 24 bytes, range-scaled into
//! f16 as `shlmap`'s values are.

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::{SlotKind, TextureSlot};
use super::lighting::Recipe;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::tables::{f16_range_scale, max_abs};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{Inputs, ShaderVariant, TechniqueError};
use super::{ShaderReads, Technique};
use crate::bake::ssbump::{SsBumpMaps, SsBumpStorage};
use crate::gpu::layout::ShaderIds;
use crate::gpu::{Context, Image, ImageDesc};

/// Lightmaps per texel (one RGBA group each).
pub const RNM_LIGHTMAPS: usize = 3;

/// `SHVIS_RNM_VARIANT`'s ids (glsl/technique/rnm.frag): each variant's
/// `RnmVariant::shader_value`, named.
pub fn variant_ids() -> ShaderIds {
    let name = |variant: RnmVariant| match variant {
        RnmVariant::NormalMap => "RNM_NORMAL_MAP",
        RnmVariant::NormalMapAo => "RNM_NORMAL_MAP_AO",
        RnmVariant::SelfShadowed => "RNM_SELF_SHADOWED",
    };
    ShaderIds {
        selector: "RNM_VARIANT",
        ids: RnmVariant::ALL
            .iter()
            .map(|&variant| (name(variant), variant.shader_value()))
            .collect(),
    }
}

/// The fragment shader of a variant.
pub fn fragment_shader(variant: RnmVariant) -> ShaderVariant {
    ShaderVariant {
        path: "technique/rnm.frag",
        defines: vec![("RNM_VARIANT", variant.shader_value())],
    }
}

/// The three lightmaps, range-scaled into f16, and a recipe that always gives the block
/// undoing that scale (the lighting is baked in).
pub(crate) fn prepare(
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let input_error = |detail: &str| TechniqueError::Input {
        label: label.into(),
        detail: detail.into(),
    };
    let map = inputs
        .sh_lightmap
        .ok_or_else(|| input_error("needs the SH lightmap bake (its rnm lightmaps)"))?;
    let texels = (map.res * map.res) as usize;
    if map.basis_irradiance.len() != texels {
        return Err(input_error("the SH lightmap bake has no rnm lightmaps"));
    }
    let max = max_abs(
        map.basis_irradiance
            .iter()
            .flat_map(|b| b.iter().flat_map(|v| v.to_array())),
    );
    if !max.is_finite() {
        return Err(input_error(
            "the rnm lightmaps are not finite (non-finite lighting?)",
        ));
    }
    let scale = f16_range_scale(max);
    // Value 4i + c of a texel is colour c of lightmap i (c = 3: padding).
    let groups = pack_groups(texels, RNM_LIGHTMAPS * VALUES_PER_TEXEL, |t, value| {
        let (i, c) = (value / VALUES_PER_TEXEL, value % VALUES_PER_TEXEL);
        match c {
            3 => f16::ZERO,
            _ => f16::from_f32(map.basis_irradiance[t][i][c] * scale),
        }
    });
    Ok(super::shlmap::baked_lightmap(
        &groups,
        map.res,
        format!("{label}.lightmaps"),
        scale,
    ))
}

/// The material-space SSBump / AO texture `rnmao` and `ssbump` bind (module doc), or `None`
/// for `rnm`.
///
/// # Errors
/// An input error when the variant needs the maps and the scene has none (no height map).
pub(crate) fn material_texture(
    ctx: &Arc<Context>,
    variant: RnmVariant,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<Option<Image>, TechniqueError> {
    if !variant.needs_height() {
        return Ok(None);
    }
    let maps = inputs.ssbump.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the material's height map (the built-in scenes have one; a glTF scene takes --height-map FILE --height-scale S)".into(),
    })?;
    if maps.texels.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: "the SSBump texture is not finite".into(),
        });
    }
    Ok(Some(upload_maps(ctx, maps, &format!("{label}.ssbump_ao"))?))
}

/// The image of `maps` in its storage format with its box-filtered MIP chain.
fn upload_maps(ctx: &Arc<Context>, maps: &SsBumpMaps, name: &str) -> Result<Image, TechniqueError> {
    let levels = crate::scene::mip::box_mip_levels(maps.width, maps.height, maps.texels.clone());
    let (format, bytes): (vk::Format, Vec<Vec<u8>>) = match maps.storage {
        SsBumpStorage::Unorm8 => (
            vk::Format::R8G8B8A8_UNORM,
            levels
                .iter()
                .map(|(_, _, texels)| {
                    texels
                        .iter()
                        .flat_map(|t| t.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8))
                        .collect()
                })
                .collect(),
        ),
        SsBumpStorage::Float16 => (
            vk::Format::R16G16B16A16_SFLOAT,
            levels
                .iter()
                .map(|(_, _, texels)| {
                    texels
                        .iter()
                        .flat_map(|t| t.map(|v| f16::from_f32(v).to_bits()))
                        .flat_map(u16::to_le_bytes)
                        .collect()
                })
                .collect(),
        ),
    };
    let level_bytes: Vec<Vec<&[u8]>> = bytes.iter().map(|b| vec![b.as_slice()]).collect();
    let desc =
        ImageDesc::texture_2d(format, maps.width, maps.height).mip_levels(levels.len() as u32);
    Ok(Image::with_data(ctx, &desc, &level_bytes, name)?)
}

/// Which per-pixel weights blend the three `rnm` lightmaps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RnmVariant {
    /// `rnm`: saturate(N·B_i)², normalized (Listing 1).
    NormalMap,
    /// `rnmao`: Listing 1 times the height field's scalar ambient occlusion.
    NormalMapAo,
    /// `ssbump`: D_i · directional occlusion_i read from the SSBump texture (Listing 2).
    SelfShadowed,
}

impl RnmVariant {
    pub const ALL: [RnmVariant; 3] = [
        RnmVariant::NormalMap,
        RnmVariant::NormalMapAo,
        RnmVariant::SelfShadowed,
    ];

    /// The value of the shader macro `SHVIS_RNM_VARIANT`.
    pub fn shader_value(self) -> u32 {
        match self {
            RnmVariant::NormalMap => 0,
            RnmVariant::NormalMapAo => 1,
            RnmVariant::SelfShadowed => 2,
        }
    }

    /// Whether it reads the height field's SSBump / AO texture.
    pub fn needs_height(self) -> bool {
        self != RnmVariant::NormalMap
    }
}

/// The radiosity-normal-mapping family (Green, Valve): three lightmaps of irradiance around
/// the HL2 tangent-space basis, blended per pixel — `rnm` (Listing 1, weights from the
/// normal map), `rnmao` (× scalar AO of the height field), `ssbump` (Listing 2, the
/// self-shadowed bump map's texels are the weights).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rnm {
    pub variant: RnmVariant,
}

impl Family for Rnm {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "rnm, rnmao, ssbump",
        what: "radiosity normal mapping: three lightmaps in the HL2 basis; ao: × height-field AO; ssbump: self-shadowed bump map",
        paper: "Green, Valve (SIGGRAPH 2007 course)",
        in_paper_table: false,
    };
    const EXAMPLE: Rnm = Rnm {
        variant: RnmVariant::NormalMap,
    };

    fn members() -> Vec<Rnm> {
        RnmVariant::ALL.map(|variant| Rnm { variant }).to_vec()
    }

    fn table_rows() -> Vec<Rnm> {
        Rnm::members()
    }

    fn headline(path: HwPath) -> Vec<Rnm> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Rnm::EXAMPLE],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        match self.variant {
            RnmVariant::NormalMap => "rnm",
            RnmVariant::NormalMapAo => "rnmao",
            RnmVariant::SelfShadowed => "ssbump",
        }
        .into()
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            ssbump: self.variant.needs_height(),
            ..BakeNeeds::SH_LIGHTMAP
        }
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
        Ok(Form {
            material_textures: self.variant.needs_height(),
            ..Form::values(path, BlockCodec::Ratio(NormColours::GroupRgb))
        })
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
        ctx: &Arc<Context>,
        _: HwPath,
        inputs: &Inputs<'_>,
        label: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError> {
        let images: Vec<Image> = material_texture(ctx, self.variant, inputs, label)?
            .into_iter()
            .collect();
        Ok((!images.is_empty()).then_some(TextureSlot {
            kind: SlotKind::Material,
            images,
        }))
    }

    fn fragment_shader(self) -> ShaderVariant {
        fragment_shader(self.variant)
    }

    fn reads(self) -> ShaderReads {
        ShaderReads {
            reads_normal_map: match self.variant {
                RnmVariant::NormalMap | RnmVariant::NormalMapAo => true,
                RnmVariant::SelfShadowed => false,
            },
            ..ShaderReads::PLAIN
        }
    }

    fn options_tag(self, _: &()) -> Option<String> {
        None
    }

    fn sample_fit(self, _: &()) -> Option<crate::sh::samples::SampleFit> {
        None
    }

    fn values(self) -> Option<super::values::ValueMap> {
        use super::values::{self, Colour, Value, ValueMap};
        let basis = crate::bake::ssbump::hl2_basis();
        // Three RGB groups, their alphas padding.
        let values = (0..3)
            .flat_map(|i| {
                (0..4).map(move |c| {
                    (c < 3).then(|| Value {
                        coefficient: format!("E_{i}"),
                        index: i,
                        colour: Colour::Channel(c as u8),
                    })
                })
            })
            .collect();
        let weights = match self.variant {
            RnmVariant::NormalMap => "w_i = saturate(m . B_i)^2 / sum over j of saturate(m . B_j)^2",
            RnmVariant::NormalMapAo => "w_i = saturate(m . B_i)^2 / sum over j of saturate(m . B_j)^2, times the height field's AO",
            RnmVariant::SelfShadowed => "w_i = the SSBump texel's channel i (it replaces the normal map)",
        };
        Some(ValueMap {
            stored: "irradiance about each of the three HL2 basis directions (the clamped-cosine lobe about B_i, with visibility and inter-reflection)",
            basis: serde_json::json!({
                "name": "radiosity normal mapping (HL2 basis)",
                "reference": "Green, Efficient self-shadowed radiosity normal mapping, Valve",
                "frame": "tangent (x along +u, y image up, z the surface normal)",
                "directions": basis.map(|b| [b.x, b.y, b.z]),
            }),
            values,
            steps: values::evaluated_and_unscaled(
                values::TANGENT_NORMAL,
                &format!("E = sum over i of w_i E_i, per colour; {weights}"),
            ),
        })
    }
}
