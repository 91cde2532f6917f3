// Counts shaded fragments (src/render/mod.rs, SceneGpu::shading_load): with additive blending
// every fragment that passes the depth test adds 1 to its pixel's red — and to its green
// its share of the subgroup it ran in (SHVIS_SUBGROUP_BALLOT: the subgroup's size over the
// fragments in it, helper lanes excluded; else 1), so that green sums to the lanes the draw
// kept busy: subgroups × size, idle lanes of partly covered ones included.
#version 450
#ifndef SHVIS_SUBGROUP_BALLOT
#define SHVIS_SUBGROUP_BALLOT 0
#endif
#if SHVIS_SUBGROUP_BALLOT
#extension GL_KHR_shader_subgroup_ballot : require
#endif
layout(location = 0) out vec4 out_count;

void main() {
    float lanes = 1.0;
#if SHVIS_SUBGROUP_BALLOT
    uint fragments = subgroupBallotBitCount(subgroupBallot(!gl_HelperInvocation));
    lanes = float(gl_SubgroupSize) / float(max(fragments, 1u));
#endif
    out_count = vec4(1.0, lanes, 0.0, 1.0);
}
