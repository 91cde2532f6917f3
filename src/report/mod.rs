//! Reports: image files (EXR linear, PNG sRGB), frame-time statistics, and the cost table
//! (`table.md`, `table.json`, DESIGN §4).

pub mod figures;
pub mod html;
pub mod image;
pub mod metrics;
pub mod plot;
pub mod table;

use std::path::PathBuf;

/// Errors writing a report or image.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{}: cannot write: {detail}", .path.display())]
    Write { path: PathBuf, detail: String },
    #[error("{}: unsupported image extension (use .png or .exr)", .path.display())]
    Extension { path: PathBuf },
}
