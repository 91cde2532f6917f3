// sgN: spherical Gaussian lightmaps (src/technique/hemisphere.rs). Per texel SHVIS_SG_GROUPS
// RGBA groups of SHVIS_SG_LOBES RGB amplitudes (value 3k + c); the lobes' tangent-space axes
// and sharpness in the uniform block; E(m) = Σ_k a_k ∫ G_k max(0, m·ω) dω at the normal
// map's tangent-space normal (glsl/include/sg.glsl); radiance = albedo/π · max(0, E).
#version 450
#extension GL_GOOGLE_include_directive : require
#define SHVIS_FRAGMENT 1
#include "common.glsl"
#include "sg.glsl"

layout(std140, set = 0, binding = SHVIS_BINDING_TECHNIQUE_PARAMS) uniform SgParams {
    // x: factor undoing the f16 range scaling.
    layout(offset = 0) vec4 unscale;
    // Axis (tangent space) in .xyz, sharpness in .w.
    layout(offset = 16) vec4 lobes[12];
} params;

#define SHVIS_PER_TEXEL_GROUPS SHVIS_SG_GROUPS
#include "per_texel.glsl"
#include "diffuse_out.glsl"

#if SHVIS_SG_GROUPS > 9
#error "at most 12 lobes (9 groups)"
#endif

void main() {
    float v[36];
    UNROLL for (int i = 0; i < 36; ++i) {
        v[i] = 0.0;
    }
    // dx9 indexes its sampler array by constants only: one read per group, unrolled.
#define SHVIS_SG_READ(g) { vec4 t = SAMPLE_PER_TEXEL(g); v[4 * g] = t.x; v[4 * g + 1] = t.y; v[4 * g + 2] = t.z; v[4 * g + 3] = t.w; }
    SHVIS_SG_READ(0)
    SHVIS_SG_READ(1)
    SHVIS_SG_READ(2)
    SHVIS_SG_READ(3)
#if SHVIS_SG_GROUPS > 4
    SHVIS_SG_READ(4)
#endif
#if SHVIS_SG_GROUPS > 5
    SHVIS_SG_READ(5)
#endif
#if SHVIS_SG_GROUPS > 6
    SHVIS_SG_READ(6)
#endif
#if SHVIS_SG_GROUPS > 7
    SHVIS_SG_READ(7)
#endif
#if SHVIS_SG_GROUPS > 8
    SHVIS_SG_READ(8)
#endif
    vec3 m = tangent_space_normal();
    vec3 irradiance = vec3(0.0);
    UNROLL for (int k = 0; k < SHVIS_SG_LOBES; ++k) {
        vec4 lobe = params.lobes[k];
        irradiance += vec3(v[3 * k], v[3 * k + 1], v[3 * k + 2])
            * sg_cosine_integral(dot(lobe.xyz, m), lobe.w);
    }
    write_diffuse(max(irradiance * params.unscale.x, vec3(0.0)));
}
