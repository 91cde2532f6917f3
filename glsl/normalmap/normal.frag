#version 450
// Writes the high mesh's object-space normal into T's own texels only (the mask plays
// the paper's stencil, §3.3); w = 1 marks a generated texel.
#include "normalmap_project.glsl"

layout(location = 0) in vec3 in_normal;
layout(location = 1) flat in uint in_triangle;

layout(location = 0) out vec4 out_normal;

void main() {
    uint texel = uint(gl_FragCoord.y) * push.res + uint(gl_FragCoord.x);
    if (owner[texel].x != float(in_triangle + 1u)) {
        discard;
    }
    float len = length(in_normal);
    if (len < 1e-12) {
        discard;
    }
    out_normal = vec4(in_normal / len, 1.0);
}
