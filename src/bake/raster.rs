//! Texel rasterization of a mesh into its lightmap parameterization (DESIGN §1 "Lightmap"),
//! and gutter dilation.
//!
//! Texel (x, y) of a `res`² lightmap has its centre at uv = ((x+½)/res, (y+½)/res); uv v = 0
//! is row 0; storage is row-major, index y·res + x. A texel is *covered* when its centre lies
//! in some triangle's UV image. Its bake position is the barycentric interpolation of the
//! triangle's corners at that centre, and its normal is the triangle's *geometric* normal
//! (from positions), because visibility below the geometric tangent plane is the surface's
//! own (DESIGN §1 "Shading model"); the winding normal is flipped when it disagrees with
//! the interpolated vertex normals, so meshes with clockwise winding still bake the side
//! they are shaded on.
//!
//! Inside tests are inclusive with a small barycentric tolerance ([`EDGE_EPS`]), so a texel
//! centre exactly on an edge shared by two triangles is never lost to rounding (no cracks);
//! the first triangle, in index order, that claims a texel keeps it. Triangles with zero
//! area in 3D or in UV cannot be baked; they are skipped, counted, and reported once with
//! `log::warn!`.
//!
//! [`dilate`] fills gutter texels around charts from their filled 8-neighbours so that
//! bilinear filtering at chart borders does not fetch unbaked texels (DESIGN §6 "texels on
//! chart borders").

use std::ops::{Add, Mul};

use glam::{DVec2, Vec3, Vec4};

use super::BakeError;
use crate::scene::Mesh;

/// Barycentric tolerance of the inside test: texel centres this far outside (as a fraction
/// of the triangle's UV height) still count, which closes cracks on shared edges.
pub const EDGE_EPS: f64 = 1e-6;

/// Barycentric margin inside a second triangle for a texel centre to count as a chart
/// overlap (far above [`EDGE_EPS`], so centres on shared edges never count).
const OVERLAP_MARGIN: f64 = 1e-4;

/// Texels of a lightmap covered by a mesh, with what the bake needs at each.
#[derive(Clone, Debug, PartialEq)]
pub struct LightmapTexels {
    /// Texels per side.
    pub res: u32,
    /// Whether a triangle covers the texel centre; row-major, index y·res + x.
    pub covered: Vec<bool>,
    /// World position at the texel centre (zero where not covered), metres.
    pub position: Vec<Vec3>,
    /// Unit geometric normal, world space (zero where not covered).
    pub normal: Vec<Vec3>,
    /// The normal map's frame at the texel centre: the interpolated vertex normal and
    /// tangent (with handedness in w), as `glsl/include/common.glsl` builds it per pixel
    /// — what tangent-space lightmaps (`rnm`) are baked in. Zero where not
    /// covered.
    pub shading_normal: Vec<Vec3>,
    pub tangent: Vec<Vec4>,
}

impl LightmapTexels {
    /// Number of covered texels.
    pub fn covered_count(&self) -> usize {
        self.covered.iter().filter(|&&c| c).count()
    }

    /// The number of covered texels, or an error when there are none.
    ///
    /// # Errors
    /// [`BakeError::EmptyLightmap`] when no texel is covered.
    pub fn require_covered(&self) -> Result<usize, BakeError> {
        match self.covered_count() {
            0 => Err(BakeError::EmptyLightmap),
            n => Ok(n),
        }
    }

    /// Row-major index of the texel whose area contains `uv` (clamped to the lightmap).
    pub fn texel_index(&self, uv: [f32; 2]) -> usize {
        texel_index_of(self.res, uv)
    }
}

/// Row-major index of the texel of a `res`² lightmap whose area contains `uv` (clamped).
pub fn texel_index_of(res: u32, uv: [f32; 2]) -> usize {
    let to_texel = |c: f32| ((c * res as f32).floor().max(0.0) as u32).min(res - 1);
    (to_texel(uv[1]) * res + to_texel(uv[0])) as usize
}

/// 2D cross product (signed parallelogram area).
fn cross2(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Rasterizes the mesh's `uv_lightmap` into a `res`² texel grid (see the module doc).
pub fn rasterize(mesh: &Mesh, res: u32) -> LightmapTexels {
    rasterize_uvs(
        mesh,
        res,
        "lightmap UVs overlap",
        "each gets the first triangle's bake, so the others are lit wrongly (give non-overlapping TEXCOORD_1 charts, or remove them to have shvis generate some)",
    )
}

/// [`rasterize`], its overlap warning starting `overlap` and ending `consequence`, for
/// the UVs of other roles (the normal-map baker rasterizes material UVs).
pub fn rasterize_uvs(mesh: &Mesh, res: u32, overlap: &str, consequence: &str) -> LightmapTexels {
    let n = (res as usize) * (res as usize);
    let mut out = LightmapTexels {
        res,
        covered: vec![false; n],
        position: vec![Vec3::ZERO; n],
        normal: vec![Vec3::ZERO; n],
        shading_normal: vec![Vec3::ZERO; n],
        tangent: vec![Vec4::ZERO; n],
    };
    let mut degenerate = 0usize;
    // Texels whose centre lies well inside more than one triangle.
    let mut overlapped = vec![false; n];
    for t in 0..mesh.triangle_count() {
        let idx = &mesh.indices[3 * t..3 * t + 3];
        let Some(v) = idx
            .iter()
            .map(|&i| mesh.vertices.get(i as usize))
            .collect::<Option<Vec<_>>>()
        else {
            degenerate += 1; // an index out of range: nothing to bake
            continue;
        };
        let p = [0, 1, 2].map(|k| Vec3::from(v[k].position));
        // UV corners in texel units.
        let q = [0, 1, 2].map(|k| DVec2::from(v[k].uv_lightmap.map(f64::from)) * f64::from(res));
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let cross = e1.cross(e2);
        let area_uv = cross2(q[1] - q[0], q[2] - q[0]);
        // Zero area: |e1 × e2| = |e1||e2| sin θ below f32 resolution of the edge lengths
        // (written as "has area" so that NaN corners count as degenerate too).
        let has_area_3d = cross.length() > 1e-7 * (e1.length_squared() + e2.length_squared());
        let has_area_uv = area_uv.abs() > 1e-9; // texels²
        if !(has_area_3d && has_area_uv) {
            degenerate += 1;
            continue;
        }
        let mut normal = cross.normalize();
        let shading: Vec3 = v.iter().map(|v| Vec3::from(v.normal)).sum();
        if shading.dot(normal) < 0.0 {
            normal = -normal;
        }
        // Texel centres x+½ inside the UV bounding box.
        let lo = q[0].min(q[1]).min(q[2]);
        let hi = q[0].max(q[1]).max(q[2]);
        let first = |c: f64| (c - 0.5).ceil().clamp(0.0, f64::from(res)) as u32;
        let last = |c: f64| ((c - 0.5).floor() + 1.0).clamp(0.0, f64::from(res)) as u32;
        for y in first(lo.y)..last(hi.y) {
            for x in first(lo.x)..last(hi.x) {
                let i = y as usize * res as usize + x as usize;
                let c = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                let w0 = cross2(q[2] - q[1], c - q[1]) / area_uv;
                let w1 = cross2(q[0] - q[2], c - q[2]) / area_uv;
                let w2 = 1.0 - w0 - w1;
                if w0 < -EDGE_EPS || w1 < -EDGE_EPS || w2 < -EDGE_EPS {
                    continue;
                }
                if out.covered[i] {
                    // First writer wins; a centre well inside a second triangle (not on a
                    // shared edge) means the charts overlap.
                    overlapped[i] |= w0.min(w1).min(w2) > OVERLAP_MARGIN;
                    continue;
                }
                out.covered[i] = true;
                out.position[i] = p[0] * w0 as f32 + p[1] * w1 as f32 + p[2] * w2 as f32;
                out.normal[i] = normal;
                let (w0, w1, w2) = (w0 as f32, w1 as f32, w2 as f32);
                let vn = |k: usize| Vec3::from(v[k].normal);
                let vt = |k: usize| Vec4::from(v[k].tangent);
                out.shading_normal[i] = (vn(0) * w0 + vn(1) * w1 + vn(2) * w2).normalize_or(normal);
                let tangent = vt(0) * w0 + vt(1) * w1 + vt(2) * w2;
                out.tangent[i] = tangent.truncate().extend(v[0].tangent[3].signum());
            }
        }
    }
    if degenerate > 0 {
        log::warn!(
            "lightmap raster: skipped {degenerate} degenerate triangles (zero area in 3D or in lightmap UV)"
        );
    }
    let overlapping = overlapped.iter().filter(|&&o| o).count();
    if overlapping > 0 {
        let covered = out.covered.iter().filter(|&&c| c).count();
        log::warn!(
            "{overlap}: {overlapping} of {covered} covered texels ({:.2} %) lie inside more than one triangle; {consequence}",
            100.0 * overlapping as f64 / covered.max(1) as f64
        );
    }
    out
}

/// Gutter dilation: `passes` times, every texel not yet filled that has filled
/// 8-neighbours becomes their average. Filled = `covered` at first, then also texels filled
/// by earlier passes. Each pass reads the previous one's values, so the result does not
/// depend on the visiting order.
///
/// # Panics
/// When `values` or `covered` do not hold res² entries (a bug in the caller).
pub fn dilate<T>(values: &mut [T], covered: &[bool], res: u32, passes: u32)
where
    T: Copy + Add<Output = T> + Mul<f32, Output = T>,
{
    DilationPlan::new(covered, res, passes).apply(values);
}

/// Which texels [`dilate`] fills, pass by pass, and from which neighbours: it depends on
/// the coverage only, so one plan serves every value array of a lightmap (and vectors of
/// values per texel, [`DilationPlan::apply_vectors`]). Within a pass the targets were not
/// filled before it and the sources were, so a pass can be applied in place.
#[derive(Clone, Debug, Default)]
pub struct DilationPlan {
    /// Filled texels in pass order.
    targets: Vec<u32>,
    /// The 8-neighbours each target averages (row-major order), `starts`-delimited.
    sources: Vec<u32>,
    starts: Vec<u32>,
}

impl DilationPlan {
    /// The plan of `passes` dilation passes of a res² lightmap with this coverage.
    ///
    /// # Panics
    /// When `covered` does not hold res² entries (a bug in the caller).
    pub fn new(covered: &[bool], res: u32, passes: u32) -> DilationPlan {
        let n = res as usize;
        assert_eq!(covered.len(), n * n, "dilate: coverage is not res²");
        let mut plan = DilationPlan {
            starts: vec![0],
            ..DilationPlan::default()
        };
        let mut filled = covered.to_vec();
        for _ in 0..passes {
            let pass_start = plan.targets.len();
            for y in 0..n {
                for x in 0..n {
                    let i = y * n + x;
                    if filled[i] {
                        continue;
                    }
                    let before = plan.sources.len();
                    for ny in y.saturating_sub(1)..(y + 2).min(n) {
                        for nx in x.saturating_sub(1)..(x + 2).min(n) {
                            let j = ny * n + nx;
                            // `filled` is updated after the pass: these were filled before it.
                            if j != i && filled[j] {
                                plan.sources.push(j as u32);
                            }
                        }
                    }
                    if plan.sources.len() > before {
                        plan.targets.push(i as u32);
                        plan.starts.push(plan.sources.len() as u32);
                    }
                }
            }
            if plan.targets.len() == pass_start {
                break;
            }
            for &t in &plan.targets[pass_start..] {
                filled[t as usize] = true;
            }
        }
        plan
    }

    /// Each target with its sources, in pass order.
    fn entries(&self) -> impl Iterator<Item = (usize, &[u32])> {
        self.targets.iter().enumerate().map(|(k, &t)| {
            let range = self.starts[k] as usize..self.starts[k + 1] as usize;
            (t as usize, &self.sources[range])
        })
    }

    /// Dilates one value per texel.
    pub fn apply<T>(&self, values: &mut [T])
    where
        T: Copy + Add<Output = T> + Mul<f32, Output = T>,
    {
        for (target, sources) in self.entries() {
            let sum = sources[1..]
                .iter()
                .fold(values[sources[0] as usize], |s, &j| s + values[j as usize]);
            values[target] = sum * (1.0 / sources.len() as f32);
        }
    }

    /// Dilates texel-major vectors of `n` values per texel, component by component as
    /// [`Self::apply`] would each (the same sums in the same order).
    pub fn apply_vectors(&self, values: &mut [f32], n: usize) {
        let mut sum = vec![0.0f32; n];
        for (target, sources) in self.entries() {
            let first = sources[0] as usize;
            sum.copy_from_slice(&values[first * n..(first + 1) * n]);
            for &j in &sources[1..] {
                let j = j as usize;
                for (s, v) in sum.iter_mut().zip(&values[j * n..(j + 1) * n]) {
                    *s += *v;
                }
            }
            let scale = 1.0 / sources.len() as f32;
            for (v, s) in values[target * n..(target + 1) * n].iter_mut().zip(&sum) {
                *v = *s * scale;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    fn vertex(p: [f32; 3], uv: [f32; 2]) -> Vertex {
        Vertex {
            position: p,
            normal: [0.0, 1.0, 0.0],
            uv_lightmap: uv,
            ..Vertex::default()
        }
    }

    /// A unit square on y = 0 whose lightmap UVs are `uv0..uv1`, as two triangles sharing
    /// the diagonal.
    fn square(uv0: f32, uv1: f32) -> Mesh {
        Mesh {
            vertices: vec![
                vertex([0.0, 0.0, 0.0], [uv0, uv0]),
                vertex([1.0, 0.0, 0.0], [uv1, uv0]),
                vertex([1.0, 0.0, 1.0], [uv1, uv1]),
                vertex([0.0, 0.0, 1.0], [uv0, uv1]),
            ],
            // Counter-clockwise seen from +Y: (0,0,0) → (0,0,1) → (1,0,1).
            indices: vec![0, 3, 2, 0, 2, 1],
        }
    }

    /// Interpolated positions are f32 sums of three products.
    const POSITION: f32 = 1e-6;

    #[test]
    fn full_square_covers_every_texel_without_cracks() {
        let t = rasterize(&square(0.0, 1.0), 16);
        assert_eq!(t.covered_count(), 256, "the shared diagonal lost texels");
        for y in 0..16 {
            for x in 0..16 {
                let i = y * 16 + x;
                let want = Vec3::new((x as f32 + 0.5) / 16.0, 0.0, (y as f32 + 0.5) / 16.0);
                assert!((t.position[i] - want).length() < POSITION, "texel {x},{y}");
                assert_eq!(t.normal[i], Vec3::Y);
            }
        }
    }

    #[test]
    fn texel_aligned_chart_covers_exactly_its_rectangle() {
        // Corners on texel boundaries 4/16 and 12/16: texels 4..12 in x and y.
        let t = rasterize(&square(0.25, 0.75), 16);
        for y in 0..16 {
            for x in 0..16 {
                let inside = (4..12).contains(&x) && (4..12).contains(&y);
                assert_eq!(t.covered[y * 16 + x], inside, "texel {x},{y}");
            }
        }
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        let mut m = square(0.0, 1.0);
        // Zero 3D area (repeated corner) and zero UV area (collinear UVs).
        m.vertices.push(vertex([0.0, 0.0, 0.0], [0.1, 0.1]));
        m.vertices.push(vertex([2.0, 0.0, 0.0], [0.9, 0.9]));
        m.vertices.push(vertex([2.0, 1.0, 0.0], [0.5, 0.5]));
        m.indices = vec![0, 0, 1, 4, 5, 6];
        let t = rasterize(&m, 16);
        assert_eq!(t.covered_count(), 0);
        assert!(matches!(t.require_covered(), Err(BakeError::EmptyLightmap)));
    }

    #[test]
    fn clockwise_winding_keeps_the_shaded_side() {
        let mut m = square(0.0, 1.0);
        m.indices = vec![0, 2, 3, 0, 1, 2]; // clockwise from +Y, vertex normals +Y
        let t = rasterize(&m, 16);
        assert!(t.normal.iter().all(|&n| n == Vec3::Y));
    }

    #[test]
    fn dilation_fills_gutters_ring_by_ring_with_neighbour_averages() {
        let res = 8;
        let mut covered = vec![false; 64];
        let mut values = vec![0.0f32; 64];
        // Two covered texels side by side in the middle: 1 and 3.
        covered[3 * 8 + 3] = true;
        values[3 * 8 + 3] = 1.0;
        covered[3 * 8 + 4] = true;
        values[3 * 8 + 4] = 3.0;
        dilate(&mut values, &covered, res, 1);
        assert_eq!(values[2 * 8 + 2], 1.0); // touches only the first
        assert_eq!(values[2 * 8 + 3], 2.0); // touches both
        assert_eq!(values[4 * 8 + 5], 3.0);
        assert_eq!(values[8 + 1], 0.0, "one pass reaches one ring only");
        dilate(&mut values, &covered, res, 2);
        assert!(values[8 + 1] > 0.0, "second pass reaches the next ring");
        assert_eq!(values[3 * 8 + 3], 1.0, "covered texels never change");
    }

    #[test]
    fn dilation_of_vectors_equals_dilating_each_component() {
        let res: usize = 12;
        // A ragged coverage: a diagonal band and a lone texel.
        let covered: Vec<bool> = (0..res * res)
            .map(|i| (i % res).abs_diff(i / res) <= 1 || i == 5 * res + 10)
            .collect();
        let n = 5;
        let mut vectors: Vec<f32> = (0..res * res * n)
            .map(|i| (i as f32 * 0.37).sin())
            .collect();
        let mut planes: Vec<Vec<f32>> = (0..n)
            .map(|k| (0..res * res).map(|t| vectors[t * n + k]).collect())
            .collect();
        let plan = DilationPlan::new(&covered, res as u32, 3);
        plan.apply_vectors(&mut vectors, n);
        for (k, plane) in planes.iter_mut().enumerate() {
            dilate(plane, &covered, res as u32, 3);
            for t in 0..res * res {
                assert_eq!(
                    vectors[t * n + k].to_bits(),
                    plane[t].to_bits(),
                    "texel {t}, component {k}"
                );
            }
        }
    }
}
