//! `shvis relight` (`shvis::relight`) on the test house: every dynamic technique
//! × path follows a rotating environment with validation clean across its table swaps
//! (blocking and overlapped uploads), a blocking rebuild every frame has no lag error and
//! one every other frame has, a frame whose data is current equals the static image,
//! shlmap is reported as static, and the animation has one frame per frame of the run.

mod common;

use std::path::Path;

use shvis::relight::{RelightSettings, UploadMode, run};
use shvis::technique::{HwPath, Technique};

fn settings(out: &Path, every: u32, upload: UploadMode) -> RelightSettings {
    RelightSettings {
        techniques: ["unc3", "pca4", "pca4w", "sh2", "preconv", "shlmap"]
            .iter()
            .map(|t| t.parse::<Technique>().expect("technique"))
            .collect(),
        paths: vec![HwPath::Dx9, HwPath::Dx10],
        frames: 4,
        every,
        upload,
        turns: 0.25,
        fade_to: None,
        samples: 2,
        width: 64,
        height: 40,
        ref_spp: 4,
        seed: 1,
        exposure: 0.0,
        out: out.to_path_buf(),
    }
}

#[test]
fn dynamic_techniques_follow_a_rotating_environment() {
    let ctx = common::validated_context();
    let prepared = common::house();
    // The last run also cross-fades to an overcast, uniform sky (time of day).
    let overcast = shvis::env::EnvMap::from_fn(64, 32, |_| [0.9, 0.95, 1.0]);
    let runs = [
        (1, UploadMode::Blocking, None),
        (2, UploadMode::Blocking, None),
        (1, UploadMode::Overlapped, Some(overcast)),
    ];
    for (every, upload, fade_to) in runs {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("relight-{every}-{upload}"));
        let _ = std::fs::remove_dir_all(&out);
        std::fs::create_dir_all(&out).expect("output folder");
        let faded = fade_to.is_some();
        let table = run(
            &ctx,
            prepared,
            &RelightSettings {
                fade_to,
                ..settings(&out, every, upload)
            },
        )
        .expect("relight runs");
        assert_eq!(table.faded, faded);
        common::assert_validation_clean(&ctx, &format!("relight every {every}, {upload}"));
        assert_eq!(
            table.static_only,
            vec![Technique::Shlmap(shvis::technique::Shlmap)]
        );
        assert_eq!(table.results.len(), 5 * 2);
        for row in &table.results {
            let label = format!("{}.{}", row.technique, row.path);
            // Rebuilds are due at frames K, 2K, … < 4 (frame 0's data comes with the build).
            let due = (4 - 1) / every;
            match upload {
                UploadMode::Blocking => {
                    assert_eq!(row.updates, due, "{label}");
                    assert_eq!(row.swap_latency_frames_median, Some(0.0), "{label}");
                }
                UploadMode::Overlapped => {
                    assert!(row.updates + row.skipped_updates <= due, "{label}: {row:?}");
                }
            }
            if row.updates > 0 {
                assert!(
                    row.cpu_build_ms_median.is_some_and(|ms| ms > 0.0),
                    "{label}"
                );
                assert!(row.upload_ms_median.is_some(), "{label}");
            }
            assert!(row.table_bytes > 0, "{label}");
            assert!(row.gpu_ms_median.is_some(), "{label}: timestamps");
            assert!(!row.sampled.is_empty(), "{label}");
            for f in &row.sampled {
                let (err, stat, lag) = (
                    f.rel_rmse.expect("error"),
                    f.static_rel_rmse.expect("static error"),
                    f.lag_rel_rmse.expect("lag error"),
                );
                assert!(err.is_finite() && stat > 0.0, "{label}: {f:?}");
                if f.lag_frames == 0 {
                    // The run's data was built for this very frame: the static image.
                    assert!(lag < 1e-6 && (err - stat).abs() < 1e-6, "{label}: {f:?}");
                } else {
                    assert!(lag > 0.0, "{label}: {f:?}");
                }
            }
            // One animation frame per frame of the run.
            let file = std::fs::File::open(out.join(format!("{label}.apng.png"))).expect("apng");
            let reader = png::Decoder::new(std::io::BufReader::new(file))
                .read_info()
                .expect("a PNG");
            let frames = reader.info().animation_control().map(|a| a.num_frames);
            assert_eq!(frames, Some(4), "{label}");
        }
        if every == 2 && upload == UploadMode::Blocking {
            assert!(
                table
                    .results
                    .iter()
                    .flat_map(|r| &r.sampled)
                    .any(|f| f.lag_frames > 0)
            );
        }
    }
}
