// Per-texel (lightmap) data of a technique, SHVIS_PER_TEXEL_GROUPS RGBA groups
// (src/technique/texels.rs): dx9 binds one 2D texture per group, dx10 one 2D array with a
// layer per group. SAMPLE_PER_TEXEL(g) reads group g at the fragment's lightmap UV; on dx9
// g must be a constant expression (sampler arrays are indexed by constants only).
// FETCH_PER_TEXEL(g, ij) reads texel ij of group g unfiltered; PER_TEXEL_SIZE is the
// lightmap's size in texels (ivec2).
#ifndef SHVIS_PER_TEXEL_GLSL
#define SHVIS_PER_TEXEL_GLSL

#ifndef SHVIS_PER_TEXEL_GROUPS
#error "define SHVIS_PER_TEXEL_GROUPS before including per_texel.glsl"
#endif

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D per_texel_tex[SHVIS_PER_TEXEL_GROUPS];
#define SAMPLE_PER_TEXEL(g) texture(per_texel_tex[g], in_uv_lightmap)
#define FETCH_PER_TEXEL(g, ij) texelFetch(per_texel_tex[g], ij, 0)
#define PER_TEXEL_SIZE textureSize(per_texel_tex[0], 0)
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray per_texel_tex;
#define SAMPLE_PER_TEXEL(g) texture(per_texel_tex, vec3(in_uv_lightmap, float(g)))
#define FETCH_PER_TEXEL(g, ij) texelFetch(per_texel_tex, ivec3(ij, g), 0)
#define PER_TEXEL_SIZE textureSize(per_texel_tex, 0).xy
#endif

#endif
