// The cost model's builds of glsl/technique/cluster.frag (`cost::CountPlan`,
// `technique::cluster::count_plan`), never drawn as a technique; the same decode
// (cluster_decode.glsl) with every loop unrolled, so that the SPIR-V counts are what one
// pixel runs (with SHVIS_COUNT_LOOPS the drawn shader's loops kept, so that the counts give
// the loops one pixel enters). SHVIS_COUNT_PATH (ids from src/technique/cluster.rs):
// SHVIS_COUNT_INSIDE keeps the decode inside a cluster, SHVIS_COUNT_ACROSS the decode across
// a boundary, SHVIS_COUNT_BEFORE_BRANCH neither (the work before the branch, kept alive by a
// sum of it), SHVIS_COUNT_ACROSS_LOOP_CUT the decode across a boundary with its loop cut
// (what a batch none of whose lanes takes the boundary path runs of it, on a device that
// runs untaken branches masked and skips loops no lane enters); SHVIS_COUNT_MEASURE
// measures, drawn once additively: red 1 where the fragment's subgroup takes the boundary
// path (SHVIS_SUBGROUP_VOTE: subgroupAny; else the fragment's own), green 1 per fragment.
#version 450
#extension GL_GOOGLE_include_directive : require
#ifndef SHVIS_COUNT_PATH
#error "a count build names its path (SHVIS_COUNT_PATH)"
#endif
#ifndef SHVIS_COUNT_MEASURE
#error "the count path ids are not defined (technique::block::path_defines gives them)"
#endif
#ifndef SHVIS_SUBGROUP_VOTE
#define SHVIS_SUBGROUP_VOTE 0
#endif
#if SHVIS_COUNT_PATH == SHVIS_COUNT_MEASURE && SHVIS_SUBGROUP_VOTE
#extension GL_KHR_shader_subgroup_vote : require
#endif
#extension GL_EXT_control_flow_attributes : require
#ifndef SHVIS_COUNT_LOOPS
#define SHVIS_COUNT_LOOPS 0
#endif
#define UNROLL [[unroll]]
#if SHVIS_COUNT_LOOPS
#define KEEP_LOOP [[dont_unroll]]
#else
#define KEEP_LOOP [[unroll]]
#endif
#define CLUSTER_MEAN_ONLY (SHVIS_COUNT_PATH == SHVIS_COUNT_ACROSS_LOOP_CUT)
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"
#include "cluster_decode.glsl"

void main() {
    float y[9];
    sh_eval_order3(shading_normal(), y);
    vec3 e;
#if SHVIS_SEAM_BLEND
    vec4 v[4][GROUPS];
    float w[4];
    int c[4];
    cluster_taps(v, w, c);
#if SHVIS_COUNT_PATH == SHVIS_COUNT_MEASURE
    bool across = !(c[0] == c[1] && c[0] == c[2] && c[0] == c[3]);
#if SHVIS_SUBGROUP_VOTE
    across = subgroupAny(across);
#endif
    out_radiance = vec4(across ? 1.0 : 0.0, 1.0, 0.0, 1.0);
    return;
#elif SHVIS_COUNT_PATH == SHVIS_COUNT_BEFORE_BRANCH
    float before = float(c[0] + c[1] + c[2] + c[3]) + w[0] + w[1] + w[2] + w[3];
    UNROLL for (int i = 0; i < 9; ++i) {
        before += y[i];
    }
    e = vec3(before);
#elif SHVIS_COUNT_PATH == SHVIS_COUNT_INSIDE
    e = cluster_decode_inside(v, w, c, y);
#else
    // SHVIS_COUNT_ACROSS, and SHVIS_COUNT_ACROSS_LOOP_CUT through CLUSTER_MEAN_ONLY.
    e = cluster_decode_across(v, w, c, y);
#endif
#else
    e = cluster_decode_naive(y);
#endif
    write_diffuse(max(e, vec3(0.0)));
}
