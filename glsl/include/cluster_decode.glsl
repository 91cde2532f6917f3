// The decode of vqK / cpcaK_M (src/technique/cluster.rs), shared by the drawn shader
// (glsl/technique/cluster.frag) and the cost model's count builds (glsl/cost/cluster.frag):
// the cluster block in uniforms, the per-texel groups, the bilinear taps, and the
// reconstruction E(n) = Σ_i (μ_C,i + Σ_k w_k B_C,k,i) y_i(n) of one texel or tap.
// The including shader defines UNROLL and KEEP_LOOP (the loop attributes) and may define
// CLUSTER_MEAN_ONLY 1: the decode reads the cluster mean alone, its loop over vectors cut.
#ifndef SHVIS_CLUSTER_DECODE_GLSL
#define SHVIS_CLUSTER_DECODE_GLSL

#ifndef CLUSTER_MEAN_ONLY
#define CLUSTER_MEAN_ONLY 0
#endif

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

// The block's vector at `at` (9 coefficients) dotted with the basis values y(n), RGB.
vec3 block_dot(int at, float y[9]) {
    vec3 sum = vec3(0.0);
    UNROLL for (int i = 0; i < 9; ++i) {
        sum += params.coeffs[at + i].rgb * y[i];
    }
    return sum;
}

// tap · (mean_c + Σ_k w_k B_c,k) · y(n): the cluster's share of the irradiance at n. Each
// vector is dotted with y(n) as it is read, so that only y and a running RGB sum stay live
// (accumulating the 9 SH coefficients first and evaluating them once holds 36 floats per
// pixel, and measured slower on lavapipe).
vec3 cluster_irradiance(float tap, vec4 v[GROUPS], int c, float y[9]) {
    int base = c * BLOCK;
    vec3 e = tap * block_dot(base + 9 * M, y);
#if M > 0 && !CLUSTER_MEAN_ONLY
    // Kept a loop when drawn: Mesa's NIR unrolls short loops in full, and unrolled the
    // decode measured 2× slower on lavapipe (cpca8_7 183 against 90 ms).
    // The weights shift down one place per vector, so that weight k is always lane 0 of
    // the first group: `v[k / 4][k % 4]` in a kept loop indexes a local array, which
    // lavapipe spills to memory and gathers from at every vector (cpca8_11 144 against
    // 103 ms with the weight read taken out), while a shift is register moves. Groups as
    // plain variables (no array), so that a build with every loop unrolled can unroll it.
    vec4 w0 = v[0];
#if GROUPS > 1
    vec4 w1 = v[1];
#endif
#if GROUPS > 2
    vec4 w2 = v[2];
#endif
#if GROUPS > 3
    vec4 w3 = v[3];
#endif
    KEEP_LOOP for (int k = 0; k < M; ++k) {
        float weight = w0.x;
#if GROUPS == 1
        w0 = w0.yzwx;
#elif GROUPS == 2
        w0 = vec4(w0.yzw, w1.x);
        w1 = w1.yzwx;
#elif GROUPS == 3
        w0 = vec4(w0.yzw, w1.x);
        w1 = vec4(w1.yzw, w2.x);
        w2 = w2.yzwx;
#else
        w0 = vec4(w0.yzw, w1.x);
        w1 = vec4(w1.yzw, w2.x);
        w2 = vec4(w2.yzw, w3.x);
        w3 = w3.yzwx;
#endif
        e += (tap * weight) * block_dot(base + 9 * k, y);
    }
#endif
    return e;
}

// The four taps of the sampler's own bilinear footprint (texel centres at (i + 0.5) / res,
// clamped): every group of each, its bilinear weight and its cluster.
void cluster_taps(out vec4 v[4][GROUPS], out float w[4], out int c[4]) {
    ivec2 res = PER_TEXEL_SIZE;
    vec2 st = in_uv_lightmap * vec2(res) - 0.5;
    vec2 base = floor(st);
    vec2 f = st - base;
    UNROLL for (int tap = 0; tap < 4; ++tap) {
        ivec2 offset = ivec2(tap & 1, tap >> 1);
        ivec2 ij = clamp(ivec2(base) + offset, ivec2(0), res - 1);
        vec2 w2 = mix(1.0 - f, f, vec2(offset));
        UNROLL for (int g = 0; g < GROUPS; ++g) {
            v[tap][g] = fetch_group(g, ij);
        }
        w[tap] = w2.x * w2.y;
        c[tap] = cluster_index(v[tap][M / 4]);
    }
}

// Inside a cluster the decode is linear: blend the weights, decode once (the same sum, a
// quarter of the cluster block's reads).
vec3 cluster_decode_inside(vec4 v[4][GROUPS], float w[4], int c[4], float y[9]) {
    vec4 blended[GROUPS];
    UNROLL for (int g = 0; g < GROUPS; ++g) {
        blended[g] = w[0] * v[0][g] + w[1] * v[1][g] + w[2] * v[2][g] + w[3] * v[3][g];
    }
    return cluster_irradiance(1.0, blended, c[0], y);
}

// Across a boundary each tap is decoded in its own cluster and the results blended.
vec3 cluster_decode_across(vec4 v[4][GROUPS], float w[4], int c[4], float y[9]) {
    vec3 e = vec3(0.0);
    UNROLL for (int tap = 0; tap < 4; ++tap) {
        e += cluster_irradiance(w[tap], v[tap], c[tap], y);
    }
    return e;
}

// Naive seams: the weights filtered bilinearly, decoded in the nearest texel's cluster.
vec3 cluster_decode_naive(float y[9]) {
    ivec2 res = PER_TEXEL_SIZE;
    ivec2 nearest = clamp(ivec2(floor(in_uv_lightmap * vec2(res))), ivec2(0), res - 1);
    vec4 v[GROUPS];
    UNROLL for (int g = 0; g < GROUPS; ++g) {
        v[g] = sample_group(g);
    }
    return cluster_irradiance(1.0, v, cluster_index(fetch_group(M / 4, nearest)), y);
}

#endif
