//! The independent check of [`super::gpu`]: a ray-cast normal-map baker, the software
//! approach the paper compares against (NVIDIA Melody; xNormal works the same way).
//!
//! For every texel the low mesh covers (its material-UV raster, [`super::low_texels`]),
//! two rays leave the low surface point p along the interpolated vertex normal n, one each
//! way (from p ∓ ε n, so a high surface through p itself is found); the nearer hit on the
//! high mesh within the search distance D wins, and the texel stores the high mesh's
//! interpolated vertex normal there. Hits use the bake's BVH ([`crate::bake::trace`],
//! obvhs), both faces. Texels whose rays find nothing within D stay empty.
//!
//! This projects along the interpolated normal where the GPU method projects along T's
//! face normal, so the two agree where the high surface is near the low one and differ by
//! the parallax of the two directions elsewhere — what the GPU vs CPU comparison measures.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use super::{COVERED, NormalImage, NormalMapError, NormalMapSettings, expand_borders, low_texels};
use crate::bake::trace::Tracer;
use crate::scene::Mesh;

/// Which direction the rays leave the low surface in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RayDirection {
    /// The interpolated vertex normal: the software bakers' choice (the check).
    Interpolated,
    /// The low triangle's face normal: the GPU method's projection direction, to tell
    /// differences of direction from differences of method.
    Face,
}

/// Wall-clock phases of one CPU bake, seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CpuTiming {
    pub bvh_s: f64,
    pub trace_s: f64,
    pub total_s: f64,
    /// Rays cast (two per covered texel).
    pub rays: u64,
}

/// Bakes `high`'s normals onto `low`'s material UVs by ray casting `along` the chosen
/// direction (module doc), then
/// expands borders by `settings.expand` passes. Mirroring, culling and draw mode do not
/// apply (rays find the nearest surface both ways by construction).
///
/// # Errors
/// Invalid inputs ([`super::validate`]).
pub fn bake(
    high: &Mesh,
    low: &Mesh,
    settings: &NormalMapSettings,
    along: RayDirection,
) -> Result<(NormalImage, CpuTiming), NormalMapError> {
    super::validate(high, low, settings)?;
    let started = Instant::now();
    let tracer = Tracer::new(high);
    let bvh_s = started.elapsed().as_secs_f64();
    let frames = low_texels(low, settings.res);
    let traced = Instant::now();
    let d = settings.max_distance;
    let eps = tracer.ray_epsilon();
    let normal_at = |tri: u32, u: f32, v: f32| {
        let i = &high.indices[3 * tri as usize..3 * tri as usize + 3];
        let n = |k: usize| Vec3::from(high.vertices[i[k] as usize].normal);
        (n(0) * (1.0 - u - v) + n(1) * u + n(2) * v).normalize_or_zero()
    };
    let mut image = NormalImage::empty(settings.res);
    image
        .texels
        .par_iter_mut()
        .enumerate()
        .filter(|(i, _)| frames.covered[*i])
        .for_each(|(i, texel)| {
            let p = frames.position[i];
            let n = match along {
                RayDirection::Interpolated => frames.shading_normal[i],
                RayDirection::Face => frames.normal[i],
            };
            let best = [n, -n]
                .into_iter()
                .filter_map(|dir| {
                    let hit = tracer.closest_hit(p - dir * eps, dir)?;
                    let distance = hit.t - eps;
                    (distance <= d).then_some((distance.abs(), hit))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((_, hit)) = best {
                let normal = normal_at(hit.triangle, hit.u, hit.v);
                if normal != Vec3::ZERO {
                    *texel = normal.extend(COVERED).to_array();
                }
            }
        });
    let trace_s = traced.elapsed().as_secs_f64();
    expand_borders(&mut image, settings.expand);
    Ok((
        super::require_texels(image, d)?,
        CpuTiming {
            bvh_s,
            trace_s,
            total_s: started.elapsed().as_secs_f64(),
            rays: 2 * frames.covered_count() as u64,
        },
    ))
}
