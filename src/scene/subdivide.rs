//! Conforming subdivision of a mesh to a target edge length (the vertex density of
//! per-vertex PCA, `pcaMv`).
//!
//! Each round splits every edge longer than the target at its midpoint — the decision is
//! the edge's, so both triangles sharing it split it alike and no T-junction appears — and
//! re-triangulates each triangle by how many of its edges were split: one (two triangles,
//! through the opposite corner), two (three: the midpoints joined, the remaining quad cut
//! along its shorter diagonal) or three (four, the midpoint triangle in the centre). Rounds
//! repeat until no edge is longer than the target. Midpoint attributes are the average of
//! the edge's ends (normal and tangent renormalized, the tangent's handedness kept), so the
//! surface and its parameterizations are unchanged: the triangles are planar pieces of the
//! old ones.

use std::collections::HashMap;

use glam::Vec3;

use super::{Mesh, Vertex};

/// Rounds at most: each halves the longest edges, so 2^24 × the target is far beyond
/// any scene.
const MAX_ROUNDS: u32 = 24;

/// `mesh` with no edge longer than `max_edge` metres (module doc).
///
/// # Panics
/// Unless `max_edge` is positive and finite (the CLI validates it).
pub fn subdivide(mesh: &Mesh, max_edge: f32) -> Mesh {
    assert!(
        max_edge.is_finite() && max_edge > 0.0,
        "subdivide: edge {max_edge}"
    );
    let mut out = mesh.clone();
    for _ in 0..MAX_ROUNDS {
        if !split_round(&mut out, max_edge) {
            break;
        }
    }
    out
}

fn position(v: &Vertex) -> Vec3 {
    Vec3::from(v.position)
}

fn midpoint(a: &Vertex, b: &Vertex) -> Vertex {
    let avg = |x: &[f32], y: &[f32], out: &mut [f32]| {
        for ((o, p), q) in out.iter_mut().zip(x).zip(y) {
            *o = 0.5 * (p + q);
        }
    };
    let mut v = *a;
    avg(&a.position, &b.position, &mut v.position);
    avg(&a.uv_material, &b.uv_material, &mut v.uv_material);
    avg(&a.uv_lightmap, &b.uv_lightmap, &mut v.uv_lightmap);
    avg(&a.albedo_tint, &b.albedo_tint, &mut v.albedo_tint);
    let n = (Vec3::from(a.normal) + Vec3::from(b.normal)).normalize_or(Vec3::from(a.normal));
    v.normal = n.into();
    let t = (Vec3::from_slice(&a.tangent[..3]) + Vec3::from_slice(&b.tangent[..3]))
        .normalize_or(Vec3::from_slice(&a.tangent[..3]));
    v.tangent = [t.x, t.y, t.z, a.tangent[3]];
    v
}

/// One round; whether any edge was split.
fn split_round(mesh: &mut Mesh, max_edge: f32) -> bool {
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
    let long = |mesh: &Mesh, a: u32, b: u32| {
        position(&mesh.vertices[a as usize]).distance(position(&mesh.vertices[b as usize]))
            > max_edge
    };
    // Midpoints in triangle order, so the result does not depend on hashing.
    for tri in 0..mesh.indices.len() / 3 {
        for e in 0..3 {
            let (a, b) = (
                mesh.indices[3 * tri + e],
                mesh.indices[3 * tri + (e + 1) % 3],
            );
            if long(mesh, a, b) && !mid.contains_key(&key(a, b)) {
                let v = midpoint(&mesh.vertices[a as usize], &mesh.vertices[b as usize]);
                mid.insert(key(a, b), mesh.vertices.len() as u32);
                mesh.vertices.push(v);
            }
        }
    }
    if mid.is_empty() {
        return false;
    }
    let mut indices = Vec::with_capacity(mesh.indices.len() * 2);
    for tri in mesh.indices.chunks_exact(3) {
        let c = [tri[0], tri[1], tri[2]];
        // m[e]: midpoint of edge e = (c[e], c[e+1]).
        let m: [Option<u32>; 3] =
            std::array::from_fn(|e| mid.get(&key(c[e], c[(e + 1) % 3])).copied());
        match m.iter().filter(|x| x.is_some()).count() {
            0 => indices.extend_from_slice(&c),
            1 => {
                let e = m.iter().position(Option::is_some).expect("one split");
                let (a, b, o, x) = (c[e], c[(e + 1) % 3], c[(e + 2) % 3], m[e].unwrap());
                indices.extend_from_slice(&[a, x, o, x, b, o]);
            }
            2 => {
                // The unsplit edge is e; corners a → b along it, o opposite.
                let e = m.iter().position(Option::is_none).expect("one unsplit");
                let (a, b, o) = (c[e], c[(e + 1) % 3], c[(e + 2) % 3]);
                let (mb, ma) = (m[(e + 1) % 3].unwrap(), m[(e + 2) % 3].unwrap());
                // Corner triangle at o, then the quad a, b, mb, ma cut along its shorter
                // diagonal.
                indices.extend_from_slice(&[ma, mb, o]);
                let p = |i: u32| position(&mesh.vertices[i as usize]);
                if p(a).distance(p(mb)) <= p(b).distance(p(ma)) {
                    indices.extend_from_slice(&[a, b, mb, a, mb, ma]);
                } else {
                    indices.extend_from_slice(&[a, b, ma, b, mb, ma]);
                }
            }
            _ => {
                let [m0, m1, m2] = m.map(Option::unwrap);
                indices.extend_from_slice(&[c[0], m0, m2, m0, c[1], m1, m2, m1, c[2], m0, m1, m2]);
            }
        }
    }
    mesh.indices = indices;
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vertex(p: [f32; 3]) -> Vertex {
        Vertex {
            position: p,
            normal: [0.0, 1.0, 0.0],
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: [p[0], p[2]],
            uv_lightmap: [p[0] / 4.0, p[2] / 4.0],
            albedo_tint: [1.0; 3],
        }
    }

    fn area(mesh: &Mesh) -> f32 {
        (0..mesh.triangle_count())
            .map(|t| {
                let [a, b, c] = mesh.triangle_positions(t);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    #[test]
    fn edges_end_below_the_target_without_t_junctions_and_the_surface_is_kept() {
        // A 4 × 1 quad (two triangles sharing an edge) and a thin sliver.
        let mesh = Mesh {
            vertices: vec![
                vertex([0.0, 0.0, 0.0]),
                vertex([4.0, 0.0, 0.0]),
                vertex([4.0, 0.0, 1.0]),
                vertex([0.0, 0.0, 1.0]),
            ],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let fine = subdivide(&mesh, 0.3);
        assert!((area(&fine) - area(&mesh)).abs() < 1e-4);
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in fine.indices.chunks_exact(3) {
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                let p = |i: u32| position(&fine.vertices[i as usize]);
                assert!(p(a).distance(p(b)) <= 0.3 + 1e-6);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        // Conforming: every edge has one or two triangles, and the one-triangle (boundary)
        // edges add up to the quad's perimeter.
        assert!(edges.values().all(|&n| n <= 2));
        let boundary: f32 = edges
            .iter()
            .filter(|&(_, &n)| n == 1)
            .map(|(&(a, b), _)| {
                position(&fine.vertices[a as usize]).distance(position(&fine.vertices[b as usize]))
            })
            .sum();
        assert!((boundary - 10.0).abs() < 1e-3, "{boundary}");
        // Attributes are interpolated with the position.
        for v in &fine.vertices {
            assert!((v.uv_lightmap[0] - v.position[0] / 4.0).abs() < 1e-6);
        }
        // A mesh already fine enough is returned as is.
        let same = subdivide(&mesh, 10.0);
        assert_eq!((same.vertices, same.indices), (mesh.vertices, mesh.indices));
    }
}
