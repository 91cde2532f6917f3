//! GLSL → SPIR-V with shaderc, at run time.
//!
//! Why run time: shader variants (hardware path, later SH order and PCA size) are chosen
//! by the command line, binding numbers and limits come from Rust constants
//! (`layout::SHADER_MACROS`) in one place, and a test compiles every variant. The sources
//! are embedded with `include_str!`, so the binary runs from anywhere. Includes resolve
//! against `glsl/include/`; a compile error names the file and line.

use super::GpuError;
use super::layout::SHADER_MACROS;

/// Every GLSL file, by its path under `glsl/`.
const SOURCES: &[(&str, &str)] = &[
    (
        "include/common.glsl",
        include_str!("../../glsl/include/common.glsl"),
    ),
    (
        "include/grouped.glsl",
        include_str!("../../glsl/include/grouped.glsl"),
    ),
    (
        "include/sh.glsl",
        include_str!("../../glsl/include/sh.glsl"),
    ),
    (
        "include/sh_product.glsl",
        include_str!("../../glsl/include/sh_product.glsl"),
    ),
    (
        "include/sphere.glsl",
        include_str!("../../glsl/include/sphere.glsl"),
    ),
    (
        "reference/gbuffer.frag",
        include_str!("../../glsl/reference/gbuffer.frag"),
    ),
    (
        "study/reconstruct.comp",
        include_str!("../../glsl/study/reconstruct.comp"),
    ),
    (
        "technique/mesh.vert",
        include_str!("../../glsl/technique/mesh.vert"),
    ),
    (
        "technique/pca.frag",
        include_str!("../../glsl/technique/pca.frag"),
    ),
    (
        "technique/pcaw.frag",
        include_str!("../../glsl/technique/pcaw.frag"),
    ),
    (
        "technique/preconv.frag",
        include_str!("../../glsl/technique/preconv.frag"),
    ),
    (
        "technique/sh2.frag",
        include_str!("../../glsl/technique/sh2.frag"),
    ),
    (
        "technique/shlmap.frag",
        include_str!("../../glsl/technique/shlmap.frag"),
    ),
    (
        "technique/unc.frag",
        include_str!("../../glsl/technique/unc.frag"),
    ),
];

/// Which pipeline stage a source is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderStage {
    Vertex,
    Fragment,
    Compute,
}

fn source(path: &str) -> Option<&'static str> {
    SOURCES.iter().find(|(p, _)| *p == path).map(|(_, s)| *s)
}

/// Compiles `glsl/{path}` with the layout macros plus `defines` (each `SHVIS_{name}`).
///
/// # Errors
/// An unknown path, or the compiler's diagnostics joined on one line
/// ("glsl/technique/x.frag:12: error: …").
pub fn compile_glsl(
    path: &str,
    stage: ShaderStage,
    defines: &[(&str, u32)],
) -> Result<Vec<u32>, GpuError> {
    let text = source(path)
        .ok_or_else(|| GpuError::Shader(format!("glsl/{path}: no such embedded shader")))?;
    compile_source(&format!("glsl/{path}"), text, stage, defines)
}

/// Compiles GLSL `text` reported as `name` in diagnostics; see [`compile_glsl`].
pub fn compile_source(
    name: &str,
    text: &str,
    stage: ShaderStage,
    defines: &[(&str, u32)],
) -> Result<Vec<u32>, GpuError> {
    let compiler = shaderc::Compiler::new()
        .map_err(|e| GpuError::Shader(format!("shaderc unavailable: {e}")))?;
    let mut options = shaderc::CompileOptions::new()
        .map_err(|e| GpuError::Shader(format!("shaderc options: {e}")))?;
    options.set_target_env(
        shaderc::TargetEnv::Vulkan,
        shaderc::EnvVersion::Vulkan1_2 as u32,
    );
    options.set_optimization_level(shaderc::OptimizationLevel::Performance);
    options.set_generate_debug_info();
    for (name, value) in SHADER_MACROS.iter().chain(defines) {
        options.add_macro_definition(&format!("SHVIS_{name}"), Some(&value.to_string()));
    }
    options.set_include_callback(|requested, _kind, _from, _depth| {
        let path = format!("include/{requested}");
        source(&path)
            .map(|content| shaderc::ResolvedInclude {
                resolved_name: format!("glsl/{path}"),
                content: content.to_string(),
            })
            .ok_or_else(|| format!("include \"{requested}\" not found under glsl/include/"))
    });
    let kind = match stage {
        ShaderStage::Vertex => shaderc::ShaderKind::Vertex,
        ShaderStage::Fragment => shaderc::ShaderKind::Fragment,
        ShaderStage::Compute => shaderc::ShaderKind::Compute,
    };
    let artifact = compiler
        .compile_into_spirv(text, kind, name, "main", Some(&options))
        .map_err(|e| {
            let one_line = e
                .to_string()
                .lines()
                .map(str::trim)
                .filter(|l| !l.is_empty())
                .collect::<Vec<_>>()
                .join("; ");
            GpuError::Shader(format!("shader compile failed: {one_line}"))
        })?;
    Ok(artifact.as_binary().to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_embedded_stage_compiles_for_both_paths() {
        for path_dx9 in [0, 1] {
            compile_glsl("technique/mesh.vert", ShaderStage::Vertex, &[]).unwrap();
            compile_glsl(
                "technique/preconv.frag",
                ShaderStage::Fragment,
                &[("PATH_DX9", path_dx9)],
            )
            .unwrap();
            compile_glsl(
                "technique/sh2.frag",
                ShaderStage::Fragment,
                &[("PATH_DX9", path_dx9)],
            )
            .unwrap();
            compile_glsl(
                "technique/shlmap.frag",
                ShaderStage::Fragment,
                &[("PATH_DX9", path_dx9), ("SHLMAP_GROUPS", 7)],
            )
            .unwrap();
        }
        for path_dx9 in [0, 1] {
            for groups in [3, 4, 9] {
                compile_glsl(
                    "technique/unc.frag",
                    ShaderStage::Fragment,
                    &[("PATH_DX9", path_dx9), ("UNC_GROUPS", groups)],
                )
                .unwrap();
            }
        }
        for path_dx9 in [0, 1] {
            for groups in [1, 2, 3, 4, 6] {
                compile_glsl(
                    "technique/pca.frag",
                    ShaderStage::Fragment,
                    &[("PATH_DX9", path_dx9), ("PCA_GROUPS", groups)],
                )
                .unwrap();
                compile_glsl(
                    "technique/pcaw.frag",
                    ShaderStage::Fragment,
                    &[("PATH_DX9", path_dx9), ("PCA_GROUPS", groups)],
                )
                .unwrap();
            }
        }
        for output in 0..4 {
            compile_glsl(
                "reference/gbuffer.frag",
                ShaderStage::Fragment,
                &[("GBUFFER", 1), ("GBUFFER_OUTPUT", output)],
            )
            .unwrap();
        }
        compile_glsl(
            "technique/mesh.vert",
            ShaderStage::Vertex,
            &[("GBUFFER", 1)],
        )
        .unwrap();
        for param in 0..4 {
            compile_glsl(
                "study/reconstruct.comp",
                ShaderStage::Compute,
                &[("STUDY_PARAM", param)],
            )
            .unwrap();
        }
    }

    #[test]
    fn compile_error_names_file_and_line_on_one_line() {
        let broken = "#version 450\n#extension GL_GOOGLE_include_directive : require\n#include \"sh.glsl\"\nvoid main() {\n    float x = undefined_thing;\n}\n";
        let e = compile_source(
            "glsl/technique/broken.frag",
            broken,
            ShaderStage::Fragment,
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("glsl/technique/broken.frag:5"), "{e}");
        assert!(e.contains("undefined_thing"), "{e}");
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn unknown_shader_is_an_error_naming_it() {
        let e = compile_glsl("technique/nope.frag", ShaderStage::Fragment, &[]).unwrap_err();
        assert!(e.to_string().contains("glsl/technique/nope.frag"), "{e}");
    }
}
