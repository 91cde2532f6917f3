// l1, l1geo, l1zh3, zh3, l1lum: the SH lightmaps engines ship (src/technique/sh_variant.rs).
// Per texel SHVIS_ENGINE_SH_GROUPS RGBA groups of stored values (ShBasis::encode's layout),
// reconstructed at the shading normal by glsl/include/sh_bases.glsl;
// radiance = albedo/π · max(0, E(n)).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh_bases.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ShLightmapParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_ENGINE_SH_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

void main() {
    float v[16];
    UNROLL for (int i = 0; i < 16; ++i) {
        v[i] = 0.0;
    }
    // dx9 indexes its sampler array by constants only: one read per group, unrolled.
    vec4 g0 = SAMPLE_PER_TEXEL(0);
    v[0] = g0.x; v[1] = g0.y; v[2] = g0.z; v[3] = g0.w;
    vec4 g1 = SAMPLE_PER_TEXEL(1);
    v[4] = g1.x; v[5] = g1.y; v[6] = g1.z; v[7] = g1.w;
#if SHVIS_ENGINE_SH_GROUPS > 2
    vec4 g2 = SAMPLE_PER_TEXEL(2);
    v[8] = g2.x; v[9] = g2.y; v[10] = g2.z; v[11] = g2.w;
#endif
#if SHVIS_ENGINE_SH_GROUPS > 3
    vec4 g3 = SAMPLE_PER_TEXEL(3);
    v[12] = g3.x; v[13] = g3.y; v[14] = g3.z; v[15] = g3.w;
#endif
    vec3 irradiance = engine_sh_irradiance(v, shading_normal()) * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
