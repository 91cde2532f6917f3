//! The cost model's columns of a bench's rows (`crate::cost`, fitted by `crate::probe`):
//! the lanes each row keeps busy, its modelled time in the speed state it is compared in,
//! and measured ÷ modelled; and, beside the rows, the states the bench's frames ran in and
//! the probe's own shaders drawn over the scene.

use std::sync::Arc;

use super::{BenchError, BenchSettings};
use crate::gpu::Context;
use crate::probe::scene_check::SceneCheck;
use crate::probe::{DeviceStates, Monitor, Probe, Segmented};
use crate::render::SceneGpu;
use crate::report::table::BenchRow;

/// What the model adds beside the rows.
pub(super) struct ModelColumns {
    /// The share of the bench's monitor frames in each speed state.
    pub bench_state_shares: Vec<f64>,
    /// The probe's shaders over the scene's mesh, each against the model.
    pub scene_checks: Vec<SceneCheck>,
}

/// Fills every row's `coverage`, `edge_pixels`, `model_ms`, `model_state`,
/// `model_state_frames` and `x_model` from `probe`'s model; returns the columns beside them.
pub(super) fn fill_model_columns(
    ctx: &Arc<Context>,
    scene: &SceneGpu,
    probe: &Probe,
    monitor: &Monitor,
    settings: &BenchSettings,
    rows: &mut [BenchRow],
    samples: &[Segmented],
) -> Result<ModelColumns, BenchError> {
    let monitor_frames: Vec<f64> = samples.iter().flat_map(Segmented::monitor_frames).collect();
    let shares = monitor.states.shares_of(&monitor_frames);
    log::info!(
        "cost model: {}; the bench's monitor frames: {} in each state",
        monitor.states.describe(),
        DeviceStates::format_shares(&shares)
    );
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
    let scene_checks =
        crate::probe::scene_check::run(ctx, scene, &probe.model, &load, pixels, settings.frames)?;
    log::info!(
        "cost model, the probe's shaders over the scene: {}",
        crate::probe::scene_check::summary(&scene_checks)
    );
    for (row, times) in rows.iter_mut().zip(samples) {
        let load = row.own_mesh_load.unwrap_or(load);
        row.coverage = load.lanes / pixels;
        row.edge_pixels = load.edge_pixels;
        // Like with like: the row's frames in the fastest state it ran in that the probe
        // has a model of (its fastest build's), against that model; else every frame
        // against the main model.
        let states = &monitor.states;
        let modelled = probe.state_models.iter().map(|m| m.state);
        let (model, measured, state, state_frames) = match times.fastest_state(states, modelled) {
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
    Ok(ModelColumns {
        bench_state_shares: shares,
        scene_checks,
    })
}
