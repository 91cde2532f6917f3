// The mesh pass's vertex shader, shared by every technique: world-space attributes to the
// fragment stage (glsl/include/common.glsl), clip position from FrameParams. With
// SHVIS_VERTEX_WEIGHT_GROUPS > 0 (pcaMv, src/technique/vertex.rs) it also passes that many
// RGBA8 groups of per-vertex PCA weights on, for the rasterizer to interpolate.
#version 450
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec4 tangent;
layout(location = 3) in vec2 uv_material;
layout(location = 4) in vec2 uv_lightmap;
layout(location = 5) in vec3 albedo_tint;

layout(location = 0) out vec3 out_normal_world;
layout(location = 1) out vec4 out_tangent_world;
layout(location = 2) out vec2 out_uv_material;
layout(location = 3) out vec2 out_uv_lightmap;
layout(location = 4) out vec3 out_albedo_tint;
#if defined(SHVIS_GBUFFER) && SHVIS_GBUFFER
layout(location = 5) out vec3 out_position_world; // only the reference's G-buffer reads it
#endif
#if defined(SHVIS_VERTEX_WEIGHT_GROUPS) && SHVIS_VERTEX_WEIGHT_GROUPS > 0
layout(location = 6) in vec4 vertex_weights[SHVIS_VERTEX_WEIGHT_GROUPS];
layout(location = 6) out vec4 out_vertex_weights[SHVIS_VERTEX_WEIGHT_GROUPS];
#endif

void main() {
    out_normal_world = normal;
    out_tangent_world = tangent;
    out_uv_material = uv_material;
    out_uv_lightmap = uv_lightmap;
    out_albedo_tint = albedo_tint;
#if defined(SHVIS_GBUFFER) && SHVIS_GBUFFER
    out_position_world = position;
#endif
#if defined(SHVIS_VERTEX_WEIGHT_GROUPS) && SHVIS_VERTEX_WEIGHT_GROUPS > 0
    for (int g = 0; g < SHVIS_VERTEX_WEIGHT_GROUPS; ++g) {
        out_vertex_weights[g] = vertex_weights[g];
    }
#endif
    gl_Position = frame.clip_from_world * vec4(position, 1.0);
}
