//! `shvis relight`: the environment turns about +Y over the run
//! ([`crate::env::schedule`]) and every technique with dynamic lighting follows it.
//!
//! With `--fade-to ENV` the environment also cross-fades to a second one over the run
//! (time of day; the SH blended, the references' maps blended texel by texel).
//!
//! Per technique × path the technique is built once with two copies of its lighting data
//! (`technique::build_dynamic`: the per-texel bake data is uploaded once and never again).
//! Every K frames (`every`) its lighting data — L×H or T_k tables, uniforms
//! (`technique::lighting`) — is rebuilt for the schedule's SH at that frame:
//!
//! - **overlapped** (default): a worker thread builds it on the CPU while the frame loop
//!   keeps drawing with the front copy; at the first frame after the build finished, the
//!   loop writes the back copy's uniforms, submits the staging copy of its tables without
//!   waiting (`gpu::PendingUpload`) and makes it the front copy — the GPU orders the
//!   frame after the copy. Frames never wait for a build or a copy; the lighting a frame
//!   shows is at least one frame old (`swap latency`);
//! - **blocking** (`--blocking-upload`): build, upload and wait between two frames.
//!
//! Each frame is rendered and timed. At a few sampled frames the image is compared with the
//! point-sampled reference of the environment rotated to that frame (the map resampled,
//! `EnvMap::sample_bilinear`), and with the same technique built for that frame's exact
//! lighting: the **static** error at the same lighting and the **lag** error of data that
//! is `lag_frames` old are reported separately.
//!
//! Writes `relight.md`, `relight.json`, the sampled frames and their references (PNG), and
//! one animated PNG per technique × path of the whole run.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use crate::env::EnvMap;
use crate::env::schedule::{LightingSchedule, rotation_about_y};
use crate::gpu::TimingStats;
use crate::gpu::{Context, GpuError};
use crate::prepare::Prepared;
use crate::reference::{ReferenceSettings, render_reference};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::report::image::{to_srgb8, write_png};
use crate::report::metrics::image_error;
use crate::sh::Order;
use crate::sh::zonal::irradiance_from_radiance;
use crate::technique::{self, HwPath, Inputs, LightingData, Technique, TechniqueError};

/// What a relight run does.
#[derive(Clone, Debug, PartialEq)]
pub struct RelightSettings {
    pub techniques: Vec<Technique>,
    pub paths: Vec<HwPath>,
    /// Frames of the run (one full turn of `turns` over them).
    pub frames: u32,
    /// Rebuild the lighting-dependent data every this many frames (≥ 1).
    pub every: u32,
    /// How updates reach the GPU.
    pub upload: UploadMode,
    /// Full turns of the environment over the run.
    pub turns: f64,
    /// An environment cross-faded to over the run (time of day), if any.
    pub fade_to: Option<EnvMap>,
    /// Frames at which errors are measured (spread over the run).
    pub samples: u32,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of each sampled frame's reference.
    pub ref_spp: u32,
    pub seed: u64,
    pub exposure: f32,
    pub out: PathBuf,
}

/// How the lighting data is rebuilt and uploaded during the frame loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum UploadMode {
    /// The CPU build runs on a worker thread while frames keep drawing with the front set;
    /// its upload is submitted without waiting and swapped in when the GPU has copied it.
    Overlapped,
    /// Build, upload and wait between two frames (the baseline that stalls the loop).
    Blocking,
}

impl std::fmt::Display for UploadMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            UploadMode::Overlapped => "overlapped",
            UploadMode::Blocking => "blocking",
        })
    }
}

/// Errors of a relight run.
#[derive(Debug, thiserror::Error)]
pub enum RelightError {
    #[error("relight: {0}")]
    Settings(String),
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Errors at one sampled frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SampledFrame {
    pub frame: u32,
    /// Rotation of the environment at this frame, degrees.
    pub degrees: f64,
    /// Frames since the data was last rebuilt.
    pub lag_frames: u32,
    /// The run's image against the reference.
    pub rel_rmse: Option<f64>,
    /// The technique built for this frame's exact lighting, against the reference.
    pub static_rel_rmse: Option<f64>,
    /// The run's image against that static image: what the lag costs.
    pub lag_rel_rmse: Option<f64>,
}

/// One technique × path of the run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelightRow {
    pub technique: Technique,
    pub path: HwPath,
    /// Updates of the lighting-dependent data swapped in during the run.
    pub updates: u32,
    /// Rebuilds due while the previous one was still being built (overlapped mode).
    pub skipped_updates: u32,
    /// Median ms of one CPU build of the lighting data (tables, uniforms).
    pub cpu_build_ms_median: Option<f64>,
    /// Median ms the frame loop spent on one upload: writing the uniforms, staging the
    /// tables and submitting their copy (blocking mode: and waiting for it).
    pub upload_ms_median: Option<f64>,
    /// Median frames from a rebuild's request to the first frame drawing it (0 in blocking
    /// mode).
    pub swap_latency_frames_median: Option<f64>,
    /// Bytes one update uploads (uniforms, tables, per-texel data formed from the lighting).
    pub table_bytes: u64,
    /// GPU ms per frame over the run (timestamps).
    pub gpu_ms_median: Option<f64>,
    pub gpu_ms_min: Option<f64>,
    pub gpu_ms_max: Option<f64>,
    pub sampled: Vec<SampledFrame>,
    /// Pixels the f16 target clipped at 65504 (or that were not finite), over every frame
    /// of the run and the sampled frames' static images: the lighting is too bright for the
    /// target, and the row's errors measure the clipping (a warning says so).
    pub clipped_pixels: u64,
}

/// The run's table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelightTable {
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    pub every: u32,
    pub upload: UploadMode,
    pub turns: f64,
    /// Whether the run cross-faded to a second environment.
    pub faded: bool,
    pub reference_spp: u32,
    pub results: Vec<RelightRow>,
    /// Techniques asked for whose lighting is baked in (`shlmap`): not run.
    pub static_only: Vec<Technique>,
}

impl RelightTable {
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "device: {} · {}×{} · {} frames, {} turn(s){}, lighting data rebuilt every {} frames, {} upload · references {} spp (point-sampled)\n\n",
            self.device,
            self.width,
            self.height,
            self.frames,
            self.turns,
            if self.faded {
                " and a cross-fade to a second environment"
            } else {
                ""
            },
            self.every,
            self.upload,
            self.reference_spp
        );
        s += "| technique | path | updates | KiB per update | CPU build ms | upload ms | swap latency (frames) | GPU ms median | min | max | sampled frames: error (static, lag) |\n";
        s += "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
        let opt = |v: Option<f64>, d: usize| v.map_or("—".to_string(), |v| format!("{v:.d$}"));
        for r in &self.results {
            let sampled: Vec<String> = r
                .sampled
                .iter()
                .map(|f| {
                    format!(
                        "f{} {:.0}°: {} ({}, {})",
                        f.frame,
                        f.degrees,
                        opt(f.rel_rmse, 4),
                        opt(f.static_rel_rmse, 4),
                        opt(f.lag_rel_rmse, 4)
                    )
                })
                .collect();
            let updates = match r.skipped_updates {
                0 => r.updates.to_string(),
                n => format!("{} ({n} skipped)", r.updates),
            };
            s += &format!(
                "| {} | {} | {} | {:.1} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.technique,
                r.path,
                updates,
                r.table_bytes as f64 / 1024.0,
                opt(r.cpu_build_ms_median, 2),
                opt(r.upload_ms_median, 2),
                opt(r.swap_latency_frames_median, 0),
                opt(r.gpu_ms_median, 3),
                opt(r.gpu_ms_min, 3),
                opt(r.gpu_ms_max, 3),
                sampled.join(" · ")
            );
        }
        for t in &self.static_only {
            s += &format!(
                "\n{t}: its lighting is baked into the lightmap; it cannot follow a changing environment and was not run.\n"
            );
        }
        s
    }
}

/// The sampled frames: `samples` frames spread over the run, midway between rebuilds
/// where possible (so the lag shows).
pub fn sampled_frames(frames: u32, samples: u32, every: u32) -> Vec<u32> {
    let mut out: Vec<u32> = (0..samples)
        .map(|i| {
            let f = ((f64::from(i) + 0.5) * f64::from(frames) / f64::from(samples.max(1))) as u32;
            (f - f % every + every / 2).min(frames.saturating_sub(1))
        })
        .collect();
    out.dedup();
    out
}

/// The environment of the schedule's `frame` as a map, for its reference: `env` faded
/// towards `to` by the schedule's weight, turned by its angle about +Y (g(ω) = f(Rᵀω), as
/// `sh::rotate`), at `env`'s resolution.
fn scheduled_env(
    env: &EnvMap,
    to: Option<&EnvMap>,
    schedule: &LightingSchedule,
    frame: u32,
) -> EnvMap {
    let r = rotation_about_y(schedule.angle(frame)).transpose();
    let t = schedule.fade(frame) as f32;
    EnvMap::from_fn(env.width, env.height, |d| {
        let a = env.sample_bilinear(r * d);
        match to {
            Some(to) if t > 0.0 => {
                let b = to.sample_bilinear(r * d);
                std::array::from_fn(|c| (1.0 - t) * a[c] + t * b[c])
            }
            _ => a,
        }
    })
}

/// Runs the schedule (module doc) and writes its files into `settings.out` (must exist).
pub fn run(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    settings: &RelightSettings,
) -> Result<RelightTable, RelightError> {
    if settings.frames == 0 || settings.every == 0 {
        return Err(RelightError::Settings(
            "--frames and --every must be at least 1".into(),
        ));
    }
    let order = Order::new((prepared.radiance_sh.len() as f64).sqrt() as u32)
        .map_err(|e| RelightError::Settings(e.to_string()))?;
    let mut schedule = LightingSchedule::rotating(
        order,
        prepared.radiance_sh.clone(),
        settings.turns,
        settings.frames,
    );
    if let Some(to) = &settings.fade_to {
        // Time of day: from the scene's environment to `to` over the whole run.
        schedule.to = Some(crate::env::project::project_sh(to, order));
        schedule.fade_frames = settings.frames.saturating_sub(1);
    }
    let scene = SceneGpu::new(
        ctx,
        &prepared.scene,
        &FrameSettings {
            width: settings.width,
            height: settings.height,
            ..FrameSettings::default()
        },
    )?;
    let sampled = sampled_frames(settings.frames, settings.samples, settings.every);
    // References of the sampled frames' lighting.
    let mut references = Vec::new();
    for &f in &sampled {
        let env = scheduled_env(&prepared.env, settings.fade_to.as_ref(), &schedule, f);
        let reference = render_reference(
            ctx,
            &prepared.scene,
            &env,
            &ReferenceSettings {
                width: settings.width,
                height: settings.height,
                spp: settings.ref_spp,
                seed: settings.seed,
                bounces: 0,
                footprint: false,
            },
        )?;
        write_png(
            &settings.out.join(format!("reference.f{f}.png")),
            &reference.frame,
            settings.exposure,
        )?;
        log::info!(
            "relight: reference at frame {f} in {:.1} s (noise {:.4})",
            reference.seconds,
            reference.rel_noise
        );
        references.push(reference.frame);
    }
    let mut rows = Vec::new();
    let mut static_only = Vec::new();
    for &technique in &settings.techniques {
        if !technique.dynamic_lighting() {
            static_only.push(technique);
            continue;
        }
        for &path in settings.paths.iter().filter(|&&p| technique.runs_on(p)) {
            rows.push(run_row(
                ctx,
                &scene,
                prepared,
                &schedule,
                technique,
                path,
                &sampled,
                &references,
                settings,
            )?);
        }
    }
    let table = RelightTable {
        device: ctx.device_name().to_string(),
        width: settings.width,
        height: settings.height,
        frames: settings.frames,
        every: settings.every,
        upload: settings.upload,
        turns: settings.turns,
        faded: settings.fade_to.is_some(),
        reference_spp: settings.ref_spp,
        results: rows,
        static_only,
    };
    let write = |name: &str, text: String| -> Result<(), ReportError> {
        let path = settings.out.join(name);
        crate::files::write(&path, text).map_err(|e| ReportError::Write {
            path,
            detail: e.to_string(),
        })
    };
    write("relight.md", table.to_markdown())?;
    let json = serde_json::to_string_pretty(&table).map_err(|e| ReportError::Write {
        path: settings.out.join("relight.json"),
        detail: e.to_string(),
    })?;
    write("relight.json", json + "\n")?;
    Ok(table)
}

/// The lighting inputs of `prepared` with radiance `radiance_sh` (irradiance derived).
fn with_lighting<'a>(
    prepared: &'a Prepared,
    radiance_sh: &'a [[f64; 3]],
    irradiance_sh: &'a [[f64; 3]],
) -> Inputs<'a> {
    Inputs {
        radiance_sh,
        irradiance_sh,
        ..prepared.inputs()
    }
}

/// Lighting and its order-3 irradiance at `frame` of `schedule`.
fn lighting_at(schedule: &LightingSchedule, frame: u32) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let radiance = schedule.at(frame);
    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
    (radiance, irradiance)
}

/// What the frame loop measured of the lighting updates.
#[derive(Default)]
struct UpdateTimes {
    cpu_ms: Vec<f64>,
    upload_ms: Vec<f64>,
    /// Frames from each rebuild's request to its swap.
    latency: Vec<f64>,
    /// Rebuild requests dropped because the previous one was still being built.
    skipped: u32,
}

/// A CPU build running on the worker: the frame whose lighting it builds, and its result
/// with the build's ms.
type Building<'s> = (
    u32,
    std::thread::ScopedJoinHandle<'s, Result<(LightingData, f64), TechniqueError>>,
);

#[allow(clippy::too_many_arguments)]
fn run_row(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    prepared: &Prepared,
    schedule: &LightingSchedule,
    technique: Technique,
    path: HwPath,
    sampled: &[u32],
    references: &[Frame],
    settings: &RelightSettings,
) -> Result<RelightRow, RelightError> {
    let label = format!("{technique}.{path}");
    let (radiance, irradiance) = lighting_at(schedule, 0);
    let (mut tech, recipe) = technique::build_dynamic(
        ctx,
        scene,
        technique,
        path,
        &with_lighting(prepared, &radiance, &irradiance),
    )?;
    let recipe = &recipe;
    let build_cpu = move |frame: u32| -> Result<(LightingData, f64), TechniqueError> {
        let start = Instant::now();
        let (radiance, irradiance) = lighting_at(schedule, frame);
        let data = recipe.build(&radiance, &irradiance)?;
        Ok((data, start.elapsed().as_secs_f64() * 1e3))
    };
    let mut times = UpdateTimes::default();
    let (mut gpu_ms, mut frames_srgb, mut sampled_rows) = (Vec::new(), Vec::new(), Vec::new());
    let mut clipped_pixels = 0u64;
    // The frame whose lighting the front set holds.
    let mut in_use = 0u32;
    std::thread::scope(|scope| -> Result<(), RelightError> {
        let mut building: Option<Building<'_>> = None;
        for f in 0..settings.frames {
            let due = f > 0 && f % settings.every == 0;
            match settings.upload {
                UploadMode::Blocking if due => {
                    let (data, cpu_ms) = build_cpu(f)?;
                    let start = Instant::now();
                    tech.update_lighting(&data)?;
                    tech.wait_for_upload()?;
                    times.upload_ms.push(start.elapsed().as_secs_f64() * 1e3);
                    times.cpu_ms.push(cpu_ms);
                    times.latency.push(0.0);
                    in_use = f;
                }
                UploadMode::Blocking => {}
                UploadMode::Overlapped => {
                    // A finished build goes up at once (the frame below draws it)…
                    if building.as_ref().is_some_and(|(_, h)| h.is_finished()) {
                        let (requested, handle) = building.take().expect("checked above");
                        let (data, cpu_ms) = handle.join().map_err(|_| {
                            RelightError::Settings(format!("{label}: the table build panicked"))
                        })??;
                        let start = Instant::now();
                        tech.update_lighting(&data)?;
                        times.upload_ms.push(start.elapsed().as_secs_f64() * 1e3);
                        times.cpu_ms.push(cpu_ms);
                        times.latency.push(f64::from(f - requested));
                        in_use = requested;
                    }
                    // …and a due rebuild starts on the worker unless one is running.
                    if due {
                        if building.is_some() {
                            times.skipped += 1;
                        } else {
                            building = Some((f, scope.spawn(move || build_cpu(f))));
                        }
                    }
                }
            }
            let frame = tech.render(scene, 0, 1)?;
            clipped_pixels += frame.clipped_pixels();
            gpu_ms.extend_from_slice(&frame.ms);
            frames_srgb.push(to_srgb8(&frame, settings.exposure));
            if let Some(k) = sampled.iter().position(|&s| s == f) {
                write_png(
                    &settings.out.join(format!("{label}.f{f}.png")),
                    &frame,
                    settings.exposure,
                )?;
                let (radiance, irradiance) = lighting_at(schedule, f);
                let exact = technique::build(
                    ctx,
                    scene,
                    technique,
                    path,
                    &with_lighting(prepared, &radiance, &irradiance),
                )?;
                let static_frame = exact.render(scene, 0, 1)?;
                clipped_pixels += static_frame.clipped_pixels();
                let reference = &references[k];
                sampled_rows.push(SampledFrame {
                    frame: f,
                    degrees: schedule.angle(f).to_degrees(),
                    lag_frames: f - in_use,
                    rel_rmse: image_error(&frame, reference).map(|e| e.rel_rmse),
                    static_rel_rmse: image_error(&static_frame, reference).map(|e| e.rel_rmse),
                    lag_rel_rmse: image_error(&frame, &static_frame).map(|e| e.rel_rmse),
                });
            }
        }
        // A build still running at the end is joined (its result unused).
        if let Some((_, handle)) = building.take() {
            let _ = handle.join();
        }
        tech.wait_for_upload()?;
        Ok(())
    })?;
    let table_bytes = tech.update_bytes();
    drop(tech);
    write_apng(
        &settings.out.join(format!("{label}.apng.png")),
        settings.width,
        settings.height,
        &frames_srgb,
    )?;
    let timing = TimingStats::from_ms(&gpu_ms);
    if clipped_pixels > 0 {
        log::warn!(
            "{label}: {clipped_pixels} pixels clipped at the f16 target's 65504 (or not finite) over the run: the environment is too bright for this target; scale it down"
        );
    }
    log::info!("relight: {label} done");
    Ok(RelightRow {
        technique,
        path,
        updates: times.cpu_ms.len() as u32,
        skipped_updates: times.skipped,
        cpu_build_ms_median: median(&mut times.cpu_ms),
        upload_ms_median: median(&mut times.upload_ms),
        swap_latency_frames_median: median(&mut times.latency),
        table_bytes,
        gpu_ms_median: timing.map(|t| t.ms_median),
        gpu_ms_min: timing.map(|t| t.ms_min),
        gpu_ms_max: timing.map(|t| t.ms_max),
        sampled: sampled_rows,
        clipped_pixels,
    })
}

/// Median of `values` (sorted in place), `None` when empty.
fn median(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// Whether `name` is one of the images a relight run writes: `{label}.f{N}.png` (a frame of
/// a technique or of the reference) or `{label}.apng.png` (its animation).
pub fn is_relight_image(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".png") else {
        return false;
    };
    if stem.ends_with(".apng") {
        return true;
    }
    stem.rsplit_once(".f").is_some_and(|(label, frame)| {
        !label.is_empty() && !frame.is_empty() && frame.bytes().all(|b| b.is_ascii_digit())
    })
}

/// An animated PNG of 8-bit sRGB frames at 12 frames per second, looping.
fn write_apng(path: &Path, width: u32, height: u32, frames: &[Vec<u8>]) -> Result<(), ReportError> {
    let err = |e: png::EncodingError| ReportError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    };
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_animated(frames.len() as u32, 0).map_err(err)?;
    encoder.set_frame_delay(1, 12).map_err(err)?;
    let mut writer = encoder.write_header().map_err(err)?;
    for frame in frames {
        writer.write_image_data(frame).map_err(err)?;
    }
    writer.finish().map_err(err)?;
    crate::report::image::write_file(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relight_images_are_told_from_other_files() {
        for ours in ["unc6.dx10.f4.png", "reference.f12.png", "pca8.dx9.apng.png"] {
            assert!(is_relight_image(ours), "{ours}");
        }
        for theirs in [
            "relight.md",
            "photo.png",
            "notes.f.png",
            "x.fa1.png",
            ".f3.png",
            "a.f3.exr",
        ] {
            assert!(!is_relight_image(theirs), "{theirs}");
        }
    }

    #[test]
    fn sampled_frames_sit_between_rebuilds() {
        assert_eq!(sampled_frames(48, 4, 8), vec![4, 20, 28, 44]);
        assert_eq!(sampled_frames(10, 3, 1), vec![1, 5, 8]);
        assert!(sampled_frames(48, 4, 8).iter().all(|f| f % 8 == 4));
    }
}
