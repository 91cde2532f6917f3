//! Techniques of the paper's cost table (DESIGN §2) on the two hardware paths.
//!
//! - [`spec`]: what a technique is, GPU-free — family and parameters, names, the paper's
//!   figures, what it needs from the bake, which reference it meets.
//! - one module per family ([`unc`], [`pca`], [`shlmap`], [`preconv`], [`sh2`]): what it
//!   uploads and which fragment shader it runs (`fragment_shader`).
//! - [`texels`] (per-texel groups) and [`tables`] (normal-indexed tables): the data layouts
//!   the families share.
//! - [`finish`]: the one path from uploaded data to a drawable [`TechniqueGpu`], with the
//!   path rules and the cost table's memory and lookup columns.
//!
//! [`build`] and [`fragment_shader`] dispatch on the family by exhaustive matches; README
//! "How to add a technique" lists the places a new family touches.

pub mod finish;
pub mod pca;
pub mod preconv;
pub mod sh2;
pub mod shlmap;
pub mod spec;
pub mod tables;
pub mod texels;
pub mod unc;

use std::sync::Arc;

pub use spec::{BakeNeeds, HwPath, ParseError, ReferenceModel, Technique};

use crate::bake::ao::AoMap;
use crate::bake::pca::PcaModel;
use crate::bake::shlmap::ShLightmap;
use crate::bake::visibility::VisibilityMap;
use crate::gpu::{self, Context, GpuError, Image, MeshPipeline};
use crate::render::{Frame, SceneGpu};
use crate::sh::Order;

/// What techniques read from the bake and the lighting prep.
pub struct Inputs<'a> {
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
    /// Order-3 SH of incident radiance with inter-reflection per texel (`shlmap`).
    pub sh_lightmap: Option<&'a ShLightmap>,
    /// L×H table texels per hemisphere / face side.
    pub table_res: u32,
    /// Clamped-cosine order of the L×H product.
    pub h_order: Order,
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

/// The fragment shader each family registers.
pub fn fragment_shader(technique: Technique) -> ShaderVariant {
    match technique {
        Technique::Unc { order } => unc::fragment_shader(order),
        Technique::Pca { m, weights_only } => pca::fragment_shader(m, weights_only),
        Technique::Shlmap => shlmap::fragment_shader(),
        Technique::Preconv => preconv::fragment_shader(),
        Technique::Sh2 => sh2::fragment_shader(),
    }
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

/// A technique ready to draw: its pipeline and the resources it owns.
pub struct TechniqueGpu {
    pub technique: Technique,
    pub path: HwPath,
    pub pipeline: MeshPipeline,
    pub stats: TechniqueStats,
    _images: Vec<Image>,
    _buffers: Vec<gpu::Buffer>,
}

impl TechniqueGpu {
    /// "preconv.dx10": debug label and timestamp row.
    pub fn label(&self) -> String {
        format!("{}.{}", self.technique, self.path)
    }

    /// Renders `scene` with this technique: `warmup` untimed frames, then `frames` timed
    /// ones, and reads the last image back.
    pub fn render(&self, scene: &SceneGpu, warmup: u32, frames: u32) -> Result<Frame, GpuError> {
        scene.render_pipeline(&self.pipeline, warmup, frames)
    }
}

/// Builds `technique` on `path` for `scene`.
pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    technique: Technique,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    match technique {
        Technique::Unc { order } => unc::build(ctx, scene, order, path, inputs),
        Technique::Pca { m, weights_only } => pca::build(ctx, scene, m, weights_only, path, inputs),
        Technique::Shlmap => shlmap::build(ctx, scene, path, inputs),
        Technique::Preconv => preconv::build(ctx, scene, path, inputs),
        Technique::Sh2 => sh2::build(ctx, scene, path, inputs),
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

    #[test]
    fn every_registered_fragment_shader_compiles_on_both_paths() {
        let beyond_the_table = ["unc2", "unc5", "pca20", "pca20w"];
        let techniques = Technique::ALL
            .iter()
            .copied()
            .chain(beyond_the_table.iter().map(|n| n.parse().unwrap()));
        for technique in techniques {
            let shader = fragment_shader(technique);
            for &path in HwPath::ALL {
                let mut defines = vec![path.shader_define()];
                defines.extend_from_slice(&shader.defines);
                compile_glsl(shader.path, ShaderStage::Fragment, &defines)
                    .unwrap_or_else(|e| panic!("{technique}.{path}: {e}"));
            }
        }
    }
}
