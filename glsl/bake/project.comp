#version 450
// The GPU visibility simulator's projection: per point, v_i = Σ_{r visible} w·y_i(d_r)
// (Iwanicki–Sloan eq. (4) by the bake's quadrature, src/bake/visibility.rs eq. (1)) from
// the mask the direction passes set, and the AO of the same rays,
// AO = Σ_visible n·d_r / Σ_{n·d_r > 0} n·d_r.
layout(local_size_x = 64) in;

layout(std430, set = 0, binding = 0) readonly buffer Points {
    vec4 points[];
};
layout(std430, set = 0, binding = 1) readonly buffer Masks {
    uint masks[];
};
// w·y_i(d_r), direction-major: weighted_basis[r * coeff_count + i].
layout(std430, set = 0, binding = 2) readonly buffer WeightedBasis {
    float weighted_basis[];
};
layout(std430, set = 0, binding = 3) readonly buffer Directions {
    vec4 directions[];
};
layout(std430, set = 0, binding = 4) writeonly buffer Coefficients {
    float coeffs[];
};
layout(std430, set = 0, binding = 5) writeonly buffer Occlusion {
    float ao[];
};

layout(push_constant) uniform Push {
    uint point_count;
    uint coeff_count;
    uint mask_words;
    uint direction_count;
} push;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= push.point_count) {
        return;
    }
    vec3 normal = points[2 * i + 1].xyz;
    uint first = i * push.mask_words;
    for (uint k = 0u; k < push.coeff_count; k++) {
        float sum = 0.0;
        for (uint w = 0u; w < push.mask_words; w++) {
            uint bits = masks[first + w];
            while (bits != 0u) {
                int b = findLSB(bits);
                bits &= bits - 1u;
                sum += weighted_basis[(32u * w + uint(b)) * push.coeff_count + k];
            }
        }
        coeffs[i * push.coeff_count + k] = sum;
    }
    float up = 0.0;
    float visible = 0.0;
    for (uint r = 0u; r < push.direction_count; r++) {
        float c = dot(normal, directions[r].xyz);
        if (c > 0.0) {
            up += c;
            if ((masks[first + r / 32u] & (1u << (r % 32u))) != 0u) {
                visible += c;
            }
        }
    }
    ao[i] = up > 0.0 ? visible / up : 1.0;
}
