// Test harness (tests/engine_sh.rs): glsl/include/dice.glsl's reconstruction for a list of
// stored-value sets and tangent-space directions, to compare with src/sh/dice.rs.
#version 450
#extension GL_GOOGLE_include_directive : require

layout(local_size_x = 64) in;

layout(push_constant) uniform Push {
    uint count;
    // vec4s of the face table at the start of the cases buffer.
    uint table;
    // vec4s per case: the stored groups, then the direction.
    uint stride;
} pc;

layout(std430, set = 0, binding = 0) readonly buffer Cases { vec4 cases[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Irradiance { vec4 irradiance[]; };

uint case_base;
#define DICE_FACE(k) cases[k]
#define DICE_READ(g) cases[case_base + uint(g)]
#include "dice.glsl"

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    case_base = pc.table + i * pc.stride;
    vec3 m = cases[case_base + pc.stride - 1u].xyz;
    irradiance[i] = vec4(dice_irradiance(m), 0.0);
}
