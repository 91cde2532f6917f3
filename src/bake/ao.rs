//! Scalar ambient occlusion per lightmap texel, the per-texel data of the `preconv`
//! technique (DESIGN §2; Iwanicki–Sloan §5 "Preconv").
//!
//! AO(x) = (1/π) ∫_{H(n)} V(x, ω) max(0, n·ω) dω: the cosine-weighted fraction of the
//! hemisphere about the *geometric* normal n whose rays escape to infinity (DESIGN §1:
//! below the geometric tangent plane the surface occludes itself, so it is not sampled).
//!
//! Estimator, per texel with N rays: the 2D Hammersley set ((i+½)/N, φ₂(i)) (φ₂ = base-2
//! radical inverse), shifted by a Cranley–Patterson rotation taken from a hash of
//! (seed, texel index), mapped to the unit disk by Shirley–Chiu's concentric map and lifted
//! to the hemisphere by Malley's method (z = √(1 − x² − y²)), which makes the directions
//! cosine-distributed; AO is then the plain fraction of escaping rays. Every texel depends
//! only on (seed, texel index, N), so a bake is identical whatever the thread count.
//!
//! After tracing, [`bake_ao`] dilates the result 2 texels into the chart gutters; gutter
//! texels further out are 1 (unoccluded). Tests: `tests/bake_ao.rs` (open plane = 1,
//! inner corner = ½, closed box = 0, thread-count independence, house overhang).

use std::f64::consts::FRAC_PI_4;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{DVec2, Vec3};

use rayon::prelude::*;

use super::directions::{splitmix64, unit_f64};
use super::raster::{LightmapTexels, dilate};
use super::trace::Tracer;
use super::{BakeStats, progress_bar};

/// Gutter texels filled around charts after the bake.
pub const DILATION_PASSES: u32 = 2;

/// What an AO bake does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AoSettings {
    /// Rays per texel (validated by [`super::validate_rays`]).
    pub rays: u32,
    /// Seed of the per-texel sample rotations.
    pub seed: u64,
    /// Show a progress bar on stderr.
    pub progress: bool,
}

/// A baked AO lightmap.
#[derive(Clone, Debug, PartialEq)]
pub struct AoMap {
    /// Texels per side.
    pub res: u32,
    /// Escaping fraction in [0, 1]; row-major, index y·res + x; gutters dilated.
    pub values: Vec<f32>,
    /// Which texels were baked (the rest are dilated or 1).
    pub covered: Vec<bool>,
    /// Rays and time of the bake.
    pub stats: BakeStats,
}

/// Cranley–Patterson shift of texel `texel_index` under `seed`.
fn rotation(seed: u64, texel_index: u64) -> DVec2 {
    let h = splitmix64(splitmix64(seed) ^ texel_index);
    DVec2::new(unit_f64(h), unit_f64(splitmix64(h)))
}

/// Base-2 radical inverse φ₂(i) (van der Corput), exact in f64.
fn radical_inverse(i: u32) -> f64 {
    f64::from(i.reverse_bits()) * (1.0 / 4_294_967_296.0)
}

/// (x + s) mod 1 for x, s ∈ [0, 1), kept below 1 under rounding.
fn wrap(x: f64) -> f64 {
    let w = if x >= 1.0 { x - 1.0 } else { x };
    if w >= 1.0 { 0.0 } else { w }
}

/// Shirley–Chiu concentric map, [0, 1)² → unit disk, preserving fractional area.
fn concentric_disk(u: DVec2) -> DVec2 {
    let a = 2.0 * u - DVec2::ONE;
    if a == DVec2::ZERO {
        return DVec2::ZERO;
    }
    let (r, phi) = if a.x.abs() > a.y.abs() {
        (a.x, FRAC_PI_4 * (a.y / a.x))
    } else {
        (a.y, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a.x / a.y))
    };
    r * DVec2::new(phi.cos(), phi.sin())
}

/// Malley's method: a cosine-distributed direction about +z from a square sample.
fn cosine_hemisphere(u: DVec2) -> [f64; 3] {
    let d = concentric_disk(u);
    [d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt()]
}

/// AO at one surface point: the fraction of `rays` cosine-weighted directions about the
/// unit geometric `normal` that escape to infinity (see the module doc). `texel_index`
/// selects the sample rotation under `seed`. A zero normal has no hemisphere: 1.
pub fn ao_at(
    tracer: &Tracer,
    position: Vec3,
    normal: Vec3,
    rays: u32,
    seed: u64,
    texel_index: u64,
) -> f32 {
    let Some(n) = normal.try_normalize() else {
        return 1.0;
    };
    if rays == 0 {
        return 1.0;
    }
    let origin = tracer.offset_origin(position, n);
    let (t, b) = n.any_orthonormal_pair();
    let shift = rotation(seed, texel_index);
    let inv_n = 1.0 / f64::from(rays);
    let mut escaped = 0u32;
    for i in 0..rays {
        let u = DVec2::new(
            wrap((f64::from(i) + 0.5) * inv_n + shift.x),
            wrap(radical_inverse(i) + shift.y),
        );
        let [x, y, z] = cosine_hemisphere(u);
        let dir = (t * x as f32 + b * y as f32 + n * z as f32).normalize();
        if !tracer.occluded(origin, dir, f32::INFINITY) {
            escaped += 1;
        }
    }
    (f64::from(escaped) * inv_n) as f32
}

/// Bakes AO for every covered texel, in parallel over rows, then dilates
/// [`DILATION_PASSES`] texels into the gutters (see the module doc).
pub fn bake_ao(tracer: &Tracer, texels: &LightmapTexels, settings: &AoSettings) -> AoMap {
    let res = texels.res as usize;
    let start = Instant::now();
    let progress = progress_bar(settings.progress, res, "AO");
    let rays_done = AtomicU64::new(0);
    let mut values = vec![1.0f32; res * res];
    values
        .par_chunks_mut(res.max(1))
        .enumerate()
        .with_max_len(1)
        .for_each(|(y, row)| {
            let mut row_rays = 0u64;
            for (x, value) in row.iter_mut().enumerate() {
                let i = y * res + x;
                if texels.covered[i] {
                    *value = ao_at(
                        tracer,
                        texels.position[i],
                        texels.normal[i],
                        settings.rays,
                        settings.seed,
                        i as u64,
                    );
                    row_rays += u64::from(settings.rays);
                }
            }
            let total = rays_done.fetch_add(row_rays, Ordering::Relaxed) + row_rays;
            if settings.progress {
                let s = start.elapsed().as_secs_f64().max(1e-9);
                progress.set_message(format!("{:.2} Mrays/s", total as f64 / s * 1e-6));
                progress.inc(1);
            }
        });
    progress.finish_and_clear();
    dilate(&mut values, &texels.covered, texels.res, DILATION_PASSES);
    let covered = texels.covered_count();
    let map = AoMap {
        res: texels.res,
        values,
        covered: texels.covered.clone(),
        stats: BakeStats {
            rays_traced: rays_done.into_inner(),
            seconds: start.elapsed().as_secs_f64(),
        },
    };
    log::info!(
        "AO bake: {covered} texels × {} rays: {}",
        settings.rays,
        map.stats
    );
    map
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The concentric map is area preserving; its corners hit the rim exactly up to f64.
    const F64_ROUND: f64 = 1e-12;

    #[test]
    fn concentric_map_centre_rim_and_diagonals() {
        assert_eq!(concentric_disk(DVec2::splat(0.5)), DVec2::ZERO);
        for u in [
            DVec2::ZERO,
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
            DVec2::ONE,
        ] {
            assert!((concentric_disk(u).length() - 1.0).abs() < F64_ROUND, "{u}");
        }
        // A diagonal point lands on the 45° ray at radius |2u−1|.
        let d = concentric_disk(DVec2::splat(0.8));
        assert!((d.x - d.y).abs() < F64_ROUND && (d.length() - 0.6).abs() < F64_ROUND);
    }

    #[test]
    fn hammersley_directions_are_cosine_distributed() {
        // E[z] = 2/3 for the cosine-weighted hemisphere; E[x] = E[y] = 0.
        let n = 4096;
        let shift = rotation(7, 11);
        let mut mean = [0.0f64; 3];
        for i in 0..n {
            let u = DVec2::new(
                wrap((f64::from(i) + 0.5) / f64::from(n) + shift.x),
                wrap(radical_inverse(i) + shift.y),
            );
            let d = cosine_hemisphere(u);
            assert!(d[2] >= 0.0);
            for k in 0..3 {
                mean[k] += d[k] / f64::from(n);
            }
        }
        // Low-discrepancy error ~ log N / N, far below 1e-2 at N = 4096.
        assert!(mean[0].abs() < 1e-2 && mean[1].abs() < 1e-2, "{mean:?}");
        assert!((mean[2] - 2.0 / 3.0).abs() < 1e-2, "{mean:?}");
    }

    #[test]
    fn rotations_differ_per_texel_and_seed() {
        assert_ne!(rotation(0, 0), rotation(0, 1));
        assert_ne!(rotation(0, 0), rotation(1, 0));
        assert_eq!(rotation(3, 5), rotation(3, 5));
        assert_eq!(radical_inverse(1), 0.5);
        assert_eq!(radical_inverse(3), 0.75);
    }
}
