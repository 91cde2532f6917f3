// nmprtsvdM: normal mapping for PRT with the course's normal basis (Sloan, PRT course;
// src/technique/nmprt.rs). Per texel c_m = V_Mᵀ R M l for m < M, RGB (value
// 3m + c, 4 per RGBA texel in SHVIS_NMPRT_GROUPS groups, formed when the lighting
// changes); U(n)S on the disk of tangent-space normals (uv = n.xy·½ + ½, bilinear) in
// SHVIS_NMPRT_BASIS_LAYERS RGBA layers. radiance = albedo/π · Σ_m (US)_m(n) c_m.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform NmprtParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_NMPRT_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D normal_basis_tex[SHVIS_NMPRT_BASIS_LAYERS];
#define SAMPLE_BASIS(k, uv) texture(normal_basis_tex[k], uv)
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2DArray normal_basis_tex;
#define SAMPLE_BASIS(k, uv) texture(normal_basis_tex, vec3(uv, float(k)))
#endif

void main() {
    vec2 uv = tangent_space_normal().xy * 0.5 + 0.5;
    float u[4 * SHVIS_NMPRT_BASIS_LAYERS];
    UNROLL for (int k = 0; k < SHVIS_NMPRT_BASIS_LAYERS; ++k) {
        vec4 b = SAMPLE_BASIS(k, uv);
        u[4 * k] = b.x; u[4 * k + 1] = b.y; u[4 * k + 2] = b.z; u[4 * k + 3] = b.w;
    }
    float c[4 * SHVIS_NMPRT_GROUPS];
    UNROLL for (int g = 0; g < SHVIS_NMPRT_GROUPS; ++g) {
        vec4 v = SAMPLE_PER_TEXEL(g);
        c[4 * g] = v.x; c[4 * g + 1] = v.y; c[4 * g + 2] = v.z; c[4 * g + 3] = v.w;
    }
    vec3 irradiance = vec3(0.0);
    UNROLL for (int m = 0; m < SHVIS_NMPRT_VECTORS; ++m) {
        irradiance += u[m] * vec3(c[3 * m], c[3 * m + 1], c[3 * m + 2]);
    }
    write_diffuse(max(irradiance * params.unscale.x, vec3(0.0)));
}
