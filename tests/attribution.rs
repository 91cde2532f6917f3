//! The error attribution ladder of the bench (`shvis::attribution`): on the test
//! house, every row's rungs go from the footprint reference to the technique's own bench
//! image, every rung's image is written at the ladder's grid (every 2nd pixel) and is the
//! image its error was measured on (the frame-sized images picked at that grid), the
//! visibility-truncation rung falls towards order 6, and the last CPU rung meets the GPU
//! at f16 level (8-bit weights: see the bound below). Real Vulkan on lavapipe with validation on.

mod common;

use std::path::Path;

use shvis::bench::{BenchSettings, run};
use shvis::report::LADDER_DIR;
use shvis::report::table::{AttributionKind, BenchRow};
use shvis::technique::{HwPath, Technique};

/// RGBA of an EXR file, as f32.
fn read_exr(path: &Path) -> (usize, Vec<[f32; 4]>) {
    use exr::prelude::read_first_rgba_layer_from_file;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| {
            (
                size.width(),
                vec![[0.0f32; 4]; size.width() * size.height()],
            )
        },
        |(w, px): &mut (usize, Vec<[f32; 4]>), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b, a];
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.layer_data.channel_data.pixels
}

/// Relative RMSE of `test` against `reference` over pixels covered in both.
fn rel_rmse(test: &[[f32; 4]], reference: &[[f32; 4]]) -> f64 {
    let (mut se, mut sq) = (0.0f64, 0.0f64);
    for (t, r) in test.iter().zip(reference) {
        if t[3] < 0.5 || r[3] < 0.5 {
            continue;
        }
        for c in 0..3 {
            se += (f64::from(t[c]) - f64::from(r[c])).powi(2);
            sq += f64::from(r[c]).powi(2);
        }
    }
    (se / sq).sqrt()
}

/// The ladder's grid in the bench below: every 2nd pixel of its 160 × 100 frames.
const LADDER_STRIDE: u32 = 2;
const FRAME_WIDTH: usize = 160;

/// A frame-sized image at the ladder's grid (every [`LADDER_STRIDE`]-th pixel in each
/// direction); a ladder rung as it is.
fn at_grid((width, pixels): (usize, Vec<[f32; 4]>)) -> Vec<[f32; 4]> {
    if width != FRAME_WIDTH {
        assert_eq!(
            width,
            FRAME_WIDTH / LADDER_STRIDE as usize,
            "a rung's width"
        );
        return pixels;
    }
    let s = LADDER_STRIDE as usize;
    pixels
        .chunks(width)
        .step_by(s)
        .flat_map(|row| row.iter().step_by(s).copied())
        .collect()
}

fn step(row: &BenchRow, kind: AttributionKind) -> f64 {
    row.attribution
        .iter()
        .find(|s| s.step == kind)
        .and_then(|s| s.rel_rmse)
        .unwrap_or_else(|| panic!("{} {}: no {kind:?} rung", row.technique, row.path))
}

#[test]
fn ladders_telescope_from_the_reference_to_the_bench_image() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let out_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("attribution-bench");
    let _ = std::fs::remove_dir_all(&out_dir);
    std::fs::create_dir_all(&out_dir).expect("output folder");
    let techniques: Vec<Technique> = [
        "unc3", "unc4", "unc6", "pca16", "pca16w", "preconv", "sh2", "shlmap", "l1geo", "zh3",
        "hb6", "dice",
    ]
    .iter()
    .map(|t| t.parse().expect("technique name"))
    .collect();
    let table = run(
        &ctx,
        prepared,
        &BenchSettings {
            techniques: techniques.clone(),
            paths: vec![HwPath::Dx9, HwPath::Dx10],
            frames: 1,
            warmup: 0,
            width: FRAME_WIDTH as u32,
            height: 100,
            exposure: 0.0,
            ref_spp: 16,
            bounces: shvis::bake::shlmap::DEFAULT_BOUNCES,
            footprint_reference: true,
            seed: 5,
            specular: None,
            out: out_dir.clone(),
            probe: false,
            probe_fresh: false,
            probe_frames: 5,
            relight_degrees: None,
            ladder: true,
            ladder_stride: LADDER_STRIDE,
            dx11_rows: None,
        },
    )
    .expect("bench runs");
    common::assert_validation_clean(&ctx, "bench with the error ladder");
    eprintln!("{}", table.to_markdown());
    assert_eq!(table.results.len(), techniques.len() * 2);

    for row in &table.results {
        let label = format!("{}.{}", row.technique, row.path);
        let steps = &row.attribution;
        // Footprint → point first; the GPU image last, and it is the bench's own output.
        assert_eq!(steps[0].step, AttributionKind::PixelFootprint, "{label}");
        let last = steps.last().expect("rungs");
        assert_eq!(last.image, format!("{label}.exr"), "{label}");
        assert_eq!(last.step, AttributionKind::Gpu, "{label}");
        assert!(steps.len() >= 4, "{label}: {steps:?}");
        assert!(
            steps[1..steps.len() - 1]
                .iter()
                .all(|s| s.image.starts_with(LADDER_DIR)),
            "{label}: {steps:?}"
        );
        // Every rung's image exists, and the errors were measured on those images: the
        // ladder starts at the reference the row is measured against.
        let start = match row.reference {
            shvis::report::table::RowReference::Bounced(n) => format!("reference_bounces{n}.exr"),
            _ => "reference.exr".to_string(),
        };
        let mut previous = at_grid(read_exr(&out_dir.join(&start)));
        for s in steps {
            let path = out_dir.join(&s.image);
            let png = path.with_extension("png");
            assert!(png.is_file(), "{}", png.display());
            let image = read_exr(&path);
            if s.image.starts_with(LADDER_DIR) {
                assert_eq!(
                    image.0,
                    FRAME_WIDTH / LADDER_STRIDE as usize,
                    "{label}: {s:?}"
                );
            }
            let image = at_grid(image);
            let measured = s.rel_rmse.expect("rung error");
            let recomputed = rel_rmse(&image, &previous);
            // Ladder images are stored in f16: ≲ 5e-4 relative per image.
            assert!(
                (recomputed - measured).abs() <= 1.5e-3 + 0.01 * measured,
                "{label} {:?}: {recomputed} from the files, {measured} in the table",
                s.step
            );
            previous = image;
        }
        // The last CPU rung meets the GPU at f16 level: f16 textures ≲ 2e-3; pca's RGBA8
        // weights come back from lavapipe's filter about one 8-bit step off (≈ 3e-3, README).
        let gpu = step(row, AttributionKind::Gpu);
        let bound = match row.technique {
            Technique::Pca(shvis::technique::Pca { .. }) => 5e-3,
            _ => 2e-3,
        };
        assert!(gpu <= bound, "{label}: CPU → GPU {gpu}");
    }

    let row = |name: &str, path: HwPath| {
        let t: Technique = name.parse().unwrap();
        table
            .results
            .iter()
            .find(|r| r.technique == t && r.path == path)
            .expect("row")
    };
    for path in [HwPath::Dx9, HwPath::Dx10] {
        // Visibility truncation falls towards order 6; the rungs before it are shared.
        let vis = |t: &str| step(row(t, path), AttributionKind::VisibilityOrder);
        assert!(
            vis("unc6") < vis("unc4") && vis("unc6") < vis("unc3"),
            "{path}: {} {} {}",
            vis("unc3"),
            vis("unc4"),
            vis("unc6")
        );
        assert_eq!(vis("unc6"), vis("pca16"));
        // PCA adds its compression step; the weights-only variant has no table rung.
        assert!(step(row("pca16", path), AttributionKind::PcaCompression) > 0.0);
        assert!(
            row("pca16w", path)
                .attribution
                .iter()
                .all(|s| s.step != AttributionKind::NormalTable)
        );
        // shlmap starts from the inter-reflected references and gathers at the pixel.
        let shlmap = row("shlmap", path);
        assert!(step(shlmap, AttributionKind::RadianceOrder) > 0.0);
        assert!(
            shlmap.attribution[1]
                .image
                .ends_with("shlmap.radiance_order.exr")
        );
        // The SH lightmap bases share shlmap's first rung, then add their basis (and, for
        // the non-linear L1 curves, their reconstruction) rung.
        for name in ["l1geo", "zh3"] {
            let r = row(name, path);
            assert_eq!(
                step(r, AttributionKind::RadianceOrder),
                step(shlmap, AttributionKind::RadianceOrder),
                "{name}"
            );
            assert!(step(r, AttributionKind::Basis) > 0.0, "{name}");
        }
        // The tangent-frame bases, fitted from the samples by default, go from the point
        // reference straight to the basis fitted from each pixel's own samples: no order-3
        // SH between.
        for name in ["hb6", "dice"] {
            let r = row(name, path);
            assert!(
                r.attribution
                    .iter()
                    .all(|s| s.step != AttributionKind::RadianceOrder
                        && s.step != AttributionKind::Basis),
                "{name}: {:?}",
                r.attribution
            );
            assert!(step(r, AttributionKind::SampledBasis) > 0.0, "{name}");
            assert!(
                r.attribution[1].image.ends_with(".basis.samples.exr"),
                "{name}: {}",
                r.attribution[1].image
            );
        }
        assert!(step(row("l1geo", path), AttributionKind::Reconstruction) > 0.0);
        // sh2's product is exact for order-3 lighting and order-2 visibility (the clamped
        // cosine has no band 3): its rung is at rounding level.
        assert!(step(row("sh2", path), AttributionKind::ProductOrder) < 1e-6);
    }
}

/// Every technique's real dx11 blocks (the house's bakes) pass the check a cached entry
/// must pass before it is believed: a second read through the bake cache uses the file and
/// leaves it as it was (a failing check would rebuild and rewrite it, with a warning).
#[test]
fn the_house_dx11_blocks_pass_their_cache_check() {
    let house = common::house();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dx11-block-check");
    let _ = std::fs::remove_dir_all(&dir);
    let mut inputs = house.inputs();
    inputs.cache_dir = Some(&dir);
    let mut checked = 0;
    for &t in Technique::all() {
        if t.form_on(HwPath::Dx11).is_err() {
            continue;
        }
        let first = shvis::technique::dx11_decoded_values(t, &inputs).unwrap();
        let written: Vec<(std::path::PathBuf, std::time::SystemTime)> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                (e.path(), e.metadata().unwrap().modified().unwrap())
            })
            .collect();
        let again = shvis::technique::dx11_decoded_values(t, &inputs).unwrap();
        assert_eq!(first, again, "{t}");
        for (path, modified) in written {
            assert_eq!(
                std::fs::metadata(&path).unwrap().modified().unwrap(),
                modified,
                "{t}: {} was rebuilt: its real blocks failed the cache check",
                path.display()
            );
        }
        checked += 1;
    }
    assert!(checked > 20, "{checked} techniques");
    let _ = std::fs::remove_dir_all(&dir);
}
