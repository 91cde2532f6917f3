//! shvis — reference implementation of *Normal Mapping with Low-Frequency Precomputed
//! Visibility* (Iwanicki & Sloan) and the techniques around it.
//!
//! Data flows one way (DESIGN §5): scene + env → bake → lighting prep → GPU upload per
//! technique and path → frames with timestamps → readback → metrics → report. The modules
//! stand in [`LAYERS`], lowest first: a module uses only modules of lower layers, or of its
//! own layer without closing a cycle (tests/layering.rs reads every `crate::` path of
//! `src/` against it). `sh`, `sphere`, `env`, `scene` and `bake` know nothing of Vulkan;
//! `gpu` knows nothing of SH; `technique` is where they meet; the cost model (`cost`) is a
//! client of techniques, asked by the bench and the probe, never part of building one.
//!
//! Unsafe code is denied everywhere but in [`UNSAFE_MODULES`]: `gpu` (Vulkan), the bake's
//! SIMD ray traversal (`bake::trace`), the transfer bake's AVX2 sums (`bake::outer`) and `files` (the SIGINT/SIGTERM handler that removes
//! temporaries, and with the `test-hooks` feature the hooks that kill or interrupt the
//! process mid-write); each block says why it is sound (`// SAFETY:`).
#![deny(unsafe_code)]

pub mod attribution;
pub mod bake;
pub mod bench;
pub mod cost;
pub mod env;
pub mod export;
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

/// The crate's layers, lowest first. The command line (`src/cli`, in the binary) stands
/// above them all.
pub const LAYERS: &[&[&str]] = &[
    // Foundations: Vulkan, SH and sphere maths, the resource budget.
    &["gpu", "sh", "sphere", "limits"],
    // Files: atomic writes, hashes, output folders.
    &["files"],
    &["env"],
    &["scene"],
    // CPU bakes, the normal distribution's moments, the cost model's vocabulary.
    &["bake", "ndf", "cost"],
    // The scene on the GPU and its frames.
    &["render"],
    &["technique"],
    &["reference"],
    &["probe"],
    &["report"],
    &["prepare"],
    &["attribution", "normalmap"],
    // The commands' work.
    &["bench", "study", "relight", "view", "tools", "export"],
];

/// The modules (paths from the crate root) where `unsafe` is allowed; nowhere else does
/// `#[allow(unsafe_code)]` appear.
pub const UNSAFE_MODULES: &[&str] = &["gpu", "bake::trace", "bake::outer", "files"];
