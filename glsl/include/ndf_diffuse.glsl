// Diffuse shading under NDF filtering (Olano & North; src/technique/ndf_diffuse.rs has the
// derivation): the weight of the filter and the zonal attenuation of SH bands 1 and 2.
// Needs common.glsl (normal_tex, in_uv_material, frame).
#ifndef SHVIS_NDF_DIFFUSE_GLSL
#define SHVIS_NDF_DIFFUSE_GLSL

// w = clamp(λ, 0, 1), λ the normal map's level of detail: 0 where the map is magnified
// (bilinear blending of neighbours is no spread the pixel sees), 1 from one level of
// minification on; 0 with flat normals.
float ndf_filter_weight() {
    if (frame.normal_scale == 0.0) {
        return 0.0;
    }
    return clamp(textureQueryLod(normal_tex, in_uv_material).y, 0.0, 1.0);
}

// (a_1, a_2) of the von Mises–Fisher distribution of mean length r, each blended toward
// 1 by (1 − w): a_1 = r, a_2 = 2r²/(3 − r²).
vec2 ndf_zonal_attenuation(float r, float w) {
    r = clamp(r, 0.0, 1.0);
    vec2 a = vec2(r, 2.0 * r * r / (3.0 - r * r));
    return vec2(1.0) + w * (a - vec2(1.0));
}

#endif
