//! The ladder's "exact lighting, exact clamped cosine" integrals:
//!
//! ```text
//! G_j(n) = ∫ L(ω) max(0, n·ω) y_j(ω) dω,   j < O²   (so ∫ L V_O H_n dω = Σ_j V_j G_j(n))
//! ```
//!
//! with L the full environment map, not its SH. Two approximations, both measured in
//! `tests` below rather than assumed:
//!
//! 1. **Quadrature of L.** The map's texels are merged into blocks of about 2.8° (the map
//!    cut into [`QUADRATURE_COLUMNS`] × columns/2 blocks); each block contributes its exact
//!    radiance integral W = Σ L_texel Ω_texel at its luminance-weighted centroid direction
//!    (the texels' centres weighted by luminance × solid angle). The centroid makes the
//!    rule exact for integrands linear across a block, so a sun is placed where it is, not
//!    at a block centre; the error is second order in the block size.
//! 2. **A table over normals.** G(n) is tabulated at the texel centres of a seamless cube
//!    map ([`NORMAL_TABLE_RES`]² per face) and read back with the cube's bilinear filter
//!    (`SphereMap::bilinear_taps`). G is a clamped-cosine convolution, smooth in n except
//!    for a kink where a concentrated light crosses the horizon.
//!
//! Everything is f64. Cost: 6·R² normals × blocks × O² multiply-adds (R 32, order 6,
//! 8192 blocks: ≈ 2·10⁹, a few seconds on two cores), independent of the image size.

use glam::DVec3;
use rayon::prelude::*;

use crate::env::EnvMap;
use crate::sh::Order;
use crate::sh::basis::eval_basis;
use crate::sphere::{Parameterization, SphereMap};

/// Blocks across the map's width (2.8° at 128).
pub const QUADRATURE_COLUMNS: u32 = 128;
/// Cube-face texels per side of the normal table.
pub const NORMAL_TABLE_RES: u32 = 32;

/// The map as weighted directions: Σ_d W_d f(ω_d) ≈ ∫ L f dω for smooth f.
pub struct EnvQuadrature {
    pub dirs: Vec<DVec3>,
    /// ∫ L dω over the block, RGB.
    pub weights: Vec<[f64; 3]>,
}

impl EnvQuadrature {
    /// Blocks of ⌈width / `columns`⌉ × the same number of rows (module doc).
    pub fn new(env: &EnvMap, columns: u32) -> EnvQuadrature {
        let block = env.width.div_ceil(columns.max(1)).max(1);
        let (bw, bh) = (env.width.div_ceil(block), env.height.div_ceil(block));
        let mut dirs = Vec::with_capacity((bw * bh) as usize);
        let mut weights = Vec::with_capacity((bw * bh) as usize);
        for by in 0..bh {
            for bx in 0..bw {
                let (mut w, mut centroid, mut centre) = ([0.0f64; 3], DVec3::ZERO, DVec3::ZERO);
                for y in by * block..((by + 1) * block).min(env.height) {
                    let omega = env.texel_solid_angle(y);
                    for x in bx * block..((bx + 1) * block).min(env.width) {
                        let [r, g, b] = env.texel(x, y);
                        let d = env.texel_center_dir(x, y);
                        for (wc, l) in w.iter_mut().zip([r, g, b]) {
                            *wc += f64::from(l) * omega;
                        }
                        let lum =
                            (0.2126 * r as f64 + 0.7152 * g as f64 + 0.0722 * b as f64).max(0.0);
                        centroid += d * (lum * omega);
                        centre += d * omega;
                    }
                }
                let dir = centroid.try_normalize().or(centre.try_normalize());
                if let Some(dir) = dir.filter(|_| w.iter().any(|&v| v != 0.0)) {
                    dirs.push(dir);
                    weights.push(w);
                }
            }
        }
        EnvQuadrature { dirs, weights }
    }

    /// G_j(n) for j < `order`², RGB, by the quadrature (no table).
    pub fn integrate(&self, order: Order, basis: &[f64], n: DVec3, out: &mut [[f64; 3]]) {
        let n2 = order.coeff_count();
        let out = &mut out[..n2];
        out.fill([0.0; 3]);
        for (d, (dir, w)) in self.dirs.iter().zip(&self.weights).enumerate() {
            let cos = n.dot(*dir);
            if cos <= 0.0 {
                continue;
            }
            let cw = w.map(|v| v * cos);
            for (o, y) in out.iter_mut().zip(&basis[d * n2..(d + 1) * n2]) {
                for c in 0..3 {
                    o[c] += y * cw[c];
                }
            }
        }
    }

    /// y_j(ω_d) for every direction, direction-major (`order`² per direction).
    pub fn basis(&self, order: Order) -> Vec<f64> {
        let n2 = order.coeff_count();
        let mut out = vec![0.0; self.dirs.len() * n2];
        out.par_chunks_mut(n2)
            .zip(&self.dirs)
            .for_each(|(o, &d)| eval_basis(order, d, o));
        out
    }
}

/// G_j(n) at the texel centres of a seamless cube, read back bilinearly (module doc).
pub struct ExactLightTable {
    pub order: Order,
    map: SphereMap,
    /// `order`² RGB values per cube texel, texel-major.
    values: Vec<[f64; 3]>,
}

impl ExactLightTable {
    pub fn new(env: &EnvMap, order: Order) -> ExactLightTable {
        let quadrature = EnvQuadrature::new(env, QUADRATURE_COLUMNS);
        let basis = quadrature.basis(order);
        let map = SphereMap::new(Parameterization::CubeDx10, NORMAL_TABLE_RES)
            .expect("NORMAL_TABLE_RES is a valid resolution");
        let n2 = order.coeff_count();
        let res = map.res();
        let mut values = vec![[0.0; 3]; map.sample_count() * n2];
        values.par_chunks_mut(n2).enumerate().for_each(|(t, out)| {
            let (face, rest) = (t as u32 / (res * res), t as u32 % (res * res));
            let n = map.texel_center_dir(face, rest % res, rest / res);
            quadrature.integrate(order, &basis, n, out);
        });
        ExactLightTable { order, map, values }
    }

    /// G_j(n), j < `out.len()` ≤ order², RGB.
    pub fn eval(&self, n: DVec3, out: &mut [[f64; 3]]) {
        let n2 = self.order.coeff_count();
        let taps = self.map.bilinear_taps(n);
        out.fill([0.0; 3]);
        for (&i, &w) in taps.index.iter().zip(&taps.weight) {
            if w == 0.0 {
                continue;
            }
            let texel = &self.values[i as usize * n2..(i as usize + 1) * n2];
            for (o, v) in out.iter_mut().zip(texel) {
                for c in 0..3 {
                    o[c] += w * v[c];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadrature against the full-resolution map texel by texel, and the table
    /// against the quadrature, at scattered normals: both well under the ladder's rungs.
    #[test]
    fn quadrature_and_table_track_the_full_map() {
        let env = crate::env::resolve("sky").expect("the built-in sky");
        let order = Order::SIX;
        let n2 = order.coeff_count();
        let full = EnvQuadrature::new(&env, env.width);
        let coarse = EnvQuadrature::new(&env, QUADRATURE_COLUMNS);
        let (full_basis, coarse_basis) = (full.basis(order), coarse.basis(order));
        let table = ExactLightTable::new(&env, order);
        let (mut a, mut b, mut t) = (vec![[0.0; 3]; n2], vec![[0.0; 3]; n2], vec![[0.0; 3]; n2]);
        let (mut quad_err, mut table_err, mut norm) = (0.0f64, 0.0f64, 0.0f64);
        for k in 0..200 {
            // Golden-angle spiral over the sphere.
            let z = 1.0 - (2.0 * k as f64 + 1.0) / 200.0;
            let phi = k as f64 * 2.399_963_229_728_653;
            let s = (1.0 - z * z).sqrt();
            let n = DVec3::new(s * phi.cos(), z, s * phi.sin());
            full.integrate(order, &full_basis, n, &mut a);
            coarse.integrate(order, &coarse_basis, n, &mut b);
            table.eval(n, &mut t);
            for j in 0..n2 {
                for c in 0..3 {
                    quad_err += (a[j][c] - b[j][c]).powi(2);
                    table_err += (a[j][c] - t[j][c]).powi(2);
                    norm += a[j][c].powi(2);
                }
            }
        }
        let (quad_rel, table_rel) = ((quad_err / norm).sqrt(), (table_err / norm).sqrt());
        eprintln!("exact-light quadrature {quad_rel:.2e}, table {table_rel:.2e}");
        assert!(quad_rel < 1e-3, "quadrature {quad_rel}");
        assert!(table_rel < 5e-3, "table {table_rel}");
    }
}
