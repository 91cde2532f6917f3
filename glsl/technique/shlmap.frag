// shlmap: the SH lightmap baseline (Iwanicki–Sloan §5, "SHLmap"; DESIGN §2;
// src/technique/shlmap.rs). Per texel, order-3 RGB SH of incident radiance with
// inter-reflection (27 values, value 3k + c, 4 per RGBA texel in SHLMAP_GROUPS groups);
// radiance = albedo/π · convolve-with-clamped-cosine-and-evaluate at the shading normal.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ShLightmapParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_SHLMAP_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_SHLMAP_GROUPS != 7
#error "the unpacking below is written for 27 values in 7 groups"
#endif

void main() {
    vec4 g0 = SAMPLE_PER_TEXEL(0), g1 = SAMPLE_PER_TEXEL(1), g2 = SAMPLE_PER_TEXEL(2),
         g3 = SAMPLE_PER_TEXEL(3), g4 = SAMPLE_PER_TEXEL(4), g5 = SAMPLE_PER_TEXEL(5),
         g6 = SAMPLE_PER_TEXEL(6);
    vec3 radiance[9] = vec3[9](
        g0.xyz, vec3(g0.w, g1.xy), vec3(g1.zw, g2.x), g2.yzw,
        g3.xyz, vec3(g3.w, g4.xy), vec3(g4.zw, g5.x), g5.yzw,
        g6.xyz);
    vec3 irradiance = sh_irradiance_order3(radiance, shading_normal()) * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
