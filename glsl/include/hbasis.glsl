// The H-basis (Habel & Wimmer 2010; src/sh/hbasis.rs, whose module doc has the functions):
// six polynomials orthonormal over the tangent-frame hemisphere, evaluated at a
// tangent-space direction m (z along the surface normal).
#ifndef SHVIS_HBASIS_GLSL
#define SHVIS_HBASIS_GLSL

#include "math.glsl"
#include "unroll.glsl"

void hbasis_eval(vec3 m, out float h[6]) {
    const float k0 = 1.0 / sqrt(2.0 * PI);
    const float k1 = sqrt(3.0 / (2.0 * PI));
    const float k2 = sqrt(15.0 / (2.0 * PI));
    h[0] = k0;
    h[1] = k1 * m.y;
    h[2] = k1 * (2.0 * m.z - 1.0);
    h[3] = k1 * m.x;
    h[4] = k2 * m.x * m.y;
    h[5] = 0.5 * k2 * (m.x * m.x - m.y * m.y);
}

// Σ_i h_i H_i(m), RGB, for `count` (4 or 6) coefficients stored as v[3i + c].
vec3 hbasis_irradiance(float v[20], int count, vec3 m) {
    float h[6];
    hbasis_eval(m, h);
    vec3 e = vec3(0.0);
    UNROLL for (int i = 0; i < count; ++i) {
        e += vec3(v[3 * i], v[3 * i + 1], v[3 * i + 2]) * h[i];
    }
    return e;
}

#endif
