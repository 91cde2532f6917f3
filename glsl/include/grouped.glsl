// The fragment body shared by unc.frag and pca.frag (src/technique/unc.rs and pca.rs;
// layouts in src/technique/texels.rs and tables.rs):
//   radiance = albedo/π · (mean(n) + Σ_g dot(texel_g(uv), table_{c,g}(n)))
// GROUPS (≤ 9) texel groups of 4 values; tables per colour c and group g, 4 values per RGBA
// texel; SHVIS_WITH_MEAN adds an RGB mean table (PCA's V_e term). dx9: texel groups in
// GROUPS 2D textures, each colour's tables in one 2D texture with the GROUPS dual-paraboloid
// spheres side by side (sphere.glsl), the mean in one more; dx10: a 2D array and a cube-map
// array (cube c·GROUPS + g, mean at 3·GROUPS). Groups are unrolled, so every sampler-array
// index is a constant.
#ifndef SHVIS_GROUPED_GLSL
#define SHVIS_GROUPED_GLSL

#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sphere.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform GroupedParams {
    // x: factor undoing the tables' f16 range scaling; y: table texels per side.
    layout(offset = 0) vec4 unscale_res;
} params;

#define SHVIS_PER_TEXEL_GROUPS GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform sampler2D table_tex[3];
#if SHVIS_WITH_MEAN
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 2) uniform sampler2D mean_tex;
#endif
// Sphere g of colour c: hemisphere squares at columns 2g (y ≥ 0) and 2g + 1 (y < 0).
#define SAMPLE_TABLE(c, g) texture(table_tex[c], vec2((2.0 * float(g) + hemi.z + hemi.x) / (2.0 * float(GROUPS)), hemi.y))
#define SAMPLE_MEAN() texture(mean_tex, vec2((hemi.z + hemi.x) / 2.0, hemi.y)).rgb
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0 + 1) uniform samplerCubeArray table_tex;
#define SAMPLE_TABLE(c, g) texture(table_tex, vec4(n, float((c) * GROUPS + (g))))
#define SAMPLE_MEAN() texture(table_tex, vec4(n, float(3 * GROUPS))).rgb
#endif

#define ACCUMULATE(g) { \
    vec4 v = SAMPLE_PER_TEXEL(g); \
    sum += vec3(dot(v, SAMPLE_TABLE(0, g)), dot(v, SAMPLE_TABLE(1, g)), dot(v, SAMPLE_TABLE(2, g))); \
}

void main() {
    vec3 n = shading_normal();
#if SHVIS_PATH_DX9
    vec3 hemi = dual_paraboloid_dir_to_uv(n, params.unscale_res.y);
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
    vec3 irradiance = max(sum * params.unscale_res.x, vec3(0.0));
    write_diffuse(irradiance);
}

#endif
