// The ending every diffuse technique shares: radiance = albedo/π · irradiance, plus the
// specular material term when the scene has one (`--specular`, specular.glsl), written to
// the colour target (alpha 1 marks covered pixels for the readback).
#ifndef SHVIS_DIFFUSE_OUT_GLSL
#define SHVIS_DIFFUSE_OUT_GLSL

#include "specular.glsl"

layout(location = 0) out vec4 out_radiance;

void write_diffuse(vec3 irradiance) {
    vec3 radiance = material_albedo() / PI * irradiance;
#ifdef SHVIS_SPECULAR
    radiance += specular_radiance();
#endif
    out_radiance = vec4(radiance, 1.0);
}

#endif
