// unc3 / unc4 / unc6: per-texel SH visibility · L×H table looked up by the normal
// (Iwanicki–Sloan §3, eq. (4); DESIGN §2; src/technique/unc.rs).
//   radiance = albedo/π · Σ_j V_j (L×H_n)_j
// V: SHVIS_UNC_GROUPS RGBA texels of 4 coefficients (flat index 4g + k). L×H: per colour and
// group, 4 coefficients per RGBA texel. dx9: V in GROUPS 2D textures; L×H in one 2D texture
// per colour, the GROUPS dual-paraboloid "spheres" side by side, each two hemisphere squares
// wide (sphere.glsl). dx10: V in one 2D array (layer g); L×H in a cube-map array, cube
// c·GROUPS + g. Groups are unrolled so every sampler-array index is a constant.
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sphere.glsl"

#define GROUPS SHVIS_UNC_GROUPS

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform UncParams {
    // x: factor undoing the table's f16 range scaling; y: L×H texels per hemisphere side.
    layout(offset = 0) vec4 lxh_unscale_res;
} params;

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D vis_tex[GROUPS];
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D lxh_tex[3];
#define SAMPLE_VIS(g) texture(vis_tex[g], in_uv_lightmap)
// Sphere g of colour c: hemisphere squares at columns 2g (y ≥ 0) and 2g + 1 (y < 0).
#define SAMPLE_LXH(c, g) texture(lxh_tex[c], vec2((2.0 * float(g) + hemi.z + hemi.x) / (2.0 * float(GROUPS)), hemi.y))
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray vis_tex;
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform samplerCubeArray lxh_tex;
#define SAMPLE_VIS(g) texture(vis_tex, vec3(in_uv_lightmap, float(g)))
#define SAMPLE_LXH(c, g) texture(lxh_tex, vec4(n, float((c) * GROUPS + (g))))
#endif

#define ACCUMULATE(g) { \
    vec4 v = SAMPLE_VIS(g); \
    sum += vec3(dot(v, SAMPLE_LXH(0, g)), dot(v, SAMPLE_LXH(1, g)), dot(v, SAMPLE_LXH(2, g))); \
}

layout(location = 0) out vec4 out_radiance;

void main() {
    vec3 n = shading_normal();
#if SHVIS_PATH_DX9
    vec3 hemi = dual_paraboloid_dir_to_uv(n, params.lxh_unscale_res.y);
#endif
    vec3 sum = vec3(0.0);
    ACCUMULATE(0)
#if GROUPS > 1
    ACCUMULATE(1)
#endif
#if GROUPS > 2
    ACCUMULATE(2)
#endif
#if GROUPS > 3
    ACCUMULATE(3)
#endif
#if GROUPS > 4
    ACCUMULATE(4)
#endif
#if GROUPS > 5
    ACCUMULATE(5)
#endif
#if GROUPS > 6
    ACCUMULATE(6)
#endif
#if GROUPS > 7
    ACCUMULATE(7)
#endif
#if GROUPS > 8
    ACCUMULATE(8)
#endif
#if GROUPS > 9
#error "unc supports at most order 6 (9 groups)"
#endif
    vec3 irradiance = max(sum * params.lxh_unscale_res.x, vec3(0.0));
    out_radiance = vec4(material_albedo() / PI * irradiance, 1.0);
}
