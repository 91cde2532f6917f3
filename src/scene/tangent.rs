//! Generated tangent frames (DESIGN §1): MikkTSpace (Mikkelsen 2008, the `bevy_mikktspace`
//! crate) run on (u, 1 − v).
//!
//! glTF's UV origin is the top-left corner, so image-up is *decreasing* v. MikkTSpace's
//! bitangent points toward increasing texture t; feeding it t = 1 − v makes the encoded
//! bitangent w·(n × t) point toward decreasing v, which is what glTF normal maps (+Y green =
//! image up) and Blender's exporter expect. The tangent (+u) is unaffected by the flip.
//!
//! Corners where MikkTSpace cannot produce a frame (no UV variation, a failed run) get
//! [`fallback_tangent`]: any unit vector perpendicular to the normal, w = +1. Every output is
//! Gram–Schmidt orthonormalized against its normal. Tests: a quad with known UVs, a mirrored
//! quad (w = −1), and a quad without UV variation.

use glam::{Vec2, Vec3, Vec4};

/// Tangent lengths below this (after removing the normal component) count as undefined.
const MIN_TANGENT_LENGTH: f32 = 1e-6;

/// Mesh data MikkTSpace reads, one face per triangle of `indices`.
struct Faces<'a> {
    positions: &'a [Vec3],
    normals: &'a [Vec3],
    uvs: &'a [Vec2],
    indices: &'a [u32],
    /// Output, one per corner (3 per triangle).
    tangents: Vec<Vec4>,
}

impl Faces<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.indices[3 * face + vert] as usize
    }
}

impl bevy_mikktspace::Geometry for Faces<'_> {
    fn num_faces(&self) -> usize {
        self.indices.len() / 3
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[self.vertex(face, vert)].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[self.vertex(face, vert)].to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        // DESIGN §1: (u, 1 − v), so the bitangent points toward decreasing v.
        let uv = self.uvs[self.vertex(face, vert)];
        [uv.x, 1.0 - uv.y]
    }
    fn set_tangent(
        &mut self,
        tangent_space: Option<bevy_mikktspace::TangentSpace>,
        face: usize,
        vert: usize,
    ) {
        // None (a degenerate face with no neighbour to borrow from) stays zero and gets
        // the fallback below.
        if let (Some(ts), Some(slot)) = (tangent_space, self.tangents.get_mut(3 * face + vert)) {
            *slot = Vec4::from_array(ts.tangent_encoded());
        }
    }
}

/// Any unit tangent perpendicular to unit `normal`, w = +1 (used where UVs define none).
pub fn fallback_tangent(normal: Vec3) -> Vec4 {
    let n = normal.try_normalize().unwrap_or(Vec3::Z);
    n.any_orthonormal_vector().extend(1.0)
}

/// `tangent` made unit and perpendicular to `normal` with w = ±1, or the fallback when it
/// has no component off the normal (or is not finite).
pub fn orthonormalize(normal: Vec3, tangent: Vec4) -> Vec4 {
    let t = tangent.truncate();
    let ortho = t - normal * normal.dot(t);
    let w = if tangent.w < 0.0 { -1.0 } else { 1.0 };
    if ortho.is_finite() && ortho.length() > MIN_TANGENT_LENGTH {
        ortho.normalize().extend(w)
    } else {
        fallback_tangent(normal)
    }
}

/// MikkTSpace tangents of an indexed triangle list, one per corner (`indices.len()`
/// values, triangle t's corners at 3t..3t+3), each unit, ⊥ its vertex normal, w = ±1 with
/// the bitangent w·(n × t) toward decreasing v.
///
/// `positions`, `normals` (unit) and `uvs` (material, TEXCOORD_0) are per vertex; every
/// index must be in range (debug-checked; the loader validates files).
pub fn generate(positions: &[Vec3], normals: &[Vec3], uvs: &[Vec2], indices: &[u32]) -> Vec<Vec4> {
    debug_assert!(
        indices
            .iter()
            .all(|&i| (i as usize) < positions.len().min(normals.len()).min(uvs.len())),
        "index out of range"
    );
    let corners = indices.len() / 3 * 3;
    let mut faces = Faces {
        positions,
        normals,
        uvs,
        indices: &indices[..corners],
        tangents: vec![Vec4::ZERO; corners],
    };
    if corners == 0 || bevy_mikktspace::generate_tangents(&mut faces).is_err() {
        faces.tangents.iter_mut().for_each(|t| *t = Vec4::ZERO);
    }
    faces
        .tangents
        .iter()
        .zip(&indices[..corners])
        .map(|(&t, &i)| orthonormalize(normals[i as usize], t))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// MikkTSpace works in f32 on unit-sized input.
    const TOL: f32 = 1e-5;

    /// A unit quad in the XY plane facing +Z, counter-clockwise, with the given corner UVs
    /// (corners at (0,0), (1,0), (1,1), (0,1)).
    fn quad(uvs: [Vec2; 4]) -> Vec<Vec4> {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        generate(&p, &[Vec3::Z; 4], &uvs, &[0, 1, 2, 0, 2, 3])
    }

    fn bitangent(t: Vec4) -> Vec3 {
        t.w * Vec3::Z.cross(t.truncate())
    }

    #[test]
    fn quad_tangent_is_plus_u_and_bitangent_toward_decreasing_v() {
        // glTF layout: image top (v = 0) at world +Y, so decreasing v is +Y.
        let t = quad([
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
        ]);
        assert_eq!(t.len(), 6);
        for c in t {
            assert!((c.truncate() - Vec3::X).length() < TOL, "tangent {c}");
            assert_eq!(c.w, 1.0);
            assert!((bitangent(c) - Vec3::Y).length() < TOL, "bitangent {c}");
        }
    }

    #[test]
    fn mirrored_uvs_flip_w() {
        // u still runs along +X, but v now decreases toward world −Y: w = −1.
        let t = quad([
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]);
        for c in t {
            assert!((c.truncate() - Vec3::X).length() < TOL, "tangent {c}");
            assert_eq!(c.w, -1.0);
            assert!((bitangent(c) + Vec3::Y).length() < TOL, "bitangent {c}");
        }
        // Mirrored in u: u runs along −X.
        let t = quad([
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
        ]);
        for c in t {
            assert!((c.truncate() + Vec3::X).length() < TOL, "tangent {c}");
            assert!((bitangent(c) - Vec3::Y).length() < TOL, "bitangent {c}");
        }
    }

    #[test]
    fn constant_uvs_give_a_unit_perpendicular_fallback() {
        for c in quad([Vec2::ZERO; 4]) {
            assert!((c.truncate().length() - 1.0).abs() < TOL);
            assert!(c.truncate().dot(Vec3::Z).abs() < TOL);
            assert_eq!(c.w.abs(), 1.0);
        }
    }
}
