//! `shvis bench` and `shvis probe`: the cost table and the device's microbenchmarks.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;

use shvis::bench::BenchSettings;
use shvis::bench::plan::{Plan, duration};
use shvis::prepare::prepare_with;
use shvis::technique::HwPath;

use super::args::{
    BakerArgs, GpuArgs, NormalFilterArg, SceneArgs, SpecularArgs, at_least_one_f64, finite_degrees,
    finite_f32, with_normal_filter,
};
use super::{
    DEFAULT_EXPOSURE_EV, MAX_BOUNCES, MAX_FRAME_SIDE, OUT_FOLDER, RunInputs, check_frame_memory,
    check_rows, clear_earlier_files, clear_earlier_run, create_dir, parse_list, parse_techniques,
    prepare_settings, print_table, print_written, with_gpu,
};

#[derive(Args, Debug)]
pub(super) struct ProbeArgs {
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
    /// Screen area of the probe's triangles, pixels, at most half the screen (default: the built-in house's
    /// pixel-weighted triangle area at this size, as `shvis bench` sizes them for its scene).
    #[arg(long, value_parser = at_least_one_f64)]
    triangle_pixels: Option<f64>,
    /// Output directory (probe.md, probe.json).
    #[arg(short, long, default_value = "probe-out")]
    out: PathBuf,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct BenchArgs {
    #[arg(help_heading = "Rows", long, default_value = "sky")]
    env: String,
    /// A named set — `headline` (the paper's table and rows of each later family),
    /// `paper` (the paper's table), `all` (every row) — given alone, or a comma-separated list
    /// of names (`shvis techniques`).
    #[arg(help_heading = "Rows", long, default_value = "headline")]
    techniques: String,
    /// Comma-separated hardware paths (`dx9`, `dx10`, `dx11`); with `--techniques
    /// headline`, `dx11` measures `shlmap` and `unc6` only.
    #[arg(help_heading = "Rows", long, default_value = "dx9,dx10")]
    paths: String,
    /// How unc* and preconv read the normal map: `mip` (its MIP chain of averaged normals)
    /// or `ndf` (filtered as a distribution, Olano & North: the techniques' `…ndf`
    /// variants; the other techniques have none and stay as they are).
    #[arg(help_heading = "Rows", long, value_enum, default_value_t = NormalFilterArg::Mip)]
    normal_filter: NormalFilterArg,
    /// Timed frames per technique × path (after the warm-up).
    #[arg(help_heading = "Frames and timing", long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: u32,
    /// Untimed warm-up frames per technique × path.
    #[arg(help_heading = "Frames and timing", long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(0..=10_000))]
    warmup: u32,
    #[arg(help_heading = "Frames and timing", long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    width: u32,
    #[arg(help_heading = "Frames and timing", long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(1..=MAX_FRAME_SIDE as i64))]
    height: u32,
    /// Exposure in EV of the PNG images.
    #[arg(help_heading = "Output", long, default_value_t = DEFAULT_EXPOSURE_EV, allow_hyphen_values = true, value_parser = finite_f32)]
    exposure: f32,
    /// Samples per pixel of the reference the errors are measured against (0: no errors);
    /// at most `reference --ref-spp`'s limit.
    #[arg(help_heading = "Reference and errors", long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
    ref_spp: u32,
    /// Measure against the point-sampled reference (the techniques' own pixel sampling)
    /// instead of the footprint reference.
    #[arg(help_heading = "Reference and errors", long)]
    point_reference: bool,
    /// Bounces of inter-reflection in shlmap's and the nmprt* transfer bakes and in the
    /// reference they are measured against (the other techniques model direct light and
    /// meet the direct reference).
    #[arg(help_heading = "Reference and errors", long, default_value_t = shvis::bake::shlmap::DEFAULT_BOUNCES, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Leave out the device probe and the rows' model columns.
    #[arg(help_heading = "Frames and timing", long)]
    no_probe: bool,
    /// Timed frames per microbenchmark of the device probe (default: `--frames`, within
    /// 5–30); fewer measure faster and fit the model less closely.
    #[arg(help_heading = "Frames and timing", long, value_parser = clap::value_parser!(u32).range(1..=1_000), conflicts_with = "no_probe")]
    probe_frames: Option<u32>,
    /// The device probe: `cached` reuses one measured before on this device, driver and
    /// build with the same settings (in the bake cache's folder), `fresh` measures again.
    #[arg(help_heading = "Frames and timing", long, value_enum, default_value_t = ProbeMode::Cached, conflicts_with = "no_probe")]
    probe: ProbeMode,
    /// The error ladder evaluates every Nth pixel in each direction and measures each of
    /// its steps at those pixels (1: every pixel; default 2; the rung images are 1/N of the frame's width and height).
    #[arg(help_heading = "Reference and errors", long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=16))]
    ladder_stride: Option<u32>,
    /// Leave out, with a note, technique × path pairs that cannot run (`nmprtsvdMp` on dx9)
    /// instead of failing.
    #[arg(help_heading = "Rows", long)]
    skip_unsupported: bool,
    /// Exit non-zero when a row is suspect (non-finite pixels, an error above 1, or a mean
    /// 25 % off its reference's); the table and images are written first either way.
    #[arg(help_heading = "Reference and errors", long)]
    strict: bool,
    /// Measure under the environment turned DEG degrees about +Y after the bake:
    /// references under the turned map, techniques with dynamic lighting relit to it
    /// through their lighting update, baked ones (shlmap, rnm*) as baked. No error ladder.
    #[arg(help_heading = "Frames and timing", long, value_name = "DEG", allow_hyphen_values = true, value_parser = finite_degrees)]
    relight_rotate: Option<f64>,
    /// Output directory.
    #[arg(help_heading = "Output", short, long, default_value = "bench-out")]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    baker: BakerArgs,
    #[command(flatten)]
    gpu: GpuArgs,
    #[command(flatten)]
    specular: SpecularArgs,
}

pub(super) fn run_probe(a: ProbeArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 48)?;
    let half_screen = f64::from(a.width) * f64::from(a.height) / 2.0;
    if let Some(px) = a.triangle_pixels.filter(|&px| px > half_screen) {
        bail!(
            "--triangle-pixels {px}: at most {half_screen} at {}×{} (two triangles fill the screen)",
            a.width,
            a.height
        );
    }
    create_dir(&a.out)?;
    with_gpu(&a.gpu, |ctx| {
        let probe = shvis::probe::run(
            ctx,
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
                progress: true,
            },
        )?;
        out!("{}", probe.to_markdown());
        print_written(&shvis::report::write_probe(&probe, &a.out)?)?;
        Ok(())
    })
}

/// Refuses the reference options that would do nothing: `--point-reference` without a
/// reference (`--ref-spp 0`), and `--ladder-stride` where the error ladder does not run
/// (`shvis::bench::BenchSettings`'s ladder: a footprint reference, not relit, no specular
/// term).
fn check_reference_options(a: &BenchArgs) -> Result<()> {
    if a.ref_spp == 0 && a.point_reference {
        bail!(
            "--point-reference picks the reference the errors are measured against: not with --ref-spp 0 (no reference)"
        );
    }
    if a.ladder_stride.is_none() {
        return Ok(());
    }
    let no_ladder = if a.ref_spp == 0 {
        Some("--ref-spp 0 (no reference)")
    } else if a.point_reference {
        Some("--point-reference (the ladder starts from the footprint reference)")
    } else if a.relight_rotate.is_some() {
        Some("--relight-rotate")
    } else if !a.specular.specular.is_empty() {
        Some("--specular")
    } else {
        None
    };
    match no_ladder {
        Some(why) => {
            bail!("--ladder-stride sets the error ladder's grid: there is no ladder with {why}")
        }
        None => Ok(()),
    }
}

/// Whether a bench reuses a cached device probe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum ProbeMode {
    /// Reuse the probe measured before on this device, driver and build, if there is one.
    Cached,
    /// Measure it again.
    Fresh,
}

pub(super) fn run_bench(a: BenchArgs) -> Result<()> {
    a.baker.check()?;
    check_reference_options(&a)?;
    check_frame_memory(a.width, a.height, 320)?;
    let mut settings = BenchSettings {
        techniques: with_normal_filter(parse_techniques(&a.techniques)?, a.normal_filter),
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
        probe_fresh: a.probe == ProbeMode::Fresh,
        probe_frames: a.probe_frames.unwrap_or(a.frames.clamp(5, 30)),
        relight_degrees: a.relight_rotate,
        ladder: true,
        ladder_stride: a
            .ladder_stride
            .unwrap_or(shvis::bench::DEFAULT_LADDER_STRIDE),
        dx11_rows: (a.techniques.trim() == "headline")
            .then(|| shvis::technique::catalog::headline_on(HwPath::Dx11)),
    };
    check_rows(
        &a.techniques,
        &settings.techniques,
        &settings.paths,
        a.skip_unsupported,
    )?;
    if a.relight_rotate.is_some() && !a.specular.specular.is_empty() {
        bail!("--relight-rotate: not with --specular (its light is the bake's sun)");
    }
    RunInputs::of_scene(&a.scene)
        .env("--env", &a.env)
        .check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    shvis::files::remove_stale_temps(&a.out);
    let started = Instant::now();
    let prepare_settings = prepare_settings(&a.scene, &a.env, &settings.techniques, a.bounces)?;
    // The device before the bake: a missing GPU should not cost one, and `--baker gpu`
    // bakes on it.
    with_gpu(&a.gpu, |ctx| {
        let scene =
            shvis::prepare::resolve_scene(&prepare_settings.scene, prepare_settings.vis_res)?;
        let cached_probe = shvis::bench::cached_probe(ctx, &settings, &scene);
        drop(scene);
        let plan = Plan::new(
            ctx,
            &settings,
            a.specular.specular.len(),
            &prepare_settings,
            cached_probe,
        );
        for line in plan.describe(&settings).lines() {
            log::info!("{line}");
        }
        let bakes_started = Instant::now();
        let mut prepared = prepare_with(&prepare_settings, &a.baker.visibility_baker(ctx))?;
        prepared.prepare_techniques(&settings.techniques)?;
        let bake_seconds = bakes_started.elapsed().as_secs_f64();
        settings.specular = a.specular.settings(&prepared.env)?;
        if shvis::technique::catalog::named_set(a.techniques.trim()).is_some() {
            // The whole table on a scene without a height map: the rows that need one are
            // left out (named explicitly they fail with the reason).
            let dropped = shvis::bench::rows::drop_rows_without_height_map(
                &mut settings.techniques,
                &prepared,
            );
            if !dropped.is_empty() {
                let names: Vec<String> = dropped.iter().map(|t| t.name()).collect();
                note!(
                    "note: scene '{}' has no height map (--height-map): leaving out {}",
                    prepared.scene.name,
                    names.join(", ")
                );
            }
        }
        // Inputs, device and bakes are good: the earlier run's report goes only now.
        clear_earlier_run(
            &a.out,
            &[
                "table.md",
                "table.json",
                shvis::report::html::INDEX_NAME,
                "probe.md",
                "probe.json",
            ],
        );
        clear_earlier_files(&a.out, shvis::report::bench_output::is_bench_image);
        let _ = std::fs::remove_dir_all(a.out.join(shvis::report::LADDER_DIR));
        let table = shvis::bench::run(ctx, &prepared, &settings)?;
        plan.record(&table, bake_seconds);
        note!(
            "bench: {} in all (the plan said about {})",
            duration(started.elapsed().as_secs_f64()),
            duration(plan.estimate_seconds())
        );
        print_table(
            &table.to_markdown(),
            &a.out,
            "table.md, table.json",
            started,
        )?;
        let suspect: Vec<String> = table
            .results
            .iter()
            .filter_map(|r| Some(format!("{}.{} ({})", r.name(), r.path, r.suspect.as_ref()?)))
            .collect();
        if a.strict && !suspect.is_empty() {
            bail!(
                "--strict: {} suspect row(s): {}",
                suspect.len(),
                suspect.join(", ")
            );
        }
        Ok(())
    })
}
