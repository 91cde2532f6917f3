//! Normal distribution mapping (Olano & North) on lavapipe with validation on:
//! the specular term under naive MIP and NDF filtering against its footprint reference.

mod common;

use glam::Vec3;
use shvis::render::specular::{NormalFilter, SpecularLight, render_specular, upload_maps};
use shvis::render::{FrameSettings, SceneGpu};
use shvis::scene::{Texture8, bumpy};
use shvis::study::ndf::{NdfStudySettings, SpecularScene, run};
use shvis::technique::HwPath;

/// The receding bumpy plane prepared at a small lightmap (the diffuse and `--specular` tests).
fn bumpy_prepared() -> shvis::prepare::Prepared {
    shvis::prepare::prepare(&shvis::prepare::PrepareSettings {
        scene: "bumpy".into(),
        vis_res: 64,
        ..shvis::prepare::PrepareSettings::default()
    })
    .unwrap()
}

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

/// On the receding bumpy plane (isotropic bumps) and on the wavy sphere (parallel ripples,
/// where the highlight must elongate): NDF filtering at least halves the minified specular
/// error of naive MIP filtering on both paths, and the per-texel normalisation keeps the
/// highlight's energy within 5 %.
#[test]
fn ndf_filtering_halves_the_minified_specular_error_and_keeps_its_energy() {
    let ctx = common::validated_context();
    for scene in SpecularScene::ALL {
        let (study, _) = run(
            &ctx,
            &NdfStudySettings {
                scene,
                sigma: 0.1,
                light_dir: match scene {
                    SpecularScene::Bumpy => Vec3::new(0.0, 0.3, -1.0),
                    SpecularScene::Wavy => shvis::scene::wavy::light_dir(),
                },
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
                "{} {path}: rel RMSE mip {:.3} ndf {:.3} ndfn {:.3}; energy mip {:.3} ndf {:.3} ndfn {:.3}",
                scene.name(),
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
            if scene == SpecularScene::Bumpy {
                assert!(
                    (mip.energy_minified - 1.0).abs() > 0.2,
                    "the naive filter's energy is off"
                );
            }
        }
    }
    common::assert_validation_clean(&ctx, "ndf study");
}

/// The diffuse NDF variants (`unc6ndf`, `preconvndf`) on both paths: where the normal map
/// is magnified they give the unfiltered image (the filter's weight is 0); where it is
/// minified the mean over the plane moves to the technique's own footprint truth — for
/// preconv all the way (the order-3 expectation is exact), for unc6 most of it (the
/// isotropic vMF fit).
#[test]
fn diffuse_ndf_variants_change_nothing_magnified_and_follow_the_footprint_minified() {
    use shvis::render::specular::normal_map_lod;
    use shvis::study::ndf_diffuse::own_footprint;
    use shvis::technique::{self, NdfBase, Technique};

    let ctx = common::validated_context();
    let mut prepared = bumpy_prepared();
    let bases = [
        NdfBase::Unc {
            order: shvis::sh::Order::SIX,
        },
        NdfBase::Preconv,
    ];
    let all: Vec<Technique> = bases
        .iter()
        .flat_map(|&b| {
            [
                b.technique(),
                Technique::Ndf(shvis::technique::Ndf { base: b }),
            ]
        })
        .collect();
    prepared.prepare_techniques(&all).unwrap();
    let receding = prepared.scene.camera;
    let mut overhead = receding;
    overhead.position = Vec3::new(0.0, 0.2, -10.0);
    overhead.target = Vec3::new(0.0, 0.0, -10.0);
    overhead.up = Vec3::NEG_Z;
    let settings = |level0| FrameSettings {
        width: 160,
        height: 90,
        material_level0: level0,
        ..FrameSettings::default()
    };
    for (camera, magnified) in [(overhead, true), (receding, false)] {
        prepared.scene.camera = camera;
        let gpu = SceneGpu::new(&ctx, &prepared.scene, &settings(false)).unwrap();
        let mut level0 = SceneGpu::new(&ctx, &prepared.scene, &settings(true)).unwrap();
        let lod = normal_map_lod(&ctx, &gpu).unwrap();
        let mask: Vec<bool> = lod
            .iter()
            .map(|l| l.is_some_and(|l| if magnified { l <= 0.0 } else { l >= 2.0 }))
            .collect();
        let selected = mask.iter().filter(|&&m| m).count();
        assert!(selected > 1000, "magnified {magnified}: {selected} pixels");
        let inputs = prepared.inputs();
        for &base in &bases {
            for path in [HwPath::Dx9, HwPath::Dx10] {
                let render = |t| {
                    technique::build(&ctx, &gpu, t, path, &inputs)
                        .unwrap()
                        .render(&gpu, 0, 1)
                        .unwrap()
                };
                let plain = render(base.technique());
                let filtered = render(Technique::Ndf(shvis::technique::Ndf { base }));
                let label = format!("{}.{path}", base.technique());
                let mean = |f: &shvis::render::Frame| {
                    let sum: f64 = (0..mask.len())
                        .filter(|&i| mask[i])
                        .map(|i| f64::from(f.rgba[i][1]))
                        .sum();
                    sum / selected as f64
                };
                if magnified {
                    let peak = plain.rgba.iter().map(|p| p[1]).fold(0.0f32, f32::max);
                    let worst = (0..mask.len())
                        .filter(|&i| mask[i])
                        .flat_map(|i| (0..3).map(move |c| (i, c)))
                        .map(|(i, c)| (plain.rgba[i][c] - filtered.rgba[i][c]).abs())
                        .fold(0.0f32, f32::max);
                    assert!(peak > 0.0, "{label}: lit");
                    assert!(
                        worst <= 1e-5 * peak,
                        "{label}: magnified change {worst} of {peak}"
                    );
                } else {
                    let tech =
                        technique::build(&ctx, &level0, base.technique(), path, &inputs).unwrap();
                    let truth = own_footprint(&mut level0, &tech, 8).unwrap();
                    let (before, after) = (
                        (mean(&plain) - mean(&truth)).abs(),
                        (mean(&filtered) - mean(&truth)).abs(),
                    );
                    let bound = match base {
                        NdfBase::Preconv => 0.2,
                        NdfBase::Unc { .. } => 0.6,
                    };
                    assert!(
                        before > 0.01 * mean(&truth) && after <= bound * before,
                        "{label}: |mean − own footprint| {before} unfiltered, {after} with the NDF"
                    );
                }
            }
        }
    }
    common::assert_validation_clean(&ctx, "diffuse NDF variants");
}

/// `--specular` as a material term of the cost-table techniques: a technique built on a
/// scene with the term renders its own image plus exactly the standalone specular pass of
/// the same filtering (to the f16 target's rounding), on both paths — for a per-texel
/// technique (preconv), a table technique (unc6 on dx10; on dx9 its 14 textures plus the
/// three moment maps break the 16-texture rule, which must be refused) and the per-vertex
/// one (pca12v, its own vertex stage).
#[test]
fn the_specular_term_adds_the_standalone_pass_to_every_technique() {
    use shvis::render::specular::SpecularTerm;
    use shvis::technique::{self, Technique, TechniqueError};

    let ctx = common::validated_context();
    let mut prepared = bumpy_prepared();
    let techniques: Vec<Technique> = ["preconv", "unc6", "pca12v"]
        .iter()
        .map(|t| t.parse().unwrap())
        .collect();
    prepared.prepare_techniques(&techniques).unwrap();
    let light = SpecularLight {
        direction: Vec3::new(0.0, 0.3, -1.0).normalize(),
        radiance: Vec3::splat(0.5),
    };
    let settings = FrameSettings {
        width: 160,
        height: 90,
        ..FrameSettings::default()
    };
    let plain = SceneGpu::new(&ctx, &prepared.scene, &settings).unwrap();
    let standalone = SceneGpu::new(
        &ctx,
        &prepared.scene,
        &FrameSettings {
            float32_target: true,
            ..settings
        },
    )
    .unwrap();
    let maps = shvis::ndf::build(&prepared.scene.material.normal, 1.0, 0.1);
    let inputs = prepared.inputs();
    for filter in NormalFilter::ALL {
        let mut with_term = SceneGpu::new(&ctx, &prepared.scene, &settings).unwrap();
        let term = SpecularTerm {
            filter,
            light,
            sigma: 0.1,
        };
        with_term.add_specular(&ctx, &prepared.scene, term).unwrap();
        for path in [HwPath::Dx9, HwPath::Dx10] {
            let images = upload_maps(&ctx, &maps, path).unwrap();
            let specular =
                render_specular(&ctx, &standalone, &maps, &images, &light, filter, path, 1)
                    .unwrap();
            let peak = specular.rgba.iter().map(|p| p[0]).fold(0.0f32, f32::max);
            assert!(peak > 0.1, "{filter:?}: the highlight is in view ({peak})");
            for &t in &techniques {
                let built = technique::build(&ctx, &with_term, t, path, &inputs);
                if t.name() == "unc6" && path == HwPath::Dx9 && filter != NormalFilter::Mip {
                    assert!(
                        matches!(built, Err(TechniqueError::Dx9Rule { .. })),
                        "unc6.dx9 with the moment maps must break the texture rule"
                    );
                    continue;
                }
                let built = built.unwrap();
                let extra = filter.extra_lookups();
                let base = technique::build(&ctx, &plain, t, path, &inputs).unwrap();
                assert_eq!(
                    built.stats.lookups_per_pixel,
                    base.stats.lookups_per_pixel + extra,
                    "{t}.{path}"
                );
                let sum = built.render(&with_term, 0, 1).unwrap();
                let diffuse = base.render(&plain, 0, 1).unwrap();
                let mut worst = 0.0f32;
                for i in 0..sum.rgba.len() {
                    for c in 0..3 {
                        let expected = diffuse.rgba[i][c] + specular.rgba[i][c];
                        let err = (sum.rgba[i][c] - expected).abs() / expected.abs().max(1.0);
                        worst = worst.max(err);
                    }
                }
                // f16 targets: 2⁻¹⁰ relative per image, two images rounded.
                assert!(worst <= 4e-3, "{t}.{path} {filter:?}: {worst}");
            }
        }
    }
    common::assert_validation_clean(&ctx, "specular term in the techniques");
}

/// The bench with `--specular mip,ndf,ndfn` on the receding plane: one row per technique ×
/// path × filtering, and the NDF rows' error against the reference with the specular
/// footprint reference summed in well under the naive MIP rows'.
#[test]
fn the_bench_measures_the_specular_filterings_side_by_side() {
    use shvis::bench::{BenchSettings, SpecularSettings, run};
    use shvis::technique::Technique;

    let ctx = common::validated_context();
    let mut prepared = bumpy_prepared();
    let preconv: Technique = "preconv".parse().unwrap();
    prepared.prepare_techniques(&[preconv]).unwrap();
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("ndf-specular-bench");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let table = run(
        &ctx,
        &prepared,
        &BenchSettings {
            techniques: vec![preconv],
            paths: vec![HwPath::Dx9, HwPath::Dx10],
            frames: 1,
            warmup: 0,
            width: 320,
            height: 180,
            exposure: 0.0,
            ref_spp: 16,
            bounces: 0,
            footprint_reference: true,
            seed: 3,
            specular: Some(SpecularSettings {
                filters: NormalFilter::ALL.to_vec(),
                light: SpecularLight {
                    direction: Vec3::new(0.0, 0.3, -1.0).normalize(),
                    radiance: Vec3::splat(0.5),
                },
                sigma: 0.1,
            }),
            out: out.clone(),
            probe: false,
            probe_fresh: false,
            probe_frames: 5,
            relight_degrees: None,
            ladder: true,
            ladder_stride: 1,
            dx11_rows: None,
        },
    )
    .unwrap();
    assert_eq!(table.results.len(), 6);
    for path in [HwPath::Dx9, HwPath::Dx10] {
        let error = |f| {
            table
                .results
                .iter()
                .find(|r| r.path == path && r.specular == Some(f))
                .and_then(|r| r.rel_rmse)
                .unwrap()
        };
        let (mip, ndf) = (error(NormalFilter::Mip), error(NormalFilter::Ndf));
        eprintln!("{path}: preconv+specmip {mip:.4}, +specndf {ndf:.4}");
        assert!(ndf < 0.6 * mip, "{path}: {ndf} vs {mip}");
    }
    assert!(out.join("preconv.dx10.specndf.exr").exists());
    common::assert_validation_clean(&ctx, "bench with the specular term");
}
