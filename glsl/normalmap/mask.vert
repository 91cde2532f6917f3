#version 450
// Coverage mask of the low mesh in texture space (Gumbau et al. §3.3, the stencil):
// each texel records which low triangle owns it. The depth test (LESS, depth growing
// with the triangle index) lets the first triangle in index order keep a texel two
// triangles overlap, as the CPU raster does.

layout(location = 0) in vec2 in_uv;
layout(location = 1) in uint in_triangle;

layout(push_constant) uniform Push {
    uint triangle_count;
} push;

layout(location = 0) flat out uint out_triangle;

void main() {
    out_triangle = in_triangle;
    float depth = (float(in_triangle) + 0.5) / float(push.triangle_count);
    gl_Position = vec4(in_uv * 2.0 - 1.0, depth, 1.0);
}
