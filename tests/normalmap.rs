//! GPU normal-map generation (Gumbau et al.) against analytic normals and the
//! CPU ray-cast baker, on lavapipe with validation on.

mod common;
mod scratch;

use glam::{Vec2, Vec3};
use scratch::Scratch;
use shvis::normalmap::cpu::RayDirection;
use shvis::normalmap::simplify::{sphere_high, sphere_low};
use shvis::normalmap::{
    AngleStats, DrawMode, NormalImage, NormalMapSettings, angle_deg, cpu, expand_borders, gpu,
    low_texels, output, tangent_space,
};
use shvis::scene::{Mesh, Vertex};

/// Distance along unit `dir` from `p` (inside the unit sphere) to the sphere.
fn to_unit_sphere(p: Vec3, dir: Vec3) -> f32 {
    let b = p.dot(dir);
    -b + (b * b - p.length_squared() + 1.0).sqrt()
}

/// Angles between each interior texel's normal and the unit sphere's normal where the
/// baker looked: along the owning low triangle's face normal (GPU) or along the
/// interpolated normal (CPU).
fn sphere_errors(image: &NormalImage, low: &Mesh, along_face: bool) -> AngleStats {
    let frames = low_texels(low, image.res);
    let interior = image.interior();
    let angles = (0..image.texels.len())
        .filter(|&i| interior[i])
        .map(|i| {
            assert!(
                frames.covered[i],
                "texel {i} generated but not on the low mesh"
            );
            let p = frames.position[i];
            let dir = if along_face {
                frames.normal[i]
            } else {
                frames.shading_normal[i]
            };
            let exact = (p + dir * to_unit_sphere(p, dir)).normalize();
            angle_deg(image.normal(i), exact)
        })
        .collect();
    AngleStats::of(angles).expect("interior texels")
}

#[test]
fn sphere_normals_match_the_analytic_sphere_on_gpu_and_cpu() {
    let ctx = common::validated_context();
    let high = sphere_high(7, 1.0);
    assert!(high.triangle_count() >= 100_000);
    for low_level in [1, 2] {
        let low = sphere_low(low_level, 1.0, 256).unwrap();
        assert!((80..=320).contains(&low.triangle_count()));
        let settings = NormalMapSettings::new(&low, 256);
        let (image, timing) = gpu::bake(&ctx, &high, &low, &settings).unwrap();
        let gpu_stats = sphere_errors(&image, &low, true);
        let (cpu_image, _) = cpu::bake(&high, &low, &settings, RayDirection::Interpolated).unwrap();
        let cpu_stats = sphere_errors(&cpu_image, &low, false);
        eprintln!(
            "{} low triangles: GPU {gpu_stats} ({} high triangles drawn); CPU {cpu_stats}",
            low.triangle_count(),
            timing.triangles_drawn
        );
        for stats in [gpu_stats, cpu_stats] {
            assert!(stats.count > 10_000, "{stats}");
            assert!(stats.median_deg <= 0.5 && stats.p99_deg <= 3.0, "{stats}");
        }
    }
    common::assert_validation_clean(&ctx, "normalmap sphere");
}

#[test]
fn draw_modes_and_culling_change_no_texel() {
    let ctx = common::validated_context();
    let high = sphere_high(4, 1.0);
    let low = sphere_low(1, 1.0, 64).unwrap();
    let base = NormalMapSettings::new(&low, 64);
    let (reference, _) = gpu::bake(&ctx, &high, &low, &base).unwrap();
    assert!(reference.covered_count() > 1000);
    for (draws, cull) in [
        (DrawMode::Direct, true),
        (DrawMode::Indirect, false),
        (DrawMode::Direct, false),
    ] {
        let settings = NormalMapSettings {
            draws,
            cull,
            ..base
        };
        let (image, _) = gpu::bake(&ctx, &high, &low, &settings).unwrap();
        assert_eq!(image, reference, "{draws:?}, cull {cull}");
    }
    common::assert_validation_clean(&ctx, "normalmap draw modes");
}

/// A quad with unique UVs over the whole map, facing +z at height `z`.
fn low_quad(z: f32) -> Mesh {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    Mesh {
        vertices: corners
            .iter()
            .map(|&(x, y)| Vertex {
                position: [x, y, z],
                normal: [0.0, 0.0, 1.0],
                tangent: [1.0, 0.0, 0.0, 1.0],
                uv_material: [(x + 1.0) / 2.0, (1.0 - y) / 2.0],
                ..Vertex::default()
            })
            .collect(),
        indices: vec![0, 1, 2, 0, 2, 3],
    }
}

/// Appends a rectangle (two triangles) with a constant vertex normal.
fn push_rect(mesh: &mut Mesh, p: [Vec3; 4], normal: Vec3) {
    let base = mesh.vertices.len() as u32;
    for q in p {
        mesh.vertices.push(Vertex {
            position: q.to_array(),
            normal: normal.to_array(),
            ..Vertex::default()
        });
    }
    mesh.indices
        .extend([base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// The paper's Fig. 4 case: a concave "C" profile — a floor, a wall at x = 1 and a roof
/// over the floor's right half, facing down at it. The low quad hovers just above the
/// floor; from its camera the roof hides the floor's right half.
fn overhang() -> Mesh {
    let mut m = Mesh::default();
    let v = Vec3::new;
    push_rect(
        &mut m,
        [
            v(-1.2, -1.2, 0.0),
            v(1.0, -1.2, 0.0),
            v(1.0, 1.2, 0.0),
            v(-1.2, 1.2, 0.0),
        ],
        Vec3::Z,
    );
    push_rect(
        &mut m,
        [
            v(1.0, -1.2, 0.0),
            v(1.0, -1.2, 0.3),
            v(1.0, 1.2, 0.3),
            v(1.0, 1.2, 0.0),
        ],
        -Vec3::X,
    );
    push_rect(
        &mut m,
        [
            v(0.0, -1.2, 0.3),
            v(0.0, 1.2, 0.3),
            v(1.0, 1.2, 0.3),
            v(1.0, -1.2, 0.3),
        ],
        -Vec3::Z,
    );
    m
}

#[test]
fn vertex_mirroring_defeats_self_occlusion() {
    let ctx = common::validated_context();
    let (high, low) = (overhang(), low_quad(0.05));
    let settings = NormalMapSettings {
        max_distance: 0.5,
        ..NormalMapSettings::new(&low, 64)
    };
    let under_roof = |i: usize| i % 64 >= 32; // x > 0
    let fraction_up = |image: &NormalImage, region: &dyn Fn(usize) -> bool| {
        let texels: Vec<usize> = (0..image.texels.len())
            .filter(|&i| image.texels[i][3] == 1.0 && region(i))
            .collect();
        let up = texels
            .iter()
            .filter(|&&i| angle_deg(image.normal(i), Vec3::Z) < 1.0)
            .count();
        up as f64 / texels.len() as f64
    };
    let (mirrored, _) = gpu::bake(&ctx, &high, &low, &settings).unwrap();
    let (plain, _) = gpu::bake(
        &ctx,
        &high,
        &low,
        &NormalMapSettings {
            mirror: false,
            ..settings
        },
    )
    .unwrap();
    let (rays, _) = cpu::bake(&high, &low, &settings, RayDirection::Interpolated).unwrap();
    assert_eq!(mirrored.covered_count(), 64 * 64);
    // Right: the floor everywhere. Wrong without mirroring: the roof's −z under it.
    let all = |_: usize| true;
    eprintln!(
        "up: mirrored {:.4}, rays {:.4}, plain {:.4} / {:.4} (open / under the roof)",
        fraction_up(&mirrored, &all),
        fraction_up(&rays, &all),
        fraction_up(&plain, &|i| !under_roof(i)),
        fraction_up(&plain, &under_roof)
    );
    assert!(fraction_up(&mirrored, &|_| true) > 0.99);
    assert!(fraction_up(&rays, &|_| true) > 0.99);
    assert!(fraction_up(&plain, &|i| !under_roof(i)) > 0.99);
    assert!(fraction_up(&plain, &under_roof) < 0.01);
    common::assert_validation_clean(&ctx, "normalmap mirroring");
}

#[test]
fn border_expansion_fills_k_texels_and_keeps_bilinear_lookups_inside_charts() {
    let ctx = common::validated_context();
    let high = sphere_high(4, 1.0);
    let low = sphere_low(1, 1.0, 64).unwrap();
    let res = 64usize;
    let raw_settings = NormalMapSettings {
        expand: 0,
        ..NormalMapSettings::new(&low, 64)
    };
    let (raw, _) = gpu::bake(&ctx, &high, &low, &raw_settings).unwrap();
    // Bilinear lookups anywhere in the footprint of a generated texel (up to ½ texel from
    // its centre, towards each corner): the four taps each lookup reads.
    let generated: Vec<usize> = (0..res * res)
        .filter(|&i| raw.texels[i][3] == 1.0)
        .collect();
    let taps_empty = |image: &NormalImage| {
        let mut empty = 0;
        for &i in &generated {
            let centre = Vec2::new((i % res) as f32 + 0.5, (i / res) as f32 + 0.5);
            for offset in [
                Vec2::new(-0.49, -0.49),
                Vec2::new(0.49, -0.49),
                Vec2::new(-0.49, 0.49),
                Vec2::new(0.49, 0.49),
            ] {
                let p = centre + offset - 0.5;
                let (x0, y0) = (p.x.floor() as usize, p.y.floor() as usize);
                for (x, y) in [(x0, y0), (x0 + 1, y0), (x0, y0 + 1), (x0 + 1, y0 + 1)] {
                    if image.texels[y.min(res - 1) * res + x.min(res - 1)][3] == 0.0 {
                        empty += 1;
                    }
                }
            }
        }
        empty
    };
    assert!(
        taps_empty(&raw) > 0,
        "without expansion some edge lookups mix in empty texels"
    );
    for k in [1u32, 3] {
        let (expanded, _) = gpu::bake(
            &ctx,
            &high,
            &low,
            &NormalMapSettings {
                expand: k,
                ..raw_settings
            },
        )
        .unwrap();
        // The GPU passes do what the CPU twin does.
        let mut twin = raw.clone();
        expand_borders(&mut twin, k);
        for (g, c) in expanded.texels.iter().zip(&twin.texels) {
            assert_eq!(g[3], c[3]);
            assert!(
                g[3] == 0.0
                    || angle_deg(Vec3::from_slice(&g[..3]), Vec3::from_slice(&c[..3])) < 1e-2
            );
        }
        // Exactly the texels within Chebyshev distance k of a generated texel are filled.
        for y in 0..res {
            for x in 0..res {
                let near =
                    (y.saturating_sub(k as usize)..(y + k as usize + 1).min(res)).any(|yy| {
                        (x.saturating_sub(k as usize)..(x + k as usize + 1).min(res))
                            .any(|xx| raw.texels[yy * res + xx][3] == 1.0)
                    });
                assert_eq!(
                    expanded.texels[y * res + x][3] > 0.0,
                    near,
                    "texel {x},{y}, k = {k}"
                );
            }
        }
        assert_eq!(taps_empty(&expanded), 0, "k = {k}");
    }
    common::assert_validation_clean(&ctx, "normalmap expansion");
}

#[test]
fn written_gltf_and_tangent_map_give_back_the_object_normals_in_the_renderer_frame() {
    let ctx = common::validated_context();
    // A high sphere whose normals wander off the radial direction: a non-trivial map.
    let mut high = sphere_high(5, 1.0);
    for v in &mut high.vertices {
        let p = Vec3::from(v.position);
        let wobble = Vec3::new((7.0 * p.y).sin(), (5.0 * p.z).sin(), (6.0 * p.x).sin()) * 0.5;
        v.normal = (p + wobble).normalize().to_array();
    }
    let res = 128;
    let low = sphere_low(1, 1.0, res).unwrap();
    let (image, _) = gpu::bake(&ctx, &high, &low, &NormalMapSettings::new(&low, res)).unwrap();
    let tangent = tangent_space(&image, &low_texels(&low, res));
    let dir = Scratch::new("normalmap", "low");
    output::write_map(&dir.join("map.png"), res, &tangent, [0.0, 0.0, 1.0]).unwrap();
    output::write_low_gltf(&dir.join("low.gltf"), &low, Some("map.png")).unwrap();
    let scene = shvis::scene::gltf::load(&dir.join("low.gltf"), res).unwrap();
    assert_eq!(scene.mesh.triangle_count(), low.triangle_count());
    let map = &scene.material.normal;
    assert_eq!((map.width, map.height), (res, res));
    // Decode as glsl/include/common.glsl::shading_normal does, per texel centre.
    let frames = low_texels(&scene.mesh, res);
    let interior = image.interior();
    let mut angles = Vec::new();
    let mut tilted = 0;
    for i in (0..image.texels.len()).filter(|&i| interior[i]) {
        let [r, g, b, _] = map.texels[i].map(|c| f32::from(c) / 255.0 * 2.0 - 1.0);
        let m = Vec3::new(r, g, b).normalize();
        let n = frames.shading_normal[i].normalize();
        let t4 = frames.tangent[i];
        let t = (t4.truncate() - n * n.dot(t4.truncate())).normalize();
        let bitangent = n.cross(t) * t4.w.signum();
        let world = (t * m.x + bitangent * m.y + n * m.z).normalize();
        angles.push(angle_deg(world, image.normal(i)));
        tilted += usize::from(m.z < 0.95);
    }
    let stats = AngleStats::of(angles).unwrap();
    eprintln!("decoded through the renderer's frame: {stats}; {tilted} texels tilted > 18°");
    assert!(tilted > stats.count / 10, "the map is not trivial");
    assert!(stats.p99_deg < 1.0 && stats.max_deg < 2.0, "{stats}");
    common::assert_validation_clean(&ctx, "normalmap glTF round trip");
}

#[test]
fn a_written_gltf_references_its_map_below_its_folder_by_an_encoded_uri() {
    let res = 64;
    let low = sphere_low(1, 1.0, res).unwrap();
    let dir = Scratch::new("normalmap", "uri");
    let maps = dir.join("maps 100%");
    std::fs::create_dir_all(&maps).unwrap();
    let map = maps.join("n#1.png");
    output::write_map(
        &map,
        res,
        &vec![[0.0, 0.0, 1.0, 1.0]; (res * res) as usize],
        [0.0; 3],
    )
    .unwrap();
    let gltf = dir.join("low 50%.gltf");
    let uri = shvis::normalmap::job::relative_uri(&gltf, &map).unwrap();
    assert_eq!(uri, "maps%20100%25/n%231.png");
    output::write_low_gltf(&gltf, &low, Some(&uri)).unwrap();
    let scene = shvis::scene::gltf::load(&gltf, res).unwrap();
    assert_eq!(
        (scene.material.normal.width, scene.material.normal.height),
        (res, res)
    );
    // A map beside the glTF's folder cannot be referenced from it.
    let inner = dir.join("inner").join("low.gltf");
    let e = shvis::normalmap::job::relative_uri(&inner, &map).unwrap_err();
    assert!(e.contains("outside the folder of --gltf"), "{e}");
}
