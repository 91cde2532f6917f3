//! The lightmap bases from `shlmap`'s bake — the engine SH bases (`l1`, `l1geo`, `l1zh3`,
//! `zh3`, `l1lum`, `shlmapw`; `sh::bases`), the H-basis (`hb4`, `hb6`; `sh::hbasis`), SG
//! (`sgN`; `sh::sg`) and Ambient Dice (`dice`, `dicey`; `sh::dice`): the
//! shader's reconstructions against the CPU's on the same stored values, hard cases
//! included; every row on both paths against the bounced reference.

mod common;

use ash::vk;
use glam::DVec3;
use gpu_allocator::MemoryLocation;
use shvis::gpu::{
    Buffer, ComputePipeline, ComputePipelineDesc, Resource, ShaderStage, compile_glsl,
};
use shvis::report::metrics::image_error;
use shvis::sh::Order;
use shvis::sh::bases::ShBasis;
use shvis::sh::basis::eval_basis;
use shvis::sh::hbasis::{self, HBasisSize};
use shvis::technique::sh_variant::{basis_ids, shader_value};
use shvis::technique::{Family, HwPath, Technique};

/// Order-3 RGB radiance cases: random lights and skies, and the hard ones — black, L1 of
/// zero length, no mean (L0 = 0), one direction exactly (Geomerics' r = 1), a sun of 1e5.
fn radiance_cases() -> Vec<Vec<[f64; 3]>> {
    let mut rng = common::Rng(0x5eed_0051);
    let mut unit = || rng.below(2001) as f64 / 1000.0 - 1.0;
    let delta = |d: DVec3, rgb: [f64; 3]| -> Vec<[f64; 3]> {
        let mut y = [0.0; 9];
        eval_basis(Order::THREE, d.normalize(), &mut y);
        y.iter().map(|&v| rgb.map(|c| c * v)).collect()
    };
    let mut cases = vec![
        vec![[0.0; 3]; 9],
        {
            let mut c = vec![[0.0; 3]; 9];
            c[0] = [1.0, 0.8, 0.6];
            c
        },
        {
            let mut c = vec![[0.0; 3]; 9];
            c[2] = [0.4, 0.3, 0.2];
            c[5] = [0.1, 0.1, 0.1];
            c
        },
        {
            // A mean near zero under a strong direction (a ringing SH): the clamped ratios.
            let mut c = vec![[0.0; 3]; 9];
            c[0] = [0.01, 0.012, 0.008];
            c[2] = [0.4, 0.3, 0.5];
            c[3] = [-0.2, 0.1, 0.0];
            c
        },
        {
            // A negative mean (a truncated SH's radiance) with and without a direction.
            let mut c = vec![[0.0; 3]; 9];
            c[0] = [-0.2, -0.1, -0.3];
            c
        },
        {
            let mut c = vec![[0.0; 3]; 9];
            c[0] = [-0.2, 0.1, -0.3];
            c[1] = [0.3, 0.2, 0.1];
            c[6] = [0.1, 0.2, 0.3];
            c
        },
        delta(DVec3::new(0.0, 0.0, 1.0), [1.0, 1.0, 1.0]),
        delta(DVec3::new(0.3, 0.8, -0.5), [1e5, 0.9e5, 0.7e5]),
    ];
    for _ in 0..60 {
        let d = DVec3::new(unit(), unit(), unit() + 0.01);
        let mut c = delta(d, [1.0 + unit(), 1.0 + unit(), 1.0 + unit()]);
        let ambient = 1.0 + unit();
        c[0] = c[0].map(|v| v + ambient);
        for k in c.iter_mut().skip(1) {
            *k = k.map(|v| v + 0.1 * unit());
        }
        cases.push(c);
    }
    cases
}

fn normals() -> Vec<DVec3> {
    let mut n: Vec<DVec3> = shvis::sh::project::sphere_quadrature(6)
        .into_iter()
        .map(|(d, _)| d)
        .collect();
    n.extend([DVec3::Z, DVec3::NEG_Z, DVec3::X, DVec3::NEG_Y]);
    n
}

/// Runs the check compute shader `shader` (`glsl/check/`, with `defines`) over `count` cases
/// in `input` with push constants `push` (its first word the count), and returns its
/// `out_floats` × `count` output floats.
fn run_check(
    ctx: &std::sync::Arc<shvis::gpu::Context>,
    shader: &str,
    defines: &[(&'static str, u32)],
    input: &[u8],
    push: &[u32],
    count: usize,
    out_floats: usize,
) -> Vec<f32> {
    let cases = Buffer::with_data(
        ctx,
        input,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        "check.cases",
    )
    .unwrap();
    let out = Buffer::new(
        ctx,
        (count * out_floats * 4) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuToCpu,
        "check.values",
    )
    .unwrap();
    let spirv = compile_glsl(shader, ShaderStage::Compute, defines).unwrap();
    let pipeline = ComputePipeline::new(
        ctx,
        &ComputePipelineDesc {
            name: shader,
            spirv: &spirv,
            resources: &[(0, Resource::Storage(&cases)), (1, Resource::Storage(&out))],
            push_constant_bytes: 4 * push.len() as u32,
        },
    )
    .unwrap();
    pipeline
        .dispatch(
            [(count as u32).div_ceil(64), 1, 1],
            bytemuck::cast_slice(push),
        )
        .unwrap();
    bytemuck::cast_slice(out.read().unwrap()).to_vec()
}

#[test]
fn every_reconstruction_in_the_shader_matches_the_cpu_to_1e_4() {
    let ctx = common::validated_context();
    let radiance = radiance_cases();
    let normals = normals();
    for basis in ShBasis::ALL {
        // The stored values as f32 (what a texel holds before f16), and the normal as f32:
        // both sides evaluate exactly the same inputs.
        let mut data: Vec<[f32; 4]> = Vec::new();
        let mut want: Vec<[f64; 3]> = Vec::new();
        let mut scale: Vec<f64> = Vec::new();
        for r in &radiance {
            let stored: Vec<f32> = basis.encode(r, None).iter().map(|&v| v as f32).collect();
            let stored64: Vec<f64> = stored.iter().map(|&v| f64::from(v)).collect();
            let mean = stored64[..3].iter().map(|v| v.abs()).fold(0.0, f64::max);
            for &n in &normals {
                let n32 = n.as_vec3();
                let mut flat = stored.clone();
                flat.resize(28, 0.0);
                for g in 0..7 {
                    data.push([
                        flat[4 * g],
                        flat[4 * g + 1],
                        flat[4 * g + 2],
                        flat[4 * g + 3],
                    ]);
                }
                data.push([n32.x, n32.y, n32.z, 0.0]);
                want.push(basis.irradiance(&stored64, n32.as_dvec3().normalize()));
                scale.push(mean);
            }
        }
        let count = want.len();
        let values = run_check(
            &ctx,
            "check/sh_bases.comp",
            &[
                vec![("ENGINE_SH_BASIS", shader_value(basis))],
                basis_ids().ids,
            ]
            .concat(),
            bytemuck::cast_slice(&data),
            &[count as u32],
            count,
            4,
        );
        let got: &[[f32; 4]] = bytemuck::cast_slice(&values);
        let mut worst = 0.0f64;
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                // Relative to the case's level (its largest mean coefficient): the shader
                // works in f32, so 1e-4 of the signal, not of a value that cancels to 0.
                let level = scale[i].max(w[c].abs()).max(1e-30);
                let err = (f64::from(g[c]) - w[c]).abs() / level;
                worst = worst.max(err);
                assert!(
                    err < 1e-4,
                    "{basis:?} case {} normal {}: GPU {} CPU {} ({err:.2e})",
                    i / normals.len(),
                    i % normals.len(),
                    g[c],
                    w[c]
                );
            }
        }
        println!("{basis:?}: largest relative difference GPU − CPU {worst:.2e} over {count} cases");
    }
    common::assert_validation_clean(&ctx, "sh_bases check");
}

/// A sky's order-3 radiance and a texel frame tilted 37° about +y: the fitted coefficient
/// set of the tangent-space checks.
fn tilted_sky() -> (Vec<[f64; 3]>, [DVec3; 3]) {
    let mut radiance = vec![[0.0; 3]; 9];
    radiance[0] = [2.0, 1.8, 1.5];
    radiance[2] = [1.0, 0.9, 0.6];
    radiance[5] = [0.3, 0.2, 0.1];
    let frame = [
        DVec3::new(0.8, 0.0, -0.6),
        DVec3::Y,
        DVec3::new(0.6, 0.0, 0.8),
    ];
    (radiance, frame)
}

#[test]
fn the_h_basis_shader_matches_the_cpu_to_1e_4() {
    let ctx = common::validated_context();
    let mut rng = common::Rng(0x4b_a515);
    let mut unit = || rng.below(2001) as f64 / 1000.0 - 1.0;
    // Coefficient sets: random, and one from a projected sky through a tilted frame.
    let mut sets: Vec<Vec<[f64; 3]>> = (0..40)
        .map(|_| (0..6).map(|_| [unit(), unit(), unit()]).collect())
        .collect();
    let (radiance, frame) = tilted_sky();
    sets.push(hbasis::project_irradiance(&radiance, frame, HBasisSize::H6));
    let dirs: Vec<DVec3> = hbasis::hemisphere_quadrature(4)
        .into_iter()
        .map(|(m, _)| m)
        .chain([DVec3::Z, DVec3::X])
        .collect();
    for size in [HBasisSize::H4, HBasisSize::H6] {
        let (mut data, mut want, mut level) = (Vec::new(), Vec::new(), Vec::new());
        for set in &sets {
            let coeffs: Vec<[f32; 3]> = set[..size.count()]
                .iter()
                .map(|c| c.map(|v| v as f32))
                .collect();
            let mut flat: Vec<f32> = coeffs.iter().flatten().copied().collect();
            flat.resize(20, 0.0);
            let as64: Vec<[f64; 3]> = coeffs.iter().map(|c| c.map(f64::from)).collect();
            let scale = as64.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
            for &m in &dirs {
                let m32 = m.as_vec3();
                for g in 0..5 {
                    data.push([
                        flat[4 * g],
                        flat[4 * g + 1],
                        flat[4 * g + 2],
                        flat[4 * g + 3],
                    ]);
                }
                data.push([m32.x, m32.y, m32.z, 0.0]);
                want.push(hbasis::irradiance(&as64, m32.as_dvec3()));
                level.push(scale);
            }
        }
        let count = want.len();
        let values = run_check(
            &ctx,
            "check/hbasis.comp",
            &[],
            bytemuck::cast_slice(&data),
            &[count as u32, size.count() as u32],
            count,
            4,
        );
        let got: &[[f32; 4]] = bytemuck::cast_slice(&values);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                let err = (f64::from(g[c]) - w[c]).abs() / level[i].max(w[c].abs()).max(1e-30);
                assert!(
                    err < 1e-4,
                    "{size:?} case {i}: GPU {} CPU {} ({err:.2e})",
                    g[c],
                    w[c]
                );
            }
        }
    }
    common::assert_validation_clean(&ctx, "hbasis check");
}

#[test]
fn the_ambient_dice_shader_matches_the_cpu_to_1e_4() {
    use shvis::sh::dice::{DiceVariant, dice};
    let ctx = common::validated_context();
    let basis = dice();
    let mut rng = common::Rng(0xd1ce);
    let mut unit = || rng.below(2001) as f64 / 1000.0 - 1.0;
    // Directions: the fitting nodes, every stored vertex, face centre and edge midpoint,
    // and one below the horizon (lifted to it).
    let mut dirs: Vec<DVec3> = basis.nodes().iter().map(|&(m, _)| m).collect();
    dirs.extend(basis.vertices.iter().copied());
    for face in &basis.faces {
        dirs.push(face.centre);
        for i in 0..3 {
            let (a, b) = (face.vertices[i], face.vertices[(i + 1) % 3]);
            dirs.push((basis.vertices[a] + basis.vertices[b]).normalize());
        }
    }
    dirs.push(DVec3::new(0.3, -0.2, -0.5).normalize());
    let table = shvis::technique::hemisphere::dice_face_table();
    for variant in DiceVariant::ALL {
        let values = variant.stored_values();
        let groups = values.div_ceil(4);
        // Value sets: random, and one fitted to a sky through a tilted frame.
        let mut sets: Vec<Vec<f64>> = (0..6)
            .map(|_| (0..values).map(|_| unit()).collect())
            .collect();
        let (radiance, frame) = tilted_sky();
        sets.push(basis.project_irradiance(variant, &radiance, frame));
        let mut data: Vec<[f32; 4]> = table.clone();
        let (mut want, mut level) = (Vec::new(), Vec::new());
        for set in &sets {
            let set32: Vec<f32> = set.iter().map(|&v| v as f32).collect();
            let as64: Vec<f64> = set32.iter().map(|&v| f64::from(v)).collect();
            let scale = as64.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for &m in &dirs {
                let m32 = m.as_vec3();
                for g in 0..groups {
                    data.push(std::array::from_fn(|k| {
                        set32.get(4 * g + k).copied().unwrap_or(0.0)
                    }));
                }
                data.push([m32.x, m32.y, m32.z, 0.0]);
                want.push(basis.irradiance(variant, &as64, m32.as_dvec3()));
                level.push(scale);
            }
        }
        let count = want.len();
        let got = run_check(
            &ctx,
            "check/dice.comp",
            &[
                ("DICE_YCOCG", u32::from(variant == DiceVariant::YCoCg)),
                ("DICE_FACES", basis.faces.len() as u32),
            ],
            bytemuck::cast_slice(&data),
            &[count as u32, table.len() as u32, groups as u32 + 1],
            count,
            4,
        );
        let got: &[[f32; 4]] = bytemuck::cast_slice(&got);
        let mut worst = 0.0f64;
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            for c in 0..3 {
                let err = (f64::from(g[c]) - w[c]).abs() / level[i].max(w[c].abs()).max(1e-30);
                worst = worst.max(err);
                assert!(
                    err < 1e-4,
                    "{variant:?} case {i}: GPU {} CPU {} ({err:.2e})",
                    g[c],
                    w[c]
                );
            }
        }
        println!("{variant:?}: largest relative difference {worst:.2e} over {count} cases");
    }
    common::assert_validation_clean(&ctx, "dice check");
}

#[test]
fn the_sg_shader_matches_the_cpu_to_1e_4() {
    use shvis::sh::sg::{LOBE_COUNTS, SgBasis, cosine_integral_fitted};
    let ctx = common::validated_context();
    // Every lobe count's sharpness, μ·n over [−1, 1] (both branches of the fit).
    let mut cases: Vec<[f32; 2]> = Vec::new();
    for n in LOBE_COUNTS {
        let sharpness = SgBasis::new(n).sharpness as f32;
        for i in 0..=200 {
            cases.push([-1.0 + i as f32 / 100.0, sharpness]);
        }
    }
    let count = cases.len();
    let got = run_check(
        &ctx,
        "check/sg.comp",
        &[],
        bytemuck::cast_slice(&cases),
        &[count as u32],
        count,
        1,
    );
    for (c, &g) in cases.iter().zip(&got) {
        let (t, sharpness) = (f64::from(c[0]), f64::from(c[1]));
        let want = cosine_integral_fitted(t, sharpness);
        let peak = cosine_integral_fitted(1.0, sharpness);
        let err = (f64::from(g) - want).abs() / peak;
        assert!(
            err < 1e-4,
            "t {t} λ {sharpness}: GPU {g} CPU {want} ({err:.2e})"
        );
    }
    common::assert_validation_clean(&ctx, "sg check");
}

#[test]
fn every_engine_basis_meets_the_bounced_reference_on_both_paths() {
    let ctx = common::validated_context();
    let (reference, settings) = common::house_reference(&ctx);
    let bounced = reference.bounced.as_ref().expect("a bounced reference");
    let prepared = common::house();
    let shlmap: Vec<f64> = HwPath::ALL
        .iter()
        .map(|&path| {
            let frame = common::render(
                &ctx,
                prepared,
                Technique::Shlmap(shvis::technique::Shlmap),
                path,
                &settings,
            );
            image_error(&frame, &bounced.frame).unwrap().rel_rmse
        })
        .collect();
    let techniques = Technique::from(shvis::technique::ShVariant::EXAMPLE)
        .family_members()
        .into_iter()
        .chain(Technique::from(shvis::technique::Hemisphere::EXAMPLE).family_members());
    for technique in techniques {
        let errors: Vec<f64> = HwPath::ALL
            .iter()
            .map(|&path| {
                let frame = common::render(&ctx, prepared, technique, path, &settings);
                image_error(&frame, &bounced.frame).unwrap().rel_rmse
            })
            .collect();
        println!("{technique}: relative RMSE {errors:?} (shlmap {shlmap:?})");
        assert!(errors.iter().all(|&e| e < 0.4), "{technique}: {errors:?}");
        assert!(
            (errors[0] - errors[1]).abs() < 0.01,
            "{technique}: dx9 vs dx10 {errors:?}"
        );
    }
    common::assert_validation_clean(&ctx, "engine bases");
}
