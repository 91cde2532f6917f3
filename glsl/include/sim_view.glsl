// The GPU visibility simulator's view of one direction d (src/gpu/visibility_sim.rs):
// an orthographic projection along d of the scene's bounding box onto the plane spanned
// by u, v, the window fitted to the box's projection. "sky" is a point's distance below
// the plane facing d that touches the box: nearer the sky = smaller. Shared by
// depth.vert and mark.comp.
layout(push_constant) uniform DirectionView {
    vec4 axis_u;      // xyz: the image's x axis; w: the window's centre along it
    vec4 axis_v;      // xyz: the image's y axis; w: the window's centre along it
    vec4 axis_d;      // xyz: the direction d (towards the sky); w: the sky plane along it
    vec4 centre;      // xyz: the box centre c (origin of the coordinates); w: constant bias, metres
    vec4 window;      // x, y: the window's half extents along u, v; z: sky range; w: bias per unit tan θ, metres
    uint res;         // depth-map texels per side
    uint direction;   // index of d in the bake's direction set
    uint point_count;
    uint mask_words;  // 32-bit mask words per point
    float t_min;      // smallest hit distance counted by the exact test, metres (the CPU tracer's)
    float epsilon;    // the ray origins' offset along the normal, metres (the CPU tracer's)
    uvec2 pad;
} push;

// (x, y) in [-1, 1]² and the sky distance of world point p.
vec3 sim_view(vec3 p) {
    vec3 q = p - push.centre.xyz;
    return vec3((dot(q, push.axis_u.xyz) - push.axis_u.w) / push.window.x,
                (dot(q, push.axis_v.xyz) - push.axis_v.w) / push.window.y,
                push.axis_d.w - dot(q, push.axis_d.xyz));
}
