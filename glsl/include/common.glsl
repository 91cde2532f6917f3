// Shared by every mesh-pass shader: the per-frame block, the interface between
// mesh.vert and the technique fragment shaders, material sampling and normal mapping.
// Mirrors src/gpu/layout.rs (FrameParams) and src/scene/mod.rs (Vertex).
#ifndef SHVIS_COMMON_GLSL
#define SHVIS_COMMON_GLSL

#include "math.glsl"
#include "unroll.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_FRAME) uniform FrameParams {
    layout(offset = 0) mat4 clip_from_world;
    layout(offset = 64) vec4 camera_position;
    layout(offset = 80) float normal_scale; // glTF normalTexture.scale; 0 = flat normals
} frame;

#ifdef SHVIS_FRAGMENT
layout(set = 0, binding = SHVIS_BINDING_ALBEDO) uniform sampler2D albedo_tex;
layout(set = 0, binding = SHVIS_BINDING_NORMAL_MAP) uniform sampler2D normal_tex;

// Diffuse shading needs no view vector, so the world position is not passed on.
layout(location = 0) in vec3 in_normal_world;
layout(location = 1) in vec4 in_tangent_world;
layout(location = 2) in vec2 in_uv_material;
layout(location = 3) in vec2 in_uv_lightmap;
layout(location = 4) in vec3 in_albedo_tint;
#if defined(SHVIS_GBUFFER) && SHVIS_GBUFFER
layout(location = 5) in vec3 in_position_world;
#endif

// Material textures through their MIP chains (what every technique does), or at full
// resolution with SHVIS_MATERIAL_LEVEL0 (the footprint reference, which integrates the
// pixel footprint itself).
#if defined(SHVIS_MATERIAL_LEVEL0) && SHVIS_MATERIAL_LEVEL0
#define SAMPLE_MATERIAL(tex, uv) textureLod(tex, uv, 0.0)
#else
#define SAMPLE_MATERIAL(tex, uv) texture(tex, uv)
#endif

// Linear albedo: the sRGB texture is decoded by the sampler.
vec3 material_albedo() {
    return SAMPLE_MATERIAL(albedo_tex, in_uv_material).rgb * in_albedo_tint;
}

// The normal map's tangent-space normal (x along +u, y image up, z out), x and y scaled by
// normal_scale, unit; (0, 0, 1) for flat normals or a texel that decodes to zero length.
vec3 tangent_space_normal() {
    if (frame.normal_scale == 0.0) {
        return vec3(0.0, 0.0, 1.0);
    }
    vec3 m = SAMPLE_MATERIAL(normal_tex, in_uv_material).xyz * 2.0 - 1.0;
    m.xy *= frame.normal_scale;
    float m_len = length(m);
    return m_len > 1e-6 ? m / m_len : vec3(0.0, 0.0, 1.0);
}

// The normal map's frame in world space (columns: tangent, bitangent, interpolated normal;
// glTF convention, DESIGN §1: +Y green = image up; bitangent = w · cross(n, t) points toward
// decreasing v); false where the tangent is degenerate.
bool tangent_frame(out mat3 frame_world) {
    vec3 n = normalize(in_normal_world);
    vec3 t = in_tangent_world.xyz - n * dot(n, in_tangent_world.xyz);
    float t_len = length(t);
    if (t_len < 1e-6) {
        frame_world = mat3(1.0);
        return false;
    }
    t /= t_len;
    frame_world = mat3(t, cross(n, t) * in_tangent_world.w, n);
    return true;
}

// World-space shading normal from the tangent-space normal map. A degenerate tangent
// falls back to the interpolated normal.
vec3 shading_normal() {
    mat3 f;
    if (!tangent_frame(f)) {
        return normalize(in_normal_world);
    }
    vec3 m = tangent_space_normal();
    return normalize(f[0] * m.x + f[1] * m.y + f[2] * m.z);
}
#endif

#endif
