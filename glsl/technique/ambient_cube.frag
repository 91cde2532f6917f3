// acube, acubels: Valve's ambient cube lightmaps (src/technique/ambient_cube.rs, whose module
// doc has the math). Per texel the RGB values of the six faces (+x, −x, +y, −y, +z, −z of
// the tangent frame; value 3 face + c, 18 in SHVIS_AMBIENT_CUBE_GROUPS = 5 RGBA groups, the
// last two values unused), evaluated at the normal map's tangent-space normal m:
// E(m) = m.x² C[±x] + m.y² C[±y] + m.z² C[±z], each axis' face chosen by its sign;
// radiance = albedo/π · max(0, E).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform ShLightmapParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_AMBIENT_CUBE_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

// Branch-free: each axis selects its face by its sign (+ at 0, where its weight is 0).
vec3 ambient_cube_irradiance(float v[20], vec3 m) {
    vec3 w = m * m;
    bvec3 positive = greaterThanEqual(m, vec3(0.0));
    vec3 cx = mix(vec3(v[3], v[4], v[5]), vec3(v[0], v[1], v[2]), bvec3(positive.x));
    vec3 cy = mix(vec3(v[9], v[10], v[11]), vec3(v[6], v[7], v[8]), bvec3(positive.y));
    vec3 cz = mix(vec3(v[15], v[16], v[17]), vec3(v[12], v[13], v[14]), bvec3(positive.z));
    return w.x * cx + w.y * cy + w.z * cz;
}

void main() {
    float v[20];
    // dx9 indexes its sampler array by constants only: one read per group, unrolled.
    vec4 g0 = SAMPLE_PER_TEXEL(0);
    v[0] = g0.x; v[1] = g0.y; v[2] = g0.z; v[3] = g0.w;
    vec4 g1 = SAMPLE_PER_TEXEL(1);
    v[4] = g1.x; v[5] = g1.y; v[6] = g1.z; v[7] = g1.w;
    vec4 g2 = SAMPLE_PER_TEXEL(2);
    v[8] = g2.x; v[9] = g2.y; v[10] = g2.z; v[11] = g2.w;
    vec4 g3 = SAMPLE_PER_TEXEL(3);
    v[12] = g3.x; v[13] = g3.y; v[14] = g3.z; v[15] = g3.w;
    vec4 g4 = SAMPLE_PER_TEXEL(4);
    v[16] = g4.x; v[17] = g4.y; v[18] = g4.z; v[19] = g4.w;
    vec3 irradiance = ambient_cube_irradiance(v, tangent_space_normal()) * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
