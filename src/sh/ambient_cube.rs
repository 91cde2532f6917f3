//! The ambient cube (Valve's Source engine: McTaggart, "Half-Life 2 / Valve Source Shading",
//! GDC 2004; Mitchell, McTaggart & Green, "Shading in Valve's Source Engine", SIGGRAPH 2006
//! course) over a tangent frame: six RGB values, one per ±axis of the frame, blended by the
//! squared components of the normal; the fits of a texel's irradiance to it. The lightmap
//! family that stores it is `crate::technique::ambient_cube`.
//!
//! # Evaluation
//!
//! The faces are +x, −x, +y, −y, +z, −z of the tangent frame, in that order ([`FACES`]).
//! At a tangent-space direction m = (x, y, z) (unit, z along the surface normal):
//!
//! ```text
//! E(m) = x² C[x ≥ 0 ? +x : −x] + y² C[y ≥ 0 ? +y : −y] + z² C[z ≥ 0 ? +z : −z]      (1)
//! ```
//!
//! i.e. Σ_i C_i w_i(m) ([`weights`]): w_+x = x² where x ≥ 0 and 0 where x < 0, w_−x the
//! other way round, likewise for y and z. The weights are non-negative and sum to |m|² = 1,
//! so a cube of one value is that value everywhere; each vanishes on its split plane, so (1)
//! is continuous, with a kink across x = 0 and y = 0.
//!
//! # Fits
//!
//! Both fit the texel's irradiance E(T m) at the world normal T m / |T m| (T = [tangent,
//! bitangent, normal], the texel's normal-map frame): from its order-3 RGB radiance SH here
//! ([`crate::sh::hbasis::irradiance_in_frame`], `--basis-fit l2`), or from its radiance
//! samples through each fit's kernel ([`least_squares_kernel`]; `crate::sh::samples`, the
//! default).
//!
//! [`CubeFit::Projection`], Valve's definition: each face holds the irradiance of a normal
//! along its axis,
//!
//! ```text
//! C_±a = E(±T e_a)                                                               (2)
//! ```
//!
//! so the cube is exact at the six axes, where one weight is 1 and the others 0.
//!
//! [`CubeFit::LeastSquares`]: the cube closest to E over the hemisphere a normal-mapped
//! normal reads,
//!
//! ```text
//! min_C ∫_{z ≥ 0} |E(T m) − Σ_i C_i w_i(m)|² dω(m)
//!   ⇔  Σ_j G_ij C_j = b_i,   G_ij = ∫_{z ≥ 0} w_i w_j dω,   b_i = ∫_{z ≥ 0} E(T m) w_i dω   (3)
//! ```
//!
//! per colour, over the five faces that reach z ≥ 0 (w_−z vanishes there). G is the same
//! for every texel: diagonal π/5 (±x, ±y) and 2π/5 (+z), π/30 between an x face and a y
//! face, π/15 between +z and an x or y face, 0 between opposite faces (a test checks). It
//! and its inverse are built once; a fit is then one weighted sum of E over the rule's
//! nodes per colour. −z keeps (2)'s value E(−T e_z): never read by a normal with z ≥ 0,
//! kept so the texel is Valve's six-value cube.
//!
//! # Quadrature
//!
//! On each octant of the hemisphere (x = 0 and y = 0, where the weights switch faces, are
//! octant boundaries) the integrands of (3) are polynomials of degree ≤ 4 in m when T is
//! orthonormal (E(T m) is then a spherical polynomial of degree 2, each weight x², y², z²
//! or 0; for other frames E(T m / |T m|) is smooth but not polynomial and the rule
//! approximates it, as the H-basis' does). The rule ([`octant_quadrature`]) takes, in each
//! of the four octants, [`FIT_N`] Gauss–Legendre nodes in the elevation θ ∈ [0, π/2]
//! (z = sin θ, dω = cos θ dθ dφ) times [`FIT_N`] in the octant's quarter of azimuth:
//! 4·11² = 484 nodes, one irradiance evaluation each per texel. On an octant such a
//! polynomial is a trigonometric polynomial of degree ≤ 5 in θ and ≤ 4 in φ, which no
//! Gauss–Legendre rule integrates exactly but on which it converges super-exponentially: at
//! `FIT_N` = 11 the octant moments ∫ x^a y^b z^c dω, a + b + c ≤ 4, match their closed
//! forms Γ(α)Γ(β)Γ(γ) / (4 Γ(α + β + γ)), α = (a+1)/2, β = (b+1)/2, γ = (c+1)/2, to
//! round-off (a test checks to 1e-14). The H-basis rule (`sh::hbasis::hemisphere_quadrature`)
//! does not serve, however many nodes: its equally spaced azimuths, even 4k of them with
//! none on a split line, integrate a half circle's cos φ or a quarter's sin 2φ only
//! approximately (a midpoint rule over an interval of length ℓ integrates e^{ipφ} exactly
//! only where pℓ is a multiple of 2π), and its Gauss–Legendre rule in z meets √(1 − z²)³
//! in terms such as |x|³ that the split leaves in b: ∫_{z ≥ 0} |x|³ dω = π/2 comes out low
//! by a relative 1.7e-5 at n = 16, 6e-8 at n = 64 — convergence like n⁻⁴.

//!

use std::sync::OnceLock;

use glam::DVec3;

use super::gauss_legendre;
use super::hbasis::irradiance_in_frame;

/// Values per colour: one per ±axis of the tangent frame (module doc, (1)).
pub const FACES: usize = 6;

/// The faces a normal with z ≥ 0 reads: all but −z, the last.
pub const UPPER_FACES: usize = FACES - 1;

/// Gauss–Legendre nodes per octant in elevation and in azimuth of the least-squares rule
/// (module doc, Quadrature).
pub const FIT_N: usize = 11;

/// The tangent-space axis of each face, in face order.
pub const AXES: [DVec3; FACES] = [
    DVec3::X,
    DVec3::NEG_X,
    DVec3::Y,
    DVec3::NEG_Y,
    DVec3::Z,
    DVec3::NEG_Z,
];

/// How a texel's cube is fitted to its irradiance (module doc, Fits).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CubeFit {
    /// Valve's: each face the irradiance along its axis, (2).
    Projection,
    /// The hemisphere's least-squares cube, (3).
    LeastSquares,
}

impl CubeFit {
    pub const ALL: [CubeFit; 2] = [CubeFit::Projection, CubeFit::LeastSquares];
}

/// The six basis functions of (1) at tangent-space `m`, in face order: the square of each
/// component on the face of its sign (+ at exactly 0, where the value is 0 anyway), 0 on
/// the other.
pub fn weights(m: DVec3) -> [f64; FACES] {
    let mut w = [0.0; FACES];
    for (axis, v) in [m.x, m.y, m.z].into_iter().enumerate() {
        w[2 * axis + usize::from(v < 0.0)] = v * v;
    }
    w
}

/// (1): Σ_i C_i w_i(m), RGB, at tangent-space `m`.
pub fn irradiance(c: &[[f64; 3]; FACES], m: DVec3) -> [f64; 3] {
    let w = weights(m);
    std::array::from_fn(|k| c.iter().zip(&w).map(|(ci, wi)| ci[k] * wi).sum())
}

/// The cube (RGB per face, face order) of the irradiance received under order-3 RGB
/// radiance SH `radiance` (world space) by a texel whose normal-map frame is `frame` =
/// [tangent, bitangent, normal], fitted by `fit` (module doc, (2) and (3)).
///
/// # Panics
/// If `radiance` holds fewer than 9 coefficients.
pub fn project_irradiance(
    radiance: &[[f64; 3]],
    frame: [DVec3; 3],
    fit: CubeFit,
) -> [[f64; 3]; FACES] {
    assert!(radiance.len() >= 9, "order-3 radiance needed");
    let along = |axis: DVec3| irradiance_in_frame(radiance, frame, axis);
    match fit {
        CubeFit::Projection => AXES.map(along),
        CubeFit::LeastSquares => {
            let ls = least_squares();
            let mut c = [[0.0; 3]; FACES];
            for (&(m, _), solve) in ls.nodes.iter().zip(&ls.solve) {
                let e = along(m);
                for (ci, s) in c.iter_mut().zip(solve) {
                    for k in 0..3 {
                        ci[k] += s * e[k];
                    }
                }
            }
            c[FACES - 1] = along(DVec3::NEG_Z);
            c
        }
    }
}

/// Nodes (tangent space, z > 0) and weights (sr, summing to 2π) of the octant rule: in each
/// of the hemisphere's four octants, `n` Gauss–Legendre nodes in the elevation θ ∈ [0, π/2]
/// times `n` in the octant's quarter of azimuth, weight w_θ w_φ cos θ (module doc,
/// Quadrature). No node lies on x = 0 or y = 0.
pub fn octant_quadrature(n: usize) -> Vec<(DVec3, f64)> {
    use std::f64::consts::{FRAC_PI_2, FRAC_PI_4};
    let (xs, ws) = gauss_legendre(n);
    let mut out = Vec::with_capacity(4 * n * n);
    for quarter in 0..4 {
        let start = quarter as f64 * FRAC_PI_2;
        for (u, wu) in xs.iter().zip(&ws) {
            // [−1, 1] → [0, π/2]: θ = π/4 (u + 1), dθ = π/4 du.
            let (sin_t, cos_t) = (FRAC_PI_4 * (u + 1.0)).sin_cos();
            for (v, wv) in xs.iter().zip(&ws) {
                let (sin_p, cos_p) = (start + FRAC_PI_4 * (v + 1.0)).sin_cos();
                out.push((
                    DVec3::new(cos_t * cos_p, cos_t * sin_p, sin_t),
                    FRAC_PI_4 * wu * FRAC_PI_4 * wv * cos_t,
                ));
            }
        }
    }
    out
}

/// The least-squares fit of (3), the same for every texel: the rule's nodes and, per node
/// q, its weight times G⁻¹ w(m_q) over the five upper faces, so that
/// `C_i = Σ_q solve[q][i] · E(T m_q)`.
struct LeastSquares {
    nodes: Vec<(DVec3, f64)>,
    solve: Vec<[f64; UPPER_FACES]>,
}

fn least_squares() -> &'static LeastSquares {
    static FIT: OnceLock<LeastSquares> = OnceLock::new();
    FIT.get_or_init(|| {
        let nodes = octant_quadrature(FIT_N);
        let gram = nalgebra::Matrix5::<f64>::from_fn(|i, j| {
            nodes
                .iter()
                .map(|&(m, w)| {
                    let b = weights(m);
                    w * b[i] * b[j]
                })
                .sum()
        });
        let inverse = gram
            .try_inverse()
            .expect("the Gram matrix of the five upper faces is positive definite");
        let solve: Vec<[f64; UPPER_FACES]> = nodes
            .iter()
            .map(|&(m, w)| {
                let b = weights(m);
                std::array::from_fn(|i| {
                    w * (0..UPPER_FACES)
                        .map(|j| inverse[(i, j)] * b[j])
                        .sum::<f64>()
                })
            })
            .collect();
        LeastSquares { nodes, solve }
    })
}

/// The least-squares fit's response to the irradiance of a single direction ω (tangent
/// space), for the five upper faces: Σ_q solve[q][i] max(0, m_q·ω), so that a cube from
/// radiance samples is C_i = Σ_s w_s L_s · kernel_i(ω_s) (`sh::samples`).
pub fn least_squares_kernel(omega: DVec3) -> [f64; UPPER_FACES] {
    let ls = least_squares();
    let mut k = [0.0; UPPER_FACES];
    for (&(m, _), solve) in ls.nodes.iter().zip(&ls.solve) {
        let cosine = m.dot(omega);
        if cosine > 0.0 {
            for (ki, s) in k.iter_mut().zip(solve) {
                *ki += s * cosine;
            }
        }
    }
    k
}

/// Values per texel: RGB of each face.
pub const STORED_VALUES: usize = 3 * FACES;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::Order;
    use crate::sh::basis::eval_basis;
    use crate::sh::hbasis::hemisphere_quadrature;
    use crate::sh::zonal::{eval_rgb, irradiance_from_radiance};
    use std::f64::consts::PI;

    /// A tilted orthonormal frame: tangent, bitangent, normal.
    fn tilted_frame() -> [DVec3; 3] {
        [
            DVec3::new(0.8, 0.0, -0.6),
            DVec3::Y,
            DVec3::new(0.6, 0.0, 0.8),
        ]
    }

    /// Radiance with L0, L1 and L2 terms.
    fn sky() -> Vec<[f64; 3]> {
        let mut radiance = vec![[0.0; 3]; 9];
        radiance[0] = [2.0, 1.8, 1.5];
        radiance[1] = [0.2, 0.1, 0.0];
        radiance[2] = [1.0, 0.9, 0.6];
        radiance[3] = [-0.4, 0.1, 0.2];
        radiance[4] = [0.3, 0.2, 0.1];
        radiance[5] = [0.3, 0.2, 0.1];
        radiance[6] = [0.1; 3];
        radiance[8] = [-0.2, 0.1, 0.3];
        radiance
    }

    /// The irradiance at tangent-space `m` through the SH expansion of irradiance (a path
    /// independent of the fits' per-node kernel).
    fn reference(radiance: &[[f64; 3]], frame: [DVec3; 3], m: DVec3) -> [f64; 3] {
        let n = (frame[0] * m.x + frame[1] * m.y + frame[2] * m.z).normalize();
        eval_rgb(
            &irradiance_from_radiance(radiance, Order::THREE),
            Order::THREE,
            n,
        )
    }

    /// ∫_{z ≥ 0} |E − cube|² dω by a finer octant rule than the fit's.
    fn hemisphere_error(radiance: &[[f64; 3]], frame: [DVec3; 3], c: &[[f64; 3]; 6]) -> f64 {
        octant_quadrature(16)
            .into_iter()
            .map(|(m, w)| {
                let (want, got) = (reference(radiance, frame, m), irradiance(c, m));
                w * (0..3).map(|k| (got[k] - want[k]).powi(2)).sum::<f64>()
            })
            .sum()
    }

    /// Γ(k/2).
    fn gamma_half(k: u32) -> f64 {
        if k.is_multiple_of(2) {
            (1..k / 2).map(f64::from).product::<f64>()
        } else {
            (0..k / 2).map(|j| f64::from(j) + 0.5).product::<f64>() * PI.sqrt()
        }
    }

    #[test]
    fn the_weights_are_non_negative_and_sum_to_one() {
        let mut dirs: Vec<DVec3> = hemisphere_quadrature(7)
            .into_iter()
            .map(|(m, _)| m)
            .collect();
        dirs.extend(hemisphere_quadrature(5).into_iter().map(|(m, _)| -m));
        dirs.extend(AXES);
        dirs.push(DVec3::new(0.0, -0.6, 0.8));
        for m in dirs {
            let w = weights(m);
            assert!(w.iter().all(|&v| v >= 0.0), "{m}: {w:?}");
            let sum: f64 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-14, "{m}: {sum}");
            // At most one face per axis.
            for a in 0..3 {
                assert!(w[2 * a] == 0.0 || w[2 * a + 1] == 0.0, "{m}: {w:?}");
            }
        }
        // One-hot at the axes, on the face of the axis' sign.
        for (f, axis) in AXES.iter().enumerate() {
            let w = weights(*axis);
            for (g, v) in w.iter().enumerate() {
                assert_eq!(*v, if f == g { 1.0 } else { 0.0 }, "{axis}: {w:?}");
            }
        }
        let w = weights(DVec3::new(-0.6, 0.0, 0.8));
        for (got, want) in w.iter().zip([0.0, 0.36, 0.0, 0.0, 0.64, 0.0]) {
            assert!((got - want).abs() < 1e-15, "{w:?}");
        }
    }

    #[test]
    fn the_projection_is_exact_at_the_axes() {
        let radiance = sky();
        let frame = tilted_frame();
        let c = project_irradiance(&radiance, frame, CubeFit::Projection);
        for (f, &axis) in AXES.iter().enumerate() {
            let want = reference(&radiance, frame, axis);
            let got = irradiance(&c, axis);
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-12,
                    "face {f}: {got:?} vs {want:?}"
                );
                assert!((c[f][k] - want[k]).abs() < 1e-12, "face {f}: {c:?}");
            }
        }
        // Between the axes it is only an approximation of this irradiance.
        let m = DVec3::new(0.6, 0.0, 0.8);
        let (got, want) = (irradiance(&c, m), reference(&radiance, frame, m));
        assert!((got[0] - want[0]).abs() > 1e-3, "{got:?} vs {want:?}");
    }

    #[test]
    fn constant_irradiance_is_reproduced_by_both_fits() {
        let mut radiance = vec![[0.0; 3]; 9];
        radiance[0] = [1.0, 0.8, 0.5];
        let want = radiance[0].map(|v| PI * v / (2.0 * PI.sqrt()));
        // Neither unit nor orthogonal: the normal is T m normalised.
        let frame = [
            DVec3::new(1.2, 0.1, 0.0),
            DVec3::new(0.2, 0.9, 0.1),
            DVec3::new(0.0, -0.1, 1.1),
        ];
        let mut dirs: Vec<DVec3> = hemisphere_quadrature(6)
            .into_iter()
            .map(|(m, _)| m)
            .collect();
        dirs.extend(octant_quadrature(5).into_iter().map(|(m, _)| m));
        dirs.extend(&AXES[..5]);
        for fit in CubeFit::ALL {
            let c = project_irradiance(&radiance, frame, fit);
            for &m in &dirs {
                let got = irradiance(&c, m);
                for k in 0..3 {
                    assert!((got[k] - want[k]).abs() < 1e-10, "{fit:?} {m}: {got:?}");
                }
            }
            // −z holds the irradiance below.
            for k in 0..3 {
                assert!((c[5][k] - want[k]).abs() < 1e-10, "{fit:?}: {c:?}");
            }
        }
    }

    #[test]
    fn least_squares_beats_the_projection_over_the_hemisphere() {
        let radiance = sky();
        for frame in [[DVec3::X, DVec3::Y, DVec3::Z], tilted_frame()] {
            let projection = project_irradiance(&radiance, frame, CubeFit::Projection);
            let ls = project_irradiance(&radiance, frame, CubeFit::LeastSquares);
            let (p, l) = (
                hemisphere_error(&radiance, frame, &projection),
                hemisphere_error(&radiance, frame, &ls),
            );
            assert!(l < 0.9 * p, "{l} vs {p}");
            // The optimum: no upper face's value moved either way lowers the error.
            for f in 0..5 {
                for k in 0..3 {
                    for step in [1e-3, -1e-3] {
                        let mut moved = ls;
                        moved[f][k] += step;
                        let e = hemisphere_error(&radiance, frame, &moved);
                        assert!(e > l, "face {f} colour {k} {step}: {e} vs {l}");
                    }
                }
            }
            // −z is the projection's: the irradiance below.
            assert_eq!(ls[5], projection[5]);
        }
    }

    #[test]
    fn the_frame_carries_tangent_space_to_the_world() {
        // A frame rotated about the normal by 90°: tangent-space x is world y. Light from
        // world +y then reads as tangent-space +x.
        let mut y = [0.0; 9];
        eval_basis(Order::THREE, DVec3::new(0.0, 0.6, 0.8), &mut y);
        let radiance: Vec<[f64; 3]> = y.iter().map(|&v| [v; 3]).collect();
        let frame = [DVec3::Y, DVec3::NEG_X, DVec3::Z];
        for fit in CubeFit::ALL {
            let c = project_irradiance(&radiance, frame, fit);
            assert!(c[0][0] > c[1][0] + 0.2, "{fit:?}: {c:?}");
            assert!((c[2][0] - c[3][0]).abs() < 1e-12, "{fit:?}: {c:?}");
            let toward = irradiance(&c, DVec3::new(0.6, 0.0, 0.8))[0];
            let away = irradiance(&c, DVec3::new(-0.6, 0.0, 0.8))[0];
            assert!(toward > away + 0.2, "{fit:?}: {toward} vs {away}");
        }
    }

    #[test]
    fn the_rule_integrates_the_octant_moments_and_the_gram_matrix() {
        let rule = octant_quadrature(FIT_N);
        let total: f64 = rule.iter().map(|(_, w)| w).sum();
        assert!((total - 2.0 * PI).abs() < 1e-14, "{total}");
        assert!(
            rule.iter()
                .all(|(m, _)| m.x != 0.0 && m.y != 0.0 && m.z > 0.0)
        );
        let octant = |a: u32, b: u32, c: u32| {
            gamma_half(a + 1) * gamma_half(b + 1) * gamma_half(c + 1)
                / (4.0 * gamma_half(a + b + c + 3))
        };
        assert!((octant(0, 0, 0) - PI / 2.0).abs() < 1e-15);
        for a in 0..5 {
            for b in 0..5 - a {
                for c in 0..5 - a - b {
                    let got: f64 = rule
                        .iter()
                        .filter(|(m, _)| m.x > 0.0 && m.y > 0.0)
                        .map(|&(m, w)| {
                            w * m.x.powi(a as i32) * m.y.powi(b as i32) * m.z.powi(c as i32)
                        })
                        .sum();
                    let want = octant(a, b, c);
                    assert!(
                        (got - want).abs() < 1e-14,
                        "x^{a} y^{b} z^{c}: {got} vs {want}"
                    );
                }
            }
        }
        // The Gram matrix of the module doc.
        let (d, e, g) = (PI / 5.0, PI / 30.0, PI / 15.0);
        let want = [
            [d, 0.0, e, e, g],
            [0.0, d, e, e, g],
            [e, e, d, 0.0, g],
            [e, e, 0.0, d, g],
            [g, g, g, g, 2.0 * d],
        ];
        for (i, row) in want.iter().enumerate() {
            for (j, want) in row.iter().enumerate() {
                let got: f64 = rule
                    .iter()
                    .map(|&(m, w)| w * weights(m)[i] * weights(m)[j])
                    .sum();
                assert!((got - want).abs() < 1e-14, "G{i}{j}: {got} vs {want}");
            }
        }
    }
}
