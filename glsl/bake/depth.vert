#version 450
// The scene seen from the sky along one direction (orthographic): depth = sky distance
// over the box's sky range, so the depth test keeps the surface nearest the sky.
#include "sim_view.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 0) out float out_sky;
// The triangle + 1: the simulator draws its triangles unindexed (vertex 3t + k is corner
// k of triangle t), so every corner carries the same value.
layout(location = 1) flat out uint out_triangle;

void main() {
    vec3 view = sim_view(in_position);
    gl_Position = vec4(view.xy, view.z / push.window.z, 1.0);
    out_sky = view.z;
    out_triangle = uint(gl_VertexIndex) / 3u + 1u;
}
