//! Arbitrary bytes as an environment map (OpenEXR or Radiance HDR, by magic bytes) through
//! `shvis::env::equirect::load_from_slice`. Errors are expected; a panic, an abort or a
//! runaway allocation is a bug (headers are sized against the budget before decoding).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = shvis::env::equirect::load_from_slice(data);
});
