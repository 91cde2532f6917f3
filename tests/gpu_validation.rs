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
/// span no lavapipe frame reaches: validation stays clean, every timed frame is reported,
/// and a frame's time is the query's span over its draws — of the order of a frame timed
/// alone, not of 64 of them.
#[test]
fn frames_timed_several_to_a_query_are_per_frame_times() {
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
    let alone = tech.time(&scene, 2, 5).unwrap();
    scene.set_min_query_span(1e6);
    let batched = tech.time(&scene, 2, 5).unwrap();
    assert_eq!(batched.len(), 5, "{batched:?}");
    // The fastest frame of each: the other test of this binary renders on the same two
    // cores, and a median of five can catch its load on one side only.
    let fastest = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    let (a, b) = (fastest(&alone), fastest(&batched));
    // 64 frames a query: a query's span undivided would be ≈ 64× a frame.
    assert!(
        b > a / 8.0 && b < a * 8.0,
        "a frame alone {a} ms, in queries of many {b} ms"
    );
    common::assert_validation_clean(&ctx, "batched timing");
}
