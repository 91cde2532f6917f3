//! Loading and saving equirectangular radiance maps (DESIGN §1, §4 `--env PATH`).
//!
//! The format is detected by magic bytes — OpenEXR `76 2f 31 01`, Radiance `#?RADIANCE`
//! or `#?RGBE` — so a misnamed file still loads and a text file named `x.exr` is a clear
//! [`EnvError::Format`]; the extension only appears in that error's text.
//!
//! - OpenEXR via the `exr` crate: the first valid layer with R, G and B channels (any
//!   sample type, converted to f32; other channels ignored), largest resolution level.
//! - Radiance RGBE via `image`'s HDR decoder (f32 RGB).
//!
//! Validation, in this order: non-empty ([`EnvError::Empty`]), 2:1 or 1:1
//! ([`EnvError::Shape`]; 1:1 is a Debevec angular probe, resampled onto an equirect map by
//! [`super::angular`]), at least [`MIN_ENV_HEIGHT`] rows ([`EnvError::TooSmall`]), every
//! channel finite ([`EnvError::NonFinite`] with the count
//! and the first texel in row-major order; DESIGN §6), negative values clamped to 0 with
//! one `log::warn!` giving their count (they are not radiance, but some tools emit tiny
//! negatives from filtering).

use std::io::Cursor;
use std::path::Path;

use super::angular::AngularProbe;
use super::{EnvError, EnvMap};

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const RADIANCE_MAGICS: [&[u8]; 2] = [b"#?RADIANCE", b"#?RGBE"];

/// How a 1:1 image is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SquareLayout {
    /// As an angular probe if the content says so: no light outside the inscribed disk
    /// (at most [`MAX_LIGHT_OUTSIDE_DISK`] of it); otherwise [`EnvError::Ambiguous`].
    Detect,
    /// As an angular probe whatever lies outside the disk (ignored).
    Angular,
}

/// Fewest rows of a map, and side of an angular probe (resampled to as many rows): a single
/// row spans every elevation from the zenith to the nadir, so its texel centres all lie on
/// the horizon and it cannot tell the sky from the ground.
pub const MIN_ENV_HEIGHT: u32 = 2;

/// Share of a 1:1 image's light allowed outside its disk for detection as a probe.
pub const MAX_LIGHT_OUTSIDE_DISK: f64 = 1e-3;

/// Loads an OpenEXR or Radiance HDR equirectangular map (or angular probe) and validates it
/// (module doc), telling 1:1 images apart by their content ([`SquareLayout::Detect`]).
///
/// # Errors
/// [`EnvError::Io`] (cannot read), [`EnvError::Format`] (neither format, or decoding
/// failed), [`EnvError::Empty`], [`EnvError::Shape`] (not 2:1 or 1:1),
/// [`EnvError::TooSmall`], [`EnvError::NonFinite`], [`EnvError::Ambiguous`].
pub fn load(path: &Path) -> Result<EnvMap, EnvError> {
    load_as(path, SquareLayout::Detect)
}

/// [`load`], with the reading of a 1:1 image given.
pub fn load_as(path: &Path, square: SquareLayout) -> Result<EnvMap, EnvError> {
    let bytes = read_env_file(path, MAX_ENV_FILE_BYTES, "an environment map")?;
    decode(&bytes, path, square)
}

/// The bytes of an environment's file, at most `limit`, its errors as [`EnvError`]s.
pub(super) fn read_env_file(
    path: &Path,
    limit: u64,
    what: &'static str,
) -> Result<Vec<u8>, EnvError> {
    crate::files::read_bounded(path, limit, what).map_err(|e| match e {
        crate::files::FileError::Io { cause: source, .. } => EnvError::Io {
            path: path.to_owned(),
            source,
        },
        e => EnvError::Format {
            path: path.to_owned(),
            detail: e
                .to_string()
                .replacen(&format!("{}: ", path.display()), "", 1),
        },
    })
}

/// [`load`] of bytes in memory (`<memory>` in messages): the entry point of the
/// `env_map` fuzz target and of the loaders' mutation test.
///
/// # Errors
/// As [`load`], less [`EnvError::Io`].
pub fn load_from_slice(bytes: &[u8]) -> Result<EnvMap, EnvError> {
    decode(bytes, Path::new("<memory>"), SquareLayout::Detect)
}

fn decode(bytes: &[u8], path: &Path, square: SquareLayout) -> Result<EnvMap, EnvError> {
    let format_err = |detail: String| EnvError::Format {
        path: path.to_owned(),
        detail,
    };
    let map = if bytes.starts_with(&EXR_MAGIC) {
        check_exr_header(bytes, path)?;
        decode_exr(bytes).map_err(|e| {
            format_err(
                missing_rgb(bytes)
                    .unwrap_or_else(|| crate::files::decoder_error("OpenEXR file", e)),
            )
        })?
    } else if RADIANCE_MAGICS.iter().any(|m| bytes.starts_with(m)) {
        let meta = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes))
            .map_err(|e| format_err(crate::files::decoder_error("Radiance HDR file", e)))?
            .metadata();
        check_env_size(path, u64::from(meta.width), u64::from(meta.height))?;
        decode_hdr(bytes)
            .map_err(|e| format_err(crate::files::decoder_error("Radiance HDR file", e)))?
    } else {
        let ext = path
            .extension()
            .map(|e| format!("despite its .{} extension", e.to_string_lossy()))
            .unwrap_or_else(|| "no extension".to_owned());
        let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02x}")).collect();
        return Err(format_err(format!(
            "not an OpenEXR or Radiance HDR file ({ext}; starts with bytes [{}])",
            head.join(" ")
        )));
    };
    validate(map, path, square)
}

/// Widest environment map accepted (texels; 16384 × 8192 is 1.5 GiB of f32 RGB).
pub const MAX_ENV_WIDTH: u64 = 16384;
/// Largest environment file read.
pub const MAX_ENV_FILE_BYTES: u64 = 4 << 30;

/// Every layer's size from the EXR header, checked before any texel is allocated.
fn check_exr_header(bytes: &[u8], path: &Path) -> Result<(), EnvError> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| {
        EnvError::Format {
            path: path.to_owned(),
            detail: crate::files::decoder_error("OpenEXR file", e),
        }
    })?;
    for header in &meta.headers {
        let size = header.layer_size;
        check_env_size(path, size.width() as u64, size.height() as u64)?;
    }
    Ok(())
}

/// A `width × height` map against [`MAX_ENV_WIDTH`] and the memory available (the decoded
/// texels, the validated copy and the SH projection's working set: ~3 × 12 bytes a texel).
fn check_env_size(path: &Path, width: u64, height: u64) -> Result<(), EnvError> {
    let side = width.max(height);
    let limit_err = |e: crate::limits::LimitError| EnvError::Format {
        path: path.to_owned(),
        detail: e.to_string(),
    };
    crate::limits::check_at_most(
        format_args!("the header's {width}×{height} texels: a side"),
        side,
        MAX_ENV_WIDTH,
        "the widest map accepted",
    )
    .map_err(limit_err)?;
    crate::limits::check_memory(
        format_args!("decoding its {width}×{height} texels"),
        crate::limits::image_bytes(width, height, 36),
        "",
    )
    .map_err(limit_err)
}

/// The first RGB layer of an OpenEXR file (its header's sizes checked first), for inputs
/// other than environments (height maps); the error in words.
pub(crate) fn decode_exr_rgb(bytes: &[u8], path: &Path) -> Result<EnvMap, EnvError> {
    check_exr_header(bytes, path)?;
    decode_exr(bytes).map_err(|e| EnvError::Format {
        path: path.to_owned(),
        detail: missing_rgb(bytes)
            .unwrap_or_else(|| format!("not an OpenEXR image with R, G and B channels: {e}")),
    })
}

/// Where an OpenEXR file's header reads but no layer has R, G and B channels: that, with the
/// channels it has.
fn missing_rgb(bytes: &[u8]) -> Option<String> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).ok()?;
    let channels: Vec<String> = meta
        .headers
        .iter()
        .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
        .collect();
    let has = |name: &str| {
        channels
            .iter()
            .any(|c| c == name || c.ends_with(&format!(".{name}")))
    };
    (!(has("R") && has("G") && has("B"))).then(|| {
        format!(
            "an OpenEXR image with no R, G and B channels (it has {})",
            if channels.is_empty() {
                "none".to_string()
            } else {
                channels.join(", ")
            }
        )
    })
}

fn decode_exr(bytes: &[u8]) -> Result<EnvMap, exr::error::Error> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgb_channels(
            |size: Vec2<usize>, _: &RgbChannels| {
                (
                    size.width(),
                    vec![[0.0f32; 3]; size.width() * size.height()],
                )
            },
            |(w, texels): &mut (usize, Vec<[f32; 3]>),
             pos: Vec2<usize>,
             (r, g, b): (f32, f32, f32)| {
                texels[pos.y() * *w + pos.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok(EnvMap {
        width: size.width() as u32,
        height: size.height() as u32,
        texels,
    })
}

/// The texels of a Radiance HDR file whose size [`check_env_size`] has passed: without the
/// image crate's own 512 MiB allocation limit, which refuses valid maps below
/// [`MAX_ENV_WIDTH`] (10240 × 5120).
fn decode_hdr(bytes: &[u8]) -> Result<EnvMap, image::ImageError> {
    let mut reader = image::ImageReader::with_format(Cursor::new(bytes), image::ImageFormat::Hdr);
    reader.no_limits();
    let img = reader.decode()?.into_rgb32f();
    Ok(EnvMap {
        width: img.width(),
        height: img.height(),
        texels: img.pixels().map(|p| p.0).collect(),
    })
}

/// Shape and value checks of the module doc; clamps negatives in place.
fn validate(mut map: EnvMap, path: &Path, square: SquareLayout) -> Result<EnvMap, EnvError> {
    let (width, height) = (map.width, map.height);
    if width == 0 || height == 0 {
        return Err(EnvError::Empty {
            path: path.to_owned(),
            width,
            height,
        });
    }
    if square == SquareLayout::Angular && width != height {
        return Err(EnvError::Format {
            path: path.to_owned(),
            detail: format!("angular: names a 1:1 angular probe, this map is {width}×{height}"),
        });
    }
    if width != 2 * height && width != height {
        return Err(EnvError::Shape {
            path: path.to_owned(),
            width,
            height,
        });
    }
    if height < MIN_ENV_HEIGHT {
        return Err(EnvError::TooSmall {
            path: path.to_owned(),
            width,
            height,
        });
    }
    debug_assert_eq!(map.texels.len(), width as usize * height as usize);
    let mut non_finite = 0usize;
    let mut first = None;
    let mut negative = 0usize;
    for (i, t) in map.texels.iter_mut().enumerate() {
        if t.iter().any(|c| !c.is_finite()) {
            non_finite += 1;
            first.get_or_insert(i);
            continue;
        }
        if t.iter().any(|c| *c < 0.0) {
            negative += 1;
            *t = t.map(|c| c.max(0.0));
        }
    }
    if let Some(i) = first {
        return Err(EnvError::NonFinite {
            path: path.to_owned(),
            count: non_finite,
            x: (i % width as usize) as u32,
            y: (i / width as usize) as u32,
        });
    }
    if negative > 0 {
        log::warn!(
            "{}: {negative} texels have negative radiance; clamped to 0",
            path.display()
        );
    }
    check_range(&map, path)?;
    let map = if width == height {
        let probe = AngularProbe {
            size: width,
            texels: map.texels,
        };
        let outside = probe.light_outside_disk();
        if square == SquareLayout::Detect && outside > MAX_LIGHT_OUTSIDE_DISK {
            return Err(EnvError::Ambiguous {
                path: path.to_owned(),
                width,
                outside,
            });
        }
        if square == SquareLayout::Angular && outside > 0.999 {
            return Err(EnvError::Format {
                path: path.to_owned(),
                detail: "read as an angular probe (angular:) it is black: over 99.9 % of its light lies outside the probe's disk".into(),
            });
        }
        if square == SquareLayout::Angular && outside > MAX_LIGHT_OUTSIDE_DISK {
            log::warn!(
                "{}: read as an angular probe (angular:), {:.1} % of its light lies outside the probe's disk and is dropped",
                path.display(),
                100.0 * outside
            );
        }
        log::info!(
            "{}: {width}×{width} read as a Debevec angular probe, resampled to {}×{width} equirect",
            path.display(),
            2 * width
        );
        probe.to_equirect(2 * width)
    } else {
        map
    };
    warn_if_frames_clip(&map, path);
    Ok(map)
}

/// Largest radiance accepted in a loaded map. Far above any captured sky (a physical sun
/// is ~1e9 in W·sr⁻¹·m⁻²), and low enough that the f32 sums over the largest map
/// (1.3e8 texels × SH basis values ≤ 1e2) stay below 1e23, finite with a wide margin,
/// for every technique and the reference alike.
pub const MAX_ENV_RADIANCE: f32 = 1e12;

/// Largest value of an f16 render target (`half::f16::MAX`).
pub const F16_TARGET_MAX: f64 = 65504.0;

/// Refuses texels above [`MAX_ENV_RADIANCE`], naming the first and the largest value.
fn check_range(map: &EnvMap, path: &Path) -> Result<(), EnvError> {
    let mut first = None;
    let mut count = 0usize;
    let mut largest = 0.0f32;
    for (i, t) in map.texels.iter().enumerate() {
        let m = t[0].max(t[1]).max(t[2]);
        if m > MAX_ENV_RADIANCE {
            count += 1;
            first.get_or_insert(i);
            largest = largest.max(m);
        }
    }
    match first {
        None => Ok(()),
        Some(i) => Err(EnvError::Format {
            path: path.to_owned(),
            detail: format!(
                "{count} texels exceed the radiance limit {MAX_ENV_RADIANCE:e} (largest {largest:e}, first at x={}, y={}); scale the map down",
                i % map.width as usize,
                i / map.width as usize
            ),
        }),
    }
}

/// Warns when a white surface facing the brightest hemisphere could exceed an f16 frame
/// target: the bound is ∫ L dω / π over the whole sphere (irradiance over π, albedo 1).
/// The frames themselves are checked after rendering (`render::Frame::clipped`).
fn warn_if_frames_clip(map: &EnvMap, path: &Path) {
    let mut integral = 0.0f64;
    for y in 0..map.height {
        let omega = map.texel_solid_angle(y);
        let row = &map.texels[(y * map.width) as usize..((y + 1) * map.width) as usize];
        let max_row: f64 = row
            .iter()
            .map(|t| f64::from(t[0].max(t[1]).max(t[2])))
            .sum();
        integral += omega * max_row;
    }
    let bound = integral / std::f64::consts::PI;
    if bound > F16_TARGET_MAX {
        log::warn!(
            "{}: lit surfaces may reach radiance {bound:.3e}, above the f16 frame targets' {F16_TARGET_MAX}; such pixels are reported as clipped",
            path.display()
        );
    }
}

/// Writes `map` as an RGB f32 OpenEXR file ([`EnvMap::save_exr`]).
pub(super) fn save_exr(map: &EnvMap, path: &Path) -> Result<(), EnvError> {
    let (w, h) = (map.width as usize, map.height as usize);
    if map.texels.len() != w * h || w == 0 || h == 0 {
        return Err(EnvError::Write {
            path: path.to_owned(),
            detail: format!(
                "{}×{} map holds {} texels",
                map.width,
                map.height,
                map.texels.len()
            ),
        });
    }
    use exr::prelude::{Image, SpecificChannels, WritableImage};
    let channels = SpecificChannels::rgb(|p: exr::math::Vec2<usize>| {
        let t = map.texels[p.1 * w + p.0];
        (t[0], t[1], t[2])
    });
    let write_err = |detail: String| EnvError::Write {
        path: path.to_owned(),
        detail,
    };
    let mut bytes = Cursor::new(Vec::new());
    Image::from_encoded_channels((w, h), crate::files::EXR_ENCODING, channels)
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| write_err(e.to_string()))?;
    crate::files::write(path, bytes.into_inner()).map_err(|e| write_err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp_path(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!("shvis-env-unit-{}-{name}", std::process::id()))
    }

    #[test]
    fn negative_texels_are_clamped() {
        let map = EnvMap {
            width: 4,
            height: 2,
            texels: vec![[-1.0, 0.5, -0.0]; 8],
        };
        let ok = validate(map, Path::new("neg.exr"), SquareLayout::Detect)
            .expect("negatives are not an error");
        assert!(ok.texels.iter().all(|t| *t == [0.0, 0.5, 0.0]));
    }

    #[test]
    fn empty_and_shape_errors() {
        let empty = EnvMap {
            width: 0,
            height: 0,
            texels: vec![],
        };
        assert!(matches!(
            validate(empty, Path::new("e.exr"), SquareLayout::Detect),
            Err(EnvError::Empty { .. })
        ));
        let odd = EnvMap {
            width: 3,
            height: 2,
            texels: vec![[0.0; 3]; 6],
        };
        let e = validate(odd, Path::new("odd.exr"), SquareLayout::Detect).unwrap_err();
        assert!(
            matches!(
                e,
                EnvError::Shape {
                    width: 3,
                    height: 2,
                    ..
                }
            ),
            "{e}"
        );
        // A 1:1 image lit outside its disk is ambiguous: refused unless read as a probe on
        // request, which resamples it onto a 2:1 map (a constant stays constant).
        let square = EnvMap {
            width: 8,
            height: 8,
            texels: vec![[0.5; 3]; 64],
        };
        let e = validate(square.clone(), Path::new("sq.exr"), SquareLayout::Detect).unwrap_err();
        assert!(
            matches!(e, EnvError::Ambiguous { width: 8, outside, .. } if outside > 0.05),
            "{e}"
        );
        assert!(e.to_string().contains("angular:sq.exr"), "{e}");
        let map = validate(square, Path::new("probe.exr"), SquareLayout::Angular)
            .expect("a probe loads when asked for");
        assert_eq!((map.width, map.height), (16, 8));
        assert!(map.texels.iter().flatten().all(|&v| (v - 0.5).abs() < 1e-6));
        // A probe, black outside its disk, is detected by its content.
        let probe = AngularProbe::from_fn(16, |d| [1.0 + d.x as f32, 1.0, 0.5]);
        assert_eq!(probe.light_outside_disk(), 0.0);
        let detected = EnvMap {
            width: 16,
            height: 16,
            texels: probe.texels,
        };
        let map = validate(detected, Path::new("p.exr"), SquareLayout::Detect).expect("detected");
        assert_eq!((map.width, map.height), (32, 16));
    }

    #[test]
    fn radiance_hdr_loads() {
        // Minimal flat (non-RLE) RGBE file: 4×2, every texel (1.0, 0.5, 0.25).
        let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n".to_vec();
        for _ in 0..8 {
            bytes.extend_from_slice(&[128, 64, 32, 129]); // mantissas × 2^(129−136)
        }
        let path = temp_path("flat.hdr");
        std::fs::write(&path, &bytes).expect("temp file");
        let map = load(&path);
        let _ = std::fs::remove_file(&path);
        let map = map.expect("valid HDR");
        assert_eq!((map.width, map.height), (4, 2));
        for t in &map.texels {
            assert!(
                (t[0] - 1.0).abs() < 1e-2 && (t[2] - 0.25).abs() < 1e-2,
                "{t:?}"
            );
        }
    }
}
