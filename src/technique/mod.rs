//! Techniques of the paper's cost table (DESIGN §2) and the two hardware paths.
//!
//! A technique is one module that says what it needs from the bake and the lighting prep
//! ([`Inputs`]), what it uploads, and which fragment shader it runs; adding one touches its
//! module, its shader, the `TechniqueId` list and tests. The CLI's names live here only.

pub mod grouped;
pub mod pca;
pub mod preconv;
pub mod sh2;
pub mod shlmap;
pub mod unc;

use std::fmt;
use std::str::FromStr;
use std::sync::Arc;

use ash::vk;

use crate::bake::ao::AoMap;
use crate::bake::pca::PcaModel;
use crate::bake::shlmap::ShLightmap;
use crate::bake::visibility::VisibilityMap;
use crate::gpu::{self, Context, GpuError, Image, MeshPipeline, layout};
use crate::render::SceneGpu;
use crate::sh::Order;

/// The techniques that exist, in DESIGN §2 order; `FromStr`/`Display` use the CLI names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TechniqueId {
    Unc3,
    Unc4,
    Unc6,
    Pca4,
    Pca8,
    Pca12,
    Pca16,
    Pca24,
    Pca4w,
    Pca8w,
    Pca12w,
    Pca16w,
    Pca24w,
    Shlmap,
    Preconv,
    Sh2,
}

impl TechniqueId {
    pub const ALL: &'static [TechniqueId] = &[
        TechniqueId::Unc3,
        TechniqueId::Unc4,
        TechniqueId::Unc6,
        TechniqueId::Pca4,
        TechniqueId::Pca8,
        TechniqueId::Pca12,
        TechniqueId::Pca16,
        TechniqueId::Pca24,
        TechniqueId::Pca4w,
        TechniqueId::Pca8w,
        TechniqueId::Pca12w,
        TechniqueId::Pca16w,
        TechniqueId::Pca24w,
        TechniqueId::Shlmap,
        TechniqueId::Preconv,
        TechniqueId::Sh2,
    ];

    pub fn name(self) -> &'static str {
        match self {
            TechniqueId::Unc3 => "unc3",
            TechniqueId::Unc4 => "unc4",
            TechniqueId::Unc6 => "unc6",
            TechniqueId::Pca4 => "pca4",
            TechniqueId::Pca8 => "pca8",
            TechniqueId::Pca12 => "pca12",
            TechniqueId::Pca16 => "pca16",
            TechniqueId::Pca24 => "pca24",
            TechniqueId::Pca4w => "pca4w",
            TechniqueId::Pca8w => "pca8w",
            TechniqueId::Pca12w => "pca12w",
            TechniqueId::Pca16w => "pca16w",
            TechniqueId::Pca24w => "pca24w",
            TechniqueId::Shlmap => "shlmap",
            TechniqueId::Preconv => "preconv",
            TechniqueId::Sh2 => "sh2",
        }
    }
}

impl fmt::Display for TechniqueId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for TechniqueId {
    type Err = TechniqueError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        TechniqueId::ALL
            .iter()
            .copied()
            .find(|t| t.name() == s)
            .ok_or_else(|| TechniqueError::UnknownTechnique {
                name: s.to_string(),
                known: join_names(TechniqueId::ALL.iter().map(|t| t.name())),
            })
    }
}

impl TechniqueId {
    /// ms/frame of the paper's cost table (GeForce GTX 295, 1280×800, 512² visibility;
    /// DESIGN §3) for the techniques it measured.
    pub fn paper_ms(self) -> Option<f64> {
        Some(match self {
            TechniqueId::Unc6 => 8.19,
            TechniqueId::Unc4 => 3.33,
            TechniqueId::Unc3 => 2.75,
            TechniqueId::Pca4 => 1.40,
            TechniqueId::Pca8 => 2.08,
            TechniqueId::Pca16 => 3.61,
            TechniqueId::Pca24 => 5.56,
            TechniqueId::Shlmap => 0.846,
            TechniqueId::Preconv => 0.648,
            TechniqueId::Sh2 => 0.607,
            _ => return None,
        })
    }

    /// The paper's time relative to its `preconv`.
    pub fn paper_ratio_to_preconv(self) -> Option<f64> {
        Some(self.paper_ms()? / TechniqueId::Preconv.paper_ms()?)
    }
}

/// The hardware paths of DESIGN §2.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HwPath {
    /// DX9-class: 2D textures only, ≤ 16 textures per draw, 4 values per RGBA texel.
    Dx9,
    /// DX10-class: texture arrays for per-texel data, seamless cube (array) tables.
    Dx10,
}

impl HwPath {
    pub const ALL: &'static [HwPath] = &[HwPath::Dx9, HwPath::Dx10];

    pub fn name(self) -> &'static str {
        match self {
            HwPath::Dx9 => "dx9",
            HwPath::Dx10 => "dx10",
        }
    }

    /// The value of the shader macro `SHVIS_PATH_DX9`.
    pub fn shader_define(self) -> (&'static str, u32) {
        ("PATH_DX9", (self == HwPath::Dx9) as u32)
    }
}

impl fmt::Display for HwPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for HwPath {
    type Err = TechniqueError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        HwPath::ALL
            .iter()
            .copied()
            .find(|p| p.name() == s)
            .ok_or_else(|| TechniqueError::UnknownPath {
                name: s.to_string(),
                known: join_names(HwPath::ALL.iter().map(|p| p.name())),
            })
    }
}

fn join_names<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

/// What techniques read from the bake and the lighting prep.
pub struct Inputs<'a> {
    /// Ambient occlusion in the lightmap (`preconv`).
    pub ao: &'a AoMap,
    /// Order-3 SH of irradiance (radiance convolved with the clamped cosine), RGB.
    pub irradiance_sh: &'a [[f64; 3]],
    /// SH of radiance, RGB, to at least the visibility order + 2 (L×H tables).
    pub radiance_sh: &'a [[f64; 3]],
    /// SH visibility per lightmap texel (`unc*`).
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

/// Memory and cost figures of a technique on a path (the cost table's columns).
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

/// A technique ready to draw: its pipeline and the resources it owns.
pub struct TechniqueGpu {
    pub id: TechniqueId,
    pub path: HwPath,
    pub pipeline: MeshPipeline,
    pub stats: TechniqueStats,
    _images: Vec<Image>,
    _buffers: Vec<gpu::Buffer>,
}

impl TechniqueGpu {
    /// "preconv.dx10": debug label and timestamp row.
    pub fn label(&self) -> String {
        format!("{}.{}", self.id, self.path)
    }
}

/// Builds technique `id` on `path`.
pub fn build(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: TechniqueId,
    path: HwPath,
    inputs: &Inputs<'_>,
) -> Result<TechniqueGpu, TechniqueError> {
    match id {
        TechniqueId::Unc3 | TechniqueId::Unc4 | TechniqueId::Unc6 => {
            unc::build(ctx, scene, id, path, inputs)
        }
        TechniqueId::Preconv => preconv::build(ctx, scene, path, inputs),
        TechniqueId::Shlmap => shlmap::build(ctx, scene, path, inputs),
        TechniqueId::Sh2 => sh2::build(ctx, scene, path, inputs),
        _ => pca::build(ctx, scene, id, path, inputs),
    }
}

/// The end shared by techniques with one uniform block (`params`, std140 bytes) and their
/// per-texel `images` at TEXTURE0 — one image as a single texture, several as a texture
/// array (dx9's `sampler2D t[N]`): path rules, uniform buffer, `shader` compiled with the
/// path's define plus `defines`, pipeline.
#[allow(clippy::too_many_arguments)]
pub(crate) fn finish_per_texel(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    id: TechniqueId,
    path: HwPath,
    shader: &str,
    defines: &[(&str, u32)],
    params: &[u8],
    images: Vec<Image>,
    stats: TechniqueStats,
) -> Result<TechniqueGpu, TechniqueError> {
    let label = format!("{id}.{path}");
    let refs: Vec<&Image> = images.iter().collect();
    check_path_rules(&label, path, &refs)?;
    let params_buffer = gpu::Buffer::with_data(
        ctx,
        params,
        vk::BufferUsageFlags::UNIFORM_BUFFER,
        &format!("{label}.params"),
    )?;
    let mut all_defines = vec![path.shader_define()];
    all_defines.extend_from_slice(defines);
    let fragment = gpu::compile_glsl(shader, gpu::ShaderStage::Fragment, &all_defines)?;
    let sampler = scene.lightmap_sampler();
    let textures = match images.as_slice() {
        [one] => gpu::Resource::Texture(one, sampler),
        many => gpu::Resource::TextureArray(many.iter().map(|i| (i, sampler)).collect()),
    };
    let mut resources = scene.common_resources();
    resources.push((
        layout::BINDING_TECHNIQUE_PARAMS,
        gpu::Resource::Uniform(&params_buffer),
    ));
    resources.push((layout::BINDING_TECHNIQUE_TEXTURE0, textures));
    let pipeline = scene.mesh_pipeline(ctx, &label, &fragment, &resources)?;
    drop(resources);
    Ok(TechniqueGpu {
        id,
        path,
        pipeline,
        stats,
        _images: images,
        _buffers: vec![params_buffer],
    })
}

/// Enforces the `dx9` rules in code (DESIGN §2): only 2D textures, at most
/// `DX9_MAX_TEXTURES` per draw counting albedo and normal map.
pub fn check_path_rules(
    label: &str,
    path: HwPath,
    technique_textures: &[&Image],
) -> Result<(), TechniqueError> {
    if path != HwPath::Dx9 {
        return Ok(());
    }
    let total = technique_textures.len() as u32 + layout::MATERIAL_TEXTURES;
    if total > layout::DX9_MAX_TEXTURES {
        return Err(TechniqueError::Dx9Rule {
            label: label.into(),
            detail: format!(
                "needs {total} textures per draw, dx9 allows {}",
                layout::DX9_MAX_TEXTURES
            ),
        });
    }
    if let Some(img) = technique_textures
        .iter()
        .find(|i| i.desc().view_type != vk::ImageViewType::TYPE_2D)
    {
        return Err(TechniqueError::Dx9Rule {
            label: label.into(),
            detail: format!(
                "binds a {:?} texture; dx9 allows only 2D textures",
                img.desc().view_type
            ),
        });
    }
    Ok(())
}

/// Errors of building a technique.
#[derive(Debug, thiserror::Error)]
pub enum TechniqueError {
    #[error("unknown technique '{name}'; known: {known}")]
    UnknownTechnique { name: String, known: String },
    #[error("unknown path '{name}'; known: {known}")]
    UnknownPath { name: String, known: String },
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

    #[test]
    fn names_round_trip_and_unknown_lists_known() {
        for &t in TechniqueId::ALL {
            assert_eq!(t.name().parse::<TechniqueId>().unwrap(), t);
        }
        for &p in HwPath::ALL {
            assert_eq!(p.name().parse::<HwPath>().unwrap(), p);
        }
        let e = "unc7".parse::<TechniqueId>().unwrap_err().to_string();
        assert!(e.contains("unc7") && e.contains("preconv"), "{e}");
        let e = "dx11".parse::<HwPath>().unwrap_err().to_string();
        assert!(e.contains("dx9, dx10"), "{e}");
    }
}
