//! Ambient Dice (Iwanicki & Sloan, "Ambient Dice", EGSR 2017) over a tangent frame's
//! hemisphere: values at the vertices of an icosahedron, read through the one spherical
//! triangle that holds the direction — 3 vertices of 12 — so a lightmap texel's irradiance
//! at a normal-mapped normal costs three vertices' data whatever the basis' size.
//!
//! # Geometry
//!
//! The icosahedron (0, ±1, ±φ) and its cyclic permutations, normalised, in the tangent
//! frame as they stand: +z (the surface normal) passes through the midpoint of the edge
//! (0, ±1, φ). Four vertices are above the horizon ((0, ±1, φ), (±φ, 0, 1)), four on it
//! ((±1, ±φ, 0)), and the faces that reach z > 0 add only (±φ, 0, −1): a lightmap stores
//! those ten ([`STORED_VERTICES`]; a test checks the cover), the hemisphere being all a
//! normal-mapped normal reads. (A vertex at +z needs eleven, a face centre at +z all
//! twelve.) Directions are located by the face
//! whose centre is nearest (the spherical faces of a regular polyhedron are the Voronoi
//! cells of their centres). Within face (v0, v1, v2), a direction m has barycentrics
//! λ = [v0 v1 v2]⁻¹ m, normalised to b = λ / Σλ — the barycentrics of m's central
//! projection onto the face's plane, which agree on a shared edge for both faces (the
//! edge's chord is in both planes), so anything interpolated from one edge's data is
//! continuous across it.
//!
//! # Hybrid cubic Bézier (the `dice` variant; the paper's §3)
//!
//! Each vertex v_i stores the value f_i and the directional derivatives (du_i, dv_i) along
//! its tangents (t_u, t_v) (built per vertex, [`Dice::vertex_tangents`]). On a face, a cubic
//! Bézier triangle in b with control points (indices the powers of b0, b1, b2):
//!
//! ```text
//! c300 = f0,  c030 = f1,  c003 = f2                                        (corners)
//! c_edge(i→j) = f_i + (du_i (t_u,i·v_j) + dv_i (t_v,i·v_j)) / 3             (1)
//! ```
//!
//! (1) matches the patch's derivative along the edge to the vertex's gradient: the central
//! projection moves m along the edge at the rate v_j − (v_i·v_j) v_i, whose tangential part
//! the gradient meets. The centre is Farin's hybrid: one candidate per edge, each making the
//! cross-boundary derivative along that edge linear (its middle Bernstein coefficient the
//! mean of the outer two), for the edge opposite v0
//!
//! ```text
//! c111⁽⁰⁾ = ¼(c021 + c012) + ½(c120 + c102) − ¼(c030 + c003)                  (2)
//! ```
//!
//! (and cyclically), blended by ω_i = b_j b_k / (b0 b1 + b1 b2 + b2 b0), which is 1 on the
//! candidate's own edge. The patch reproduces constants and the face plane's quadratics;
//! it is C0 across edges exactly (tested) and smooth across them only approximately — the
//! paper's own centre points use constants fitted to the icosahedron's curvature instead.
//! Evaluation is linear in the stored data: [`Dice::weights`] gives each of the face's three
//! vertices' weights on (f, du, dv). RGB: 9 values per vertex, 90 per texel; a direction
//! reads 27.
//!
//! # YCoCg (the `dicey` variant; the paper's §3.2)
//!
//! Luminance Y = R/4 + G/2 + B/4 by the hybrid Bézier; chroma Co = (R − B)/2,
//! Cg = (2G − R − B)/4 by the linear interpolation Σ b_i c_i of the values alone: 5 values
//! per vertex, 50 per texel; a direction reads 15. RGB = (Y + Co − Cg, Y + Cg, Y − Co − Cg).
//!
//! # Fit
//!
//! The stored data minimise the hemisphere's squared irradiance error,
//! Σ_q w_q (Σ_k x_k B_k(m_q) − E(T m_q))², over the Gauss–Legendre × azimuth rule of
//! [`FIT_N`] (`hbasis::hemisphere_quadrature`), E the texel's irradiance — from its order-3
//! radiance SH (`sh::zonal`), or from its radiance samples through the fit's kernels
//! ([`Dice::hybrid_kernel`], `crate::sh::samples`) — and T its normal-map frame. The design is the same for every
//! texel, so its weighted pseudo-inverse is computed once by SVD (f64, singular values below
//! 1e-10 of the largest dropped — the lowest vertices' data barely reach z ≥ 0); a fit
//! is then one matrix product per colour.

use glam::{DMat3, DVec3};

use super::Order;
use super::hbasis::hemisphere_quadrature;

/// Vertices a lightmap stores (module doc).
pub const STORED_VERTICES: usize = 10;

/// Gauss–Legendre nodes in z of the fitting rule (2·FIT_N azimuths each).
pub const FIT_N: usize = 6;

/// The two variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DiceVariant {
    /// `dice`: RGB value and two derivatives per vertex, hybrid Bézier.
    Rgb,
    /// `dicey`: Y by hybrid Bézier, Co and Cg linear.
    YCoCg,
}

impl DiceVariant {
    pub const ALL: [DiceVariant; 2] = [DiceVariant::Rgb, DiceVariant::YCoCg];

    /// Values stored per vertex.
    pub fn per_vertex(self) -> usize {
        match self {
            DiceVariant::Rgb => 9,
            DiceVariant::YCoCg => 5,
        }
    }

    /// Values stored per texel.
    pub fn stored_values(self) -> usize {
        STORED_VERTICES * self.per_vertex()
    }

    /// Values one direction reads.
    pub fn values_read(self) -> usize {
        3 * self.per_vertex()
    }
}

/// One face: its vertices (indices into the stored vertices), centre, the dual vectors
/// giving λ_i = dual_i · m, and the edge factors of (1): `edge[i][j]` = (t_u,i·v_j,
/// t_v,i·v_j).
#[derive(Clone, Debug)]
pub struct Face {
    pub vertices: [usize; 3],
    pub centre: DVec3,
    pub dual: [DVec3; 3],
    pub edge: [[[f64; 2]; 3]; 3],
}

/// Weights of one direction on the data of its face's three vertices: `value[i]`,
/// `du[i]`, `dv[i]` (hybrid Bézier) and `linear[i]` (= b_i) for vertex `vertices[i]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Weights {
    pub face: usize,
    pub vertices: [usize; 3],
    pub value: [f64; 3],
    pub du: [f64; 3],
    pub dv: [f64; 3],
    pub linear: [f64; 3],
}

/// The basis: geometry and the fit's pseudo-inverses.
#[derive(Clone, Debug)]
pub struct Dice {
    /// Stored vertices (tangent space), upper ring first.
    pub vertices: Vec<DVec3>,
    /// Per stored vertex (t_u, t_v).
    pub vertex_tangents: Vec<[DVec3; 2]>,
    /// Faces reaching z ≥ 0.
    pub faces: Vec<Face>,
    nodes: Vec<(DVec3, f64)>,
    /// 3·STORED_VERTICES × nodes, row-major: the hybrid fit.
    pinv_hybrid: Vec<f64>,
    /// STORED_VERTICES × nodes: the linear fit.
    pinv_linear: Vec<f64>,
}

/// The basis, built once.
pub fn dice() -> &'static Dice {
    static DICE: std::sync::OnceLock<Dice> = std::sync::OnceLock::new();
    DICE.get_or_init(Dice::new)
}

/// The full icosahedron in tangent space (module doc), stored vertices first, and its 20
/// faces.
fn icosahedron() -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let phi = 0.5 * (1.0 + 5f64.sqrt());
    let mut vertices = Vec::with_capacity(12);
    for s1 in [1.0, -1.0] {
        for s2 in [1.0, -1.0] {
            vertices.push(DVec3::new(0.0, s1, s2 * phi).normalize());
            vertices.push(DVec3::new(s1, s2 * phi, 0.0).normalize());
            vertices.push(DVec3::new(s2 * phi, 0.0, s1).normalize());
        }
    }
    // From the top, then by azimuth.
    vertices.sort_by(|p, q| {
        let level = |v: &DVec3| (-v.z * 1e6).round() as i64;
        level(p)
            .cmp(&level(q))
            .then(p.y.atan2(p.x).total_cmp(&q.y.atan2(q.x)))
    });
    let edge = 1.0 / 5f64.sqrt();
    let adjacent = |i: usize, j: usize| (vertices[i].dot(vertices[j]) - edge).abs() < 1e-9;
    let mut faces = Vec::with_capacity(20);
    for i in 0..12 {
        for j in i + 1..12 {
            for k in j + 1..12 {
                if adjacent(i, j) && adjacent(j, k) && adjacent(i, k) {
                    faces.push([i, j, k]);
                }
            }
        }
    }
    (vertices, faces)
}

impl Dice {
    fn new() -> Dice {
        let (all, all_faces) = icosahedron();
        let vertices: Vec<DVec3> = all[..STORED_VERTICES].to_vec();
        let vertex_tangents: Vec<[DVec3; 2]> = vertices
            .iter()
            .map(|&v| {
                let u = DVec3::Z.cross(v).normalize();
                [u, v.cross(u)]
            })
            .collect();
        let faces: Vec<Face> = all_faces
            .iter()
            .filter(|f| f.iter().any(|&i| all[i].z > 1e-9))
            .map(|&f| {
                let v = f.map(|i| vertices[i]);
                let inverse = DMat3::from_cols(v[0], v[1], v[2]).inverse();
                let rows = inverse.transpose();
                let dual = [rows.x_axis, rows.y_axis, rows.z_axis];
                let edge = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        let [tu, tv] = vertex_tangents[f[i]];
                        [tu.dot(v[j]), tv.dot(v[j])]
                    })
                });
                Face {
                    vertices: f,
                    centre: (v[0] + v[1] + v[2]).normalize(),
                    dual,
                    edge,
                }
            })
            .collect();
        let mut dice = Dice {
            vertices,
            vertex_tangents,
            faces,
            nodes: hemisphere_quadrature(FIT_N),
            pinv_hybrid: Vec::new(),
            pinv_linear: Vec::new(),
        };
        let hybrid_rows: Vec<Vec<f64>> = dice
            .nodes
            .iter()
            .map(|&(m, _)| {
                let w = dice.weights(m);
                let mut row = vec![0.0; 3 * STORED_VERTICES];
                for i in 0..3 {
                    let v = w.vertices[i];
                    row[3 * v] += w.value[i];
                    row[3 * v + 1] += w.du[i];
                    row[3 * v + 2] += w.dv[i];
                }
                row
            })
            .collect();
        let linear_rows: Vec<Vec<f64>> = dice
            .nodes
            .iter()
            .map(|&(m, _)| {
                let w = dice.weights(m);
                let mut row = vec![0.0; STORED_VERTICES];
                for i in 0..3 {
                    row[w.vertices[i]] += w.linear[i];
                }
                row
            })
            .collect();
        dice.pinv_hybrid = weighted_pinv(&hybrid_rows, &dice.nodes);
        dice.pinv_linear = weighted_pinv(&linear_rows, &dice.nodes);
        dice
    }

    /// The face holding tangent-space direction `m` (nearest centre).
    pub fn face_of(&self, m: DVec3) -> usize {
        let mut best = (0, f64::NEG_INFINITY);
        for (f, face) in self.faces.iter().enumerate() {
            let d = face.centre.dot(m);
            if d > best.1 {
                best = (f, d);
            }
        }
        best.0
    }

    /// The weights of direction `m` (tangent space; below the horizon it is lifted to it,
    /// as the shader does) in the face that holds it.
    pub fn weights(&self, m: DVec3) -> Weights {
        let m = lift_to_hemisphere(m);
        self.weights_in_face(self.face_of(m), m)
    }

    /// The weights of `m` by face `face`'s patch (its own face or, on a shared edge, its
    /// neighbour's: the continuity tests).
    pub fn weights_in_face(&self, face: usize, m: DVec3) -> Weights {
        let f = &self.faces[face];
        let lambda = f.dual.map(|d| d.dot(m));
        let sum: f64 = lambda.iter().sum();
        let b = lambda.map(|l| l / sum);
        // Bernstein weights of the corners, edge points e[i][j] (i→j, the point next to
        // v_i on edge ij) and centre.
        let mut corner = b.map(|x| x * x * x);
        let mut edge_point = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                if i != j {
                    edge_point[i][j] = 3.0 * b[i] * b[i] * b[j];
                }
            }
        }
        let centre = 6.0 * b[0] * b[1] * b[2];
        let pair = b[0] * b[1] + b[1] * b[2] + b[2] * b[0];
        let omega = if pair > 1e-300 {
            [b[1] * b[2], b[2] * b[0], b[0] * b[1]].map(|w| w / pair)
        } else {
            [1.0 / 3.0; 3]
        };
        // (2) for the edge opposite v_i (j, k the others), weighted by ω_i:
        // ¼(c_edge(j→k) + c_edge(k→j)) + ½(c_edge(j→i) + c_edge(k→i)) − ¼(f_j + f_k).
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let w = centre * omega[i];
            edge_point[j][k] += 0.25 * w;
            edge_point[k][j] += 0.25 * w;
            edge_point[j][i] += 0.5 * w;
            edge_point[k][i] += 0.5 * w;
            corner[j] -= 0.25 * w;
            corner[k] -= 0.25 * w;
        }
        // (1): each edge point is f_i + (du_i a_ij + dv_i b_ij)/3.
        let mut out = Weights {
            face,
            vertices: f.vertices,
            linear: b,
            ..Weights::default()
        };
        for i in 0..3 {
            out.value[i] = corner[i];
            for (j, (&w, factors)) in edge_point[i].iter().zip(&f.edge[i]).enumerate() {
                if i != j {
                    out.value[i] += w;
                    out.du[i] += w * factors[0] / 3.0;
                    out.dv[i] += w * factors[1] / 3.0;
                }
            }
        }
        out
    }

    /// Irradiance (RGB) at tangent-space `m` from `stored` ([`DiceVariant::stored_values`]
    /// values in the module doc's layout).
    pub fn irradiance(&self, variant: DiceVariant, stored: &[f64], m: DVec3) -> [f64; 3] {
        self.irradiance_with(variant, stored, &self.weights(m))
    }

    /// [`Dice::irradiance`] with the weights given.
    pub fn irradiance_with(&self, variant: DiceVariant, stored: &[f64], w: &Weights) -> [f64; 3] {
        let per = variant.per_vertex();
        match variant {
            DiceVariant::Rgb => std::array::from_fn(|c| {
                (0..3)
                    .map(|i| {
                        let base = per * w.vertices[i];
                        w.value[i] * stored[base + c]
                            + w.du[i] * stored[base + 3 + c]
                            + w.dv[i] * stored[base + 6 + c]
                    })
                    .sum()
            }),
            DiceVariant::YCoCg => {
                let (mut y, mut co, mut cg) = (0.0, 0.0, 0.0);
                for i in 0..3 {
                    let base = per * w.vertices[i];
                    y += w.value[i] * stored[base]
                        + w.du[i] * stored[base + 1]
                        + w.dv[i] * stored[base + 2];
                    co += w.linear[i] * stored[base + 3];
                    cg += w.linear[i] * stored[base + 4];
                }
                ycocg_to_rgb([y, co, cg])
            }
        }
    }

    /// The stored data fitting irradiance values `e` (RGB) given at the fit's nodes.
    pub fn fit(&self, variant: DiceVariant, e: &[[f64; 3]]) -> Vec<f64> {
        let q = self.nodes.len();
        assert_eq!(e.len(), q, "one irradiance per fitting node");
        let apply = |pinv: &[f64], rows: usize, channel: &dyn Fn(usize) -> f64| -> Vec<f64> {
            (0..rows)
                .map(|r| (0..q).map(|i| pinv[r * q + i] * channel(i)).sum())
                .collect()
        };
        let hybrid_rows = 3 * STORED_VERTICES;
        let mut out = vec![0.0; variant.stored_values()];
        match variant {
            DiceVariant::Rgb => {
                for c in 0..3 {
                    let x = apply(&self.pinv_hybrid, hybrid_rows, &|i| e[i][c]);
                    for v in 0..STORED_VERTICES {
                        for k in 0..3 {
                            out[9 * v + 3 * k + c] = x[3 * v + k];
                        }
                    }
                }
            }
            DiceVariant::YCoCg => {
                let ycocg: Vec<[f64; 3]> = e.iter().map(|&rgb| rgb_to_ycocg(rgb)).collect();
                let y = apply(&self.pinv_hybrid, hybrid_rows, &|i| ycocg[i][0]);
                let co = apply(&self.pinv_linear, STORED_VERTICES, &|i| ycocg[i][1]);
                let cg = apply(&self.pinv_linear, STORED_VERTICES, &|i| ycocg[i][2]);
                for v in 0..STORED_VERTICES {
                    out[5 * v..5 * v + 3].copy_from_slice(&y[3 * v..3 * v + 3]);
                    out[5 * v + 3] = co[v];
                    out[5 * v + 4] = cg[v];
                }
            }
        }
        out
    }

    /// The fit's response to the irradiance of a single direction: row r of the hybrid
    /// fit (`3·STORED_VERTICES` rows: vertex v's value, du, dv at 3v, 3v + 1, 3v + 2)
    /// applied to E(m_q) = max(0, m_q·ω) at the nodes, so that a fit of sampled radiance
    /// is Σ_s w_s L_s · kernel(ω_s) (`sh::samples`).
    pub fn hybrid_kernel(&self, omega: DVec3) -> Vec<f64> {
        self.kernel(&self.pinv_hybrid, 3 * STORED_VERTICES, omega)
    }

    /// [`Self::hybrid_kernel`] for the linear fit of the chroma (`STORED_VERTICES` rows).
    pub fn linear_kernel(&self, omega: DVec3) -> Vec<f64> {
        self.kernel(&self.pinv_linear, STORED_VERTICES, omega)
    }

    fn kernel(&self, pinv: &[f64], rows: usize, omega: DVec3) -> Vec<f64> {
        let q = self.nodes.len();
        let e: Vec<f64> = self
            .nodes
            .iter()
            .map(|&(m, _)| m.dot(omega).max(0.0))
            .collect();
        (0..rows)
            .map(|r| {
                pinv[r * q..(r + 1) * q]
                    .iter()
                    .zip(&e)
                    .map(|(p, e)| p * e)
                    .sum()
            })
            .collect()
    }

    /// The fitting nodes (tangent space) and weights.
    pub fn nodes(&self) -> &[(DVec3, f64)] {
        &self.nodes
    }

    /// The stored data of the irradiance received under order-3 RGB radiance SH
    /// `radiance` (world space) by a texel whose normal-map frame is `frame` = [tangent,
    /// bitangent, normal] (module doc, Fit).
    pub fn project_irradiance(
        &self,
        variant: DiceVariant,
        radiance: &[[f64; 3]],
        frame: [DVec3; 3],
    ) -> Vec<f64> {
        let irradiance = super::zonal::irradiance_from_radiance(radiance, Order::THREE);
        let e: Vec<[f64; 3]> = self
            .nodes
            .iter()
            .map(|&(m, _)| {
                let world = frame[0] * m.x + frame[1] * m.y + frame[2] * m.z;
                match world.try_normalize() {
                    Some(n) => super::zonal::eval_rgb(&irradiance, Order::THREE, n),
                    None => [0.0; 3],
                }
            })
            .collect();
        self.fit(variant, &e)
    }
}

/// m with z raised to ≥ 0 and renormalised (+z when nothing is left): the stored faces
/// cover the upper hemisphere only.
pub fn lift_to_hemisphere(m: DVec3) -> DVec3 {
    DVec3::new(m.x, m.y, m.z.max(0.0))
        .try_normalize()
        .unwrap_or(DVec3::Z)
}

/// (R, G, B) → (Y, Co, Cg).
pub fn rgb_to_ycocg([r, g, b]: [f64; 3]) -> [f64; 3] {
    [
        0.25 * r + 0.5 * g + 0.25 * b,
        0.5 * (r - b),
        0.5 * g - 0.25 * (r + b),
    ]
}

/// (Y, Co, Cg) → (R, G, B).
pub fn ycocg_to_rgb([y, co, cg]: [f64; 3]) -> [f64; 3] {
    [y + co - cg, y + cg, y - co - cg]
}

/// (W^½ A)⁺ W^½ for design rows `rows` at `nodes` (weights w), row-major columns × nodes:
/// V Λ⁺ Vᵀ Aᵀ W from the symmetric eigendecomposition AᵀWA = V Λ Vᵀ, eigenvalues below
/// 1e-20 of the largest (singular values of W^½ A below 1e-10) dropped.
fn weighted_pinv(rows: &[Vec<f64>], nodes: &[(DVec3, f64)]) -> Vec<f64> {
    let (q, n) = (rows.len(), rows[0].len());
    let mut ata = nalgebra::DMatrix::<f64>::zeros(n, n);
    for (row, &(_, w)) in rows.iter().zip(nodes) {
        for j in 0..n {
            for k in 0..n {
                ata[(j, k)] += w * row[j] * row[k];
            }
        }
    }
    let eigen = ata.symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    let inverse = nalgebra::DVector::from_iterator(
        n,
        eigen
            .eigenvalues
            .iter()
            .map(|&l| if l > 1e-20 * largest { 1.0 / l } else { 0.0 }),
    );
    let v = &eigen.eigenvectors;
    let ata_pinv = v * nalgebra::DMatrix::from_diagonal(&inverse) * v.transpose();
    let mut pinv = vec![0.0; n * q];
    for k in 0..n {
        for (i, (row, &(_, w))) in rows.iter().zip(nodes).enumerate() {
            pinv[k * q + i] = w * (0..n).map(|j| ata_pinv[(k, j)] * row[j]).sum::<f64>();
        }
    }
    pinv
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Lcg(u64);
    impl Lcg {
        fn unit(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    fn random_data(rng: &mut Lcg, variant: DiceVariant) -> Vec<f64> {
        (0..variant.stored_values()).map(|_| rng.unit()).collect()
    }

    #[test]
    fn nine_vertices_and_their_faces_cover_the_upper_hemisphere() {
        let (all, faces) = icosahedron();
        assert_eq!((all.len(), faces.len()), (12, 20));
        // +z through the midpoint of the top edge.
        let top = (all[0] + all[1]).normalize();
        assert!((top - DVec3::Z).length() < 1e-12, "{top}");
        // Every face with a vertex outside the ten stored lies wholly below the horizon.
        for f in &faces {
            if f.iter().any(|&i| i >= STORED_VERTICES) {
                assert!(f.iter().all(|&i| all[i].z < 1e-12), "{f:?}");
            }
        }
        let d = dice();
        assert_eq!(d.faces.len(), 12);
        // Every direction of the hemisphere lies inside the face its nearest centre names.
        for (m, _) in hemisphere_quadrature(24) {
            let w = d.weights(m);
            assert!(w.linear.iter().all(|&b| b > -1e-12), "{m}: {:?}", w.linear);
        }
        // The vertex tangents are orthonormal and tangent.
        for (v, [u, t]) in d.vertices.iter().zip(&d.vertex_tangents) {
            assert!(u.dot(*v).abs() < 1e-12 && t.dot(*v).abs() < 1e-12 && u.dot(*t).abs() < 1e-12);
            assert!((u.length() - 1.0).abs() < 1e-12 && (t.length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn at_a_vertex_the_patch_is_the_stored_value() {
        let d = dice();
        let mut rng = Lcg(7);
        for variant in DiceVariant::ALL {
            let data = random_data(&mut rng, variant);
            for (v, &p) in d.vertices.iter().enumerate().filter(|(_, p)| p.z >= 0.0) {
                let got = d.irradiance(variant, &data, p);
                let per = variant.per_vertex();
                let want = match variant {
                    DiceVariant::Rgb => [data[per * v], data[per * v + 1], data[per * v + 2]],
                    DiceVariant::YCoCg => {
                        ycocg_to_rgb([data[per * v], data[per * v + 3], data[per * v + 4]])
                    }
                };
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() < 1e-12,
                        "{variant:?} vertex {v}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn at_a_face_centre_each_vertex_weighs_a_third_and_constants_are_reproduced() {
        let d = dice();
        for (f, face) in d.faces.iter().enumerate() {
            let w = d.weights_in_face(f, face.centre);
            for i in 0..3 {
                // Value 1 at one vertex, 0 elsewhere, no derivatives: by hand (module doc's
                // (1), (2)) b = ⅓ gives 1/27 + 2·3/27 + 6/27 · ⅓ = ⅓.
                assert!(
                    (w.value[i] - 1.0 / 3.0).abs() < 1e-12,
                    "face {f}: {:?}",
                    w.value
                );
                assert!((w.linear[i] - 1.0 / 3.0).abs() < 1e-12);
            }
        }
        // A constant with no derivatives is itself everywhere.
        let mut data = vec![0.0; DiceVariant::Rgb.stored_values()];
        for v in 0..STORED_VERTICES {
            data[9 * v..9 * v + 3].copy_from_slice(&[2.0, 1.0, 0.5]);
        }
        for (m, _) in hemisphere_quadrature(12) {
            let got = d.irradiance(DiceVariant::Rgb, &data, m);
            for (c, want) in [2.0, 1.0, 0.5].iter().enumerate() {
                assert!((got[c] - want).abs() < 1e-12, "{m}: {got:?}");
            }
        }
    }

    #[test]
    fn the_interpolation_is_continuous_across_every_edge() {
        let d = dice();
        let mut rng = Lcg(11);
        for variant in DiceVariant::ALL {
            let data = random_data(&mut rng, variant);
            let mut shared = 0;
            for (f, a) in d.faces.iter().enumerate() {
                for (g, b) in d.faces.iter().enumerate().skip(f + 1) {
                    let common: Vec<usize> = a
                        .vertices
                        .iter()
                        .copied()
                        .filter(|v| b.vertices.contains(v))
                        .collect();
                    if common.len() != 2 {
                        continue;
                    }
                    shared += 1;
                    let (p, q) = (d.vertices[common[0]], d.vertices[common[1]]);
                    for t in [0.1, 0.25, 0.5, 0.8] {
                        let m = (p * (1.0 - t) + q * t).normalize();
                        let one = d.irradiance_with(variant, &data, &d.weights_in_face(f, m));
                        let two = d.irradiance_with(variant, &data, &d.weights_in_face(g, m));
                        for c in 0..3 {
                            assert!(
                                (one[c] - two[c]).abs() < 1e-12,
                                "{variant:?} faces {f}/{g} t {t}: {one:?} vs {two:?}"
                            );
                        }
                    }
                }
            }
            assert_eq!(shared, 15, "edges shared by two stored faces");
        }
    }

    #[test]
    fn the_fit_is_the_least_squares_optimum_and_scales_linearly() {
        let d = dice();
        // A sky-like texel under a tilted frame.
        let mut radiance = vec![[0.0; 3]; 9];
        radiance[0] = [2.0, 1.8, 1.5];
        radiance[2] = [1.0, 0.9, 0.6];
        radiance[3] = [-0.4, 0.1, 0.2];
        radiance[5] = [0.3, 0.2, 0.1];
        radiance[8] = [-0.2, 0.1, 0.3];
        let frame = [
            DVec3::new(0.8, 0.0, -0.6),
            DVec3::Y,
            DVec3::new(0.6, 0.0, 0.8),
        ];
        let irr = crate::sh::zonal::irradiance_from_radiance(&radiance, Order::THREE);
        let target: Vec<[f64; 3]> = d
            .nodes()
            .iter()
            .map(|&(m, _)| {
                let n = (frame[0] * m.x + frame[1] * m.y + frame[2] * m.z).normalize();
                crate::sh::zonal::eval_rgb(&irr, Order::THREE, n)
            })
            .collect();
        for variant in DiceVariant::ALL {
            let x = d.project_irradiance(variant, &radiance, frame);
            // The variant's own metric: YCoCg fits Y, Co and Cg each.
            let space = |rgb: [f64; 3]| match variant {
                DiceVariant::Rgb => rgb,
                DiceVariant::YCoCg => rgb_to_ycocg(rgb),
            };
            let residual = |x: &[f64]| -> f64 {
                d.nodes()
                    .iter()
                    .zip(&target)
                    .map(|(&(m, w), &t)| {
                        let (e, t) = (space(d.irradiance(variant, x, m)), space(t));
                        w * (0..3).map(|c| (e[c] - t[c]).powi(2)).sum::<f64>()
                    })
                    .sum()
            };
            // Brute force: no single coefficient moved either way lowers the residual.
            let best = residual(&x);
            for k in 0..x.len() {
                for step in [1e-3, -1e-3] {
                    let mut y = x.clone();
                    y[k] += step;
                    let r = residual(&y);
                    assert!(
                        r >= best - 1e-12,
                        "{variant:?} coefficient {k}: {r} < {best}"
                    );
                }
            }
            // Small against the signal: the basis holds a smooth irradiance well.
            let energy: f64 = d
                .nodes()
                .iter()
                .zip(&target)
                .map(|(&(_, w), t)| w * t.iter().map(|v| v * v).sum::<f64>())
                .sum();
            assert!(best < 1e-3 * energy, "{variant:?}: {best} vs {energy}");
            // A sun of 1e5 scales the data by 1e5; a black texel stores zeros.
            let sun: Vec<[f64; 3]> = radiance.iter().map(|c| c.map(|v| v * 1e5)).collect();
            let big = d.project_irradiance(variant, &sun, frame);
            for (a, b) in x.iter().zip(&big) {
                assert!((a * 1e5 - b).abs() <= 1e-9 * b.abs().max(1e5 * 1e-3));
            }
            let black = d.project_irradiance(variant, &vec![[0.0; 3]; 9], frame);
            assert!(black.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn ycocg_round_trips() {
        let rgb = [0.3, 1.7, -0.2];
        let back = ycocg_to_rgb(rgb_to_ycocg(rgb));
        for c in 0..3 {
            assert!((back[c] - rgb[c]).abs() < 1e-15);
        }
    }
}
