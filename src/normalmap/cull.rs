//! Culling of the high mesh per low triangle (the paper's §4 "octree-based acceleration
//! structure", here a uniform grid): only high triangles that can project into T's texels
//! are drawn in T's render.
//!
//! A high triangle can contribute to T only if part of it lies in T's prism — the points
//! whose orthogonal projection onto T's plane Π falls in T and whose distance to Π is at
//! most D (`max_distance`). The grid returns the triangles whose bounding boxes overlap the
//! prism's bounding box; two exact separating-axis tests then drop those entirely beyond
//! ±D of Π and those whose projection onto Π is separated from T by one of T's edges. What
//! remains is a superset of what the render needs, so culling never changes a texel.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use crate::scene::Mesh;

/// Target mean number of triangles per grid cell.
const TRIANGLES_PER_CELL: f32 = 4.0;
/// Most cells per axis.
const MAX_CELLS_PER_AXIS: usize = 256;

/// A uniform grid over the high mesh's triangles, each listed in every cell its bounding
/// box overlaps.
pub struct TriangleGrid {
    lo: Vec3A,
    cell: Vec3A,
    dims: [usize; 3],
    /// Cell c's triangles are `ids[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    ids: Vec<u32>,
    corners: Vec<[Vec3A; 3]>,
}

impl TriangleGrid {
    pub fn new(mesh: &Mesh) -> TriangleGrid {
        let corners: Vec<[Vec3A; 3]> = (0..mesh.triangle_count())
            .map(|t| mesh.triangle_positions(t).map(Vec3A::from))
            .collect();
        let (lo, hi) = mesh.bounds();
        let (lo, hi) = (Vec3A::from(lo), Vec3A::from(hi));
        let extent = (hi - lo).max(Vec3A::splat(1e-6 * (hi - lo).max_element().max(1e-30)));
        // Cells roughly cubic, about TRIANGLES_PER_CELL triangles each.
        let cells = (corners.len() as f32 / TRIANGLES_PER_CELL).max(1.0);
        let side = (extent.x * extent.y * extent.z / cells).cbrt();
        let dims = [extent.x, extent.y, extent.z]
            .map(|e| ((e / side).ceil() as usize).clamp(1, MAX_CELLS_PER_AXIS));
        let cell = extent / Vec3A::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
        let mut grid = TriangleGrid {
            lo,
            cell,
            dims,
            starts: Vec::new(),
            ids: Vec::new(),
            corners,
        };
        // Counting sort into cells.
        let cell_count = dims[0] * dims[1] * dims[2];
        let mut counts = vec![0u32; cell_count + 1];
        for c in &grid.corners {
            grid.for_cells(tri_lo(c), tri_hi(c), |i| counts[i + 1] += 1);
        }
        for i in 0..cell_count {
            counts[i + 1] += counts[i];
        }
        let mut fill = counts.clone();
        let mut ids = vec![0u32; counts[cell_count] as usize];
        for (t, c) in grid.corners.iter().enumerate() {
            grid.for_cells(tri_lo(c), tri_hi(c), |i| {
                ids[fill[i] as usize] = t as u32;
                fill[i] += 1;
            });
        }
        grid.starts = counts;
        grid.ids = ids;
        grid
    }

    fn cell_range(&self, lo: Vec3A, hi: Vec3A) -> [std::ops::RangeInclusive<usize>; 3] {
        let to_cell = |p: Vec3A, axis: usize| {
            let f = ((p[axis] - self.lo[axis]) / self.cell[axis]).floor();
            (f.max(0.0) as usize).min(self.dims[axis] - 1)
        };
        [0, 1, 2].map(|a| to_cell(lo, a)..=to_cell(hi, a))
    }

    fn for_cells(&self, lo: Vec3A, hi: Vec3A, mut f: impl FnMut(usize)) {
        let [xs, ys, zs] = self.cell_range(lo, hi);
        for z in zs {
            for y in ys.clone() {
                for x in xs.clone() {
                    f((z * self.dims[1] + y) * self.dims[0] + x);
                }
            }
        }
    }

    /// High triangles that may lie in the prism of low triangle `v` with unit normal `n`
    /// and half-depth `max_distance` (module doc), ascending. `seen` is scratch of one
    /// entry per high triangle, all `false` on entry and on return.
    pub fn prism_candidates(
        &self,
        v: [Vec3; 3],
        n: Vec3,
        max_distance: f32,
        seen: &mut [bool],
    ) -> Vec<u32> {
        let v = v.map(Vec3A::from);
        let n = Vec3A::from(n);
        let offset = n.abs() * max_distance;
        let lo = v[0].min(v[1]).min(v[2]) - offset;
        let hi = v[0].max(v[1]).max(v[2]) + offset;
        // In-plane outward edge normals of T.
        let edges = [0, 1, 2].map(|k| {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            let outward = (b - a).cross(n);
            (outward, outward.dot(a))
        });
        let plane = n.dot(v[0]);
        let (mut out, mut touched) = (Vec::new(), Vec::new());
        let [xs, ys, zs] = self.cell_range(lo, hi);
        for z in zs {
            for y in ys.clone() {
                for x in xs.clone() {
                    let c = (z * self.dims[1] + y) * self.dims[0] + x;
                    let ids = &self.ids[self.starts[c] as usize..self.starts[c + 1] as usize];
                    for &t in ids {
                        if std::mem::replace(&mut seen[t as usize], true) {
                            continue;
                        }
                        touched.push(t);
                        let p = &self.corners[t as usize];
                        if !(tri_lo(p).cmple(hi).all() && tri_hi(p).cmpge(lo).all()) {
                            continue;
                        }
                        let k = p.map(|q| n.dot(q) - plane);
                        let beyond = |side: f32| k.iter().all(|&k| side * k > max_distance);
                        if beyond(1.0) || beyond(-1.0) {
                            continue;
                        }
                        let outside_edge =
                            edges.iter().any(|&(e, d)| p.iter().all(|&q| e.dot(q) > d));
                        if !outside_edge {
                            out.push(t);
                        }
                    }
                }
            }
        }
        for t in touched {
            seen[t as usize] = false;
        }
        out.sort_unstable();
        out
    }

    /// [`Self::prism_candidates`] of every low triangle (`None`: a degenerate one, drawn
    /// with nothing), in parallel.
    pub fn candidates_per_triangle(
        &self,
        low: &[Option<([Vec3; 3], Vec3)>],
        max_distance: f32,
    ) -> Vec<Vec<u32>> {
        low.par_iter()
            .map_init(
                || vec![false; self.corners.len()],
                |seen, tri| match tri {
                    Some((v, n)) => self.prism_candidates(*v, *n, max_distance, seen),
                    None => Vec::new(),
                },
            )
            .collect()
    }
}

fn tri_lo(c: &[Vec3A; 3]) -> Vec3A {
    c[0].min(c[1]).min(c[2])
}

fn tri_hi(c: &[Vec3A; 3]) -> Vec3A {
    c[0].max(c[1]).max(c[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    /// A grid of small triangles over the unit square at z = height(x, y).
    fn sheet(n: usize) -> Mesh {
        let mut mesh = Mesh::default();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                mesh.vertices.push(Vertex {
                    position: [x, y, 0.1 * (7.0 * x).sin() * (5.0 * y).cos()],
                    ..Vertex::default()
                });
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = (j * (n + 1) + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
                mesh.indices.extend([a, b, d, a, d, c]);
            }
        }
        mesh
    }

    #[test]
    fn candidates_are_a_superset_of_the_triangles_in_the_prism() {
        let mesh = sheet(40);
        let grid = TriangleGrid::new(&mesh);
        let low = [
            Vec3::new(0.2, 0.2, 0.05),
            Vec3::new(0.6, 0.3, 0.0),
            Vec3::new(0.3, 0.7, -0.02),
        ];
        let n = super::super::projection::face_normal(low).unwrap();
        let d = 0.15;
        let mut seen = vec![false; mesh.triangle_count()];
        let got = grid.prism_candidates(low, n, d, &mut seen);
        assert!(seen.iter().all(|s| !s), "scratch is reset");
        assert!(
            !got.is_empty() && got.len() < mesh.triangle_count() / 2,
            "{}",
            got.len()
        );
        // Brute force: every triangle with a corner or centroid inside the prism is kept.
        let inside = |q: Vec3| {
            let k = n.dot(q - low[0]);
            let p = q - n * k;
            let inside_t = (0..3).all(|e| {
                let (a, b) = (low[e], low[(e + 1) % 3]);
                (b - a).cross(n).dot(p - a) <= 0.0
            });
            k.abs() <= d && inside_t
        };
        for t in 0..mesh.triangle_count() {
            let p = mesh.triangle_positions(t);
            let probes = [p[0], p[1], p[2], (p[0] + p[1] + p[2]) / 3.0];
            if probes.iter().any(|&q| inside(q)) {
                assert!(
                    got.binary_search(&(t as u32)).is_ok(),
                    "triangle {t} culled"
                );
            }
        }
    }
}
