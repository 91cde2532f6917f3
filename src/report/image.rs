//! Writing rendered frames: OpenEXR keeps linear radiance (f32), PNG is sRGB-encoded
//! after scaling by 2^exposure (EV) and clamping.

use std::path::Path;

use super::ReportError;
use crate::render::Frame;

/// The image formats a frame can be written as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameFormat {
    /// Linear f32 OpenEXR.
    Exr,
    /// 8-bit sRGB PNG after exposure.
    Png,
}

/// The format `path`'s extension asks for (checked before any work is done).
///
/// # Errors
/// [`ReportError::Extension`] for anything but `.exr` / `.png` (any case).
pub fn frame_format(path: &Path) -> Result<FrameFormat, ReportError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => Ok(FrameFormat::Exr),
        Some("png") => Ok(FrameFormat::Png),
        _ => Err(ReportError::Extension {
            path: path.to_path_buf(),
        }),
    }
}

/// Writes `frame` as EXR or PNG by the extension of `path`.
pub fn write_frame(path: &Path, frame: &Frame, exposure_ev: f32) -> Result<(), ReportError> {
    match frame_format(path)? {
        FrameFormat::Exr => write_exr(path, frame),
        FrameFormat::Png => write_png(path, frame, exposure_ev),
    }
}

/// Linear RGBA f32 OpenEXR.
pub fn write_exr(path: &Path, frame: &Frame) -> Result<(), ReportError> {
    write_rgba_exr(path, frame, |v| v)
}

/// As [`write_exr`] with half-float channels (half the bytes): for the error ladder's
/// intermediate images, whose rung errors are computed from the f32 frames in memory.
pub fn write_exr_half(path: &Path, frame: &Frame) -> Result<(), ReportError> {
    write_rgba_exr(path, frame, exr::prelude::f16::from_f32)
}

/// RGBA OpenEXR of `frame` with samples `convert(v)`.
fn write_rgba_exr<T: exr::prelude::IntoSample>(
    path: &Path,
    frame: &Frame,
    convert: impl Fn(f32) -> T + Sync,
) -> Result<(), ReportError> {
    use exr::prelude::{Image, SpecificChannels, WritableImage};
    let w = frame.width as usize;
    let channels = SpecificChannels::rgba(|p: exr::math::Vec2<usize>| {
        let t = frame.rgba[p.1 * w + p.0];
        (convert(t[0]), convert(t[1]), convert(t[2]), convert(t[3]))
    });
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_encoded_channels(
        (w, frame.height as usize),
        crate::files::EXR_ENCODING,
        channels,
    )
    .write()
    .to_buffered(&mut bytes)
    .map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })?;
    write_file(path, &bytes.into_inner())
}

/// `bytes` to `path` atomically (`files::write_atomic`), the error naming `path`.
pub(crate) fn write_file(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    crate::files::write_atomic(path, bytes).map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        detail: match e {
            crate::files::FileError::Io { cause: source, .. } => source.to_string(),
            e => e.to_string(),
        },
    })
}

/// PNG bytes of an 8-bit image of `channels` (3: RGB, 4: RGBA, 1: grey).
pub(crate) fn encode_png(
    bytes: &[u8],
    width: u32,
    height: u32,
    color: image::ExtendedColorType,
) -> Result<Vec<u8>, image::ImageError> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out).write_image(bytes, width, height, color)?;
    Ok(out)
}

/// 8-bit sRGB PNG of `frame · 2^exposure_ev`.
pub fn write_png(path: &Path, frame: &Frame, exposure_ev: f32) -> Result<(), ReportError> {
    if !exposure_ev.is_finite() {
        return Err(ReportError::Write {
            path: path.to_path_buf(),
            detail: format!("exposure {exposure_ev} EV is not a finite number"),
        });
    }
    let bytes = to_srgb8(frame, exposure_ev);
    let png = encode_png(
        &bytes,
        frame.width,
        frame.height,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })?;
    write_file(path, &png)
}

/// sRGB-encoded RGB8 of `frame · 2^exposure_ev`; NaN becomes 0.
pub fn to_srgb8(frame: &Frame, exposure_ev: f32) -> Vec<u8> {
    let scale = exposure_ev.exp2();
    frame
        .rgba
        .iter()
        .flat_map(|t| [t[0], t[1], t[2]])
        .map(|c| {
            let c = (c * scale).clamp(0.0, 1.0); // NaN.clamp → NaN, `as u8` maps it to 0
            let s = if c <= 0.0031308 {
                c * 12.92
            } else {
                1.055 * c.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0).round() as u8
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_frames_with_equal_pixels_are_equal_bytes() {
        let (width, height) = (256u32, 256u32);
        let frame = Frame {
            width,
            height,
            rgba: (0..width * height)
                .map(|i| {
                    let v = (i.wrapping_mul(2_654_435_761) >> 8) as f32 * 1e-6;
                    [v, v * 0.5, 1.0 - v, 1.0]
                })
                .collect(),
            ms: vec![],
        };
        let dir = std::env::temp_dir().join(format!("shvis-exr-frame-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bytes: Vec<Vec<u8>> = (0..4)
            .map(|k| {
                let path = dir.join(format!("{k}.exr"));
                write_exr(&path, &frame).unwrap();
                std::fs::read(&path).unwrap()
            })
            .collect();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(bytes.windows(2).all(|w| w[0] == w[1]));
    }
}
