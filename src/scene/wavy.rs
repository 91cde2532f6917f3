//! The built-in test scene `wavy`: Olano & North's wavy sphere (their Figs. 1–2),
//! a smooth sphere whose normal map carries parallel ripples, so that a minified pixel
//! covers normals spread along one axis only — the highlight must blur and *elongate*
//! across the ripples, which an averaged normal cannot do (the NDF's covariance can).
//!
//! A unit sphere at the origin, a 96 × 48 latitude–longitude mesh with analytic normals
//! and tangents (t = ∂P/∂u along the longitude, w = +1: the bitangent points north, toward
//! decreasing v as DESIGN §1 asks); material UVs tile the 256² ripple map
//! [`TILES_AROUND`] × [`TILES_DOWN`] times, square texels at the equator (≈ 326 per metre).
//! The ripples: h = A sin(2π k x) along the map's x (the longitude), k = [`RIPPLES_PER_TILE`],
//! slopes up to [`MAX_SLOPE`]. Lightmap UVs are generated (`lightmap_uv::generate`). White
//! albedo. The camera sits 5 m away: at 480×270 one pixel covers ≈ 5 texels at the centre
//! of the disc and more toward its rim (`study ndf` measures it per pixel).

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

use super::{Camera, Material, Mesh, Scene, SceneError, Texture8, Vertex, lightmap_uv};

/// Normal-map texels per side.
pub const NORMAL_MAP_SIDE: u32 = 256;
/// Ripples across one tile.
pub const RIPPLES_PER_TILE: f32 = 32.0;
/// Largest slope of the ripples (≈ 39°).
pub const MAX_SLOPE: f32 = 0.8;
/// Material tiles around the equator and from pole to pole.
pub const TILES_AROUND: f32 = 8.0;
pub const TILES_DOWN: f32 = 4.0;
/// Mesh segments around and from pole to pole.
const SEGMENTS_AROUND: u32 = 96;
const SEGMENTS_DOWN: u32 = 48;

/// Builds the sphere with lightmap UVs generated for `lightmap_res`² texels.
///
/// # Errors
/// [`SceneError::LightmapRes`] for a resolution outside the generated charts' range,
/// [`SceneError::ChartsDoNotFit`] for one too small for them.
pub fn build(lightmap_res: u32) -> Result<Scene, SceneError> {
    lightmap_uv::check_res(lightmap_res)?;
    let mut mesh = sphere_mesh();
    // Too many charts for the resolution: the same error, naming the resolution.
    lightmap_uv::generate(&mut mesh, lightmap_res).map_err(|e| SceneError::ChartsDoNotFit {
        res: lightmap_res,
        charts: e.charts,
    })?;
    Ok(Scene {
        name: "wavy".to_string(),
        mesh,
        material: Material {
            albedo: Texture8::solid([255; 4]),
            normal: ripple_normal_map(),
            normal_scale: 1.0,
            height: None,
        },
        camera: camera(),
    })
}

/// The latitude–longitude unit sphere (module doc): v = 0 at the north pole (+y),
/// u = 0 facing +z.
fn sphere_mesh() -> Mesh {
    let mut mesh = Mesh::default();
    for j in 0..=SEGMENTS_DOWN {
        let v = j as f32 / SEGMENTS_DOWN as f32;
        let theta = PI * v;
        for i in 0..=SEGMENTS_AROUND {
            let u = i as f32 / SEGMENTS_AROUND as f32;
            let phi = TAU * u;
            let normal = Vec3::new(
                theta.sin() * phi.sin(),
                theta.cos(),
                theta.sin() * phi.cos(),
            );
            // ∂P/∂φ / sin θ: defined at the poles too.
            let tangent = Vec3::new(phi.cos(), 0.0, -phi.sin());
            mesh.vertices.push(Vertex {
                position: normal.to_array(),
                normal: normal.to_array(),
                tangent: tangent.extend(1.0).to_array(),
                uv_material: (Vec2::new(u * TILES_AROUND, v * TILES_DOWN)).to_array(),
                uv_lightmap: [0.0; 2],
                albedo_tint: [1.0; 3],
            });
        }
    }
    let row = SEGMENTS_AROUND + 1;
    for j in 0..SEGMENTS_DOWN {
        for i in 0..SEGMENTS_AROUND {
            let (a, b) = (j * row + i, j * row + i + 1);
            let (c, d) = (a + row, b + row);
            // Outward winding: (b − a) × (c − a) along the normal. The polar rows' degenerate
            // triangles are left out.
            if j != 0 {
                mesh.indices.extend([a, c, b]);
            }
            if j != SEGMENTS_DOWN - 1 {
                mesh.indices.extend([b, c, d]);
            }
        }
    }
    mesh
}

/// The ripple normal map (module doc), glTF convention: x along +u, y image up.
pub fn ripple_normal_map() -> Texture8 {
    let n = NORMAL_MAP_SIDE;
    let k = TAU * RIPPLES_PER_TILE / n as f32;
    let texels = (0..n * n)
        .map(|i| {
            let x = (i % n) as f32 + 0.5;
            let dhdx = MAX_SLOPE * (k * x).cos();
            let normal = Vec3::new(-dhdx, 0.0, 1.0).normalize();
            Texture8::encode_normal(normal)
        })
        .collect();
    Texture8 {
        width: n,
        height: n,
        texels,
    }
}

/// 5 m in front of the sphere, a little above its equator.
pub fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 1.0, 5.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        fov_y: 45f32.to_radians(),
        z_near: 0.05,
        z_far: 100.0,
    }
}

/// Toward the study's light: above and to the left of the camera, so the highlight sits
/// on the visible disc away from its rim.
pub fn light_dir() -> Vec3 {
    Vec3::new(-0.5, 0.6, 1.0).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sphere_winds_outward_with_frames_as_the_shaders_decode_them() {
        let scene = build(128).unwrap();
        let mesh = &scene.mesh;
        assert!(mesh.triangle_count() > 8000);
        for t in 0..mesh.triangle_count() {
            let [a, b, c] = mesh.triangle_positions(t);
            let centre = (a + b + c) / 3.0;
            assert!(
                (b - a).cross(c - a).dot(centre) > 0.0,
                "triangle {t} faces inward"
            );
        }
        for v in &mesh.vertices {
            let (n, t) = (Vec3::from(v.normal), Vec3::from_slice(&v.tangent[..3]));
            assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(t).abs() < 1e-5);
            // The bitangent w·(n × t) points toward decreasing v: north, where y grows.
            let bitangent = n.cross(t) * v.tangent[3];
            if n.y.abs() < 0.99 {
                assert!(bitangent.y > 0.0, "{bitangent} at {n}");
            }
            let uv = Vec2::from(v.uv_lightmap);
            assert!(uv.min_element() > 0.0 && uv.max_element() < 1.0);
        }
        let cam = scene.camera;
        assert!(cam.project_to_pixel(Vec3::ZERO, 480, 270).is_some());
    }

    #[test]
    fn the_ripples_spread_the_normals_along_x_only() {
        let map = ripple_normal_map();
        let normals: Vec<Vec3> = map
            .texels
            .iter()
            .map(|t| crate::scene::decode_normal(*t, 1.0))
            .collect();
        let mean = normals.iter().sum::<Vec3>() / normals.len() as f32;
        let var = |f: fn(Vec3) -> f32| {
            normals.iter().map(|&n| f(n).powi(2)).sum::<f32>() / normals.len() as f32
        };
        // y is 0 up to the 8-bit code's half step (128/255·2 − 1 ≈ 0.004).
        assert!(mean.x.abs() < 2e-3 && mean.y.abs() < 5e-3, "{mean}");
        // Anisotropic: all the spread is across the ripples.
        assert!(var(|n| n.x) > 0.1 && var(|n| n.y) < 1e-4);
    }
}
