//! Projection of a function on the sphere onto real SH by an exact product quadrature,
//! and the matching reconstruction.
//!
//! # Math
//!
//! The coefficients of f in the orthonormal basis of [`crate::sh`] (DESIGN §1) are
//! f_i = ∫ f(ω) y_i(ω) dω. With ω = (√(1−z²) cos φ, √(1−z²) sin φ, z) and dω = dz dφ,
//! the product rule
//!
//! ```text
//! ∫ g dω ≈ Σ_a Σ_b  w_a · (2π/M) · g(z_a, φ_b),   z_a, w_a: n-point Gauss–Legendre,
//!                                                φ_b = 2π(b + ½)/M, M = 2n
//! ```
//!
//! is exact for every polynomial g of degree ≤ 2n−1 in (x, y, z) restricted to the
//! sphere: in z it is a polynomial of degree ≤ 2n−1 (Gauss–Legendre with n nodes is
//! exact there), in φ a trigonometric polynomial of degree ≤ 2n−1 (M = 2n equispaced
//! nodes integrate e^{ikφ} exactly for |k| < M). A band-limited f with bands ≤ B
//! projected to `order` N needs degree B + N − 1 ≤ 2n − 1, i.e.
//! n ≥ ⌈(B + N)/2⌉ ([`exact_quadrature_n`]). For other f the rule converges
//! spectrally with n.
//!
//! Rings (fixed z) are summed in parallel (rayon) and combined in a fixed order with
//! Neumaier's compensated summation, so results are deterministic (STYLE §4: long
//! sums are compensated).
//!
//! Tests: here (constants and band-limited inputs projected exactly) and
//! `tests/sh_oracle.rs` (orthonormality at order 13 to 1e-12).

use glam::DVec3;
use rayon::prelude::*;

use super::basis::eval_basis;
use super::{Order, gauss_legendre};

/// Nodes and weights of the product rule of the module doc: `n` Gauss–Legendre nodes
/// in z times 2n equispaced azimuths, 2n² unit directions whose weights (sr) sum to 4π.
///
/// Exact for every polynomial of degree ≤ 2n−1 on the sphere. Ring-major order: the
/// 2n directions of the lowest z first. `n = 0` gives an empty rule.
pub fn sphere_quadrature(n: usize) -> Vec<(DVec3, f64)> {
    let (zs, ws) = gauss_legendre(n);
    let n_phi = 2 * n;
    let mut out = Vec::with_capacity(n * n_phi);
    for (z, w) in zs.iter().zip(&ws) {
        let r = (1.0 - z * z).max(0.0).sqrt();
        let weight = w * 2.0 * std::f64::consts::PI / n_phi as f64;
        for b in 0..n_phi {
            let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / n_phi as f64;
            out.push((DVec3::new(r * phi.cos(), r * phi.sin(), *z), weight));
        }
    }
    out
}

/// Smallest `n` for which [`sphere_quadrature`]`(n)` projects a function whose SH
/// bands are all ≤ `band_limit` onto `order` exactly: ⌈(band_limit + order)/2⌉
/// (at least 1).
pub fn exact_quadrature_n(order: Order, band_limit: u32) -> usize {
    ((band_limit + order.get()) as usize).div_ceil(2).max(1)
}

/// SH coefficients f_i = ∫ f(ω) y_i(ω) dω for the bands l < `order`, by the product rule
/// [`sphere_quadrature`]`(quadrature_n)` (exact when `quadrature_n` ≥
/// [`exact_quadrature_n`] of f's band limit).
///
/// `f` receives unit directions (frame: the SH frame, +z the polar axis) and is called
/// 2·`quadrature_n`² times, in parallel. Returns `order.coeff_count()` values; all
/// zero when `quadrature_n` is 0.
pub fn project_fn(order: Order, f: impl Fn(DVec3) -> f64 + Sync, quadrature_n: usize) -> Vec<f64> {
    let nc = order.coeff_count();
    let (zs, ws) = gauss_legendre(quadrature_n);
    let n_phi = 2 * quadrature_n;
    let rings: Vec<Vec<f64>> = zs
        .par_iter()
        .zip(ws.par_iter())
        .map(|(z, w)| {
            let r = (1.0 - z * z).max(0.0).sqrt();
            let weight = w * 2.0 * std::f64::consts::PI / n_phi as f64;
            let mut y = vec![0.0; nc];
            let mut ring = vec![0.0; nc];
            for b in 0..n_phi {
                let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / n_phi as f64;
                let dir = DVec3::new(r * phi.cos(), r * phi.sin(), *z);
                let v = f(dir) * weight;
                eval_basis(order, dir, &mut y);
                for (acc, yi) in ring.iter_mut().zip(&y) {
                    *acc += v * yi;
                }
            }
            ring
        })
        .collect();
    // Neumaier summation over rings, in ring order (deterministic).
    let mut sum = vec![0.0; nc];
    let mut comp = vec![0.0; nc];
    for ring in &rings {
        for i in 0..nc {
            let t = sum[i] + ring[i];
            comp[i] += if sum[i].abs() >= ring[i].abs() {
                (sum[i] - t) + ring[i]
            } else {
                (ring[i] - t) + sum[i]
            };
            sum[i] = t;
        }
    }
    sum.iter().zip(&comp).map(|(s, c)| s + c).collect()
}

/// Reconstruction Σ_i c_i y_i(`dir`) over the bands l < `order`: the inverse of
/// [`project_fn`] for band-limited functions. `dir` is unit length (debug-checked).
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` values.
pub fn eval(coeffs: &[f64], order: Order, dir: DVec3) -> f64 {
    let n = order.coeff_count();
    assert!(
        coeffs.len() >= n,
        "{} coefficients given, order {order} needs {n}",
        coeffs.len()
    );
    let mut stack = [0.0f64; 64];
    let mut heap = Vec::new();
    let y: &mut [f64] = if n <= stack.len() {
        &mut stack[..n]
    } else {
        heap.resize(n, 0.0);
        &mut heap
    };
    eval_basis(order, dir, y);
    coeffs[..n].iter().zip(y.iter()).map(|(c, y)| c * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::sh_index;
    use std::f64::consts::PI;

    /// Exact quadrature of O(1) polynomials: a few hundred f64 terms.
    const EXACT: f64 = 1e-13;

    #[test]
    fn weights_sum_to_4_pi_and_directions_are_unit() {
        for n in [1, 2, 7, 20] {
            let q = sphere_quadrature(n);
            assert_eq!(q.len(), 2 * n * n);
            let total: f64 = q.iter().map(|(_, w)| w).sum();
            assert!((total - 4.0 * PI).abs() < EXACT, "n={n}: {total}");
            for (d, _) in &q {
                assert!((d.length() - 1.0).abs() < 1e-15, "{d}");
            }
        }
        assert!(sphere_quadrature(0).is_empty());
    }

    #[test]
    fn band_limited_inputs_project_exactly() {
        // f = 1 + 2 y_1^1 − 0.5 y_3^−2 (bands ≤ 3) projected to order 4: n = 4 is exact.
        let order = Order::FOUR;
        let mut want = vec![0.0; order.coeff_count()];
        want[0] = 2.0 * PI.sqrt(); // 1 = 2√π · y_0^0
        want[sh_index(1, 1)] = 2.0;
        want[sh_index(3, -2)] = -0.5;
        let f = |d: DVec3| eval(&want, order, d);
        let n = exact_quadrature_n(order, 3);
        assert_eq!(n, 4);
        let got = project_fn(order, f, n);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert!((g - w).abs() < EXACT, "i={i}: {g} vs {w}");
        }
        assert!(project_fn(order, f, 0).iter().all(|c| *c == 0.0));
    }

    #[test]
    fn eval_above_64_coefficients() {
        let order = Order::new(9).expect("valid order");
        let mut c = vec![0.0; order.coeff_count()];
        c[sh_index(8, 0)] = 1.0;
        let want = (17.0 / (4.0 * PI)).sqrt();
        assert!((eval(&c, order, DVec3::Z) - want).abs() < EXACT);
    }
}
