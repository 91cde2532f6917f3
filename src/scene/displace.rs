//! Real micro-geometry from a material's height field: the ground truth of
//! self-shadowing techniques. The flat, normal-mapped scene is what `rnm`, `ssbump`,
//! `shlmap`… shade; this is the surface their maps describe.
//!
//! The mesh is subdivided ([`super::subdivide`]) until no edge exceeds a texel's diagonal
//! (so a texel-aligned quad ends with a vertex at every texel corner), then every vertex
//! moves along its normal by its height:
//!
//! ```text
//! p' = p + n · h(uv) · s        n' = normalize(t·(−∂h/∂x) + b·(∂h/∂y_up) + n)
//! ```
//!
//! with h bilinear in the field (texel centres at (i+½)/W, wrapped: bump textures tile),
//! its gradient by central differences of that interpolant in texel units, and s the
//! metres per texel of the material's UV mapping — one scale for the scene, the
//! area-weighted mean over its triangles, exact for uniformly mapped scenes such as the
//! built-in ones. Heights are ≥ 0 (mortar at 0, brick faces raised), so a floor meets its
//! walls without a gap for light to leak through. Horizontal and vertical steps are both in
//! texels, so n' is the normal the normal map was derived from (`house::brick_normal`).
//! The result keeps the material's albedo and replaces the normal map by a flat one
//! (`normal_scale` 0): the geometry now carries the detail.

use glam::{Vec3, Vec4};

use super::HeightField;
use super::{Material, Scene, Texture8};

/// Most triangles a displaced scene may have (BVH and G-buffer stay tractable).
pub const MAX_DISPLACED_TRIANGLES: usize = 4_000_000;

/// Errors of displacing a scene, one line each.
#[derive(Debug, thiserror::Error)]
pub enum DisplaceError {
    #[error(
        "scene '{0}' has no height map to displace: use --scene patio (the built-in bricks at a size that displaces)"
    )]
    NoHeightMap(String),
    #[error(
        "scene '{scene}' would need ≈ {triangles} triangles to resolve its height map at one vertex per texel (at most {MAX_DISPLACED_TRIANGLES}); displace a smaller scene such as `patio`"
    )]
    TooLarge { scene: String, triangles: usize },
    #[error("scene '{0}': its material UVs have no area, so heights have no scale")]
    NoUvArea(String),
}

/// Metres per material texel of `scene` (module doc), or `None` without UV area.
pub fn metres_per_texel(scene: &Scene, field: &HeightField) -> Option<f64> {
    let (mut world, mut texels) = (0.0f64, 0.0f64);
    let m = &scene.mesh;
    for t in 0..m.triangle_count() {
        let i = &m.indices[3 * t..3 * t + 3];
        let v = [0, 1, 2].map(|k| &m.vertices[i[k] as usize]);
        let p = v.map(|v| Vec3::from(v.position).as_dvec3());
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let uv = v.map(|v| glam::DVec2::from(v.uv_material.map(f64::from)));
        let (a, b) = (uv[1] - uv[0], uv[2] - uv[0]);
        let area_uv = 0.5 * (a.x * b.y - a.y * b.x).abs() * (field.width * field.height) as f64;
        if area.is_finite() && area_uv.is_finite() && area_uv > 0.0 {
            world += area;
            texels += area_uv;
        }
    }
    // Σ area / Σ texels = area-weighted mean of each triangle's (metres per texel)².
    (texels > 0.0).then(|| (world / texels).sqrt())
}

/// Whether `scene` can be displaced: it has a height map, its material UVs have area, and
/// its estimated triangles stay within [`MAX_DISPLACED_TRIANGLES`] (a cheap check, before
/// any bake).
///
/// # Errors
/// Which of those fails.
pub fn displaceable(scene: &Scene) -> Result<(), DisplaceError> {
    height_and_scale(scene).map(|_| ())
}

/// The height map of `scene` and its metres per texel, when it can be displaced
/// ([`displaceable`]).
fn height_and_scale(scene: &Scene) -> Result<(&HeightField, f64), DisplaceError> {
    let field = scene
        .material
        .height
        .as_ref()
        .ok_or_else(|| DisplaceError::NoHeightMap(scene.name.clone()))?;
    let scale = metres_per_texel(scene, field)
        .ok_or_else(|| DisplaceError::NoUvArea(scene.name.clone()))?;
    let area: f64 = (0..scene.mesh.triangle_count())
        .map(|t| {
            let p = scene.mesh.triangle_positions(t).map(|p| p.as_dvec3());
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum();
    // Right triangles with one-texel legs: two per texel².
    let estimate = (2.0 * area / (scale * scale)) as usize;
    if estimate > MAX_DISPLACED_TRIANGLES {
        return Err(DisplaceError::TooLarge {
            scene: scene.name.clone(),
            triangles: estimate,
        });
    }
    Ok((field, scale))
}

/// `scene` with its height-mapped surfaces displaced into real geometry (module doc).
///
/// # Errors
/// [`DisplaceError`] when the scene has no height map, no UV area, or would need more than
/// [`MAX_DISPLACED_TRIANGLES`].
pub fn displace(scene: &Scene) -> Result<Scene, DisplaceError> {
    let (field, scale) = height_and_scale(scene)?;
    let mut mesh = super::subdivide::subdivide(
        &scene.mesh,
        (scale * std::f64::consts::SQRT_2 * 1.0001) as f32,
    );
    if mesh.triangle_count() > MAX_DISPLACED_TRIANGLES {
        return Err(DisplaceError::TooLarge {
            scene: scene.name.clone(),
            triangles: mesh.triangle_count(),
        });
    }
    for v in &mut mesh.vertices {
        let (x, y) = (
            f64::from(v.uv_material[0]) * field.width as f64 - 0.5,
            f64::from(v.uv_material[1]) * field.height as f64 - 0.5,
        );
        let h = field.sample(x, y);
        let dhdx = 0.5 * (field.sample(x + 1.0, y) - field.sample(x - 1.0, y));
        // +Y (image up) is −v, the row above.
        let dhdy_up = 0.5 * (field.sample(x, y - 1.0) - field.sample(x, y + 1.0));
        let n = Vec3::from(v.normal);
        let tangent = super::tangent::orthonormalize(n, Vec4::from(v.tangent));
        let t = tangent.truncate();
        let b = n.cross(t) * tangent.w;
        let p = Vec3::from(v.position) + n * (h * scale) as f32;
        let normal = (t * -dhdx as f32 + b * -dhdy_up as f32 + n).normalize_or(n);
        v.position = p.into();
        v.normal = normal.into();
        v.tangent = super::tangent::orthonormalize(normal, tangent).into();
    }
    let flat = Texture8 {
        width: 1,
        height: 1,
        texels: vec![[128, 128, 255, 255]],
    };
    Ok(Scene {
        name: format!("{}-displaced", scene.name),
        mesh,
        material: Material {
            albedo: scene.material.albedo.clone(),
            normal: flat,
            normal_scale: 0.0,
            height: None,
        },
        camera: scene.camera,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_patio_displaces_at_one_texel_and_the_house_is_refused() {
        let patio = super::super::patio::build(128).unwrap();
        let field = patio.material.height.clone().unwrap();
        let s = metres_per_texel(&patio, &field).unwrap();
        assert!((s - 1.0 / 256.0).abs() < 1e-9, "{s}");
        let displaced = displace(&patio).unwrap();
        let n = displaced.mesh.triangle_count();
        assert!((200_000..600_000).contains(&n), "{n}");
        // Heights lie between the mortar (0) and the brick faces, along each face normal.
        let top = field.h.iter().copied().fold(0.0, f64::max) * s;
        let mut raised = 0usize;
        for v in &displaced.mesh.vertices {
            let p = Vec3::from(v.position);
            // Distance in front of the nearest of the floor and the two wall planes.
            let off = p.y.min(p.z + 0.5).min(p.x + 0.5);
            assert!(off > -1e-5 && off < top as f32 + 1e-5, "{p}");
            raised += usize::from(off > 0.5 * top as f32);
        }
        assert!(
            raised > displaced.mesh.vertices.len() / 2,
            "most texels are brick faces"
        );
        match displace(&crate::scene::house::build(512).unwrap()) {
            Err(DisplaceError::TooLarge { .. }) => {}
            other => panic!("the house displaced: {:?}", other.map(|s| s.name)),
        }
    }
}
