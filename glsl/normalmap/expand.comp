#version 450
// One border-expansion pass (Gumbau et al. §3.5), the GPU twin of
// src/normalmap/mod.rs::expand_borders: an empty texel (w = 0) with non-empty
// 8-neighbours becomes their normalized mean, w = 0.5. Reads texels[src + i], writes
// texels[dst + i] (two halves of one buffer, ping-pong).

layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) buffer Texels {
    vec4 texels[];
};

layout(push_constant) uniform Push {
    uint res;
    uint src;
    uint dst;
} push;

void main() {
    uvec2 p = gl_GlobalInvocationID.xy;
    if (p.x >= push.res || p.y >= push.res) {
        return;
    }
    uint i = p.y * push.res + p.x;
    vec4 c = texels[push.src + i];
    if (c.w > 0.0) {
        texels[push.dst + i] = c;
        return;
    }
    vec3 sum = vec3(0.0);
    uint count = 0u;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 q = ivec2(p) + ivec2(dx, dy);
            if ((dx == 0 && dy == 0) || any(lessThan(q, ivec2(0))) ||
                any(greaterThanEqual(q, ivec2(push.res)))) {
                continue;
            }
            vec4 n = texels[push.src + uint(q.y) * push.res + uint(q.x)];
            if (n.w > 0.0) {
                sum += n.xyz;
                count += 1u;
            }
        }
    }
    texels[push.dst + i] = (count > 0u && length(sum) > 1e-6) ? vec4(normalize(sum), 0.5)
                                                              : vec4(0.0);
}
