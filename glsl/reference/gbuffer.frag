// G-buffer passes of the reference renderer (src/reference.rs): the same rasterization,
// normal mapping and texture sampling as the techniques, one quantity per pass into an
// RGBA32F target. SHVIS_GBUFFER_OUTPUT: 0 world position, 1 shading normal (normal-mapped),
// 2 linear albedo, 3 interpolated vertex normal (the tangent plane of "V = 0 below"),
// 4 lightmap UV (the error ladder's texel lookups, src/attribution), 5 the normal map's
// tangent-space normal, 6 and 7 the tangent and bitangent of its world frame (the H-basis
// rungs of the ladder).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(location = 0) out vec4 out_value;

void main() {
#if SHVIS_GBUFFER_OUTPUT == 0
    out_value = vec4(in_position_world, 1.0);
#elif SHVIS_GBUFFER_OUTPUT == 1
    out_value = vec4(shading_normal(), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == 2
    out_value = vec4(material_albedo(), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == 3
    out_value = vec4(normalize(in_normal_world), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == 4
    out_value = vec4(in_uv_lightmap, 0.0, 1.0);
#elif SHVIS_GBUFFER_OUTPUT == 5
    out_value = vec4(tangent_space_normal(), 1.0);
#else
    mat3 f;
    tangent_frame(f);
    out_value = vec4(SHVIS_GBUFFER_OUTPUT == 6 ? f[0] : f[1], 1.0);
#endif
}
