//! Ambient-occlusion bake against cases with known answers (DESIGN §6): an open plane
//! (AO = 1), the inner corner of a floor and a wall (AO = ½, the wall hides exactly half of
//! the cosine-weighted hemisphere), the floor of a closed box (AO = 0), thread-count
//! independence on the house, and the house's overhang darker than open ground.

use glam::Vec3;
use shvis::bake::ao::{AoSettings, ao_at, bake_ao};
use shvis::bake::raster::rasterize;
use shvis::bake::trace::Tracer;
use shvis::scene::{Mesh, house};

mod common;
use common::{FULL_UV, NO_UV, quad};

/// Floor y = 0 over [−h, h]², facing +Y, carrying the whole lightmap.
fn floor(m: &mut Mesh, h: f32) {
    let c = |x: f32, z: f32| Vec3::new(x, 0.0, z);
    quad(m, [c(-h, h), c(h, h), c(h, -h), c(-h, -h)], FULL_UV);
}

fn settings(rays: u32) -> AoSettings {
    AoSettings {
        rays,
        seed: 1,
        progress: false,
    }
}

#[test]
fn open_plane_is_unoccluded_everywhere() {
    let mut m = Mesh::default();
    floor(&mut m, 10.0);
    let texels = rasterize(&m, 16);
    assert_eq!(texels.covered_count(), 256);
    let ao = bake_ao(&Tracer::new(&m), &texels, &settings(256));
    assert!(ao.values.iter().all(|&v| v == 1.0), "{:?}", ao.values);
    assert_eq!(ao.stats.rays_traced, 256 * 256);
}

/// Rays per estimate in the inner-corner test.
const CORNER_RAYS: u32 = 4096;
/// 4σ of a binomial estimate of p = ½ from `CORNER_RAYS` independent rays,
/// 4·√(p(1−p)/N) ≈ 0.031. The stratified Hammersley set does far better; this is the bound
/// an unbiased estimator must meet. The finite 200 m wall hides directions only up to
/// ~1e-5 from the horizon at 1e-3 m away, far below it.
const CORNER_TOL: f32 = 4.0 * 0.5 / 64.0;

#[test]
fn inner_corner_of_floor_and_wall_is_half_occluded() {
    let h = 100.0;
    let mut m = Mesh::default();
    floor(&mut m, h);
    // Wall x = 0 facing +X, from the floor to 2h high.
    let w = |y: f32, z: f32| Vec3::new(0.0, y, z);
    quad(
        &mut m,
        [w(0.0, h), w(0.0, -h), w(2.0 * h, -h), w(2.0 * h, h)],
        NO_UV,
    );
    let tracer = Tracer::new(&m);
    for (k, z) in [0.0, 3.0, -40.0].into_iter().enumerate() {
        let p = Vec3::new(1e-3, 0.0, z);
        let ao = ao_at(&tracer, p, Vec3::Y, CORNER_RAYS, 9, k as u64);
        assert!((ao - 0.5).abs() < CORNER_TOL, "AO {ao} at {p}");
    }
}

/// Unit cube [−1, 1]³ as six quads, only the floor (y = −1, normal +Y inward) charted.
fn closed_box() -> Mesh {
    let mut m = Mesh::default();
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // Floor facing up into the box.
    quad(
        &mut m,
        [
            v(-1., -1., 1.),
            v(1., -1., 1.),
            v(1., -1., -1.),
            v(-1., -1., -1.),
        ],
        FULL_UV,
    );
    let faces = [
        [
            v(-1., 1., -1.),
            v(1., 1., -1.),
            v(1., 1., 1.),
            v(-1., 1., 1.),
        ], // ceiling
        [
            v(-1., -1., -1.),
            v(1., -1., -1.),
            v(1., 1., -1.),
            v(-1., 1., -1.),
        ], // z = −1
        [
            v(1., -1., 1.),
            v(-1., -1., 1.),
            v(-1., 1., 1.),
            v(1., 1., 1.),
        ], // z = +1
        [
            v(-1., -1., 1.),
            v(-1., -1., -1.),
            v(-1., 1., -1.),
            v(-1., 1., 1.),
        ], // x = −1
        [
            v(1., -1., -1.),
            v(1., -1., 1.),
            v(1., 1., 1.),
            v(1., 1., -1.),
        ], // x = +1
    ];
    for f in faces {
        quad(&mut m, f, NO_UV);
    }
    m
}

#[test]
fn floor_of_a_closed_box_is_fully_occluded() {
    let m = closed_box();
    let texels = rasterize(&m, 16);
    assert_eq!(texels.covered_count(), 256);
    let ao = bake_ao(&Tracer::new(&m), &texels, &settings(256));
    assert!(ao.values.iter().all(|&v| v == 0.0), "{:?}", ao.values);
}

fn house_bake(threads: usize) -> Result<Vec<u32>, Box<dyn std::error::Error>> {
    let scene = house::build(64)?;
    let texels = rasterize(&scene.mesh, 64);
    let tracer = Tracer::new(&scene.mesh);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let ao = pool.install(|| bake_ao(&tracer, &texels, &settings(64)));
    assert_eq!(ao.stats.rays_traced, texels.require_covered()? as u64 * 64);
    Ok(ao.values.iter().map(|v| v.to_bits()).collect())
}

#[test]
fn house_bake_is_identical_for_any_thread_count() -> Result<(), Box<dyn std::error::Error>> {
    let one = house_bake(1)?;
    let two = house_bake(2)?;
    assert!(one == two, "1-thread and 2-thread bakes differ");
    Ok(())
}

/// Rays for the landmark comparisons: σ ≤ 0.5/√1024 ≈ 0.016 per estimate.
const LANDMARK_RAYS: u32 = 1024;
/// The porch roof hides roughly half the sky from under it; the margin is ≫ 4σ.
const OVERHANG_MARGIN: f32 = 0.3;
/// Open ground sees everything but the distant house and fence (form factor ≈ 0.05).
const OPEN_MIN_AO: f32 = 0.9;

#[test]
fn house_overhang_is_darker_than_open_ground() -> Result<(), Box<dyn std::error::Error>> {
    let scene = house::build(256)?;
    let tracer = Tracer::new(&scene.mesh);
    let l = house::landmarks();
    let under = ao_at(&tracer, l.under_overhang, Vec3::Y, LANDMARK_RAYS, 0, 0);
    let open = ao_at(&tracer, l.open_ground, Vec3::Y, LANDMARK_RAYS, 0, 1);
    assert!(open >= OPEN_MIN_AO, "open ground AO {open}");
    assert!(
        under + OVERHANG_MARGIN < open,
        "under the overhang {under}, open {open}"
    );
    // The baked map agrees at the texel under the landmark (texel centre within a texel).
    let texels = rasterize(&scene.mesh, 256);
    let near = |p: Vec3| {
        (0..texels.position.len())
            .filter(|&i| texels.covered[i] && texels.normal[i] == Vec3::Y)
            .min_by(|&a, &b| {
                let (da, db) = (
                    texels.position[a].distance(p),
                    texels.position[b].distance(p),
                );
                da.total_cmp(&db)
            })
    };
    let (Some(a), Some(b)) = (near(l.under_overhang), near(l.open_ground)) else {
        return Err("no ground texel near the landmarks".into());
    };
    let ao = |i: usize| {
        ao_at(
            &tracer,
            texels.position[i],
            texels.normal[i],
            256,
            0,
            i as u64,
        )
    };
    assert!(
        ao(a) + OVERHANG_MARGIN < ao(b),
        "baked texels {} vs {}",
        ao(a),
        ao(b)
    );
    Ok(())
}

#[test]
fn house_landmarks_are_visible_from_the_default_camera() -> Result<(), Box<dyn std::error::Error>> {
    let scene = house::build(64)?;
    let tracer = Tracer::new(&scene.mesh);
    let l = house::landmarks();
    let eye = scene.camera.position;
    for (name, p) in [
        ("under_overhang", l.under_overhang),
        ("open_ground", l.open_ground),
        ("brick_wall", l.brick_wall),
    ] {
        let to = p - eye;
        // Stop 1 cm short of the landmark's own surface.
        let blocked = tracer.occluded(eye, to.normalize(), to.length() - 0.01);
        assert!(!blocked, "{name} at {p} is hidden from the camera");
    }
    Ok(())
}
