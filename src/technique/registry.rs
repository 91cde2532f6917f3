//! The one list of technique families ([`with_families`]) and what is generated from it:
//! the [`Technique`] enum (a variant per family, holding the family's parameters), the
//! dispatch of every [`Family`] method, the family options of a run ([`FamilyOptions`]) and
//! the catalog's per-family listing. A new family is one line here.
//!
//! Other layers dispatch their own per-family interfaces the same way (the error ladder's
//! recipes, `crate::attribution`): `with_families!(their_macro)` hands them the list.

use super::family::{Description, Family, Form, Refusal};
use super::finish::TextureSlot;
use super::lighting::Recipe;
use super::spec::{BakeNeeds, HwPath, ReferenceModel};
use super::texels::TexelGroups;
use super::{Inputs, ShaderReads, ShaderVariant, TechniqueError};

/// Calls `$then!` with the registry: `Variant: module::Family` per family, in the cost
/// table's order. `module` is the family's module in `src/technique/` and its ladder
/// recipe's in `src/attribution/`; both are declared from this list
/// ([`declare_family_modules`], `attribution`'s `declare_ladder_modules`).
macro_rules! with_families {
    ($then:ident) => {
        $then! {
            Unc: unc::Unc,
            Pca: pca::Pca,
            Shlmap: shlmap::Shlmap,
            Preconv: preconv::Preconv,
            Sh2: sh2::Sh2,
            Vq: vq::Vq,
            Cpca: cpca::Cpca,
            PcaVertex: vertex::PcaVertex,
            Rnm: rnm::Rnm,
            Ndf: ndf_diffuse::Ndf,
            Nmprt: nmprt::Nmprt,
            ShVariant: sh_variant::ShVariant,
            Hemisphere: hemisphere::Hemisphere,
            AmbientCube: ambient_cube::AmbientCube,
        }
    };
}
pub(crate) use with_families;

/// `pub mod` of every family's module, expanded in `technique/mod.rs`.
macro_rules! declare_family_modules {
    ($($variant:ident: $module:ident::$family:ident,)*) => {
        $(pub mod $module;)*
    };
}
pub(crate) use declare_family_modules;

macro_rules! define_technique {
    ($($variant:ident: $module:ident::$family:ident,)*) => {
        define_technique!(@types $($variant: $crate::technique::$module::$family,)*);
    };
    (@types $($variant:ident: $family:ty,)*) => {
        /// A technique: a family of the registry and its parameters.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Technique {
            $($variant($family),)*
        }

        $(impl From<$family> for Technique {
            fn from(member: $family) -> Technique {
                Technique::$variant(member)
            }
        })*

        /// Each family's run options ([`Family::Options`]), one field per family, named as
        /// its variant.
        #[allow(non_snake_case)]
        #[derive(Clone, Copy, Debug, Default, PartialEq)]
        pub struct FamilyOptions {
            $(pub $variant: <$family as Family>::Options,)*
        }

        impl Technique {
            /// The cost table's rows, family by family.
            pub fn all() -> &'static [Technique] {
                static ALL: std::sync::OnceLock<Vec<Technique>> = std::sync::OnceLock::new();
                ALL.get_or_init(|| {
                    let mut rows = Vec::new();
                    $(rows.extend(<$family>::table_rows().into_iter().map(Technique::$variant));)*
                    rows
                })
            }

            /// The `headline` set's rows on `path`, family by family.
            pub fn headline(path: HwPath) -> Vec<Technique> {
                let mut rows = Vec::new();
                $(rows.extend(<$family>::headline(path).into_iter().map(Technique::$variant));)*
                rows
            }

            /// Every family: its description, its members and the member whose bake it
            /// describes.
            pub fn families() -> Vec<(Description, Vec<Technique>, Technique)> {
                vec![$((
                    <$family as Family>::DESCRIPTION,
                    <$family>::members().into_iter().map(Technique::$variant).collect(),
                    Technique::$variant(<$family as Family>::EXAMPLE),
                ),)*]
            }

            /// What `shvis techniques` says of its family.
            pub fn description(self) -> Description {
                match self {
                    $(Technique::$variant(_) => <$family as Family>::DESCRIPTION,)*
                }
            }

            /// Every technique of this one's family that a name may denote.
            pub fn family_members(self) -> Vec<Technique> {
                match self {
                    $(Technique::$variant(_) => {
                        <$family>::members().into_iter().map(Technique::$variant).collect()
                    })*
                }
            }

            /// The CLI name.
            pub fn name(self) -> String {
                match self {
                    $(Technique::$variant(member) => member.name(),)*
                }
            }

            /// ms/frame of the paper's cost table for the techniques it measured.
            pub fn paper_ms(self) -> Option<f64> {
                match self {
                    $(Technique::$variant(member) => member.paper_ms(),)*
                }
            }

            /// What the technique reads from the bake.
            pub fn needs(self) -> BakeNeeds {
                match self {
                    $(Technique::$variant(member) => member.needs(),)*
                }
            }

            /// The ground truth its error is measured against.
            pub fn reference(self) -> ReferenceModel {
                match self {
                    $(Technique::$variant(member) => member.reference(),)*
                }
            }

            /// Whether a change of lighting needs only new per-lighting data (tables,
            /// uniforms), not a new bake.
            pub fn dynamic_lighting(self) -> bool {
                match self {
                    $(Technique::$variant(member) => member.dynamic_lighting(),)*
                }
            }

            /// The NDF-filtered variant (`--normal-filter ndf`), where the family has one.
            pub fn ndf_variant(self) -> Option<Technique> {
                match self {
                    $(Technique::$variant(member) => member.ndf_variant(),)*
                }
            }

            /// Its form on `path`, or why it cannot run there: what bench, render, view,
            /// the ladder and export consult.
            pub fn form_on(self, path: HwPath) -> Result<Form, Refusal> {
                match self {
                    $(Technique::$variant(member) => member.form_on(path),)*
                }
            }

            /// The fragment shader and its defines.
            pub fn fragment_shader(self) -> ShaderVariant {
                match self {
                    $(Technique::$variant(member) => member.fragment_shader(),)*
                }
            }

            /// What its fragment shader reads ([`ShaderReads`]).
            pub fn reads(self) -> ShaderReads {
                match self {
                    $(Technique::$variant(member) => member.reads(),)*
                }
            }

            /// What its per-texel values are, as data ([`Family::values`]).
            pub fn values(self) -> Option<super::values::ValueMap> {
                match self {
                    $(Technique::$variant(member) => member.values(),)*
                }
            }

            /// What the run's options change in its data ("running" for an `sgN` fitted
            /// by the running average), for labels and cache keys.
            pub fn options_tag(self, options: &FamilyOptions) -> Option<String> {
                match self {
                    $(Technique::$variant(member) => member.options_tag(&options.$variant),)*
                }
            }

            /// The basis the SH lightmap bake fits from the samples for it under the run's
            /// options ([`Family::sample_fit`]).
            pub fn sample_fit(self, options: &FamilyOptions) -> Option<crate::sh::samples::SampleFit> {
                match self {
                    $(Technique::$variant(member) => member.sample_fit(&options.$variant),)*
                }
            }

            pub(crate) fn prepare_data(
                self,
                path: HwPath,
                inputs: &Inputs<'_>,
                label: &str,
            ) -> Result<(TexelGroups, Recipe), TechniqueError> {
                match self {
                    $(Technique::$variant(member) => {
                        member.prepare(path, inputs, &inputs.options.$variant, label)
                    })*
                }
            }

            pub(crate) fn extra_slot(
                self,
                ctx: &std::sync::Arc<crate::gpu::Context>,
                path: HwPath,
                inputs: &Inputs<'_>,
                label: &str,
            ) -> Result<Option<TextureSlot>, TechniqueError> {
                match self {
                    $(Technique::$variant(member) => member.extra_slot(ctx, path, inputs, label),)*
                }
            }
        }
    };
}

with_families!(define_technique);
