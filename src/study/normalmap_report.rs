//! `shvis study normalmap` as one call: the timing tables, the real model simplified to
//! each ratio (its rows said as they are measured), and the report written.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::gpu::Context;
use crate::normalmap::AngleStats;
use crate::report::ReportError;

use super::normalmap::{
    NormalMapStudy, NormalMapStudyError, NormalMapStudySettings, model_row, timings, write_report,
};

/// Errors of [`run`].
#[derive(Debug, thiserror::Error)]
pub enum NormalMapRunError {
    /// The model at one ratio failed; `what` names both.
    #[error("{what}")]
    Model {
        what: String,
        source: NormalMapStudyError,
    },
    #[error(transparent)]
    Study(#[from] NormalMapStudyError),
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Runs the study on `ctx` (the model part when `settings.model` is set), writing the
/// model's files into `dir`, then the report; returns the report's files.
pub fn run(
    ctx: &Arc<Context>,
    settings: &NormalMapStudySettings,
    dir: &Path,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>, NormalMapRunError> {
    say(&format!("timings on {}:", ctx.device_name()));
    let timings = timings(ctx, settings)?;
    let mut models = Vec::new();
    if let Some(model) = &settings.model {
        for &ratio in &settings.ratios {
            let row = model_row(ctx, settings, model, ratio, dir).map_err(|source| {
                NormalMapRunError::Model {
                    what: format!("{} at {ratio}", model.display()),
                    source,
                }
            })?;
            let fmt = |s: &Option<AngleStats>| s.map_or("-".to_string(), |s| s.to_string());
            say(&format!(
                "{} kept {:.0} %: {} → {} triangles; GPU vs CPU (interpolated rays) {}; (face rays) {}",
                model.display(),
                ratio * 100.0,
                row.high_triangles,
                row.low_triangles,
                fmt(&row.vs_cpu),
                fmt(&row.vs_cpu_face)
            ));
            for (path, mapped, flat) in &row.render {
                say(&format!(
                    "  unc6 {path}: relative RMSE vs the high mesh's reference {mapped:.4} with the map, {flat:.4} flat"
                ));
            }
            models.push(row);
        }
    }
    let result = NormalMapStudy {
        device: ctx.device_name().to_string(),
        timings,
        models,
    };
    Ok(write_report(&result, dir)?)
}
