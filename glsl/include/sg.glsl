// Spherical Gaussians (src/sh/sg.rs, whose module doc has the formulas): a lobe
// G(ω) = exp(λ(μ·ω − 1)) and Hill's fitted approximation of its product with the clamped
// cosine about a normal, integrated over the sphere (MJP, "SG Series Part 3").
#ifndef SHVIS_SG_GLSL
#define SHVIS_SG_GLSL

#include "math.glsl"

// ∫ G(ω; μ, λ) max(0, n·ω) dω for t = μ·n.
float sg_cosine_integral(float t, float sharpness) {
    const float c0 = 0.36;
    const float c1 = 1.0 / (4.0 * c0);
    float e = exp(-sharpness);
    float e2 = e * e;
    float r = 1.0 / sharpness;
    float scale = 1.0 + 2.0 * e2 - r;
    float bias = (e - e2) * r - e2;
    float x = sqrt(max(1.0 - scale, 0.0));
    float x0 = c0 * t;
    float x1 = c1 * x;
    float y = abs(x0) <= x1 ? (x0 + x1) * (x0 + x1) / x : clamp(t, 0.0, 1.0);
    float integral = 2.0 * PI * (1.0 - exp(-2.0 * sharpness)) * r;
    return (scale * y + bias) * integral;
}

#endif
