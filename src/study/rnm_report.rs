//! `shvis study rnm` as one call: each environment's measurements (said row by row) and the
//! report with its composites.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::gpu::Context;
use crate::report::ReportError;

use super::rnm::{RnmStudyError, RnmStudySettings, run_env, write_report};

/// Errors of [`run`].
#[derive(Debug, thiserror::Error)]
pub enum RnmRunError {
    /// The scene cannot be loaded or displaced (checked before any environment's bake).
    #[error("--scene {scene}")]
    Scene {
        scene: String,
        source: RnmStudyError,
    },
    /// One environment failed.
    #[error("--env {env}")]
    Env { env: String, source: RnmStudyError },
    #[error(transparent)]
    Report(#[from] ReportError),
}

/// Measures every environment of `envs` on `ctx` and writes the report into `dir` (PNG
/// composites at `exposure` EV); returns the files written.
pub fn run(
    ctx: &Arc<Context>,
    envs: &[String],
    settings: &RnmStudySettings,
    dir: &Path,
    exposure: f32,
    say: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>, RnmRunError> {
    let scene_error = |source: RnmStudyError| RnmRunError::Scene {
        scene: settings.scene.clone(),
        source,
    };
    let scene = crate::prepare::resolve_scene(&settings.scene, settings.vis_res)
        .map_err(|e| scene_error(RnmStudyError::Prepare(e.into())))?;
    crate::scene::displace::displaceable(&scene).map_err(|e| scene_error(e.into()))?;
    let mut results = Vec::new();
    for env in envs {
        let result = run_env(ctx, env, settings).map_err(|source| RnmRunError::Env {
            env: env.clone(),
            source,
        })?;
        say(&format!(
            "{env}: displaced reference {} triangles, noise {:.4} (flat {:.4}); relative RMSE vs displaced / vs flat:",
            result.displaced_triangles, result.displaced_noise, result.flat_noise
        ));
        for row in &result.rows {
            say(&format!(
                "  {:<7} {:<4} {:<7} {:.4} / {:.4}",
                row.technique.name(),
                row.path.name(),
                row.light_model,
                row.vs_displaced,
                row.vs_flat
            ));
        }
        results.push(result);
    }
    Ok(write_report(
        &results,
        settings,
        ctx.device_name(),
        dir,
        exposure,
    )?)
}
