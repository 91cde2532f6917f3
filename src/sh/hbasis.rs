//! The H-basis (Habel & Wimmer, "Efficient Irradiance Normal Mapping", I3D 2010): an
//! orthonormal basis of polynomials over the upper hemisphere of a surface's tangent frame,
//! in which a lightmap stores the irradiance a normal-mapped normal will see — so the
//! tangent-space normal indexes it directly, without the frame.
//!
//! # Functions
//!
//! For a tangent-space direction m = (x, y, z), z ≥ 0 (z along the surface normal):
//!
//! ```text
//! H1 = 1/√(2π)                       H4 = √(3/2π) x
//! H2 = √(3/2π) y                     H5 = √(15/2π) x y
//! H3 = √(3/2π) (2z − 1)              H6 = √(15/2π) (x² − y²)/2
//! ```
//!
//! orthonormal over the hemisphere (∫ H_i H_j dω = δ_ij; a unit test checks it). `H4` keeps
//! the first four (the paper's H4: constant and linear), `H6` all six (its H6: the two
//! quadratic functions of the azimuth added). Signs are this module's (the paper's up to
//! sign); projection and evaluation use the same ones.
//!
//! # Projection
//!
//! A texel stores h_i = ∫_{z ≥ 0} E(T m) H_i(m) dω(m), E the irradiance it receives (from
//! its order-3 SH here, `sh::zonal`; from its radiance samples through
//! [`irradiance_kernel`] in `crate::sh::samples`), T the texel's normal-map frame (tangent, bitangent, normal; the
//! world normal of tangent-space m is T m normalised, as the shader builds it), by a
//! Gauss–Legendre × azimuth rule over the hemisphere ([`hemisphere_quadrature`]; with an
//! orthonormal T, E(T m) has degree 2 and the products degree 4, so [`PROJECTION_N`] = 4
//! integrates them exactly). Reconstruction: E(m) ≈ Σ_i h_i H_i(m).

use glam::DVec3;

use super::gauss_legendre;
use super::zonal::irradiance_at;

/// The paper's two sizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum HBasisSize {
    H4,
    H6,
}

impl HBasisSize {
    /// Functions per colour.
    pub fn count(self) -> usize {
        match self {
            HBasisSize::H4 => 4,
            HBasisSize::H6 => 6,
        }
    }
}

/// Gauss–Legendre nodes per unit of z in the projection rule (module doc).
pub const PROJECTION_N: usize = 4;

const TWO_PI: f64 = 2.0 * std::f64::consts::PI;

/// The six H functions at tangent-space `m` (not clamped to z ≥ 0).
pub fn eval(m: DVec3) -> [f64; 6] {
    let k0 = 1.0 / TWO_PI.sqrt();
    let k1 = (3.0 / TWO_PI).sqrt();
    let k2 = (15.0 / TWO_PI).sqrt();
    [
        k0,
        k1 * m.y,
        k1 * (2.0 * m.z - 1.0),
        k1 * m.x,
        k2 * m.x * m.y,
        0.5 * k2 * (m.x * m.x - m.y * m.y),
    ]
}

/// Nodes (tangent space, z ≥ 0) and weights (sr, summing to 2π) of the hemisphere rule: `n`
/// Gauss–Legendre nodes in z ∈ [0, 1] times 2n azimuths; exact for polynomials of degree
/// ≤ 2n − 1 in z and < 2n in the azimuth.
pub fn hemisphere_quadrature(n: usize) -> Vec<(DVec3, f64)> {
    let (zs, ws) = gauss_legendre(n);
    let n_phi = 2 * n;
    let mut out = Vec::with_capacity(n * n_phi);
    for (z, w) in zs.iter().zip(&ws) {
        let (z, w) = (0.5 * (z + 1.0), 0.5 * w);
        let r = (1.0 - z * z).max(0.0).sqrt();
        for b in 0..n_phi {
            let phi = TWO_PI * (b as f64 + 0.5) / n_phi as f64;
            out.push((
                DVec3::new(r * phi.cos(), r * phi.sin(), z),
                w * TWO_PI / n_phi as f64,
            ));
        }
    }
    out
}

/// The H coefficients (RGB, `size.count()` of them) of the irradiance received under
/// order-3 RGB radiance SH `radiance` (world space) by a texel whose normal-map frame is
/// `frame` = [tangent, bitangent, normal] (module doc).
///
/// # Panics
/// If `radiance` holds fewer than 9 coefficients.
pub fn project_irradiance(
    radiance: &[[f64; 3]],
    frame: [DVec3; 3],
    size: HBasisSize,
) -> Vec<[f64; 3]> {
    assert!(radiance.len() >= 9, "order-3 radiance needed");
    let count = size.count();
    let mut h = vec![[0.0; 3]; count];
    for (m, w) in hemisphere_rule() {
        let e = irradiance_in_frame(radiance, frame, *m);
        let basis = eval(*m);
        for (hi, bi) in h.iter_mut().zip(&basis) {
            for c in 0..3 {
                hi[c] += w * e[c] * bi;
            }
        }
    }
    h
}

/// The irradiance E(T m / |T m|) (RGB) a texel with normal-map frame `frame` = T =
/// [tangent, bitangent, normal] receives at tangent-space normal `m` under order-3 RGB
/// radiance SH `radiance` (world space): the world normal built as the shader builds it,
/// zero where T m vanishes (a texel without a frame).
///
/// # Panics
/// If `radiance` holds fewer than 9 coefficients.
pub fn irradiance_in_frame(radiance: &[[f64; 3]], frame: [DVec3; 3], m: DVec3) -> [f64; 3] {
    let world = frame[0] * m.x + frame[1] * m.y + frame[2] * m.z;
    world
        .try_normalize()
        .map_or([0.0; 3], |n| irradiance_at(radiance, n))
}

/// Gauss–Legendre nodes per unit of z of the rule behind [`irradiance_kernel`].
pub const KERNEL_N: usize = 24;

/// The projection's response to the irradiance of a single direction ω (tangent space):
/// k_i(ω) = ∫_{z ≥ 0} H_i(m) max(0, m·ω) dω(m), so that a texel's H coefficients from
/// radiance samples are h_i = Σ_s w_s L_s k_i(ω_s) (`sh::samples`). By the hemisphere rule
/// of [`KERNEL_N`] (the clamped cosine's kink makes no rule exact; a test checks k against a
/// rule four times finer, within 0.5 % of k's scale).
pub fn irradiance_kernel(omega: DVec3) -> [f64; 6] {
    static RULE: std::sync::OnceLock<Vec<(DVec3, f64)>> = std::sync::OnceLock::new();
    let rule = RULE.get_or_init(|| hemisphere_quadrature(KERNEL_N));
    let mut k = [0.0; 6];
    for &(m, w) in rule {
        let cosine = m.dot(omega);
        if cosine <= 0.0 {
            continue;
        }
        for (ki, hi) in k.iter_mut().zip(eval(m)) {
            *ki += w * cosine * hi;
        }
    }
    k
}

/// Σ_i h_i H_i(m), RGB, for `h` of either size.
pub fn irradiance(h: &[[f64; 3]], m: DVec3) -> [f64; 3] {
    let basis = eval(m);
    std::array::from_fn(|c| h.iter().zip(&basis).map(|(hi, b)| hi[c] * b).sum())
}

fn hemisphere_rule() -> &'static [(DVec3, f64)] {
    static RULE: std::sync::OnceLock<Vec<(DVec3, f64)>> = std::sync::OnceLock::new();
    RULE.get_or_init(|| hemisphere_quadrature(PROJECTION_N))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::Order;
    use crate::sh::basis::eval_basis;

    const TIGHT: f64 = 1e-12;

    #[test]
    fn the_functions_are_orthonormal_over_the_hemisphere() {
        let rule = hemisphere_quadrature(PROJECTION_N);
        let total: f64 = rule.iter().map(|(_, w)| w).sum();
        assert!((total - TWO_PI).abs() < TIGHT);
        for i in 0..6 {
            for j in 0..6 {
                let dot: f64 = rule.iter().map(|&(m, w)| w * eval(m)[i] * eval(m)[j]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (dot - want).abs() < TIGHT,
                    "H{} · H{} = {dot}",
                    i + 1,
                    j + 1
                );
            }
        }
    }

    #[test]
    fn irradiance_in_the_span_is_reproduced_and_h6_refines_h4() {
        // Radiance whose irradiance, over the hemisphere of an axis-aligned frame, is
        // linear in the normal: L0 and L1 only (E = a + b·n, in H4's span).
        let mut radiance = vec![[0.0; 3]; 9];
        radiance[0] = [1.0, 0.8, 0.5];
        radiance[1] = [0.2, 0.1, 0.0];
        radiance[2] = [0.4, 0.3, 0.2];
        radiance[3] = [-0.1, 0.0, 0.1];
        let frame = [DVec3::X, DVec3::Y, DVec3::Z];
        let h4 = project_irradiance(&radiance, frame, HBasisSize::H4);
        for (m, _) in hemisphere_quadrature(6) {
            let want = crate::sh::zonal::eval_rgb(
                &crate::sh::zonal::irradiance_from_radiance(&radiance, Order::THREE),
                Order::THREE,
                m,
            );
            let got = irradiance(&h4, m);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-10, "{m}: {got:?} vs {want:?}");
            }
        }
        // With band 2, H6 fits at least as well as H4 over the hemisphere.
        radiance[4] = [0.3, 0.2, 0.1];
        radiance[8] = [-0.2, 0.1, 0.3];
        radiance[6] = [0.1; 3];
        let h4 = project_irradiance(&radiance, frame, HBasisSize::H4);
        let h6 = project_irradiance(&radiance, frame, HBasisSize::H6);
        let error = |h: &[[f64; 3]]| -> f64 {
            hemisphere_quadrature(6)
                .into_iter()
                .map(|(m, w)| {
                    let want = crate::sh::zonal::eval_rgb(
                        &crate::sh::zonal::irradiance_from_radiance(&radiance, Order::THREE),
                        Order::THREE,
                        m,
                    );
                    let got = irradiance(h, m);
                    w * (0..3).map(|c| (got[c] - want[c]).powi(2)).sum::<f64>()
                })
                .sum()
        };
        assert!(error(&h6) < error(&h4), "{} vs {}", error(&h6), error(&h4));
    }

    #[test]
    fn the_frame_carries_tangent_space_to_the_world() {
        // A frame rotated about the normal by 90°: tangent-space x is world y. Light from
        // world +y then reads as tangent-space +x.
        let mut y = [0.0; 9];
        eval_basis(Order::THREE, DVec3::new(0.0, 0.6, 0.8), &mut y);
        let radiance: Vec<[f64; 3]> = y.iter().map(|&v| [v; 3]).collect();
        let frame = [DVec3::Y, DVec3::NEG_X, DVec3::Z];
        let h = project_irradiance(&radiance, frame, HBasisSize::H6);
        let toward = irradiance(&h, DVec3::new(0.6, 0.0, 0.8))[0];
        let away = irradiance(&h, DVec3::new(-0.6, 0.0, 0.8))[0];
        assert!(toward > away + 0.2, "{toward} vs {away}");
    }

    #[test]
    fn the_irradiance_kernel_agrees_with_a_finer_rule() {
        let fine = hemisphere_quadrature(4 * KERNEL_N);
        for omega in [
            DVec3::Z,
            DVec3::new(0.6, 0.0, 0.8),
            DVec3::new(-0.3, 0.7, 0.2).normalize(),
            DVec3::new(0.5, -0.5, -0.5).normalize(),
        ] {
            let coarse = irradiance_kernel(omega);
            let mut exact = [0.0; 6];
            for &(m, w) in &fine {
                let cosine = m.dot(omega).max(0.0);
                for (e, h) in exact.iter_mut().zip(eval(m)) {
                    *e += w * cosine * h;
                }
            }
            let scale = exact.iter().fold(0.0f64, |a, v| a.max(v.abs())).max(1e-12);
            for (c, e) in coarse.iter().zip(&exact) {
                assert!(
                    (c - e).abs() <= 5e-3 * scale,
                    "{omega}: {coarse:?} vs {exact:?}"
                );
            }
        }
    }
}
