//! Normal distribution mapping (Olano & North, issue 19) on lavapipe with validation on:
//! the specular term under naive MIP and NDF filtering against its footprint reference.

mod common;

use glam::Vec3;
use shvis::ndf::render::{NormalFilter, SpecularLight, render_specular, upload_maps};
use shvis::render::{FrameSettings, SceneGpu};
use shvis::scene::{Texture8, bumpy};
use shvis::study::ndf::{NdfStudySettings, run};
use shvis::technique::HwPath;

#[test]
fn a_constant_normal_map_shades_the_same_under_every_filter() {
    let ctx = common::validated_context();
    let mut scene = bumpy::build(64).unwrap();
    scene.material.normal = Texture8 {
        width: 16,
        height: 16,
        texels: vec![[150, 110, 240, 255]; 256],
    };
    let maps = shvis::ndf::build(&scene.material.normal, 1.0, 0.1);
    let gpu = SceneGpu::new(
        &ctx,
        &scene,
        &FrameSettings {
            width: 160,
            height: 90,
            flat_normals: false,
            float32_target: true,
            material_level0: false,
        },
    )
    .unwrap();
    let light = SpecularLight {
        direction: Vec3::new(0.0, 0.3, -1.0).normalize(),
        radiance: Vec3::ONE,
    };
    for path in [HwPath::Dx9, HwPath::Dx10] {
        let images = upload_maps(&ctx, &maps, path).unwrap();
        let frame =
            |filter| render_specular(&ctx, &gpu, &maps, &images, &light, filter, path, 1).unwrap();
        let mip = frame(NormalFilter::Mip);
        let peak = mip.rgba.iter().map(|p| p[0]).fold(0.0f32, f32::max);
        assert!(peak > 0.0, "the highlight is in view");
        for filter in [NormalFilter::Ndf, NormalFilter::NdfNormalized] {
            let other = frame(filter);
            let worst = mip
                .rgba
                .iter()
                .zip(&other.rgba)
                .map(|(a, b)| (a[0] - b[0]).abs())
                .fold(0.0f32, f32::max);
            // 8-bit normal decode vs exact moments: a few 1e-3 of the peak.
            assert!(
                worst <= 5e-3 * peak,
                "{filter:?} on {path}: {worst} of {peak}"
            );
        }
    }
    common::assert_validation_clean(&ctx, "ndf constant map");
}

#[test]
fn ndf_filtering_halves_the_minified_specular_error_and_keeps_its_energy() {
    let ctx = common::validated_context();
    let (study, _) = run(
        &ctx,
        &NdfStudySettings {
            sigma: 0.1,
            light_dir: Vec3::new(0.0, 0.3, -1.0),
            width: 480,
            height: 270,
            spp: 64,
            paths: vec![HwPath::Dx9, HwPath::Dx10],
            frames: 1,
        },
    )
    .unwrap();
    assert!(study.minified_pixels > 5000, "{}", study.minified_pixels);
    for path in [HwPath::Dx9, HwPath::Dx10] {
        let row = |f| {
            study
                .rows
                .iter()
                .find(|r| r.filter == f && r.path == path)
                .unwrap()
        };
        let (mip, ndf, ndfn) = (
            row(NormalFilter::Mip),
            row(NormalFilter::Ndf),
            row(NormalFilter::NdfNormalized),
        );
        eprintln!(
            "{path}: rel RMSE mip {:.3} ndf {:.3} ndfn {:.3}; energy mip {:.3} ndf {:.3} ndfn {:.3}",
            mip.rel_rmse_minified,
            ndf.rel_rmse_minified,
            ndfn.rel_rmse_minified,
            mip.energy_minified,
            ndf.energy_minified,
            ndfn.energy_minified
        );
        assert!(ndf.rel_rmse_minified <= 0.5 * mip.rel_rmse_minified);
        assert!(ndfn.rel_rmse_minified <= 0.5 * mip.rel_rmse_minified);
        assert!(
            (ndfn.energy_minified - 1.0).abs() <= 0.05,
            "{}",
            ndfn.energy_minified
        );
        assert!(
            (mip.energy_minified - 1.0).abs() > 0.2,
            "the naive filter's energy is off"
        );
    }
    common::assert_validation_clean(&ctx, "ndf study");
}
