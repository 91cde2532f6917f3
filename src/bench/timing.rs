//! A bench's frame times: each row's frames timed in chunks between readings of the
//! probe's monitor frame (`probe::states`), in [`TIMING_ROUNDS`] rounds over every row, and
//! up to [`MODEL_STATE_ROUNDS`] more rounds for a row without frames of two agreeing builds
//! in a state the probe has a model of; after its first round a row slower than
//! [`SLOW_FRAME_MS`] a frame times one frame per round.

use super::rows::RowTechniques;
use super::{BenchError, BenchSettings, Clock};
use crate::gpu::{GpuError, TimingStats};
use crate::probe::states::{BUILD_AGREEMENT, Segment};
use crate::probe::{Monitor, Probe, Segmented};
use crate::report::table::BenchRow;
use crate::technique::{HwPath, Technique};

/// Rounds a row's timed frames are split into, each round over every row (the main bench;
/// with `--specular` one): a slow spell of a shared device then lands on a share of every
/// row's frames instead of on all of a few rows'.
pub(super) const TIMING_ROUNDS: u32 = 3;

/// Frames of a row timed between two monitor readings, at most ([`timed_segments`]).
const CHUNK_FRAMES: u32 = 3;

/// Rounds more, at most, for a row that has no frames in a state the probe has a model of,
/// or not two builds there that agree within [`BUILD_AGREEMENT`].
const MODEL_STATE_ROUNDS: usize = 3;

/// Passes over the rows still to settle, at most, counting those that time none
/// ([`Rounds::until_modelled`]).
const MAX_RETIMING_PASSES: usize = 4 * MODEL_STATE_ROUNDS;

/// The share of the rows a re-timing round times that it must settle for another round to
/// follow ([`Rounds::until_modelled`]).
const SETTLED_SHARE: f64 = 0.25;

/// A row whose frames so far have a median this slow (ms) or slower times one frame per
/// round after its first: a frame this long varies by a small share of itself, and such
/// frames are most of a run's time where they occur (lavapipe decodes block-compressed
/// textures in software: its dx11 rows take ≈ 1 s a frame). Its rounds still each run on a
/// build of its own, as the speed states need.
pub(super) const SLOW_FRAME_MS: f64 = 250.0;

/// How the rounds after the first time a row: on a build of its own each, `per_round`
/// frames (one for a row slower than [`SLOW_FRAME_MS`]) after one warm-up frame, between
/// monitor readings.
pub(super) struct Rounds<'a> {
    pub rows_of: RowTechniques<'a>,
    pub monitor: Option<&'a Monitor>,
    pub per_round: u32,
    pub settings: &'a BenchSettings,
}

impl Rounds<'_> {
    /// One more round of a row, on a build of its own (`probe::states`: builds differ).
    fn time_round(
        &self,
        technique: Technique,
        path: HwPath,
        times: &mut Segmented,
        clock: &mut Clock,
    ) -> Result<(), BenchError> {
        let tech = self.rows_of.build(technique, path)?;
        clock.split(|p| &mut p.build);
        let build = times.0.last().map_or(0, |s| s.build + 1);
        let frames = self.round_frames(times);
        let scene = self.rows_of.scene;
        times.0.extend(timed_segments(
            self.monitor,
            build,
            self.settings.warmup.min(1),
            frames,
            |w, n| tech.time(scene, w, n),
        )?);
        clock.split(|p| &mut p.render);
        Ok(())
    }

    /// Frames a round after the first times of a row with these frames so far: one for a
    /// row slower than [`SLOW_FRAME_MS`], else `per_round`.
    fn round_frames(&self, times: &Segmented) -> u32 {
        let timed: Vec<f64> = times.0.iter().flat_map(|s| s.ms.iter().copied()).collect();
        if !timed.is_empty() && crate::gpu::frame_timing::median(&timed) >= SLOW_FRAME_MS {
            1
        } else {
            self.per_round
        }
    }

    /// Rounds 2 … `rounds` over every row.
    pub(super) fn later_rounds(
        &self,
        rounds: u32,
        rows: &[BenchRow],
        samples: &mut [Segmented],
        clock: &mut Clock,
    ) -> Result<(), BenchError> {
        for round in 1..rounds {
            for (row, times) in rows.iter().zip(samples.iter_mut()) {
                clock.progress.step(&format!(
                    "{}.{}: timing round {} of {rounds}",
                    row.technique,
                    row.path,
                    round + 1
                ));
                self.time_round(row.technique, row.path, times, clock)?;
            }
        }
        Ok(())
    }

    /// A row with no frames in a state the probe has a model of (the device sat in another
    /// through all its rounds) is timed in up to MODEL_STATE_ROUNDS more until it has some:
    /// else its ×model would set frames of one state against the model of another. So is a
    /// row whose frames in its fastest modelled state came from fewer than two builds with
    /// a chunk's frames there (CHUNK_FRAMES, or a round's where a round times fewer), or
    /// whose two fastest such builds there differ by more than BUILD_AGREEMENT: a build can run
    /// ≈ 25 % slow for as long as it lives (`probe::states`), and its time there is its
    /// fastest build's. Not with `--specular`: its rows differ by the specular term bound
    /// when they were measured, and only the last one is bound now.
    ///
    /// Such rounds are only spent where they can settle a row: a row is passed over while
    /// the monitor reads a state with no model (its frames could not count), and the rounds
    /// stop once one settles fewer than [`SETTLED_SHARE`] of the rows it timed — the builds
    /// then disagree because the device's speed drifts between rounds, not because one build
    /// is odd, and more rounds would only repeat every row's work.
    pub(super) fn until_modelled(
        &self,
        probe: &Probe,
        monitor: &Monitor,
        rows: &[BenchRow],
        samples: &mut [Segmented],
        clock: &mut Clock,
    ) -> Result<(), BenchError> {
        let modelled: Vec<usize> = probe.state_models.iter().map(|m| m.state).collect();
        let unsettled = |samples: &[Segmented]| -> Vec<usize> {
            (0..rows.len())
                .filter(|&i| {
                    match samples[i].fastest_state(&monitor.states, modelled.iter().copied()) {
                        Some((state, _, _)) => {
                            // A build counts with the frames of one chunk of a round there.
                            let frames = self.round_frames(&samples[i]).min(CHUNK_FRAMES);
                            !samples[i].builds_agree_in(
                                &monitor.states,
                                state,
                                BUILD_AGREEMENT,
                                frames as usize,
                            )
                        }
                        None => true,
                    }
                })
                .collect()
        };
        let mut left = unsettled(samples);
        // Rounds that timed a row, and passes over the rows in all (a pass that times none
        // costs a monitor frame per row: a spell in a state with no model waits a few).
        let (mut rounds, mut passes) = (0, 0);
        while rounds < MODEL_STATE_ROUNDS && passes < MAX_RETIMING_PASSES {
            passes += 1;
            if left.is_empty() {
                break;
            }
            log::info!(
                "cost model: {} row(s) without frames of two builds within {:.0} % of each other in a modelled state, timed again",
                left.len(),
                100.0 * BUILD_AGREEMENT
            );
            clock.progress.add(left.len());
            let (mut timed, mut passed_over) = (0usize, 0usize);
            for &i in &left {
                clock.progress.step(&format!(
                    "{}.{}: timed again",
                    rows[i].technique, rows[i].path
                ));
                let now = monitor.states.state_of(monitor.read()?);
                if !now.is_some_and(|s| modelled.contains(&s)) {
                    passed_over += 1;
                    continue;
                }
                self.time_round(rows[i].technique, rows[i].path, &mut samples[i], clock)?;
                timed += 1;
            }
            if timed > 0 {
                rounds += 1;
            }
            let still = unsettled(samples);
            let settled = left.len() - still.len();
            left = still;
            if passed_over > 0 {
                log::info!(
                    "cost model: {passed_over} row(s) passed over, the device in a state with no model"
                );
            }
            if timed > 0 && (settled as f64) < SETTLED_SHARE * timed as f64 {
                log::info!(
                    "cost model: {settled} of {timed} row(s) timed again settled; the builds of {} row(s) still disagree (the device's speed drifts between rounds), no more rounds",
                    left.len()
                );
                break;
            }
        }
        Ok(())
    }
}

/// Each row's time columns from all its frames (every segment logged at debug level).
pub(super) fn fill_times(rows: &mut [BenchRow], samples: &[Segmented]) {
    if log::log_enabled!(log::Level::Debug) {
        for (row, times) in rows.iter().zip(samples) {
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
    for (row, times) in rows.iter_mut().zip(samples) {
        let timing = TimingStats::from_ms(&times.all());
        row.ms_median = timing.map(|t| t.ms_median);
        row.ms_min = timing.map(|t| t.ms_min);
        row.ms_max = timing.map(|t| t.ms_max);
        row.frames = times.all().len();
    }
}

/// Times `frames` frames (after `warmup` untimed ones) with `time` (warm-up, frames → ms),
/// on pipeline build `build`, in chunks of at most [`CHUNK_FRAMES`] with a monitor reading
/// before each and after the last (NaN without a monitor): the states (`probe::states`) are
/// told apart per chunk, not per round (one round of a row can span a second, as long as
/// the device's stay in a state).
pub(super) fn timed_segments(
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
