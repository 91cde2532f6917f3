//! The paper's method (Gumbau et al. §3) as data for [`crate::gpu::normal_bake`]: per low
//! triangle its view ([`super::projection`]), its share of the high mesh ([`super::cull`])
//! and its draw; then the bake and its timing.

use std::sync::Arc;
use std::time::Instant;

use glam::{Vec2, Vec3};

use super::cull::TriangleGrid;
use super::projection::{face_normal, triangle_view};
use super::{DrawMode, NormalImage, NormalMapError, NormalMapSettings};
use crate::gpu::Context;
use crate::gpu::normal_bake::{self, PhaseMs, ProjectionDraw, ProjectionJob};
use crate::scene::Mesh;

/// Where one GPU bake spent its time.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct GpuTiming {
    /// Views and culling on the CPU, seconds.
    pub prepare_s: f64,
    /// Uploads, shader compiles, pipelines, seconds.
    pub setup_s: f64,
    /// The one command buffer, submission to readback, seconds.
    pub execute_s: f64,
    /// Everything, seconds.
    pub total_s: f64,
    /// GPU timestamps of the three phases (`None` without timestamps).
    pub gpu_ms: Option<PhaseMs>,
    /// High triangles drawn, summed over low triangles.
    pub triangles_drawn: u64,
    /// Low triangles with a view (the rest own no texels).
    pub renders: u32,
}

/// Bakes `high`'s normals onto `low`'s material UVs on the GPU (module doc of
/// [`crate::gpu::normal_bake`]).
///
/// # Errors
/// Invalid inputs ([`super::validate`]), a device without what the draw mode needs, or a
/// failing Vulkan call.
pub fn bake(
    ctx: &Arc<Context>,
    high: &Mesh,
    low: &Mesh,
    settings: &NormalMapSettings,
) -> Result<(NormalImage, GpuTiming), NormalMapError> {
    super::validate(high, low, settings)?;
    let started = Instant::now();
    let res = settings.res;
    let d = settings.max_distance;
    let low_count = low.triangle_count();
    let corners = |t: usize| {
        let i = &low.indices[3 * t..3 * t + 3];
        let v = [0, 1, 2].map(|k| Vec3::from(low.vertices[i[k] as usize].position));
        let uv = [0, 1, 2].map(|k| Vec2::from(low.vertices[i[k] as usize].uv_material));
        (v, uv)
    };
    let mut views = Vec::with_capacity(low_count * 32);
    let mut prisms = Vec::with_capacity(low_count);
    let mut mask_vertices: Vec<u8> = Vec::with_capacity(low_count * 36);
    for t in 0..low_count {
        let (v, uv) = corners(t);
        let view = triangle_view(v, uv, d, settings.mirror);
        let matrices = view.map_or([0.0; 32], |view| {
            let mut m = [0.0f32; 32];
            m[..16].copy_from_slice(&view.view_from_world.to_cols_array());
            m[16..].copy_from_slice(&view.clip_from_view.to_cols_array());
            m
        });
        views.extend_from_slice(&matrices);
        prisms.push(view.and(face_normal(v)).map(|n| (v, n)));
        for c in uv {
            mask_vertices.extend_from_slice(bytemuck::bytes_of(&c.to_array()));
            mask_vertices.extend_from_slice(&(t as u32).to_ne_bytes());
        }
    }
    let draw_for = |t: usize, first_index: u32, index_count: u32| {
        let (_, uv) = corners(t);
        let lo = uv[0].min(uv[1]).min(uv[2]) * res as f32;
        let hi = uv[0].max(uv[1]).max(uv[2]) * res as f32;
        ProjectionDraw {
            triangle: t as u32,
            first_index,
            index_count,
            scissor: [
                lo.x.floor().max(0.0) as u32,
                lo.y.floor().max(0.0) as u32,
                (hi.x.ceil() as u32 + 1).min(res),
                (hi.y.ceil() as u32 + 1).min(res),
            ],
        }
    };
    let (indices, draws) = if settings.cull {
        let grid = TriangleGrid::new(high);
        let candidates = grid.candidates_per_triangle(&prisms, d);
        let mut indices = Vec::new();
        let mut draws = Vec::new();
        for (t, list) in candidates.iter().enumerate() {
            if list.is_empty() {
                continue;
            }
            let first = indices.len() as u32;
            for &h in list {
                indices.extend_from_slice(&high.indices[3 * h as usize..3 * h as usize + 3]);
            }
            draws.push(draw_for(t, first, 3 * list.len() as u32));
        }
        (indices, draws)
    } else {
        let all = high.indices.len() as u32;
        let draws = (0..low_count)
            .filter(|&t| prisms[t].is_some())
            .map(|t| draw_for(t, 0, all))
            .collect();
        (high.indices.clone(), draws)
    };
    let triangles_drawn = draws.iter().map(|d| u64::from(d.index_count / 3)).sum();
    let renders = prisms.iter().filter(|p| p.is_some()).count() as u32;
    if draws.is_empty() {
        return Err(NormalMapError::Invalid(format!(
            "no high-mesh triangle lies within {d} of the low mesh: are the meshes in the same place and scale? (--distance)"
        )));
    }
    let high_vertices: Vec<[f32; 6]> = high
        .vertices
        .iter()
        .map(|v| {
            let [px, py, pz] = v.position;
            let [nx, ny, nz] = v.normal;
            [px, py, pz, nx, ny, nz]
        })
        .collect();
    let prepare_s = started.elapsed().as_secs_f64();
    let result = normal_bake::run(
        ctx,
        &ProjectionJob {
            res,
            mask_vertices: &mask_vertices,
            low_triangles: low_count as u32,
            high_vertices: bytemuck::cast_slice(&high_vertices),
            high_indices: &indices,
            views: bytemuck::cast_slice(&views),
            draws: &draws,
            indirect: settings.draws == DrawMode::Indirect,
            max_distance: d,
            mirror: settings.mirror,
            expand_passes: settings.expand,
        },
    )?;
    let image = super::require_texels(
        NormalImage {
            res,
            texels: result.texels,
        },
        d,
    )?;
    Ok((
        image,
        GpuTiming {
            prepare_s,
            setup_s: result.setup_s,
            execute_s: result.execute_s,
            total_s: started.elapsed().as_secs_f64(),
            gpu_ms: result.gpu_ms,
            triangles_drawn,
            renders,
        },
    ))
}
