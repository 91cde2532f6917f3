//! Radiosity normal mapping: the `rnm` lightmaps of an open plane reproduce the
//! flat irradiance and follow the light's side; Listing 2 with the unoccluded D encoding
//! of a normal map draws what Listing 1 draws from the normal map itself, per pixel, to
//! f16 precision, on both paths; `ssbump` under a grazing sun darkens the mortar joints
//! that `rnm` leaves lit.

mod common;

use glam::{DVec3, Vec3};
use shvis::bake::raster::rasterize;
use shvis::bake::shlmap::{BakeLighting, ShLightmap, ShLightmapSettings, bake_sh_lightmap};
use shvis::bake::ssbump::{SsBumpMaps, SsBumpStorage};
use shvis::bake::trace::Tracer;
use shvis::env::EnvMap;
use shvis::render::{FrameSettings, SceneGpu};
use shvis::scene::{Camera, Material, Mesh, Scene, Vertex, lightmap_uv};
use shvis::sh::Order;
use shvis::technique::{self, HwPath, RnmVariant, Technique};

/// A 4 m square floor facing +Y, tangent +X (so B₀ leans to +X, B₁ to −Z, B₂ to +Z).
fn plane() -> Scene {
    let f = 2.0f32;
    let corners = [[-f, 0.0, f], [f, 0.0, f], [f, 0.0, -f], [-f, 0.0, -f]];
    let mut mesh = Mesh {
        vertices: corners
            .iter()
            .map(|&p| Vertex {
                position: p,
                normal: [0.0, 1.0, 0.0],
                tangent: [1.0, 0.0, 0.0, 1.0],
                uv_material: [p[0], p[2]],
                uv_lightmap: [0.0, 0.0],
                albedo_tint: [1.0; 3],
            })
            .collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
    };
    lightmap_uv::generate(&mut mesh, 16).expect("one chart fits");
    Scene {
        name: "plane".into(),
        mesh,
        material: Material {
            albedo: common::solid_texture([255; 4]),
            normal: common::solid_texture([128, 128, 255, 255]),
            normal_scale: 0.0,
            height: None,
        },
        camera: Camera {
            position: Vec3::new(0.0, 3.0, 3.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 1.0,
            z_near: 0.05,
            z_far: 50.0,
        },
    }
}

fn bake(scene: &Scene, env: &EnvMap) -> ShLightmap {
    let texels = rasterize(&scene.mesh, 16);
    let radiance = shvis::env::project::project_sh(env, Order::new(8).unwrap());
    bake_sh_lightmap(
        scene,
        &Tracer::new(&scene.mesh),
        &texels,
        &BakeLighting::Sh(&radiance),
        &ShLightmapSettings {
            rays: 4096,
            seed: 3,
            bounces: 0,
            progress: false,
        },
        &[],
    )
}

/// Mean over covered texels of lightmap i (luminance-free: channel 0).
fn mean_lightmap(map: &ShLightmap, i: usize) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (t, lobes) in map.basis_irradiance.iter().enumerate() {
        if map.covered[t] {
            sum += f64::from(lobes[i].x);
            n += 1;
        }
    }
    sum / n as f64
}

/// Quasi-random directions over 4096 rays: 1 % of π.
const RAY_NOISE: f64 = 0.01 * std::f64::consts::PI;

#[test]
fn rnm_lightmaps_of_an_open_plane_reproduce_the_flat_irradiance_and_follow_the_light() {
    let scene = plane();
    let pi = std::f64::consts::PI;
    // A constant sky: every lobe is tilted alike, and the flat normalization (eq. (4) of
    // bake::shlmap) makes each the irradiance π of the open plane (the raw lobes gather
    // π(1 + 1/√3)/2 ≈ 0.79π).
    let uniform = bake(&scene, &EnvMap::from_fn(64, 32, |_| [1.0; 3]));
    for i in 0..3 {
        let e = mean_lightmap(&uniform, i);
        assert!((e - pi).abs() < RAY_NOISE, "lightmap {i}: {e}, want π");
    }
    // Brighter towards +X: B₀ (leaning to +X) gathers most, B₁ and B₂ (mirror images in
    // z) alike, and their mean is still the flat irradiance ∫ (1 + x) cos θ = π.
    let sided = bake(
        &scene,
        &EnvMap::from_fn(64, 32, |d: DVec3| [(1.0 + d.x) as f32; 3]),
    );
    let e: Vec<f64> = (0..3).map(|i| mean_lightmap(&sided, i)).collect();
    assert!(e[0] > e[1] + 0.3 && e[0] > e[2] + 0.3, "{e:?}");
    assert!((e[1] - e[2]).abs() < RAY_NOISE, "{e:?}");
    let mean = e.iter().sum::<f64>() / 3.0;
    assert!((mean - pi).abs() < RAY_NOISE, "{e:?}");
}

#[test]
fn listing_2_with_the_unoccluded_d_encoding_equals_listing_1_per_pixel() {
    let prepared = common::house();
    let ctx = common::validated_context();
    let (width, height) = (160, 100);
    // Constant tilted normal maps: D is not linear in N, so with a varying map the filtered
    // D of Listing 2 and the D of the filtered N of Listing 1 differ by design; a constant
    // map filters to itself, and what remains is the shared basis, tangent frame and
    // colour convention of the CPU encoding and the shader.
    for tilt in [[170u8, 110, 230, 255], [90, 160, 235, 255]] {
        let mut scene = prepared.scene.clone();
        scene.material.normal = common::solid_texture(tilt);
        let maps = SsBumpMaps {
            // f16 storage: the comparison is of the shader's arithmetic, not of the
            // techniques' 8-bit texture.
            storage: SsBumpStorage::Float16,
            ..SsBumpMaps::unoccluded(&scene.material.normal, scene.material.normal_scale)
        };
        let inputs = technique::Inputs {
            ssbump: Some(&maps),
            ndf_moments: None,
            transfer: None,
            ..prepared.inputs()
        };
        let settings = FrameSettings {
            width,
            height,
            ..FrameSettings::default()
        };
        let gpu_scene = SceneGpu::new(&ctx, &scene, &settings).expect("scene uploads");
        for path in [HwPath::Dx9, HwPath::Dx10] {
            let render = |variant| {
                let t = Technique::Rnm(shvis::technique::Rnm { variant });
                let built = technique::build(&ctx, &gpu_scene, t, path, &inputs)
                    .unwrap_or_else(|e| panic!("{t}.{path}: {e}"));
                built.render(&gpu_scene, 0, 1).expect("renders")
            };
            let listing1 = render(RnmVariant::NormalMap);
            let listing2 = render(RnmVariant::SelfShadowed);
            let covered: Vec<([f32; 4], [f32; 4])> = listing1
                .rgba
                .iter()
                .zip(&listing2.rgba)
                .filter(|(a, b)| {
                    assert_eq!(a[3], b[3], "coverage differs");
                    a[3] > 0.5
                })
                .map(|(a, b)| (*a, *b))
                .collect();
            // f16 storage of D and of the target: a few half-float ulps (2^-10 relative) of
            // the value, and of the image's mean where the lightmaps' negative light (the
            // SH lighting's ringing) cancels a pixel to near zero.
            let mean = covered.iter().map(|(a, _)| a[0] + a[1] + a[2]).sum::<f32>()
                / (3 * covered.len().max(1)) as f32;
            let mut worst = 0.0f32;
            for (a, b) in &covered {
                for c in 0..3 {
                    let allowed = 4.0 * 9.8e-4 * a[c].abs().max(b[c].abs()) + 1e-4 * mean;
                    worst = worst.max((a[c] - b[c]).abs() / allowed);
                }
            }
            let covered = covered.len();
            assert!(covered > 1000, "{covered} covered pixels");
            assert!(
                worst <= 1.0,
                "tilt {tilt:?} {path}: a difference {worst}× the f16 tolerance"
            );
        }
        common::assert_validation_clean(&ctx, "rnm / ssbump");
    }
}

/// The built-in house at 128² texels × 256 rays with 2 bounces under the built-in sky: the
/// settings at which the sky's SH, ringing below zero around the sun, let a channel's three
/// signed lobes cancel to almost nothing and eq. (4) of `bake::shlmap` scale single texels
/// to 10⁴ (covered, (77, 104)) and 10⁷ (a gutter, (108, 82)) — fireflies of rnm, rnmao and
/// ssbump. With the factor taken from the positive parts (at most 3√3) the largest value is
/// the sunlit lobe's irradiance (≈ 43).
#[test]
fn rnm_lightmaps_stay_bounded_where_the_sky_rings() {
    let scene = shvis::scene::house::build(128).expect("the house builds");
    let env = shvis::env::resolve("sky").expect("the built-in sky");
    let radiance = shvis::env::project::project_sh(&env, Order::new(8).unwrap());
    let map = bake_sh_lightmap(
        &scene,
        &Tracer::new(&scene.mesh),
        &rasterize(&scene.mesh, 128),
        &BakeLighting::Sh(&radiance),
        &ShLightmapSettings {
            rays: 256,
            seed: 0,
            bounces: 2,
            progress: false,
        },
        &[],
    );
    let largest = map
        .basis_irradiance
        .iter()
        .flat_map(|lobes| lobes.iter().flat_map(|v| v.to_array()))
        .fold(0.0f32, |m, v| {
            if v.is_finite() {
                m.max(v.abs())
            } else {
                f32::INFINITY
            }
        });
    assert!(
        largest < 100.0,
        "an rnm value of {largest}: the normalization blew up"
    );
}
