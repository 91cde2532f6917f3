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

/// Fewest frames of a row in a speed state for its ×model to be taken there.
pub(super) const MIN_STATE_FRAMES: usize = 3;

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
        let modelled = probe.state_models.iter().map(|m| m.state);
        let (state, measured, state_frames) = compared_time(times, &monitor.states, modelled);
        let model = state.and_then(|s| probe.model_of(s));
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

/// A row's time for its ×model (like with like): the median of its fastest build's frames in
/// the fastest state of `modelled` that it ran at least [`MIN_STATE_FRAMES`] frames in,
/// with the state and its frame count; where it ran that many in none (a second-long dx11
/// frame whose monitor frames read as spikes), its fastest build's frames whatever the
/// state, for the main model (state `None`, 0 frames), not the few frames a state filter
/// happened to keep.
pub(super) fn compared_time(
    times: &Segmented,
    states: &DeviceStates,
    modelled: impl IntoIterator<Item = usize>,
) -> (Option<usize>, Option<f64>, usize) {
    let mut modelled: Vec<usize> = modelled.into_iter().collect();
    // States are numbered fastest first.
    modelled.sort_unstable();
    modelled
        .into_iter()
        .find_map(|state| match times.median_in(states, state) {
            (Some(ms), frames) if frames >= MIN_STATE_FRAMES => {
                Some((Some(state), Some(ms), frames))
            }
            _ => None,
        })
        .unwrap_or_else(|| (None, times.fastest_build_median(), 0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_row_with_few_frames_in_a_state_is_timed_by_its_fastest_build() {
        let states = DeviceStates::from_monitor(&[3.0, 3.1, 3.2, 3.0, 3.1, 3.05, 3.15, 3.1]);
        let spike = states.spike_ms * 2.0;
        // Second-long frames, one per build: only the slowest sits between two monitor
        // frames that are not spikes.
        let mut heavy = Segmented::default();
        heavy.push(0, 3.0, vec![1133.0], spike);
        heavy.push(1, spike, vec![1200.0], 3.1);
        heavy.push(2, 3.0, vec![1541.0], 3.1);
        heavy.push(3, 3.1, vec![1300.0], spike);
        assert_eq!(compared_time(&heavy, &states, [0]), (None, Some(1133.0), 0));
        // Three frames in the state: taken there.
        let mut settled = Segmented::default();
        settled.push(0, 3.0, vec![10.0, 11.0], 3.1);
        settled.push(1, 3.0, vec![12.0], 3.1);
        settled.push(2, 3.0, vec![30.0], spike);
        assert_eq!(
            compared_time(&settled, &states, [0]),
            (Some(0), Some(10.5), 3)
        );
        // Two frames in the fast state, three in the slow one: compared in the slow one.
        let two = DeviceStates::from_monitor(&[1.0, 1.0, 1.0, 2.0, 2.0, 2.0]);
        let mut split = Segmented::default();
        split.push(0, 1.0, vec![5.0, 5.5], 1.0);
        split.push(1, 2.0, vec![8.0, 8.5, 9.0], 2.0);
        assert_eq!(compared_time(&split, &two, [1, 0]), (Some(1), Some(8.5), 3));
    }
}
