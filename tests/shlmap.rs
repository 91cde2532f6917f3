//! `shlmap` (order-3 SH of incident radiance with inter-reflection, Iwanicki–Sloan §5):
//! a bounce brightens the floor next to a sunlit wall; the technique is measured against
//! the reference with 2 bounces (and is closer to it than to the direct-only one); on an
//! open plane the bounced reference is the direct one; both paths agree.

mod common;

use glam::{DVec3, Vec3};
use shvis::bake::raster::rasterize;
use shvis::bake::shlmap::{BakeLighting, ShLightmap, ShLightmapSettings, bake_sh_lightmap};
use shvis::bake::trace::Tracer;
use shvis::env::EnvMap;
use shvis::report::metrics::image_error;
use shvis::scene::{Camera, Material, Mesh, Scene, Vertex, lightmap_uv};
use shvis::sh::Order;
use shvis::technique::{HwPath, Technique};

/// Appends the quad a, b, c, d (counter-clockwise seen from the side `normal` points to).
fn quad(mesh: &mut Mesh, corners: [[f32; 3]; 4], normal: [f32; 3], tint: f32) {
    let base = mesh.vertices.len() as u32;
    for p in corners {
        mesh.vertices.push(Vertex {
            position: p,
            normal,
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: [p[0], p[2]],
            uv_lightmap: [0.0, 0.0],
            albedo_tint: [tint; 3],
        });
    }
    mesh.indices
        .extend([0, 1, 2, 0, 2, 3].iter().map(|i| base + i));
}

/// A 12 m square floor (albedo 0.3) and a 6 m long, 3 m high, 0.4 m thick white (0.8)
/// wall along x at z = 0; lightmap UVs generated for `res`.
fn wall_scene(res: u32) -> Scene {
    scene(res, true)
}

/// The floor of [`wall_scene`], with its wall if `wall`.
fn scene(res: u32, wall: bool) -> Scene {
    let mut mesh = Mesh {
        vertices: vec![],
        indices: vec![],
    };
    let (f, h, t, l) = (6.0, 3.0, 0.2, 3.0);
    quad(
        &mut mesh,
        [[-f, 0.0, f], [f, 0.0, f], [f, 0.0, -f], [-f, 0.0, -f]],
        [0.0, 1.0, 0.0],
        0.3,
    );
    if wall {
        let w = 0.8;
        // +Z (sunlit) and −Z faces, the two ends, the top.
        quad(
            &mut mesh,
            [[-l, 0.0, t], [l, 0.0, t], [l, h, t], [-l, h, t]],
            [0.0, 0.0, 1.0],
            w,
        );
        quad(
            &mut mesh,
            [[l, 0.0, -t], [-l, 0.0, -t], [-l, h, -t], [l, h, -t]],
            [0.0, 0.0, -1.0],
            w,
        );
        quad(
            &mut mesh,
            [[l, 0.0, t], [l, 0.0, -t], [l, h, -t], [l, h, t]],
            [1.0, 0.0, 0.0],
            w,
        );
        quad(
            &mut mesh,
            [[-l, 0.0, -t], [-l, 0.0, t], [-l, h, t], [-l, h, -t]],
            [-1.0, 0.0, 0.0],
            w,
        );
        quad(
            &mut mesh,
            [[-l, h, t], [l, h, t], [l, h, -t], [-l, h, -t]],
            [0.0, 1.0, 0.0],
            w,
        );
    }
    lightmap_uv::generate(&mut mesh, res).expect("charts fit");
    let texture = common::solid_texture;
    Scene {
        name: "wall".into(),
        mesh,
        material: Material {
            albedo: texture([255; 4]),
            normal: texture([128, 128, 255, 255]),
            normal_scale: 0.0,
            height: None,
        },
        camera: Camera {
            position: Vec3::new(0.0, 4.0, 9.0),
            target: Vec3::new(0.0, 0.5, 0.0),
            up: Vec3::Y,
            fov_y: 50f32.to_radians(),
            z_near: 0.05,
            z_far: 100.0,
        },
    }
}

/// A dim sky and a broad bright lobe (a soft sun) from +Z at 30° elevation.
fn sun_env() -> EnvMap {
    let sun = DVec3::new(0.0, 0.5, 0.75f64.sqrt());
    EnvMap::from_fn(128, 64, |d| {
        let lobe = 40.0 * d.dot(sun).max(0.0).powi(16);
        let sky = if d.y > 0.0 { 0.3 } else { 0.05 };
        [(sky + lobe) as f32; 3]
    })
}

fn bake(scene: &Scene, res: u32, bounces: u32) -> ShLightmap {
    let texels = rasterize(&scene.mesh, res);
    let tracer = Tracer::new(&scene.mesh);
    let radiance = shvis::env::project::project_sh(&sun_env(), Order::new(8).unwrap());
    bake_sh_lightmap(
        scene,
        &tracer,
        &texels,
        &BakeLighting::Sh(&radiance),
        &ShLightmapSettings {
            rays: 512,
            seed: 5,
            bounces,
            progress: false,
        },
        &[],
    )
}

/// Mean irradiance at the normal over floor texels whose centre lies in x ∈ (−2, 2), z ∈ z_range.
fn mean_floor_irradiance(scene: &Scene, map: &ShLightmap, z_range: (f32, f32)) -> f64 {
    let texels = rasterize(&scene.mesh, map.res);
    let (mut sum, mut n) = (0.0, 0);
    for i in 0..texels.covered.len() {
        let p = texels.position[i];
        if texels.covered[i]
            && p.y.abs() < 1e-4
            && texels.normal[i].y > 0.99
            && p.x.abs() < 2.0
            && p.z > z_range.0
            && p.z < z_range.1
        {
            sum += map.irradiance(i, Vec3::Y).x as f64;
            n += 1;
        }
    }
    assert!(n >= 10, "only {n} floor texels in z ∈ {z_range:?}");
    sum / n as f64
}

#[test]
fn one_bounce_brightens_the_floor_next_to_a_lit_wall() {
    let res = 96;
    let scene = wall_scene(res);
    let direct = bake(&scene, res, 0);
    let bounced = bake(&scene, res, 1);
    let near = (0.25, 0.9);
    let far = (4.5, 5.8);
    let (near0, near1) = (
        mean_floor_irradiance(&scene, &direct, near),
        mean_floor_irradiance(&scene, &bounced, near),
    );
    let (far0, far1) = (
        mean_floor_irradiance(&scene, &direct, far),
        mean_floor_irradiance(&scene, &bounced, far),
    );
    let (gain_near, gain_far) = (near1 / near0 - 1.0, far1 / far0 - 1.0);
    println!(
        "floor irradiance next to the wall {near0:.4} → {near1:.4} (+{:.1}%), far from it {far0:.4} → {far1:.4} (+{:.1}%)",
        100.0 * gain_near,
        100.0 * gain_far
    );
    // The wall reflects 0.8 of the sun onto the floor in front of it, which sees the wall
    // over a large solid angle: a clear gain there, and more than far away.
    assert!(gain_near > 0.05, "bounce gain next to the wall {gain_near}");
    assert!(
        gain_near > 2.0 * gain_far.max(0.0),
        "{gain_near} vs {gain_far}"
    );
    // Inter-reflection only adds light: no covered texel gets darker at its own normal
    // (up to the order-3 truncation of the added light, 1% of the texel's irradiance).
    let texels = rasterize(&scene.mesh, res);
    for i in 0..direct.covered.len() {
        if direct.covered[i] {
            let n = texels.normal[i];
            let (e0, e1) = (direct.irradiance(i, n), bounced.irradiance(i, n));
            assert!(
                (e1 - e0).min_element() > -1e-2 * e0.max_element().max(0.1),
                "texel {i}: {e0} → {e1}"
            );
        }
    }
}

#[test]
fn shlmap_meets_the_reference_with_two_bounces() {
    let ctx = common::validated_context();
    let (reference, settings) = common::house_reference(&ctx);
    let bounced = reference
        .bounced
        .as_ref()
        .expect("the house reference has bounces");
    assert_eq!(bounced.bounces, 2);
    let prepared = common::house();
    let mut errors = vec![];
    for &path in HwPath::ALL {
        let frame = common::render(
            &ctx,
            prepared,
            Technique::Shlmap(shvis::technique::Shlmap),
            path,
            &settings,
        );
        let against_bounced = image_error(&frame, &bounced.frame).unwrap().rel_rmse;
        let against_direct = image_error(&frame, &reference.frame).unwrap().rel_rmse;
        println!(
            "shlmap.{path}: relative RMSE {against_bounced:.4} against the 2-bounce reference \
             (noise {:.4}), {against_direct:.4} against the direct-only one",
            bounced.rel_noise
        );
        // It models inter-reflection, so the bounced reference is the one it should meet.
        assert!(
            against_bounced < against_direct,
            "{against_bounced} vs {against_direct}"
        );
        assert!(against_bounced < 0.3, "{against_bounced}");
        errors.push(against_bounced);
    }
    assert!(
        (errors[0] - errors[1]).abs() < 0.01,
        "dx9 vs dx10: {errors:?}"
    );
    // The bounced reference is brighter than the direct one (light only adds up).
    let sum = |f: &shvis::render::Frame| {
        f.rgba
            .iter()
            .map(|t| t[0] as f64 + t[1] as f64 + t[2] as f64)
            .sum::<f64>()
    };
    assert!(sum(&bounced.frame) > 1.01 * sum(&reference.frame));
}

/// Where inter-reflection is strong (the floor in front of the sunlit white wall), shlmap
/// with 2 bounces is far closer to the 2-bounce reference than to the direct-only one.
#[test]
fn shlmap_tracks_strong_inter_reflection() {
    let res = 96;
    let scene = wall_scene(res);
    let map = bake(&scene, res, 2);
    let env = sun_env();
    let ctx = common::validated_context();
    let (width, height) = (160, 100);
    let reference = shvis::reference::render_reference(
        &ctx,
        &scene,
        &env,
        &shvis::reference::ReferenceSettings {
            width,
            height,
            spp: 256,
            seed: 9,
            bounces: 2,
            footprint: true,
        },
    )
    .expect("reference renders");
    let bounced = reference.bounced.as_ref().unwrap();
    let settings = shvis::render::FrameSettings {
        width,
        height,
        ..Default::default()
    };
    let gpu = shvis::render::SceneGpu::new(&ctx, &scene, &settings).unwrap();
    let ao = shvis::bake::ao::AoMap {
        res,
        values: vec![1.0; (res * res) as usize],
        covered: map.covered.clone(),
        stats: shvis::bake::BakeStats::default(),
    };
    let radiance = shvis::env::project::project_sh(&env, Order::new(8).unwrap());
    let irradiance = shvis::sh::zonal::irradiance_from_radiance(&radiance[..9], Order::THREE);
    let inputs = shvis::technique::Inputs {
        ao: &ao,
        irradiance_sh: &irradiance,
        radiance_sh: &radiance,
        visibility: None,
        pca: None,
        clusters: &[],
        vertex_pca: &[],
        sh_lightmap: Some(&map),
        ssbump: None,
        ndf_moments: None,
        transfer: None,
        table_res: 16,
        h_order: Order::THREE,
        options: Default::default(),
        cache_dir: None,
    };
    for &path in HwPath::ALL {
        let tech = shvis::technique::build(
            &ctx,
            &gpu,
            Technique::Shlmap(shvis::technique::Shlmap),
            path,
            &inputs,
        )
        .unwrap();
        let frame = tech.render(&gpu, 0, 1).unwrap();
        let e_bounced = image_error(&frame, &bounced.frame).unwrap().rel_rmse;
        let e_direct = image_error(&frame, &reference.frame).unwrap().rel_rmse;
        println!(
            "wall scene shlmap.{path}: relative RMSE {e_bounced:.4} against the 2-bounce reference (noise {:.4}), {e_direct:.4} against the direct-only one",
            bounced.rel_noise
        );
        assert!(e_bounced < 0.5 * e_direct, "{e_bounced} vs {e_direct}");
        // What is left beyond the reference's own noise is shlmap's error.
        let beyond_noise = (e_bounced.powi(2) - bounced.rel_noise.powi(2))
            .max(0.0)
            .sqrt();
        assert!(beyond_noise < 0.05, "{beyond_noise}");
    }
    common::assert_validation_clean(&ctx, "wall scene shlmap");
}

/// Fitting the tangent-frame bases from the samples (`--basis-fit samples`) changes nothing
/// the bake already made, gives every covered texel each fit, and agrees with the same fit
/// made from the texel's SH (`l2`) where the light is smooth: on the floor of the wall
/// scene, away from the wall, the irradiance at +z from either fit is within a few percent.
#[test]
fn the_bases_fitted_from_samples_leave_the_bake_as_it_was() {
    use shvis::sh::ambient_cube::CubeFit;
    use shvis::sh::hbasis::{self, HBasisSize};
    use shvis::sh::samples::SampleFit;
    let scene = wall_scene(32);
    let texels = rasterize(&scene.mesh, 32);
    let tracer = Tracer::new(&scene.mesh);
    let radiance = shvis::env::project::project_sh(&sun_env(), Order::new(8).unwrap());
    let settings = ShLightmapSettings {
        rays: 1024,
        seed: 5,
        bounces: 1,
        progress: false,
    };
    let fits = [
        SampleFit::HBasis(HBasisSize::H6),
        SampleFit::AmbientCube(CubeFit::Projection),
    ];
    let plain = bake_sh_lightmap(
        &scene,
        &tracer,
        &texels,
        &BakeLighting::Sh(&radiance),
        &settings,
        &[],
    );
    let fitted = bake_sh_lightmap(
        &scene,
        &tracer,
        &texels,
        &BakeLighting::Sh(&radiance),
        &settings,
        &fits,
    );
    assert_eq!(plain.coeffs, fitted.coeffs);
    assert_eq!(plain.basis_irradiance, fitted.basis_irradiance);
    assert!(plain.fitted.fits.is_empty() && plain.fitted.per_texel() == 0);
    assert_eq!(fitted.fitted.fits.len(), 2);
    let h6 = fitted.fitted(fits[0]).expect("the H6 fit");
    let cube = fitted.fitted(fits[1]).expect("the cube fit");
    let (h6, cube) = (h6.texel_values(), cube.texel_values());
    assert_eq!(h6.len(), 32 * 32 * 18);
    assert_eq!(cube.len(), 32 * 32 * 18);
    let mut compared = 0;
    for t in 0..32 * 32 {
        if !fitted.covered[t] || fitted.frame[t].z_axis.y < 0.99 {
            continue;
        }
        let frame = [
            fitted.frame[t].x_axis,
            fitted.frame[t].y_axis,
            fitted.frame[t].z_axis,
        ]
        .map(|c| c.as_dvec3());
        let sh: Vec<[f64; 3]> = fitted.texel(t).iter().map(|c| c.map(f64::from)).collect();
        let from_sh = hbasis::irradiance(
            &hbasis::project_irradiance(&sh, frame, HBasisSize::H6),
            glam::DVec3::Z,
        )[0];
        let v = &h6[t * 18..(t + 1) * 18];
        let h: Vec<[f64; 3]> = (0..6)
            .map(|i| std::array::from_fn(|c| f64::from(v[3 * i + c])))
            .collect();
        let from_samples = hbasis::irradiance(&h, glam::DVec3::Z)[0];
        // The cube's +z face is the irradiance at the normal, which the SH holds to 9 %.
        let cube_z = f64::from(cube[t * 18 + 12]);
        assert!(
            (from_samples - from_sh).abs() <= 0.1 * from_sh.abs().max(1e-3),
            "texel {t}: H6 at +z {from_samples} from samples, {from_sh} from the SH"
        );
        assert!(
            (cube_z - from_sh).abs() <= 0.1 * from_sh.abs().max(1e-3),
            "texel {t}: cube +z {cube_z}, H6 from the SH {from_sh}"
        );
        compared += 1;
    }
    assert!(compared > 50, "{compared} floor texels compared");
}

/// A black sky with a sun disc of 2° radius from +Z at 30° elevation (radiance 1000): too
/// small for the shared directions or for an order-8 SH.
fn small_sun_env() -> EnvMap {
    let sun = DVec3::new(0.0, 0.5, 0.75f64.sqrt());
    let cos_radius = 2f64.to_radians().cos();
    EnvMap::from_fn(512, 256, |d| {
        [if d.dot(sun) > cos_radius { 1000.0 } else { 0.0 }; 3]
    })
}

/// A direct-only bake of `scene` from the full-resolution `env` (eq. (6)).
fn bake_from_pixels(scene: &Scene, env: &EnvMap, res: u32) -> ShLightmap {
    bake_sh_lightmap(
        scene,
        &Tracer::new(&scene.mesh),
        &rasterize(&scene.mesh, res),
        &BakeLighting::Pixels(env),
        &ShLightmapSettings {
            rays: 512,
            seed: 5,
            bounces: 0,
            progress: false,
        },
        &[],
    )
}

/// Under a uniform sky of radiance 1 an open floor receives π: the shared and the
/// importance-sampled rays' weights (eq. (6)) add up to the sphere, not to more.
#[test]
fn a_bake_from_the_pixels_weighs_its_two_kinds_of_ray_to_the_map_itself() {
    let scene = scene(32, false);
    let env = EnvMap::from_fn(64, 32, |_| [1.0; 3]);
    let map = bake_from_pixels(&scene, &env, 32);
    assert_eq!(map.env, shvis::bake::shlmap::BakeEnv::Pixels);
    let e = mean_floor_irradiance(&scene, &map, (-5.0, 5.0));
    let pi = std::f64::consts::PI;
    assert!((e - pi).abs() < 0.01 * pi, "{e}");
}

/// A 2° sun that the shared directions would miss lights the open floor with what the
/// map's own order-3 SH gives there, and the wall's shadow stays dark.
#[test]
fn a_small_sun_from_the_pixels_lights_the_open_floor_and_not_the_shadow() {
    let res = 64;
    let scene = wall_scene(res);
    let env = small_sun_env();
    let map = bake_from_pixels(&scene, &env, res);
    let sh3: Vec<[f32; 3]> = shvis::env::project::project_sh(&env, Order::THREE)
        .iter()
        .map(|c| c.map(|v| v as f32))
        .collect();
    let expected = shvis::bake::shlmap::irradiance_at(&sh3, Vec3::Y).x as f64;
    let lit = mean_floor_irradiance(&scene, &map, (2.5, 5.5));
    let shadow = mean_floor_irradiance(&scene, &map, (-3.0, -0.5));
    assert!(
        (lit - expected).abs() < 0.02 * expected,
        "{lit} against {expected}"
    );
    assert!(shadow.abs() < 0.01 * expected, "{shadow} in the shadow");
}
