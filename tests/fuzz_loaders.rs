//! Fuzzing on stable Rust: mutated inputs through the environment-map loaders
//! (OpenEXR in four compressions, Radiance HDR flat and run-length) and the bake cache
//! readers, in process, deterministic and bounded (a few thousand cases, seconds). Every
//! mutation must end in `Ok` or `Err` — never a panic — and whatever loads must hold what
//! the loader promises (finite texels within the radiance limit, the stated shape; a cache
//! whose values a bake can produce). The glTF loader has its own (`tests/scene_gltf.rs`,
//! `mutated_files_never_panic`); `fuzz/` keeps cargo-fuzz targets for nightly users.

mod common;

use std::panic::{AssertUnwindSafe, catch_unwind};

use common::Rng;

use shvis::bake::BakeStats;
use shvis::bake::cache::{HEADER_BYTES, decode_visibility, encode_visibility};
use shvis::bake::visibility::VisibilityMap;
use shvis::env::EnvMap;
use shvis::env::equirect::{MAX_ENV_RADIANCE, load_from_slice};
use shvis::files::hash64;
use shvis::sh::Order;

/// One mutation of `seed`: bit flips, a truncation, a byte run overwritten with an edge
/// value (0x00, 0x7f, 0x80, 0xff), or a chunk duplicated.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = seed.to_vec();
    match rng.below(5) {
        0 => b.truncate(rng.below(seed.len())),
        1 => {
            let at = rng.below(b.len());
            let fill = [0x00, 0x7f, 0x80, 0xff][rng.below(4)];
            let end = (at + 1 + rng.below(8)).min(b.len());
            b[at..end].fill(fill);
        }
        2 => {
            let at = rng.below(b.len());
            let len = rng.below(64).min(b.len() - at);
            let chunk = b[at..at + len].to_vec();
            let to = rng.below(b.len());
            b.splice(to..to, chunk);
        }
        _ => {
            for _ in 0..=rng.below(4) {
                let i = rng.below(b.len());
                b[i] ^= 1 << rng.below(8);
            }
        }
    }
    b
}

fn sky(w: u32, h: u32) -> EnvMap {
    EnvMap {
        width: w,
        height: h,
        texels: (0..w * h)
            .map(|i| [i as f32 * 0.01, 1.0, (i % 7) as f32])
            .collect(),
    }
}

fn exr_bytes(map: &EnvMap, compression: exr::prelude::Compression) -> Vec<u8> {
    use exr::prelude::*;
    let w = map.width as usize;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let t = map.texels[p.1 * w + p.0];
        (t[0], t[1], t[2])
    });
    let encoding = Encoding {
        compression,
        ..Encoding::FAST_LOSSLESS
    };
    let mut out = std::io::Cursor::new(Vec::new());
    Image::from_encoded_channels((w, map.height as usize), encoding, channels)
        .write()
        .to_buffered(&mut out)
        .unwrap();
    out.into_inner()
}

fn hdr_bytes(map: &EnvMap) -> Vec<u8> {
    let mut out = Vec::new();
    let pixels: Vec<image::Rgb<f32>> = map.texels.iter().map(|t| image::Rgb(*t)).collect();
    image::codecs::hdr::HdrEncoder::new(&mut out)
        .encode(&pixels, map.width as usize, map.height as usize)
        .unwrap();
    out
}

/// What a loaded map must satisfy.
fn check_loaded(map: &EnvMap) -> Result<(), String> {
    if map.width == 0 || map.width != 2 * map.height {
        return Err(format!("shape {}×{}", map.width, map.height));
    }
    if map.texels.len() != (map.width * map.height) as usize {
        return Err("texel count".into());
    }
    if let Some(t) = map.texels.iter().find(|t| {
        t.iter()
            .any(|c| !c.is_finite() || *c < 0.0 || *c > MAX_ENV_RADIANCE)
    }) {
        return Err(format!("texel {t:?} loaded"));
    }
    Ok(())
}

#[test]
fn mutated_environment_maps_load_or_fail_cleanly() {
    use exr::prelude::Compression;
    let map = sky(32, 16);
    let mut seeds: Vec<(String, Vec<u8>)> = [
        Compression::Uncompressed,
        Compression::RLE,
        Compression::ZIP16,
        Compression::PIZ,
    ]
    .into_iter()
    .map(|c| (format!("exr {c:?}"), exr_bytes(&map, c)))
    .collect();
    seeds.push(("hdr flat".into(), hdr_bytes(&sky(6, 3))));
    seeds.push(("hdr run-length".into(), hdr_bytes(&map)));
    let mut rng = Rng(0x0e5d_2100_0000_0021);
    let (mut loaded, mut refused) = (0usize, 0usize);
    for (name, seed) in &seeds {
        let original = load_from_slice(seed).unwrap_or_else(|e| panic!("{name}: {e}"));
        check_loaded(&original).unwrap();
        for case in 0..400 {
            let bytes = mutate(seed, &mut rng);
            match catch_unwind(AssertUnwindSafe(|| load_from_slice(&bytes))) {
                Err(_) => panic!("{name} mutation {case} panicked"),
                Ok(Ok(m)) => {
                    if let Err(e) = check_loaded(&m) {
                        panic!("{name} mutation {case}: {e}");
                    }
                    loaded += 1;
                }
                Ok(Err(e)) => {
                    let msg = e.to_string();
                    assert!(
                        msg.starts_with("<memory>") && !msg.contains('\n'),
                        "{name} mutation {case}: {msg}"
                    );
                    refused += 1;
                }
            }
        }
    }
    println!("environment mutations: {loaded} loaded, {refused} refused");
    assert!(refused > 0 && loaded > 0);
}

fn visibility(res: u32, order: Order) -> VisibilityMap {
    let texels = (res * res) as usize;
    let n2 = order.coeff_count();
    VisibilityMap {
        res,
        order,
        coeffs: (0..texels * n2)
            .map(|i| ((i % 13) as f32 - 6.0) * 0.1)
            .collect(),
        covered: (0..texels).map(|i| i % 3 != 0).collect(),
        ao: (0..texels).map(|i| (i % 11) as f32 / 10.0).collect(),
        stats: BakeStats {
            rays_traced: 1234,
            seconds: 0.5,
        },
    }
}

/// What a decoded cache must satisfy (the reader's promise).
fn check_cache(m: &VisibilityMap, res: u32, order: Order) -> Result<(), String> {
    let texels = (res * res) as usize;
    if m.res != res || m.order != order {
        return Err("res/order".into());
    }
    if m.coeffs.len() != texels * order.coeff_count()
        || m.covered.len() != texels
        || m.ao.len() != texels
    {
        return Err("lengths".into());
    }
    if m.coeffs.iter().any(|c| !c.is_finite() || c.abs() > 1e3) {
        return Err("coefficient out of range".into());
    }
    if m.ao.iter().any(|a| !(0.0..=1.0).contains(a)) {
        return Err("AO out of range".into());
    }
    Ok(())
}

#[test]
fn mutated_cache_files_are_rejected_or_valid() {
    let (res, order, key) = (16, Order::new(3).unwrap(), 0x1234_5678_9abc_def0);
    let seed = encode_visibility(&visibility(res, order), key);
    assert!(decode_visibility(&seed, key, res, order).is_ok());
    let mut rng = Rng(0xcac4_e000_0000_0021);
    let (mut loaded, mut refused) = (0usize, 0usize);
    for case in 0..3000 {
        let mut bytes = mutate(&seed, &mut rng);
        // Half the cases keep a valid checksum over the mutated payload, so that the
        // payload's own checks are what is exercised.
        if case % 2 == 0 && bytes.len() >= HEADER_BYTES {
            let len = (bytes.len() - HEADER_BYTES) as u64;
            let h = hash64(&bytes[HEADER_BYTES..]);
            bytes[24..32].copy_from_slice(&len.to_le_bytes());
            bytes[32..40].copy_from_slice(&h.to_le_bytes());
        }
        match catch_unwind(AssertUnwindSafe(|| {
            decode_visibility(&bytes, key, res, order)
        })) {
            Err(_) => panic!("cache mutation {case} panicked"),
            Ok(Ok(m)) => {
                if let Err(e) = check_cache(&m, res, order) {
                    panic!("cache mutation {case} decoded to a bad map: {e}");
                }
                loaded += 1;
            }
            Ok(Err(e)) => {
                assert!(!e.is_empty() && !e.contains('\n'), "{e}");
                refused += 1;
            }
        }
    }
    println!("cache mutations: {loaded} decoded, {refused} refused");
    assert!(refused > 0);
}
