//! The transfer-matrix bake (`bake::transfer`). With the lighting fixed,
//! M·l must equal the SH lightmap's per-texel coefficients for the same bake (same rays,
//! seed, bounces, lighting truncated to M's order) — with and without inter-reflection —
//! and the bounces must change M.

use shvis::bake::raster::rasterize;
use shvis::bake::shlmap::{BakeLighting, ShLightmapSettings, bake_sh_lightmap};
use shvis::bake::trace::Tracer;
use shvis::bake::transfer::{TransferMap, TransferSettings, bake_transfer};
use shvis::env::project::project_sh;
use shvis::env::sky::{SkyParams, sky};
use shvis::sh::Order;

/// The house at 64² texels: its scene, lightmap texels and tracer.
struct House {
    scene: shvis::scene::Scene,
    texels: shvis::bake::raster::LightmapTexels,
    tracer: Tracer,
}

impl House {
    fn new() -> House {
        let scene = shvis::scene::house::build(64).expect("the house builds");
        let texels = rasterize(&scene.mesh, 64);
        let tracer = Tracer::new(&scene.mesh);
        House {
            scene,
            texels,
            tracer,
        }
    }

    /// The transfer bake with the tests' 64 rays and seed 3.
    fn transfer(&self, order: Order, bounces: u32) -> TransferMap {
        let settings = TransferSettings {
            lighting_order: order,
            rays: 64,
            seed: 3,
            bounces,
            progress: false,
        };
        bake_transfer(&self.scene, &self.tracer, &self.texels, &settings)
    }
}

#[test]
fn transfer_times_lighting_equals_the_sh_lightmap() {
    let house = House::new();
    let (scene, texels, tracer) = (&house.scene, &house.texels, &house.tracer);
    let order = Order::new(4).unwrap();
    // The built-in sky's gradient and ground without the sun: directional, yet its order-3
    // irradiance stays positive, so the SH lightmap's clamp of negative bounce irradiance
    // (the one non-linear step, module doc of bake::transfer) never acts.
    let smooth = SkyParams {
        sun_radiance: 0.0,
        ..SkyParams::default()
    };
    let l = project_sh(&sky(256, &smooth), order);
    let mut bounced_differs = false;
    let mut direct_rows = Vec::new();
    for bounces in [0, 2] {
        let shl = bake_sh_lightmap(
            scene,
            tracer,
            texels,
            &BakeLighting::Sh(&l),
            &ShLightmapSettings {
                rays: 64,
                seed: 3,
                bounces,
                progress: false,
            },
            &[],
        );
        let transfer = house.transfer(order, bounces);
        let (mut worst, mut scale, mut texels_compared) = (0.0f64, 0.0f64, 0usize);
        for i in (0..texels.covered.len()).filter(|&i| texels.covered[i]) {
            let got = transfer.transferred(i, &l);
            let want = shl.texel(i);
            for (g, w) in got.iter().zip(want) {
                for c in 0..3 {
                    worst = worst.max((g[c] - f64::from(w[c])).abs());
                    scale = scale.max(f64::from(w[c]).abs());
                }
            }
            if bounces == 0 {
                direct_rows.push(got);
            } else if (got[0][0] - direct_rows[texels_compared][0][0]).abs() > 1e-3 * scale {
                bounced_differs = true;
            }
            texels_compared += 1;
        }
        println!(
            "{bounces} bounces: {texels_compared} texels, max |M·l − shlmap| = {worst:.3e} of max |coefficient| {scale:.3}"
        );
        assert!(texels_compared > 500);
        assert!(
            worst <= 2e-5 * scale,
            "{bounces} bounces: M·l differs from the SH lightmap by {worst:e} (scale {scale})"
        );
    }
    assert!(bounced_differs, "inter-reflection did not change M");
}

/// The compression tests' bake: order-3 lighting, 1 bounce; the built-in sky to order 3;
/// the covered texels.
fn order3_transfer() -> (TransferMap, Vec<[f64; 3]>, Vec<usize>) {
    let house = House::new();
    let order = Order::new(3).unwrap();
    let transfer = house.transfer(order, 1);
    let l = project_sh(&sky(128, &SkyParams::default()), order);
    let covered = (0..house.texels.covered.len())
        .filter(|&i| house.texels.covered[i])
        .collect();
    (transfer, l, covered)
}

/// PCA of the matrices: every vector kept rebuilds M·l; fewer keep less, monotonically, and
/// the error of K vectors is what the left-out variance allows.
#[test]
fn compressed_transfer_converges_to_the_full_matrices() {
    let (transfer, l, covered) = order3_transfer();
    let scale = covered
        .iter()
        .flat_map(|&i| transfer.transferred(i, &l))
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let mut last_error = f64::INFINITY;
    let mut last_energy = 0.0;
    for k in [1, 4, 16, 64, 3 * 9 * 9] {
        let compressed = transfer.compress(k).unwrap();
        let error = covered
            .iter()
            .map(|&i| {
                let (a, b) = (transfer.transferred(i, &l), compressed.transferred(i, &l));
                a.iter()
                    .zip(&b)
                    .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
                    .fold(0.0f64, f64::max)
            })
            .fold(0.0f64, f64::max);
        println!(
            "K = {k}: energy {:.5}, max |M·l − M_K·l| = {:.3e} of {scale:.3}",
            compressed.energy, error
        );
        assert!(compressed.energy >= last_energy - 1e-12);
        assert!(
            error <= last_error * 1.0001 + 1e-6 * scale,
            "K = {k}: {error} after {last_error}"
        );
        (last_error, last_energy) = (error, compressed.energy);
    }
    assert!(last_error < 1e-4 * scale, "all vectors: {last_error}");
    assert!(transfer.compress(0).is_err() && transfer.compress(3 * 9 * 9 + 1).is_err());
}

/// CPCA of the matrices (the visibility's cluster fit on the 3·9·N-vectors): one cluster is
/// the PCA; more clusters of the same M reconstruct M·l better (iterative CPCA never raises
/// the squared error it minimizes; checked on the RMS over texels).
#[test]
fn clustered_transfer_is_pca_with_one_cluster_and_improves_with_more() {
    use shvis::bake::cluster::Clustering;
    let (transfer, l, covered) = order3_transfer();
    let rms = |f: &dyn Fn(usize) -> [[f64; 3]; 9]| {
        let sum: f64 = covered
            .iter()
            .map(|&i| {
                let (a, b) = (transfer.transferred(i, &l), f(i));
                a.iter()
                    .zip(&b)
                    .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).powi(2)))
                    .sum::<f64>()
            })
            .sum();
        (sum / covered.len() as f64).sqrt()
    };
    let m = 4;
    let pca = transfer.compress(m).unwrap();
    let pca_error = rms(&|i| pca.transferred(i, &l));
    let one = transfer
        .compress_clustered(1, m, Clustering::Iterative, 3)
        .unwrap();
    let one_error = rms(&|i| one.transferred(i, &l));
    println!("M = {m}: PCA RMS {pca_error:.4e}, CPCA 1 cluster {one_error:.4e}");
    assert!(
        (one_error - pca_error).abs() <= 1e-3 * pca_error,
        "{one_error} against {pca_error}"
    );
    let mut last = one_error;
    for k in [4, 16] {
        let cpca = transfer
            .compress_clustered(k, m, Clustering::Iterative, 3)
            .unwrap();
        let error = rms(&|i| cpca.transferred(i, &l));
        println!("CPCA {k} × {m}: RMS {error:.4e}");
        assert!(error < last, "{k} clusters: {error} after {last}");
        last = error;
    }
    assert!(
        transfer
            .compress_clustered(0, m, Clustering::Iterative, 3)
            .is_err()
    );
}
