#version 450
// The nearest surface's sky distance, metres, in full f32, and its triangle + 1 as an
// exact float (R32G32_SFLOAT target; 0 = no surface; below 2^24 triangles).
layout(location = 0) in float in_sky;
layout(location = 1) flat in uint in_triangle;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = vec4(in_sky, float(in_triangle), 0.0, 0.0);
}
