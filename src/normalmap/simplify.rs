//! Low meshes for normal-map generation: from one detailed mesh by simplification
//! (meshoptimizer's edge collapse, through the `meshopt` crate), and the built-in test
//! shapes (icospheres; `sphere:LEVEL`). Either way the low mesh gets smooth normals, a
//! unique material parameterization from the chart generator
//! ([`crate::scene::lightmap_uv::generate`], gutters of 2 texels at the map's resolution,
//! also used as its lightmap UVs) and MikkTSpace tangents on it, de-indexed so every
//! corner keeps its own tangent.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::NormalMapError;
use crate::scene::{Mesh, Vertex, lightmap_uv, tangent};

/// What [`simplify`] did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SimplifyReport {
    pub from_triangles: usize,
    pub to_triangles: usize,
    /// meshoptimizer's resulting error, relative to the mesh extent.
    pub relative_error: f32,
    pub charts: usize,
}

/// Positions welded exactly and the triangles re-indexed onto them (UV and normal seams
/// do not block collapses: the low mesh gets new ones).
fn weld(mesh: &Mesh) -> (Vec<[f32; 3]>, Vec<u32>) {
    let mut index_of: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let remap: Vec<u32> = mesh
        .vertices
        .iter()
        .map(|v| {
            *index_of
                .entry(v.position.map(f32::to_bits))
                .or_insert_with(|| {
                    positions.push(v.position);
                    (positions.len() - 1) as u32
                })
        })
        .collect();
    let indices = mesh.indices.iter().map(|&i| remap[i as usize]).collect();
    (positions, indices)
}

/// Simplifies `high` to about `ratio` of its triangles and prepares it as a low mesh for a
/// `res`² map (module doc).
///
/// # Errors
/// A ratio outside (0, 1], a result without triangles, or charts that do not fit `res`.
pub fn simplify(
    high: &Mesh,
    ratio: f32,
    res: u32,
) -> Result<(Mesh, SimplifyReport), NormalMapError> {
    if !(ratio > 0.0 && ratio <= 1.0) {
        return Err(NormalMapError::Invalid(format!(
            "--simplify {ratio} must be in (0, 1]"
        )));
    }
    let (positions, indices) = weld(high);
    let target = ((indices.len() / 3) as f32 * ratio).round().max(1.0) as usize * 3;
    let adapter = meshopt::VertexDataAdapter::new(bytemuck::cast_slice(&positions), 12, 0)
        .map_err(|e| NormalMapError::Invalid(format!("simplify: {e}")))?;
    let mut relative_error = 0.0f32;
    let simplified = meshopt::simplify(
        &indices,
        &adapter,
        target,
        f32::MAX,
        meshopt::SimplifyOptions::None,
        Some(&mut relative_error),
    );
    if simplified.is_empty() {
        return Err(NormalMapError::Invalid(
            "simplification left no triangles".into(),
        ));
    }
    let positions: Vec<Vec3> = positions.iter().map(|&p| Vec3::from(p)).collect();
    let (low, charts) = prepare_low(&positions, &simplified, res)?;
    let report = SimplifyReport {
        from_triangles: high.triangle_count(),
        to_triangles: low.triangle_count(),
        relative_error,
        charts,
    };
    Ok((low, report))
}

/// Corners whose faces meet at more than this angle get separate normals.
pub const CREASE_ANGLE_DEG: f32 = 60.0;

/// A low mesh from positions and triangles: per corner the area-weighted normal of the
/// faces around its vertex within [`CREASE_ANGLE_DEG`] of its own face (smooth across
/// gentle curvature, split at creases such as a board's edges), generated charts as
/// material (and lightmap) UVs for a `res`² map, MikkTSpace tangents; de-indexed (module
/// doc). Returns the mesh and its chart count.
///
/// # Errors
/// Charts that do not fit `res`.
pub fn prepare_low(
    positions: &[Vec3],
    indices: &[u32],
    res: u32,
) -> Result<(Mesh, usize), NormalMapError> {
    let triangles = indices.len() / 3;
    let corner = |t: usize, k: usize| positions[indices[3 * t + k] as usize];
    let area_normals: Vec<Vec3> = (0..triangles)
        .map(|t| (corner(t, 1) - corner(t, 0)).cross(corner(t, 2) - corner(t, 0)))
        .collect();
    let mut faces_at: Vec<Vec<u32>> = vec![Vec::new(); positions.len()];
    for t in 0..triangles {
        for k in 0..3 {
            faces_at[indices[3 * t + k] as usize].push(t as u32);
        }
    }
    let cos_crease = CREASE_ANGLE_DEG.to_radians().cos();
    let mut mesh = Mesh::default();
    for t in 0..triangles {
        let own = area_normals[t].normalize_or_zero();
        for k in 0..3 {
            let v = indices[3 * t + k] as usize;
            let normal: Vec3 = faces_at[v]
                .iter()
                .map(|&f| area_normals[f as usize])
                .filter(|n| n.normalize_or_zero().dot(own) >= cos_crease)
                .sum();
            mesh.indices.push(mesh.vertices.len() as u32);
            mesh.vertices.push(Vertex {
                position: positions[v].to_array(),
                normal: normal.normalize_or(own).to_array(),
                albedo_tint: [1.0; 3],
                ..Vertex::default()
            });
        }
    }
    let charts = lightmap_uv::generate(&mut mesh, res)
        .map_err(|e| {
            NormalMapError::Invalid(format!(
                "the low mesh's {} charts do not fit a {res}² map",
                e.charts
            ))
        })?
        .charts;
    for v in &mut mesh.vertices {
        v.uv_material = v.uv_lightmap;
    }
    let tangents = tangent::generate(
        &mesh
            .vertices
            .iter()
            .map(|v| Vec3::from(v.position))
            .collect::<Vec<_>>(),
        &mesh
            .vertices
            .iter()
            .map(|v| Vec3::from(v.normal))
            .collect::<Vec<_>>(),
        &mesh
            .vertices
            .iter()
            .map(|v| Vec2::from(v.uv_material))
            .collect::<Vec<_>>(),
        &mesh.indices,
    );
    let vertices = mesh
        .indices
        .iter()
        .zip(&tangents)
        .map(|(&i, t)| Vertex {
            tangent: t.to_array(),
            ..mesh.vertices[i as usize]
        })
        .collect();
    let corners = mesh.indices.len() as u32;
    Ok((
        Mesh {
            vertices,
            indices: (0..corners).collect(),
        },
        charts,
    ))
}

/// A unit icosphere: the icosahedron with each triangle split into 4 `level` times, every
/// vertex projected onto the unit sphere (20·4^level triangles). Positions and indices.
pub fn icosphere(level: u32) -> (Vec<Vec3>, Vec<u32>) {
    let g = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, g, 0.0),
        (1.0, g, 0.0),
        (-1.0, -g, 0.0),
        (1.0, -g, 0.0),
        (0.0, -1.0, g),
        (0.0, 1.0, g),
        (0.0, -1.0, -g),
        (0.0, 1.0, -g),
        (g, 0.0, -1.0),
        (g, 0.0, 1.0),
        (-g, 0.0, -1.0),
        (-g, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut indices: Vec<u32> = vec![
        0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7,
        1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9,
        8, 1,
    ];
    for _ in 0..level {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut split = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let p = ((positions[a as usize] + positions[b as usize]) * 0.5).normalize();
                positions.push(p);
                (positions.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(indices.len() * 4);
        for t in indices.chunks_exact(3) {
            let (a, b, c) = (t[0], t[1], t[2]);
            let ab = split(a, b, &mut positions);
            let bc = split(b, c, &mut positions);
            let ca = split(c, a, &mut positions);
            next.extend_from_slice(&[a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca]);
        }
        indices = next;
    }
    (positions, indices)
}

/// A high-mesh icosphere of `radius`: vertex normals are the exact sphere normals.
pub fn sphere_high(level: u32, radius: f32) -> Mesh {
    let (positions, indices) = icosphere(level);
    Mesh {
        vertices: positions
            .iter()
            .map(|&p| Vertex {
                position: (p * radius).to_array(),
                normal: p.to_array(),
                albedo_tint: [1.0; 3],
                ..Vertex::default()
            })
            .collect(),
        indices,
    }
}

/// A low-mesh icosphere of `radius` prepared for a `res`² map ([`prepare_low`]).
///
/// # Errors
/// Charts that do not fit `res`.
pub fn sphere_low(level: u32, radius: f32, res: u32) -> Result<Mesh, NormalMapError> {
    let (positions, indices) = icosphere(level);
    let positions: Vec<Vec3> = positions.iter().map(|&p| p * radius).collect();
    Ok(prepare_low(&positions, &indices, res)?.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts_and_radius() {
        for level in 0..4 {
            let (p, i) = icosphere(level);
            assert_eq!(i.len() / 3, 20 * 4usize.pow(level));
            // Euler: V − E + F = 2 with E = 3F/2.
            assert_eq!(p.len() + i.len() / 3 - i.len() / 2, 2);
            assert!(p.iter().all(|p| (p.length() - 1.0).abs() < 1e-6));
        }
    }

    #[test]
    fn simplified_low_mesh_has_unique_uvs_and_unit_frames() {
        let high = sphere_high(4, 1.0);
        let (low, report) = simplify(&high, 0.05, 256).unwrap();
        assert!(
            report.to_triangles < high.triangle_count() / 10,
            "{report:?}"
        );
        assert!(report.to_triangles >= 20, "{report:?}");
        assert!(
            low.vertices
                .iter()
                .all(|v| v.uv_material.iter().all(|c| (0.0..=1.0).contains(c)))
        );
        for v in &low.vertices {
            let (n, t) = (Vec3::from(v.normal), Vec3::from_slice(&v.tangent[..3]));
            assert!((n.length() - 1.0).abs() < 1e-4 && (t.length() - 1.0).abs() < 1e-3);
            assert!(n.dot(t).abs() < 1e-3);
        }
        assert!(simplify(&high, 0.0, 256).is_err());
    }
}
