//! What a technique *is*, without a GPU: the vocabulary every family answers in — what it
//! needs from the bake ([`BakeNeeds`]), which reference it meets ([`ReferenceModel`]) — and
//! how a CLI name parses: the inverse of each family's name over its members
//! ([`super::Family`]; `Technique` itself is generated from the registry,
//! [`super::registry`]).

use std::fmt;
use std::str::FromStr;

pub use crate::gpu::HwPath;
use crate::sh::Order;

pub use super::registry::{FamilyOptions, Technique};

/// The clustered model a technique reads from the bake.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ClusterNeed {
    pub k: u32,
    /// Vectors per cluster (0: VQ).
    pub m: u32,
    pub clustering: crate::bake::cluster::Clustering,
}

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
    /// The visibility baked at mesh vertices for (M weights, longest edge in cm; `None`:
    /// the mesh as authored) (`bake::vertex_pca`).
    pub vertex_pca: Option<(u32, Option<u32>)>,
}

impl BakeNeeds {
    /// The SH lightmap alone: what `shlmap` and the bases fitted from its bake read.
    pub const SH_LIGHTMAP: BakeNeeds = BakeNeeds {
        visibility: None,
        pca_vectors: None,
        sh_lightmap: true,
        ao: false,
        clusters: None,
        ssbump: false,
        ndf_moments: false,
        transfer: false,
        vertex_pca: None,
    };

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

/// The figure of `key` in a paper's table of (parameter, ms/frame).
pub(crate) fn paper_figure(table: &[(u32, f64)], key: u32) -> Option<f64> {
    table.iter().find(|(k, _)| *k == key).map(|&(_, ms)| ms)
}

impl Technique {
    /// The paper's time relative to its `preconv`.
    pub fn paper_ratio_to_preconv(self) -> Option<f64> {
        let preconv: Technique = super::preconv::Preconv.into();
        Some(self.paper_ms()? / preconv.paper_ms()?)
    }

    /// Whether it can run on `path` ([`Technique::form_on`]).
    pub fn runs_on(self, path: HwPath) -> bool {
        self.form_on(path).is_ok()
    }

    /// Every technique a CLI name can denote: every member of every family. Parsing is the
    /// inverse of [`Technique::name`] over this set.
    pub fn nameable() -> Vec<Technique> {
        Technique::families()
            .into_iter()
            .flat_map(|(_, members, _)| members)
            .collect()
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

impl fmt::Display for Technique {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

impl FromStr for Technique {
    type Err = ParseError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        use super::cluster::{CLUSTER_UNIFORM_VEC4S, CPCA_CLUSTERS, CPCA_VECTORS, VQ_CLUSTERS};
        use super::pca::{PCA_MAX_VECTORS, PCA_VECTORS_PER_TEXEL};
        use super::unc::UNC_ORDERS;
        use super::vertex::VERTEX_EDGES_CM;
        let found = Technique::nameable().into_iter().find(|t| t.name() == s);
        found.ok_or_else(|| ParseError::UnknownTechnique {
            name: s.to_string(),
            known: format!(
                "{} (and uncO for O in {}..={}, pcaM/pcaMw for M a multiple of {} up to {}, \
                 vqK[n] for K in {:?}, cpcaK_M[s][n] for K in {:?}, M in {:?}, K·(M+1) ≤ {}, \
                 pcaMv[E] for E in {:?} cm, uncOndf and preconvndf, nmprtsvdM[p] for M in 1..=9)",
                join_names(Technique::all().iter().map(|t| t.name())),
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
    use crate::technique::{NmprtVariant, SeamMode};

    #[test]
    fn names_round_trip_and_unknown_lists_known() {
        for &t in Technique::all() {
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
            Technique::Unc(crate::technique::Unc {
                order: Order::new(5).unwrap()
            })
        );
        assert_eq!(
            "pca20w".parse::<Technique>().unwrap(),
            Technique::Pca(crate::technique::Pca {
                m: 20,
                weights_only: true
            })
        );
        assert_eq!(
            "cpca8_11n".parse::<Technique>().unwrap(),
            Technique::Cpca(crate::technique::Cpca {
                k: 8,
                m: 11,
                iterative: true,
                seams: SeamMode::Naive,
            })
        );
        assert_eq!(
            "vq64"
                .parse::<Technique>()
                .unwrap()
                .needs()
                .clusters
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
        assert_eq!(
            Technique::Sh2(crate::technique::Sh2).paper_ratio_to_preconv(),
            Some(r)
        );
    }

    #[test]
    fn needs_and_references_follow_the_family() {
        let pca = Technique::Pca(crate::technique::Pca {
            m: 12,
            weights_only: true,
        });
        assert_eq!(pca.needs().pca_vectors, Some(12));
        assert_eq!(pca.needs().visibility, Some(Order::SIX));
        assert!(
            Technique::Shlmap(crate::technique::Shlmap)
                .needs()
                .sh_lightmap
                && !Technique::Shlmap(crate::technique::Shlmap).dynamic_lighting()
        );
        assert!(Technique::Preconv(crate::technique::Preconv).needs().ao);
        let nmprt: Technique = "nmprtsvd6".parse().unwrap();
        assert_eq!(
            nmprt,
            Technique::Nmprt(crate::technique::Nmprt {
                variant: NmprtVariant::Svd { m: 6 }
            })
        );
        assert!(nmprt.needs().transfer && nmprt.needs().inter_reflection());
        assert!(nmprt.dynamic_lighting() && !nmprt.needs().sh_lightmap);
        assert!("nmprtsvd10".parse::<Technique>().is_err());
        for &t in Technique::all() {
            // Its reference is inter-reflected exactly where its bake carries the bounces.
            let bounced = t.reference() == ReferenceModel::InterReflected;
            let lightmapped = t.needs().inter_reflection();
            assert_eq!(bounced, lightmapped, "{t}");
        }
    }
}
