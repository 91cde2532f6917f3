//! Per-vertex PCA (`pcaMv`): the order-6 visibility baked at the vertices of the
//! mesh, optionally subdivided to a target edge length (`scene::subdivide`), and expressed
//! in the lightmap's global PCA basis quantized as `pcaMw` stores it — so `pcaMv` and
//! `pcaMw` share one uniform block and differ only in where the weights live (a vertex
//! stream, interpolated by the rasterizer, against a bilinearly filtered lightmap).
//!
//! With the quantized basis B_k' = s_k B_k and mean V_e' = V_e + Σ lo_k B_k
//! (`bake::pca::QuantizedPca`), the weight of a vertex visibility V is
//! u_k = B_k'·(V − V_e') / ‖B_k'‖², stored as round(255 u_k) clamped to [0, 255]: vertices
//! whose visibility leaves the texels' weight range are clamped, part of the measured loss.

use glam::Vec3;

use super::pca::QuantizedPca;
use super::trace::Tracer;
use super::visibility::{VisibilitySettings, bake_points};
use crate::scene::Mesh;
use crate::scene::subdivide::subdivide;

/// Weights of one mesh's vertices.
#[derive(Clone, Debug)]
pub struct VertexPca {
    /// Longest edge the mesh was subdivided to (None: as authored).
    pub max_edge: Option<f32>,
    /// The mesh the weights belong to (render it, not the scene's).
    pub mesh: Mesh,
    pub m: usize,
    /// Vertex-major, M per vertex, UNORM8.
    pub weights_unorm: Vec<u8>,
    /// Weights that fell outside [0, 1] and were clamped.
    pub clamped: usize,
    /// RMS over vertices of the coefficient L2 distance between the baked visibility and
    /// its quantized reconstruction.
    pub rms_error: f64,
    pub rays_traced: u64,
}

/// Bakes `mesh` (subdivided to `max_edge` when given) at its vertices with `settings`
/// through `tracer` (the scene's: subdivision does not move the surface) and projects onto
/// the quantized basis `q` (module doc).
pub fn bake_vertex_pca(
    tracer: &Tracer,
    mesh: &Mesh,
    max_edge: Option<f32>,
    q: &QuantizedPca,
    settings: &VisibilitySettings,
) -> VertexPca {
    let mesh = match max_edge {
        Some(e) => subdivide(mesh, e),
        None => mesh.clone(),
    };
    let position: Vec<Vec3> = mesh.vertices.iter().map(|v| v.position.into()).collect();
    let normal: Vec<Vec3> = mesh
        .vertices
        .iter()
        .map(|v| Vec3::from(v.normal).normalize_or(Vec3::Y))
        .collect();
    let vis = bake_points(tracer, &position, &normal, settings);
    let m = q.m;
    let mut weights_unorm = Vec::with_capacity(mesh.vertices.len() * m);
    let mut clamped = 0;
    let mut sq_error = 0.0;
    for i in 0..mesh.vertices.len() {
        let v = vis.point(i);
        let mut recon = q.mean.clone();
        for b in &q.basis {
            let norm2: f64 = b.iter().map(|x| x * x).sum();
            let u = if norm2 > 0.0 {
                b.iter()
                    .zip(v)
                    .zip(&q.mean)
                    .map(|((bj, &vj), ej)| bj * (f64::from(vj) - ej))
                    .sum::<f64>()
                    / norm2
            } else {
                0.0
            };
            clamped += usize::from(!(0.0..=1.0).contains(&u));
            let stored = (u * 255.0).round().clamp(0.0, 255.0);
            weights_unorm.push(stored as u8);
            for (r, bj) in recon.iter_mut().zip(b) {
                *r += stored / 255.0 * bj;
            }
        }
        sq_error += recon
            .iter()
            .zip(v)
            .map(|(r, &vj)| (r - f64::from(vj)).powi(2))
            .sum::<f64>();
    }
    let n = mesh.vertices.len().max(1);
    VertexPca {
        max_edge,
        m,
        weights_unorm,
        clamped,
        rms_error: (sq_error / n as f64).sqrt(),
        rays_traced: vis.rays_traced,
        mesh,
    }
}
