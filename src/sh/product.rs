//! SH products: the real triple-product (Gaunt) tensor and the product matrix of
//! Iwanicki–Sloan §3.3 (DESIGN §2, the L×H tables and `sh2`).
//!
//! # Math
//!
//! For real SH (convention of [`crate::sh`], DESIGN §1) the tensor
//!
//! ```text
//! T(i, j, k) = ∫ y_i(ω) y_j(ω) y_k(ω) dω
//! ```
//!
//! projects products: if f = Σ f_i y_i and g = Σ g_j y_j, the coefficients of f·g are
//! (f·g)_k = Σ_ij f_i g_j T(i, j, k) (Iwanicki–Sloan §2.1 and eq. (4): "the SH product of
//! two of the three terms, followed by a dot product with the third"; Ng et al. 2004,
//! Sloan 2008 "Stupid SH Tricks" §Products). Fixing f gives the *product matrix*
//! M(k, j) = Σ_i f_i T(i, j, k), so that (f·g) projected to the output order is M·g; the
//! paper's §3.3 builds its L×H tables by scaling the rows of L's product matrix.
//!
//! Selection rules: T(i, j, k) = 0 unless |l₁−l₂| ≤ l₃ ≤ l₁+l₂, l₁+l₂+l₃ is even,
//! |m₃| ∈ {|m₁|+|m₂|, ||m₁|−|m₂||} and an even number of the m are negative. Only the
//! entries these rules allow are computed and stored (a few percent of the dense tensor).
//!
//! # Exact evaluation (no brute-force quadrature)
//!
//! With z = cos θ, y_l^m(ω) = y_l^{|m|}(z, φ=0) · c_m(φ) where c_m = cos(mφ) for m > 0,
//! sin(|m|φ) for m < 0 and 1 for m = 0 (eq. (3): the √2 and P_l^{|m|} sit in the φ = 0
//! value). The integral separates:
//!
//! ```text
//! T = Z · F,   Z = ∫₋₁¹ Π_k y_{l_k}^{|m_k|}(z, 0) dz,   F = ∫₀^{2π} Π_k c_{m_k}(φ) dφ
//! ```
//!
//! F is computed in closed form by expanding each c_m into e^{±i|m|φ} terms with
//! coefficients ½ and ∓i/2 (exact in binary): F = 2π × the sum of the coefficient
//! products whose exponents cancel, so the m-rules give exact zeros. When F ≠ 0 the
//! |m_k| sum to an even number, so the z-integrand is a polynomial of degree
//! ≤ l₁+l₂+l₃ (the sinᵐθ factors pair into powers of 1−z²); Gauss–Legendre with
//! ⌈(L+1)/2⌉ nodes, L the largest band sum, integrates it exactly. The φ = 0 values come
//! from [`eval_basis`], stable to order 30, so entries are accurate to ~1e-15.
//! A handful of allowed entries vanish by accident (zeros of 3j symbols); they are
//! stored with values of order 1e-17.
//!
//! [`product_matrix`] keeps one tensor per order triple in a process-wide cache, so
//! building the §3.3 matrix for visibility order 6 and clamped-cosine order 3 (L of
//! order 8: tensor (8, 6, 3), 920 entries) is a sparse contraction of 920 multiply-adds,
//! about 2 µs. Building a tensor costs ~0.3 ms for (8, 6, 3), ~4 ms for (8, 8, 8) and
//! ~0.2 s for (16, 16, 16) (unoptimised test profile).
//!
//! Tests: here (T(0, j, k) = δ_jk/√(4π), symmetry, the product of band-limited
//! functions) and `tests/sh_oracle.rs` (tensors (3,3,6), (4,4,4), (6,3,8) against
//! sympy's exact Gaunt coefficients to 1e-12; product matrix against the projected
//! pointwise product).

use std::collections::HashMap;
use std::sync::{Arc, OnceLock, RwLock};

use glam::DVec3;

use super::basis::eval_basis;
use super::{Order, gauss_legendre, sh_index};

/// One stored entry T(i, j, k) of a [`GauntTensor`] (flat indices l(l+1)+m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GauntEntry {
    /// Index into the first factor (i < a²).
    pub i: u32,
    /// Index into the second factor (j < b²).
    pub j: u32,
    /// Index into the product (k < c²).
    pub k: u32,
    /// ∫ y_i y_j y_k dω.
    pub value: f64,
}

/// The real Gaunt tensor T(i, j, k) = ∫ y_i y_j y_k dω for i < a², j < b², k < c², stored
/// sparsely: only the entries the selection rules allow (module doc), sorted by
/// (i, j, k). Every entry not stored is exactly zero.
#[derive(Clone, Debug)]
pub struct GauntTensor {
    orders: (Order, Order, Order),
    entries: Vec<GauntEntry>,
}

/// A dense row-major matrix of f64 (the product matrix of Iwanicki–Sloan §3.3).
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl Matrix {
    /// A `rows` × `cols` matrix of zeros.
    pub fn zeros(rows: usize, cols: usize) -> Matrix {
        Matrix {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// Wraps row-major `data`.
    ///
    /// # Panics
    /// If `data.len() != rows * cols`.
    pub fn from_row_major(rows: usize, cols: usize, data: Vec<f64>) -> Matrix {
        assert_eq!(
            data.len(),
            rows * cols,
            "{rows}×{cols} matrix from {} values",
            data.len()
        );
        Matrix { rows, cols, data }
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The row-major values, `rows * cols` of them.
    pub fn as_slice(&self) -> &[f64] {
        &self.data
    }

    /// Row `r` as a slice of `cols` values.
    ///
    /// # Panics
    /// If `r >= rows`.
    pub fn row(&self, r: usize) -> &[f64] {
        &self.data[r * self.cols..(r + 1) * self.cols]
    }

    /// Mutable row `r` (e.g. to scale the rows by clamped-cosine coefficients, §3.3).
    ///
    /// # Panics
    /// If `r >= rows`.
    pub fn row_mut(&mut self, r: usize) -> &mut [f64] {
        &mut self.data[r * self.cols..(r + 1) * self.cols]
    }

    /// Entry (r, c).
    ///
    /// # Panics
    /// If `r >= rows` or `c >= cols`.
    pub fn get(&self, r: usize, c: usize) -> f64 {
        assert!(c < self.cols, "column {c} of a {}-column matrix", self.cols);
        self.data[r * self.cols + c]
    }

    /// M·v, `rows` values.
    ///
    /// # Panics
    /// If `v.len() != cols`.
    pub fn mul_vec(&self, v: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.rows];
        self.mul_vec_into(v, &mut out);
        out
    }

    /// M·v written to `out` (no allocation).
    ///
    /// # Panics
    /// If `v.len() != cols` or `out.len() != rows`.
    pub fn mul_vec_into(&self, v: &[f64], out: &mut [f64]) {
        assert_eq!(
            v.len(),
            self.cols,
            "vector of {} for {} columns",
            v.len(),
            self.cols
        );
        assert_eq!(
            out.len(),
            self.rows,
            "output of {} for {} rows",
            out.len(),
            self.rows
        );
        for (o, row) in out.iter_mut().zip(self.data.chunks_exact(self.cols.max(1))) {
            *o = row.iter().zip(v).map(|(a, b)| a * b).sum();
        }
    }
}

impl GauntTensor {
    /// The orders (a, b, c) of the three factors.
    pub fn orders(&self) -> (Order, Order, Order) {
        self.orders
    }

    /// The stored entries, sorted by (i, j, k).
    pub fn entries(&self) -> &[GauntEntry] {
        &self.entries
    }

    /// Number of stored entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no entry is stored (never the case: T(0, 0, 0) = 1/√(4π)).
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// T(i, j, k); 0.0 for every entry not stored, including indices out of range.
    pub fn get(&self, i: usize, j: usize, k: usize) -> f64 {
        let key = (i as u64, j as u64, k as u64);
        self.entries
            .binary_search_by(|e| (e.i as u64, e.j as u64, e.k as u64).cmp(&key))
            .map_or(0.0, |p| self.entries[p].value)
    }

    /// Product matrix M(k, j) = Σ_i f_i T(i, j, k): c² rows, b² columns, so that the
    /// coefficients of f·g truncated to order c are M·g (Iwanicki–Sloan §3.3).
    ///
    /// # Panics
    /// If `f` holds fewer than a² values.
    pub fn product_matrix(&self, f: &[f64]) -> Matrix {
        let (a, b, c) = self.orders;
        assert!(
            f.len() >= a.coeff_count(),
            "{} coefficients given, order {a} needs {}",
            f.len(),
            a.coeff_count()
        );
        let cols = b.coeff_count();
        let mut m = Matrix::zeros(c.coeff_count(), cols);
        for e in &self.entries {
            m.data[e.k as usize * cols + e.j as usize] += f[e.i as usize] * e.value;
        }
        m
    }

    /// Coefficients (f·g)_k = Σ_ij f_i g_j T(i, j, k) for k < c², without forming the
    /// matrix.
    ///
    /// # Panics
    /// If `f` holds fewer than a² or `g` fewer than b² values.
    pub fn product(&self, f: &[f64], g: &[f64]) -> Vec<f64> {
        let (a, b, c) = self.orders;
        assert!(
            f.len() >= a.coeff_count() && g.len() >= b.coeff_count(),
            "{} and {} coefficients given, orders {a} and {b} need {} and {}",
            f.len(),
            g.len(),
            a.coeff_count(),
            b.coeff_count()
        );
        let mut out = vec![0.0; c.coeff_count()];
        for e in &self.entries {
            out[e.k as usize] += f[e.i as usize] * g[e.j as usize] * e.value;
        }
        out
    }
}

/// The Gaunt tensor T(i, j, k) = ∫ y_i y_j y_k dω for i < a², j < b², k < c², computed
/// exactly (module doc) and stored sparsely. Cost grows like the number of allowed
/// entries times ⌈(a+b+c−2)/2⌉ nodes (timings in the module doc); use
/// [`cached_gaunt_tensor`] to build each once.
pub fn gaunt_tensor(a: Order, b: Order, c: Order) -> GauntTensor {
    let max_order = a.max(b).max(c);
    let band_sum = (a.get() + b.get() + c.get() - 3) as usize;
    // n nodes are exact to degree 2n − 1 ≥ band_sum.
    let (zs, ws) = gauss_legendre((band_sum + 1).div_ceil(2));
    // y_l^{m≥0} at φ = 0 for every node: node-major table.
    let nc = max_order.coeff_count();
    let mut at_node = vec![0.0; zs.len() * nc];
    for (t, z) in zs.iter().enumerate() {
        let s = (1.0 - z * z).max(0.0).sqrt();
        eval_basis(
            max_order,
            DVec3::new(s, 0.0, *z),
            &mut at_node[t * nc..(t + 1) * nc],
        );
    }
    let z_integral = |p: usize, q: usize, r: usize| -> f64 {
        ws.iter()
            .enumerate()
            .map(|(t, w)| {
                let y = &at_node[t * nc..(t + 1) * nc];
                w * y[p] * y[q] * y[r]
            })
            .sum()
    };

    let mut entries = Vec::new();
    for l1 in 0..a.get() as i32 {
        for m1 in -l1..=l1 {
            for l2 in 0..b.get() as i32 {
                for m2 in -l2..=l2 {
                    let l3_max = (l1 + l2).min(c.get() as i32 - 1);
                    for l3 in ((l1 - l2).abs()..=l3_max).step_by(2) {
                        for m3 in candidate_m3(m1, m2, l3) {
                            let f = azimuth_integral(m1, m2, m3);
                            if f == 0.0 {
                                continue;
                            }
                            let z = z_integral(
                                sh_index(l1, m1.abs()),
                                sh_index(l2, m2.abs()),
                                sh_index(l3, m3.abs()),
                            );
                            entries.push(GauntEntry {
                                i: sh_index(l1, m1) as u32,
                                j: sh_index(l2, m2) as u32,
                                k: sh_index(l3, m3) as u32,
                                value: z * f,
                            });
                        }
                    }
                }
            }
        }
    }
    entries.sort_by_key(|e| (e.i, e.j, e.k));
    GauntTensor {
        orders: (a, b, c),
        entries,
    }
}

/// The m₃ with |m₃| ∈ {|m₁|+|m₂|, ||m₁|−|m₂||}, |m₃| ≤ l₃, both signs; the sign rule is
/// left to [`azimuth_integral`], which returns an exact 0.0 where it fails.
fn candidate_m3(m1: i32, m2: i32, l3: i32) -> impl Iterator<Item = i32> {
    let (a1, a2) = (m1.abs(), m2.abs());
    let (sum, diff) = (a1 + a2, (a1 - a2).abs());
    // When m₁ or m₂ is 0, sum = diff: list it once.
    let distinct = if diff == sum { None } else { Some(diff) };
    [Some(sum), distinct]
        .into_iter()
        .flatten()
        .filter(move |a3| *a3 <= l3)
        .flat_map(|a3| if a3 == 0 { vec![0] } else { vec![a3, -a3] })
}

/// F = ∫₀^{2π} c_{m₁} c_{m₂} c_{m₃} dφ with c_m = cos(mφ) (m > 0), sin(|m|φ) (m < 0),
/// 1 (m = 0), by expanding into e^{±i|m|φ} (module doc). Exact zeros where the m-rules
/// forbid; otherwise 2π times a multiple of 1/8.
fn azimuth_integral(m1: i32, m2: i32, m3: i32) -> f64 {
    // Terms (exponent, coefficient re, coefficient im) of one factor.
    fn terms(m: i32) -> [(i32, f64, f64); 2] {
        let a = m.abs();
        match m.signum() {
            0 => [(0, 1.0, 0.0), (0, 0.0, 0.0)],
            1 => [(a, 0.5, 0.0), (-a, 0.5, 0.0)],
            _ => [(a, 0.0, -0.5), (-a, 0.0, 0.5)], // sin = (e^{ia} − e^{−ia})/(2i)
        }
    }
    let (mut re, mut im) = (0.0, 0.0);
    for (e1, r1, i1) in terms(m1) {
        for (e2, r2, i2) in terms(m2) {
            for (e3, r3, i3) in terms(m3) {
                if e1 + e2 + e3 != 0 {
                    continue;
                }
                let (pr, pi) = (r1 * r2 - i1 * i2, r1 * i2 + i1 * r2);
                re += pr * r3 - pi * i3;
                im += pr * i3 + pi * r3;
            }
        }
    }
    debug_assert_eq!(im, 0.0, "azimuthal integral of a real product is real");
    2.0 * std::f64::consts::PI * re
}

/// The tensor for (a, b, c) from a process-wide cache, computed on first use.
pub fn cached_gaunt_tensor(a: Order, b: Order, c: Order) -> Arc<GauntTensor> {
    type Cache = RwLock<HashMap<(Order, Order, Order), Arc<GauntTensor>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let key = (a, b, c);
    // A poisoned lock only means another thread panicked mid-insert; the map is still valid.
    if let Some(t) = cache.read().unwrap_or_else(|e| e.into_inner()).get(&key) {
        return t.clone();
    }
    let tensor = Arc::new(gaunt_tensor(a, b, c));
    cache
        .write()
        .unwrap_or_else(|e| e.into_inner())
        .entry(key)
        .or_insert(tensor)
        .clone()
}

/// The product matrix of Iwanicki–Sloan §3.3: M (out_order² rows × g_order² columns)
/// with M(k, j) = Σ_i f_i T(i, j, k), so that (f·g) projected to `out_order` is M·g for
/// any g of order `g_order`. Exact when out_order ≥ f_order + g_order − 1. The tensor
/// comes from [`cached_gaunt_tensor`].
///
/// # Panics
/// If `f` holds fewer than `f_order.coeff_count()` values.
pub fn product_matrix(f: &[f64], f_order: Order, g_order: Order, out_order: Order) -> Matrix {
    cached_gaunt_tensor(f_order, g_order, out_order).product_matrix(f)
}

/// Coefficients of f·g projected to `out_order` (Σ_ij f_i g_j T(i, j, k)), through the
/// cached tensor.
///
/// # Panics
/// If `f` or `g` holds fewer coefficients than its order needs.
pub fn product(f: &[f64], f_order: Order, g: &[f64], g_order: Order, out_order: Order) -> Vec<f64> {
    cached_gaunt_tensor(f_order, g_order, out_order).product(f, g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::project::{eval, exact_quadrature_n, project_fn};
    use std::f64::consts::PI;

    /// Exact rules (Gauss–Legendre, closed-form φ integrals) on O(1) values.
    const EXACT: f64 = 1e-13;

    fn order(n: u32) -> Order {
        Order::new(n).expect("valid order")
    }

    #[test]
    fn first_index_zero_is_identity_over_sqrt_4_pi() {
        // y_0^0 = 1/√(4π) ⇒ T(0, j, k) = δ_jk / √(4π).
        let t = gaunt_tensor(order(1), order(5), order(5));
        for j in 0..25 {
            for k in 0..25 {
                let want = if j == k { 1.0 / (4.0 * PI).sqrt() } else { 0.0 };
                assert!((t.get(0, j, k) - want).abs() < EXACT, "T(0,{j},{k})");
            }
        }
    }

    #[test]
    fn symmetric_and_sparse() {
        let t = gaunt_tensor(order(4), order(4), order(4));
        for e in t.entries() {
            let (i, j, k) = (e.i as usize, e.j as usize, e.k as usize);
            for (p, q, r) in [(j, i, k), (k, j, i), (i, k, j)] {
                assert!((t.get(p, q, r) - e.value).abs() < EXACT, "({i},{j},{k})");
            }
        }
        assert!(t.len() < 16 * 16 * 16 / 5, "{} entries stored", t.len());
        assert_eq!(t.get(16, 0, 0), 0.0);
    }

    #[test]
    fn azimuth_integral_closed_forms() {
        let two_pi = 2.0 * PI;
        assert_eq!(azimuth_integral(0, 0, 0), two_pi);
        assert_eq!(azimuth_integral(1, 1, 0), PI); // ∫cos² = π
        assert_eq!(azimuth_integral(-2, -2, 0), PI); // ∫sin² = π
        assert_eq!(azimuth_integral(1, -1, 0), 0.0);
        assert_eq!(azimuth_integral(1, 2, 3), PI / 2.0); // ∫cos φ cos 2φ cos 3φ
        assert_eq!(azimuth_integral(-1, -2, 3), -PI / 2.0); // ∫sin φ sin 2φ cos 3φ
        assert_eq!(azimuth_integral(-1, 2, -3), PI / 2.0);
        assert_eq!(azimuth_integral(-1, -2, -3), 0.0); // odd in φ
    }

    #[test]
    fn product_matrix_projects_pointwise_product() {
        // f, g of order 3: f·g has bands ≤ 4, so order 5 holds it exactly.
        let (fo, go, out) = (order(3), order(3), order(5));
        let f: Vec<f64> = (0..9).map(|i| (i as f64 * 0.7).sin()).collect();
        let g: Vec<f64> = (0..9).map(|i| (i as f64 * 1.3 + 0.2).cos()).collect();
        let m = product_matrix(&f, fo, go, out);
        assert_eq!((m.rows(), m.cols()), (25, 9));
        let got = m.mul_vec(&g);
        let want = project_fn(
            out,
            |d| eval(&f, fo, d) * eval(&g, go, d),
            exact_quadrature_n(out, 4),
        );
        for (k, (a, b)) in got.iter().zip(&want).enumerate() {
            assert!((a - b).abs() < EXACT, "k={k}: {a} vs {b}");
        }
        let direct = product(&f, fo, &g, go, out);
        for (a, b) in got.iter().zip(&direct) {
            assert!((a - b).abs() < EXACT);
        }
    }
}
