//! Writing generated maps and the low mesh that uses them.
//!
//! - `.png`: 16-bit RGB, each component encoded c ↦ (c + 1)/2 (the glTF convention the
//!   scene loader decodes; +Y green for tangent space).
//! - `.exr`: f32 RGBA, the raw signed components and the coverage flag in A (1 generated,
//!   0.5 expanded, 0 empty) — for inspection and exact comparisons.
//! - [`write_low_gltf`]: the low mesh (world space, identity node) with NORMAL, TANGENT,
//!   TEXCOORD_0 (the map's UVs) and TEXCOORD_1 (its lightmap UVs), one material whose
//!   `normalTexture` is the PNG, ready for `shvis bench --scene`.

use std::path::Path;

use serde_json::json;

use super::NormalMapError;
use crate::render::Frame;
use crate::scene::Mesh;

fn io_error(path: &Path, e: impl std::fmt::Display) -> NormalMapError {
    NormalMapError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes `res`² texels (xyz a unit vector or, where `w` = 0, `empty`) as a 16-bit PNG or
/// an f32 EXR, by the extension of `path` (module doc).
///
/// # Errors
/// Another extension, or a file that cannot be written.
pub fn write_map(
    path: &Path,
    res: u32,
    texels: &[[f32; 4]],
    empty: [f32; 3],
) -> Result<(), NormalMapError> {
    let vector = |t: &[f32; 4]| {
        if t[3] > 0.0 {
            [t[0], t[1], t[2]]
        } else {
            empty
        }
    };
    // A non-finite vector would be written as a valid-looking colour (NaN clamps to 0).
    let non_finite = texels
        .iter()
        .filter(|t| !vector(t).iter().all(|c| c.is_finite()))
        .count();
    if non_finite > 0 {
        return Err(io_error(
            path,
            format!("{non_finite} texels hold a non-finite vector; the map is not written"),
        ));
    }
    match path.extension().and_then(|e| e.to_str()) {
        Some("png") => {
            let mut encoded = Vec::new();
            let data: Vec<u16> = texels
                .iter()
                .flat_map(|t| {
                    vector(t).map(|c| ((c * 0.5 + 0.5).clamp(0.0, 1.0) * 65535.0).round() as u16)
                })
                .collect();
            image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(res, res, data)
                .ok_or_else(|| io_error(path, "texel count is not res²"))?
                .write_to(
                    &mut std::io::Cursor::new(&mut encoded),
                    image::ImageFormat::Png,
                )
                .map_err(|e| io_error(path, e))?;
            crate::files::write(path, &encoded).map_err(|e| io_error(path, e))
        }
        Some("exr") => {
            let frame = Frame {
                width: res,
                height: res,
                rgba: texels
                    .iter()
                    .map(|t| {
                        let [x, y, z] = vector(t);
                        [x, y, z, t[3]]
                    })
                    .collect(),
                ms: Vec::new(),
            };
            crate::report::image::write_exr(path, &frame).map_err(|e| match e {
                crate::report::ReportError::Write { detail, .. } => io_error(path, detail),
                e => io_error(path, e),
            })
        }
        _ => Err(io_error(path, "the output must be a .png or .exr")),
    }
}

/// Writes `mesh` as `path` (.gltf) + `path`.bin, its material's normal texture the image at
/// `normal_map_uri` (relative to the .gltf; `None`: no normal map) (module doc).
///
/// # Errors
/// A file that cannot be written.
pub fn write_low_gltf(
    path: &Path,
    mesh: &Mesh,
    normal_map_uri: Option<&str>,
) -> Result<(), NormalMapError> {
    let (document, buffer) = low_gltf(path, mesh, normal_map_uri)?;
    let bin_path = path.with_extension("bin");
    crate::files::write(&bin_path, &buffer).map_err(|e| io_error(&bin_path, e))?;
    crate::files::write(path, document).map_err(|e| io_error(path, e))
}

/// [`write_low_gltf`]'s two files, unwritten: the glTF document of `path` and the bytes of
/// its buffer `path`.bin.
///
/// # Errors
/// A `path` without a file name.
pub fn low_gltf(
    path: &Path,
    mesh: &Mesh,
    normal_map_uri: Option<&str>,
) -> Result<(String, Vec<u8>), NormalMapError> {
    let n = mesh.vertices.len();
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: &[u8], target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({
            "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(), "target": target
        }));
        bin.extend_from_slice(bytes);
    };
    const ARRAY_BUFFER: u32 = 34962;
    const ELEMENT_ARRAY_BUFFER: u32 = 34963;
    let attr = |f: &dyn Fn(&crate::scene::Vertex) -> Vec<f32>| -> Vec<u8> {
        mesh.vertices
            .iter()
            .flat_map(f)
            .flat_map(f32::to_le_bytes)
            .collect()
    };
    push(&attr(&|v| v.position.to_vec()), ARRAY_BUFFER);
    push(&attr(&|v| v.normal.to_vec()), ARRAY_BUFFER);
    push(&attr(&|v| v.tangent.to_vec()), ARRAY_BUFFER);
    push(&attr(&|v| v.uv_material.to_vec()), ARRAY_BUFFER);
    push(&attr(&|v| v.uv_lightmap.to_vec()), ARRAY_BUFFER);
    let indices: Vec<u8> = mesh.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    push(&indices, ELEMENT_ARRAY_BUFFER);
    let (lo, hi) = mesh.bounds();
    const FLOAT: u32 = 5126;
    const UNSIGNED_INT: u32 = 5125;
    let accessor = |view: usize, kind: &str| json!({ "bufferView": view, "componentType": FLOAT, "count": n, "type": kind });
    let mut position = accessor(0, "VEC3");
    position["min"] = json!(lo.to_array());
    position["max"] = json!(hi.to_array());
    let bin_path = path.with_extension("bin");
    let bin_name = bin_path
        .file_name()
        .and_then(|f| f.to_str())
        .map(crate::scene::gltf::percent_encode)
        .ok_or_else(|| io_error(path, "not a file name"))?;
    let mut material = json!({
        "name": "normalmap",
        "pbrMetallicRoughness": { "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0 },
    });
    let mut document = json!({
        "asset": { "version": "2.0", "generator": "shvis normalmap" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{
            "attributes": { "POSITION": 0, "NORMAL": 1, "TANGENT": 2, "TEXCOORD_0": 3, "TEXCOORD_1": 4 },
            "indices": 5, "material": 0, "mode": 4
        }] }],
        "materials": [],
        "buffers": [{ "uri": bin_name, "byteLength": bin.len() }],
        "bufferViews": views,
        "accessors": [
            position,
            accessor(1, "VEC3"),
            accessor(2, "VEC4"),
            accessor(3, "VEC2"),
            accessor(4, "VEC2"),
            json!({ "bufferView": 5, "componentType": UNSIGNED_INT, "count": mesh.indices.len(), "type": "SCALAR" }),
        ],
    });
    if let Some(uri) = normal_map_uri {
        material["normalTexture"] = json!({ "index": 0 });
        document["images"] = json!([{ "uri": uri }]);
        document["textures"] = json!([{ "source": 0 }]);
    }
    document["materials"] = json!([material]);
    let text = serde_json::to_string_pretty(&document).map_err(|e| io_error(path, e))?;
    Ok((text, bin))
}
