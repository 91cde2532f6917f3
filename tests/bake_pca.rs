//! PCA compression of visibility lightmaps (`shvis::bake::pca`, Iwanicki–Sloan §4):
//! exact reconstruction of low-rank data, degenerate inputs (zero variance, rank below
//! M, huge dynamic range) without NaN, the UNORM quantization error against its bound,
//! and the energy captured by the built-in house's visibility.

use std::time::Instant;

use shvis::bake::pca::{PcaModel, fit};
use shvis::bake::raster::rasterize;
use shvis::bake::trace::Tracer;
use shvis::bake::visibility::{VisibilityMap, VisibilitySettings, bake_visibility};
use shvis::scene::house;
use shvis::sh::Order;

/// Per-coefficient reconstruction error of exactly low-rank data: the input and the
/// weights are f32 (relative rounding 6e-8) and every value here is below ~4 in
/// magnitude, so a few f32 ulps of 4 plus f64 round-off stay well under this.
const F32_EXACT: f64 = 1e-6;

/// Deterministic uniform numbers in [-1, 1) (64-bit LCG, top 24 bits).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f64 / (1u64 << 23) as f64 - 1.0
    }
}

/// `count` orthonormal vectors of length n (Gram–Schmidt of random vectors).
fn orthonormal(n: usize, count: usize, rng: &mut Lcg) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = Vec::new();
    while out.len() < count {
        let mut v: Vec<f64> = (0..n).map(|_| rng.next()).collect();
        for b in &out {
            let d: f64 = v.iter().zip(b).map(|(x, y)| x * y).sum();
            v.iter_mut().zip(b).for_each(|(x, y)| *x -= d * y);
        }
        let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.iter_mut().for_each(|x| *x /= len);
        out.push(v);
    }
    out
}

/// A res² map of `order`, every texel covered, texel t = `f(t)`.
fn map(res: u32, order: Order, f: impl Fn(usize) -> Vec<f64>) -> VisibilityMap {
    let texels = (res as usize).pow(2);
    let coeffs = (0..texels)
        .flat_map(|t| {
            let v = f(t);
            assert_eq!(v.len(), order.coeff_count());
            v.into_iter().map(|c| c as f32)
        })
        .collect();
    VisibilityMap {
        res,
        order,
        coeffs,
        covered: vec![true; texels],
        ao: vec![1.0; texels],
        stats: shvis::bake::BakeStats::default(),
    }
}

/// Texel t = mean + Σ_k w_tk dirs_k with uniform random weights in [-1, 1).
fn low_rank(res: u32, order: Order, rank: usize, seed: u64) -> VisibilityMap {
    let n = order.coeff_count();
    let mut rng = Lcg(seed);
    let mean: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let dirs = orthonormal(n, rank, &mut rng);
    let weights: Vec<f64> = (0..(res as usize).pow(2) * rank)
        .map(|_| rng.next())
        .collect();
    map(res, order, |t| {
        let mut v = mean.clone();
        for (k, d) in dirs.iter().enumerate() {
            v.iter_mut()
                .zip(d)
                .for_each(|(x, y)| *x += weights[t * rank + k] * y);
        }
        v
    })
}

fn max_texel_error(model: &PcaModel, vis: &VisibilityMap) -> f64 {
    (0..(vis.res as usize).pow(2))
        .filter(|&t| vis.covered[t])
        .flat_map(|t| {
            let r = model.reconstruct(t);
            let v: Vec<f64> = vis.texel(t).iter().map(|&c| f64::from(c)).collect();
            r.into_iter().zip(v).map(|(a, b)| (a - b).abs())
        })
        .fold(0.0, f64::max)
}

fn all_finite(model: &PcaModel) -> bool {
    model
        .mean
        .iter()
        .chain(model.basis.iter().flatten())
        .all(|x| x.is_finite())
        && model.eigenvalues.iter().all(|x| x.is_finite() && *x >= 0.0)
        && model.weights.iter().all(|w| w.is_finite())
}

#[test]
fn rank_three_data_is_reconstructed_exactly_by_three_vectors() {
    let mut vis = low_rank(16, Order::SIX, 3, 1);
    // A few uncovered, all-zero texels (beyond the gutters) get weight 0.
    let n = Order::SIX.coeff_count();
    for t in [0, 17, 255] {
        vis.covered[t] = false;
        vis.coeffs[t * n..(t + 1) * n].fill(0.0);
    }
    let model = fit(&vis, 3).unwrap();
    assert!(all_finite(&model));
    let err = max_texel_error(&model, &vis);
    assert!(err <= F32_EXACT, "max error {err:e}");
    let e3 = model.energy_captured(3);
    assert!((e3 - 1.0).abs() <= 1e-12, "energy_captured(3) = {e3}");
    assert!(model.eigenvalues[3] <= 1e-12 * model.eigenvalues[0]);
    assert!(model.weights[..3].iter().all(|&w| w == 0.0));
    assert!(model.rms_reconstruction_error(&vis) <= F32_EXACT);
}

#[test]
fn constant_data_has_zero_variance_and_no_nan() {
    let c: Vec<f64> = (0..36).map(|i| 0.25 * i as f64 - 3.0).collect();
    let vis = map(16, Order::SIX, |_| c.clone());
    for m in [1, 5, 36] {
        let model = fit(&vis, m).unwrap();
        assert!(all_finite(&model));
        assert_eq!(model.energy_captured(m), 1.0);
        assert!(model.eigenvalues.iter().all(|&l| l == 0.0));
        assert!(model.weights.iter().all(|&w| w == 0.0));
        for t in [0, 100, 255] {
            let r = model.reconstruct(t);
            assert!(r.iter().zip(&c).all(|(a, b)| (a - b).abs() <= 1e-12));
        }
        for bits in [8, 16] {
            let q = model.quantize(bits);
            assert!(q.weights_unorm.iter().all(|&u| u == 0));
            assert!(q.basis.iter().flatten().all(|&x| x == 0.0));
            let r = q.reconstruct(7);
            assert!(r.iter().zip(&c).all(|(a, b)| (a - b).abs() <= 1e-12));
            assert_eq!(q.rms_error_against(&model), 0.0);
        }
    }
}

#[test]
fn basis_larger_than_the_rank_adds_no_nan_and_stays_exact() {
    let vis = low_rank(16, Order::FOUR, 2, 7);
    for m in [2, 3, 10, 16] {
        let model = fit(&vis, m).unwrap();
        assert!(all_finite(&model));
        let err = max_texel_error(&model, &vis);
        assert!(err <= F32_EXACT, "m = {m}: max error {err:e}");
        assert!((model.energy_captured(2) - 1.0).abs() <= 1e-12);
        let q = model.quantize(8);
        assert!(
            q.mean
                .iter()
                .chain(q.basis.iter().flatten())
                .all(|x| x.is_finite())
        );
        assert!(q.rms_error_against(&model) <= q.error_bound());
    }
}

#[test]
fn huge_dynamic_range_stays_finite() {
    let mut vis = low_rank(16, Order::SIX, 36, 3);
    let n = Order::SIX.coeff_count();
    vis.coeffs[40 * n..41 * n]
        .iter_mut()
        .for_each(|c| *c *= 1e6);
    for m in [1, 8, 36] {
        let model = fit(&vis, m).unwrap();
        assert!(all_finite(&model), "m = {m}");
        assert!(model.rms_reconstruction_error(&vis).is_finite());
        assert!(model.energy_captured(m).is_finite());
        let q = model.quantize(8);
        assert!(q.rms_error_against(&model).is_finite());
    }
    // The full basis still reconstructs the outlier to f32 precision, relative to its size.
    let model = fit(&vis, n).unwrap();
    let big: Vec<f64> = vis.texel(40).iter().map(|&c| f64::from(c)).collect();
    let scale = big.iter().map(|c| c.abs()).fold(0.0, f64::max);
    let err = model
        .reconstruct(40)
        .iter()
        .zip(&big)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err <= 1e-6 * scale, "outlier error {err:e} of {scale:e}");
}

#[test]
fn quantization_error_is_within_half_an_lsb_per_weight() {
    // Full-rank data with a decaying spectrum, like visibility.
    let n = Order::SIX.coeff_count();
    let mut rng = Lcg(11);
    let dirs = orthonormal(n, n, &mut rng);
    let mean: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let w: Vec<f64> = (0..256 * n).map(|_| rng.next()).collect();
    let vis = map(16, Order::SIX, |t| {
        let mut v = mean.clone();
        for (k, d) in dirs.iter().enumerate() {
            let a = w[t * n + k] * 0.7f64.powi(k as i32);
            v.iter_mut().zip(d).for_each(|(x, y)| *x += a * y);
        }
        v
    });
    let model = fit(&vis, 8).unwrap();
    let (q8, q16) = (model.quantize(8), model.quantize(16));
    let (e8, e16) = (q8.rms_error_against(&model), q16.rms_error_against(&model));
    println!(
        "quantization RMS error: 8-bit {e8:.3e} (bound {:.3e}), 16-bit {e16:.3e} (bound {:.3e}); \
         PCA-8 fit error {:.3e}",
        q8.error_bound(),
        q16.error_bound(),
        model.rms_reconstruction_error(&vis)
    );
    // The bound: half an LSB (hi_k − lo_k)/(2(2^b − 1)) per weight along orthonormal
    // basis vectors gives ‖δ‖ ≤ √Σ(hi_k − lo_k)² / (2(2^b − 1)) for every texel.
    let mut ranges = [(f64::INFINITY, f64::NEG_INFINITY); 8];
    for tw in model.weights.chunks_exact(8) {
        for (r, &x) in ranges.iter_mut().zip(tw) {
            *r = (r.0.min(f64::from(x)), r.1.max(f64::from(x)));
        }
    }
    let spread = ranges
        .iter()
        .map(|(lo, hi)| (hi - lo).powi(2))
        .sum::<f64>()
        .sqrt();
    for (q, bits) in [(&q8, 8), (&q16, 16)] {
        let bound = spread / (2.0 * f64::from((1u32 << bits) - 1));
        assert!((q.error_bound() - bound).abs() <= 1e-12 * bound);
        for t in 0..256 {
            let (a, b) = (q.reconstruct(t), model.reconstruct(t));
            let d = a
                .iter()
                .zip(&b)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(
                d <= bound * (1.0 + 1e-9),
                "{bits}-bit texel {t}: {d:e} > {bound:e}"
            );
        }
        assert!(q.weights_unorm.iter().all(|&u| u32::from(u) < (1 << bits)));
    }
    assert!(e8 > 0.0 && e8 <= q8.error_bound());
    assert!(e16 < e8 / 100.0, "16-bit {e16:e} vs 8-bit {e8:e}");
}

#[test]
fn energy_grows_with_m_and_error_is_the_tail() {
    let vis = low_rank(16, Order::FOUR, 16, 5);
    let full = fit(&vis, 16).unwrap();
    let energies: Vec<f64> = (0..=16).map(|m| full.energy_captured(m)).collect();
    assert!(energies.windows(2).all(|e| e[0] < e[1]), "{energies:?}");
    assert_eq!(energies[0], 0.0);
    assert!((energies[16] - 1.0).abs() <= 1e-12);
    // Every texel covered: the fit's mean squared error is the sum of the dropped
    // eigenvalues (up to the f32 weights).
    for m in 1..=16 {
        let model = fit(&vis, m).unwrap();
        let tail: f64 = model.eigenvalues[m..].iter().sum();
        let mse = model.rms_reconstruction_error(&vis).powi(2);
        assert!(
            (mse - tail).abs() <= 1e-6 * (1.0 + tail),
            "m = {m}: {mse} vs {tail}"
        );
    }
}

#[test]
fn house_visibility_energy_captured() {
    let scene = house::build(64).unwrap();
    let texels = rasterize(&scene.mesh, 64);
    let settings = VisibilitySettings {
        order: Order::SIX,
        rays: 64,
        seed: 0,
        progress: false,
    };
    let start = Instant::now();
    let vis = bake_visibility(&Tracer::new(&scene.mesh), &texels, &settings);
    let bake_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let model = fit(&vis, 24).unwrap();
    let fit_s = start.elapsed().as_secs_f64();
    println!("house 64² × 64 rays: bake {bake_s:.2} s, PCA fit {fit_s:.3} s");
    let mut last = 0.0;
    for m in [4, 8, 12, 16, 24] {
        let e = model.energy_captured(m);
        let rms = fit(&vis, m).unwrap().rms_reconstruction_error(&vis);
        println!("  M = {m:2}: energy captured {e:.4}, RMS coefficient error {rms:.4}");
        assert!(e > last && e <= 1.0);
        last = e;
    }
    assert!(all_finite(&model));
}
