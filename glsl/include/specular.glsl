// The specular material term of a directional light under three normal-map filterings
// (Olano & North; src/render/specular.rs): L = k_s E · D(h) where n·l > 0 and n·v > 0
// (n the interpolated normal; no shadowing or masking, as in the paper).
// SHVIS_SPECULAR, where defined, is one of the ids of src/render/specular.rs:
//   SHVIS_SPECULAR_MIP:  the MIP chain of averaged normals, renormalized, base lobe
//                        D = κ₀ g(|h − n̄|²/σ²)/σ³;
//   SHVIS_SPECULAR_NDF:  the NDF maps' filtered moments, D = κ₀ g(d)/√det S;
//   SHVIS_SPECULAR_NDFN: the same with the per-texel 1/N of the maps.
// g(t) = max(0, 1 − t/16)^8 (Pearson type II, m = 8), d = (h − u)ᵀ S⁻¹ (h − u) in the
// normal map's tangent space, S = E[xxᵀ] − uuᵀ. The study's own pass (ndf/specular.frag)
// and every technique's ending (diffuse_out.glsl, `--specular`) evaluate it here; the
// world position comes from the vertex stage (SHVIS_GBUFFER).
#ifndef SHVIS_SPECULAR_GLSL
#define SHVIS_SPECULAR_GLSL

#ifdef SHVIS_SPECULAR
#ifndef SHVIS_SPECULAR_MIP
#error "the specular filtering ids are not defined (render::specular::filter_ids)"
#endif

layout(std140, set = 0, binding = SHVIS_BINDING_SPECULAR_PARAMS) uniform SpecularParams {
    layout(offset = 0) vec4 light_dir;       // xyz: unit, toward the light
    layout(offset = 16) vec4 light_radiance; // rgb: k_s · E
    layout(offset = 32) float sigma;         // base spread of a full-resolution texel
    layout(offset = 36) float kappa0;        // 1 / N(n, σ²I)
} specular_params;

#if SHVIS_SPECULAR != SHVIS_SPECULAR_MIP
#if SHVIS_PATH_DX9
// (E[x], E[y], E[z], 1/N), (E[xx], E[yy], E[zz], ·), (E[xy], E[xz], E[yz], ·)
layout(set = 0, binding = SHVIS_BINDING_SPECULAR_MOMENTS) uniform sampler2D specular_moments_tex[3];
#define SPECULAR_MOMENTS(k) SAMPLE_MATERIAL(specular_moments_tex[k], in_uv_material)
#else
layout(set = 0, binding = SHVIS_BINDING_SPECULAR_MOMENTS) uniform sampler2DArray specular_moments_tex;
#define SPECULAR_MOMENTS(k) SAMPLE_MATERIAL(specular_moments_tex, vec3(in_uv_material, float(k)))
#endif
#endif

float pearson(float t) {
    float b = max(0.0, 1.0 - t / 16.0);
    b *= b;
    b *= b;
    return b * b;
}

vec3 specular_radiance() {
    vec3 n = normalize(in_normal_world);
    vec3 v = normalize(frame.camera_position.xyz - in_position_world);
    vec3 l = specular_params.light_dir.xyz;
    if (dot(n, l) <= 0.0 || dot(n, v) <= 0.0) {
        return vec3(0.0);
    }
    mat3 f;
    tangent_frame(f);
    vec3 h = normalize(l + v);
    vec3 h_ts = h * f; // (h·t, h·b, h·n)
#if SHVIS_SPECULAR == SHVIS_SPECULAR_MIP
    vec3 r = h_ts - tangent_space_normal();
    float s2 = specular_params.sigma * specular_params.sigma;
    float density = specular_params.kappa0 * pearson(dot(r, r) / s2) / (s2 * specular_params.sigma);
#else
    vec4 m0 = SPECULAR_MOMENTS(0);
    vec4 m1 = SPECULAR_MOMENTS(1);
    vec4 m2 = SPECULAR_MOMENTS(2);
    vec3 u = m0.xyz;
    mat3 second = mat3(m1.x, m2.x, m2.y,
                       m2.x, m1.y, m2.z,
                       m2.y, m2.z, m1.z);
    mat3 s = second - outerProduct(u, u);
    float det = determinant(s);
    vec3 r = h_ts - u;
    float density = det > 0.0 ? pearson(dot(r, inverse(s) * r)) / sqrt(det) : 0.0;
#if SHVIS_SPECULAR == SHVIS_SPECULAR_NDF
    density *= specular_params.kappa0;
#else
    density *= m0.w;
#endif
#endif
    return specular_params.light_radiance.rgb * density;
}

#endif
#endif
