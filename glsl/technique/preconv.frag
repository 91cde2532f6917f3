// preconv: scalar ambient occlusion × pre-convolved order-3 irradiance at the per-pixel
// normal (Iwanicki–Sloan §5, "Preconv"; DESIGN §2; src/technique/preconv.rs).
// radiance = albedo/π · AO · E(n), E from SH irradiance coefficients (already multiplied
// by the clamped-cosine factors A_l) in uniforms.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform PreconvParams {
    layout(offset = 0) vec4 irradiance_sh[9]; // order-3 RGB in .rgb
} params;

#if SHVIS_PATH_DX9
// dx9: per-texel data in plain 2D textures.
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D ao_tex;
float sample_ao(vec2 uv) { return texture(ao_tex, uv).r; }
#else
// dx10: per-texel data in a texture array (one layer for scalar AO).
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray ao_tex;
float sample_ao(vec2 uv) { return texture(ao_tex, vec3(uv, 0.0)).r; }
#endif

layout(location = 0) out vec4 out_radiance;

void main() {
    vec3 n = shading_normal();
    vec3 irradiance = max(sh_eval_rgb_order3(params.irradiance_sh, n), vec3(0.0));
    float ao = sample_ao(in_uv_lightmap);
    out_radiance = vec4(material_albedo() / PI * ao * irradiance, 1.0);
}
