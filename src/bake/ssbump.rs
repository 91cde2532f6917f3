//! Self-shadowed bump maps (Green, "Efficient self-shadowed radiosity normal mapping",
//! Valve): the Half-Life 2 tangent-space basis, the D encoding of a normal
//! (eq. (3)) and its directional occlusion from a height field.
//!
//! **Basis.** Eq. (1) as printed lists B₀ twice, and its third vector (−√(2/3), 0, 1/√3) is
//! not orthogonal to the printed one. The basis meant — and the one the Source SDK ships
//! (`bumpvects.h`) — is
//!
//! ```text
//! B₀ = ( √(2/3),     0, 1/√3)    B₁ = (−1/√6,  1/√2, 1/√3)    B₂ = (−1/√6, −1/√2, 1/√3)
//! ```
//!
//! orthonormal (test), each 54.7° from the surface normal +Z, 120° apart around it.
//!
//! **D encoding.** D_i = saturate(N·B_i)² / Σ_j saturate(N·B_j)²; the unperturbed normal
//! (0, 0, 1) has N·B_i = 1/√3 for all i, so D = (⅓, ⅓, ⅓) exactly.
//!
//! **Directional occlusion.** From every texel of a height field (heights in texels, wrapped
//! at the borders: bump textures tile), `rays` directions spread uniformly over the upper
//! hemisphere (a seeded Hammersley set, the same for every texel) are marched through the
//! bilinearly interpolated field; channel i's occlusion is the visible fraction weighted by
//! each ray's saturate(ω·B_i) — "a smaller angular distribution centred upon the basis
//! vector" (the paper's wording) — and scalar AO the visible fraction weighted by ω·N, N the
//! texel's normal. The SSBump texel is D_i · occlusion_i.
//!
//! Tangent space follows DESIGN §1: +X along +u (image right), +Y image up (−v), +Z out.

use glam::DVec3;
use rayon::prelude::*;

use super::directions::{splitmix64, unit_f64};
use crate::scene::HeightField;

/// The HL2 basis (module doc).
pub fn hl2_basis() -> [DVec3; 3] {
    let (s3, s6, s2) = (3f64.sqrt(), 6f64.sqrt(), 2f64.sqrt());
    [
        DVec3::new((2.0f64 / 3.0).sqrt(), 0.0, 1.0 / s3),
        DVec3::new(-1.0 / s6, 1.0 / s2, 1.0 / s3),
        DVec3::new(-1.0 / s6, -1.0 / s2, 1.0 / s3),
    ]
}

/// Eq. (3): the blend weights of normal `n` (normalized first); the unperturbed weights
/// for a normal facing away from all three directions.
pub fn d_encoding(n: DVec3) -> [f64; 3] {
    let n = n.normalize_or(DVec3::Z);
    let dp = hl2_basis().map(|b| n.dot(b).clamp(0.0, 1.0).powi(2));
    let sum: f64 = dp.iter().sum();
    if sum > 0.0 {
        dp.map(|d| d / sum)
    } else {
        [1.0 / 3.0; 3]
    }
}

/// Per texel: directional occlusion per basis channel and scalar AO.
#[derive(Clone, Debug, PartialEq)]
pub struct Occlusion {
    pub channels: Vec<[f64; 3]>,
    pub ao: Vec<f64>,
}

/// `rays` directions uniform over the upper hemisphere (z > 0): a Hammersley set with a
/// seeded rotation about +Z.
pub fn hemisphere_directions(rays: usize, seed: u64) -> Vec<DVec3> {
    let turn = unit_f64(splitmix64(seed)) * std::f64::consts::TAU;
    (0..rays)
        .map(|i| {
            let u = (i as f64 + 0.5) / rays as f64;
            let v = f64::from((i as u32).reverse_bits()) / 4_294_967_296.0;
            let z = 1.0 - u; // uniform in z ∈ (0, 1]: uniform solid angle
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = v * std::f64::consts::TAU + turn;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// Whether the ray from the surface at texel (x, y) along `d` leaves the field unblocked:
/// marched in half-texel steps until it rises above the field's highest point — at most
/// ⌈(top − start) / rise per step⌉ steps, counted, so that no height makes it stall
/// (`scene::height_field::MAX_HEIGHT_SCALE` keeps the count modest).
fn escapes(field: &HeightField, top: f64, x: usize, y: usize, d: DVec3) -> bool {
    let start = field.h[y * field.width + x];
    let horizontal = d.truncate().length();
    if horizontal < 1e-12 {
        return true;
    }
    if d.z <= 0.0 {
        // Never rises: the hemisphere's directions have z > 0.
        return false;
    }
    // Image rows grow downward: +Y tangent is −row.
    let step = 0.5 / horizontal;
    let steps = ((top - start) / (d.z * step)).ceil().max(0.0) as u64 + 1;
    let origin = DVec3::new(x as f64, y as f64, start);
    for k in 1..=steps {
        let p = origin + d * (k as f64 * step);
        if p.z > top {
            return true;
        }
        if field.sample(p.x, 2.0 * y as f64 - p.y) > p.z {
            return false;
        }
    }
    true
}

/// Directional occlusion and AO of every texel of `field` with `rays` rays (module doc).
pub fn occlusion(field: &HeightField, rays: usize, seed: u64) -> Occlusion {
    let dirs = hemisphere_directions(rays, seed);
    let basis = hl2_basis();
    let top = field.h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let per_texel: Vec<([f64; 3], f64)> = (0..field.width * field.height)
        .into_par_iter()
        .map(|t| {
            let (x, y) = (t % field.width, t / field.width);
            let n = field.normal(x, y);
            let (mut vis, mut all) = ([0.0; 3], [0.0; 3]);
            let (mut ao_vis, mut ao_all) = (0.0, 0.0);
            for &d in &dirs {
                let free = escapes(field, top, x, y, d);
                for i in 0..3 {
                    let w = d.dot(basis[i]).max(0.0);
                    all[i] += w;
                    if free {
                        vis[i] += w;
                    }
                }
                let w = d.dot(n).max(0.0);
                ao_all += w;
                if free {
                    ao_vis += w;
                }
            }
            let channels =
                std::array::from_fn(|i| if all[i] > 0.0 { vis[i] / all[i] } else { 1.0 });
            (channels, if ao_all > 0.0 { ao_vis / ao_all } else { 1.0 })
        })
        .collect();
    Occlusion {
        channels: per_texel.iter().map(|p| p.0).collect(),
        ao: per_texel.iter().map(|p| p.1).collect(),
    }
}

/// The SSBump texels of `field`: D of each texel's normal times its channel occlusion; and
/// the plain D encoding.
pub fn ssbump(field: &HeightField, occ: &Occlusion) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let plain: Vec<[f64; 3]> = (0..field.width * field.height)
        .map(|t| d_encoding(field.normal(t % field.width, t / field.width)))
        .collect();
    let shadowed = plain
        .iter()
        .zip(&occ.channels)
        .map(|(d, o)| std::array::from_fn(|i| d[i] * o[i]))
        .collect();
    (shadowed, plain)
}

/// Rays per texel of the SSBump bake the techniques use (the `shvis ssbump` default, the
/// paper's "300 rays").
pub const DEFAULT_RAYS: usize = 300;

/// What `ssbump` and `rnmao` read from a material's height field: per texel of the field,
/// RGB = the SSBump (D · directional occlusion), A = scalar AO. Tiled by the material UVs
/// like the normal map (row 0 at v = 0).
#[derive(Clone, Debug, PartialEq)]
pub struct SsBumpMaps {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
    /// How the GPU stores the texels.
    pub storage: SsBumpStorage,
}

/// Texel format of the SSBump / AO texture on the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SsBumpStorage {
    /// RGBA8 UNORM, 4 bytes per texel: what Valve ships (and the normal map's format), the
    /// techniques' default.
    Unorm8,
    /// RGBA16F, 8 bytes per texel: to check the shader against Listing 1 at f16 precision.
    Float16,
}

impl SsBumpMaps {
    /// The self-shadowed maps of `field` with `rays` per texel.
    pub fn bake(field: &HeightField, rays: usize, seed: u64) -> SsBumpMaps {
        let occ = occlusion(field, rays, seed);
        let (shadowed, _) = ssbump(field, &occ);
        SsBumpMaps {
            width: field.width as u32,
            height: field.height as u32,
            texels: shadowed
                .iter()
                .zip(&occ.ao)
                .map(|(d, &ao)| [d[0] as f32, d[1] as f32, d[2] as f32, ao as f32])
                .collect(),
            storage: SsBumpStorage::Unorm8,
        }
    }

    /// The unoccluded maps of a tangent-space normal map (8-bit, decoded as the shader
    /// decodes it, x and y times `normal_scale`): D of each texel's normal, AO 1 —
    /// Listing 2's texture when nothing shadows, what makes it equal to Listing 1.
    pub fn unoccluded(normal_map: &crate::scene::Texture8, normal_scale: f32) -> SsBumpMaps {
        let decode = |c: u8| f64::from(c) / 255.0 * 2.0 - 1.0;
        SsBumpMaps {
            width: normal_map.width,
            height: normal_map.height,
            texels: normal_map
                .texels
                .iter()
                .map(|t| {
                    let s = f64::from(normal_scale);
                    let n = DVec3::new(decode(t[0]) * s, decode(t[1]) * s, decode(t[2]));
                    let d = d_encoding(n);
                    [d[0] as f32, d[1] as f32, d[2] as f32, 1.0]
                })
                .collect(),
            storage: SsBumpStorage::Unorm8,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_basis_is_orthonormal_and_flat_normals_encode_to_thirds() {
        let b = hl2_basis();
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((b[i].dot(b[j]) - want).abs() < 1e-15, "B{i}·B{j}");
            }
            // 54.7° from the normal, all three.
            assert!((b[i].z - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        }
        let d = d_encoding(DVec3::Z);
        assert!(d.iter().all(|&x| (x - 1.0 / 3.0).abs() < 1e-15), "{d:?}");
        // A normal along B0 puts all weight on channel 0.
        let d = d_encoding(b[0]);
        assert!(
            (d[0] - 1.0).abs() < 1e-15 && d[1] < 1e-15 && d[2] < 1e-15,
            "{d:?}"
        );
    }

    #[test]
    fn a_flat_field_is_unoccluded() {
        let field = HeightField {
            width: 8,
            height: 8,
            h: vec![2.0; 64],
        };
        let occ = occlusion(&field, 64, 1);
        assert!(occ.channels.iter().flatten().all(|&o| o == 1.0));
        assert!(occ.ao.iter().all(|&a| a == 1.0));
        let (shadowed, plain) = ssbump(&field, &occ);
        assert_eq!(shadowed, plain);
    }

    #[test]
    fn a_v_groove_matches_its_closed_form() {
        // A groove along image columns, walls at slope tan α, then a plateau: from the
        // bottom line a direction is blocked iff ω_z < |ω_x| tan α (module doc of the test).
        let alpha = 40f64.to_radians();
        let (w, h) = (96usize, 4usize);
        let centre = 48.0;
        let plateau = 30.0 * alpha.tan();
        let field = HeightField {
            width: w,
            height: h,
            h: (0..w * h)
                .map(|t| {
                    ((t % w) as f64 - centre)
                        .abs()
                        .mul_add(alpha.tan(), 0.0)
                        .min(plateau)
                })
                .collect(),
        };
        let rays = 8192;
        let occ = occlusion(&field, rays, 7);
        let bottom = 2 * w + centre as usize;
        // The same visibility region integrated by a fine quadrature over the hemisphere.
        let basis = hl2_basis();
        let (mut vis, mut all, mut ao_vis, mut ao_all) = ([0.0; 3], [0.0; 3], 0.0, 0.0);
        let steps = 800;
        for iz in 0..steps {
            let z = (iz as f64 + 0.5) / steps as f64;
            for ip in 0..steps {
                let phi = (ip as f64 + 0.5) / steps as f64 * std::f64::consts::TAU;
                let r = (1.0 - z * z).sqrt();
                let d = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                let free = d.z >= d.x.abs() * alpha.tan();
                for i in 0..3 {
                    let wt = d.dot(basis[i]).max(0.0);
                    all[i] += wt;
                    if free {
                        vis[i] += wt;
                    }
                }
                ao_all += d.z;
                if free {
                    ao_vis += d.z;
                }
            }
        }
        // Scalar AO at the kink uses the kink's central-difference normal, +Z here.
        assert!(
            (ao_vis / ao_all - alpha.cos()).abs() < 2e-3,
            "quadrature AO vs cos α"
        );
        let noise = 3.0 * (0.25 / rays as f64).sqrt();
        for i in 0..3 {
            let want = vis[i] / all[i];
            let got = occ.channels[bottom][i];
            assert!(
                (got - want).abs() < noise + 0.01,
                "channel {i}: {got} vs {want}"
            );
        }
        assert!(
            (occ.ao[bottom] - alpha.cos()).abs() < noise + 0.01,
            "{}",
            occ.ao[bottom]
        );
    }
}
