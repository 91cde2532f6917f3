// UNROLL before a loop of a constant trip count: the loop is unrolled in the SPIR-V, which
// the cost model counts as written (src/cost/spirv.rs), so each iteration is counted — a
// loop left in would be counted once. A shader that keeps its loops in the drawn build
// (cluster.frag, whose count builds unroll them) defines UNROLL itself first. Where the
// compiler has no loop attributes (an engine's WebGL compiler reading decode.glsl), UNROLL
// is nothing and the loops stay loops.
#ifndef SHVIS_UNROLL_GLSL
#define SHVIS_UNROLL_GLSL
#ifndef UNROLL
#ifdef GL_EXT_control_flow_attributes
#extension GL_EXT_control_flow_attributes : enable
#define UNROLL [[unroll]]
#else
#define UNROLL
#endif
#endif
#endif
