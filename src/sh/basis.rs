//! Evaluation of the real SH basis y_l^m(ω) (Iwanicki–Sloan eqs. (1)–(3); convention in
//! [`crate::sh`], DESIGN §1) for any order up to [`MAX_ORDER`](super::MAX_ORDER).
//!
//! # Method
//!
//! With z = cos θ and s = sin θ, write the normalised, "sinᵐθ-divided" Legendre function
//!
//! ```text
//! Q_l^m(z) = K_l^m P_l^m(z) / sᵐ          (a polynomial in z, P with Condon–Shortley phase)
//! ```
//!
//! so that for m > 0, y_l^{±m} = √2 Q_l^m(z) · {Re, Im}(x + iy)ᵐ, since
//! (x + iy)ᵐ = sᵐ (cos mφ + i sin mφ). Everything is a polynomial in (x, y, z): no
//! atan2/acos, exact at the poles (where x + iy = 0). Recurrences (no factorials):
//!
//! 1. Diagonal: Q_0^0 = 1/√(4π), Q_m^m = −√((2m+1)/(2m)) · Q_{m−1}^{m−1} — the running
//!    product of K_m^m/K_{m−1}^{m−1} = 1/√((2m)(2m−1)) · √((2m+1)/(2m−1)) with
//!    P_m^m/P_{m−1}^{m−1} = −(2m−1)·s.
//! 2. First off-diagonal: Q_{m+1}^m = √(2m+3) · z · Q_m^m.
//! 3. Three-term recurrence in l (the normalised form of DLMF 14.10.3):
//!    Q_l^m = a_l^m (z Q_{l−1}^m − b_l^m Q_{l−2}^m), a_l^m = √((4l²−1)/(l²−m²)),
//!    b_l^m = √(((l−1)²−m²)/(4(l−1)²−1)).
//!
//! The constants (Q_m^m, a, b) are tabulated once for every (l, m) up to order 30. The
//! normalised recurrence is the standard stable one: no factorial is ever formed, the
//! Q stay below ~10⁶ at order 30 (at the poles, where sᵐ = 0 kills them) and every
//! y_l^m is bounded by √((2l+1)/2π). Tested: closed forms for l ≤ 2, orthonormality to
//! order 6 to 1e-12, the addition theorem Σ_m (y_l^m)² = (2l+1)/4π to order 30, and the
//! poles exactly and 1e-9 from them at order 30 (DESIGN §6).

use std::sync::OnceLock;

use glam::{DVec3, Vec3};

use super::{MAX_ORDER, Order, sh_index};

/// Writes y_l^m(`dir`) for every band l < `order` to `out[l(l+1)+m]`.
///
/// `dir` must be unit length (debug-checked; validate user input with
/// [`super::unit_dir`]). `out` must hold at least `order.coeff_count()` values; entries
/// past that are left untouched.
///
/// # Panics
/// If `out` is shorter than `order.coeff_count()`.
pub fn eval_basis(order: Order, dir: DVec3, out: &mut [f64]) {
    debug_assert!(
        (dir.length_squared() - 1.0).abs() < 1e-9,
        "{dir} is not unit length"
    );
    let n = order.get() as i32;
    assert!(
        out.len() >= order.coeff_count(),
        "output slice holds {} values, order {n} needs {}",
        out.len(),
        order.coeff_count()
    );
    let (x, y, z) = (dir.x, dir.y, dir.z);
    let table = recurrence_table();

    // m = 0: zonal column, Q_l^0 = y_l^0.
    let mut q_prev = 0.0;
    let mut q = table[0].0;
    out[0] = q;
    for l in 1..n {
        let (a, b) = table[sh_index(l, 0)];
        (q_prev, q) = (q, a * (z * q - b * q_prev));
        out[sh_index(l, 0)] = q;
    }
    // m > 0: (x + iy)^m = c + i s by complex multiplication (exact at the poles), times √2:
    // the azimuthal factors √2·sinᵐθ·cos(mφ), √2·sinᵐθ·sin(mφ) of eq. (3).
    let (mut c, mut s) = (1.0, 0.0);
    for m in 1..n {
        (c, s) = (x * c - y * s, x * s + y * c);
        let (re, im) = (std::f64::consts::SQRT_2 * c, std::f64::consts::SQRT_2 * s);
        let mut q_prev = 0.0;
        let mut q = table[sh_index(m, m)].0;
        out[sh_index(m, m)] = q * re;
        out[sh_index(m, -m)] = q * im;
        for l in (m + 1)..n {
            let (a, b) = table[sh_index(l, m)];
            (q_prev, q) = (q, a * (z * q - b * q_prev));
            out[sh_index(l, m)] = q * re;
            out[sh_index(l, -m)] = q * im;
        }
    }
}

/// Recurrence constants for every (l, m ≥ 0) up to [`MAX_ORDER`], at index l(l+1)+m:
/// (Q_m^m, 0) on the diagonal (step 1, a constant), (a_l^m, b_l^m) below it (steps 2–3;
/// b = 0 at l = m+1, where a = √(2m+3)). Built once, ~15 kB.
fn recurrence_table() -> &'static [(f64, f64)] {
    static TABLE: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let n = MAX_ORDER as i32;
        let mut table = vec![(0.0, 0.0); (n * n) as usize];
        let mut q_mm = 1.0 / (4.0 * std::f64::consts::PI).sqrt();
        for m in 0..n {
            let mf = m as f64;
            if m > 0 {
                q_mm *= -((2.0 * mf + 1.0) / (2.0 * mf)).sqrt();
            }
            table[sh_index(m, m)] = (q_mm, 0.0);
            for l in (m + 1)..n {
                let (lf, l1) = (l as f64, (l - 1) as f64);
                let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
                let b = ((l1 * l1 - mf * mf) / (4.0 * l1 * l1 - 1.0)).sqrt();
                table[sh_index(l, m)] = (a, b);
            }
        }
        table
    })
}

/// f32 variant of [`eval_basis`] for GPU-side data: evaluated in f64, rounded once.
///
/// # Panics
/// If `out` is shorter than `order.coeff_count()`.
pub fn eval_basis_f32(order: Order, dir: Vec3, out: &mut [f32]) {
    let mut wide = [0.0f64; 64];
    let count = order.coeff_count();
    assert!(
        out.len() >= count,
        "output slice holds {} values, order {order} needs {count}",
        out.len()
    );
    // Renormalise in f64 so an f32-rounded unit vector passes the debug check.
    let dir = dir.as_dvec3().normalize();
    if count <= wide.len() {
        eval_basis(order, dir, &mut wide);
        for (o, w) in out.iter_mut().zip(&wide[..count]) {
            *o = *w as f32;
        }
    } else {
        let wide = eval_basis_vec(order, dir);
        for (o, w) in out.iter_mut().zip(&wide) {
            *o = *w as f32;
        }
    }
}

/// [`eval_basis`] into a new vector of `order.coeff_count()` values.
pub fn eval_basis_vec(order: Order, dir: DVec3) -> Vec<f64> {
    let mut out = vec![0.0; order.coeff_count()];
    eval_basis(order, dir, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::gauss_legendre;
    use std::f64::consts::PI;

    /// Closed forms vs recurrence: a handful of f64 operations each, values O(1).
    const CLOSED_FORM: f64 = 1e-14;
    /// Orthonormality by an exact quadrature (DESIGN-level target for SH math).
    const ORTHONORMAL: f64 = 1e-12;
    /// f32 rounding of O(1) values.
    const F32_ROUND: f64 = 1e-6;

    /// Deterministic well-spread unit vectors (golden-angle spiral) plus the axes.
    fn test_dirs() -> Vec<DVec3> {
        let mut dirs: Vec<DVec3> = (0..97)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / 97.0;
                let phi = i as f64 * PI * (3.0 - 5f64.sqrt());
                let r = (1.0 - z * z).sqrt();
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        dirs.extend([
            DVec3::X,
            DVec3::NEG_X,
            DVec3::Y,
            DVec3::NEG_Y,
            DVec3::Z,
            DVec3::NEG_Z,
        ]);
        dirs
    }

    fn closed_form_l2(d: DVec3) -> [f64; 9] {
        let (x, y, z) = (d.x, d.y, d.z);
        let k1 = (3.0 / (4.0 * PI)).sqrt();
        let k2 = 0.5 * (15.0 / PI).sqrt();
        [
            1.0 / (2.0 * PI.sqrt()),
            -k1 * y,
            k1 * z,
            -k1 * x,
            k2 * x * y,
            -k2 * y * z,
            0.25 * (5.0 / PI).sqrt() * (3.0 * z * z - 1.0),
            -k2 * x * z,
            0.25 * (15.0 / PI).sqrt() * (x * x - y * y),
        ]
    }

    #[test]
    fn matches_closed_forms_up_to_band_2() {
        for d in test_dirs() {
            let got = eval_basis_vec(Order::THREE, d);
            let want = closed_form_l2(d);
            for i in 0..9 {
                assert!(
                    (got[i] - want[i]).abs() < CLOSED_FORM,
                    "dir {d} index {i}: {} vs {}",
                    got[i],
                    want[i]
                );
            }
        }
    }

    #[test]
    fn orthonormal_to_order_6() {
        // y_i·y_j has degree ≤ 10 in z (16 GL nodes are exact to degree 31) and
        // trigonometric degree ≤ 10 in φ (32 uniform nodes are exact below 32).
        let order = Order::SIX;
        let nc = order.coeff_count();
        let (zs, ws) = gauss_legendre(16);
        let n_phi = 32;
        let mut gram = vec![0.0; nc * nc];
        let mut y = vec![0.0; nc];
        for (z, w) in zs.iter().zip(&ws) {
            let r = (1.0 - z * z).sqrt();
            for k in 0..n_phi {
                let phi = 2.0 * PI * k as f64 / n_phi as f64;
                eval_basis(order, DVec3::new(r * phi.cos(), r * phi.sin(), *z), &mut y);
                let weight = w * 2.0 * PI / n_phi as f64;
                for i in 0..nc {
                    for j in 0..nc {
                        gram[i * nc + j] += weight * y[i] * y[j];
                    }
                }
            }
        }
        for i in 0..nc {
            for j in 0..nc {
                let want = if i == j { 1.0 } else { 0.0 };
                let got = gram[i * nc + j];
                assert!((got - want).abs() < ORTHONORMAL, "<y{i}, y{j}> = {got}");
            }
        }
    }

    #[test]
    fn poles_exact_and_1e_9_away() {
        // At z = ±1 only m = 0 survives: y_l^0(±z) = √((2l+1)/4π)·(±1)^l (P_l(±1) = (±1)^l).
        let order = Order::new(MAX_ORDER).expect("valid order");
        for sign in [1.0, -1.0] {
            let pole = eval_basis_vec(order, DVec3::new(0.0, 0.0, sign));
            for l in 0..MAX_ORDER as i32 {
                let want = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * sign.powi(l);
                for m in -l..=l {
                    let got = pole[sh_index(l, m)];
                    if m == 0 {
                        assert!(
                            (got - want).abs() < CLOSED_FORM * (l + 1) as f64,
                            "l={l}: {got} vs {want}"
                        );
                    } else {
                        assert_eq!(got, 0.0, "l={l} m={m} at pole {sign}");
                    }
                }
            }
            // 1e-9 away (in angle) the basis is continuous: |Δy| ≤ |∇y|·1e-9, with
            // |∇y_l^m| ≤ l(l+1)·max|y| ~ 900·2.2; allow 1e-5.
            let eps = 1e-9;
            for azimuth in [0.0, 1.0, 2.5, -2.0] {
                let d = DVec3::new(
                    eps * f64::cos(azimuth),
                    eps * f64::sin(azimuth),
                    sign * (1.0 - eps * eps).sqrt(),
                );
                let near = eval_basis_vec(order, d);
                for (i, (a, b)) in near.iter().zip(&pole).enumerate() {
                    assert!(a.is_finite() && (a - b).abs() < 1e-5, "i={i}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn finite_and_bounded_at_order_30() {
        // |y_l^m| ≤ √((2l+1)/4π)·√2 for every real SH (addition theorem).
        let order = Order::new(MAX_ORDER).expect("valid order");
        for d in test_dirs() {
            let y = eval_basis_vec(order, d);
            for l in 0..MAX_ORDER as i32 {
                let bound = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * 2f64.sqrt() + 1e-12;
                for m in -l..=l {
                    let v = y[sh_index(l, m)];
                    assert!(v.is_finite() && v.abs() <= bound, "{d} l={l} m={m}: {v}");
                }
            }
            // Addition theorem: Σ_m y_l^m(ω)² = (2l+1)/4π for every band.
            for l in 0..MAX_ORDER as i32 {
                let sum: f64 = (-l..=l).map(|m| y[sh_index(l, m)].powi(2)).sum();
                let want = (2 * l + 1) as f64 / (4.0 * PI);
                assert!(
                    (sum - want).abs() < 1e-12 * want,
                    "{d} l={l}: {sum} vs {want}"
                );
            }
        }
    }

    #[test]
    fn f32_variant_matches_f64() {
        for order in [Order::THREE, Order::SIX, Order::new(12).expect("valid")] {
            for d in test_dirs() {
                let mut narrow = vec![0.0f32; order.coeff_count()];
                eval_basis_f32(order, d.as_vec3(), &mut narrow);
                let wide = eval_basis_vec(order, d);
                for (a, b) in narrow.iter().zip(&wide) {
                    assert!((*a as f64 - b).abs() < F32_ROUND, "{d}: {a} vs {b}");
                }
            }
        }
    }
}
