// Sphere parameterizations on the GPU: the Shirley–Chiu concentric map, the shrunk dual
// paraboloid / dual orthographic maps and cube face selection. Mirrors src/sphere (see its
// module docs for the conventions: hemisphere 0 is y ≥ 0, disk = world (x, z), the square
// shrunk so the equator lands on the outer ring of texel centres; cube faces in Vulkan
// order +X, −X, +Y, −Y, +Z, −Z).
#ifndef SHVIS_SPHERE_GLSL
#define SHVIS_SPHERE_GLSL

#include "math.glsl"

// Unit disk → square [−1, 1]² (Shirley & Chiu 1997); src/sphere/concentric.rs.
vec2 concentric_disk_to_square(vec2 q) {
    const float quarter_pi = PI / 4.0;
    float r = length(q);
    if (r == 0.0) {
        return vec2(0.0);
    }
    if (abs(q.x) >= abs(q.y)) {
        float a = q.x >= 0.0 ? r : -r;
        return vec2(a, a * atan(q.y / q.x) / quarter_pi);
    }
    float b = q.y >= 0.0 ? r : -r;
    return vec2(b * atan(q.x / q.y) / quarter_pi, b);
}

// Square [−1, 1]² → texture coordinates of one hemisphere image, shrunk so s = ±1 lands on
// the centres of texels 0 and res − 1.
vec2 dual_square_to_uv(vec2 s, float res) {
    return 0.5 + clamp(s, -1.0, 1.0) * ((res - 1.0) / (2.0 * res));
}

// (u, v, hemisphere) of unit direction d in the dual paraboloid map (Heidrich & Seidel 1998).
vec3 dual_paraboloid_dir_to_uv(vec3 d, float res) {
    vec2 disk = d.xz / (1.0 + abs(d.y));
    return vec3(dual_square_to_uv(concentric_disk_to_square(disk), res), d.y < 0.0 ? 1.0 : 0.0);
}

// (u, v, hemisphere) of unit direction d in the dual orthographic map.
vec3 dual_ortho_dir_to_uv(vec3 d, float res) {
    vec2 disk = d.xz;
    float r2 = dot(disk, disk);
    disk = r2 > 1.0 ? disk * inversesqrt(r2) : disk;
    return vec3(dual_square_to_uv(concentric_disk_to_square(disk), res), d.y < 0.0 ? 1.0 : 0.0);
}

// (s, t, face) of direction d by the Vulkan cube face-selection table; ties go to X, then Y.
vec3 cube_dir_to_face_st(vec3 d) {
    vec3 a = abs(d);
    float face;
    float sc;
    float tc;
    float ma;
    if (a.x >= a.y && a.x >= a.z) {
        face = d.x < 0.0 ? 1.0 : 0.0;
        ma = a.x;
        sc = d.x < 0.0 ? d.z : -d.z;
        tc = -d.y;
    } else if (a.y >= a.z) {
        face = d.y < 0.0 ? 3.0 : 2.0;
        ma = a.y;
        sc = d.x;
        tc = d.y < 0.0 ? -d.z : d.z;
    } else {
        face = d.z < 0.0 ? 5.0 : 4.0;
        ma = a.z;
        sc = d.z < 0.0 ? -d.x : d.x;
        tc = -d.y;
    }
    return vec3(0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0), face);
}

#endif
