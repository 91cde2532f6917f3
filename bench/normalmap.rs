//! Criterion benches of normal-map generation: the per-low-triangle culling
//! (grid build + prism queries) and the CPU ray-cast baker, on a 81,920-triangle sphere
//! for a 320-triangle low sphere at 512², and the GPU bake on the first Vulkan device
//! (lavapipe in CI) when one is present. `shvis study normalmap` has the full tables.
//!
//! `cargo bench --bench normalmap`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shvis::gpu::{Context, ContextDesc};
use shvis::normalmap::cpu::{self, RayDirection};
use shvis::normalmap::cull::TriangleGrid;
use shvis::normalmap::projection::face_normal;
use shvis::normalmap::simplify::{sphere_high, sphere_low};
use shvis::normalmap::{NormalMapSettings, gpu};

fn normalmap(c: &mut Criterion) {
    let high = sphere_high(6, 1.0);
    let low = sphere_low(2, 1.0, 512).unwrap();
    let settings = NormalMapSettings::new(&low, 512);
    let prisms: Vec<_> = (0..low.triangle_count())
        .map(|t| {
            let v = low.triangle_positions(t);
            face_normal(v).map(|n| (v, n))
        })
        .collect();
    let mut group = c.benchmark_group("normalmap");
    group.sample_size(10);
    group.bench_function("cull_81920_for_320", |b| {
        b.iter(|| {
            let grid = TriangleGrid::new(&high);
            black_box(grid.candidates_per_triangle(&prisms, settings.max_distance))
        })
    });
    group.bench_function("cpu_bake_81920_for_320_at_512", |b| {
        b.iter(|| black_box(cpu::bake(&high, &low, &settings, RayDirection::Interpolated).unwrap()))
    });
    match Context::new(&ContextDesc::default()) {
        Ok(ctx) => {
            group.bench_function("gpu_bake_81920_for_320_at_512", |b| {
                b.iter(|| black_box(gpu::bake(&ctx, &high, &low, &settings).unwrap()))
            });
        }
        Err(e) => eprintln!("no Vulkan device, GPU bake not benched: {e}"),
    }
    group.finish();
}

criterion_group!(benches, normalmap);
criterion_main!(benches);
