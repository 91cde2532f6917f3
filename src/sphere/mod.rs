//! Sphere parameterizations (in progress).
