//! SH math against values from outside the code (`tests/data/*.csv`, written by
//! `tests/data/make_sh_reference.py` with mpmath/sympy; rerun it with
//! `python3 -m pip install mpmath sympy scipy numpy && python3 tests/data/make_sh_reference.py`)
//! and against identities that need no oracle: orthonormality, rotation invariants,
//! products of band-limited functions, windowing (DESIGN §1, §6; STYLE §8).

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::{DMat3, DQuat, DVec3, Vec3};
use shvis::sh::basis::{eval_basis, eval_basis_f32, eval_basis_vec};
use shvis::sh::product::{gaunt_tensor, product_matrix};
use shvis::sh::project::{eval, exact_quadrature_n, project_fn, sphere_quadrature};
use shvis::sh::rotate::{rotate, rotation_matrices};
use shvis::sh::window::{Taper, Window, apply, deringing_width};
use shvis::sh::{Order, sh_index};

/// Basis vs mpmath (40 digits): the recurrence loses a few ulps per band on O(1) values;
/// DESIGN's target for SH math in f64.
const BASIS_F64: f64 = 1e-12;
/// Basis in f32: the direction is rounded to f32 (relative 6e-8) and |∇y_l^m| ≲ 25 for
/// l ≤ 12, plus one f32 rounding of the value.
const BASIS_F32: f64 = 1e-5;
/// Gaunt coefficients vs sympy's exact values: exact quadrature in f64 on O(1) values.
const GAUNT: f64 = 1e-12;
/// Orthonormality by an exact quadrature at order 13 (169² inner products, 338 nodes).
const ORTHONORMAL: f64 = 1e-12;
/// Band energy before and after rotation: the blocks are orthogonal to ~1e-14 and the
/// energies are O(1).
const ENERGY: f64 = 1e-12;
/// Rotation vs re-projection of f(Rᵀω): both sides exact in exact arithmetic; the
/// quadrature sums a few hundred O(1) terms.
const REPROJECTION: f64 = 1e-10;
/// Composition and identity: products of orthogonal blocks, O(1) coefficients.
const COMPOSITION: f64 = 1e-12;
/// Product matrix vs projected pointwise product (both exact, O(1) values).
const PRODUCT: f64 = 1e-12;
/// Deringed reconstruction checked on a grid other than the one the search used: the
/// search refines minima to 1e-9 rad, so the off-grid minimum is ≥ −(1e-9)²·|f''|.
const DERINGED_MIN: f64 = 1e-12;

fn data_path(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

/// Rows of a CSV file without its `#` comment lines and its header row.
fn csv_rows(name: &str) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(data_path(name))
        .unwrap_or_else(|e| panic!("{name}: {e} (rerun tests/data/make_sh_reference.py)"));
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .skip(1)
        .map(|l| l.split(',').map(|s| s.trim().to_string()).collect())
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|e| panic!("bad number {s:?} in tests/data: {e}"))
}

fn order(n: u32) -> Order {
    Order::new(n).expect("valid order")
}

/// SplitMix64: a seeded, dependency-free generator for test inputs.
struct Rng(u64);

impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [−1, 1).
    fn symmetric(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }

    fn coeffs(&mut self, order: Order) -> Vec<f64> {
        (0..order.coeff_count()).map(|_| self.symmetric()).collect()
    }

    /// A uniformly random rotation (unit quaternion by rejection in the 4-ball).
    fn rotation(&mut self) -> DMat3 {
        loop {
            let q = DQuat::from_xyzw(
                self.symmetric(),
                self.symmetric(),
                self.symmetric(),
                self.symmetric(),
            );
            let len2 = q.length_squared();
            if len2 > 1e-3 && len2 <= 1.0 {
                return DMat3::from_quat(q.normalize());
            }
        }
    }
}

#[test]
fn basis_matches_mpmath_including_poles() {
    let rows = csv_rows("sh_basis_order13.csv");
    let order = order(13);
    assert!(rows.len() >= 26, "{} directions", rows.len());
    let mut poles = 0;
    for row in &rows {
        assert_eq!(row.len(), 3 + 169, "row width");
        let dir = DVec3::new(num(&row[0]), num(&row[1]), num(&row[2]));
        if dir.x == 0.0 && dir.y == 0.0 {
            poles += 1;
        }
        let want: Vec<f64> = row[3..].iter().map(|s| num(s)).collect();
        let got = eval_basis_vec(order, dir);
        let mut narrow = vec![0.0f32; 169];
        eval_basis_f32(order, dir.as_vec3(), &mut narrow);
        for i in 0..169 {
            assert!(
                (got[i] - want[i]).abs() <= BASIS_F64,
                "{dir}: y{i} = {} vs mpmath {}",
                got[i],
                want[i]
            );
            assert!(
                (narrow[i] as f64 - want[i]).abs() <= BASIS_F32,
                "{dir} (f32): y{i} = {} vs mpmath {}",
                narrow[i],
                want[i]
            );
        }
    }
    assert_eq!(poles, 2, "both exact poles are in the file");
}

#[test]
fn basis_f32_entry_point_accepts_f32_directions() {
    // The f32 path normalises in f64; an f32-rounded unit vector must pass.
    let d = Vec3::new(0.6, 0.0, 0.8);
    let mut narrow = vec![0.0f32; 4];
    eval_basis_f32(order(2), d, &mut narrow);
    let k = (3.0 / (4.0 * PI)).sqrt();
    assert!((narrow[3] as f64 + k * 0.6).abs() < BASIS_F32, "{narrow:?}");
}

fn check_gaunt(a: u32, b: u32, c: u32) {
    let mut want: HashMap<(usize, usize, usize), f64> = HashMap::new();
    for row in csv_rows(&format!("gaunt_{a}_{b}_{c}.csv")) {
        let idx = |s: &str| {
            s.parse::<usize>()
                .unwrap_or_else(|e| panic!("bad index {s:?}: {e}"))
        };
        want.insert((idx(&row[0]), idx(&row[1]), idx(&row[2])), num(&row[3]));
    }
    assert!(!want.is_empty());
    let t = gaunt_tensor(order(a), order(b), order(c));
    let (na, nb, nc) = ((a * a) as usize, (b * b) as usize, (c * c) as usize);
    for &(i, j, k) in want.keys() {
        assert!(i < na && j < nb && k < nc, "({i},{j},{k}) out of range");
    }
    // Every entry of the dense tensor: CSV value, or zero where the CSV has none.
    for i in 0..na {
        for j in 0..nb {
            for k in 0..nc {
                let w = want.get(&(i, j, k)).copied().unwrap_or(0.0);
                let g = t.get(i, j, k);
                assert!(
                    (g - w).abs() <= GAUNT,
                    "({a},{b},{c}) T({i},{j},{k}) = {g} vs sympy {w}"
                );
            }
        }
    }
    // The stored entries are the only non-zeros.
    for e in t.entries() {
        let key = (e.i as usize, e.j as usize, e.k as usize);
        if !want.contains_key(&key) {
            assert!(e.value.abs() <= GAUNT, "stored {key:?} = {}", e.value);
        }
    }
}

#[test]
fn gaunt_3_3_6_matches_sympy() {
    check_gaunt(3, 3, 6);
}

#[test]
fn gaunt_4_4_4_matches_sympy() {
    check_gaunt(4, 4, 4);
}

#[test]
fn gaunt_6_3_8_matches_sympy() {
    check_gaunt(6, 3, 8);
}

#[test]
fn orthonormal_to_order_13_by_quadrature() {
    // y_i·y_j has degree ≤ 24; sphere_quadrature(13) is exact to degree 25.
    let order = order(13);
    let nc = order.coeff_count();
    let mut gram = vec![0.0; nc * nc];
    let mut y = vec![0.0; nc];
    for (d, w) in sphere_quadrature(13) {
        eval_basis(order, d, &mut y);
        for i in 0..nc {
            for j in i..nc {
                gram[i * nc + j] += w * y[i] * y[j];
            }
        }
    }
    for i in 0..nc {
        for j in i..nc {
            let want = if i == j { 1.0 } else { 0.0 };
            let got = gram[i * nc + j];
            assert!((got - want).abs() <= ORTHONORMAL, "<y{i}, y{j}> = {got}");
        }
    }
}

fn band_energies(c: &[f64], order: Order) -> Vec<f64> {
    (0..order.get() as i32)
        .map(|l| (-l..=l).map(|m| c[sh_index(l, m)].powi(2)).sum())
        .collect()
}

#[test]
fn rotation_preserves_band_energy_orders_6_and_12() {
    let mut rng = Rng(6012);
    for n in [6, 12] {
        let order = order(n);
        for _ in 0..8 {
            let c = rng.coeffs(order);
            let r = rng.rotation();
            let before = band_energies(&c, order);
            let after = band_energies(&rotate(&c, order, r), order);
            for (l, (a, b)) in before.iter().zip(&after).enumerate() {
                assert!((a - b).abs() <= ENERGY, "order {n} band {l}: {a} -> {b}");
            }
        }
    }
}

#[test]
fn rotation_matches_reprojection_of_rotated_function() {
    // g(ω) = f(Rᵀω) is band-limited like f, so the projection is exact.
    let mut rng = Rng(77);
    for n in [6, 12] {
        let order = order(n);
        for _ in 0..3 {
            let c = rng.coeffs(order);
            let r = rng.rotation();
            let got = rotate(&c, order, r);
            let rt = r.transpose();
            let want = project_fn(
                order,
                |w| eval(&c, order, rt * w),
                exact_quadrature_n(order, n - 1),
            );
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    (g - w).abs() <= REPROJECTION,
                    "order {n} i={i}: rotated {g} vs re-projected {w}"
                );
            }
        }
    }
}

#[test]
fn rotations_compose_and_identity_is_identity() {
    let mut rng = Rng(4242);
    let order = order(12);
    for _ in 0..4 {
        let c = rng.coeffs(order);
        let (r1, r2) = (rng.rotation(), rng.rotation());
        let twice = rotate(&rotate(&c, order, r1), order, r2);
        let once = rotate(&c, order, r2 * r1);
        for (i, (a, b)) in twice.iter().zip(&once).enumerate() {
            assert!(
                (a - b).abs() <= COMPOSITION,
                "i={i}: R1 then R2 {a} vs R2·R1 {b}"
            );
        }
        let same = rotate(&c, order, DMat3::IDENTITY);
        for (i, (a, b)) in same.iter().zip(&c).enumerate() {
            assert!(
                (a - b).abs() <= COMPOSITION,
                "i={i}: identity gave {a}, not {b}"
            );
        }
    }
}

#[test]
fn rotated_zonal_matches_addition_theorem_at_order_30() {
    // y_l^0(Rᵀω) = √(4π/(2l+1)) Σ_m y_l^m(R ẑ) y_l^m(ω): the rotation blocks' column m=0
    // must equal the basis at R ẑ — the recurrence against the basis at order 30.
    let order = order(30);
    let mut rng = Rng(30);
    for _ in 0..3 {
        let r = rng.rotation();
        let y = eval_basis_vec(order, (r * DVec3::Z).normalize());
        for band in rotation_matrices(order, r) {
            let l = band.l() as i32;
            let scale = (4.0 * PI / (2 * l + 1) as f64).sqrt();
            for m in -l..=l {
                let want = scale * y[sh_index(l, m)];
                let got = band.get(m, 0);
                assert!(
                    (got - want).abs() <= COMPOSITION,
                    "l={l} m={m}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn product_matrix_equals_projection_of_pointwise_product() {
    // f, g of order 3 ⇒ f·g has bands ≤ 4, held exactly by order 5.
    let (fo, go, out) = (order(3), order(3), order(5));
    let mut rng = Rng(335);
    for _ in 0..4 {
        let f = rng.coeffs(fo);
        let g = rng.coeffs(go);
        let got = product_matrix(&f, fo, go, out).mul_vec(&g);
        let want = project_fn(
            out,
            |w| eval(&f, fo, w) * eval(&g, go, w),
            exact_quadrature_n(out, 4),
        );
        for (k, (a, b)) in got.iter().zip(&want).enumerate() {
            assert!(
                (a - b).abs() <= PRODUCT,
                "k={k}: matrix {a} vs projection {b}"
            );
        }
    }
}

#[test]
fn window_none_is_identity_and_hanning_zeroes_high_bands() {
    let order = order(8);
    let c = Rng(8).coeffs(order);
    let mut same = c.clone();
    apply(Window::None, &mut same, order);
    assert_eq!(same, c);
    let w = 3.0;
    let mut h = c.clone();
    apply(Window::Hanning { w }, &mut h, order);
    assert_eq!(h[0], c[0], "the mean is kept");
    for l in 0..8 {
        for m in -l..=l {
            let i = sh_index(l, m);
            if l as f64 >= w {
                assert_eq!(h[i], 0.0, "band {l} > w survived");
            } else {
                assert!(h[i].abs() <= c[i].abs(), "band {l} grew");
            }
        }
    }
}

/// Golden-angle spiral: well-spread directions unrelated to the quadrature grids.
fn spiral(n: usize) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let phi = i as f64 * PI * (3.0 - 5f64.sqrt());
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

#[test]
fn deringing_makes_a_ringing_step_non_negative() {
    // A hemisphere step about a tilted axis (visibility of a half-space; a clamped
    // cosine with the cosine replaced by 1), projected to order 8 by a fine quadrature.
    let order = order(8);
    let axis = DVec3::new(0.3, -0.4, 0.866).normalize();
    let step = |w: DVec3| if w.dot(axis) > 0.0 { 1.0 } else { 0.0 };
    let c = project_fn(order, step, 256);
    let check = spiral(20_000);
    let min_of = |c: &[f64]| {
        check
            .iter()
            .map(|d| eval(c, order, *d))
            .fold(f64::INFINITY, f64::min)
    };
    let raw_min = min_of(&c);
    assert!(
        raw_min < -0.01,
        "the unwindowed step should ring negative: {raw_min}"
    );
    for taper in [Taper::Hanning, Taper::Lanczos] {
        let width = deringing_width(taper, &c, order).expect("a window is needed");
        let mut d = c.clone();
        apply(Window::Deringing { taper }, &mut d, order);
        let deringed_min = min_of(&d);
        assert!(
            deringed_min >= -DERINGED_MIN,
            "{taper:?} w={width}: min {deringed_min}"
        );
        // Gentle, not the mean only: band 1 keeps most of its energy.
        let kept = taper.sigma(1, width);
        assert!(kept > 0.5 && width > 2.0, "{taper:?} w={width} σ_1={kept}");
    }
}
