// Test harness (tests/engine_sh.rs): glsl/include/hbasis.glsl's reconstruction for a list
// of coefficient sets and tangent-space directions, to compare with src/sh/hbasis.rs.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "hbasis.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint count;
    uint coefficients;
} pc;

// Case i: 20 values (18 used: 6 RGB coefficients, value 3k + c) in vec4s 0..4, the
// direction in vec4 5.
layout(std430, set = 0, binding = 0) readonly buffer Cases { vec4 cases[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Irradiance { vec4 irradiance[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint base = i * 6u;
    float v[20];
    for (int g = 0; g < 5; ++g) {
        vec4 c = cases[base + uint(g)];
        v[4 * g] = c.x; v[4 * g + 1] = c.y; v[4 * g + 2] = c.z; v[4 * g + 3] = c.w;
    }
    irradiance[i] = vec4(hbasis_irradiance(v, int(pc.coefficients), cases[base + 5u].xyz), 0.0);
}
