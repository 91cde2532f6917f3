//! What a bench will do and about how long it will take, said before it starts, and its
//! progress with an ETA while it measures rows.
//!
//! The estimate is, per phase, its work times a rate: the probe (frames + 1) per
//! megapixel, the references samples per pixel per megapixel (footprint and point), every
//! row's builds (rows × rounds), its frames, its ladder per megapixel of its grid, its images
//! per row; the bakes in seconds. A row's frames are the frames it will draw (warm-up included, one a
//! round after the first where it is slower than `SLOW_FRAME_MS`) at its median frame time
//! in this device's last bench that drew it, or per megapixel where none did, plus a cost
//! per row and round beside its frames (monitor readings, submission, read-back): a bench of
//! other rows than the last, or with other frame counts, is priced by what its own rows
//! cost. The rates and row times are this device's from its last benches at the same frame
//! size (`bench-rates-<key>.json` in the bake cache's folder, rewritten after every bench)
//! or, with none, those of a 2-core lavapipe machine ([`Rates::LAVAPIPE`]); the plan says
//! which. The bakes are those of the last bench with the same bakes on this machine
//! (cached ones then cost nothing), else the lavapipe machine's scaled by texels × rays.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::BenchSettings;
use super::timing::{SLOW_FRAME_MS, TIMING_ROUNDS};
use crate::files::Hasher64;
use crate::gpu::Context;
use crate::prepare::PrepareSettings;
use crate::report::table::{BenchPhases, BenchTable};
use crate::technique::Technique;

/// Bump when the meaning of a rates file changes.
const RATES_VERSION: u64 = 2;

/// Seconds per unit of work of each phase (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rates {
    /// Per (probe frame + 1) per megapixel.
    pub probe: f64,
    /// Per reference sample per pixel per megapixel.
    pub reference: f64,
    /// Per row build.
    pub build: f64,
    /// Per frame (warm-up or timed) per megapixel, of a row this device has not timed (from
    /// a run: its rows' frames, as planned, at their medians, over their frame-megapixels).
    pub frame: f64,
    /// Per row per timing round, beside its frames.
    pub row_round: f64,
    /// Per row's ladder per megapixel of its grid (`--ladder-stride`).
    pub ladder: f64,
    /// Per row's images, and the figures.
    pub images: f64,
}

impl Rates {
    /// A 2-core AMD EPYC VM with lavapipe (llvmpipe, LLVM 15): its `make bench` runs from
    /// a fresh clone (the headline set on dx9, dx10 and dx11 at 1280×800), the frames' rate
    /// per frame a row would draw were it not slow (the slow dx11 rows draw one a round after
    /// their first; 0.07–0.1 s per such frame-megapixel across its speed states). Its probe
    /// at 5 frames a point took 33–62 s over six such runs, one or two speed states (43 s
    /// the median).
    pub const LAVAPIPE: Rates = Rates {
        probe: 7.0,
        reference: 0.215,
        build: 0.17,
        frame: 0.072,
        row_round: 0.1,
        ladder: 1.55,
        images: 0.13,
    };

    /// The rates of a finished bench of `work` with `phases`, whose rows drew `drawn`
    /// frame-megapixels in `frame_seconds` of frames.
    fn from_run(work: &Work, phases: &BenchPhases, drawn: f64, frame_seconds: f64) -> Rates {
        let per = |seconds: f64, units: f64, default: f64| {
            if units > 0.0 && seconds > 0.0 {
                seconds / units
            } else {
                default
            }
        };
        let d = Rates::LAVAPIPE;
        Rates {
            probe: per(phases.probe, work.probe, d.probe),
            reference: per(
                phases.references + phases.ladder_setup,
                work.reference,
                d.reference,
            ),
            build: per(phases.build, work.builds, d.build),
            frame: per(frame_seconds, drawn, d.frame),
            row_round: per(
                (phases.render - frame_seconds).max(0.0),
                work.row_rounds,
                d.row_round,
            ),
            ladder: per(phases.ladder, work.ladder, d.ladder),
            images: per(phases.row_images + phases.figures, work.images, d.images),
        }
    }
}

/// The work of a bench, in the units of [`Rates`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Work {
    probe: f64,
    reference: f64,
    builds: f64,
    /// Frame-megapixels of the rows with no time of their own.
    frames: f64,
    /// Seconds of the frames of the rows with a time of their own.
    known_frame_seconds: f64,
    row_rounds: f64,
    ladder: f64,
    images: f64,
}

/// What a bench will do (rows, frames, references, probe, bakes) and its estimate.
pub struct Plan {
    rows: usize,
    techniques: usize,
    rounds: u32,
    work: Work,
    probe_cached: Option<String>,
    rates: Rates,
    rates_from: String,
    bake_seconds: f64,
    bakes_from: String,
    bake_key: u64,
    rates_file: PathBuf,
    bake_names: Vec<&'static str>,
    schedule: FrameSchedule,
    /// Rows the plan priced by their own last time.
    known_rows: usize,
}

/// How a bench's rows draw their frames (`bench::timing`): `warmup` before the first
/// round's `per_round`, one before each later round's.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FrameSchedule {
    warmup: u32,
    per_round: u32,
    rounds: u32,
}

impl FrameSchedule {
    /// The schedule of a bench of `settings` with `specular_filters` specular filterings (0:
    /// none; a specular bench times its rows in one round).
    fn of(settings: &BenchSettings, specular_filters: usize) -> FrameSchedule {
        let rounds = if specular_filters > 0 {
            1
        } else {
            TIMING_ROUNDS.min(settings.frames.max(1))
        };
        FrameSchedule {
            warmup: settings.warmup,
            per_round: settings.frames.div_ceil(rounds),
            rounds,
        }
    }

    /// Frames a row draws, warm-up and its image's included, where its frames take `ms`
    /// (unknown: `None`): a slow row one a round after its first.
    fn frames(&self, ms: Option<f64>) -> u32 {
        let later = if ms.is_some_and(|ms| ms >= SLOW_FRAME_MS) {
            1
        } else {
            self.per_round
        };
        self.warmup + self.per_round + 1 + (self.rounds - 1) * (self.warmup.min(1) + later)
    }
}

/// A row's key in the rates file: "technique.path".
fn row_key(technique: impl std::fmt::Display, path: impl std::fmt::Display) -> String {
    format!("{technique}.{path}")
}

impl Plan {
    /// The plan of a bench of `settings` (its rows before any is left out for lack of a
    /// height map) with `specular_filters` specular filterings (0: none; its specular term
    /// is set up after the bakes) after bakes of `prepare`; `probe_cached`: when the cached
    /// probe it will reuse was measured, if there is one.
    pub fn new(
        ctx: &Context,
        settings: &BenchSettings,
        specular_filters: usize,
        prepare: &PrepareSettings,
        probe_cached: Option<String>,
    ) -> Plan {
        let rows_per_filter = settings.row_count();
        let filters = specular_filters.max(1);
        let rows = rows_per_filter * filters;
        let schedule = FrameSchedule::of(settings, specular_filters);
        let rounds = schedule.rounds;
        let mpx = f64::from(settings.width) * f64::from(settings.height) / 1e6;
        let rates_file = rates_file(ctx, settings.width, settings.height);
        let history = read_history(&rates_file);
        // Each row's last median frame time on this device (specular rows: none kept).
        let row_ms = |technique: Technique, path| {
            history
                .as_ref()
                .filter(|_| specular_filters == 0)
                .and_then(|h| h.row_ms.get(&row_key(technique, path)).copied())
        };
        let (mut unknown_frames, mut known_frame_seconds, mut known_rows) = (0.0, 0.0, 0);
        for &technique in &settings.techniques {
            for &path in settings
                .paths
                .iter()
                .filter(|&&p| settings.measures(technique, p))
            {
                let ms = row_ms(technique, path);
                let frames = f64::from(schedule.frames(ms)) * filters as f64;
                match ms {
                    Some(ms) => {
                        known_frame_seconds += frames * ms / 1000.0;
                        known_rows += 1;
                    }
                    None => unknown_frames += frames * mpx,
                }
            }
        }
        let references = if settings.ref_spp == 0 {
            0.0
        } else if settings.footprint_reference {
            2.0
        } else {
            1.0
        };
        let ladder = settings.ladder_runs(specular_filters > 0);
        let work = Work {
            probe: if settings.probe && probe_cached.is_none() {
                f64::from(settings.probe_frames + 1) * mpx
            } else {
                0.0
            },
            reference: references * f64::from(settings.ref_spp) * mpx,
            builds: (rows as u32 * rounds) as f64,
            frames: unknown_frames,
            known_frame_seconds,
            row_rounds: (rows as u32 * rounds) as f64,
            ladder: if ladder {
                rows as f64 * mpx / f64::from(settings.ladder_stride.pow(2))
            } else {
                0.0
            },
            images: rows as f64,
        };
        let bake_key = bake_key(prepare, &settings.techniques);
        let (rates, rates_from) = match &history {
            Some(h) => (h.rates, format!("this device's last bench, {}", h.measured)),
            None => (
                Rates::LAVAPIPE,
                "a 2-core lavapipe machine's rates: no bench on this device yet".into(),
            ),
        };
        let (bake_seconds, bakes_from) = match history.as_ref().filter(|h| h.bake_key == bake_key) {
            Some(h) => (h.bake_seconds, "as the last run's".to_string()),
            None => (
                default_bake_seconds(prepare, &settings.techniques),
                "from a 2-core machine's rates".to_string(),
            ),
        };
        Plan {
            rows,
            techniques: settings.techniques.len(),
            rounds,
            work,
            probe_cached,
            rates,
            rates_from,
            bake_seconds,
            bakes_from,
            bake_key,
            rates_file,
            bake_names: bake_names(prepare, &settings.techniques),
            schedule,
            known_rows,
        }
    }

    /// Seconds the bench is expected to take after its bakes, per phase in order.
    fn phase_seconds(&self) -> [f64; 6] {
        let (w, r) = (&self.work, &self.rates);
        [
            w.probe * r.probe,
            w.reference * r.reference,
            w.builds * r.build,
            w.frames * r.frame + w.known_frame_seconds + w.row_rounds * r.row_round,
            w.ladder * r.ladder,
            w.images * r.images,
        ]
    }

    /// Seconds of the whole run, bakes included.
    pub fn estimate_seconds(&self) -> f64 {
        self.bake_seconds + self.phase_seconds().iter().sum::<f64>()
    }

    /// The plan in a few lines, for the terminal.
    pub fn describe(&self, settings: &BenchSettings) -> String {
        let [probe, references, builds, frames, ladder, images] = self.phase_seconds();
        let paths: Vec<String> = settings.paths.iter().map(|p| p.to_string()).collect();
        let probe_line = match (&self.probe_cached, settings.probe) {
            (_, false) => "no device probe (--no-probe)".to_string(),
            (Some(when), true) => format!("the device probe measured {when}, reused"),
            (None, true) => format!(
                "the device probe ({} frames per microbenchmark) ≈ {}",
                settings.probe_frames,
                duration(probe)
            ),
        };
        format!(
            "plan: {} rows ({} techniques × {}) at {}×{}, {} timed frames each after {} warm-up, in {} rounds ≈ {} (builds {}, frames {}: {} of the rows at their own last time here, images {})\n\
             plan: bakes ({}) ≈ {} ({}); {}; references at {} spp ≈ {}; error ladder ≈ {}\n\
             plan: about {} in all ({})",
            self.rows,
            self.techniques,
            paths.join(", "),
            settings.width,
            settings.height,
            settings.frames,
            settings.warmup,
            self.rounds,
            duration(builds + frames + images),
            duration(builds),
            duration(frames),
            self.known_rows,
            duration(images),
            self.bake_names.join(", "),
            duration(self.bake_seconds),
            self.bakes_from,
            probe_line,
            settings.ref_spp,
            duration(references),
            duration(ladder),
            duration(self.estimate_seconds()),
            self.rates_from,
        )
    }

    /// Rewrites this device's rates file from the finished `table` and its bakes' seconds.
    pub fn record(&self, table: &BenchTable, bake_seconds: f64) {
        let mut work = self.work;
        // The probe ran only when none was reused.
        if table.phases.probe <= 0.0 {
            work.probe = 0.0;
        }
        // Rows left out (no height map) did no work.
        let scale = if self.rows > 0 {
            table.results.len() as f64 / self.rows as f64
        } else {
            0.0
        };
        work.builds *= scale;
        work.row_rounds *= scale;
        work.ladder *= scale;
        work.images *= scale;
        // What the rows' planned frames took at their medians; the rest of the render phase
        // (re-timing rounds among it) is the rows' rounds' own cost.
        let mpx = f64::from(table.width) * f64::from(table.height) / 1e6;
        let (mut drawn, mut frame_seconds) = (0.0, 0.0);
        let mut row_ms = read_history(&self.rates_file)
            .map(|h| h.row_ms)
            .unwrap_or_default();
        for row in &table.results {
            let Some(ms) = row.ms_median.filter(|ms| ms.is_finite() && *ms > 0.0) else {
                continue;
            };
            let frames = f64::from(self.schedule.frames(Some(ms)));
            drawn += frames * mpx;
            frame_seconds += frames * ms / 1000.0;
            if row.specular.is_none() {
                row_ms.insert(row_key(row.technique, row.path), ms);
            }
        }
        let mut rates = Rates::from_run(&work, &table.phases, drawn, frame_seconds);
        if work.probe == 0.0 {
            rates.probe =
                read_history(&self.rates_file).map_or(self.rates.probe, |h| h.rates.probe);
        }
        let history = History {
            version: RATES_VERSION,
            measured: crate::files::clock::utc_now(),
            rates,
            bake_key: self.bake_key,
            bake_seconds,
            row_ms,
        };
        let written = serde_json::to_vec_pretty(&history)
            .map_err(|e| e.to_string())
            .and_then(|json| {
                crate::files::write(&self.rates_file, json).map_err(|e| e.to_string())
            });
        if let Err(e) = written {
            log::warn!("{}: rates not kept: {e}", self.rates_file.display());
        }
    }
}

/// A device's rates file.
#[derive(Clone, Serialize, Deserialize)]
struct History {
    version: u64,
    /// When (UTC).
    measured: String,
    rates: Rates,
    /// The bakes of that run ([`bake_key`]) and their seconds.
    bake_key: u64,
    bake_seconds: f64,
    /// Each row's median frame time, ms, in the last bench that drew it ([`row_key`]).
    row_ms: BTreeMap<String, f64>,
}

/// The rates file of this device at a `width` × `height` frame: rates per megapixel learnt
/// from a small frame (where each frame's fixed cost dominates) would price a large one many
/// times over, so each frame size keeps its own.
fn rates_file(ctx: &Context, width: u32, height: u32) -> PathBuf {
    let device = ctx.device_summary();
    let mut h = Hasher64::default();
    for text in [device.name.as_str(), device.driver.as_str()] {
        h.write(text.as_bytes());
        h.write_u64(text.len() as u64);
    }
    h.write_u64(u64::from(width));
    h.write_u64(u64::from(height));
    crate::bake::cache::default_cache_dir().join(format!("bench-rates-{:016x}.json", h.finish()))
}

/// This device's rates file, if there is one to believe; one that is not believed is said,
/// left unused, and rewritten by the bench's end.
fn read_history(file: &Path) -> Option<History> {
    let bytes = crate::files::read_bounded(file, 1 << 20, "bench rates").ok()?;
    let history = serde_json::from_slice::<History>(&bytes)
        .map_err(|e| e.to_string())
        .and_then(|h| h.check().map(|()| h));
    match history {
        Ok(h) => Some(h),
        Err(why) => {
            log::warn!(
                "{}: bench rates not believed ({why}); the plan uses a 2-core lavapipe \
                 machine's, and this bench measures them again",
                file.display()
            );
            None
        }
    }
}

impl History {
    /// Why the file cannot be believed, if it cannot: another version, a rate or the bakes'
    /// seconds not finite, not positive or beyond a day, or a date that is not one.
    fn check(&self) -> Result<(), String> {
        if self.version != RATES_VERSION {
            return Err(format!(
                "version {}, this build reads {RATES_VERSION}",
                self.version
            ));
        }
        let r = &self.rates;
        for (name, seconds) in [
            ("probe", r.probe),
            ("reference", r.reference),
            ("build", r.build),
            ("frame", r.frame),
            ("row_round", r.row_round),
            ("ladder", r.ladder),
            ("images", r.images),
            ("bake_seconds", self.bake_seconds),
        ] {
            if !(seconds.is_finite() && seconds > 0.0 && seconds <= DAY_SECONDS) {
                return Err(format!(
                    "{name} is {seconds} s, not a duration between 0 and a day"
                ));
            }
        }
        if let Some((row, ms)) = self
            .row_ms
            .iter()
            .find(|(_, ms)| !(ms.is_finite() && **ms > 0.0 && **ms <= 1000.0 * DAY_SECONDS))
        {
            return Err(format!("{row} is {ms} ms a frame, not a duration"));
        }
        if !crate::files::clock::is_utc_minute(&self.measured) {
            return Err(format!(
                "measured {:?} is not a UTC time \"YYYY-MM-DD HH:MM\"",
                self.measured
            ));
        }
        Ok(())
    }
}

/// Longest any one rate or bake of a bench may take, seconds.
const DAY_SECONDS: f64 = 86_400.0;

/// What changes the bakes of a run: the prepare settings and the techniques' needs.
fn bake_key(prepare: &PrepareSettings, techniques: &[Technique]) -> u64 {
    let mut h = Hasher64::default();
    h.write(format!("{prepare:?}").as_bytes());
    for t in techniques {
        h.write(t.name().as_bytes());
        h.write_u64(0);
    }
    h.finish()
}

/// The bakes a run does, in words.
fn bake_names(prepare: &PrepareSettings, techniques: &[Technique]) -> Vec<&'static str> {
    let any =
        |f: fn(&crate::technique::BakeNeeds) -> bool| techniques.iter().any(|t| f(&t.needs()));
    let mut names = vec!["visibility"];
    if prepare.sh_lightmap_bounces.is_some() {
        names.push("SH lightmap");
    }
    if prepare.transfer_bounces.is_some() {
        names.push("transfer matrices");
    }
    if any(|n| n.clusters.is_some()) {
        names.push("clusters");
    }
    if any(|n| n.pca_vectors.is_some()) {
        names.push("PCA");
    }
    if any(|n| n.ao) {
        names.push("AO");
    }
    names
}

/// The bakes' seconds on a 2-core machine (the house at 512² texels × 1024 rays: visibility
/// 0.5 s, the SH lightmap 6.5 s and the transfer matrices 22 s with 2 bounces, each basis
/// fitted from the samples [`SECONDS_PER_SAMPLE_FIT`], k-means 0.12 s per cluster, a CPCA
/// fit 7.5 s), scaled by texels × rays; the SH lightmap's rays and fits by
/// [`PIXELS_BAKE_FACTOR`] with `--bake-env pixels`.
fn default_bake_seconds(prepare: &PrepareSettings, techniques: &[Technique]) -> f64 {
    let scale =
        f64::from(prepare.vis_res).powi(2) * f64::from(prepare.rays) / (512.0 * 512.0 * 1024.0);
    let passes = |bounces: Option<u32>| bounces.map_or(0.0, |b| f64::from(1 + b) / 3.0);
    let fits = if prepare.sh_lightmap_bounces.is_some() {
        prepare.sample_fits.len() as f64
    } else {
        0.0
    };
    let own_rays = match prepare.bake_env {
        crate::bake::shlmap::BakeEnv::Sh => 1.0,
        crate::bake::shlmap::BakeEnv::Pixels => PIXELS_BAKE_FACTOR,
    };
    let mut seconds = 0.5
        + (6.5 * passes(prepare.sh_lightmap_bounces) + SECONDS_PER_SAMPLE_FIT * fits) * own_rays
        + 18.5 * passes(prepare.transfer_bounces);
    for t in techniques {
        if let Some(c) = t.needs().clusters {
            seconds += if c.m == 0 { 0.09 * f64::from(c.k) } else { 6.0 };
        }
    }
    seconds * scale
}

/// How much longer the SH lightmap bake takes with `--bake-env pixels` (each texel's own
/// rays, drawn one by one from the map, and a quarter more samples per fit): the house at
/// 512² × 1024 rays with nine fits, 50.0 s → 87.0 s on 2 cores.
pub const PIXELS_BAKE_FACTOR: f64 = 1.75;

/// Seconds one basis fitted from the samples adds to the SH lightmap bake of the house at
/// 512² texels × 1024 rays on 2 cores (the headline's four tangent-frame bases together,
/// over four).
pub const SECONDS_PER_SAMPLE_FIT: f64 = 1.6;

/// Progress over the rows' timing rounds with an ETA from the pace so far.
pub(crate) struct Progress {
    total: usize,
    done: usize,
    started: Option<Instant>,
}

impl Progress {
    pub(crate) fn new(steps: usize) -> Progress {
        Progress {
            total: steps,
            done: 0,
            started: None,
        }
    }

    /// `steps` more steps than planned.
    pub(crate) fn add(&mut self, steps: usize) {
        self.total += steps;
    }

    /// One more step of `total` is about to start (`what`): logged with the time left.
    pub(crate) fn step(&mut self, what: &str) {
        let started = *self.started.get_or_insert_with(Instant::now);
        if self.done > 0 && self.total > self.done {
            let left = started.elapsed().as_secs_f64() / self.done as f64
                * (self.total - self.done) as f64;
            log::info!(
                "[{}/{}] {what} — about {} left",
                self.done + 1,
                self.total,
                duration(left)
            );
        } else {
            log::info!(
                "[{}/{}] {what}",
                self.done + 1,
                self.total.max(self.done + 1)
            );
        }
        self.done += 1;
        self.total = self.total.max(self.done);
    }
}

/// "3 min 20 s", "45 s".
pub fn duration(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    if s >= 60 {
        format!("{} min {:02} s", s / 60, s % 60)
    } else {
        format!("{s} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn durations_read_as_minutes_and_seconds() {
        assert_eq!(duration(0.4), "0 s");
        assert_eq!(duration(59.6), "1 min 00 s");
        assert_eq!(duration(275.8), "4 min 36 s");
    }

    #[test]
    fn rates_from_a_run_divide_its_seconds_by_its_work() {
        let work = Work {
            probe: 2.0,
            reference: 10.0,
            builds: 4.0,
            frames: 100.0,
            known_frame_seconds: 0.0,
            row_rounds: 4.0,
            ladder: 0.0,
            images: 4.0,
        };
        let phases = BenchPhases {
            probe: 20.0,
            references: 1.5,
            ladder_setup: 0.5,
            build: 2.0,
            render: 7.0,
            row_images: 1.0,
            ladder: 3.0,
            figures: 1.0,
        };
        // The rows drew 50 frame-megapixels in 3 s of frames; the rest of the render phase
        // is their rounds' own cost.
        let r = Rates::from_run(&work, &phases, 50.0, 3.0);
        assert_eq!(r.probe, 10.0);
        assert_eq!(r.reference, 0.2);
        assert_eq!(r.build, 0.5);
        assert_eq!(r.frame, 0.06);
        assert_eq!(r.row_round, 1.0);
        // No ladder work: the default rate stays.
        assert_eq!(r.ladder, Rates::LAVAPIPE.ladder);
        assert_eq!(r.images, 0.5);
    }

    #[test]
    fn a_slow_row_is_planned_at_one_frame_a_round_after_its_first() {
        let schedule = FrameSchedule {
            warmup: 1,
            per_round: 3,
            rounds: 3,
        };
        // 1 warm-up + 3 + the image, then two rounds of 1 warm-up + 3 (a slow row: + 1).
        assert_eq!(schedule.frames(None), 13);
        assert_eq!(schedule.frames(Some(30.0)), 13);
        assert_eq!(schedule.frames(Some(SLOW_FRAME_MS)), 9);
        let once = FrameSchedule {
            warmup: 10,
            per_round: 100,
            rounds: 1,
        };
        assert_eq!(once.frames(Some(1000.0)), 111);
    }

    #[test]
    fn a_rates_file_that_cannot_be_a_measurement_is_not_believed() {
        let dir = std::env::temp_dir().join(format!("shvis-rates-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("bench-rates.json");
        let good = History {
            version: RATES_VERSION,
            measured: "2026-12-06 10:00".into(),
            rates: Rates::LAVAPIPE,
            bake_key: 1,
            bake_seconds: 30.0,
            row_ms: BTreeMap::from([("unc6.dx9".to_string(), 85.0)]),
        };
        let written = |h: &History| {
            std::fs::write(&file, serde_json::to_vec(h).unwrap()).unwrap();
            read_history(&file)
        };
        assert!(written(&good).is_some());
        for (lie, says) in [
            (
                History {
                    rates: Rates {
                        frame: -0.1,
                        ..Rates::LAVAPIPE
                    },
                    ..good.clone()
                },
                "frame is -0.1 s",
            ),
            (
                History {
                    rates: Rates {
                        probe: 1e9,
                        ..Rates::LAVAPIPE
                    },
                    ..good.clone()
                },
                "probe is 1000000000 s",
            ),
            (
                History {
                    bake_seconds: 0.0,
                    ..good.clone()
                },
                "bake_seconds is 0 s",
            ),
            (
                History {
                    measured: "| x |".into(),
                    ..good.clone()
                },
                "measured \"| x |\" is not a UTC time",
            ),
            (
                History {
                    row_ms: BTreeMap::from([("unc6.dx11".to_string(), -1.0)]),
                    ..good.clone()
                },
                "unc6.dx11 is -1 ms a frame",
            ),
            (
                History {
                    version: 0,
                    ..good.clone()
                },
                "version 0",
            ),
        ] {
            assert!(written(&lie).is_none(), "{says}");
            assert!(lie.check().unwrap_err().contains(says), "{says}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
