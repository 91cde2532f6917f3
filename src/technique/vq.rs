//! `vqK`, `vqKn`: VQ of the order-6 visibility (the PRT course): a cluster index per texel
//! and per cluster SH(μ_C·L) in uniforms. Its data, shader and cost are the clustered
//! techniques' (`super::cluster`, with M = 0).

use std::sync::Arc;

use super::cluster::{
    SeamMode, VQ_CLUSTERS, clustered_form, clustered_needs, fragment_shader, prepare, reads,
};
use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::Recipe;
use super::spec::{BakeNeeds, ClusterNeed, HwPath, ReferenceModel};
use super::texels::TexelGroups;
use super::{Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::bake::cluster::Clustering;
use crate::gpu::Context;

/// The `vqK` / `vqKn` family: each texel's order-6 visibility replaced by its k-means
/// cluster's mean (VQ, PRT course); a cluster index per texel, per cluster SH(μ_C·L) in
/// uniforms.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Vq {
    pub k: u32,
    pub seams: SeamMode,
}

impl Vq {
    /// The clustered model it reads.
    pub fn cluster_need(self) -> ClusterNeed {
        ClusterNeed {
            k: self.k,
            m: 0,
            clustering: Clustering::KMeans,
        }
    }
}

impl Family for Vq {
    type Options = ();
    const DESCRIPTION: Description = Description {
        names: "vqK, vqKn",
        what: "k-means cluster of the visibility per texel, per-cluster lighting in uniforms (n: naive seams)",
        paper: "Sloan et al., PRT course (CPCA)",
        in_paper_table: false,
    };
    const EXAMPLE: Vq = Vq {
        k: 256,
        seams: SeamMode::Blended,
    };

    fn members() -> Vec<Vq> {
        VQ_CLUSTERS
            .iter()
            .flat_map(|&k| SeamMode::ALL.map(|seams| Vq { k, seams }))
            .collect()
    }

    fn table_rows() -> Vec<Vq> {
        vec![Vq::EXAMPLE]
    }

    fn headline(path: HwPath) -> Vec<Vq> {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => vec![Vq {
                k: 64,
                seams: SeamMode::Blended,
            }],
            HwPath::Dx11 => Vec::new(),
        }
    }

    fn name(self) -> String {
        format!("vq{}{}", self.k, self.seams.suffix())
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
        fragment_shader(self.k, 0, self.seams)
    }

    fn reads(self) -> ShaderReads {
        reads(0, self.seams)
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
