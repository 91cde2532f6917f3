//! `shvis study bases`, the hemisphere table: a lightmap texel on a floor under each
//! environment, and every lightmap basis fitted from the same radiance samples of that
//! texel ([`crate::sh::samples`]), measured against the irradiance and the radiance those
//! samples carry. The report is [`super::bases_hemisphere_report`].
//!
//! # The texel and its samples
//!
//! The texel faces up: its tangent frame is T = [t, b, n] = [+X, −Z, +Y] (t × b = n), and a
//! tangent-space direction m has m_z along n. Only light from above the floor's plane
//! reaches it. Each environment gives two sets of samples (tangent-space directions ω_s,
//! solid angles w_s in sr, RGB radiance L_s):
//!
//! ```text
//! full   ω_s = Tᵀ d_t,   w_s = Ω_t,   L_s = L_t     for every pixel t with d_t·n > 0     (1)
//! sh8    ω_q, w_q the hemisphere rule of SH_RULE_N,   L_q = Σ_i c_i y_i(T ω_q)           (2)
//! ```
//!
//! In (1) d_t is the pixel's centre direction and Ω_t its exact solid angle; the pixels
//! below the plane are dropped. A map whose upper half holds more than
//! [`MAX_PIXEL_SAMPLES`] pixels is first box-filtered 2 × 2 (solid-angle weighted, so each
//! merged pixel keeps the exact solid angle and energy of its four) until it does not; a
//! 2k map (2048 × 1024) is read whole. An `sh:FILE` environment has no pixels: its (1) is
//! (2) with the file's own coefficients. In (2) c is the environment's order-8 radiance SH
//! (an `sh:FILE` of higher order truncated to 8): what the lightmap bake's escaped rays
//! read. SH_RULE_N = [`SH_RULE_N`]: 48 Gauss–Legendre nodes in m_z times 96 azimuths.
//!
//! # Fits, per source
//!
//! SH of order k = 2…5 (the rows L1…L4), projected in world space from the samples:
//!
//! ```text
//! c_i = Σ_s w_s L_s y_i(T ω_s),  Ê(m) = Σ_l A_l Σ_j c_lj y_lj(T m),  L̂(m) = Σ_i c_i y_i(T m)  (3)
//! ```
//!
//! with A_l the clamped cosine's factors (`sh::zonal`). The engine's SH bases
//! (`sh::bases::ShBasis`: Geomerics, hallucinated and stored ZH3, luminance L1, deringed L2
//! over the texel's hemisphere) encode the order-3 c of (3); its L1 linear and L2 are the
//! rows L1 and L2. The H-basis, Ambient Dice, the ambient cube and the spherical Gaussians
//! (every lobe count, every solver) are [`crate::sh::samples::SampleFit::fit`] of the
//! samples. The rows and their fits are [`super::bases_hemisphere_fits`].
//!
//! # Truth
//!
//! ```text
//! E(m) = Σ_s w_s L_s max(0, m·ω_s)        over the full samples (1)                     (4)
//! ```
//!
//! by brute force at every normal. The radiance truth is the full source itself: L_s at
//! its samples, and at a lat-long pixel the map read bilinearly at full resolution (the SH
//! evaluated for `sh:FILE`). Both sources are measured against this one truth, so the
//! `sh8` errors show what the bake's order-8 SH hides from each basis.
//!
//! # Metrics
//!
//! On luminance (Rec. 709), each estimate clamped at 0 per channel as its shader clamps:
//!
//! ```text
//! (a)  ε = √(Σ_j w_j (Ê_j − E_j)²) / √(Σ_j w_j E_j²)                                     (5)
//! (b)  MSE = (1/P) Σ_p (Ê_p − E_p)²,   relative: MSE / ((1/P) Σ_p E_p²)                   (6)
//! ```
//!
//! (5) is solid-angle weighted: for irradiance over the normals of the hemisphere rule
//! (`--quadrature` Q: Q nodes in m_z times 2Q azimuths, weights summing to 2π), for
//! radiance over the full samples (1). (6) weighs every pixel alike, as the published
//! Probulator-style comparisons do: P = 128 × 32 pixel centres of a lat-long image of the
//! upper hemisphere, φ_i = 2π(i + ½)/128, θ_j = (π/2)(j + ½)/32 from the normal. Where the
//! error and the truth are both constant the relative MSE (6) is ε² of (5) (a test
//! checks). Radiance is measured only for the bases that store it (SH, SG); the H-basis,
//! Ambient Dice and the ambient cube store irradiance, and the engine bases reconstruct
//! irradiance only.
//!
//! # Bytes
//!
//! A basis of v values per texel is stored on `dx10` as RGBA16F texels, four values each:
//!
//! ```text
//! bytes = 8 ⌈v / 4⌉                                                                      (7)
//! ```

use std::path::{Path, PathBuf};

use glam::DVec3;
use rayon::prelude::*;

use super::bases_hemisphere_fits::{fit, specs, to_tangent, to_world, warm_up, world_sh};
use crate::env::{self, EnvError, EnvMap};
use crate::sh::Order;
use crate::sh::bases::luminance;
use crate::sh::basis::eval_basis;
use crate::sh::hbasis;
use crate::sh::samples::Sample;
use crate::sh::zonal;

/// Most pixels the `full` source keeps before it is box-filtered (module doc, (1)).
pub const MAX_PIXEL_SAMPLES: usize = 1 << 20;

/// Gauss–Legendre nodes in m_z of the hemisphere rule on which an SH is sampled (2).
pub const SH_RULE_N: usize = 48;

/// Order of the environment SH the bake reads ((2), the `sh8` source).
pub const BAKE_ORDER: u32 = 8;

/// The lat-long image of (6): pixels across (azimuth) and down (polar angle).
pub const LATLONG: [usize; 2] = [128, 32];

/// An environment as the study reads it.
pub enum Source {
    /// A map of pixels (`sky`, `sky:DEG`, a probe file).
    Map(EnvMap),
    /// RGB SH coefficients (`sh:FILE`).
    Sh(Vec<[f64; 3]>),
}

impl Source {
    /// Loads `name` as [`env::resolve`] names it, `sh:FILE` kept as its coefficients.
    ///
    /// # Errors
    /// An environment that does not load.
    pub fn load(name: &str) -> Result<Source, EnvError> {
        match name.strip_prefix(env::SH_PREFIX) {
            Some(path) => Ok(Source::Sh(env::sh_file::load(Path::new(path))?)),
            None => Ok(Source::Map(env::resolve(name)?)),
        }
    }

    /// Radiance (RGB) in world direction `d` (unit): the map read bilinearly at full
    /// resolution, or the SH evaluated.
    pub fn radiance(&self, d: DVec3) -> [f64; 3] {
        match self {
            Source::Map(map) => map.sample_bilinear(d).map(f64::from),
            Source::Sh(coeffs) => zonal::eval_rgb(coeffs, env::sh_file::order_of(coeffs), d),
        }
    }

    /// The radiance SH of order [`BAKE_ORDER`] (an `sh:FILE` of lower order as given).
    pub fn bake_sh(&self) -> Vec<[f64; 3]> {
        let order = Order::new(BAKE_ORDER).expect("the bake's order is valid");
        match self {
            Source::Map(map) => env::project::project_sh(map, order),
            Source::Sh(coeffs) => coeffs[..coeffs.len().min(order.coeff_count())].to_vec(),
        }
    }
}

/// Where the errors are measured: the hemisphere rule's normals and weights for (5), the
/// lat-long pixel centres for (6); all in tangent space.
pub struct Normals {
    pub normals: Vec<DVec3>,
    /// Solid angle of each normal's node (sr, summing to 2π).
    pub weights: Vec<f64>,
    pub latlong: Vec<DVec3>,
}

impl Normals {
    /// The hemisphere rule of `quadrature` nodes in m_z times 2·`quadrature` azimuths, and
    /// the [`LATLONG`] pixels.
    pub fn new(quadrature: usize) -> Normals {
        let (normals, weights): (Vec<DVec3>, Vec<f64>) = hbasis::hemisphere_quadrature(quadrature)
            .into_iter()
            .unzip();
        Normals {
            normals,
            weights,
            latlong: latlong_normals(),
        }
    }
}

/// The pixel centres of (6), row-major from the normal down to the horizon.
pub fn latlong_normals() -> Vec<DVec3> {
    let [width, height] = LATLONG;
    (0..height)
        .flat_map(|j| {
            (0..width).map(move |i| {
                let phi = 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / width as f64;
                let theta = std::f64::consts::FRAC_PI_2 * (j as f64 + 0.5) / height as f64;
                DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
            })
        })
        .collect()
}

/// (5) and (6) of one reconstruction against the truth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Errors {
    /// (5): solid-angle-weighted RMS relative to the truth's.
    pub rms_rel: f64,
    /// (6): per-pixel MSE over the mean squared truth.
    pub mse_rel: f64,
    /// (6): per-pixel MSE (luminance² in the environment's units).
    pub mse: f64,
}

impl Errors {
    /// (5) of `estimate` against `truth` with `weights`, (6) of `estimate_px` against
    /// `truth_px`. A truth that is zero everywhere gives relative errors of 0.
    pub fn new(
        weights: &[f64],
        estimate: &[f64],
        truth: &[f64],
        estimate_px: &[f64],
        truth_px: &[f64],
    ) -> Errors {
        let (mut num, mut den) = (0.0, 0.0);
        for ((w, e), t) in weights.iter().zip(estimate).zip(truth) {
            num += w * (e - t).powi(2);
            den += w * t * t;
        }
        let pixels = truth_px.len().max(1) as f64;
        let mse = estimate_px
            .iter()
            .zip(truth_px)
            .map(|(e, t)| (e - t).powi(2))
            .sum::<f64>()
            / pixels;
        let mean_sq = truth_px.iter().map(|t| t * t).sum::<f64>() / pixels;
        Errors {
            rms_rel: ratio(num.sqrt(), den.sqrt()),
            mse_rel: ratio(mse, mean_sq),
            mse,
        }
    }
}

fn ratio(num: f64, den: f64) -> f64 {
    if den > 0.0 { num / den } else { 0.0 }
}

/// One basis fitted from one source, measured.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SourceErrors {
    pub irradiance: Errors,
    /// `None` for the bases that store irradiance only (module doc, Metrics).
    pub radiance: Option<Errors>,
    /// SG: the share of amplitudes the solver made negative.
    pub negative_amplitudes: Option<f64>,
}

/// One basis under one environment.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HemisphereRow {
    pub env: String,
    /// "L2", "H6", "Dice YCoCg", "SG9 nnls"…
    pub basis: String,
    /// One of [`super::bases_hemisphere_fits::FAMILIES`].
    pub family: &'static str,
    /// Values stored per texel (RGB counted three times).
    pub values: usize,
    /// Bytes per texel on `dx10` (7).
    pub bytes: usize,
    /// Fitted from the pixels (1).
    pub full: SourceErrors,
    /// Fitted from the order-8 SH (2).
    pub sh8: SourceErrors,
}

/// What one environment's sources hold.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct HemisphereEnv {
    pub env: String,
    /// "pixels" (1) or "SH on the hemisphere rule" (`sh:FILE`).
    pub full_kind: &'static str,
    pub full_samples: usize,
    /// Side of the box filter applied to the pixels (1: every pixel as it is).
    pub pixel_step: u32,
    pub sh8_samples: usize,
    /// Order of the SH of (2).
    pub sh8_order: u32,
}

/// The hemisphere table of every environment.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct HemisphereStudy {
    /// Normals of (5) for irradiance.
    pub normals: usize,
    /// Pixels of (6): across, down.
    pub latlong: [usize; 2],
    pub envs: Vec<HemisphereEnv>,
    pub rows: Vec<HemisphereRow>,
}

/// (7): bytes per texel of `values` values stored as RGBA16F.
pub fn dx10_bytes(values: usize) -> usize {
    8 * values.div_ceil(4)
}

/// The hemisphere table of one environment (module doc).
pub fn measure(
    env: &str,
    source: &Source,
    normals: &Normals,
) -> (HemisphereEnv, Vec<HemisphereRow>) {
    let (full, pixel_step, full_kind) = match source {
        Source::Map(map) => {
            let (samples, step) = pixel_samples(map);
            (samples, step, "pixels")
        }
        Source::Sh(coeffs) => (sh_samples(coeffs), 1, "SH on the hemisphere rule"),
    };
    let bake = source.bake_sh();
    let sh8 = sh_samples(&bake);
    let radiance_latlong: Vec<[f64; 3]> = normals
        .latlong
        .iter()
        .map(|&m| source.radiance(to_world(m)))
        .collect();
    let rows = measure_samples(env, &full, &sh8, &radiance_latlong, normals);
    let info = HemisphereEnv {
        env: env.to_string(),
        full_kind,
        full_samples: full.len(),
        pixel_step,
        sh8_samples: sh8.len(),
        sh8_order: env::sh_file::order_of(&bake).get(),
    };
    (info, rows)
}

/// Every basis fitted from `full` and from `sh8`, against the truth of `full` (4) and the
/// full-resolution radiance `radiance_latlong` at the lat-long pixels.
pub fn measure_samples(
    env: &str,
    full: &[Sample],
    sh8: &[Sample],
    radiance_latlong: &[[f64; 3]],
    normals: &Normals,
) -> Vec<HemisphereRow> {
    warm_up();
    let shade = |v: [f64; 3]| luminance(v.map(|c| c.max(0.0)));
    let truth = Truth {
        irradiance: irradiance_truth(full, &normals.normals)
            .into_iter()
            .map(shade)
            .collect(),
        irradiance_latlong: irradiance_truth(full, &normals.latlong)
            .into_iter()
            .map(shade)
            .collect(),
        radiance: full.iter().map(|s| shade(s.radiance)).collect(),
        radiance_latlong: radiance_latlong.iter().map(|&l| shade(l)).collect(),
    };
    let from_full = measure_source(full, full, normals, &truth);
    let from_sh8 = measure_source(sh8, full, normals, &truth);
    specs()
        .into_iter()
        .zip(from_full.into_iter().zip(from_sh8))
        .map(|(spec, (full, sh8))| HemisphereRow {
            env: env.to_string(),
            basis: spec.label(),
            family: spec.family(),
            values: spec.values(),
            bytes: dx10_bytes(spec.values()),
            full,
            sh8,
        })
        .collect()
}

/// Luminance of the truth (module doc, Truth), clamped at 0.
struct Truth {
    /// (4) at the rule's normals.
    irradiance: Vec<f64>,
    /// (4) at the lat-long pixels.
    irradiance_latlong: Vec<f64>,
    /// L_s at the full samples.
    radiance: Vec<f64>,
    /// The full-resolution radiance at the lat-long pixels.
    radiance_latlong: Vec<f64>,
}

/// (4): E at each tangent-space normal (RGB), by brute force over `samples`.
pub fn irradiance_truth(samples: &[Sample], normals: &[DVec3]) -> Vec<[f64; 3]> {
    // Blocks of normals in parallel, samples in chunks that stay in cache for the block.
    const NORMALS_PER_TASK: usize = 16;
    const SAMPLES_PER_CHUNK: usize = 4096;
    let blocks: Vec<Vec<[f64; 3]>> = normals
        .par_chunks(NORMALS_PER_TASK)
        .map(|block| {
            let mut acc = vec![[0.0; 3]; block.len()];
            for chunk in samples.chunks(SAMPLES_PER_CHUNK) {
                for (a, n) in acc.iter_mut().zip(block) {
                    let mut part = [0.0; 3];
                    for s in chunk {
                        let cosine = n.dot(s.dir);
                        if cosine > 0.0 {
                            let k = s.weight * cosine;
                            for c in 0..3 {
                                part[c] += k * s.radiance[c];
                            }
                        }
                    }
                    for c in 0..3 {
                        a[c] += part[c];
                    }
                }
            }
            acc
        })
        .collect();
    blocks.concat()
}

/// Whether [`pixel_samples`] can bring `source`'s pixels above the floor within
/// [`MAX_PIXEL_SAMPLES`]: its 2 × 2 filter halves maps of even height only.
///
/// # Errors
/// [`EnvError::Format`] naming the map's size and what to do.
pub fn check_filterable(name: &str, source: &Source) -> Result<(), EnvError> {
    let Source::Map(map) = source else {
        return Ok(());
    };
    // Rows whose centres lie above the horizon: the upper half, rounded down.
    let upper = |w: u32, h: u32| u64::from(w) * u64::from(h / 2);
    let (mut w, mut h) = (map.width, map.height);
    while upper(w, h) > MAX_PIXEL_SAMPLES as u64 && w % 2 == 0 && h % 2 == 0 && h >= 4 {
        (w, h) = (w / 2, h / 2);
    }
    if upper(w, h) > MAX_PIXEL_SAMPLES as u64 {
        return Err(EnvError::Format {
            path: PathBuf::from(name),
            detail: format!(
                "{}×{}: halving it 2 × 2 stops at {w}×{h} (an odd size) with {} pixels above the floor, more than the study's {MAX_PIXEL_SAMPLES}; resample the map to a height that halves further (a power of two)",
                map.width,
                map.height,
                upper(w, h)
            ),
        });
    }
    Ok(())
}

/// (1) of a map: its pixels above the floor's plane, box-filtered while they exceed
/// [`MAX_PIXEL_SAMPLES`]; and the filter's side.
fn pixel_samples(map: &EnvMap) -> (Vec<Sample>, u32) {
    let upper = |m: &EnvMap| {
        (0..m.height)
            .filter(|&y| m.texel_center_dir(0, y).y > 0.0)
            .count()
            * m.width as usize
    };
    let mut step = 1;
    let mut filtered: Option<EnvMap> = None;
    loop {
        let current = filtered.as_ref().unwrap_or(map);
        let even = current.width % 2 == 0 && current.height % 2 == 0 && current.height >= 4;
        if upper(current) <= MAX_PIXEL_SAMPLES || !even {
            break;
        }
        let next = halve(current);
        filtered = Some(next);
        step *= 2;
    }
    let m = filtered.as_ref().unwrap_or(map);
    let mut samples = Vec::with_capacity(upper(m));
    for y in 0..m.height {
        let weight = m.texel_solid_angle(y);
        for x in 0..m.width {
            let d = m.texel_center_dir(x, y);
            if d.y <= 0.0 {
                continue; // below the floor's plane: no light reaches the texel
            }
            samples.push(Sample {
                dir: to_tangent(d),
                weight,
                radiance: m.texel(x, y).map(f64::from),
            });
        }
    }
    (samples, step)
}

/// The map box-filtered 2 × 2: each pixel the solid-angle-weighted mean of its four, so
/// that its exact solid angle times its radiance is theirs summed. Width and height even.
fn halve(map: &EnvMap) -> EnvMap {
    let (width, height) = (map.width / 2, map.height / 2);
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        let rows = [2 * y, 2 * y + 1].map(|r| (r, map.texel_solid_angle(r)));
        let total = 2.0 * (rows[0].1 + rows[1].1);
        for x in 0..width {
            let mut sum = [0.0f64; 3];
            for (r, omega) in rows {
                for c in [2 * x, 2 * x + 1] {
                    let t = map.texel(c, r);
                    for k in 0..3 {
                        sum[k] += omega * f64::from(t[k]);
                    }
                }
            }
            texels.push(sum.map(|s| (s / total) as f32));
        }
    }
    EnvMap {
        width,
        height,
        texels,
    }
}

/// (2): `coeffs` (world space, n² of them) evaluated on the hemisphere rule of
/// [`SH_RULE_N`] about the floor's normal.
fn sh_samples(coeffs: &[[f64; 3]]) -> Vec<Sample> {
    let order = env::sh_file::order_of(coeffs);
    let mut y = vec![0.0; order.coeff_count()];
    hbasis::hemisphere_quadrature(SH_RULE_N)
        .into_iter()
        .map(|(m, weight)| {
            eval_basis(order, to_world(m), &mut y);
            let radiance: [f64; 3] = std::array::from_fn(|c| {
                coeffs.iter().zip(&y).map(|(k, yk)| k[c] * yk).sum::<f64>()
            });
            Sample {
                dir: m,
                weight,
                radiance,
            }
        })
        .collect()
}

/// Every basis fitted from `samples` and measured against `truth`, whose radiance
/// samples are those of `full`; in [`specs`] order.
fn measure_source(
    samples: &[Sample],
    full: &[Sample],
    normals: &Normals,
    truth: &Truth,
) -> Vec<SourceErrors> {
    let sh = world_sh(samples);
    let shade = |v: [f64; 3]| luminance(v.map(|c| c.max(0.0)));
    specs()
        .into_par_iter()
        .map(|spec| {
            let (fitted, negative_amplitudes) = fit(spec, samples, &sh);
            let at = |ms: &[DVec3]| -> Vec<f64> {
                ms.iter().map(|&m| shade(fitted.irradiance(m))).collect()
            };
            let irradiance = Errors::new(
                &normals.weights,
                &at(&normals.normals),
                &truth.irradiance,
                &at(&normals.latlong),
                &truth.irradiance_latlong,
            );
            let radiance_at = |dirs: &mut dyn Iterator<Item = DVec3>| -> Option<Vec<f64>> {
                dirs.map(|m| fitted.radiance(m).map(shade)).collect()
            };
            let radiance = radiance_at(&mut full.iter().map(|s| s.dir)).and_then(|at_samples| {
                let at_pixels = radiance_at(&mut normals.latlong.iter().copied())?;
                let weights: Vec<f64> = full.iter().map(|s| s.weight).collect();
                Some(Errors::new(
                    &weights,
                    &at_samples,
                    &truth.radiance,
                    &at_pixels,
                    &truth.radiance_latlong,
                ))
            });
            SourceErrors {
                irradiance,
                radiance,
                negative_amplitudes,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn maps_the_filter_cannot_bring_within_the_samples_are_refused() {
        let map = |width: u32, height: u32| {
            Source::Map(EnvMap {
                width,
                height,
                texels: vec![[1.0; 3]; width as usize * height as usize],
            })
        };
        // 4096 × 1024 halves to 2048 × 512: 524 288 pixels above the floor.
        assert!(check_filterable("even", &map(4096, 1024)).is_ok());
        let e = check_filterable("odd", &map(4098, 1025))
            .unwrap_err()
            .to_string();
        assert!(e.contains("4098×1025") && e.contains("resample"), "{e}");
        // Small odd maps need no filter.
        assert!(check_filterable("small", &map(202, 101)).is_ok());
    }

    /// The study's own tolerance for a basis that can hold the lighting exactly: the
    /// kernel tables of `sh::samples` read their kernels to about 10⁻³ of their scale,
    /// and the samples' quadrature of the clamped cosine errs by about as much.
    const REPRODUCED: f64 = 0.01;

    fn row<'a>(rows: &'a [HemisphereRow], basis: &str) -> &'a HemisphereRow {
        rows.iter()
            .find(|r| r.basis == basis)
            .unwrap_or_else(|| panic!("no row {basis}"))
    }

    #[test]
    fn a_constant_environment_gives_every_irradiance_basis_pi_l() {
        // Lit from every direction (no floor cuts it): E = π L at every normal.
        let l = [1.0, 0.8, 0.5];
        let samples: Vec<Sample> = crate::sh::project::sphere_quadrature(48)
            .into_iter()
            .map(|(dir, weight)| Sample {
                dir,
                weight,
                radiance: l,
            })
            .collect();
        let normals = Normals::new(8);
        let want = PI * luminance(l);
        for e in irradiance_truth(&samples, &normals.normals) {
            assert!((luminance(e) - want).abs() < REPRODUCED * want, "{e:?}");
        }
        let radiance = vec![l; normals.latlong.len()];
        let rows = measure_samples("constant", &samples, &samples, &radiance, &normals);
        assert_eq!(rows.len(), specs().len());
        for r in rows.iter().filter(|r| r.family != "SG") {
            assert!(r.full.irradiance.rms_rel < REPRODUCED, "{r:?}");
            assert!(r.full.irradiance.mse_rel < REPRODUCED * REPRODUCED, "{r:?}");
            assert_eq!(r.full.radiance.is_some(), r.family == "SH", "{r:?}");
        }
        for r in rows.iter().filter(|r| r.family == "SH") {
            let radiance = r.full.radiance.expect("SH stores radiance");
            assert!(radiance.rms_rel < 1e-9, "{r:?}");
        }
        assert!(
            rows.iter()
                .filter(|r| r.family == "SG")
                .all(|r| { r.full.radiance.is_some() && r.full.negative_amplitudes.is_some() })
        );
    }

    #[test]
    fn a_constant_sky_above_the_floor_is_held_by_sh_and_the_h_basis() {
        // The floor cuts the sky: E(m) = π L (1 + m_z)/2, linear in m_z, which every SH
        // order and both H-bases hold (H1 and H3 span it).
        let l = [1.0f32, 0.8, 0.5];
        let source = Source::Map(EnvMap::from_fn(128, 64, |_| l));
        let normals = Normals::new(8);
        let (info, rows) = measure("constant sky", &source, &normals);
        assert_eq!((info.full_samples, info.pixel_step), (128 * 32, 1));
        assert_eq!(info.sh8_order, BAKE_ORDER);
        let Source::Map(map) = &source else {
            unreachable!("built as a map")
        };
        let (full, _) = pixel_samples(map);
        let lum = luminance(l.map(f64::from));
        for (m, e) in normals
            .normals
            .iter()
            .zip(irradiance_truth(&full, &normals.normals))
        {
            let want = PI * lum * (1.0 + m.z) / 2.0;
            assert!(
                (luminance(e) - want).abs() < REPRODUCED * want,
                "{m}: {e:?}"
            );
        }
        for basis in ["L1", "L2", "L3", "L4", "H4", "H6"] {
            let r = row(&rows, basis);
            assert!(r.full.irradiance.rms_rel < REPRODUCED, "{r:?}");
            assert!(r.sh8.irradiance.rms_rel < REPRODUCED, "{r:?}");
        }
    }

    #[test]
    fn the_two_sources_of_an_order_3_sh_environment_are_the_same() {
        let mut coeffs = vec![[0.0; 3]; 9];
        coeffs[0] = [2.0, 1.8, 1.5];
        coeffs[2] = [0.6, 0.5, 0.4];
        coeffs[3] = [-0.3, 0.1, 0.2];
        coeffs[6] = [0.1; 3];
        let normals = Normals::new(6);
        let (info, rows) = measure("sh", &Source::Sh(coeffs), &normals);
        assert_eq!(info.sh8_order, 3);
        assert_eq!(info.full_samples, info.sh8_samples);
        for r in &rows {
            assert_eq!(r.full, r.sh8, "{}", r.basis);
        }
    }

    #[test]
    fn the_two_metrics_agree_on_a_constant_error_field() {
        // Truth E and error δ constant: (5) is δ/E; (6) is δ², relative δ²/E² = (5)².
        let normals = Normals::new(8);
        let (e, delta) = (2.5, 0.1);
        let (q, p) = (normals.normals.len(), normals.latlong.len());
        let errors = Errors::new(
            &normals.weights,
            &vec![e + delta; q],
            &vec![e; q],
            &vec![e + delta; p],
            &vec![e; p],
        );
        assert!((errors.rms_rel - delta / e).abs() < 1e-12, "{errors:?}");
        assert!((errors.mse - delta * delta).abs() < 1e-12, "{errors:?}");
        assert!(
            (errors.mse_rel.sqrt() - errors.rms_rel).abs() < 1e-12,
            "{errors:?}"
        );
        let zero = Errors::new(&[1.0], &[1.0], &[0.0], &[1.0], &[0.0]);
        assert_eq!((zero.rms_rel, zero.mse_rel, zero.mse), (0.0, 0.0, 1.0));
    }

    #[test]
    fn bytes_are_rgba16f_texels_of_four_values() {
        for (values, bytes) in [
            (12, 24),
            (27, 56),
            (90, 184),
            (50, 104),
            (18, 40),
            (48, 96),
            (75, 152),
            (6, 16),
            (15, 32),
        ] {
            assert_eq!(dx10_bytes(values), bytes, "{values} values");
        }
    }

    #[test]
    fn the_latlong_pixels_cover_the_upper_hemisphere() {
        let pixels = latlong_normals();
        assert_eq!(pixels.len(), LATLONG[0] * LATLONG[1]);
        for m in &pixels {
            assert!(m.z > 0.0 && (m.length() - 1.0).abs() < 1e-12, "{m}");
        }
    }

    #[test]
    fn halving_keeps_the_energy_of_the_pixels() {
        let map = EnvMap::from_fn(64, 32, |d| [(1.0 + d.y) as f32, 0.5, (d.x * d.x) as f32]);
        let small = halve(&map);
        let energy = |m: &EnvMap| -> f64 {
            (0..m.height)
                .map(|y| {
                    let omega = m.texel_solid_angle(y);
                    (0..m.width)
                        .map(|x| omega * f64::from(m.texel(x, y)[0]))
                        .sum::<f64>()
                })
                .sum()
        };
        assert_eq!((small.width, small.height), (32, 16));
        assert!((energy(&small) - energy(&map)).abs() < 1e-5 * energy(&map));
    }
}
