// vqK and cpcaK_M: a cluster index and M 8-bit weights per texel, per cluster and basis
// vector (and the cluster mean) the order-3 SH of B_C,k·L convolved with the clamped cosine
// in a uniform block — pcaw.frag's weights-only route, one block per cluster (PRT course:
// per-cluster work on the CPU, the linear combination on the GPU; src/technique/cluster.rs).
// Value j of a texel is lane j%4 of group j/4: weights 0 … M−1, then the index as UNORM8.
//
// Cluster boundaries (SHVIS_SEAM_BLEND): 1 fetches the 4 bilinear taps unfiltered, decodes
// each in its own cluster and blends the reconstructions bilinearly (the mitigation) —
// where all four share a cluster that is one decode of the blended weights; 0
// filters the weights bilinearly across the boundary and decodes them in the nearest
// texel's cluster (the known artifact).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"

#define K SHVIS_CLUSTERS
#define M SHVIS_CLUSTER_VECTORS
#define GROUPS ((M + 4) / 4)
#define BLOCK ((M + 1) * 9)

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ClusterParams {
    // Cluster c, vector k (k = M: the mean), coefficient i at [BLOCK·c + 9k + i], RGB in .xyz.
    layout(offset = 0) vec4 coeffs[K * BLOCK];
} params;

#define SHVIS_PER_TEXEL_GROUPS GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if GROUPS > 4
#error "at most 4 groups (15 vectors and the index)"
#endif

// Group g of texel ij, unfiltered (on dx9 each branch indexes the sampler array by a
// constant).
vec4 fetch_group(int g, ivec2 ij) {
#if SHVIS_PATH_DX9
    if (g == 0) return FETCH_PER_TEXEL(0, ij);
#if GROUPS > 1
    if (g == 1) return FETCH_PER_TEXEL(1, ij);
#endif
#if GROUPS > 2
    if (g == 2) return FETCH_PER_TEXEL(2, ij);
#endif
#if GROUPS > 3
    if (g == 3) return FETCH_PER_TEXEL(3, ij);
#endif
    return vec4(0.0);
#else
    return FETCH_PER_TEXEL(g, ij);
#endif
}

// Group g at the fragment, bilinearly filtered.
vec4 sample_group(int g) {
#if SHVIS_PATH_DX9
    if (g == 0) return SAMPLE_PER_TEXEL(0);
#if GROUPS > 1
    if (g == 1) return SAMPLE_PER_TEXEL(1);
#endif
#if GROUPS > 2
    if (g == 2) return SAMPLE_PER_TEXEL(2);
#endif
#if GROUPS > 3
    if (g == 3) return SAMPLE_PER_TEXEL(3);
#endif
    return vec4(0.0);
#else
    return SAMPLE_PER_TEXEL(g);
#endif
}

int cluster_index(vec4 index_group) {
    return min(int(index_group[M % 4] * 255.0 + 0.5), K - 1);
}

// e += tap · (mean_c + Σ_k w_k B_c,k), in SH(·L) coefficients.
void add_cluster(inout vec4 e[9], float tap, vec4 v[GROUPS], int c) {
    int base = c * BLOCK;
    for (int i = 0; i < 9; ++i) {
        e[i] += tap * params.coeffs[base + 9 * M + i];
    }
    for (int k = 0; k < M; ++k) {
        float w = tap * v[k / 4][k % 4];
        for (int i = 0; i < 9; ++i) {
            e[i] += w * params.coeffs[base + 9 * k + i];
        }
    }
}

void main() {
    vec4 e[9];
    for (int i = 0; i < 9; ++i) {
        e[i] = vec4(0.0);
    }
    ivec2 res = PER_TEXEL_SIZE;
#if SHVIS_SEAM_BLEND
    // The sampler's own bilinear footprint: texel centres at (i + 0.5) / res, clamped.
    vec2 st = in_uv_lightmap * vec2(res) - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    vec4 v[4][GROUPS];
    float w[4];
    int c[4];
    for (int tap = 0; tap < 4; ++tap) {
        ivec2 offset = ivec2(tap & 1, tap >> 1);
        ivec2 ij = clamp(ivec2(base) + offset, ivec2(0), res - 1);
        vec2 w2 = mix(1.0 - f, f, vec2(offset));
        for (int g = 0; g < GROUPS; ++g) {
            v[tap][g] = fetch_group(g, ij);
        }
        w[tap] = w2.x * w2.y;
        c[tap] = cluster_index(v[tap][M / 4]);
    }
    if (c[0] == c[1] && c[0] == c[2] && c[0] == c[3]) {
        // Inside a cluster the decode is linear: blend the weights, decode once (the
        // same sum, a quarter of the cluster block's reads).
        vec4 blended[GROUPS];
        for (int g = 0; g < GROUPS; ++g) {
            blended[g] = w[0] * v[0][g] + w[1] * v[1][g] + w[2] * v[2][g] + w[3] * v[3][g];
        }
        add_cluster(e, 1.0, blended, c[0]);
    } else {
        for (int tap = 0; tap < 4; ++tap) {
            add_cluster(e, w[tap], v[tap], c[tap]);
        }
    }
#else
    ivec2 nearest = clamp(ivec2(floor(in_uv_lightmap * vec2(res))), ivec2(0), res - 1);
    vec4 v[GROUPS];
    for (int g = 0; g < GROUPS; ++g) {
        v[g] = sample_group(g);
    }
    add_cluster(e, 1.0, v, cluster_index(fetch_group(M / 4, nearest)));
#endif
    vec3 irradiance = max(sh_eval_rgb_order3(e, shading_normal()), vec3(0.0));
    write_diffuse(irradiance);
}
