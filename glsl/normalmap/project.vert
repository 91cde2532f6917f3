#version 450
// One render of the high mesh per low triangle T (Gumbau et al. §3.1): gl_InstanceIndex is
// T (the draw's firstInstance). View along T's normal (eqs. (1)-(2)), vertex mirroring
// through T's plane (eq. (6)), pseudo-orthographic projection onto T's texels (eqs. (3)-(5)).
#include "normalmap_project.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;

layout(location = 0) out vec3 out_normal;
layout(location = 1) flat out uint out_triangle;

void main() {
    uint t = uint(gl_InstanceIndex);
    vec4 w = views[t].view_from_world * vec4(in_position, 1.0);
    if (push.mirror != 0u) {
        // k = signed distance to T's plane (z = -D in view space); every vertex goes
        // behind the plane, so the depth test keeps the surface nearest T on either side.
        float k = w.z + push.max_distance;
        w.z = -push.max_distance - abs(k);
    }
    gl_Position = views[t].clip_from_view * w;
    out_normal = in_normal;
    out_triangle = t;
}
