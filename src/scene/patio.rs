//! The built-in test scene `patio`: a 1 m × 1 m brick floor in the corner of
//! two 0.5 m brick walls, seen from close by — small enough that [`super::displace`] can
//! build its bricks as real geometry (a vertex at every height-texel corner, 0.26 M triangles), so
//! self-shadowing techniques (`ssbump`, `rnmao`) meet a ground truth with the bricks'
//! own shadows in it.
//!
//! It reuses the house's quads, chart packing and brick material (albedo, normal map and
//! the height field the normal map is derived from; [`super::house`]): one texture tile per
//! metre, so a height texel is 1/256 m. Under a low sun (`--env sky:15`) the floor is lit at
//! grazing incidence and the mortar joints shadow themselves.

use glam::{Vec2, Vec3};

use super::house::{self, Quad, TINT_WALL};
use super::{Camera, Material, Scene, SceneError};

/// Floor side and wall height, metres.
const SIDE: f32 = 1.0;
const WALL_HEIGHT: f32 = 0.5;

/// Builds the patio with lightmap UVs packed for `lightmap_res`² texels.
///
/// # Errors
/// [`SceneError::LightmapRes`] when the charts do not fit or the resolution is outside
/// the house's range.
pub fn build(lightmap_res: u32) -> Result<Scene, SceneError> {
    let h = 0.5 * SIDE;
    let quad = |origin: Vec3, t: Vec3, b: Vec3, size: Vec2| Quad {
        origin,
        t,
        b,
        size,
        tint: TINT_WALL,
        half_density: false,
    };
    let quads = [
        // Floor, normal +Y.
        quad(
            Vec3::new(-h, 0.0, h),
            Vec3::X,
            Vec3::NEG_Z,
            Vec2::splat(SIDE),
        ),
        // Back wall, normal +Z.
        quad(
            Vec3::new(-h, 0.0, -h),
            Vec3::X,
            Vec3::Y,
            Vec2::new(SIDE, WALL_HEIGHT),
        ),
        // Left wall, normal +X.
        quad(
            Vec3::new(-h, 0.0, h),
            Vec3::NEG_Z,
            Vec3::Y,
            Vec2::new(SIDE, WALL_HEIGHT),
        ),
    ];
    Ok(Scene {
        name: "patio".to_string(),
        mesh: house::quads_mesh(&quads, lightmap_res)?,
        material: Material {
            albedo: house::brick_albedo(),
            normal: house::brick_normal(),
            normal_scale: 1.0,
            height: Some(house::brick_height_field()),
        },
        camera: camera(),
    })
}

/// From the open front-right corner, 1.4 m away, looking into the corner.
pub fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.85, 0.65, 1.05),
        target: Vec3::new(-0.13, 0.1, -0.17),
        up: Vec3::Y,
        fov_y: 50f32.to_radians(),
        z_near: 0.02,
        z_far: 20.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_and_walls_face_into_the_corner_and_are_in_view() {
        let scene = build(128).expect("patio at 128");
        assert_eq!(scene.mesh.triangle_count(), 6);
        let normals: Vec<Vec3> = scene
            .mesh
            .vertices
            .iter()
            .step_by(4)
            .map(|v| Vec3::from(v.normal))
            .collect();
        assert_eq!(normals, vec![Vec3::Y, Vec3::Z, Vec3::X]);
        for v in &scene.mesh.vertices {
            let p = Vec3::from(v.position);
            let (x, y) = scene
                .camera
                .project_to_pixel(p, 640, 400)
                .expect("in front of the camera");
            // Every corner projects into (or just beside) the frame.
            assert!(
                (-80.0..720.0).contains(&x) && (-80.0..480.0).contains(&y),
                "{p} → {x},{y}"
            );
        }
    }
}
