// The specular term of a directional light under three normal-map filterings (Olano &
// North; issue 19; src/ndf/render.rs): L = k_s E · D(h) where n·l > 0 and n·v > 0.
//   SHVIS_NDF_FILTER 0 (mip):  the MIP chain of averaged normals, renormalized, base lobe
//                              D = κ₀ g(|h − n̄|²/σ²)/σ³;
//   SHVIS_NDF_FILTER 1 (ndf):  the NDF maps' filtered moments, D = κ₀ g(d)/√det S;
//   SHVIS_NDF_FILTER 2 (ndfn): the same with the per-texel 1/N of the maps.
// g(t) = max(0, 1 − t/16)^8 (Pearson type II, m = 8), d = (h − u)ᵀ S⁻¹ (h − u) in the
// normal map's tangent space, S = E[xxᵀ] − uuᵀ.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform SpecularParams {
    layout(offset = 0) vec4 light_dir;       // xyz: unit, toward the light
    layout(offset = 16) vec4 light_radiance; // rgb: k_s · E
    layout(offset = 32) float sigma;         // base spread of a full-resolution texel
    layout(offset = 36) float kappa0;        // 1 / N(n, σ²I)
} params;

#if SHVIS_NDF_FILTER != 0
#if SHVIS_PATH_DX9
// (E[x], E[y], E[z], 1/N), (E[xx], E[yy], E[zz], ·), (E[xy], E[xz], E[yz], ·)
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D ndf_tex[3];
#define NDF_MOMENTS(k) SAMPLE_MATERIAL(ndf_tex[k], in_uv_material)
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray ndf_tex;
#define NDF_MOMENTS(k) SAMPLE_MATERIAL(ndf_tex, vec3(in_uv_material, float(k)))
#endif
#endif

layout(location = 0) out vec4 out_color;

float pearson(float t) {
    float b = max(0.0, 1.0 - t / 16.0);
    b *= b;
    b *= b;
    return b * b;
}

void main() {
    vec3 n = normalize(in_normal_world);
    vec3 v = normalize(frame.camera_position.xyz - in_position_world);
    vec3 l = params.light_dir.xyz;
    vec3 h = normalize(l + v);
    float lit = (dot(n, l) > 0.0 && dot(n, v) > 0.0) ? 1.0 : 0.0;
    // The normal map's frame, as shading_normal() builds it.
    vec3 t = in_tangent_world.xyz - n * dot(n, in_tangent_world.xyz);
    t = length(t) > 1e-6 ? normalize(t) : vec3(1.0, 0.0, 0.0);
    vec3 b = cross(n, t) * in_tangent_world.w;
    vec3 h_ts = vec3(dot(h, t), dot(h, b), dot(h, n));
#if SHVIS_NDF_FILTER == 0
    vec3 r = h_ts - tangent_space_normal();
    float s2 = params.sigma * params.sigma;
    float density = params.kappa0 * pearson(dot(r, r) / s2) / (s2 * params.sigma);
#else
    vec4 m0 = NDF_MOMENTS(0);
    vec4 m1 = NDF_MOMENTS(1);
    vec4 m2 = NDF_MOMENTS(2);
    vec3 u = m0.xyz;
    mat3 second = mat3(m1.x, m2.x, m2.y,
                       m2.x, m1.y, m2.z,
                       m2.y, m2.z, m1.z);
    mat3 s = second - outerProduct(u, u);
    float det = determinant(s);
    vec3 r = h_ts - u;
    float density = det > 0.0 ? pearson(dot(r, inverse(s) * r)) / sqrt(det) : 0.0;
#if SHVIS_NDF_FILTER == 1
    density *= params.kappa0;
#else
    density *= m0.w;
#endif
#endif
    out_color = vec4(params.light_radiance.rgb * density * lit, 1.0);
}
