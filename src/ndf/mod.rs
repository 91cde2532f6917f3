//! Normal distribution mapping (Olano & North, UNC TR 97-041): a normal map's
//! normals as a field of 3D Gaussians whose nine linear moments MIP-map exactly, and the
//! specular lobe evaluated from them.
//!
//! **Moments** (§5). A texel with unit normal n and base spread σ (the surface's own
//! roughness, a parameter) is the 3D Gaussian with mean u = n and covariance σ²I, i.e.
//! first moment E[x] = n and second moments E[xxᵀ] = nnᵀ + σ²I. A MIP texel is the
//! equal-weight mixture of the texels it covers, and the best single Gaussian of a mixture
//! has the mixture's moments (the paper's mixture rule):
//!
//! ```text
//! u_mix = Σ p_i u_i,   E[xxᵀ]_mix = Σ p_i E[xxᵀ]_i,   S_mix = E[xxᵀ]_mix − u_mix u_mixᵀ
//! ```
//!
//! so averaging the nine moments (no renormalisation) *is* the filter, in the box MIP chain
//! and in the hardware's trilinear interpolation alike. They are stored as three RGBA32F
//! textures (dx9) or the three layers of one array (dx10, dx11): (E[x], E[y], E[z], 1/N),
//! (E[xx], E[yy], E[zz], 0), (E[xy], E[xz], E[yz], 0) in the normal map's tangent space.
//! RGBA32F, not the paper's 16 bits: S = E[xxᵀ] − uuᵀ cancels to σ² ≈ 10⁻² against terms
//! of ≈ 1, and f16's 2⁻¹¹ relative step would be a 5–20 % error in S for σ = 0.1–0.05.
//!
//! **Density** (§6). With d = (h − u)ᵀ S⁻¹ (h − u) at the half vector h, the Pearson type
//! II kernel g(t) = max(0, 1 − t/2m)^m, m = 8, approximates the Gaussian's e^(−t/2) (the
//! paper prints the divisor as "2^m", which does not tend to the Gaussian; 2m does), and
//!
//! ```text
//! D_partial(h) = κ₀ · g(d) / √det S                    (partial normalisation, the paper's choice)
//! D_full(h)    = g(d) / (√det S · N(u, S)),  N = ∫_S² g(d(x)) / √det S dω(x)   (per MIP texel)
//! ```
//!
//! κ₀ = 1/N(n, σ²I) makes both equal the normalized base lobe at full resolution, where the
//! reference evaluates it texel by texel; N is integrated numerically per texel of every
//! level ([`normalization`]) and interpolated by the hardware (the paper's "MIP-map of
//! normalization factors", an approximation between texels).

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::scene::{HeightField, Texture8, decode_normal};

/// The moment maps' texel format on the GPU (every path; the cost model prices lookups
/// into it as `cost::Kind::TrilinearWide`).
pub const MOMENT_FORMAT: ash::vk::Format = ash::vk::Format::R32G32B32A32_SFLOAT;

/// The Pearson type II exponent m (the paper's eight).
pub const PEARSON_M: f64 = 8.0;
/// Smallest base spread accepted (S must stay invertible in f32).
pub const MIN_SIGMA: f32 = 0.01;
/// Largest base spread accepted.
pub const MAX_SIGMA: f32 = 1.0;
/// Rings × azimuths of the normalization quadrature.
const QUADRATURE: (usize, usize) = (32, 32);

/// g(t) = max(0, 1 − t/2m)^m.
pub fn pearson(t: f64) -> f64 {
    (1.0 - t / (2.0 * PEARSON_M)).max(0.0).powf(PEARSON_M)
}

/// Nine moments of one texel or MIP texel: E[x] and E[xxᵀ] (symmetric).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moments {
    pub mean: DVec3,
    pub second: DMat3,
}

impl Moments {
    /// A texel of unit normal `n` and base spread `sigma`: E[x] = n, E[xxᵀ] = nnᵀ + σ²I.
    pub fn of_normal(n: DVec3, sigma: f64) -> Moments {
        let outer = DMat3::from_cols(n * n.x, n * n.y, n * n.z);
        Moments {
            mean: n,
            second: outer + DMat3::IDENTITY * (sigma * sigma),
        }
    }

    /// The covariance S = E[xxᵀ] − uuᵀ.
    pub fn covariance(&self) -> DMat3 {
        let u = self.mean;
        self.second - DMat3::from_cols(u * u.x, u * u.y, u * u.z)
    }

    /// The equal-weight mixture of `parts` (mean and second moments averaged).
    pub fn mixture(parts: &[Moments]) -> Moments {
        let n = parts.len().max(1) as f64;
        Moments {
            mean: parts.iter().map(|m| m.mean).sum::<DVec3>() / n,
            second: parts.iter().fold(DMat3::ZERO, |s, m| s + m.second) * (1.0 / n),
        }
    }

    /// The 12 texture values (three RGBA texels; `inv_norm` in the first's alpha).
    pub fn texels(&self, inv_norm: f64) -> [[f32; 4]; 3] {
        let (u, m) = (self.mean, self.second);
        [
            [u.x as f32, u.y as f32, u.z as f32, inv_norm as f32],
            [m.x_axis.x as f32, m.y_axis.y as f32, m.z_axis.z as f32, 0.0],
            [m.y_axis.x as f32, m.z_axis.x as f32, m.z_axis.y as f32, 0.0],
        ]
    }

    /// The moments stored in three texels ([`Self::texels`]).
    pub fn from_texels(t: &[[f32; 4]; 3]) -> Moments {
        let f = |v: f32| f64::from(v);
        let (xy, xz, yz) = (f(t[2][0]), f(t[2][1]), f(t[2][2]));
        Moments {
            mean: DVec3::new(f(t[0][0]), f(t[0][1]), f(t[0][2])),
            second: DMat3::from_cols(
                DVec3::new(f(t[1][0]), xy, xz),
                DVec3::new(xy, f(t[1][1]), yz),
                DVec3::new(xz, yz, f(t[1][2])),
            ),
        }
    }

    /// g(d(h)) / √det S, unnormalized; 0 for a degenerate S.
    pub fn partial_density(&self, h: DVec3) -> f64 {
        let s = self.covariance();
        let det = s.determinant();
        if det.is_nan() || det <= 0.0 {
            return 0.0;
        }
        let r = h - self.mean;
        pearson(r.dot(s.inverse() * r)) / det.sqrt()
    }
}

/// N(u, S) = ∫_S² g(d(x))/√det S dω by a polar quadrature about u's direction over the
/// kernel's support (module doc); `None` for a degenerate S.
pub fn normalization(m: &Moments) -> Option<f64> {
    let s = m.covariance();
    let det = s.determinant();
    if det.is_nan() || det <= 0.0 {
        return None;
    }
    let inv = s.inverse();
    let u = m.mean;
    let len = u.length();
    let axis = if len > 1e-9 { u / len } else { DVec3::Z };
    // Support: d ≤ 2m, inside |x − u|² ≤ 2m λ_max ≤ 2m tr S.
    let r2 = 2.0 * PEARSON_M * (s.x_axis.x + s.y_axis.y + s.z_axis.z);
    let cos_max = if len > 1e-9 {
        ((1.0 + len * len - r2) / (2.0 * len)).clamp(-1.0, 1.0)
    } else {
        -1.0
    };
    let theta_max = cos_max.acos();
    let (e1, e2) = axis.any_orthonormal_pair();
    let (rings, azimuths) = QUADRATURE;
    let (dt, dp) = (
        theta_max / rings as f64,
        std::f64::consts::TAU / azimuths as f64,
    );
    let mut sum = 0.0;
    for i in 0..rings {
        let theta = (i as f64 + 0.5) * dt;
        let (st, ct) = theta.sin_cos();
        for j in 0..azimuths {
            let (sp, cp) = ((j as f64 + 0.5) * dp).sin_cos();
            let x = axis * ct + (e1 * cp + e2 * sp) * st;
            let r = x - u;
            sum += pearson(r.dot(inv * r)) * st;
        }
    }
    Some(sum * dt * dp / det.sqrt())
}

/// The NDF MIP chain of a normal map: per level (width, height, three RGBA32F images).
#[derive(Clone, Debug)]
pub struct NdfMaps {
    pub sigma: f32,
    /// κ₀ = 1/N(n, σ²I) (module doc).
    pub kappa0: f64,
    pub levels: Vec<NdfLevel>,
}

/// One MIP level: `textures[k]` is image k's texels, row-major.
#[derive(Clone, Debug)]
pub struct NdfLevel {
    pub width: u32,
    pub height: u32,
    pub textures: [Vec<[f32; 4]>; 3],
}

impl NdfLevel {
    /// The moments of texel `i`.
    pub fn moments(&self, i: usize) -> Moments {
        Moments::from_texels(&[
            self.textures[0][i],
            self.textures[1][i],
            self.textures[2][i],
        ])
    }
}

/// Builds the NDF maps of `normal_map` with base spread `sigma` (module doc): level 0 from
/// the decoded normals, each further level the 2×2 box average of the moments (the
/// material textures' chain, [`crate::scene::mip::box_mip_levels`]), then 1/N per texel.
pub fn build(normal_map: &Texture8, normal_scale: f32, sigma: f32) -> NdfMaps {
    let s = f64::from(sigma);
    let mut levels = moment_levels(normal_map, normal_scale, s);
    let base = normalization(&Moments::of_normal(DVec3::Z, s)).unwrap_or(1.0);
    for (l, level) in levels.iter_mut().enumerate() {
        let inv: Vec<f32> = (0..level.textures[0].len())
            .into_par_iter()
            .map(|i| {
                let n = if l == 0 {
                    Some(base)
                } else {
                    normalization(&level.moments(i))
                };
                n.map_or(0.0, |n| (1.0 / n) as f32)
            })
            .collect();
        for (t, v) in level.textures[0].iter_mut().zip(inv) {
            t[3] = v;
        }
    }
    NdfMaps {
        sigma,
        kappa0: 1.0 / base,
        levels,
    }
}

/// The moments of the normal map's own normals, without a base spread or normalisation
/// (σ = 0, 1/N = 0): what the diffuse filtering of [`diffuse`] reads, E[nnᵀ] of unit
/// normals having trace 1.
pub fn moment_maps(normal_map: &Texture8, normal_scale: f32) -> NdfMaps {
    NdfMaps {
        sigma: 0.0,
        kappa0: 0.0,
        levels: moment_levels(normal_map, normal_scale, 0.0),
    }
}

/// The moments of a height field's own normals (σ = 0, as [`moment_maps`]): the surface a
/// normal map is derived from, without its 8-bit quantization (the house's bricks;
/// `HeightField::normal`, the same central differences).
pub fn moment_maps_from_height(field: &HeightField) -> NdfMaps {
    let normals = (0..field.width * field.height)
        .map(|i| field.normal(i % field.width, i / field.width))
        .collect();
    NdfMaps {
        sigma: 0.0,
        kappa0: 0.0,
        levels: levels_of_normals(field.width as u32, field.height as u32, normals, 0.0),
    }
}

/// The box MIP chain of the moments of `normal_map`'s texels with base spread `sigma`.
fn moment_levels(normal_map: &Texture8, normal_scale: f32, sigma: f64) -> Vec<NdfLevel> {
    let normals = normal_map
        .texels
        .iter()
        .map(|&t| decode_normal(t, normal_scale).as_dvec3())
        .collect();
    levels_of_normals(normal_map.width, normal_map.height, normals, sigma)
}

/// The box MIP chain of the moments of unit `normals` (w × h, row-major), spread `sigma`.
fn levels_of_normals(w: u32, h: u32, normals: Vec<DVec3>, sigma: f64) -> Vec<NdfLevel> {
    let level0: Vec<[[f32; 4]; 3]> = normals
        .into_iter()
        .map(|n| Moments::of_normal(n, sigma).texels(0.0))
        .collect();
    type Chain = Vec<(u32, u32, Vec<[f32; 4]>)>;
    let chains: Vec<Chain> = (0..3)
        .map(|k| crate::scene::mip::box_mip_levels(w, h, level0.iter().map(|t| t[k]).collect()))
        .collect();
    (0..chains[0].len())
        .map(|l| NdfLevel {
            width: chains[0][l].0,
            height: chains[0][l].1,
            textures: [0, 1, 2].map(|k| chains[k][l].2.clone()),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pearson_tends_to_the_gaussian_and_has_compact_support() {
        assert_eq!(pearson(0.0), 1.0);
        assert!((pearson(1.0) - (-0.5f64).exp()).abs() < 0.01);
        assert_eq!(pearson(16.0), 0.0);
        assert_eq!(pearson(40.0), 0.0);
    }

    #[test]
    fn normalization_integrates_the_density_to_one() {
        // Brute force over a fine Fibonacci sphere for a few moment sets.
        let cases = [
            Moments::of_normal(DVec3::Z, 0.1),
            Moments::of_normal(DVec3::new(0.6, 0.0, 0.8), 0.3),
            Moments::mixture(&[
                Moments::of_normal(DVec3::new(0.5, 0.0, 0.866), 0.08),
                Moments::of_normal(DVec3::new(-0.5, 0.0, 0.866), 0.08),
            ]),
        ];
        let n = 400_000;
        for m in cases {
            let norm = normalization(&m).unwrap();
            let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let mut sum = 0.0;
            for i in 0..n {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - z * z).sqrt();
                let (s, c) = (golden * i as f64).sin_cos();
                sum += m.partial_density(DVec3::new(r * c, r * s, z));
            }
            let brute = sum * 4.0 * std::f64::consts::PI / n as f64;
            assert!((norm / brute - 1.0).abs() < 0.01, "{norm} vs {brute}");
        }
    }

    #[test]
    fn mixture_rule_and_constant_maps() {
        let a = Moments::of_normal(DVec3::new(0.3, 0.1, 0.948_683_3).normalize(), 0.05);
        let b = Moments::of_normal(DVec3::new(-0.2, 0.4, 0.894_427_2).normalize(), 0.05);
        let mix = Moments::mixture(&[a, b]);
        assert!((mix.mean - (a.mean + b.mean) / 2.0).length() < 1e-15);
        // Covariance = E[xxᵀ] − uuᵀ: the spread between the means appears along a − b.
        let d = a.mean - b.mean;
        let expected =
            DMat3::IDENTITY * 0.0025 + DMat3::from_cols(d * d.x, d * d.y, d * d.z) * 0.25;
        let s = mix.covariance();
        for c in 0..3 {
            assert!((s.col(c) - expected.col(c)).length() < 1e-12);
        }
        // A constant normal map: every level keeps zero extra covariance (σ²I only).
        let map = Texture8 {
            width: 8,
            height: 8,
            texels: vec![[160, 100, 230, 255]; 64],
        };
        let maps = build(&map, 1.0, 0.1);
        assert_eq!(maps.levels.len(), 4);
        for level in &maps.levels {
            for i in 0..level.textures[0].len() {
                let s = level.moments(i).covariance();
                let extra = s - DMat3::IDENTITY * 0.01;
                assert!(
                    extra.to_cols_array().iter().all(|v| v.abs() < 1e-6),
                    "{extra:?}"
                );
                assert!(
                    (f64::from(level.textures[0][i][3]) - maps.kappa0).abs() < 1e-3 * maps.kappa0
                );
            }
        }
    }

    #[test]
    fn mip_levels_hold_the_moments_of_their_full_resolution_footprint() {
        let mut texels = Vec::new();
        for y in 0..16u32 {
            for x in 0..16u32 {
                let r = (128.0 + 100.0 * ((x * 7 + y * 3) as f32).sin()) as u8;
                let g = (128.0 + 90.0 * ((x * 5 + y * 11) as f32).cos()) as u8;
                texels.push([r, g, 200, 255]);
            }
        }
        let map = Texture8 {
            width: 16,
            height: 16,
            texels,
        };
        let maps = build(&map, 1.0, 0.05);
        for (l, level) in maps.levels.iter().enumerate() {
            let side = 1usize << l;
            for ty in 0..level.height as usize {
                for tx in 0..level.width as usize {
                    let parts: Vec<Moments> = (0..side * side)
                        .map(|k| {
                            let (x, y) = (tx * side + k % side, ty * side + k / side);
                            Moments::of_normal(
                                decode_normal(map.texels[y * 16 + x], 1.0).as_dvec3(),
                                0.05,
                            )
                        })
                        .collect();
                    let exact = Moments::mixture(&parts);
                    let got = level.moments(ty * level.width as usize + tx);
                    assert!((got.mean - exact.mean).length() < 1e-6, "level {l}");
                    for c in 0..3 {
                        assert!(
                            (got.second.col(c) - exact.second.col(c)).length() < 1e-6,
                            "level {l}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn height_field_moments_match_the_normal_map_derived_from_it() {
        let field = crate::scene::house::brick_height_field();
        let from_height = moment_maps_from_height(&field);
        let scene = crate::scene::house::build(64).unwrap();
        let from_map = moment_maps(&scene.material.normal, scene.material.normal_scale);
        assert_eq!(from_height.levels.len(), from_map.levels.len());
        for (lh, lm) in from_height.levels.iter().zip(&from_map.levels) {
            for i in 0..lh.textures[0].len() {
                let (a, b) = (lh.moments(i), lm.moments(i));
                // 8-bit quantization of the map: ≤ 1/127 per component, plus rounding.
                assert!(
                    (a.mean - b.mean).abs().max_element() < 0.012,
                    "{:?} {:?}",
                    a.mean,
                    b.mean
                );
                let tr = |m: &Moments| m.second.x_axis.x + m.second.y_axis.y + m.second.z_axis.z;
                assert!(
                    (tr(&a) - 1.0).abs() < 1e-5,
                    "unit normals' E[nnᵀ] has trace 1"
                );
            }
        }
        let coarse = from_height.levels.last().unwrap().moments(0);
        assert!(
            coarse.mean.length() < 0.999,
            "the bricks' normals spread: r = {}",
            coarse.mean.length()
        );
    }
}
