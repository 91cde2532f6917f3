//! Techniques on the three hardware paths (`dx9`, `dx10`, `dx11`; DESIGN §2).
//!
//! - [`family`]: the interface every family implements ([`Family`]) — its names, bake,
//!   reference, lighting, form on each path ([`Form`], [`Refusal`]), preparation, shader and
//!   reads; [`registry`]: the one list of families, from which [`Technique`] and its
//!   dispatch are generated.
//! - one module per family, declared from the registry's list: [`unc`], [`pca`],
//!   [`shlmap`], [`preconv`], [`sh2`], [`vq`] and [`cpca`] (sharing [`cluster`]), [`vertex`]
//!   (`pcaMv`), [`rnm`], [`ndf_diffuse`], [`nmprt`], [`sh_variant`] (the SH lightmaps
//!   engines ship), [`hemisphere`] (bases over the tangent-frame hemisphere),
//!   [`ambient_cube`].
//! - [`spec`]: the GPU-free vocabulary (what a technique needs from the bake, its reference)
//!   and name parsing; [`catalog`]: the named sets and `shvis techniques`' listing.
//! - [`texels`] (per-texel groups), [`tables`] (normal-indexed tables) and [`block`] (the
//!   dx11 blocks): the data layouts the families share.
//! - [`lighting`]: the lighting-dependent half of each technique (uniforms, tables) and
//!   its recipe, so lighting can change without touching the per-texel data (§3.3).
//! - [`finish`]: the one path from uploaded data to a drawable [`TechniqueGpu`], with the
//!   path rules and the cost table's memory and lookup columns; [`cost`]: its counts for the
//!   cost model.
//!
//! docs/design.md, "How to add a technique", lists what a new family writes.

pub mod block;
pub mod catalog;
pub mod cluster;
pub mod cost;
pub mod family;
pub mod finish;
pub mod lighting;
pub mod registry;
use registry::declare_family_modules;
registry::with_families!(declare_family_modules);
pub mod spec;
pub mod tables;
pub mod texels;
pub mod values;

use std::sync::Arc;

pub use cluster::SeamMode;
pub use cpca::Cpca;
pub use family::{Family, Form, Refusal, Storage};
pub use hemisphere::{Hemisphere, HemisphereBasis, HemisphereOptions};
pub use lighting::{LightingData, LightingRecipe};
pub use ndf_diffuse::{Ndf, NdfBase};
pub use nmprt::{Nmprt, NmprtVariant};
pub use pca::Pca;
pub use preconv::Preconv;
pub use rnm::{Rnm, RnmVariant};
pub use sh_variant::{ShVariant, ShVariantBasis};
pub use sh2::Sh2;
pub use shlmap::Shlmap;
pub use spec::{
    BakeNeeds, ClusterNeed, FamilyOptions, HwPath, ParseError, ReferenceModel, Technique,
};
pub use unc::Unc;
pub use vertex::PcaVertex;
pub use vq::Vq;

use lighting::LightingSet;

use crate::bake::ao::AoMap;
use crate::bake::cluster::ClusteredModel;
use crate::bake::pca::PcaModel;
use crate::bake::shlmap::ShLightmap;
use crate::bake::vertex_pca::VertexPca;
use crate::bake::visibility::VisibilityMap;
use crate::gpu::{self, Context, GpuError, Image};
use crate::render::{Frame, SceneGpu};
use crate::sh::Order;

/// What techniques read from the bake and the lighting prep.
pub struct Inputs<'a> {
    /// The bake cache's folder, where derived data is cached too (the dx11 blocks); `None`:
    /// nothing cached.
    pub cache_dir: Option<&'a std::path::Path>,
    /// Ambient occlusion in the lightmap (`preconv`).
    pub ao: &'a AoMap,
    /// Order-3 SH of irradiance (radiance convolved with the clamped cosine), RGB.
    pub irradiance_sh: &'a [[f64; 3]],
    /// SH of radiance, RGB, to at least the visibility order + 2 (L×H tables).
    pub radiance_sh: &'a [[f64; 3]],
    /// SH visibility per lightmap texel (`unc*`, `sh2`).
    pub visibility: Option<&'a VisibilityMap>,
    /// PCA of the visibility with the largest basis any `pca*` uses (24 vectors).
    pub pca: Option<&'a PcaModel>,
    /// VQ / CPCA fits of the visibility (`vqK`, `cpcaK_M`), found by their `ClusterNeed`.
    pub clusters: &'a [ClusteredModel],
    /// Visibility baked at mesh vertices (`pcaMv`), found by M and edge length.
    pub vertex_pca: &'a [VertexPca],
    /// Order-3 SH of incident radiance with inter-reflection per texel (`shlmap`), and the
    /// three `rnm` lightmaps baked with it.
    pub sh_lightmap: Option<&'a ShLightmap>,
    /// The material's SSBump and AO (`ssbump`, `rnmao`), from its height field.
    pub ssbump: Option<&'a crate::bake::ssbump::SsBumpMaps>,
    /// The moments of the material's normal map (`uncOndf`, `preconvndf`;
    /// `crate::ndf::moment_maps`).
    pub ndf_moments: Option<&'a crate::ndf::NdfMaps>,
    /// Transfer matrices with inter-reflection per texel (`nmprt*`).
    pub transfer: Option<&'a Arc<crate::bake::transfer::TransferMap>>,
    /// L×H table texels per hemisphere / face side.
    pub table_res: u32,
    /// Clamped-cosine order of the L×H product.
    pub h_order: Order,
    /// Each family's run options (`--sg-solve` for the hemisphere bases).
    pub options: FamilyOptions,
}

/// Memory and cost figures of a technique on a path (the cost table's columns), computed
/// from what it binds ([`finish::stats`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TechniqueStats {
    /// Bytes of per-texel (lightmap) data on the GPU.
    pub texel_bytes: u64,
    /// Bytes of per-lighting lookup tables and uniforms.
    pub table_bytes: u64,
    /// Textures bound for the draw, albedo and normal map included.
    pub textures_bound: u32,
    /// Texture fetches per pixel, albedo and normal map included.
    pub lookups_per_pixel: u32,
}

/// A fragment shader under `glsl/` and the `SHVIS_*` defines of one technique's variant
/// (the path's define is added by [`finish::finish`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShaderVariant {
    pub path: &'static str,
    pub defines: Vec<(&'static str, u32)>,
}

/// What a family's fragment shader reads per pixel beyond one fetch of each layer it binds:
/// the cost table's lookup columns ([`finish::stats`]) and the cost model's counts
/// ([`cost::counts`]) follow it.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderReads {
    /// Where the shader reads its per-texel data otherwise than each layer once (the
    /// clustered techniques' taps).
    pub per_texel_taps: Option<PerTexelTaps>,
    /// How often it fetches each normal-indexed table: twice for `uncOndf` (at ±μ,
    /// `ndf_diffuse`), once otherwise.
    pub table_fetches: u32,
    /// Whether it reads the normal map (`ssbump`: its texel replaces it).
    pub reads_normal_map: bool,
    /// How the cost model counts a shader whose work per pixel depends on its data; `None`:
    /// the drawn shader's own SPIR-V.
    pub count_plan: Option<crate::cost::CountPlan>,
}

/// Per-texel fetches per pixel of a shader that reads its lightmap tap by tap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerTexelTaps {
    pub lookups: u32,
    /// Of `lookups`, the unfiltered texel fetches (`texelFetch`).
    pub fetches: u32,
}

impl ShaderReads {
    /// Each per-texel layer and table once, the normal map read, counted as drawn.
    pub const PLAIN: ShaderReads = ShaderReads {
        per_texel_taps: None,
        table_fetches: 1,
        reads_normal_map: true,
        count_plan: None,
    };
}

/// An input error unless `coeffs` has at least `need` SH coefficients (`what`: "lighting",
/// "irradiance"), so a too-short lighting is one clear line, not a panic in the maths.
pub(crate) fn require_coefficients(
    coeffs: &[[f64; 3]],
    need: usize,
    what: &str,
    label: &str,
) -> Result<(), TechniqueError> {
    if coeffs.len() < need {
        return Err(TechniqueError::Input {
            label: label.into(),
            detail: format!(
                "needs {what} with {need} SH coefficients, got {}",
                coeffs.len()
            ),
        });
    }
    Ok(())
}

/// Order-3 RGB SH coefficients as a std140 `vec4[9]` (RGB in .xyz): the uniform blocks of
/// `preconv` (irradiance) and `sh2` (radiance).
pub(crate) fn rgb_order3_block(coeffs: &[[f64; 3]]) -> [[f32; 4]; 9] {
    let mut block = [[0.0f32; 4]; 9];
    for (dst, src) in block.iter_mut().zip(coeffs) {
        *dst = [src[0] as f32, src[1] as f32, src[2] as f32, 0.0];
    }
    block
}

/// A technique ready to draw: its per-texel images and one or two copies of its lighting
/// data ([`lighting`]), each with its pipeline.
pub struct TechniqueGpu {
    pub technique: Technique,
    pub path: HwPath,
    pub stats: TechniqueStats,
    // Declared first so it drops (waiting for the GPU) before the images it writes.
    /// The last update's table copy, until it is known to have landed.
    upload: Option<gpu::PendingUpload>,
    sets: Vec<LightingSet>,
    front: usize,
    /// The bake's per-texel images (binding TEXTURE0 where a set has none of its own).
    per_texel: finish::TextureSlot,
    /// The technique's material textures or normal basis (the next binding).
    extra: Option<finish::TextureSlot>,
    /// The fragment shader its pipelines run (SPIR-V), for the cost model's counts.
    fragment: Vec<u32>,
    /// The technique's own mesh (`pcaMv`: the scene's surface with weights per vertex);
    /// `None` draws the scene's.
    mesh: Option<gpu::MeshBuffers>,
    ctx: Arc<Context>,
}

impl TechniqueGpu {
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &Arc<Context>,
        technique: Technique,
        path: HwPath,
        stats: TechniqueStats,
        per_texel: finish::TextureSlot,
        extra: Option<finish::TextureSlot>,
        fragment: Vec<u32>,
        sets: Vec<LightingSet>,
    ) -> Self {
        TechniqueGpu {
            technique,
            path,
            stats,
            upload: None,
            sets,
            front: 0,
            per_texel,
            extra,
            fragment,
            mesh: None,
            ctx: ctx.clone(),
        }
    }

    /// "preconv.dx10": debug label and timestamp row.
    pub fn label(&self) -> String {
        format!("{}.{}", self.technique, self.path)
    }

    /// Renders `scene` with this technique's front lighting set: `warmup` untimed frames,
    /// then `frames` timed ones, and reads the last image back. Waits for its frames, so no
    /// set is in use by the GPU between calls.
    pub fn render(&self, scene: &SceneGpu, warmup: u32, frames: u32) -> Result<Frame, GpuError> {
        let pipeline = &self.sets[self.front].pipeline;
        match &self.mesh {
            Some(mesh) => scene.render_pipeline_on(pipeline, mesh, warmup, frames),
            None => scene.render_pipeline(pipeline, warmup, frames),
        }
    }

    /// Frame times of [`Self::render`], the image not read back.
    pub fn time(&self, scene: &SceneGpu, warmup: u32, frames: u32) -> Result<Vec<f64>, GpuError> {
        let pipeline = &self.sets[self.front].pipeline;
        match &self.mesh {
            Some(mesh) => scene.time_pipeline_on(pipeline, mesh, warmup, frames),
            None => scene.time_pipeline(pipeline, warmup, frames),
        }
    }

    /// Triangles one frame draws: the technique's own mesh's, else the scene's.
    pub fn triangle_count(&self, scene: &SceneGpu) -> u32 {
        self.mesh
            .as_ref()
            .map_or_else(|| scene.triangle_count(), gpu::MeshBuffers::triangle_count)
    }

    /// Bytes one lighting update writes: the uniform block and every lighting image (tables,
    /// and per-texel data formed from the lighting, `nmprt*`).
    pub fn update_bytes(&self) -> u64 {
        let set = &self.sets[self.front];
        set.params.size() + set.images().map(|i| i.desc().level0_bytes()).sum::<u64>()
    }

    /// Copies of the lighting data (2 when built with [`build_dynamic`]).
    pub fn lighting_sets(&self) -> usize {
        self.sets.len()
    }

    /// Replaces the lighting data with `data` without waiting for the GPU (double
    /// buffering, [`lighting`]): writes the back set's uniforms, submits the staging copy of
    /// its tables and makes it the front set. Frames submitted from now on draw the new
    /// data — the GPU orders them after the copy (its closing barrier), so the CPU never
    /// waits — while the old set stays intact for frames that were already submitted.
    ///
    /// The back set must not be read by frames in flight; [`Self::render`] waits for its
    /// frames, so between calls it never is.
    pub fn update_lighting(&mut self, data: &LightingData) -> Result<(), TechniqueError> {
        let label = self.label();
        if self.sets.len() < 2 {
            return Err(TechniqueError::Input {
                label,
                detail: "built with one lighting set; build it with build_dynamic to update it"
                    .into(),
            });
        }
        let back = (self.front + 1) % self.sets.len();
        let set = &mut self.sets[back];
        set.check_layout(data, self.path, &label)?;
        set.params.write(&data.params)?;
        // The previous copy went into the other set; its staging buffer is released once
        // the GPU is done with it (dropping waits, and by now it has long landed).
        self.upload = None;
        let levels = data.image_uploads(self.path);
        if !levels.is_empty() {
            let uploads: Vec<(&Image, &[Vec<&[u8]>])> = set
                .images()
                .zip(&levels)
                .map(|(image, (_, l))| (image, l.as_slice()))
                .collect();
            let name = format!("{label}.update");
            self.upload = Some(gpu::PendingUpload::submit(&self.ctx, &uploads, &name)?);
        }
        self.front = back;
        Ok(())
    }

    /// Whether the last update's table copy is still running on the GPU (never blocks).
    pub fn upload_in_flight(&mut self) -> Result<bool, TechniqueError> {
        let done = match &self.upload {
            Some(upload) => upload.is_done()?,
            None => true,
        };
        if done {
            self.upload = None;
        }
        Ok(!done)
    }

    /// Blocks until the last update's table copy has landed.
    pub fn wait_for_upload(&mut self) -> Result<(), TechniqueError> {
        if let Some(upload) = self.upload.take() {
            upload.wait()?;
        }
        Ok(())
    }
}

/// Builds `technique` on `path` for `scene` with one copy of its lighting data.
pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    Ok(build_sets(ctx, scene, technique, path, inputs, 1, None)?.0)
}

/// [`build`] with `fragment` (SPIR-V) in place of the technique's own shader: a shader
/// assembled from `shvis export`'s decode snippet, to check it draws what the technique
/// draws.
pub fn build_with_fragment(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
    fragment: Vec<u32>,
) -> Result<TechniqueGpu, TechniqueError> {
    Ok(build_sets(ctx, scene, technique, path, inputs, 1, Some(fragment))?.0)
}

/// Builds `technique` for lighting that changes: two copies of its lighting data to swap
/// between ([`TechniqueGpu::update_lighting`]), and the recipe that builds new data. Refuses
/// techniques whose lighting is baked in (`shlmap`).
pub fn build_dynamic(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<(TechniqueGpu, LightingRecipe), TechniqueError> {
    if !technique.dynamic_lighting() {
        return Err(TechniqueError::Input {
            label: format!("{technique}.{path}"),
            detail:
                "its lighting is baked into the lightmap; it cannot follow a changing environment"
                    .into(),
        });
    }
    build_sets(ctx, scene, technique, path, inputs, 2, None)
}

/// The per-texel data of `technique` as [`build`] uploads it on `path` before any block
/// compression (`shvis export`).
///
/// # Errors
/// Inputs the technique lacks.
pub fn per_texel_data(
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<texels::TexelGroups, TechniqueError> {
    Ok(prepare(technique, path, inputs)?.0)
}

/// What `technique`'s `dx11` blocks decode to, for the error ladder's block compression
/// rung.
///
/// # Errors
/// A technique without a dx11 form, or inputs it lacks.
pub fn dx11_decoded_values(
    technique: Technique,
    inputs: &Inputs<'_>,
) -> Result<block::DecodedBlocks, TechniqueError> {
    let label = format!("{technique}.{}", HwPath::Dx11);
    let codec = block::dx11_codec(technique, &label)?;
    let (texels, _) = prepare(technique, HwPath::Dx11, inputs)?;
    Ok(block::compress_cached(&texels, codec, &label, inputs.cache_dir)?.decode())
}

/// The CPU half of a build: the per-texel data to upload and the lighting recipe.
fn prepare(
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<(texels::TexelGroups, LightingRecipe), TechniqueError> {
    let label = format!("{technique}.{path}");
    let (texels, recipe) = technique.prepare_data(path, inputs, &label)?;
    let recipe = LightingRecipe {
        technique,
        path,
        h_order: inputs.h_order,
        recipe,
    };
    Ok((texels, recipe))
}

fn build_sets(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
    sets: usize,
    own_fragment: Option<Vec<u32>>,
) -> Result<(TechniqueGpu, LightingRecipe), TechniqueError> {
    let label = format!("{technique}.{path}");
    let form = technique
        .form_on(path)
        .map_err(|why| refused(&label, path, why))?;
    let (texels, recipe) = prepare(technique, path, inputs)?;
    let data = recipe.build(inputs.radiance_sh, inputs.irradiance_sh)?;
    if form.storage == Storage::VertexStream {
        let gpu = vertex::finish(ctx, scene, technique, path, inputs, &data, sets)?;
        return Ok((gpu, recipe));
    }
    let per_texel =
        block::upload_per_texel(ctx, &texels, technique, path, &label, inputs.cache_dir)?;
    let extra = technique.extra_slot(ctx, path, inputs, &label)?;
    let gpu = finish::finish(
        ctx,
        scene,
        technique,
        path,
        per_texel,
        extra,
        &data,
        sets,
        own_fragment,
    )?;
    Ok((gpu, recipe))
}

/// The error of building `label` on a path it has no form on.
pub fn refused(label: &str, path: HwPath, why: Refusal) -> TechniqueError {
    TechniqueError::Input {
        label: label.into(),
        detail: format!("cannot run on {path}: {why}"),
    }
}

/// Errors of building a technique.
#[derive(Debug, thiserror::Error)]
pub enum TechniqueError {
    #[error("{label}: breaks the dx9 rules: {detail}")]
    Dx9Rule { label: String, detail: String },
    #[error("{label}: {detail}")]
    Input { label: String, detail: String },
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::{ShaderStage, compile_glsl};

    /// Every registered technique's fragment shader (and a few beyond the table's rows) on
    /// every path, compiled as its build compiles it, with `f` given each result.
    fn for_every_fragment_shader(
        mut f: impl FnMut(Technique, HwPath, Result<Vec<u32>, crate::gpu::GpuError>),
    ) {
        let beyond_the_table = [
            "unc2",
            "unc5",
            "pca20",
            "pca20w",
            "vq16n",
            "cpca32_11",
            "cpca4_3n",
            "cpca4_15",
        ];
        let techniques = Technique::all()
            .iter()
            .copied()
            .chain(beyond_the_table.iter().map(|n| n.parse().unwrap()));
        for technique in techniques {
            let shader = technique.fragment_shader();
            for &path in HwPath::ALL {
                let mut defines = block::path_defines(technique, path);
                defines.extend_from_slice(&shader.defines);
                // What the build adds from its data (the default lighting order's).
                if let Technique::Nmprt(nmprt::Nmprt {
                    variant: NmprtVariant::SvdPixel { .. },
                }) = technique
                {
                    let order = crate::bake::transfer::DEFAULT_LIGHTING_ORDER;
                    defines.push(nmprt::pixel_row_groups(order.coeff_count()));
                }
                f(
                    technique,
                    path,
                    compile_glsl(shader.path, ShaderStage::Fragment, &defines),
                );
            }
        }
    }

    #[test]
    fn every_registered_fragment_shader_compiles_on_both_paths() {
        for_every_fragment_shader(|technique, path, spirv| {
            if let Err(e) = spirv {
                panic!("{technique}.{path}: {e}");
            }
        });
    }

    /// The cost model counts a shader's SPIR-V as written: a loop left in it would be
    /// counted once however many times it runs. Every shader without a count plan (whose
    /// count builds unroll what the drawn one keeps) is unrolled in full.
    #[test]
    fn every_counted_fragment_shader_is_unrolled() {
        let mut kept = Vec::new();
        for_every_fragment_shader(|technique, path, spirv| {
            let spirv = spirv.unwrap_or_else(|e| panic!("{technique}.{path}: {e}"));
            let counts = crate::cost::spirv::count(&spirv);
            if technique.reads().count_plan.is_none() && counts.loops > 0 {
                kept.push(format!("{technique}.{path}: {} loop(s)", counts.loops));
            }
        });
        assert!(kept.is_empty(), "loops counted once: {kept:#?}");
    }
}
