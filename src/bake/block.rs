//! Block compression of per-texel data as DX11-class hardware stores it: 4 × 4 texels in
//! 16 bytes (1 byte per texel), BC6H for unsigned half-float RGB, BC7 for 8-bit RGBA; BC4
//! for one 8-bit channel in 8 bytes (half a byte per texel).
//!
//! Encoding is Intel's ISPC Texture Compressor (`intel_tex_2`, prebuilt kernels) at a chosen
//! quality; decoding — the CPU's view of what the GPU will read, for the error ladder and
//! the tests — is `bcdec_rs`, an independent decoder, so an encoder bug cannot hide behind
//! a matching decoder of our own.
//!
//! BC6H here is the unsigned variant (the encoder writes no other): values must lie in
//! [0, 65504]. Whatever does not — negative, non-finite, or above the largest half — is
//! clamped and counted ([`Clamped`]) for the caller to report; nothing is clamped silently.
//! A side that is not a multiple of 4 is padded by repeating the last row and column.

use half::f16;

/// Largest finite half float, BC6H's ceiling.
pub const HALF_MAX: f32 = 65504.0;

/// Bytes per 4 × 4 block (BC6H and BC7).
pub const BLOCK_BYTES: usize = 16;

/// Bytes per 4 × 4 BC4 block.
pub const BC4_BLOCK_BYTES: usize = 8;

/// The encoder's BC6H quality settings, fastest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Bc6hQuality {
    VeryFast,
    Fast,
    Basic,
    Slow,
    VerySlow,
}

impl Bc6hQuality {
    pub const ALL: [Bc6hQuality; 5] = [
        Bc6hQuality::VeryFast,
        Bc6hQuality::Fast,
        Bc6hQuality::Basic,
        Bc6hQuality::Slow,
        Bc6hQuality::VerySlow,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Bc6hQuality::VeryFast => "very-fast",
            Bc6hQuality::Fast => "fast",
            Bc6hQuality::Basic => "basic",
            Bc6hQuality::Slow => "slow",
            Bc6hQuality::VerySlow => "very-slow",
        }
    }

    fn settings(self) -> intel_tex_2::bc6h::EncodeSettings {
        use intel_tex_2::bc6h;
        match self {
            Bc6hQuality::VeryFast => bc6h::very_fast_settings(),
            Bc6hQuality::Fast => bc6h::fast_settings(),
            Bc6hQuality::Basic => bc6h::basic_settings(),
            Bc6hQuality::Slow => bc6h::slow_settings(),
            Bc6hQuality::VerySlow => bc6h::very_slow_settings(),
        }
    }
}

/// The encoder's BC7 quality settings (with alpha), fastest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Bc7Quality {
    UltraFast,
    VeryFast,
    Fast,
    Basic,
    Slow,
}

impl Bc7Quality {
    pub const ALL: [Bc7Quality; 5] = [
        Bc7Quality::UltraFast,
        Bc7Quality::VeryFast,
        Bc7Quality::Fast,
        Bc7Quality::Basic,
        Bc7Quality::Slow,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Bc7Quality::UltraFast => "ultra-fast",
            Bc7Quality::VeryFast => "very-fast",
            Bc7Quality::Fast => "fast",
            Bc7Quality::Basic => "basic",
            Bc7Quality::Slow => "slow",
        }
    }

    fn settings(self, alpha: bool) -> intel_tex_2::bc7::EncodeSettings {
        use intel_tex_2::bc7;
        match (self, alpha) {
            (Bc7Quality::UltraFast, true) => bc7::alpha_ultra_fast_settings(),
            (Bc7Quality::VeryFast, true) => bc7::alpha_very_fast_settings(),
            (Bc7Quality::Fast, true) => bc7::alpha_fast_settings(),
            (Bc7Quality::Basic, true) => bc7::alpha_basic_settings(),
            (Bc7Quality::Slow, true) => bc7::alpha_slow_settings(),
            (Bc7Quality::UltraFast, false) => bc7::opaque_ultra_fast_settings(),
            (Bc7Quality::VeryFast, false) => bc7::opaque_very_fast_settings(),
            (Bc7Quality::Fast, false) => bc7::opaque_fast_settings(),
            (Bc7Quality::Basic, false) => bc7::opaque_basic_settings(),
            (Bc7Quality::Slow, false) => bc7::opaque_slow_settings(),
        }
    }
}

/// Values an encoder clamped into its range.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Clamped {
    /// Negative or not a number: stored as 0.
    pub below: u64,
    /// Above [`HALF_MAX`] (or +∞): stored as [`HALF_MAX`].
    pub above: u64,
}

impl Clamped {
    pub fn add(&mut self, other: Clamped) {
        self.below += other.below;
        self.above += other.above;
    }
}

/// Bytes of the BC6H or BC7 blocks of a `res` × `res` image (the side padded to a
/// multiple of 4).
pub fn compressed_bytes(res: u32) -> usize {
    let blocks = res.div_ceil(4) as usize;
    blocks * blocks * BLOCK_BYTES
}

/// The `res` × `res` image of `C`-byte texels padded to a multiple of 4 on each side
/// ([`source_index`]), row-major: what the encoder reads.
fn padded<const C: usize>(texels: &[[u8; C]], res: u32) -> (Vec<u8>, u32) {
    assert_eq!(texels.len(), (res * res) as usize, "res² texels");
    let side = res.div_ceil(4) * 4;
    let mut data = Vec::with_capacity((side * side) as usize * C);
    for y in 0..side {
        for x in 0..side {
            data.extend_from_slice(&texels[source_index(res, x, y)]);
        }
    }
    (data, side)
}

/// Texel (x, y) of the padded image: the nearest texel of the `res`-sided source.
fn source_index(res: u32, x: u32, y: u32) -> usize {
    (y.min(res - 1) * res + x.min(res - 1)) as usize
}

/// BC6H (unsigned) blocks of the RGB image `rgb` (`res` × `res`, row-major), and what was
/// clamped into [0, 65504].
///
/// # Panics
/// If `rgb` does not hold res² texels.
pub fn encode_bc6h(rgb: &[[f32; 3]], res: u32, quality: Bc6hQuality) -> (Vec<u8>, Clamped) {
    assert_eq!(rgb.len(), (res * res) as usize, "res² texels");
    let side = res.div_ceil(4) * 4;
    let mut clamped = Clamped::default();
    let mut data = Vec::with_capacity((side * side) as usize * 8);
    for y in 0..side {
        for x in 0..side {
            let inside = x < res && y < res;
            for &v in &rgb[source_index(res, x, y)] {
                let stored = if v.is_nan() || v < 0.0 {
                    clamped.below += u64::from(inside);
                    0.0
                } else if v > HALF_MAX {
                    clamped.above += u64::from(inside);
                    HALF_MAX
                } else {
                    v
                };
                data.extend_from_slice(&f16::from_f32(stored).to_le_bytes());
            }
            data.extend_from_slice(&[0, 0]);
        }
    }
    let settings = quality.settings();
    let blocks = in_bands(&data, side, 8, |band, height| {
        intel_tex_2::bc6h::compress_blocks(
            &settings,
            &intel_tex_2::RgbaSurface {
                data: band,
                width: side,
                height,
                stride: side * 8,
            },
        )
    });
    (blocks, clamped)
}

/// The `res` × `res` image of `C`-channel texels that `blocks` decode to, each block by
/// `decode` (its 4 × 4 texels row-major into the scratch slice).
fn decode_blocks<T: Copy + Default, const C: usize>(
    blocks: &[u8],
    res: u32,
    block_bytes: usize,
    decode: impl Fn(&[u8], &mut [T]),
) -> Vec<[T; C]> {
    let per_side = res.div_ceil(4) as usize;
    assert_eq!(
        blocks.len(),
        per_side * per_side * block_bytes,
        "blocks of a res² image"
    );
    let res = res as usize;
    let mut out = vec![[T::default(); C]; res * res];
    let mut texels = vec![T::default(); 16 * C];
    for (b, block) in blocks.chunks_exact(block_bytes).enumerate() {
        let (bx, by) = (b % per_side, b / per_side);
        decode(block, &mut texels);
        for j in 0..4 {
            for i in 0..4 {
                let (x, y) = (4 * bx + i, 4 * by + j);
                if x < res && y < res {
                    out[y * res + x] = std::array::from_fn(|c| texels[(4 * j + i) * C + c]);
                }
            }
        }
    }
    out
}

/// The RGB image BC6H (unsigned) `blocks` of a `res` × `res` image decode to.
///
/// # Panics
/// If `blocks` is not [`compressed_bytes`]`(res)` long.
pub fn decode_bc6h(blocks: &[u8], res: u32) -> Vec<[f32; 3]> {
    decode_blocks(blocks, res, BLOCK_BYTES, |block, texels| {
        bcdec_rs::bc6h_float(block, texels, 12, false)
    })
}

/// BC7 blocks (the encoder's basic quality) of the RGBA8 image `rgba`; `alpha`: the alpha
/// channel holds data (else it is taken as opaque and decodes as 255).
///
/// # Panics
/// If `rgba` does not hold res² texels.
pub fn encode_bc7(rgba: &[[u8; 4]], res: u32, alpha: bool) -> Vec<u8> {
    encode_bc7_at(rgba, res, alpha, Bc7Quality::Basic)
}

/// [`encode_bc7`] at `quality`.
///
/// # Panics
/// If `rgba` does not hold res² texels.
pub fn encode_bc7_at(rgba: &[[u8; 4]], res: u32, alpha: bool, quality: Bc7Quality) -> Vec<u8> {
    let (data, side) = padded(rgba, res);
    let settings = quality.settings(alpha);
    in_bands(&data, side, 4, |band, height| {
        intel_tex_2::bc7::compress_blocks(
            &settings,
            &intel_tex_2::RgbaSurface {
                data: band,
                width: side,
                height,
                stride: side * 4,
            },
        )
    })
}

/// BC4 blocks of the one-channel 8-bit image `r`.
///
/// # Panics
/// If `r` does not hold res² texels.
pub fn encode_bc4(r: &[u8], res: u32) -> Vec<u8> {
    let texels: Vec<[u8; 1]> = r.iter().map(|&v| [v]).collect();
    let (data, side) = padded(&texels, res);
    in_bands(&data, side, 1, |band, height| {
        intel_tex_2::bc4::compress_blocks(&intel_tex_2::RSurface {
            data: band,
            width: side,
            height,
            stride: side,
        })
    })
}

/// Rows of blocks an encoder call takes at a time in [`in_bands`].
const BAND_BLOCK_ROWS: usize = 8;

/// The blocks of the padded `side` × `side` image `data` (`texel_bytes` per texel) as
/// `compress(band, rows)` gives them for bands of [`BAND_BLOCK_ROWS`] rows of blocks,
/// encoded in parallel and concatenated in order: the encoder takes every block on its
/// own, so these are the blocks of one call over the whole image.
fn in_bands(
    data: &[u8],
    side: u32,
    texel_bytes: usize,
    compress: impl Fn(&[u8], u32) -> Vec<u8> + Sync,
) -> Vec<u8> {
    use rayon::prelude::*;
    let band_bytes = BAND_BLOCK_ROWS * 4 * side as usize * texel_bytes;
    let row_bytes = side as usize * texel_bytes;
    let bands: Vec<Vec<u8>> = data
        .par_chunks(band_bytes.max(1))
        .map(|band| compress(band, (band.len() / row_bytes.max(1)) as u32))
        .collect();
    bands.concat()
}

/// The one-channel image BC4 `blocks` of a `res` × `res` image decode to.
///
/// # Panics
/// If `blocks` is not the blocks of a res² image.
pub fn decode_bc4(blocks: &[u8], res: u32) -> Vec<u8> {
    decode_blocks::<u8, 1>(blocks, res, BC4_BLOCK_BYTES, |block, texels| {
        bcdec_rs::bc4(block, texels, 4, false)
    })
    .into_iter()
    .map(|[v]| v)
    .collect()
}

/// The RGBA8 image BC7 `blocks` of a `res` × `res` image decode to.
///
/// # Panics
/// If `blocks` is not [`compressed_bytes`]`(res)` long.
pub fn decode_bc7(blocks: &[u8], res: u32) -> Vec<[u8; 4]> {
    decode_blocks(blocks, res, BLOCK_BYTES, |block, texels| {
        bcdec_rs::bc7(block, texels, 16)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coloured light whose intensity varies smoothly (BC6H interpolates each block
    /// along one line in RGB, as a lightmap's colours mostly are).
    fn smooth(res: u32) -> Vec<[f32; 3]> {
        (0..res * res)
            .map(|i| {
                let (x, y) = ((i % res) as f32 / res as f32, (i / res) as f32 / res as f32);
                let s = 1.0 + x + 0.5 * y * y;
                [s, 0.8 * s, 0.5 * s]
            })
            .collect()
    }

    #[test]
    fn bands_encode_the_blocks_of_one_call_over_the_image() {
        // 18 rows of blocks: two whole bands and a short one.
        let res = 72u32;
        let rgba: Vec<[u8; 4]> = (0..res * res)
            .map(|i| {
                let v = i.wrapping_mul(2654435761);
                [
                    v as u8,
                    (v >> 8) as u8,
                    (i / res * 3) as u8,
                    (v >> 16) as u8,
                ]
            })
            .collect();
        let (data, side) = padded(&rgba, res);
        let settings = Bc7Quality::Basic.settings(true);
        let whole = intel_tex_2::bc7::compress_blocks(
            &settings,
            &intel_tex_2::RgbaSurface {
                data: &data,
                width: side,
                height: side,
                stride: side * 4,
            },
        );
        assert_eq!(encode_bc7_at(&rgba, res, true, Bc7Quality::Basic), whole);
        let red: Vec<u8> = rgba.iter().map(|t| t[0]).collect();
        let whole = intel_tex_2::bc4::compress_blocks(&intel_tex_2::RSurface {
            data: &red,
            width: res,
            height: res,
            stride: res,
        });
        assert_eq!(encode_bc4(&red, res), whole);
        let rgb: Vec<[f32; 3]> = smooth(res)
            .iter()
            .zip(&rgba)
            .map(|(s, t)| [s[0] * f32::from(t[0]), s[1], s[2] + f32::from(t[1])])
            .collect();
        let (banded, _) = encode_bc6h(&rgb, res, Bc6hQuality::Fast);
        let halves: Vec<u8> = rgb
            .iter()
            .flat_map(|t| {
                let mut texel = [0u8; 8];
                for (c, &v) in t.iter().enumerate() {
                    texel[2 * c..2 * c + 2].copy_from_slice(&f16::from_f32(v).to_le_bytes());
                }
                texel
            })
            .collect();
        let whole = intel_tex_2::bc6h::compress_blocks(
            &Bc6hQuality::Fast.settings(),
            &intel_tex_2::RgbaSurface {
                data: &halves,
                width: res,
                height: res,
                stride: res * 8,
            },
        );
        assert_eq!(banded, whole);
    }

    #[test]
    fn bc6h_round_trips_a_smooth_image_within_a_few_per_cent() {
        for res in [16, 18] {
            let image = smooth(res);
            let (blocks, clamped) = encode_bc6h(&image, res, Bc6hQuality::Basic);
            assert_eq!(clamped, Clamped::default());
            assert_eq!(blocks.len(), compressed_bytes(res));
            let back = decode_bc6h(&blocks, res);
            for (a, b) in image.iter().zip(&back) {
                for c in 0..3 {
                    assert!(
                        (a[c] - b[c]).abs() <= 0.02 * a[c].abs().max(0.1),
                        "{a:?} {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn bc6h_clamps_what_it_cannot_hold_and_counts_it() {
        let mut image = smooth(8);
        image[0] = [-1.0, f32::NAN, 2.0];
        image[9] = [1e6, f32::INFINITY, 1.0];
        let (blocks, clamped) = encode_bc6h(&image, 8, Bc6hQuality::VeryFast);
        assert_eq!(clamped, Clamped { below: 2, above: 2 });
        let back = decode_bc6h(&blocks, 8);
        assert!(back.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
        assert!(back[9][0] > 0.5 * HALF_MAX, "{:?}", back[9]);
    }

    #[test]
    fn bc7_round_trips_a_smooth_image_within_a_few_levels() {
        let res = 12;
        let image: Vec<[u8; 4]> = (0..res * res)
            .map(|i| [(i % res * 20) as u8, (i / res * 20) as u8, 128, 255])
            .collect();
        let back = decode_bc7(&encode_bc7(&image, res, true), res);
        for (a, b) in image.iter().zip(&back) {
            for c in 0..4 {
                assert!(
                    (i32::from(a[c]) - i32::from(b[c])).abs() <= 6,
                    "{a:?} {b:?}"
                );
            }
        }
    }
}
