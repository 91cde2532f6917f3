//! Normal-map generation from a high-polygon mesh for a low one (Gumbau, González and
//! Chover, *GPU-based normal map generation*): `shvis normalmap`.
//!
//! The product is the paper's GPU method ([`gpu`]): one render of the high mesh per low
//! triangle T through T's view and pseudo-orthographic projection ([`projection`], eqs.
//! (1)–(5)), vertex mirroring in the vertex shader (eq. (6)) so the depth test keeps the
//! surface nearest T's plane, a coverage mask so only T's own texels are written (§3.3),
//! and border expansion (§3.5). [`cull`] limits each render to the high triangles in T's
//! prism (§4's acceleration structure). The check is [`cpu`], the software approach the
//! paper compares with: rays along the low surface's interpolated normal, both ways.
//!
//! Both produce a [`NormalImage`] of object-space normals (the paper's output);
//! [`tangent_space`] turns it into this project's tangent-space convention (glTF, +Y green,
//! the low mesh's MikkTSpace frame exactly as `glsl/include/common.glsl` decodes it), and
//! [`output`] writes 16-bit PNG, EXR and a glTF of the low mesh that uses the map.
//! [`simplify`] makes low meshes from one detailed mesh.
//!
//! Texel conventions are the lightmap's (DESIGN §1): the map is `res`² over the low mesh's
//! material UVs (TEXCOORD_0, which must be unique and inside [0, 1]), texel (x, y) centred
//! at ((x+½)/res, (y+½)/res), row 0 at v = 0.

pub mod cpu;
pub mod cull;
pub mod gpu;
pub mod job;
pub mod output;
pub mod projection;
pub mod simplify;

use glam::{Vec3, Vec4};

use crate::bake::raster::{self, LightmapTexels};
use crate::gpu::GpuError;
use crate::scene::Mesh;

/// Smallest and largest map side accepted.
pub const MIN_RES: u32 = 4;
pub const MAX_RES: u32 = 4096;
/// Most border-expansion passes accepted.
pub const MAX_EXPAND: u32 = 64;
/// Default search distance D as a fraction of the low mesh's bounding-box diagonal.
pub const DEFAULT_DISTANCE_FRACTION: f32 = 0.05;
/// Most low triangles (their ids travel as exact f32 integers in the mask).
pub const MAX_LOW_TRIANGLES: usize = 1 << 24;

/// Coverage flag (texel `w`) of a texel whose normal was generated.
pub const COVERED: f32 = 1.0;
/// Coverage flag of a texel filled by border expansion.
pub const EXPANDED: f32 = 0.5;

/// How the GPU baker issues its per-triangle renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DrawMode {
    /// One `vkCmdDrawIndexedIndirect` with a command per low triangle (`firstInstance` =
    /// the triangle), no state changes between them.
    Indirect,
    /// One `vkCmdDrawIndexed` per low triangle, each with a scissor around T's texels.
    Direct,
}

/// What a normal-map bake does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalMapSettings {
    /// Texels per side.
    pub res: u32,
    /// Border-expansion passes (§3.5): texels within `expand` of a chart get filled.
    pub expand: u32,
    /// Search distance D, metres: surfaces farther from the low surface are ignored.
    pub max_distance: f32,
    /// Vertex mirroring (eq. (6)); off reproduces the paper's Fig. 4 failure.
    pub mirror: bool,
    /// Draw only each low triangle's prism candidates ([`cull`]); off draws the whole
    /// high mesh per low triangle.
    pub cull: bool,
    pub draws: DrawMode,
}

impl NormalMapSettings {
    /// Defaults for `res`: 2 expansion passes, D from [`default_max_distance`], mirroring,
    /// culling, indirect draws.
    pub fn new(low: &Mesh, res: u32) -> NormalMapSettings {
        NormalMapSettings {
            res,
            expand: 2,
            max_distance: default_max_distance(low),
            mirror: true,
            cull: true,
            draws: DrawMode::Indirect,
        }
    }
}

/// [`DEFAULT_DISTANCE_FRACTION`] of the low mesh's bounding-box diagonal.
pub fn default_max_distance(low: &Mesh) -> f32 {
    let (lo, hi) = low.bounds();
    DEFAULT_DISTANCE_FRACTION * (hi - lo).length()
}

/// Why a normal map could not be made.
#[derive(Debug, thiserror::Error)]
pub enum NormalMapError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// Unusable input or settings; the message says which and why.
    #[error("{0}")]
    Invalid(String),
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error(transparent)]
    File(#[from] crate::files::FileError),
}

/// A generated map: `res`² texels, row-major, row 0 at v = 0; `xyz` the unit object-space
/// normal, `w` [`COVERED`], [`EXPANDED`] or 0 (empty).
#[derive(Clone, Debug, PartialEq)]
pub struct NormalImage {
    pub res: u32,
    pub texels: Vec<[f32; 4]>,
}

impl NormalImage {
    pub fn empty(res: u32) -> NormalImage {
        NormalImage {
            res,
            texels: vec![[0.0; 4]; (res as usize) * (res as usize)],
        }
    }

    pub fn normal(&self, i: usize) -> Vec3 {
        Vec4::from(self.texels[i]).truncate()
    }

    /// Texels generated (not expanded, not empty).
    pub fn covered_count(&self) -> usize {
        self.texels.iter().filter(|t| t[3] == COVERED).count()
    }

    /// Generated texels whose 8 neighbours are generated too: the texels away from chart
    /// borders, where the two bakers' coverage rules cannot differ.
    pub fn interior(&self) -> Vec<bool> {
        let n = self.res as usize;
        let covered = |x: usize, y: usize| self.texels[y * n + x][3] == COVERED;
        let mut out = vec![false; n * n];
        for y in 1..n.saturating_sub(1) {
            for x in 1..n - 1 {
                out[y * n + x] =
                    (y - 1..=y + 1).all(|yy| (x - 1..=x + 1).all(|xx| covered(xx, yy)));
            }
        }
        out
    }
}

/// Most subdivision levels of `sphere:LEVEL` (level 9: 5.2 M triangles).
pub const MAX_SPHERE_LEVEL: u32 = 9;

/// Which side of the pair a mesh is for ([`load_mesh`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshRole {
    High,
    /// Prepared for a `res`² map (built-in shapes get generated UVs).
    Low {
        res: u32,
    },
}

/// A mesh from `sphere:LEVEL` (a unit icosphere, [`simplify::sphere_high`] /
/// [`simplify::sphere_low`]) or a glTF file (world space, as `--scene` loads it).
///
/// # Errors
/// A bad level, or a file the loader refuses.
pub fn load_mesh(spec: &str, role: MeshRole) -> Result<Mesh, NormalMapError> {
    if let Some(level) = spec.strip_prefix("sphere:") {
        let level: u32 = level
            .parse()
            .ok()
            .filter(|&l| l <= MAX_SPHERE_LEVEL)
            .ok_or_else(|| {
                NormalMapError::Invalid(format!(
                    "'{spec}': the level must be an integer in 0..={MAX_SPHERE_LEVEL}"
                ))
            })?;
        return match role {
            MeshRole::High => Ok(simplify::sphere_high(level, 1.0)),
            MeshRole::Low { res } => simplify::sphere_low(level, 1.0, res),
        };
    }
    let lightmap_res = match role {
        MeshRole::High => 1024,
        MeshRole::Low { res } => res,
    }
    .clamp(
        crate::scene::lightmap_uv::MIN_LIGHTMAP_RES,
        crate::scene::lightmap_uv::MAX_LIGHTMAP_RES,
    );
    crate::scene::gltf::load(std::path::Path::new(spec), lightmap_res)
        .map(|scene| scene.mesh)
        .map_err(|e| NormalMapError::Invalid(e.to_string()))
}

/// Checks the inputs both bakers share.
///
/// # Errors
/// [`NormalMapError::Invalid`] naming the problem.
pub fn validate(high: &Mesh, low: &Mesh, s: &NormalMapSettings) -> Result<(), NormalMapError> {
    let bad = |m: String| Err(NormalMapError::Invalid(m));
    if !(MIN_RES..=MAX_RES).contains(&s.res) {
        return bad(format!(
            "resolution {} is outside {MIN_RES}..={MAX_RES}",
            s.res
        ));
    }
    if s.expand > MAX_EXPAND {
        return bad(format!(
            "{} expansion passes: at most {MAX_EXPAND}",
            s.expand
        ));
    }
    if !(s.max_distance.is_finite() && s.max_distance > 0.0) {
        return bad(format!(
            "search distance {} must be positive and finite",
            s.max_distance
        ));
    }
    for (mesh, which) in [(high, "high"), (low, "low")] {
        if mesh.triangle_count() == 0 {
            return bad(format!("the {which} mesh has no triangles"));
        }
    }
    if low.triangle_count() > MAX_LOW_TRIANGLES {
        return bad(format!(
            "the low mesh has {} triangles: at most {MAX_LOW_TRIANGLES}",
            low.triangle_count()
        ));
    }
    let outside = low
        .vertices
        .iter()
        .filter(|v| {
            v.uv_material
                .iter()
                .any(|&c| !(-1e-4..=1.0 + 1e-4).contains(&c))
        })
        .count();
    if outside > 0 {
        return bad(format!(
            "{outside} low-mesh vertices have material UVs outside [0, 1]: a normal map needs a unique parameterization (use --simplify to generate one)"
        ));
    }
    // No triangle with area in UV space: the mesh has no material UVs (glTF's default is
    // (0, 0) at every vertex), and no texel could be covered.
    let has_uv_area = low.indices.chunks_exact(3).any(|t| {
        let uv = |k: usize| {
            low.vertices
                .get(t[k] as usize)
                .map(|v| glam::Vec2::from(v.uv_material))
        };
        match (uv(0), uv(1), uv(2)) {
            (Some(a), Some(b), Some(c)) => (b - a).perp_dot(c - a).abs() > 1e-12,
            _ => false,
        }
    });
    if !has_uv_area {
        return bad(
            "the low mesh has no material UVs (TEXCOORD_0): every triangle has zero area in UV space; a normal map needs a unique parameterization (use --simplify to generate one)"
                .to_string(),
        );
    }
    Ok(())
}

/// The low mesh's texels in its material UVs: position, geometric and interpolated
/// normal and tangent per covered texel ([`raster::rasterize`], first triangle wins).
pub fn low_texels(low: &Mesh, res: u32) -> LightmapTexels {
    let mut by_material = low.clone();
    for v in &mut by_material.vertices {
        v.uv_lightmap = v.uv_material;
    }
    raster::rasterize_uvs(
        &by_material,
        res,
        "the low mesh's material UVs (TEXCOORD_0) overlap",
        "each such texel gets the first triangle's normal (give the low mesh unique material UVs)",
    )
}

/// `image` unless no texel found a high surface within `max_distance`.
///
/// # Errors
/// [`NormalMapError::Invalid`] for an empty map (meshes apart, or D too small).
pub(crate) fn require_texels(
    image: NormalImage,
    max_distance: f32,
) -> Result<NormalImage, NormalMapError> {
    if image.covered_count() == 0 {
        return Err(NormalMapError::Invalid(format!(
            "no texel found a high-mesh surface within {max_distance} of the low mesh: are the meshes in the same place and scale? (--distance)"
        )));
    }
    Ok(image)
}

/// Border expansion (§3.5), the CPU twin of `glsl/normalmap/expand.comp`: `passes` times,
/// every empty texel with non-empty 8-neighbours becomes their normalized mean, flagged
/// [`EXPANDED`]. Each pass reads the previous pass's result.
pub fn expand_borders(image: &mut NormalImage, passes: u32) {
    let n = image.res as usize;
    for _ in 0..passes {
        let src = image.texels.clone();
        for y in 0..n {
            for x in 0..n {
                let i = y * n + x;
                if src[i][3] > 0.0 {
                    continue;
                }
                let mut sum = Vec3::ZERO;
                let mut count = 0;
                for ny in y.saturating_sub(1)..(y + 2).min(n) {
                    for nx in x.saturating_sub(1)..(x + 2).min(n) {
                        let t = src[ny * n + nx];
                        if (ny, nx) != (y, x) && t[3] > 0.0 {
                            sum += Vec4::from(t).truncate();
                            count += 1;
                        }
                    }
                }
                if count > 0 && sum.length() > 1e-6 {
                    image.texels[i] = sum.normalize().extend(EXPANDED).to_array();
                }
            }
        }
    }
}

/// Tangent-space normals of `image` in the low mesh's frame, encoded as the renderer
/// decodes them (`common.glsl::shading_normal`: n = normalize(interpolated normal),
/// t = Gram–Schmidt of the interpolated tangent, b = w · n × t; stored m = (n·t, n·b, n·n)
/// so that t m.x + b m.y + n m.z is the object normal). Texels the raster did not cover
/// (expansion borders) take their frame from the nearest covered texels by the same
/// dilation; empty texels become flat (0, 0, 1). `w` is copied.
pub fn tangent_space(image: &NormalImage, frames: &LightmapTexels) -> Vec<[f32; 4]> {
    let passes = MAX_EXPAND + 1;
    let mut normal = frames.shading_normal.clone();
    let mut tangent = frames.tangent.clone();
    raster::dilate(&mut normal, &frames.covered, image.res, passes);
    raster::dilate(&mut tangent, &frames.covered, image.res, passes);
    image
        .texels
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let flat = [0.0, 0.0, 1.0, t[3]];
            if t[3] == 0.0 {
                return flat;
            }
            let Some(n) = normal[i].try_normalize() else {
                return flat;
            };
            let tw = tangent[i];
            let Some(tt) = (tw.truncate() - n * n.dot(tw.truncate())).try_normalize() else {
                return flat;
            };
            let b = n.cross(tt) * if tw.w < 0.0 { -1.0 } else { 1.0 };
            let m = Vec4::from(*t).truncate();
            [m.dot(tt), m.dot(b), m.dot(n), t[3]]
        })
        .collect()
}

/// Angle between two directions, degrees (0 for a zero vector against itself).
pub fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    let (a, b) = (
        a.as_dvec3().normalize_or_zero(),
        b.as_dvec3().normalize_or_zero(),
    );
    a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Median, 99th percentile and maximum of a set of angles.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct AngleStats {
    pub count: usize,
    pub median_deg: f64,
    pub p99_deg: f64,
    pub max_deg: f64,
}

impl AngleStats {
    /// `None` for an empty set.
    pub fn of(mut angles: Vec<f64>) -> Option<AngleStats> {
        if angles.is_empty() {
            return None;
        }
        angles.sort_by(f64::total_cmp);
        let at = |q: f64| angles[((angles.len() - 1) as f64 * q).round() as usize];
        Some(AngleStats {
            count: angles.len(),
            median_deg: at(0.5),
            p99_deg: at(0.99),
            max_deg: angles[angles.len() - 1],
        })
    }
}

impl std::fmt::Display for AngleStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "median {:.4}°, p99 {:.4}°, max {:.3}° over {} texels",
            self.median_deg, self.p99_deg, self.max_deg, self.count
        )
    }
}

/// Angles between two maps' normals over the texels both generated and `mask` allows.
pub fn compare(a: &NormalImage, b: &NormalImage, mask: &[bool]) -> Option<AngleStats> {
    let angles = (0..a.texels.len())
        .filter(|&i| mask[i] && a.texels[i][3] == COVERED && b.texels[i][3] == COVERED)
        .map(|i| angle_deg(a.normal(i), b.normal(i)))
        .collect();
    AngleStats::of(angles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expansion_fills_exactly_the_texels_within_k_of_a_chart() {
        let mut image = NormalImage::empty(16);
        let n = Vec3::new(0.0, 0.6, 0.8);
        for y in 6..9 {
            for x in 5..7 {
                image.texels[y * 16 + x] = n.extend(COVERED).to_array();
            }
        }
        expand_borders(&mut image, 2);
        for y in 0..16i32 {
            for x in 0..16i32 {
                let dist = (5 - x).max(x - 6).max(6 - y).max(y - 8).max(0);
                let t = image.texels[(y * 16 + x) as usize];
                assert_eq!(t[3] > 0.0, dist <= 2, "texel {x},{y} at distance {dist}");
                if t[3] > 0.0 {
                    assert!(angle_deg(Vec4::from(t).truncate(), n) < 1e-4);
                }
            }
        }
    }

    #[test]
    fn angle_stats_order_statistics() {
        let s = AngleStats::of((0..=100).map(f64::from).collect()).unwrap();
        assert_eq!(
            (s.median_deg, s.p99_deg, s.max_deg, s.count),
            (50.0, 99.0, 100.0, 101)
        );
        assert!(AngleStats::of(Vec::new()).is_none());
        assert!((angle_deg(Vec3::X, Vec3::Y) - 90.0).abs() < 1e-9);
    }
}
