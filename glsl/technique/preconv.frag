// preconv: scalar ambient occlusion × pre-convolved order-3 irradiance at the per-pixel
// normal (Iwanicki–Sloan §5, "Preconv"; DESIGN §2; src/technique/preconv.rs).
// radiance = albedo/π · AO · E(n), E from SH irradiance coefficients (already multiplied
// by the clamped-cosine factors A_l) in uniforms.
//
// SHVIS_NDF_DIFFUSE (`preconvndf`; src/technique/ndf_diffuse.rs): E averaged over the pixel's
// normals exactly, E[E(n)] = Σ E_i E[y_i(n)] from the NDF maps' nine moments turned into
// the world frame, blended with E(n) by the filter's weight (0 where magnified).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sh.glsl"

#ifndef SHVIS_NDF_DIFFUSE
#define SHVIS_NDF_DIFFUSE 0
#endif

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform PreconvParams {
    layout(offset = 0) vec4 irradiance_sh[9]; // order-3 RGB in .rgb
} params;

#define SHVIS_PER_TEXEL_GROUPS 1
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_NDF_DIFFUSE
#include "ndf_diffuse.glsl"
// (E[x], E[y], E[z], ·), (E[xx], E[yy], E[zz], ·), (E[xy], E[xz], E[yz], ·), tangent space.
#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D ndf_tex[3];
#define NDF_MOMENTS(k) SAMPLE_MATERIAL(ndf_tex[k], in_uv_material)
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2DArray ndf_tex;
#define NDF_MOMENTS(k) SAMPLE_MATERIAL(ndf_tex, vec3(in_uv_material, float(k)))
#endif

// E[E(n)] over the pixel's normals (world frame f of the normal map).
vec3 filtered_irradiance(mat3 f) {
    vec4 m0 = NDF_MOMENTS(0);
    vec4 m1 = NDF_MOMENTS(1);
    vec4 m2 = NDF_MOMENTS(2);
    mat3 second = mat3(m1.x, m2.x, m2.y,
                       m2.x, m1.y, m2.z,
                       m2.y, m2.z, m1.z);
    float y[9];
    sh_expect_order3(f * m0.xyz, f * second * transpose(f), y);
    return sh_dot_rgb_order3(params.irradiance_sh, y);
}
#endif

void main() {
    vec3 n = shading_normal();
    vec3 irradiance = sh_eval_rgb_order3(params.irradiance_sh, n);
#if SHVIS_NDF_DIFFUSE
    mat3 f;
    float w = tangent_frame(f) ? ndf_filter_weight() : 0.0;
    irradiance = mix(irradiance, filtered_irradiance(f), w);
#endif
    irradiance = max(irradiance, vec3(0.0));
    float ao = SAMPLE_PER_TEXEL(0).r;
    write_diffuse(ao * irradiance);
}
