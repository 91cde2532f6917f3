// The fragment body shared by unc.frag and pca.frag (src/technique/unc.rs and pca.rs;
// layouts in src/technique/texels.rs and tables.rs):
//   radiance = albedo/π · (mean(n) + Σ_g dot(texel_g(uv), table_{c,g}(n)))
// GROUPS (≤ 9) texel groups of 4 values; tables per colour c and group g, 4 values per RGBA
// texel; SHVIS_WITH_MEAN adds an RGB mean table (PCA's V_e term). dx9: texel groups in
// GROUPS 2D textures, each colour's tables in one 2D texture with the GROUPS dual-paraboloid
// spheres side by side (sphere.glsl), the mean in one more; dx10: a 2D array and a cube-map
// array (cube c·GROUPS + g, mean at 3·GROUPS). Groups are unrolled, so every sampler-array
// index is a constant.
//
// SHVIS_NDF_DIFFUSE (unc only, `uncOndf`; src/technique/ndf_diffuse.rs): the L×H tables filtered by
// the isotropic NDF of the pixel's normals, (1 − a_2) T0 + (a_2 + a_1)/2 T(n) +
// (a_2 − a_1)/2 T(−n): the mean moment at binding TEXTURE0 + 1 (the tables move one on),
// every table fetched at ±n, T0 per group and colour in the uniform block.
#ifndef SHVIS_GROUPED_GLSL
#define SHVIS_GROUPED_GLSL

#ifndef SHVIS_NDF_DIFFUSE
#define SHVIS_NDF_DIFFUSE 0
#endif

#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sphere.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform GroupedParams {
    // x: factor undoing the tables' f16 range scaling; y: table texels per side.
    layout(offset = 0) vec4 unscale_res;
#if SHVIS_NDF_DIFFUSE
    // The tables' band 0, T0_j = L_j / 4, unscaled: vec4 c·GROUPS + g holds j = 4g..4g+3.
    layout(offset = 16) vec4 ambient[3 * GROUPS];
#endif
} params;

#define SHVIS_PER_TEXEL_GROUPS GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_NDF_DIFFUSE
#include "ndf_diffuse.glsl"
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D ndf_mean_tex;
#define TABLE_BINDING (SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 2)
#else
#define TABLE_BINDING (SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1)
#endif

#if SHVIS_PATH_DX9
layout(set = 0, binding = TABLE_BINDING) uniform sampler2D table_tex[3];
#if SHVIS_WITH_MEAN
layout(set = 0, binding = TABLE_BINDING + 1) uniform sampler2D mean_tex;
#endif
// Sphere g of colour c at direction d (hemisphere coordinates hm): hemisphere squares at
// columns 2g (y ≥ 0) and 2g + 1 (y < 0).
#define SAMPLE_TABLE(c, g, d, hm) texture(table_tex[c], vec2((2.0 * float(g) + hm.z + hm.x) / (2.0 * float(GROUPS)), hm.y))
#define SAMPLE_MEAN() texture(mean_tex, vec2((hemi.z + hemi.x) / 2.0, hemi.y)).rgb
#else
layout(set = 0, binding = TABLE_BINDING) uniform samplerCubeArray table_tex;
#define SAMPLE_TABLE(c, g, d, hm) texture(table_tex, vec4(d, float((c) * GROUPS + (g))))
#define SAMPLE_MEAN() texture(table_tex, vec4(n, float(3 * GROUPS))).rgb
#endif

#define TABLE_DOT(v, g, d, hm) vec3(dot(v, SAMPLE_TABLE(0, g, d, hm)), dot(v, SAMPLE_TABLE(1, g, d, hm)), dot(v, SAMPLE_TABLE(2, g, d, hm)))

#if SHVIS_NDF_DIFFUSE
#define NDF_ACCUMULATE(v, g) \
    sum_opposite += TABLE_DOT(v, g, -n, hemi_opposite); \
    ambient += vec3(dot(v, params.ambient[g]), dot(v, params.ambient[GROUPS + g]), dot(v, params.ambient[2 * GROUPS + g]));
#else
#define NDF_ACCUMULATE(v, g)
#endif

#define ACCUMULATE(g) { \
    vec4 v = SAMPLE_PER_TEXEL(g); \
    sum += TABLE_DOT(v, g, n, hemi); \
    NDF_ACCUMULATE(v, g) \
}

void main() {
    vec3 n = shading_normal();
#if SHVIS_PATH_DX9
    vec3 hemi = dual_paraboloid_dir_to_uv(n, params.unscale_res.y);
#if SHVIS_NDF_DIFFUSE
    vec3 hemi_opposite = dual_paraboloid_dir_to_uv(-n, params.unscale_res.y);
#endif
#endif
#if SHVIS_NDF_DIFFUSE
    vec3 sum_opposite = vec3(0.0);
    vec3 ambient = vec3(0.0);
#endif
#if SHVIS_WITH_MEAN
    vec3 sum = SAMPLE_MEAN();
#else
    vec3 sum = vec3(0.0);
#endif
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
#error "at most 9 groups (order-6 visibility, 36 values)"
#endif
#if SHVIS_NDF_DIFFUSE
    float r = length(SAMPLE_MATERIAL(ndf_mean_tex, in_uv_material).xyz);
    vec2 a = ndf_zonal_attenuation(r, ndf_filter_weight());
    sum = 0.5 * (a.y + a.x) * sum + 0.5 * (a.y - a.x) * sum_opposite;
    vec3 irradiance = max(sum * params.unscale_res.x + (1.0 - a.y) * ambient, vec3(0.0));
#else
    vec3 irradiance = max(sum * params.unscale_res.x, vec3(0.0));
#endif
    write_diffuse(irradiance);
}

#endif
