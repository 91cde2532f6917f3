//! The device probe, kept between benches: a bench reuses the probe measured before on the
//! same device and driver, by the same build, with the same settings — its model and speed
//! states — and rebuilds only the monitor ([`super::monitor`]); `--probe fresh` measures
//! again (and replaces the file). A file is `probe-<key>.json` in the bake cache's directory,
//! the key a hash of everything that changes the measurement and a format version; a file
//! that does not parse or names another device is measured over.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{Monitor, Probe, ProbeSettings, monitor, run_with_monitor};
use crate::files::Hasher64;
use crate::gpu::{Context, GpuError};

pub use crate::files::clock::utc_now;

/// Bump when a cached probe of an older layout or meaning must not be reused.
const CACHE_VERSION: u64 = 1;
/// Largest probe file read (a probe's JSON is a few hundred KiB).
const MAX_PROBE_BYTES: u64 = 16 << 20;

/// The cache file of a probe of `s` on `ctx`'s device, in `dir`.
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
    if !fresh && let Some(mut probe) = read(&file, ctx.device_name()) {
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
    read(&path(dir, ctx, s), ctx.device_name()).map(|p| format!("{} UTC", p.measured_at))
}

/// The probe in `file`, if it is one of `device`.
fn read(file: &Path, device: &str) -> Option<Probe> {
    let bytes = crate::files::read_bounded(file, MAX_PROBE_BYTES, "cached probe").ok()?;
    let probe: Probe = match serde_json::from_slice(&bytes) {
        Ok(p) => p,
        Err(e) => {
            log::warn!("{}: not a probe ({e}); measuring again", file.display());
            return None;
        }
    };
    (probe.device == device).then_some(probe)
}
