// nmprtsvdMp: normal mapping for PRT with the course's pixel shader (Sloan, PRT course;
// src/technique/nmprt.rs). Per texel the matrices P = V_Mᵀ R M (M × O² per
// colour; row (m, c) in SHVIS_NMPRT_ROW_GROUPS = ⌈O²/4⌉ RGBA groups at layer
// (3m + c)·ROW_GROUPS + k) as bake data; the lighting l per colour in uniforms; per pixel
// c_m = P_m l, then Σ_m (US)_m(n) c_m with US on the disk of tangent-space normals (as
// nmprtsvd.frag). Nothing per texel changes with the lighting. dx10 only: the layers exceed
// dx9's 16 textures (the path rules refuse it). The row length is compiled in (the build
// sets it from the transfer bake's order) and every loop unrolled, so that each uniform
// read has a constant index (read at a loop-derived index, the 192 reads cost lavapipe a
// loop each and are counted once).
#version 450
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform NmprtPixelParams {
    // x: factor undoing the matrices' f16 range scaling.
    layout(offset = 0) vec4 unscale;
    // Colour c, group k at c·NMPRT_MAX_ROW_GROUPS + k: lighting coefficients 4k … 4k+3.
    layout(offset = 16) vec4 light[3 * SHVIS_NMPRT_MAX_ROW_GROUPS];
} params;

#ifndef SHVIS_NMPRT_ROW_GROUPS
#error "the build defines SHVIS_NMPRT_ROW_GROUPS (LightingData::defines)"
#endif
#define SHVIS_PER_TEXEL_GROUPS (3 * SHVIS_NMPRT_VECTORS * SHVIS_NMPRT_MAX_ROW_GROUPS)
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
    [[unroll]] for (int k = 0; k < SHVIS_NMPRT_BASIS_LAYERS; ++k) {
        vec4 b = SAMPLE_BASIS(k, uv);
        u[4 * k] = b.x; u[4 * k + 1] = b.y; u[4 * k + 2] = b.z; u[4 * k + 3] = b.w;
    }
    vec3 irradiance = vec3(0.0);
    [[unroll]] for (int m = 0; m < SHVIS_NMPRT_VECTORS; ++m) {
        vec3 c_m;
        [[unroll]] for (int c = 0; c < 3; ++c) {
            float acc = 0.0;
            [[unroll]] for (int k = 0; k < SHVIS_NMPRT_ROW_GROUPS; ++k) {
                acc += dot(SAMPLE_PER_TEXEL((3 * m + c) * SHVIS_NMPRT_ROW_GROUPS + k),
                           params.light[c * SHVIS_NMPRT_MAX_ROW_GROUPS + k]);
            }
            c_m[c] = acc;
        }
        irradiance += u[m] * c_m;
    }
    write_diffuse(max(irradiance * params.unscale.x, vec3(0.0)));
}
