//! The normal-mapping-for-PRT techniques (`technique::nmprt`)
//! against what they must equal — with the lighting fixed, `nmprt` renders `shlmap`'s
//! image of the same bake (f16 on the GPU, both paths, validation on); with zero bounces
//! its irradiance is unc6's direct lighting of the same rays (lighting band-limited so the
//! two products are exact: the clamped-cosine truncation is their only approximation, and
//! it is the same); the normal basis with all nine vectors is the full evaluation in f64,
//! through the tangent-frame change.

mod common;

use std::sync::Arc;

use glam::DVec3;
use shvis::bake::lxh::LxhMatrices;
use shvis::bake::raster::rasterize;
use shvis::bake::shlmap::{BakeLighting, ShLightmapSettings, bake_sh_lightmap};
use shvis::bake::trace::Tracer;
use shvis::bake::transfer::{DEFAULT_LIGHTING_ORDER, TransferSettings, bake_transfer};
use shvis::env::project::project_sh;
use shvis::env::sky::{SkyParams, sky};
use shvis::render::{Frame, FrameSettings, SceneGpu};
use shvis::sh::Order;
use shvis::sh::zonal::irradiance_from_radiance;
use shvis::technique::nmprt::{NmprtRecipe, convolved_basis};
use shvis::technique::{self, HwPath, Inputs, NmprtVariant, Technique};

/// The built-in sky without its sun, to `order`: directional, and its bounce irradiance
/// stays positive (the SH lightmap's clamp never acts, `bake::transfer`).
fn smooth_sky(order: Order) -> Vec<[f64; 3]> {
    let smooth = SkyParams {
        sun_radiance: 0.0,
        ..SkyParams::default()
    };
    project_sh(&sky(256, &smooth), order)
}

/// A validated context and the test house on the GPU at 160×100.
fn gpu_house(prepared: &shvis::prepare::Prepared) -> (Arc<shvis::gpu::Context>, SceneGpu) {
    let ctx = common::validated_context();
    let frame = FrameSettings {
        width: 160,
        height: 100,
        ..FrameSettings::default()
    };
    let scene = SceneGpu::new(&ctx, &prepared.scene, &frame).expect("scene");
    (ctx, scene)
}

/// Over `want`'s covered pixels: the largest |got − want| of a channel, the largest
/// channel of `want`, and the channels compared.
fn max_difference(got: &Frame, want: &Frame) -> (f32, f32, usize) {
    let (mut worst, mut largest, mut count) = (0.0f32, 0.0f32, 0usize);
    for (a, b) in got.rgba.iter().zip(&want.rgba) {
        if b[3] > 0.5 {
            for c in 0..3 {
                worst = worst.max((a[c] - b[c]).abs());
                largest = largest.max(b[c]);
                count += 1;
            }
        }
    }
    (worst, largest, count)
}

#[test]
fn nmprt_renders_the_sh_lightmap_of_the_same_bake_on_both_paths() {
    let prepared = common::house();
    let transfer = prepared.transfer.as_ref().expect("the test house bakes M");
    let settings = &prepared.visibility_settings;
    let texels = rasterize(&prepared.scene.mesh, prepared.visibility.res);
    let tracer = Tracer::new(&prepared.scene.mesh);
    let l = smooth_sky(DEFAULT_LIGHTING_ORDER);
    let shl = bake_sh_lightmap(
        &prepared.scene,
        &tracer,
        &texels,
        &BakeLighting::Sh(&l),
        &ShLightmapSettings {
            rays: settings.rays,
            seed: settings.seed,
            bounces: transfer.bounces,
            progress: false,
        },
        &[],
    );
    let irradiance = irradiance_from_radiance(&l[..9], Order::THREE);
    let inputs = Inputs {
        radiance_sh: &l,
        irradiance_sh: &irradiance,
        sh_lightmap: Some(&shl),
        ..prepared.inputs()
    };
    let (ctx, scene) = gpu_house(prepared);
    let nmprt = Technique::Nmprt(shvis::technique::Nmprt {
        variant: NmprtVariant::Full,
    });
    for &path in HwPath::ALL.iter().filter(|&&p| nmprt.runs_on(p)) {
        let render = |t: Technique| {
            technique::build(&ctx, &scene, t, path, &inputs)
                .expect("builds")
                .render(&scene, 0, 1)
                .expect("renders")
        };
        let want = render(Technique::Shlmap(shvis::technique::Shlmap));
        let got = render(Technique::Nmprt(shvis::technique::Nmprt {
            variant: NmprtVariant::Full,
        }));
        let (worst, largest, lit) = max_difference(&got, &want);
        println!("{path}: {lit} channels, max |nmprt − shlmap| = {worst:.3e} of max {largest:.3}");
        assert!(lit > 3000 && largest > 0.0);
        // Both store the same values in f16 and write an f16 target: a few f16 steps.
        assert!(
            worst <= 4e-3 * largest,
            "{path}: nmprt differs from shlmap by {worst} (max {largest})"
        );
    }
    common::assert_validation_clean(&ctx, "nmprt and shlmap");
}

#[test]
fn unbounced_nmprt_is_unc6_direct_lighting_of_the_same_rays() {
    let prepared = common::house();
    let vis = &prepared.visibility;
    let settings = &prepared.visibility_settings;
    let texels = rasterize(&prepared.scene.mesh, vis.res);
    let tracer = Tracer::new(&prepared.scene.mesh);
    let transfer = bake_transfer(
        &prepared.scene,
        &tracer,
        &texels,
        &TransferSettings {
            lighting_order: DEFAULT_LIGHTING_ORDER,
            rays: settings.rays,
            seed: settings.seed,
            bounces: 0,
            progress: false,
        },
    );
    // Lighting of order 3: L·H₃ is of order 5 < 6, so unc6's product and visibility
    // truncations are exact and both sum L·H₃ over the same unoccluded rays.
    let mut l = smooth_sky(Order::new(8).unwrap());
    l[9..].iter_mut().for_each(|c| *c = [0.0; 3]);
    let lxh = LxhMatrices::new(&l, Order::SIX, Order::THREE);
    let n2 = Order::SIX.coeff_count();
    let stride = vis.order.coeff_count();
    let (mut worst, mut scale, mut compared) = (0.0f64, 0.0f64, 0usize);
    for t in (0..texels.covered.len()).filter(|&t| texels.covered[t]) {
        let n = texels.normal[t].as_dvec3().normalize();
        let transferred = transfer.transferred(t, &l);
        let a = convolved_basis(n);
        let v: Vec<f64> = vis.coeffs[t * stride..t * stride + n2]
            .iter()
            .map(|&x| f64::from(x))
            .collect();
        let unc = lxh.shade(n, &v);
        for c in 0..3 {
            let e: f64 = (0..9).map(|j| a[j] * transferred[j][c]).sum();
            worst = worst.max((e - unc[c]).abs());
            scale = scale.max(unc[c].abs());
        }
        compared += 1;
    }
    println!("{compared} texels: max |nmprt(0 bounces) − unc6| = {worst:.3e} of {scale:.3}");
    assert!(compared > 1000);
    // f32 storage of M and V: relative 1e-6 of the summands.
    assert!(worst <= 1e-5 * scale, "{worst} of {scale}");
}

#[test]
fn nine_singular_vectors_are_the_full_evaluation_at_normal_mapped_normals() {
    let prepared = common::house();
    let transfer: &Arc<_> = prepared.transfer.as_ref().expect("the test house bakes M");
    let l = &prepared.radiance_sh;
    let irradiance = &prepared.irradiance_sh;
    let svd = NmprtRecipe::new(NmprtVariant::Svd { m: 9 }, transfer.clone());
    let full = NmprtRecipe::new(NmprtVariant::Full, transfer.clone());
    let normals = [
        DVec3::Z,
        DVec3::new(0.4, -0.3, 0.866).normalize(),
        DVec3::new(-0.7, 0.5, 0.3).normalize(),
    ];
    let (mut worst, mut scale, mut compared) = (0.0f64, 0.0f64, 0usize);
    for t in (0..transfer.covered.len())
        .filter(|&t| transfer.covered[t])
        .step_by(7)
    {
        let c = svd.texel_values(t, l, irradiance);
        let world = full.texel_values(t, l, irradiance);
        // The frame as `nmprt::to_tangent` takes it: re-orthonormalized in f64, its
        // handedness kept.
        let [tg, bt, ns] = transfer.frames[t].map(|v| v.as_dvec3());
        let ns = ns.normalize();
        let tg = (tg - ns * ns.dot(tg)).normalize();
        let bt = ns.cross(tg) * tg.cross(bt).dot(ns).signum();
        for n in normals {
            let a_world = convolved_basis(tg * n.x + bt * n.y + ns * n.z);
            for ch in 0..3 {
                let want: f64 = (0..9).map(|j| a_world[j] * world[3 * j + ch]).sum();
                let got: f64 = (0..9)
                    .map(|m| svd.basis.basis_value(m, n) * c[3 * m + ch])
                    .sum();
                worst = worst.max((got - want).abs());
                scale = scale.max(want.abs());
            }
        }
        compared += 1;
    }
    println!("{compared} texels × 3 normals: max |svd9 − full| = {worst:.3e} of {scale:.3}");
    assert!(compared > 100);
    assert!(worst <= 1e-9 * scale, "{worst} of {scale}");
}

/// `nmprtsvd4p`, the course's pixel shader (per-texel V_MᵀRM, l in uniforms, the product
/// per pixel), renders what `nmprtsvd4` (the same product formed per texel on the CPU)
/// renders, to f16 storage of the two; dx9 refuses it by its texture count.
#[test]
fn the_pixel_shader_form_renders_the_per_texel_form() {
    let prepared = common::house();
    let (ctx, scene) = gpu_house(prepared);
    let inputs = prepared.inputs();
    let render = |t: &str, path: HwPath| {
        technique::build(&ctx, &scene, t.parse().unwrap(), path, &inputs)
            .expect("builds")
            .render(&scene, 0, 1)
            .expect("renders")
    };
    let want = render("nmprtsvd4", HwPath::Dx10);
    let got = render("nmprtsvd4p", HwPath::Dx10);
    let (worst, largest, count) = max_difference(&got, &want);
    println!("nmprtsvd4p against nmprtsvd4: max {worst:.3e} of max {largest:.3}");
    assert!(count > 3000 && largest > 0.0);
    // 256 f16 matrix entries times the lighting against 12 f16 values: a few 1e-3.
    assert!(worst <= 1e-2 * largest, "{worst} of {largest}");
    let technique: Technique = "nmprtsvd4p".parse().unwrap();
    assert!(!technique.runs_on(HwPath::Dx9) && technique.runs_on(HwPath::Dx10));
    assert_eq!(
        technique.form_on(HwPath::Dx9),
        Err(technique::Refusal::Dx9Textures)
    );
    // The build refuses it by its form, before any upload.
    match technique::build(&ctx, &scene, technique, HwPath::Dx9, &inputs) {
        Err(e) => {
            let e = e.to_string();
            let why = technique::Refusal::Dx9Textures.to_string();
            assert!(
                e.contains("cannot run on dx9") && e.contains(&why),
                "dx9: {e}"
            );
        }
        Ok(_) => panic!("dx9: built with more than 16 textures"),
    }
    common::assert_validation_clean(&ctx, "nmprtsvd4p");
}

/// The normal basis `nmprtsvdM` binds captures, vector by vector, the energy the
/// `nmprt-svd` study finds for the course's cosine-weighted A over the sphere.
#[test]
fn the_normal_basis_captures_the_energy_the_study_finds() {
    use shvis::study::nmprt_svd::{NormalWeighting, energy_captured, normal_matrix_over};
    let basis = shvis::technique::nmprt::NormalBasis::new(16);
    let a = normal_matrix_over(16, 96, NormalWeighting::Cosine, false);
    let study = energy_captured(&a);
    for m in 1..=9 {
        assert!(
            (basis.energy(m) - study[m - 1]).abs() < 2e-3,
            "M = {m}: {} against the study's {}",
            basis.energy(m),
            study[m - 1]
        );
    }
}
