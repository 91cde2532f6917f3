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
//! than two builds (each with a chunk's frames there) whose medians agree within
//! [`BUILD_AGREEMENT`](crate::probe::states::BUILD_AGREEMENT), gets up to
//! [`MODEL_STATE_ROUNDS`] more (`probe::states`).

mod ladder;
mod model;
pub mod plan;
mod references;
pub mod rows;
mod timing;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use crate::gpu::{Context, GpuError};
use crate::prepare::Prepared;
use crate::probe::{Monitor, Probe};
use crate::render::specular::{NormalFilter, SpecularLight, SpecularTerm};
use crate::render::{FrameSettings, SceneGpu};
use crate::report::ReportError;
use crate::report::bench_output::BenchOutput;
use crate::report::table::{BenchPhases, BenchTable, fill_ratios_to_preconv};
use crate::technique::{HwPath, Technique, TechniqueError};
use ladder::Ladder;
pub use references::References;
use references::render_references;
use rows::{RowTechniques, measure_rows};
use timing::{Rounds, TIMING_ROUNDS, fill_times};

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
    /// Measure the probe again even where one measured before on this device, driver and
    /// build is cached (`probe::cache`).
    pub probe_fresh: bool,
    /// Timed frames per microbenchmark of the probe.
    pub probe_frames: u32,
    /// Run the error ladder where there is a point reference (`crate::attribution`).
    pub ladder: bool,
    /// The ladder evaluates every `ladder_stride`-th pixel in each direction, and measures
    /// each of its steps there (1: every pixel).
    pub ladder_stride: u32,
    /// The techniques measured on `dx11` where `paths` has it (`None`: every one with a
    /// dx11 form; the `headline` set: `catalog::headline_on(HwPath::Dx11)`).
    pub dx11_rows: Option<Vec<Technique>>,
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

/// `--ladder-stride`'s default: the ladder at one pixel of each 2×2 block, a quarter of
/// its CPU work (on the house at 1280×800 every step of the headline rows within 2 % of
/// its every-pixel value, at most 0.0003 absolute).
pub const DEFAULT_LADDER_STRIDE: u32 = 2;

impl BenchSettings {
    /// Whether the bench runs its error ladder: asked for, against a footprint reference
    /// (the point reference beside it is the ladder's first rung), not relit (its CPU rungs
    /// use the bake's lighting) and without a specular term (`specular`; its CPU rungs are
    /// diffuse).
    pub(crate) fn ladder_runs(&self, specular: bool) -> bool {
        self.ladder
            && self.footprint_reference
            && self.ref_spp > 0
            && !specular
            && self.relight_degrees.is_none()
    }

    /// Whether the run measures `technique` on `path`: it runs there
    /// (`Technique::runs_on`) and, on dx11, is one of [`BenchSettings::dx11_rows`].
    pub fn measures(&self, technique: Technique, path: HwPath) -> bool {
        technique.runs_on(path)
            && (path != HwPath::Dx11
                || self
                    .dx11_rows
                    .as_ref()
                    .is_none_or(|rows| rows.contains(&technique)))
    }

    /// The rows per filtering: technique × path pairs the run measures.
    pub fn row_count(&self) -> usize {
        self.techniques
            .iter()
            .map(|&t| self.paths.iter().filter(|&&p| self.measures(t, p)).count())
            .sum()
    }

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
///
/// Phases, each taking the previous one's product: the probe (the device's cost model),
/// the references, the error ladder's set-up, the first timing round (every row built,
/// timed, drawn, measured and attributed), the later rounds, the model's columns, the
/// table; every file goes through one [`BenchOutput`].
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
    let mut clock = Clock::start();
    let mut out = BenchOutput::new(&settings.out, settings.exposure);
    let probe = run_probe(ctx, prepared, settings, &out)?;
    // The probe's monitor, timed around every row's frames (`probe::states`).
    let monitor = probe.as_ref().map(|(_, m)| m);
    clock.split(|p| &mut p.probe);
    let relit = settings.relight_degrees.map(|d| Relit::new(prepared, d));
    let env = relit.as_ref().map_or(&prepared.env, |r| &r.env);
    let references = render_references(ctx, prepared, env, settings, &out)?;
    clock.split(|p| &mut p.references);
    let ladder = Ladder::new(ctx, prepared, settings, references.as_ref(), &out)?;
    clock.split(|p| &mut p.ladder_setup);
    let frame_settings = FrameSettings {
        width: settings.width,
        height: settings.height,
        flat_normals: false,
        ..FrameSettings::default()
    };
    let mut scene = SceneGpu::new(ctx, &prepared.scene, &frame_settings)?;
    let rounds = if settings.specular.is_some() {
        1
    } else {
        TIMING_ROUNDS.min(settings.frames.max(1))
    };
    let per_round = settings.frames.div_ceil(rounds);
    let filters = settings.specular.as_ref().map_or(1, |s| s.filters.len());
    let rows_planned = settings.row_count() * filters;
    clock.progress = plan::Progress::new(rows_planned * rounds as usize);
    let (mut rows, mut samples) = measure_rows(
        ctx,
        &mut scene,
        prepared,
        relit.as_ref(),
        references.as_ref(),
        &ladder,
        settings,
        per_round,
        monitor,
        &mut clock,
        &mut out,
    )?;
    let timing = Rounds {
        rows_of: RowTechniques {
            ctx,
            scene: &scene,
            prepared,
            relit: relit.as_ref(),
        },
        monitor,
        per_round,
        settings,
    };
    timing.later_rounds(rounds, &rows, &mut samples, &mut clock)?;
    if let Some((probe, monitor)) = probe.as_ref().filter(|_| settings.specular.is_none()) {
        timing.until_modelled(probe, monitor, &rows, &mut samples, &mut clock)?;
    }
    fill_times(&mut rows, &samples);
    fill_ratios_to_preconv(&mut rows);
    let modelled = match &probe {
        Some((probe, monitor)) => Some(model::fill_model_columns(
            ctx, &scene, probe, monitor, settings, &mut rows, &samples,
        )?),
        None => None,
    };
    let mut table = assemble_table(
        ctx,
        prepared,
        settings,
        &references,
        &relit,
        probe,
        modelled,
    );
    table.results = rows;
    table.ladder_stride = ladder.stride();
    out.plots(&table, &settings.paths);
    clock.split(|p| &mut p.figures);
    table.seconds = clock.started.elapsed().as_secs_f64();
    table.phases = clock.phases;
    let page = out.table(&table)?;
    log::info!("wrote {}", page.display());
    log::info!(
        "bench: {} rows in {:.1} s ({})",
        table.results.len(),
        table.seconds,
        table.phases.summary()
    );
    Ok(table)
}

/// With `settings.probe`, the device probe at the bench's size (`crate::probe`) and its
/// monitor; its page written.
fn run_probe(
    ctx: &Arc<Context>,
    prepared: &Prepared,
    settings: &BenchSettings,
    out: &BenchOutput,
) -> Result<Option<(Probe, Monitor)>, BenchError> {
    if !settings.probe {
        return Ok(None);
    }
    let (probe, monitor) = crate::probe::cache::run_cached(
        ctx,
        &probe_settings(settings, &prepared.scene),
        &crate::bake::cache::default_cache_dir(),
        settings.probe_fresh,
    )?;
    log::info!(
        "probe: {:.1} s, model within {:.1} % of its microbenchmarks; {}",
        probe.seconds,
        100.0 * probe.worst_relative_error(),
        probe.states.describe()
    );
    out.probe(&probe)?;
    Ok(Some((probe, monitor)))
}

/// The device probe a bench of `settings` on `scene` runs (or reuses).
pub fn probe_settings(
    settings: &BenchSettings,
    scene: &crate::scene::Scene,
) -> crate::probe::ProbeSettings {
    crate::probe::ProbeSettings {
        width: settings.width,
        height: settings.height,
        triangle_pixels: scene.pixel_weighted_triangle_area(settings.width, settings.height),
        warmup: settings.warmup.min(5),
        frames: settings.probe_frames,
        progress: true,
    }
}

/// When the cached probe a bench of `settings` on `scene` would reuse was measured, if
/// there is one and `--probe fresh` is not asked for.
pub fn cached_probe(
    ctx: &Context,
    settings: &BenchSettings,
    scene: &crate::scene::Scene,
) -> Option<String> {
    if !settings.probe || settings.probe_fresh {
        return None;
    }
    crate::probe::cache::measured_at(
        &crate::bake::cache::default_cache_dir(),
        ctx,
        &probe_settings(settings, scene),
    )
}

/// The table's header fields (its rows and timings are filled by [`run`]).
fn assemble_table(
    ctx: &Context,
    prepared: &Prepared,
    settings: &BenchSettings,
    references: &Option<References>,
    relit: &Option<Relit>,
    probe: Option<(Probe, Monitor)>,
    modelled: Option<model::ModelColumns>,
) -> BenchTable {
    let bounced = references.as_ref().and_then(|r| r.main.bounced.as_ref());
    let (bench_state_shares, scene_checks) = match modelled {
        Some(m) => (Some(m.bench_state_shares), m.scene_checks),
        None => (None, Vec::new()),
    };
    BenchTable {
        table_version: crate::report::table::TABLE_VERSION,
        reference_spp: settings.ref_spp,
        ladder_stride: None,
        reference_rel_noise: references.as_ref().map(|r| r.main.rel_noise),
        reference_bounces: bounced.map_or(0, |b| b.bounces),
        reference_bounced_rel_noise: bounced.map(|b| b.rel_noise),
        device: ctx.device_name().to_string(),
        driver: ctx.device_summary().driver,
        width: settings.width,
        height: settings.height,
        vis_res: prepared.visibility.res,
        device_states: probe.as_ref().map(|(p, _)| p.states.clone()),
        bench_state_shares,
        scene_checks,
        state_cost_models: probe
            .as_ref()
            .map(|(p, _)| p.state_models.clone())
            .unwrap_or_default(),
        probe_measured: probe.as_ref().map(|(p, _)| match &p.reused_from {
            Some(file) => format!("{} UTC (reused from {file})", p.measured_at),
            None => format!("{} UTC (this run)", p.measured_at),
        }),
        cost_model: probe.map(|(p, _)| p.model),
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
        results: Vec::new(),
        seconds: 0.0,
        phases: BenchPhases::default(),
    }
}

/// A stopwatch over the whole bench that adds the time since its last split to a phase of
/// [`BenchPhases`], so the phases add up to its wall time (the scene upload and the time
/// between rows count as builds).
pub(crate) struct Clock {
    started: Instant,
    lap: Instant,
    phases: BenchPhases,
    /// The rows' timing rounds, with the time left.
    pub(crate) progress: plan::Progress,
}

impl Clock {
    fn start() -> Clock {
        Clock {
            started: Instant::now(),
            lap: Instant::now(),
            phases: BenchPhases::default(),
            progress: plan::Progress::new(0),
        }
    }

    /// Adds the time since the last split to `phase`.
    pub(crate) fn split(&mut self, phase: fn(&mut BenchPhases) -> &mut f64) {
        *phase(&mut self.phases) += self.lap.elapsed().as_secs_f64();
        self.lap = Instant::now();
    }
}
