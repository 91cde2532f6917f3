//! `cpcaK_M`, `cpcaK_Ms`, `…n`: clustered PCA of the order-6 visibility (the PRT course;
//! Sloan et al. 2003): a cluster index and M 8-bit weights per texel, per cluster and
//! vector SH(B_C,k·L) in uniforms. Its data, shader and cost are the clustered techniques'
//! (`super::cluster`).

use std::sync::Arc;

use super::cluster::{
    CPCA_CLUSTERS, CPCA_VECTORS, SeamMode, clusters_fit_uniforms, clustered_form, clustered_needs,
    fragment_shader, prepare, reads,
};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::Recipe;
use super::spec::{BakeNeeds, ClusterNeed, HwPath, ReferenceModel};
use super::texels::TexelGroups;
use super::{Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::cluster::Clustering;
use crate::gpu::Context;

/// The `cpcaK_M` family: iterative CPCA, K clusters of M vectors (PRT course); `cpcaK_Ms`
/// (`iterative: false`): static CPCA (k-means clusters, then a PCA each). A cluster index
/// and M 8-bit weights per texel, per cluster and vector SH(B_C,k·L) in uniforms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cpca {
    pub k: u32,
    pub m: u32,
    pub iterative: bool,
    pub seams: SeamMode,
}

impl Cpca {
    /// The clustered model it reads.
    pub fn cluster_need(self) -> ClusterNeed {
        ClusterNeed {
            k: self.k,
            m: self.m,
            clustering: if self.iterative {
                Clustering::Iterative
            } else {
                Clustering::KMeans
            },
        }
    }
}

impl Family for Cpca {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "cpcaK_M, cpcaK_Ms, …n",
        what: "clustered PCA: a cluster and M weights per texel (s: static clusters; n: naive seams)",
        paper: "Sloan et al., CPCA for PRT (SIGGRAPH 2003)",
        in_paper_table: false,
    };
    const EXAMPLE: Cpca = Cpca {
        k: 8,
        m: 11,
        iterative: true,
        seams: SeamMode::Blended,
    };

    fn members() -> Vec<Cpca> {
        CPCA_CLUSTERS
            .iter()
            .flat_map(|&k| CPCA_VECTORS.iter().map(move |&m| (k, m)))
            .filter(|&(k, m)| clusters_fit_uniforms(k, m))
            .flat_map(|(k, m)| {
                [true, false].into_iter().flat_map(move |iterative| {
                    SeamMode::ALL.map(|seams| Cpca {
                        k,
                        m,
                        iterative,
                        seams,
                    })
                })
            })
            .collect()
    }

    fn table_rows() -> Vec<Cpca> {
        let cpca = |m, iterative, seams| Cpca {
            k: 8,
            m,
            iterative,
            seams,
        };
        vec![
            cpca(7, true, SeamMode::Blended),
            cpca(11, true, SeamMode::Blended),
            cpca(11, false, SeamMode::Blended),
            cpca(11, true, SeamMode::Naive),
        ]
    }

    fn headline(path: HwPath) -> Vec<Cpca> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Cpca::EXAMPLE],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        format!(
            "cpca{}_{}{}{}",
            self.k,
            self.m,
            if self.iterative { "" } else { "s" },
            self.seams.suffix()
        )
    }

    fn paper_ms(self) -> Option<f64> {
        None
    }

    fn needs(self) -> BakeNeeds {
        clustered_needs(self.cluster_need())
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
        clustered_form(path)
    }

    fn prepare(
        self,
        _: HwPath,
        inputs: &Inputs<'_>,
        _: &(),
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError> {
        prepare(self.cluster_need(), inputs, label)
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
        fragment_shader(self.k, self.m, self.seams)
    }

    fn reads(self) -> ShaderReads {
        reads(self.m, self.seams)
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
