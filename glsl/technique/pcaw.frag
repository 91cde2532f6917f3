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

// Every uniform read has a constant index: the groups and coefficients are unrolled here,
// not left to the driver (with loop-derived indices lavapipe gathers the block per pixel,
// issue 20: pca24w 215 ms against pca24's 62 ms at 1280×800), and the sums are RGB only.
#define COEFF(k, i) params.coeffs[9 * (k) + (i)].rgb
#define ACC_I(w, g, i) e[i] += w.x * COEFF(4 * (g), i) + w.y * COEFF(4 * (g) + 1, i) \
    + w.z * COEFF(4 * (g) + 2, i) + w.w * COEFF(4 * (g) + 3, i);
#define ACC_GROUP(g) { \
    vec4 w = GROUP_WEIGHTS(g); \
    ACC_I(w, g, 0) ACC_I(w, g, 1) ACC_I(w, g, 2) ACC_I(w, g, 3) ACC_I(w, g, 4) \
    ACC_I(w, g, 5) ACC_I(w, g, 6) ACC_I(w, g, 7) ACC_I(w, g, 8) \
}
#if defined(SHVIS_VERTEX_WEIGHTS) && SHVIS_VERTEX_WEIGHTS
#define GROUP_WEIGHTS(g) in_vertex_weights[g]
#else
#define GROUP_WEIGHTS(g) SAMPLE_PER_TEXEL(g)
#endif

void main() {
    vec3 e[9] = vec3[9](COEFF(BASIS_COUNT, 0), COEFF(BASIS_COUNT, 1), COEFF(BASIS_COUNT, 2),
                        COEFF(BASIS_COUNT, 3), COEFF(BASIS_COUNT, 4), COEFF(BASIS_COUNT, 5),
                        COEFF(BASIS_COUNT, 6), COEFF(BASIS_COUNT, 7), COEFF(BASIS_COUNT, 8));
    ACC_GROUP(0)
#if GROUPS > 1
    ACC_GROUP(1)
#endif
#if GROUPS > 2
    ACC_GROUP(2)
#endif
#if GROUPS > 3
    ACC_GROUP(3)
#endif
#if GROUPS > 4
    ACC_GROUP(4)
#endif
#if GROUPS > 5
    ACC_GROUP(5)
#endif
#if GROUPS > 6
#error "at most 6 groups (24 basis vectors)"
#endif
    float y[9];
    sh_eval_order3(shading_normal(), y);
    vec3 irradiance = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        irradiance += e[i] * y[i];
    }
    irradiance = max(irradiance, vec3(0.0));
    write_diffuse(irradiance);
}
