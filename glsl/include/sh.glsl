// Real spherical harmonics, DESIGN §1 convention (Condon–Shortley phase; index l(l+1)+m;
// the pole is +z of the world frame). Mirrors src/sh/basis.rs.
#ifndef SHVIS_SH_GLSL
#define SHVIS_SH_GLSL

#include "math.glsl"
#include "unroll.glsl"

const float SH_K00 = 0.5 * sqrt(1.0 / PI);
const float SH_K1 = sqrt(3.0 / (4.0 * PI));
const float SH_K2 = 0.5 * sqrt(15.0 / PI);
const float SH_K20 = 0.25 * sqrt(5.0 / PI);
const float SH_K22 = 0.25 * sqrt(15.0 / PI);

// The 9 basis functions of order 3 (bands 0..2) at unit direction d.
void sh_eval_order3(vec3 d, out float y[9]) {
    y[0] = SH_K00;
    y[1] = -SH_K1 * d.y;
    y[2] = SH_K1 * d.z;
    y[3] = -SH_K1 * d.x;
    y[4] = SH_K2 * d.x * d.y;
    y[5] = -SH_K2 * d.y * d.z;
    y[6] = SH_K20 * (3.0 * d.z * d.z - 1.0);
    y[7] = -SH_K2 * d.x * d.z;
    y[8] = SH_K22 * (d.x * d.x - d.y * d.y);
}

// E[y_i(x)] of the order-3 basis over a distribution of unit directions with mean u and
// second moments m = E[xxᵀ]: each y_i is a polynomial of degree ≤ 2, so substituting the
// moments is exact (src/technique/ndf_diffuse.rs, expected_sh_order3).
void sh_expect_order3(vec3 u, mat3 m, out float y[9]) {
    y[0] = SH_K00;
    y[1] = -SH_K1 * u.y;
    y[2] = SH_K1 * u.z;
    y[3] = -SH_K1 * u.x;
    y[4] = SH_K2 * m[0][1];
    y[5] = -SH_K2 * m[1][2];
    y[6] = SH_K20 * (2.0 * m[2][2] - m[0][0] - m[1][1]);
    y[7] = -SH_K2 * m[0][2];
    y[8] = SH_K22 * (m[0][0] - m[1][1]);
}

// Σ c_i y_i for order-3 RGB coefficients in .rgb and basis values y.
vec3 sh_dot_rgb_order3(vec4 c[9], float y[9]) {
    vec3 sum = vec3(0.0);
    UNROLL for (int i = 0; i < 9; ++i) {
        sum += c[i].rgb * y[i];
    }
    return sum;
}

// Σ c_i y_i(d) for order-3 RGB coefficients stored in .rgb (e.g. irradiance already
// convolved with the clamped cosine, src/sh/zonal.rs).
vec3 sh_eval_rgb_order3(vec4 c[9], vec3 d) {
    float y[9];
    sh_eval_order3(d, y);
    return sh_dot_rgb_order3(c, y);
}

// Irradiance E(n) = ∫ L max(0, n·ω) dω from order-3 RGB radiance coefficients: the
// clamped-cosine convolution (band factors A_l = π, 2π/3, π/4; src/sh/zonal.rs) evaluated
// at unit n. Used where radiance, not irradiance, reaches the shader (shlmap, sh2).
vec3 sh_irradiance_order3(vec3 radiance[9], vec3 n) {
    const float a[3] = float[3](PI, 2.0 * PI / 3.0, PI / 4.0);
    float y[9];
    sh_eval_order3(n, y);
    vec3 sum = radiance[0] * (a[0] * y[0]);
    UNROLL for (int i = 1; i < 4; ++i) {
        sum += radiance[i] * (a[1] * y[i]);
    }
    UNROLL for (int i = 4; i < 9; ++i) {
        sum += radiance[i] * (a[2] * y[i]);
    }
    return sum;
}

#endif
