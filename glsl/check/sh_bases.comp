// Test harness (tests/engine_sh.rs): glsl/include/sh_bases.glsl's reconstruction of
// SHVIS_ENGINE_SH_BASIS for a list of stored-value sets and normals, so the shader's
// arithmetic can be compared with src/sh/bases.rs.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sh_bases.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint count;
} pc;

// Case i: 16 stored values (7 vec4s for L2's 27, the rest zero-padded) and a normal.
layout(std430, set = 0, binding = 0) readonly buffer Cases { vec4 cases[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Irradiance { vec4 irradiance[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint base = i * 8u;
#if SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L2
    // L2: 27 values in vec4s 0..6, normal in vec4 7.
    vec3 radiance[9];
    float flat_v[28];
    for (int g = 0; g < 7; ++g) {
        vec4 c = cases[base + uint(g)];
        flat_v[4 * g] = c.x; flat_v[4 * g + 1] = c.y; flat_v[4 * g + 2] = c.z; flat_v[4 * g + 3] = c.w;
    }
    for (int k = 0; k < 9; ++k) {
        radiance[k] = vec3(flat_v[3 * k], flat_v[3 * k + 1], flat_v[3 * k + 2]);
    }
    irradiance[i] = vec4(sh_irradiance_order3(radiance, cases[base + 7u].xyz), 0.0);
#else
    float v[16];
    for (int g = 0; g < 4; ++g) {
        vec4 c = cases[base + uint(g)];
        v[4 * g] = c.x; v[4 * g + 1] = c.y; v[4 * g + 2] = c.z; v[4 * g + 3] = c.w;
    }
    irradiance[i] = vec4(engine_sh_irradiance(v, cases[base + 7u].xyz), 0.0);
#endif
}
