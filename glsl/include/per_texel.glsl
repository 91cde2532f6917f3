// Per-texel (lightmap) data of a technique, SHVIS_PER_TEXEL_GROUPS RGBA groups
// (src/technique/texels.rs): dx9 binds one 2D texture per group, dx10 one 2D array with a
// layer per group. SAMPLE_PER_TEXEL(g) reads group g at the fragment's lightmap UV; on dx9
// g must be a constant expression (sampler arrays are indexed by constants only).
// SAMPLE_PER_TEXEL_LOD0(g) is the same at level 0 explicitly (for reads in non-uniform
// control flow). FETCH_PER_TEXEL(g, ij) reads texel ij of group g unfiltered;
// PER_TEXEL_SIZE is the lightmap's size in texels (ivec2).
//
// dx11 (src/technique/block.rs), by SHVIS_PER_TEXEL_CODEC: SHVIS_CODEC_BC4 — one value per
// texel in BC4, read as dx10 reads it; SHVIS_CODEC_RATIO_* — the groups as ratios to a
// per-texel norm: layer g of per_texel_tex[0] (BC7) holds s = (128 + 127 r) / 255 for each
// value's ratio r, layer 0 of per_texel_tex[1] (BC6H) the norms n (RGB); value =
// (255 s − 128) / 127 · n of the value's colour — RATIO_ONE: every value n.r;
// RATIO_TRIPLETS: value j = 4g + i has colour j mod 3 (RGB triplets, 3k + c);
// RATIO_GROUP_RGB: colour i, alpha with red (an RGB triple per group). The codec ids are
// Rust's (technique::block::codec_ids), given to every technique compile.
#ifndef SHVIS_PER_TEXEL_GLSL
#define SHVIS_PER_TEXEL_GLSL

#ifndef SHVIS_PER_TEXEL_GROUPS
#error "define SHVIS_PER_TEXEL_GROUPS before including per_texel.glsl"
#endif
#ifndef SHVIS_CODEC_NONE
#error "the codec ids are not defined (technique::block::path_defines gives them)"
#endif
#ifndef SHVIS_PATH_DX11
#define SHVIS_PATH_DX11 0
#endif
#ifndef SHVIS_PER_TEXEL_CODEC
#define SHVIS_PER_TEXEL_CODEC SHVIS_CODEC_NONE
#endif
#define PER_TEXEL_RATIOS (SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_ONE || \
                          SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_TRIPLETS || \
                          SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_GROUP_RGB)

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D per_texel_tex[SHVIS_PER_TEXEL_GROUPS];
#define SAMPLE_PER_TEXEL(g) texture(per_texel_tex[g], in_uv_lightmap)
#define SAMPLE_PER_TEXEL_LOD0(g) textureLod(per_texel_tex[g], in_uv_lightmap, 0.0)
#define FETCH_PER_TEXEL(g, ij) texelFetch(per_texel_tex[g], ij, 0)
#define PER_TEXEL_SIZE textureSize(per_texel_tex[0], 0)
#elif SHVIS_PATH_DX11 && PER_TEXEL_RATIOS
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray per_texel_tex[2];

// The norm of each channel of group g from the texel's norms n.
vec4 per_texel_norms(vec3 n, int g) {
#if SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_ONE
    return vec4(n.r);
#elif SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_TRIPLETS
    int first = g % 3;
    return first == 0 ? n.rgbr : (first == 1 ? n.gbrg : n.brgb);
#elif SHVIS_PER_TEXEL_CODEC == SHVIS_CODEC_RATIO_GROUP_RGB
    return n.rgbr;
#else
#error "unknown ratio codec"
#endif
}

vec4 per_texel_decode(vec4 s, vec3 n, int g) {
    return (s * (255.0 / 127.0) - 128.0 / 127.0) * per_texel_norms(n, g);
}

#define SAMPLE_PER_TEXEL(g) per_texel_decode(texture(per_texel_tex[0], vec3(in_uv_lightmap, float(g))), texture(per_texel_tex[1], vec3(in_uv_lightmap, 0.0)).rgb, (g))
#define SAMPLE_PER_TEXEL_LOD0(g) per_texel_decode(textureLod(per_texel_tex[0], vec3(in_uv_lightmap, float(g)), 0.0), textureLod(per_texel_tex[1], vec3(in_uv_lightmap, 0.0), 0.0).rgb, (g))
#define FETCH_PER_TEXEL(g, ij) per_texel_decode(texelFetch(per_texel_tex[0], ivec3(ij, g), 0), texelFetch(per_texel_tex[1], ivec3(ij, 0), 0).rgb, (g))
#define PER_TEXEL_SIZE textureSize(per_texel_tex[0], 0).xy
#else
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2DArray per_texel_tex;
#define SAMPLE_PER_TEXEL(g) texture(per_texel_tex, vec3(in_uv_lightmap, float(g)))
#define SAMPLE_PER_TEXEL_LOD0(g) textureLod(per_texel_tex, vec3(in_uv_lightmap, float(g)), 0.0)
#define FETCH_PER_TEXEL(g, ij) texelFetch(per_texel_tex, ivec3(ij, g), 0)
#define PER_TEXEL_SIZE textureSize(per_texel_tex, 0).xy
#endif

#endif
