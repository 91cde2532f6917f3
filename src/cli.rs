//! The command line (DESIGN §4): clap types and the commands. `anyhow` lives here and in
//! main.rs only; every failure becomes one `error: …` line and a non-zero exit.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::{Context as _, Result, bail};
use clap::{Args, Parser, Subcommand};

use shvis::gpu::{Context, ContextDesc};
use shvis::prepare::{PrepareSettings, Prepared, bake_scene_ao, prepare, resolve_scene};
use shvis::render::{FrameSettings, SceneGpu};
use shvis::report::image::{write_exr, write_frame, write_png};
use shvis::report::metrics::TimingStats;
use shvis::report::table::{BenchRow, BenchTable};
use shvis::technique::{self, HwPath, TechniqueId};
use shvis::{bake, report};

/// Largest frame side accepted before asking the device (which may allow less).
const MAX_FRAME_SIDE: u32 = 16384;
/// PNG exposure unless `--exposure` says otherwise.
const DEFAULT_EXPOSURE_EV: f32 = -1.0;
/// Most bounces of inter-reflection accepted (each adds a pass over the lightmap).
const MAX_BOUNCES: u32 = 16;

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
    /// Bake lightmap data (ambient occlusion) and write it as EXR for inspection.
    Bake(BakeArgs),
    /// Render one technique on one hardware path to a PNG or EXR.
    Render(RenderArgs),
    /// Ground truth: G-buffer on the GPU, ray-cast visibility and importance-sampled
    /// environment integration on the CPU; prints its noise level.
    Reference(ReferenceArgs),
    /// Time every technique × path and write table.md, table.json and images.
    Bench(BenchArgs),
    /// SH utilities for checking the math from outside (17 significant digits).
    #[command(subcommand)]
    Sh(ShCommand),
    /// Reproduce the paper's side studies.
    #[command(subcommand)]
    Study(StudyCommand),
}

#[derive(Subcommand, Debug)]
enum StudyCommand {
    /// Appendix A / Figure 8: MSE of SH basis functions stored in four sphere
    /// parameterizations against total samples (CPU emulation and real texture hardware).
    Params(StudyParamsArgs),
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
    /// `house` (built-in) or a .gltf/.glb file.
    #[arg(long, default_value = "house")]
    scene: String,
    /// Lightmap texels per side.
    #[arg(long, default_value_t = 512)]
    vis_res: u32,
    /// Rays per lightmap texel.
    #[arg(long, default_value_t = 1024)]
    rays: u32,
    /// Seed of the bake's sample patterns.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// SH order of the visibility bake (bands l < order).
    #[arg(long, default_value_t = 6)]
    order: u32,
    /// L×H table texels per hemisphere (dx9) or cube face (dx10) side.
    #[arg(long, default_value_t = 32)]
    table_res: u32,
    /// SH order of the clamped cosine in the L×H product (the paper uses 3).
    #[arg(long, default_value_t = 3)]
    h_order: u32,
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
    /// Output directory (ao.exr).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    /// `sky` (built-in) or an .exr/.hdr equirectangular environment map.
    #[arg(long, default_value = "sky")]
    env: String,
    /// Technique name (see `shvis bench`).
    #[arg(long)]
    technique: TechniqueId,
    /// Hardware path: dx9 or dx10.
    #[arg(long, default_value = "dx10")]
    path: HwPath,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV applied before sRGB encoding (PNG only). The default −1 keeps the
    /// built-in sky's sunlit ground out of clipping.
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_negative_numbers = true)]
    exposure: f32,
    /// Bounces of inter-reflection baked for shlmap.
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Ignore the normal map (shade with interpolated normals).
    #[arg(long)]
    flat_normals: bool,
    /// Output image: .png (sRGB) or .exr (linear).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct ReferenceArgs {
    /// `house` (built-in) or a .gltf/.glb file.
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
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_negative_numbers = true)]
    exposure: f32,
    /// Reflections of light to include (0: direct light only, the model of every technique
    /// but shlmap; shlmap bakes 2 by default).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    #[command(flatten)]
    gpu: GpuArgs,
    /// Output image: .exr (linear) or .png (sRGB).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Debug)]
struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
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
    /// Timed frames per technique × path (after the warm-up).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Untimed warm-up frames per technique × path.
    #[arg(long, default_value_t = 10)]
    warmup: u32,
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV of the PNG images.
    #[arg(long, default_value_t = DEFAULT_EXPOSURE_EV, allow_negative_numbers = true)]
    exposure: f32,
    /// Samples per pixel of the reference the errors are measured against (0: no errors).
    #[arg(long, default_value_t = 64)]
    ref_spp: u32,
    /// Bounces of inter-reflection in shlmap's bake and in the reference it is measured
    /// against (the other techniques model direct light and meet the direct reference).
    #[arg(long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Output directory.
    #[arg(long, default_value = "bench-out")]
    out: PathBuf,
}

/// Parses the arguments and runs the command.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Bake(a) => run_bake(a).context("bake"),
        Command::Render(a) => run_render(a).context("render"),
        Command::Reference(a) => run_reference(a).context("reference"),
        Command::Bench(a) => run_bench(a).context("bench"),
        Command::Sh(c) => run_sh(c).context("sh"),
        Command::Study(StudyCommand::Params(a)) => run_study_params(a).context("study params"),
    }
}

fn run_study_params(a: StudyParamsArgs) -> Result<()> {
    use shvis::sh::Order;
    use shvis::sphere::Parameterization;
    use shvis::study::{params, params_gpu};
    if a.directions == 0 || a.directions > 100_000_000 {
        bail!(
            "--directions {} is out of range 1..=100000000",
            a.directions
        );
    }
    create_dir(&a.out)?;
    let started = Instant::now();
    let points = params::run_study(a.directions, a.seed);
    log::info!(
        "CPU emulation: {} parameterization × resolution × order points at {} directions in {:.1} s",
        points.len(),
        a.directions,
        started.elapsed().as_secs_f64()
    );
    let mut written = params::write_report(&points, &a.out)?;
    if !a.no_gpu {
        let gpu_started = Instant::now();
        let ctx = open_gpu(&a.gpu)?;
        let mut directions =
            params::study_directions(a.directions.min(a.gpu_directions.max(1)), a.seed);
        directions.truncate(a.gpu_directions.max(1));
        let configs: Vec<(Parameterization, u32)> = Parameterization::ALL
            .iter()
            .flat_map(|&p| params::resolutions(p).iter().map(move |&r| (p, r)))
            .collect();
        let gpu_points = params_gpu::run_gpu_study(&ctx, &configs, Order::SIX, &directions)?;
        let path = a.out.join("gpu.csv");
        let csv = params_gpu::gpu_csv(&gpu_points);
        std::fs::write(&path, csv).with_context(|| format!("{}: cannot write", path.display()))?;
        let md_path = a.out.join("params.md");
        let mut md = std::fs::read_to_string(&md_path).unwrap_or_default();
        md += &params_gpu::gpu_summary_markdown(&gpu_points, ctx.device_name(), directions.len());
        std::fs::write(&md_path, md)
            .with_context(|| format!("{}: cannot write", md_path.display()))?;
        written.push(path);
        log::info!(
            "GPU reconstruction on {} in {:.1} s",
            ctx.device_name(),
            gpu_started.elapsed().as_secs_f64()
        );
        check_validation(&ctx, a.gpu.validate)?;
    }
    for p in &written {
        println!("wrote {}", p.display());
    }
    println!("study params: {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// 17 significant digits: enough to round-trip an f64.
fn fmt17(v: f64) -> String {
    format!("{v:.16e}")
}

fn parse_direction(text: &str, what: &str) -> Result<glam::DVec3> {
    let parts: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|p| !p.is_empty())
        .collect();
    let values: Vec<f64> = parts
        .iter()
        .map(|p| p.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("{what}: '{text}' is not three numbers"))?;
    let [x, y, z] = values[..] else {
        bail!("{what}: '{text}' is not three numbers");
    };
    Ok(shvis::sh::unit_dir(glam::DVec3::new(x, y, z)).with_context(|| what.to_string())?)
}

fn run_sh(c: ShCommand) -> Result<()> {
    use std::io::{BufRead, Write};

    use shvis::sh::{Order, basis::eval_basis, zonal};
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    match c {
        ShCommand::Eval { order } => {
            let order = Order::new(order)?;
            let mut values = vec![0.0; order.coeff_count()];
            for (i, line) in std::io::stdin().lock().lines().enumerate() {
                let line = line.context("reading stdin")?;
                if line.trim().is_empty() || line.trim_start().starts_with('#') {
                    continue;
                }
                let dir = parse_direction(&line, &format!("stdin line {}", i + 1))?;
                eval_basis(order, dir, &mut values);
                let text: Vec<String> = values.iter().map(|&v| fmt17(v)).collect();
                writeln!(out, "{}", text.join(" "))?;
            }
        }
        ShCommand::Project { env, order } => {
            let order = Order::new(order)?;
            let env = shvis::env::resolve(&env)?;
            for c in shvis::env::project::project_sh(&env, order) {
                writeln!(out, "{} {} {}", fmt17(c[0]), fmt17(c[1]), fmt17(c[2]))?;
            }
        }
        ShCommand::Irradiance {
            env,
            normal,
            order,
            exact,
        } => {
            let n = parse_direction(&normal, "--normal")?;
            let order = order.map(Order::new).transpose()?;
            let env = shvis::env::resolve(&env)?;
            let e = if exact {
                shvis::env::project::irradiance_brute_force(&env, n)
            } else {
                let order = order.unwrap_or(Order::THREE);
                let radiance = shvis::env::project::project_sh(&env, order);
                zonal::eval_rgb(&zonal::irradiance_from_radiance(&radiance, order), order, n)
            };
            writeln!(out, "{} {} {}", fmt17(e[0]), fmt17(e[1]), fmt17(e[2]))?;
        }
    }
    out.flush()?;
    Ok(())
}

fn prepare_settings(
    scene: &SceneArgs,
    env: &str,
    sh_lightmap_bounces: Option<u32>,
) -> Result<PrepareSettings> {
    Ok(PrepareSettings {
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
        sh_lightmap_bounces,
    })
}

fn open_gpu(gpu: &GpuArgs) -> Result<Arc<Context>> {
    let ctx = Context::new(&ContextDesc {
        validate: gpu.validate,
        device: gpu.device.clone(),
    })?;
    log::info!("device: {}", ctx.device_name());
    Ok(ctx)
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create directory", dir.display()))
}

fn run_bake(a: BakeArgs) -> Result<()> {
    let vis_res = bake::validate_res(a.scene.vis_res)?;
    let rays = bake::validate_rays(a.scene.rays)?;
    let settings = prepare_settings(&a.scene, "sky", None)?;
    let scene = resolve_scene(&a.scene.scene, vis_res)?;
    create_dir(&a.out)?;
    let ao = bake_scene_ao(&scene, vis_res, rays, a.scene.seed, true)?;
    let covered = ao.covered.iter().filter(|&&c| c).count();
    println!(
        "AO bake: {}² texels ({covered} covered) × {rays} rays, {} triangles: {:.2} s, {:.2} Mrays/s",
        vis_res,
        scene.mesh.triangle_count(),
        ao.seconds,
        ao.rays_per_second() / 1e6
    );
    let visibility = shvis::prepare::bake_scene_visibility(&scene, vis_res, rays, &settings)?;
    println!(
        "visibility bake: order {} × {rays} rays: {:.2} s, {:.2} Mrays/s",
        visibility.order,
        visibility.seconds,
        visibility.rays_per_second() / 1e6
    );
    shvis::bake::cache::write_exr_layers(&a.out, &visibility)?;
    println!(
        "wrote {}/ (visibility coefficient and ao EXR layers)",
        a.out.display()
    );
    Ok(())
}

fn run_render(a: RenderArgs) -> Result<()> {
    check_output_extension(&a.out)?;
    // The device first: a missing GPU should not cost a bake.
    let ctx = open_gpu(&a.gpu)?;
    let bounces = (a.technique == TechniqueId::Shlmap).then_some(a.bounces);
    let prepared = prepare(&prepare_settings(&a.scene, &a.env, bounces)?)?;
    let settings = FrameSettings {
        width: a.width,
        height: a.height,
        flat_normals: a.flat_normals,
        ..FrameSettings::default()
    };
    let scene_gpu = SceneGpu::new(&ctx, &prepared.scene, &settings)?;
    let tech = technique::build(&ctx, &scene_gpu, a.technique, a.path, &prepared.inputs())?;
    let frame = scene_gpu.render(&tech, 0, 1)?;
    write_frame(&a.out, &frame, a.exposure)?;
    check_validation(&ctx, a.gpu.validate)?;
    println!("wrote {} ({})", a.out.display(), tech.label());
    Ok(())
}

fn run_reference(a: ReferenceArgs) -> Result<()> {
    check_output_extension(&a.out)?;
    let ctx = open_gpu(&a.gpu)?;
    let vis_res = bake::validate_res(a.vis_res)?;
    let env = shvis::env::resolve(&a.env)?;
    let scene = resolve_scene(&a.scene, vis_res)?;
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
        },
    )?;
    let (frame, noise) = match &image.bounced {
        Some(b) => (&b.frame, b.rel_noise),
        None => (&image.frame, image.rel_noise),
    };
    write_frame(&a.out, frame, a.exposure)?;
    check_validation(&ctx, a.gpu.validate)?;
    println!(
        "reference: {} spp, {} bounces, {:.1} M rays in {:.1} s; noise (relative standard error of the image) {:.4}",
        a.spp,
        a.bounces,
        image.rays as f64 / 1e6,
        image.seconds,
        noise
    );
    println!("wrote {}", a.out.display());
    Ok(())
}

fn check_output_extension(path: &Path) -> Result<()> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
    {
        Some(e) if e == "png" || e == "exr" => Ok(()),
        _ => Err(report::ReportError::Extension {
            path: path.to_path_buf(),
        }
        .into()),
    }
}

/// With `--validate`, any validation error or warning fails the command.
fn check_validation(ctx: &Context, validate: bool) -> Result<()> {
    let (errors, warnings) = ctx.message_counts();
    if validate && (errors > 0 || warnings > 0) {
        bail!("validation reported {errors} errors and {warnings} warnings (see the log above)");
    }
    Ok(())
}

fn parse_list<T: std::str::FromStr>(list: &str, all: &[T]) -> Result<Vec<T>>
where
    T: Copy,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    if list == "all" {
        return Ok(all.to_vec());
    }
    list.split(',')
        .map(|s| s.trim().parse::<T>().map_err(anyhow::Error::from))
        .collect()
}

fn run_bench(a: BenchArgs) -> Result<()> {
    let techniques = parse_list(&a.techniques, TechniqueId::ALL)?;
    let paths = parse_list(&a.paths, HwPath::ALL)?;
    create_dir(&a.out)?;
    let started = Instant::now();
    let with_shlmap = techniques.contains(&TechniqueId::Shlmap);
    let prepared: Prepared = prepare(&prepare_settings(
        &a.scene,
        &a.env,
        with_shlmap.then_some(a.bounces),
    )?)?;
    let ctx = open_gpu(&a.gpu)?;
    if !ctx.supports_timestamps() {
        bail!(
            "{}: the graphics queue has no timestamps, frames cannot be timed",
            ctx.device_name()
        );
    }
    let settings = FrameSettings {
        width: a.width,
        height: a.height,
        flat_normals: false,
        ..FrameSettings::default()
    };
    let reference = if a.ref_spp > 0 {
        let image = shvis::reference::render_reference(
            &ctx,
            &prepared.scene,
            &prepared.env,
            &shvis::reference::ReferenceSettings {
                width: a.width,
                height: a.height,
                spp: a.ref_spp,
                seed: a.scene.seed,
                bounces: if with_shlmap { a.bounces } else { 0 },
            },
        )?;
        log::info!(
            "reference: {} spp in {:.1} s, relative noise {:.4}",
            a.ref_spp,
            image.seconds,
            image.rel_noise
        );
        write_exr(&a.out.join("reference.exr"), &image.frame)?;
        write_png(&a.out.join("reference.png"), &image.frame, a.exposure)?;
        if let Some(b) = &image.bounced {
            log::info!(
                "reference with {} bounces: relative noise {:.4}",
                b.bounces,
                b.rel_noise
            );
            let name = format!("reference_bounces{}", b.bounces);
            write_exr(&a.out.join(format!("{name}.exr")), &b.frame)?;
            write_png(&a.out.join(format!("{name}.png")), &b.frame, a.exposure)?;
        }
        Some(image)
    } else {
        None
    };
    let scene_gpu = SceneGpu::new(&ctx, &prepared.scene, &settings)?;
    let mut rows = Vec::new();
    for &t in &techniques {
        for &p in &paths {
            let tech = technique::build(&ctx, &scene_gpu, t, p, &prepared.inputs())?;
            let frame = scene_gpu.render(&tech, a.warmup, a.frames)?;
            let stats = TimingStats::from_ms(&frame.ms);
            // shlmap models inter-reflection: it meets the reference that has it.
            let (reference_frame, reference_kind) = match &reference {
                None => (None, "none".to_string()),
                Some(r) => match (&r.bounced, t) {
                    (Some(b), TechniqueId::Shlmap) => {
                        (Some(&b.frame), format!("{} bounces", b.bounces))
                    }
                    _ => (Some(&r.frame), "direct".to_string()),
                },
            };
            let error =
                reference_frame.and_then(|r| shvis::report::metrics::image_error(&frame, r));
            if t == TechniqueId::Shlmap {
                if let Some(e) = reference
                    .as_ref()
                    .and_then(|r| shvis::report::metrics::image_error(&frame, &r.frame))
                {
                    log::info!(
                        "{}: relative RMSE against the direct-only reference {:.4}",
                        tech.label(),
                        e.rel_rmse
                    );
                }
            }
            write_png(
                &a.out.join(format!("{}.png", tech.label())),
                &frame,
                a.exposure,
            )?;
            write_exr(&a.out.join(format!("{}.exr", tech.label())), &frame)?;
            rows.push(BenchRow {
                technique: t.to_string(),
                path: p.to_string(),
                ms_median: stats.map(|s| s.ms_median),
                ms_min: stats.map(|s| s.ms_min),
                ms_max: stats.map(|s| s.ms_max),
                frames: frame.ms.len(),
                rel_rmse: error.map(|e| e.rel_rmse),
                psnr: error.map(|e| e.psnr),
                texel_bytes: tech.stats.texel_bytes,
                table_bytes: tech.stats.table_bytes,
                textures_bound: tech.stats.textures_bound,
                lookups_per_pixel: tech.stats.lookups_per_pixel,
                ratio_to_preconv: None,
                paper_ms: t.paper_ms(),
                paper_ratio_to_preconv: t.paper_ratio_to_preconv(),
                reference: reference_kind,
            });
        }
    }
    shvis::report::table::fill_ratios_to_preconv(&mut rows);
    let table = BenchTable {
        reference_spp: a.ref_spp,
        reference_rel_noise: reference.as_ref().map(|r| r.rel_noise),
        reference_bounces: reference
            .as_ref()
            .and_then(|r| r.bounced.as_ref())
            .map_or(0, |b| b.bounces),
        reference_bounced_rel_noise: reference
            .as_ref()
            .and_then(|r| r.bounced.as_ref())
            .map(|b| b.rel_noise),
        device: ctx.device_name().to_string(),
        width: a.width,
        height: a.height,
        vis_res: a.scene.vis_res,
        results: rows,
    };
    table.write(&a.out)?;
    for path in &paths {
        match shvis::report::plot::write_pca_error_plot(&table.results, path.name(), &a.out) {
            Ok(files) => files
                .iter()
                .for_each(|f| log::info!("wrote {}", f.display())),
            Err(e) => log::warn!("{e}"),
        }
    }
    match shvis::report::plot::write_speed_error_plot(&table, &a.out) {
        Ok(files) => files
            .iter()
            .for_each(|f| log::info!("wrote {}", f.display())),
        Err(e) => log::warn!("{e}"),
    }
    println!("{}", table.to_markdown());
    println!(
        "wrote {}/table.md, table.json and images in {:.1} s",
        a.out.display(),
        started.elapsed().as_secs_f64()
    );
    check_validation(&ctx, a.gpu.validate)?;
    Ok(())
}
