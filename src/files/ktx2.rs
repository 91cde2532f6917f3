//! A KTX2 writer (Khronos KTX File Format 2.0) for the images `shvis export` writes: one
//! level, no supercompression, a basic data format descriptor (Khronos Data Format 1.3)
//! for each format shvis stores.
//!
//! ```text
//! identifier · header (vkFormat, typeSize, width, height, depth 0, layers, faces, levels 1,
//! supercompression 0) · index (DFD, key/value data, no global data) · level index ·
//! DFD · key/value data ("KTXorientation", "KTXwriter") · level 0, aligned to
//! lcm(block bytes, 4): layer-major, then face, then rows
//! ```
//!
//! The DFD is the one libktx writes for the format (Khronos `dfdutils`, `createDFDPacked`
//! and `createDFDCompressed`): BT.709 primaries, linear transfer, straight alpha, and each
//! sample's bounds as libktx sets them — 0 … 2^bits − 1 for UNORM, 0 … 0xFFFFFFFF for a
//! UNORM block (BC4, BC7), −1.0 … 1.0 for SFLOAT and 0.0 … 1.0 for a UFLOAT block (BC6H), as
//! f32 bits. Rows run down from the image's top-left texel (v = 0 first): orientation "rd".

use ash::vk;

/// The file identifier «KTX 20».
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// The `KTXorientation` of every file: rows run right and down from the first texel.
pub const ORIENTATION: &str = "rd";

/// What one KTX2 file holds: `layers` array layers (0: not an array) of `faces` faces (1,
/// or 6 for a cube) of `width` × `height` texels of `format`, in `data` (level 0).
pub struct Ktx2Image<'a> {
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    pub faces: u32,
    pub data: &'a [u8],
}

/// Format facts of the DFD: (colour model, block side, bytes per block, type size,
/// samples as (bit offset, bit length − 1, channel type, lower, upper)).
type Sample = (u16, u8, u8, u32, u32);

fn describe(format: vk::Format) -> Option<(u8, u8, u8, u32, Vec<Sample>)> {
    const RGBSDA: u8 = 1;
    const BC4: u8 = 131;
    const BC6H: u8 = 133;
    const BC7: u8 = 134;
    const FLOAT: u8 = 0x80;
    const SIGNED: u8 = 0x40;
    const ALPHA: u8 = 15;
    let (minus_one, one) = ((-1f32).to_bits(), 1f32.to_bits());
    let float_rgba = |bits: u16| -> Vec<Sample> {
        [0u8, 1, 2, ALPHA]
            .iter()
            .enumerate()
            .map(|(i, &c)| {
                (
                    bits * i as u16,
                    (bits - 1) as u8,
                    c | FLOAT | SIGNED,
                    minus_one,
                    one,
                )
            })
            .collect()
    };
    Some(match format {
        vk::Format::R16G16B16A16_SFLOAT => (RGBSDA, 1, 8, 2, float_rgba(16)),
        vk::Format::R32G32B32A32_SFLOAT => (RGBSDA, 1, 16, 4, float_rgba(32)),
        vk::Format::R16_SFLOAT => (
            RGBSDA,
            1,
            2,
            2,
            vec![(0, 15, FLOAT | SIGNED, minus_one, one)],
        ),
        vk::Format::R8G8B8A8_UNORM => (
            RGBSDA,
            1,
            4,
            1,
            [0u8, 1, 2, ALPHA]
                .iter()
                .enumerate()
                .map(|(i, &c)| (8 * i as u16, 7, c, 0, 255))
                .collect(),
        ),
        vk::Format::R8_UNORM => (RGBSDA, 1, 1, 1, vec![(0, 7, 0, 0, 255)]),
        vk::Format::BC4_UNORM_BLOCK => (BC4, 4, 8, 1, vec![(0, 63, 0, 0, u32::MAX)]),
        vk::Format::BC6H_UFLOAT_BLOCK => (BC6H, 4, 16, 1, vec![(0, 127, FLOAT, 0, one)]),
        vk::Format::BC7_UNORM_BLOCK => (BC7, 4, 16, 1, vec![(0, 127, 0, 0, u32::MAX)]),
        _ => return None,
    })
}

/// The bytes of a KTX2 file holding `image`, or `None` for a format it does not describe.
///
/// # Panics
/// If `image.data` is not the level's size.
pub fn encode(image: &Ktx2Image<'_>) -> Option<Vec<u8>> {
    let (model, side, block_bytes, type_size, samples) = describe(image.format)?;
    let blocks = |n: u32| u64::from(n.div_ceil(u32::from(side)));
    let level_bytes = blocks(image.width)
        * blocks(image.height)
        * u64::from(block_bytes)
        * u64::from(image.layers.max(1))
        * u64::from(image.faces);
    assert_eq!(image.data.len() as u64, level_bytes, "level 0's bytes");

    let mut dfd = Vec::new();
    let block_size = 24 + 16 * samples.len() as u32;
    dfd.extend_from_slice(&(4 + block_size).to_le_bytes());
    dfd.extend_from_slice(&0u32.to_le_bytes()); // vendor Khronos, basic descriptor
    dfd.extend_from_slice(&(2 | (block_size << 16)).to_le_bytes()); // version 2
    dfd.extend_from_slice(&[model, 1, 1, 0]); // BT.709 primaries, linear, straight alpha
    dfd.extend_from_slice(&[side - 1, side - 1, 0, 0]);
    dfd.extend_from_slice(&[block_bytes, 0, 0, 0, 0, 0, 0, 0]);
    for (offset, length, channel, lower, upper) in &samples {
        dfd.extend_from_slice(&offset.to_le_bytes());
        dfd.extend_from_slice(&[*length, *channel, 0, 0, 0, 0]);
        dfd.extend_from_slice(&lower.to_le_bytes());
        dfd.extend_from_slice(&upper.to_le_bytes());
    }

    // Pairs sorted by key, each padded to 4 bytes (KTX 2.0 §3.11).
    let mut kvd = Vec::new();
    let writer = format!("shvis {}", env!("CARGO_PKG_VERSION"));
    for (key, value) in [
        ("KTXorientation", ORIENTATION),
        ("KTXwriter", writer.as_str()),
    ] {
        let pair = format!("{key}\0{value}\0");
        kvd.extend_from_slice(&(pair.len() as u32).to_le_bytes());
        kvd.extend_from_slice(pair.as_bytes());
        kvd.resize(kvd.len().next_multiple_of(4), 0);
    }

    let level_index_at = 80usize;
    let dfd_at = level_index_at + 24;
    let kvd_at = dfd_at + dfd.len();
    let align = lcm(usize::from(block_bytes), 4);
    let data_at = (kvd_at + kvd.len()).next_multiple_of(align);

    let mut out = Vec::with_capacity(data_at + image.data.len());
    out.extend_from_slice(&IDENTIFIER);
    for v in [
        image.format.as_raw() as u32,
        type_size,
        image.width,
        image.height,
        0,
        image.layers,
        image.faces,
        1,
        0,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [
        dfd_at as u32,
        dfd.len() as u32,
        kvd_at as u32,
        kvd.len() as u32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&[0u8; 16]); // no supercompression global data
    for v in [data_at as u64, level_bytes, level_bytes] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    out.resize(data_at, 0);
    out.extend_from_slice(image.data);
    Some(out)
}

fn lcm(a: usize, b: usize) -> usize {
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    a / gcd(a, b) * b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_index_and_level_sit_where_the_format_says() {
        let data = vec![7u8; 2 * 16];
        let bytes = encode(&Ktx2Image {
            format: vk::Format::BC7_UNORM_BLOCK,
            width: 8,
            height: 4,
            layers: 0,
            faces: 1,
            data: &data,
        })
        .unwrap();
        assert_eq!(&bytes[..12], &IDENTIFIER);
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap());
        assert_eq!(u32_at(12), vk::Format::BC7_UNORM_BLOCK.as_raw() as u32);
        assert_eq!((u32_at(20), u32_at(24), u32_at(36)), (8, 4, 1));
        let (offset, length) = (u64_at(80) as usize, u64_at(88) as usize);
        assert_eq!(offset % 16, 0);
        assert_eq!(&bytes[offset..offset + length], &data[..]);
        assert_eq!(bytes.len(), offset + length);
        let (kvd_at, kvd_len) = (u32_at(56) as usize, u32_at(60) as usize);
        let kvd = &bytes[kvd_at..kvd_at + kvd_len];
        let first = u32::from_le_bytes(kvd[..4].try_into().unwrap()) as usize;
        assert_eq!(&kvd[4..4 + first], b"KTXorientation\0rd\0");
        assert!(kvd.windows(10).any(|w| w == b"KTXwriter\0"));
        assert!(
            encode(&Ktx2Image {
                format: vk::Format::D32_SFLOAT,
                width: 1,
                height: 1,
                layers: 0,
                faces: 1,
                data: &[0; 4],
            })
            .is_none()
        );
    }

    /// Each sample's lower and upper bound as libktx writes them for the format.
    #[test]
    fn sample_bounds_are_libktx_s() {
        let (zero, one, minus_one) = (0u32, 1f32.to_bits(), (-1f32).to_bits());
        for (format, lower, upper) in [
            (vk::Format::BC6H_UFLOAT_BLOCK, zero, one),
            (vk::Format::BC7_UNORM_BLOCK, zero, u32::MAX),
            (vk::Format::BC4_UNORM_BLOCK, zero, u32::MAX),
            (vk::Format::R16G16B16A16_SFLOAT, minus_one, one),
            (vk::Format::R32G32B32A32_SFLOAT, minus_one, one),
            (vk::Format::R16_SFLOAT, minus_one, one),
            (vk::Format::R8G8B8A8_UNORM, zero, 255),
            (vk::Format::R8_UNORM, zero, 255),
        ] {
            let (.., samples) = describe(format).unwrap();
            for (.., l, u) in samples {
                assert_eq!((l, u), (lower, upper), "{format:?}");
            }
        }
    }
}
