// Real spherical harmonics, DESIGN §1 convention (Condon–Shortley phase; index l(l+1)+m;
// the pole is +z of the world frame). Mirrors src/sh/basis.rs.
#ifndef SHVIS_SH_GLSL
#define SHVIS_SH_GLSL

#include "math.glsl"

// The 9 basis functions of order 3 (bands 0..2) at unit direction d.
void sh_eval_order3(vec3 d, out float y[9]) {
    const float k00 = 0.5 * sqrt(1.0 / PI);
    const float k1 = sqrt(3.0 / (4.0 * PI));
    const float k2 = 0.5 * sqrt(15.0 / PI);
    const float k20 = 0.25 * sqrt(5.0 / PI);
    const float k22 = 0.25 * sqrt(15.0 / PI);
    y[0] = k00;
    y[1] = -k1 * d.y;
    y[2] = k1 * d.z;
    y[3] = -k1 * d.x;
    y[4] = k2 * d.x * d.y;
    y[5] = -k2 * d.y * d.z;
    y[6] = k20 * (3.0 * d.z * d.z - 1.0);
    y[7] = -k2 * d.x * d.z;
    y[8] = k22 * (d.x * d.x - d.y * d.y);
}

// Σ c_i y_i(d) for order-3 RGB coefficients stored in .rgb (e.g. irradiance already
// convolved with the clamped cosine, src/sh/zonal.rs).
vec3 sh_eval_rgb_order3(vec4 c[9], vec3 d) {
    float y[9];
    sh_eval_order3(d, y);
    vec3 sum = vec3(0.0);
    for (int i = 0; i < 9; ++i) {
        sum += c[i].rgb * y[i];
    }
    return sum;
}

// Irradiance E(n) = ∫ L max(0, n·ω) dω from order-3 RGB radiance coefficients: the
// clamped-cosine convolution (band factors A_l = π, 2π/3, π/4; src/sh/zonal.rs) evaluated
// at unit n. Used where radiance, not irradiance, reaches the shader (shlmap, sh2).
vec3 sh_irradiance_order3(vec3 radiance[9], vec3 n) {
    const float a[3] = float[3](PI, 2.0 * PI / 3.0, PI / 4.0);
    float y[9];
    sh_eval_order3(n, y);
    vec3 sum = radiance[0] * (a[0] * y[0]);
    for (int i = 1; i < 4; ++i) {
        sum += radiance[i] * (a[1] * y[i]);
    }
    for (int i = 4; i < 9; ++i) {
        sum += radiance[i] * (a[2] * y[i]);
    }
    return sum;
}

#endif
