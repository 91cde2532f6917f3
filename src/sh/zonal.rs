//! The clamped cosine H(ω) = max(0, cos θ) in SH, its convolution factors, and
//! radiance → irradiance (Ramamoorthi & Hanrahan 2001, "An Efficient Representation
//! for Irradiance Environment Maps"; Sloan 2008 "Stupid SH Tricks" §"Convolution").
//!
//! # Math
//!
//! H is zonal about +z, so only y_l^0 coefficients are non-zero:
//!
//! ```text
//! z_l = ∫ H y_l^0 dω = 2π √((2l+1)/(4π)) · I_l,   I_l = ∫₀¹ P_l(t) t dt
//! I_0 = 1/2,  I_1 = 1/3,  I_l = 0 for odd l ≥ 3,
//! I_l = (−1)^(l/2+1) / ((l−1)(l+2)) · (l−1)!!/l!!   for even l ≥ 2
//! ```
//!
//! (I_2 = 1/8, I_4 = −1/48, I_6 = 1/128.) The double-factorial ratio (l−1)!!/l!! =
//! Π_{k=2,4,…,l} (k−1)/k is a running product, so any band is finite and accurate.
//!
//! By the Funk–Hecke theorem, convolving a function with a zonal kernel scales band l
//! by √(4π/(2l+1))·z_l = 2π·I_l =: A_l (A_0 = π, A_1 = 2π/3, A_2 = π/4, A_l = 0 for odd
//! l ≥ 3). Hence the irradiance E(n) = ∫ L(ω) max(0, n·ω) dω has SH coefficients
//! E_l^m = A_l · L_l^m (Iwanicki–Sloan §5, `preconv`/`shlmap`; DESIGN §1, §2).
//!
//! Tests: odd bands exactly zero, A_0..A_2, z_l against an exact sphere quadrature of
//! H·y_l^0 for l ≤ 12.

use glam::DVec3;

use super::basis::eval_basis;
use super::{Order, sh_index};

/// ∫₀¹ P_l(t) t dt (see the module doc); exactly 0.0 for odd l ≥ 3.
fn legendre_first_moment(l: u32) -> f64 {
    match l {
        0 => 0.5,
        1 => 1.0 / 3.0,
        _ if l % 2 == 1 => 0.0,
        _ => {
            // (l−1)!!/l!! as a running product of (k−1)/k over even k.
            let ratio: f64 = (1..=l / 2)
                .map(|j| (2 * j - 1) as f64 / (2 * j) as f64)
                .product();
            let sign = if (l / 2) % 2 == 1 { 1.0 } else { -1.0 }; // (−1)^(l/2+1)
            let lf = l as f64;
            sign * ratio / ((lf - 1.0) * (lf + 2.0))
        }
    }
}

/// SH coefficient z_l of the clamped cosine max(0, cos θ) about +z (only m = 0 is
/// non-zero): z_0 = √π/2, z_1 = √(π/3), z_2 = √(5π)/8; exactly 0.0 for odd l ≥ 3.
pub fn clamped_cosine_zonal(l: u32) -> f64 {
    let lf = l as f64;
    2.0 * std::f64::consts::PI
        * ((2.0 * lf + 1.0) / (4.0 * std::f64::consts::PI)).sqrt()
        * legendre_first_moment(l)
}

/// Convolution factor A_l = √(4π/(2l+1))·z_l = 2π ∫₀¹ P_l(t) t dt by which band l of a
/// radiance function is scaled to give irradiance: A_0 = π, A_1 = 2π/3, A_2 = π/4,
/// exactly 0.0 for odd l ≥ 3.
pub fn clamped_cosine_convolution(l: u32) -> f64 {
    2.0 * std::f64::consts::PI * legendre_first_moment(l)
}

/// SH of irradiance E(n) = ∫ L(ω) max(0, n·ω) dω from the SH of radiance L (RGB), both
/// truncated to `order`: E_l^m = A_l · L_l^m.
///
/// # Panics
/// If `radiance` holds fewer than `order.coeff_count()` coefficients.
pub fn irradiance_from_radiance(radiance: &[[f64; 3]], order: Order) -> Vec<[f64; 3]> {
    assert!(
        radiance.len() >= order.coeff_count(),
        "{} coefficients given, order {order} needs {}",
        radiance.len(),
        order.coeff_count()
    );
    let mut out = Vec::with_capacity(order.coeff_count());
    for l in 0..order.get() as i32 {
        let a = clamped_cosine_convolution(l as u32);
        for m in -l..=l {
            out.push(radiance[sh_index(l, m)].map(|c| a * c));
        }
    }
    out
}

/// Irradiance (RGB) at unit direction `n` under order-3 RGB radiance SH `radiance`:
/// Σ_lm A_l L_l^m y_l^m(n), without forming the irradiance coefficients (the per-node
/// kernel of the tangent-space fits, `sh::hbasis` and `technique::ambient_cube`).
///
/// # Panics
/// If `radiance` holds fewer than 9 coefficients.
pub fn irradiance_at(radiance: &[[f64; 3]], n: DVec3) -> [f64; 3] {
    assert!(radiance.len() >= 9, "order-3 radiance needed");
    let mut y = [0.0; 9];
    eval_basis(Order::THREE, n, &mut y);
    let mut e = [0.0; 3];
    for l in 0..3 {
        let a = clamped_cosine_convolution(l as u32);
        for m in -l..=l {
            let k = sh_index(l, m);
            for (c, ec) in e.iter_mut().enumerate() {
                *ec += a * radiance[k][c] * y[k];
            }
        }
    }
    e
}

/// Evaluates an RGB SH expansion Σᵢ cᵢ yᵢ(`dir`) over the bands l < `order`.
/// `dir` is unit length (debug-checked).
///
/// # Panics
/// If `coeffs` holds fewer than `order.coeff_count()` coefficients.
pub fn eval_rgb(coeffs: &[[f64; 3]], order: Order, dir: DVec3) -> [f64; 3] {
    let n = order.coeff_count();
    assert!(
        coeffs.len() >= n,
        "{} coefficients given, order {order} needs {n}",
        coeffs.len()
    );
    if n <= 64 {
        let mut y = [0.0f64; 64];
        eval_basis(order, dir, &mut y);
        dot_rgb(coeffs, &y[..n])
    } else {
        dot_rgb(coeffs, &super::basis::eval_basis_vec(order, dir))
    }
}

fn dot_rgb(coeffs: &[[f64; 3]], y: &[f64]) -> [f64; 3] {
    let mut sum = [0.0; 3];
    for (c, y) in coeffs.iter().zip(y) {
        for k in 0..3 {
            sum[k] += c[k] * y;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::gauss_legendre;
    use std::f64::consts::PI;

    /// Closed forms of a few f64 operations.
    const CLOSED_FORM: f64 = 1e-14;
    /// Exact (polynomial) quadrature of z_l on the hemisphere, O(1) values.
    const QUADRATURE: f64 = 1e-13;

    #[test]
    fn odd_bands_from_3_are_exactly_zero() {
        for l in (3..200).step_by(2) {
            assert_eq!(clamped_cosine_zonal(l), 0.0, "z_{l}");
            assert_eq!(clamped_cosine_convolution(l), 0.0, "A_{l}");
        }
    }

    #[test]
    fn known_values() {
        let want_a = [
            PI,
            2.0 * PI / 3.0,
            PI / 4.0,
            0.0,
            -PI / 24.0,
            0.0,
            PI / 64.0,
        ];
        for (l, want) in want_a.iter().enumerate() {
            let got = clamped_cosine_convolution(l as u32);
            assert!(
                (got - want).abs() < CLOSED_FORM,
                "A_{l} = {got}, want {want}"
            );
        }
        let want_z = [PI.sqrt() / 2.0, (PI / 3.0).sqrt(), (5.0 * PI).sqrt() / 8.0];
        for (l, want) in want_z.iter().enumerate() {
            let got = clamped_cosine_zonal(l as u32);
            assert!(
                (got - want).abs() < CLOSED_FORM,
                "z_{l} = {got}, want {want}"
            );
        }
        // High bands stay finite and decay like l^(-5/2)·√l.
        let z1000 = clamped_cosine_zonal(1000);
        assert!(z1000.is_finite() && z1000.abs() < 1e-5 && z1000 != 0.0);
    }

    #[test]
    fn zonal_matches_sphere_quadrature_to_l_12() {
        // z_l = ∫_{t∈[0,1]} ∫_φ t · y_l^0(ω) dφ dt: the integrand is a polynomial of degree
        // ≤ 13 in t, so 16 Gauss–Legendre nodes mapped to [0, 1] are exact; y_l^0 comes
        // from the basis recurrence, so this also checks the convention (y_l^0 along +z).
        let order = Order::new(13).expect("valid order");
        let (ts, ws) = gauss_legendre(16);
        let mut y = vec![0.0; order.coeff_count()];
        let mut z = [0.0; 13];
        for (t, w) in ts.iter().zip(&ws) {
            let t = 0.5 * (t + 1.0);
            let r = (1.0 - t * t).sqrt();
            eval_basis(order, DVec3::new(r, 0.0, t), &mut y);
            for (l, zl) in z.iter_mut().enumerate() {
                *zl += 0.5 * w * 2.0 * PI * t * y[sh_index(l as i32, 0)];
            }
        }
        for (l, want) in z.iter().enumerate() {
            let got = clamped_cosine_zonal(l as u32);
            assert!((got - want).abs() < QUADRATURE, "z_{l}: {got} vs {want}");
        }
    }

    #[test]
    fn irradiance_of_constant_radiance_is_pi() {
        // L = 1 ⇒ L_0^0 = 2√π ⇒ E(n) = π for every n.
        let order = Order::SIX;
        let mut radiance = vec![[0.0; 3]; order.coeff_count()];
        radiance[0] = [2.0 * PI.sqrt(); 3];
        let e = irradiance_from_radiance(&radiance, order);
        for n in [DVec3::Z, DVec3::NEG_Y, DVec3::new(0.6, 0.0, 0.8)] {
            for c in eval_rgb(&e, order, n) {
                assert!((c - PI).abs() < CLOSED_FORM, "E({n}) = {c}");
            }
        }
    }

    #[test]
    fn irradiance_at_a_direction_is_the_irradiance_expansion_there() {
        let radiance: Vec<[f64; 3]> = (0..9)
            .map(|k| {
                let k = k as f64;
                [0.3 - 0.05 * k, 0.1 * (k - 4.0), 0.02 * k * k - 0.4]
            })
            .collect();
        let e = irradiance_from_radiance(&radiance, Order::THREE);
        for n in [
            DVec3::Z,
            DVec3::NEG_X,
            DVec3::new(0.6, 0.0, 0.8),
            DVec3::new(-0.48, 0.6, -0.64),
        ] {
            let want = eval_rgb(&e, Order::THREE, n);
            let got = irradiance_at(&radiance, n);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < CLOSED_FORM,
                    "{n}: {got:?} vs {want:?}"
                );
            }
        }
    }

    #[test]
    fn eval_rgb_above_64_coefficients() {
        let order = Order::new(10).expect("valid order");
        let mut c = vec![[0.0; 3]; order.coeff_count()];
        c[sh_index(9, 0)] = [1.0, 2.0, 3.0];
        let v = eval_rgb(&c, order, DVec3::Z);
        let y = (19.0 / (4.0 * PI)).sqrt();
        for (k, want) in [y, 2.0 * y, 3.0 * y].iter().enumerate() {
            assert!((v[k] - want).abs() < CLOSED_FORM * 10.0, "{v:?}");
        }
    }
}
