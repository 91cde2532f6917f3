//! Reports: image files (EXR linear, PNG sRGB), frame-time statistics, and the cost table
//! (`table.md`, `table.json`, DESIGN §4).

pub mod bench_output;
pub mod figures;
pub mod html;
pub mod image;
pub mod metrics;
pub mod plot;
pub mod results;
pub mod table;

use std::path::{Path, PathBuf};

/// Errors writing a report or image.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{}: cannot write: {detail}", .path.display())]
    Write { path: PathBuf, detail: String },
    #[error("{}: unsupported image extension (use .png or .exr)", .path.display())]
    Extension { path: PathBuf },
}

/// Folder of the error ladder's CPU rung images, inside the bench's output.
pub const LADDER_DIR: &str = "ladder";

/// Writes `text` as `dir/name`; returns the path.
pub fn write_text(dir: &Path, name: &str, text: &str) -> Result<PathBuf, ReportError> {
    let path = dir.join(name);
    crate::files::write(&path, text).map_err(|e| ReportError::Write {
        path: path.clone(),
        detail: e.to_string(),
    })?;
    Ok(path)
}

/// Writes `value` as pretty JSON `dir/name`; returns the path.
pub fn write_json(
    dir: &Path,
    name: &str,
    value: &impl serde::Serialize,
) -> Result<PathBuf, ReportError> {
    let json = serde_json::to_string_pretty(value).map_err(|e| ReportError::Write {
        path: dir.join(name),
        detail: e.to_string(),
    })?;
    write_text(dir, name, &json)
}

/// Writes the probe's `probe.md` and `probe.json` into `dir`; returns their paths.
pub fn write_probe(probe: &crate::probe::Probe, dir: &Path) -> Result<Vec<PathBuf>, ReportError> {
    Ok(vec![
        write_text(dir, "probe.md", &probe.to_markdown())?,
        write_json(dir, "probe.json", probe)?,
    ])
}
