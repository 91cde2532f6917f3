//! The device probe and cost model on lavapipe with validation on: every
//! microbenchmark runs and is counted as generated, the fit is printed, and every
//! technique's counts come from its own shader. No timing is asserted (timings go in
//! `shvis probe` and the bench); what can fail here is structure.

mod common;

use shvis::cost::Kind;
use shvis::probe::{ProbeSettings, run_with_monitor};
use shvis::render::FrameSettings;
use shvis::technique::{self, HwPath, Technique};

#[test]
fn the_probe_runs_every_microbenchmark_and_fits_a_model_to_them() {
    let ctx = common::validated_context();
    let (probe, monitor) = run_with_monitor(
        &ctx,
        &ProbeSettings {
            width: 320,
            height: 200,
            triangle_pixels: 200.0,
            warmup: 1,
            frames: 5,
            progress: false,
        },
    )
    .expect("probe runs");
    eprintln!("{}", probe.to_markdown());
    // The empty frame, 3 empty-shader points, 4 finer triangle grids, the counts of each
    // kind, every varying over some of the grids and the untaken-branch points.
    let counts: usize = Kind::ALL
        .iter()
        .map(|&k| shvis::probe::probe_counts(k).len())
        .sum();
    let branches = shvis::probe::UNTAKEN_BRANCH_READS.len();
    let varying_grids = shvis::probe::VARYING_GRIDS.len();
    assert_eq!(
        probe.points.len(),
        4 + 4 + counts + varying_grids + branches
    );
    // The varying points over grids: as many triangles as the grids they are drawn over.
    let grid_triangles = |p: &&shvis::probe::ProbePoint| p.triangles > 8 * probe.grid * probe.grid;
    let over_grids: Vec<u32> = probe
        .points
        .iter()
        .filter(|p| p.kind == Some(Kind::Varying))
        .filter(grid_triangles)
        .map(|p| p.triangles)
        .collect();
    let side = |t: u32| f64::from(t / 2).sqrt().round() as u32;
    assert_eq!(
        over_grids.iter().map(|&t| side(t)).collect::<Vec<_>>(),
        shvis::probe::VARYING_GRIDS,
        "{over_grids:?}"
    );
    assert_eq!(
        probe.points.iter().filter(|p| p.in_untaken_branch).count(),
        branches
    );
    for p in &probe.points {
        assert!(p.ms_median.is_finite() && p.ms_median > 0.0, "{p:?}");
        assert!(p.frames > 0 && p.state_frames <= p.frames, "{p:?}");
        assert!(p.model_ms.is_finite(), "{p:?}");
        if let Some(kind) = p.kind {
            // The point is counted as what it was generated with, its branch's work apart.
            let counts = if p.in_untaken_branch {
                assert!(p.counts.get(kind) < f64::from(p.count), "{p:?}");
                p.untaken
            } else {
                p.counts
            };
            assert!(counts.get(kind) >= f64::from(p.count), "{p:?}");
        }
    }
    let m = &probe.model;
    assert!(m.per_unit_ms.iter().all(|c| c.is_finite()), "{m:?}");
    assert!((0.0..=1.0).contains(&m.untaken_share), "{m:?}");
    assert!(m.fixed_ms.is_finite() && m.pixel_ms.is_finite() && m.depth_test_ms.is_finite());
    assert!(m.per_triangle_ms.is_finite(), "{m:?}");
    assert!(m.per_triangle_varying_ms.is_finite() && m.per_triangle_varying_ms >= 0.0);
    // The screen-filling quad shades every pixel exactly once.
    assert_eq!(probe.screen_fragments, 320 * 200);
    // The states come from the monitor frames, and the kept monitor times again.
    let states = &probe.states;
    assert!(!states.monitor_ms.is_empty() && states.main_state < states.count());
    // The main state has a model, and it is the probe's: that of the fastest state with a
    // model.
    assert_eq!(probe.model_of(states.main_state), Some(&probe.model));
    for m in &probe.state_models {
        assert!(
            states.monitor_ms[m.state] >= states.monitor_ms[states.main_state],
            "{states:?}"
        );
        assert!(!m.worst_point.is_empty(), "{m:?}");
    }
    assert!(
        (states.shares.iter().sum::<f64>() - 1.0).abs() < 1e-9,
        "{states:?}"
    );
    let again = monitor.read().expect("the monitor times");
    assert!(again.is_finite() && again > 0.0, "{again}");
    assert_eq!(monitor.states, probe.states);
    drop(monitor);
    common::assert_validation_clean(&ctx, "probe");
}

#[test]
fn every_technique_counts_its_lookups_by_kind_and_its_shader_ops() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let settings = FrameSettings {
        width: 160,
        height: 100,
        ..FrameSettings::default()
    };
    let scene = shvis::render::SceneGpu::new(&ctx, &prepared.scene, &settings).unwrap();
    let inputs = prepared.inputs();
    for &t in Technique::all() {
        for &path in HwPath::ALL.iter().filter(|&&p| t.runs_on(p)) {
            let tech = technique::build(&ctx, &scene, t, path, &inputs).unwrap();
            let costs = technique::cost::counts(&ctx, &scene, &tech).unwrap();
            let c = costs.done;
            let lookups: f64 = Kind::ALL
                .iter()
                .filter(|k| k.is_lookup())
                .map(|&k| c.get(k))
                .sum();
            // The cost model's lookups are the cost table's.
            assert_eq!(
                lookups,
                f64::from(tech.stats.lookups_per_pixel),
                "{t}.{path}: {c:?}"
            );
            // dx9 binds no arrays or cubes; dx10's per-texel data is an array.
            if path == HwPath::Dx9 {
                assert_eq!(
                    c.get(Kind::Array2d) + c.get(Kind::CubeArray),
                    0.0,
                    "{t}.{path}"
                );
            } else {
                assert_eq!(
                    c.get(Kind::Bilinear2d) + c.get(Kind::Dependent2d),
                    0.0,
                    "{t}.{path}"
                );
            }
            assert!(
                c.get(Kind::FloatOp) > 0.0 && c.get(Kind::Varying) > 0.0,
                "{t}.{path}"
            );
            // Block-compressed layers are dx11's alone, and its norms are read once a pixel.
            let blocks: f64 = [Kind::Bc6hArray, Kind::Bc7Array, Kind::Bc4Array]
                .iter()
                .map(|&k| c.get(k))
                .sum();
            if path == HwPath::Dx11 {
                assert!(c.get(Kind::Bc6hArray) <= 1.0, "{t}.{path}: {c:?}");
            } else {
                assert_eq!(blocks, 0.0, "{t}.{path}: {c:?}");
            }
            // RGBA32F lookups are the NDF moment maps': preconvndf reads all three, unc6ndf
            // the first; no other technique binds RGBA32F (no specular term here).
            let wide = match t {
                Technique::Ndf(shvis::technique::Ndf {
                    base: shvis::technique::NdfBase::Preconv,
                }) => 3.0,
                Technique::Ndf(shvis::technique::Ndf { .. }) => 1.0,
                _ => 0.0,
            };
            assert_eq!(c.get(Kind::TrilinearWide), wide, "{t}.{path}: {c:?}");
            // Every technique reads the albedo, the one sRGB texture.
            // (The clustered rows' counts are shares of their variants': 1 within rounding.)
            assert!(
                (c.get(Kind::TrilinearSrgb) - 1.0).abs() < 1e-9,
                "{t}.{path}: {c:?}"
            );
            // The clustered decodes are counted as run, their loops unrolled: 9 reads of
            // the cluster's block per vector and mean inside a cluster, four decodes for
            // the measured share of fragments whose batch straddles a boundary.
            let vectors = match t {
                Technique::Vq(shvis::technique::Vq { .. }) => Some(0),
                Technique::Cpca(shvis::technique::Cpca { m, .. }) => Some(m),
                _ => None,
            };
            if let Some(m) = vectors {
                let inside = f64::from(9 * (m + 1));
                let reads = c.get(Kind::IndexedUniformRead);
                // Where no lane of a batch straddles a boundary, the boundary path's
                // straight-line code — four reads of a mean block — is untaken work.
                let untaken = costs.untaken.get(Kind::IndexedUniformRead);
                let fetches = c.get(Kind::TexelFetch);
                // The decode's loop over the vectors is kept where drawn: one entered per
                // decode, none for VQ (no vectors).
                let loops = c.get(Kind::Loop);
                match (m, t.to_string().ends_with('n')) {
                    (0, _) => assert_eq!(loops, 0.0, "{t}.{path}"),
                    (_, true) => assert_eq!(loops, 1.0, "{t}.{path}"),
                    (_, false) => assert!(loops > 1.0 && loops < 5.0, "{t}.{path}: {loops}"),
                }
                assert!(
                    reads >= inside && reads < 4.0 * inside,
                    "{t}.{path}: {reads} block reads, {inside} per decode"
                );
                if t.to_string().ends_with('n') {
                    assert_eq!(reads, inside, "{t}.{path}: the naive shader decodes once");
                    assert_eq!(untaken, 0.0, "{t}.{path}: the naive shader has no branch");
                    assert_eq!(fetches, 1.0, "{t}.{path}: the nearest texel's index");
                } else {
                    assert!(reads > inside, "{t}.{path}: no fragment straddles clusters");
                    assert!(
                        untaken > 0.0 && untaken < 4.0 * 9.0,
                        "{t}.{path}: {untaken} untaken block reads"
                    );
                    assert_eq!(
                        fetches,
                        f64::from(
                            tech.stats.lookups_per_pixel - shvis::gpu::layout::MATERIAL_TEXTURES
                        ),
                        "{t}.{path}: every tap fetched unfiltered"
                    );
                }
                // Built for changing lighting (two copies of the block), counted the same.
                let (dynamic, _) =
                    technique::build_dynamic(&ctx, &scene, t, path, &inputs).unwrap();
                let dynamic = technique::cost::counts(&ctx, &scene, &dynamic).unwrap();
                assert_eq!(dynamic.done, c, "{t}.{path}: double-buffered counts");
            }
        }
    }
    // Overdraw: every covered pixel is shaded at least once, hidden surfaces drawn before
    // their occluders more often.
    let shaded = scene.shaded_fragments(&ctx).unwrap();
    let frame = common::render(
        &ctx,
        prepared,
        "preconv".parse().unwrap(),
        HwPath::Dx10,
        &settings,
    );
    let covered = frame.rgba.iter().filter(|p| p[3] > 0.5).count() as u64;
    assert!(
        shaded >= covered && covered > 1000,
        "{shaded} shaded, {covered} covered"
    );
    // The probe's shaders over the scene: each counted as written (the albedo the one sRGB
    // lookup, the normal map a UNORM one), timed, and priced by the model it is given.
    let model = shvis::cost::CostModel {
        fixed_ms: 0.5,
        pixel_ms: 1.0,
        depth_test_ms: 0.2,
        per_triangle_ms: 1e-4,
        per_edge_pixel_ms: 1e-6,
        per_triangle_varying_ms: 1e-6,
        per_unit_ms: [2.0; shvis::cost::KINDS],
        untaken_share: 1.0,
    };
    let load = scene.shading_load(&ctx, None).unwrap();
    let checks = shvis::probe::scene_check::run(&ctx, &scene, &model, &load, 160.0 * 100.0, 3)
        .expect("the scene checks run");
    let lookups = |c: &shvis::probe::scene_check::SceneCheck| {
        [Kind::TrilinearSrgb, Kind::Trilinear2d].map(|k| c.counts.get(k))
    };
    assert_eq!(
        checks.iter().map(lookups).collect::<Vec<_>>(),
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        "{checks:?}"
    );
    for c in &checks {
        assert!(c.ms_median.is_finite() && c.ms_median > 0.0, "{c:?}");
        let priced = model.predict(
            &c.counts,
            load.lanes / (160.0 * 100.0),
            scene.triangle_count(),
            load.edge_pixels,
        );
        assert_eq!(c.model_ms, priced, "{c:?}");
        assert!(
            c.counts.get(Kind::Varying) >= 2.0,
            "reads its lightmap UV: {c:?}"
        );
    }
    assert!(checks[1].model_ms > checks[0].model_ms, "{checks:?}");
    common::assert_validation_clean(&ctx, "technique cost counts");
}

/// A probe measured once is reused by the next run with the same settings on the same
/// device and build (its model and speed states read back, the monitor rebuilt and
/// working); `fresh` measures again; other settings are another probe.
#[test]
fn a_cached_probe_is_reused_and_fresh_measures_again() {
    let ctx = common::validated_context();
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("probe-cache");
    let _ = std::fs::remove_dir_all(&dir);
    let settings = ProbeSettings {
        width: 48,
        height: 32,
        triangle_pixels: 200.0,
        warmup: 0,
        frames: 5,
        progress: false,
    };
    let (first, _) = shvis::probe::cache::run_cached(&ctx, &settings, &dir, false).unwrap();
    assert!(first.reused_from.is_none());
    let (again, monitor) = shvis::probe::cache::run_cached(&ctx, &settings, &dir, false).unwrap();
    assert!(again.reused_from.is_some(), "not reused");
    assert_eq!(again.model, first.model);
    assert_eq!(again.measured_at, first.measured_at);
    assert!(
        monitor.read().unwrap() > 0.0,
        "the rebuilt monitor times frames"
    );
    let other = ProbeSettings {
        frames: 6,
        ..settings
    };
    assert_ne!(
        shvis::probe::cache::path(&dir, &ctx, &settings),
        shvis::probe::cache::path(&dir, &ctx, &other)
    );
    let (fresh, _) = shvis::probe::cache::run_cached(&ctx, &settings, &dir, true).unwrap();
    assert!(fresh.reused_from.is_none(), "fresh reused the cache");

    // What a cached probe claims is checked before it is believed: a file that parses but
    // holds what no measurement gives is measured over, and the file rewritten.
    let file = shvis::probe::cache::path(&dir, &ctx, &settings);
    let good: serde_json::Value = serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(shvis::probe::cache::check(&fresh, &settings), Ok(()));
    let lie = |edit: &dyn Fn(&mut serde_json::Value)| {
        let mut v = good.clone();
        edit(&mut v);
        v
    };
    let lies = [
        (
            lie(&|v| v["model"]["fixed_ms"] = (-1.0).into()),
            "the model's fixed_ms is -1.0 ms",
        ),
        (
            lie(&|v| v["model"]["per_unit_ms"][2] = 1e300.into()),
            "the model's per_unit_ms is 1e300 ms",
        ),
        (
            lie(&|v| v["model"]["untaken_share"] = 7.0.into()),
            "untaken_share is 7",
        ),
        (
            lie(&|v| v["states"]["main_state"] = 9.into()),
            "speed states are not states",
        ),
        (
            lie(&|v| v["points"][0]["ms_median"] = (-0.5).into()),
            "point 0's median is -0.5 ms",
        ),
        (
            lie(&|v| v["measured_at"] = "<script>".into()),
            "measured_at \"<script>\" is not a UTC time",
        ),
        (lie(&|v| v["width"] = 4096.into()), "measured at 4096×32"),
    ];
    for (json, says) in &lies {
        let probe: shvis::probe::Probe = serde_json::from_value(json.clone()).unwrap();
        let why = shvis::probe::cache::check(&probe, &settings).unwrap_err();
        assert!(why.contains(says), "{why} (expected {says})");
    }
    std::fs::write(&file, serde_json::to_vec(&lies[0].0).unwrap()).unwrap();
    let (measured, _) = shvis::probe::cache::run_cached(&ctx, &settings, &dir, false).unwrap();
    assert!(measured.reused_from.is_none(), "a lying cache was believed");
    assert_eq!(shvis::probe::cache::check(&measured, &settings), Ok(()));
    let rewritten: shvis::probe::Probe =
        serde_json::from_slice(&std::fs::read(&file).unwrap()).unwrap();
    assert_eq!(rewritten.measured_at, measured.measured_at, "rewritten");
    assert!(rewritten.model.fixed_ms >= 0.0);
    common::assert_validation_clean(&ctx, "probe cache");
}
