#version 450
// One direction of the GPU visibility simulator (PRT course, "GPU simulator"): a point
// above its horizon (n·d > 0) sees the sky along d when no triangle of the 3 × 3 map
// texels around it lies on its ray and either one of them crosses the ray's line at or
// below the point or nothing in the depth map lies nearer the sky than it by more than the
// bias; then bit `direction` of its mask is set.
//
// Why the exact test: a point within a map texel of an occluder's silhouette (a floor
// texel at the foot of a wall) reads the texel beside the occluder — a leak — or reads the
// occluder where it does not cover the point — a false shadow. The triangles the map holds
// around it, tested against the line through the point along d (Möller–Trumbore, both
// faces, t ≥ t_min from the same origin as the CPU tracer's), settle both: the nearest
// surface above the point is on its ray, and if it is one of them it is found. The depth
// test decides only where none of them crosses the line (triangles smaller than a texel).
#include "sim_view.glsl"

layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer DepthMap {
    // Per map texel: sky distance of the nearest surface, its triangle + 1 (0: none).
    vec2 sky_depth[];
};
// Per point: ray origin (xyz) then unit geometric normal (xyz).
layout(std430, set = 0, binding = 1) readonly buffer Points {
    vec4 points[];
};
layout(std430, set = 0, binding = 2) buffer Masks {
    uint masks[];
};
// Triangle t's corners at 3t, 3t + 1, 3t + 2.
layout(std430, set = 0, binding = 3) readonly buffer Triangles {
    vec4 corners[];
};

// Past ~84° the slope term stops growing: a grazing ray is biased by 10 texel slopes.
const float MAX_TAN = 10.0;

const float MISSES = -3.0e38;

// Where the line origin + s·d crosses triangle t (s, either sign), or MISSES.
float crossing(uint t, vec3 origin, vec3 d) {
    vec3 a = corners[3u * t].xyz;
    vec3 e1 = corners[3u * t + 1u].xyz - a;
    vec3 e2 = corners[3u * t + 2u].xyz - a;
    vec3 p = cross(d, e2);
    float det = dot(e1, p);
    if (det == 0.0) {
        return MISSES;
    }
    float inv = 1.0 / det;
    vec3 s = origin - a;
    float u = dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) {
        return MISSES;
    }
    vec3 q = cross(s, e1);
    float v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return MISSES;
    }
    return dot(e2, q) * inv;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.point_count) {
        return;
    }
    vec3 origin = points[2 * i].xyz;
    vec3 normal = points[2 * i + 1].xyz;
    vec3 d = push.axis_d.xyz;
    float c = dot(normal, d);
    if (c <= 0.0) {
        return;
    }
    vec3 view = sim_view(origin);
    int last = int(push.res) - 1;
    ivec2 texel = clamp(ivec2(floor((view.xy * 0.5 + 0.5) * float(push.res))), ivec2(0), ivec2(last));
    // The exact test: a triangle of the 3 × 3 texels on the ray occludes (as on the CPU);
    // one the line crosses at or below the origin (its own surface) is the nearest to
    // the sky there unless a triangle too small to be any texel's nearest lies above.
    // The line meets the origin's own surface about ε/cos θ below it; a texel further.
    float texel_side = 2.0 * max(push.window.x, push.window.y) / float(push.res);
    float own_surface = -(2.0 * push.epsilon / c + texel_side);
    bool below_seen = false;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 n = clamp(texel + ivec2(dx, dy), ivec2(0), ivec2(last));
            uint t = uint(sky_depth[uint(n.y) * push.res + uint(n.x)].y);
            if (t == 0u) {
                continue;
            }
            float s = crossing(t - 1u, origin, d);
            if (s >= push.t_min) {
                return;
            }
            below_seen = below_seen || s >= own_surface;
        }
    }
    // No triangle around decides: the depth test (the map's nearest surface is no nearer
    // the sky than the origin by more than the bias).
    float blocker = sky_depth[uint(texel.y) * push.res + uint(texel.x)].x;
    float tan_angle = min(sqrt(max(1.0 - c * c, 0.0)) / c, MAX_TAN);
    float bias = push.centre.w + push.window.w * tan_angle;
    if (below_seen || view.z <= blocker + bias) {
        uint w = i * push.mask_words + push.direction / 32u;
        masks[w] |= 1u << (push.direction % 32u);
    }
}
