//! The device probe, kept between benches: a bench reuses the probe measured before on the
//! same device and driver, by the same build, with the same settings — its model and speed
//! states — and rebuilds only the monitor ([`super::monitor`]); `--probe fresh` measures
//! again (and replaces the file). A file is `probe-<key>.json` in the bake cache's directory,
//! the key a hash of everything that changes the measurement and a format version; a file
//! that does not parse, names another device or holds what no measurement gives
//! ([`check`]: a cost that is negative, not finite or beyond a quarter of an hour, a speed
//! state that is not one, a text with markup) is said and measured over.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{Monitor, Probe, ProbeSettings, monitor, run_with_monitor};
use crate::files::Hasher64;
use crate::gpu::{Context, GpuError};

pub use crate::files::clock::utc_now;

/// Bump when a cached probe of an older layout or meaning must not be reused.
const CACHE_VERSION: u64 = 2;
/// Largest probe file read (a probe's JSON is a few hundred KiB).
const MAX_PROBE_BYTES: u64 = 16 << 20;

/// The cache file of a probe of `s` on `ctx`'s device, in `dir` (`s.progress` does not
/// enter).
pub fn path(dir: &Path, ctx: &Context, s: &ProbeSettings) -> PathBuf {
    let device = ctx.device_summary();
    let mut h = Hasher64::default();
    h.write_u64(CACHE_VERSION);
    for text in [
        device.name.as_str(),
        device.driver.as_str(),
        env!("CARGO_PKG_VERSION"),
        env!("SHVIS_GIT_COMMIT"),
    ] {
        h.write(text.as_bytes());
        h.write_u64(text.len() as u64);
    }
    for v in [
        u64::from(s.width),
        u64::from(s.height),
        s.triangle_pixels.to_bits(),
        u64::from(s.warmup),
        u64::from(s.frames),
    ] {
        h.write_u64(v);
    }
    dir.join(format!("probe-{:016x}.json", h.finish()))
}

/// The probe of `s` on `ctx`'s device and its monitor: read from `dir` when a probe with the
/// same key is there and `fresh` is not asked for, else measured and written there.
pub fn run_cached(
    ctx: &Arc<Context>,
    s: &ProbeSettings,
    dir: &Path,
    fresh: bool,
) -> Result<(Probe, Monitor), GpuError> {
    let file = path(dir, ctx, s);
    if !fresh && let Some(mut probe) = read(&file, ctx.device_name(), s) {
        log::info!(
            "probe: reusing the one measured {} ({}; --probe fresh measures again)",
            probe.measured_at,
            file.display()
        );
        let monitor = monitor(ctx, s, probe.states.clone())?;
        probe.reused_from = Some(file.display().to_string());
        return Ok((probe, monitor));
    }
    let (probe, monitor) = run_with_monitor(ctx, s)?;
    let written = std::fs::create_dir_all(dir)
        .map_err(|e| e.to_string())
        .and_then(|()| serde_json::to_vec(&probe).map_err(|e| e.to_string()))
        .and_then(|json| crate::files::write(&file, json).map_err(|e| e.to_string()));
    if let Err(e) = written {
        log::warn!("{}: probe not cached: {e}", file.display());
    }
    Ok((probe, monitor))
}

/// When the cached probe of `s` on `ctx`'s device in `dir` was measured, if there is one.
pub fn measured_at(dir: &Path, ctx: &Context, s: &ProbeSettings) -> Option<String> {
    read(&path(dir, ctx, s), ctx.device_name(), s).map(|p| format!("{} UTC", p.measured_at))
}

/// The probe in `file`, if it is one of `device` with settings `s` that can be believed.
fn read(file: &Path, device: &str, s: &ProbeSettings) -> Option<Probe> {
    let bytes = crate::files::read_bounded(file, MAX_PROBE_BYTES, "cached probe").ok()?;
    let probe: Probe = match serde_json::from_slice(&bytes) {
        Ok(p) => p,
        Err(e) => {
            log::warn!("{}: not a probe ({e}); measuring again", file.display());
            return None;
        }
    };
    if probe.device != device {
        return None;
    }
    if let Err(why) = check(&probe, s) {
        log::warn!(
            "{}: cached probe not believed ({why}); measuring again",
            file.display()
        );
        return None;
    }
    Some(probe)
}

/// Longest time any part of a probe's model or point may take, ms (a quarter of an hour).
const MAX_MS: f64 = 1e6;

/// Why `probe` cannot be a measurement of `s`, if it cannot: its frame or frame count
/// differs, a cost or time of its models and points is negative, not finite or beyond
/// [`MAX_MS`], a share is outside [0, 1], a state index names no state, or a text it shows
/// (`measured_at`, a state's worst point) holds markup or control characters.
pub fn check(probe: &Probe, s: &ProbeSettings) -> Result<(), String> {
    if (probe.width, probe.height, probe.frames) != (s.width, s.height, s.frames) {
        return Err(format!(
            "measured at {}×{} with {} frames, not {}×{} with {}",
            probe.width, probe.height, probe.frames, s.width, s.height, s.frames
        ));
    }
    let time = |name: &str, ms: f64| {
        if ms.is_finite() && (0.0..=MAX_MS).contains(&ms) {
            Ok(())
        } else {
            Err(format!(
                "{name} is {ms:?} ms, not a time between 0 and {MAX_MS:e} ms"
            ))
        }
    };
    let share = |name: &str, x: f64| {
        if (0.0..=1.0).contains(&x) {
            Ok(())
        } else {
            Err(format!("{name} is {x}, not a share between 0 and 1"))
        }
    };
    let states = probe.states.monitor_ms.len();
    if states == 0 || probe.states.shares.len() != states || probe.states.main_state >= states {
        return Err(format!(
            "its speed states are not states ({} medians, {} shares, main state {})",
            states,
            probe.states.shares.len(),
            probe.states.main_state
        ));
    }
    for (i, &ms) in probe.states.monitor_ms.iter().enumerate() {
        time(&format!("state {i}'s monitor frame"), ms)?;
    }
    for (i, &x) in probe.states.shares.iter().enumerate() {
        share(&format!("state {i}'s share"), x)?;
    }
    time("the spike threshold", probe.states.spike_ms)?;
    if let Some(ms) = probe.states.threshold_ms {
        time("the state threshold", ms)?;
    }
    let models = std::iter::once((None, &probe.model))
        .chain(probe.state_models.iter().map(|m| (Some(m.state), &m.model)));
    for (state, model) in models {
        let of = state.map_or_else(|| "the model".to_string(), |i| format!("state {i}'s model"));
        if state.is_some_and(|i| i >= states) {
            return Err(format!("{of} names no state"));
        }
        for (name, ms) in [
            ("fixed_ms", model.fixed_ms),
            ("pixel_ms", model.pixel_ms),
            ("depth_test_ms", model.depth_test_ms),
            ("per_triangle_ms", model.per_triangle_ms),
            ("per_edge_pixel_ms", model.per_edge_pixel_ms),
            ("per_triangle_varying_ms", model.per_triangle_varying_ms),
        ]
        .into_iter()
        .chain(model.per_unit_ms.iter().map(|&ms| ("per_unit_ms", ms)))
        {
            time(&format!("{of}'s {name}"), ms)?;
        }
        share(&format!("{of}'s untaken_share"), model.untaken_share)?;
    }
    if probe.points.is_empty() {
        return Err("it has no points".into());
    }
    for (i, p) in probe.points.iter().enumerate() {
        time(&format!("point {i}'s median"), p.ms_median)?;
        time(&format!("point {i}'s model time"), p.model_ms)?;
        if !(p.coverage.is_finite()
            && p.coverage >= 0.0
            && p.edge_pixels.is_finite()
            && p.edge_pixels >= 0.0)
        {
            return Err(format!("point {i}'s coverage or edge pixels is not a size"));
        }
    }
    if !crate::files::clock::is_utc_minute(&probe.measured_at) {
        return Err(format!(
            "measured_at {:?} is not a UTC time \"YYYY-MM-DD HH:MM\"",
            probe.measured_at
        ));
    }
    for m in &probe.state_models {
        if m.worst_point
            .chars()
            .any(|c| c.is_control() || "<>|`*[]\\".contains(c))
        {
            return Err(format!(
                "state {}'s worst point {:?} holds markup",
                m.state, m.worst_point
            ));
        }
        if !(m.worst_relative_error.is_finite() && m.worst_relative_error >= 0.0) {
            return Err(format!(
                "state {}'s worst error is {}",
                m.state, m.worst_relative_error
            ));
        }
    }
    Ok(())
}
