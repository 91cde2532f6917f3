//! Argument groups several commands share (scene and bake, device, baker, specular term,
//! normal filtering) and the value parsers of numeric options.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Result, bail};
use clap::Args;

use shvis::bake::gpu_visibility::GpuVisibilitySettings;
use shvis::gpu::Context;
use shvis::technique::Technique;

/// A finite f32 (clap value parser): NaN and ±inf are refused where they are typed, not
/// turned into a black image later.
pub(super) fn finite_f32(text: &str) -> Result<f32, String> {
    let v: f32 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} is not a finite number"))
    }
}

/// A finite f64 (clap value parser), as [`finite_f32`].
pub(super) fn finite_f64(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} is not a finite number"))
    }
}

/// A finite f64 of at least 1 (clap value parser): a screen area in pixels.
pub(super) fn at_least_one_f64(text: &str) -> Result<f64, String> {
    let v = finite_f64(text)?;
    if v >= 1.0 {
        Ok(v)
    } else {
        Err(format!("{text} is below 1"))
    }
}

/// A rotation in degrees: finite, within ±360.
pub(super) fn finite_degrees(s: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v.abs() <= 360.0 {
        Ok(v)
    } else {
        Err(format!("{s} is not a finite angle within ±360 degrees"))
    }
}

#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Scene and bake")]
pub(super) struct SceneArgs {
    /// A built-in scene (`house`, `patio`: a brick corner, `bumpy`, `wavy`) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    pub(super) scene: String,
    /// Lightmap texels per side.
    #[arg(long, default_value_t = 512)]
    pub(super) vis_res: u32,
    /// Rays per lightmap texel.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(shvis::bake::MIN_RAYS as i64..=shvis::bake::MAX_RAYS as i64))]
    pub(super) rays: u32,
    /// Seed of the bake's sample patterns.
    #[arg(long, default_value_t = 0)]
    pub(super) seed: u64,
    /// SH order of the visibility bake (bands l < order); at most 28, as the L×H product
    /// needs lighting of order + 2 ≤ 30.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=shvis::prepare::MAX_VISIBILITY_ORDER as i64))]
    pub(super) order: u32,
    /// L×H table texels per hemisphere (dx9) or cube face (dx10) side.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(shvis::prepare::TABLE_RES_MIN as i64..=shvis::prepare::TABLE_RES_MAX as i64))]
    pub(super) table_res: u32,
    /// SH order of the clamped cosine in the L×H product (the paper uses 3).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=shvis::sh::MAX_ORDER as i64))]
    pub(super) h_order: u32,
    /// How sgN techniques fit their lobes' amplitudes: projection, ls (least squares),
    /// nnls (non-negative least squares), running (running average), running-nn.
    #[arg(long = "sg-solve", default_value_t = shvis::sh::sg::DEFAULT_SOLVER)]
    pub(super) sg_solve: shvis::sh::sg::Solver,
    /// What the tangent-frame bases (hb4, hb6, sgN, dice, dicey, acube, acubels) are
    /// fitted from: samples (each texel's radiance samples, the bake's rays) or l2 (the
    /// texel's order-3 SH).
    #[arg(long = "basis-fit", default_value_t = shvis::sh::samples::BasisFit::Samples)]
    pub(super) basis_fit: shvis::sh::samples::BasisFit,
    /// What the SH lightmap bake's rays read of the environment where they escape: sh (its
    /// order-8 SH at each shared direction) or pixels (the full-resolution map, with a
    /// quarter as many rays again per texel importance-sampled from it).
    #[arg(long = "bake-env", default_value_t = shvis::bake::shlmap::BakeEnv::Sh)]
    pub(super) bake_env: shvis::bake::shlmap::BakeEnv,
    /// Lighting order O of the transfer matrices of the nmprt* techniques (9 × O² per
    /// texel and colour): at most the prepared lighting's order 8.
    #[arg(long, default_value_t = shvis::bake::transfer::DEFAULT_LIGHTING_ORDER.get(), value_parser = clap::value_parser!(u32).range(1..=shvis::prepare::LIGHTING_ORDER as i64))]
    pub(super) transfer_order: u32,
    /// Height map of the scene's material (PNG/EXR luminance), tiled by its UVs like the
    /// normal map: what `ssbump` and `rnmao` shadow with (replaces the built-in bricks').
    #[arg(long)]
    pub(super) height_map: Option<PathBuf>,
    /// Height of a white `--height-map` texel, in texels of the map (at most 100).
    #[arg(long, default_value_t = 1.0, requires = "height_map", value_parser = finite_f64)]
    pub(super) height_scale: f64,
}

#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Device")]
pub(super) struct GpuArgs {
    /// Pick the first Vulkan device whose name contains this.
    #[arg(long)]
    pub(super) device: Option<String>,
    /// Turn on VK_LAYER_KHRONOS_validation.
    #[arg(long)]
    pub(super) validate: bool,
}

/// Who bakes the visibility (`bake`, `render`, `bench`).
#[derive(Args, Debug)]
#[command(next_help_heading = "GPU baker")]
pub(super) struct BakerArgs {
    /// Who bakes the visibility: `cpu` (ray tracing, cached) or `gpu` (the PRT course's
    /// GPU simulator: a depth map per direction, not cached).
    #[arg(long, value_enum, default_value_t = VisibilityBakerArg::Cpu)]
    pub(super) baker: VisibilityBakerArg,
    /// `--baker gpu`: depth-map texels per side (16–8192; default 4096).
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=shvis::bake::gpu_visibility::MAX_DEPTH_RES as i64))]
    depth_res: Option<u32>,
    /// `--baker gpu`: constant depth bias, depth-map texels (default 0.1).
    #[arg(long, value_parser = finite_f32)]
    depth_bias: Option<f32>,
    /// `--baker gpu`: depth bias per unit tan of the ray's angle to the normal, texels
    /// (default 0.5).
    #[arg(long, value_parser = finite_f32)]
    slope_bias: Option<f32>,
}

impl BakerArgs {
    /// Refuses the GPU baker's settings without `--baker gpu`, where they would do nothing.
    pub(super) fn check(&self) -> Result<()> {
        if self.baker == VisibilityBakerArg::Gpu {
            return Ok(());
        }
        let given = [
            ("--depth-res", self.depth_res.is_some()),
            ("--depth-bias", self.depth_bias.is_some()),
            ("--slope-bias", self.slope_bias.is_some()),
        ];
        if let Some((option, _)) = given.iter().find(|(_, set)| *set) {
            bail!("{option} tunes the GPU baker's depth maps: only with --baker gpu");
        }
        Ok(())
    }

    /// The baker `prepare_with` runs, on `ctx` for `gpu`.
    pub(super) fn visibility_baker(&self, ctx: &Arc<Context>) -> shvis::prepare::VisibilityBaker {
        let defaults = GpuVisibilitySettings::default();
        match self.baker {
            VisibilityBakerArg::Cpu => shvis::prepare::VisibilityBaker::Cpu,
            VisibilityBakerArg::Gpu => shvis::prepare::VisibilityBaker::Gpu {
                ctx: ctx.clone(),
                settings: GpuVisibilitySettings {
                    depth_res: self.depth_res.unwrap_or(defaults.depth_res),
                    bias_texels: self.depth_bias.unwrap_or(defaults.bias_texels),
                    slope_bias_texels: self.slope_bias.unwrap_or(defaults.slope_bias_texels),
                },
            },
        }
    }
}

/// `--baker`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum VisibilityBakerArg {
    /// Ray tracing (cached).
    Cpu,
    /// The PRT course's GPU simulator (not cached).
    Gpu,
}

/// `--normal-filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum NormalFilterArg {
    Mip,
    Ndf,
}

/// `techniques` under `--normal-filter`: with `ndf` each unc*/preconv replaced by its NDF
/// variant (duplicates dropped), a note naming those without one.
pub(super) fn with_normal_filter(
    techniques: Vec<Technique>,
    filter: NormalFilterArg,
) -> Vec<Technique> {
    if filter == NormalFilterArg::Mip {
        return techniques;
    }
    let unfiltered: Vec<String> = techniques
        .iter()
        .filter(|t| t.ndf_variant().is_none())
        .map(|t| t.name())
        .collect();
    if !unfiltered.is_empty() {
        note!(
            "note: --normal-filter ndf applies to unc* and preconv; {} read the MIP chain",
            unfiltered.join(", ")
        );
    }
    let mut seen = std::collections::HashSet::new();
    techniques
        .into_iter()
        .map(|t| t.ndf_variant().unwrap_or(t))
        .filter(|t| seen.insert(*t))
        .collect()
}

/// The specular material term of `render` and `bench` (`shvis::render::specular`).
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Specular term")]
pub(super) struct SpecularArgs {
    /// Add a specular term (Blinn-style microfacet density at the half vector of the
    /// environment's sun, or of `--light-dir`) to every technique, its normal map filtered
    /// as `mip` (averaged normals), `ndf` (normal distribution mapping, partial
    /// normalisation: the paper's choice) or `ndfn` (the per-texel normalisation map).
    /// `bench` takes a comma-separated list and measures every row once per filtering.
    #[arg(long, value_delimiter = ',')]
    pub(super) specular: Vec<shvis::render::specular::NormalFilter>,
    /// Base spread σ of a full-resolution texel's normals (the surface's roughness).
    #[arg(long, default_value_t = 0.1, value_parser = finite_f32, requires = "specular")]
    specular_sigma: f32,
    /// Specular factor k_s multiplied into the light's irradiance.
    #[arg(long, default_value_t = 0.04, value_parser = finite_f32, requires = "specular")]
    specular_ks: f32,
    /// Direction toward the specular light (x,y,z) instead of the sun's; its irradiance
    /// stays the sun's. Only with `--specular`.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = finite_f32, requires = "specular")]
    light_dir: Option<Vec<f32>>,
}

impl SpecularArgs {
    /// The one filtering `render` takes, and its term for `env`.
    pub(super) fn term(
        &self,
        env: &shvis::env::EnvMap,
    ) -> Result<Option<shvis::render::specular::SpecularTerm>> {
        let [filter] = self.specular.as_slice() else {
            if self.specular.len() > 1 {
                bail!("--specular: render takes one filtering (mip, ndf or ndfn)");
            }
            return Ok(None);
        };
        let Some(s) = self.settings(env)? else {
            return Ok(None);
        };
        Ok(Some(shvis::render::specular::SpecularTerm {
            filter: *filter,
            light: s.light,
            sigma: s.sigma,
        }))
    }

    /// The bench's specular settings for `env`, or `None` without `--specular`.
    pub(super) fn settings(
        &self,
        env: &shvis::env::EnvMap,
    ) -> Result<Option<shvis::bench::SpecularSettings>> {
        if self.specular.is_empty() {
            return Ok(None);
        }
        if !(shvis::ndf::MIN_SIGMA..=shvis::ndf::MAX_SIGMA).contains(&self.specular_sigma) {
            bail!(
                "--specular-sigma {} is outside {}..={}",
                self.specular_sigma,
                shvis::ndf::MIN_SIGMA,
                shvis::ndf::MAX_SIGMA
            );
        }
        if !(self.specular_ks.is_finite() && (0.0..=1.0).contains(&self.specular_ks)) {
            bail!("--specular-ks {} is outside 0..=1", self.specular_ks);
        }
        let Some((sun, irradiance)) = env.dominant_light() else {
            bail!("--specular: the environment is black, it has no light to reflect");
        };
        let direction = match &self.light_dir {
            None => sun.as_vec3(),
            Some(v) => {
                let d = <[f32; 3]>::try_from(v.as_slice())
                    .map(glam::Vec3::from)
                    .map_err(|_| anyhow::anyhow!("--light-dir needs three numbers x,y,z"))?;
                if !(d.is_finite() && d.length() > 1e-6) {
                    bail!("--light-dir {},{},{} is not a direction", d.x, d.y, d.z);
                }
                d.normalize()
            }
        };
        let radiance = glam::DVec3::from(irradiance).as_vec3() * self.specular_ks;
        if !radiance.is_finite() {
            bail!("--specular: the environment's sun has a non-finite irradiance {radiance}");
        }
        let names: Vec<&str> = self.specular.iter().map(|f| f.name()).collect();
        note!(
            "specular ({}): light toward {:.3},{:.3},{:.3}, k_s·E = {:.4},{:.4},{:.4}, σ = {}",
            names.join(", "),
            direction.x,
            direction.y,
            direction.z,
            radiance.x,
            radiance.y,
            radiance.z,
            self.specular_sigma
        );
        let mut filters = self.specular.clone();
        filters.dedup();
        Ok(Some(shvis::bench::SpecularSettings {
            filters,
            light: shvis::render::specular::SpecularLight {
                direction,
                radiance,
            },
            sigma: self.specular_sigma,
        }))
    }
}
