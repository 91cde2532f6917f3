//! Writing rendered frames: OpenEXR keeps linear radiance (f32), PNG is sRGB-encoded
//! after scaling by 2^exposure (EV) and clamping.

use std::path::Path;

use super::ReportError;
use crate::render::Frame;

/// Writes `frame` as EXR or PNG by the extension of `path`.
pub fn write_frame(path: &Path, frame: &Frame, exposure_ev: f32) -> Result<(), ReportError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => write_exr(path, frame),
        Some("png") => write_png(path, frame, exposure_ev),
        _ => Err(ReportError::Extension {
            path: path.to_path_buf(),
        }),
    }
}

/// Linear RGBA f32 OpenEXR.
pub fn write_exr(path: &Path, frame: &Frame) -> Result<(), ReportError> {
    use exr::prelude::{Image, SpecificChannels, WritableImage};
    let w = frame.width as usize;
    let channels = SpecificChannels::rgba(|p: exr::math::Vec2<usize>| {
        let t = frame.rgba[p.1 * w + p.0];
        (t[0], t[1], t[2], t[3])
    });
    Image::from_encoded_channels(
        (w, frame.height as usize),
        crate::files::EXR_ENCODING,
        channels,
    )
    .write()
    .to_file(path)
    .map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })
}

/// 8-bit sRGB PNG of `frame · 2^exposure_ev`.
pub fn write_png(path: &Path, frame: &Frame, exposure_ev: f32) -> Result<(), ReportError> {
    let bytes = to_srgb8(frame, exposure_ev);
    image::save_buffer_with_format(
        path,
        &bytes,
        frame.width,
        frame.height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| ReportError::Write {
        path: path.to_path_buf(),
        detail: e.to_string(),
    })
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
