//! The lightmap bases engines ship, as encodings of order-3 RGB radiance SH and their
//! irradiance reconstructions at a normal: L1 with linear, Geomerics and hallucinated-ZH3
//! reconstruction, stored ZH3, luminance-directional L1, and L2 plain or deringed
//! ([`ShBasis`]). The `l1*`, `zh3`, `l1lum` and `shlmapw` techniques store what
//! [`ShBasis::encode`] gives per lightmap texel; their shaders (`glsl/include/sh_bases.glsl`)
//! evaluate what [`ShBasis::irradiance`] evaluates; `shvis study bases` measures both against
//! exact irradiance.
//!
//! # Notation
//!
//! c_lm (RGB) are radiance coefficients (DESIGN §1); A_0 = π, A_1 = 2π/3, A_2 = π/4 the
//! clamped-cosine factors ([`super::zonal`]); K_1 = √(3/4π). The linear band as a vector,
//! d = (−c_11, −c_1−1, c_10), so that Σ_m c_1m y_1m(n) = K_1 d·n. Luminance is Rec. 709:
//! w = (0.2126, 0.7152, 0.0722), f_lum = Σ_c w_c f_c.
//!
//! # Bases (per colour channel unless stated)
//!
//! ```text
//! L1 linear     E(n) = A_0 c_00 y_00 + A_1 K_1 d·n                                       (1)
//! Geomerics     R_0 = A_0 c_00 y_00,  R_1 = ½ A_1 K_1 d,  r = |R_1|/R_0 (≤ 1),
//!               q = (1 + n·R̂_1)/2,  p = 1 + 2r,  a = (1 − r)/(1 + r),
//!               E(n) = R_0 (a + (1 − a)(p + 1) q^p)                                       (2)
//! ZH3 axis      â = d_lum/|d_lum|   (shared by the three channels)                        (3)
//! ZH3 stored    z = √(4π/5) Σ_m c_2m y_2m(â)   (the projection onto the zonal harmonic
//!               about â),  E(n) = (1) + A_2 z Y_20(â·n),  Y_20(t) = √(5/16π)(3t² − 1)      (4)
//! ZH3 halluc.   r = min(|d·â| / c_00, √3),  z = c_00 (0.08 r + 0.6 r²),  E(n) as (4)      (5)
//! L1 luminance  stored c_00 (RGB) and e = d_lum, ê = e · min(1, √3 c_00,lum / |e|);
//!               E_c(n) = A_0 c_00,c y_00 + (c_00,c / c_00,lum) A_1 K_1 ê·n                (6)
//! L2            E(n) = Σ_l A_l Σ_m c_lm y_lm(n)                                           (7)
//! L2 deringed   (7) with c_lm ← σ_l(w) c_lm, σ the Hanning window, w the gentlest width
//!               for which (7) is non-negative over the shaded normals (a texel's
//!               hemisphere, or the sphere), smallest over RGB                             (8)
//! ```
//!
//! (2) is Geomerics' non-linear L1 reconstruction (Enlighten; "Reconstructing Diffuse
//! Lighting", CEDEC 2015, as Bakery's `shEvaluateDiffuseL1Geomerics`), written here in
//! irradiance units: R_0 is the mean of E over all normals and 2R_1 the linear term, so the
//! curve keeps (1)'s mean, reaches 0 opposite a single direction and is never negative.
//! (3)–(5) are Roughton, Sloan, Silvennoinen, Iwanicki and Shirley, "ZH3: Quadratic Zonal
//! Harmonics" (i3D 2024): the quadratic band reduced to one zonal coefficient per colour
//! about the luminance's linear direction, stored (4) or hallucinated from L1 by the
//! paper's curve fit (§3.4.3) at no storage cost (5). (6) is luminance-directional L1 as
//! Unreal's HQ lightmaps store it: the colour of the ambient term scales one luminance
//! direction. (8) is [`super::window`]'s deringing (Sloan, "Deringing Spherical
//! Harmonics", 2017, reduced to the Hanning family's one width) applied to the irradiance
//! (the factors σ_l commute with the convolution, so the radiance coefficients take them):
//! it removes the negative lobes a small bright sun rings into order-3 irradiance
//! (a lone direction's dips to −4 % of its peak) at the price of blur where it acts.
//!
//! # Degenerate inputs
//!
//! For non-negative radiance |d| ≤ √3 c_00 (equality for a single direction), so the ratios
//! of (5) and (6) never exceed √3; an SH that rings or a noisy gather can break that where
//! the mean is near zero, and the ratio would then blow up (z grows as |d|²/c_00): both are
//! clamped to √3, as Geomerics' r is to 1.
//!
//! c_00 ≤ 0 (a black texel, or a truncated SH with no mean): Geomerics gives 0,
//! hallucinated ZH3 and L1 luminance drop their non-linear or directional term. d_lum = 0
//! (no direction): the ZH3 axis is undefined and the zonal term is dropped (stored as 0).
//! |R_1| = 0: Geomerics is R_0. q is clamped to [0, 1] so the pole opposite R̂_1 gives
//! exactly 0^p = 0.

use glam::DVec3;

use super::basis::eval_basis;
use super::window::{Taper, deringing_width_on_grid};
use super::zonal::clamped_cosine_convolution;
use super::{Order, sh_index};

/// Rec. 709 luminance weights.
pub const LUMINANCE: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// y_00 = 1/(2√π).
const Y00: f64 = 0.282_094_791_773_878_14;
/// K_1 = √(3/4π).
const K1: f64 = 0.488_602_511_902_919_9;
/// The largest |d| / c_00 of non-negative radiance (module doc, degenerate inputs).
const SQRT_3: f64 = 1.732_050_807_568_877_2;
/// √(5/16π), the zonal harmonic Y_20(t) = this · (3t² − 1).
const K20: f64 = 0.315_391_565_252_520_05;

/// The hallucination curve of ZH3 (5): z = c_00 (ZH3_LINEAR r + ZH3_QUADRATIC r²).
pub const ZH3_LINEAR: f64 = 0.08;
pub const ZH3_QUADRATIC: f64 = 0.6;

/// An encoding of order-3 RGB radiance SH and its reconstruction (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShBasis {
    /// (1): 4 coefficients per colour, linear.
    L1,
    /// (2): the same 12 values, Geomerics' non-linear curve.
    L1Geomerics,
    /// (5): the same 12 values, a zonal quadratic term hallucinated from them.
    L1Zh3Hallucinated,
    /// (4): L1 plus one stored zonal coefficient per colour, 15 values.
    Zh3,
    /// (6): RGB ambient plus the luminance's linear band, 6 values.
    L1Luminance,
    /// (7): all 9 coefficients per colour, 27 values (`shlmap`).
    L2,
    /// (8): (7) windowed so that irradiance is non-negative.
    L2Deringed,
}

impl ShBasis {
    pub const ALL: [ShBasis; 7] = [
        ShBasis::L1,
        ShBasis::L1Geomerics,
        ShBasis::L1Zh3Hallucinated,
        ShBasis::Zh3,
        ShBasis::L1Luminance,
        ShBasis::L2,
        ShBasis::L2Deringed,
    ];

    /// A short label for tables: "L1 linear", "ZH3 stored"…
    pub fn label(self) -> &'static str {
        match self {
            ShBasis::L1 => "L1 linear",
            ShBasis::L1Geomerics => "L1 Geomerics",
            ShBasis::L1Zh3Hallucinated => "L1 + hallucinated ZH3",
            ShBasis::Zh3 => "ZH3 stored",
            ShBasis::L1Luminance => "L1 luminance",
            ShBasis::L2 => "L2",
            ShBasis::L2Deringed => "L2 deringed",
        }
    }

    /// Values [`Self::encode`] stores (RGB counted three times).
    pub fn stored_values(self) -> usize {
        match self {
            ShBasis::L1 | ShBasis::L1Geomerics | ShBasis::L1Zh3Hallucinated => 12,
            ShBasis::Zh3 => 15,
            ShBasis::L1Luminance => 6,
            ShBasis::L2 | ShBasis::L2Deringed => 27,
        }
    }

    /// The basis that evaluates the same stored values linearly: `L1` for the non-linear
    /// L1 reconstructions, itself otherwise. The error ladder's "basis" rung uses it, the
    /// "reconstruction" rung the basis itself.
    pub fn linear(self) -> ShBasis {
        match self {
            ShBasis::L1Geomerics | ShBasis::L1Zh3Hallucinated => ShBasis::L1,
            ShBasis::L1
            | ShBasis::Zh3
            | ShBasis::L1Luminance
            | ShBasis::L2
            | ShBasis::L2Deringed => self,
        }
    }

    /// What a texel stores for order-3 RGB radiance coefficients `radiance` (at least 9):
    /// values 3k + c are colour c of stored coefficient k, in the order of the module doc —
    /// L1: c_00, c_1−1, c_10, c_11; ZH3: those and z; L1 luminance: c_00 (RGB), then
    /// e = d_lum's SH coefficients (e_1−1, e_10, e_11) as values 3..6; L2: the 9.
    /// `shaded`: the normals the texel is shaded with — the hemisphere about this axis (a
    /// lightmap texel's geometric normal), or with `None` the whole sphere; only the
    /// deringing (8) looks at it.
    ///
    /// # Panics
    /// If `radiance` holds fewer than 9 coefficients.
    pub fn encode(self, radiance: &[[f64; 3]], shaded: Option<DVec3>) -> Vec<f64> {
        assert!(radiance.len() >= 9, "order-3 radiance needed");
        let rgb = |k: usize| radiance[k];
        let flat = |coeffs: &[[f64; 3]]| coeffs.iter().flatten().copied().collect::<Vec<f64>>();
        match self {
            ShBasis::L1 | ShBasis::L1Geomerics | ShBasis::L1Zh3Hallucinated => flat(&radiance[..4]),
            ShBasis::Zh3 => {
                let mut v = flat(&radiance[..4]);
                let z = match zh3_axis(&radiance[..4]) {
                    Some(axis) => zonal_projection(radiance, axis),
                    None => [0.0; 3],
                };
                v.extend(z);
                v
            }
            ShBasis::L1Luminance => {
                let mut v = rgb(0).to_vec();
                v.extend((1..4).map(|k| luminance(rgb(k))));
                v
            }
            ShBasis::L2 => flat(&radiance[..9]),
            ShBasis::L2Deringed => {
                let mut c: Vec<[f64; 3]> = radiance[..9].to_vec();
                if let Some(w) = deringing_width_rgb(&c, shaded) {
                    for l in 1..3i32 {
                        let sigma = Taper::Hanning.sigma(l as u32, w);
                        for m in -l..=l {
                            for v in &mut c[sh_index(l, m)] {
                                *v *= sigma;
                            }
                        }
                    }
                }
                flat(&c)
            }
        }
    }

    /// Irradiance E(n) (RGB, not clamped) from `stored` values of [`Self::encode`]'s layout
    /// at unit `n` (module doc).
    ///
    /// # Panics
    /// If `stored` holds fewer than [`Self::stored_values`] values.
    pub fn irradiance(self, stored: &[f64], n: DVec3) -> [f64; 3] {
        assert!(stored.len() >= self.stored_values(), "short stored data");
        let coeff = |k: usize| [stored[3 * k], stored[3 * k + 1], stored[3 * k + 2]];
        let l1 = || -> [[f64; 3]; 4] { std::array::from_fn(coeff) };
        match self {
            ShBasis::L1 => l1_linear(&l1(), n),
            ShBasis::L1Geomerics => {
                let l1 = l1();
                std::array::from_fn(|c| {
                    let d = linear_vector(&l1, c);
                    geomerics(A0 * Y00 * l1[0][c], 0.5 * A1 * K1 * d, n)
                })
            }
            ShBasis::L1Zh3Hallucinated => {
                let l1 = l1();
                let linear = l1_linear(&l1, n);
                let Some(axis) = zh3_axis(&l1) else {
                    return linear;
                };
                std::array::from_fn(|c| {
                    let c00 = l1[0][c];
                    let z = if c00 > 0.0 {
                        let r = (linear_vector(&l1, c).dot(axis).abs() / c00).min(SQRT_3);
                        c00 * (ZH3_LINEAR * r + ZH3_QUADRATIC * r * r)
                    } else {
                        0.0
                    };
                    linear[c] + A2 * z * zonal_y20(axis.dot(n))
                })
            }
            ShBasis::Zh3 => {
                let l1 = l1();
                let linear = l1_linear(&l1, n);
                let z = coeff(4);
                let Some(axis) = zh3_axis(&l1) else {
                    return linear;
                };
                let y = zonal_y20(axis.dot(n));
                std::array::from_fn(|c| linear[c] + A2 * z[c] * y)
            }
            ShBasis::L1Luminance => {
                let ambient = [stored[0], stored[1], stored[2]];
                let e = DVec3::new(-stored[5], -stored[3], stored[4]);
                let mean_lum = luminance(ambient);
                let directional = if mean_lum > 0.0 {
                    let e = e.clamp_length_max(SQRT_3 * mean_lum);
                    A1 * K1 * e.dot(n) / mean_lum
                } else {
                    0.0
                };
                std::array::from_fn(|c| A0 * Y00 * ambient[c] + ambient[c] * directional)
            }
            ShBasis::L2 | ShBasis::L2Deringed => {
                let mut y = [0.0; 9];
                eval_basis(Order::THREE, n, &mut y);
                let mut e = [0.0; 3];
                for (k, yk) in y.iter().enumerate() {
                    let a = clamped_cosine_convolution(band_of(k));
                    for (c, ec) in e.iter_mut().enumerate() {
                        *ec += a * stored[3 * k + c] * yk;
                    }
                }
                e
            }
        }
    }
}

const A0: f64 = std::f64::consts::PI;
const A1: f64 = 2.0 * std::f64::consts::PI / 3.0;
const A2: f64 = std::f64::consts::PI / 4.0;

fn band_of(k: usize) -> u32 {
    match k {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// Σ_c w_c v_c.
pub fn luminance(v: [f64; 3]) -> f64 {
    LUMINANCE[0] * v[0] + LUMINANCE[1] * v[1] + LUMINANCE[2] * v[2]
}

/// d = (−c_11, −c_1−1, c_10) of channel `c` (module doc).
fn linear_vector(l1: &[[f64; 3]], c: usize) -> DVec3 {
    DVec3::new(-l1[3][c], -l1[1][c], l1[2][c])
}

/// (1) for every channel.
fn l1_linear(l1: &[[f64; 3]], n: DVec3) -> [f64; 3] {
    std::array::from_fn(|c| A0 * Y00 * l1[0][c] + A1 * K1 * linear_vector(l1, c).dot(n))
}

/// (2) for one channel, from the mean irradiance `r0` and half the linear term `r1`.
pub fn geomerics(r0: f64, r1: DVec3, n: DVec3) -> f64 {
    if r0 <= 0.0 {
        return 0.0;
    }
    let len = r1.length();
    if len == 0.0 {
        return r0;
    }
    let r = (len / r0).min(1.0);
    let q = (0.5 * (1.0 + n.dot(r1 / len))).clamp(0.0, 1.0);
    let p = 1.0 + 2.0 * r;
    let a = (1.0 - r) / (1.0 + r);
    r0 * (a + (1.0 - a) * (p + 1.0) * q.powf(p))
}

/// (3): the luminance's linear direction, or `None` when it has none.
pub fn zh3_axis(l1: &[[f64; 3]]) -> Option<DVec3> {
    let d = DVec3::new(-luminance(l1[3]), -luminance(l1[1]), luminance(l1[2]));
    let len = d.length();
    (len > 0.0 && len.is_finite()).then(|| d / len)
}

/// Y_20 about an axis at cos t: √(5/16π)(3t² − 1).
fn zonal_y20(t: f64) -> f64 {
    K20 * (3.0 * t * t - 1.0)
}

/// (4)'s z per channel: the projection of band 2 onto the zonal harmonic about `axis`.
fn zonal_projection(radiance: &[[f64; 3]], axis: DVec3) -> [f64; 3] {
    let mut y = [0.0; 9];
    eval_basis(Order::THREE, axis, &mut y);
    let scale = (4.0 * std::f64::consts::PI / 5.0).sqrt();
    std::array::from_fn(|c| scale * (4..9).map(|k| radiance[k][c] * y[k]).sum::<f64>())
}

/// (8)'s width: the smallest over RGB of the gentlest Hanning width that makes each
/// channel's irradiance non-negative over the shaded normals (the hemisphere about
/// `shaded`, else the sphere), or `None` when none rings negative there.
fn deringing_width_rgb(radiance: &[[f64; 3]], shaded: Option<DVec3>) -> Option<f64> {
    let hemisphere: Vec<DVec3>;
    let grid = match shaded {
        Some(axis) if axis.length_squared() > 0.0 => {
            hemisphere = deringing_grid()
                .iter()
                .copied()
                .filter(|d| d.dot(axis) >= 0.0)
                .collect();
            &hemisphere[..]
        }
        _ => deringing_grid(),
    };
    let irradiance: [Vec<f64>; 3] = std::array::from_fn(|c| {
        (0..9)
            .map(|k| clamped_cosine_convolution(band_of(k)) * radiance[k][c])
            .collect()
    });
    let w = irradiance
        .iter()
        .filter_map(|e| {
            deringing_width_on_grid(Taper::Hanning, e, Order::THREE, grid, DERINGING_REL)
        })
        .reduce(f64::min)?;
    // The minimum need not be monotonic in w: a channel non-negative at its own width may
    // dip at a narrower one. Then the strongest window (the mean alone) is used.
    let all_non_negative = irradiance.iter().all(|e| {
        let mut windowed = e.clone();
        for (k, v) in windowed.iter_mut().enumerate() {
            *v *= Taper::Hanning.sigma(band_of(k), w);
        }
        grid.iter()
            .all(|&d| super::project::eval(&windowed, Order::THREE, d) >= 0.0)
    });
    Some(if all_non_negative { w } else { 1.0 })
}

/// Relative precision of (8)'s width.
const DERINGING_REL: f64 = 1e-4;

/// (8)'s directions: 16 × 32 of an exact sphere quadrature, dense enough for order-3
/// irradiance that a dip between them stays within a few 10⁻³ of the mean (the shader
/// clamps it to 0).
fn deringing_grid() -> &'static [DVec3] {
    static GRID: std::sync::OnceLock<Vec<DVec3>> = std::sync::OnceLock::new();
    GRID.get_or_init(|| {
        super::project::sphere_quadrature(16)
            .into_iter()
            .map(|(d, _)| d)
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::project::{project_fn, sphere_quadrature};

    /// f64 sums of a few products.
    const TIGHT: f64 = 1e-12;

    /// Order-3 RGB radiance SH of a unit-solid-angle delta of `rgb` from `dir` plus a
    /// uniform `ambient`.
    fn delta_plus_ambient(dir: DVec3, rgb: [f64; 3], ambient: f64) -> Vec<[f64; 3]> {
        let mut y = [0.0; 9];
        eval_basis(Order::THREE, dir.normalize(), &mut y);
        (0..9)
            .map(|k| {
                std::array::from_fn(|c| rgb[c] * y[k] + if k == 0 { ambient / Y00 } else { 0.0 })
            })
            .collect()
    }

    fn sphere_dirs() -> Vec<DVec3> {
        sphere_quadrature(24).into_iter().map(|(d, _)| d).collect()
    }

    #[test]
    fn l2_is_the_clamped_cosine_convolution_and_l1_its_first_two_bands() {
        let radiance = delta_plus_ambient(DVec3::new(0.3, -0.5, 0.8), [1.0, 0.5, 0.25], 0.2);
        for n in sphere_dirs() {
            let full = ShBasis::L2.irradiance(&ShBasis::L2.encode(&radiance, None), n);
            let want = crate::sh::zonal::eval_rgb(
                &crate::sh::zonal::irradiance_from_radiance(&radiance, Order::THREE),
                Order::THREE,
                n,
            );
            for c in 0..3 {
                assert!((full[c] - want[c]).abs() < TIGHT, "{n}");
            }
            let mut truncated = radiance.clone();
            for k in truncated.iter_mut().skip(4) {
                *k = [0.0; 3];
            }
            let want = ShBasis::L2.irradiance(&ShBasis::L2.encode(&truncated, None), n);
            let l1 = ShBasis::L1.irradiance(&ShBasis::L1.encode(&radiance, None), n);
            for c in 0..3 {
                assert!((l1[c] - want[c]).abs() < TIGHT, "{n}");
            }
        }
    }

    #[test]
    fn a_lone_direction_is_reconstructed_as_each_formula_says() {
        // One direction of unit radiance·solid angle: E(n) = max(0, n·ω) exactly.
        let w = DVec3::new(0.0, 0.0, 1.0);
        let radiance = delta_plus_ambient(w, [1.0; 3], 0.0);
        // Geomerics: r = 1, p = 3, a = 0: E = R_0 · 4 q³ with R_0 = 1/4, so E(ω) = 1 and
        // E(−ω) = 0 exactly — the true values at the poles of its own axis.
        let geo = |n: DVec3| {
            ShBasis::L1Geomerics.irradiance(&ShBasis::L1Geomerics.encode(&radiance, None), n)[0]
        };
        assert!((geo(w) - 1.0).abs() < TIGHT, "{}", geo(w));
        assert!(geo(-w).abs() < TIGHT, "{}", geo(-w));
        let side = DVec3::X;
        assert!((geo(side) - 0.125).abs() < TIGHT, "{}", geo(side));
        // Linear L1: 1/4 + ½ cos θ.
        let lin = ShBasis::L1.irradiance(&ShBasis::L1.encode(&radiance, None), w)[0];
        assert!((lin - 0.75).abs() < TIGHT);
        // Stored ZH3 of a zonal function about its own axis is L2 exactly.
        for n in sphere_dirs() {
            let zh3 = ShBasis::Zh3.irradiance(&ShBasis::Zh3.encode(&radiance, None), n)[0];
            let l2 = ShBasis::L2.irradiance(&ShBasis::L2.encode(&radiance, None), n)[0];
            assert!((zh3 - l2).abs() < TIGHT, "{n}: {zh3} vs {l2}");
        }
    }

    #[test]
    fn hallucinated_zh3_matches_the_paper_by_hand() {
        // L1 with c_00 = 1 and c_10 = 0.5 (d = (0, 0, 0.5)): â = +z, r = 0.5,
        // z = 1 · (0.08·0.5 + 0.6·0.25) = 0.19. At n = +z:
        // E = π·y00·1 + (2π/3)·K1·0.5 + (π/4)·0.19·√(5/16π)·2
        //   = 0.886226925 + 0.511663354 + 0.094129023 = 1.492019303.
        let mut radiance = vec![[0.0; 3]; 9];
        radiance[0] = [1.0; 3];
        radiance[2] = [0.5; 3];
        let e = ShBasis::L1Zh3Hallucinated.irradiance(
            &ShBasis::L1Zh3Hallucinated.encode(&radiance, None),
            DVec3::Z,
        );
        assert!((e[0] - 1.492_019_303).abs() < 1e-8, "{e:?}");
        // At the equator, Y_20 = −√(5/16π): E = 0.886226925 − (π/4)·0.19·0.315391565.
        let e = ShBasis::L1Zh3Hallucinated.irradiance(
            &ShBasis::L1Zh3Hallucinated.encode(&radiance, None),
            DVec3::X,
        );
        assert!(
            (e[0] - (0.886_226_925 - 0.047_064_512)).abs() < 1e-8,
            "{e:?}"
        );
    }

    #[test]
    fn degenerate_inputs_stay_finite() {
        let zero = vec![[0.0; 3]; 9];
        // L1 of zero length with a mean: no axis, ZH3 falls back to L1, Geomerics to R_0.
        let mut ambient = zero.clone();
        ambient[0] = [2.0; 3];
        // L0 = 0 with a direction (a truncated SH's radiance).
        let mut no_mean = zero.clone();
        no_mean[2] = [0.3; 3];
        for radiance in [&zero, &ambient, &no_mean] {
            for basis in ShBasis::ALL {
                let stored = basis.encode(radiance, None);
                assert_eq!(stored.len(), basis.stored_values());
                for n in sphere_dirs() {
                    let e = basis.irradiance(&stored, n);
                    assert!(e.iter().all(|v| v.is_finite()), "{basis:?} {n} {e:?}");
                }
            }
        }
        for basis in ShBasis::ALL {
            let e = basis.irradiance(&basis.encode(&zero, None), DVec3::Y);
            assert_eq!(e, [0.0; 3], "{basis:?}: a black texel is black");
            let want = A0 * Y00 * 2.0;
            let e = basis.irradiance(&basis.encode(&ambient, None), DVec3::Y);
            assert!(
                e.iter().all(|v| (v - want).abs() < TIGHT),
                "{basis:?} {e:?}"
            );
        }
        assert!(zh3_axis(&zero[..4]).is_none());
        // A mean near zero under a strong direction: the ratios are clamped to √3, so the
        // reconstructions stay of the order of the mean, not of |d|²/c00.
        let mut ringing = zero.clone();
        ringing[0] = [1e-3; 3];
        ringing[2] = [0.5; 3];
        for basis in [ShBasis::L1Zh3Hallucinated, ShBasis::L1Luminance] {
            let e = basis.irradiance(&basis.encode(&ringing, None), DVec3::Z)[0];
            let linear = ShBasis::L1.irradiance(&ShBasis::L1.encode(&ringing, None), DVec3::Z)[0];
            assert!(e.abs() < 10.0 * 1e-3 + linear.abs(), "{basis:?}: {e}");
            let bound = 1e-3 * (A0 * Y00 + A1 * K1 * SQRT_3);
            if basis == ShBasis::L1Luminance {
                assert!(e <= bound * (1.0 + 1e-12), "{e} > {bound}");
            }
        }
        // Geomerics and L1 luminance with no mean: no light from the curve, no direction.
        let g =
            ShBasis::L1Geomerics.irradiance(&ShBasis::L1Geomerics.encode(&no_mean, None), DVec3::Z);
        assert_eq!(g, [0.0; 3]);
        let l =
            ShBasis::L1Luminance.irradiance(&ShBasis::L1Luminance.encode(&no_mean, None), DVec3::Z);
        assert_eq!(l, [0.0; 3]);
    }

    #[test]
    fn a_sun_of_1e5_scales_every_basis_linearly() {
        let dir = DVec3::new(0.4, 0.7, -0.3);
        let sky = delta_plus_ambient(dir, [1.0, 0.9, 0.7], 0.3);
        let sun: Vec<[f64; 3]> = delta_plus_ambient(dir, [1e5, 0.9e5, 0.7e5], 0.3e5);
        for basis in ShBasis::ALL {
            for n in sphere_dirs() {
                let a = basis.irradiance(&basis.encode(&sky, None), n);
                let b = basis.irradiance(&basis.encode(&sun, None), n);
                for c in 0..3 {
                    assert!(b[c].is_finite());
                    assert!(
                        (b[c] - 1e5 * a[c]).abs() <= 1e-9 * 1e5 * (1.0 + a[c].abs()),
                        "{basis:?} {n}"
                    );
                }
            }
        }
    }

    #[test]
    fn deringing_removes_the_negative_lobe_of_a_small_sun_and_keeps_the_mean() {
        let radiance = delta_plus_ambient(DVec3::new(0.2, 0.9, 0.1), [10.0, 9.0, 8.0], 0.05);
        let dirs = sphere_dirs();
        let min_of = |basis: ShBasis| {
            let stored = basis.encode(&radiance, None);
            dirs.iter()
                .flat_map(|&n| basis.irradiance(&stored, n))
                .fold(f64::INFINITY, f64::min)
        };
        assert!(min_of(ShBasis::L2) < -0.1, "the plain L2 rings");
        // Non-negative on the search grid; between its points within 3·10⁻³ of the mean.
        let mean = A0 * Y00 * radiance[0][0];
        let dip = min_of(ShBasis::L2Deringed);
        assert!(dip > -3e-3 * mean, "{dip} (mean {mean})");
        let plain = ShBasis::L2.encode(&radiance, None);
        let deringed = ShBasis::L2Deringed.encode(&radiance, None);
        assert_eq!(plain[..3], deringed[..3]);
        // Over the hemisphere of a texel's normal: non-negative there, and gentler (closer
        // to the plain L2) than over the whole sphere.
        let up = DVec3::new(0.0, 1.0, 0.0);
        let hemi = ShBasis::L2Deringed.encode(&radiance, Some(up));
        let hemi_min = dirs
            .iter()
            .filter(|n| n.dot(up) >= 0.0)
            .flat_map(|&n| ShBasis::L2Deringed.irradiance(&hemi, n))
            .fold(f64::INFINITY, f64::min);
        assert!(hemi_min > -3e-3 * mean, "{hemi_min}");
        let distance =
            |a: &[f64]| -> f64 { a.iter().zip(&plain).map(|(x, y)| (x - y).abs()).sum() };
        assert!(
            distance(&hemi) < distance(&deringed),
            "the hemisphere window is gentler"
        );
        // Non-negative irradiance is left alone.
        let soft = delta_plus_ambient(DVec3::Z, [1.0; 3], 2.0);
        assert_eq!(
            ShBasis::L2.encode(&soft, None),
            ShBasis::L2Deringed.encode(&soft, None)
        );
    }

    #[test]
    fn stored_zh3_is_the_least_squares_zonal_coefficient() {
        // Project a function exactly, then check that z minimises the error of L1 + z·Y20(â)
        // against the function's band 2 over the sphere (the derivative in z vanishes).
        let f = |d: DVec3| (1.0 + 0.8 * d.x + 0.5 * d.y * d.y - 0.3 * d.x * d.z).max(0.0);
        let coeffs = project_fn(Order::THREE, f, 64);
        let radiance: Vec<[f64; 3]> = coeffs.iter().map(|&v| [v; 3]).collect();
        let stored = ShBasis::Zh3.encode(&radiance, None);
        let axis = zh3_axis(&radiance[..4]).unwrap();
        let z = stored[12];
        let grad: f64 = sphere_quadrature(24)
            .into_iter()
            .map(|(d, w)| {
                let mut y = [0.0; 9];
                eval_basis(Order::THREE, d, &mut y);
                let band2: f64 = (4..9).map(|k| coeffs[k] * y[k]).sum();
                let yz = zonal_y20(axis.dot(d));
                w * (z * yz - band2) * yz
            })
            .sum();
        assert!(grad.abs() < 1e-10, "{grad}");
    }
}
