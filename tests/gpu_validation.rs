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
    for &id in Technique::ALL {
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
