//! Criterion benches of the visibility bake: traced rays per second of the
//! full bake (raster done, trace + project + dilate timed) on the built-in house and on
//! a generated 204,800-triangle displaced grid, the same rays traced one by one with
//! `Tracer::occluded` for comparison, and the SH projection of one texel's visible set
//! (1024 directions → order 6, 36 coefficients). Seeded, deterministic inputs.
//!
//! `cargo bench --bench bake`; the thread count is rayon's default (all cores).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use shvis::bake::directions::{DirectionSet, ShProjector, above_horizon};
use shvis::bake::raster::{LightmapTexels, rasterize};
use shvis::bake::trace::Tracer;
use shvis::bake::visibility::{VisibilitySettings, bake_visibility};
use shvis::scene::{Mesh, house};
use shvis::sh::Order;

#[path = "bake_scenes.rs"]
mod bake_scenes;

/// Cells per side of the generated grid: 2·320² = 204,800 triangles.
const GRID_CELLS: u32 = 320;

fn settings(rays: u32) -> VisibilitySettings {
    VisibilitySettings {
        order: Order::SIX,
        rays,
        seed: 1,
        progress: false,
    }
}

/// Rays traced by the single-ray path over all covered texels (returns the count).
fn single_ray_pass(tracer: &Tracer, texels: &LightmapTexels, dirs: &DirectionSet) -> u64 {
    (0..texels.covered.len())
        .into_par_iter()
        .filter(|&i| texels.covered[i])
        .map(|i| {
            let n = texels.normal[i];
            let o = tracer.offset_origin(texels.position[i], n);
            let mut traced = 0u64;
            let mut escaped = 0u32;
            for &d in dirs.dirs() {
                if above_horizon(n, d) {
                    traced += 1;
                    escaped += u32::from(!tracer.occluded(o, d, f32::INFINITY));
                }
            }
            black_box(escaped);
            traced
        })
        .sum()
}

fn bench_scene(c: &mut Criterion, name: &str, mesh: &Mesh, res: u32, rays: u32) {
    let texels = rasterize(mesh, res);
    let tracer = Tracer::new(mesh);
    let s = settings(rays);
    let traced = bake_visibility(&tracer, &texels, &s).stats.rays_traced;
    let mut g = c.benchmark_group(format!("visibility_bake/{name}"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(traced));
    g.bench_function(format!("{res}x{res}_{rays}rays_coherent"), |b| {
        b.iter(|| black_box(bake_visibility(&tracer, &texels, &s)))
    });
    let dirs = DirectionSet::new(rays, s.seed);
    g.bench_function(
        format!("{res}x{res}_{rays}rays_single_ray_trace_only"),
        |b| b.iter(|| black_box(single_ray_pass(&tracer, &texels, &dirs))),
    );
    g.finish();
}

fn visibility_bake(c: &mut Criterion) {
    let house = house::build(128).expect("the built-in house builds");
    bench_scene(c, "house", &house.mesh, 128, 256);
    let grid = bake_scenes::displaced_grid(GRID_CELLS);
    bench_scene(c, "grid204800", &grid, 128, 256);
}

fn sh_projection(c: &mut Criterion) {
    let dirs = DirectionSet::new(1024, 1);
    let projector = ShProjector::new(&dirs, Order::SIX);
    // 256 visible sets: the upper hemisphere of a spread of normals, minus a cone.
    let masks: Vec<Vec<u64>> = (0..256)
        .map(|k| {
            let t = k as f32 * 2.399_963;
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / 256.0;
            let r = (1.0 - z * z).sqrt();
            let n = Vec3::new(r * t.cos(), r * t.sin(), z);
            let blocker = Vec3::new(n.z, n.x, n.y).normalize();
            let mut m = vec![0u64; dirs.mask_words()];
            for (i, &d) in dirs.dirs().iter().enumerate() {
                if above_horizon(n, d) && d.dot(blocker) < 0.6 {
                    m[i / 64] |= 1 << (i % 64);
                }
            }
            m
        })
        .collect();
    let mut out = [0.0f64; 36];
    let mut g = c.benchmark_group("sh_projection");
    g.throughput(Throughput::Elements(masks.len() as u64));
    for bits in [8, 4] {
        let p = ShProjector::with_chunk_bits(&dirs, Order::SIX, bits);
        g.bench_function(format!("order6_1024rays_per_texel_chunk{bits}"), |b| {
            b.iter(|| {
                for m in &masks {
                    out.fill(0.0);
                    p.project(black_box(m), &mut out);
                    black_box(&out);
                }
            })
        });
    }
    black_box(projector.chunk_bits());
    g.finish();
}

criterion_group!(benches, sh_projection, visibility_bake);
criterion_main!(benches);
