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

/// The mirror rules of `bake::lxh::mirror` against the basis itself: y_k(g·d) equals
/// sign(class(k), g) · y_k(d) at scattered directions, for every mirror and band to l = 7.
#[test]
fn mirror_parity_rules_match_the_basis() {
    use shvis::bake::lxh::{mirror, parity_class};
    use shvis::sh::basis::eval_basis;
    let order = Order::new(8).unwrap();
    let (mut a, mut b) = (vec![0.0; 64], vec![0.0; 64]);
    for s in 0..50 {
        let t = s as f64 * 0.7 + 0.1;
        let d = DVec3::new(
            t.sin() * (2.0 * t).cos(),
            t.cos(),
            t.sin() * (2.0 * t).sin(),
        )
        .normalize();
        eval_basis(order, d, &mut a);
        for g in 1..8u32 {
            eval_basis(order, mirror(g, d), &mut b);
            for l in 0..8u32 {
                for m in -(l as i32)..=(l as i32) {
                    let k = (l as i32 * (l as i32 + 1) + m) as usize;
                    let sign = if (parity_class(l, m) & g).count_ones().is_multiple_of(2) {
                        1.0
                    } else {
                        -1.0
                    };
                    assert!((b[k] - sign * a[k]).abs() < 1e-12, "l {l} m {m} mirror {g}");
                }
            }
        }
    }
    // The hemispheres of the tables split in y: there the coefficients with m < 0 flip.
    for l in 0..8u32 {
        for m in -(l as i32)..=(l as i32) {
            assert_eq!(parity_class(l, m) & 2 != 0, m < 0, "l {l} m {m}");
        }
    }
}

/// The symmetric build (§3.3) equals the per-normal evaluation to 1e-12 for visibility
/// orders 3, 4 and 6 on both tables' parameterizations, and nearly every texel shares an
/// orbit.
#[test]
fn symmetric_build_equals_the_direct_one() {
    use shvis::bake::lxh::SymmetricBuild;
    use shvis::sphere::{Parameterization, SphereMap};
    for v_order in [Order::THREE, Order::FOUR, Order::SIX] {
        let l_order = Order::new(v_order.get() + 2).unwrap();
        let l = coeffs(l_order, 7);
        let rgb: Vec<[f64; 3]> = l.iter().map(|&x| [x, -0.25 * x, 2.0 * x]).collect();
        for h_order in [Order::THREE, Order::new(5).unwrap()] {
            let m = LxhMatrices::new(&rgb, v_order, h_order);
            for kind in [Parameterization::DualParaboloid, Parameterization::CubeDx10] {
                for res in [7, 16, 32] {
                    let map = SphereMap::new(kind, res).unwrap();
                    let build = SymmetricBuild::new(map);
                    let (shared, singles) = build.coverage();
                    eprintln!(
                        "{kind} {res}: {} orbits, {shared} texels from orbits, {singles} singles",
                        build.orbit_count()
                    );
                    assert_eq!(shared + singles, map.sample_count());
                    assert!(
                        singles * 50 <= map.sample_count(),
                        "{kind} {res}: {singles} singles"
                    );
                    let table = build.build_f64(&m);
                    let n2 = v_order.coeff_count();
                    let mut worst = 0.0f64;
                    for face in 0..kind.face_count() {
                        for j in 0..res {
                            for i in 0..res {
                                let t = map.texel_index(face, i, j);
                                let want = m.eval(map.texel_center_dir(face, i, j));
                                for (jj, w) in want.iter().enumerate() {
                                    for c in 0..3 {
                                        let got = table[(t * n2 + jj) * 3 + c];
                                        worst = worst.max((got - w[c]).abs());
                                    }
                                }
                            }
                        }
                    }
                    assert!(
                        worst < 1e-12,
                        "order {v_order} h {h_order} {kind} {res}: {worst:e}"
                    );
                }
            }
        }
    }
}

/// Tables are linear in the lighting (§3.3: blend tables or blend lighting): the table of
/// (1 − t)·L_a + t·L_b equals the same blend of the two tables, in f64, to 1e-12.
#[test]
fn table_of_blended_lighting_is_the_blend_of_the_tables() {
    use shvis::bake::lxh::SymmetricBuild;
    use shvis::env::schedule::blend;
    use shvis::sphere::{Parameterization, SphereMap};
    let l_order = Order::new(8).unwrap();
    let a: Vec<[f64; 3]> = coeffs(l_order, 11)
        .iter()
        .map(|&x| [x, 0.3 * x, -x])
        .collect();
    let b: Vec<[f64; 3]> = coeffs(l_order, 12)
        .iter()
        .map(|&x| [-x, x, 0.5 * x])
        .collect();
    for kind in [Parameterization::DualParaboloid, Parameterization::CubeDx10] {
        let build = SymmetricBuild::new(SphereMap::new(kind, 16).unwrap());
        for t in [0.0, 0.25, 0.7, 1.0] {
            let table =
                |l: &[[f64; 3]]| build.build_f64(&LxhMatrices::new(l, Order::SIX, Order::THREE));
            let of_blend = table(&blend(&a, &b, t));
            let (ta, tb) = (table(&a), table(&b));
            let worst = of_blend
                .iter()
                .zip(ta.iter().zip(&tb))
                .map(|(x, (p, q))| (x - ((1.0 - t) * p + t * q)).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-12, "{kind} t {t}: {worst:e}");
        }
    }
}
