//! Lightmap parameterization (DESIGN §1 "Lightmap"): the texel-aligned chart packer shared
//! by the built-in house and by glTF scenes, and generated unique lightmap UVs for meshes
//! that come without TEXCOORD_1.
//!
//! **Packer.** Each chart is a rectangle of `size` metres drawn at `density_scale` times a
//! uniform density d (texels per metre); at density d it needs ⌈size·d·scale⌉ texels per
//! side (at least 1). Charts are shelf-packed, tallest first, with [`GUTTER_TEXELS`] empty
//! texels between charts and around the border. The density is the largest one for which
//! everything fits, found by bisection: packing is monotone enough in d for the bisection to
//! land on a near-largest fitting density, and the total area gives the upper bound
//! d ≤ res / √(Σ area·scale²).
//!
//! **Generated UVs** ([`generate`]). No well-kept pure-Rust unwrapper exists, and xatlas
//! bindings need a C++ build, so the charts are built here with a simple, predictable
//! method suited to low-frequency visibility:
//! 1. *Charts*: flood fill across shared edges (corners welded by exact position, so UV and
//!    normal seams do not cut charts), seeded at the largest unassigned triangle, accepting
//!    a neighbour whose geometric normal is within [`CHART_MAX_ANGLE_DEG`] of the seed's.
//!    Every triangle of a chart is then within 2·30° of the chart's mean normal, so the
//!    projection below never flips a triangle.
//! 2. *Projection*: onto the plane perpendicular to the chart's area-weighted mean normal,
//!    rotated to the principal axes of its corners (a tighter bounding rectangle).
//! 3. *Packing*: the bounding rectangles go through the packer above at the actual
//!    `lightmap_res`, so gutters are counted in real texels; each chart is centred in its
//!    texel rectangle at the uniform density (square texels, no stretch).
//! 4. *Splitting*: corners are re-indexed per (vertex, chart), so a vertex shared by two
//!    charts becomes two vertices, each with its own chart's lightmap UV.
//!
//! Texels of different charts are therefore disjoint by construction: each chart's
//! triangles lie inside its own texel rectangle and rectangles are ≥ 2 texels apart.
//! Limitation: a chart whose normals stay within the cone can still overlap *itself* in
//! projection (a shallow spiral ramp); real models rarely do, and such texels are shared
//! only within one chart. Tests: `generated_charts_have_disjoint_texels` here and
//! `tests/scene_gltf.rs`.

use rustc_hash::FxHashMap;

use glam::{DVec2, DVec3};

use super::{Mesh, Vertex};

/// Empty texels between two charts and between a chart and the lightmap border.
pub const GUTTER_TEXELS: u32 = 2;
/// Smallest lightmap resolution accepted for glTF scenes (a few charts plus gutters).
pub const MIN_LIGHTMAP_RES: u32 = 16;
/// Largest lightmap resolution accepted.
pub const MAX_LIGHTMAP_RES: u32 = 8192;
/// Largest angle between a triangle's normal and its chart seed's normal, degrees.
pub const CHART_MAX_ANGLE_DEG: f64 = 30.0;

/// Bisection steps on the density: 2⁻⁴⁰ relative, far below one texel.
const BISECTION_STEPS: u32 = 40;
/// Upper clamp of a chart side, texels (keeps u32 sums far from overflow).
const MAX_CHART_TEXELS: f64 = 1e9;

/// [`SceneError::LightmapRes`] unless `res` is within [`MIN_LIGHTMAP_RES`]..=[`MAX_LIGHTMAP_RES`]
/// (scenes with generated lightmap UVs: glTF without TEXCOORD_1, the wavy sphere).
pub fn check_res(res: u32) -> Result<(), super::SceneError> {
    if (MIN_LIGHTMAP_RES..=MAX_LIGHTMAP_RES).contains(&res) {
        Ok(())
    } else {
        Err(super::SceneError::LightmapRes {
            res,
            min: MIN_LIGHTMAP_RES,
            max: MAX_LIGHTMAP_RES,
        })
    }
}

/// One chart to pack: a rectangle in metres and its density relative to the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChartSize {
    /// Rectangle extents, metres (≥ 0).
    pub size: DVec2,
    /// Texel density multiplier (1 = uniform; the house ground uses ½).
    pub density_scale: f64,
}

/// Texel rectangle of one packed chart: corner (x, y) and size (w, h), texels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChartRect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

/// A packed layout: one rectangle per chart, in input order.
#[derive(Clone, Debug, PartialEq)]
pub struct Packing {
    pub rects: Vec<ChartRect>,
    /// The uniform density reached, texels per metre (before each chart's `density_scale`).
    pub density: f64,
}

/// Chart sizes in texels at `density` texels per metre (at least 1×1).
fn chart_texels(charts: &[ChartSize], density: f64) -> Vec<(u32, u32)> {
    charts
        .iter()
        .map(|c| {
            let d = density * c.density_scale;
            let texels = |m: f64| (m * d).ceil().clamp(1.0, MAX_CHART_TEXELS) as u32;
            (texels(c.size.x), texels(c.size.y))
        })
        .collect()
}

/// Shelf packing, tallest first, with [`GUTTER_TEXELS`] between charts and at the border.
fn shelf_pack(sizes: &[(u32, u32)], res: u32) -> Option<Vec<ChartRect>> {
    let g = u64::from(GUTTER_TEXELS);
    let res = u64::from(res);
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| (std::cmp::Reverse(sizes[i].1), std::cmp::Reverse(sizes[i].0)));
    let mut rects = vec![ChartRect::default(); sizes.len()];
    let (mut x, mut y, mut shelf) = (g, g, 0u64);
    for i in order {
        let (w, h) = (u64::from(sizes[i].0), u64::from(sizes[i].1));
        if x + w + g > res {
            (x, y, shelf) = (g, y + shelf + g, 0);
        }
        if x + w + g > res || y + h + g > res {
            return None;
        }
        // All four fit below `res` ≤ u32::MAX here.
        rects[i] = ChartRect {
            x: x as u32,
            y: y as u32,
            w: w as u32,
            h: h as u32,
        };
        x += w + g;
        shelf = shelf.max(h);
    }
    Some(rects)
}

/// Packs `charts` into a `res`² lightmap at the largest uniform density that fits
/// (bisection), or `None` when even 1×1-texel charts do not fit.
pub fn pack_charts(charts: &[ChartSize], res: u32) -> Option<Packing> {
    let mut best = Packing {
        rects: shelf_pack(&chart_texels(charts, 0.0), res)?,
        density: 0.0,
    };
    let area: f64 = charts
        .iter()
        .map(|c| c.size.x * c.size.y * c.density_scale * c.density_scale)
        .sum();
    let longest = charts
        .iter()
        .map(|c| c.size.max_element() * c.density_scale)
        .fold(0.0, f64::max);
    // Total chart area cannot exceed the lightmap: an upper bound on the density. Charts
    // of zero area (lines) are bounded by their length instead.
    let mut hi = f64::from(res) / area.sqrt();
    if !hi.is_finite() {
        hi = f64::from(res) / longest;
    }
    if !hi.is_finite() || hi <= 0.0 {
        return Some(best);
    }
    let mut lo = 0.0;
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (lo + hi);
        match shelf_pack(&chart_texels(charts, mid), res) {
            Some(rects) => {
                best = Packing {
                    rects,
                    density: mid,
                };
                lo = mid;
            }
            None => hi = mid,
        }
    }
    Some(best)
}

/// Outcome of [`generate`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GeneratedCharts {
    pub charts: usize,
    /// Texels per metre of the packing.
    pub density_per_m: u64,
}

/// Why [`generate`] failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooManyCharts {
    pub charts: usize,
}

/// Replaces `mesh`'s lightmap UVs with a generated unique parameterization for a
/// `res`² lightmap (module doc), splitting vertices shared between charts.
///
/// # Errors
/// [`TooManyCharts`] when the charts do not fit even at one texel each.
pub fn generate(mesh: &mut Mesh, res: u32) -> Result<GeneratedCharts, TooManyCharts> {
    // Geometric normals (unit or zero) and areas.
    let (normals, areas) = triangle_normals_and_areas(mesh);
    let adjacency = EdgeAdjacency::new(mesh);
    let (chart_of, charts) = grow_charts(&normals, &areas, &adjacency);
    let projected = project_charts(mesh, &charts, &normals, &areas);

    let packing = pack_charts(&projected.sizes, res).ok_or(TooManyCharts {
        charts: charts.len(),
    })?;

    let (vertices, indices) = split_vertices(mesh, &chart_of, &projected, &packing, res);
    mesh.vertices = vertices;
    mesh.indices = indices;
    Ok(GeneratedCharts {
        charts: charts.len(),
        density_per_m: packing.density as u64,
    })
}

/// Per triangle of `mesh`: its geometric normal (unit or zero) and its area.
fn triangle_normals_and_areas(mesh: &Mesh) -> (Vec<DVec3>, Vec<f64>) {
    let corner = |t: usize, k: usize| mesh.indices[3 * t + k] as usize;
    let pos = |i: usize| DVec3::from(mesh.vertices[i].position.map(f64::from));
    (0..mesh.triangle_count())
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| pos(corner(t, k)));
            let cross = (b - a).cross(c - a);
            (cross.normalize_or_zero(), 0.5 * cross.length())
        })
        .unzip()
}

/// The triangles across each edge of a mesh, corners welded by exact position.
struct EdgeAdjacency {
    /// (edge key, triangle, corner) sorted: an edge's triangles are one run, in triangle
    /// order.
    edge_triangles: Vec<(u64, u32, u32)>,
    /// `edge_run[3t + k]`: the run (first, count) of triangle t's edge from corner k (one
    /// pass over the runs instead of a binary search per edge visit).
    edge_run: Vec<(u32, u32)>,
}

impl EdgeAdjacency {
    /// Welds `mesh`'s corners by exact position, then maps each undirected edge to its
    /// triangles.
    fn new(mesh: &Mesh) -> EdgeAdjacency {
        let tri_count = mesh.triangle_count();
        let corner = |t: usize, k: usize| mesh.indices[3 * t + k] as usize;
        let mut weld: FxHashMap<[u32; 3], u32> = FxHashMap::default();
        let welded: Vec<u32> = mesh
            .vertices
            .iter()
            .map(|v| {
                let next = weld.len() as u32;
                *weld.entry(v.position.map(f32::to_bits)).or_insert(next)
            })
            .collect();
        let edge_key = |a: u32, b: u32| (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
        let mut edge_triangles: Vec<(u64, u32, u32)> = Vec::with_capacity(3 * tri_count);
        for t in 0..tri_count {
            for k in 0..3 {
                let (a, b) = (welded[corner(t, k)], welded[corner(t, (k + 1) % 3)]);
                if a != b {
                    edge_triangles.push((edge_key(a, b), t as u32, k as u32));
                }
            }
        }
        edge_triangles.sort_unstable();
        let mut edge_run = vec![(0u32, 0u32); 3 * tri_count];
        let mut first = 0;
        for run in edge_triangles.chunk_by(|x, y| x.0 == y.0) {
            for &(_, t, k) in run {
                edge_run[3 * t as usize + k as usize] = (first as u32, run.len() as u32);
            }
            first += run.len();
        }
        EdgeAdjacency {
            edge_triangles,
            edge_run,
        }
    }

    /// The (edge key, triangle, corner) entries sharing triangle `t`'s edge from corner `k`
    /// (`t` among them).
    fn neighbours(&self, t: usize, k: usize) -> &[(u64, u32, u32)] {
        let (first, count) = self.edge_run[3 * t + k];
        &self.edge_triangles[first as usize..(first + count) as usize]
    }
}

/// Charts by flood fill from the largest unassigned triangle (module doc): each
/// triangle's chart id, and each chart's triangles.
fn grow_charts(
    normals: &[DVec3],
    areas: &[f64],
    adjacency: &EdgeAdjacency,
) -> (Vec<u32>, Vec<Vec<usize>>) {
    let tri_count = normals.len();
    let cos_max = CHART_MAX_ANGLE_DEG.to_radians().cos();
    let mut by_area: Vec<usize> = (0..tri_count).collect();
    by_area.sort_by(|&a, &b| areas[b].total_cmp(&areas[a]).then(a.cmp(&b)));
    let mut chart_of = vec![u32::MAX; tri_count];
    let mut charts: Vec<Vec<usize>> = Vec::new();
    for seed in by_area {
        if chart_of[seed] != u32::MAX {
            continue;
        }
        let id = charts.len() as u32;
        let n_seed = normals[seed];
        chart_of[seed] = id;
        let mut members = vec![seed];
        let mut next = 0;
        while next < members.len() {
            let t = members[next];
            next += 1;
            for k in 0..3 {
                for &(_, o, _) in adjacency.neighbours(t, k) {
                    let o = o as usize;
                    if chart_of[o] == u32::MAX && normals[o].dot(n_seed) >= cos_max {
                        chart_of[o] = id;
                        members.push(o);
                    }
                }
            }
        }
        charts.push(members);
    }
    (chart_of, charts)
}

/// The charts projected to their planes ([`project_charts`]).
struct ProjectedCharts {
    /// Each triangle corner's chart-local 2D position (a vertex projects alike in every
    /// triangle of its chart).
    local: Vec<DVec2>,
    /// Per chart its bounding rectangle's size, metres (uniform density).
    sizes: Vec<ChartSize>,
    /// Per chart its bounding rectangle's lower corner in chart-local coordinates.
    mins: Vec<DVec2>,
}

/// Projects each chart onto the plane of its area-weighted mean normal, rotated to the
/// principal axes of its corners; records the 2D corners and bounding rectangles.
fn project_charts(
    mesh: &Mesh,
    charts: &[Vec<usize>],
    normals: &[DVec3],
    areas: &[f64],
) -> ProjectedCharts {
    let corner = |t: usize, k: usize| mesh.indices[3 * t + k] as usize;
    let pos = |i: usize| DVec3::from(mesh.vertices[i].position.map(f64::from));
    let mut local = vec![DVec2::ZERO; 3 * mesh.triangle_count()];
    let mut sizes = Vec::with_capacity(charts.len());
    let mut mins = Vec::with_capacity(charts.len());
    for members in charts {
        let mean = members
            .iter()
            .map(|&t| normals[t] * areas[t])
            .sum::<DVec3>()
            .try_normalize()
            .unwrap_or(normals[members[0]]);
        let axis = if mean == DVec3::ZERO { DVec3::Z } else { mean };
        let (e1, e2) = axis.any_orthonormal_pair();
        let origin = pos(corner(members[0], 0));
        let project = |i: usize| {
            let d = pos(i) - origin;
            DVec2::new(d.dot(e1), d.dot(e2))
        };
        // Principal axes of the projected corners: a tighter rectangle.
        let points: Vec<DVec2> = members
            .iter()
            .flat_map(|&t| (0..3).map(move |k| (t, k)))
            .map(|(t, k)| project(corner(t, k)))
            .collect();
        let centre = points.iter().sum::<DVec2>() / points.len() as f64;
        let (mut cxx, mut cxy, mut cyy) = (0.0, 0.0, 0.0);
        for p in &points {
            let d = *p - centre;
            (cxx, cxy, cyy) = (cxx + d.x * d.x, cxy + d.x * d.y, cyy + d.y * d.y);
        }
        let angle = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
        let rot = DVec2::from_angle(-angle);
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for &t in members {
            for k in 0..3 {
                let p = rot.rotate(project(corner(t, k)));
                (lo, hi) = (lo.min(p), hi.max(p));
                local[3 * t + k] = p;
            }
        }
        sizes.push(ChartSize {
            size: hi - lo,
            density_scale: 1.0,
        });
        mins.push(lo);
    }
    ProjectedCharts { local, sizes, mins }
}

/// `mesh`'s vertices split per chart, each with its lightmap UV in the chart's packed
/// rectangle, and the triangles' indices into them.
fn split_vertices(
    mesh: &Mesh,
    chart_of: &[u32],
    projected: &ProjectedCharts,
    packing: &Packing,
    res: u32,
) -> (Vec<Vertex>, Vec<u32>) {
    let ProjectedCharts { local, sizes, mins } = projected;
    let corner = |t: usize, k: usize| mesh.indices[3 * t + k] as usize;
    let inv_res = 1.0 / f64::from(res);
    // The new index of (old vertex, chart): most vertices lie in one chart, kept per
    // vertex; a vertex's further charts go to a map.
    const NONE: u32 = u32::MAX;
    let mut first_chart = vec![(NONE, NONE); mesh.vertices.len()];
    let mut remap: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    let mut vertices: Vec<Vertex> = Vec::with_capacity(mesh.vertices.len());
    let mut indices = Vec::with_capacity(mesh.indices.len());
    for (t, &id) in chart_of.iter().enumerate() {
        let rect = packing.rects[id as usize];
        let d = packing.density;
        let extent = sizes[id as usize].size * d;
        let offset = (DVec2::new(f64::from(rect.w), f64::from(rect.h)) - extent).max(DVec2::ZERO)
            * 0.5
            + DVec2::new(f64::from(rect.x), f64::from(rect.y));
        for k in 0..3 {
            let old = corner(t, k) as u32;
            let (chart, first_index) = first_chart[old as usize];
            if chart == id {
                indices.push(first_index);
                continue;
            }
            let mut new_vertex = || {
                let p = local[3 * t + k] - mins[id as usize];
                let mut uv = (offset + p * d) * inv_res;
                if !uv.is_finite() {
                    // Only for absurd input (zero density): the chart's rectangle centre.
                    uv = (DVec2::new(f64::from(rect.x), f64::from(rect.y))
                        + 0.5 * DVec2::new(f64::from(rect.w), f64::from(rect.h)))
                        * inv_res;
                }
                let mut v = mesh.vertices[old as usize];
                v.uv_lightmap = [uv.x as f32, uv.y as f32];
                vertices.push(v);
                (vertices.len() - 1) as u32
            };
            let index = if chart == NONE {
                let index = new_vertex();
                first_chart[old as usize] = (id, index);
                index
            } else {
                *remap.entry((old, id)).or_insert_with(new_vertex)
            };
            indices.push(index);
        }
    }
    (vertices, indices)
}

#[cfg(test)]
mod tests {
    use std::collections::HashMap;

    use super::*;
    use glam::Vec3;

    /// Texel centres covered by the UV triangle (inclusive, tiny tolerance), as indices.
    pub(crate) fn covered_texels(uv: [[f32; 2]; 3], res: u32) -> Vec<u32> {
        let p = uv.map(|c| DVec2::new(f64::from(c[0]), f64::from(c[1])) * f64::from(res));
        let lo = p[0].min(p[1]).min(p[2]).floor().max(DVec2::ZERO);
        let hi = p[0]
            .max(p[1])
            .max(p[2])
            .ceil()
            .min(DVec2::splat(f64::from(res)));
        let area = (p[1] - p[0]).perp_dot(p[2] - p[0]);
        let mut out = Vec::new();
        if area.abs() < 1e-12 {
            return out;
        }
        for y in lo.y as u32..hi.y as u32 {
            for x in lo.x as u32..hi.x as u32 {
                let c = DVec2::new(f64::from(x) + 0.5, f64::from(y) + 0.5);
                let w = [0, 1, 2]
                    .map(|k| (p[(k + 2) % 3] - p[(k + 1) % 3]).perp_dot(c - p[(k + 1) % 3]) / area);
                if w.iter().all(|&b| b >= -1e-6) {
                    out.push(y * res + x);
                }
            }
        }
        out
    }

    /// A bumpy grid (height field) plus a cube: several charts, shared vertices.
    fn test_mesh() -> Mesh {
        let mut m = Mesh::default();
        let n = 12;
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
                let y = 0.3 * (6.0 * x).sin() * (5.0 * z).cos();
                m.vertices.push(Vertex {
                    position: [x, y, z],
                    normal: [0.0, 1.0, 0.0],
                    ..Vertex::default()
                });
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
                m.indices.extend([a, c, b, b, c, d]);
            }
        }
        // A unit cube sharing its 8 corners among 12 triangles, offset to x ∈ [2, 3].
        let base = m.vertices.len() as u32;
        for k in 0..8 {
            let p = Vec3::new((k & 1) as f32 + 2.0, ((k >> 1) & 1) as f32, (k >> 2) as f32);
            m.vertices.push(Vertex {
                position: p.to_array(),
                ..Vertex::default()
            });
        }
        let faces = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        for f in faces {
            m.indices.extend(
                [f[0], f[1], f[2], f[0], f[2], f[3]]
                    .iter()
                    .map(|&k| base + k),
            );
        }
        m
    }

    /// Chart id per triangle, recovered from the mesh: triangles are joined when they share
    /// a vertex index (vertices are split per chart, so this never joins two charts).
    fn components(m: &Mesh) -> Vec<usize> {
        let mut parent: Vec<usize> = (0..m.vertices.len()).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for t in m.indices.chunks(3) {
            for k in 1..3 {
                let (a, b) = (
                    find(&mut parent, t[0] as usize),
                    find(&mut parent, t[k] as usize),
                );
                parent[a] = b;
            }
        }
        m.indices
            .chunks(3)
            .map(|t| find(&mut parent, t[0] as usize))
            .collect()
    }

    #[test]
    fn generated_charts_have_disjoint_texels() {
        for res in [64, 256] {
            let mut m = test_mesh();
            let before = m.triangle_count();
            let out = match generate(&mut m, res) {
                Ok(o) => o,
                Err(e) => panic!("res {res}: {e:?}"),
            };
            assert_eq!(m.triangle_count(), before);
            // The cube has 6 faces at 90°: at least 6 charts for it, one or more for the grid.
            assert!(out.charts >= 7, "res {res}: {out:?}");
            for v in &m.vertices {
                assert!(v.uv_lightmap.iter().all(|c| (0.0..=1.0).contains(c)));
            }
            let comp = components(&m);
            let mut owner: HashMap<u32, usize> = HashMap::new();
            let mut covered = 0;
            for (t, tri) in m.indices.chunks(3).enumerate() {
                let uv = [0, 1, 2].map(|k| m.vertices[tri[k] as usize].uv_lightmap);
                for texel in covered_texels(uv, res) {
                    covered += 1;
                    let o = *owner.entry(texel).or_insert(comp[t]);
                    assert_eq!(o, comp[t], "res {res}: texel {texel} shared by two charts");
                }
            }
            assert!(covered > 0);
        }
    }

    #[test]
    fn packer_keeps_gutters_and_grows_with_resolution() {
        let charts: Vec<ChartSize> = (1..30)
            .map(|i| ChartSize {
                size: DVec2::new(0.1 * i as f64, 0.05 * (30 - i) as f64),
                density_scale: if i % 3 == 0 { 0.5 } else { 1.0 },
            })
            .collect();
        let small = pack_charts(&charts, 64).map(|p| p.density);
        let large = pack_charts(&charts, 512).map(|p| p.density);
        assert!(large > small, "{large:?} vs {small:?}");
        let Some(p) = pack_charts(&charts, 512) else {
            panic!("does not fit");
        };
        let g = GUTTER_TEXELS;
        for (i, r) in p.rects.iter().enumerate() {
            assert!(r.x >= g && r.y >= g && r.x + r.w + g <= 512 && r.y + r.h + g <= 512);
            for o in &p.rects[i + 1..] {
                let apart = r.x + r.w + g <= o.x
                    || o.x + o.w + g <= r.x
                    || r.y + r.h + g <= o.y
                    || o.y + o.h + g <= r.y;
                assert!(apart, "{r:?} {o:?}");
            }
        }
    }

    #[test]
    fn too_many_charts_and_zero_area_are_handled() {
        let many = vec![
            ChartSize {
                size: DVec2::ONE,
                density_scale: 1.0
            };
            1000
        ];
        assert!(pack_charts(&many, 16).is_none());
        let lines = vec![
            ChartSize {
                size: DVec2::new(1.0, 0.0),
                density_scale: 1.0
            };
            3
        ];
        assert!(pack_charts(&lines, 64).is_some_and(|p| p.density > 0.0));
        let points = vec![
            ChartSize {
                size: DVec2::ZERO,
                density_scale: 1.0
            };
            3
        ];
        assert!(pack_charts(&points, 64).is_some());
    }
}
