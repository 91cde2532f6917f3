//! The "normal basis" of normal mapping for PRT (Sloan, PRT course): how much of the
//! outgoing radiance as a function of the tangent-space normal the first M singular
//! vectors of the course's matrix A capture (`shvis study nmprt-svd`).
//!
//! A has one row per normal n_k of the hemisphere, sampled on the unit disk by a `side`²
//! grid of bilinear nodes mapped to the hemisphere orthographically (n = (x, y, √(1−x²−y²)),
//! the course's shader looks U up at `normal.xy·½ + ½`), and one column per quadratic SH
//! basis function j of the transferred incident radiance:
//!
//! ```text
//! A_kj = ∫_{ω_z > 0} y_j(ω) · max(0, n_k·ω) dω
//! ```
//!
//! — the clamped cosine about n_k against the basis function, the lighting clamped to the
//! surface's hemisphere first (the course: "the lighting environment should be clamped to
//! the hemisphere before this integral happens"). Then A = U S Vᵀ and e(n) ≈ U(n) S_M Vᵀ l'
//! with the first M singular values; the squared error captured is Σ_{k≤M} σ_k² / Σ σ_k².
//! Rows are weighted for a least-squares fit over the hemisphere: **uniform** (√dω of the
//! node: dω = dA/n_z on the orthographic disk) or **cosine-weighted** (√(n_z dω) = √dA:
//! normals near the tangent-space z preferred), the course's two figures.
//!
//! The study also builds A with the lighting over the whole sphere (A_kj = A_l·y_j(n_k),
//! [`normal_matrix_over`]): that variant reproduces the course's figures (M = 4: 94.0 /
//! 96.2 % against its 93.9 / 96.4; M = 6: 98.7 / 99.2 against 98.7 / 99.3 on a 32² grid),
//! while clamping to the hemisphere makes A's columns dependent (rank 6: six singular
//! values hold all of it, four hold 98.4 / 99.1 %).

use glam::DVec3;
use nalgebra::DMatrix;
use rayon::prelude::*;

use crate::sh::{Order, basis::eval_basis};
use crate::technique::nmprt::disk_normals;

/// Rows weighted for a least-squares fit over the hemisphere of normals (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalWeighting {
    Uniform,
    Cosine,
}

/// The course's figures for M = 4 and 6 (uniform, cosine-weighted), "SE" in percent.
pub const COURSE_ENERGY: [(usize, f64, f64); 2] = [(4, 93.9, 96.4), (6, 98.7, 99.3)];

/// A (rows: the normals of [`disk_normals`], columns: the 9 quadratic SH functions), by a
/// `quadrature`² midpoint rule over the upper hemisphere in (cos θ, φ) (equal solid angle
/// per cell), rows scaled by the weighting's √weight.
pub fn normal_matrix(side: usize, quadrature: usize, weighting: NormalWeighting) -> DMatrix<f64> {
    normal_matrix_over(side, quadrature, weighting, true)
}

/// [`normal_matrix`], with the lighting clamped to the surface's hemisphere or (`false`)
/// over the whole sphere (then A_kj = A_l · y_j(n_k), the plain convolved basis).
pub fn normal_matrix_over(
    side: usize,
    quadrature: usize,
    weighting: NormalWeighting,
    hemisphere_clamped: bool,
) -> DMatrix<f64> {
    let (z0, z_span) = if hemisphere_clamped {
        (0.0, 1.0)
    } else {
        (-1.0, 2.0)
    };
    let cells: Vec<(DVec3, [f64; 9])> = (0..quadrature * quadrature)
        .map(|q| {
            let (a, b) = (q / quadrature, q % quadrature);
            let z = z0 + z_span * (a as f64 + 0.5) / quadrature as f64;
            let phi = std::f64::consts::TAU * (b as f64 + 0.5) / quadrature as f64;
            let s = (1.0 - z * z).sqrt();
            let w = DVec3::new(s * phi.cos(), s * phi.sin(), z);
            let mut y = [0.0; 9];
            eval_basis(Order::THREE, w, &mut y);
            (w, y)
        })
        .collect();
    let d_omega = z_span * std::f64::consts::TAU / (quadrature * quadrature) as f64;
    let normals = disk_normals(side);
    // Rows in parallel, each summed in cell order: the same matrix on any thread count.
    let rows: Vec<[f64; 9]> = normals
        .par_iter()
        .map(|(n, area)| {
            let mut row = [0.0f64; 9];
            for (w, y) in &cells {
                let c = n.dot(*w);
                if c > 0.0 {
                    for (r, yj) in row.iter_mut().zip(y) {
                        *r += yj * c * d_omega;
                    }
                }
            }
            let weight = match weighting {
                NormalWeighting::Uniform => area / n.z.max(1e-6),
                NormalWeighting::Cosine => *area,
            };
            row.map(|r| r * weight.sqrt())
        })
        .collect();
    let mut a = DMatrix::<f64>::zeros(normals.len(), 9);
    for (k, row) in rows.iter().enumerate() {
        for (j, r) in row.iter().enumerate() {
            a[(k, j)] = *r;
        }
    }
    a
}

/// The three-row HL2 alternative (the course: "HL2 basis (3 rows for the matrix)"): the
/// share of ‖A‖² that the span of the Half-Life 2 blend weights D_k(n) (Green's eq. (3),
/// `bake::ssbump::d_encoding`, as functions of the normal, rows weighted as A's) captures
/// — the least-squares fit e(n) ≈ Σ_k D_k(n) h_k of every column. Never above the first
/// three singular values', which are the best any three functions of n can do.
pub fn hl2_energy(side: usize, a: &DMatrix<f64>, weighting: NormalWeighting) -> f64 {
    let normals = disk_normals(side);
    assert_eq!(normals.len(), a.nrows(), "A was built on the same grid");
    let mut f = DMatrix::<f64>::zeros(normals.len(), 3);
    for (k, (n, area)) in normals.iter().enumerate() {
        let weight = match weighting {
            NormalWeighting::Uniform => area / n.z.max(1e-6),
            NormalWeighting::Cosine => *area,
        };
        for (j, d) in crate::bake::ssbump::d_encoding(*n).iter().enumerate() {
            f[(k, j)] = d * weight.sqrt();
        }
    }
    // Orthonormal basis of F's columns, then the projection of A onto it.
    let q = f.qr().q();
    let projected = &q * (q.transpose() * a);
    projected.norm_squared() / a.norm_squared()
}

/// The share of ‖A‖² captured by the first M = 1…9 singular values.
pub fn energy_captured(a: &DMatrix<f64>) -> [f64; 9] {
    let mut s: Vec<f64> = a.singular_values().iter().copied().collect();
    s.sort_by(|x, y| y.total_cmp(x));
    let total: f64 = s.iter().map(|v| v * v).sum();
    let mut out = [0.0; 9];
    let mut acc = 0.0;
    for (m, share) in out.iter_mut().enumerate() {
        acc += s.get(m).map_or(0.0, |v| v * v);
        *share = acc / total;
    }
    out
}

/// The study's table: energy captured for M = 1…9, uniform and cosine-weighted, with the
/// lighting clamped to the hemisphere (`clamped`) and over the whole sphere (`sphere`),
/// beside the course's figures.
pub fn to_markdown(
    side: usize,
    clamped: [&[f64; 9]; 2],
    sphere: [&[f64; 9]; 2],
    hl2: [f64; 4],
) -> String {
    let mut s = format!(
        "Normal basis of normal mapping for PRT: energy of A ({side}² disk grid of normals, quadratic SH) captured by the first M singular values, %\n\n| M | clamped, uniform | clamped, cosine | whole sphere, uniform | whole sphere, cosine | course (uniform / cosine) |\n|---:|---:|---:|---:|---:|---|\n"
    );
    for m in 1..=9 {
        let course = COURSE_ENERGY
            .iter()
            .find(|(k, _, _)| *k == m)
            .map_or("—".to_string(), |(_, u, c)| format!("{u} / {c}"));
        s += &format!(
            "| {m} | {:.1} | {:.1} | {:.1} | {:.1} | {course} |\n",
            100.0 * clamped[0][m - 1],
            100.0 * clamped[1][m - 1],
            100.0 * sphere[0][m - 1],
            100.0 * sphere[1][m - 1]
        );
    }
    s += &format!(
        "| HL2 (3 rows) | {:.1} | {:.1} | {:.1} | {:.1} | — |\n",
        100.0 * hl2[0],
        100.0 * hl2[1],
        100.0 * hl2[2],
        100.0 * hl2[3]
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nine_singular_values_reconstruct_a_exactly_and_energy_is_monotone() {
        let a = normal_matrix(12, 48, NormalWeighting::Uniform);
        let svd = a.clone().svd(true, true);
        let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
        let rebuilt = &u * DMatrix::from_diagonal(&svd.singular_values) * &v_t;
        let err = (&rebuilt - &a).abs().max();
        assert!(
            err < 1e-12 * a.abs().max().max(1.0),
            "M = 9 rebuilds A to {err:e}"
        );
        let e = energy_captured(&a);
        assert!((e[8] - 1.0).abs() < 1e-12);
        assert!(e.windows(2).all(|w| w[1] >= w[0]), "{e:?}");
        // Band 0 alone is a large share (irradiance is smooth in n).
        assert!(e[0] > 0.5 && e[0] < 1.0, "{e:?}");
        // Three HL2 weights can do no better than the first three singular vectors.
        let hl2 = hl2_energy(12, &a, NormalWeighting::Uniform);
        assert!(
            hl2 > 0.5 && hl2 <= e[2] + 1e-12,
            "HL2 {hl2} vs SVD-3 {}",
            e[2]
        );
    }

    #[test]
    fn clamped_cosine_row_of_the_z_normal_is_the_hemisphere_irradiance_of_band_0() {
        // n = +z, y_0 = 1/(2√π): ∫_{z>0} y_0 cos θ dω = π/(2√π) = √π/2.
        let a = normal_matrix(1, 256, NormalWeighting::Cosine);
        // One node at the disk centre (area 4): unscale by √4.
        let got = a[(0, 0)] / 2.0;
        assert!(
            (got - std::f64::consts::PI.sqrt() / 2.0).abs() < 1e-4,
            "{got}"
        );
    }
}
