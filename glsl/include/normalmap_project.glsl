// Shared by normalmap/project.vert and normalmap/normal.frag: the per-low-triangle views (src/normalmap/
// projection.rs) and the push constants of the projection pass.
#ifndef SHVIS_NORMALMAP_PROJECT_GLSL
#define SHVIS_NORMALMAP_PROJECT_GLSL

struct TriangleView {
    mat4 view_from_world;
    mat4 clip_from_view;
};

layout(std430, set = 0, binding = 0) readonly buffer Views {
    TriangleView views[];
};

// Owner + 1 of each texel, in .x (mask.frag), row-major.
layout(std430, set = 0, binding = 1) readonly buffer Mask {
    vec4 owner[];
};

layout(push_constant) uniform Push {
    float max_distance;
    uint mirror;
    uint res;
} push;

#endif
