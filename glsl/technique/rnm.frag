// rnm / rnmao / ssbump: radiosity normal mapping and self-shadowed bump maps (Green,
// Valve; src/technique/rnm.rs). Three lightmaps of irradiance around the HL2
// basis directions (per-texel groups 0–2, .rgb), blended per pixel by SHVIS_RNM_VARIANT
// (ids from src/technique/rnm.rs):
//   SHVIS_RNM_NORMAL_MAP (rnm):      Listing 1, saturate(N·B_i)² normalized, N from the normal map;
//   SHVIS_RNM_NORMAL_MAP_AO (rnmao): Listing 1 × the height field's AO (ssbump_ao_tex.a);
//   SHVIS_RNM_SELF_SHADOWED (ssbump): Listing 2, the SSBump texel (ssbump_ao_tex.rgb) as weights.
// radiance = albedo/π · Σ w_i E_i.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform RnmParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS 3
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#ifndef SHVIS_RNM_NORMAL_MAP
#error "the rnm variant ids are not defined (technique::block::path_defines gives them)"
#endif

#if SHVIS_RNM_VARIANT != SHVIS_RNM_NORMAL_MAP
// Material space, sampled like the normal map: RGB = SSBump, A = AO.
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D ssbump_ao_tex;
#endif

// The HL2 basis (src/bake/ssbump.rs: orthonormal, 54.7° from +Z, 120° apart).
const vec3 BUMP_BASIS[3] = vec3[3](
    vec3(0.81649658, 0.0, 0.57735027),
    vec3(-0.40824829, 0.70710678, 0.57735027),
    vec3(-0.40824829, -0.70710678, 0.57735027));

void main() {
    vec3 lightmap0 = SAMPLE_PER_TEXEL(0).rgb;
    vec3 lightmap1 = SAMPLE_PER_TEXEL(1).rgb;
    vec3 lightmap2 = SAMPLE_PER_TEXEL(2).rgb;
#if SHVIS_RNM_VARIANT == SHVIS_RNM_SELF_SHADOWED
    vec3 w = SAMPLE_MATERIAL(ssbump_ao_tex, in_uv_material).rgb;
#else
    vec3 n = tangent_space_normal();
    vec3 dp = clamp(vec3(dot(n, BUMP_BASIS[0]), dot(n, BUMP_BASIS[1]), dot(n, BUMP_BASIS[2])), 0.0, 1.0);
    dp *= dp;
    float sum = dot(dp, vec3(1.0));
    vec3 w = sum > 0.0 ? dp / sum : vec3(1.0 / 3.0);
#if SHVIS_RNM_VARIANT == SHVIS_RNM_NORMAL_MAP_AO
    w *= SAMPLE_MATERIAL(ssbump_ao_tex, in_uv_material).a;
#endif
#endif
    vec3 irradiance = (w.x * lightmap0 + w.y * lightmap1 + w.z * lightmap2) * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
