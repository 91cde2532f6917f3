// sh2: order-2 visibility per texel, order-3 lighting in uniforms, the SH product,
// clamped-cosine convolution and evaluation all in the shader (Iwanicki–Sloan §5, "SH2";
// DESIGN §2; src/technique/sh2.rs). No tables, no dependent lookups.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"
#include "sh_product.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform Sh2Params {
    layout(offset = 0) vec4 lighting_sh[9]; // order-3 radiance, RGB in .rgb
} params;

#define SHVIS_PER_TEXEL_GROUPS 1
#include "per_texel.glsl"
#include "diffuse_out.glsl"

void main() {
    vec3 incident[9];
    sh_product_l3_v2(params.lighting_sh, SAMPLE_PER_TEXEL(0), incident);
    vec3 irradiance = max(sh_irradiance_order3(incident, shading_normal()), vec3(0.0));
    write_diffuse(irradiance);
}
