//! The reference renderer against answers computed independently of it: a lone ground
//! plane under a constant environment (closed form: radiance = albedo) and under the
//! built-in sky (radiance = albedo/π · E(+Y) with E by direct quadrature over the map's
//! texels, `env::project::irradiance_brute_force`), each within the noise it reports.

mod common;

use glam::{DVec3, Vec3};
use shvis::env::EnvMap;
use shvis::env::project::irradiance_brute_force;
use shvis::env::sky::{SkyParams, sky};
use shvis::reference::{ReferenceSettings, render_reference};
use shvis::render::Frame;
use shvis::scene::{Camera, Material, Mesh, Scene, Texture8, Vertex};

const ALBEDO: f32 = 0.5;
/// Image means are compared within this many standard errors of the mean.
const SIGMAS: f64 = 5.0;

/// A 200 m square ground (normal +Y, flat normals, white texture × ALBEDO) seen from above.
fn ground_scene() -> Scene {
    let corners = [
        (-100.0, -100.0),
        (100.0, -100.0),
        (100.0, 100.0),
        (-100.0, 100.0),
    ];
    let vertices = corners
        .iter()
        .map(|&(x, z)| Vertex {
            position: [x, 0.0, z],
            normal: [0.0, 1.0, 0.0],
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: [x / 10.0, z / 10.0],
            uv_lightmap: [(x + 100.0) / 200.0, (z + 100.0) / 200.0],
            albedo_tint: [ALBEDO; 3],
        })
        .collect();
    let white = Texture8 {
        width: 1,
        height: 1,
        texels: vec![[255; 4]],
    };
    let flat = Texture8 {
        width: 1,
        height: 1,
        texels: vec![[128, 128, 255, 255]],
    };
    Scene {
        name: "ground".into(),
        mesh: Mesh {
            vertices,
            indices: vec![0, 2, 1, 0, 3, 2],
        },
        material: Material {
            albedo: white,
            normal: flat,
            normal_scale: 0.0,
            height: None,
        },
        camera: Camera {
            position: Vec3::new(0.0, 5.0, 0.5),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40f32.to_radians(),
            z_near: 0.1,
            z_far: 500.0,
        },
    }
}

/// Mean and standard error of the mean of the red channel over covered pixels.
fn mean_and_error(frame: &Frame) -> (f64, f64) {
    let values: Vec<f64> = frame
        .rgba
        .iter()
        .filter(|t| t[3] > 0.5)
        .map(|t| t[0] as f64)
        .collect();
    let n = values.len() as f64;
    assert!(n > 1000.0, "only {n} pixels covered");
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

fn render(env: &EnvMap) -> (Frame, f64) {
    let ctx = common::validated_context();
    let image = render_reference(
        &ctx,
        &ground_scene(),
        env,
        &ReferenceSettings {
            width: 96,
            height: 64,
            spp: 32,
            seed: 1,
            bounces: 0,
            footprint: true,
        },
    )
    .expect("reference renders");
    common::assert_validation_clean(&ctx, "reference");
    (image.frame, image.rel_noise)
}

#[test]
fn constant_environment_gives_the_albedo() {
    let env = EnvMap::from_fn(64, 32, |_| [1.0; 3]);
    let (frame, noise) = render(&env);
    let (mean, err) = mean_and_error(&frame);
    println!(
        "constant env: mean {mean:.5} ± {err:.5} (expected {ALBEDO}), reported noise {noise:.4}"
    );
    assert!(
        (mean - ALBEDO as f64).abs() < SIGMAS * err,
        "{mean} ± {err}"
    );
    assert!(noise > 0.0 && noise < 0.5, "reported noise {noise}");
}

#[test]
fn sky_matches_brute_force_irradiance() {
    let env = sky(256, &SkyParams::default());
    let e = irradiance_brute_force(&env, DVec3::Y);
    let expected = ALBEDO as f64 / std::f64::consts::PI * e[0];
    let (frame, noise) = render(&env);
    let (mean, err) = mean_and_error(&frame);
    println!("sky: mean {mean:.5} ± {err:.5} (expected {expected:.5}), reported noise {noise:.4}");
    assert!(
        (mean - expected).abs() < SIGMAS * err,
        "{mean} ± {err} vs {expected}"
    );
}

/// On a lone plane no ray from the surface hits anything: the reference with bounces is
/// the direct one, sample for sample.
#[test]
fn bounces_add_nothing_on_an_open_plane() {
    let ctx = common::validated_context();
    let env = shvis::env::sky::sky(128, &SkyParams::default());
    let image = render_reference(
        &ctx,
        &ground_scene(),
        &env,
        &ReferenceSettings {
            width: 48,
            height: 32,
            spp: 8,
            seed: 2,
            bounces: 2,
            footprint: true,
        },
    )
    .expect("reference renders");
    let bounced = image.bounced.expect("bounced image");
    assert_eq!(bounced.bounces, 2);
    assert!(image.frame.rgba.iter().any(|t| t[3] > 0.5 && t[0] > 0.0));
    assert_eq!(bounced.frame.rgba, image.frame.rgba);
    common::assert_validation_clean(&ctx, "reference with bounces");
}
