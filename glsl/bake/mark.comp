#version 450
// One direction of the GPU visibility simulator (PRT course, "GPU simulator"): a point
// above its horizon (n·d > 0) sees the sky along d when nothing in the depth map lies
// nearer the sky than it by more than the bias; then bit `direction` of its mask is set.
#include "sim_view.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer DepthMap {
    float sky_depth[];
};
// Per point: ray origin (xyz) then unit geometric normal (xyz).
layout(std430, set = 0, binding = 1) readonly buffer Points {
    vec4 points[];
};
layout(std430, set = 0, binding = 2) buffer Masks {
    uint masks[];
};

// Past ~84° the slope term stops growing: a grazing ray is biased by 10 texel slopes.
const float MAX_TAN = 10.0;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.point_count) {
        return;
    }
    vec3 origin = points[2 * i].xyz;
    vec3 normal = points[2 * i + 1].xyz;
    float c = dot(normal, push.axis_d.xyz);
    if (c <= 0.0) {
        return;
    }
    vec3 view = sim_view(origin);
    ivec2 texel = ivec2(floor((view.xy * 0.5 + 0.5) * float(push.res)));
    texel = clamp(texel, ivec2(0), ivec2(int(push.res) - 1));
    float blocker = sky_depth[uint(texel.y) * push.res + uint(texel.x)];
    float tan_angle = min(sqrt(max(1.0 - c * c, 0.0)) / c, MAX_TAN);
    float bias = push.centre.w + push.window.w * tan_angle;
    if (view.z <= blocker + bias) {
        uint w = i * push.mask_words + push.direction / 32u;
        masks[w] |= 1u << (push.direction % 32u);
    }
}
