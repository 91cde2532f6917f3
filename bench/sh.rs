//! Criterion benches of the SH core: basis evaluation at order 6 in f32 (per
//! direction), projection of a 512×256 environment to order 8, and the §3.3 product
//! matrix for H order 3 × V order 6 (lighting at order 8 = O+2). Inputs are seeded.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec3, Vec3};
use shvis::env::project::project_sh;
use shvis::env::sky::{SkyParams, sky};
use shvis::sh::Order;
use shvis::sh::basis::eval_basis_f32;
use shvis::sh::product::gaunt_tensor;

/// Deterministic unit directions (golden-spiral points).
fn directions(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
            DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3()
        })
        .collect()
}

fn sh_eval(c: &mut Criterion) {
    let dirs = directions(1024);
    let mut out = [0.0f32; 36];
    let mut g = c.benchmark_group("sh_eval");
    g.throughput(Throughput::Elements(dirs.len() as u64));
    g.bench_function("order6_f32_x1024", |b| {
        b.iter(|| {
            for &d in &dirs {
                eval_basis_f32(Order::SIX, black_box(d), &mut out);
                black_box(&out);
            }
        })
    });
    g.finish();
}

fn env_projection(c: &mut Criterion) {
    let env = sky(512, &SkyParams::default());
    let order = Order::new(8).expect("valid order");
    let mut g = c.benchmark_group("env_projection");
    g.sample_size(10);
    g.bench_function("512x256_order8", |b| {
        b.iter(|| black_box(project_sh(black_box(&env), order)))
    });
    g.finish();
}

fn product_matrix(c: &mut Criterion) {
    let (l_order, v_order, h_order) = (Order::new(8).expect("valid"), Order::SIX, Order::THREE);
    let tensor = gaunt_tensor(l_order, v_order, h_order);
    let env = sky(128, &SkyParams::default());
    let lighting: Vec<f64> = project_sh(&env, l_order).iter().map(|c| c[1]).collect();
    c.bench_function("product_matrix_h3_v6_l8", |b| {
        b.iter(|| black_box(tensor.product_matrix(black_box(&lighting))))
    });
}

/// L×H table build (§3.3): order-6 visibility, H order 3, 32² per hemisphere (dual
/// paraboloid) and 6 × 32² (cube), one core. `direct`: every normal on its own (the
/// baseline); `symmetric`: the mirror-orbit build with its orbits found once, into
/// a new table; `symmetric_in_place`: the same into an existing table (the per-frame path);
/// `rebuild`: product matrices for new lighting plus the in-place build.
fn lxh_table(c: &mut Criterion) {
    use shvis::bake::lxh::{LxhMatrices, SymmetricBuild, build_table_direct};
    use shvis::sphere::{Parameterization, SphereMap};
    let env = sky(128, &SkyParams::default());
    let radiance = project_sh(&env, Order::new(8).expect("valid"));
    let mut g = c.benchmark_group("lxh_table");
    let m = LxhMatrices::new(&radiance, Order::SIX, Order::THREE);
    for kind in [Parameterization::DualParaboloid, Parameterization::CubeDx10] {
        let map = SphereMap::new(kind, 32).expect("valid");
        g.bench_function(format!("direct_order6_h3_{kind}_32"), |b| {
            b.iter(|| black_box(build_table_direct(black_box(&m), map)))
        });
        let build = SymmetricBuild::new(map);
        g.bench_function(format!("symmetric_order6_h3_{kind}_32"), |b| {
            b.iter(|| black_box(build.build(black_box(&m))))
        });
        let mut table = build.build(&m);
        g.bench_function(format!("symmetric_in_place_order6_h3_{kind}_32"), |b| {
            b.iter(|| build.rebuild(black_box(&m), &mut table))
        });
        g.bench_function(format!("rebuild_order6_h3_{kind}_32"), |b| {
            b.iter(|| {
                let m = LxhMatrices::new(black_box(&radiance), Order::SIX, Order::THREE);
                build.rebuild(&m, &mut table)
            })
        });
    }
    // The alternative of §3.3: blend two built tables (they are linear in L) instead of
    // rebuilding from blended lighting.
    let map = SphereMap::new(Parameterization::DualParaboloid, 32).expect("valid");
    let a = SymmetricBuild::new(map).build(&m);
    let b = SymmetricBuild::new(map).build(&LxhMatrices::new(
        &radiance
            .iter()
            .map(|c| [c[2], c[1], c[0]])
            .collect::<Vec<_>>(),
        Order::SIX,
        Order::THREE,
    ));
    g.bench_function("blend_tables_order6_dual-paraboloid_32", |bch| {
        bch.iter(|| {
            let t = black_box(0.3f32);
            let blended: Vec<[f32; 3]> = a
                .values
                .iter()
                .zip(&b.values)
                .map(|(x, y)| std::array::from_fn(|c| (1.0 - t) * x[c] + t * y[c]))
                .collect();
            black_box(blended)
        })
    });
    g.finish();
}

/// One lighting update of a technique on the CPU: `LightingRecipe::build` —
/// product matrices, the symmetric table build, the technique's own tables (T_k for pca),
/// layout per path and f16 range scaling — for the paper's 32² tables. What `shvis
/// relight` reports as "CPU build ms", here without the GPU competing for the cores.
fn lighting_update(c: &mut Criterion) {
    use shvis::bake::ao::AoMap;
    use shvis::bake::pca::PcaModel;
    use shvis::bake::visibility::VisibilityMap;
    use shvis::sh::zonal::irradiance_from_radiance;
    use shvis::technique::{HwPath, Inputs, LightingRecipe, Technique};
    let env = sky(128, &SkyParams::default());
    let radiance = project_sh(&env, Order::new(8).expect("valid"));
    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
    // Bake data of 2 × 2 texels: the recipes only keep its order and (pca) basis.
    let (res, n) = (2u32, 36usize);
    let visibility = VisibilityMap {
        res,
        order: Order::SIX,
        coeffs: (0..4 * n).map(|i| (i as f32 * 0.37).sin()).collect(),
        covered: vec![true; 4],
        ao: vec![0.5; 4],
        stats: Default::default(),
    };
    let ao = AoMap {
        res,
        values: vec![0.5; 4],
        covered: vec![true; 4],
        stats: Default::default(),
    };
    let pca = PcaModel {
        order: Order::SIX,
        mean: (0..n).map(|j| 0.1 / (1.0 + j as f64)).collect(),
        basis: (0..24)
            .map(|k| (0..n).map(|j| if j == k { 1.0 } else { 0.0 }).collect())
            .collect(),
        eigenvalues: vec![1.0; n],
        weights: (0..4 * 24).map(|i| (i as f32 * 0.11).cos()).collect(),
        res,
    };
    let inputs = Inputs {
        ao: &ao,
        irradiance_sh: &irradiance,
        radiance_sh: &radiance,
        visibility: Some(&visibility),
        pca: Some(&pca),
        clusters: &[],
        vertex_pca: &[],
        sh_lightmap: None,
        ssbump: None,
        ndf_moments: None,
        transfer: None,
        table_res: 32,
        h_order: Order::THREE,
        options: Default::default(),
        cache_dir: None,
    };
    let mut g = c.benchmark_group("lighting_update");
    for name in ["unc6", "pca16", "pca16w", "sh2"] {
        let technique: Technique = name.parse().expect("technique");
        for &path in HwPath::ALL {
            let recipe = LightingRecipe::new(technique, path, &inputs).expect("recipe");
            g.bench_function(format!("{name}_{path}_32"), |b| {
                b.iter(|| black_box(recipe.build(black_box(&radiance), &irradiance)))
            });
        }
    }
    g.finish();
}

/// One lighting update of the `nmprt*` techniques: per covered texel l' = M·l
/// from order-8 transfer matrices, the variant's projection, gutter dilation and f16
/// packing — on a synthetic 256² lightmap (all texels covered, tangent frames turning with
/// the texel), a quarter of the bench's 512² house (152 372 covered texels).
fn nmprt_lighting_update(c: &mut Criterion) {
    use glam::Vec3;
    use shvis::bake::transfer::{TRANSFER_ROWS, TransferMap};
    use shvis::sh::zonal::irradiance_from_radiance;
    use shvis::technique::nmprt::NmprtRecipe;
    use shvis::technique::{NmprtVariant, Technique};
    use std::sync::Arc;
    let env = sky(128, &SkyParams::default());
    let order = Order::new(8).expect("valid");
    let radiance = project_sh(&env, order);
    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
    let res = 256u32;
    let texels = (res * res) as usize;
    let size = 3 * TRANSFER_ROWS * order.coeff_count();
    let transfer = Arc::new(TransferMap {
        res,
        lighting_order: order,
        bounces: 2,
        matrices: (0..texels * size)
            .map(|i| ((i % 977) as f32 * 0.013).sin() * 0.1)
            .collect(),
        covered: vec![true; texels],
        frames: (0..texels)
            .map(|t| {
                let a = t as f32 * 0.001;
                let n = Vec3::new(a.sin() * 0.3, 0.2, 1.0).normalize();
                let t = n.any_orthonormal_vector();
                [t, n.cross(t), n]
            })
            .collect(),
        stats: Default::default(),
    });
    let mut g = c.benchmark_group("lighting_update");
    g.sample_size(10);
    for variant in [
        NmprtVariant::Full,
        NmprtVariant::Svd { m: 6 },
        NmprtVariant::Hl2,
        NmprtVariant::Ratio,
    ] {
        let name = Technique::Nmprt(shvis::technique::Nmprt { variant }).name();
        let recipe = NmprtRecipe::new(variant, transfer.clone());
        g.bench_function(format!("{name}_256"), |b| {
            b.iter(|| black_box(recipe.lighting(black_box(&radiance), &irradiance, "bench")))
        });
    }
    g.finish();
}

criterion_group!(
    benches,
    sh_eval,
    env_projection,
    product_matrix,
    lxh_table,
    lighting_update,
    nmprt_lighting_update
);
criterion_main!(benches);
