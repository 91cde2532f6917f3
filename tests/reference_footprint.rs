//! The footprint reference against an independent brute force: a bumpy,
//! normal-mapped plane seen at a grazing angle, where the normal map's MIP chain is deep.
//!
//! Brute force, on the CPU with no G-buffer: 16 × 16 primary rays per pixel from the camera
//! (inverse of `clip_from_world`), intersected with the plane y = 0 analytically, the normal
//! map read bilinearly at full resolution (repeat wrap, texel centres at (i + ½)/W), and
//! under a constant environment of radiance 1 the closed form of the shading integral:
//! with V = 0 below the geometric tangent plane (+Y), ∫ max(0, n_s·ω) over the upper
//! hemisphere = π (1 + n_s·Y)/2, so radiance = albedo (1 + n_s.y)/2 — no noise at all.

mod common;

use glam::{Mat4, Vec2, Vec3, Vec4};
use shvis::env::EnvMap;
use shvis::reference::{ReferenceImage, ReferenceSettings, render_reference};
use shvis::scene::{Camera, Material, Mesh, Scene, Texture8, Vertex};

const ALBEDO: f32 = 0.6;
/// Material UV per metre: the normal map tiles 4 times a metre.
const TILES_PER_METRE: f32 = 4.0;
const SIZE: (u32, u32) = (64, 40);
const NORMAL_MAP_SIDE: u32 = 64;
/// Bumps per normal-map side, and their slope amplitude.
const BUMPS: f32 = 4.0;
const SLOPE: f32 = 1.2;
const HALF_EXTENT: f32 = 300.0;

/// A normal map of an egg-crate height field h = sin(2π·k·x) sin(2π·k·y), slopes up to
/// `SLOPE`; or a flat one.
fn normal_map(bumpy: bool) -> Texture8 {
    let n = NORMAL_MAP_SIDE;
    let encode = |v: f32| ((v * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
    let texels = (0..n * n)
        .map(|i| {
            if !bumpy {
                return [128, 128, 255, 255];
            }
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            let w = 2.0 * std::f32::consts::PI * BUMPS / n as f32;
            let dx = SLOPE * (w * x).cos() * (w * y).sin();
            let dy = SLOPE * (w * x).sin() * (w * y).cos();
            let m = Vec3::new(-dx, -dy, 1.0).normalize();
            [encode(m.x), encode(m.y), encode(m.z), 255]
        })
        .collect();
    Texture8 {
        width: n,
        height: n,
        texels,
    }
}

fn camera() -> Camera {
    Camera {
        position: Vec3::new(0.0, 0.6, 0.0),
        target: Vec3::new(0.0, 0.0, -12.0),
        up: Vec3::Y,
        fov_y: 30f32.to_radians(),
        z_near: 0.05,
        z_far: 1000.0,
    }
}

fn plane_scene(bumpy: bool) -> Scene {
    let h = HALF_EXTENT;
    let vertices = [(-h, -h), (h, -h), (h, h), (-h, h)]
        .iter()
        .map(|&(x, z)| Vertex {
            position: [x, 0.0, z],
            normal: [0.0, 1.0, 0.0],
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv_material: [x * TILES_PER_METRE, z * TILES_PER_METRE],
            uv_lightmap: [(x + h) / (2.0 * h), (z + h) / (2.0 * h)],
            albedo_tint: [ALBEDO; 3],
        })
        .collect();
    Scene {
        name: "bumpy plane".into(),
        mesh: Mesh {
            vertices,
            indices: vec![0, 2, 1, 0, 3, 2],
        },
        material: Material {
            albedo: Texture8 {
                width: 1,
                height: 1,
                texels: vec![[255; 4]],
            },
            normal: normal_map(bumpy),
            normal_scale: 1.0,
            height: None,
        },
        camera: camera(),
    }
}

/// Bilinear, repeat-wrapped read of the normal map at `uv`, decoded to [−1, 1].
fn sample_normal(tex: &Texture8, uv: Vec2) -> Vec3 {
    let (w, h) = (tex.width as i64, tex.height as i64);
    let (fx, fy) = (uv.x * w as f32 - 0.5, uv.y * h as f32 - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let texel = |x: i64, y: i64| {
        let t = tex.texels[(y.rem_euclid(h) * w + x.rem_euclid(w)) as usize];
        Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) / 255.0
    };
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0).lerp(texel(x0 + 1, y0), tx);
    let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), tx);
    top.lerp(bottom, ty) * 2.0 - Vec3::ONE
}

/// Box-filtered radiance of every pixel by 16 × 16 primary rays, and whether all of its
/// rays hit the plane.
fn brute_force(scene: &Scene) -> Vec<Option<f64>> {
    const SUB: u32 = 16;
    let (w, h) = SIZE;
    let world_from_clip: Mat4 = scene.camera.clip_from_world(w as f32 / h as f32).inverse();
    let unproject = |ndc: Vec4| {
        let p = world_from_clip * ndc;
        p.truncate() / p.w
    };
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0f64;
            let mut all_hit = true;
            for k in 0..SUB * SUB {
                let px = x as f32 + ((k % SUB) as f32 + 0.5) / SUB as f32;
                let py = y as f32 + ((k / SUB) as f32 + 0.5) / SUB as f32;
                let ndc = Vec2::new(2.0 * px / w as f32 - 1.0, 2.0 * py / h as f32 - 1.0);
                let near = unproject(ndc.extend(0.0).extend(1.0));
                let far = unproject(ndc.extend(1.0).extend(1.0));
                let dir = far - near;
                let t = -near.y / dir.y;
                let p = near + dir * t;
                if !(t > 0.0 && p.x.abs() < HALF_EXTENT && p.z.abs() < HALF_EXTENT) {
                    all_hit = false;
                    continue;
                }
                let m = sample_normal(
                    &scene.material.normal,
                    Vec2::new(p.x, p.z) * TILES_PER_METRE,
                );
                let len = m.length();
                let n_y = if len > 1e-6 { m.z / len } else { 1.0 };
                sum += (ALBEDO as f64) * (1.0 + n_y as f64) / 2.0;
            }
            out.push(all_hit.then_some(sum / (SUB * SUB) as f64));
        }
    }
    out
}

fn reference(scene: &Scene, footprint: bool, spp: u32) -> ReferenceImage {
    let ctx = common::validated_context();
    let env = EnvMap::from_fn(64, 32, |_| [1.0; 3]);
    let image = render_reference(
        &ctx,
        scene,
        &env,
        &ReferenceSettings {
            width: SIZE.0,
            height: SIZE.1,
            spp,
            seed: 5,
            bounces: 0,
            footprint,
        },
    )
    .expect("reference renders");
    common::assert_validation_clean(&ctx, "footprint reference");
    image
}

/// (mean of `image`, mean of `truth`, relative RMSE) over pixels fully covered in both.
fn compare(image: &ReferenceImage, truth: &[Option<f64>]) -> (f64, f64, f64) {
    let (mut a, mut b, mut se, mut sq, mut n) = (0.0, 0.0, 0.0, 0.0, 0usize);
    for (t, want) in image.frame.rgba.iter().zip(truth) {
        let Some(want) = *want else { continue };
        if t[3] < 1.0 {
            continue;
        }
        let got = t[0] as f64;
        (a, b, n) = (a + got, b + want, n + 1);
        se += (got - want).powi(2);
        sq += want * want;
    }
    assert!(n > 500, "only {n} pixels fully covered");
    (a / n as f64, b / n as f64, (se / sq).sqrt())
}

#[test]
fn footprint_reference_meets_the_brute_force_and_point_sampling_does_not() {
    let scene = plane_scene(true);
    let truth = brute_force(&scene);
    let footprint = reference(&scene, true, 256);
    let point = reference(&scene, false, 256);
    assert_eq!(footprint.strata.side, 8);
    let (mean_f, mean_bf, rmse_f) = compare(&footprint, &truth);
    let (mean_p, _, rmse_p) = compare(&point, &truth);
    let off = |m: f64| (m / mean_bf - 1.0) * 100.0;
    println!(
        "brute force mean {mean_bf:.5}; footprint {mean_f:.5} ({:+.2} %, rel RMSE {rmse_f:.4}, noise {:.4}); \
         point {mean_p:.5} ({:+.2} %, rel RMSE {rmse_p:.4}, noise {:.4})",
        off(mean_f),
        footprint.rel_noise,
        off(mean_p),
        point.rel_noise
    );
    assert!(
        off(mean_f).abs() < 0.5,
        "footprint mean off by {:.2} %",
        off(mean_f)
    );
    assert!(
        off(mean_p).abs() > 0.5,
        "point mean within 0.5 %: {:.2} %",
        off(mean_p)
    );
    // Per pixel the footprint reference differs from the truth by its noise alone (the
    // stratified estimate's reported noise is an upper bound); point sampling by more.
    assert!(
        rmse_f < 1.5 * footprint.rel_noise + 0.005,
        "footprint rel RMSE {rmse_f} vs noise {}",
        footprint.rel_noise
    );
    assert!(rmse_p > rmse_f, "point {rmse_p} vs footprint {rmse_f}");
}

#[test]
fn flat_shaded_footprint_and_point_references_agree_within_noise() {
    let scene = plane_scene(false);
    let footprint = reference(&scene, true, 64);
    let point = reference(&scene, false, 64);
    let (mut se, mut sq, mut n) = (0.0f64, 0.0f64, 0usize);
    for (f, p) in footprint.frame.rgba.iter().zip(&point.frame.rgba) {
        // Away from the horizon: pixels the plane covers entirely.
        if f[3] < 1.0 || p[3] < 1.0 {
            continue;
        }
        se += (f[0] as f64 - p[0] as f64).powi(2);
        sq += (p[0] as f64).powi(2);
        n += 1;
    }
    assert!(n > 500, "only {n} pixels");
    let rel = (se / sq).sqrt();
    // Two independent estimates of the same values: their difference has √2 × the noise.
    let expected = (footprint.rel_noise.powi(2) + point.rel_noise.powi(2)).sqrt();
    println!(
        "flat: footprint vs point rel RMSE {rel:.4}, combined noise {expected:.4} over {n} pixels"
    );
    assert!(rel < 1.3 * expected, "{rel} vs {expected}");
}
