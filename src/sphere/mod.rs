//! Sphere parameterizations for storing smooth signals (SH L×H tables) in textures, with
//! CPU reconstruction that matches hardware bilinear filtering — the four candidates of
//! Iwanicki–Sloan App. A (Figure 8), and the `dx9`/`dx10` table layouts of §3.2 (DESIGN §2).
//!
//! | [`Parameterization`] | name | images | module |
//! |---|---|---|---|
//! | `DualOrtho` | `dual-ortho` | 2 hemispheres | [`dual_ortho`] |
//! | `DualParaboloid` | `dual-paraboloid` | 2 hemispheres | [`dual_paraboloid`] (Heidrich & Seidel 1998) |
//! | `CubeDx9` | `cube-dx9` | 6 faces, per-face filtering | [`cube`] |
//! | `CubeDx10` | `cube-dx10` | 6 faces, seamless filtering | [`cube`] |
//!
//! # Conventions
//!
//! - Directions are unit [`DVec3`] in the world frame, +Y up (DESIGN §1). For L×H tables
//!   they are normals.
//! - `res` is texels per side of one hemisphere square or cube face; a map holds
//!   `faces·res²` samples (2·res² for dual maps, equator texels counted twice; 6·res² for
//!   cubes). Texel (i, j) of image `face` (hemisphere or cube face) is stored at flat index
//!   `face·res² + j·res + i`; i runs along u, j along v; its centre is at
//!   uv = ((i+½)/res, (j+½)/res) (DESIGN §1, the same texel-centre rule as the lightmap).
//! - **Dual maps**: hemisphere 0 is y ≥ 0, hemisphere 1 is y < 0 (the equator y = 0 goes to
//!   0, but both images hold it). A direction is projected to the unit disk (paraboloid or
//!   orthographic, disk x = world x, disk y = world z in *both* hemispheres), the disk is
//!   stretched to the square [−1, 1]² by the Shirley–Chiu map ([`concentric`]), and the
//!   square is *shrunk onto the texel centres* (App. A: "shrink the mapping so that the
//!   equator maps exactly to the outer ring of texel centers on the square"):
//!
//!   ```text
//!   u = ½ + s·(res−1)/(2·res),  s ∈ [−1, 1]     (s = ±1 ↦ texel centres 0 and res−1)
//!   ```
//!
//!   So every texel centre is a direction of its hemisphere (no texel wasted outside the
//!   disk), the outer ring of both images lies exactly on the equator with bit-identical
//!   directions, and bilinear filtering never reaches past the ring: reconstruction is C0
//!   across the equator by construction. Addressing is clamp-to-edge (never exercised).
//! - **Cubes**: the Vulkan face table and filtering rules in [`cube`]; `dx9` clamps to the
//!   face edge, `dx10` filters across edges and averages the three texels at a corner.
//!
//! # Reconstruction
//!
//! [`SphereMap::bilinear_taps`] computes the four texel indices and weights of a direction
//! once (they sum to 1); [`BilinearTaps::apply`] reuses them for any number of stored
//! signals — the study in [`crate::study::params`] applies one set of taps to 36 SH basis
//! functions. [`SphereMap::reconstruct_bilinear`] is the one-signal convenience.
//!
//! Tests: unit tests here and in each module; DESIGN §6's hard cases (Shirley–Chiu centre
//! and diagonals, dual-paraboloid equator, cube edges and corners) in `tests/sphere.rs`.

pub mod concentric;
pub mod cube;
pub mod dual_ortho;
pub mod dual_paraboloid;

use std::fmt;
use std::str::FromStr;

use glam::{DVec2, DVec3};

/// Smallest accepted resolution: the dual maps' shrink divides by res − 1.
pub const MIN_RES: u32 = 2;
/// Largest accepted resolution (6·4096² texel indices fit in `u32` with room to spare).
pub const MAX_RES: u32 = 4096;

/// Errors of the sphere layer; each message is one line naming the bad input.
#[derive(Debug, thiserror::Error)]
pub enum SphereError {
    /// A parameterization name that is not one of [`Parameterization::ALL`].
    #[error(
        "unknown parameterization '{0}' (expected dual-ortho, dual-paraboloid, cube-dx9 or cube-dx10)"
    )]
    UnknownParameterization(String),
    /// A resolution outside [`MIN_RES`]..=[`MAX_RES`].
    #[error("sphere map resolution {0} is out of range (expected {MIN_RES}..={MAX_RES})")]
    ResolutionOutOfRange(u32),
    /// A value array whose length does not match the map.
    #[error("{kind} at resolution {res} holds {expected} texels, got {got} values")]
    GridSize {
        /// Parameterization name.
        kind: Parameterization,
        /// Resolution.
        res: u32,
        /// `faces·res²`.
        expected: usize,
        /// Length given.
        got: usize,
    },
}

/// One of the four sphere parameterizations compared in Iwanicki–Sloan App. A.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Parameterization {
    /// Two orthographic hemisphere images, concentric-mapped and shrunk ([`dual_ortho`]).
    DualOrtho,
    /// Two paraboloid hemisphere images, concentric-mapped and shrunk
    /// ([`dual_paraboloid`]); the `dx9` L×H layout.
    DualParaboloid,
    /// Cube map filtered per face with clamp-to-edge (DX9-class hardware, [`cube`]).
    CubeDx9,
    /// Cube map with seamless filtering across faces (DX10+ and Vulkan, [`cube`]); the
    /// `dx10` L×H layout.
    CubeDx10,
}

impl Parameterization {
    /// All four, in the paper's order (App. A list).
    pub const ALL: [Parameterization; 4] = [
        Parameterization::DualOrtho,
        Parameterization::DualParaboloid,
        Parameterization::CubeDx9,
        Parameterization::CubeDx10,
    ];

    /// The CLI/report spelling: `dual-ortho`, `dual-paraboloid`, `cube-dx9`, `cube-dx10`.
    pub const fn name(self) -> &'static str {
        match self {
            Parameterization::DualOrtho => "dual-ortho",
            Parameterization::DualParaboloid => "dual-paraboloid",
            Parameterization::CubeDx9 => "cube-dx9",
            Parameterization::CubeDx10 => "cube-dx10",
        }
    }

    /// Number of images: 2 hemispheres or 6 cube faces.
    pub const fn face_count(self) -> u32 {
        if self.is_cube() { cube::FACE_COUNT } else { 2 }
    }

    /// Whether this is one of the cube maps.
    pub const fn is_cube(self) -> bool {
        matches!(self, Parameterization::CubeDx9 | Parameterization::CubeDx10)
    }
}

impl fmt::Display for Parameterization {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Parameterization {
    type Err = SphereError;

    /// Parses exactly the names of [`Parameterization::name`].
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Parameterization::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| SphereError::UnknownParameterization(s.to_owned()))
    }
}

/// The four texels and bilinear weights that reconstruct one direction; weights sum
/// to 1. A weight may be 0 (e.g. the folded-in corner texel of a seamless cube).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilinearTaps {
    /// Flat texel indices `face·res² + j·res + i`.
    pub index: [u32; 4],
    /// Weights, same order.
    pub weight: [f64; 4],
}

impl BilinearTaps {
    /// Σ `weight[k]·values[index[k]]` for a single-channel array of the map's texels.
    ///
    /// # Panics
    /// If `values` is shorter than the map (a bug: [`TexelGrid`] checks lengths).
    pub fn apply(&self, values: &[f64]) -> f64 {
        (0..4)
            .map(|k| self.weight[k] * values[self.index[k] as usize])
            .sum()
    }
}

/// A parameterization at a resolution: the addressing and filtering of one texture
/// (a pair of hemisphere images or a cube map).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SphereMap {
    kind: Parameterization,
    res: u32,
}

impl SphereMap {
    /// A map of `kind` with `res` texels per side of each image.
    ///
    /// # Errors
    /// [`SphereError::ResolutionOutOfRange`] unless [`MIN_RES`] ≤ `res` ≤ [`MAX_RES`].
    pub fn new(kind: Parameterization, res: u32) -> Result<Self, SphereError> {
        if (MIN_RES..=MAX_RES).contains(&res) {
            Ok(SphereMap { kind, res })
        } else {
            Err(SphereError::ResolutionOutOfRange(res))
        }
    }

    /// The parameterization.
    pub const fn kind(&self) -> Parameterization {
        self.kind
    }

    /// Texels per side of one hemisphere square or cube face.
    pub const fn res(&self) -> u32 {
        self.res
    }

    /// Total texels: 2·res² (dual maps) or 6·res² (cubes) — the x axis of Figure 8.
    pub const fn sample_count(&self) -> usize {
        (self.kind.face_count() * self.res * self.res) as usize
    }

    /// Flat index of texel (i, j) of image `face`: `face·res² + j·res + i`.
    pub const fn texel_index(&self, face: u32, i: u32, j: u32) -> usize {
        ((face * self.res + j) * self.res + i) as usize
    }

    /// Image (hemisphere 0 = +Y / 1 = −Y, or cube face +X…−Z) and uv ∈ [0, 1]² in that
    /// image of unit direction `dir`.
    pub fn dir_to_texcoord(&self, dir: DVec3) -> (u32, DVec2) {
        if self.kind.is_cube() {
            cube::dir_to_face_st(dir)
        } else {
            let h = hemisphere_of(dir);
            (h, self.dual_texcoord_in(h, dir))
        }
    }

    /// Unit direction at uv of image `face`; inverse of
    /// [`dir_to_texcoord`](Self::dir_to_texcoord). For dual maps, uv outside the shrunk square
    /// [½/res, 1−½/res]² is clamped onto it (the equator).
    pub fn texcoord_to_dir(&self, face: u32, uv: DVec2) -> DVec3 {
        debug_assert!(
            face < self.kind.face_count(),
            "image {face} of {}",
            self.kind
        );
        if self.kind.is_cube() {
            cube::face_st_to_dir(face, uv)
        } else {
            let scale = 2.0 * f64::from(self.res) / f64::from(self.res - 1);
            self.dual_square_to_dir(face, (uv - DVec2::splat(0.5)) * scale)
        }
    }

    /// Unit direction through the centre of texel (i, j) of image `face` — where a bake
    /// evaluates the stored signal. Outer-ring texels of the dual maps are exactly on the
    /// equator (y = 0), with identical directions in both hemispheres.
    pub fn texel_center_dir(&self, face: u32, i: u32, j: u32) -> DVec3 {
        debug_assert!(
            i < self.res && j < self.res,
            "texel ({i}, {j}) at res {}",
            self.res
        );
        if self.kind.is_cube() {
            let r = f64::from(self.res);
            let st = DVec2::new((f64::from(i) + 0.5) / r, (f64::from(j) + 0.5) / r);
            cube::face_st_to_dir(face, st)
        } else {
            // s = (2i + 1 − res)/(res − 1): exactly ±1 on the outer ring.
            let d = f64::from(self.res - 1);
            let s = |k: u32| (2.0 * f64::from(k) + 1.0 - f64::from(self.res)) / d;
            self.dual_square_to_dir(face, DVec2::new(s(i), s(j)))
        }
    }

    /// The four texels and weights that hardware bilinear filtering uses for `dir`
    /// (per-face clamp for dual maps and `cube-dx9`, seamless for `cube-dx10`).
    pub fn bilinear_taps(&self, dir: DVec3) -> BilinearTaps {
        let (face, uv) = self.dir_to_texcoord(dir);
        match self.kind {
            Parameterization::CubeDx10 => cube::seamless_taps(self.res, face, uv),
            _ => cube::clamped_taps(self.res, face, uv),
        }
    }

    /// Bilinearly reconstructed value of `values` at `dir`, as the texture unit filters.
    ///
    /// # Panics
    /// If `values` was made for another map (a bug, not an input error).
    pub fn reconstruct_bilinear(&self, values: &TexelGrid, dir: DVec3) -> f64 {
        assert_eq!(values.map, *self, "texel grid of another sphere map");
        self.bilinear_taps(dir).apply(&values.values)
    }

    /// uv in hemisphere `h` of a dual map for `dir` projected from that hemisphere (valid
    /// for `dir` in the closed hemisphere; on the equator both give identical uv).
    ///
    /// # Panics
    /// If the map is a cube (a bug: only dual maps have hemispheres).
    pub fn dual_texcoord_in(&self, h: u32, dir: DVec3) -> DVec2 {
        let p = match self.kind {
            Parameterization::DualOrtho => dual_ortho::project(h, dir),
            Parameterization::DualParaboloid => dual_paraboloid::project(h, dir),
            _ => unreachable!("{} is not a dual map", self.kind),
        };
        dual_disk_to_texcoord(p, self.res)
    }

    /// Direction of square point `s` ∈ [−1, 1]² (clamped) of hemisphere `h`.
    fn dual_square_to_dir(&self, h: u32, s: DVec2) -> DVec3 {
        let s = s.clamp(DVec2::NEG_ONE, DVec2::ONE);
        let p = concentric::square_to_disk(s);
        if s.x.abs() == 1.0 || s.y.abs() == 1.0 {
            // Outer ring: the equator exactly, the same bits for both hemispheres.
            let q = p.normalize();
            return DVec3::new(q.x, 0.0, q.y);
        }
        match self.kind {
            Parameterization::DualOrtho => dual_ortho::unproject(h, p),
            Parameterization::DualParaboloid => dual_paraboloid::unproject(h, p),
            _ => unreachable!("{} is not a dual map", self.kind),
        }
    }
}

/// Hemisphere of a dual map holding `dir`: 0 for y ≥ 0 (+Y, the equator included),
/// 1 for y < 0.
pub fn hemisphere_of(dir: DVec3) -> u32 {
    u32::from(dir.y < 0.0)
}

/// Disk point → uv of a dual-map hemisphere image: Shirley–Chiu to the square, then the
/// shrink u = ½ + s·(res−1)/(2·res) that puts the rim on the outer ring of texel centres.
pub fn dual_disk_to_texcoord(p: DVec2, res: u32) -> DVec2 {
    let s = concentric::disk_to_square(p).clamp(DVec2::NEG_ONE, DVec2::ONE);
    DVec2::splat(0.5) + s * (f64::from(res - 1) / f64::from(2 * res))
}

/// Texel values of one signal stored in a [`SphereMap`], in flat texel order.
#[derive(Clone, Debug, PartialEq)]
pub struct TexelGrid {
    map: SphereMap,
    values: Vec<f64>,
}

impl TexelGrid {
    /// Wraps `values` (flat order `face·res² + j·res + i`).
    ///
    /// # Errors
    /// [`SphereError::GridSize`] unless `values.len() == map.sample_count()`.
    pub fn new(map: SphereMap, values: Vec<f64>) -> Result<Self, SphereError> {
        if values.len() == map.sample_count() {
            Ok(TexelGrid { map, values })
        } else {
            Err(SphereError::GridSize {
                kind: map.kind,
                res: map.res,
                expected: map.sample_count(),
                got: values.len(),
            })
        }
    }

    /// `f` evaluated at every texel centre direction ([`SphereMap::texel_center_dir`]).
    pub fn from_fn(map: SphereMap, f: impl Fn(DVec3) -> f64) -> Self {
        let r = map.res;
        let values = (0..map.kind.face_count())
            .flat_map(|face| (0..r * r).map(move |k| (face, k % r, k / r)))
            .map(|(face, i, j)| f(map.texel_center_dir(face, i, j)))
            .collect();
        TexelGrid { map, values }
    }

    /// The map these values belong to.
    pub const fn map(&self) -> SphereMap {
        self.map
    }

    /// All values in flat texel order.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Value of texel (i, j) of image `face`.
    pub fn get(&self, face: u32, i: u32, j: u32) -> f64 {
        self.values[self.map.texel_index(face, i, j)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Weights of four O(1) terms summed in f64.
    const WEIGHT_SUM: f64 = 1e-14;
    /// Direction → uv → direction through trig in f64 (texel centres).
    const ROUND_TRIP: f64 = 1e-13;

    #[test]
    fn names_round_trip_and_reject_unknown() {
        for p in Parameterization::ALL {
            assert_eq!(p.name().parse::<Parameterization>().ok(), Some(p));
            assert_eq!(p.to_string(), p.name());
            assert_eq!(
                serde_json::to_string(&p).ok(),
                Some(format!("\"{}\"", p.name()))
            );
        }
        let e = "cube".parse::<Parameterization>().unwrap_err().to_string();
        assert!(e.contains("'cube'") && !e.contains('\n'), "{e}");
        assert!(SphereMap::new(Parameterization::CubeDx9, 1).is_err());
        assert!(SphereMap::new(Parameterization::CubeDx9, MAX_RES + 1).is_err());
    }

    #[test]
    fn sample_counts() {
        let m = |k, r| SphereMap::new(k, r).map(|m| m.sample_count()).ok();
        assert_eq!(m(Parameterization::DualOrtho, 16), Some(512));
        assert_eq!(m(Parameterization::DualParaboloid, 32), Some(2048));
        assert_eq!(m(Parameterization::CubeDx9, 16), Some(1536));
        assert_eq!(m(Parameterization::CubeDx10, 4), Some(96));
    }

    #[test]
    fn texel_centres_map_to_themselves() {
        for kind in Parameterization::ALL {
            for res in [2, 3, 8] {
                let map = SphereMap::new(kind, res).expect("valid res");
                for face in 0..kind.face_count() {
                    for k in 0..res * res {
                        let (i, j) = (k % res, k / res);
                        let d = map.texel_center_dir(face, i, j);
                        assert!((d.length() - 1.0).abs() < WEIGHT_SUM, "{d}");
                        let taps = map.bilinear_taps(d);
                        let sum: f64 = taps.weight.iter().sum();
                        assert!((sum - 1.0).abs() < WEIGHT_SUM);
                        // dir → uv lands on the texel centre (the well-conditioned way
                        // round for every kind; uv → dir is not for dual-ortho at the rim).
                        let (f, uv) = map.dir_to_texcoord(d);
                        let centre =
                            DVec2::new(f64::from(i) + 0.5, f64::from(j) + 0.5) / f64::from(res);
                        assert!(
                            (uv - centre).length() < ROUND_TRIP,
                            "{kind} {uv} vs {centre}"
                        );
                        // All weight on this texel — or, on the equator, on its twin in the
                        // other hemisphere, which holds the same direction.
                        let on_equator = !kind.is_cube() && d.y == 0.0;
                        assert!(f == face || on_equator, "{kind} ({face},{i},{j}) -> {f}");
                        let own = map.texel_index(f, i, j) as u32;
                        let w: f64 = (0..4)
                            .filter(|&t| taps.index[t] == own)
                            .map(|t| taps.weight[t])
                            .sum();
                        assert!(
                            (w - 1.0).abs() < ROUND_TRIP,
                            "{kind} res {res} ({face},{i},{j}): {taps:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn grid_size_is_checked() {
        let map = SphereMap::new(Parameterization::CubeDx10, 4).expect("valid res");
        let e = TexelGrid::new(map, vec![0.0; 95]).unwrap_err().to_string();
        assert!(
            e.contains("96") && e.contains("95") && e.contains("cube-dx10"),
            "{e}"
        );
        assert!(TexelGrid::new(map, vec![0.0; 96]).is_ok());
    }
}
