//! L×H tables (`bake::lxh`, Iwanicki–Sloan §3.3) against independent integrals.

use glam::DVec3;
use shvis::bake::lxh::LxhMatrices;
use shvis::sh::Order;
use shvis::sh::project::{eval, sphere_quadrature};
use shvis::sh::zonal::{clamped_cosine_convolution, eval_rgb, irradiance_from_radiance};

/// Sums of a few hundred products of O(1) terms in f64.
const EXACT: f64 = 1e-11;

/// Deterministic pseudo-random coefficients in [−1, 1], decaying with the band.
fn coeffs(order: Order, salt: u64) -> Vec<f64> {
    (0..order.coeff_count())
        .map(|i| {
            let mut z = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt;
            z ^= z >> 29;
            z = z.wrapping_mul(0xBF58_476D_1CE4_E5B9);
            let l = (i as f64).sqrt().floor();
            ((z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) / (1.0 + l)
        })
        .collect()
}

#[test]
fn table_equals_the_triple_integral_with_truncated_clamped_cosine() {
    // With L band-limited to O+2, V to O and H truncated to `h_order`, Σ_j V_j (L×H_n)_j is
    // exactly ∫ L V H_trunc dω: check against a quadrature that is exact for the product.
    for (v_order, h_order) in [
        (Order::THREE, Order::THREE),
        (Order::SIX, Order::THREE),
        (Order::SIX, Order::new(5).unwrap()),
    ] {
        let l_order = Order::new(v_order.get() + 2).unwrap();
        let l = coeffs(l_order, 1);
        let v = coeffs(v_order, 2);
        let rgb: Vec<[f64; 3]> = l.iter().map(|&x| [x, 0.5 * x, -x]).collect();
        let m = LxhMatrices::new(&rgb, v_order, h_order);
        let degree = l_order.get() + v_order.get() + h_order.get();
        let quad = sphere_quadrature(degree as usize);
        for n in [
            DVec3::Y,
            DVec3::new(0.3, -0.5, 0.81).normalize(),
            DVec3::NEG_Z,
        ] {
            // H truncated: h_lm(n) = A_l y_lm(n) (zonal rotation of the clamped cosine).
            let mut h = shvis::sh::basis::eval_basis_vec(h_order, n);
            for (i, hk) in h.iter_mut().enumerate() {
                *hk *= clamped_cosine_convolution((i as f64).sqrt().floor() as u32);
            }
            let exact: f64 = quad
                .iter()
                .map(|&(d, w)| {
                    w * eval(&l, l_order, d) * eval(&v, v_order, d) * eval(&h, h_order, d)
                })
                .sum();
            let table = m.shade(n, &v);
            assert!(
                (table[0] - exact).abs() < EXACT,
                "{v_order}/{h_order} at {n}: {} vs {exact}",
                table[0]
            );
            assert!((table[1] - 0.5 * exact).abs() < EXACT);
            assert!((table[2] + exact).abs() < EXACT);
        }
    }
}

#[test]
fn unoccluded_visibility_gives_sh_irradiance() {
    // V ≡ 1 (V_0 = √4π): the table reproduces order-3 SH irradiance E(n) (§3.3 with H of order 3).
    let l_order = Order::new(8).unwrap();
    let rgb: Vec<[f64; 3]> = coeffs(l_order, 3).iter().map(|&x| [x, x, x]).collect();
    let m = LxhMatrices::new(&rgb, Order::SIX, Order::THREE);
    let mut v = vec![0.0; 36];
    v[0] = (4.0 * std::f64::consts::PI).sqrt();
    let e = irradiance_from_radiance(&rgb[..9], Order::THREE);
    for n in [DVec3::X, DVec3::new(-0.2, 0.9, 0.4).normalize()] {
        let want = eval_rgb(&e, Order::THREE, n);
        let got = m.shade(n, &v);
        assert!((got[0] - want[0]).abs() < EXACT, "{got:?} vs {want:?}");
    }
}
