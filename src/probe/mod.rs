//! The device probe and the cost model (`shvis probe`, run first by `shvis bench`).
//!
//! **Probe.** On the current Vulkan device, at the bench's target format and resolution, a
//! screen-filling grid of triangles as large as the scene's (`ProbeSettings::triangle_pixels`,
//! the scene's pixel-weighted triangle area: lavapipe shades in blocks, and the smaller the
//! triangles the more of a block's lanes idle — a bilinear lookup cost 2.3 ns per pixel over
//! two screen-filling triangles and 3.6 ns over 125-pixel ones) is drawn with generated
//! fragment shaders that each do N operations of one kind (straight-line code, no loops):
//! bilinear 2D lookups (RGBA16F, the lightmap sampler, a texture each, as dx9 binds them),
//! trilinear lookups (RGBA8 with MIP chains, the material sampler, ≈ 2.7 texels per pixel;
//! the same in sRGB, as the albedo, and in RGBA32F, as the NDF moment maps),
//! 2D-array lookups, cube-array lookups (32² faces, as the tables), dependent lookups (each
//! one's coordinates from the previous one's result, into textures the size of a dx9 table
//! strip), scalar fused multiply-adds (four independent vec4 chains), interpolated varyings
//! read, and uniform vec4 reads at constant and at per-pixel indices; plus the empty shader
//! (it writes its lightmap coordinates, which every technique reads) over the full screen,
//! over half of it, with the depth test off, and over grids of 2·64², 2·96², 2·128², 2·256²
//! triangles (the per-triangle cost), the shader that reads all 14 varyings over the 2·96²
//! and 2·256² grids (a varying's per-triangle cost), and a frame that shades nothing. The points' frames
//! (`gpu::pass`) are taken in rounds over all points so that a slow drift of a shared
//! device spreads over every point instead of landing on a few; cheap points get more
//! frames. A shared device also switches between speed states every few seconds (on this
//! project's VM the empty shader over the screen takes 1.7 or 3.4 ms, a neighbour's memory
//! traffic by the look of it): a monitor frame after each point's frames tells which state
//! they ran in ([`states`]); a model is fitted per state to the points' medians in it
//! (the main one: the fastest state every point ran in, the device least disturbed). A
//! point with fewer than 5 frames (from fewer than 3 rounds) in the fastest state of ≥ 20 %
//! of the monitor frames, or that the fit misses by more than 8 % while no two of its
//! builds agree within 10 %, is timed in another batch of rounds on freshly built
//! pipelines, its frames pooled with the first and its time that of its fastest build (a
//! build can run ≈ 25 % slow for as long as it lives, `states`), then the model is fitted
//! again — up to two such batches. A batch warms each pipeline up in its first round, and
//! a cheap point's (under 40 ms a frame) in every round.
//!
//! **Model.** The costs of [`crate::cost::CostModel`] are fitted to the points' medians by
//! a **minimax** fit: the costs that make the largest relative error over the points least
//! (a linear program, [`chebyshev_fit`](fit::chebyshev_fit)), as the model is judged by its
//! worst point. A least-squares fit (weighted by 1/t) leaves 7.6–9.5 % on the same points
//! where this leaves 6.1–8.0 %.
//!
//! **Modules.** This file holds the probe's types ([`Probe`], [`ProbePoint`],
//! [`StateModel`], [`ProbeSettings`]), its entry points ([`run`], [`run_with_monitor`],
//! [`monitor`]) and the [`Monitor`] kept for the bench. Beside it:
//! - `shaders`: the GLSL of the microbenchmarks, N operations of one kind per shader;
//! - `resources`: the probe's scene (the grids of triangle pairs, their side for the
//!   triangle area asked for) and the textures and uniform block the shaders read;
//! - `schedule`: what is measured and in which order — every point, its pipeline and
//!   counts, the interleaved rounds with their monitor frames, the points timed again;
//! - `fit`: the cost model fitted to the points' medians per speed state, the minimax
//!   linear program;
//! - `report`: the probe as markdown;
//! - [`states`]: the device's speed states, told apart by the monitor frames, and the
//!   timings labelled by them;
//! - [`cache`]: a probe reused from an earlier run on the same device and settings;
//! - [`scene_check`]: the model checked by shaders of known counts over a bench's scene.

pub mod cache;
mod fit;
mod report;
mod resources;
pub mod scene_check;
mod schedule;
mod shaders;
pub mod states;

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::cost::{CostCounts, CostModel, Kind};
use crate::gpu::{Context, GpuError, MeshBuffers, Sampler};
use crate::render::SceneGpu;
use fit::{fit_points, main_model, measure, predict_point, state_models};
use resources::{
    ProbeResources, base_grid, point_resources, probe_target, shading_loads, upload_probe_mesh,
};
use schedule::{
    Batches, Planned, PointPlanner, RETIME_BATCHES, TRIANGLE_GRIDS, missed_points, monitor_frame,
    point_specs, retime,
};

pub use schedule::{UNTAKEN_BRANCH_READS, VARYING_GRIDS, probe_counts};
pub use states::{DeviceStates, Segmented};

/// One microbenchmark.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ProbePoint {
    /// `None` for the empty shader.
    pub kind: Option<Kind>,
    /// Operations of `kind` generated.
    pub count: u32,
    /// Lanes busy per screen pixel (`SceneGpu::shading_load`).
    pub coverage: f64,
    /// Triangles drawn (2, or a grid's for the per-triangle cost).
    pub triangles: u32,
    /// Their edges on the screen, pixels.
    pub edge_pixels: f64,
    pub depth_test: bool,
    /// Whether its operations sit in a branch that no lane takes (the untaken-branch
    /// points, [`CostModel::untaken_share`]).
    pub in_untaken_branch: bool,
    /// What the shader's SPIR-V counts (all kinds), less `untaken`.
    pub counts: CostCounts,
    /// What its untaken branch counts.
    pub untaken: CostCounts,
    /// Median of its timed frames in the main state, of its fastest build there (of all
    /// its frames where none ran in it: `state_frames` 0).
    pub ms_median: f64,
    /// Batches of interleaved rounds it was timed in (1 to 1 + RETIME_BATCHES).
    pub batches: u32,
    /// Frames timed, and of them in the main state ([`states`]).
    pub frames: usize,
    pub state_frames: usize,
    /// The fitted model's prediction.
    pub model_ms: f64,
}

/// The model fitted to the points' frames in one speed state ([`states`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StateModel {
    pub state: usize,
    pub model: CostModel,
    /// Largest |model − measured| / measured over the points in this state.
    pub worst_relative_error: f64,
    /// The point of that error, and its frames in this state.
    pub worst_point: String,
}

impl StateModel {
    fn new(state: usize, model: CostModel, points: &[ProbePoint]) -> Self {
        let worst = points
            .iter()
            .max_by(|a, b| relative_error(a).total_cmp(&relative_error(b)));
        StateModel {
            state,
            model,
            worst_relative_error: worst.map_or(0.0, relative_error),
            worst_point: worst.map_or(String::new(), |p| {
                format!(
                    "{} ×{} ({:.3} ms measured over {} frames, {:.3} modelled)",
                    p.label(),
                    p.count,
                    p.ms_median,
                    p.state_frames,
                    p.model_ms
                )
            }),
        }
    }
}

impl ProbePoint {
    /// Its kind's name, or the empty shader's, and where its operations sit.
    pub fn label(&self) -> String {
        let name = self.kind.map_or("empty shader", Kind::name);
        if self.in_untaken_branch {
            format!("{name} in a branch no lane takes")
        } else {
            name.to_string()
        }
    }
}

/// |model − measured| / measured of a point.
fn relative_error(p: &ProbePoint) -> f64 {
    (p.model_ms - p.ms_median).abs() / p.ms_median
}

/// Largest [`relative_error`] over `points`.
fn worst_relative_error(points: &[ProbePoint]) -> f64 {
    points.iter().map(relative_error).fold(0.0, f64::max)
}

/// The probe's result.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Probe {
    pub device: String,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// Fragments the screen-filling grid shades (`SceneGpu::shading_load`): one per
    /// pixel ([`CostModel::predict`]'s coverage is in lanes per pixel, `ProbePoint::coverage`).
    pub screen_fragments: u64,
    /// The triangles' screen area asked for, pixels, and the grid side it gave (2·side²
    /// triangles over 1.2 × the view each way).
    pub triangle_pixels: f64,
    pub grid: u32,
    pub model: CostModel,
    /// The speed states the monitor frames fell into; `model` and the points' medians are
    /// the main state's.
    pub states: DeviceStates,
    /// A model per state that every point has frames in (the main state's among them).
    pub state_models: Vec<StateModel>,
    pub points: Vec<ProbePoint>,
    pub seconds: f64,
    /// When it was measured, UTC ("YYYY-MM-DD HH:MM").
    #[serde(default)]
    pub measured_at: String,
    /// The cache file it was read from, when a bench reused it (`cache`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reused_from: Option<String>,
}

impl Probe {
    /// Largest |model − measured| / measured over the points.
    pub fn worst_relative_error(&self) -> f64 {
        worst_relative_error(&self.points)
    }

    /// The model of `state`, if the probe fitted one.
    pub fn model_of(&self, state: usize) -> Option<&CostModel> {
        self.state_models
            .iter()
            .find(|m| m.state == state)
            .map(|m| &m.model)
    }
}

/// How the probe runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSettings {
    pub width: u32,
    pub height: u32,
    /// Screen area of the probe's triangles, pixels: the scene's
    /// [`Scene::pixel_weighted_triangle_area`](crate::scene::Scene::pixel_weighted_triangle_area)
    /// (`shvis bench`), the built-in house's by default.
    pub triangle_pixels: f64,
    pub warmup: u32,
    pub frames: u32,
    /// Show progress bars on stderr (its shaders built, its rounds of timed frames).
    pub progress: bool,
}

/// Runs the probe (module doc).
///
/// # Errors
/// Vulkan or shader failures, and a fit that is not finite (a device whose timings are
/// all zero).
pub fn run(ctx: &Arc<Context>, s: &ProbeSettings) -> Result<Probe, GpuError> {
    run_with_monitor(ctx, s).map(|(probe, _)| probe)
}

/// [`run`], keeping its [`Monitor`].
pub fn run_with_monitor(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
) -> Result<(Probe, Monitor), GpuError> {
    let started = std::time::Instant::now();
    let base = base_grid(s.width, s.height, s.triangle_pixels);
    let gpu = probe_target(ctx, s, base)?;
    let nothing_mesh = upload_probe_mesh(ctx, s, false, 0)?;
    let full_mesh = upload_probe_mesh(ctx, s, false, base)?;
    let half_mesh = upload_probe_mesh(ctx, s, true, base)?;
    let grids = TRIANGLE_GRIDS
        .iter()
        .map(|&g| upload_probe_mesh(ctx, s, false, g))
        .collect::<Result<Vec<_>, _>>()?;
    let (res, linear) = point_resources(ctx)?;
    let planner = PointPlanner {
        ctx,
        gpu: &gpu,
        res: &res,
        linear: &linear,
        pixels: f64::from(s.width) * f64::from(s.height),
        loads: shading_loads(
            ctx,
            &gpu,
            [&nothing_mesh, &full_mesh, &half_mesh]
                .into_iter()
                .chain(&grids),
        )?,
    };
    let screen_fragments = planner.load_of(&full_mesh.0).map_or(0, |l| l.fragments);

    // Every point's pipeline first, then the timed frames in interleaved rounds.
    let specs = point_specs(ctx, &nothing_mesh.0, &full_mesh.0, &half_mesh.0, &grids);
    let bar = crate::bake::progress_bar(s.progress, specs.len(), "probe shaders");
    let mut planned = specs
        .into_iter()
        .map(|(kind, count, untaken, depth_test, mesh)| {
            let (point, pipeline) = planner.plan(kind, count, untaken, depth_test, mesh)?;
            bar.inc(1);
            Ok(Planned {
                point,
                pipeline,
                build: 0,
                mesh,
            })
        })
        .collect::<Result<Vec<_>, GpuError>>()?;
    bar.finish_and_clear();
    let batches = Batches::new(&gpu, s, &planned, &full_mesh.0)?;
    let all: Vec<usize> = (0..planned.len()).collect();
    let (mut timed, mut monitor) = batches.time_batch(
        &planned,
        &all,
        &vec![f64::NAN; planned.len()],
        "probe frames",
    )?;
    let mut states = DeviceStates::from_monitor(&monitor);
    let mut points: Vec<ProbePoint> = planned.iter().map(|p| p.point.clone()).collect();
    measure(&mut points, &timed, &states, states.main_state);
    let mut model = fit_points(ctx, &points)?;
    // A point with too few frames in the sought state, or that the fit misses by more than
    // RETIME_ERROR while its builds disagree (`missed_points`), is timed in another batch,
    // on a pipeline built afresh (a build can run a shader ≈ 25 % slower than another for
    // as long as it lives, `states`); its segments join the first ones, each point's time
    // is its fastest build's, the states are told apart again over every monitor frame and
    // the model fitted again, up to RETIME_BATCHES batches while a point is still missed.
    let mut missed = missed_points(&model, &points, &timed, &states);
    for _ in 0..RETIME_BATCHES {
        if missed.is_empty() {
            break;
        }
        retime(
            &planner,
            &batches,
            &mut planned,
            &missed,
            &points,
            &mut timed,
            &mut monitor,
        )?;
        states = DeviceStates::from_monitor(&monitor);
        measure(&mut points, &timed, &states, states.main_state);
        for &i in &missed {
            points[i].batches += 1;
        }
        model = fit_points(ctx, &points)?;
        missed = missed_points(&model, &points, &timed, &states);
    }
    let model = main_model(ctx, &mut states, &mut points, &timed, model)?;
    for p in &mut points {
        p.model_ms = predict_point(&model, p);
    }
    let state_models = state_models(ctx, &model, &points, &timed, &states)?;
    let monitor_pipeline = planned.swap_remove(batches.monitor_index).pipeline;
    drop(planned);
    let probe = Probe {
        device: ctx.device_name().to_string(),
        width: s.width,
        height: s.height,
        frames: batches.rounds * batches.per_round,
        screen_fragments,
        triangle_pixels: s.triangle_pixels,
        grid: base,
        model,
        states: states.clone(),
        state_models,
        points,
        seconds: started.elapsed().as_secs_f64(),
        measured_at: cache::utc_now(),
        reused_from: None,
    };
    let monitor = Monitor {
        pipeline: monitor_pipeline,
        mesh: full_mesh.0,
        _resources: res,
        _linear: linear,
        gpu,
        states,
    };
    Ok((probe, monitor))
}

/// The monitor of a probe measured before (`states` its speed states), built alone: the
/// empty shader over the screen of `s`'s grid, as [`run_with_monitor`] builds it.
pub fn monitor(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    states: DeviceStates,
) -> Result<Monitor, GpuError> {
    let base = base_grid(s.width, s.height, s.triangle_pixels);
    let gpu = probe_target(ctx, s, base)?;
    let full_mesh = upload_probe_mesh(ctx, s, false, base)?;
    let (res, linear) = point_resources(ctx)?;
    let planner = PointPlanner {
        ctx,
        gpu: &gpu,
        res: &res,
        linear: &linear,
        pixels: f64::from(s.width) * f64::from(s.height),
        loads: shading_loads(ctx, &gpu, std::iter::once(&full_mesh))?,
    };
    let (_, pipeline) = planner.plan(None, 0, false, true, &full_mesh.0)?;
    Ok(Monitor {
        pipeline,
        mesh: full_mesh.0,
        _resources: res,
        _linear: linear,
        gpu,
        states,
    })
}

/// The probe's monitor point (the empty shader over the screen), kept past the probe for
/// `shvis bench` to read between every few frames of its rows, so that they are compared
/// with the model of the state they ran in (`states`).
pub struct Monitor {
    pipeline: crate::gpu::MeshPipeline,
    mesh: MeshBuffers,
    /// What the pipeline's descriptor set refers to (every probe point binds the uniforms).
    _resources: ProbeResources,
    _linear: Sampler,
    gpu: SceneGpu,
    /// The states the probe told apart.
    pub states: DeviceStates,
}

impl Monitor {
    /// One monitor frame now, ms (NaN without timestamps).
    pub fn read(&self) -> Result<f64, GpuError> {
        monitor_frame(&self.gpu, &self.pipeline, &self.mesh)
    }
}
