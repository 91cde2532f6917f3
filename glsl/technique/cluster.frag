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
#extension GL_EXT_control_flow_attributes : require
#define UNROLL
#define KEEP_LOOP [[dont_unroll]]
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"
#include "cluster_decode.glsl"

void main() {
    float y[9];
    sh_eval_order3(shading_normal(), y);
#if SHVIS_SEAM_BLEND
    vec4 v[4][GROUPS];
    float w[4];
    int c[4];
    cluster_taps(v, w, c);
    vec3 e;
    if (c[0] == c[1] && c[0] == c[2] && c[0] == c[3]) {
        e = cluster_decode_inside(v, w, c, y);
    } else {
        e = cluster_decode_across(v, w, c, y);
    }
#else
    vec3 e = cluster_decode_naive(y);
#endif
    write_diffuse(max(e, vec3(0.0)));
}
