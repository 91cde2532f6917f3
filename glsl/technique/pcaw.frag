// pca4w … pca24w, the weights-only variant (Iwanicki–Sloan §4, footnote 2; DESIGN §2;
// src/technique/pca.rs): per basis vector (and the mean) the order-3 SH of V_k·L, already
// convolved with the clamped cosine (A_l folded in), sits in a uniform block; the shader
// sums w_k times them and evaluates at the normal — no dependent texture lookups.
// SHVIS_VERTEX_WEIGHTS (pcaMv, src/technique/vertex.rs): the weights come interpolated from
// the vertex stream instead of the lightmap.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"

#define GROUPS SHVIS_PCA_GROUPS
#define BASIS_COUNT (4 * GROUPS)

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform PcaWeightsParams {
    // Basis k's 9 RGB coefficients at [9k + i]; the mean's at [9·BASIS_COUNT + i].
    layout(offset = 0) vec4 coeffs[(BASIS_COUNT + 1) * 9];
} params;

#if defined(SHVIS_VERTEX_WEIGHTS) && SHVIS_VERTEX_WEIGHTS
layout(location = 6) in vec4 in_vertex_weights[GROUPS];
#else
#define SHVIS_PER_TEXEL_GROUPS GROUPS
#include "per_texel.glsl"
#endif
#include "diffuse_out.glsl"

void main() {
    vec4 e[9];
    for (int i = 0; i < 9; ++i) {
        e[i] = params.coeffs[9 * BASIS_COUNT + i];
    }
    for (int g = 0; g < GROUPS; ++g) {
#if defined(SHVIS_VERTEX_WEIGHTS) && SHVIS_VERTEX_WEIGHTS
        vec4 w = in_vertex_weights[g];
#elif SHVIS_PATH_DX9
        // Constant indices for the sampler array: unrolled by the compiler per g below.
        vec4 w = vec4(0.0);
        if (g == 0) w = SAMPLE_PER_TEXEL(0);
#if GROUPS > 1
        if (g == 1) w = SAMPLE_PER_TEXEL(1);
#endif
#if GROUPS > 2
        if (g == 2) w = SAMPLE_PER_TEXEL(2);
#endif
#if GROUPS > 3
        if (g == 3) w = SAMPLE_PER_TEXEL(3);
#endif
#if GROUPS > 4
        if (g == 4) w = SAMPLE_PER_TEXEL(4);
#endif
#if GROUPS > 5
        if (g == 5) w = SAMPLE_PER_TEXEL(5);
#endif
#if GROUPS > 6
#error "at most 6 groups (24 basis vectors)"
#endif
#else
        vec4 w = SAMPLE_PER_TEXEL(g);
#endif
        for (int i = 0; i < 9; ++i) {
            e[i] += w.x * params.coeffs[9 * (4 * g) + i] + w.y * params.coeffs[9 * (4 * g + 1) + i]
                  + w.z * params.coeffs[9 * (4 * g + 2) + i] + w.w * params.coeffs[9 * (4 * g + 3) + i];
        }
    }
    vec3 irradiance = max(sh_eval_rgb_order3(e, shading_normal()), vec3(0.0));
    write_diffuse(irradiance);
}
