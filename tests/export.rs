//! `shvis export`: every KTX2 file read back by the `ktx2` crate holds the texels the
//! renderer uploads, the manifest names every file, and the decode snippet, compiled in
//! place of the technique's shader, draws the technique's image.

mod common;

use shvis::export::export;
use shvis::gpu::{HwPath, ShaderStage, compile_source};
use shvis::render::{FrameSettings, SceneGpu};
use shvis::technique::block::{compress, dx11_codec};
use shvis::technique::{self, LightingRecipe, Technique, per_texel_data};

/// Level 0 of a KTX2 file, after checking the reader's header against the expectation.
fn level0(bytes: &[u8], format: ash::vk::Format, side: u32, layers: u32, faces: u32) -> Vec<u8> {
    let reader = ktx2::Reader::new(bytes).expect("a valid KTX2 file");
    let header = reader.header();
    assert_eq!(
        header.format.map(|f| f.value()),
        Some(format.as_raw() as u32)
    );
    assert_eq!((header.pixel_width, header.pixel_height), (side, side));
    assert_eq!((header.layer_count, header.face_count), (layers, faces));
    assert_eq!(header.level_count, 1);
    reader.levels().next().expect("level 0").data.to_vec()
}

#[test]
fn every_file_reads_back_as_the_texels_the_renderer_uploads() {
    let prepared = common::house();
    let inputs = prepared.inputs();
    for (name, path) in [
        ("shlmap", HwPath::Dx11),
        ("unc6", HwPath::Dx11),
        ("unc6", HwPath::Dx10),
        ("preconv", HwPath::Dx11),
        ("rnm", HwPath::Dx10),
        ("rnm", HwPath::Dx11),
    ] {
        let t: Technique = name.parse().unwrap();
        let label = format!("{t}.{path}");
        let out = export(prepared, t, path).unwrap_or_else(|e| panic!("{label}: {e}"));
        let manifest: serde_json::Value =
            serde_json::from_slice(out.file("manifest.json").expect("manifest")).unwrap();
        assert_eq!(manifest["technique"], name);
        assert_eq!(manifest["path"], path.name());
        for (file, _) in &out.files {
            if file != "manifest.json" {
                assert!(
                    manifest.to_string().contains(file.as_str()),
                    "{label}: the manifest names {file}"
                );
            }
        }
        // The per-texel images as `technique::block::upload_per_texel` uploads them.
        let texels = per_texel_data(t, path, &inputs).unwrap();
        let uploads: Vec<(ash::vk::Format, u32, Vec<u8>)> = match path {
            HwPath::Dx11 => compress(&texels, dx11_codec(t, &label).unwrap(), &label)
                .unwrap()
                .image_levels()
                .into_iter()
                .map(|(desc, levels, _)| (desc.format, desc.layers, levels[0].concat()))
                .collect(),
            HwPath::Dx9 | HwPath::Dx10 => {
                vec![(
                    texels.format,
                    texels.groups.len() as u32,
                    texels.groups.concat(),
                )]
            }
        };
        for ((format, layers, bytes), file) in uploads
            .iter()
            .zip(["per_texel.ktx2", "per_texel_norms.ktx2"])
        {
            let read = level0(out.file(file).expect(file), *format, texels.res, *layers, 1);
            assert!(read == *bytes, "{label}: {file} holds the uploaded texels");
        }
        // The tables as `NormalTableData::upload` uploads them.
        let recipe = LightingRecipe::new(t, path, &inputs).unwrap();
        let lighting = recipe
            .build(inputs.radiance_sh, inputs.irradiance_sh)
            .unwrap();
        assert_eq!(out.file("params.bin"), Some(lighting.params.as_slice()));
        if let Some(tables) = &lighting.tables {
            for (i, image) in tables.images.iter().enumerate() {
                let file = format!("table_{i}.ktx2");
                let desc = image.desc;
                let read = level0(
                    out.file(&file).expect("table"),
                    desc.format,
                    desc.width,
                    desc.layers / 6,
                    6,
                );
                assert!(
                    read == tables.image_levels(i)[0].concat(),
                    "{label}: {file}"
                );
            }
        } else {
            assert!(out.file("table_0.ktx2").is_none());
        }
    }
}

#[test]
fn the_decode_snippet_draws_the_techniques_image() {
    let ctx = common::validated_context();
    let prepared = common::house();
    let settings = FrameSettings {
        width: 160,
        height: 100,
        ..FrameSettings::default()
    };
    let scene = SceneGpu::new(&ctx, &prepared.scene, &settings).unwrap();
    for (name, path) in [
        ("shlmap", HwPath::Dx11),
        ("unc6", HwPath::Dx11),
        ("unc6", HwPath::Dx10),
        ("rnm", HwPath::Dx10),
        ("rnm", HwPath::Dx11),
    ] {
        let t: Technique = name.parse().unwrap();
        let out = export(prepared, t, path).unwrap();
        let snippet = std::str::from_utf8(out.file("decode.glsl").unwrap()).unwrap();
        assert!(!snippet.contains("#include"), "self-contained");
        let spirv = compile_source("decode.glsl", snippet, ShaderStage::Fragment, &[])
            .unwrap_or_else(|e| panic!("{t}.{path}: the snippet compiles: {e}"));
        let own = technique::build(&ctx, &scene, t, path, &prepared.inputs()).unwrap();
        let expected = own.render(&scene, 0, 1).unwrap();
        drop(own);
        let snippet_built =
            technique::build_with_fragment(&ctx, &scene, t, path, &prepared.inputs(), spirv)
                .unwrap();
        let got = snippet_built.render(&scene, 0, 1).unwrap();
        drop(snippet_built);
        let worst = expected
            .rgba
            .iter()
            .zip(&got.rgba)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .fold(0f32, f32::max);
        assert!(
            worst <= 1e-6,
            "{t}.{path}: the snippet's image differs by {worst}"
        );
    }
    drop(scene);
    common::assert_validation_clean(&ctx, "export snippets");
}

/// The export's glTF (`scene::gltf::write`) is valid to the `gltf` crate and loads back
/// through shvis' own loader to the scene the lightmap was baked for: the same triangles,
/// positions, normals, tangents, both UV sets (TEXCOORD_1 taken as given), tints, textures
/// and camera.
#[test]
fn the_exported_gltf_loads_back_to_the_baked_scene() {
    let prepared = common::house();
    let out = export(prepared, "shlmap".parse().unwrap(), HwPath::Dx10).unwrap();
    let dir = std::env::temp_dir().join(format!("shvis-export-gltf-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in &out.files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    let gltf = gltf::Gltf::from_slice(out.file("scene.gltf").unwrap()).expect("valid glTF");
    let primitive = gltf.meshes().next().unwrap().primitives().next().unwrap();
    for semantic in [
        "POSITION",
        "NORMAL",
        "TANGENT",
        "TEXCOORD_0",
        "TEXCOORD_1",
        "COLOR_0",
    ] {
        assert!(
            primitive
                .attributes()
                .any(|(s, _)| s.to_string() == semantic),
            "{semantic}"
        );
    }
    let manifest: serde_json::Value =
        serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
    assert_eq!(manifest["geometry"]["gltf"], "scene.gltf");

    assert_reopens_as_baked(&dir, prepared);
    let _ = std::fs::remove_dir_all(&dir);
}

/// shvis' own loader reads the export's glTF in `dir` back to `prepared`'s scene: the same
/// triangles, positions, normals, tangents, both UV sets (TEXCOORD_1 taken as given),
/// tints, textures and camera.
fn assert_reopens_as_baked(dir: &std::path::Path, prepared: &shvis::prepare::Prepared) {
    let baked = &prepared.scene;
    let res = prepared.visibility.res;
    let loaded = shvis::scene::gltf::load(&dir.join("scene.gltf"), res).unwrap();
    assert_eq!(loaded.mesh.indices, baked.mesh.indices);
    assert_eq!(loaded.mesh.vertices.len(), baked.mesh.vertices.len());
    for (a, b) in loaded.mesh.vertices.iter().zip(&baked.mesh.vertices) {
        assert_eq!(a.position, b.position);
        assert_eq!(a.uv_material, b.uv_material);
        assert_eq!(a.uv_lightmap, b.uv_lightmap);
        assert_eq!(a.albedo_tint, b.albedo_tint);
        let close = |x: &[f32], y: &[f32]| x.iter().zip(y).all(|(p, q)| (p - q).abs() < 1e-5);
        assert!(close(&a.normal, &b.normal), "{:?} {:?}", a.normal, b.normal);
        assert!(
            close(&a.tangent, &b.tangent),
            "{:?} {:?}",
            a.tangent,
            b.tangent
        );
    }
    for (a, b) in [
        (&loaded.material.albedo, &baked.material.albedo),
        (&loaded.material.normal, &baked.material.normal),
    ] {
        assert_eq!((a.width, a.height), (b.width, b.height));
        assert!(a.texels == b.texels);
    }
    assert_eq!(loaded.material.normal_scale, baked.material.normal_scale);
    let (c, d) = (loaded.camera, baked.camera);
    assert!((c.position - d.position).length() < 1e-4);
    let forward = |cam: shvis::scene::Camera| (cam.target - cam.position).normalize();
    assert!(forward(c).dot(forward(d)) > 0.9999);
    assert!((c.fov_y - d.fov_y).abs() < 1e-6);
}

/// Runs `tests/engine/SCRIPT` under node with `args`, which must succeed, and returns the
/// JSON it prints on stdout (`label` names the failures).
fn engine_script(script: &str, args: &[&std::ffi::OsStr], label: &str) -> serde_json::Value {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/engine")
        .join(script);
    let run = std::process::Command::new("node")
        .arg(path)
        .args(args)
        .output()
        .expect("node (scripts/install-deps.sh installs it)");
    assert!(
        run.status.success(),
        "{label}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    serde_json::from_slice(&run.stdout).unwrap()
}

/// The export in `dir` read with nothing of shvis (`tests/engine/check_export.mjs`): its
/// report (every KTX2 file through ktx-parse, the glTF through the Khronos validator),
/// after checking the validator found no error and no warning.
fn read_with_engine_tools(dir: &std::path::Path, label: &str) -> serde_json::Value {
    let report = engine_script("check_export.mjs", &[dir.as_os_str()], label);
    let gltf = &report["gltf"];
    assert_eq!(gltf["numErrors"], 0, "{label}: {gltf}");
    assert_eq!(gltf["numWarnings"], 0, "{label}: {gltf}");
    report
}

/// Every exportable technique on dx10 and dx11 (of the clustered ones, those the test house
/// fits clusters for), its files read as an engine's tools read them, with nothing of shvis
/// (`tests/engine/check_export.mjs`, npm packages pinned by its lockfile): each KTX2 file
/// through ktx-parse — the format, size, layers and faces the manifest names, one level,
/// no supercompression, BT.709 linear, the sample bounds libktx writes, `KTXorientation`
/// "rd" and a `KTXwriter` — and the glTF through the Khronos glTF validator: no errors, no
/// warnings.
#[test]
fn ktx_parse_and_the_gltf_validator_read_every_export() {
    let prepared = common::house();
    let res = prepared.visibility.res;
    let exportable: Vec<(Technique, HwPath)> = Technique::families()
        .into_iter()
        .flat_map(|(_, members, _)| members)
        .flat_map(|t| [(t, HwPath::Dx10), (t, HwPath::Dx11)])
        .filter(|&(t, path)| shvis::export::refusal(t, path).is_none())
        .collect();
    assert!(exportable.len() >= 40, "{} exports", exportable.len());
    let (mut clustered, mut unfitted) = (0, 0);
    for (t, path) in exportable {
        let label = format!("{t}.{path}");
        let out = match export(prepared, t, path) {
            Ok(out) => out,
            // The shared house fits only the cost table's clusters.
            Err(e) if t.needs().clusters.is_some() && e.to_string().contains("cluster") => {
                unfitted += 1;
                continue;
            }
            Err(e) => panic!("{label}: {e}"),
        };
        clustered += usize::from(t.needs().clusters.is_some());
        let dir = std::env::temp_dir().join(format!(
            "shvis-export-engine-{}-{label}",
            std::process::id()
        ));
        out.write(&dir).unwrap();
        let report = read_with_engine_tools(&dir, &label);

        let manifest: serde_json::Value =
            serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
        assert_block_covers_params(&label, &manifest, out.file("params.bin").unwrap_or(&[]));
        assert_eq!(manifest["lightmap"]["orientation"], "rd", "{label}");
        assert_eq!(
            manifest["conventions"]["sh_basis"]["pole_axis"], "+Z",
            "{label}"
        );
        let files = report["ktx2"].as_array().unwrap();
        let named = out
            .files
            .iter()
            .filter(|(f, _)| f.ends_with(".ktx2"))
            .count();
        assert_eq!(files.len(), named, "{label}: ktx-parse read every file");
        for file in files {
            let f = file["file"].as_str().unwrap();
            let format = ash::vk::Format::from_raw(file["vkFormat"].as_i64().unwrap() as i32);
            assert!(
                manifest.to_string().contains(&format!("{format:?}")),
                "{label}/{f}: the manifest names {format:?}"
            );
            assert_eq!(file["levelCount"], 1, "{label}/{f}");
            assert_eq!(file["supercompressionScheme"], 0, "{label}/{f}");
            assert_eq!(file["pixelDepth"], 0, "{label}/{f}");
            assert_eq!(
                (
                    file["colorPrimaries"].clone(),
                    file["transferFunction"].clone()
                ),
                (1.into(), 1.into())
            );
            if f.starts_with("per_texel") {
                assert_eq!(file["pixelWidth"], res, "{label}/{f}");
                assert_eq!(file["pixelHeight"], res, "{label}/{f}");
            }
            assert_eq!(file["keyValue"]["KTXorientation"], "rd", "{label}/{f}");
            assert!(
                file["keyValue"]["KTXwriter"]
                    .as_str()
                    .is_some_and(|w| w.starts_with("shvis ")),
                "{label}/{f}"
            );
            let (one, minus_one) = (1f32.to_bits(), (-1f32).to_bits());
            let bounds = match format {
                ash::vk::Format::BC6H_UFLOAT_BLOCK => (0, one),
                ash::vk::Format::BC7_UNORM_BLOCK | ash::vk::Format::BC4_UNORM_BLOCK => {
                    (0, u32::MAX)
                }
                ash::vk::Format::R8G8B8A8_UNORM | ash::vk::Format::R8_UNORM => (0, 255),
                _ => (minus_one, one),
            };
            for sample in file["samples"].as_array().unwrap() {
                assert_eq!(
                    (sample["lower"].as_u64(), sample["upper"].as_u64()),
                    (Some(bounds.0.into()), Some(bounds.1.into())),
                    "{label}/{f}: {sample}"
                );
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(clustered >= 4, "{clustered} clustered exports read");
    eprintln!(
        "{clustered} clustered exports read; {unfitted} have no cluster fit on the test house"
    );
}

/// The manifest's `uniform_block` of an export spells out its `params.bin`: the block by
/// name, every field a vec4 with its std140 offset, count and values, the fields following
/// each other and covering the file byte for byte.
fn assert_block_covers_params(label: &str, manifest: &serde_json::Value, params: &[u8]) {
    let block = &manifest["uniform_block"];
    assert_eq!(block["bytes"], params.len(), "{label}");
    if params.is_empty() {
        return;
    }
    assert!(
        block["block"]
            .as_str()
            .is_some_and(|b| b.ends_with("Params")),
        "{label}: {block}"
    );
    let fields = block["fields"].as_array().unwrap();
    assert!(!fields.is_empty(), "{label}");
    let mut rebuilt = vec![0u8; params.len()];
    let mut end = 0;
    for field in fields {
        assert_eq!(field["type"], "vec4", "{label}: {field}");
        let offset = field["offset"].as_u64().unwrap() as usize;
        let count = field["count"].as_u64().unwrap() as usize;
        assert_eq!(offset, end, "{label}: fields follow each other");
        let values = field["values"].as_array().unwrap();
        // A lone vec4 holds its four components; an array, one list per element.
        let elements: Vec<&serde_json::Value> = if count == 1 && !values[0].is_array() {
            vec![&field["values"]]
        } else {
            values.iter().collect()
        };
        for (k, element) in elements.iter().enumerate() {
            for (c, v) in element.as_array().unwrap().iter().enumerate() {
                let at = offset + 16 * k + 4 * c;
                rebuilt[at..at + 4].copy_from_slice(&(v.as_f64().unwrap() as f32).to_le_bytes());
            }
        }
        end = offset + 16 * count;
    }
    assert_eq!(end, params.len(), "{label}: the fields cover params.bin");
    assert_eq!(rebuilt, params, "{label}: the values are params.bin's");
}

/// The manifest spells out `params.bin` (`assert_block_covers_params`), the techniques of
/// the engine tests here; every other export in `ktx_parse_and_the_gltf_validator_read_every_export`.
#[test]
fn the_manifest_spells_out_the_uniform_block() {
    let prepared = common::house();
    for name in ["shlmap", "sg9", "dice", "unc6"] {
        let out = export(prepared, name.parse().unwrap(), HwPath::Dx10).unwrap();
        let manifest: serde_json::Value =
            serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
        assert_block_covers_params(name, &manifest, out.file("params.bin").unwrap());
    }
}

/// docs/export.md's table of what each technique exports on dx10 and dx11: `yes`, or why
/// not, in `shvis::export::refusal`'s words; a family's members with the same answers share
/// a row.
fn export_table() -> String {
    let cell = |t: Technique, path: HwPath| match shvis::export::refusal(t, path) {
        None => "yes".to_string(),
        Some(shvis::export::ExportError::Refused { detail, .. }) => detail,
        Some(other) => other.to_string(),
    };
    let mut table = String::from("| techniques | dx10 | dx11 |\n|---|---|---|\n");
    for (_, members, _) in Technique::families() {
        let mut rows: Vec<(Vec<String>, String, String)> = Vec::new();
        for t in members {
            let (dx10, dx11) = (cell(t, HwPath::Dx10), cell(t, HwPath::Dx11));
            match rows.iter_mut().find(|(_, a, b)| *a == dx10 && *b == dx11) {
                Some((names, _, _)) => names.push(format!("`{t}`")),
                None => rows.push((vec![format!("`{t}`")], dx10, dx11)),
            }
        }
        for (names, dx10, dx11) in rows {
            table += &format!("| {} | {dx10} | {dx11} |\n", names.join(", "));
        }
    }
    table
}

/// docs/export.md lists what each technique exports, as `shvis export` decides it (the
/// table is regenerated by `cargo test --test export print_the_export_table -- --ignored
/// --nocapture`).
#[test]
fn docs_list_what_each_technique_exports() {
    let docs =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/export.md")).unwrap();
    assert!(
        docs.contains(&export_table()),
        "docs/export.md's table differs from shvis export's refusals:\n{}",
        export_table()
    );
}

/// Prints docs/export.md's table of what each technique exports.
#[test]
#[ignore]
fn print_the_export_table() {
    print!("{}", export_table());
}

/// The manifest's `shader.inputs` are the fragment inputs `decode.glsl` declares, name and
/// type, each with the glTF attribute that carries it.
#[test]
fn the_manifest_names_every_input_of_the_decode_shader() {
    let prepared = common::house();
    let out = export(prepared, "hb4".parse().unwrap(), HwPath::Dx10).unwrap();
    let snippet = std::str::from_utf8(out.file("decode.glsl").unwrap()).unwrap();
    // The reference's G-buffer input sits in a branch export's defines leave out.
    let mut in_gbuffer_branch = false;
    let declared: Vec<(String, String)> = snippet
        .lines()
        .filter(|l| {
            if l.starts_with("#if") && l.contains("SHVIS_GBUFFER") {
                in_gbuffer_branch = true;
            } else if in_gbuffer_branch && l.starts_with("#endif") {
                in_gbuffer_branch = false;
                return false;
            }
            !in_gbuffer_branch
        })
        .filter_map(|l| {
            let rest = l.trim().strip_prefix("layout(location = ")?;
            let decl = rest.split_once(") in ")?.1.trim_end_matches(';');
            let (ty, name) = decl.split_once(' ')?;
            Some((name.to_string(), ty.to_string()))
        })
        .collect();
    let manifest: serde_json::Value =
        serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
    let named: Vec<(String, String)> = manifest["shader"]["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            (
                i["name"].as_str().unwrap().into(),
                i["type"].as_str().unwrap().into(),
            )
        })
        .collect();
    assert_eq!(declared, named);
}

/// Linear RGBA f32 pixels, the top row first, as `render_in_chromium.mjs` writes them.
fn read_f32_frame(path: &std::path::Path, width: u32, height: u32) -> shvis::render::Frame {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(bytes.len(), (width * height * 16) as usize);
    let values: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    shvis::render::Frame {
        width,
        height,
        rgba: values
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect(),
        ms: Vec::new(),
    }
}

/// How the three.js page shades: with the export's decode.glsl, or with a shader it writes
/// from the manifest's value map alone.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Shading {
    DecodeGlsl,
    Manifest,
}

/// What the three.js page drew against shvis' render of one export.
struct EngineComparison {
    label: String,
    rel_rmse: f64,
    compared: u64,
    elsewhere: u64,
}

/// Exports each of `exports` from `prepared`, draws it with the three.js page
/// (tests/engine/view.mjs) in headless Chromium at `width` × `height`, shaded as `shading`
/// says, and compares its linear image with shvis' own render of the technique. The two rasterizers (lavapipe,
/// SwiftShader) place triangle edges a fraction of a pixel apart, so a few pixels along
/// silhouettes see another surface in each image (a pillar in one, the wall behind it in the
/// other, or a triangle across a mirrored-UV seam whose normal-map frame is flipped): those
/// are told apart by what they see — world position, vertex normal and the normal map's
/// bitangent from both renderers — and counted, not compared. Both images go to `root` as PNGs and as
/// f32 RGBA (`LABEL.shvis.f32`, `LABEL.radiance.f32`).
fn compare_in_three_js(
    ctx: &std::sync::Arc<shvis::gpu::Context>,
    prepared: &shvis::prepare::Prepared,
    exports: &[(&str, HwPath)],
    (width, height): (u32, u32),
    shading: Shading,
    root: &std::path::Path,
) -> Vec<EngineComparison> {
    let settings = FrameSettings {
        width,
        height,
        ..FrameSettings::default()
    };
    let scene = SceneGpu::new(ctx, &prepared.scene, &settings).unwrap();
    let seen = shvis::reference::render_point_gbuffer(ctx, &prepared.scene, width, height).unwrap();
    let eye = prepared.scene.camera.position;
    let _ = std::fs::remove_dir_all(root);
    std::fs::create_dir_all(root).unwrap();
    let mut results = Vec::new();
    for &(name, path) in exports {
        let t: Technique = name.parse().unwrap();
        let label = format!("{t}.{path}");
        let dir = root.join(&label);
        export(prepared, t, path).unwrap().write(&dir).unwrap();
        let own = technique::build(ctx, &scene, t, path, &prepared.inputs()).unwrap();
        let expected = own.render(&scene, 0, 1).unwrap();
        drop(own);
        let (width_arg, height_arg, out) =
            (width.to_string(), height.to_string(), root.join(&label));
        let mut args = vec![
            dir.as_os_str(),
            width_arg.as_ref(),
            height_arg.as_ref(),
            out.as_os_str(),
        ];
        if shading == Shading::Manifest {
            args.push("manifest".as_ref());
        }
        let offered = engine_script("render_in_chromium.mjs", &args, &label);
        assert_eq!(
            offered["bptc"], true,
            "{label}: the browser exposes no EXT_texture_compression_bptc ({offered})"
        );
        let read =
            |kind: &str| read_f32_frame(&root.join(format!("{label}.{kind}.f32")), width, height);
        let (got, position, normal) = (read("radiance"), read("position"), read("normal"));
        let bitangent = read("bitangent");
        let (mut squared_error, mut squared) = (0f64, 0f64);
        let (mut compared, mut elsewhere) = (0u64, 0u64);
        for p in 0..(width * height) as usize {
            let (a, b) = (expected.rgba[p], got.rgba[p]);
            match (a[3] > 0.5, b[3] > 0.5) {
                (false, false) => continue,
                (true, true) => {}
                _ => {
                    elsewhere += 1;
                    continue;
                }
            }
            let v3 = |f: &shvis::render::Frame| glam::Vec3::from_slice(&f.rgba[p][..3]);
            let gap = v3(&seen.position).distance(v3(&position));
            let distance = v3(&seen.position).distance(eye);
            let facing = v3(&seen.vertex_normal).dot(v3(&normal));
            let frame = v3(&seen.bitangent).dot(v3(&bitangent));
            if gap > 0.01 * distance || facing < 0.999 || frame < 0.99 {
                elsewhere += 1;
                continue;
            }
            compared += 1;
            for c in 0..3 {
                squared_error += f64::from(a[c] - b[c]).powi(2);
                squared += f64::from(a[c]).powi(2);
            }
        }
        let expected_bytes: Vec<u8> = expected
            .rgba
            .iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
            .collect();
        std::fs::write(root.join(format!("{label}.shvis.f32")), expected_bytes).unwrap();
        for (frame, file) in [(&expected, "shvis"), (&got, "three")] {
            shvis::report::image::write_png(&root.join(format!("{label}.{file}.png")), frame, 0.0)
                .unwrap();
        }
        let rel_rmse = (squared_error / squared).sqrt();
        eprintln!(
            "{label}: rel. RMSE {:.3} % over {compared} pixels; {elsewhere} pixels see another surface in each image ({})",
            100.0 * rel_rmse,
            offered["renderer"]
        );
        results.push(EngineComparison {
            label,
            rel_rmse,
            compared,
            elsewhere,
        });
    }
    drop(scene);
    results
}

/// The page's image matches shvis' within 2 % relative RMSE over the pixels both see alike,
/// which are most of the frame; those that see another surface are at most 1 % of them.
fn assert_engine_matches(results: &[EngineComparison], pixels: u32) {
    for r in results {
        let label = &r.label;
        assert!(
            r.compared > u64::from(pixels) / 16,
            "{label}: {} pixels compared",
            r.compared
        );
        assert!(
            r.elsewhere * 100 <= r.compared,
            "{label}: {} pixels see another surface",
            r.elsewhere
        );
        assert!(r.rel_rmse <= 0.02, "{label}: relative RMSE {}", r.rel_rmse);
    }
}

/// An engine loads the export from its files alone: three.js (tests/engine/view.mjs, npm
/// `three` and `ktx-parse` pinned by the lockfile) in headless Chromium reads the glTF, the
/// KTX2 files, the manifest and decode.glsl, and draws the scene from the glTF's camera. Its
/// linear image matches shvis' own render of the technique within 2 % relative RMSE
/// ([`compare_in_three_js`]), on dx10 data and on dx11 data (BC7/BC6H through
/// EXT_texture_compression_bptc). The images are in target/tmp/engine_threejs.
#[test]
fn three_js_in_headless_chromium_draws_each_export_as_shvis_renders_it() {
    three_js_draws_the_house(
        &["shlmap", "l1", "zh3", "hb4", "sg9", "dice"],
        Shading::DecodeGlsl,
        "engine_threejs",
    );
}

/// [`compare_in_three_js`] of `techniques` on dx10 and dx11 on the test house at 320 × 200,
/// each within 2 % ([`assert_engine_matches`]); the images go to target/tmp/`folder`.
fn three_js_draws_the_house(techniques: &[&str], shading: Shading, folder: &str) {
    let ctx = common::validated_context();
    let exports: Vec<(&str, HwPath)> = techniques
        .iter()
        .flat_map(|&t| [(t, HwPath::Dx10), (t, HwPath::Dx11)])
        .collect();
    let root = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(folder);
    let size = (320, 200);
    let results = compare_in_three_js(&ctx, common::house(), &exports, size, shading, &root);
    assert_engine_matches(&results, size.0 * size.1);
    common::assert_validation_clean(&ctx, folder);
}

/// A glTF scene's export (NormalTangentMirrorTest, from ../shared/assets: no lightmap UVs
/// of its own, so the export carries the ones shvis made) passes the Khronos glTF validator
/// (no errors, no warnings), reopens in shvis as the scene it baked, and three.js draws it
/// with the lightmap in place as shvis renders it (within 2 % relative RMSE, at 640 × 400:
/// the model fills a small part of its camera's view).
#[test]
fn a_gltf_scene_exports_and_reopens_in_shvis_and_three_js() {
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/assets/models/NormalTangentMirrorTest/NormalTangentMirrorTest.gltf"
    );
    let root = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("engine_threejs_gltf");
    let prepared = shvis::prepare::prepare(&shvis::prepare::PrepareSettings {
        scene: model.into(),
        vis_res: 128,
        rays: 64,
        cache_dir: Some(concat!(env!("CARGO_TARGET_TMPDIR"), "/bake-cache").into()),
        sh_lightmap_bounces: Some(shvis::bake::shlmap::DEFAULT_BOUNCES),
        sample_fits: shvis::prepare::sample_fits_for(
            &["hb4".parse().unwrap()],
            &Default::default(),
        ),
        ..Default::default()
    })
    .expect("the glTF prepares");
    let reopened = root.join("reopened");
    let _ = std::fs::remove_dir_all(&reopened);
    export(&prepared, "shlmap".parse().unwrap(), HwPath::Dx10)
        .unwrap()
        .write(&reopened)
        .unwrap();
    assert_reopens_as_baked(&reopened, &prepared);
    read_with_engine_tools(&reopened, "glTF scene");

    let ctx = common::validated_context();
    let size = (640, 400);
    let results = compare_in_three_js(
        &ctx,
        &prepared,
        &[
            ("shlmap", HwPath::Dx10),
            ("shlmap", HwPath::Dx11),
            ("hb4", HwPath::Dx11),
        ],
        size,
        Shading::DecodeGlsl,
        &root.join("three"),
    );
    assert_engine_matches(&results, size.0 * size.1);
    common::assert_validation_clean(&ctx, "three.js comparison of a glTF scene");
}

/// The manifest maps every per-texel value (value j: coefficient, basis index, colour) for
/// each technique that describes its values as data; the other channels are padding, and
/// padding is zero in every texel of the dx10 file.
#[test]
fn the_manifest_maps_every_value_and_the_padding_is_zero() {
    let prepared = common::house();
    let mut described = Vec::new();
    for (_, members, _) in Technique::families() {
        for t in members {
            if shvis::export::refusal(t, HwPath::Dx10).is_some()
                || t.needs().clusters.is_some()
                || t.values().is_none()
            {
                continue;
            }
            let out = export(prepared, t, HwPath::Dx10).unwrap();
            let manifest: serde_json::Value =
                serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
            let per_texel = &manifest["per_texel"];
            let values = &per_texel["values"];
            let total = per_texel["values_per_texel"].as_u64().unwrap() as usize;
            let count = values["count"].as_u64().unwrap() as usize;
            let padding: Vec<usize> = values["padding"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| p.as_u64().unwrap() as usize)
                .collect();
            let map = values["map"].as_array().unwrap();
            assert_eq!(map.len(), count, "{t}");
            let mut js: Vec<usize> = map
                .iter()
                .map(|e| e["j"].as_u64().unwrap() as usize)
                .chain(padding.iter().copied())
                .collect();
            js.sort_unstable();
            assert_eq!(
                js,
                (0..total).collect::<Vec<_>>(),
                "{t}: values and padding cover each channel once"
            );
            let mut seen = std::collections::HashSet::new();
            for entry in map {
                let key = (
                    entry["index"].as_u64().unwrap(),
                    entry["colour"].to_string(),
                );
                assert!(
                    seen.insert(key),
                    "{t}: value {} maps what another value maps",
                    entry["j"]
                );
            }
            assert!(!values["shading"].as_array().unwrap().is_empty(), "{t}");
            let layers = per_texel["layers"].as_u64().unwrap() as u32;
            let res = per_texel["res"].as_u64().unwrap() as u32;
            let format = ash::vk::Format::R16G16B16A16_SFLOAT;
            if out.file("per_texel.ktx2").is_some()
                && per_texel["files"][0]["format"] == format!("{format:?}")
            {
                let data = level0(out.file("per_texel.ktx2").unwrap(), format, res, layers, 1);
                let texel_bytes = (res * res * 8) as usize;
                for &p in &padding {
                    let layer = &data[(p / 4) * texel_bytes..(p / 4 + 1) * texel_bytes];
                    let nonzero = layer
                        .chunks_exact(8)
                        .filter(|texel| texel[2 * (p % 4)..2 * (p % 4) + 2] != [0, 0])
                        .count();
                    assert_eq!(nonzero, 0, "{t}: padding value {p} is not zero");
                }
            }
            described.push(t.to_string());
        }
    }
    for name in [
        "unc6", "shlmap", "l1", "zh3", "l1lum", "hb4", "sg9", "dice", "dicey", "acube",
    ] {
        assert!(
            described.contains(&name.to_string()),
            "{name} describes its values"
        );
    }
}

/// docs/export.md's table of what each exported technique binds at run time (dx10, from
/// the shared test house's exports; the clustered members the house fits no clusters for
/// are counted below it): its per-texel data, its tables, its uniform block and whether it
/// reads the normal map.
fn run_time_table() -> String {
    let prepared = common::house();
    let short = |format: &str| {
        format
            .replace("R16G16B16A16_SFLOAT", "RGBA16F")
            .replace("R8G8B8A8_UNORM", "RGBA8")
            .replace("R8_UNORM", "R8")
            .replace("R16_SFLOAT", "R16F")
    };
    let mut table = String::from(
        "| techniques | per-texel data | tables | uniform block (`params.bin`) | normal map |\n|---|---|---|---|---|\n",
    );
    let mut unfitted = Vec::new();
    for (_, members, _) in Technique::families() {
        let mut rows: Vec<(Vec<String>, [String; 4])> = Vec::new();
        for t in members {
            if shvis::export::refusal(t, HwPath::Dx10).is_some() {
                continue;
            }
            let Ok(out) = export(prepared, t, HwPath::Dx10) else {
                unfitted.push(format!("`{t}`"));
                continue;
            };
            let m: serde_json::Value =
                serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
            let per_texel = &m["per_texel"];
            let layers = per_texel["layers"].as_u64().unwrap();
            let data = format!(
                "{layers} layer{} {}",
                if layers == 1 { "" } else { "s" },
                short(per_texel["files"][0]["format"].as_str().unwrap())
            );
            let tables: Vec<String> = m["tables"]
                .as_array()
                .unwrap()
                .iter()
                .map(|t| {
                    let kind = if t["kind"].as_str().unwrap().starts_with("cube") {
                        "cube array"
                    } else {
                        "2D array"
                    };
                    format!(
                        "{kind}, {} layers {}",
                        t["layers"],
                        short(t["format"].as_str().unwrap())
                    )
                })
                .collect();
            let tables = if tables.is_empty() {
                "none".to_string()
            } else {
                tables.join("; ")
            };
            let block = &m["uniform_block"];
            let block = format!(
                "`{}`, {} bytes",
                block["block"].as_str().unwrap(),
                block["bytes"]
            );
            let normal_map = if t.reads().reads_normal_map {
                "yes"
            } else {
                "no"
            }
            .to_string();
            let cells = [data, tables, block, normal_map];
            match rows.iter_mut().find(|(_, c)| *c == cells) {
                Some((names, _)) => names.push(format!("`{t}`")),
                None => rows.push((vec![format!("`{t}`")], cells)),
            }
        }
        for (names, cells) in rows {
            table += &format!("| {} | {} |\n", names.join(", "), cells.join(" | "));
        }
    }
    if !unfitted.is_empty() {
        table += &format!(
            "\nNot in the table: {} clustered members (the other `vq*` and `cpca*`). The table comes from the test suite's house, which fits only the cost table's clusters; `shvis export` fits a member's clusters and writes it like the `cpca` rows above.\n",
            unfitted.len()
        );
    }
    table
}

/// docs/export.md lists what each exported technique needs at run time, as its export
/// binds it (regenerate with `cargo test --test export print_the_run_time_table -- --ignored
/// --nocapture`).
#[test]
fn docs_list_what_each_export_needs_at_run_time() {
    let docs =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/export.md")).unwrap();
    let table = run_time_table();
    assert!(
        docs.contains(&table),
        "docs/export.md's run-time table differs from the exports:\n{table}"
    );
}

/// Prints docs/export.md's table of what each exported technique needs at run time.
#[test]
#[ignore]
fn print_the_run_time_table() {
    print!("{}", run_time_table());
}

/// The field paths of a manifest value: objects by key, list elements as `[]`; the maps
/// keyed by names (`shader.defines`, `shader.bindings`), the basis' own parameters and the
/// shading steps' arguments stop at their own path.
fn field_paths(
    value: &serde_json::Value,
    path: &str,
    out: &mut std::collections::BTreeSet<String>,
) {
    let opaque = [
        "shader.defines",
        "shader.bindings",
        "per_texel.values.basis",
        "per_texel.values.shading[]",
    ];
    match value {
        serde_json::Value::Object(map) if !opaque.contains(&path) => {
            for (k, v) in map {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                field_paths(v, &p, out);
            }
        }
        serde_json::Value::Array(items) if items.first().is_some_and(|i| i.is_object()) => {
            if opaque.contains(&path) {
                out.insert(path.to_string());
            }
            for item in items {
                field_paths(item, &format!("{path}[]"), out);
            }
        }
        _ => {
            out.insert(path.to_string());
        }
    }
}

/// docs/export.md's schema names every field the manifests of several techniques on both
/// paths hold.
#[test]
fn the_docs_schema_names_every_manifest_field() {
    let prepared = common::house();
    let docs =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/export.md")).unwrap();
    let schema = docs
        .split("### Schema")
        .nth(1)
        .expect("docs/export.md has a schema section")
        .split("\n## ")
        .next()
        .unwrap();
    let mut fields = std::collections::BTreeSet::new();
    for name in ["shlmap", "unc6", "pca8", "sg9", "dicey", "preconv"] {
        for path in [HwPath::Dx10, HwPath::Dx11] {
            let out = export(prepared, name.parse().unwrap(), path).unwrap();
            let manifest: serde_json::Value =
                serde_json::from_slice(out.file("manifest.json").unwrap()).unwrap();
            field_paths(&manifest, "", &mut fields);
        }
    }
    let missing: Vec<&String> = fields
        .iter()
        .filter(|f| !schema.contains(&format!("`{f}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "fields the schema does not name: {missing:?}"
    );
}

/// The manifest is the whole contract for the SH, H-basis and SG rows: the three.js page
/// writes its fragment shader from `per_texel.values`, `per_texel.codec` and
/// `conventions.sh_basis` alone (`manifestShader` in tests/engine/view.mjs, no decode.glsl)
/// and draws `shlmap`, `l1`, `hb4` and `sg9` from dx10 and dx11 exports as shvis renders
/// them, within 2 % relative RMSE.
#[test]
fn three_js_shades_from_the_manifest_alone() {
    three_js_draws_the_house(
        &["shlmap", "l1", "hb4", "sg9"],
        Shading::Manifest,
        "engine_threejs_manifest",
    );
}
