//! The interface every technique family implements ([`Family`]): each decision a family
//! makes — its names, description, bake, reference, lighting, its form on each hardware
//! path, its preparation, shader and what the shader reads, its own options and its
//! headline rows — is a required method here, answered in the family's own module.
//!
//! [`super::registry`] lists the families once; [`super::Technique`] is generated from that
//! list, with one dispatch per method, so a new family is its module, its shader, its ladder
//! recipe (`crate::attribution`) and one registry line.

use std::sync::Arc;

use super::block::BlockCodec;
use super::finish::TextureSlot;
use super::lighting::Recipe;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::texels::TexelGroups;
use super::{Inputs, ShaderReads, ShaderVariant, Technique, TechniqueError};
use crate::gpu::Context;

/// What `shvis techniques` says of a family.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Description {
    /// The names it takes: "uncO", "pcaM, pcaMw", …; its group on the report page.
    pub names: &'static str,
    /// What it is, in one line.
    pub what: &'static str,
    /// Where it comes from.
    pub paper: &'static str,
    /// Whether its rows are the paper's cost table (Iwanicki & Sloan, Table 1).
    pub in_paper_table: bool,
}

/// How a technique's per-texel data is stored on a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// Textures of values (dx9: packed 2D, dx10: arrays), `super::texels`.
    Textures,
    /// Block-compressed textures (dx11), decoded in `glsl/include/per_texel.glsl`.
    Blocks(BlockCodec),
    /// A vertex stream of the technique's own mesh (`pcaMv`): no per-texel data.
    VertexStream,
}

/// A technique's form on a path: how its data is stored and bound.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Form {
    pub storage: Storage,
    /// It also samples material-space textures of its own (SSBump, AO, NDF moments).
    pub material_textures: bool,
    /// Its per-texel data is formed from the lighting at each change (`nmprt*`), not baked.
    pub per_lighting_texels: bool,
}

impl Form {
    /// Per-texel textures, nothing else of its own.
    pub const TEXTURES: Form = Form {
        storage: Storage::Textures,
        material_textures: false,
        per_lighting_texels: false,
    };

    /// Per-texel values: textures on dx9 and dx10, `codec`'s blocks on dx11.
    pub fn values(path: HwPath, codec: BlockCodec) -> Form {
        match path {
            HwPath::Dx9 | HwPath::Dx10 => Form::TEXTURES,
            HwPath::Dx11 => Form {
                storage: Storage::Blocks(codec),
                ..Form::TEXTURES
            },
        }
    }

    /// The dx11 codec, where the data is block-compressed.
    pub fn codec(self) -> Option<BlockCodec> {
        match self.storage {
            Storage::Blocks(codec) => Some(codec),
            Storage::Textures | Storage::VertexStream => None,
        }
    }

    /// Why `shvis export` cannot write a technique of this form, if it cannot: export writes
    /// per-texel images, tables and a uniform block.
    pub fn export_refusal(self) -> Option<Refusal> {
        if self.storage == Storage::VertexStream {
            Some(Refusal::VertexStream)
        } else if self.per_lighting_texels {
            Some(Refusal::RebuiltPerLighting)
        } else if self.material_textures {
            Some(Refusal::MaterialTextures)
        } else {
            None
        }
    }
}

/// Why a technique has no form on a path (or no export): one text per reason, which
/// bench, render, view, the ladder and export all print.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    #[error("its per-texel matrices need more textures than dx9 binds")]
    Dx9Textures,
    #[error("its per-texel cluster indices cannot be block-compressed")]
    ClusterIndices,
    #[error("its per-texel data is rebuilt for each lighting, not baked")]
    RebuiltPerLighting,
    #[error("its weights live in the vertex stream, not in per-texel data")]
    VertexStream,
    #[error("it also reads material-space textures, which export does not write yet")]
    MaterialTextures,
}

/// One technique family: a value is a member (the family's parameters), GPU-free until
/// [`Family::extra_slot`]. Every method is required, so a family answers each question.
pub trait Family: Copy + Eq + std::hash::Hash + std::fmt::Debug + Into<Technique> {
    /// The family's own run options (`--sg-solve` for the hemisphere bases); `()` for none.
    type Options: Copy + Default + std::fmt::Debug + PartialEq;

    /// What `shvis techniques` says of it.
    const DESCRIPTION: Description;

    /// The member whose bake `shvis techniques` describes.
    const EXAMPLE: Self;

    /// Every member a CLI name may denote (each valid parameter).
    fn members() -> Vec<Self>;

    /// Its rows of the cost table (`Technique::all`, the `all` set), in order.
    fn table_rows() -> Vec<Self>;

    /// Its rows in the `headline` set on `path` (what `make bench` measures).
    fn headline(path: HwPath) -> Vec<Self>;

    /// The CLI name; parsing is its inverse over [`Family::members`].
    fn name(self) -> String;

    /// ms/frame of the paper's cost table, where the paper measured it.
    fn paper_ms(self) -> Option<f64>;

    /// What it reads from the bake.
    fn needs(self) -> BakeNeeds;

    /// The ground truth its error is measured against.
    fn reference(self) -> ReferenceModel;

    /// Whether a change of lighting needs only new per-lighting data, not a new bake.
    fn dynamic_lighting(self) -> bool;

    /// Its variant with the normal map filtered as a distribution (`--normal-filter ndf`).
    fn ndf_variant(self) -> Option<Technique>;

    /// Its form on `path`, or why it has none.
    fn form_on(self, path: HwPath) -> Result<Form, Refusal>;

    /// The CPU half of a build on `path`: the per-texel data to upload and what its
    /// lighting data needs besides the lighting.
    fn prepare(
        self,
        path: HwPath,
        inputs: &Inputs<'_>,
        options: &Self::Options,
        label: &str,
    ) -> Result<(TexelGroups, Recipe), TechniqueError>;

    /// Its own slot besides the per-texel data and tables: material textures or a normal
    /// basis.
    fn extra_slot(
        self,
        ctx: &Arc<Context>,
        path: HwPath,
        inputs: &Inputs<'_>,
        label: &str,
    ) -> Result<Option<TextureSlot>, TechniqueError>;

    /// Its fragment shader and defines.
    fn fragment_shader(self) -> ShaderVariant;

    /// What its fragment shader reads per pixel (the cost model's input).
    fn reads(self) -> ShaderReads;

    /// What its per-texel values are, as data for engines (`super::values`); `None` where
    /// only its shader says it.
    fn values(self) -> Option<super::values::ValueMap>;

    /// What its options change in its data, for labels and cache keys (`None`: nothing).
    fn options_tag(self, options: &Self::Options) -> Option<String>;

    /// The basis the SH lightmap bake fits from each texel's radiance samples for it
    /// (`crate::sh::samples`; `None`: it reads no such fit).
    fn sample_fit(self, options: &Self::Options) -> Option<crate::sh::samples::SampleFit>;
}
