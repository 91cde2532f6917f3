// hb4, hb6: H-basis lightmaps (src/technique/hemisphere.rs). Per texel SHVIS_HBASIS_GROUPS RGBA
// groups of SHVIS_HBASIS_COUNT RGB coefficients (value 3i + c), evaluated at the normal
// map's tangent-space normal by glsl/include/hbasis.glsl; radiance = albedo/π · max(0, E).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "hbasis.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ShLightmapParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_HBASIS_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

void main() {
    float v[20];
    UNROLL for (int i = 0; i < 20; ++i) {
        v[i] = 0.0;
    }
    // dx9 indexes its sampler array by constants only: one read per group, unrolled.
    vec4 g0 = SAMPLE_PER_TEXEL(0);
    v[0] = g0.x; v[1] = g0.y; v[2] = g0.z; v[3] = g0.w;
    vec4 g1 = SAMPLE_PER_TEXEL(1);
    v[4] = g1.x; v[5] = g1.y; v[6] = g1.z; v[7] = g1.w;
    vec4 g2 = SAMPLE_PER_TEXEL(2);
    v[8] = g2.x; v[9] = g2.y; v[10] = g2.z; v[11] = g2.w;
#if SHVIS_HBASIS_GROUPS > 3
    vec4 g3 = SAMPLE_PER_TEXEL(3);
    v[12] = g3.x; v[13] = g3.y; v[14] = g3.z; v[15] = g3.w;
    vec4 g4 = SAMPLE_PER_TEXEL(4);
    v[16] = g4.x; v[17] = g4.y; v[18] = g4.z; v[19] = g4.w;
#endif
    vec3 irradiance = hbasis_irradiance(v, SHVIS_HBASIS_COUNT, tangent_space_normal())
        * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
