// pca4 … pca24: M PCA weights per texel · per-basis tables T_k(n) = ∫ L V_k H_n, plus the
// mean's table (Iwanicki–Sloan §4, eq. (6); DESIGN §2; src/technique/pca.rs):
// radiance = albedo/π · (T_mean(n) + Σ_k w_k T_k(n)).
#version 450
#extension GL_GOOGLE_include_directive : require
#define GROUPS SHVIS_PCA_GROUPS
#define SHVIS_WITH_MEAN 1
#include "grouped.glsl"
