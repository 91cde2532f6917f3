//! Occlusion rays against a mesh, over an obvhs compressed-wide BVH (CWBVH, Ylitie et al.
//! 2017) of its triangles; Möller–Trumbore intersection, both faces of a triangle occlude.
//!
//! Self-intersection (DESIGN §6 "rays grazing surfaces"): a ray leaving a surface starts at
//! [`Tracer::offset_origin`], the surface point moved along its geometric normal by
//! [`Tracer::ray_epsilon`] = max(1e-4 × scene diagonal, 64 ulp of the largest coordinate),
//! and only hits with t ≥ [`Tracer::t_min`] (1e-3 of that) count. With a direction in the
//! upper hemisphere the ray then moves away from the plane of its own triangle, even when
//! grazing, so it cannot hit it, while geometry a millimetre away (the inner corner of a
//! floor and a wall) still occludes for scenes up to tens of metres. The scale-relative term
//! keeps the offset meaningful for scenes in other units; the ulp term keeps it above f32
//! rounding for scenes far from the origin.
//!
//! Triangles with zero area or non-finite corners are left out of the BVH: they cannot
//! occlude anything.

use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::Ray,
    triangle::Triangle,
};

use crate::scene::Mesh;

/// Normal offset of ray origins relative to the scene's bounding-box diagonal.
pub const EPSILON_PER_EXTENT: f32 = 1e-4;

/// Any-hit ray queries against a static mesh.
pub struct Tracer {
    /// `None` for a mesh without a usable triangle: nothing occludes.
    bvh: Option<CwBvh>,
    /// Triangles in BVH primitive order (`triangles[i]` = input `primitive_indices[i]`).
    triangles: Vec<Triangle>,
    ray_epsilon: f32,
}

impl Tracer {
    /// Builds the BVH over the mesh's triangles (see the module doc for what is skipped).
    pub fn new(mesh: &Mesh) -> Tracer {
        let input: Vec<Triangle> = (0..mesh.triangle_count())
            .filter(|&t| {
                mesh.indices[3 * t..3 * t + 3]
                    .iter()
                    .all(|&i| (i as usize) < mesh.vertices.len())
            })
            .map(|t| mesh.triangle_positions(t))
            .filter(|p| {
                let finite = p.iter().all(|v| v.is_finite());
                finite && (p[1] - p[0]).cross(p[2] - p[0]).length_squared() > 0.0
            })
            .map(|p| Triangle {
                v0: p[0].into(),
                v1: p[1].into(),
                v2: p[2].into(),
            })
            .collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for t in &input {
            for v in [t.v0, t.v1, t.v2] {
                (lo, hi) = (lo.min(v.into()), hi.max(v.into()));
            }
        }
        let ray_epsilon = if input.is_empty() {
            0.0
        } else {
            let extent = (hi - lo).length();
            let largest = lo.abs().max(hi.abs()).max_element();
            (EPSILON_PER_EXTENT * extent).max(64.0 * f32::EPSILON * largest)
        };
        if input.is_empty() {
            return Tracer {
                bvh: None,
                triangles: input,
                ray_epsilon,
            };
        }
        let mut build_time = Duration::ZERO;
        let bvh = build_cwbvh_from_tris(&input, BvhBuildParams::medium_build(), &mut build_time);
        let triangles = bvh
            .primitive_indices
            .iter()
            .map(|&i| input[i as usize])
            .collect();
        log::debug!(
            "CWBVH over {} triangles built in {:.3} s",
            input.len(),
            build_time.as_secs_f64()
        );
        Tracer {
            bvh: Some(bvh),
            triangles,
            ray_epsilon,
        }
    }

    /// Number of triangles in the BVH (degenerate ones left out).
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The normal offset of ray origins, metres (see the module doc).
    pub fn ray_epsilon(&self) -> f32 {
        self.ray_epsilon
    }

    /// Smallest hit distance counted, metres: 1e-3 × [`Self::ray_epsilon`].
    pub fn t_min(&self) -> f32 {
        1e-3 * self.ray_epsilon
    }

    /// Origin for rays leaving the surface at `position` with unit geometric `normal`.
    pub fn offset_origin(&self, position: Vec3, normal: Vec3) -> Vec3 {
        position + normal * self.ray_epsilon
    }

    /// Whether any triangle lies along the ray `origin + t·dir`, t ∈ [`Self::t_min`], `t_max`]
    /// (`dir` unit length, so t is metres; `t_max` may be infinite).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let Some(bvh) = &self.bvh else {
            return false;
        };
        let ray = Ray::new(Vec3A::from(origin), Vec3A::from(dir), self.t_min(), t_max);
        !bvh.ray_traverse_miss(ray, |ray, id| self.triangles[id].intersect(ray))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    fn mesh(tris: &[[Vec3; 3]]) -> Mesh {
        let mut m = Mesh::default();
        for t in tris {
            for p in t {
                m.indices.push(m.vertices.len() as u32);
                m.vertices.push(Vertex {
                    position: p.to_array(),
                    ..Vertex::default()
                });
            }
        }
        m
    }

    #[test]
    fn hits_in_range_only_and_both_faces() {
        let tri = [
            Vec3::new(-1.0, -1.0, 5.0),
            Vec3::new(1.0, -1.0, 5.0),
            Vec3::new(0.0, 1.0, 5.0),
        ];
        let tracer = Tracer::new(&mesh(&[tri]));
        assert_eq!(tracer.triangle_count(), 1);
        assert!(tracer.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        assert!(tracer.occluded(Vec3::new(0.0, 0.0, 10.0), Vec3::NEG_Z, f32::INFINITY));
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::Z, 4.9));
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::NEG_Z, f32::INFINITY));
        assert!(!tracer.occluded(Vec3::new(3.0, 0.0, 0.0), Vec3::Z, f32::INFINITY));
    }

    #[test]
    fn degenerate_and_empty_meshes_occlude_nothing() {
        let p = Vec3::new(0.0, 0.0, 1.0);
        let tracer = Tracer::new(&mesh(&[[p, p, Vec3::ONE]]));
        assert_eq!(tracer.triangle_count(), 0);
        assert!(!tracer.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
        assert!(!Tracer::new(&Mesh::default()).occluded(Vec3::ZERO, Vec3::Z, 1.0));
    }

    #[test]
    fn grazing_rays_from_offset_origins_miss_their_own_plane() {
        // A 20 m plane in two triangles; rays barely above the horizon from points on it.
        let a = [
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, 10.0),
        ];
        let b = [a[0], a[2], Vec3::new(10.0, 0.0, -10.0)];
        let tracer = Tracer::new(&mesh(&[a, b]));
        for k in 0..64 {
            let phi = k as f32 * 0.1;
            let p = Vec3::new(3.0 * phi.sin(), 0.0, 2.0 * phi.cos());
            let dir = Vec3::new(phi.cos(), 1e-6, phi.sin()).normalize();
            let o = tracer.offset_origin(p, Vec3::Y);
            assert!(
                !tracer.occluded(o, dir, f32::INFINITY),
                "ray {k} hit its own plane"
            );
        }
    }
}
