//! `shvis bench` as a library (DESIGN §4): render the reference(s), time every
//! technique × path on the same scene, measure each against the reference its spec names
//! ([`Technique::reference`]), and write the cost table, images and plots.
//!
//! A row's error is the relative RMSE of its image against the reference over covered
//! pixels (`report::metrics`); its time is the median of `frames` timed frames
//! (`gpu::pass`: timestamps around the scene pass), taken in [`TIMING_ROUNDS`] rounds over
//! every row — the row rebuilt for each, `warmup` untimed frames before the first and one
//! before each later round — so that a slow spell of a shared device spreads over all rows;
//! a row that ran in none of the speed states the probe has a model of, or in one on fewer
//! than two builds whose medians agree within [`BUILD_AGREEMENT`], gets up to
//! [`MODEL_STATE_ROUNDS`] more (`probe::states`).

pub mod rows;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use crate::attribution::{LadderPixels, cpu_rungs};
use crate::gpu::TimingStats;
use crate::gpu::{Context, GpuError};
use crate::prepare::Prepared;
use crate::probe::states::Segment;
use crate::probe::{Monitor, Segmented};
use crate::reference::{ReferenceImage, ReferenceSettings, render_reference};
use crate::render::specular::{NormalFilter, SpecularLight, SpecularTerm};
use crate::render::{Frame, FrameSettings, SceneGpu};
use crate::report::figures::{
    DIFFERENCE_SCALE, FIGURES, difference, write_figures, write_ladder_sheet,
};
use crate::report::image::{write_exr, write_exr_half, write_png};
use crate::report::metrics::image_error;
use crate::report::plot::{CostAxis, write_error_plot, write_pca_error_plot};
use crate::report::table::{
    AttributionKind, AttributionStep, BenchPhases, BenchRow, BenchTable, RowReference,
    fill_ratios_to_preconv,
};
use crate::report::{LADDER_DIR, ReportError};
use crate::technique::{self, HwPath, ReferenceModel, Technique, TechniqueError};

/// What a bench run does.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchSettings {
    pub techniques: Vec<Technique>,
    pub paths: Vec<HwPath>,
    /// Timed frames per technique × path.
    pub frames: u32,
    /// Untimed frames before them.
    pub warmup: u32,
    pub width: u32,
    pub height: u32,
    /// Exposure in EV of the PNG images.
    pub exposure: f32,
    /// Samples per pixel of the reference (0: no reference, no error columns).
    pub ref_spp: u32,
    /// Bounces of the inter-reflected reference (and of the SH lightmap bake).
    pub bounces: u32,
    /// Integrate the pixel footprint in the reference (`reference::ReferenceSettings`).
    pub footprint_reference: bool,
    /// Seed of the reference's sampling.
    pub seed: u64,
    /// The specular material term (`--specular`): every technique × path is measured once
    /// per filtering with the term added, against references with the term's own footprint
    /// reference (`reference::specular::render_reference`, the same for every filtering) summed in.
    pub specular: Option<SpecularSettings>,
    /// Output directory (must exist).
    pub out: PathBuf,
    /// `--relight-rotate DEG`: measure under the bake's environment turned this many
    /// degrees about +Y ([`Relit`]).
    pub relight_degrees: Option<f64>,
    /// Run the device probe first (`crate::probe`, at the bench's size) and give every row
    /// the model's time (`model_ms`, `x_model`); `probe.md`/`probe.json` beside the table.
    pub probe: bool,
}

/// The specular term of a bench: its light and base spread, and the normal-map filterings
/// measured side by side.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecularSettings {
    pub filters: Vec<NormalFilter>,
    pub light: SpecularLight,
    pub sigma: f32,
}

impl SpecularSettings {
    fn term(&self, filter: NormalFilter) -> SpecularTerm {
        SpecularTerm {
            filter,
            light: self.light,
            sigma: self.sigma,
        }
    }
}

impl BenchSettings {
    /// Whether a technique of the run bakes inter-reflection (and so needs the
    /// inter-reflected reference).
    pub fn needs_inter_reflection(&self) -> bool {
        self.techniques.iter().any(|t| t.needs().inter_reflection())
    }
}

/// The lighting of a `--relight-rotate` bench: the bake's environment turned
/// about +Y (g(ω) = f(Rᵀω), the map resampled bilinearly) and its SH projections. The
/// references are rendered under it; every technique with dynamic lighting is built for
/// the bake's lighting and then relit to it through its lighting recipe and
/// `TechniqueGpu::update_lighting` (the path `shvis relight` takes); the baked ones
/// (`shlmap`, `rnm*`) keep the lighting they were baked with — what not relighting costs.
pub struct Relit {
    pub degrees: f64,
    pub env: crate::env::EnvMap,
    pub radiance_sh: Vec<[f64; 3]>,
    pub irradiance_sh: Vec<[f64; 3]>,
}

impl Relit {
    pub fn new(prepared: &Prepared, degrees: f64) -> Relit {
        let r = crate::env::schedule::rotation_about_y(degrees.to_radians()).transpose();
        let env = &prepared.env;
        let env =
            crate::env::EnvMap::from_fn(env.width, env.height, |d| env.sample_bilinear(r * d));
        let order = crate::sh::Order::new(prepared.radiance_sh.len().isqrt() as u32)
            .expect("the prepared lighting has a valid order");
        let radiance_sh = crate::env::project::project_sh(&env, order);
        let irradiance_sh =
            crate::sh::zonal::irradiance_from_radiance(&radiance_sh[..9], crate::sh::Order::THREE);
        Relit {
            degrees,
            env,
            radiance_sh,
            irradiance_sh,
        }
    }
}

/// Errors of a bench run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("{device}: the graphics queue has no timestamps, frames cannot be timed")]
    NoTimestamps { device: String },
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Runs the bench on `prepared` and writes its files into `settings.out`: table.md,
/// table.json, an image per row (PNG + EXR), the reference(s), the plots. Returns the table.
pub fn run(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    settings: &BenchSettings,
) -> Result<BenchTable, BenchError> {
    if !ctx.supports_timestamps() {
        return Err(BenchError::NoTimestamps {
            device: ctx.device_name().to_string(),
        });
    }
    let started = Instant::now();
    let mut phases = BenchPhases::default();
    let mut lap = Lap::start();
    let cost_model = if settings.probe {
        let probe = crate::probe::run_with_monitor(
            ctx,
            &crate::probe::ProbeSettings {
                width: settings.width,
                height: settings.height,
                triangle_pixels: prepared
                    .scene
                    .pixel_weighted_triangle_area(settings.width, settings.height),
                warmup: settings.warmup.min(5),
                frames: settings.frames.clamp(5, 30),
            },
        )?;
        let (probe, monitor) = probe;
        log::info!(
            "probe: {:.1} s, model within {:.1} % of its microbenchmarks; {}",
            probe.seconds,
            100.0 * probe.worst_relative_error(),
            probe.states.describe()
        );
        crate::report::write_probe(&probe, &settings.out)?;
        Some((probe, monitor))
    } else {
        None
    };
    // The probe's monitor, timed around every row's frames (`probe::states`).
    let monitor = cost_model.as_ref().map(|(_, m)| m);
    lap.split(&mut phases.probe);
    let relit = settings.relight_degrees.map(|d| Relit::new(prepared, d));
    let env = relit.as_ref().map_or(&prepared.env, |r| &r.env);
    let reference = render_references(ctx, prepared, env, settings)?;
    lap.split(&mut phases.references);
    let frame_settings = FrameSettings {
        width: settings.width,
        height: settings.height,
        flat_normals: false,
        ..FrameSettings::default()
    };
    // The ladder's CPU rungs model the diffuse techniques alone (`attribution` leaves
    // specular rows out).
    let ladder = match reference.as_ref().and_then(|r| r.point.as_ref()) {
        Some(_) if relit.is_some() => {
            log::info!("error ladder: left out when relit (its CPU rungs use the bake's lighting)");
            None
        }
        Some(_) if settings.specular.is_some() => {
            log::info!("error ladder: left out with --specular (its CPU rungs are diffuse)");
            None
        }
        Some(_) => Some(ladder_pixels(ctx, prepared, settings)?),
        None => None,
    };
    let mut ladder = Ladder {
        pixels: ladder,
        written: std::collections::HashSet::new(),
    };
    lap.split(&mut phases.ladder_setup);
    let mut scene = SceneGpu::new(ctx, &prepared.scene, &frame_settings)?;
    let filters: Vec<Option<NormalFilter>> = match &settings.specular {
        Some(s) => s.filters.iter().copied().map(Some).collect(),
        None => vec![None],
    };
    let mut rows = Vec::new();
    // Every row's frame times so far, in segments between monitor frames (the later timing
    // rounds add to them).
    let mut samples: Vec<Segmented> = Vec::new();
    let rounds = if settings.specular.is_some() {
        1
    } else {
        TIMING_ROUNDS.min(settings.frames.max(1))
    };
    let per_round = settings.frames.div_ceil(rounds);
    // The images the figures need, kept until they are drawn (the first filtering's).
    let mut figure_frames = std::collections::HashMap::new();
    for (k, &filter) in filters.iter().enumerate() {
        if let (Some(filter), Some(s)) = (filter, &settings.specular) {
            scene.add_specular(ctx, &prepared.scene, s.term(filter))?;
        }
        let rows_of = RowTechniques {
            ctx,
            scene: &scene,
            prepared,
            relit: relit.as_ref(),
        };
        for &technique in &settings.techniques {
            for &path in &settings.paths {
                if !technique.runs_on(path) {
                    if k == 0 {
                        log::info!(
                            "{technique}.{path}: left out (it does not fit the path's rules)"
                        );
                    }
                    continue;
                }
                let reference = reference.as_ref();
                let measured = measure_row(
                    &rows_of,
                    technique,
                    path,
                    reference,
                    &mut ladder,
                    settings,
                    per_round,
                    monitor,
                    &mut lap,
                    &mut phases,
                );
                let (row, frame, segments) = match measured {
                    // The specular term's moment maps can take a dx9 draw past its textures.
                    Err(BenchError::Technique(e @ TechniqueError::Dx9Rule { .. }))
                        if filter.is_some() =>
                    {
                        log::warn!("{e} (with the specular term): row left out");
                        continue;
                    }
                    other => other?,
                };
                rows.push(row);
                samples.push(Segmented(segments));
                if k == 0
                    && FIGURES
                        .iter()
                        .any(|f| f.techniques().any(|t| t == technique))
                {
                    figure_frames.insert((technique, path), frame);
                }
            }
        }
    }
    for &path in &settings.paths {
        let written = write_figures(
            &settings.out,
            path,
            reference.as_ref().map(|r| &r.main.frame),
            &|t| figure_frames.get(&(t, path)),
            settings.exposure,
        );
        match written {
            Ok(files) => files
                .iter()
                .for_each(|f| log::info!("wrote {}", f.display())),
            Err(e) => log::warn!("{e}"),
        }
    }
    drop(figure_frames);
    let rows_of = RowTechniques {
        ctx,
        scene: &scene,
        prepared,
        relit: relit.as_ref(),
    };
    // One more round of a row, on a build of its own (`probe::states`: builds differ).
    let mut time_round = |technique, path, times: &mut Segmented| -> Result<(), BenchError> {
        let tech = rows_of.build(technique, path)?;
        lap.split(&mut phases.build);
        let build = times.0.last().map_or(0, |s| s.build + 1);
        times.0.extend(timed_segments(
            monitor,
            build,
            settings.warmup.min(1),
            per_round,
            |w, n| tech.time(&scene, w, n),
        )?);
        lap.split(&mut phases.render);
        Ok(())
    };
    for _ in 1..rounds {
        for (row, times) in rows.iter().zip(&mut samples) {
            time_round(row.technique, row.path, times)?;
        }
    }
    // A row with no frames in a state the probe has a model of (the device sat in another
    // through all its rounds) is timed in up to MODEL_STATE_ROUNDS more until it has some:
    // else its ×model would set frames of one state against the model of another. So is a
    // row whose frames in its fastest modelled state came from fewer than two builds, or
    // whose two fastest builds there differ by more than BUILD_AGREEMENT: a build can run
    // ≈ 25 % slow for as long as it lives (`probe::states`), and its time there is its
    // fastest build's (one run: pca12v 1.33× on the one build it had in the modelled
    // state, 56 ms frames on another in the other state; pca12v25's builds ran 1.00×,
    // 1.37×, 1.18× in another). Not
    // with `--specular`: its rows differ by the specular term bound when they were
    // measured, and only the last one is bound now.
    if let Some((probe, monitor)) = cost_model.as_ref().filter(|_| settings.specular.is_none()) {
        let modelled: Vec<usize> = probe.state_models.iter().map(|m| m.state).collect();
        for _ in 0..MODEL_STATE_ROUNDS {
            let unmodelled: Vec<usize> = (0..rows.len())
                .filter(|&i| {
                    match samples[i].fastest_state(&monitor.states, modelled.iter().copied()) {
                        Some((state, _, _)) => {
                            !samples[i].builds_agree_in(&monitor.states, state, BUILD_AGREEMENT)
                        }
                        None => true,
                    }
                })
                .collect();
            if unmodelled.is_empty() {
                break;
            }
            log::info!(
                "cost model: {} row(s) without frames of two builds within {:.0} % of each other in a modelled state, timed again",
                unmodelled.len(),
                100.0 * BUILD_AGREEMENT
            );
            for i in unmodelled {
                time_round(rows[i].technique, rows[i].path, &mut samples[i])?;
            }
        }
    }
    if log::log_enabled!(log::Level::Debug) {
        for (row, times) in rows.iter().zip(&samples) {
            for s in &times.0 {
                log::debug!(
                    "timed {} {:?}: build {}, monitor {:.2} ms, frames {:.1?} ms, monitor {:.2} ms",
                    row.technique,
                    row.path,
                    s.build,
                    s.monitor_before,
                    s.ms,
                    s.monitor_after
                );
            }
        }
    }
    for (row, times) in rows.iter_mut().zip(&samples) {
        let timing = TimingStats::from_ms(&times.all());
        row.ms_median = timing.map(|t| t.ms_median);
        row.ms_min = timing.map(|t| t.ms_min);
        row.ms_max = timing.map(|t| t.ms_max);
        row.frames = times.all().len();
    }
    fill_ratios_to_preconv(&mut rows);
    let mut bench_state_shares = None;
    let mut scene_checks = Vec::new();
    if let Some((probe, monitor)) = &cost_model {
        let monitor_frames: Vec<f64> = samples.iter().flat_map(Segmented::monitor_frames).collect();
        let shares = monitor.states.shares_of(&monitor_frames);
        log::info!(
            "cost model: {}; the bench's monitor frames: {} in each state",
            monitor.states.describe(),
            crate::probe::DeviceStates::format_shares(&shares)
        );
        bench_state_shares = Some(shares);
        // Lanes busy per screen pixel, overdraw included: the same for every row that draws
        // the scene's mesh.
        let pixels = f64::from(settings.width) * f64::from(settings.height);
        let load = scene.shading_load(ctx, None)?;
        log::info!(
            "cost model: {:.3} fragments shaded and {:.3} lanes busy per screen pixel{}, {:.0} pixels of triangle edges",
            load.fragments as f64 / pixels,
            load.lanes / pixels,
            if load.measured_lanes {
                ""
            } else {
                " (no subgroup ballot in fragment shaders: lanes = fragments)"
            },
            load.edge_pixels
        );
        scene_checks = crate::probe::scene_check::run(
            ctx,
            &scene,
            &probe.model,
            &load,
            pixels,
            settings.frames,
        )?;
        log::info!(
            "cost model, the probe's shaders over the scene: {}",
            crate::probe::scene_check::summary(&scene_checks)
        );
        for (row, times) in rows.iter_mut().zip(&samples) {
            let load = row.own_mesh_load.unwrap_or(load);
            row.coverage = load.lanes / pixels;
            row.edge_pixels = load.edge_pixels;
            // Like with like: the row's frames in the fastest state it ran in that the probe
            // has a model of (its fastest build's), against that model; else every frame
            // against the main model.
            let states = &monitor.states;
            let modelled = probe.state_models.iter().map(|m| m.state);
            let (model, measured, state, state_frames) = match times.fastest_state(states, modelled)
            {
                Some((state, ms, frames)) => (probe.model_of(state), Some(ms), Some(state), frames),
                None => (None, None, None, 0),
            };
            let model = model.unwrap_or(&probe.model);
            let measured = measured.or(row.ms_median);
            let counts = model.with_untaken(&row.cost, &row.untaken_cost);
            let predicted = model.predict(&counts, row.coverage, row.triangles, row.edge_pixels);
            row.model_ms = Some(predicted);
            row.model_state = state;
            row.model_state_frames = Some(state_frames);
            row.x_model = measured.map(|ms| ms / predicted);
        }
    }
    let bounced = reference.as_ref().and_then(|r| r.main.bounced.as_ref());
    let mut table = BenchTable {
        reference_spp: settings.ref_spp,
        reference_rel_noise: reference.as_ref().map(|r| r.main.rel_noise),
        reference_bounces: bounced.map_or(0, |b| b.bounces),
        reference_bounced_rel_noise: bounced.map(|b| b.rel_noise),
        device: ctx.device_name().to_string(),
        width: settings.width,
        height: settings.height,
        vis_res: prepared.visibility.res,
        device_states: cost_model.as_ref().map(|(p, _)| p.states.clone()),
        bench_state_shares,
        scene_checks,
        state_cost_models: cost_model
            .as_ref()
            .map(|(p, _)| p.state_models.clone())
            .unwrap_or_default(),
        cost_model: cost_model.map(|(p, _)| p.model),
        relit: relit.as_ref().map(|r| {
            format!(
                "the environment turned {}° about +Y after the bake; dynamic-lighting rows relit to it, baked rows (shlmap, rnm*) as baked",
                r.degrees
            )
        }),
        specular: settings.specular.as_ref().map(|s| {
            let (d, e) = (s.light.direction, s.light.radiance);
            format!(
                "light toward ({:.3}, {:.3}, {:.3}), k_s·E = ({:.4}, {:.4}, {:.4}), σ = {}",
                d.x, d.y, d.z, e.x, e.y, e.z, s.sigma
            )
        }),
        results: rows,
        seconds: 0.0,
        phases,
    };
    write_plots(&table, &settings.paths, &settings.out);
    lap.split(&mut table.phases.figures);
    table.seconds = started.elapsed().as_secs_f64();
    table.write(&settings.out)?;
    let page = crate::report::html::write_index(&table, &settings.out)?;
    log::info!("wrote {}", page.display());
    log::info!(
        "bench: {} rows in {:.1} s ({})",
        table.results.len(),
        table.seconds,
        table.phases.summary()
    );
    Ok(table)
}

/// The references a bench measures against.
pub struct References {
    /// What the error column is against: the footprint reference (or the point one with
    /// `--point-reference`), with the inter-reflected image when a technique needs it.
    pub main: ReferenceImage,
    /// With a footprint `main`: the point-sampled reference from the same samples'
    /// settings, the first rung of the error attribution.
    pub point: Option<ReferenceImage>,
}

/// The references: `main`, written as `reference*.{exr,png}`, and with a footprint main
/// the point-sampled one as `reference_point*.{exr,png}`.
fn render_references(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    env: &crate::env::EnvMap,
    settings: &BenchSettings,
) -> Result<Option<References>, BenchError> {
    if settings.ref_spp == 0 {
        return Ok(None);
    }
    let render = |footprint: bool, name: &str| -> Result<ReferenceImage, BenchError> {
        let reference_settings = ReferenceSettings {
            width: settings.width,
            height: settings.height,
            spp: settings.ref_spp,
            seed: settings.seed,
            bounces: if settings.needs_inter_reflection() {
                settings.bounces
            } else {
                0
            },
            footprint,
        };
        let mut image = render_reference(ctx, &prepared.scene, env, &reference_settings)?;
        if let Some(s) = &settings.specular {
            let term = s.term(NormalFilter::Mip);
            let specular = specular_reference(ctx, prepared, &term, &reference_settings)?;
            add_rgb(&mut image.frame, &specular);
            if let Some(b) = &mut image.bounced {
                add_rgb(&mut b.frame, &specular);
            }
        }
        log::info!(
            "{name}: {} spp ({}×{} sub-pixel strata) in {:.1} s, relative noise {:.4}",
            settings.ref_spp,
            image.strata.side,
            image.strata.side,
            image.seconds,
            image.rel_noise
        );
        write_images(&settings.out, name, &image.frame, settings.exposure)?;
        if let Some(b) = &image.bounced {
            log::info!(
                "{name} with {} bounces: relative noise {:.4}",
                b.bounces,
                b.rel_noise
            );
            let file = format!("{name}_bounces{}", b.bounces);
            write_images(&settings.out, &file, &b.frame, settings.exposure)?;
        }
        Ok(image)
    };
    let main = render(settings.footprint_reference, "reference")?;
    let point = if settings.footprint_reference {
        Some(render(false, "reference_point")?)
    } else {
        None
    };
    Ok(Some(References { main, point }))
}

/// The footprint (or, without `settings.footprint`, point) reference of the specular term
/// alone: the same BRDF from the full-resolution normals (`reference::specular::render_reference`).
fn specular_reference(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    term: &SpecularTerm,
    settings: &ReferenceSettings,
) -> Result<Frame, BenchError> {
    let mut gpu = SceneGpu::new(
        ctx,
        &prepared.scene,
        &FrameSettings {
            width: settings.width,
            height: settings.height,
            float32_target: true,
            ..FrameSettings::default()
        },
    )?;
    let maps = crate::ndf::build(
        &prepared.scene.material.normal,
        prepared.scene.material.normal_scale,
        term.sigma,
    );
    let started = Instant::now();
    let frame = crate::reference::specular::render_reference(
        ctx,
        &mut gpu,
        prepared.scene.camera.position,
        &maps,
        &term.light,
        settings,
    )?;
    log::info!(
        "specular reference ({}): {:.1} s",
        if settings.footprint {
            "footprint"
        } else {
            "point"
        },
        started.elapsed().as_secs_f64()
    );
    Ok(frame)
}

/// Adds `extra`'s colour to `frame` (same size), alpha kept.
fn add_rgb(frame: &mut Frame, extra: &Frame) {
    for (p, e) in frame.rgba.iter_mut().zip(&extra.rgba) {
        for c in 0..3 {
            p[c] += e[c];
        }
    }
}

/// The image of `reference` a technique is measured against, and how the row names it.
fn reference_for(technique: Technique, reference: &ReferenceImage) -> (&Frame, RowReference) {
    match (technique.reference(), &reference.bounced) {
        (ReferenceModel::InterReflected, Some(b)) => (&b.frame, RowReference::Bounced(b.bounces)),
        (ReferenceModel::InterReflected, None) | (ReferenceModel::Direct, _) => {
            (&reference.frame, RowReference::Direct)
        }
    }
}

/// The error ladder's state over a bench: the per-pixel data of the CPU rungs and the
/// rung images already written (rungs shared by rows are written once).
struct Ladder {
    pixels: Option<LadderPixels>,
    written: std::collections::HashSet<String>,
}

/// Renders the point G-buffer and traces the per-pixel visibility of the ladder.
fn ladder_pixels(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    settings: &BenchSettings,
) -> Result<LadderPixels, BenchError> {
    let pixels = LadderPixels::new(ctx, prepared, settings.width, settings.height)?;
    log::info!(
        "error ladder: {} pixels, visibility traced per pixel ({} rays) and exact lighting tabulated in {:.1} s",
        pixels.len(),
        pixels.rays_traced(),
        pixels.seconds
    );
    std::fs::create_dir_all(settings.out.join(LADDER_DIR)).map_err(|e| ReportError::Write {
        path: settings.out.join(LADDER_DIR),
        detail: e.to_string(),
    })?;
    Ok(pixels)
}

/// Rounds a row's timed frames are split into, each round over every row (the main bench;
/// with `--specular` one): a slow spell of a shared device then lands on a share of every
/// row's frames instead of on all of a few rows'.
const TIMING_ROUNDS: u32 = 3;

/// Frames of a row timed between two monitor readings, at most ([`timed_segments`]).
const CHUNK_FRAMES: u32 = 3;

/// Rounds more, at most, for a row that has no frames in a state the probe has a model of,
/// or not two builds there that agree within [`BUILD_AGREEMENT`].
const MODEL_STATE_ROUNDS: usize = 3;

/// How far (relative) the second-fastest build of a row, in the state it is compared in,
/// may run from the fastest before the row gets another round on a fresh build (most
/// rows' builds agree within 5 %; an odd build runs 13–37 % slow).
const BUILD_AGREEMENT: f64 = 0.1;

/// The file stem of the reference image `frame` was taken from (`reference_for`).
fn reference_stem(name: &str, kind: RowReference) -> String {
    match kind {
        RowReference::Bounced(n) => format!("{name}_bounces{n}"),
        RowReference::Direct | RowReference::None => name.to_string(),
    }
}

/// The attribution ladder of a row (`crate::attribution`): footprint → point reference,
/// the technique's CPU rungs (written to `ladder/`), then the GPU image `frame`; without
/// CPU rungs it steps from the point reference to the image.
#[allow(clippy::too_many_arguments)]
fn attribution(
    prepared: &Prepared,
    technique: Technique,
    path: HwPath,
    frame: &Frame,
    references: Option<&References>,
    ladder: &mut Ladder,
    settings: &BenchSettings,
) -> Result<Vec<AttributionStep>, BenchError> {
    let Some((r, Some(point))) = references.map(|r| (r, r.point.as_ref())) else {
        return Ok(vec![]);
    };
    if settings.specular.is_some() {
        return Ok(vec![]);
    }
    let (footprint, _) = reference_for(technique, &r.main);
    let (point, kind) = reference_for(technique, point);
    let rel = |a: &Frame, b: &Frame| image_error(a, b).map(|e| e.rel_rmse);
    let mut steps = vec![AttributionStep {
        step: AttributionKind::PixelFootprint,
        rel_rmse: rel(point, footprint),
        image: format!("{}.exr", reference_stem("reference_point", kind)),
    }];
    let rungs = match &ladder.pixels {
        Some(pixels) => cpu_rungs(pixels, prepared, technique, path)?,
        None => vec![],
    };
    let mut previous = point;
    for rung in &rungs {
        let image = format!("{LADDER_DIR}/{}.exr", rung.stem);
        if ladder.written.insert(rung.stem.clone()) {
            let dir = settings.out.join(LADDER_DIR);
            write_exr_half(&dir.join(format!("{}.exr", rung.stem)), &rung.frame)?;
            let png = dir.join(format!("{}.png", rung.stem));
            write_png(&png, &rung.frame, settings.exposure)?;
        }
        steps.push(AttributionStep {
            step: rung.step,
            rel_rmse: rel(&rung.frame, previous),
            image,
        });
        previous = &rung.frame;
    }
    let mut sheet: Vec<(String, &Frame)> = vec![
        ("reference".into(), footprint),
        ("point reference".into(), point),
    ];
    sheet.extend(rungs.iter().map(|r| (r.step.name().to_string(), &r.frame)));
    sheet.push(("GPU".into(), frame));
    let file = settings
        .out
        .join(LADDER_DIR)
        .join(format!("{technique}.{path}.sheet.png"));
    let written = std::fs::create_dir_all(settings.out.join(LADDER_DIR))
        .map_err(|e| {
            format!(
                "{}: cannot create: {e}",
                settings.out.join(LADDER_DIR).display()
            )
        })
        .and_then(|()| {
            write_ladder_sheet(&file, &sheet, settings.exposure).map_err(|e| e.to_string())
        });
    match written {
        Ok(()) => log::info!("wrote {}", file.display()),
        Err(e) => log::warn!("{e}"),
    }
    steps.push(AttributionStep {
        step: if rungs.is_empty() {
            AttributionKind::Technique
        } else {
            AttributionKind::Gpu
        },
        rel_rmse: rel(frame, previous),
        image: format!("{technique}.{path}.exr"),
    });
    Ok(steps)
}

/// A stopwatch that adds the time since its last split to a phase of [`BenchPhases`]; one
/// runs through the whole bench, so the phases add up to its wall time (the scene upload
/// and the time between rows count as builds).
struct Lap(Instant);

impl Lap {
    fn start() -> Lap {
        Lap(Instant::now())
    }

    fn split(&mut self, phase: &mut f64) {
        *phase += self.0.elapsed().as_secs_f64();
        self.0 = Instant::now();
    }
}

/// What every row's technique is built from: the device, the scene on it, the bake, and
/// the turned light when the bench relights.
struct RowTechniques<'a> {
    ctx: &'a Arc<Context>,
    scene: &'a SceneGpu,
    prepared: &'a Prepared,
    relit: Option<&'a Relit>,
}

impl RowTechniques<'_> {
    /// One row's technique, built for the bench's lighting (relit through
    /// `update_lighting` when the bench turns the light and the technique can follow).
    fn build(
        &self,
        technique: Technique,
        path: HwPath,
    ) -> Result<technique::TechniqueGpu, BenchError> {
        let (ctx, scene, inputs) = (self.ctx, self.scene, self.prepared.inputs());
        Ok(match self.relit {
            Some(relit) if technique.dynamic_lighting() => {
                let (mut tech, recipe) =
                    technique::build_dynamic(ctx, scene, technique, path, &inputs)?;
                let data = recipe.build(&relit.radiance_sh, &relit.irradiance_sh)?;
                tech.update_lighting(&data)?;
                tech.wait_for_upload()?;
                tech
            }
            _ => technique::build(ctx, scene, technique, path, &inputs)?,
        })
    }
}

/// Times `frames` frames (after `warmup` untimed ones) with `time` (warm-up, frames → ms),
/// on pipeline build `build`, in chunks of at most [`CHUNK_FRAMES`] with a monitor reading
/// before each and after the last (NaN without a monitor): the states (`probe::states`) are
/// told apart per chunk, not per round (one round of a row can span a second, as long as
/// the device's stay in a state).
fn timed_segments(
    monitor: Option<&Monitor>,
    build: usize,
    warmup: u32,
    frames: u32,
    time: impl Fn(u32, u32) -> Result<Vec<f64>, GpuError>,
) -> Result<Vec<Segment>, BenchError> {
    let read = || -> Result<f64, BenchError> {
        Ok(monitor.map(Monitor::read).transpose()?.unwrap_or(f64::NAN))
    };
    let chunks = frames.div_ceil(CHUNK_FRAMES).max(1);
    let mut before = read()?;
    let mut segments = Vec::new();
    for c in 0..chunks {
        // Even chunks: 7 frames are 3 + 2 + 2.
        let n = frames / chunks + u32::from(c < frames % chunks);
        let ms = time(if c == 0 { warmup } else { 0 }, n)?;
        let after = read()?;
        segments.push(Segment {
            build,
            monitor_before: before,
            ms,
            monitor_after: after,
        });
        before = after;
    }
    Ok(segments)
}

/// Builds, times (the first of the timing rounds: `frames`), writes and measures one
/// technique × path; returns its row, image and timed segments.
#[allow(clippy::too_many_arguments)]
fn measure_row(
    rows_of: &RowTechniques<'_>,
    technique: Technique,
    path: HwPath,
    references: Option<&References>,
    ladder: &mut Ladder,
    settings: &BenchSettings,
    frames: u32,
    monitor: Option<&Monitor>,
    lap: &mut Lap,
    phases: &mut BenchPhases,
) -> Result<(BenchRow, Frame, Vec<Segment>), BenchError> {
    let (scene, prepared) = (rows_of.scene, rows_of.prepared);
    let tech = rows_of.build(technique, path)?;
    let costs = technique::cost::counts(rows_of.ctx, scene, &tech)?;
    lap.split(&mut phases.build);
    let segments = timed_segments(monitor, 0, settings.warmup, frames, |w, n| {
        tech.time(scene, w, n)
    })?;
    // The image: one more frame, read back (its time is not kept).
    let frame = tech.render(scene, 0, 1)?;
    let frame_ms: Vec<f64> = segments.iter().flat_map(|s| s.ms.iter().copied()).collect();
    lap.split(&mut phases.render);
    let specular = scene.specular().map(|s| s.term.filter);
    let label = match specular {
        Some(f) => format!("{}.spec{}", tech.label(), f.name()),
        None => tech.label(),
    };
    let timing = TimingStats::from_ms(&frame_ms);
    let (reference_frame, reference_kind) = match references {
        Some(r) => {
            let (f, kind) = reference_for(technique, &r.main);
            (Some(f), kind)
        }
        None => (None, RowReference::None),
    };
    let error = reference_frame.and_then(|r| image_error(&frame, r));
    if let (RowReference::Bounced(_), Some(r)) = (reference_kind, references)
        && let Some(e) = image_error(&frame, &r.main.frame)
    {
        log::info!(
            "{label}: relative RMSE against the direct-only reference {:.4}",
            e.rel_rmse
        );
    }
    // Every row against the inter-reflected reference too, where there is one: the
    // comparison of techniques with and without inter-reflection on one ground truth.
    let rel_rmse_bounced = match (reference_kind, references) {
        (RowReference::Bounced(_), _) => error.map(|e| e.rel_rmse),
        (_, Some(r)) => r
            .main
            .bounced
            .as_ref()
            .and_then(|b| image_error(&frame, &b.frame))
            .map(|e| e.rel_rmse),
        (_, None) => None,
    };
    write_images(&settings.out, &label, &frame, settings.exposure)?;
    if let Some(r) = reference_frame {
        let diff = difference(&frame, r, DIFFERENCE_SCALE);
        let name = format!("{label}.diff{DIFFERENCE_SCALE}.png");
        write_png(&settings.out.join(name), &diff, settings.exposure)?;
    }
    // The share of the screen covered; the model uses the scene's shaded fragments (`run`).
    let covered = frame.rgba.iter().filter(|p| p[3] > 0.5).count();
    lap.split(&mut phases.row_images);
    let attribution = attribution(
        prepared, technique, path, &frame, references, ladder, settings,
    )?;
    lap.split(&mut phases.ladder);
    let row = BenchRow {
        technique,
        path,
        specular,
        cost: costs.done,
        untaken_cost: costs.untaken,
        coverage: covered as f64 / frame.rgba.len().max(1) as f64,
        own_mesh_load: if settings.probe {
            technique::vertex::own_mesh_load(rows_of.ctx, scene, technique, &prepared.inputs())?
        } else {
            None
        },
        triangles: tech.triangle_count(scene),
        edge_pixels: 0.0,
        model_ms: None,
        x_model: None,
        model_state: None,
        model_state_frames: None,
        ms_median: timing.map(|s| s.ms_median),
        ms_min: timing.map(|s| s.ms_min),
        ms_max: timing.map(|s| s.ms_max),
        frames: frame_ms.len(),
        rel_rmse: error.map(|e| e.rel_rmse),
        rel_rmse_bounced,
        psnr: error.map(|e| e.psnr),
        texel_bytes: tech.stats.texel_bytes,
        table_bytes: tech.stats.table_bytes,
        textures_bound: tech.stats.textures_bound,
        lookups_per_pixel: tech.stats.lookups_per_pixel,
        ratio_to_preconv: None,
        paper_ms: technique.paper_ms(),
        paper_ratio_to_preconv: technique.paper_ratio_to_preconv(),
        reference: reference_kind,
        attribution,
        clipped_pixels: frame.clipped_pixels(),
    };
    if row.clipped_pixels > 0 {
        log::warn!(
            "{label}: {} pixels clipped at the f16 target's 65504 (or not finite); the row is marked",
            row.clipped_pixels
        );
    }
    Ok((row, frame, segments))
}

/// `{name}.png` (with `exposure`) and `{name}.exr` in `dir`.
fn write_images(dir: &Path, name: &str, frame: &Frame, exposure: f32) -> Result<(), ReportError> {
    write_exr(&dir.join(format!("{name}.exr")), frame)?;
    write_png(&dir.join(format!("{name}.png")), frame, exposure)
}

/// The PCA plot per path and the speed/error and storage/error plots; a plot that cannot be drawn (no font)
/// is a warning, not a failed bench.
fn write_plots(table: &BenchTable, paths: &[HwPath], dir: &Path) {
    let report = |result: Result<Vec<PathBuf>, ReportError>| match result {
        Ok(files) => files
            .iter()
            .for_each(|f| log::info!("wrote {}", f.display())),
        Err(e) => log::warn!("{e}"),
    };
    for &path in paths {
        report(write_pca_error_plot(&table.results, path, dir));
    }
    report(write_error_plot(table, dir, CostAxis::Time));
    report(write_error_plot(table, dir, CostAxis::Storage));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_round_is_timed_in_even_chunks_of_at_most_chunk_frames_with_one_warm_up() {
        for frames in [0, 1, 3, 7, 34] {
            let calls = std::cell::RefCell::new(Vec::new());
            let segments = timed_segments(None, 2, 5, frames, |warmup, n| {
                calls.borrow_mut().push((warmup, n));
                Ok(vec![1.0; n as usize])
            })
            .unwrap();
            let calls = calls.into_inner();
            let sizes: Vec<u32> = calls.iter().map(|&(_, n)| n).collect();
            assert_eq!(sizes.iter().sum::<u32>(), frames, "{sizes:?}");
            assert!(sizes.iter().all(|&n| n <= CHUNK_FRAMES), "{sizes:?}");
            let (min, max) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
            assert!(max - min <= 1, "uneven chunks {sizes:?}");
            assert_eq!(calls[0].0, 5, "the warm-up goes before the first chunk");
            assert!(calls[1..].iter().all(|&(w, _)| w == 0), "{calls:?}");
            assert_eq!(segments.len(), calls.len());
            assert!(
                segments
                    .iter()
                    .all(|s| s.build == 2 && s.monitor_after.is_nan())
            );
        }
    }
}
