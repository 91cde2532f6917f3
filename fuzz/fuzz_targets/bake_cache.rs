//! Arbitrary bytes as a visibility bake cache file through
//! `shvis::bake::cache::decode_visibility` (16² texels, order 3, a fixed key). The first
//! fuzz byte chooses whether the header's length and checksum are fixed up, so that the
//! payload's own checks are reached. Errors are expected; a panic is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;
use shvis::bake::cache::{HEADER_BYTES, decode_visibility, hash64};
use shvis::sh::Order;

const KEY: u64 = 0x1234_5678_9abc_def0;

fuzz_target!(|data: &[u8]| {
    let Some((&fix, rest)) = data.split_first() else {
        return;
    };
    let mut bytes = rest.to_vec();
    if fix & 1 == 1 && bytes.len() >= HEADER_BYTES {
        let len = (bytes.len() - HEADER_BYTES) as u64;
        let h = hash64(&bytes[HEADER_BYTES..]);
        bytes[24..32].copy_from_slice(&len.to_le_bytes());
        bytes[32..40].copy_from_slice(&h.to_le_bytes());
    }
    let order = Order::new(3).expect("order 3");
    if let Ok(map) = decode_visibility(&bytes, KEY, 16, order) {
        assert!(map.coeffs.iter().all(|c| c.is_finite()));
        assert!(map.ao.iter().all(|a| (0.0..=1.0).contains(a)));
    }
});
