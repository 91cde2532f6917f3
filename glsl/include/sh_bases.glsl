// The engine lightmap bases' irradiance reconstructions (src/sh/bases.rs, equations
// (1)–(8) of its module doc), for the stored layout of ShBasis::encode: v[3k + c] is colour c
// of stored coefficient k. SHVIS_ENGINE_SH_BASIS selects one (ids SHVIS_SH_BASIS_*, from
// src/technique/sh_variant.rs):
//   L1: L1 linear (1)   L1_GEOMERICS: L1 Geomerics (2)
//   L1_ZH3_HALLUCINATED: L1 + hallucinated ZH3 (5)   ZH3: ZH3 stored (4)
//   L1_LUMINANCE: L1 luminance (6)
//   L2: L2 (7), deringed L2 (8): sh.glsl's sh_irradiance_order3 on 27 values (shlmap.frag);
//     engine_sh_irradiance is not defined for it.
// Every reconstruction is homogeneous of degree one in v (a range scale commutes with it).
#ifndef SHVIS_SH_BASES_GLSL
#define SHVIS_SH_BASES_GLSL

#include "sh.glsl"

#ifndef SHVIS_ENGINE_SH_BASIS
#error "define SHVIS_ENGINE_SH_BASIS before including sh_bases.glsl"
#endif
#ifndef SHVIS_SH_BASIS_L2
#error "the engine SH basis ids are not defined (technique::engine_sh::basis_ids)"
#endif

const vec3 SH_LUMINANCE = vec3(0.2126, 0.7152, 0.0722);
// √(5/16π): the zonal harmonic about an axis, Y_20(t) = SH_K20_ZONAL · (3t² − 1).
const float SH_K20_ZONAL = 0.31539156525252005;
// The largest |d| / c_00 of non-negative radiance; the ratios of (5) and (6) are clamped to it.
const float SH_SQRT_3 = 1.7320508075688772;

// d = (−c_11, −c_1−1, c_10) of channel c: the linear band as a vector.
vec3 sh_linear_vector(float v[16], int c) {
    return vec3(-v[9 + c], -v[3 + c], v[6 + c]);
}

// (1): π c_00 y_00 + (2π/3) K_1 d·n, RGB.
vec3 sh_l1_linear(float v[16], vec3 n) {
    vec3 e;
    UNROLL for (int c = 0; c < 3; ++c) {
        e[c] = PI * SH_K00 * v[c] + (2.0 * PI / 3.0) * SH_K1 * dot(sh_linear_vector(v, c), n);
    }
    return e;
}

// (2) for one channel: mean irradiance r0, half the linear term r1.
float sh_geomerics(float r0, vec3 r1, vec3 n) {
    if (r0 <= 0.0) {
        return 0.0;
    }
    float len = length(r1);
    if (len == 0.0) {
        return r0;
    }
    float r = min(len / r0, 1.0);
    float q = clamp(0.5 * (1.0 + dot(n, r1 / len)), 0.0, 1.0);
    float p = 1.0 + 2.0 * r;
    float a = (1.0 - r) / (1.0 + r);
    return r0 * (a + (1.0 - a) * (p + 1.0) * pow(q, p));
}

// (3): the luminance's linear direction; false when it has none.
bool sh_zh3_axis(float v[16], out vec3 axis) {
    vec3 d = sh_linear_vector(v, 0) * SH_LUMINANCE.r + sh_linear_vector(v, 1) * SH_LUMINANCE.g
           + sh_linear_vector(v, 2) * SH_LUMINANCE.b;
    float len = length(d);
    axis = len > 0.0 ? d / len : vec3(0.0, 0.0, 1.0);
    return len > 0.0;
}

#if SHVIS_ENGINE_SH_BASIS != SHVIS_SH_BASIS_L2
vec3 engine_sh_irradiance(float v[16], vec3 n) {
#if SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L1
    return sh_l1_linear(v, n);
#elif SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L1_GEOMERICS
    vec3 e;
    UNROLL for (int c = 0; c < 3; ++c) {
        vec3 r1 = 0.5 * (2.0 * PI / 3.0) * SH_K1 * sh_linear_vector(v, c);
        e[c] = sh_geomerics(PI * SH_K00 * v[c], r1, n);
    }
    return e;
#elif SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L1_ZH3_HALLUCINATED || SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_ZH3
    vec3 e = sh_l1_linear(v, n);
    vec3 axis;
    if (!sh_zh3_axis(v, axis)) {
        return e;
    }
    float t = dot(axis, n);
    float y20 = SH_K20_ZONAL * (3.0 * t * t - 1.0);
    vec3 z;
#if SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L1_ZH3_HALLUCINATED
    UNROLL for (int c = 0; c < 3; ++c) {
        float c00 = v[c];
        float r = c00 > 0.0 ? min(abs(dot(sh_linear_vector(v, c), axis)) / c00, SH_SQRT_3) : 0.0;
        z[c] = c00 > 0.0 ? c00 * (0.08 * r + 0.6 * r * r) : 0.0;
    }
#else
    z = vec3(v[12], v[13], v[14]);
#endif
    return e + (PI / 4.0) * z * y20;
#elif SHVIS_ENGINE_SH_BASIS == SHVIS_SH_BASIS_L1_LUMINANCE
    vec3 ambient = vec3(v[0], v[1], v[2]);
    vec3 d = vec3(-v[5], -v[3], v[4]);
    float mean_lum = dot(ambient, SH_LUMINANCE);
    float d_len = length(d);
    if (mean_lum > 0.0 && d_len > SH_SQRT_3 * mean_lum) {
        d *= SH_SQRT_3 * mean_lum / d_len;
    }
    float directional = mean_lum > 0.0 ? (2.0 * PI / 3.0) * SH_K1 * dot(d, n) / mean_lum : 0.0;
    return PI * SH_K00 * ambient + ambient * directional;
#else
#error "unknown SHVIS_ENGINE_SH_BASIS"
#endif
}
#endif

#endif
