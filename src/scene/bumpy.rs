//! The built-in test scene `bumpy`: a bumpy plane receding to the horizon, the
//! setting of Olano & North's Fig. 1 in which normal-map filtering decides the look — near
//! the camera the bumps are magnified, toward the horizon one pixel covers tens of them.
//!
//! An 8 m × 60 m ground at y = 0 seen from 1.5 m above its near edge, looking down its
//! length; one texture tile per metre of a 256² normal map of an egg-crate height field
//! h = A sin(2π k x) sin(2π k y), k = 8 bumps per tile, slopes up to 0.8 (≈ 39°): the
//! normals spread isotropically. White albedo. Minification (texels per pixel along the
//! view) grows from ≈ 1 at the near edge to > 50 at the far end (`study ndf` measures it
//! per pixel).

use glam::{Vec2, Vec3};

use super::house::{self, Quad};
use super::{Camera, Material, Scene, SceneError, Texture8};

/// Normal-map texels per side (one tile per metre).
pub const NORMAL_MAP_SIDE: u32 = 256;
/// Bumps per tile side.
pub const BUMPS_PER_TILE: f32 = 8.0;
/// Largest slope of the height field.
pub const MAX_SLOPE: f32 = 0.8;

/// Plane width and length, metres.
const WIDTH: f32 = 8.0;
const LENGTH: f32 = 60.0;

/// Builds the plane with its lightmap UVs packed for `lightmap_res`² texels.
///
/// # Errors
/// [`SceneError::LightmapRes`] for a resolution outside the house's range.
pub fn build(lightmap_res: u32) -> Result<Scene, SceneError> {
    let quads = [Quad {
        origin: Vec3::new(-0.5 * WIDTH, 0.0, 1.0),
        t: Vec3::X,
        b: Vec3::NEG_Z,
        size: Vec2::new(WIDTH, LENGTH),
        tint: Vec3::ONE,
        half_density: false,
    }];
    Ok(Scene {
        name: "bumpy".to_string(),
        mesh: house::quads_mesh(&quads, lightmap_res)?,
        material: Material {
            albedo: Texture8::solid([255; 4]),
            normal: egg_crate_normal_map(),
            normal_scale: 1.0,
            height: None,
        },
        camera: camera(),
    })
}

/// The egg-crate normal map (module doc), glTF convention: x along +u, y image up.
pub fn egg_crate_normal_map() -> Texture8 {
    let n = NORMAL_MAP_SIDE;
    let k = std::f32::consts::TAU * BUMPS_PER_TILE / n as f32;
    // h = A sin(k x) sin(k y): |∇h| ≤ A k √2 at the diagonals; A k = MAX_SLOPE / √2.
    let ak = MAX_SLOPE / std::f32::consts::SQRT_2;
    let texels = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            let dhdx = ak * (k * x).cos() * (k * y).sin();
            // Image rows grow downward; the map's +y is image up.
            let dhdy_up = -ak * (k * x).sin() * (k * y).cos();
            let normal = Vec3::new(-dhdx, -dhdy_up, 1.0).normalize();
            Texture8::encode_normal(normal)
        })
        .collect();
    Texture8 {
        width: n,
        height: n,
        texels,
    }
}

/// 1.5 m above the near edge, looking down the plane's length toward the horizon.
pub fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 1.5, 1.5),
        target: Vec3::new(0.0, 0.4, -12.0),
        up: Vec3::Y,
        fov_y: 45f32.to_radians(),
        z_near: 0.05,
        z_far: 200.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_plane_recedes_in_view_and_the_bumps_spread_the_normals() {
        let scene = build(128).unwrap();
        assert_eq!(scene.mesh.triangle_count(), 2);
        let cam = scene.camera;
        for p in [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -50.0)] {
            assert!(cam.project_to_pixel(p, 480, 270).is_some(), "{p} in view");
        }
        let map = &scene.material.normal;
        let mean: Vec3 = map
            .texels
            .iter()
            .map(|t| crate::scene::decode_normal(*t, 1.0))
            .sum::<Vec3>()
            / map.texels.len() as f32;
        // Symmetric bumps: the mean normal is +z, shortened by the spread.
        assert!(
            mean.x.abs() < 1e-3 && mean.y.abs() < 1e-3 && mean.z < 0.95,
            "{mean}"
        );
    }
}
