//! Generated scenes for the bake's benches (included by `bench/bake.rs` with `#[path]`): a
//! displaced grid of ≥ 200k triangles whose lightmap UVs are its grid coordinates, so the
//! real raster → trace → project path runs on it.

use glam::Vec3;
use shvis::scene::{Mesh, Vertex};

/// Half the side of the grid, metres.
pub const GRID_HALF: f32 = 10.0;

/// Height of the terrain at (x, z): rolling hills with steep ridges and pits, so that
/// texels see a good deal of occlusion (valleys, overhang-free).
pub fn terrain_height(x: f32, z: f32) -> f32 {
    1.2 * (0.9 * x).sin() * (0.7 * z).cos()
        + 0.5 * (2.3 * x + 1.1 * z).sin()
        + 0.25 * (5.3 * x).cos() * (4.1 * z).sin()
}

/// A `cells`² grid over [−GRID_HALF, GRID_HALF]² displaced by [`terrain_height`]:
/// 2·cells² triangles, counter-clockwise from above, normals by central differences,
/// lightmap UV = grid coordinates (unique, covering [0, 1]²).
pub fn displaced_grid(cells: u32) -> Mesh {
    let n = cells + 1;
    let step = 2.0 * GRID_HALF / cells as f32;
    let mut mesh = Mesh::default();
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (-GRID_HALF + i as f32 * step, -GRID_HALF + j as f32 * step);
            let h = 0.5 * step;
            let dx = (terrain_height(x + h, z) - terrain_height(x - h, z)) / (2.0 * h);
            let dz = (terrain_height(x, z + h) - terrain_height(x, z - h)) / (2.0 * h);
            mesh.vertices.push(Vertex {
                position: [x, terrain_height(x, z), z],
                normal: Vec3::new(-dx, 1.0, -dz).normalize().to_array(),
                uv_lightmap: [i as f32 / cells as f32, j as f32 / cells as f32],
                ..Vertex::default()
            });
        }
    }
    for j in 0..cells {
        for i in 0..cells {
            let a = j * n + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n);
            // Counter-clockwise seen from +Y: a → d → c, a → c → b.
            mesh.indices.extend([a, d, c, a, c, b]);
        }
    }
    mesh
}
