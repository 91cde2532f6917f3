// The normal map's level of detail at each pixel (textureQueryLod's unclamped λ; ≤ 0:
// magnified, k: 2^k texels per pixel), for the minified / magnified masks of
// `shvis study ndf` (src/render/specular.rs, normal_map_lod).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(location = 0) out vec4 out_lod;

void main() {
    out_lod = vec4(textureQueryLod(normal_tex, in_uv_material).y, 0.0, 0.0, 1.0);
}
