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
// pca24w 215 ms against pca24's 62 ms at 1280×800), and the sums are RGB only.
// y(n) is evaluated first and each basis vector dotted with it as it is read, so only y,
// one dot and the RGB sum stay live (summing the 9 SH coefficients over the basis first
// keeps 27 floats live across every group — more than the 16 vector registers lavapipe
// has, as in cluster.frag): E = Σ_i (m_i + Σ_k w_k c_ki) y_i = m·y + Σ_k w_k (c_k·y).
#define COEFF(k, i) params.coeffs[9 * (k) + (i)].rgb
#define DOT_Y(k) (COEFF(k, 0) * y[0] + COEFF(k, 1) * y[1] + COEFF(k, 2) * y[2] \
    + COEFF(k, 3) * y[3] + COEFF(k, 4) * y[4] + COEFF(k, 5) * y[5] + COEFF(k, 6) * y[6] \
    + COEFF(k, 7) * y[7] + COEFF(k, 8) * y[8])
#define ACC_GROUP(g) { \
    vec4 w = GROUP_WEIGHTS(g); \
    irradiance += w.x * DOT_Y(4 * (g)); \
    irradiance += w.y * DOT_Y(4 * (g) + 1); \
    irradiance += w.z * DOT_Y(4 * (g) + 2); \
    irradiance += w.w * DOT_Y(4 * (g) + 3); \
}
#if defined(SHVIS_VERTEX_WEIGHTS) && SHVIS_VERTEX_WEIGHTS
#define GROUP_WEIGHTS(g) in_vertex_weights[g]
#else
#define GROUP_WEIGHTS(g) SAMPLE_PER_TEXEL(g)
#endif

void main() {
    float y[9];
    sh_eval_order3(shading_normal(), y);
    vec3 irradiance = DOT_Y(BASIS_COUNT);
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
    irradiance = max(irradiance, vec3(0.0));
    write_diffuse(irradiance);
}
