//! `preconv`: scalar ambient occlusion × irradiance from the pre-convolved environment
//! (Iwanicki–Sloan §2 and §5, "Preconv"; DESIGN §2).
//!
//! radiance = albedo/π · AO(x) · E(n), with E(n) = Σ_{l<3} A_l Σ_m L_lm y_lm(n) evaluated at
//! the normal-mapped normal, so shadows of the sun are not modelled at all — only
//! how open each texel is. Per texel: one f16 (R16_SFLOAT, 2 bytes). Per lighting: 9 RGB
//! coefficients in a uniform block. dx9 binds AO as a 2D texture, dx10 as a one-layer
//! 2D array (`super::texels`), the rest is shared (glsl/technique/preconv.frag).

use ash::vk;
use half::f16;

use super::block::BlockCodec;
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::{LightingData, Recipe};
use super::spec::{BakeNeeds, ReferenceModel};
use super::texels::TexelGroups;
use super::{HwPath, ShaderReads, Technique};
use super::{Inputs, ShaderVariant, TechniqueError, rgb_order3_block};
use crate::gpu::Context;
use std::sync::Arc;

/// Uniforms of glsl/technique/preconv.frag, block `PreconvParams` (std140).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PreconvParams {
    /// offset 0: order-3 irradiance SH, RGB in .xyz (std140 pads vec3 arrays to 16 B).
    pub irradiance_sh: [[f32; 4]; 9],
}
const _: () = assert!(std::mem::size_of::<PreconvParams>() == 144);
crate::gpu::layout::glsl_block!(PreconvParams = "PreconvParams" { irradiance_sh });

/// The fragment shader of `preconv`.
pub fn fragment_shader() -> ShaderVariant {
    ShaderVariant {
        path: "technique/preconv.frag",
        defines: vec![],
    }
}

/// The ambient occlusion per texel, and the recipe of the lighting data.
pub(crate) fn prepare(inputs: &Inputs<'_>, label: &str) -> (TexelGroups, Recipe) {
    let ao = inputs.ao;
    let ao_f16: Vec<f16> = ao.values.iter().map(|&a| f16::from_f32(a)).collect();
    let texels = TexelGroups::new(
        vk::Format::R16_SFLOAT,
        ao.res,
        &[ao_f16],
        format!("{label}.ao"),
    );
    (texels, Recipe::Preconv)
}

/// The uniform block of order-3 irradiance `irradiance_sh`.
pub fn lighting(irradiance_sh: &[[f64; 3]], label: &str) -> Result<LightingData, TechniqueError> {
    super::require_coefficients(irradiance_sh, 9, "irradiance", label)?;
    let params = PreconvParams {
        irradiance_sh: rgb_order3_block(irradiance_sh),
    };
    Ok(LightingData::params(bytemuck::bytes_of(&params).to_vec()))
}

/// The `preconv` family (one member).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Preconv;

impl Family for Preconv {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "preconv",
        what: "ambient occlusion × pre-convolved irradiance at the normal",
        paper: "Iwanicki & Sloan §5",
        in_paper_table: true,
    };
    const EXAMPLE: Preconv = Preconv;

    fn members() -> Vec<Preconv> {
        vec![Preconv]
    }

    fn table_rows() -> Vec<Preconv> {
        vec![Preconv]
    }

    fn headline(path: HwPath) -> Vec<Preconv> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Preconv],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        "preconv".into()
    }

    fn paper_ms(self) -> Option<f64> {
        Some(0.648)
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            ao: true,
            ..BakeNeeds::default()
        }
    }

    fn reference(self) -> ReferenceModel {
        ReferenceModel::Direct
    }

    fn dynamic_lighting(self) -> bool {
        true
    }

    fn ndf_variant(self) -> Option<Technique> {
        Some(
            super::ndf_diffuse::Ndf {
                base: super::ndf_diffuse::NdfBase::Preconv,
            }
            .into(),
        )
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        Ok(Form::values(path, BlockCodec::Bc4))
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        Ok(prepare(inputs, label))
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

    fn values(self) -> Option<super::values::ValueMap> {
        use super::values::{self, Colour, Step, Value, ValueMap};
        Some(ValueMap {
            stored: "ambient occlusion: the texel's unoccluded fraction of the cosine-weighted hemisphere",
            basis: serde_json::json!({"name": "scalar"}),
            values: vec![Some(Value {
                coefficient: "AO".into(),
                index: 0,
                colour: Colour::Shared,
            })],
            steps: [
                Step(serde_json::json!({
                    "op": "evaluate",
                    "at": values::WORLD_NORMAL,
                    "gives": "E(n) = sum over k < 9 of E_k y_k(n), per colour, E_k = uniform_block.irradiance_sh[k].rgb (order-3 SH of irradiance: the clamped cosine's A_l already folded in)",
                })),
                Step(serde_json::json!({"op": "multiply", "by": "AO"})),
            ]
            .into_iter()
            .chain(values::diffuse_ending())
            .collect(),
        })
    }
}
