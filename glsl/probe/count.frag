// Counts shaded fragments (src/render.rs, SceneGpu::shaded_fragments): with additive
// blending every fragment that passes the depth test adds 1 to its pixel.
#version 450
layout(location = 0) out vec4 out_count;

void main() {
    out_count = vec4(1.0);
}
