//! The footprint reference of the specular term (`render::specular`): the footprint
//! reference's G-buffer passes (full-resolution normal map at stratified sub-pixel
//! positions, [`super`]) with the base lobe of each sample's own normal evaluated, so it
//! integrates exactly the BRDF the full-resolution surface has over each pixel.

use std::sync::Arc;

use glam::{DVec3, Vec3};

use super::ReferenceSettings;
use crate::gpu::{Context, GpuError};
use crate::ndf::{NdfMaps, pearson};
use crate::render::specular::SpecularLight;
use crate::render::{Frame, SceneGpu};

/// The base lobe at full resolution: κ₀ g(|h − n|²/σ²)/σ³.
pub fn base_lobe(h: DVec3, n: DVec3, sigma: f64, kappa0: f64) -> f64 {
    kappa0 * pearson((h - n).length_squared() / (sigma * sigma)) / sigma.powi(3)
}

/// The frame jitter (pixels) that puts pixel centres on stratum `j` of `side`² cells,
/// jittered within the cell by a hash of (`seed`, `j`): the same positions for every pixel.
pub fn stratum_jitter(seed: u64, j: u32, side: u32) -> [f32; 2] {
    let jitter = |axis: u64| {
        let hash = crate::files::splitmix64(seed ^ (u64::from(j) << 1 | axis));
        crate::bake::directions::unit_f64(hash) as f32
    };
    let sx = ((j % side) as f32 + jitter(0)) / side as f32;
    let sy = ((j / side) as f32 + jitter(1)) / side as f32;
    [0.5 - sx, 0.5 - sy]
}

/// Most sub-pixel strata per side of the specular reference (32² = 1024 G-buffer sets).
pub const MAX_REFERENCE_SIDE: u32 = 32;

/// The footprint reference of the specular image (module doc): ⌈√spp⌉² (≤ 32²) jittered
/// strata of the pixel, one G-buffer set each, the positions shared by all pixels. More
/// strata than the diffuse reference's 8² because nothing else averages here: a pixel near
/// the horizon covers hundreds of bumps, and 64 shared positions alias into moiré.
/// Deterministic for a seed. Without `settings.footprint`, one sample at each pixel centre
/// through the MIP chains (the point reference).
pub fn render_reference(
    ctx: &Arc<Context>,
    scene: &mut SceneGpu,
    camera_position: Vec3,
    maps: &NdfMaps,
    light: &SpecularLight,
    settings: &ReferenceSettings,
) -> Result<Frame, GpuError> {
    // The point reference reads the MIP chains at the pixel centre, as the diffuse one does.
    let pipelines = super::gbuffer_pipelines(ctx, scene, settings.footprint, 4)?;
    let side = if settings.footprint {
        ((settings.spp.max(1) as f64).sqrt().ceil() as u32).min(MAX_REFERENCE_SIDE)
    } else {
        1
    };
    let (w, h) = (settings.width as usize, settings.height as usize);
    let mut sum = vec![[0.0f64; 4]; w * h];
    let count = side * side;
    let l = light.direction.normalize().as_dvec3();
    let (sigma, kappa0) = (f64::from(maps.sigma), maps.kappa0);
    let eye = camera_position.as_dvec3();
    for j in 0..count {
        scene.set_jitter(if settings.footprint {
            stratum_jitter(settings.seed, j, side)
        } else {
            [0.0, 0.0]
        })?;
        let position = scene.render_pipeline(&pipelines[0], 0, 1)?;
        let normal = scene.render_pipeline(&pipelines[1], 0, 1)?;
        let vertex_normal = scene.render_pipeline(&pipelines[3], 0, 1)?;
        for (i, acc) in sum.iter_mut().enumerate() {
            let p = position.rgba[i];
            if p[3] < 0.5 {
                continue;
            }
            let pos = DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let n = Vec3::from_slice(&normal.rgba[i][..3])
                .as_dvec3()
                .normalize_or_zero();
            let ng = Vec3::from_slice(&vertex_normal.rgba[i][..3])
                .as_dvec3()
                .normalize_or_zero();
            let v = (eye - pos).normalize_or_zero();
            let lit = ng.dot(l) > 0.0 && ng.dot(v) > 0.0;
            let d = if lit {
                base_lobe((l + v).normalize_or_zero(), n, sigma, kappa0)
            } else {
                0.0
            };
            for (a, r) in acc.iter_mut().zip(light.radiance.to_array()) {
                *a += d * f64::from(r);
            }
            acc[3] += 1.0;
        }
    }
    scene.set_jitter([0.0, 0.0])?;
    let n = f64::from(count);
    Ok(Frame {
        width: settings.width,
        height: settings.height,
        rgba: sum
            .iter()
            .map(|a| {
                let covered = a[3] / n;
                let scale = if a[3] > 0.0 { 1.0 / a[3] } else { 0.0 };
                // Covered where every stratum hit the surface (coverage edges excluded).
                [
                    (a[0] * scale) as f32,
                    (a[1] * scale) as f32,
                    (a[2] * scale) as f32,
                    if covered >= 1.0 { 1.0 } else { 0.0 },
                ]
            })
            .collect(),
        ms: Vec::new(),
    })
}
