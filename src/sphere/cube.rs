//! Cube-map parameterization with hardware bilinear filtering, per face (`dx9`) or
//! seamless across faces (`dx10`) — the last two candidates of Iwanicki–Sloan App. A.
//!
//! # Face selection (Vulkan spec, "Cube Map Face Selection and Transformations")
//!
//! Faces in layer order +X, −X, +Y, −Y, +Z, −Z (also D3D's `D3DCUBEMAP_FACES` order). The
//! major axis ma is the component of largest magnitude; (sc, tc) come from the spec's table
//! and the face coordinates are s = ½(sc/|ma| + 1), t = ½(tc/|ma| + 1) ∈ [0, 1]:
//!
//! ```text
//! face  layer   sc    tc    ma        as axes (N, S, T): cube point = N + sc·S + tc·T
//!  +X     0    −rz   −ry   rx         N=+X  S=−Z  T=−Y
//!  −X     1    +rz   −ry   rx         N=−X  S=+Z  T=−Y
//!  +Y     2    +rx   +rz   ry         N=+Y  S=+X  T=+Z
//!  −Y     3    +rx   −rz   ry         N=−Y  S=+X  T=−Z
//!  +Z     4    +rx   −ry   rz         N=+Z  S=+X  T=−Y
//!  −Z     5    −rx   −ry   rz         N=−Z  S=−X  T=−Y
//! ```
//!
//! Ties (directions exactly on a cube edge) go to X, then Y — the spec lets the
//! implementation choose; with seamless filtering every choice gives the same value.
//! Texel (i, j) of a face covers s ∈ [i/res, (i+1)/res), t ∈ [j/res, (j+1)/res) (i along
//! s, j along t), centre ((i+½)/res, (j+½)/res).
//!
//! # Filtering
//!
//! Bilinear as the texture unit does it (Vulkan spec "Texel Filtering", linear): with
//! x = s·res − ½, i₀ = ⌊x⌋, α = x − i₀ (same for t, j₀, β) the four texels
//! (i₀, j₀), (i₀+1, j₀), (i₀, j₀+1), (i₀+1, j₀+1) get weights (1−α)(1−β), α(1−β), (1−α)β,
//! αβ. Weights are exact f64 here; real hardware rounds α, β to 8 fractional bits
//! (D3D10+) — a ≤ 2⁻⁹ relative difference that this CPU reference leaves out.
//!
//! - **`dx9`** (per face): texel indices outside the face are clamped to its edge
//!   (clamp-to-edge addressing within the face, as non-seamless D3D9/GL cube maps and
//!   `VK_EXT_non_seamless_cube_map` with `CLAMP_TO_EDGE`). Discontinuous across edges.
//! - **`dx10`** (seamless; Vulkan spec "Cube Map Edge Handling", D3D10+,
//!   `ARB_seamless_cube_map`): a texel one step outside a face edge is the texel of the
//!   adjacent face that touches the same edge at the same position along it. [`seamless_taps`]
//!   finds it geometrically: the cube-surface point on the shared edge at that texel's
//!   along-edge coordinate, re-expressed in the adjacent face's (sc, tc) (one of which is
//!   then ±1), with the edge coordinate rounded to the edge row of that face. At a cube
//!   corner one of the four texels lies outside in both i and j and exists on no face; it
//!   is replaced by the average of the three texels that meet at the corner (the other
//!   three taps), as OpenGL 4.6 §8.14.1 / `ARB_seamless_cube_map` recommend and Vulkan's
//!   edge handling follows (the specs allow implementations some latitude there, so a GPU
//!   may differ in the corner texel by rounding). Continuous everywhere, corners included
//!   (tests `seamless_is_continuous_across_every_edge`, `seamless_is_continuous_at_all_8_corners`
//!   in `tests/sphere.rs`).

use glam::{DVec2, DVec3};

use super::BilinearTaps;

/// Number of faces of a cube map.
pub const FACE_COUNT: u32 = 6;

/// Face names in layer order (Vulkan/D3D): +X, −X, +Y, −Y, +Z, −Z.
pub const FACE_NAMES: [&str; 6] = ["+X", "-X", "+Y", "-Y", "+Z", "-Z"];

/// (N, S, T) per face, from the Vulkan face-selection table (module doc): the cube point
/// of face coordinates (sc, tc) is N + sc·S + tc·T, and sc = d·S/|ma|, tc = d·T/|ma|.
const FACE_AXES: [[DVec3; 3]; 6] = [
    [DVec3::X, DVec3::NEG_Z, DVec3::NEG_Y],
    [DVec3::NEG_X, DVec3::Z, DVec3::NEG_Y],
    [DVec3::Y, DVec3::X, DVec3::Z],
    [DVec3::NEG_Y, DVec3::X, DVec3::NEG_Z],
    [DVec3::Z, DVec3::X, DVec3::NEG_Y],
    [DVec3::NEG_Z, DVec3::NEG_X, DVec3::NEG_Y],
];

/// The face whose major axis is that of `dir` (ties: X, then Y, see the module doc).
pub fn face_of(dir: DVec3) -> u32 {
    let a = dir.abs();
    let (axis, negative) = if a.x >= a.y && a.x >= a.z {
        (0, dir.x < 0.0)
    } else if a.y >= a.z {
        (1, dir.y < 0.0)
    } else {
        (2, dir.z < 0.0)
    };
    2 * axis + u32::from(negative)
}

/// Face and face coordinates (s, t) ∈ [0, 1]² of `dir` (any non-zero length).
pub fn dir_to_face_st(dir: DVec3) -> (u32, DVec2) {
    let face = face_of(dir);
    let [n, s, t] = FACE_AXES[face as usize];
    let ma = dir.dot(n); // |ma| > 0 for a non-zero direction
    let sc = dir.dot(s) / ma;
    let tc = dir.dot(t) / ma;
    (face, DVec2::new(0.5 * (sc + 1.0), 0.5 * (tc + 1.0)))
}

/// Unit direction of face coordinates `st` on `face`; inverse of [`dir_to_face_st`].
pub fn face_st_to_dir(face: u32, st: DVec2) -> DVec3 {
    cube_point(face, 2.0 * st.x - 1.0, 2.0 * st.y - 1.0).normalize()
}

/// The point N + sc·S + tc·T on the surface of the cube [−1, 1]³.
fn cube_point(face: u32, sc: f64, tc: f64) -> DVec3 {
    let [n, s, t] = FACE_AXES[face as usize];
    n + sc * s + tc * t
}

/// Flat texel index of (face, i, j): `face·res² + j·res + i`.
fn flat(res: u32, face: u32, i: u32, j: u32) -> u32 {
    (face * res + j) * res + i
}

/// Per-face clamped bilinear taps (`dx9` cube and the dual maps): the texels of
/// `face` around `uv` ∈ [0, 1]², indices clamped to the face.
pub(super) fn clamped_taps(res: u32, face: u32, uv: DVec2) -> BilinearTaps {
    let last = f64::from(res - 1);
    let x = (uv.x * f64::from(res) - 0.5).clamp(-0.5, last + 0.5);
    let y = (uv.y * f64::from(res) - 0.5).clamp(-0.5, last + 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (a, b) = (x - x0, y - y0);
    let clamp = |v: f64| v.clamp(0.0, last) as u32;
    let (i0, i1, j0, j1) = (clamp(x0), clamp(x0 + 1.0), clamp(y0), clamp(y0 + 1.0));
    BilinearTaps {
        index: [
            flat(res, face, i0, j0),
            flat(res, face, i1, j0),
            flat(res, face, i0, j1),
            flat(res, face, i1, j1),
        ],
        weight: [(1.0 - a) * (1.0 - b), a * (1.0 - b), (1.0 - a) * b, a * b],
    }
}

/// Seamless (`dx10`) bilinear taps at face coordinates `st` of `face` (module doc):
/// texels past an edge come from the adjacent face; the missing corner texel is the
/// average of the other three, folded into their weights (its own weight is then 0).
pub fn seamless_taps(res: u32, face: u32, st: DVec2) -> BilinearTaps {
    let top = f64::from(res) - 0.5;
    let x = (st.x * f64::from(res) - 0.5).clamp(-0.5, top);
    let y = (st.y * f64::from(res) - 0.5).clamp(-0.5, top);
    let (x0, y0) = (x.floor(), y.floor());
    let (a, b) = (x - x0, y - y0);
    let (i0, j0) = (x0 as i64, y0 as i64);
    let corners = [(i0, j0), (i0 + 1, j0), (i0, j0 + 1), (i0 + 1, j0 + 1)];
    let mut weight = [(1.0 - a) * (1.0 - b), a * (1.0 - b), (1.0 - a) * b, a * b];
    let mut index = [0u32; 4];
    let mut missing = None;
    for (k, &(i, j)) in corners.iter().enumerate() {
        match wrap_texel(res, face, i, j) {
            Some(idx) => index[k] = idx,
            None => missing = Some(k),
        }
    }
    if let Some(m) = missing {
        // Corner texel = mean of the three that exist: spread its weight over them.
        let share = weight[m] / 3.0;
        weight[m] = 0.0;
        let donor = (m + 1) % 4;
        index[m] = index[donor];
        for (k, w) in weight.iter_mut().enumerate() {
            if k != m {
                *w += share;
            }
        }
    }
    BilinearTaps { index, weight }
}

/// Flat index of texel (i, j) of `face`, where i, j ∈ [−1, res] may step one texel past
/// an edge onto the adjacent face; `None` when past two edges (a cube corner).
fn wrap_texel(res: u32, face: u32, i: i64, j: i64) -> Option<u32> {
    let n = i64::from(res);
    let i_out = !(0..n).contains(&i);
    let j_out = !(0..n).contains(&j);
    match (i_out, j_out) {
        (false, false) => Some(flat(res, face, i as u32, j as u32)),
        (true, true) => None,
        _ => {
            // The point on the shared edge at the texel's along-edge centre coordinate.
            let coord = |k: i64| -> f64 {
                if k < 0 {
                    -1.0
                } else if k >= n {
                    1.0
                } else {
                    (2.0 * k as f64 + 1.0) / f64::from(res) - 1.0
                }
            };
            let (sc, tc) = (coord(i), coord(j));
            let q = cube_point(face, sc, tc);
            let [_, s, t] = FACE_AXES[face as usize];
            let out_normal = if i_out { sc * s } else { tc * t };
            let f2 = face_of(out_normal);
            let [n2, s2, t2] = FACE_AXES[f2 as usize];
            debug_assert!((q.dot(n2) - 1.0).abs() < 1e-12, "{q} is not on face {f2}");
            // Texel containing the point; the edge coordinate (±1) lands in the edge row.
            let index =
                |c: f64| ((0.5 * (c + 1.0) * f64::from(res)).floor() as i64).clamp(0, n - 1) as u32;
            Some(flat(res, f2, index(q.dot(s2)), index(q.dot(t2))))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A division and a normalisation in f64.
    const ROUND_TRIP: f64 = 1e-14;

    #[test]
    fn face_table_matches_vulkan_spec() {
        // Face centres and the (sc, tc) of a point off-centre, straight from the table.
        let r = DVec3::new(0.3, -0.2, 0.1);
        let cases = [
            (DVec3::X, 0, (-r.z, -r.y)),
            (DVec3::NEG_X, 1, (r.z, -r.y)),
            (DVec3::Y, 2, (r.x, r.z)),
            (DVec3::NEG_Y, 3, (r.x, -r.z)),
            (DVec3::Z, 4, (r.x, -r.y)),
            (DVec3::NEG_Z, 5, (-r.x, -r.y)),
        ];
        for (axis, face, (sc, tc)) in cases {
            let d = axis + r - axis * axis.dot(r); // |ma| = 1, tangential part of r
            let (f, st) = dir_to_face_st(d);
            assert_eq!(f, face, "{}", FACE_NAMES[face as usize]);
            let expect = DVec2::new(0.5 * (sc + 1.0), 0.5 * (tc + 1.0));
            assert!((st - expect).length() < ROUND_TRIP, "{st} vs {expect}");
            assert_eq!(dir_to_face_st(axis), (face, DVec2::splat(0.5)));
        }
    }

    #[test]
    fn face_st_round_trip() {
        for face in 0..FACE_COUNT {
            for k in 0..121 {
                let st = DVec2::new((k % 11) as f64 / 10.0, (k / 11) as f64 / 10.0);
                let d = face_st_to_dir(face, st);
                let (f, back) = dir_to_face_st(d);
                let interior = st.cmpgt(DVec2::ZERO).all() && st.cmplt(DVec2::ONE).all();
                if interior {
                    assert_eq!(f, face);
                    assert!((back - st).length() < ROUND_TRIP, "{st} -> {d} -> {back}");
                } else {
                    // On an edge the tie rule may pick the neighbour; same direction.
                    assert!((face_st_to_dir(f, back) - d).length() < ROUND_TRIP);
                }
            }
        }
    }

    #[test]
    fn wrapped_texel_is_the_edge_neighbour() {
        // The texel across an edge must be the closest texel centre on the other face.
        let res = 5;
        for face in 0..FACE_COUNT {
            for k in 0..res as i64 {
                for (i, j) in [(-1, k), (res as i64, k), (k, -1), (k, res as i64)] {
                    let idx = wrap_texel(res, face, i, j).expect("edge, not corner");
                    let (f2, rest) = (idx / (res * res), idx % (res * res));
                    assert_ne!(f2, face);
                    let (i2, j2) = (rest % res, rest / res);
                    let centre = |f: u32, i: f64, j: f64| {
                        let h = 2.0 / f64::from(res);
                        cube_point(f, -1.0 + (i + 0.5) * h, -1.0 + (j + 0.5) * h)
                    };
                    // The virtual texel centre one step past the edge lies on the face's
                    // plane at N + (1+h)·N2 + a·A; folded over the edge it is the
                    // neighbour's centre N2 + (1−h)·N + a·A (same along-edge coordinate a,
                    // half a texel from the edge): virt − h·(N + N2).
                    let h = 1.0 / f64::from(res);
                    let n = FACE_AXES[face as usize][0];
                    let n2 = FACE_AXES[f2 as usize][0];
                    let expect = centre(face, i as f64, j as f64) - h * (n + n2);
                    let real = centre(f2, f64::from(i2), f64::from(j2));
                    assert!(
                        (real - expect).length() < 1e-12,
                        "face {face} ({i},{j}) -> face {f2} ({i2},{j2}): {real} vs {expect}"
                    );
                }
            }
            assert_eq!(wrap_texel(res, face, -1, -1), None);
            assert_eq!(wrap_texel(res, face, res as i64, -1), None);
        }
    }
}
