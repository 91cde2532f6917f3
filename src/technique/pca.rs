//! `pca4` … `pca24` and the weights-only `pca4w` … `pca24w` (Iwanicki–Sloan §4, eqs.
//! (5)–(6); DESIGN §2).
//!
//! The order-6 visibility is compressed to a mean V_e plus M principal vectors V_k
//! (`bake::pca`), weights quantized to 8-bit UNORM with each basis vector's range pushed
//! into the basis and the mean (so the shader reads weights in [0, 1] straight from RGBA8
//! textures, M/4 of them). Eq. (6) then needs, per lighting:
//!
//! - `pcaM`: a colour table per basis vector and one for the mean,
//!   T_k(n) = ∫ L V_k H_n = Σ_j V_kj (L×H_n)_j, built from the order-6 L×H table (`bake::lxh`)
//!   and laid out like `unc*` (`super::tables`: 4 basis vectors per RGBA texel, per
//!   colour) — M + 1 dependent lookups per pixel;
//! - `pcaMw`: per basis vector the order-3 SH of V_k·L (Gaunt product, `sh::product`),
//!   already multiplied by the clamped-cosine factors A_l, in a uniform block; the shader
//!   sums the weighted vectors and evaluates at the normal — no dependent lookups.
//!
//! Both compute ∫ L V H₃ (H truncated to order 3: the order-3 projection of V·L is all an
//! order-3 H sees), so they differ only by the table's parameterization and f16 storage.
//! The quantized model is refitted per M (the mean absorbs Σ_{k<M} lo_k V_k).

use std::sync::Arc;

use ash::vk;

use super::block::{BlockCodec, NormColours};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::{LightingData, Recipe};
use super::spec::{BakeNeeds, ReferenceModel, paper_figure};
use super::tables::{NormalTableData, lxh_table, normal_table_data, table_map};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{HwPath, Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::lxh::SymmetricBuild;
use crate::bake::pca::{PcaModel, QuantizedPca};
use crate::gpu::Context;
use crate::sh::Order;
use crate::sh::product::product;
use crate::sh::zonal::clamped_cosine_convolution;

/// Bits per stored weight.
pub const WEIGHT_BITS: u32 = 8;

/// Order of the lighting the weights-only variant multiplies the basis with.
const WEIGHTS_ONLY_LIGHTING_ORDER: u32 = 8;

/// Order of the lighting the weights-only blocks are built from.
pub fn weights_only_lighting_order() -> Order {
    Order::new(WEIGHTS_ONLY_LIGHTING_ORDER).expect("valid order")
}

/// The fragment shader of `pca{m}` / `pca{m}w`.
pub fn fragment_shader(m: u32, weights_only: bool) -> ShaderVariant {
    ShaderVariant {
        path: if weights_only {
            "technique/pcaw.frag"
        } else {
            "technique/pca.frag"
        },
        defines: vec![("PCA_GROUPS", m.div_ceil(VALUES_PER_TEXEL as u32))],
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

/// The first `m` vectors quantized: their weights per texel, and the recipe of the lighting
/// data ([`lighting`]: the quantized basis and mean).
pub(crate) fn prepare(
    m: u32,
    weights_only: bool,
    path: HwPath,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    let m = m as usize;
    let model = inputs.pca.ok_or_else(|| TechniqueError::Input {
        label: label.into(),
        detail: "needs the PCA of the visibility bake".into(),
    })?;
    if model.basis.len() < m {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs {m} principal vectors, the fit has {}",
                model.basis.len()
            ),
        });
    }
    let q = quantized_prefix(model, m);
    let weights = weight_groups(&q, label);
    let table = if weights_only {
        None
    } else {
        let map = table_map(path, inputs.table_res, label)?;
        Some(Arc::new(SymmetricBuild::new(map)))
    };
    Ok((
        weights,
        Recipe::Pca {
            order: model.order,
            table,
            basis: q.basis,
            mean: q.mean,
        },
    ))
}

/// The lighting data of a quantized basis (`basis`, `mean`, visibility order `order`):
/// with `table` (`pcaM`) the tables T_k(n) and T_e(n) over its map and their decoding
/// block; without (`pcaMw`) the V_k·L uniform block.
#[allow(clippy::too_many_arguments)]
pub fn lighting(
    basis: &[Vec<f64>],
    mean: &[f64],
    order: Order,
    path: HwPath,
    table: Option<&SymmetricBuild>,
    h_order: Order,
    radiance_sh: &[[f64; 3]],
    label: &str,
) -> Result<LightingData, TechniqueError> {
    let Some(table) = table else {
        let need = Order::new(WEIGHTS_ONLY_LIGHTING_ORDER)
            .expect("valid order")
            .coeff_count();
        super::require_coefficients(radiance_sh, need, "lighting", label)?;
        let block = weights_only_block(basis, mean, order, radiance_sh);
        return Ok(LightingData::params(bytemuck::cast_slice(&block).to_vec()));
    };
    let tables = tables_data(basis, mean, order, path, table, h_order, radiance_sh, label)?;
    Ok(LightingData {
        params: bytemuck::bytes_of(&tables.params(table.map().res())).to_vec(),
        tables: Some(tables),
        texels: None,
        defines: Vec::new(),
    })
}

/// The quantized weights, 4 per RGBA8 texel.
fn weight_groups(q: &QuantizedPca, label: &str) -> TexelGroups {
    let texels = (q.res * q.res) as usize;
    let groups = pack_groups(texels, q.m, |t, k| q.weights_unorm[t * q.m + k] as u8);
    TexelGroups::new(
        vk::Format::R8G8B8A8_UNORM,
        q.res,
        &groups,
        format!("{label}.weights"),
    )
}

/// Uniforms of glsl/technique/pcaw.frag: per basis vector, then the mean, the order-3 SH
/// of V_k·L times A_l, RGB in .xyz.
pub fn weights_only_block(
    basis: &[Vec<f64>],
    mean: &[f64],
    order: Order,
    radiance_sh: &[[f64; 3]],
) -> Vec<[f32; 4]> {
    let l_order = Order::new(WEIGHTS_ONLY_LIGHTING_ORDER).expect("valid order");
    let coeffs_of = |v: &[f64]| -> [[f32; 4]; 9] {
        let mut out = [[0.0f32; 4]; 9];
        for c in 0..3 {
            let l: Vec<f64> = radiance_sh[..l_order.coeff_count()]
                .iter()
                .map(|rgb| rgb[c])
                .collect();
            let vl = product(&l, l_order, v, order, Order::THREE);
            for (i, o) in out.iter_mut().enumerate() {
                let band = (i as f64).sqrt().floor() as u32;
                o[c] = (clamped_cosine_convolution(band) * vl[i]) as f32;
            }
        }
        out
    };
    basis
        .iter()
        .map(Vec::as_slice)
        .chain(std::iter::once(mean))
        .flat_map(coeffs_of)
        .collect()
}

/// Tables T_k(n) = Σ_j V_kj (L×H_n)_j and the mean's, from the order-6 L×H table.
#[allow(clippy::too_many_arguments)]
fn tables_data(
    basis: &[Vec<f64>],
    mean: &[f64],
    order: Order,
    path: HwPath,
    table: &SymmetricBuild,
    h_order: Order,
    radiance_sh: &[[f64; 3]],
    label: &str,
) -> Result<NormalTableData, TechniqueError> {
    let m = basis.len();
    let map = table.map();
    let lxh = lxh_table(table, radiance_sh, order, h_order, label)?;
    let project = |t: usize, v: &[f64]| lxh.project(t, v);
    let samples = map.sample_count();
    let basis_tables: Vec<[f32; 3]> = (0..samples)
        .flat_map(|t| basis.iter().map(move |b| (t, b)))
        .map(|(t, b)| project(t, b))
        .collect();
    let mean_table: Vec<[f32; 3]> = (0..samples).map(|t| project(t, mean)).collect();
    let mean_fn = |t: usize| mean_table[t];
    normal_table_data(
        path,
        map,
        m.div_ceil(VALUES_PER_TEXEL),
        |t, g, c| {
            std::array::from_fn(|lane| {
                let k = VALUES_PER_TEXEL * g + lane;
                if k < m {
                    basis_tables[t * m + k][c]
                } else {
                    0.0
                }
            })
        },
        Some(&mean_fn),
        &format!("{label}.tables"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model with `full` orthonormal axis vectors and weights that are a known function
    /// of (texel, k).
    fn model(full: usize, texels: usize) -> PcaModel {
        let n = 36;
        PcaModel {
            order: Order::SIX,
            mean: (0..n).map(|j| 0.01 * j as f64).collect(),
            basis: (0..full)
                .map(|k| (0..n).map(|j| if j == k { 1.0 } else { 0.0 }).collect())
                .collect(),
            eigenvalues: vec![1.0; n],
            weights: (0..texels * full)
                .map(|i| ((i % full) as f32 - 3.0) * 0.25 + (i / full) as f32 * 0.125)
                .collect(),
            res: (texels as f64).sqrt() as u32,
        }
    }

    #[test]
    fn quantized_prefix_is_the_first_m_vectors_within_a_quantization_step() {
        let full = model(24, 16);
        for m in [4usize, 8, 12, 24] {
            let q = quantized_prefix(&full, m);
            assert_eq!((q.m, q.basis.len()), (m, m));
            assert_eq!(q.weights_unorm.len(), 16 * m);
            for t in 0..16 {
                // The prefix reconstructs mean + the first m weighted vectors of the full
                // model, to within half a quantization step per weight.
                let want: Vec<f64> = (0..36)
                    .map(|j| {
                        full.mean[j]
                            + (0..m)
                                .map(|k| full.weights[t * 24 + k] as f64 * full.basis[k][j])
                                .sum::<f64>()
                    })
                    .collect();
                let got = q.reconstruct(t);
                let step = 0.5
                    * q.basis
                        .iter()
                        .map(|b| b.iter().fold(0.0f64, |a, v| a.max(v.abs())))
                        .fold(0.0, f64::max)
                    / 255.0;
                for j in 0..36 {
                    assert!(
                        (got[j] - want[j]).abs() <= step + 1e-9,
                        "m {m} t {t} j {j}: {} vs {}",
                        got[j],
                        want[j]
                    );
                }
            }
        }
        // Asking for more vectors than the fit has gives them all.
        assert_eq!(quantized_prefix(&model(8, 4), 12).m, 8);
    }
}

/// The `pcaM` / `pcaMw` family: M PCA weights per texel; `weights_only`: the basis'
/// SH(V_k·L) in uniforms instead of tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Pca {
    pub m: u32,
    pub weights_only: bool,
}

/// Largest PCA basis (`pca24`): the fit in `prepare` computes this many vectors.
pub const PCA_MAX_VECTORS: u32 = 24;
/// PCA weights are packed 4 per RGBA8 texel, so M is a multiple of this.
pub const PCA_VECTORS_PER_TEXEL: u32 = 4;

/// The paper's ms/frame of the table variant (the only one it timed).
const PAPER_MS: &[(u32, f64)] = &[(4, 1.40), (8, 2.08), (16, 3.61), (24, 5.56)];

/// Every M a `pcaM` name may take.
pub fn vector_counts() -> impl Iterator<Item = u32> {
    (PCA_VECTORS_PER_TEXEL..=PCA_MAX_VECTORS).step_by(PCA_VECTORS_PER_TEXEL as usize)
}

impl Family for Pca {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "pcaM, pcaMw",
        what: "M PCA weights of the visibility per texel; per-vector tables (w: SH of V_k·L in uniforms)",
        paper: "Iwanicki & Sloan §3–4",
        in_paper_table: true,
    };
    const EXAMPLE: Pca = Pca {
        m: 8,
        weights_only: false,
    };

    fn members() -> Vec<Pca> {
        vector_counts()
            .flat_map(|m| [false, true].map(|weights_only| Pca { m, weights_only }))
            .collect()
    }

    fn table_rows() -> Vec<Pca> {
        [false, true]
            .into_iter()
            .flat_map(|weights_only| [4, 8, 12, 16, 24].map(|m| Pca { m, weights_only }))
            .collect()
    }

    fn headline(path: HwPath) -> Vec<Pca> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => Pca::table_rows(),
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        format!("pca{}{}", self.m, if self.weights_only { "w" } else { "" })
    }

    fn paper_ms(self) -> Option<f64> {
        (!self.weights_only)
            .then(|| paper_figure(PAPER_MS, self.m))
            .flatten()
    }

    fn needs(self) -> BakeNeeds {
        BakeNeeds {
            visibility: Some(Order::SIX),
            pca_vectors: Some(self.m),
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
        None
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
        prepare(self.m, self.weights_only, path, inputs, label)
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
        fragment_shader(self.m, self.weights_only)
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
        None
    }
}
