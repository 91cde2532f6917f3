//! `shvis ssbump`: a self-shadowed bump map (Green, Valve) from a height map, written as
//! 16-bit PNG and EXR beside the plain D encoding (`*_d`) and the scalar AO (`*_ao`), the
//! six files as one set (`files::FileSet`).

use std::path::{Path, PathBuf};

use crate::bake::ssbump::{occlusion, ssbump};
use crate::render::Frame;
use crate::report::ReportError;
use crate::report::image::write_exr;
use crate::scene::SceneError;

/// The name of the built-in height field (the house's bricks).
pub const HOUSE: &str = "house";
/// Largest bilateral pre-filter σ accepted, texels.
pub const MAX_BILATERAL: f64 = 64.0;
/// The bilateral pre-filter's range σ as a fraction of the height range.
pub const BILATERAL_RANGE_FRACTION: f64 = 0.05;

/// What `shvis ssbump` makes.
#[derive(Clone, Debug, PartialEq)]
pub struct SsbumpJob {
    /// A PNG or EXR height map (luminance in [0, 1]), or [`HOUSE`].
    pub height: PathBuf,
    /// Height of a white texel in texels (with [`HOUSE`]: a factor on its heights).
    pub scale: f64,
    /// Rays per texel.
    pub rays: u32,
    /// Bilateral pre-filter's spatial σ, texels (0: off).
    pub bilateral: f64,
    pub seed: u64,
    /// Output .png (the other files beside it).
    pub out: PathBuf,
}

/// Figures of a written SSBump.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsbumpSummary {
    pub width: usize,
    pub height: usize,
    /// Mean directional occlusion per basis direction.
    pub mean_occlusion: [f64; 3],
    pub mean_ao: f64,
}

/// Errors of [`run`].
#[derive(Debug, thiserror::Error)]
pub enum SsbumpError {
    /// A setting out of range; the message names it.
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error(transparent)]
    Limit(#[from] crate::limits::LimitError),
    #[error("{}: cannot write", .path.display())]
    Write {
        path: PathBuf,
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error(transparent)]
    File(#[from] crate::files::FileError),
}

impl SsbumpJob {
    /// Checks the settings, before any work.
    pub fn check(&self) -> Result<(), SsbumpError> {
        let max = crate::scene::height_field::MAX_HEIGHT_SCALE;
        if !(self.scale.is_finite() && self.scale > 0.0 && self.scale <= max) {
            return Err(SsbumpError::Invalid(format!(
                "--height-scale {:?} must be in (0, {max}]",
                self.scale
            )));
        }
        if !(self.bilateral.is_finite() && (0.0..=MAX_BILATERAL).contains(&self.bilateral)) {
            return Err(SsbumpError::Invalid(format!(
                "--bilateral {} must be in 0..=64 texels",
                self.bilateral
            )));
        }
        if self.height.as_os_str() != HOUSE {
            let stem = self.out.with_extension("").display().to_string();
            let outputs: Vec<(String, PathBuf)> = ["", "_d", "_ao"]
                .iter()
                .flat_map(|side| {
                    ["png", "exr"].map(|ext| {
                        let option = if side.is_empty() {
                            "--out".to_string()
                        } else {
                            format!("--out's {side} file")
                        };
                        (option, PathBuf::from(format!("{stem}{side}.{ext}")))
                    })
                })
                .collect();
            crate::files::check_outputs_spare_inputs(&outputs, &[("--height-map", &self.height)])
                .map_err(|e| SsbumpError::Invalid(e.to_string()))?;
        }
        if self.out.extension().and_then(|e| e.to_str()) != Some("png") {
            return Err(SsbumpError::Invalid(format!(
                "{}: the output must be a .png",
                self.out.display()
            )));
        }
        Ok(())
    }
}

/// Bytes the bake holds per height texel at once: the filtered heights, the occlusion and
/// AO, the SSBump, plain D and AO colours (f64) and the 16-bit images being encoded.
const BAKE_BYTES_PER_TEXEL: u64 = 160;

/// Checks `job`, bakes the occlusion and writes the files.
pub fn run(job: &SsbumpJob) -> Result<SsbumpSummary, SsbumpError> {
    job.check()?;
    let field = if job.height.as_os_str() == HOUSE {
        let mut field = crate::scene::house::brick_height_field();
        field.h.iter_mut().for_each(|h| *h *= job.scale);
        field
    } else {
        crate::scene::load_height_map(&job.height, job.scale)?
    };
    let (width, height) = (field.width, field.height);
    crate::limits::check_memory(
        format_args!("the SSBump bake of {width}×{height} height texels"),
        (width * height) as u64 * BAKE_BYTES_PER_TEXEL,
        "use a smaller height map",
    )?;
    let range = field.h.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - field.h.iter().copied().fold(f64::INFINITY, f64::min);
    let field = field.bilateral(job.bilateral, BILATERAL_RANGE_FRACTION * range.max(1e-9));
    let occ = occlusion(&field, job.rays as usize, job.seed);
    let (shadowed, plain) = ssbump(&field, &occ);
    let ao: Vec<[f64; 3]> = occ.ao.iter().map(|&v| [v; 3]).collect();
    let stem = job.out.with_extension("");
    let with_suffix =
        |suffix: &str, ext: &str| PathBuf::from(format!("{}{suffix}.{ext}", stem.display()));
    let mut files = crate::files::FileSet::new();
    for (texels, suffix) in [(&shadowed, ""), (&plain, "_d"), (&ao, "_ao")] {
        let png = with_suffix(suffix, "png");
        write_png16(
            &png,
            &files.stage(&png),
            width as u32,
            height as u32,
            texels,
        )?;
        let frame = Frame {
            width: width as u32,
            height: height as u32,
            rgba: texels
                .iter()
                .map(|t| [t[0] as f32, t[1] as f32, t[2] as f32, 1.0])
                .collect(),
            ms: Vec::new(),
        };
        let exr = with_suffix(suffix, "exr");
        write_exr(&files.stage(&exr), &frame).map_err(|e| match e {
            ReportError::Write { detail, .. } => ReportError::Write {
                path: exr.clone(),
                detail,
            },
            e => e,
        })?;
    }
    files.commit()?;
    let mean =
        |i: usize| occ.channels.iter().map(|c| c[i]).sum::<f64>() / occ.channels.len() as f64;
    Ok(SsbumpSummary {
        width,
        height,
        mean_occlusion: [mean(0), mean(1), mean(2)],
        mean_ao: occ.ao.iter().sum::<f64>() / occ.ao.len() as f64,
    })
}

/// Writes RGB texels in [0, 1] as a 16-bit PNG into `to`, the temporary of `path` (the
/// file named in errors).
fn write_png16(
    path: &Path,
    to: &Path,
    width: u32,
    height: u32,
    texels: &[[f64; 3]],
) -> Result<(), SsbumpError> {
    let write_error = |source: Box<dyn std::error::Error + Send + Sync>| SsbumpError::Write {
        path: path.to_path_buf(),
        source,
    };
    let data: Vec<u16> = texels
        .iter()
        .flat_map(|t| t.map(|v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16))
        .collect();
    let mut encoded = Vec::new();
    image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(width, height, data)
        .expect("3 channels per texel")
        .write_to(
            &mut std::io::Cursor::new(&mut encoded),
            image::ImageFormat::Png,
        )
        .map_err(|e| write_error(Box::new(e)))?;
    crate::files::write(to, &encoded).map_err(|e| write_error(Box::new(e)))
}
