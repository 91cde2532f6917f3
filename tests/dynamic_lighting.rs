//! Dynamic lighting on the GPU (`technique::lighting`): every technique built with
//! two lighting sets takes new tables with validation clean, the frame right after the
//! non-blocking update draws exactly the new data and the other set keeps the old; the
//! tables of blended lighting are the
//! blend of the two tables to f16 precision as uploaded, and render as the blend of the two
//! images.

mod common;

use shvis::env::schedule::{LightingSchedule, blend};
use shvis::render::{Frame, FrameSettings, SceneGpu};
use shvis::sh::Order;
use shvis::sh::zonal::irradiance_from_radiance;
use shvis::technique::{self, HwPath, Inputs, LightingData, Technique};

const DYNAMIC: [&str; 13] = [
    "unc3",
    "unc4",
    "unc6",
    "pca4",
    "pca16",
    "pca4w",
    "sh2",
    "preconv",
    "nmprt",
    "nmprtsvd6",
    "nmprtsvd4p",
    "nmprthl2",
    "nmprtratio",
];

fn settings() -> FrameSettings {
    FrameSettings {
        width: 80,
        height: 50,
        ..FrameSettings::default()
    }
}

/// The house's lighting turned `quarter_turns` × 90° about +Y, and its irradiance.
fn turned(quarter_turns: u32) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let sh = &common::house().radiance_sh;
    let order = Order::new((sh.len() as f64).sqrt() as u32).unwrap();
    let radiance = LightingSchedule::rotating(order, sh.clone(), 1.0, 4).at(quarter_turns);
    let irradiance = irradiance_from_radiance(&radiance[..9], Order::THREE);
    (radiance, irradiance)
}

fn with<'a>(radiance: &'a [[f64; 3]], irradiance: &'a [[f64; 3]]) -> Inputs<'a> {
    Inputs {
        radiance_sh: radiance,
        irradiance_sh: irradiance,
        ..common::house().inputs()
    }
}

fn max_difference(a: &Frame, b: &Frame) -> f32 {
    a.rgba
        .iter()
        .zip(&b.rgba)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

fn max_value(a: &Frame) -> f32 {
    a.rgba
        .iter()
        .flat_map(|p| &p[..3])
        .fold(0.0f32, |m, v| m.max(v.abs()))
}

#[test]
fn every_dynamic_technique_swaps_its_tables_with_validation_clean() {
    let ctx = common::validated_context();
    let scene = SceneGpu::new(&ctx, &common::house().scene, &settings()).expect("scene");
    let (la, ea) = turned(0);
    let (lb, eb) = turned(1);
    for name in DYNAMIC {
        let technique: Technique = name.parse().unwrap();
        for &path in HwPath::ALL.iter().filter(|&&p| technique.runs_on(p)) {
            let label = format!("{technique}.{path}");
            let (mut tech, recipe) =
                technique::build_dynamic(&ctx, &scene, technique, path, &with(&la, &ea))
                    .expect("builds with two lighting sets");
            assert_eq!(tech.lighting_sets(), 2, "{label}");
            let before = tech.render(&scene, 0, 1).expect("renders");
            let static_b = technique::build(&ctx, &scene, technique, path, &with(&lb, &eb))
                .expect("static build")
                .render(&scene, 0, 1)
                .expect("renders");
            assert!(
                max_difference(&before, &static_b) > 1e-3 * max_value(&before),
                "{label}: a quarter turn of the sun changes the image"
            );
            let data_b = recipe.build(&lb, &eb).expect("lighting data");
            tech.update_lighting(&data_b).expect("update submits");
            // The very next frame, submitted without waiting for the copy, draws exactly
            // the new data: the GPU orders it after the copy.
            let after = tech.render(&scene, 0, 1).expect("renders");
            assert_eq!(
                max_difference(&after, &static_b),
                0.0,
                "{label}: the updated set is the static build's data"
            );
            // And back through the other set, which kept the old data intact.
            tech.update_lighting(&recipe.build(&la, &ea).unwrap())
                .expect("update submits");
            let back = tech.render(&scene, 0, 1).expect("renders");
            assert_eq!(max_difference(&back, &before), 0.0, "{label}: swapped back");
            tech.wait_for_upload().expect("the copy lands");
            assert!(!tech.upload_in_flight().unwrap(), "{label}");
            common::assert_validation_clean(&ctx, &format!("{label} across table swaps"));
        }
    }
    // Techniques with baked lighting cannot be built for it; mismatched data is refused.
    let shlmap = technique::build_dynamic(
        &ctx,
        &scene,
        Technique::Shlmap(shvis::technique::Shlmap),
        HwPath::Dx10,
        &with(&la, &ea),
    );
    assert!(shlmap.is_err());
    let (mut unc4, _) = technique::build_dynamic(
        &ctx,
        &scene,
        "unc4".parse().unwrap(),
        HwPath::Dx10,
        &with(&la, &ea),
    )
    .unwrap();
    let (_, unc6) = technique::build_dynamic(
        &ctx,
        &scene,
        "unc6".parse().unwrap(),
        HwPath::Dx10,
        &with(&la, &ea),
    )
    .unwrap();
    let err = unc4
        .update_lighting(&unc6.build(&lb, &eb).unwrap())
        .expect_err("unc6's tables do not fit unc4's sets");
    assert!(err.to_string().contains("layout"), "{err}");
    let mut single = technique::build(
        &ctx,
        &scene,
        "unc4".parse().unwrap(),
        HwPath::Dx9,
        &with(&la, &ea),
    )
    .unwrap();
    assert!(
        single
            .update_lighting(&LightingData::params(vec![0; 16]))
            .is_err()
    );
    common::assert_validation_clean(&ctx, "refused updates");
}

/// Decoded table values (f16 × unscale) of `data`, in upload order.
fn decoded(data: &LightingData) -> Vec<f32> {
    let tables = data.tables.as_ref().expect("tables");
    tables
        .images
        .iter()
        .flat_map(|i| i.layers.iter().flatten().flatten())
        .map(|v| v.to_f32() * tables.unscale)
        .collect()
}

#[test]
fn tables_of_blended_lighting_are_the_blend_of_the_tables_in_f16() {
    let ctx = common::validated_context();
    let scene = SceneGpu::new(&ctx, &common::house().scene, &settings()).expect("scene");
    let (la, _) = turned(0);
    let (lb, _) = turned(1);
    for name in ["unc6", "pca16"] {
        let technique: Technique = name.parse().unwrap();
        for &path in HwPath::ALL {
            let label = format!("{technique}.{path}");
            let irradiance = |l: &[[f64; 3]]| irradiance_from_radiance(&l[..9], Order::THREE);
            let (ea, eb) = (irradiance(&la), irradiance(&lb));
            let (mut tech, recipe) =
                technique::build_dynamic(&ctx, &scene, technique, path, &with(&la, &ea)).unwrap();
            let image_a = tech.render(&scene, 0, 1).unwrap();
            let (a, b) = (
                recipe.build(&la, &ea).unwrap(),
                recipe.build(&lb, &eb).unwrap(),
            );
            tech.update_lighting(&b).unwrap();
            let image_b = tech.render(&scene, 0, 1).unwrap();
            for t in [0.3, 0.5] {
                let lt = blend(&la, &lb, t);
                let et = irradiance(&lt);
                let of_blend = recipe.build(&lt, &et).unwrap();
                // Each stored value is within half an f16 ulp (2^-11 relative) of its f32
                // value, plus the subnormal step; the f32 tables are linear in L to ~1e-7.
                let floor = 2f32.powi(-25)
                    * [&a, &b, &of_blend]
                        .iter()
                        .map(|d| d.tables.as_ref().unwrap().unscale)
                        .fold(0.0, f32::max);
                let (da, db, dt) = (decoded(&a), decoded(&b), decoded(&of_blend));
                let t32 = t as f32;
                let worst = dt
                    .iter()
                    .zip(da.iter().zip(&db))
                    .map(|(&x, (&p, &q))| {
                        let bound = 2f32.powi(-11)
                            * (x.abs() + (1.0 - t32) * p.abs() + t32 * q.abs())
                            * 1.01
                            + 1e-6 * (p.abs() + q.abs())
                            + 2.0 * floor;
                        (x - ((1.0 - t32) * p + t32 * q)).abs() / bound
                    })
                    .fold(0.0, f32::max);
                assert!(worst <= 1.0, "{label} t {t}: {worst} of the f16 bound");
                // On the GPU: the image of the blended tables is the blend of the images,
                // wherever the shader's clamp of negative irradiance (SH ringing) did not
                // act — a clamped channel is exactly 0 in one of the three images.
                tech.update_lighting(&of_blend).unwrap();
                let image_t = tech.render(&scene, 0, 1).unwrap();
                let scale = max_value(&image_a).max(max_value(&image_b));
                let (mut worst, mut compared, mut covered) = (0.0f32, 0usize, 0usize);
                for (x, (p, q)) in image_t
                    .rgba
                    .iter()
                    .zip(image_a.rgba.iter().zip(&image_b.rgba))
                {
                    if x[3] < 0.5 {
                        continue;
                    }
                    covered += 1;
                    if (0..3).any(|c| x[c] <= 0.0 || p[c] <= 0.0 || q[c] <= 0.0) {
                        continue;
                    }
                    compared += 1;
                    for c in 0..3 {
                        worst = worst.max((x[c] - ((1.0 - t32) * p[c] + t32 * q[c])).abs());
                    }
                }
                assert!(
                    compared * 2 > covered,
                    "{label}: {compared} of {covered} unclamped"
                );
                assert!(
                    worst <= 4e-3 * scale,
                    "{label} t {t}: image of the blend off by {worst} (max {scale})"
                );
            }
            common::assert_validation_clean(&ctx, &label);
        }
    }
}
