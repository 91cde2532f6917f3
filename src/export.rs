//! `shvis export`: a technique's baked data as files an engine loads (docs/export.md).
//!
//! ```text
//! per_texel.ktx2         the per-texel data: dx10 RGBA16F / RGBA8 / R16F 2D array (layer g =
//!                        values 4g … 4g+3); dx11 BC7 ratios or BC4 values (technique::block)
//! per_texel_norms.ktx2   dx11 ratio codecs: the BC6H per-texel norms (one layer)
//! table_{i}.ktx2         the normal-indexed tables: cube arrays (faces 6) of RGBA16F
//! params.bin             the uniform block, std140, as the shader declares it
//! decode.glsl            the technique's fragment shader as one self-contained file
//! scene.gltf, scene.bin  the scene the lightmap was baked for, with its lightmap UVs
//! albedo.png, normal.png   (TEXCOORD_1) and material (`scene::gltf::write`)
//! manifest.json          what each file holds, the decode, the conventions
//! ```
//!
//! The files are what the renderer uploads: the tests read them back with the `ktx2`
//! crate and compare texels, and build the technique with `decode.glsl` compiled in place
//! of its own shader.

use std::path::Path;

use serde_json::json;

use crate::files::ktx2::{Ktx2Image, encode};
use crate::prepare::Prepared;
use crate::technique::block::{BlockCodec, NormColours, compress_cached, dx11_codec, path_defines};
use crate::technique::texels::TexelGroups;
use crate::technique::{
    HwPath, LightingData, LightingRecipe, Technique, TechniqueError, per_texel_data,
};

/// Errors of an export.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("{label}: {detail}")]
    Refused { label: String, detail: String },
    #[error(transparent)]
    Technique(#[from] TechniqueError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    File(#[from] crate::files::FileError),
}

/// Version of the manifest's layout (`manifest_version`; docs/export.md).
pub const MANIFEST_VERSION: u32 = 2;

/// An export: each file's name and bytes, the manifest last.
pub struct Export {
    pub files: Vec<(String, Vec<u8>)>,
}

/// Why `technique` has no export on `path`, if it has none: no form on the path, or a form
/// with more than per-texel images, tables and a uniform block; `shvis export` asks before
/// the bake.
pub fn refusal(technique: Technique, path: HwPath) -> Option<ExportError> {
    match technique.form_on(path) {
        Err(why) => Some(ExportError::Refused {
            label: format!("{technique}.{path}"),
            detail: format!("cannot run on {path}: {why}"),
        }),
        Ok(form) => form.export_refusal().map(|why| ExportError::Refused {
            label: technique.name(),
            detail: format!("has no export: {why}"),
        }),
    }
}

/// The fragment inputs `decode.glsl` reads (glsl/include/common.glsl, fed by
/// glsl/scene/mesh.vert), each with the glTF attribute of `scene.gltf` it carries:
/// (name, GLSL type, glTF attribute, meaning).
pub const SHADER_INPUTS: [(&str, &str, &str, &str); 5] = [
    (
        "in_normal_world",
        "vec3",
        "NORMAL",
        "the vertex normal, world space",
    ),
    (
        "in_tangent_world",
        "vec4",
        "TANGENT",
        "the glTF tangent (xyz world space, w the bitangent's sign)",
    ),
    (
        "in_uv_material",
        "vec2",
        "TEXCOORD_0",
        "the material UV (albedo and normal textures)",
    ),
    (
        "in_uv_lightmap",
        "vec2",
        "TEXCOORD_1",
        "the lightmap UV (per-texel data)",
    ),
    (
        "in_albedo_tint",
        "vec3",
        "COLOR_0",
        "the linear tint multiplied into the base colour",
    ),
];

fn ktx2(image: &Ktx2Image<'_>, label: &str) -> Result<Vec<u8>, ExportError> {
    encode(image).ok_or_else(|| ExportError::Refused {
        label: label.into(),
        detail: format!("format {:?} has no KTX2 description here", image.format),
    })
}

/// The per-texel data of an export on dx10: one 2D array.
fn dx10_per_texel(texels: &TexelGroups, label: &str) -> Result<Vec<u8>, ExportError> {
    let data: Vec<u8> = texels.groups.concat();
    ktx2(
        &Ktx2Image {
            format: texels.format,
            width: texels.res,
            height: texels.res,
            layers: texels.groups.len() as u32,
            faces: 1,
            data: &data,
        },
        label,
    )
}

/// The manifest's codec entry for data of `values` values per texel.
fn codec_json(codec: BlockCodec, values: usize) -> serde_json::Value {
    match codec {
        BlockCodec::Bc4 => json!({
            "name": "bc4",
            "decode": "value = texture(per_texel, uv).r (BC4_UNORM: the value in [0, 1])",
        }),
        BlockCodec::Ratio(colours) => json!({
            "name": "ratio-to-norm",
            "decode": "value_j = (255 * s_j - 128) / 127 * n[colour(j)], s_j = channel j mod 4 of layer j div 4 of per_texel (BC7_UNORM), n = per_texel_norms layer 0 (BC6H_UFLOAT, RGB)",
            "constants": {
                "scale": 255.0,
                "offset": crate::technique::block::RATIO_OFFSET,
                "divisor": crate::technique::block::RATIO_DIVISOR,
            },
            "colour": match colours {
                NormColours::One => "0 for every value (n.r)",
                NormColours::Triplets => "j mod 3 (values 3k + c are RGB triplets)",
                NormColours::GroupRgb => "(j mod 4) mod 3 (an RGB triple per layer, alpha with red)",
            },
            "norm_colour": (0..values).map(|j| colours.colour(j)).collect::<Vec<_>>(),
            "filtering": "filter s and n bilinearly apart, then decode (as decode.glsl does)",
        }),
    }
}

/// Builds the export of `technique` on `path` from `prepared`.
///
/// # Errors
/// A technique with no export ([`refusal`]) or no form on the path, the dx9 path (export
/// writes the array layouts), inputs the technique lacks.
pub fn export(
    prepared: &Prepared,
    technique: Technique,
    path: HwPath,
) -> Result<Export, ExportError> {
    let label = format!("{technique}.{path}");
    let refused = |detail: String| ExportError::Refused {
        label: label.clone(),
        detail,
    };
    if let Some(refused) = refusal(technique, path) {
        return Err(refused);
    }
    if path == HwPath::Dx9 {
        return Err(refused(
            "export writes the dx10 and dx11 layouts (arrays, cube maps); pass --path dx10 or dx11"
                .into(),
        ));
    }
    let inputs = prepared.inputs();
    let texels = per_texel_data(technique, path, &inputs)?;
    let recipe = LightingRecipe::new(technique, path, &inputs)?;
    let lighting = recipe.build(inputs.radiance_sh, inputs.irradiance_sh)?;
    let mut files = Vec::new();
    let per_texel = per_texel_files(
        technique,
        path,
        &texels,
        &label,
        inputs.cache_dir,
        &mut files,
    )?;
    let tables = table_files(&lighting, &label, &mut files)?;
    files.push(("params.bin".into(), lighting.params.clone()));
    let shader = technique.fragment_shader();
    let mut defines = path_defines(technique, path);
    defines.push(("MATERIAL_LEVEL0", 0));
    defines.extend_from_slice(&shader.defines);
    defines.extend_from_slice(&lighting.defines);
    let glsl_text = crate::gpu::flattened_glsl(shader.path, &defines)?;
    files.push(("decode.glsl".into(), glsl_text.clone().into_bytes()));
    let geometry = crate::scene::gltf::write::write_gltf(&prepared.scene)
        .map_err(|e| refused(format!("the scene's glTF: {e}")))?;
    files.extend(geometry);
    let layout = crate::gpu::layout::SHADER_MACROS
        .iter()
        .map(|(n, v)| (format!("SHVIS_{n}"), json!(v)))
        .collect::<serde_json::Map<_, _>>();
    let manifest = json!({
        "shvis_export": env!("CARGO_PKG_VERSION"),
        "manifest_version": MANIFEST_VERSION,
        "technique": technique.name(),
        "path": path.name(),
        "family": crate::technique::catalog::family_of(technique),
        "per_texel": per_texel,
        "tables": tables,
        "geometry": {
            "gltf": crate::scene::gltf::write::GLTF_FILE,
            "files": [
                crate::scene::gltf::write::BIN_FILE,
                crate::scene::gltf::write::ALBEDO_FILE,
                crate::scene::gltf::write::NORMAL_FILE,
            ],
            "lightmap_uv": "TEXCOORD_1 (the UVs the lightmap was baked with; origin top left, texel centres at (i + ½)/res)",
            "material_uv": "TEXCOORD_0",
            "albedo_tint": "COLOR_0 (linear RGB, multiplied into the base colour)",
        },
        "uniform_block": uniform_block(&glsl_text, &lighting.params).map_err(|e| refused(format!("params.bin's block: {e}")))?,
        "shader": {
            "file": "decode.glsl",
            "stage": "fragment",
            "source": format!("glsl/{}", shader.path),
            "defines": defines.iter().map(|(n, v)| (format!("SHVIS_{n}"), json!(v))).collect::<serde_json::Map<_, _>>(),
            "bindings": layout,
            "inputs": SHADER_INPUTS.iter().map(|(name, ty, gltf, meaning)| json!({"name": name, "type": ty, "gltf": gltf, "meaning": meaning})).collect::<Vec<_>>(),
        },
        "lightmap": {
            "orientation": crate::files::ktx2::ORIENTATION,
            "orientation_meaning": "KTXorientation: texel (0, 0) is the lightmap's top-left, at uv (0, 0); rows run down (+v)",
            "texel_centre": "uv = (i + 0.5) / res",
            "colour_space": "linear (no sRGB transfer)",
            "gutter_dilation_texels": crate::bake::visibility::DILATION_PASSES,
            "filtering": "bilinear, clamped to the edge",
        },
        "conventions": {
            "sh_basis": {
                "normalisation": "orthonormal over the sphere",
                "condon_shortley_phase": true,
                "index": "l * (l + 1) + m",
                "frame": "world",
                "pole_axis": "+Z",
                "band_1": ["-sqrt(3/4pi) y", "sqrt(3/4pi) z", "-sqrt(3/4pi) x"],
            },
            "sh": "real SH, Sloan's graphics convention with the Condon–Shortley phase (y1-1 = −√(3/4π)·y, y10 = √(3/4π)·z, y11 = −√(3/4π)·x), flat index l(l+1)+m; order n = bands l < n",
            "space": "right-handed, +Y up; tangent space z = the surface normal (glTF tangents)",
            "lightmap_uv": "the scene's lightmap UVs: glTF TEXCOORD_1, or generated where a file has none; texel centres at (i + ½)/res",
            "radiance": "linear RGB; the shader writes albedo/π · irradiance",
        },
    });
    let manifest =
        serde_json::to_vec_pretty(&manifest).map_err(|e| refused(format!("manifest: {e}")))?;
    files.push(("manifest.json".into(), manifest));
    Ok(Export { files })
}

/// Adds the per-texel files of `texels` on `path` to `files` (dx11: the technique's block
/// codec; else the plain 2D array) and returns their manifest entry.
fn per_texel_files(
    technique: Technique,
    path: HwPath,
    texels: &TexelGroups,
    label: &str,
    cache_dir: Option<&Path>,
    files: &mut Vec<(String, Vec<u8>)>,
) -> Result<serde_json::Value, ExportError> {
    let values = texels.groups.len() * crate::technique::texels::VALUES_PER_TEXEL;
    let per_texel = match path {
        HwPath::Dx11 => {
            let codec = dx11_codec(technique, label)?;
            let block = compress_cached(texels, codec, label, cache_dir)?;
            let images = block.image_levels();
            let mut names = Vec::new();
            for (k, (desc, levels, _)) in images.iter().enumerate() {
                let name = if k == 0 {
                    "per_texel.ktx2"
                } else {
                    "per_texel_norms.ktx2"
                };
                let data: Vec<u8> = levels[0].concat();
                files.push((
                    name.to_string(),
                    ktx2(
                        &Ktx2Image {
                            format: desc.format,
                            width: desc.width,
                            height: desc.height,
                            layers: desc.layers,
                            faces: 1,
                            data: &data,
                        },
                        label,
                    )?,
                ));
                names.push(json!({"file": name, "format": format!("{:?}", desc.format), "layers": desc.layers}));
            }
            json!({
                "files": names,
                "res": texels.res,
                "layers": texels.groups.len(),
                "values_per_texel": values,
                "codec": codec_json(codec, values),
                "bytes_per_texel": block.bytes_per_texel(),
            })
        }
        HwPath::Dx9 | HwPath::Dx10 => {
            files.push(("per_texel.ktx2".into(), dx10_per_texel(texels, label)?));
            json!({
                "files": [{"file": "per_texel.ktx2", "format": format!("{:?}", texels.format), "layers": texels.groups.len()}],
                "res": texels.res,
                "layers": texels.groups.len(),
                "values_per_texel": values,
                "codec": {"name": "plain", "decode": "value_j = channel j mod 4 of layer j div 4 (RGBA8 as unorm)"},
            })
        }
    };
    let mut per_texel = per_texel;
    per_texel["values"] = match technique.values() {
        Some(map) => map.to_json(values),
        None => json!(null),
    };
    Ok(per_texel)
}

/// Adds each of `lighting`'s normal-indexed tables to `files` as `table_{i}.ktx2` and
/// returns their manifest entries.
fn table_files(
    lighting: &LightingData,
    label: &str,
    files: &mut Vec<(String, Vec<u8>)>,
) -> Result<Vec<serde_json::Value>, ExportError> {
    let mut tables = Vec::new();
    if let Some(data) = &lighting.tables {
        for (i, image) in data.images.iter().enumerate() {
            let desc = image.desc;
            let cube = matches!(
                desc.view_type,
                ash::vk::ImageViewType::CUBE | ash::vk::ImageViewType::CUBE_ARRAY
            );
            let (layers, faces) = if cube {
                (desc.layers / 6, 6)
            } else {
                (desc.layers, 1)
            };
            let bytes: Vec<u8> = data.image_levels(i)[0].concat();
            let name = format!("table_{i}.ktx2");
            files.push((
                name.clone(),
                ktx2(
                    &Ktx2Image {
                        format: desc.format,
                        width: desc.width,
                        height: desc.height,
                        layers,
                        faces,
                        data: &bytes,
                    },
                    label,
                )?,
            ));
            tables.push(json!({
                "file": name,
                "format": format!("{:?}", desc.format),
                "kind": if cube { "cube array (+X −X +Y −Y +Z −Z per layer)" } else { "2D array" },
                "layers": layers,
                "unscale": data.unscale,
            }));
        }
    }
    Ok(tables)
}

impl Export {
    /// Writes the export into `dir` as one run ([`crate::files::replace_dir`]): the files
    /// of an earlier export there are replaced all at once, never mixed with these; a
    /// folder holding anything but an earlier export is refused.
    ///
    /// # Errors
    /// A file that cannot be written, or a `dir` that is not an earlier export.
    pub fn write(&self, dir: &Path) -> Result<(), ExportError> {
        crate::files::replace_dir(dir, "--out", is_export_dir, |tmp| {
            for (name, bytes) in &self.files {
                crate::files::write_atomic(&tmp.join(name), bytes)?;
            }
            Ok(())
        })?;
        Ok(())
    }

    /// The bytes of file `name`.
    pub fn file(&self, name: &str) -> Option<&[u8]> {
        self.files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, b)| b.as_slice())
    }
}

/// Whether `dir` holds an export: its `manifest.json` has `shvis_export` (every version).
pub fn is_export_dir(dir: &Path) -> bool {
    crate::files::read_bounded(&dir.join("manifest.json"), 1 << 20, "an export manifest")
        .ok()
        .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
        .is_some_and(|m| m.get("shvis_export").is_some())
}

/// The manifest's `uniform_block`: `params.bin` as the technique's block in `glsl` declares
/// it (the block at `SHVIS_BINDING_TECHNIQUE_PARAMS`, every member with an explicit
/// std140 `layout(offset = …)`), each field with its offset, type, element count and the
/// values `params` holds there (floats for float types, integers for integer types);
/// members that start past `params`' end are those the build's `#if`s leave out.
///
/// # Errors
/// A member inside `params` whose type or array length cannot be read (a declaration this
/// reader does not know): the manifest would leave it out, and an engine binding the block
/// from the fields would read zeros there.
fn uniform_block(glsl: &str, params: &[u8]) -> Result<serde_json::Value, String> {
    let mut entry = json!({
        "file": "params.bin",
        "bytes": params.len(),
        "layout": "std140, little-endian",
    });
    let Some(start) = glsl.find("binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ") else {
        return Ok(entry);
    };
    let rest = &glsl[start..];
    let name = rest["binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ".len()..]
        .split(|c: char| !c.is_alphanumeric() && c != '_')
        .next()
        .unwrap_or_default();
    let body = rest
        .split_once('{')
        .and_then(|(_, b)| b.split_once('}'))
        .map_or("", |(b, _)| b);
    let mut fields = Vec::new();
    for line in body.lines() {
        let code = line.split("//").next().unwrap_or_default().trim();
        let Some(rest) = code.strip_prefix("layout(offset = ") else {
            continue;
        };
        let unread = |why: &str| format!("{name}'s member `{code}`: {why}");
        let (offset, decl) = rest
            .split_once(')')
            .ok_or_else(|| unread("no closing parenthesis"))?;
        let offset: usize = offset
            .trim()
            .parse()
            .map_err(|_| unread("the offset is not a number"))?;
        // A member past the block's bytes is one the technique's build leaves out (an
        // `#if` branch of the declaration).
        if offset >= params.len() {
            continue;
        }
        let (ty, member) = decl
            .trim()
            .trim_end_matches(';')
            .split_once(' ')
            .ok_or_else(|| unread("no type and name"))?;
        let member = member.trim();
        let (member, count) = match member.split_once('[') {
            // A length such as `7 * 12` or `(BASIS_COUNT + 1) * 9`: arithmetic on numbers
            // and the shader's defines.
            Some((m, n)) => {
                let length = glsl_constant(glsl, n.trim_end_matches(']'), 0)
                    .ok_or_else(|| unread("its array length is not a constant of the shader"))?;
                (m, length)
            }
            None => (member, 1),
        };
        let (components, integer, stride) = match ty {
            "float" => (1, false, 16),
            "int" | "uint" => (1, true, 16),
            "vec2" => (2, false, 16),
            "vec4" => (4, false, 16),
            "ivec4" | "uvec4" => (4, true, 16),
            "mat4" => (16, false, 64),
            _ => return Err(unread("a type the manifest does not describe")),
        };
        let element = |k: usize| -> Vec<serde_json::Value> {
            (0..components)
                .map(|c| {
                    let at = offset + k * stride + 4 * c;
                    let word = params
                        .get(at..at + 4)
                        .map_or([0; 4], |b| [b[0], b[1], b[2], b[3]]);
                    if integer {
                        json!(i32::from_le_bytes(word))
                    } else {
                        json!(f32::from_le_bytes(word))
                    }
                })
                .collect()
        };
        let values: Vec<serde_json::Value> = if count == 1 && components == 1 {
            element(0)
        } else {
            (0..count).map(|k| json!(element(k))).collect()
        };
        fields.push(json!({
            "name": member,
            "offset": offset,
            "type": ty,
            "count": count,
            "array_stride": if count > 1 { json!(stride) } else { json!(null) },
            "values": values,
        }));
    }
    entry["block"] = json!(name);
    entry["fields"] = json!(fields);
    Ok(entry)
}

/// The value of the integer constant expression `text` in `glsl`: numbers, `#define`d names
/// (their first definition), `+ - * /` and parentheses, as the GLSL preprocessor and
/// compiler evaluate an array length; `None` for anything else (`depth` bounds the
/// definitions followed).
fn glsl_constant(glsl: &str, text: &str, depth: u32) -> Option<usize> {
    if depth > 16 {
        return None;
    }
    let define = |symbol: &str| -> Option<usize> {
        let value = glsl.lines().find_map(|l| {
            let rest = l.trim_start().strip_prefix("#define")?;
            let rest = rest.trim_start().strip_prefix(symbol)?;
            rest.starts_with(char::is_whitespace).then(|| rest.trim())
        })?;
        glsl_constant(glsl, value, depth + 1)
    };
    let tokens: Vec<String> = {
        let mut tokens = Vec::new();
        let mut word = String::new();
        for c in text.chars() {
            if c.is_alphanumeric() || c == '_' {
                word.push(c);
                continue;
            }
            if !word.is_empty() {
                tokens.push(std::mem::take(&mut word));
            }
            if !c.is_whitespace() {
                tokens.push(c.to_string());
            }
        }
        if !word.is_empty() {
            tokens.push(word);
        }
        tokens
    };
    // Recursive descent: sum := product (('+'|'-') product)*, product := atom (('*'|'/') atom)*.
    fn sum(t: &[String], at: &mut usize, atom: &dyn Fn(&str) -> Option<usize>) -> Option<i64> {
        let mut v = product(t, at, atom)?;
        while let Some(op) = t.get(*at).filter(|op| *op == "+" || *op == "-") {
            let plus = op == "+";
            *at += 1;
            let r = product(t, at, atom)?;
            v = if plus {
                v.checked_add(r)?
            } else {
                v.checked_sub(r)?
            };
        }
        Some(v)
    }
    fn product(t: &[String], at: &mut usize, atom: &dyn Fn(&str) -> Option<usize>) -> Option<i64> {
        let mut v = primary(t, at, atom)?;
        while let Some(op) = t.get(*at).filter(|op| *op == "*" || *op == "/") {
            let times = op == "*";
            *at += 1;
            let r = primary(t, at, atom)?;
            v = if times {
                v.checked_mul(r)?
            } else {
                v.checked_div(r)?
            };
        }
        Some(v)
    }
    fn primary(t: &[String], at: &mut usize, atom: &dyn Fn(&str) -> Option<usize>) -> Option<i64> {
        let token = t.get(*at)?;
        *at += 1;
        if token == "(" {
            let v = sum(t, at, atom)?;
            (t.get(*at)? == ")").then_some(())?;
            *at += 1;
            return Some(v);
        }
        let value = match token.parse::<usize>() {
            Ok(n) => n,
            Err(_) => atom(token)?,
        };
        i64::try_from(value).ok()
    }
    let mut at = 0;
    let value = sum(&tokens, &mut at, &define)?;
    (at == tokens.len()).then_some(())?;
    usize::try_from(value).ok()
}

#[cfg(test)]
mod tests {
    use super::glsl_constant;

    #[test]
    fn array_lengths_are_evaluated_as_glsl_constants() {
        let glsl = "#define SHVIS_CLUSTERS 64\n#define SHVIS_CLUSTER_VECTORS 7\n#define K SHVIS_CLUSTERS\n#define M SHVIS_CLUSTER_VECTORS\n#define BLOCK ((M + 1) * 9)\n#define GROUPS ((M + 4) / 4)\n#define KEEP 3\n";
        let value = |text| glsl_constant(glsl, text, 0);
        assert_eq!(value("7 * 12"), Some(84));
        assert_eq!(value("K * BLOCK"), Some(64 * 72));
        assert_eq!(value("3 * GROUPS"), Some(6));
        assert_eq!(value("(M + 1) * 9 - 2"), Some(70));
        assert_eq!(value("K"), Some(64), "K is not KEEP");
        for unreadable in ["UNDEFINED", "(7", "7 )", "2 - 3", "4 / 0", "7 % 2", ""] {
            assert_eq!(value(unreadable), None, "{unreadable}");
        }
        assert_eq!(glsl_constant("#define A B\n#define B A\n", "A", 0), None);
    }
}
