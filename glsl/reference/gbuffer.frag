// G-buffer passes of the reference renderer (src/reference/mod.rs): the same rasterization,
// normal mapping and texture sampling as the techniques, one quantity per pass into an
// RGBA32F target. SHVIS_GBUFFER_OUTPUT (ids SHVIS_GBUFFER_*, from src/reference/mod.rs):
// POSITION world position, NORMAL shading normal (normal-mapped), ALBEDO linear albedo,
// VERTEX_NORMAL interpolated vertex normal (the tangent plane of "V = 0 below"),
// UV_LIGHTMAP lightmap UV (the error ladder's texel lookups, src/attribution),
// TANGENT_NORMAL the normal map's tangent-space normal, TANGENT and BITANGENT those of its
// world frame (the H-basis rungs of the ladder).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

#ifndef SHVIS_GBUFFER_POSITION
#error "the G-buffer output ids are not defined (reference::gbuffer_output_ids)"
#endif

layout(location = 0) out vec4 out_value;

void main() {
#if SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_POSITION
    out_value = vec4(in_position_world, 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_NORMAL
    out_value = vec4(shading_normal(), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_ALBEDO
    out_value = vec4(material_albedo(), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_VERTEX_NORMAL
    out_value = vec4(normalize(in_normal_world), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_UV_LIGHTMAP
    out_value = vec4(in_uv_lightmap, 0.0, 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_TANGENT_NORMAL
    out_value = vec4(tangent_space_normal(), 1.0);
#elif SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_TANGENT || SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_BITANGENT
    mat3 f;
    tangent_frame(f);
    out_value = vec4(SHVIS_GBUFFER_OUTPUT == SHVIS_GBUFFER_TANGENT ? f[0] : f[1], 1.0);
#else
#error "unknown SHVIS_GBUFFER_OUTPUT"
#endif
}
