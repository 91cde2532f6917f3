//! `unc3`, `unc4`, `unc6`: uncompressed SH visibility per texel and an L×H table indexed
//! by the normal (Iwanicki–Sloan §3, eq. (4); DESIGN §2).
//!
//! ```text
//! I_c(n) = Σ_j V_j(uv) · (L×H_n)_{c,j},   j < O²
//! ```
//!
//! Per texel: the first O² coefficients of the baked visibility, 4 per RGBA16F texel
//! (G = ⌈O²/4⌉ groups, `super::texels`; unc3's last group is padded with zeros). Per
//! lighting: the L×H table of `bake::lxh` for order O in the same groups per colour
//! (`super::tables`). dx9 binds G + 3 + 2 textures (unc6: 14 ≤ 16); the path rules refuse
//! more. The shader is `glsl/technique/unc.frag` over `glsl/include/grouped.glsl`.

use std::sync::Arc;

use ash::vk;
use half::f16;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::{LightingData, Recipe};
use super::spec::{BakeNeeds, ReferenceModel, paper_figure};
use super::tables::{lxh_table, normal_table_data, table_map};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{HwPath, Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::lxh::SymmetricBuild;
use crate::gpu::Context;
use crate::sh::Order;

/// RGBA groups of order-`order` visibility.
pub fn groups(order: Order) -> usize {
    order.coeff_count().div_ceil(VALUES_PER_TEXEL)
}

/// The fragment shader of `unc{order}`.
pub fn fragment_shader(order: Order) -> ShaderVariant {
    ShaderVariant {
        path: "technique/unc.frag",
        defines: vec![("UNC_GROUPS", groups(order) as u32)],
    }
}

/// The first O² visibility coefficients per texel, and the recipe of the lighting data
/// ([`lighting`]).
pub(crate) fn prepare(
    order: Order,
    path: HwPath,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let n = order.coeff_count();
    let vis = inputs.visibility.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the SH visibility bake".into(),
    })?;
    if vis.order < order {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs visibility of order {order}, the bake has {}",
                vis.order
            ),
        });
    }
    let texels = (vis.res * vis.res) as usize;
    let stride = vis.order.coeff_count();
    let vis_groups = pack_groups(texels, n, |t, j| f16::from_f32(vis.coeffs[t * stride + j]));
    let texels = TexelGroups::new(
        vk::Format::R16G16B16A16_SFLOAT,
        vis.res,
        &vis_groups,
        format!("{label}.visibility"),
    );
    let map = table_map(path, inputs.table_res, label)?;
    let table = Arc::new(SymmetricBuild::new(map));
    Ok((texels, Recipe::Unc { order, table }))
}

/// The L×H table of order `order` for `radiance_sh` over `table`'s map (`bake::lxh`), in
/// ⌈O²/4⌉ groups per colour, and its decoding block.
pub fn lighting(
    order: Order,
    path: HwPath,
    table: &SymmetricBuild,
    h_order: Order,
    radiance_sh: &[[f64; 3]],
    label: &str,
) -> Result<LightingData, TechniqueError> {
    let n = order.coeff_count();
    let map = table.map();
    let table = lxh_table(table, radiance_sh, order, h_order, label)?;
    let tables = normal_table_data(
        path,
        map,
        groups(order),
        |t, g, c| {
            std::array::from_fn(|k| {
                let j = VALUES_PER_TEXEL * g + k;
                if j < n {
                    table.values[t * n + j][c]
                } else {
                    0.0
                }
            })
        },
        None,
        &format!("{label}.lxh"),
    )?;
    Ok(LightingData {
        params: bytemuck::bytes_of(&tables.params(map.res())).to_vec(),
        tables: Some(tables),
        texels: None,
        defines: Vec::new(),
    })
}

/// The `uncO` family: O is the visibility order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Unc {
    pub order: Order,
}

/// Visibility orders a `uncO` name may ask for: the shader packs at most 9 RGBA groups
/// (order 6), and order 1 has no directional information to shadow with.
pub const UNC_ORDERS: std::ops::RangeInclusive<u32> = 2..=6;

/// The paper's ms/frame (GeForce GTX 295, 1280×800, 512² visibility).
const PAPER_MS: &[(u32, f64)] = &[(6, 8.19), (4, 3.33), (3, 2.75)];

impl Family for Unc {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "uncO",
        what: "SH visibility of order O per texel, an L×H table looked up by the normal",
        paper: "Iwanicki & Sloan §3",
        in_paper_table: true,
    };
    const EXAMPLE: Unc = Unc { order: Order::SIX };

    fn members() -> Vec<Unc> {
        UNC_ORDERS
            .filter_map(|o| Order::new(o).ok())
            .map(|order| Unc { order })
            .collect()
    }

    fn table_rows() -> Vec<Unc> {
        [Order::THREE, Order::FOUR, Order::SIX]
            .map(|order| Unc { order })
            .to_vec()
    }

    fn headline(path: HwPath) -> Vec<Unc> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => Unc::table_rows(),
            HwPath::Dx11 => vec![Unc::EXAMPLE],
        }
    }

    fn name(self) -> String {
        format!("unc{}", self.order)
    }

    fn paper_ms(self) -> Option<f64> {
        paper_figure(PAPER_MS, self.order.get())
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            visibility: Some(self.order),
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
                base: super::ndf_diffuse::NdfBase::Unc { order: self.order },
            }
            .into(),
        )
    }

    fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
        Ok(Form::values(path, BlockCodec::Ratio(NormColours::One)))
    }

    fn prepare(
        self,
        path: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.order, path, inputs, label)
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
        fragment_shader(self.order)
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
        use super::values::{self, Step};
        let names = values::sh_coefficient_names(self.order.coeff_count().isqrt());
        Some(values::ValueMap {
            stored: "visibility V(omega) (1 where the environment is seen, 0 where the scene blocks it), projected into SH",
            basis: serde_json::json!({
                "name": "sh",
                "order": self.order.get(),
                "frame": "world",
                "convention": "conventions.sh_basis",
            }),
            values: values::shared(&names),
            steps: [
                Step(serde_json::json!({
                    "op": "dot",
                    "with": "the L x H tables (manifest tables, in order) read at the world shading normal n: per colour, (L x H_n)_j for each value j, in the values' groups",
                    "at": values::WORLD_NORMAL,
                    "gives": "sum over j of V_j (L x H_n)_j, per colour (eq. (4) of Iwanicki & Sloan)",
                })),
                Step(serde_json::json!({"op": "multiply", "by": "uniform_block.unscale_res.x"})),
            ]
            .into_iter()
            .chain(values::diffuse_ending())
            .collect(),
        })
    }
}
