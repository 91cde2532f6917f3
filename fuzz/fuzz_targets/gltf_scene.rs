//! Arbitrary bytes as a `.glb` or `.gltf` (embedded data only) through the scene loader,
//! `shvis::scene::gltf::load_from_slice`. Errors are expected; a panic, an abort or a
//! runaway allocation is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

/// Small enough for fast runs, large enough for dozens of generated charts.
const LIGHTMAP_RES: u32 = 64;

fuzz_target!(|data: &[u8]| {
    let _ = shvis::scene::gltf::load_from_slice(data, LIGHTMAP_RES);
});
