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

#define SHVIS_PER_TEXEL_GROUPS 1
#include "per_texel.glsl"
#include "diffuse_out.glsl"

void main() {
    vec3 n = shading_normal();
    vec3 irradiance = max(sh_eval_rgb_order3(params.irradiance_sh, n), vec3(0.0));
    float ao = SAMPLE_PER_TEXEL(0).r;
    write_diffuse(ao * irradiance);
}
