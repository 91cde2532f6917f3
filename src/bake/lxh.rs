//! L×H lookup tables (Iwanicki–Sloan §3.2–3.3, DESIGN §2 `unc*`).
//!
//! For a lighting environment L and a surface normal n, the table stores the SH coefficients
//! (order O, the visibility order) of the product L·H_n, H_n(ω) = max(0, n·ω), so that the
//! shader evaluates eq. (4) as one dot product with the texel's visibility V:
//!
//! ```text
//! I(n) = ∫ L V H_n dω ≈ Σ_j V_j (L×H_n)_j,   (L×H_n)_j = Σ_k M_kj h_k(n)
//! ```
//!
//! M is the *product matrix* of §3.3 (`sh::product`): M_kj = Σ_i L_i ∫ y_i y_j y_k dω with
//! L projected to order O+2 (enough for the product with an order-3 H to be exact in the
//! bands the dot product reads), rows k over the clamped cosine's bands (order `h_order`,
//! 3 in the paper) and columns j over V's bands. h_k(n) are the coefficients of the clamped
//! cosine rotated to n: h_lm(n) = A_l y_lm(n), A_l = √(4π/(2l+1)) z_l (`sh::zonal`).
//! "Scaling the rows of the product matrix by the clamped-cosine coefficients oriented along
//! each table normal" (§3.3) is exactly Σ_k M_kj h_k(n). Truncating H to order 3 is a
//! measurable error (its odd bands ≥ 3 vanish, band 4 is the first dropped), so `h_order`
//! is a parameter.
//!
//! Cost per normal: h² basis values and h²·O²·3 multiply-adds (order 6, h 3: 972); a
//! 2×32² dual-paraboloid table (2048 normals) is ≈ 2 M multiply-adds, under a millisecond on
//! one core. Tests: `tests/lxh.rs` (DC visibility reproduces SH irradiance; against direct
//! quadrature of ∫ L V H for band-limited L and V).

use glam::DVec3;

use crate::sh::Order;
use crate::sh::basis::eval_basis;
use crate::sh::product::{Matrix, cached_gaunt_tensor};
use crate::sh::zonal::clamped_cosine_convolution;
use crate::sphere::SphereMap;

/// The per-lighting part of an L×H table: one product matrix per colour channel.
#[derive(Clone, Debug)]
pub struct LxhMatrices {
    pub v_order: Order,
    pub h_order: Order,
    /// M per colour (R, G, B): h² rows × O² columns.
    pub per_channel: [Matrix; 3],
    /// A_l y_lm scaling per row k (the clamped-cosine factor of band l(k)).
    row_factor: Vec<f64>,
}

impl LxhMatrices {
    /// Builds the matrices from RGB radiance SH of at least order `v_order + 2`.
    ///
    /// # Panics
    /// If `radiance_sh` is shorter than (v_order+2)² (a programming error: the lighting
    /// prep projects to that order).
    pub fn new(radiance_sh: &[[f64; 3]], v_order: Order, h_order: Order) -> LxhMatrices {
        let l_order = Order::new(v_order.get() + 2).unwrap_or(v_order);
        LxhMatrices::with_lighting_order(radiance_sh, l_order, v_order, h_order)
    }

    /// As [`new`](Self::new) with the lighting truncated to `l_order` instead of O + 2.
    /// With `h_order` ≥ `l_order` + `v_order` − 1 the clamped cosine is not truncated at all
    /// (L·V has no band beyond that), so `shade` is ∫ L_l V H dω exactly — the error
    /// ladder's "lighting truncated, cosine exact" rung (`crate::attribution`).
    ///
    /// # Panics
    /// If `radiance_sh` is shorter than `l_order`² (a programming error).
    pub fn with_lighting_order(
        radiance_sh: &[[f64; 3]],
        l_order: Order,
        v_order: Order,
        h_order: Order,
    ) -> LxhMatrices {
        assert!(
            radiance_sh.len() >= l_order.coeff_count(),
            "L×H needs lighting of order {l_order}, got {} coefficients",
            radiance_sh.len()
        );
        let tensor = cached_gaunt_tensor(l_order, v_order, h_order);
        let per_channel = [0, 1, 2].map(|c| {
            let l: Vec<f64> = radiance_sh[..l_order.coeff_count()]
                .iter()
                .map(|rgb| rgb[c])
                .collect();
            tensor.product_matrix(&l)
        });
        let row_factor = (0..h_order.get())
            .flat_map(|l| std::iter::repeat_n(clamped_cosine_convolution(l), (2 * l + 1) as usize))
            .collect();
        LxhMatrices {
            v_order,
            h_order,
            per_channel,
            row_factor,
        }
    }

    /// (L×H_n)_j for j < O², RGB, into `out`; `h` is scratch of h² values.
    pub fn eval_into(&self, n: DVec3, h: &mut [f64], out: &mut [[f64; 3]]) {
        eval_basis(self.h_order, n, h);
        for (hk, f) in h.iter_mut().zip(&self.row_factor) {
            *hk *= f;
        }
        let cols = self.v_order.coeff_count();
        // Channel-major accumulation over contiguous rows (vectorizes), then interleave.
        let mut acc = [[0.0f64; 36]; 3];
        if cols <= 36 {
            for (c, m) in self.per_channel.iter().enumerate() {
                let a = &mut acc[c][..cols];
                for (k, &hk) in h.iter().enumerate() {
                    if hk != 0.0 {
                        for (o, &mkj) in a.iter_mut().zip(m.row(k)) {
                            *o += mkj * hk;
                        }
                    }
                }
            }
            for (j, o) in out.iter_mut().enumerate().take(cols) {
                *o = [acc[0][j], acc[1][j], acc[2][j]];
            }
            return;
        }
        for o in out.iter_mut() {
            *o = [0.0; 3];
        }
        for (k, &hk) in h.iter().enumerate() {
            if hk == 0.0 {
                continue;
            }
            for (c, m) in self.per_channel.iter().enumerate() {
                for (o, &mkj) in out.iter_mut().zip(m.row(k)) {
                    o[c] += mkj * hk;
                }
            }
        }
    }

    /// (L×H_n)_j for j < O², RGB.
    pub fn eval(&self, n: DVec3) -> Vec<[f64; 3]> {
        let mut h = vec![0.0; self.h_order.coeff_count()];
        let mut out = vec![[0.0; 3]; self.v_order.coeff_count()];
        self.eval_into(n, &mut h, &mut out);
        out
    }

    /// Outgoing radiance integral I(n) = Σ_j V_j (L×H_n)_j for visibility `v` (O² values).
    pub fn shade(&self, n: DVec3, v: &[f64]) -> [f64; 3] {
        let lxh = self.eval(n);
        let mut sum = [0.0; 3];
        for (vj, t) in v.iter().zip(&lxh) {
            for c in 0..3 {
                sum[c] += vj * t[c];
            }
        }
        sum
    }
}

/// A table over the texel-centre normals of a sphere map: for texel t (flat index of
/// `SphereMap::texel_index`) and coefficient j, `values[t·O² + j]` RGB.
#[derive(Clone, Debug)]
pub struct LxhTable {
    pub map: SphereMap,
    pub v_order: Order,
    pub values: Vec<[f32; 3]>,
}

/// Fills an L×H table for every texel centre of `map`.
pub fn build_table(m: &LxhMatrices, map: SphereMap) -> LxhTable {
    let n_coeffs = m.v_order.coeff_count();
    let res = map.res();
    let mut values = vec![[0.0f32; 3]; map.sample_count() * n_coeffs];
    let mut h = vec![0.0; m.h_order.coeff_count()];
    let mut out = vec![[0.0; 3]; n_coeffs];
    for face in 0..map.kind().face_count() {
        for j in 0..res {
            for i in 0..res {
                m.eval_into(map.texel_center_dir(face, i, j), &mut h, &mut out);
                let t = map.texel_index(face, i, j);
                for (dst, src) in values[t * n_coeffs..(t + 1) * n_coeffs]
                    .iter_mut()
                    .zip(&out)
                {
                    *dst = src.map(|v| v as f32);
                }
            }
        }
    }
    LxhTable {
        map,
        v_order: m.v_order,
        values,
    }
}
