//! SH projection of an equirectangular radiance map: L_i = ∫ L(ω) y_i(ω) dω
//! (Iwanicki–Sloan §2.1, §3.3 "L projected to order O+2"; DESIGN §1).
//!
//! # Quadrature
//!
//! Each texel is read as constant radiance over its exact spherical rectangle
//! (φ ∈ [φ₀, φ₀+Δφ], θ ∈ [θ_top, θ_bottom]; module doc of [`crate::env`]), so
//!
//! ```text
//! L_i = Σ_texels L_t · ∫_t y_i dω
//! ```
//!
//! and ∫_t y_i dω is integrated with a 3×3 Gauss–Legendre product rule in (θ, φ) over
//! the texel (measure sin θ dθ dφ), its nine weights rescaled so that they sum to the
//! texel's exact solid angle Δφ(cos θ_top − cos θ_bottom). Why not the centre sample
//! times Ω: that midpoint rule errs by O(Δθ²) in θ — 1.4·10⁻⁵ of L_0 in L_2^0 for a
//! constant 512×256 map — whereas the 3-point rule errs by O(Δθ⁶); a constant map then
//! projects to c·2√π in L_0 and ≈ 10⁻¹⁴ elsewhere. The rule is exact for the
//! piecewise-constant map up to that quadrature error, so the remaining error of a
//! smooth map sampled at texel centres is the point-vs-box difference, O(Δθ²)·|∂²L|.
//!
//! Sums are compensated (Neumaier) within each row and across rows; rows run in
//! parallel (rayon) and their partials are reduced in row order, so the result is
//! deterministic. Cost: 9 basis evaluations per texel.

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use super::EnvMap;
use crate::sh::Order;
use crate::sh::basis::eval_basis;

/// Nodes of the 3-point Gauss–Legendre rule on [−1, 1], with weights 5/9, 8/9, 5/9.
fn gauss3() -> ([f64; 3], [f64; 3]) {
    let a = (3.0f64 / 5.0).sqrt();
    ([-a, 0.0, a], [5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])
}

/// Neumaier-compensated sum.
#[derive(Clone, Copy, Default)]
struct Neumaier {
    sum: f64,
    comp: f64,
}

impl Neumaier {
    fn add(&mut self, v: f64) {
        let t = self.sum + v;
        if self.sum.abs() >= v.abs() {
            self.comp += (self.sum - t) + v;
        } else {
            self.comp += (v - t) + self.sum;
        }
        self.sum = t;
    }
    fn value(self) -> f64 {
        self.sum + self.comp
    }
}

/// RGB SH coefficients L_i, i < `order.coeff_count()`, of `env` (module doc for the
/// quadrature). Coefficient i is at flat index l(l+1)+m (DESIGN §1).
///
/// # Panics
/// If `env.texels.len() != width·height` (a malformed map built by hand).
pub fn project_sh(env: &EnvMap, order: Order) -> Vec<[f64; 3]> {
    let (w, h) = (env.width as usize, env.height as usize);
    assert_eq!(
        env.texels.len(),
        w * h,
        "{w}×{h} map holds {} texels",
        env.texels.len()
    );
    let n = order.coeff_count();
    let rows: Vec<Vec<[f64; 3]>> = (0..env.height)
        .into_par_iter()
        .map(|y| project_row(env, order, y))
        .collect();
    (0..n)
        .map(|i| {
            std::array::from_fn(|k| {
                let mut acc = Neumaier::default();
                for row in &rows {
                    acc.add(row[i][k]);
                }
                acc.value()
            })
        })
        .collect()
}

/// The per-texel quadrature of one row (module doc): θ nodes (sin θ, cos θ, weight),
/// the common weight scale (exact solid angle / raw rule), and the φ step.
struct RowRule {
    theta: [(f64, f64, f64); 3],
    scale: f64,
    d_phi: f64,
}

impl RowRule {
    fn new(env: &EnvMap, y: u32) -> RowRule {
        let (w, h) = (env.width as f64, env.height as f64);
        let (g_nodes, g_weights) = gauss3();
        let d_phi = 2.0 * PI / w;
        let d_theta = PI / h;
        let theta_mid = (y as f64 + 0.5) * d_theta;
        let mut theta = [(0.0, 0.0, 0.0); 3];
        for k in 0..3 {
            let t = theta_mid + 0.5 * d_theta * g_nodes[k];
            theta[k] = (t.sin(), t.cos(), g_weights[k] * t.sin());
        }
        let raw: f64 = theta.iter().map(|t| t.2).sum::<f64>() * 0.5 * d_theta * d_phi;
        let omega = env.texel_solid_angle(y);
        // Each (θ, φ) node's weight: GL in θ × GL in φ (both halves of ½Δ·Σ g = Δ).
        let scale = omega / raw * 0.5 * d_theta * 0.5 * d_phi;
        RowRule {
            theta,
            scale,
            d_phi,
        }
    }

    /// Calls `f(direction, weight)` for the 9 nodes of texel `x`; weights sum to Ω_texel.
    fn for_each_node(&self, env: &EnvMap, x: u32, mut f: impl FnMut(DVec3, f64)) {
        let (g_nodes, g_weights) = gauss3();
        let phi_mid = 2.0 * PI * ((x as f64 + 0.5) / env.width as f64 - 0.5);
        for (sin_t, cos_t, wt) in self.theta {
            for j in 0..3 {
                let phi = phi_mid + 0.5 * self.d_phi * g_nodes[j];
                let (sin_p, cos_p) = phi.sin_cos();
                let dir = DVec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p);
                f(dir, wt * g_weights[j] * self.scale);
            }
        }
    }
}

/// Irradiance E(n) = ∫ L(ω) max(0, n·ω) dω by direct quadrature over the texels (the same
/// per-texel rule as [`project_sh`]): the ground truth that order-3 SH irradiance
/// approximates (`shvis sh irradiance --exact`). `normal` must be unit length.
pub fn irradiance_brute_force(env: &EnvMap, normal: DVec3) -> [f64; 3] {
    let rows: Vec<[f64; 3]> = (0..env.height)
        .into_par_iter()
        .map(|y| {
            let rule = RowRule::new(env, y);
            let mut acc = [Neumaier::default(); 3];
            for x in 0..env.width {
                let l_t = env.texels[y as usize * env.width as usize + x as usize];
                let mut cosine = 0.0;
                rule.for_each_node(env, x, |dir, weight| {
                    cosine += weight * normal.dot(dir).max(0.0);
                });
                for k in 0..3 {
                    acc[k].add(l_t[k] as f64 * cosine);
                }
            }
            acc.map(Neumaier::value)
        })
        .collect();
    std::array::from_fn(|k| {
        let mut acc = Neumaier::default();
        for r in &rows {
            acc.add(r[k]);
        }
        acc.value()
    })
}

/// Compensated partial sums of one row: Σ_x L_t ∫_t y_i dω.
fn project_row(env: &EnvMap, order: Order, y: u32) -> Vec<[f64; 3]> {
    let n = order.coeff_count();
    let rule = RowRule::new(env, y);
    let mut basis_weighted = vec![0.0; n];
    let mut basis = vec![0.0; n];
    let mut acc = vec![[Neumaier::default(); 3]; n];
    for x in 0..env.width {
        let l_t = env.texels[y as usize * env.width as usize + x as usize];
        if l_t == [0.0; 3] {
            continue;
        }
        basis_weighted.fill(0.0);
        rule.for_each_node(env, x, |dir, weight| {
            eval_basis(order, dir, &mut basis);
            for (b, v) in basis_weighted.iter_mut().zip(&basis) {
                *b += weight * v;
            }
        });
        for (a, b) in acc.iter_mut().zip(&basis_weighted) {
            for k in 0..3 {
                a[k].add(l_t[k] as f64 * b);
            }
        }
    }
    acc.into_iter().map(|a| a.map(Neumaier::value)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Compensated sums of ~10⁵ O(1) terms, each carrying a few ulps of basis error.
    const CONSTANT_MAP: f64 = 1e-12;

    #[test]
    fn constant_map_projects_to_dc_only() {
        let c = 0.75f32;
        let env = EnvMap::from_fn(64, 32, |_| [c; 3]);
        let coeffs = project_sh(&env, Order::new(8).expect("valid"));
        let dc = c as f64 * 2.0 * PI.sqrt();
        assert!(
            (coeffs[0][0] - dc).abs() < CONSTANT_MAP * dc,
            "{:?}",
            coeffs[0]
        );
        for (i, cf) in coeffs.iter().enumerate().skip(1) {
            // 3-point rule on a 32-row map: error O(Δθ⁶) with band-7 derivatives.
            assert!(cf[1].abs() < 1e-7 * dc, "coefficient {i}: {cf:?}");
        }
    }

    #[test]
    fn neumaier_recovers_cancellation() {
        let mut s = Neumaier::default();
        for v in [1.0, 1e100, 1.0, -1e100] {
            s.add(v);
        }
        assert_eq!(s.value(), 2.0);
    }
}
