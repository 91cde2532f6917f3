// unc3 / unc4 / unc6: per-texel SH visibility · L×H table looked up by the normal
// (Iwanicki–Sloan §3, eq. (4); DESIGN §2; src/technique/unc.rs). V_j in groups of 4 per
// texel, (L×H_n)_j in the same groups per colour: radiance = albedo/π · Σ_j V_j (L×H_n)_j.
#version 450
#extension GL_GOOGLE_include_directive : require
#define GROUPS SHVIS_UNC_GROUPS
#define SHVIS_WITH_MEAN 0
#include "grouped.glsl"
