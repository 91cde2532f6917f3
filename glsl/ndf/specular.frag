// The specular term alone (glsl/include/specular.glsl), for `study ndf`: its three
// filterings against their footprint reference (src/render/specular.rs).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "specular.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    out_color = vec4(specular_radiance(), 1.0);
}
