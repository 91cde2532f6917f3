//! `shvis study …`: the paper's side studies.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Subcommand};

use shvis::study::report::StudyReport;
use shvis::technique::{HwPath, Technique};

use super::args::{GpuArgs, SceneArgs, finite_f32};
use super::{
    DEFAULT_EXPOSURE_EV, MAX_BOUNCES, MAX_FRAME_SIDE, OUT_FOLDER, RunInputs, clear_earlier_files,
    create_dir, named_once, prepare_settings, print_table, print_written, say, with_gpu,
};

#[derive(Subcommand, Debug)]
pub(super) enum StudyCommand {
    /// Appendix A / Figure 8: MSE of SH basis functions stored in four sphere
    /// parameterizations against total samples (CPU emulation and real texture hardware).
    Params(StudyParamsArgs),
    /// Visibility reconstruction error against storage for global PCA, VQ and static /
    /// iterative CPCA fitted to the same bake.
    Compression(StudyCompressionArgs),
    /// The screen-space discontinuity at cluster boundaries of a clustered technique
    /// (vqK, cpcaK_M) with the 4-tap seam blending and without it.
    Seams(StudySeamsArgs),
    /// rnm, rnmao, ssbump, shlmap and unc6 against the displaced-geometry reference and the
    /// flat normal-mapped one, per environment; the Fig. 1 composite.
    Rnm(StudyRnmArgs),
    /// GPU normal-map generation timed against triangle counts and resolution (the paper's
    /// Tables 1 and 2) beside the CPU baker; GPU vs CPU maps of a real model simplified;
    /// the map rendered through unc6 against the high mesh's reference.
    Normalmap(StudyNormalmapArgs),
    /// The specular term of a directional light on the receding bumpy plane and the wavy
    /// sphere under naive MIP filtering and normal distribution mapping (partial /
    /// per-texel normalisation), against its footprint reference, with a composite per
    /// scene; the diffuse techniques and their NDF variants.
    Ndf(StudyNdfArgs),
    /// Energy captured by the first M = 1…9 singular values of normal mapping for PRT's
    /// normal basis (PRT course), uniform and cosine-weighted, beside the course's.
    NmprtSvd(StudyNmprtSvdArgs),
    /// Irradiance error over all normals of each engine lightmap basis (L1 linear,
    /// Geomerics, hallucinated and stored ZH3, luminance L1, L2, deringed L2) against exact
    /// irradiance, per environment; and on a floor under each environment every lightmap
    /// basis (SH L1–L4, the engine bases, H-basis, Ambient Dice, ambient cube, SG) fitted
    /// from the environment's pixels and from its order-8 SH: irradiance and radiance
    /// error against bytes per texel.
    Bases(StudyBasesArgs),
    /// Each lightmap basis' error against the rays per texel of its bake (64 … 4096) and
    /// against its bytes per texel, against the inter-reflected footprint reference.
    Rays(StudyRaysArgs),
    /// The SH lightmap block-compressed (BC6H, BC7) under each packing of its signed
    /// coefficients — raw, offset, band-0 ratios — and BC6H's encoder settings against
    /// time: irradiance error and bytes per texel.
    Block(StudyBlockArgs),
}

#[derive(Args, Debug)]
pub(super) struct StudyBlockArgs {
    /// Environment the SH lightmap is baked under (as for `render`).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Reflections baked into the SH lightmap.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Output directory: block.md, block.json.
    #[arg(short, long, default_value = "study-out/block")]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudyBasesArgs {
    /// Environments, comma-separated: `sky`, `sky:DEG`, .exr/.hdr probes, `angular:PATH`,
    /// `sh:FILE` (SH coefficients as `shvis sh project` prints them).
    #[arg(long, value_delimiter = ',', default_value = "sky,sky:15,sky:60")]
    envs: Vec<String>,
    /// Normals: an exact sphere quadrature of Q × 2Q nodes (the sphere table) and a
    /// hemisphere rule of Q × 2Q nodes (the hemisphere table).
    #[arg(long, default_value_t = 16, value_parser = clap::value_parser!(u32).range(4..=256))]
    quadrature: u32,
    /// Output directory: bases.md, bases.json, bases_error.svg/.png,
    /// bases_hemisphere.svg/.png.
    #[arg(short, long, default_value = "study-out/bases")]
    out: PathBuf,
}

#[derive(Args, Debug)]
pub(super) struct StudyRaysArgs {
    /// Environment the lightmap is baked under (as for `render`).
    #[arg(long, default_value = "sky")]
    env: String,
    /// Rows, comma-separated (any lightmap technique).
    #[arg(long, default_value = "shlmap,l1,zh3,hb4,sg9,sg12,dice,acube")]
    techniques: String,
    /// Paths, comma-separated.
    #[arg(long, default_value = "dx10,dx11")]
    paths: String,
    /// Rays per texel of each bake, comma-separated.
    #[arg(long = "ray-counts", value_delimiter = ',', default_value = "64,256,1024,4096", value_parser = clap::value_parser!(u32).range(shvis::bake::MIN_RAYS as i64..=shvis::bake::MAX_RAYS as i64))]
    ray_counts: Vec<u32>,
    /// A built-in scene (`house`, `patio`: a brick corner, `bumpy`, `wavy`) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    scene: String,
    /// Lightmap texels per side.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=4096))]
    vis_res: u32,
    /// Seed of the bake's sample patterns.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// How sgN techniques fit their lobes' amplitudes (as for `bench`).
    #[arg(long = "sg-solve", default_value_t = shvis::sh::sg::DEFAULT_SOLVER)]
    sg_solve: shvis::sh::sg::Solver,
    /// What the tangent-frame bases are fitted from: samples or l2 (as for `bench`).
    #[arg(long = "basis-fit", default_value_t = shvis::sh::samples::BasisFit::Samples)]
    basis_fit: shvis::sh::samples::BasisFit,
    /// What the bake's escaped rays read of the environment: sh or pixels (as for `bench`).
    #[arg(long = "bake-env", default_value_t = shvis::bake::shlmap::BakeEnv::Sh)]
    bake_env: shvis::bake::shlmap::BakeEnv,
    /// Reflections baked into the lightmap and in the reference.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Image width.
    #[arg(long, default_value_t = 640, value_parser = clap::value_parser!(u32).range(1..=4096))]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(1..=4096))]
    height: u32,
    /// Samples per pixel of the footprint reference.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    ref_spp: u32,
    /// Output directory: rays.md, rays.json, rays.svg/.png, and each bake's bench in rays-N/.
    #[arg(short, long, default_value = "study-out/rays")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// Most disk-normal × hemisphere-cell pairs `study nmprt-svd` sums (`--disk-res`² ×
/// `--quadrature`²; the defaults are 32² × 128² ≈ 1.7·10⁷).
const MAX_NMPRT_SVD_PAIRS: u64 = 1 << 32;

#[derive(Args, Debug)]
pub(super) struct StudyNmprtSvdArgs {
    /// Disk grid of normals per side (the U textures' resolution).
    #[arg(long = "disk-res", default_value_t = 32, value_parser = clap::value_parser!(u32).range(1..=1024))]
    side: u32,
    /// Hemisphere quadrature cells per side (in cos θ and φ).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(4..=4096))]
    quadrature: u32,
    /// Output directory (nmprt_svd.md).
    #[arg(short, long, default_value = "study-out")]
    out: PathBuf,
}

#[derive(Args, Debug)]
pub(super) struct StudyNdfArgs {
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
    #[arg(long = "ref-spp", default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1024))]
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
    #[arg(long = "diffuse-ref-spp", default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    diffuse_spp: u32,
    /// Lightmap resolution of the diffuse part's bakes.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(16..=4096))]
    vis_res: u32,
    /// Output directory: ndf.md, ndf.json, fig1_ndf_{scene}.png.
    #[arg(short, long, default_value = "study-out/ndf")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudyNormalmapArgs {
    /// Runs per timing (medians are reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Map side of the triangle-count and strategy tables.
    #[arg(long = "map-res", default_value_t = 512, value_parser = clap::value_parser!(u32).range(16..=8192))]
    res: u32,
    /// A real model (.gltf/.glb) for the simplification part; without one that part is
    /// skipped with a note (`make bench-full` passes the shared assets' NormalTangentMirrorTest
    /// when they are there).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Fractions of the model's triangles to keep, comma-separated, each in (0, 1].
    #[arg(long, value_delimiter = ',', default_value = "0.05,0.02", value_parser = finite_f32)]
    ratios: Vec<f32>,
    /// Map side for the model.
    #[arg(long = "model-map-res", default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=8192))]
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
    #[arg(long = "ref-spp", default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    /// Output directory: normalmap.md, normalmap.json, the model's maps, glTFs and renders.
    #[arg(short, long, default_value = "study-out/normalmap")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudyRnmArgs {
    /// A scene with a height-mapped material small enough to displace.
    #[arg(long, default_value = "patio")]
    scene: String,
    /// Environments, comma-separated (`sky`, `sky:DEG`, .exr/.hdr maps); `sky:15` is the
    /// grazing low sun (`make bench-full` adds the shared assets' overcast probe when it is there).
    #[arg(long, value_delimiter = ',', default_value = "sky:15")]
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
    #[arg(long = "ref-spp", default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: u32,
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Output directory: rnm.md, rnm.json, fig1_<env>.png (the figures an earlier run's
    /// rnm.json lists there are removed first).
    #[arg(short, long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudySeamsArgs {
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
    #[arg(short, long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudyCompressionArgs {
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
    #[arg(short, long, default_value = "study-out")]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct StudyParamsArgs {
    /// Output directory: params.csv, params.json, params.md, params_mse.svg/png, gpu.csv.
    #[arg(short, long, default_value = "study-out")]
    out: PathBuf,
    /// Random directions for the CPU reconstruction (at most 10⁷).
    #[arg(long, default_value_t = shvis::study::params::DEFAULT_DIRECTIONS, value_parser = clap::value_parser!(usize))]
    directions: usize,
    /// Directions for the GPU reconstruction (a subset of the same set; at most 10⁷).
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

/// Runs a study, its errors prefixed with its command.
pub(super) fn run_study(c: StudyCommand) -> Result<()> {
    match c {
        StudyCommand::Params(a) => run_params(a).context("study params"),
        StudyCommand::Compression(a) => run_compression(a).context("study compression"),
        StudyCommand::Seams(a) => run_seams(a).context("study seams"),
        StudyCommand::Rnm(a) => run_rnm(a).context("study rnm"),
        StudyCommand::Ndf(a) => run_ndf(a).context("study ndf"),
        StudyCommand::NmprtSvd(a) => run_nmprt_svd(a).context("study nmprt-svd"),
        StudyCommand::Bases(a) => run_bases(a).context("study bases"),
        StudyCommand::Rays(a) => run_rays(a).context("study rays"),
        StudyCommand::Block(a) => run_block(a).context("study block"),
        StudyCommand::Normalmap(a) => run_normalmap(a).context("study normalmap"),
    }
}

fn run_compression(a: StudyCompressionArgs) -> Result<()> {
    use shvis::study::tables;
    named_once("--techniques", &a.techniques)?;
    named_once("--paths", &a.paths)?;
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    // The on-screen tables of an earlier run (this one may not measure them).
    clear_earlier_files(&a.out, |name| matches!(name, "screen.md" | "screen.json"));
    let started = Instant::now();
    let mut prepared = shvis::prepare::prepare(&prepare_settings(&a.scene, &a.env, &[], 0)?)?;
    let markdown = tables::compression_tables(&prepared, a.scene.table_res, a.scene.seed, &a.out)?;
    if a.no_gpu {
        let files = "compression.md, compression.json";
        print_table(&markdown, &a.out, files, started)?;
        return Ok(());
    }
    with_gpu(&a.gpu, |ctx| {
        prepared.prepare_techniques(&a.techniques)?;
        let size = (a.width, a.height);
        let screen_md = tables::compression_screen(
            ctx,
            &prepared,
            &a.techniques,
            &a.paths,
            &a.env,
            size,
            &a.out,
        )?;
        print_table(
            &format!("{markdown}\n{screen_md}"),
            &a.out,
            "compression.md, compression.json, screen.md, screen.json",
            started,
        )?;
        Ok(())
    })
}

fn run_nmprt_svd(a: StudyNmprtSvdArgs) -> Result<()> {
    // Every disk normal sums over every hemisphere cell: about half a minute on two cores at
    // the limit (the defaults take 0.1 s), and 96 bytes a cell.
    let (side, cells) = (u64::from(a.side), u64::from(a.quadrature).pow(2));
    shvis::limits::check_at_most(
        format_args!(
            "--disk-res {}² × --quadrature {}²: normal-direction pairs",
            a.side, a.quadrature
        ),
        side * side * cells,
        MAX_NMPRT_SVD_PAIRS,
        "lower --disk-res or --quadrature",
    )?;
    shvis::limits::check_memory(
        format_args!("--quadrature {}: the hemisphere cells", a.quadrature),
        cells.saturating_mul(96),
        "lower --quadrature",
    )?;
    create_dir(&a.out)?;
    let markdown = shvis::study::nmprt_svd_report::report(a.side as usize, a.quadrature as usize);
    out!("{markdown}");
    let report = StudyReport {
        stem: "nmprt_svd",
        markdown,
        json: None,
    };
    print_written(&shvis::study::report::write(&a.out, &report)?)?;
    Ok(())
}

fn run_rays(a: StudyRaysArgs) -> Result<()> {
    let techniques = super::parse_techniques(&a.techniques)?;
    let paths = super::parse_list(&a.paths, HwPath::ALL)?;
    super::check_rows(&a.techniques, &techniques, &paths, false)?;
    if let Some(t) = techniques.iter().find(|t| !t.needs().sh_lightmap) {
        bail!(
            "--techniques: {t} is not a lightmap technique (it does not read the SH lightmap bake)"
        );
    }
    let ray_counts = super::parse_each_once::<u32>(
        &a.ray_counts
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(","),
    )?;
    let scene = SceneArgs {
        scene: a.scene.clone(),
        vis_res: a.vis_res,
        rays: ray_counts[0],
        seed: a.seed,
        order: 6,
        table_res: 32,
        h_order: 3,
        sg_solve: a.sg_solve,
        basis_fit: a.basis_fit,
        bake_env: a.bake_env,
        transfer_order: shvis::bake::transfer::DEFAULT_LIGHTING_ORDER.get(),
        height_map: None,
        height_scale: 1.0,
    };
    RunInputs::of_scene(&scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_FOLDER)?;
    let mut prepare = prepare_settings(&scene, &a.env, &techniques, a.bounces)?;
    prepare.progress = false;
    for &rays in &ray_counts {
        shvis::prepare::check_settings(&shvis::prepare::PrepareSettings {
            rays,
            ..prepare.clone()
        })?;
    }
    create_dir(&a.out)?;
    let started = Instant::now();
    let bench = shvis::bench::BenchSettings {
        techniques,
        paths,
        frames: 3,
        warmup: 1,
        width: a.width,
        height: a.height,
        exposure: DEFAULT_EXPOSURE_EV,
        ref_spp: a.ref_spp,
        bounces: a.bounces,
        footprint_reference: true,
        seed: a.seed,
        specular: None,
        out: a.out.clone(),
        probe: false,
        probe_fresh: false,
        probe_frames: 5,
        relight_degrees: None,
        ladder: false,
        ladder_stride: 1,
        dx11_rows: None,
    };
    with_gpu(&a.gpu, |ctx| {
        // Device and bakes are good: an earlier run's benches, of ray counts this one may
        // not measure, go.
        clear_earlier_files(&a.out, |name| {
            name.strip_prefix("rays-")
                .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        });
        let study = shvis::study::rays::run(ctx, &prepare, &bench, &ray_counts, &mut say)?;
        let written = shvis::study::rays::write(&study, &a.out)?;
        print_written(&written)?;
        Ok(())
    })?;
    out!("study rays: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_bases(a: StudyBasesArgs) -> Result<()> {
    let envs = super::parse_each_once::<String>(&a.envs.join(","))?;
    envs.iter()
        .fold(RunInputs::default(), |inputs, e| inputs.env("--envs", e))
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    let study = shvis::study::bases::run(&envs, a.quadrature as usize, true)?;
    let report = StudyReport {
        stem: "bases",
        markdown: shvis::study::bases::markdown(&study),
        json: Some(serde_json::to_string_pretty(&study)?),
    };
    shvis::study::report::write(&a.out, &report).map_err(|e| e.source)?;
    let plots = shvis::study::bases::write_plot(&study, &a.out)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.out.join("bases_error.svg").display()))?;
    print_table(&report.markdown, &a.out, "bases.md, bases.json", started)?;
    print_written(&plots)?;
    Ok(())
}

fn run_block(a: StudyBlockArgs) -> Result<()> {
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    let prepared = shvis::prepare::prepare(&prepare_settings(
        &a.scene,
        &a.env,
        &[Technique::Shlmap(shvis::technique::Shlmap)],
        a.bounces,
    )?)?;
    let map = prepared
        .sh_lightmap
        .as_ref()
        .context("the SH lightmap was not baked")?;
    let study = shvis::study::block::run(map);
    let table_rows = shvis::study::block::tables(
        &prepared,
        &["unc6", "pca8"].map(|n| n.parse().expect("technique names")),
    )?;
    let report = StudyReport {
        stem: "block",
        markdown: shvis::study::block::markdown(&study)
            + &shvis::study::block::tables_markdown(&table_rows),
        json: Some(serde_json::to_string_pretty(
            &serde_json::json!({"lightmap": study, "tables": table_rows}),
        )?),
    };
    shvis::study::report::write(&a.out, &report).map_err(|e| e.source)?;
    print_table(&report.markdown, &a.out, "block.md, block.json", started)?;
    Ok(())
}

fn run_ndf(a: StudyNdfArgs) -> Result<()> {
    let [x, y, z] = <[f32; 3]>::try_from(a.light_dir.as_slice())
        .map_err(|_| anyhow::anyhow!("--light-dir needs three numbers x,y,z"))?;
    let light_dir = glam::Vec3::new(x, y, z);
    if !(light_dir.is_finite() && light_dir.length() > 1e-6) {
        bail!("--light-dir {x},{y},{z} is not a direction");
    }
    if light_dir.normalize().y <= 0.0 {
        bail!(
            "--light-dir {x},{y},{z} points at or below the bumpy plane (its normal is +y): it would light nothing"
        );
    }
    if !(shvis::ndf::MIN_SIGMA..=shvis::ndf::MAX_SIGMA).contains(&a.sigma) {
        bail!(
            "--sigma {} is outside {}..={}",
            a.sigma,
            shvis::ndf::MIN_SIGMA,
            shvis::ndf::MAX_SIGMA
        );
    }
    // Each scene × environment names its images: two with one name would overwrite them.
    let mut tags: Vec<(String, String)> = Vec::new();
    for scene in &a.diffuse_scenes {
        for env in &a.diffuse_envs {
            let tag = shvis::study::ndf_diffuse::image_tag(scene, env);
            let pair = format!("{scene} under {env}");
            if let Some((_, earlier)) = tags.iter().find(|(t, _)| *t == tag) {
                bail!(
                    "--diffuse-scenes/--diffuse-envs: {earlier} and {pair} would both write diffuse_{tag}_*; give each a distinct file name"
                );
            }
            tags.push((tag, pair));
        }
    }
    let inputs = a
        .diffuse_scenes
        .iter()
        .fold(RunInputs::default(), |inputs, s| {
            inputs.scene("--diffuse-scenes", s)
        });
    a.diffuse_envs
        .iter()
        .fold(inputs, |inputs, e| inputs.env("--diffuse-envs", e))
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    let settings = shvis::study::ndf_report::NdfRunSettings {
        scenes: a.scenes,
        sigma: a.sigma,
        light_dir,
        width: a.width,
        height: a.height,
        spp: a.spp,
        paths: a.paths,
        frames: a.frames,
        diffuse_scenes: a.diffuse_scenes,
        diffuse_envs: a.diffuse_envs,
        diffuse_spp: a.diffuse_spp,
        vis_res: a.vis_res,
        out: a.out,
    };
    with_gpu(&a.gpu, |ctx| {
        // The device is good: an earlier run's figures and images, of scenes and
        // environments this one may not measure, go.
        clear_earlier_files(&settings.out, |name| {
            (name.starts_with("fig1_ndf_") && name.ends_with(".png"))
                || (name.starts_with("diffuse_")
                    && (name.ends_with(".exr") || name.ends_with(".png")))
        });
        print_written(&shvis::study::ndf_report::run(ctx, &settings, &mut say)?)?;
        Ok(())
    })?;
    out!("study ndf: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The lightmap resolution `--model` is read at to check it before the study's work.
const MODEL_CHECK_RES: u32 = 64;

fn run_normalmap(a: StudyNormalmapArgs) -> Result<()> {
    if let Some(r) = a.ratios.iter().find(|&&r| !(r > 0.0 && r <= 1.0)) {
        bail!("--ratios: {r} is not a fraction in (0, 1] of the model's triangles");
    }
    // Each ratio names its files: two that read the same would write one set twice.
    let percents: Vec<String> = a
        .ratios
        .iter()
        .map(|&r| shvis::study::normalmap::ratio_percent(r))
        .collect();
    if let Some((i, p)) = percents
        .iter()
        .enumerate()
        .find(|(i, p)| percents[..*i].contains(p))
    {
        bail!(
            "--ratios: {} and {} are both {p} % of the model's triangles; give each ratio once",
            a.ratios[percents.iter().position(|q| q == p).unwrap_or(0)],
            a.ratios[i]
        );
    }
    // The model is read before the timings, which take minutes, so a bad one fails first.
    if let Some(model) = &a.model {
        shvis::scene::gltf::load(model, MODEL_CHECK_RES).context("--model")?;
    }
    let model_files = a
        .model
        .iter()
        .flat_map(|m| shvis::scene::gltf::files_read(m));
    model_files
        .fold(RunInputs::default().env("--env", &a.env), |inputs, f| {
            inputs.file("--model", Some(&f))
        })
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    with_gpu(&a.gpu, |ctx| {
        // The device is good: an earlier run's maps, glTFs and renders of the model at
        // other ratios go.
        clear_earlier_files(&a.out, shvis::study::normalmap::is_ratio_output);
        let model = a.model.clone();
        if model.is_none() {
            out!("note: no --model: the real-model part is skipped");
        }
        let settings = shvis::study::normalmap::NormalMapStudySettings {
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
        let written = shvis::study::normalmap_report::run(ctx, &settings, &a.out, &mut say)?;
        print_written(&written)?;
        Ok(())
    })?;
    out!("study normalmap: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_rnm(a: StudyRnmArgs) -> Result<()> {
    named_once("--envs", &a.envs)?;
    for (i, e) in a.envs.iter().enumerate() {
        let stem = shvis::study::rnm::env_stem(e);
        if let Some(other) = a.envs[..i]
            .iter()
            .find(|o| shvis::study::rnm::env_stem(o) == stem)
        {
            bail!("--envs: {other} and {e} would both write fig1_{stem}.png; rename one");
        }
        if stem.starts_with("ndf_") {
            bail!(
                "--envs: {e} would write fig1_{stem}.png, a name of study ndf's figures; rename it"
            );
        }
    }
    a.envs
        .iter()
        .fold(
            RunInputs::default().scene("--scene", &a.scene),
            |inputs, e| inputs.env("--envs", e),
        )
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    let settings = shvis::study::rnm::RnmStudySettings {
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
    with_gpu(&a.gpu, |ctx| {
        // The device is good: the figures an earlier run's report lists, of environments
        // this one may not measure, go.
        for figure in shvis::study::rnm::earlier_figures(&a.out) {
            if figure.symlink_metadata().is_ok_and(|m| m.is_file()) {
                let _ = std::fs::remove_file(&figure);
            }
        }
        let written =
            shvis::study::rnm_report::run(ctx, &a.envs, &settings, &a.out, a.exposure, &mut say)?;
        print_written(&written)?;
        Ok(())
    })?;
    out!("study rnm: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn run_seams(a: StudySeamsArgs) -> Result<()> {
    use shvis::study::tables;
    named_once("--techniques", &a.techniques)?;
    named_once("--paths", &a.paths)?;
    tables::check_clustered(&a.techniques)?;
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    with_gpu(&a.gpu, |ctx| {
        let mut prepared = shvis::prepare::prepare(&prepare_settings(&a.scene, &a.env, &[], 0)?)?;
        prepared.prepare_techniques(&a.techniques)?;
        let size = (a.width, a.height);
        let markdown = tables::seams_table(ctx, &prepared, &a.techniques, &a.paths, size, &a.out)?;
        print_table(&markdown, &a.out, "seams.md, seams.json", started)?;
        Ok(())
    })
}

/// The most directions `study params` reconstructs with (≈ 40 s on 2 cores for the CPU's).
const MAX_PARAMS_DIRECTIONS: usize = 10_000_000;

fn run_params(a: StudyParamsArgs) -> Result<()> {
    use shvis::study::{params, params_gpu};
    for (option, n) in [
        ("--directions", a.directions),
        ("--gpu-directions", a.gpu_directions),
    ] {
        if n == 0 || n > MAX_PARAMS_DIRECTIONS {
            bail!("{option} {n} is out of range 1..={MAX_PARAMS_DIRECTIONS}");
        }
    }
    create_dir(&a.out)?;
    // The GPU part of an earlier run (this one may not measure it).
    clear_earlier_files(&a.out, |name| name == "gpu.csv");
    let started = Instant::now();
    let points = params::run_study(a.directions, a.seed);
    let mut written = params::write_report(&points, &a.out)?;
    if !a.no_gpu {
        written.push(with_gpu(&a.gpu, |ctx| {
            let (dir, n, seed) = (&a.out, a.directions, a.seed);
            Ok(params_gpu::run_and_write(
                ctx,
                dir,
                n,
                a.gpu_directions,
                seed,
            )?)
        })?);
    }
    print_written(&written)?;
    out!("study params: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}
