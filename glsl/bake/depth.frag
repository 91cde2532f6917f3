#version 450
// The nearest surface's sky distance, metres, in full f32 (R32_SFLOAT target).
layout(location = 0) in float in_sky;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = vec4(in_sky, 0.0, 0.0, 0.0);
}
