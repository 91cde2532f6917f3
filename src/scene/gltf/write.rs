//! A scene as glTF 2.0 (`shvis export`'s geometry): `scene.gltf`, its buffer `scene.bin` and
//! the material's two images, `albedo.png` and `normal.png`, everything an engine needs to
//! place the exported lightmap on the surfaces it was baked for.
//!
//! One mesh of one indexed TRIANGLES primitive (u32 indices), world space (the node has no
//! transform), with the vertex streams the renderer uploads, each in its own buffer view:
//!
//! ```text
//! POSITION (VEC3, with min/max)   NORMAL (VEC3)   TANGENT (VEC4, w = handedness)
//! TEXCOORD_0 material UVs          TEXCOORD_1 the lightmap UVs the bake used
//! COLOR_0 (VEC3) the per-vertex albedo tint (linear; glTF multiplies it into base colour)
//! ```
//!
//! The material is metallic 0, roughness 1, the base colour texture `albedo.png` (sRGB) and
//! the normal texture `normal.png` with the scene's scale, both repeating; the camera is
//! the scene's (a node looking down its −Z). UVs keep glTF's origin (top left), as shvis
//! stores them, so TEXCOORD_1 addresses the exported lightmap's texels directly (texel
//! centres at (i + ½)/res). [`super::load`] reads the file back to the same scene.

use glam::Quat;
use serde_json::json;

use crate::scene::{Scene, Texture8};

/// File names the writer uses, for the manifest.
pub const GLTF_FILE: &str = "scene.gltf";
pub const BIN_FILE: &str = "scene.bin";
pub const ALBEDO_FILE: &str = "albedo.png";
pub const NORMAL_FILE: &str = "normal.png";

/// glTF's component types and buffer-view targets.
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const REPEAT: u32 = 10497;
const LINEAR: u32 = 9729;
const LINEAR_MIPMAP_LINEAR: u32 = 9987;

/// The files of `scene` as glTF 2.0: (name, bytes), the `.gltf` first.
///
/// # Errors
/// A texture the PNG encoder refuses (its text).
pub fn write_gltf(scene: &Scene) -> Result<Vec<(String, Vec<u8>)>, String> {
    let mesh = &scene.mesh;
    let count = mesh.vertices.len();
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    // Appends one tightly packed stream as a buffer view and its accessor.
    let mut stream = |bytes: &[u8], target: u32, accessor: serde_json::Value| {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        bin.resize(bin.len().next_multiple_of(4), 0);
        views.push(json!({
            "buffer": 0,
            "byteOffset": offset,
            "byteLength": bytes.len(),
            "target": target,
        }));
        let mut accessor = accessor;
        accessor["bufferView"] = json!(views.len() - 1);
        accessors.push(accessor);
        accessors.len() - 1
    };
    let indices = stream(
        bytemuck::cast_slice(&mesh.indices),
        ELEMENT_ARRAY_BUFFER,
        json!({"componentType": UNSIGNED_INT, "count": mesh.indices.len(), "type": "SCALAR"}),
    );
    let (lo, hi) = mesh.bounds();
    let vec = |kind: &str| json!({"componentType": FLOAT, "count": count, "type": kind});
    let floats = |f: &dyn Fn(&crate::scene::Vertex) -> Vec<f32>| -> Vec<f32> {
        mesh.vertices.iter().flat_map(f).collect()
    };
    let mut position = vec("VEC3");
    position["min"] = json!([lo.x, lo.y, lo.z]);
    position["max"] = json!([hi.x, hi.y, hi.z]);
    let attributes = json!({
        "POSITION": stream(bytemuck::cast_slice(&floats(&|v| v.position.to_vec())), ARRAY_BUFFER, position),
        "NORMAL": stream(bytemuck::cast_slice(&floats(&|v| v.normal.to_vec())), ARRAY_BUFFER, vec("VEC3")),
        "TANGENT": stream(bytemuck::cast_slice(&floats(&|v| v.tangent.to_vec())), ARRAY_BUFFER, vec("VEC4")),
        "TEXCOORD_0": stream(bytemuck::cast_slice(&floats(&|v| v.uv_material.to_vec())), ARRAY_BUFFER, vec("VEC2")),
        "TEXCOORD_1": stream(bytemuck::cast_slice(&floats(&|v| v.uv_lightmap.to_vec())), ARRAY_BUFFER, vec("VEC2")),
        "COLOR_0": stream(bytemuck::cast_slice(&floats(&|v| v.albedo_tint.to_vec())), ARRAY_BUFFER, vec("VEC3")),
    });

    let camera = &scene.camera;
    let (_, rotation, translation) = camera
        .view_from_world()
        .inverse()
        .to_scale_rotation_translation();
    let rotation = rotation.normalize();
    let rotation = if rotation.is_finite() {
        rotation
    } else {
        Quat::IDENTITY
    };
    let document = json!({
        "asset": {
            "version": "2.0",
            "generator": format!("shvis {}", env!("CARGO_PKG_VERSION")),
        },
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": [0, 1]}],
        "nodes": [
            {"name": scene.name, "mesh": 0},
            {
                "name": "camera",
                "camera": 0,
                "translation": [translation.x, translation.y, translation.z],
                "rotation": [rotation.x, rotation.y, rotation.z, rotation.w],
            },
        ],
        "cameras": [{
            "type": "perspective",
            "perspective": {"yfov": camera.fov_y, "znear": camera.z_near, "zfar": camera.z_far},
        }],
        "meshes": [{
            "name": scene.name,
            "primitives": [{"attributes": attributes, "indices": indices, "material": 0, "mode": 4}],
        }],
        "materials": [{
            "name": "material",
            "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0, "texCoord": 0},
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0,
            },
            "normalTexture": {"index": 1, "texCoord": 0, "scale": scene.material.normal_scale},
        }],
        "textures": [{"sampler": 0, "source": 0}, {"sampler": 0, "source": 1}],
        "samplers": [{
            "magFilter": LINEAR,
            "minFilter": LINEAR_MIPMAP_LINEAR,
            "wrapS": REPEAT,
            "wrapT": REPEAT,
        }],
        "images": [
            {"uri": ALBEDO_FILE, "mimeType": "image/png"},
            {"uri": NORMAL_FILE, "mimeType": "image/png"},
        ],
        "buffers": [{"uri": BIN_FILE, "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    let gltf = serde_json::to_vec_pretty(&document).map_err(|e| e.to_string())?;
    Ok(vec![
        (GLTF_FILE.into(), gltf),
        (BIN_FILE.into(), bin),
        (ALBEDO_FILE.into(), png(&scene.material.albedo)?),
        (NORMAL_FILE.into(), png(&scene.material.normal)?),
    ])
}

/// `texture` as an RGBA8 PNG, row 0 at the top.
fn png(texture: &Texture8) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    let raw: Vec<u8> = texture.texels.iter().flatten().copied().collect();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut bytes),
        &raw,
        texture.width,
        texture.height,
        image::ExtendedColorType::Rgba8,
        image::ImageFormat::Png,
    )
    .map_err(|e| e.to_string())?;
    Ok(bytes)
}
