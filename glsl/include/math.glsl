// Constants every shader shares; π is defined here once.
#ifndef SHVIS_MATH_GLSL
#define SHVIS_MATH_GLSL

const float PI = 3.14159265358979323846;

#endif
