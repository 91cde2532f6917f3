//! The lighting-dependent half of a technique (Iwanicki–Sloan §3.3): what has to
//! be recomputed and uploaded when the environment changes, kept apart from the per-texel
//! bake data, which never changes.
//!
//! - [`LightingData`]: a uniform block and the normal-indexed tables, on the CPU, laid out
//!   as the GPU binds them — unc: L×H tables; pca: T_k tables; pcaNw: the V_k·L block;
//!   preconv / sh2: order-3 irradiance / radiance.
//! - [`LightingRecipe`]: everything a technique needs to build its `LightingData` from new
//!   SH lighting (for pca the quantized basis), owned and `Send`, so a worker thread can
//!   build the next tables while frames run.
//! - [`LightingSet`]: one GPU copy of that data with the pipeline bound to it. A technique
//!   built for dynamic lighting has two (`technique::build_dynamic`): an update refills
//!   the back one — uniforms written, tables through a staging copy submitted without
//!   waiting (`gpu::PendingUpload`) — and makes it the front one; later frames are ordered
//!   after the copy on the GPU, earlier ones keep the old set — double buffering, with the
//!   CPU never waiting (`TechniqueGpu::update_lighting`).
//!
//! `shlmap`'s lighting is baked into its lightmap: its recipe returns the same block for any
//! lighting, and `build_dynamic` refuses it.

use std::sync::Arc;

use super::finish::TextureSlot;
use super::tables::NormalTableData;
use super::texels::TexelGroups;
use super::{HwPath, Technique, TechniqueError};
use crate::bake::lxh::SymmetricBuild;
use crate::gpu::{self, Image, ImageDesc, MeshPipeline};
use crate::sh::Order;

/// A technique's lighting-dependent data (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct LightingData {
    /// The technique's uniform block (std140 bytes).
    pub params: Vec<u8>,
    /// Its normal-indexed tables, if it has any.
    pub tables: Option<NormalTableData>,
    /// Per-texel data that depends on the lighting (`nmprt*`: the transferred radiance
    /// formed from each texel's transfer matrix), bound where other families bind their
    /// bake's per-texel data.
    pub texels: Option<TexelGroups>,
    /// Defines the fragment shader is compiled with for this data's layout, where the
    /// technique alone does not fix it (`nmprtsvdMp`: the RGBA groups of a matrix row,
    /// from the transfer bake's lighting order, so that its loops unroll).
    pub defines: Vec<(&'static str, u32)>,
}

impl LightingData {
    /// A uniform block only.
    pub fn params(params: Vec<u8>) -> Self {
        LightingData {
            params,
            tables: None,
            texels: None,
            defines: Vec::new(),
        }
    }

    /// Every image's description and texel bytes (one slice per layer, level 0), tables
    /// first, on `path`: what one update uploads.
    pub fn image_uploads(&self, path: HwPath) -> Vec<(ImageDesc, Vec<Vec<&[u8]>>)> {
        let mut out = Vec::new();
        if let Some(tables) = &self.tables {
            for (i, image) in tables.images.iter().enumerate() {
                out.push((image.desc, tables.image_levels(i)));
            }
        }
        if let Some(texels) = &self.texels {
            out.extend(texels.image_levels(path));
        }
        out
    }
}

/// What each family needs besides the lighting.
#[derive(Clone)]
pub enum Recipe {
    Unc {
        order: Order,
        /// The symmetric build over the path's table map (orbits found once).
        table: Arc<SymmetricBuild>,
    },
    Pca {
        order: Order,
        /// As `Unc`; `None` for the weights-only variant, which has no tables.
        table: Option<Arc<SymmetricBuild>>,
        /// The quantized basis V_k' and mean V_e' (`bake::pca::QuantizedPca`).
        basis: Vec<Vec<f64>>,
        mean: Vec<f64>,
    },
    Preconv,
    Sh2,
    /// `vqK` / `cpcaK_M`: per cluster the quantized basis and mean (M = 0: VQ).
    Clustered {
        order: Order,
        bases: Vec<Vec<Vec<f64>>>,
        means: Vec<Vec<f64>>,
    },
    /// Lighting baked into the per-texel data (`shlmap`): the data never changes.
    Baked(LightingData),
    /// `nmprt*`: the transfer matrices and what the variant evaluates them with.
    Nmprt(Arc<super::nmprt::NmprtRecipe>),
    /// `uncOndf` / `preconvndf`: the base technique's data; for `unc` (`order`) its uniform
    /// block followed by the L×H table's band-0 constants (`technique::ndf_diffuse`).
    Ndf {
        base: Box<Recipe>,
        order: Option<Order>,
    },
}

/// Builds a technique's [`LightingData`] for any SH lighting (module doc).
#[derive(Clone)]
pub struct LightingRecipe {
    pub technique: Technique,
    pub path: HwPath,
    /// Clamped-cosine order of the L×H product.
    pub h_order: Order,
    pub(crate) recipe: Recipe,
}

impl LightingRecipe {
    /// "unc6.dx10".
    pub fn label(&self) -> String {
        format!("{}.{}", self.technique, self.path)
    }

    /// The recipe of `technique` on `path` for the bake data of `inputs`, without a GPU
    /// (benchmarks and tests of the rebuild; `technique::build_dynamic` returns the same).
    pub fn new(
        technique: Technique,
        path: HwPath,
        inputs: &super::Inputs<'_>,
    ) -> Result<Self, TechniqueError> {
        Ok(super::prepare(technique, path, inputs)?.1)
    }

    /// The data for radiance `radiance_sh` (to the visibility order + 2) and its order-3
    /// irradiance `irradiance_sh`.
    pub fn build(
        &self,
        radiance_sh: &[[f64; 3]],
        irradiance_sh: &[[f64; 3]],
    ) -> Result<LightingData, TechniqueError> {
        self.build_recipe(&self.recipe, radiance_sh, irradiance_sh)
    }

    fn build_recipe(
        &self,
        recipe: &Recipe,
        radiance_sh: &[[f64; 3]],
        irradiance_sh: &[[f64; 3]],
    ) -> Result<LightingData, TechniqueError> {
        let label = self.label();
        match recipe {
            Recipe::Unc { order, table } => {
                super::unc::lighting(*order, self.path, table, self.h_order, radiance_sh, &label)
            }
            Recipe::Pca {
                order,
                table,
                basis,
                mean,
            } => super::pca::lighting(
                basis,
                mean,
                *order,
                self.path,
                table.as_deref(),
                self.h_order,
                radiance_sh,
                &label,
            ),
            Recipe::Preconv => super::preconv::lighting(irradiance_sh, &label),
            Recipe::Sh2 => super::sh2::lighting(radiance_sh, &label),
            Recipe::Clustered {
                order,
                bases,
                means,
            } => super::cluster::lighting(bases, means, *order, radiance_sh, &label),
            Recipe::Baked(data) => Ok(data.clone()),
            Recipe::Nmprt(recipe) => recipe.lighting(radiance_sh, irradiance_sh, &label),
            Recipe::Ndf { base, order } => {
                let mut data = self.build_recipe(base, radiance_sh, irradiance_sh)?;
                if let Some(order) = order {
                    super::require_coefficients(
                        radiance_sh,
                        order.coeff_count(),
                        "lighting",
                        &label,
                    )?;
                    let ambient = super::ndf_diffuse::ambient_block(radiance_sh, *order);
                    data.params
                        .extend_from_slice(bytemuck::cast_slice(&ambient));
                }
                Ok(data)
            }
        }
    }
}

/// One GPU copy of a technique's lighting data and the pipeline that reads it.
pub(crate) struct LightingSet {
    pub pipeline: MeshPipeline,
    pub params: gpu::Buffer,
    /// Its normal-indexed tables, one slot per binding.
    pub tables: Vec<TextureSlot>,
    /// Its lighting-dependent per-texel images (`nmprt*`), bound instead of the bake's.
    pub own_per_texel: Option<TextureSlot>,
    /// The defines its pipeline's shader was compiled with ([`LightingData::defines`]).
    pub defines: Vec<(&'static str, u32)>,
}

impl LightingSet {
    /// Its images in upload order ([`LightingData::image_uploads`]): the tables, then the
    /// lighting-dependent per-texel images.
    pub fn images(&self) -> impl Iterator<Item = &Image> {
        self.tables
            .iter()
            .chain(&self.own_per_texel)
            .flat_map(|slot| &slot.images)
    }

    /// Checks `data` has this set's layout: same uniform size, same images, same defines.
    pub fn check_layout(
        &self,
        data: &LightingData,
        path: HwPath,
        label: &str,
    ) -> Result<(), TechniqueError> {
        let uploads = data.image_uploads(path);
        let same_tables = uploads.len() == self.images().count()
            && uploads
                .iter()
                .zip(self.images())
                .all(|((desc, _), i)| desc == i.desc());
        if data.params.len() as u64 != self.params.size()
            || !same_tables
            || data.defines != self.defines
        {
            return Err(TechniqueError::Input {
                label: label.into(),
                detail: "a lighting update does not have the layout the technique was built with"
                    .into(),
            });
        }
        Ok(())
    }
}
