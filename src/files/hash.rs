//! Checksums and cache keys.
//!
//! [`hash64`] is FNV-1a over little-endian 64-bit words (odd 64-bit FNV prime), bytes of
//! a short tail folded one by one, and a SplitMix64 finalizer: every step is a bijection
//! of the state for a given input, so any change confined to one word (a flipped byte)
//! always changes the hash. It is a checksum and a cache key, not a cryptographic hash.

/// SplitMix64 finalizer (Steele et al. 2014): a well-mixed 64-bit hash.
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// 64-bit FNV prime.
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;
/// 64-bit FNV offset basis.
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// Incremental [`hash64`].
#[derive(Clone, Copy, Debug)]
pub struct Hasher64 {
    state: u64,
    len: u64,
}

impl Default for Hasher64 {
    fn default() -> Self {
        Hasher64 {
            state: FNV_OFFSET,
            len: 0,
        }
    }
}

impl Hasher64 {
    /// Folds `bytes` in (whole 64-bit words, then the tail byte by byte).
    pub fn write(&mut self, bytes: &[u8]) {
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            let word = u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]);
            self.state = (self.state ^ word).wrapping_mul(FNV_PRIME);
        }
        for &b in words.remainder() {
            self.state = (self.state ^ u64::from(b)).wrapping_mul(FNV_PRIME);
        }
        self.len = self.len.wrapping_add(bytes.len() as u64);
    }

    /// Folds a u64 in (little-endian).
    pub fn write_u64(&mut self, v: u64) {
        self.write(&v.to_le_bytes());
    }

    /// The hash of everything written.
    pub fn finish(&self) -> u64 {
        splitmix64(self.state ^ self.len)
    }
}

/// Hash of `bytes` (module doc).
pub fn hash64(bytes: &[u8]) -> u64 {
    let mut h = Hasher64::default();
    h.write(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_flipped_byte_changes_the_hash() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let h = hash64(&data);
        for i in [0, 7, 8, 500, 995, 999] {
            for bit in 0..8 {
                let mut d = data.clone();
                d[i] ^= 1 << bit;
                assert_ne!(hash64(&d), h, "byte {i} bit {bit}");
            }
        }
        assert_ne!(hash64(&data[..999]), h);
        assert_ne!(hash64(&[]), hash64(&[0]));
    }
}
