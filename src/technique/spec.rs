//! What a technique *is*, without a GPU: a family with its parameters ([`Technique`]) and
//! the hardware path it runs on ([`HwPath`]) (DESIGN §2).
//!
//! Every question the rest of the tool asks about a technique — its CLI name, the family's
//! valid parameters (which is what a name such as `unc6` or `pca12w` parses into), the paper's ms/frame, what it needs from the bake, which
//! reference its error is measured against, whether it can follow changing lighting — is
//! answered here by an exhaustive `match` on the family. There is deliberately no wildcard
//! arm over families: adding one is a compile error in each of these matches (and in
//! [`super::build`] and [`super::fragment_shader`]) until every question is answered.

use std::fmt;
use std::str::FromStr;

pub use crate::gpu::HwPath;
use crate::sh::Order;

/// A technique of the cost table: a family and its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Technique {
    /// `uncO`: uncompressed SH visibility of order O per texel and an L×H table indexed by
    /// the normal (Iwanicki–Sloan §3, eq. (4)).
    Unc { order: Order },
    /// `pcaM`: M PCA weights of the order-6 visibility per texel and per-basis tables
    /// T_k(n) (eq. (6)); `pcaMw` (`weights_only`): the basis' SH(V_k·L) in uniforms instead
    /// of tables (§4, footnote 2).
    Pca { m: u32, weights_only: bool },
    /// `shlmap`: order-3 SH of incident radiance with inter-reflection per texel (§5).
    Shlmap,
    /// `preconv`: ambient occlusion × pre-convolved irradiance (§5).
    Preconv,
    /// `sh2`: order-2 visibility per texel, the SH product in the shader (§5).
    Sh2,
    /// `vqK`: each texel's order-6 visibility replaced by its k-means cluster's mean (VQ,
    /// PRT course); a cluster index per texel, per cluster SH(μ_C·L) in uniforms.
    Vq { k: u32, seams: SeamMode },
    /// `cpcaK_M`: iterative CPCA, K clusters of M vectors (PRT course); `cpcaK_Ms`
    /// (`iterative: false`): static CPCA (k-means clusters, then a PCA each). A cluster
    /// index and M 8-bit weights per texel, per cluster and vector SH(B_C,k·L) in uniforms
    /// (the weights-only route of `pcaMw`, one block per cluster).
    Cpca {
        k: u32,
        m: u32,
        iterative: bool,
        seams: SeamMode,
    },
    /// `pcaMv` / `pcaMvE`: the first M weights of the lightmap's PCA basis baked at the
    /// vertices of the mesh (subdivided so no edge exceeds E cm; none: as authored), in a
    /// vertex stream, interpolated and shaded as `pcaMw`.
    PcaVertex { m: u32, max_edge_cm: Option<u32> },
    /// Radiosity normal mapping (Green, Valve): three lightmaps of irradiance
    /// around the HL2 tangent-space basis, blended per pixel — `rnm` (Listing 1, weights from
    /// the normal map), `rnmao` (× scalar AO of the height field), `ssbump` (Listing 2,
    /// the self-shadowed bump map's texels are the weights).
    Rnm { variant: RnmVariant },
    /// `uncOndf`, `preconvndf`: the base technique with its normal map filtered as a
    /// distribution (Olano & North; `technique::ndf_diffuse`): the clamped-cosine
    /// bands attenuated at lookup time by the zonal coefficients of the pixel's filtered
    /// normals — isotropic from the mean length for `unc`, exact from all nine moments for
    /// `preconv`.
    Ndf { base: NdfBase },
    /// Normal mapping for PRT (Sloan, PRT course; `super::nmprt`): per texel a
    /// transfer matrix M (`bake::transfer`: shadows and inter-reflection baked, lighting
    /// free) gives transferred incident radiance l' = M·l, formed on the CPU when the
    /// lighting changes and evaluated per pixel at the normal-mapped normal in one of four
    /// ways ([`NmprtVariant`]).
    Nmprt { variant: NmprtVariant },
    /// The SH-family lightmaps engines ship (`crate::sh::bases`): from the same bake as
    /// `shlmap` (order-3 incident radiance with inter-reflection), each texel stores what its
    /// basis keeps and the shader reconstructs irradiance at the normal-mapped normal —
    /// `l1`, `l1geo`, `l1zh3`, `zh3`, `l1lum`, `shlmapw` ([`EngineShBasis`]).
    EngineSh { basis: EngineShBasis },
    /// Local lightmap bases over the texel's tangent-frame hemisphere, from the same bake,
    /// indexed by the tangent-space normal: `hb4`, `hb6` — the H-basis (Habel & Wimmer 2010;
    /// `crate::sh::hbasis`); `sg5`, `sg6`, `sg9`, `sg12` — spherical Gaussians
    /// (`crate::sh::sg`); `dice`, `dicey` — Ambient Dice (Iwanicki & Sloan 2017;
    /// `crate::sh::dice`).
    Local { basis: LocalBasis },
}

/// What a `Local` technique stores.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LocalBasis {
    /// `hb4`, `hb6`: the H-basis of the irradiance over the hemisphere.
    HBasis(crate::sh::hbasis::HBasisSize),
    /// `sgN`: N spherical Gaussian lobes over the hemisphere, RGB amplitudes fitted by the
    /// run's `--sg-solve` (`crate::sh::sg`).
    Sg { lobes: u32 },
    /// `dice`, `dicey`: Ambient Dice, RGB or YCoCg (`crate::sh::dice`).
    Dice(crate::sh::dice::DiceVariant),
}

impl LocalBasis {
    /// Every member a name may denote.
    pub fn all() -> Vec<LocalBasis> {
        use crate::sh::hbasis::HBasisSize;
        [
            LocalBasis::HBasis(HBasisSize::H4),
            LocalBasis::HBasis(HBasisSize::H6),
        ]
        .into_iter()
        .chain(
            crate::sh::sg::LOBE_COUNTS
                .iter()
                .map(|&n| LocalBasis::Sg { lobes: n as u32 }),
        )
        .chain(crate::sh::dice::DiceVariant::ALL.map(LocalBasis::Dice))
        .collect()
    }

    /// The CLI name.
    pub fn name(self) -> String {
        use crate::sh::hbasis::HBasisSize;
        match self {
            LocalBasis::HBasis(HBasisSize::H4) => "hb4".into(),
            LocalBasis::HBasis(HBasisSize::H6) => "hb6".into(),
            LocalBasis::Sg { lobes } => format!("sg{lobes}"),
            LocalBasis::Dice(crate::sh::dice::DiceVariant::Rgb) => "dice".into(),
            LocalBasis::Dice(crate::sh::dice::DiceVariant::YCoCg) => "dicey".into(),
        }
    }
}

/// What an `EngineSh` technique stores and how it reconstructs (`crate::sh::bases`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EngineShBasis {
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

impl EngineShBasis {
    pub const ALL: [EngineShBasis; 6] = [
        EngineShBasis::L1,
        EngineShBasis::L1Geomerics,
        EngineShBasis::L1Zh3,
        EngineShBasis::Zh3,
        EngineShBasis::L1Luminance,
        EngineShBasis::L2Deringed,
    ];

    /// The encoding and reconstruction it runs.
    pub fn sh_basis(self) -> crate::sh::bases::ShBasis {
        use crate::sh::bases::ShBasis;
        match self {
            EngineShBasis::L1 => ShBasis::L1,
            EngineShBasis::L1Geomerics => ShBasis::L1Geomerics,
            EngineShBasis::L1Zh3 => ShBasis::L1Zh3Hallucinated,
            EngineShBasis::Zh3 => ShBasis::Zh3,
            EngineShBasis::L1Luminance => ShBasis::L1Luminance,
            EngineShBasis::L2Deringed => ShBasis::L2Deringed,
        }
    }

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            EngineShBasis::L1 => "l1",
            EngineShBasis::L1Geomerics => "l1geo",
            EngineShBasis::L1Zh3 => "l1zh3",
            EngineShBasis::Zh3 => "zh3",
            EngineShBasis::L1Luminance => "l1lum",
            EngineShBasis::L2Deringed => "shlmapw",
        }
    }
}

/// How `nmprt*` evaluates the transferred radiance at the normal-mapped normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmprtVariant {
    /// `nmprt`: y(n)ᵀ C l', the 27 coefficients of l' per texel.
    Full,
    /// `nmprtsvdM`: the course's normal basis, e(n) = U(n) S_M V_Mᵀ R l' — M values per
    /// colour per texel, U(n) looked up by the tangent-space normal.
    Svd { m: u32 },
    /// `nmprtsvdMp`: the same normal basis with the course's pixel shader — per texel the
    /// M × O² matrices V_Mᵀ R M (per colour) as bake data, the lighting l in uniforms, the
    /// matrix–vector product per pixel; nothing per texel changes with the lighting. Its
    /// 3·M·⌈O²/4⌉ RGBA layers exceed dx9's 16 textures: dx10 only.
    SvdPixel { m: u32 },
    /// `nmprthl2`: three rows — the least-squares fit of e(n) by the HL2 blend weights,
    /// three RGB values per texel blended like `rnm`.
    Hl2,
    /// `nmprtratio`: the shadowed/unshadowed luminance ratio at the texel's shading normal
    /// times the unshadowed irradiance at the normal-mapped normal.
    Ratio,
}

/// Singular vectors an `nmprtsvdM` name may keep (M = 9 is the full evaluation).
pub const NMPRT_SVD_VECTORS: std::ops::RangeInclusive<u32> = 1..=9;

/// The technique an NDF-filtered variant ([`Technique::Ndf`]) extends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NdfBase {
    Unc { order: Order },
    Preconv,
}

impl NdfBase {
    /// The unfiltered technique.
    pub fn technique(self) -> Technique {
        match self {
            NdfBase::Unc { order } => Technique::Unc { order },
            NdfBase::Preconv => Technique::Preconv,
        }
    }
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

/// The clustered model a technique reads from the bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ClusterNeed {
    pub k: u32,
    /// Vectors per cluster (0: VQ).
    pub m: u32,
    pub clustering: crate::bake::cluster::Clustering,
}

/// Visibility orders a `uncO` name may ask for: the shader packs at most 9 RGBA groups
/// (order 6), and order 1 has no directional information to shadow with.
pub const UNC_ORDERS: std::ops::RangeInclusive<u32> = 2..=6;
/// Largest PCA basis (`pca24`): the fit in `prepare` computes this many vectors.
pub const PCA_MAX_VECTORS: u32 = 24;
/// PCA weights are packed 4 per RGBA8 texel, so M is a multiple of this.
pub const PCA_VECTORS_PER_TEXEL: u32 = 4;

/// Edge lengths (cm) a `pcaMvE` name may subdivide the mesh to.
pub const VERTEX_EDGES_CM: &[u32] = &[100, 50, 25, 10];

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

/// The paper's cost table (GeForce GTX 295, 1280×800, 512² visibility; DESIGN §3), by
/// parameter where the family has one.
const PAPER_UNC_MS: &[(u32, f64)] = &[(6, 8.19), (4, 3.33), (3, 2.75)];
const PAPER_PCA_MS: &[(u32, f64)] = &[(4, 1.40), (8, 2.08), (16, 3.61), (24, 5.56)];
const PAPER_SHLMAP_MS: f64 = 0.846;
const PAPER_PRECONV_MS: f64 = 0.648;
const PAPER_SH2_MS: f64 = 0.607;

/// What a technique reads from the bake (`prepare`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BakeNeeds {
    /// SH visibility per texel, at least this order.
    pub visibility: Option<Order>,
    /// A PCA of the order-6 visibility with at least this many vectors.
    pub pca_vectors: Option<u32>,
    /// The SH lightmap (incident radiance with inter-reflection).
    pub sh_lightmap: bool,
    /// Scalar ambient occlusion per texel.
    pub ao: bool,
    /// A VQ / CPCA model of the order-6 visibility.
    pub clusters: Option<ClusterNeed>,
    /// The material's SSBump and AO textures, from its height field.
    pub ssbump: bool,
    /// The moments of the material's normal map (`crate::ndf::moment_maps`).
    pub ndf_moments: bool,
    /// Transfer matrices with inter-reflection (`bake::transfer`).
    pub transfer: bool,
}

impl BakeNeeds {
    /// Whether it bakes inter-reflection (the SH lightmap or transfer matrices), so its
    /// error is against the inter-reflected reference.
    pub fn inter_reflection(&self) -> bool {
        self.sh_lightmap || self.transfer
    }
}

/// Which ground truth a technique's error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceModel {
    /// Direct light only: the model of every technique with precomputed visibility.
    Direct,
    /// With inter-reflection (N bounces, as baked): what an SH lightmap models.
    InterReflected,
}

impl Technique {
    /// The cost table's rows, in DESIGN §2 order.
    pub const ALL: &'static [Technique] = &[
        Technique::Unc {
            order: Order::THREE,
        },
        Technique::Unc { order: Order::FOUR },
        Technique::Unc { order: Order::SIX },
        Technique::Pca {
            m: 4,
            weights_only: false,
        },
        Technique::Pca {
            m: 8,
            weights_only: false,
        },
        Technique::Pca {
            m: 12,
            weights_only: false,
        },
        Technique::Pca {
            m: 16,
            weights_only: false,
        },
        Technique::Pca {
            m: 24,
            weights_only: false,
        },
        Technique::Pca {
            m: 4,
            weights_only: true,
        },
        Technique::Pca {
            m: 8,
            weights_only: true,
        },
        Technique::Pca {
            m: 12,
            weights_only: true,
        },
        Technique::Pca {
            m: 16,
            weights_only: true,
        },
        Technique::Pca {
            m: 24,
            weights_only: true,
        },
        Technique::Shlmap,
        Technique::Preconv,
        Technique::Sh2,
        Technique::Vq {
            k: 256,
            seams: SeamMode::Blended,
        },
        Technique::Cpca {
            k: 8,
            m: 7,
            iterative: true,
            seams: SeamMode::Blended,
        },
        Technique::Cpca {
            k: 8,
            m: 11,
            iterative: true,
            seams: SeamMode::Blended,
        },
        Technique::Cpca {
            k: 8,
            m: 11,
            iterative: false,
            seams: SeamMode::Blended,
        },
        Technique::Cpca {
            k: 8,
            m: 11,
            iterative: true,
            seams: SeamMode::Naive,
        },
        Technique::PcaVertex {
            m: 12,
            max_edge_cm: None,
        },
        Technique::PcaVertex {
            m: 12,
            max_edge_cm: Some(25),
        },
        Technique::Rnm {
            variant: RnmVariant::NormalMap,
        },
        Technique::Rnm {
            variant: RnmVariant::NormalMapAo,
        },
        Technique::Rnm {
            variant: RnmVariant::SelfShadowed,
        },
        Technique::Ndf {
            base: NdfBase::Unc { order: Order::SIX },
        },
        Technique::Ndf {
            base: NdfBase::Preconv,
        },
        Technique::Nmprt {
            variant: NmprtVariant::Full,
        },
        Technique::Nmprt {
            variant: NmprtVariant::Svd { m: 4 },
        },
        Technique::Nmprt {
            variant: NmprtVariant::Svd { m: 6 },
        },
        Technique::Nmprt {
            variant: NmprtVariant::SvdPixel { m: 4 },
        },
        Technique::Nmprt {
            variant: NmprtVariant::Hl2,
        },
        Technique::Nmprt {
            variant: NmprtVariant::Ratio,
        },
        Technique::EngineSh {
            basis: EngineShBasis::L1,
        },
        Technique::EngineSh {
            basis: EngineShBasis::L1Geomerics,
        },
        Technique::EngineSh {
            basis: EngineShBasis::L1Zh3,
        },
        Technique::EngineSh {
            basis: EngineShBasis::Zh3,
        },
        Technique::EngineSh {
            basis: EngineShBasis::L1Luminance,
        },
        Technique::EngineSh {
            basis: EngineShBasis::L2Deringed,
        },
        Technique::Local {
            basis: LocalBasis::HBasis(crate::sh::hbasis::HBasisSize::H4),
        },
        Technique::Local {
            basis: LocalBasis::HBasis(crate::sh::hbasis::HBasisSize::H6),
        },
        Technique::Local {
            basis: LocalBasis::Sg { lobes: 6 },
        },
        Technique::Local {
            basis: LocalBasis::Sg { lobes: 9 },
        },
        Technique::Local {
            basis: LocalBasis::Sg { lobes: 12 },
        },
        Technique::Local {
            basis: LocalBasis::Dice(crate::sh::dice::DiceVariant::Rgb),
        },
        Technique::Local {
            basis: LocalBasis::Dice(crate::sh::dice::DiceVariant::YCoCg),
        },
    ];

    /// The CLI name: `unc6`, `pca12`, `pca12w`, `shlmap`, `preconv`, `sh2`.
    pub fn name(self) -> String {
        match self {
            Technique::Unc { order } => format!("unc{order}"),
            Technique::Pca { m, weights_only } => {
                format!("pca{m}{}", if weights_only { "w" } else { "" })
            }
            Technique::Shlmap => "shlmap".into(),
            Technique::Preconv => "preconv".into(),
            Technique::Sh2 => "sh2".into(),
            Technique::Vq { k, seams } => format!("vq{k}{}", seams.suffix()),
            Technique::Cpca {
                k,
                m,
                iterative,
                seams,
            } => format!(
                "cpca{k}_{m}{}{}",
                if iterative { "" } else { "s" },
                seams.suffix()
            ),
            Technique::PcaVertex { m, max_edge_cm } => match max_edge_cm {
                Some(cm) => format!("pca{m}v{cm}"),
                None => format!("pca{m}v"),
            },
            Technique::Rnm { variant } => match variant {
                RnmVariant::NormalMap => "rnm",
                RnmVariant::NormalMapAo => "rnmao",
                RnmVariant::SelfShadowed => "ssbump",
            }
            .into(),
            Technique::Ndf { base } => format!("{}ndf", base.technique().name()),
            Technique::Nmprt { variant } => match variant {
                NmprtVariant::Full => "nmprt".into(),
                NmprtVariant::Svd { m } => format!("nmprtsvd{m}"),
                NmprtVariant::SvdPixel { m } => format!("nmprtsvd{m}p"),
                NmprtVariant::Hl2 => "nmprthl2".into(),
                NmprtVariant::Ratio => "nmprtratio".into(),
            },
            Technique::EngineSh { basis } => basis.name().into(),
            Technique::Local { basis } => basis.name(),
        }
    }

    /// The technique without NDF filtering (itself for every other family).
    pub fn unfiltered(self) -> Technique {
        match self {
            Technique::Ndf { base } => base.technique(),
            Technique::Unc { .. }
            | Technique::Pca { .. }
            | Technique::Shlmap
            | Technique::Preconv
            | Technique::Sh2
            | Technique::Vq { .. }
            | Technique::Cpca { .. }
            | Technique::PcaVertex { .. }
            | Technique::Rnm { .. }
            | Technique::Nmprt { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => self,
        }
    }

    /// The NDF-filtered variant of `unc*` and `preconv` (`--normal-filter ndf`).
    pub fn ndf_variant(self) -> Option<Technique> {
        match self {
            Technique::Unc { order } => Some(Technique::Ndf {
                base: NdfBase::Unc { order },
            }),
            Technique::Preconv => Some(Technique::Ndf {
                base: NdfBase::Preconv,
            }),
            Technique::Ndf { .. } => Some(self),
            Technique::Pca { .. }
            | Technique::Shlmap
            | Technique::Sh2
            | Technique::Vq { .. }
            | Technique::Cpca { .. }
            | Technique::PcaVertex { .. }
            | Technique::Rnm { .. }
            | Technique::Nmprt { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => None,
        }
    }

    /// The clustered model it reads, for `vqK` and `cpcaK_M`.
    pub fn cluster_need(self) -> Option<ClusterNeed> {
        use crate::bake::cluster::Clustering;
        match self {
            Technique::Vq { k, .. } => Some(ClusterNeed {
                k,
                m: 0,
                clustering: Clustering::KMeans,
            }),
            Technique::Cpca {
                k, m, iterative, ..
            } => Some(ClusterNeed {
                k,
                m,
                clustering: if iterative {
                    Clustering::Iterative
                } else {
                    Clustering::KMeans
                },
            }),
            Technique::Unc { .. }
            | Technique::Pca { .. }
            | Technique::Shlmap
            | Technique::Preconv
            | Technique::Sh2
            | Technique::PcaVertex { .. }
            | Technique::Rnm { .. }
            | Technique::Ndf { .. }
            | Technique::Nmprt { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => None,
        }
    }

    /// ms/frame of the paper's cost table for the techniques it measured.
    pub fn paper_ms(self) -> Option<f64> {
        let lookup = |table: &[(u32, f64)], key: u32| {
            table.iter().find(|(k, _)| *k == key).map(|&(_, ms)| ms)
        };
        match self {
            Technique::Unc { order } => lookup(PAPER_UNC_MS, order.get()),
            // The paper timed only the table variant.
            Technique::Pca { m, weights_only } => {
                (!weights_only).then(|| lookup(PAPER_PCA_MS, m)).flatten()
            }
            Technique::Shlmap => Some(PAPER_SHLMAP_MS),
            Technique::Preconv => Some(PAPER_PRECONV_MS),
            Technique::Sh2 => Some(PAPER_SH2_MS),
            Technique::Vq { .. }
            | Technique::Cpca { .. }
            | Technique::PcaVertex { .. }
            | Technique::Rnm { .. }
            | Technique::Ndf { .. }
            | Technique::Nmprt { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => None,
        }
    }

    /// The paper's time relative to its `preconv`.
    pub fn paper_ratio_to_preconv(self) -> Option<f64> {
        Some(self.paper_ms()? / Technique::Preconv.paper_ms()?)
    }

    /// What the technique reads from the bake.
    pub fn needs(self) -> BakeNeeds {
        match self {
            Technique::Unc { order } => BakeNeeds {
                visibility: Some(order),
                ..BakeNeeds::default()
            },
            Technique::Pca { m, .. } => BakeNeeds {
                visibility: Some(Order::SIX),
                pca_vectors: Some(m),
                ..BakeNeeds::default()
            },
            Technique::Shlmap => BakeNeeds {
                sh_lightmap: true,
                ..BakeNeeds::default()
            },
            Technique::Preconv => BakeNeeds {
                ao: true,
                ..BakeNeeds::default()
            },
            Technique::Sh2 => BakeNeeds {
                visibility: Some(Order::TWO),
                ..BakeNeeds::default()
            },
            Technique::Vq { .. } | Technique::Cpca { .. } => BakeNeeds {
                visibility: Some(Order::SIX),
                clusters: self.cluster_need(),
                ..BakeNeeds::default()
            },
            Technique::PcaVertex { m, .. } => BakeNeeds {
                visibility: Some(Order::SIX),
                pca_vectors: Some(m),
                ..BakeNeeds::default()
            },
            Technique::EngineSh { .. } | Technique::Local { .. } => BakeNeeds {
                sh_lightmap: true,
                ..BakeNeeds::default()
            },
            Technique::Rnm { variant } => BakeNeeds {
                sh_lightmap: true,
                ssbump: variant.needs_height(),
                ..BakeNeeds::default()
            },
            Technique::Ndf { base } => BakeNeeds {
                ndf_moments: true,
                ..base.technique().needs()
            },
            Technique::Nmprt { .. } => BakeNeeds {
                transfer: true,
                ..BakeNeeds::default()
            },
        }
    }

    /// The ground truth its error is measured against.
    pub fn reference(self) -> ReferenceModel {
        match self {
            Technique::Shlmap
            | Technique::Rnm { .. }
            | Technique::Nmprt { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => ReferenceModel::InterReflected,
            Technique::Unc { .. }
            | Technique::Pca { .. }
            | Technique::Preconv
            | Technique::Sh2
            | Technique::Vq { .. }
            | Technique::Cpca { .. }
            | Technique::PcaVertex { .. }
            | Technique::Ndf { .. } => ReferenceModel::Direct,
        }
    }

    /// Whether a change of lighting needs only new per-lighting data (tables, uniforms),
    /// not a new bake.
    pub fn dynamic_lighting(self) -> bool {
        match self {
            Technique::Shlmap
            | Technique::Rnm { .. }
            | Technique::EngineSh { .. }
            | Technique::Local { .. } => false,
            Technique::Unc { .. }
            | Technique::Pca { .. }
            | Technique::Preconv
            | Technique::Sh2
            | Technique::Vq { .. }
            | Technique::Cpca { .. }
            | Technique::PcaVertex { .. }
            | Technique::Ndf { .. }
            | Technique::Nmprt { .. } => true,
        }
    }

    /// Whether it can run on `path` ([`Technique::refusal`]).
    pub fn runs_on(self, path: HwPath) -> bool {
        self.refusal(path).is_none()
    }

    /// Why it cannot run on `path`, if it cannot: every technique runs on dx10;
    /// `nmprtsvdMp`'s per-texel matrices need more than dx9's 16 textures (`finish` refuses
    /// it there by the path rules); on dx11 those whose per-texel data has no
    /// block-compressed form (`super::block::block_codec`). The bench and the suites leave
    /// such rows out.
    pub fn refusal(self, path: HwPath) -> Option<&'static str> {
        match path {
            HwPath::Dx9 => matches!(
                self,
                Technique::Nmprt {
                    variant: NmprtVariant::SvdPixel { .. },
                }
            )
            .then_some("its per-texel matrices need more textures than dx9 binds"),
            HwPath::Dx10 => None,
            HwPath::Dx11 => super::block::block_codec(self).err(),
        }
    }

    /// Every technique of this one's family that a name may denote: each valid parameter.
    pub fn family_members(self) -> Vec<Technique> {
        match self {
            Technique::Unc { .. } => UNC_ORDERS
                .filter_map(|o| Order::new(o).ok())
                .map(|order| Technique::Unc { order })
                .collect(),
            Technique::Pca { .. } => (PCA_VECTORS_PER_TEXEL..=PCA_MAX_VECTORS)
                .step_by(PCA_VECTORS_PER_TEXEL as usize)
                .flat_map(|m| [false, true].map(|weights_only| Technique::Pca { m, weights_only }))
                .collect(),
            Technique::Vq { .. } => VQ_CLUSTERS
                .iter()
                .flat_map(|&k| SeamMode::ALL.map(|seams| Technique::Vq { k, seams }))
                .collect(),
            Technique::Cpca { .. } => CPCA_CLUSTERS
                .iter()
                .flat_map(|&k| CPCA_VECTORS.iter().map(move |&m| (k, m)))
                .filter(|&(k, m)| clusters_fit_uniforms(k, m))
                .flat_map(|(k, m)| {
                    [true, false].into_iter().flat_map(move |iterative| {
                        SeamMode::ALL.map(|seams| Technique::Cpca {
                            k,
                            m,
                            iterative,
                            seams,
                        })
                    })
                })
                .collect(),
            Technique::PcaVertex { .. } => (PCA_VECTORS_PER_TEXEL..=PCA_MAX_VECTORS)
                .step_by(PCA_VECTORS_PER_TEXEL as usize)
                .flat_map(|m| {
                    std::iter::once(None)
                        .chain(VERTEX_EDGES_CM.iter().copied().map(Some))
                        .map(move |max_edge_cm| Technique::PcaVertex { m, max_edge_cm })
                })
                .collect(),
            Technique::Rnm { .. } => RnmVariant::ALL
                .map(|variant| Technique::Rnm { variant })
                .to_vec(),
            Technique::Shlmap | Technique::Preconv | Technique::Sh2 => vec![self],
            Technique::Local { .. } => LocalBasis::all()
                .into_iter()
                .map(|basis| Technique::Local { basis })
                .collect(),
            Technique::EngineSh { .. } => EngineShBasis::ALL
                .map(|basis| Technique::EngineSh { basis })
                .to_vec(),
            Technique::Ndf { .. } => UNC_ORDERS
                .filter_map(|o| Order::new(o).ok())
                .map(|order| NdfBase::Unc { order })
                .chain([NdfBase::Preconv])
                .map(|base| Technique::Ndf { base })
                .collect(),
            Technique::Nmprt { .. } => [NmprtVariant::Full, NmprtVariant::Hl2, NmprtVariant::Ratio]
                .into_iter()
                .chain(NMPRT_SVD_VECTORS.map(|m| NmprtVariant::Svd { m }))
                .chain(NMPRT_SVD_VECTORS.map(|m| NmprtVariant::SvdPixel { m }))
                .map(|variant| Technique::Nmprt { variant })
                .collect(),
        }
    }

    /// Every technique a CLI name can denote: the families of [`Technique::ALL`] with all
    /// their parameters. Parsing is the inverse of [`Technique::name`] over this set.
    pub fn nameable() -> Vec<Technique> {
        let mut all: Vec<Technique> = Technique::ALL
            .iter()
            .flat_map(|t| t.family_members())
            .collect();
        let mut seen = std::collections::HashSet::new();
        all.retain(|t| seen.insert(*t));
        all
    }
}

impl ClusterNeed {
    /// Whether `model` is the fit this need names.
    pub fn is_met_by(&self, model: &crate::bake::cluster::ClusteredModel) -> bool {
        model.clusters.len() == self.k as usize
            && model.m == self.m as usize
            && model.clustering == self.clustering
    }
}

impl SeamMode {
    pub const ALL: [SeamMode; 2] = [SeamMode::Blended, SeamMode::Naive];

    fn suffix(self) -> &'static str {
        match self {
            SeamMode::Blended => "",
            SeamMode::Naive => "n",
        }
    }
}

impl fmt::Display for Technique {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

impl FromStr for Technique {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let found = Technique::nameable().into_iter().find(|t| t.name() == s);
        found.ok_or_else(|| ParseError::UnknownTechnique {
            name: s.to_string(),
            known: format!(
                "{} (and uncO for O in {}..={}, pcaM/pcaMw for M a multiple of {} up to {}, \
                 vqK[n] for K in {:?}, cpcaK_M[s][n] for K in {:?}, M in {:?}, K·(M+1) ≤ {}, \
                 pcaMv[E] for E in {:?} cm, uncOndf and preconvndf, nmprtsvdM[p] for M in 1..=9)",
                join_names(Technique::ALL.iter().map(|t| t.name())),
                UNC_ORDERS.start(),
                UNC_ORDERS.end(),
                PCA_VECTORS_PER_TEXEL,
                PCA_MAX_VECTORS,
                VQ_CLUSTERS,
                CPCA_CLUSTERS,
                CPCA_VECTORS,
                CLUSTER_UNIFORM_VEC4S / 9,
                VERTEX_EDGES_CM
            ),
        })
    }
}

impl serde::Serialize for Technique {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

fn join_names(names: impl Iterator<Item = String>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

/// A technique or path name that does not parse.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    #[error("unknown technique '{name}'; known: {known}")]
    UnknownTechnique { name: String, known: String },
    #[error(transparent)]
    UnknownPath(#[from] crate::gpu::UnknownPath),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_lists_known() {
        for &t in Technique::ALL {
            assert_eq!(t.name().parse::<Technique>().unwrap(), t);
        }
        for &p in HwPath::ALL {
            assert_eq!(p.name().parse::<HwPath>().unwrap(), p);
        }
        let e = "unc7".parse::<Technique>().unwrap_err().to_string();
        assert!(e.contains("unc7") && e.contains("preconv"), "{e}");
        let e = "dx12".parse::<HwPath>().unwrap_err().to_string();
        assert!(e.contains("dx9, dx10, dx11"), "{e}");
    }

    #[test]
    fn parameterised_names_parse_beyond_the_cost_table() {
        assert_eq!(
            "unc5".parse::<Technique>().unwrap(),
            Technique::Unc {
                order: Order::new(5).unwrap()
            }
        );
        assert_eq!(
            "pca20w".parse::<Technique>().unwrap(),
            Technique::Pca {
                m: 20,
                weights_only: true
            }
        );
        assert_eq!(
            "cpca8_11n".parse::<Technique>().unwrap(),
            Technique::Cpca {
                k: 8,
                m: 11,
                iterative: true,
                seams: SeamMode::Naive,
            }
        );
        assert_eq!(
            "vq64"
                .parse::<Technique>()
                .unwrap()
                .cluster_need()
                .unwrap()
                .m,
            0
        );
        for bad in [
            "cpca32_15",
            "cpca8_4",
            "cpca8",
            "vq5",
            "vq256w",
            "cpca8_11nn",
            "unc",
            "unc1",
            "unc7",
            "unc+6",
            "unc06x",
            "pca",
            "pca0",
            "pca6",
            "pca28",
            "pcaw",
            "pca4ww",
            "pca-4",
            "sh3",
            "Preconv",
            "",
        ] {
            assert!(bad.parse::<Technique>().is_err(), "{bad:?} parsed");
        }
    }

    #[test]
    fn paper_figures_only_where_the_paper_measured() {
        let named = |s: &str| s.parse::<Technique>().unwrap().paper_ms();
        assert_eq!(named("unc6"), Some(8.19));
        assert_eq!(named("pca24"), Some(5.56));
        assert_eq!(named("pca12"), None);
        assert_eq!(named("pca4w"), None);
        assert_eq!(named("unc5"), None);
        let r = named("sh2").unwrap() / named("preconv").unwrap();
        assert_eq!(Technique::Sh2.paper_ratio_to_preconv(), Some(r));
    }

    #[test]
    fn needs_and_references_follow_the_family() {
        let pca = Technique::Pca {
            m: 12,
            weights_only: true,
        };
        assert_eq!(pca.needs().pca_vectors, Some(12));
        assert_eq!(pca.needs().visibility, Some(Order::SIX));
        assert!(Technique::Shlmap.needs().sh_lightmap && !Technique::Shlmap.dynamic_lighting());
        assert!(Technique::Preconv.needs().ao);
        let nmprt: Technique = "nmprtsvd6".parse().unwrap();
        assert_eq!(
            nmprt,
            Technique::Nmprt {
                variant: NmprtVariant::Svd { m: 6 }
            }
        );
        assert!(nmprt.needs().transfer && nmprt.needs().inter_reflection());
        assert!(nmprt.dynamic_lighting() && !nmprt.needs().sh_lightmap);
        assert!("nmprtsvd10".parse::<Technique>().is_err());
        for &t in Technique::ALL {
            let bounced = t.reference() == ReferenceModel::InterReflected;
            let lightmapped = matches!(
                t,
                Technique::Shlmap
                    | Technique::Rnm { .. }
                    | Technique::Nmprt { .. }
                    | Technique::EngineSh { .. }
                    | Technique::Local { .. }
            );
            assert_eq!(bounced, lightmapped, "{t}");
        }
    }
}
