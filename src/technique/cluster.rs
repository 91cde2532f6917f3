//! What `vqK` and `cpcaK_M` share (their families are `super::vq` and `super::cpca`): VQ and
//! iterative CPCA of the order-6 visibility (`bake::cluster`,
//! after the PRT course) on dx9 and dx10 (dx11 refuses them:
//! `Refusal::ClusterIndices`).
//!
//! Per texel: M 8-bit UNORM weights in the cluster's quantized basis, then the cluster index
//! as UNORM8 (K ≤ 256), packed 4 values per RGBA8 texel (`super::texels`; VQ, M = 0, is
//! one R8 texel). Per lighting: per cluster C the weights-only block of `pcaMw`
//! (`super::pca::weights_only_block`): for each vector B_C,k' and the mean μ_C' the order-3
//! SH of B·L times the clamped-cosine factors A_l, so radiance = albedo/π ·
//! E(n) with E = Σ_i (μ_C,i + Σ_k w_k B_C,k,i) y_i(n) — the per-cluster work on the CPU, the
//! linear combination on the GPU.
//!
//! Across a cluster boundary the bilinearly filtered weights of two clusters mean nothing
//! in either basis; [`SeamMode::Blended`] decodes each of the four bilinear taps in its own
//! cluster and blends the results (glsl/technique/cluster.frag), [`SeamMode::Naive`]
//! shows the artifact.
//!
//! dx9 and dx10 take the per-cluster block as uniforms ([`CLUSTER_UNIFORM_VEC4S`], 64
//! KiB); dx9's constant-register budget is not modelled, as for `pcaMw`.

use ash::vk;

use super::family::{Form, Refusal};
use super::lighting::{LightingData, Recipe};
use super::spec::{BakeNeeds, ClusterNeed, HwPath};
use super::texels::{TexelGroups, VALUES_PER_TEXEL, pack_groups};
use super::{Inputs, ShaderVariant, TechniqueError};
use super::{PerTexelTaps, ShaderReads};
use crate::bake::cluster::{ClusteredModel, QuantizedClusters};
use crate::cost::{CountPlan, CountVariant};
use crate::gpu::layout::ShaderIds;
use crate::sh::Order;

/// The fragment shader of `vqK` / `cpcaK_M`.
pub fn fragment_shader(k: u32, m: u32, seams: SeamMode) -> ShaderVariant {
    ShaderVariant {
        path: "technique/cluster.frag",
        defines: vec![
            ("CLUSTERS", k),
            ("CLUSTER_VECTORS", m),
            ("SEAM_BLEND", (seams == SeamMode::Blended) as u32),
        ],
    }
}

/// RGBA groups per texel: M weights and the index.
pub fn texel_groups(m: u32) -> u32 {
    (m + 1).div_ceil(VALUES_PER_TEXEL as u32)
}

/// Per-texel fetches of the shader: 4 unfiltered taps of every group (blended), or every
/// group filtered plus the nearest texel's index group (naive; VQ reads only the index).
pub fn per_texel_lookups(m: u32, seams: SeamMode) -> u32 {
    let groups = texel_groups(m);
    match seams {
        SeamMode::Blended => 4 * groups,
        SeamMode::Naive if m == 0 => 1,
        SeamMode::Naive => groups + 1,
    }
}

/// Of [`per_texel_lookups`], the unfiltered fetches (`texelFetch`): every tap where seams
/// are blended, the nearest texel's index group where they are naive.
pub fn per_texel_fetches(m: u32, seams: SeamMode) -> u32 {
    match seams {
        SeamMode::Blended => per_texel_lookups(m, seams),
        SeamMode::Naive => 1,
    }
}

/// What the shader of `vqK` / `cpcaK_M` (M = 0 for VQ) reads: its taps, counted by
/// [`count_plan`].
pub fn reads(m: u32, seams: SeamMode) -> ShaderReads {
    ShaderReads {
        per_texel_taps: Some(PerTexelTaps {
            lookups: per_texel_lookups(m, seams),
            fetches: per_texel_fetches(m, seams),
        }),
        count_plan: Some(count_plan(seams)),
        ..ShaderReads::PLAIN
    }
}

/// `SHVIS_COUNT_PATH` of the count shader glsl/cost/cluster.frag: which part of the decode
/// a count build keeps ([`count_plan`]).
const COUNT_INSIDE: u32 = 1;
const COUNT_ACROSS: u32 = 2;
const COUNT_MEASURE: u32 = 3;
const COUNT_BEFORE_BRANCH: u32 = 4;
const COUNT_ACROSS_LOOP_CUT: u32 = 5;

/// `SHVIS_COUNT_PATH`'s ids (glsl/cost/cluster.frag).
pub fn count_path_ids() -> ShaderIds {
    ShaderIds {
        selector: "COUNT_PATH",
        ids: vec![
            ("COUNT_INSIDE", COUNT_INSIDE),
            ("COUNT_ACROSS", COUNT_ACROSS),
            ("COUNT_MEASURE", COUNT_MEASURE),
            ("COUNT_BEFORE_BRANCH", COUNT_BEFORE_BRANCH),
            ("COUNT_ACROSS_LOOP_CUT", COUNT_ACROSS_LOOP_CUT),
        ],
    }
}

/// How the cost model counts the shader ([`CountPlan`]): its decode runs once where the
/// bilinear footprint lies inside one cluster and four times where it straddles clusters
/// (blended seams), so its counts are the inside path's (the count shader
/// glsl/cost/cluster.frag, `COUNT_INSIDE`, loops unrolled) plus, for the measured share of
/// fragments whose subgroup takes the boundary path (`COUNT_MEASURE`), the boundary path's
/// (`COUNT_ACROSS`) less the work before the branch (`COUNT_BEFORE_BRANCH`), counted once
/// already; the naive shader runs one path. Where no lane of a batch takes the boundary
/// path, its straight-line code — the boundary path with its loops cut
/// (`COUNT_ACROSS_LOOP_CUT`), less the work before the branch — is untaken work (on
/// lavapipe, which runs it masked and skips a loop no lane enters, measured: vq256 14.8 ms
/// with the branch taken out, 28.0 with it there and never taken; cpca8_7 39.8 and 53.5).
pub fn count_plan(seams: SeamMode) -> CountPlan {
    const COUNT_SHADER: &str = "cost/cluster.frag";
    let variant = |path, share, share_per_measured| CountVariant {
        defines: vec![("COUNT_PATH", path)],
        share,
        share_per_measured,
        untaken: false,
    };
    let untaken = |path, share, share_per_measured| CountVariant {
        untaken: true,
        ..variant(path, share, share_per_measured)
    };
    match seams {
        SeamMode::Naive => CountPlan {
            shader: COUNT_SHADER,
            measure_defines: None,
            variants: vec![variant(COUNT_INSIDE, 1.0, 0.0)],
        },
        SeamMode::Blended => CountPlan {
            shader: COUNT_SHADER,
            measure_defines: Some(vec![("COUNT_PATH", COUNT_MEASURE)]),
            variants: vec![
                variant(COUNT_INSIDE, 1.0, 0.0),
                variant(COUNT_ACROSS, 0.0, 1.0),
                variant(COUNT_BEFORE_BRANCH, 0.0, -1.0),
                untaken(COUNT_ACROSS_LOOP_CUT, 1.0, -1.0),
                untaken(COUNT_BEFORE_BRANCH, -1.0, 1.0),
            ],
        },
    }
}

/// The model `need` names among `inputs.clusters`.
pub fn find<'a>(
    inputs: &Inputs<'a>,
    need: ClusterNeed,
    label: &str,
) -> Result<&'a ClusteredModel, TechniqueError> {
    inputs
        .clusters
        .iter()
        .find(|c| need.is_met_by(c))
        .ok_or_else(|| TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs a {:?} fit of {} clusters × {} vectors of the visibility \
                 (Prepared::fit_clusters)",
                need.clustering, need.k, need.m
            ),
        })
}

/// The quantized model's weights and indices per texel, and the recipe of its lighting
/// data.
pub(crate) fn prepare(
    need: ClusterNeed,
    inputs: &Inputs<'_>,
    label: &str,
) -> Result<(TexelGroups, Recipe), TechniqueError> {
    if need.k > 256 || !clusters_fit_uniforms(need.k, need.m) {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "{} clusters × {} vectors do not fit an 8-bit index and a 64 KiB uniform block",
                need.k, need.m
            ),
        });
    }
    let model = find(inputs, need, label)?;
    let q = model.quantize();
    Ok((
        texel_data(&q, label),
        Recipe::Clustered {
            order: q.order,
            bases: q.bases,
            means: q.means,
        },
    ))
}

/// Weights then the index per texel (module doc).
fn texel_data(q: &QuantizedClusters, label: &str) -> TexelGroups {
    let texels = (q.res * q.res) as usize;
    let name = format!("{label}.weights_index");
    if q.m == 0 {
        let index: Vec<u8> = q.cluster_of.iter().map(|&c| c as u8).collect();
        return TexelGroups::new(vk::Format::R8_UNORM, q.res, &[index], name);
    }
    let groups = pack_groups(texels, q.m + 1, |t, j| {
        if j < q.m {
            q.weights_unorm[t * q.m + j]
        } else {
            q.cluster_of[t] as u8
        }
    });
    TexelGroups::new(vk::Format::R8G8B8A8_UNORM, q.res, &groups, name)
}

/// The uniform block (glsl/technique/cluster.frag): per cluster its `pcaMw` block.
pub fn lighting(
    bases: &[Vec<Vec<f64>>],
    means: &[Vec<f64>],
    order: Order,
    radiance_sh: &[[f64; 3]],
    label: &str,
) -> Result<LightingData, TechniqueError> {
    super::require_coefficients(
        radiance_sh,
        super::pca::weights_only_lighting_order().coeff_count(),
        "lighting",
        label,
    )?;
    let block: Vec<[f32; 4]> = bases
        .iter()
        .zip(means)
        .flat_map(|(basis, mean)| super::pca::weights_only_block(basis, mean, order, radiance_sh))
        .collect();
    Ok(LightingData::params(bytemuck::cast_slice(&block).to_vec()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_count_build_unrolls_every_loop() {
        // A loop left in a count build would be counted once instead of per iteration.
        for m in CPCA_VECTORS.iter().copied().chain([0]) {
            for seams in [SeamMode::Blended, SeamMode::Naive] {
                for path in [
                    super::super::spec::HwPath::Dx9,
                    super::super::spec::HwPath::Dx10,
                ] {
                    let plan = count_plan(seams);
                    // The measuring build compiles too (with and without subgroup votes).
                    for vote in plan.measure_defines.iter().flat_map(|_| [0, 1]) {
                        let mut defines = fragment_shader(8, m, seams).defines;
                        defines.extend(path.shader_defines());
                        defines.extend(super::super::block::shader_id_defines());
                        defines.push(("MATERIAL_LEVEL0", 0));
                        defines.push(("SUBGROUP_VOTE", vote));
                        defines.extend(plan.measure_defines.iter().flatten().copied());
                        crate::gpu::compile_glsl(
                            plan.shader,
                            crate::gpu::ShaderStage::Fragment,
                            &defines,
                        )
                        .unwrap_or_else(|e| panic!("measuring build {defines:?}: {e}"));
                    }
                    for variant in plan.variants {
                        let mut defines = fragment_shader(8, m, seams).defines;
                        defines.extend(path.shader_defines());
                        defines.extend(super::super::block::shader_id_defines());
                        defines.push(("MATERIAL_LEVEL0", 0));
                        defines.extend_from_slice(&variant.defines);
                        let spirv = crate::gpu::compile_glsl(
                            plan.shader,
                            crate::gpu::ShaderStage::Fragment,
                            &defines,
                        )
                        .unwrap();
                        let counts = crate::cost::spirv::count(&spirv);
                        assert_eq!(counts.loops, 0, "M = {m}, {seams:?}, {path:?}, {defines:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn index_follows_the_weights_and_lookups_count_the_taps() {
        let q = QuantizedClusters {
            order: Order::TWO,
            res: 2,
            m: 3,
            means: vec![vec![0.0; 4]; 3],
            bases: vec![vec![vec![0.0; 4]; 3]; 3],
            weights_unorm: (0..12).map(|i| i as u8 * 10).collect(),
            cluster_of: vec![2, 0, 1, 2],
        };
        let groups = texel_data(&q, "t");
        assert_eq!(groups.groups.len(), 1);
        assert_eq!(&groups.groups[0][..8], &[0, 10, 20, 2, 30, 40, 50, 0]);
        assert_eq!(per_texel_lookups(11, SeamMode::Blended), 12);
        assert_eq!(per_texel_lookups(11, SeamMode::Naive), 4);
        assert_eq!(per_texel_lookups(0, SeamMode::Naive), 1);
        assert_eq!(per_texel_lookups(0, SeamMode::Blended), 4);
        assert_eq!(per_texel_fetches(11, SeamMode::Blended), 12);
        assert_eq!(per_texel_fetches(11, SeamMode::Naive), 1);
        assert_eq!(per_texel_fetches(0, SeamMode::Naive), 1);
        let vq = QuantizedClusters {
            m: 0,
            weights_unorm: vec![],
            ..q
        };
        let g = texel_data(&vq, "v");
        assert_eq!(
            (g.format, g.groups[0].clone()),
            (vk::Format::R8_UNORM, vec![2, 0, 1, 2])
        );
    }
}

/// How a clustered technique crosses cluster boundaries in the lightmap.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SeamMode {
    /// The mitigation (no suffix): the 4 bilinear taps are fetched with their own cluster
    /// index, each reconstructed in its cluster and the results blended bilinearly.
    Blended,
    /// Suffix `n`: the weights bilinearly filtered across the boundary and decoded in the
    /// nearest texel's cluster (the known artifact); VQ without weights is nearest texel.
    Naive,
}

impl SeamMode {
    pub const ALL: [SeamMode; 2] = [SeamMode::Blended, SeamMode::Naive];

    pub(crate) fn suffix(self) -> &'static str {
        match self {
            SeamMode::Blended => "",
            SeamMode::Naive => "n",
        }
    }
}

/// VQ cluster counts a `vqK` name may ask for.
pub const VQ_CLUSTERS: &[u32] = &[16, 32, 64, 128, 256];
/// CPCA cluster counts and vectors per cluster a `cpcaK_M` name may ask for. M + 1 values
/// (weights and the cluster index) fill whole RGBA texels.
pub const CPCA_CLUSTERS: &[u32] = &[4, 8, 16, 32];
pub const CPCA_VECTORS: &[u32] = &[3, 7, 11, 15];
/// vec4s a clustered technique's uniform block may hold: 64 KiB, the `maxUniformBufferRange`
/// of the drivers this project runs on (lavapipe, NVIDIA; a device with less refuses the
/// technique in `finish::check_uniform_size`); 9 per cluster and vector + mean.
pub const CLUSTER_UNIFORM_VEC4S: u32 = 4096;

/// Whether K clusters of M vectors fit the clustered uniform block.
pub fn clusters_fit_uniforms(k: u32, m: u32) -> bool {
    k * (m + 1) * 9 <= CLUSTER_UNIFORM_VEC4S
}

/// What both clustered families read from the bake.
pub(crate) fn clustered_needs(need: ClusterNeed) -> BakeNeeds {
    BakeNeeds {
        visibility: Some(Order::SIX),
        clusters: Some(need),
        ..BakeNeeds::default()
    }
}

/// Cluster indices cannot be filtered or block-compressed: textures on dx9 and dx10 only.
pub(crate) fn clustered_form(path: HwPath) -> Result<Form, Refusal> {
    match path {
        HwPath::Dx9 | HwPath::Dx10 => Ok(Form::TEXTURES),
        HwPath::Dx11 => Err(Refusal::ClusterIndices),
    }
}
