//! The GLSL of the probe's microbenchmarks: for each kind of operation, a fragment shader
//! of N such operations in straight-line code (or, for the indexed uniform reads, in the
//! loop a cluster decode runs), optionally inside a branch that no lane takes, over the
//! shared interface of the techniques' shaders (`common.glsl`).

use super::resources::{TEXTURE_SIDE, TEXTURES, UNIFORM_VEC4S};
use crate::cost::Kind;

/// The varyings the probe's shaders can read (the scene vertex's 14 floats).
pub(super) const MAX_PROBE_VARYINGS: u32 = 14;

/// The GLSL of a probe point: `count` operations of `kind` (`None`: the empty shader), in
/// a branch that no lane takes where `untaken`; `counted`: the build whose SPIR-V is
/// counted (its loops unrolled, as the techniques' count builds), else the drawn one.
pub(super) fn probe_source(kind: Option<Kind>, count: u32, untaken: bool, counted: bool) -> String {
    let (decl, mut body) = match kind {
        // Every technique reads at least its lightmap coordinates; a shader that reads no
        // varying can skip lavapipe's interpolation set-up (5.4 against 8.0 ms per screen
        // over 2·32² triangles at 1280×800 in one run), a path no technique takes.
        // (A loop's cost has no points of its own.)
        None | Some(Kind::Loop) => (String::new(), "    acc.xy = in_uv_lightmap;\n".to_string()),
        Some(
            k @ (Kind::Bilinear2d | Kind::Trilinear2d | Kind::TrilinearWide | Kind::TrilinearSrgb),
        ) => filtered_2d_lookups(k, count),
        Some(Kind::TexelFetch) => texel_fetches(count),
        Some(Kind::Array2d | Kind::Bc6hArray | Kind::Bc7Array | Kind::Bc4Array) => {
            array_lookups(count)
        }
        Some(Kind::Transcendental) => (String::new(), transcendentals(count)),
        Some(Kind::IndexedPrivateRead) => (String::new(), indexed_private_reads(count)),
        Some(Kind::IntegerDivide) => (String::new(), integer_divides(count)),
        Some(Kind::CubeArray) => cube_array_lookups(count),
        Some(Kind::Dependent2d) => dependent_lookups(count),
        Some(Kind::FloatOp) => (String::new(), float_ops(count)),
        Some(Kind::Varying) => (String::new(), varying_reads(count)),
        Some(Kind::UniformRead) => uniform_reads(count),
        Some(Kind::IndexedUniformRead) => indexed_uniform_reads(count, untaken, counted),
    };
    if untaken {
        // Lightmap coordinates are never below 0: no lane takes it, and no compiler knows.
        body = format!("    if (in_uv_lightmap.x < -1.0) {{\n{body}    }}\n");
    }
    fragment_shader(&decl, &body)
}

/// The binding of the probe's textures (the techniques' first texture binding).
const TEXTURE0: &str = "SHVIS_BINDING_TECHNIQUE_TEXTURE0";

/// One texel of the probe's textures, in texture coordinates, as GLSL.
fn texel_step() -> String {
    format!("{:.8}", 1.0 / TEXTURE_SIDE as f64)
}

/// The declaration of the [`TEXTURES`] 2D textures a point's lookups read in turn.
fn texture_array_decl() -> String {
    format!("layout(set = 0, binding = {TEXTURE0}) uniform sampler2D probe_tex[{TEXTURES}];\n")
}

/// The declaration of the probe's uniform block of [`UNIFORM_VEC4S`] vec4s.
fn uniform_block_decl() -> String {
    format!(
        "layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform Probe {{ vec4 v[{UNIFORM_VEC4S}]; }} probe;\n"
    )
}

/// `count` filtered 2D lookups of `kind` (bilinear at the lightmap coordinates, trilinear at
/// the material ones), each into the next texture: the declaration and the body.
fn filtered_2d_lookups(kind: Kind, count: u32) -> (String, String) {
    let step = texel_step();
    let uv = if kind == Kind::Bilinear2d {
        "in_uv_lightmap"
    } else {
        "in_uv_material"
    };
    let mut body = String::new();
    for k in 0..count {
        body += &format!(
            "    acc += texture(probe_tex[{}], {uv} + vec2({} * {step}, 0.0));\n",
            k % TEXTURES,
            k / TEXTURES
        );
    }
    (texture_array_decl(), body)
}

/// `count` texel fetches, four per texture at the texels of a bilinear footprint: the
/// declaration and the body.
fn texel_fetches(count: u32) -> (String, String) {
    let mut body = format!(
        "    ivec2 texel = clamp(ivec2(in_uv_lightmap * {TEXTURE_SIDE}.0), ivec2(0), ivec2({}));\n",
        TEXTURE_SIDE - 2
    );
    for k in 0..count {
        body += &format!(
            "    acc += texelFetch(probe_tex[{}], texel + ivec2({}, {}), 0);\n",
            (k / 4) % TEXTURES,
            k & 1,
            (k >> 1) & 1
        );
    }
    (texture_array_decl(), body)
}

/// `count` 2D-array lookups, each into the next layer: the declaration and the body.
fn array_lookups(count: u32) -> (String, String) {
    let step = texel_step();
    let decl = format!("layout(set = 0, binding = {TEXTURE0}) uniform sampler2DArray probe_tex;\n");
    let mut body = String::new();
    for k in 0..count {
        body += &format!(
            "    acc += texture(probe_tex, vec3(in_uv_lightmap + vec2({} * {step}, 0.0), {}.0));\n",
            k / TEXTURES,
            k % TEXTURES
        );
    }
    (decl, body)
}

/// `count` cube-array lookups, each into the next cube: the declaration and the body.
fn cube_array_lookups(count: u32) -> (String, String) {
    let step = texel_step();
    let decl =
        format!("layout(set = 0, binding = {TEXTURE0}) uniform samplerCubeArray probe_tex;\n");
    let mut body = "    vec3 d = vec3(in_uv_lightmap * 2.0 - 1.0, 1.0);\n".to_string();
    for k in 0..count {
        body += &format!(
            "    acc += texture(probe_tex, vec4(d + vec3({} * {step}), {}.0));\n",
            k / TEXTURES,
            k % TEXTURES
        );
    }
    (decl, body)
}

/// `count` dependent lookups, each at coordinates moved by the previous one's result:
/// the declaration and the body.
fn dependent_lookups(count: u32) -> (String, String) {
    let step = texel_step();
    let mut body = "    vec2 c = in_uv_lightmap;\n".to_string();
    for k in 0..count {
        body += &format!(
            "    {{ vec4 s = texture(probe_tex[{}], c); c += (s.xy - 0.5) * {step}; acc += s; }}\n",
            k % TEXTURES
        );
    }
    (texture_array_decl(), body)
}

/// At least `count` float operations, in rounds of 16: the body.
fn float_ops(count: u32) -> String {
    // Four independent vec4 chains of fma(v, m, b): 16 float ops per round. m and b
    // come from the lightmap coordinates, which no compiler can fold; read from the
    // uniform block, they tied the uniform read's cost to these points, where two
    // reads cost far less than two of a long run of reads.
    let mut body = String::new();
    body +=
        "    vec4 m = vec4(0.999) + in_uv_lightmap.xyxy * 1e-6, b = in_uv_lightmap.yxyx * 1e-3;\n";
    body +=
        "    vec4 c0 = vec4(in_uv_lightmap, 0.0, 1.0), c1 = c0.yxzw, c2 = c0.xxyy, c3 = c0.yyxx;\n";
    for _ in 0..count.div_ceil(16) {
        body +=
            "    c0 = fma(c0, m, b); c1 = fma(c1, m, b); c2 = fma(c2, m, b); c3 = fma(c3, m, b);\n";
    }
    body += "    acc = c0 + c1 + c2 + c3;\n";
    body
}

/// At least `count` transcendentals, in rounds of 32: the body.
fn transcendentals(count: u32) -> String {
    // Four independent vec4 chains of sin(exp(c)), every lane from the varyings (a constant
    // lane would be folded where the device runs lanes apart): bounded, so no value
    // overflows or turns denormal however long the chain.
    let mut body = String::new();
    body += "    vec4 c0 = vec4(in_uv_lightmap, in_uv_lightmap.yx * 0.5 + 0.25), c1 = c0.yxwz, c2 = c0.zwxy, c3 = c0.wzyx;\n";
    for _ in 0..count.div_ceil(32) {
        body += "    c0 = sin(exp(c0)); c1 = sin(exp(c1)); c2 = sin(exp(c2)); c3 = sin(exp(c3));\n";
    }
    body += "    acc = c0 + c1 + c2 + c3;\n";
    body
}

/// `count` reads of a private array of 12 floats at an index computed per pixel, in blocks
/// of 9 from an array filled afresh for each block, as Ambient Dice reads a vertex's
/// values at its offset: the body.
fn indexed_private_reads(count: u32) -> String {
    let mut body = "    int o = int(in_uv_lightmap.x * 4.0) & 3;\n    float t[12];\n".to_string();
    for block in 0..count.div_ceil(9) {
        for i in 0..12 {
            body += &format!(
                "    t[{i}] = in_uv_lightmap[{}] + {}.0;\n",
                i & 1,
                block * 12 + i
            );
        }
        for k in 0..(count - 9 * block).min(9) {
            body += &format!("    acc.x += t[o + {k}];\n");
        }
    }
    body
}

/// `count` integer divisions and remainders (alternately) by a divisor that varies across
/// the screen, as a dx9 atlas tile's column and row: the body.
fn integer_divides(count: u32) -> String {
    let mut body = "    int q = int(in_uv_lightmap.x * 4096.0) + 4096;\n\
                    int d = 3 + (int(in_uv_lightmap.y * 8.0) & 7);\n"
        .to_string();
    for k in 0..count {
        let op = if k % 2 == 0 { '/' } else { '%' };
        body += &format!("    acc.x += float((q + {k}) {op} d);\n");
    }
    body
}

/// The first `count` of the scene vertex's [`MAX_PROBE_VARYINGS`] varying floats, read:
/// the body.
fn varying_reads(count: u32) -> String {
    let floats: [&str; MAX_PROBE_VARYINGS as usize] = [
        "in_normal_world.x",
        "in_normal_world.y",
        "in_normal_world.z",
        "in_tangent_world.x",
        "in_tangent_world.y",
        "in_tangent_world.z",
        "in_tangent_world.w",
        "in_uv_material.x",
        "in_uv_material.y",
        "in_uv_lightmap.x",
        "in_uv_lightmap.y",
        "in_albedo_tint.x",
        "in_albedo_tint.y",
        "in_albedo_tint.z",
    ];
    let mut body = String::new();
    for f in floats.iter().take(count as usize) {
        body += &format!("    acc.x += {f};\n");
    }
    body
}

/// `count` uniform vec4 reads at constant indices: the declaration and the body.
fn uniform_reads(count: u32) -> (String, String) {
    // The lightmap coordinates read as every technique reads them: a shader that
    // reads no varying skips lavapipe's interpolation set-up, and without them these
    // points ran 1.7 ms under the empty shader's base (their reads, 0.62–0.66 ms
    // each, were fitted at 0.52–0.56).
    let mut body = "    acc.xy = in_uv_lightmap;\n".to_string();
    for k in 0..count.min(UNIFORM_VEC4S) {
        body += &format!("    acc += probe.v[{k}];\n");
    }
    (uniform_block_decl(), body)
}

/// `count` uniform vec4 reads at indices that vary per pixel: straight-line where
/// `untaken`, else in the loop a cluster decode runs (unrolled where `counted`): the
/// declaration and the body.
fn indexed_uniform_reads(count: u32, untaken: bool, counted: bool) -> (String, String) {
    // A base that varies across the screen, as a cluster id does between texels.
    let mut body = "    int base = int(in_uv_lightmap.x * 8.0) & 7;\n".to_string();
    if untaken {
        // Straight-line (a loop no lane enters is skipped, `CostModel::untaken_share`).
        for k in 0..count.min(UNIFORM_VEC4S - 8) {
            body += &format!("    acc += probe.v[base + {k}];\n");
        }
    } else {
        // As a cluster decode reads them: a loop over blocks of 9, each read's RGB
        // scaled and summed (cluster.frag's `block_dot`), kept a loop where drawn and
        // unrolled where counted.
        let blocks = count.min(UNIFORM_VEC4S - 8) / 9;
        let attribute = if counted { "unroll" } else { "dont_unroll" };
        body += "    vec3 e = vec3(0.0);\n    float y = in_uv_lightmap.y;\n";
        body += &format!(
            "    [[{attribute}]] for (int k = 0; k < {blocks}; ++k) {{\n        int at = base + 9 * k;\n"
        );
        for i in 0..9 {
            body += &format!("        e += probe.v[at + {i}].rgb * y;\n");
        }
        body += "    }\n    acc.rgb += e;\n";
    }
    (uniform_block_decl(), body)
}

/// A probe fragment shader: `decl` after the shared interface (`common.glsl`), `body` adding
/// into `vec4 acc`, which it writes out scaled down (so nothing is dead code).
pub(super) fn fragment_shader(decl: &str, body: &str) -> String {
    format!(
        "#version 450\n#extension GL_GOOGLE_include_directive : require\n\
         #extension GL_EXT_control_flow_attributes : require\n#define SHVIS_FRAGMENT 1\n\
         #include \"common.glsl\"\n{decl}layout(location = 0) out vec4 out_color;\n\
         void main() {{\n    vec4 acc = vec4(0.0);\n{body}    out_color = vec4(acc.rgb * 1e-3 + 0.5, 1.0);\n}}\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::spirv;
    use crate::gpu::ShaderStage;
    use crate::probe::{UNTAKEN_BRANCH_READS, probe_counts};

    #[test]
    fn probe_shaders_compile_and_count_what_they_were_generated_with() {
        for kind in Kind::ALL {
            for &count in probe_counts(kind) {
                let spirv = crate::gpu::shader::compile_source(
                    "probe.frag",
                    &probe_source(Some(kind), count, false, true),
                    ShaderStage::Fragment,
                    &[],
                )
                .unwrap();
                let ops = spirv::count(&spirv);
                assert_eq!(ops.loops, 0, "{kind:?} {count}");
                match kind {
                    Kind::UniformRead => assert!(ops.uniform_reads >= count, "{ops:?}"),
                    Kind::IndexedUniformRead => {
                        assert_eq!(ops.indexed_uniform_reads, count, "{ops:?}");
                    }
                    Kind::Varying => assert_eq!(ops.varying_reads, count, "{ops:?}"),
                    Kind::FloatOp => assert!(ops.float_ops >= count, "{ops:?}"),
                    Kind::Transcendental => assert!(ops.transcendentals >= count, "{ops:?}"),
                    Kind::IntegerDivide => assert_eq!(ops.integer_divides, count, "{ops:?}"),
                    Kind::IndexedPrivateRead => {
                        assert_eq!(ops.indexed_private_reads, count, "{ops:?}");
                    }
                    _ => assert_eq!(ops.samples, count, "{kind:?}: {ops:?}"),
                }
            }
        }
        for &count in UNTAKEN_BRANCH_READS {
            let source = probe_source(Some(Kind::IndexedUniformRead), count, true, true);
            let spirv = crate::gpu::shader::compile_source(
                "probe.frag",
                &source,
                ShaderStage::Fragment,
                &[],
            )
            .unwrap();
            // SPIR-V counts the branch's reads though no lane runs them.
            let ops = spirv::count(&spirv);
            assert_eq!(ops.indexed_uniform_reads, count, "{ops:?}");
            assert!(source.contains("if (in_uv_lightmap.x < -1.0)"), "{source}");
        }
    }
}
