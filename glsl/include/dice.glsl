// Ambient Dice (Iwanicki & Sloan 2017; src/sh/dice.rs, whose module doc has the geometry,
// the hybrid cubic Bézier (1)–(2) and the YCoCg variant). The includer defines
//   SHVIS_DICE_FACES    faces in the table,
//   SHVIS_DICE_YCOCG    1: Y hybrid, Co and Cg linear; 0: RGB hybrid,
//   DICE_FACE(k)        vec4 k of the face table (src/technique/hemisphere.rs, dice_face_table),
//   DICE_READ(g)        vec4 group g of the texel's stored values (computed g),
// and gets dice_irradiance(m) at a tangent-space direction m.
#ifndef SHVIS_DICE_GLSL
#define SHVIS_DICE_GLSL

#include "unroll.glsl"
#if SHVIS_DICE_YCOCG
#define DICE_PER_VERTEX 5
#else
#define DICE_PER_VERTEX 9
#endif

// m with z raised to ≥ 0, unit (+z when nothing is left): the table covers z ≥ 0.
vec3 dice_lift(vec3 m) {
    vec3 l = vec3(m.xy, max(m.z, 0.0));
    float len = length(l);
    return len > 0.0 ? l / len : vec3(0.0, 0.0, 1.0);
}

// The face holding m (nearest centre), its three stored vertices and each vertex's
// weights on (value, du, dv) and on the linear interpolation.
void dice_weights(vec3 m, out ivec3 vertex, out vec3 w_value, out vec3 w_du, out vec3 w_dv,
                  out vec3 b) {
    int face = 0;
    float best = -2.0;
    UNROLL for (int f = 0; f < SHVIS_DICE_FACES; ++f) {
        float d = dot(m, DICE_FACE(7 * f).xyz);
        if (d > best) {
            best = d;
            face = f;
        }
    }
    int k = 7 * face;
    vec4 d0 = DICE_FACE(k + 1);
    vec4 d1 = DICE_FACE(k + 2);
    vec4 d2 = DICE_FACE(k + 3);
    vertex = ivec3(int(d0.w), int(d1.w), int(d2.w));
    vec3 lambda = vec3(dot(d0.xyz, m), dot(d1.xyz, m), dot(d2.xyz, m));
    b = lambda / (lambda.x + lambda.y + lambda.z);
    // Bernstein weights: corners, edge points e[3i + j] (next to v_i on edge ij), centre.
    vec3 corner = b * b * b;
    float e[9];
    UNROLL for (int i = 0; i < 3; ++i) {
        UNROLL for (int j = 0; j < 3; ++j) {
            e[3 * i + j] = i == j ? 0.0 : 3.0 * b[i] * b[i] * b[j];
        }
    }
    float centre = 6.0 * b.x * b.y * b.z;
    float pair = b.x * b.y + b.y * b.z + b.z * b.x;
    vec3 omega = pair > 1e-30 ? vec3(b.y * b.z, b.z * b.x, b.x * b.y) / pair : vec3(1.0 / 3.0);
    // (2): the candidate of the edge opposite v_i, weighted by ω_i.
    UNROLL for (int i = 0; i < 3; ++i) {
        int j = (i + 1) % 3;
        int l = (i + 2) % 3;
        float w = centre * omega[i];
        e[3 * j + l] += 0.25 * w;
        e[3 * l + j] += 0.25 * w;
        e[3 * j + i] += 0.5 * w;
        e[3 * l + i] += 0.5 * w;
        corner[j] -= 0.25 * w;
        corner[l] -= 0.25 * w;
    }
    // (1): edge point i→j = f_i + (du_i t_u,i·v_j + dv_i t_v,i·v_j)/3; the factors toward
    // v_i's two others in increasing order are in .xy and .zw.
    UNROLL for (int i = 0; i < 3; ++i) {
        vec4 t = DICE_FACE(k + 4 + i);
        int first = i == 0 ? 1 : 0;
        int second = i == 2 ? 1 : 2;
        float ef = e[3 * i + first];
        float es = e[3 * i + second];
        w_value[i] = corner[i] + ef + es;
        w_du[i] = (ef * t.x + es * t.z) / 3.0;
        w_dv[i] = (ef * t.y + es * t.w) / 3.0;
    }
}

// Irradiance (RGB, in the stored values' scale) at tangent-space m.
vec3 dice_irradiance(vec3 m) {
    ivec3 vertex;
    vec3 w_value, w_du, w_dv, b;
    dice_weights(dice_lift(m), vertex, w_value, w_du, w_dv, b);
    vec3 sum = vec3(0.0);
    vec3 chroma = vec3(0.0);
    UNROLL for (int i = 0; i < 3; ++i) {
        // A vertex's values start at offset base of its first group; they span 3 groups
        // (9 values) or 2 (5 values) whatever the offset.
        int base = DICE_PER_VERTEX * vertex[i];
        int g = base / 4;
        int o = base - 4 * g;
        float t[12];
        vec4 r0 = DICE_READ(g);
        vec4 r1 = DICE_READ(g + 1);
        t[0] = r0.x; t[1] = r0.y; t[2] = r0.z; t[3] = r0.w;
        t[4] = r1.x; t[5] = r1.y; t[6] = r1.z; t[7] = r1.w;
#if SHVIS_DICE_YCOCG
        t[8] = 0.0; t[9] = 0.0; t[10] = 0.0; t[11] = 0.0;
        sum.x += w_value[i] * t[o] + w_du[i] * t[o + 1] + w_dv[i] * t[o + 2];
        chroma.xy += b[i] * vec2(t[o + 3], t[o + 4]);
#else
        vec4 r2 = DICE_READ(g + 2);
        t[8] = r2.x; t[9] = r2.y; t[10] = r2.z; t[11] = r2.w;
        sum += w_value[i] * vec3(t[o], t[o + 1], t[o + 2])
            + w_du[i] * vec3(t[o + 3], t[o + 4], t[o + 5])
            + w_dv[i] * vec3(t[o + 6], t[o + 7], t[o + 8]);
#endif
    }
#if SHVIS_DICE_YCOCG
    float y = sum.x;
    float co = chroma.x;
    float cg = chroma.y;
    return vec3(y + co - cg, y + cg, y - co - cg);
#else
    return sum;
#endif
}

#endif
