// dice, dicey: Ambient Dice lightmaps (src/technique/hemisphere.rs). Per texel the stored values
// of ten icosahedron vertices (9 or 5 each) in RGBA groups; the shader reads only the three
// vertices of the face holding the normal map's tangent-space normal
// (glsl/include/dice.glsl): dx10 and dx11 at computed array layers, dx9 at computed tiles of one
// atlas texture (sampler arrays take constant indices only). radiance = albedo/π · max(0, E).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform DiceParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
    // xy: the dx9 atlas' columns and rows of tiles.
    layout(offset = 16) vec4 atlas;
    // The face table: 7 vec4s per face.
    layout(offset = 32) vec4 faces[7 * 12];
} params;

#if SHVIS_DICE_FACES > 12
#error "at most 12 faces"
#endif

#if SHVIS_PATH_DX9
layout(set = 0, binding = SHVIS_BINDING_TECHNIQUE_TEXTURE0) uniform sampler2D per_texel_atlas;
// Group g's tile, the lightmap UV kept half a texel inside it (a tile's edge filters as a
// lone texture's clamped edge would). Level 0 explicitly: neighbouring pixels may read
// different tiles.
vec4 dice_read(int g) {
    vec2 tiles = params.atlas.xy;
    vec2 res = vec2(textureSize(per_texel_atlas, 0)) / tiles;
    vec2 uv = clamp(in_uv_lightmap, 0.5 / res, 1.0 - 0.5 / res);
    vec2 tile = vec2(float(g % int(tiles.x)), float(g / int(tiles.x)));
    return textureLod(per_texel_atlas, (tile + uv) / tiles, 0.0);
}
#else
// dx10 and dx11 (whose per_texel.glsl decodes the block-compressed groups).
#define SHVIS_PER_TEXEL_GROUPS SHVIS_DICE_GROUPS
#include "per_texel.glsl"
vec4 dice_read(int g) {
    return SAMPLE_PER_TEXEL_LOD0(g);
}
#endif

#define DICE_FACE(k) params.faces[k]
#define DICE_READ(g) dice_read(g)
#include "dice.glsl"
#include "diffuse_out.glsl"

void main() {
    vec3 irradiance = dice_irradiance(tangent_space_normal()) * params.unscale.x;
    write_diffuse(max(irradiance, vec3(0.0)));
}
