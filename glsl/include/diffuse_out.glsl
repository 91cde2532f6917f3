// The ending every diffuse technique shares: radiance = albedo/π · irradiance, written to
// the colour target (alpha 1 marks covered pixels for the readback).
#ifndef SHVIS_DIFFUSE_OUT_GLSL
#define SHVIS_DIFFUSE_OUT_GLSL

layout(location = 0) out vec4 out_radiance;

void write_diffuse(vec3 irradiance) {
    out_radiance = vec4(material_albedo() / PI * irradiance, 1.0);
}

#endif
