//! shvis — reference implementation of *Normal Mapping with Low-Frequency Precomputed
//! Visibility* (Iwanicki & Sloan) and the techniques around it.
//!
//! Data flows one way (DESIGN §5): scene + env → bake → lighting prep → GPU upload per
//! technique and path → frames with timestamps → readback → metrics → report.
//! `sh`, `env`, `scene` and `bake` know nothing of Vulkan; `gpu` knows nothing of SH;
//! `technique` is where they meet. Unsafe code lives in `gpu` only.
#![deny(unsafe_code)]

pub mod attribution;
pub mod bake;
pub mod bench;
pub mod env;
pub mod files;
#[allow(unsafe_code)]
pub mod gpu;
pub mod limits;
pub mod ndf;
pub mod normalmap;
pub mod prepare;
pub mod probe;
pub mod reference;
pub mod relight;
pub mod render;
pub mod report;
pub mod scene;
pub mod sh;
pub mod sphere;
pub mod study;
pub mod technique;
pub mod tools;
pub mod view;
