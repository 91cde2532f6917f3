// Test harness (tests/engine_sh.rs): glsl/include/sg.glsl's SG–cosine integral for a list of
// (μ·n, λ) pairs, to compare with src/sh/sg.rs.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "sg.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint count;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Cases { vec2 cases[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Values { float values[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    values[i] = sg_cosine_integral(cases[i].x, cases[i].y);
}
