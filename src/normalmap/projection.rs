//! The per-triangle view of Gumbau et al. §3.2: a model/view matrix looking at a low
//! triangle T along its normal (eqs. (1)–(2)) and the pseudo-orthographic projection that
//! maps T onto its texture-space image t (eqs. (3)–(5)), plus the depth mapping of vertex
//! mirroring (§3.4, eq. (6)).
//!
//! **MV.** The camera sits at T's centroid c plus `max_distance`·N, looks at c (view −z =
//! −N), and its up vector is the 3D direction in which v grows along T (eqs. (1)–(2)):
//! solve α Δt₂ + β Δt₃ = (0, 1) in texture space, UP = ‖α Δv₂ + β Δv₃‖. In view space
//! T lies in the plane z = −D (D = `max_distance`), so a vertex's signed distance to T's
//! plane Π is k = z + D.
//!
//! **P** (Fig. 3). x and y of clip space depend on view x, y only (no z column): the six
//! unknowns P_A…P_F solve P·wⁱ = Ntⁱ for T's three view-space corners wⁱ (eq. (4)), with
//! Ntⁱ = 2tⁱ − 1 (eq. (5)) — Vulkan's NDC y points down the framebuffer, so texture row 0
//! (v = 0) is NDC y = −1 and texel (x, y) is framebuffer pixel (x, y). The z row maps depth:
//! - with mirroring, the vertex shader first replaces z by −D − |k| (eq. (6), mirroring
//!   every vertex behind Π, so "nearest the camera" becomes "nearest Π" on both sides);
//!   depth = |k| / D ∈ [0, 1];
//! - without it (the paper's failure case of Fig. 4), depth = (D − k) / 2D: the surface
//!   nearest the camera wins, k ∈ [−D, D].
//!
//! Surfaces farther than D from Π are clipped: D is the search distance the CPU baker's
//! rays use too (both directions), the equivalent of a ray caster's cage.

use glam::{DMat3, DVec3, Mat4, Vec2, Vec3, Vec4};

/// The two matrices one low triangle's render uses (`glsl/normalmap/project.vert`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleView {
    /// World → view (eq. (2)'s camera).
    pub view_from_world: Mat4,
    /// View → clip, pseudo-orthographic (Fig. 3), for the chosen depth mapping.
    pub clip_from_view: Mat4,
}

/// The up vector of eqs. (1)–(2): the unit 3D direction along T in which texture v grows.
/// `None` when T has no area in texture space (eq. (1) is singular) or in 3D.
pub fn up_vector(v: [Vec3; 3], t: [Vec2; 3]) -> Option<Vec3> {
    let (a, b) = ((t[1] - t[0]).as_dvec2(), (t[2] - t[0]).as_dvec2());
    // α a + β b = (0, 1), by Cramer's rule.
    let det = a.x * b.y - b.x * a.y;
    if det.abs() < 1e-20 {
        return None;
    }
    let alpha = -b.x / det;
    let beta = a.x / det;
    let up = (v[1] - v[0]).as_dvec3() * alpha + (v[2] - v[0]).as_dvec3() * beta;
    let up = up.try_normalize()?;
    up.is_finite().then(|| up.as_vec3())
}

/// T's unit normal from its winding (v₁ − v₀) × (v₂ − v₀); `None` when degenerate.
pub fn face_normal(v: [Vec3; 3]) -> Option<Vec3> {
    let n = (v[1] - v[0]).as_dvec3().cross((v[2] - v[0]).as_dvec3());
    n.try_normalize().map(DVec3::as_vec3)
}

/// The view and projection of low triangle `v` with texture coordinates `t` (module doc).
/// `None` for a triangle without area in 3D or in texture space (it owns no texels).
pub fn triangle_view(
    v: [Vec3; 3],
    t: [Vec2; 3],
    max_distance: f32,
    mirror: bool,
) -> Option<TriangleView> {
    let normal = face_normal(v)?;
    let up = up_vector(v, t)?;
    let centroid = (v[0] + v[1] + v[2]) / 3.0;
    let d = max_distance;
    let view_from_world = look_along(centroid + normal * d, -normal, up);
    // Eq. (3) for the x and y rows: [w.x w.y 1] · (P_A, P_B, P_C) = Nt.x, likewise y.
    let w = v.map(|p| view_from_world.transform_point3(p).as_dvec3());
    let rows = DMat3::from_cols(
        DVec3::new(w[0].x, w[1].x, w[2].x),
        DVec3::new(w[0].y, w[1].y, w[2].y),
        DVec3::ONE,
    );
    if rows.determinant().abs() < 1e-30 {
        return None;
    }
    let inverse = rows.inverse();
    let ndc = t.map(|t| t.as_dvec2() * 2.0 - 1.0); // eq. (5)
    let row_x = inverse * DVec3::new(ndc[0].x, ndc[1].x, ndc[2].x);
    let row_y = inverse * DVec3::new(ndc[0].y, ndc[1].y, ndc[2].y);
    // depth = (−z − near) / (far − near), view z ∈ [−far, −near].
    let (near, far) = if mirror { (d, 2.0 * d) } else { (0.0, 2.0 * d) };
    let rows = [
        Vec4::new(row_x.x as f32, row_x.y as f32, 0.0, row_x.z as f32),
        Vec4::new(row_y.x as f32, row_y.y as f32, 0.0, row_y.z as f32),
        Vec4::new(0.0, 0.0, -1.0 / (far - near), -near / (far - near)),
        Vec4::W,
    ];
    let clip_from_view = Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose();
    clip_from_view.is_finite().then_some(TriangleView {
        view_from_world,
        clip_from_view,
    })
}

/// Right-handed view matrix of a camera at `eye` looking along unit `forward` (view −z)
/// with unit `up` ⊥ `forward` (view +y).
fn look_along(eye: Vec3, forward: Vec3, up: Vec3) -> Mat4 {
    let side = forward.cross(up).normalize();
    let up = side.cross(forward);
    Mat4::from_cols(
        Vec4::new(side.x, up.x, -forward.x, 0.0),
        Vec4::new(side.y, up.y, -forward.y, 0.0),
        Vec4::new(side.z, up.z, -forward.z, 0.0),
        Vec4::new(-side.dot(eye), -up.dot(eye), forward.dot(eye), 1.0),
    )
}

impl TriangleView {
    /// Clip position of world point `p` as `glsl/normalmap/project.vert` computes it
    /// (mirroring with `max_distance` when `mirror`).
    pub fn project(&self, p: Vec3, max_distance: f32, mirror: bool) -> Vec4 {
        let mut w = self.view_from_world * p.extend(1.0);
        if mirror {
            let k = w.z + max_distance;
            w.z = -max_distance - k.abs();
        }
        self.clip_from_view * w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> ([Vec3; 3], [Vec2; 3]) {
        (
            [
                Vec3::new(0.3, -0.2, 1.0),
                Vec3::new(1.4, 0.1, 0.7),
                Vec3::new(0.2, 1.1, 1.3),
            ],
            [
                Vec2::new(0.1, 0.2),
                Vec2::new(0.6, 0.25),
                Vec2::new(0.2, 0.7),
            ],
        )
    }

    #[test]
    fn corners_land_on_their_texture_coordinates_at_zero_distance() {
        let (v, t) = sample();
        for mirror in [true, false] {
            let view = triangle_view(v, t, 0.5, mirror).unwrap();
            for k in 0..3 {
                let clip = view.project(v[k], 0.5, mirror);
                let ndc = t[k] * 2.0 - 1.0;
                assert!(
                    (clip.truncate().truncate() - ndc).length() < 1e-5,
                    "{clip} vs {ndc}"
                );
                let plane_depth = if mirror { 0.0 } else { 0.5 };
                assert!((clip.z - plane_depth).abs() < 1e-5, "depth {}", clip.z);
                assert_eq!(clip.w, 1.0);
            }
        }
    }

    #[test]
    fn projection_is_orthographic_along_the_normal_and_mirrors_depth() {
        let (v, t) = sample();
        let n = face_normal(v).unwrap();
        let view = triangle_view(v, t, 0.5, true).unwrap();
        let p = (v[0] + v[1] * 2.0 + v[2]) / 4.0;
        let (front, back) = (p + n * 0.2, p - n * 0.2);
        let [cp, cf, cb] = [p, front, back].map(|q| view.project(q, 0.5, true));
        // Same texel in front, behind and on the plane; depth |k| / D on both sides.
        assert!((cf.truncate().truncate() - cp.truncate().truncate()).length() < 1e-5);
        assert!((cb.truncate().truncate() - cp.truncate().truncate()).length() < 1e-5);
        assert!((cf.z - 0.4).abs() < 1e-5 && (cb.z - 0.4).abs() < 1e-5);
        // Without mirroring the front point is nearer the camera than the back one.
        let plain = triangle_view(v, t, 0.5, false).unwrap();
        let (zf, zb) = (
            plain.project(front, 0.5, false).z,
            plain.project(back, 0.5, false).z,
        );
        assert!(
            (zf - 0.3).abs() < 1e-5 && (zb - 0.7).abs() < 1e-5,
            "{zf} {zb}"
        );
    }

    #[test]
    fn up_vector_points_along_increasing_v() {
        let (v, t) = sample();
        let up = up_vector(v, t).unwrap();
        let n = face_normal(v).unwrap();
        assert!(up.dot(n).abs() < 1e-5, "UP lies in T's plane");
        // Moving along UP from the centroid changes v only (eq. (1)).
        let view = triangle_view(v, t, 1.0, false).unwrap();
        let c = (v[0] + v[1] + v[2]) / 3.0;
        let d = view.project(c + up * 0.01, 1.0, false) - view.project(c, 1.0, false);
        assert!(d.x.abs() < 1e-6 && d.y > 0.0, "{d}");
    }

    #[test]
    fn degenerate_triangles_have_no_view() {
        let (v, t) = sample();
        assert!(triangle_view([v[0], v[1], v[0]], t, 1.0, true).is_none());
        assert!(triangle_view(v, [t[0], t[0], t[1]], 1.0, true).is_none());
    }
}
