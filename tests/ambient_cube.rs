//! The ambient cube (`acube`, `acubels`; `technique::ambient_cube`): on every path the
//! drawn shader reproduces the Rust evaluation of the same stored values (the error
//! ladder's last CPU rung: the f16 lightmap texels, on dx11 the decoded blocks), and both
//! fits meet the bounced reference of the test house as the other lightmap bases do.

mod common;

use shvis::attribution::{LadderPixels, cpu_rungs};
use shvis::report::metrics::image_error;
use shvis::report::table::AttributionKind;
use shvis::technique::{HwPath, Technique};

#[test]
fn both_fits_draw_their_cpu_evaluation_and_meet_the_bounced_reference_on_every_path() {
    let ctx = common::validated_context();
    let (reference, settings) = common::house_reference(&ctx);
    let bounced = reference.bounced.as_ref().expect("a bounced reference");
    let prepared = common::house();
    let pixels = LadderPixels::new(&ctx, prepared, settings.width, settings.height, 1)
        .expect("the ladder's pixels");
    for name in ["acube", "acubels"] {
        let technique: Technique = name.parse().expect("an ambient cube name");
        assert_eq!(technique.name(), name);
        let mut errors = Vec::new();
        for &path in HwPath::ALL {
            let frame = common::render(&ctx, prepared, technique, path, &settings);
            let error = image_error(&frame, &bounced.frame).unwrap().rel_rmse;
            let rungs = cpu_rungs(&pixels, prepared, technique, path).expect("its ladder");
            let steps: Vec<AttributionKind> = rungs.iter().map(|r| r.step).collect();
            let last = rungs.last().expect("CPU rungs");
            let want = match path {
                HwPath::Dx11 => AttributionKind::BlockCompression,
                HwPath::Dx9 | HwPath::Dx10 => AttributionKind::LightmapTexels,
            };
            assert_eq!(last.step, want, "{technique}.{path}: {steps:?}");
            // The shader against the Rust evaluation of the same stored values: f32 shading
            // and the f16 target apart, the same image (a wrong face order or sign reads
            // as tens of percent); dx11's 8-bit BC7 ratios come back from lavapipe's filter
            // about one 8-bit step off, as pca's RGBA8 weights do.
            let shader = image_error(&frame, &last.frame).unwrap().rel_rmse;
            let tolerance = match path {
                HwPath::Dx11 => 5e-3,
                HwPath::Dx9 | HwPath::Dx10 => 2e-3,
            };
            println!(
                "{technique}.{path}: {error:.4} against the bounced reference, {shader:.2e} against its CPU rung"
            );
            assert!(
                shader < tolerance,
                "{technique}.{path}: {shader} from its CPU rung"
            );
            assert!(error < 0.4, "{technique}.{path}: {error}");
            errors.push(error);
        }
        assert!(
            (errors[0] - errors[1]).abs() < 0.01,
            "{technique}: dx9 vs dx10 {errors:?}"
        );
        assert!(
            (errors[2] - errors[1]).abs() < 0.02,
            "{technique}: dx11 vs dx10 {errors:?}"
        );
    }
    common::assert_validation_clean(&ctx, "ambient cube");
}
