//! `shvis view` and `shvis relight`: the scene under moving light.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;

use shvis::technique::{HwPath, Technique};

use super::args::{GpuArgs, SceneArgs, finite_f32, finite_f64};
use super::{
    DEFAULT_EXPOSURE_EV, MAX_FRAME_SIDE, OUT_FOLDER, RunInputs, check_frame_memory, check_rows,
    check_validation, clear_earlier_files, clear_earlier_run, create_dir, parse_list,
    parse_techniques, prepare_for, print_table, with_gpu,
};

#[derive(Args, Debug)]
pub(super) struct ViewArgs {
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
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

#[derive(Args, Debug)]
pub(super) struct RelightArgs {
    #[arg(long, default_value = "sky")]
    env: String,
    /// A named set (`headline`, `paper`, `all`), given alone, or a comma-separated list of
    /// technique names (shlmap's lighting is baked in: it is reported, not run).
    #[arg(long, default_value = "unc3,unc4,unc6,pca4,pca16,pca16w,sh2,preconv")]
    techniques: String,
    #[arg(long, default_value = "dx9,dx10")]
    paths: String,
    /// Leave out, with a note, technique × path pairs that cannot run (`nmprtsvdMp` on dx9)
    /// instead of failing.
    #[arg(long)]
    skip_unsupported: bool,
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
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true, value_parser = finite_f64)]
    turns: f64,
    /// Cross-fade from --env to this environment over the run (time of day).
    #[arg(long)]
    fade_to: Option<String>,
    /// Frames at which errors are measured.
    #[arg(long = "error-frames", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
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
    #[arg(short, long, default_value = "relight-out")]
    out: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    gpu: GpuArgs,
}

/// The most full turns `relight --turns` takes (more only repeats the same lighting).
const MAX_TURNS: f64 = 1000.0;

/// `shvis view`: the window opens its own presenting device (`shvis::view::run`), which
/// reports its validation counts.
pub(super) fn run_view(a: ViewArgs) -> Result<()> {
    check_frame_memory(a.width, a.height, 48)?;
    if let Some(shot) = &a.screenshot {
        if shot.extension().and_then(|e| e.to_str()) != Some("png") {
            bail!(
                "{}: --screenshot writes PNG; name a .png file",
                shot.display()
            );
        }
        shvis::files::check_writable_file(shot, "--screenshot")?;
        RunInputs::of_scene(&a.scene)
            .env("--env", &a.env)
            .check_spared_by(&[("--screenshot".to_string(), shot.clone())])?;
    }
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
        bail!(
            "no display to open a window on (DISPLAY is not set): run under `xvfb-run -a shvis view …`, or use `shvis render` / `shvis bench`"
        );
    }
    let techniques: Vec<Technique> = parse_techniques(&a.techniques)?;
    let prepared = prepare_for(
        &a.scene,
        &a.env,
        &techniques,
        shvis::bake::shlmap::DEFAULT_BOUNCES,
    )?;
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
    out!("{}", report.summary().trim_end_matches('\n'));
    let (errors, warnings) = report.validation;
    check_validation(a.gpu.validate, errors, warnings)
}

pub(super) fn run_relight(a: RelightArgs) -> Result<()> {
    // The frame targets, and a technique's frames kept (3 bytes a pixel) for its animation.
    shvis::limits::check_memory(
        format_args!(
            "--frames {} at --width {} × --height {}: the animation's frames",
            a.frames, a.width, a.height
        ),
        shvis::limits::image_bytes(u64::from(a.width), u64::from(a.height), 320).saturating_add(
            shvis::limits::image_bytes(
                u64::from(a.width),
                u64::from(a.height),
                3u64.saturating_mul(u64::from(a.frames)),
            ),
        ),
        "lower --frames, --width or --height",
    )?;
    if !(a.turns.is_finite() && a.turns.abs() <= MAX_TURNS) {
        bail!("--turns {:?} must be a number within ±{MAX_TURNS}", a.turns);
    }
    let settings = shvis::relight::RelightSettings {
        techniques: parse_techniques(&a.techniques)?,
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
    check_rows(
        &a.techniques,
        &settings.techniques,
        &settings.paths,
        a.skip_unsupported,
    )?;
    if !settings.techniques.iter().any(|t| t.dynamic_lighting()) {
        bail!(
            "--techniques {}: no technique listed follows a changing environment (their lighting is baked into the lightmap): nothing to measure",
            a.techniques
        );
    }
    let mut inputs = RunInputs::of_scene(&a.scene).env("--env", &a.env);
    if let Some(fade) = &a.fade_to {
        inputs = inputs.env("--fade-to", fade);
    }
    inputs.check_outside(&a.out, OUT_FOLDER)?;
    create_dir(&a.out)?;
    shvis::files::remove_stale_temps(&a.out);
    let started = Instant::now();
    let prepared = prepare_for(
        &a.scene,
        &a.env,
        &settings.techniques,
        shvis::bake::shlmap::DEFAULT_BOUNCES,
    )?;
    with_gpu(&a.gpu, |ctx| {
        // Inputs, device and bakes are good: the earlier run's report goes only now.
        clear_earlier_run(&a.out, &["relight.md", "relight.json"]);
        clear_earlier_files(&a.out, shvis::relight::is_relight_image);
        let table = shvis::relight::run(ctx, &prepared, &settings)?;
        print_table(
            &table.to_markdown(),
            &a.out,
            "relight.md, relight.json",
            started,
        )?;
        Ok(())
    })
}
