//! The contract between the Rust side and the shaders, as tests; no GPU needed.
//!
//! - **Blocks**: every uniform and push-constant block that a compiled shader declares —
//!   each technique's fragment shader on each path, the specular term's frame, the GPU
//!   bakes' shaders — has, member by member, the offset and size of the Rust struct that
//!   fills it (`shvis::gpu::reflect` reads the SPIR-V, `shvis::gpu::layout::GlslBlock` the
//!   struct), or is listed in [`UNMIRRORED`] with the reason it has no struct.
//! - **Ids**: the shader ids (`shvis::gpu::layout::ShaderIds`) are distinct, every compile
//!   of a technique defines each once, and no GLSL source compares a selector with a
//!   number: the numbers exist in Rust alone.

use std::collections::BTreeSet;

use shvis::gpu::layout::{BlockLayout, FrameParams, GlslBlock, SHADER_MACROS, ShaderIds};
use shvis::gpu::reflect::{self, BlockKind};
use shvis::gpu::shader::embedded_sources;
use shvis::gpu::{HwPath, ShaderStage, compile_glsl, layout};
use shvis::render::specular::{NormalFilter, SpecularParams};
use shvis::technique::Technique;

/// The Rust side of every mirrored block, by GLSL block name.
fn mirrors() -> Vec<BlockLayout> {
    use shvis::technique::{hemisphere, nmprt, preconv, sh2, shlmap, tables};
    vec![
        FrameParams::layout(),
        preconv::PreconvParams::layout(),
        sh2::Sh2Params::layout(),
        hemisphere::SgParams::layout(),
        hemisphere::DiceParams::layout(),
        shlmap::ShLightmapParams::layout(),
        shlmap::ShLightmapParams::layout().named("RnmParams"),
        shlmap::ShLightmapParams::layout().named("NmprtParams"),
        nmprt::NmprtPixelParams::layout(),
        // The NDF filtering appends its ambient vec4s (technique::lighting, `Recipe::Ndf`).
        tables::TableParams::layout().with_vec4s("ambient"),
        // Slices of vec4s: technique::cluster::lighting, technique::pca::weights_only_block.
        BlockLayout::vec4s("ClusterParams", "coeffs"),
        BlockLayout::vec4s("PcaWeightsParams", "coeffs"),
        SpecularParams::layout(),
        shvis::gpu::visibility_sim::DirectionView::layout(),
    ]
}

/// Blocks without a Rust struct, as (shader, block, why).
const UNMIRRORED: &[(&str, &str, &str)] = &[
    (
        "bake/project.comp",
        "Push",
        "four u32 words (gpu::visibility_sim, record_projection)",
    ),
    (
        "normalmap/expand.comp",
        "Push",
        "three u32 words (gpu::normal_bake)",
    ),
    ("normalmap/mask.vert", "Push", "one u32 (gpu::normal_bake)"),
    (
        "normalmap/project.vert",
        "Push",
        "three 32-bit words, f32 bits first (gpu::normal_bake, record_project)",
    ),
    (
        "normalmap/normal.frag",
        "Push",
        "the same words as normalmap/project.vert's",
    ),
];

/// The GPU bakes' shaders, compiled without defines as the bakes compile them.
const BAKE_SHADERS: &[(&str, ShaderStage)] = &[
    ("bake/mark.comp", ShaderStage::Compute),
    ("bake/depth.vert", ShaderStage::Vertex),
    ("bake/project.comp", ShaderStage::Compute),
    ("normalmap/expand.comp", ShaderStage::Compute),
    ("normalmap/mask.vert", ShaderStage::Vertex),
    ("normalmap/project.vert", ShaderStage::Vertex),
    ("normalmap/normal.frag", ShaderStage::Fragment),
];

/// A technique's fragment shader and its defines on `path`, as the build compiles it
/// (with the lighting's define of `nmprtsvdMp` at the default lighting order).
fn technique_shader(
    technique: Technique,
    path: HwPath,
) -> (&'static str, Vec<(&'static str, u32)>) {
    let shader = technique.fragment_shader();
    let mut defines = shvis::technique::block::path_defines(technique, path);
    defines.extend_from_slice(&shader.defines);
    if shader.path == "technique/nmprtsvdp.frag" {
        let order = shvis::bake::transfer::DEFAULT_LIGHTING_ORDER;
        defines.push(shvis::technique::nmprt::pixel_row_groups(
            order.coeff_count(),
        ));
    }
    (shader.path, defines)
}

/// What one compiled shader breaks of the contract; `seen` gathers the mirrors and the
/// allow-list entries it met.
struct Check {
    mirrors: Vec<BlockLayout>,
    problems: Vec<String>,
    seen_mirrors: BTreeSet<&'static str>,
    seen_unmirrored: BTreeSet<(&'static str, &'static str)>,
}

impl Check {
    /// Holds the blocks of `spirv`, compiled from `shader` (`at` names the build), to
    /// their mirrors; on a technique's draw (`technique_bindings`), also to the bindings
    /// of `gpu::layout`.
    fn shader(&mut self, at: &str, shader: &str, spirv: &[u32], technique_bindings: bool) {
        let blocks = reflect::blocks(spirv).unwrap_or_else(|e| panic!("{at}: {e}"));
        for block in &blocks {
            if let Some(&(s, b, _)) = UNMIRRORED
                .iter()
                .find(|(s, b, _)| *s == shader && *b == block.name)
            {
                self.seen_unmirrored.insert((s, b));
                continue;
            }
            let Some(mirror) = self.mirrors.iter().find(|m| m.name == block.name) else {
                self.problems.push(format!(
                    "{at}: block {} has no Rust mirror (add its struct to mirrors(), or the \
                     block to UNMIRRORED with why it has none)",
                    block.name
                ));
                continue;
            };
            self.seen_mirrors.insert(mirror.name);
            self.problems
                .extend(reflect::layout_mismatches(at, block, mirror));
            if technique_bindings && block.kind == BlockKind::Uniform {
                let binding = match block.name.as_str() {
                    "FrameParams" => layout::BINDING_FRAME,
                    "SpecularParams" => layout::BINDING_SPECULAR_PARAMS,
                    _ => layout::BINDING_TECHNIQUE_PARAMS,
                };
                if (block.set, block.binding) != (Some(0), Some(binding)) {
                    self.problems.push(format!(
                        "{at}: block {} at set {:?} binding {:?}, not set 0 binding {binding}",
                        block.name, block.set, block.binding
                    ));
                }
            }
        }
    }
}

#[test]
fn every_block_has_the_layout_of_the_rust_struct_that_fills_it() {
    let mut check = Check {
        mirrors: mirrors(),
        problems: Vec::new(),
        seen_mirrors: BTreeSet::new(),
        seen_unmirrored: BTreeSet::new(),
    };
    for &technique in Technique::all() {
        for &path in HwPath::ALL {
            let (shader, defines) = technique_shader(technique, path);
            let at = format!("glsl/{shader} ({technique}.{path})");
            let spirv = compile_glsl(shader, ShaderStage::Fragment, &defines)
                .unwrap_or_else(|e| panic!("{at}: {e}"));
            check.shader(&at, shader, &spirv, true);
        }
    }
    for filter in NormalFilter::ALL {
        for &path in HwPath::ALL {
            let shader = "ndf/specular.frag";
            let defines = shvis::render::specular::frame_defines(filter, path);
            let at = format!("glsl/{shader} ({}.{path})", filter.name());
            let spirv = compile_glsl(shader, ShaderStage::Fragment, &defines)
                .unwrap_or_else(|e| panic!("{at}: {e}"));
            check.shader(&at, shader, &spirv, true);
        }
    }
    for &(shader, stage) in BAKE_SHADERS {
        let at = format!("glsl/{shader}");
        let spirv = compile_glsl(shader, stage, &[]).unwrap_or_else(|e| panic!("{at}: {e}"));
        check.shader(&at, shader, &spirv, false);
    }
    assert!(
        check.problems.is_empty(),
        "the Rust side and the shaders disagree:\n{}",
        check.problems.join("\n")
    );
    // The tables say no more than is true: every mirror and allow-list entry was met.
    for mirror in &check.mirrors {
        assert!(
            check.seen_mirrors.contains(mirror.name),
            "no compiled shader declares block {} (a stale mirror)",
            mirror.name
        );
    }
    for &(shader, block, _) in UNMIRRORED {
        assert!(
            check.seen_unmirrored.contains(&(shader, block)),
            "glsl/{shader} declares no block {block} (a stale UNMIRRORED entry)"
        );
    }
}

/// Every set of shader ids: those of the technique shaders, the reference's G-buffer
/// outputs and the parameterization study's.
fn all_ids() -> Vec<ShaderIds> {
    let mut all = shvis::technique::block::shader_ids();
    all.push(shvis::reference::gbuffer_output_ids());
    all.push(shvis::study::params_gpu::param_ids());
    all
}

#[test]
fn shader_ids_are_distinct_and_every_technique_compile_defines_each_once() {
    // Names apart from each other, from the selectors and from the layout macros.
    let mut names: BTreeSet<&str> = SHADER_MACROS.iter().map(|(n, _)| *n).collect();
    let sets = all_ids();
    for set in &sets {
        assert!(
            names.insert(set.selector),
            "SHVIS_{} named twice",
            set.selector
        );
    }
    for set in &sets {
        let mut values = BTreeSet::new();
        for &(name, value) in &set.ids {
            assert!(names.insert(name), "SHVIS_{name} named twice");
            assert!(
                values.insert(value),
                "SHVIS_{name} = {value}: another id of SHVIS_{} has that value",
                set.selector
            );
        }
    }
    for &technique in Technique::all() {
        for &path in HwPath::ALL {
            let (_, defines) = technique_shader(technique, path);
            let mut defined = BTreeSet::new();
            for (name, _) in &defines {
                assert!(
                    defined.insert(*name),
                    "{technique}.{path}: SHVIS_{name} defined twice"
                );
            }
            for set in shvis::technique::block::shader_ids() {
                for (name, _) in set.ids {
                    assert!(
                        defined.contains(name),
                        "{technique}.{path}: no SHVIS_{name}"
                    );
                }
            }
        }
    }
}

/// Where `text` uses the selector of `ids` as a number, as "line N: text": compared with
/// a digit (`== 2`, `3 !=`) or with a name that is none of its ids, tested alone in an
/// `#if`, or defined as a digit. Comments are skipped.
fn numeric_uses(text: &str, ids: &ShaderIds) -> Vec<String> {
    let token = format!("SHVIS_{}", ids.selector);
    let word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let digit = |c: char| c.is_ascii_digit();
    let ops = ["==", "!=", "<=", ">=", "<", ">"];
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let directive = code.trim_start();
        let condition = directive.starts_with("#if ") || directive.starts_with("#elif ");
        for (at, _) in code.match_indices(&token) {
            let (before, after) = (&code[..at], &code[at + token.len()..]);
            if before.ends_with(word) || after.starts_with(word) {
                continue; // another macro that starts or ends alike
            }
            let (before, after) = (before.trim_end(), after.trim_start());
            let rhs = ops
                .iter()
                .find_map(|op| after.strip_prefix(op))
                .map(str::trim_start);
            let lhs = ops
                .iter()
                .find_map(|op| before.strip_suffix(op))
                .map(str::trim_end);
            let with_digit = rhs.is_some_and(|r| r.starts_with(digit))
                || lhs.is_some_and(|l| l.ends_with(digit));
            let with_other_name = rhs
                .and_then(|r| r.strip_prefix("SHVIS_"))
                .map(|r| r.split(|c: char| !word(c)).next().unwrap_or(""))
                .is_some_and(|name| !ids.ids.iter().any(|(n, _)| *n == name));
            let alone = condition
                && rhs.is_none()
                && lhs.is_none()
                && !before.ends_with("defined(")
                && !before.ends_with("defined");
            let defined_as_digit = before.ends_with("#define") && after.starts_with(digit);
            if with_digit || with_other_name || alone || defined_as_digit {
                found.push(format!("line {}: {}", i + 1, line.trim()));
            }
        }
    }
    found
}

#[test]
fn no_shader_compares_an_id_selector_with_a_number() {
    let sets = all_ids();
    let mut found = Vec::new();
    for (path, text) in embedded_sources() {
        for set in &sets {
            found.extend(
                numeric_uses(text, set)
                    .into_iter()
                    .map(|f| format!("glsl/{path}: SHVIS_{}: {f}", set.selector)),
            );
        }
    }
    assert!(
        found.is_empty(),
        "compare each selector with its ids' names (gpu::layout::ShaderIds):\n{}",
        found.join("\n")
    );
    for set in &sets {
        let token = format!("SHVIS_{}", set.selector);
        assert!(
            embedded_sources().iter().any(|(_, t)| t.contains(&token)),
            "no shader selects by {token}"
        );
    }
}

#[test]
fn the_id_check_catches_planted_numeric_uses() {
    let ids = ShaderIds {
        selector: "X",
        ids: vec![("X_A", 0), ("X_B", 1)],
    };
    let text = "#if SHVIS_X == 2\n\
                #elif 3 != SHVIS_X // a comment\n\
                v = SHVIS_X == SHVIS_X_A ? 1.0 : 0.0;\n\
                // SHVIS_X == 4 in a comment\n\
                #if SHVIS_X\n\
                #ifdef SHVIS_X\n\
                #if defined(SHVIS_X) && SHVIS_XY == 1\n\
                #if SHVIS_X != SHVIS_Y_A\n\
                #define SHVIS_X 0\n\
                #if SHVIS_X >= SHVIS_X_B\n";
    let found = numeric_uses(text, &ids);
    let lines: Vec<&str> = found.iter().map(|f| f.split(':').next().unwrap()).collect();
    assert_eq!(
        lines,
        ["line 1", "line 2", "line 5", "line 8", "line 9"],
        "{found:?}"
    );
}
