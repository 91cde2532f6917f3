//! Every technique × path renders on the real device (lavapipe in CI) with the Khronos
//! validation layer on, and validation reports nothing: no error, no warning.

mod common;

use shvis::render::FrameSettings;
use shvis::technique::{HwPath, Technique};

#[test]
fn every_technique_and_path_is_validation_clean() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let settings = FrameSettings {
        width: 160,
        height: 100,
        flat_normals: false,
        ..FrameSettings::default()
    };
    for &id in Technique::all() {
        for &path in HwPath::ALL.iter().filter(|&&p| id.runs_on(p)) {
            let frame = common::render(&ctx, prepared, id, path, &settings);
            let covered = (0..frame.height)
                .flat_map(|y| (0..frame.width).map(move |x| (x, y)))
                .filter(|&(x, y)| frame.covered(x, y))
                .count();
            assert!(covered > 1000, "{id}.{path}: only {covered} pixels drawn");
            assert!(
                frame.rgba.iter().flatten().all(|c| c.is_finite()),
                "{id}.{path}: non-finite pixels"
            );
            assert_eq!(frame.ms.len(), 2, "{id}.{path}: two timed frames");
            assert!(
                frame.ms.iter().all(|&ms| ms > 0.0),
                "{id}.{path}: {:?}",
                frame.ms
            );
        }
    }
    // Teardown is validated too: leaked objects are reported by vkDestroyDevice.
    let counter = ctx.message_counter();
    drop(ctx);
    assert_eq!(counter.get(), (0, 0), "validation messages during teardown");
}

#[test]
fn teardown_and_context_creation_are_clean() {
    let ctx = common::validated_context();
    assert!(!ctx.device_name().is_empty());
    common::assert_validation_clean(&ctx, "context");
}

/// Frames timed several to a query (as on a fast GPU, `gpu::frame_timing`), forced here by a
/// span no lavapipe frame reaches: validation stays clean, every timed frame is reported as
/// a finite positive time, and the image drawn is the one drawn a frame to a query. How long
/// a frame takes is the bench's to measure (`shvis bench`), not a test's to assert.
#[test]
fn frames_timed_several_to_a_query_are_all_reported() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let settings = FrameSettings {
        width: 64,
        height: 40,
        ..FrameSettings::default()
    };
    let mut scene = shvis::render::SceneGpu::new(&ctx, &prepared.scene, &settings).unwrap();
    let technique: Technique = "preconv".parse().unwrap();
    let tech =
        shvis::technique::build(&ctx, &scene, technique, HwPath::Dx10, &prepared.inputs()).unwrap();
    let every_time_reported = |what: &str, ms: &[f64]| {
        assert_eq!(ms.len(), 5, "{what}: {ms:?}");
        assert!(
            ms.iter().all(|&t| t.is_finite() && t > 0.0),
            "{what}: {ms:?}"
        );
    };
    let alone = tech.render(&scene, 2, 5).unwrap();
    every_time_reported("a frame a query, rendered", &alone.ms);
    every_time_reported("a frame a query", &tech.time(&scene, 2, 5).unwrap());
    scene.set_min_query_span(1e6);
    let batched = tech.render(&scene, 2, 5).unwrap();
    every_time_reported("frames several to a query, rendered", &batched.ms);
    every_time_reported(
        "frames several to a query",
        &tech.time(&scene, 2, 5).unwrap(),
    );
    assert!(
        batched.rgba == alone.rgba,
        "the image drawn several frames to a query differs from the one drawn alone"
    );
    common::assert_validation_clean(&ctx, "batched timing");
}
