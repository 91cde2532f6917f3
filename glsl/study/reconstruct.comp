// Appendix A on real texture hardware (src/study/params_gpu.rs): reconstruct every stored
// SH basis function at a list of directions by sampling the texture as a shader would.
// SHVIS_STUDY_PARAM (ids SHVIS_PARAM_*, from src/study/params_gpu.rs): DUAL_ORTHO,
// DUAL_PARABOLOID (2D array, layer 2·basis + hemisphere), CUBE_DX9 (2D array, layer
// 6·basis + face: per-face clamp-to-edge filtering, as a non-seamless cube), CUBE_DX10 (a
// real cube-map array: seamless filtering).
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sphere.glsl"

#ifndef SHVIS_PARAM_CUBE_DX10
#error "the parameterization ids are not defined (study::params_gpu::param_ids)"
#endif

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint direction_count;
    uint basis_count;
    float res;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Directions { vec4 directions[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Values { float values[]; };
#if SHVIS_STUDY_PARAM == SHVIS_PARAM_CUBE_DX10
layout(set = 0, binding = 2) uniform samplerCubeArray table;
#else
layout(set = 0, binding = 2) uniform sampler2DArray table;
#endif

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.direction_count) {
        return;
    }
    vec3 d = directions[i].xyz;
#if SHVIS_STUDY_PARAM == SHVIS_PARAM_DUAL_ORTHO
    vec3 uvl = dual_ortho_dir_to_uv(d, pc.res);
    float per_basis = 2.0;
#elif SHVIS_STUDY_PARAM == SHVIS_PARAM_DUAL_PARABOLOID
    vec3 uvl = dual_paraboloid_dir_to_uv(d, pc.res);
    float per_basis = 2.0;
#elif SHVIS_STUDY_PARAM == SHVIS_PARAM_CUBE_DX9
    vec3 uvl = cube_dir_to_face_st(d);
    float per_basis = 6.0;
#endif
    for (uint b = 0; b < pc.basis_count; ++b) {
#if SHVIS_STUDY_PARAM == SHVIS_PARAM_CUBE_DX10
        float v = texture(table, vec4(d, float(b))).r;
#else
        float v = texture(table, vec3(uvl.xy, per_basis * float(b) + uvl.z)).r;
#endif
        values[i * pc.basis_count + b] = v;
    }
}
