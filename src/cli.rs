//! The command line (DESIGN §4): clap types and the commands. `anyhow` lives here and in
//! main.rs only; every failure becomes one `error: …` line and a non-zero exit.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};

use shvis::bench::BenchSettings;
use shvis::gpu::{Context, ContextDesc};
use shvis::prepare::{PrepareSettings, bake_scene_ao, prepare, prepare_with, resolve_scene};
use shvis::render::{FrameSettings, SceneGpu};
use shvis::report::image::{frame_format, write_frame};
use shvis::technique::{self, HwPath, Technique};
use shvis::{bake, tools};

/// Largest frame side accepted before asking the device (which may allow less).
const MAX_FRAME_SIDE: u32 = 16384;
/// PNG exposure unless `--exposure` says otherwise.
const DEFAULT_EXPOSURE_EV: f32 = -1.0;
/// Most bounces of inter-reflection accepted (each adds a pass over the lightmap).
const MAX_BOUNCES: u32 = 16;

/// A finite f32 (clap value parser): NaN and ±inf are refused where they are typed, not
/// turned into a black image later.
fn finite_f32(text: &str) -> Result<f32, String> {
    let v: f32 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} is not a finite number"))
    }
}

/// A finite f64 (clap value parser), as [`finite_f32`].
fn finite_f64(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{text} is not a finite number"))
    }
}

/// A finite f64 of at least 1 (clap value parser): a screen area in pixels.
fn at_least_one_f64(text: &str) -> Result<f64, String> {
    let v = finite_f64(text)?;
    if v >= 1.0 {
        Ok(v)
    } else {
        Err(format!("{text} is below 1"))
    }
}

#[derive(Parser, Debug)]
#[command(
    name = "shvis",
    version,
    about = "Normal mapping with low-frequency precomputed visibility (Iwanicki & Sloan): bake, render, measure"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Bake SH visibility and ambient occlusion and write them as EXR layers for inspection.
    Bake(BakeArgs),
    /// Render one technique on one hardware path to a PNG or EXR.
    Render(RenderArgs),
    /// Ground truth: G-buffer on the GPU, ray-cast visibility and importance-sampled
    /// environment integration on the CPU; prints its noise level.
    Reference(ReferenceArgs),
    /// Time every technique × path and write table.md, table.json and images.
    Bench(BenchArgs),
    /// Microbenchmarks of the current device (lookups by kind, float ops,
    /// varyings, uniform reads, depth test) and the cost model fitted to them → probe.md,
    /// probe.json (`shvis bench` runs it first).
    Probe(ProbeArgs),
    /// A window: the scene with any technique × path switched by keys, an orbit
    /// camera, the sun turned or animated with the dynamic-lighting machinery, an overlay
    /// with GPU ms and frame rate. Needs a display (X11; `xvfb-run -a` without one).
    View(ViewArgs),
    /// Dynamic lighting (§3.3): turn the environment about +Y over a run of frames, rebuild
    /// each technique's lighting data every K frames, and report rebuild and GPU times and
    /// the errors at sampled frames (static and lag).
    Relight(RelightArgs),
    /// SH utilities for checking the math from outside (17 significant digits).
    #[command(subcommand)]
    Sh(ShCommand),
    /// Reproduce the paper's side studies.
    #[command(subcommand)]
    Study(StudyCommand),
    /// Self-shadowed bump map from a height map (Green, Valve): writes the SSBump
    /// (D · directional occlusion) as 16-bit PNG and EXR, the plain D encoding and scalar AO.
    Ssbump(SsbumpArgs),
    /// Normal map of a high-polygon mesh for a low one, on the GPU (Gumbau et al.):
    /// tangent- and object-space 16-bit PNG + EXR, optionally the low mesh as glTF.
    Normalmap(NormalmapArgs),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum BakerArg {
    /// The paper's method (one render of the high mesh per low triangle).
    Gpu,
    /// Ray casting along the low mesh's interpolated normal (the check).
    Cpu,
    /// Both: --out from the GPU, `*_cpu` beside it, and their angular difference.
    Both,
}

#[derive(Args, Debug)]
struct NormalmapArgs {
    /// High mesh: a glTF file, or `sphere:LEVEL` (a unit icosphere of 20·4^LEVEL
    /// triangles with exact normals).
    #[arg(long)]
    high: String,
    /// Low mesh with unique material UVs in [0, 1]: a glTF file or `sphere:LEVEL`
    /// (generated UVs). Leave out with --simplify.
    #[arg(
        long,
        required_unless_present = "simplify",
        conflicts_with = "simplify"
    )]
    low: Option<String>,
    /// Make the low mesh by simplifying the high one to this fraction of its triangles
    /// (meshoptimizer), with UVs from the chart generator.
    #[arg(long, value_parser = finite_f32)]
    simplify: Option<f32>,
    /// Map texels per side.
    #[arg(long, default_value_t = 1024)]
    res: u32,
    /// Border-expansion passes (texels filled around each chart).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=1024))]
    expand: u32,
    /// Search distance from the low surface, metres (default: 5 % of the low mesh's
    /// bounding-box diagonal).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f32)]
    distance: Option<f32>,
    /// Turn vertex mirroring off (the paper's Fig. 4 failure, for comparison).
    #[arg(long)]
    no_mirror: bool,
    /// Draw the whole high mesh per low triangle instead of its prism candidates.
    #[arg(long)]
    no_cull: bool,
    /// One draw call per low triangle (with a scissor) instead of one multi-draw indirect.
    #[arg(long)]
    direct_draws: bool,
    #[arg(long, value_enum, default_value = "gpu")]
    baker: BakerArg,
    /// CPU rays along each low triangle's face normal (the GPU's projection direction)
    /// instead of the interpolated normal.
    #[arg(long)]
    cpu_face_rays: bool,
    /// Output .png or .exr: the tangent-space map; the other format and `*_object` (object
    /// space) are written beside it.
    #[arg(long)]
    out: PathBuf,
    /// Also write the low mesh as this .gltf (+ .bin), its normal texture the PNG.
    #[arg(long)]
    gltf: Option<PathBuf>,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct SsbumpArgs {
    /// Height map (a PNG or EXR; luminance in [0, 1]), or `house`: the built-in bricks'
    /// height field in texels, the one their normal map is derived from.
    #[arg(long)]
    height: PathBuf,
    /// Height of a white texel, in texels (with `house`: a factor on its heights).
    #[arg(long, value_parser = finite_f64)]
    scale: f64,
    /// Rays per texel.
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..=65536))]
    rays: u32,
    /// Bilateral pre-filter: spatial σ in texels (0: off); the range σ is 5 % of the height
    /// range.
    #[arg(long, default_value_t = 0.0, value_parser = finite_f64)]
    bilateral: f64,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Output .png: also writes .exr beside it, and `*_d.png` (plain D), `*_ao.png` (AO).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Subcommand, Debug)]
enum StudyCommand {
    /// Appendix A / Figure 8: MSE of SH basis functions stored in four sphere
    /// parameterizations against total samples (CPU emulation and real texture hardware).
    Params(StudyParamsArgs),
    /// Visibility reconstruction error against storage for global PCA, VQ and
    /// static / iterative CPCA fitted to the same bake.
    Compression(StudyCompressionArgs),
    /// The screen-space discontinuity at cluster boundaries of a clustered
    /// technique (vqK, cpcaK_M) with the 4-tap seam blending and without it.
    Seams(StudySeamsArgs),
    /// rnm, rnmao, ssbump, shlmap and unc6 against the displaced-geometry
    /// reference and the flat normal-mapped one, per environment; the Fig. 1 composite.
    Rnm(StudyRnmArgs),
    /// GPU normal-map generation timed against triangle counts and resolution
    /// (the paper's Tables 1 and 2) beside the CPU baker; GPU vs CPU maps of a real model
    /// simplified; the map rendered through unc6 against the high mesh's reference.
    Normalmap(StudyNormalmapArgs),
    /// The specular term of a directional light on the receding bumpy plane and
    /// the wavy sphere under naive MIP filtering and normal distribution mapping (partial /
    /// per-texel normalisation), against its footprint reference, with a composite per
    /// scene; the diffuse techniques and their NDF variants.
    Ndf(StudyNdfArgs),
    /// Energy captured by the first M = 1…9 singular values of normal mapping for
    /// PRT's normal basis (PRT course), uniform and cosine-weighted, beside the course's.
    NmprtSvd(StudyNmprtSvdArgs),
}

#[derive(Args, Debug)]
struct StudyNmprtSvdArgs {
    /// Disk grid of normals per side (the U textures' resolution).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=1024))]
    side: u32,
    /// Hemisphere quadrature cells per side (in cos θ and φ).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(4..=4096))]
    quadrature: u32,
    /// Output directory (nmprt_svd.md).
    #[arg(long, default_value = "study-out")]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct StudyNdfArgs {
    /// Scenes of the specular part: `bumpy` (the receding plane) and `wavy` (the sphere).
    #[arg(long, value_delimiter = ',', default_value = "bumpy,wavy")]
    scenes: Vec<shvis::study::ndf::SpecularScene>,
    /// Base spread σ of a full-resolution texel's normals (the surface's own roughness).
    #[arg(long, default_value_t = 0.1, value_parser = finite_f32)]
    sigma: f32,
    /// Direction toward the light on the plane (x,y,z; normalized); the sphere's is fixed
    /// (`scene::wavy::light_dir`).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0,0.3,-1",
        allow_hyphen_values = true,
        value_parser = finite_f32
    )]
    light_dir: Vec<f32>,
    #[arg(long, default_value_t = 480, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 270, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Reference sub-pixel samples (⌈√spp⌉² strata, at most 1024).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1024))]
    spp: u32,
    #[arg(long, value_delimiter = ',', default_value = "dx9,dx10")]
    paths: Vec<HwPath>,
    /// Timed frames per row.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    frames: u32,
    /// Scenes of the diffuse part (unc6 / preconv and their NDF variants against the
    /// footprint reference); empty to skip it.
    #[arg(long, value_delimiter = ',', default_value = "bumpy,house")]
    diffuse_scenes: Vec<String>,
    /// Environments of the diffuse part, comma-separated (`sky`, `sky:DEG` or .exr/.hdr
    /// maps): each scene is measured under each.
    #[arg(long, value_delimiter = ',', default_value = "sky")]
    diffuse_envs: Vec<String>,
    /// Reference samples per pixel of the diffuse part.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    diffuse_spp: u32,
    /// Lightmap resolution of the diffuse part's bakes.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=4096))]
    vis_res: u32,
    /// Output directory: ndf.md, ndf.json, fig1_ndf_{scene}.png.
    #[arg(long, default_value = "study-out/ndf")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct StudyNormalmapArgs {
    /// Runs per timing (medians are reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Map side of the triangle-count and strategy tables.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(16..=8192))]
    res: u32,
    /// The real model (skipped with a note when the file is missing).
    #[arg(
        long,
        default_value = "../shared/assets/models/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf"
    )]
    model: PathBuf,
    /// Fractions of the model's triangles to keep, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.02", value_parser = finite_f32)]
    ratios: Vec<f32>,
    /// Map side for the model.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=8192))]
    model_res: u32,
    #[arg(long, default_value = "sky")]
    env: String,
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=8192))]
    vis_res: u32,
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    rays: u32,
    #[arg(long, value_delimiter = ',', default_value = "dx9,dx10")]
    paths: Vec<HwPath>,
    #[arg(long, default_value_t = 480, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 360, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Samples per pixel of the reference.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Output directory: normalmap.md, normalmap.json, the model's maps, glTFs and renders.
    #[arg(long, default_value = "study-out/normalmap")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct StudyRnmArgs {
    /// A scene with a height-mapped material small enough to displace.
    #[arg(long, default_value = "patio")]
    scene: String,
    /// Environments, comma-separated (`sky:15`: the grazing low sun; the overcast probe).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "sky:15,../shared/assets/env/potsdamer_platz_1k.exr"
    )]
    envs: Vec<String>,
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=8192))]
    vis_res: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=65536))]
    rays: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Inter-reflection of the lightmap bakes and the references.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    #[arg(long, value_delimiter = ',', default_value = "dx9,dx10")]
    paths: Vec<HwPath>,
    #[arg(long, default_value_t = 480, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Samples per pixel of each reference.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Output directory: rnm.md, rnm.json, fig1_<env>.png.
    #[arg(long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct StudySeamsArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Environment (as for `render`).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Clustered technique(s), comma-separated; each is measured with both seam modes.
    #[arg(long, value_delimiter = ',', default_value = "cpca8_11,vq256")]
    techniques: Vec<Technique>,
    /// Hardware paths, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "dx9,dx10")]
    paths: Vec<HwPath>,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Output directory: seams.md, seams.json.
    #[arg(long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct StudyCompressionArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Environment of the on-screen comparison (as for `render`).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Techniques rendered against unc6 (comma-separated).
    #[arg(long, value_delimiter = ',', default_values_t = shvis::study::compression::SCREEN_TECHNIQUES.iter().map(|t| t.parse::<Technique>().expect("valid")).collect::<Vec<_>>())]
    techniques: Vec<Technique>,
    /// Hardware paths of the on-screen comparison.
    #[arg(long, value_delimiter = ',', default_value = "dx9,dx10")]
    paths: Vec<HwPath>,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Only the visibility error (no GPU).
    #[arg(long)]
    no_gpu: bool,
    /// Output directory: compression.md, compression.json, screen.md, screen.json.
    #[arg(long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
struct StudyParamsArgs {
    /// Output directory: params.csv, params.json, params.md, params_mse.svg/png, gpu.csv.
    #[arg(long, default_value = "study-out")]
    out: PathBuf,
    /// Random directions for the CPU reconstruction.
    #[arg(long, default_value_t = shvis::study::params::DEFAULT_DIRECTIONS, value_parser = clap::value_parser!(usize))]
    directions: usize,
    /// Directions for the GPU reconstruction (a subset of the same set).
    #[arg(long, default_value_t = 65536)]
    gpu_directions: usize,
    /// Skip the GPU reconstruction.
    #[arg(long)]
    no_gpu: bool,
    #[arg(long, default_value_t = shvis::study::params::DEFAULT_SEED)]
    seed: u64,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Subcommand, Debug)]
enum ShCommand {
    /// Reads directions "x y z" per line on stdin, prints the order² basis values per line.
    Eval {
        #[arg(long)]
        order: u32,
    },
    /// Prints the environment's RGB SH coefficients, one line "r g b" per coefficient.
    Project {
        #[arg(long, default_value = "sky")]
        env: String,
        #[arg(long)]
        order: u32,
    },
    /// Prints the irradiance E(n) = ∫ L max(0, n·ω) dω as "r g b": from SH of the given
    /// order (default 3), or by direct quadrature over the texels with --exact.
    Irradiance {
        #[arg(long, default_value = "sky")]
        env: String,
        /// The normal "x,y,z" (normalized; zero or NaN is an error).
        #[arg(long, allow_hyphen_values = true)]
        normal: String,
        #[arg(long, conflicts_with = "exact")]
        order: Option<u32>,
        #[arg(long)]
        exact: bool,
    },
}

#[derive(Args, Debug, Clone)]
struct SceneArgs {
    /// `house` (built-in), `patio` (built-in brick corner) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    scene: String,
    /// Lightmap texels per side.
    #[arg(long, default_value_t = 512)]
    vis_res: u32,
    /// Rays per lightmap texel.
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(shvis::bake::MIN_RAYS as i64..=shvis::bake::MAX_RAYS as i64))]
    rays: u32,
    /// Seed of the bake's sample patterns.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// SH order of the visibility bake (bands l < order); at most 28, as the L×H product
    /// needs lighting of order + 2 ≤ 30.
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u32).range(1..=shvis::prepare::MAX_VISIBILITY_ORDER as i64))]
    order: u32,
    /// L×H table texels per hemisphere (dx9) or cube face (dx10) side.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(shvis::prepare::TABLE_RES_MIN as i64..=shvis::prepare::TABLE_RES_MAX as i64))]
    table_res: u32,
    /// SH order of the clamped cosine in the L×H product (the paper uses 3).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=shvis::sh::MAX_ORDER as i64))]
    h_order: u32,
    /// Lighting order O of the transfer matrices of the nmprt* techniques (9 × O² per
    /// texel and colour): at most the prepared lighting's order 8.
    #[arg(long, default_value_t = shvis::bake::transfer::DEFAULT_LIGHTING_ORDER.get(), value_parser = clap::value_parser!(u32).range(1..=shvis::prepare::LIGHTING_ORDER as i64))]
    transfer_order: u32,
    /// Height map of the scene's material (PNG/EXR luminance), tiled by its UVs like the
    /// normal map: what `ssbump` and `rnmao` shadow with (replaces the built-in bricks').
    #[arg(long)]
    height_map: Option<PathBuf>,
    /// Height of a white `--height-map` texel, in texels of the map.
    #[arg(long, default_value_t = 1.0, requires = "height_map", value_parser = finite_f64)]
    height_scale: f64,
}

/// The specular material term of `render` and `bench` (`shvis::ndf::render`).
#[derive(Args, Debug, Clone)]
struct SpecularArgs {
    /// Add a specular term (Blinn-style microfacet density at the half vector of the
    /// environment's sun, or of `--light-dir`) to every technique, its normal map filtered
    /// as `mip` (averaged normals), `ndf` (normal distribution mapping, partial
    /// normalisation: the paper's choice) or `ndfn` (the per-texel normalisation map).
    /// `bench` takes a comma-separated list and measures every row once per filtering.
    #[arg(long, value_delimiter = ',')]
    specular: Vec<shvis::render::specular::NormalFilter>,
    /// Base spread σ of a full-resolution texel's normals (the surface's roughness).
    #[arg(long, default_value_t = 0.1, value_parser = finite_f32)]
    specular_sigma: f32,
    /// Specular factor k_s multiplied into the light's irradiance.
    #[arg(long, default_value_t = 0.04, value_parser = finite_f32)]
    specular_ks: f32,
    /// Direction toward the specular light (x,y,z) instead of the sun's; its irradiance
    /// stays the sun's.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, value_parser = finite_f32)]
    light_dir: Option<Vec<f32>>,
}

impl SpecularArgs {
    /// The one filtering `render` takes, and its term for `env`.
    fn term(
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
    fn settings(&self, env: &shvis::env::EnvMap) -> Result<Option<shvis::bench::SpecularSettings>> {
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
        eprintln!(
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

#[derive(Args, Debug, Clone)]
struct GpuArgs {
    /// Pick the first Vulkan device whose name contains this.
    #[arg(long)]
    device: Option<String>,
    /// Turn on VK_LAYER_KHRONOS_validation.
    #[arg(long)]
    validate: bool,
}

#[derive(Args, Debug)]
struct BakeArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Bake nothing: check that --out holds a complete bake (its manifest.json lists every
    /// file with the size and hash it has) and print its settings; exit 1 if not.
    #[arg(long)]
    check: bool,
    /// Also run the standalone cosine-sampled AO bake (`bake::ao`) and print its figures;
    /// the AO layer written is the visibility bake's, as the techniques use.
    #[arg(long)]
    separate_ao: bool,
    #[command(flatten)]
    baker: BakerArgs,
    /// `--baker gpu`: also run the CPU bake (and one with the next seed, for the
    /// quadrature noise) and print how far the GPU's coefficients are from it.
    #[arg(long)]
    compare_cpu: bool,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Output directory (ao.exr).
    #[arg(long)]
    out: PathBuf,
}

/// Who bakes the visibility (`bake`, `render`, `bench`).
#[derive(Args, Debug)]
struct BakerArgs {
    /// Who bakes the visibility: `cpu` (ray tracing, cached) or `gpu` (the PRT course's
    /// GPU simulator: a depth map per direction, not cached).
    #[arg(long, value_enum, default_value_t = VisibilityBakerArg::Cpu)]
    baker: VisibilityBakerArg,
    /// `--baker gpu`: depth-map texels per side.
    #[arg(long, default_value_t = shvis::bake::gpu_visibility::GpuVisibilitySettings::default().depth_res, value_parser = clap::value_parser!(u32).range(16..=16384))]
    depth_res: u32,
    /// `--baker gpu`: constant depth bias, depth-map texels.
    #[arg(long, default_value_t = shvis::bake::gpu_visibility::GpuVisibilitySettings::default().bias_texels, value_parser = finite_f32)]
    depth_bias: f32,
    /// `--baker gpu`: depth bias per unit tan of the ray's angle to the normal, texels.
    #[arg(long, default_value_t = shvis::bake::gpu_visibility::GpuVisibilitySettings::default().slope_bias_texels, value_parser = finite_f32)]
    slope_bias: f32,
}

impl BakerArgs {
    fn gpu_settings(&self) -> shvis::bake::gpu_visibility::GpuVisibilitySettings {
        shvis::bake::gpu_visibility::GpuVisibilitySettings {
            depth_res: self.depth_res,
            bias_texels: self.depth_bias,
            slope_bias_texels: self.slope_bias,
        }
    }

    /// The baker `prepare_with` runs, on `ctx` for `gpu`.
    fn visibility_baker(&self, ctx: &Arc<Context>) -> shvis::prepare::VisibilityBaker {
        match self.baker {
            VisibilityBakerArg::Cpu => shvis::prepare::VisibilityBaker::Cpu,
            VisibilityBakerArg::Gpu => shvis::prepare::VisibilityBaker::Gpu {
                ctx: ctx.clone(),
                settings: self.gpu_settings(),
            },
        }
    }
}

/// `--baker`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum VisibilityBakerArg {
    /// Ray tracing (cached).
    Cpu,
    /// The PRT course's GPU simulator (not cached).
    Gpu,
}

#[derive(Args, Debug)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    baker: BakerArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    /// `sky` (built-in), an .exr/.hdr equirectangular map (2:1) or angular probe (1:1,
    /// detected by content; `angular:PATH` forces it).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Technique name (see `shvis bench`): unc3…unc6, pca4…pca24, pca4w…pca24w, shlmap,
    /// preconv, sh2.
    #[arg(long)]
    technique: Technique,
    /// Hardware path: dx9 or dx10.
    #[arg(long, default_value = "dx10")]
    path: HwPath,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV applied before sRGB encoding (PNG only). The default −1 keeps the
    /// built-in sky's sunlit ground out of clipping.
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Bounces of inter-reflection baked for shlmap and the nmprt* transfer matrices.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// How unc* and preconv read the normal map: `mip` (its MIP chain of averaged normals)
    /// or `ndf` (filtered as a distribution, Olano & North: the techniques' `…ndf`
    /// variants; the other techniques have none and stay as they are).
    #[arg(long, value_enum, default_value_t = NormalFilterArg::Mip)]
    normal_filter: NormalFilterArg,
    #[command(flatten)]
    specular: SpecularArgs,
    /// Ignore the normal map (shade with interpolated normals).
    #[arg(long)]
    flat_normals: bool,
    /// Output image: .png (sRGB) or .exr (linear).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct ReferenceArgs {
    /// `house` (built-in), `patio` (built-in brick corner) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    scene: String,
    #[arg(long, default_value = "sky")]
    env: String,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Environment samples per pixel.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Lightmap resolution the scene is built for (only the built-in house's UVs use it).
    #[arg(long, default_value_t = 512)]
    vis_res: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Reflections of light to include (0: direct light only, the model of every technique
    /// but shlmap; shlmap bakes 2 by default).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// One G-buffer sample at each pixel centre with MIP-filtered textures (the techniques'
    /// own sampling) instead of integrating the pixel footprint at full texture resolution.
    #[arg(long)]
    point: bool,
    /// Render the scene's height-mapped surfaces as real displaced micro-geometry (a vertex
    /// per height texel; flat shading normals): the ground truth of self-shadowing
    /// (small scenes such as `patio`).
    #[arg(long)]
    displaced: bool,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Output image: .exr (linear) or .png (sRGB).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct ProbeArgs {
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Timed frames per microbenchmark (the median is used).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    frames: u32,
    /// Untimed frames before them.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: u32,
    /// Screen area of the probe's triangles, pixels (default: the built-in house's
    /// pixel-weighted triangle area at this size, as `shvis bench` sizes them for its scene).
    #[arg(long, value_parser = at_least_one_f64)]
    triangle_pixels: Option<f64>,
    /// Output directory (probe.md, probe.json).
    #[arg(long, default_value = "probe-out")]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    baker: BakerArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value = "sky")]
    env: String,
    /// `all` or a comma-separated list of technique names.
    #[arg(long, default_value = "all")]
    techniques: String,
    /// Comma-separated hardware paths.
    #[arg(long, default_value = "dx9,dx10")]
    paths: String,
    /// How unc* and preconv read the normal map: `mip` (its MIP chain of averaged normals)
    /// or `ndf` (filtered as a distribution, Olano & North: the techniques' `…ndf`
    /// variants; the other techniques have none and stay as they are).
    #[arg(long, value_enum, default_value_t = NormalFilterArg::Mip)]
    normal_filter: NormalFilterArg,
    #[command(flatten)]
    specular: SpecularArgs,
    /// Timed frames per technique × path (after the warm-up).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Untimed warm-up frames per technique × path.
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: u32,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV of the PNG images.
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Samples per pixel of the reference the errors are measured against (0: no errors);
    /// at most `reference --spp`'s limit.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
    ref_spp: u32,
    /// Measure against the point-sampled reference (the techniques' own pixel sampling)
    /// instead of the footprint reference.
    #[arg(long)]
    point_reference: bool,
    /// Bounces of inter-reflection in shlmap's and the nmprt* transfer bakes and in the
    /// reference they are measured against (the other techniques model direct light and
    /// meet the direct reference).
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Leave out the device probe and the rows' model columns.
    #[arg(long)]
    no_probe: bool,
    /// Measure under the environment turned DEG degrees about +Y after the bake:
    /// references under the turned map, techniques with dynamic lighting relit to it
    /// through their lighting update, baked ones (shlmap, rnm*) as baked. No error ladder.
    #[arg(long, value_name = "DEG", value_parser = finite_degrees)]
    relight_rotate: Option<f64>,
    /// Output directory.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
}

/// A rotation in degrees: finite, within ±360.
fn finite_degrees(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|e| format!("{e}"))?;
    if v.is_finite() && v.abs() <= 360.0 {
        Ok(v)
    } else {
        Err(format!("{s} is not a finite angle within ±360 degrees"))
    }
}

#[derive(Args, Debug)]
struct ViewArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value = "sky")]
    env: String,
    /// Comma-separated techniques Tab cycles through (`all`: the cost table's).
    #[arg(long, default_value = "preconv,unc6,pca8,sh2,shlmap")]
    techniques: String,
    /// Hardware path shown first (P switches).
    #[arg(long, default_value = "dx10")]
    path: HwPath,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Quit after this many frames (else when the window closes).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    frames: Option<u32>,
    /// Switch to the next technique at this frame.
    #[arg(long)]
    switch_at: Option<u32>,
    /// Write the last frame, read back from the swapchain, as PNG (with --frames).
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Rebuild the lighting data at most every this many frames while the sun moves.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    every: u32,
    /// Start with the sun turning this many degrees per frame.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    animate: Option<f64>,
    /// No overlay.
    #[arg(long)]
    no_overlay: bool,
}

#[derive(Args, Debug)]
struct RelightArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[arg(long, default_value = "sky")]
    env: String,
    /// `all` or a comma-separated list of technique names (shlmap's lighting is baked in:
    /// it is reported, not run).
    #[arg(long, default_value = "unc3,unc4,unc6,pca4,pca16,pca16w,sh2,preconv")]
    techniques: String,
    #[arg(long, default_value = "dx9,dx10")]
    paths: String,
    /// Frames of the run.
    #[arg(long, default_value_t = 48, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Rebuild the lighting-dependent data every this many frames.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    every: u32,
    /// Build and upload between two frames, waiting for the copy (the stalling baseline),
    /// instead of building on a worker thread and swapping the double-buffered tables in
    /// when their copy has landed.
    #[arg(long)]
    blocking_upload: bool,
    /// Full turns of the environment over the run.
    #[arg(long, default_value_t = 1.0, value_parser = finite_f64)]
    turns: f64,
    /// Cross-fade from --env to this environment over the run (time of day).
    #[arg(long)]
    fade_to: Option<String>,
    /// Frames at which errors are measured.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    samples: u32,
    #[arg(long, default_value_t = 320, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Samples per pixel of each sampled frame's reference.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=65_536))]
    ref_spp: u32,
    #[arg(long, default_value = "relight-out")]
    out: PathBuf,
}

/// The frames' memory on the host, checked before any work: `bytes_per_pixel` covers the
/// readbacks (RGBA32F) and the images a command keeps (render 48, reference's G-buffers and
/// sums 160, the bench's reference, row and ladder images 320).
fn check_frame_memory(width: u32, height: u32, bytes_per_pixel: u64) -> Result<()> {
    Ok(shvis::limits::check_memory(
        format_args!("--width {width} × --height {height}: the frames"),
        shvis::limits::image_bytes(u64::from(width), u64::from(height), bytes_per_pixel),
        "lower --width or --height",
    )?)
}

fn run_view(a: ViewArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 48)?;
    if let Some(shot) = &a.screenshot {
        frame_format(shot)?;
        shvis::files::check_writable_file(shot, "--screenshot")?;
    }
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
        bail!(
            "no display to open a window on (DISPLAY is not set): run under `xvfb-run -a shvis view …`, or use `shvis render` / `shvis bench`"
        );
    }
    let techniques: Vec<Technique> = parse_list(&a.techniques, Technique::ALL)?;
    let settings = prepare_settings(
        &a.scene,
        &a.env,
        &techniques,
        shvis::bake::shlmap::DEFAULT_BOUNCES,
    )?;
    let mut prepared = prepare(&settings)?;
    prepared.prepare_techniques(&techniques)?;
    let report = shvis::view::run(
        &prepared,
        &shvis::view::ViewSettings {
            techniques,
            path: a.path,
            width: a.width,
            height: a.height,
            exposure: a.exposure,
            frames: a.frames,
            switch_at: a.switch_at,
            screenshot: a.screenshot.clone(),
            every: a.every,
            animate: a.animate,
            overlay: !a.no_overlay,
            validate: a.gpu.validate,
            device: a.gpu.device.clone(),
        },
    )?;
    println!(
        "view on {} ({} present): median frame {} ms, longest {} ms",
        report.device,
        report.present_mode,
        report
            .median_frame_ms
            .map_or("—".into(), |m| format!("{m:.2}")),
        report
            .longest_frame_ms
            .map_or("—".into(), |m| format!("{m:.2}")),
    );
    for (label, frames, wall, gpu) in &report.shown {
        println!(
            "  {label}: {frames} frames, {:.2} ms a frame ({:.1} frames/s), GPU {}",
            wall,
            1e3 / wall,
            gpu.map_or("—".into(), |g| format!("{g:.2} ms"))
        );
    }
    println!(
        "  lighting rebuilds swapped in: {} (CPU build median {}), longest frame that swapped one in {} ms",
        report.rebuilds,
        report
            .rebuild_cpu_ms
            .map_or("—".into(), |m| format!("{m:.1} ms")),
        report
            .longest_swap_frame_ms
            .map_or("—".into(), |m| format!("{m:.2}"))
    );
    let (errors, warnings) = report.validation;
    if a.gpu.validate && (errors > 0 || warnings > 0) {
        bail!("validation reported {errors} errors and {warnings} warnings (see the log above)");
    }
    Ok(())
}

fn run_relight(a: RelightArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 320)?;
    if !a.turns.is_finite() {
        bail!("--turns {} is not a finite number", a.turns);
    }
    let settings = shvis::relight::RelightSettings {
        techniques: parse_list(&a.techniques, Technique::ALL)?,
        paths: parse_list(&a.paths, HwPath::ALL)?,
        frames: a.frames,
        every: a.every,
        upload: if a.blocking_upload {
            shvis::relight::UploadMode::Blocking
        } else {
            shvis::relight::UploadMode::Overlapped
        },
        turns: a.turns,
        fade_to: a.fade_to.as_deref().map(shvis::env::resolve).transpose()?,
        samples: a.samples,
        width: a.width,
        height: a.height,
        ref_spp: a.ref_spp,
        seed: a.scene.seed,
        exposure: a.exposure,
        out: a.out.clone(),
    };
    create_dir(&a.out)?;
    let started = Instant::now();
    let mut prepared = prepare(&prepare_settings(
        &a.scene,
        &a.env,
        &settings.techniques,
        shvis::bake::shlmap::DEFAULT_BOUNCES,
    )?)?;
    prepared.prepare_techniques(&settings.techniques)?;
    let ctx = open_gpu(&a.gpu)?;
    let table = shvis::relight::run(&ctx, &prepared, &settings)?;
    print_table(
        &table.to_markdown(),
        &a.out,
        "relight.md, relight.json",
        started,
    );
    check_validation(&ctx, a.gpu.validate)
}

/// Prints a run's markdown table and where its files went.
fn print_table(markdown: &str, out: &std::path::Path, tables: &str, started: Instant) {
    println!("{markdown}");
    println!(
        "wrote {}/{tables} and images in {:.1} s",
        out.display(),
        started.elapsed().as_secs_f64()
    );
}

/// Parses the arguments and runs the command.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Bake(a) => run_bake(a).context("bake"),
        Command::Render(a) => run_render(a).context("render"),
        Command::Reference(a) => run_reference(a).context("reference"),
        Command::Bench(a) => run_bench(a).context("bench"),
        Command::Probe(a) => run_probe(a).context("probe"),
        Command::Relight(a) => run_relight(a).context("relight"),
        Command::View(a) => run_view(a).context("view"),
        Command::Sh(c) => run_sh(c).context("sh"),
        Command::Study(StudyCommand::Params(a)) => run_study_params(a).context("study params"),
        Command::Study(StudyCommand::Compression(a)) => {
            run_study_compression(a).context("study compression")
        }
        Command::Study(StudyCommand::Seams(a)) => run_study_seams(a).context("study seams"),
        Command::Study(StudyCommand::Rnm(a)) => run_study_rnm(a).context("study rnm"),
        Command::Study(StudyCommand::Ndf(a)) => run_study_ndf(a).context("study ndf"),
        Command::Study(StudyCommand::NmprtSvd(a)) => {
            run_study_nmprt_svd(a).context("study nmprt-svd")
        }
        Command::Study(StudyCommand::Normalmap(a)) => {
            run_study_normalmap(a).context("study normalmap")
        }
        Command::Ssbump(a) => run_ssbump(a).context("ssbump"),
        Command::Normalmap(a) => run_normalmap(a).context("normalmap"),
    }
}

fn run_study_compression(a: StudyCompressionArgs) -> Result<()> {
    use shvis::study::compression;
    create_dir(&a.out)?;
    let started = Instant::now();
    let mut prepared = prepare(&prepare_settings(&a.scene, &a.env, &[], 0)?)?;
    let rows = compression::run(
        &prepared.visibility,
        &compression::default_configs(),
        a.scene.table_res,
        a.scene.seed,
        Some(&prepared.cache_dir),
    )?;
    let markdown = compression::to_markdown(&rows, prepared.visibility.res, a.scene.table_res);
    shvis::files::write(a.out.join("compression.md"), &markdown).context("compression.md")?;
    shvis::files::write(
        a.out.join("compression.json"),
        serde_json::to_string_pretty(&rows)? + "\n",
    )
    .context("compression.json")?;
    if a.no_gpu {
        print_table(
            &markdown,
            &a.out,
            "compression.md, compression.json",
            started,
        );
        return Ok(());
    }
    let ctx = open_gpu(&a.gpu)?;
    prepared.prepare_techniques(&a.techniques)?;
    let screen =
        compression::screen_errors(&ctx, &prepared, &a.techniques, &a.paths, a.width, a.height)?;
    let screen_md = compression::screen_markdown(&screen, &a.env, a.width, a.height);
    shvis::files::write(a.out.join("screen.md"), &screen_md).context("screen.md")?;
    shvis::files::write(
        a.out.join("screen.json"),
        serde_json::to_string_pretty(&screen)? + "\n",
    )
    .context("screen.json")?;
    print_table(
        &format!("{markdown}\n{screen_md}"),
        &a.out,
        "compression.md, compression.json, screen.md, screen.json",
        started,
    );
    check_validation(&ctx, a.gpu.validate)
}

fn run_normalmap(a: NormalmapArgs) -> Result<()> {
    use shvis::normalmap::{self, DrawMode, MeshRole, NormalMapSettings, output};
    let ext = a.out.extension().and_then(|e| e.to_str());
    if !matches!(ext, Some("png" | "exr")) {
        bail!("{}: the output must be a .png or .exr", a.out.display());
    }
    if let Some(g) = &a.gltf
        && g.extension().and_then(|e| e.to_str()) != Some("gltf")
    {
        bail!("{}: --gltf must name a .gltf file", g.display());
    }
    if !(normalmap::MIN_RES..=normalmap::MAX_RES).contains(&a.res) {
        bail!(
            "--res {} is outside {}..={}",
            a.res,
            normalmap::MIN_RES,
            normalmap::MAX_RES
        );
    }
    let started = Instant::now();
    let high = normalmap::load_mesh(&a.high, MeshRole::High)?;
    let low = match (&a.low, a.simplify) {
        (Some(low), _) => normalmap::load_mesh(low, MeshRole::Low { res: a.res })?,
        (None, Some(ratio)) => {
            let (low, report) = normalmap::simplify::simplify(&high, ratio, a.res)?;
            println!(
                "simplified {} → {} triangles (meshoptimizer error {:.2e} of the extent), {} charts",
                report.from_triangles, report.to_triangles, report.relative_error, report.charts
            );
            low
        }
        (None, None) => bail!("give --low or --simplify"),
    };
    let settings = NormalMapSettings {
        expand: a.expand,
        max_distance: a
            .distance
            .unwrap_or_else(|| normalmap::default_max_distance(&low)),
        mirror: !a.no_mirror,
        cull: !a.no_cull,
        draws: if a.direct_draws {
            DrawMode::Direct
        } else {
            DrawMode::Indirect
        },
        ..NormalMapSettings::new(&low, a.res)
    };
    println!(
        "high {} triangles, low {} triangles, {}² texels, search distance {:.4} m",
        high.triangle_count(),
        low.triangle_count(),
        a.res,
        settings.max_distance
    );
    let frames = normalmap::low_texels(&low, a.res);
    let low_texels = frames.covered_count();
    let stem = a.out.with_extension("");
    let write_all = |image: &normalmap::NormalImage, suffix: &str| -> Result<()> {
        let tangent = normalmap::tangent_space(image, &frames);
        for ext in ["png", "exr"] {
            let path = |s: &str| PathBuf::from(format!("{}{suffix}{s}.{ext}", stem.display()));
            output::write_map(&path(""), a.res, &tangent, [0.0, 0.0, 1.0])?;
            output::write_map(&path("_object"), a.res, &image.texels, [0.0; 3])?;
        }
        Ok(())
    };
    let gpu_image = if a.baker == BakerArg::Cpu {
        None
    } else {
        let ctx = open_gpu(&a.gpu)?;
        let (image, t) = normalmap::gpu::bake(&ctx, &high, &low, &settings)?;
        let gpu_ms = t.gpu_ms.map_or("no timestamps".to_string(), |ms| {
            format!(
                "GPU mask {:.2} + project {:.2} + expand {:.2} ms",
                ms.mask, ms.project, ms.expand
            )
        });
        println!(
            "gpu ({}): {} renders, {} high triangles drawn, {} of the low mesh's {low_texels} texels; {gpu_ms}; prepare {:.3} s, setup {:.3} s, execute {:.3} s, total {:.3} s",
            ctx.device_name(),
            t.renders,
            t.triangles_drawn,
            image.covered_count(),
            t.prepare_s,
            t.setup_s,
            t.execute_s,
            t.total_s
        );
        write_all(&image, "")?;
        Some(image)
    };
    if a.baker != BakerArg::Gpu {
        let along = if a.cpu_face_rays {
            normalmap::cpu::RayDirection::Face
        } else {
            normalmap::cpu::RayDirection::Interpolated
        };
        let (image, t) = normalmap::cpu::bake(&high, &low, &settings, along)?;
        println!(
            "cpu: {} rays, {} of the low mesh's {low_texels} texels; BVH {:.3} s, trace {:.3} s, total {:.3} s",
            t.rays,
            image.covered_count(),
            t.bvh_s,
            t.trace_s,
            t.total_s
        );
        let suffix = if gpu_image.is_some() { "_cpu" } else { "" };
        write_all(&image, suffix)?;
        if let Some(gpu_image) = &gpu_image {
            let interior = gpu_image.interior();
            match normalmap::compare(gpu_image, &image, &interior) {
                Some(stats) => println!("gpu vs cpu, interior texels: {stats}"),
                None => println!("gpu vs cpu: no interior texel generated by both"),
            }
            // Angle between the two, 10° = white, where both generated a normal.
            let diff: Vec<[f32; 4]> = (0..image.texels.len())
                .map(|i| {
                    let both = gpu_image.texels[i][3] > 0.0 && image.texels[i][3] > 0.0;
                    let angle = normalmap::angle_deg(gpu_image.normal(i), image.normal(i));
                    let v = if both {
                        (angle / 10.0).min(1.0) as f32 * 2.0 - 1.0
                    } else {
                        -1.0
                    };
                    [v, v, v, 1.0]
                })
                .collect();
            let path = PathBuf::from(format!("{}_diff.png", stem.display()));
            output::write_map(&path, a.res, &diff, [0.0; 3])?;
        }
    }
    if let Some(g) = &a.gltf {
        let png = PathBuf::from(format!("{}.png", stem.display()));
        let uri = relative_uri(g, &png);
        output::write_low_gltf(g, &low, Some(&uri))?;
        println!("wrote {} (normal texture {uri})", g.display());
    }
    println!(
        "wrote {}.{{png,exr}} and {}_object.{{png,exr}} in {:.1} s",
        stem.display(),
        stem.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `target` as a URI relative to the directory of `from` (its file name when they share
/// one; else the absolute path).
fn relative_uri(from: &Path, target: &Path) -> String {
    let dir = |p: &Path| {
        p.parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
    };
    let same_dir = dir(from)
        .canonicalize()
        .ok()
        .zip(dir(target).canonicalize().ok());
    match (same_dir, target.file_name()) {
        (Some((a, b)), Some(name)) if a == b => name.to_string_lossy().into_owned(),
        _ => std::path::absolute(target)
            .unwrap_or_else(|_| target.to_path_buf())
            .display()
            .to_string(),
    }
}

fn run_ssbump(a: SsbumpArgs) -> Result<()> {
    use shvis::bake::ssbump::{occlusion, ssbump};
    if !(a.scale.is_finite() && a.scale > 0.0) {
        bail!("--scale {} must be positive and finite", a.scale);
    }
    if !(a.bilateral.is_finite() && a.bilateral >= 0.0 && a.bilateral <= 64.0) {
        bail!("--bilateral {} must be in 0..=64 texels", a.bilateral);
    }
    if a.out.extension().and_then(|e| e.to_str()) != Some("png") {
        bail!("{}: the output must be a .png", a.out.display());
    }
    let started = Instant::now();
    let field = if a.height.as_os_str() == "house" {
        let mut field = shvis::scene::house::brick_height_field();
        field.h.iter_mut().for_each(|h| *h *= a.scale);
        field
    } else {
        shvis::scene::load_height_map(&a.height, a.scale)?
    };
    let (width, height) = (field.width, field.height);
    let range = field.h.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - field.h.iter().copied().fold(f64::INFINITY, f64::min);
    let field = field.bilateral(a.bilateral, 0.05 * range.max(1e-9));
    let occ = occlusion(&field, a.rays as usize, a.seed);
    let (shadowed, plain) = ssbump(&field, &occ);
    let ao: Vec<[f64; 3]> = occ.ao.iter().map(|&v| [v; 3]).collect();
    let stem = a.out.with_extension("");
    let with_suffix =
        |suffix: &str, ext: &str| PathBuf::from(format!("{}{suffix}.{ext}", stem.display()));
    for (texels, suffix) in [(&shadowed, ""), (&plain, "_d"), (&ao, "_ao")] {
        let png = with_suffix(suffix, "png");
        let mut encoded = Vec::new();
        let data: Vec<u16> = texels
            .iter()
            .flat_map(|t| t.map(|v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16))
            .collect();
        image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(
            width as u32,
            height as u32,
            data,
        )
        .expect("3 channels per texel")
        .write_to(
            &mut std::io::Cursor::new(&mut encoded),
            image::ImageFormat::Png,
        )
        .map_err(anyhow::Error::from)
        .and_then(|()| Ok(shvis::files::write(&png, &encoded)?))
        .with_context(|| format!("{}: cannot write", png.display()))?;
        let frame = shvis::render::Frame {
            width: width as u32,
            height: height as u32,
            rgba: texels
                .iter()
                .map(|t| [t[0] as f32, t[1] as f32, t[2] as f32, 1.0])
                .collect(),
            ms: Vec::new(),
        };
        shvis::report::image::write_exr(&with_suffix(suffix, "exr"), &frame)?;
    }
    let mean =
        |i: usize| occ.channels.iter().map(|c| c[i]).sum::<f64>() / occ.channels.len() as f64;
    println!(
        "ssbump {width}×{height}, {} rays per texel: mean occlusion {:.4} {:.4} {:.4}, mean AO {:.4}; wrote {} (+ .exr, _d, _ao) in {:.1} s",
        a.rays,
        mean(0),
        mean(1),
        mean(2),
        occ.ao.iter().sum::<f64>() / occ.ao.len() as f64,
        a.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

fn run_study_nmprt_svd(a: StudyNmprtSvdArgs) -> Result<()> {
    use shvis::study::nmprt_svd::{
        NormalWeighting, energy_captured, hl2_energy, normal_matrix_over, to_markdown,
    };
    create_dir(&a.out)?;
    let (side, quadrature) = (a.side as usize, a.quadrature as usize);
    let mut svd = Vec::new();
    let mut hl2 = [0.0; 4];
    for (k, (clamped, w)) in [
        (true, NormalWeighting::Uniform),
        (true, NormalWeighting::Cosine),
        (false, NormalWeighting::Uniform),
        (false, NormalWeighting::Cosine),
    ]
    .into_iter()
    .enumerate()
    {
        let a = normal_matrix_over(side, quadrature, w, clamped);
        svd.push(energy_captured(&a));
        hl2[k] = hl2_energy(side, &a, w);
    }
    let markdown = to_markdown(side, [&svd[0], &svd[1]], [&svd[2], &svd[3]], hl2);
    println!("{markdown}");
    let path = a.out.join("nmprt_svd.md");
    shvis::files::write(&path, &markdown)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

fn run_study_ndf(a: StudyNdfArgs) -> Result<()> {
    use shvis::study::ndf;
    let [x, y, z] = <[f32; 3]>::try_from(a.light_dir.as_slice())
        .map_err(|_| anyhow::anyhow!("--light-dir needs three numbers x,y,z"))?;
    let light_dir = glam::Vec3::new(x, y, z);
    if !(light_dir.is_finite() && light_dir.length() > 1e-6) {
        bail!("--light-dir {x},{y},{z} is not a direction");
    }
    if !(shvis::ndf::MIN_SIGMA..=shvis::ndf::MAX_SIGMA).contains(&a.sigma) {
        bail!(
            "--sigma {} is outside {}..={}",
            a.sigma,
            shvis::ndf::MIN_SIGMA,
            shvis::ndf::MAX_SIGMA
        );
    }
    create_dir(&a.out)?;
    let started = Instant::now();
    let ctx = open_gpu(&a.gpu)?;
    let mut studies = Vec::new();
    for &scene in &a.scenes {
        let settings = ndf::NdfStudySettings {
            scene,
            sigma: a.sigma,
            light_dir: match scene {
                ndf::SpecularScene::Bumpy => light_dir,
                ndf::SpecularScene::Wavy => shvis::scene::wavy::light_dir(),
            },
            width: a.width,
            height: a.height,
            spp: a.spp,
            paths: a.paths.clone(),
            frames: a.frames,
        };
        let (study, composite) = ndf::run(&ctx, &settings)?;
        println!(
            "{}: {} surface pixels, {} minified ≥ {}×; reference {} strata (a quarter of them: {:.4} from it); relative RMSE / energy against the footprint reference (minified | whole surface):",
            scene.name(),
            study.plane_pixels,
            study.minified_pixels,
            ndf::MIN_MINIFICATION,
            study.strata,
            study.reference_self_error
        );
        for r in &study.rows {
            println!(
                "  spec{:<4} {:<4} {:.4} / {:.3} | {:.4} / {:.3}  {} ms",
                r.filter.name(),
                r.path.name(),
                r.rel_rmse_minified,
                r.energy_minified,
                r.rel_rmse_all,
                r.energy_all,
                r.ms_median.map_or("-".into(), |m| format!("{m:.2}"))
            );
        }
        studies.push((study, composite));
    }
    let diffuse_scenes: Vec<String> = a
        .diffuse_scenes
        .iter()
        .filter(|s| !s.is_empty())
        .cloned()
        .collect();
    let diffuse = if diffuse_scenes.is_empty() {
        None
    } else {
        use shvis::study::ndf_diffuse::arrow;
        let (mut scenes, mut rows) = (Vec::new(), Vec::new());
        for env in &a.diffuse_envs {
            let (s, r) = shvis::study::ndf_diffuse::run(
                &ctx,
                &shvis::study::ndf_diffuse::DiffuseSettings {
                    scenes: diffuse_scenes.clone(),
                    env: env.clone(),
                    width: a.width,
                    height: a.height,
                    ref_spp: a.diffuse_spp,
                    vis_res: a.vis_res,
                    paths: a.paths.clone(),
                    cache_dir: None,
                    strata_side: 16,
                    image_dir: Some(a.out.clone()),
                },
            )?;
            scenes.extend(s);
            rows.extend(r);
        }
        for s in &scenes {
            println!(
                "  {} ({}): {} covered, {} minified, {} magnified pixels; footprint vs point reference {:.4}",
                s.scene,
                s.env,
                s.covered_pixels,
                s.minified_pixels,
                s.magnified_pixels,
                s.footprint_step
            );
        }
        println!(
            "diffuse: relative RMSE against the footprint reference, unfiltered → ndf (minified ≥ 4× | magnified | all; max change where magnified):"
        );
        for r in &rows {
            println!(
                "  {:<6} {:<10} {:<8} {:<4} {} (8² blocks {}) | {} | {}; {:.1e}; own footprint {} (8² blocks {})",
                r.scene,
                r.env,
                r.technique.name(),
                r.path.name(),
                arrow(r.minified),
                arrow(r.reference_blocks),
                arrow(r.magnified),
                arrow(r.all),
                r.magnified_max_change,
                arrow(r.own_footprint_minified),
                arrow(r.own_footprint_blocks)
            );
        }
        Some((scenes, rows))
    };
    for p in ndf::write_report(&studies, diffuse.as_ref(), &a.out)? {
        println!("wrote {}", p.display());
    }
    check_validation(&ctx, a.gpu.validate)?;
    println!("study ndf: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_study_normalmap(a: StudyNormalmapArgs) -> Result<()> {
    use shvis::study::normalmap as study;
    create_dir(&a.out)?;
    let started = Instant::now();
    let ctx = open_gpu(&a.gpu)?;
    let model = a.model.exists().then(|| a.model.clone());
    if model.is_none() {
        println!(
            "note: {} not found: the real-model part is skipped",
            a.model.display()
        );
    }
    let settings = study::NormalMapStudySettings {
        repeats: a.repeats,
        res: a.res,
        model,
        ratios: a.ratios.clone(),
        model_res: a.model_res,
        env: a.env.clone(),
        vis_res: a.vis_res,
        rays: a.rays,
        width: a.width,
        height: a.height,
        spp: a.spp,
        paths: a.paths.clone(),
    };
    println!("timings on {}:", ctx.device_name());
    let timings = study::timings(&ctx, &settings)?;
    let mut models = Vec::new();
    if let Some(model) = &settings.model {
        for &ratio in &settings.ratios {
            let row = study::model_row(&ctx, &settings, model, ratio, &a.out)
                .with_context(|| format!("{} at {ratio}", model.display()))?;
            let fmt = |s: &Option<shvis::normalmap::AngleStats>| {
                s.map_or("-".to_string(), |s| s.to_string())
            };
            println!(
                "{} kept {:.0} %: {} → {} triangles; GPU vs CPU (interpolated rays) {}; (face rays) {}",
                model.display(),
                ratio * 100.0,
                row.high_triangles,
                row.low_triangles,
                fmt(&row.vs_cpu),
                fmt(&row.vs_cpu_face)
            );
            for (path, mapped, flat) in &row.render {
                println!(
                    "  unc6 {path}: relative RMSE vs the high mesh's reference {mapped:.4} with the map, {flat:.4} flat"
                );
            }
            models.push(row);
        }
    }
    let result = study::NormalMapStudy {
        device: ctx.device_name().to_string(),
        timings,
        models,
    };
    for p in study::write_report(&result, &a.out)? {
        println!("wrote {}", p.display());
    }
    check_validation(&ctx, a.gpu.validate)?;
    println!("study normalmap: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_study_rnm(a: StudyRnmArgs) -> Result<()> {
    use shvis::study::rnm;
    create_dir(&a.out)?;
    let started = Instant::now();
    let ctx = open_gpu(&a.gpu)?;
    let settings = rnm::RnmStudySettings {
        scene: a.scene.clone(),
        vis_res: a.vis_res,
        rays: a.rays,
        seed: a.seed,
        bounces: a.bounces,
        width: a.width,
        height: a.height,
        spp: a.spp,
        paths: a.paths.clone(),
        cache_dir: None,
    };
    let mut results = Vec::new();
    for env in &a.envs {
        let result = rnm::run_env(&ctx, env, &settings).with_context(|| format!("--env {env}"))?;
        println!(
            "{env}: displaced reference {} triangles, noise {:.4} (flat {:.4}); relative RMSE vs displaced / vs flat:",
            result.displaced_triangles, result.displaced_noise, result.flat_noise
        );
        for row in &result.rows {
            println!(
                "  {:<7} {:<4} {:<7} {:.4} / {:.4}",
                row.technique.name(),
                row.path.name(),
                row.light_model,
                row.vs_displaced,
                row.vs_flat
            );
        }
        results.push(result);
    }
    for p in rnm::write_report(&results, &settings, ctx.device_name(), &a.out, a.exposure)? {
        println!("wrote {}", p.display());
    }
    check_validation(&ctx, a.gpu.validate)?;
    println!("study rnm: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_study_seams(a: StudySeamsArgs) -> Result<()> {
    use shvis::study::seams;
    if let Some(t) = a.techniques.iter().find(|t| t.cluster_need().is_none()) {
        bail!("{t} is not a clustered technique (vqK, cpcaK_M)");
    }
    create_dir(&a.out)?;
    let started = Instant::now();
    let ctx = open_gpu(&a.gpu)?;
    let mut prepared = prepare(&prepare_settings(&a.scene, &a.env, &[], 0)?)?;
    prepared.prepare_techniques(&a.techniques)?;
    let mut rows = Vec::new();
    for &technique in &a.techniques {
        for &path in &a.paths {
            rows.extend(seams::measure(
                &ctx, &prepared, technique, path, a.width, a.height,
            )?);
        }
    }
    let markdown = seams::to_markdown(&rows, a.width, a.height);
    shvis::files::write(a.out.join("seams.md"), &markdown).context("seams.md")?;
    shvis::files::write(
        a.out.join("seams.json"),
        serde_json::to_string_pretty(&rows)? + "\n",
    )
    .context("seams.json")?;
    print_table(&markdown, &a.out, "seams.md, seams.json", started);
    check_validation(&ctx, a.gpu.validate)
}

fn run_study_params(a: StudyParamsArgs) -> Result<()> {
    use shvis::study::{params, params_gpu};
    if a.directions == 0 || a.directions > 100_000_000 {
        bail!(
            "--directions {} is out of range 1..=100000000",
            a.directions
        );
    }
    if a.gpu_directions == 0 || a.gpu_directions > 100_000_000 {
        bail!(
            "--gpu-directions {} is out of range 1..=100000000",
            a.gpu_directions
        );
    }
    create_dir(&a.out)?;
    let started = Instant::now();
    let points = params::run_study(a.directions, a.seed);
    let mut written = params::write_report(&points, &a.out)?;
    if !a.no_gpu {
        let ctx = open_gpu(&a.gpu)?;
        let csv = params_gpu::run_and_write(&ctx, &a.out, a.directions, a.gpu_directions, a.seed)?;
        written.push(csv);
        check_validation(&ctx, a.gpu.validate)?;
    }
    for p in &written {
        println!("wrote {}", p.display());
    }
    println!("study params: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_sh(c: ShCommand) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    match c {
        ShCommand::Eval { order } => tools::eval(order, std::io::stdin().lock(), &mut out)?,
        ShCommand::Project { env, order } => tools::project(&env, order, &mut out)?,
        ShCommand::Irradiance {
            env,
            normal,
            order,
            exact,
        } => tools::irradiance(&env, &normal, order, exact, &mut out)?,
    }
    out.flush()?;
    Ok(())
}

/// The bake settings of `scene` under `env` for `techniques`: the inter-reflected bakes
/// (SH lightmap, transfer matrices) with `bounces` where a technique needs them.
fn prepare_settings(
    scene: &SceneArgs,
    env: &str,
    techniques: &[Technique],
    bounces: u32,
) -> Result<PrepareSettings> {
    let needs = |f: fn(&shvis::technique::BakeNeeds) -> bool| {
        techniques.iter().any(|t| f(&t.needs())).then_some(bounces)
    };
    let settings = PrepareSettings {
        scene: scene.scene.clone(),
        env: env.to_string(),
        vis_res: scene.vis_res,
        rays: scene.rays,
        seed: scene.seed,
        progress: true,
        order: shvis::sh::Order::new(scene.order).context("--order")?,
        table_res: scene.table_res,
        h_order: shvis::sh::Order::new(scene.h_order).context("--h-order")?,
        cache_dir: None,
        sh_lightmap_bounces: needs(|n| n.sh_lightmap),
        transfer_bounces: needs(|n| n.transfer),
        transfer_order: shvis::sh::Order::new(scene.transfer_order).context("--transfer-order")?,
        height_map: scene
            .height_map
            .clone()
            .map(|path| (path, scene.height_scale)),
    };
    // Every range and the bake's memory, before a device is opened or a file read.
    shvis::prepare::check_settings(&settings)?;
    Ok(settings)
}

fn open_gpu(gpu: &GpuArgs) -> Result<Arc<Context>> {
    let ctx = Context::new(&ContextDesc {
        validate: gpu.validate,
        device: gpu.device.clone(),
        ..ContextDesc::default()
    })?;
    log::info!("device: {}", ctx.device_name());
    Ok(ctx)
}

/// Creates the `--out` directory and checks it takes files, before any work.
fn create_dir(dir: &Path) -> Result<()> {
    Ok(shvis::files::check_writable_dir(dir, "--out")?)
}

fn run_bake(a: BakeArgs) -> Result<()> {
    if a.check {
        let manifest = shvis::files::Manifest::verify(&a.out).map_err(anyhow::Error::msg)?;
        println!(
            "{}: complete, {} files, settings {}",
            a.out.display(),
            manifest.files.len(),
            manifest.settings
        );
        return Ok(());
    }
    let settings = prepare_settings(&a.scene, "sky", &[], 0)?;
    let vis_res = bake::validate_res(a.scene.vis_res)?;
    let rays = bake::validate_rays(a.scene.rays)?;
    create_dir(&a.out)?;
    let cache_dir = shvis::bake::cache::default_cache_dir();
    if a.baker.baker == VisibilityBakerArg::Cpu {
        shvis::files::check_writable_dir(&cache_dir, "the bake cache (SHVIS_CACHE_DIR)")?;
    }
    let scene = resolve_scene(&a.scene.scene, vis_res)?;
    if a.separate_ao {
        let ao = bake_scene_ao(&scene, vis_res, rays, a.scene.seed, true)?;
        println!(
            "separate AO bake: {vis_res}² texels ({} covered) × {rays} rays: {}",
            ao.covered.iter().filter(|&&c| c).count(),
            ao.stats
        );
    }
    let visibility = match a.baker.baker {
        VisibilityBakerArg::Cpu => {
            shvis::prepare::bake_scene_visibility(&scene, vis_res, rays, &settings)?
        }
        VisibilityBakerArg::Gpu => bake_on_gpu(&a, &scene, vis_res, rays, &settings)?,
    };
    println!(
        "visibility and AO bake ({:?}): order {} × {rays} rays, {} triangles: {}",
        a.baker.baker,
        visibility.order,
        scene.mesh.triangle_count(),
        visibility.stats
    );
    let manifest_settings = serde_json::json!({
        "scene": a.scene.scene,
        "vis_res": vis_res,
        "rays": rays,
        "order": a.scene.order,
        "seed": a.scene.seed,
        "baker": format!("{:?}", a.baker.baker).to_lowercase(),
    });
    shvis::bake::cache::write_exr_layers(&a.out, &visibility, manifest_settings)?;
    println!(
        "wrote {}/ (visibility coefficient and ao EXR layers)",
        a.out.display()
    );
    Ok(())
}

/// `shvis bake --baker gpu`: the GPU simulator, and with `--compare-cpu` its distance
/// from the CPU bake against the quadrature noise.
fn bake_on_gpu(
    a: &BakeArgs,
    scene: &shvis::scene::Scene,
    vis_res: u32,
    rays: u32,
    settings: &PrepareSettings,
) -> Result<bake::visibility::VisibilityMap> {
    use shvis::bake::gpu_visibility;
    use shvis::bake::visibility::{VisibilitySettings, bake_visibility};
    let ctx = open_gpu(&a.gpu)?;
    let texels = bake::raster::rasterize(&scene.mesh, vis_res);
    let vis_settings = VisibilitySettings {
        order: settings.order,
        rays,
        seed: settings.seed,
        progress: true,
    };
    let gpu_settings = a.baker.gpu_settings();
    let baked = gpu_visibility::bake_visibility_gpu(
        &ctx,
        &scene.mesh,
        &texels,
        &vis_settings,
        &gpu_settings,
    )?;
    let gpu_ms = baked.gpu_ms.map_or("no timestamps".into(), |(d, p)| {
        format!("GPU {d:.1} ms directions + {p:.1} ms projection")
    });
    println!(
        "gpu simulator on {}: {}² depth maps, bias {} + {}·tanθ texels: {:.2} s ({:.2} s set-up; {gpu_ms})",
        ctx.device_name(),
        a.baker.depth_res,
        a.baker.depth_bias,
        a.baker.slope_bias,
        baked.map.stats.seconds,
        baked.setup_s
    );
    if a.compare_cpu {
        let tracer = bake::trace::Tracer::new(&scene.mesh);
        let cpu = bake_visibility(&tracer, &texels, &vis_settings);
        let other_seed = bake_visibility(
            &tracer,
            &texels,
            &VisibilitySettings {
                seed: vis_settings.seed + 1,
                ..vis_settings
            },
        );
        let noise = gpu_visibility::quadrature_noise(&cpu, &other_seed);
        let (mut leaks, mut acne) = (0, 0);
        for i in 0..cpu.ao.len() {
            if cpu.covered[i] {
                let d = baked.map.ao[i] - cpu.ao[i];
                leaks += usize::from(d > 0.02);
                acne += usize::from(d < -0.02);
            }
        }
        println!("gpu AO above the cpu's by > 0.02 (leaks): {leaks} texels; below (acne): {acne}");
        let d = gpu_visibility::compare(&cpu, &baked.map, noise);
        println!(
            "gpu vs cpu: {:.3} % of {} texels differ by more than the quadrature noise {noise:.4} (L2 of the coefficients; RMS difference {:.4}); cpu bake {:.2} s, gpu {:.2} s ({:.2}×)",
            100.0 * d.fraction_above,
            d.texels,
            d.rms,
            cpu.stats.seconds,
            baked.map.stats.seconds,
            baked.map.stats.seconds / cpu.stats.seconds
        );
    }
    Ok(baked.map)
}

/// `--normal-filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum NormalFilterArg {
    Mip,
    Ndf,
}

/// `techniques` under `--normal-filter`: with `ndf` each unc*/preconv replaced by its NDF
/// variant (duplicates dropped), a note naming those without one.
fn with_normal_filter(techniques: Vec<Technique>, filter: NormalFilterArg) -> Vec<Technique> {
    if filter == NormalFilterArg::Mip {
        return techniques;
    }
    let unfiltered: Vec<String> = techniques
        .iter()
        .filter(|t| t.ndf_variant().is_none())
        .map(|t| t.name())
        .collect();
    if !unfiltered.is_empty() {
        eprintln!(
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

fn run_render(mut a: RenderArgs) -> Result<()> {
    frame_format(&a.out)?;
    check_frame_memory(a.width, a.height, 48)?;
    shvis::files::check_writable_file(&a.out, "--out")?;
    a.technique = with_normal_filter(vec![a.technique], a.normal_filter)[0];
    let settings = prepare_settings(&a.scene, &a.env, &[a.technique], a.bounces)?;
    // The device next: a missing GPU should not cost a bake.
    let ctx = open_gpu(&a.gpu)?;
    let mut prepared = prepare_with(&settings, &a.baker.visibility_baker(&ctx))?;
    prepared.prepare_techniques(&[a.technique])?;
    let settings = FrameSettings {
        width: a.width,
        height: a.height,
        flat_normals: a.flat_normals,
        ..FrameSettings::default()
    };
    let mut scene_gpu = SceneGpu::new(&ctx, &prepared.scene, &settings)?;
    if let Some(term) = a.specular.term(&prepared.env)? {
        scene_gpu.add_specular(&ctx, &prepared.scene, term)?;
    }
    let tech = technique::build(&ctx, &scene_gpu, a.technique, a.path, &prepared.inputs())?;
    let frame = tech.render(&scene_gpu, 0, 1)?;
    let clipped = frame.clipped_pixels();
    if clipped > 0 {
        log::warn!(
            "{}: {clipped} pixels clipped at the f16 target's 65504 (or not finite): the environment is too bright for this target; scale it down",
            tech.label()
        );
    }
    write_frame(&a.out, &frame, a.exposure)?;
    check_validation(&ctx, a.gpu.validate)?;
    println!("wrote {} ({})", a.out.display(), tech.label());
    Ok(())
}

fn run_reference(a: ReferenceArgs) -> Result<()> {
    frame_format(&a.out)?;
    check_frame_memory(a.width, a.height, 160)?;
    shvis::files::check_writable_file(&a.out, "--out")?;
    let min = shvis::prepare::min_vis_res(&a.scene);
    if !(min..=bake::MAX_RES).contains(&a.vis_res) {
        bail!(
            "--vis-res {} is out of range {min}..={} for scene '{}'",
            a.vis_res,
            bake::MAX_RES,
            a.scene
        );
    }
    let ctx = open_gpu(&a.gpu)?;
    let vis_res = bake::validate_res(a.vis_res)?;
    let env = shvis::env::resolve(&a.env)?;
    let mut scene = resolve_scene(&a.scene, vis_res)?;
    if a.displaced {
        let t = Instant::now();
        scene = shvis::scene::displace::displace(&scene)?;
        log::info!(
            "displaced {}: {} triangles in {:.1} s",
            scene.name,
            scene.mesh.triangle_count(),
            t.elapsed().as_secs_f64()
        );
    }
    let image = shvis::reference::render_reference(
        &ctx,
        &scene,
        &env,
        &shvis::reference::ReferenceSettings {
            width: a.width,
            height: a.height,
            spp: a.spp,
            seed: a.seed,
            bounces: a.bounces,
            footprint: !a.point,
        },
    )?;
    let (frame, noise) = match &image.bounced {
        Some(b) => (&b.frame, b.rel_noise),
        None => (&image.frame, image.rel_noise),
    };
    write_frame(&a.out, frame, a.exposure)?;
    check_validation(&ctx, a.gpu.validate)?;
    let sampling = match image.strata.side {
        1 if a.point => "point-sampled".to_string(),
        side => format!("footprint {side}×{side} strata"),
    };
    println!(
        "reference: {} spp, {sampling}, {} bounces, {:.1} M rays in {:.1} s; noise (relative standard error of the image) {:.4}",
        a.spp,
        a.bounces,
        image.rays as f64 / 1e6,
        image.seconds,
        noise
    );
    println!("wrote {}", a.out.display());
    Ok(())
}

/// With `--validate`, any validation error or warning fails the command.
fn check_validation(ctx: &Context, validate: bool) -> Result<()> {
    let (errors, warnings) = ctx.message_counts();
    if validate && (errors > 0 || warnings > 0) {
        bail!("validation reported {errors} errors and {warnings} warnings (see the log above)");
    }
    Ok(())
}

fn parse_list<T>(list: &str, all: &[T]) -> Result<Vec<T>>
where
    T: std::str::FromStr + Copy,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    if list == "all" {
        return Ok(all.to_vec());
    }
    list.split(',')
        .map(|s| s.trim().parse::<T>().map_err(anyhow::Error::from))
        .collect()
}

fn run_probe(a: ProbeArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 48)?;
    create_dir(&a.out)?;
    let ctx = open_gpu(&a.gpu)?;
    let probe = shvis::probe::run(
        &ctx,
        &shvis::probe::ProbeSettings {
            width: a.width,
            height: a.height,
            triangle_pixels: match a.triangle_pixels {
                Some(px) => px,
                None => shvis::scene::house::build(shvis::scene::house::MIN_LIGHTMAP_RES)?
                    .pixel_weighted_triangle_area(a.width, a.height),
            },
            warmup: a.warmup,
            frames: a.frames,
        },
    )?;
    println!("{}", probe.to_markdown());
    for p in shvis::report::write_probe(&probe, &a.out)? {
        println!("wrote {}", p.display());
    }
    check_validation(&ctx, a.gpu.validate)?;
    Ok(())
}

fn run_bench(a: BenchArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 320)?;
    let mut settings = BenchSettings {
        techniques: with_normal_filter(parse_list(&a.techniques, Technique::ALL)?, a.normal_filter),
        paths: parse_list(&a.paths, HwPath::ALL)?,
        frames: a.frames,
        warmup: a.warmup,
        width: a.width,
        height: a.height,
        exposure: a.exposure,
        ref_spp: a.ref_spp,
        bounces: a.bounces,
        footprint_reference: !a.point_reference,
        seed: a.scene.seed,
        specular: None,
        out: a.out.clone(),
        probe: !a.no_probe,
        relight_degrees: a.relight_rotate,
    };
    if a.relight_rotate.is_some() && !a.specular.specular.is_empty() {
        bail!("--relight-rotate: not with --specular (its light is the bake's sun)");
    }
    create_dir(&a.out)?;
    // A table from an earlier run must not sit beside this run's images if it stops early.
    for stale in ["table.md", "table.json"] {
        let _ = std::fs::remove_file(a.out.join(stale));
    }
    let started = Instant::now();
    let prepare_settings = prepare_settings(&a.scene, &a.env, &settings.techniques, a.bounces)?;
    // The device before the bake: a missing GPU should not cost one, and `--baker gpu`
    // bakes on it.
    let ctx = open_gpu(&a.gpu)?;
    let mut prepared = prepare_with(&prepare_settings, &a.baker.visibility_baker(&ctx))?;
    prepared.prepare_techniques(&settings.techniques)?;
    settings.specular = a.specular.settings(&prepared.env)?;
    if a.techniques == "all" && prepared.ssbump.is_none() {
        // The whole table on a scene without a height map: the rows that need one are left
        // out (named explicitly they fail with the reason).
        let (kept, dropped): (Vec<Technique>, Vec<Technique>) =
            settings.techniques.iter().partition(|t| !t.needs().ssbump);
        if !dropped.is_empty() {
            eprintln!(
                "note: scene '{}' has no height map (--height-map): leaving out {}",
                prepared.scene.name,
                dropped
                    .iter()
                    .map(|t| t.name())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        settings.techniques = kept;
    }
    let table = shvis::bench::run(&ctx, &prepared, &settings)?;
    print_table(
        &table.to_markdown(),
        &a.out,
        "table.md, table.json",
        started,
    );
    check_validation(&ctx, a.gpu.validate)
}
