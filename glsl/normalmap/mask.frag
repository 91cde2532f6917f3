#version 450
// Writes owner + 1 (0 stays "no triangle"); ids below 2^24 are exact in f32.

layout(location = 0) flat in uint in_triangle;
layout(location = 0) out vec4 out_owner;

void main() {
    out_owner = vec4(float(in_triangle + 1u), 0.0, 0.0, 1.0);
}
